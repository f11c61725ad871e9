#include "host/calibrate.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <iostream>
#include <map>
#include <optional>
#include <sstream>
#include <utility>

#include "calibration/measurements.h"
#include "core/error.h"
#include "load/files.h"
#include "load/host_model.h"
#include "load/schema.h"
#include "run/progress.h"
#include "run/stop_signal.h"
#include "store/analysis.h"
#include "version.h"

#if ROSGUARD_WITH_SIM
#include "sim/calibration/fit.h"
#endif
#if ROSGUARD_WITH_HW
#include "hw/calibration/suite.h"
#include "hw/host_probe.h"
#endif

namespace rosguard {
// The measuring and the documents below all serve the fit: without the sim backend,
// calibrate_host only refuses.
#if ROSGUARD_WITH_SIM
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

std::string fmt(double v, int prec = 3) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*g", prec, v);
  return buf;
}

// The measurements of an earlier calibration: a calibration.json (its "measurements") or a
// bare measurements document.
calibration::Measurements read_measurements(const std::string& file) {
  const json doc = read_json_file(file, file);
  if (doc.is_object() && doc.contains("measurements"))
    return calibration::measurements_from_json(doc.at("measurements"), file, "/measurements");
  return calibration::measurements_from_json(doc, file);
}

// Runs the suite on this host; `notes` gets its fallbacks and decisions, `probe` the host as
// probed.
calibration::Measurements measure(const CalibrateOptions& opt, std::vector<std::string>& notes,
                                  json& probe_record) {
#if ROSGUARD_WITH_HW
  // The reference bandwidth is not needed: the suite measures bandwidth_read itself.
  const hw::HostProbe probe = hw::probe_host({.measure_reference = false});
  probe_record = hw::to_json(probe);
  hw::SuiteOptions suite;
  suite.host = hw::host_facts(probe);
  suite.quick = opt.quick;
  // rclcpp: the suite's own costs over the rings, the message costs replaced afterwards.
  suite.transport = opt.transport == "rclcpp" ? "inproc" : opt.transport;
  std::atomic<bool> stop{false};
  suite.stop = &stop;
  // The suite calls progress between its timed windows, from this thread: the place to see a
  // SIGINT / SIGTERM that the handler recorded.
  // "[step/steps steps] %, elapsed, ETA, what" (a step: one timed window, or a cost block): on a
  // terminal one line rewritten in place, otherwise (a pipe, a log) a line every 5 s and the
  // last. The suite lowers `steps` as measurements reach their precision before their cap, so
  // the ETA is re-estimated as it goes (from the most windows left: an upper bound).
  std::optional<Progress> bar;
  std::pair<int, int> last{0, 0};  // the last step and steps reported
  suite.progress = [&](int step, int steps, const std::string& what) {
    if (stop_signal()) stop = true;
    if (opt.quiet) return;
    if (!bar) {
      bar.emplace(static_cast<std::size_t>(steps), true);
      bar->set_unit("steps");
    }
    bar->set_total(static_cast<std::size_t>(steps));
    // The suite names a step as it begins it: step - 1 are done (the ETA's rate).
    bar->update(static_cast<std::size_t>(step - 1), what);
    last = {step, steps};
  };
  suite.planned = [&](const hw::SuitePlan& plan) {
    if (opt.quiet) return;
    std::cerr << "calibrate: " << plan.configurations << " measurements, at most "
              << plan.max_windows << " timed windows (fewer where a measurement reaches its "
              << "precision early), buffers of " << fmt(plan.peak_mb / 1024.0, 3)
              << " GB at the peak; at most about "
              << (plan.seconds < 120.0 ? fmt(plan.seconds, 2) + " s"
                                       : fmt(plan.seconds / 60.0, 2) + " min")
              << "\n";
  };
  std::cerr << "calibrate: measuring " << suite.host.hostname << " (" << suite.host.cpus
            << " CPUs, " << (opt.quick ? "quick" : "full") << " suite)\n";
  hw::SuiteResult result = hw::run_suite(suite);
  if (bar) {
    if (!result.stopped && last.first == last.second)
      bar->update(static_cast<std::size_t>(last.second), "");  // the last step, done
    bar->finish();
  }
  notes = std::move(result.notes);
  return std::move(result.measurements);
#else
  (void)opt;
  (void)notes;
  (void)probe_record;
  throw InputError("", "",
                   "this rosguard was built without the hw backend: it cannot measure the host "
                   "(use --from CALIBRATION.json to refit earlier measurements)");
#endif
}

// --transport rclcpp: rosguard_rclcpp's middleware_bench, from $ROSGUARD_RCLCPP_BENCH or the
// first prefix on AMENT_PREFIX_PATH (a sourced ROS 2 workspace) that has it.
fs::path find_rclcpp_bench() {
  if (const char* p = std::getenv("ROSGUARD_RCLCPP_BENCH"); p && *p) {
    if (!fs::is_regular_file(p))
      throw InputError("", "",
                       std::string("ROSGUARD_RCLCPP_BENCH names ") + p + ", which is not a file");
    return p;
  }
  std::stringstream prefixes(std::getenv("AMENT_PREFIX_PATH") ? std::getenv("AMENT_PREFIX_PATH")
                                                              : "");
  for (std::string prefix; std::getline(prefixes, prefix, ':');) {
    const fs::path bench = fs::path(prefix) / "lib" / "rosguard_rclcpp" / "middleware_bench";
    if (!prefix.empty() && fs::is_regular_file(bench)) return bench;
  }
  throw InputError("", "",
                   "--transport rclcpp measures the middleware costs with the ROS 2 package "
                   "rosguard_rclcpp, and no sourced workspace has it (AMENT_PREFIX_PATH; "
                   "docs/ros2.md builds one; or name its middleware_bench in "
                   "ROSGUARD_RCLCPP_BENCH)");
}

// The sim's middleware costs as rclcpp nodes pay them on this host: middleware_bench --costs
// (1 ms self-sampling, interval regulation of a 64 MB stream, ros2/rosguard_rclcpp) replaces
// pmc_callback, publish, message_latency (with the executor's wake-up up to the subscriber's
// callback) and throttle_activation (CFB's zero-time timer to THR); local_message_latency, which
// it does not measure, goes (message_latency then serves every message). The controller's
// callbacks stay the suite's: the same regulator, and their switch in and out, which the bench's
// callback time does not hold.
void measure_rclcpp_costs(calibration::Measurements& m, std::vector<std::string>& notes,
                          bool quick) {
  const fs::path bench = find_rclcpp_bench();
  const int seconds = quick ? 3 : 10;
  const std::string cmd = "'" + bench.string() +
                          "' --mode regulate --sampling self --period-us 1000 --seconds " +
                          std::to_string(seconds) + " --costs";
  std::cerr << "calibrate: measuring the middleware costs on rclcpp nodes (" << bench.string()
            << ", " << seconds << " s)\n";
  FILE* pipe = ::popen(cmd.c_str(), "r");
  if (!pipe) throw RunError("cannot run " + bench.string());
  std::string text;
  char buf[1 << 16];
  for (std::size_t n; (n = std::fread(buf, 1, sizeof buf, pipe)) > 0;)
    text.append(buf, n);
  const int status = ::pclose(pipe);
  json doc;
  const auto line_end = text.find_last_not_of('\n');
  const auto line_start = text.rfind('\n', line_end == std::string::npos ? 0 : line_end);
  try {
    doc = json::parse(text.substr(line_start == std::string::npos ? 0 : line_start + 1));
  } catch (const json::exception&) {
  }
  if (status != 0 || !doc.is_object() || !doc.contains("costs_us"))
    throw RunError(bench.string() + " did not measure the middleware costs (exit status " +
                   std::to_string(status) + "); its output: " + text.substr(0, 400));
  std::string medians;
  for (const std::string key :
       {"pmc_callback", "publish", "message_latency", "throttle_activation"}) {
    if (!doc.at("costs_us").contains(key))
      throw RunError(bench.string() + " gave no " + key + " samples");
    auto samples = doc.at("costs_us").at(key).get<std::vector<double>>();
    if (samples.empty())
      throw RunError(bench.string() + " measured no " + key + " sample (no THR in " +
                     std::to_string(seconds) + " s?)");
    m.costs_us[key] = samples;
    std::nth_element(samples.begin(), samples.begin() + samples.size() / 2, samples.end());
    medians += (medians.empty() ? "" : ", ") + key + " " + fmt(samples[samples.size() / 2]);
  }
  m.costs_us.erase("local_message_latency");
  notes.push_back("middleware costs measured on rclcpp nodes (" + bench.string() + ", " +
                  doc.value("pmc_source", std::string("?")) + " counters, " +
                  std::to_string(seconds) + " s of 1 ms self-sampling), medians in us: " + medians +
                  "; local_message_latency left out (not measured on rclcpp), the controller's "
                  "callbacks the suite's");
  std::cerr << "calibrate: " << notes.back() << "\n";
}

json calibration_document(const calibration::Measurements& m, const std::vector<std::string>& notes,
                          const json& probe, const std::string& status) {
  return json{{"rosguard", kVersion}, {"revision", kGitRevision}, {"status", status},
              {"host_probe", probe},  {"suite_notes", notes},     {"measurements", m}};
}

// Fits the model; a refused fit is recorded in cal_file, beside the measurements it keeps.
calibration::FitReport fit_or_record(const calibration::Measurements& m,
                                     const std::vector<std::string>& notes, const json& probe,
                                     const fs::path& cal_file, const CalibrateOptions& opt) {
  try {
    calibration::FitOptions fit_options;
    fit_options.strict = opt.strict;
    fit_options.placement = opt.placement == "probed"  ? calibration::Placement::AsProbed
                            : opt.placement == "apart" ? calibration::Placement::Apart
                                                       : calibration::Placement::Best;
    return calibration::fit(m, fit_options);
  } catch (const RunError& e) {
    json doc = calibration_document(m, notes, probe, "fit refused");
    doc["error"] = e.what();
    write_file_atomic(cal_file, doc.dump(2) + "\n");
    throw RunError(std::string(e.what()) + " (the measurements are kept in " + cal_file.string() +
                   ")");
  }
}

// The uncertainty band: one platform per prior-dominated parameter and side.
using Band = std::vector<std::pair<std::string, json>>;

// Writes the band into folder, replacing an earlier calibration's (none: the folder goes).
void write_band(const fs::path& folder, const Band& band) {
  std::error_code ec;
  fs::remove_all(folder, ec);
  if (band.empty()) return;
  fs::create_directories(folder, ec);
  for (const auto& [variant, variant_doc] : band)
    write_file_atomic(folder / (variant + ".json"), variant_doc.dump(2) + "\n");
}

// The fit's summary: residual, parameters, notes and the machine measured.
// " 1.02x 1.71x ...": the ratios of `probes`.
std::string ratios(const std::vector<calibration::ContentionProbe>& probes) {
  std::string s;
  for (const auto& p : probes)
    s += " " + fmt(p.ratio, 3) + "x";
  return s;
}

void print_fit(const calibration::FitReport& report,
               const calibration::MachineIdentity& measured_on,
               const std::vector<calibration::ContentionProbe>& probes, const fs::path& cal_file) {
  std::size_t used = 0;
  for (const auto& r : report.runs)
    used += r.used ? 1 : 0;
  std::cout << "fit converged (" << report.lm_status_text << ") in " << report.iterations
            << " iterations: RMS residual " << fmt(100.0 * (std::exp(report.rms_residual) - 1.0))
            << " % over " << used << " of " << report.runs.size() << " measurements\n";
  std::vector<std::string> prior_dominated;
  for (const auto& p : report.parameters) {
    std::cout << "  " << p.name << " = " << fmt(p.value, 4)
              << (p.fitted ? " +- " + fmt(p.std_error, 2) : " (" + p.how + ")")
              << (p.prior_dominated ? "  [prior-dominated]" : "")
              << (p.at_bound ? "  [at the end of its range]" : "") << "\n";
    if (p.prior_dominated) prior_dominated.push_back(p.name);
    if (p.at_bound)
      std::cerr << "warning: " << p.name << " rests at the end of its range (" << fmt(p.value, 4)
                << "): the runs push it beyond what the model allows, and the model does not "
                   "reproduce them there (--strict refuses such a fit)\n";
  }
  for (const auto& note : report.notes)
    std::cout << "  note: " << note << "\n";
  std::cout << "measured on " << calibration::describe(measured_on)
            << (measured_on.hostname.empty() ? "" : " (" + measured_on.hostname + ")") << "\n";
  if (const auto& state = measured_on.dram_contention) {
    std::cout << "DRAM-interference state of the co-runs: " << calibration::describe(*state) << " ("
              << state->when << ")\n";
    std::size_t agree = 0;  // the probes in the recorded state
    for (const auto& p : probes)
      agree += calibration::same_contention_state(*state, p) ? 1 : 0;
    if (agree < probes.size())
      std::cerr << "warning: the DRAM interference between CPU " << state->cores[0] << " and CPU "
                << state->cores[1] << " changed during the suite (probes:" << ratios(probes)
                << "): the host moved this machine's CPUs; co-run blocks measured in another "
                   "state were taken again, and any kept are left out of the fit (named in "
                << cal_file.string() << ", suite_notes)\n";
  }
  if (measured_on.kernel.empty())
    std::cout << "  note: the measurements do not record their kernel (made before rosguard "
                 "recorded it): a run with \"platform\": \"host\" on this model will say that "
                 "its machine cannot be shown to match\n";
  if (!prior_dominated.empty()) {
    std::cerr << "warning: " << prior_dominated.size()
              << " parameter(s) rest mostly on their priors, not on this host's runs:";
    for (const auto& name : prior_dominated)
      std::cerr << " " << name;
    std::cerr << " (their uncertainty is in " << cal_file.string()
              << "; --strict refuses such a fit)\n";
  }
}

// Saves the platform (and its band) as this host's model.
void install_model(const json& platform, const Band& band) {
  std::error_code ec;
  const fs::path target = host_model_path();
  fs::create_directories(target.parent_path(), ec);
  write_file_atomic(target, platform.dump(2) + "\n");
  write_band(target.parent_path() / "band", band);
  std::cout << "installed as this host's model: " << target.string()
            << " (\"platform\": \"host\" uses it in sim)"
            << (band.empty()
                    ? ""
                    : "; its uncertainty band: " + (target.parent_path() / "band").string() + "/")
            << "\n";
}

// The validation goals (analysis/goals.json, the file make validate's report reads) against the
// slowdowns the fitted model reproduces on this host's co-runs: each co-run's time over the
// same kernel's time alone (same working set), measured and predicted, as make validate
// compares a node's slowdown in sim with hw. One "verdict:" line; the goals on regulated runs
// of held-out scenarios stay make validate's to measure.
std::string verdict(const calibration::Measurements& m, const calibration::FitReport& report,
                    const Home& home) {
  json goals;
  const fs::path goals_file = home.root / "analysis" / "goals.json";
  try {
    goals = read_json_file(goals_file, goals_file.string());
  } catch (const InputError&) {
    return "verdict: none: the validation goals (" + goals_file.string() + ") cannot be read";
  }
  const double excess_min = goals.at("excess_min").get<double>();
  double mape_bound[2] = {0.0, 0.0};  // RT, nRT
  double excess_bound = 0.0;
  for (const auto& [key, goal] : goals.at("goals").items()) {
    const bool rt = goal.at("node") == "rt";
    const double bound = goal.at("bound_pct").get<double>();
    if (goal.at("metric") == "mape_pct") mape_bound[rt ? 0 : 1] = bound;
    if (goal.at("metric") == "excess_error_pct") excess_bound = std::max(excess_bound, bound);
  }
  // The isolation run of each kernel and working set the fit used.
  std::map<std::pair<std::string, double>, const calibration::FittedRun*> alone;
  for (const auto& r : report.runs) {
    const auto& run = m.runs.at(r.index);
    if (r.used && run.corunners.empty()) alone[{run.kernel, run.working_set_kb}] = &r;
  }
  double error_sum = 0.0, excess_sum = 0.0;
  std::size_t n = 0, excess_n = 0;
  for (const auto& r : report.runs) {
    const auto& run = m.runs.at(r.index);
    if (!r.used || run.corunners.empty()) continue;
    const auto it = alone.find({run.kernel, run.working_set_kb});
    if (it == alone.end() || it->second->measured_ns <= 0 || it->second->predicted_ns <= 0)
      continue;
    const double measured = r.measured_ns / it->second->measured_ns;
    const double predicted = r.predicted_ns / it->second->predicted_ns;
    error_sum += std::abs(predicted - measured) / measured;
    ++n;
    if (measured - 1.0 >= excess_min) {
      excess_sum += std::abs((predicted - 1.0) - (measured - 1.0)) / (measured - 1.0);
      ++excess_n;
    }
  }
  const std::string goals_text = "the validation goals: slowdown MAPE <= " + fmt(mape_bound[0]) +
                                 " % (RT), <= " + fmt(mape_bound[1]) +
                                 " % (nRT), excess error <= " + fmt(excess_bound) + " %";
  if (n == 0)
    return "verdict: none: no co-run beside a run alone of its kernel to judge against " +
           goals_text;
  const double mape = 100.0 * error_sum / static_cast<double>(n);
  const double excess = excess_n ? 100.0 * excess_sum / static_cast<double>(excess_n) : 0.0;
  std::string missed;
  const auto miss = [&missed](const std::string& goal) {
    missed += (missed.empty() ? "" : ", ") + goal;
  };
  if (mape > mape_bound[0]) miss("the RT MAPE goal");
  if (mape > mape_bound[1]) miss("the nRT MAPE goal");
  if (excess_n && excess > excess_bound) miss("the excess goal");
  const std::string met = missed.empty() ? "within every goal" : "outside " + missed;
  return "verdict: " + met + " on the measured co-runs: the model's co-run slowdowns (" +
         std::to_string(n) + " co-runs, each over its kernel alone) are off by a MAPE of " +
         fmt(mape, 2) + " %" +
         (excess_n ? ", an excess error of " + fmt(excess, 3) + " % over " +
                         std::to_string(excess_n) + " with an excess >= " + fmt(excess_min)
                   : std::string(", none with an excess >= ") + fmt(excess_min)) +
         " (" + goals_text + "); make validate measures them on held-out regulated scenarios";
}

// What to run next with what was written.
std::string next_command(const CalibrateOptions& opt, const fs::path& dir) {
  std::error_code ec;
  const fs::path abs = fs::absolute(dir, ec);
  if (opt.install)
    return "next: rosguard run scenarios/examples/host.json --backend sim   (a scenario with "
           "\"platform\": \"host\" runs on this model in sim)";
  return "next: rosguard calibrate --from " + (abs / "calibration.json").string() + " --out " +
         abs.string() +
         " --install   (this fit as the host model, measuring nothing; or name it in a scenario: "
         "\"platform\": \"" +
         (abs / "platform.json").string() + "\")";
}

}  // namespace
#endif

int calibrate_host(const CalibrateOptions& opt, Loader& loader) {
#if !ROSGUARD_WITH_SIM
  (void)opt;
  (void)loader;
  throw InputError("", "",
                   "this rosguard was built without the sim backend: there is no model to fit");
#else
  if (opt.transport == "rclcpp") find_rclcpp_bench();  // refused before anything is written
  const fs::path dir = opt.out.empty() ? fs::path("results/calibration") : fs::path(opt.out);
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec || !fs::is_directory(dir))
    throw InputError("", "",
                     "--out " + dir.string() + ": cannot create the folder (" + ec.message() + ")");

  StopSignalGuard signals;
  std::vector<std::string> notes;
  json probe = nullptr;  // null: refitted from a file, nothing probed
  calibration::Measurements m =
      opt.from.empty() ? measure(opt, notes, probe) : read_measurements(opt.from);
  if (opt.transport == "rclcpp" && !stop_signal()) measure_rclcpp_costs(m, notes, opt.quick);
  if (const int sig = stop_signal()) {
    std::cerr << "calibrate: interrupted; nothing written\n";
    return 128 + sig;
  }
  const fs::path cal_file = dir / "calibration.json";
  write_file_atomic(cal_file, calibration_document(m, notes, probe, "measured").dump(2) + "\n");

  const calibration::FitReport report = fit_or_record(m, notes, probe, cal_file, opt);

  // The platform must be one the loader accepts and the sim can run.
  json platform = calibration::fitted_platform(m, report, opt.name);
  // The machine the measurements come from (not the one refitting them: --from may run
  // anywhere): "platform": "host" compares it with the machine it runs on.
  calibration::MachineIdentity measured_on = calibration::machine_identity(m.host);
  measured_on.dram_contention = calibration::suite_state(m);
  platform["measured_on"] = calibration::identity_to_json(measured_on);
  const fs::path platform_file = dir / "platform.json";
  SchemaSet(loader.home().schemas())
      .validate(platform, SchemaKind::Platform, platform_file.string());
  json doc = calibration_document(m, notes, probe, "fitted");
  doc["fit"] = calibration::to_json(report);
  write_file_atomic(platform_file, platform.dump(2) + "\n");
  write_file_atomic(cal_file, doc.dump(2) + "\n");
  // The uncertainty band: one platform per prior-dominated parameter and side, in band/ beside
  // platform.json (replacing an earlier calibration's).
  const Band band = calibration::band_platforms(platform, report);
  write_band(dir / "band", band);

  print_fit(report, measured_on, m.contention, cal_file);

  const int plot = run_analysis(loader.home(), {"calibration", dir.string()});
  if (plot != 0) std::cerr << "warning: the calibration figures could not be drawn\n";

  std::cout << "wrote " << platform_file.string() << ", " << cal_file.string() << ", "
            << (dir / "figures").string() << "/"
            << (band.empty()
                    ? ""
                    : ", " + (dir / "band").string() + "/ (" + std::to_string(band.size()) +
                          " platforms: the uncertainty band)")
            << "\n";
  if (opt.install) install_model(platform, band);
  std::cout << verdict(m, report, loader.home()) << "\n" << next_command(opt, dir) << "\n";
  return 0;
#endif
}

}  // namespace rosguard
