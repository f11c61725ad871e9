// `rosguard plot DIR` and `rosguard compare A B`: the analysis package on results folders
// (store/analysis.h).
#include "store/analysis.h"

#include <string>
#include <vector>

#include "commands/command.h"

namespace rosguard {
namespace {

struct PlotArgs {
  std::string dir, out, rt_slowdown_max;
};

struct CompareArgs {
  std::string a, b, out;
  std::vector<std::string> bands;
};

}  // namespace

CommandHandler setup_plot(CLI::App& sub) {
  auto args = std::make_shared<PlotArgs>();
  sub.add_option("results", args->dir, "Results folder of a run")->required();
  sub.add_option("--out", args->out, "Figure folder (default: RESULTS/figures)");
  sub.add_option("--rt-slowdown-max", args->rt_slowdown_max,
                 "Draw this RT slowdown bound (e.g. 1.05) as a target on every RT slowdown "
                 "figure and the trade-off figure (default: DIR/tune.json's, if any)");
  return [args](const CommandContext& c) {
    std::vector<std::string> argv = {"plot", args->dir};
    if (!args->out.empty()) argv.insert(argv.end(), {"--out", args->out});
    if (!args->rt_slowdown_max.empty())
      argv.insert(argv.end(), {"--rt-slowdown-max", args->rt_slowdown_max});
    return run_analysis(c.loader.home(), argv);
  };
}

CommandHandler setup_compare(CLI::App& sub) {
  auto args = std::make_shared<CompareArgs>();
  sub.add_option("results_a", args->a, "Reference results folder (e.g. measured)")->required();
  sub.add_option("results_b", args->b, "Results folder compared with it (e.g. simulated)")
      ->required();
  sub.add_option("--out", args->out, "Output folder (default: RESULTS_B/compare)");
  sub.add_option("--band", args->bands,
                 "A results folder of B's scenario on a band platform of B's model (rosguard "
                 "calibrate writes them into band/); repeat it, one per platform. B's "
                 "prediction band (min..max over B and these) goes into compare.csv, "
                 "summary.json, the summary and the scatter")
      ->allow_extra_args(false);

  return [args](const CommandContext& c) {
    std::vector<std::string> argv = {"compare", args->a, args->b};
    if (!args->out.empty()) argv.insert(argv.end(), {"--out", args->out});
    for (const auto& band : args->bands)
      argv.insert(argv.end(), {"--band", band});
    return run_analysis(c.loader.home(), argv);
  };
}

}  // namespace rosguard
