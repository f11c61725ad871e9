// rosguard: simulate (sim), run (hw) and analyse memory-bandwidth regulation for ROS2-style
// mixed-criticality applications. The subcommands are in commands/, one file each.
#include "commands/app.h"

int main(int argc, char** argv) {
  return rosguard::run_cli(argc, argv);
}
