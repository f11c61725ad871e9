// libsystemc defines main() and calls sc_main() from it, so a binary that links libsystemc must
// define sc_main. rosguard has its own main() and drives sc_start() itself (sim/system.cpp):
// this sc_main is never called. The library's INTERFACE link option --undefined=sc_main makes
// the linker take this object from the static library.
#include <cstdio>

// SystemC declares it extern "C" (sysc/kernel/sc_externs.h).
extern "C" int sc_main(int, char**) {
  std::fputs("rosguard: sc_main is not an entry point; run the rosguard executable\n", stderr);
  return 1;
}
