#include "tune/tune.h"

#include <stdlib.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iomanip>
#include <iostream>
#include <limits>
#include <map>
#include <optional>
#include <set>
#include <sstream>

#include "core/error.h"
#include "load/files.h"
#include "policy/rules.h"
#include "results/results.h"
#include "run/runner.h"
#include "scenario/sweep.h"
#include "tune/guard_config.h"

namespace rosguard {
namespace fs = std::filesystem;
using json = nlohmann::json;

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

// Two probes of one configuration contradict monotonicity when the one at the lower threshold
// has an RT slowdown above (or, both meeting the bound, an nRT slowdown below) the other's by
// more than this fraction of the larger (at least 0.005): wiggles from the draws of the
// middleware costs and the simulation quantum do not count.
constexpr double kMonotoneTolerance = 0.01;

double tolerance(double a, double b) {
  return std::max(0.005, kMonotoneTolerance * std::max(a, b));
}

// The default space (a scenario that sweeps no regulation key but the threshold).
const std::vector<double> kDefaultLadder = {1,  2,  3,  5,  7,  10, 15, 20, 25,
                                            30, 40, 50, 60, 70, 80, 90, 100};
// Sampling / regulation period pairs, and each policy's own default pair beside them.
const std::vector<std::pair<std::int64_t, std::int64_t>> kDefaultPeriods = {
    {100, 1000}, {500, 2500}, {1000, 5000}};

const std::string kPolicy = "regulation.policy";
const std::string kSampling = "regulation.sampling";
const std::string kSamplingPeriod = "regulation.sampling_period_us";
const std::string kRegulationPeriod = "regulation.regulation_period_us";
const std::string kThreshold = "regulation.threshold_pct";
const std::string kBudget = "regulation.budget_mbps";

std::string fmt(double v, int precision = 4) {
  if (std::isnan(v)) return "n/a";
  std::ostringstream os;
  os << std::fixed << std::setprecision(precision) << v;
  return os.str();
}

std::string compact_number(double v) {
  std::ostringstream os;
  os << std::setprecision(6) << v;
  return os.str();
}

// A JSON number for a threshold: an integer when it is one (15, not 15.0).
json number_json(double v) {
  if (std::floor(v) == v && std::abs(v) < 1e15) return static_cast<std::int64_t>(v);
  return v;
}

std::string value_text(const json& v) {
  return v.is_string() ? v.get<std::string>() : v.dump();
}

bool looks_like_path(const std::string& ref) {
  return ref.find('/') != std::string::npos ||
         (ref.size() > 5 && ref.compare(ref.size() - 5, 5, ".json") == 0);
}

// A platform or workload reference written relative to the scenario file, made absolute: the
// generated scenarios live in the results folder.
void rebase_ref(json& v, const fs::path& base) {
  if (!v.is_string()) return;
  const std::string ref = v.get<std::string>();
  if (looks_like_path(ref) && fs::path(ref).is_relative())
    v = fs::absolute(base / ref).lexically_normal().string();
}

bool is_ref_path(const std::string& path) {
  return path == "platform" ||
         (path.size() >= 9 && path.compare(path.size() - 9, 9, ".workload") == 0);
}

// One setting in one case (one point of a batch).
struct CaseResult {
  std::string point;
  double rt = kNaN;   // worst RT slowdown over the RT nodes and repetitions
  double nrt = kNaN;  // mean nRT slowdown over the nRT nodes and repetitions
};

// One setting of the regulation space over every case.
struct Eval {
  json setting;                             // values of the config paths, then the threshold
  std::map<std::string, CaseResult> cases;  // by case key
  double rt = kNaN;                         // worst over the cases
  double nrt = kNaN;                        // objective: mean over the cases
  bool feasible = false;
  int rung = -1;  // ladder index (-1: the unregulated co-run)
};

struct Search {
  json config;  // values of the config paths
  std::string label;
  ThresholdSearch search;
  std::map<int, std::string> evals;  // rung -> key into Tuner::evals_
};

struct Case {
  std::string key;    // value indexes of the case keys, "i,j"
  std::string label;  // "path=value ..."
};

// Where a point of a batch belongs: its setting (index into the batch's settings), its case,
// and how many nodes it has.
struct BatchPoint {
  std::size_t setting = 0;
  std::string case_key;
  std::size_t rt = 0, nrt = 0;
};

// One point's slowdowns, gathered over its rows (repetitions) and nodes.
struct PointSlowdowns {
  double rt = -kInf;  // the worst
  bool rt_missing = false;
  double nrt_sum = 0;
  std::size_t nrt_n = 0;
  std::size_t nrt_missing = 0;
};

// The rows of a batch's points.csv: worst RT and the sum of nRT slowdowns per point over nodes
// and repetitions.
std::map<std::string, PointSlowdowns> read_slowdowns(
    const fs::path& points_csv, const std::map<std::string, BatchPoint>& points) {
  const auto lines = split_lines(read_file(points_csv));
  if (lines.empty()) throw RunError(points_csv.string() + " is empty");
  const auto header = csv_split(lines[0]);
  std::map<std::string, std::size_t> col;
  for (std::size_t i = 0; i < header.size(); ++i)
    col[header[i]] = i;
  std::map<std::string, PointSlowdowns> acc;
  const auto cell = [&](const std::vector<std::string>& row, const std::string& c) {
    const auto it = col.find(c);
    if (it == col.end() || it->second >= row.size() || row[it->second].empty()) return kNaN;
    return std::strtod(row[it->second].c_str(), nullptr);
  };
  for (std::size_t i = 1; i < lines.size(); ++i) {
    const auto row = csv_split(lines[i]);
    const std::string id = row.at(col.at("point"));
    const auto w = points.find(id);
    if (w == points.end()) continue;
    PointSlowdowns& a = acc[id];
    for (std::size_t n = 0; n < w->second.rt; ++n) {
      const double v = cell(row, n == 0 ? "rt_slowdown" : "rt" + std::to_string(n) + "_slowdown");
      if (std::isnan(v))
        a.rt_missing = true;
      else
        a.rt = std::max(a.rt, v);
    }
    for (std::size_t n = 0; n < w->second.nrt; ++n) {
      const double v = cell(row, n == 0 ? "nrt_slowdown" : "nrt" + std::to_string(n) + "_slowdown");
      if (std::isnan(v)) {
        ++a.nrt_missing;
      } else {
        a.nrt_sum += v;
        ++a.nrt_n;
      }
    }
  }
  return acc;
}

// Each setting's worst RT and mean nRT slowdown over its cases, and whether it meets the bound.
void score_settings(const std::vector<json>& settings, double rt_slowdown_max,
                    std::map<std::string, Eval>& into) {
  for (const auto& s : settings) {
    Eval& e = into[s.dump()];
    double worst = -kInf, sum = 0;
    bool rt_missing = e.cases.empty(), nrt_missing_case = e.cases.empty();
    for (const auto& [k, r] : e.cases) {
      rt_missing = rt_missing || std::isnan(r.rt);
      nrt_missing_case = nrt_missing_case || std::isnan(r.nrt);
      worst = std::max(worst, r.rt);
      sum += r.nrt;
    }
    e.rt = rt_missing ? kNaN : worst;
    e.nrt = nrt_missing_case ? kNaN : sum / static_cast<double>(e.cases.size());
    e.feasible = !std::isnan(e.rt) && e.rt <= rt_slowdown_max;
  }
}

// Mutes std::cout while a batch runs (run_scenario's summary line is not tune's output).
class MuteStdout {
 public:
  explicit MuteStdout(bool on) : old_(on ? std::cout.rdbuf(nullptr) : nullptr) {}
  ~MuteStdout() {
    if (!old_) return;
    std::cout.rdbuf(old_);
    std::cout.clear();
  }
  MuteStdout(const MuteStdout&) = delete;
  MuteStdout& operator=(const MuteStdout&) = delete;

 private:
  std::streambuf* old_;
};

class Tuner {
 public:
  Tuner(const TuneOptions& opt, Loader& loader, const BackendRegistry& backends,
        const PolicyRegistry& policies)
      : opt_(opt), loader_(loader), backends_(backends), policies_(policies) {}

  int run();

 private:
  struct Outcome {
    const Eval* best = nullptr;
    const Eval* runner_up = nullptr;
    const Eval* unregulated = nullptr;
    const Eval* closest = nullptr;  // the lowest RT slowdown, when nothing meets the bound
    std::vector<const Eval*> per_config;
  };

  void load_source();
  // Paths and value tuples of the swept regulation keys: the dimensions of the space.
  using Dims = std::vector<std::pair<std::vector<std::string>, json>>;
  // The space: base document, cases, threshold ladder, configurations, the unregulated setting.
  void build_space();
  void prepare_base();
  Dims split_sweep(std::optional<json>& threshold_values, std::optional<json>& budget_values);
  void build_ladder(const std::optional<json>& threshold_values,
                    const std::optional<json>& budget_values);
  Dims default_space();
  json resolve_config(const std::map<std::string, json>& swept) const;
  void enumerate_configs(const Dims& dims);
  void keep_valid_configs();
  void find_unregulated();
  void prepare_folder();
  // The scenario of one batch: `settings` (rows of the setting key) x every case.
  json batch_document(const std::vector<json>& settings, const std::string& backend) const;
  // The scenario of the unregulated co-run: the unregulated policy with the other regulation
  // settings at their defaults (the metric and reference bandwidth kept), x every case.
  json unregulated_document(const std::string& backend) const;
  // Runs `doc` (batch_document of `settings`, or unregulated_document, whose one setting is
  // `settings`) into `out`; returns the exit code of the run (0, or 130 / 143 when
  // interrupted) and adds the evaluations.
  int run_batch(const std::string& name, json doc, const std::vector<json>& settings,
                const fs::path& out, std::map<std::string, Eval>& into);
  // Which setting and case each point of a batch is (new cases are added to cases_).
  std::map<std::string, BatchPoint> locate_points(const LoadedScenario& batch);
  // run_batch into probes/<name> as a batch of the search (merged into DIR at the end).
  int run_probe(const std::string& name, json doc, const std::vector<json>& settings,
                std::map<std::string, Eval>& into);
  json setting_json(const Eval& e) const;
  std::string setting_label(const json& setting) const;
  std::optional<double> budget_mbps(const json& setting) const;
  void merge_results();
  int search();
  Outcome choose();
  void print_summary(const Outcome& o) const;
  nlohmann::json tune_json(const Outcome& o) const;
  int confirm_hw(const Eval& best, const Eval* unregulated, json& doc);
  void note(const std::string& text) { notes_.push_back(text); }
  bool for_guard() const { return opt_.deployable == "guard" || !opt_.emit_guard.empty(); }
  // --emit-guard: the best setting as a guard configuration, checked as the guard reads it.
  void emit_guard(const Eval& best);

  const TuneOptions& opt_;
  Loader& loader_;
  const BackendRegistry& backends_;
  const PolicyRegistry& policies_;

  LoadedScenario src_;
  fs::path dir_;
  std::string name_;
  json base_;                                            // the given document, no sweep
  std::vector<std::pair<std::string, json>> case_keys_;  // as written, references rebased
  std::vector<std::string> config_paths_;                // setting paths but the threshold
  std::string setting_key_;                              // config paths + threshold, '+'
  std::vector<double> ladder_;
  std::optional<double> reference_mbps_;
  std::vector<Search> searches_;
  std::vector<Case> cases_;
  std::map<std::string, Case> case_by_key_;
  std::map<std::string, Eval> evals_;  // by setting tuple dump
  std::vector<std::string> evals_order_;
  std::optional<json> unregulated_setting_;
  std::vector<std::string> notes_;
  std::size_t simulated_points_ = 0;
  std::size_t case_count_ = 1;
  std::size_t grid_points_ = 0;
  int step_ = 0;
  // The search's batches in the order they ran: the unregulated co-run's, then step-NN's.
  std::vector<fs::path> batch_dirs_;
};

void Tuner::load_source() {
  const double x = opt_.rt_slowdown_max;
  if (!(x >= 1.0) || !std::isfinite(x))
    throw InputError("", "",
                     "--rt-slowdown-max must be a number of at least 1 (a slowdown is the co-run "
                     "time over the time alone; got " +
                         compact_number(x) + ")");
  if (opt_.objective != "nrt-throughput")
    throw InputError("", "", "--objective: only nrt-throughput is known");
  const json given = read_json_file(opt_.scenario_file, opt_.scenario_file);
  if (given.is_object() && given.contains("backend") && given["backend"] == "hw" &&
      opt_.confirm != "hw")
    throw InputError(opt_.scenario_file, "/backend",
                     "this scenario runs on hw, and tune searches in sim: pass --confirm hw to "
                     "search in sim and re-measure the winner on this machine, or set backend "
                     "to sim");
  RunOptions ro;
  ro.scenario_file = opt_.scenario_file;
  ro.backend = "sim";
  src_ = load_for_run(ro, loader_, backends_);
  for (const auto& p : src_.points) {
    if (p.scenario.nodes.rt.empty())
      throw InputError(opt_.scenario_file, "/nodes/rt",
                       "no RT node" +
                           (src_.points.size() > 1 ? " in point " + p.sweep.id : std::string()) +
                           ": tune keeps RT nodes within a slowdown bound, and there is nothing "
                           "to protect");
    if (p.scenario.nodes.nrt.empty())
      throw InputError(opt_.scenario_file, "/nodes/nrt",
                       "no nRT node" +
                           (src_.points.size() > 1 ? " in point " + p.sweep.id : std::string()) +
                           ": there is nothing to regulate");
  }
  name_ = src_.points.front().scenario.name;
  dir_ = opt_.out.empty() ? fs::path("results") / name_ / "tune" : opt_.out;
  std::set<double> refs;
  for (const auto& p : src_.points)
    refs.insert(p.scenario.regulation.reference_mbps);
  if (refs.size() == 1 && *refs.begin() > 0) reference_mbps_ = *refs.begin();
}

void Tuner::build_space() {
  prepare_base();
  // Sweep keys: regulation keys bound the space, the others are cases.
  std::optional<json> threshold_values, budget_values;
  Dims dims = split_sweep(threshold_values, budget_values);
  build_ladder(threshold_values, budget_values);
  // The configurations: the swept regulation keys, else the default space.
  if (dims.empty()) dims = default_space();
  config_paths_ = {kPolicy, kSampling, kSamplingPeriod, kRegulationPeriod};
  for (const auto& [paths, tuples] : dims)
    for (const auto& p : paths)
      if (std::find(config_paths_.begin(), config_paths_.end(), p) == config_paths_.end())
        config_paths_.push_back(p);
  for (const auto& p : config_paths_)
    setting_key_ += p + "+";
  setting_key_ += kThreshold;
  enumerate_configs(dims);
  keep_valid_configs();
  find_unregulated();
}

// The given document without its sweep, its file references rebased onto the scenario's folder.
void Tuner::prepare_base() {
  const fs::path base_dir = fs::absolute(fs::path(opt_.scenario_file)).parent_path();
  base_ = src_.given;
  base_.erase("sweep");
  base_.erase("$schema");
  if (base_.contains("platform")) rebase_ref(base_["platform"], base_dir);
  for (const char* kind : {"rt", "nrt"})
    if (base_.contains("nodes") && base_["nodes"].contains(kind))
      for (auto& n : base_["nodes"][kind])
        if (n.contains("workload")) rebase_ref(n["workload"], base_dir);
  if (base_.contains("regulation") && base_["regulation"].contains("budget_mbps")) {
    base_["regulation"].erase("budget_mbps");
    note(
        "the scenario's regulation.budget_mbps is left out: tune expresses a budget as "
        "threshold_pct (budget = threshold x reference_mbps)");
  }
}

// The sweep keys: the threshold or budget values apart, the other regulation keys as dimensions
// of the space (returned), the rest as cases (case_keys_).
Tuner::Dims Tuner::split_sweep(std::optional<json>& threshold_values,
                               std::optional<json>& budget_values) {
  const std::string& file = opt_.scenario_file;
  const fs::path base_dir = fs::absolute(fs::path(file)).parent_path();
  Dims dims;
  for (const std::string& key : src_.sweep_keys) {
    const std::vector<std::string> paths = split_sweep_key(key);
    const json& values = src_.expanded["sweep"][key];
    std::size_t regulation = 0;
    for (const auto& p : paths)
      regulation += p.rfind("regulation.", 0) == 0 ? 1 : 0;
    const std::string pointer = "/sweep" + to_json_pointer({{key, {}}});
    if (regulation != 0 && regulation != paths.size())
      throw InputError(file, pointer,
                       "this key ties regulation settings to other paths; tune searches the "
                       "regulation space per case: sweep them as separate keys");
    if (regulation == 0) {
      json v = values;
      for (std::size_t c = 0; c < paths.size(); ++c)
        if (is_ref_path(paths[c]))
          for (auto& value : v)
            rebase_ref(paths.size() == 1 ? value : value[c], base_dir);
      case_keys_.emplace_back(key, v);
      continue;
    }
    if (paths.size() == 1 && paths[0] == kThreshold) {
      threshold_values = values;
      continue;
    }
    if (paths.size() == 1 && paths[0] == kBudget) {
      budget_values = values;
      continue;
    }
    for (const auto& p : paths)
      if (p == kThreshold || p == kBudget)
        throw InputError(file, pointer,
                         "tune bisects the threshold: sweep " + p + " as a key of its own");
    json tuples = json::array();
    for (const auto& v : values)
      tuples.push_back(paths.size() == 1 ? json::array({v}) : v);
    dims.emplace_back(paths, tuples);
  }
  return dims;
}

// The threshold ladder: --thresholds, else the swept thresholds or budgets, else the default.
void Tuner::build_ladder(const std::optional<json>& threshold_values,
                         const std::optional<json>& budget_values) {
  const std::string& file = opt_.scenario_file;
  if (threshold_values && budget_values)
    throw InputError(file, "/sweep",
                     "the sweep has both regulation.threshold_pct and regulation.budget_mbps: "
                     "tune searches one of them");
  if (!opt_.thresholds.empty()) {
    for (double t : opt_.thresholds)
      if (!(t > 0.0 && t <= 100.0))
        throw InputError(
            "", "", "--thresholds: " + compact_number(t) + " is not a threshold in (0, 100] %");
    ladder_ = opt_.thresholds;
    if (threshold_values || budget_values)
      note("the thresholds come from --thresholds, not from the scenario's sweep");
  } else if (threshold_values) {
    for (const auto& v : *threshold_values)
      ladder_.push_back(v.get<double>());
  } else if (budget_values) {
    if (!reference_mbps_)
      throw InputError(file, "/sweep/regulation.budget_mbps",
                       "the cases have different reference bandwidths: a budget in MB/s is not "
                       "one threshold; sweep regulation.threshold_pct instead");
    for (const auto& v : *budget_values) {
      const double pct = 100.0 * v.get<double>() / *reference_mbps_;
      if (pct > 100.0)
        note("budget " + compact_number(v.get<double>()) + " MB/s is above the reference " +
             compact_number(*reference_mbps_) + " MB/s: left out");
      else
        ladder_.push_back(pct);
    }
    note("the swept budgets are searched as thresholds of the reference " +
         compact_number(*reference_mbps_) + " MB/s");
  } else {
    ladder_ = kDefaultLadder;
    note("the scenario does not sweep regulation.threshold_pct: the default ladder of " +
         std::to_string(ladder_.size()) + " thresholds (1 .. 100 %) is searched");
  }
  std::sort(ladder_.begin(), ladder_.end());
  ladder_.erase(std::unique(ladder_.begin(), ladder_.end()), ladder_.end());
  if (ladder_.empty()) throw InputError(file, "/sweep", "no threshold to search");
}

// Every policy that throttles, with each sampling mode its traits say it runs with, at the
// default period pairs and at its own default pair (e.g. MemPol's microsecond polling).
Tuner::Dims Tuner::default_space() {
  json tuples = json::array();
  for (const auto& p : policies_.all()) {
    if (!p.traits.regulates || !p.traits.throttles) continue;
    auto periods = kDefaultPeriods;
    const auto own =
        std::make_pair(p.traits.default_sampling_period_us, p.traits.default_regulation_period_us);
    if (own.first > 0 && own.second > 0 &&
        std::find(periods.begin(), periods.end(), own) == periods.end())
      periods.push_back(own);
    for (Sampling s : p.traits.samplings)
      for (const auto& [sp, rp] : periods)
        tuples.push_back(json::array({p.name, std::string(to_string(s)), sp, rp}));
  }
  note(
      "the scenario sweeps no regulation key but the threshold: the default space is "
      "searched (every registered policy that throttles x each sampling mode it runs with x "
      "sampling / regulation periods 100/1000, 500/2500, 1000/5000 us and the policy's own "
      "default pair)");
  return {{{kPolicy, kSampling, kSamplingPeriod, kRegulationPeriod}, tuples}};
}

// Every config path's value in a configuration (`swept`: the values its dimensions set):
// where no dimension sets it, the scenario's, else what a run of that setting resolves it to
// (the policy's own sampling mode and periods, else the generic ones: apply_policy_defaults).
// So each row of a generated sweep is a complete setting, whichever paths a joined key sets.
json Tuner::resolve_config(const std::map<std::string, json>& swept) const {
  json doc = {{"regulation", src_.expanded.value("regulation", json::object())}};
  for (const auto& [path, value] : swept)
    doc[json::json_pointer(to_json_pointer(parse_sweep_path(path)))] = value;
  apply_policy_defaults(doc["regulation"]);
  json config = json::array();
  for (const auto& p : config_paths_) {
    const json::json_pointer ptr(to_json_pointer(parse_sweep_path(p)));
    config.push_back(doc.contains(ptr) ? doc.at(ptr) : json(nullptr));
  }
  return config;
}

// The configurations of the space (searches_): every combination of the dimensions' values,
// resolved; those of policies that do not throttle left out, and the regulation period of
// those that ignore it collapsed.
void Tuner::enumerate_configs(const Dims& dims) {
  std::vector<std::map<std::string, json>> assigned = {{}};
  for (const auto& [paths, tuples] : dims) {
    std::vector<std::map<std::string, json>> next;
    for (const auto& a : assigned)
      for (const auto& t : tuples) {
        auto b = a;
        for (std::size_t c = 0; c < paths.size(); ++c)
          b[paths[c]] = t.at(c);
        next.push_back(std::move(b));
      }
    assigned = std::move(next);
  }
  std::set<std::string> seen;
  std::set<std::string> dropped_policies;
  std::set<std::string> collapsed;  // the regulation periods the policies that ignore it run at
  for (auto& a : assigned) {
    json config = resolve_config(a);
    const std::string policy = config[0].get<std::string>();
    const PolicyInfo* info = policies_.find(policy);
    if (!info || !info->traits.regulates || !info->traits.throttles) {
      dropped_policies.insert(policy);
      continue;
    }
    if (!info->traits.periodic_windows) {  // the regulation period is not used by the policy
      auto unswept = a;
      unswept.erase(kRegulationPeriod);
      const json period = resolve_config(unswept)[3];
      if (config[3] != period) {
        config[3] = period;
        collapsed.insert(value_text(period));
      }
    }
    if (!seen.insert(config.dump()).second) continue;
    searches_.push_back({config, "", ThresholdSearch(static_cast<int>(ladder_.size())), {}});
  }
  for (const auto& p : dropped_policies)
    note("policy " + p + " is left out of the space: it does not throttle" +
         (p == "none" ? " (the unregulated co-run is reported on its own)" : ""));
  if (!collapsed.empty()) {
    std::string periods;
    for (const auto& p : collapsed)
      periods += (periods.empty() ? "" : ", ") + p;
    note("policies with one budget per RT run ignore the regulation period: they are run at " +
         periods + " us (the scenario's regulation_period_us, else the policy's default)");
  }
}

// Each configuration must be a valid scenario in every case (policy rules, backend checks):
// those that are not are left out, with the reason.
void Tuner::keep_valid_configs() {
  const std::string& file = opt_.scenario_file;
  std::vector<Search> valid;
  std::string tmpl = (fs::temp_directory_path() / "rosguard-tune-XXXXXX").string();
  if (!::mkdtemp(tmpl.data()))
    throw RunError("cannot create a temporary folder in " + fs::temp_directory_path().string());
  const fs::path check_dir = tmpl;
  struct Cleanup {
    fs::path dir;
    ~Cleanup() {
      std::error_code ec;
      fs::remove_all(dir, ec);
    }
  } cleanup{check_dir};
  // Loads one setting (a configuration at the ladder's top rung) as a scenario of its own on
  // `backend`: InputError when it is not valid there.
  const auto check_setting = [&](const json& config, const std::string& backend,
                                 const std::string& suffix) {
    json setting = config;
    setting.push_back(number_json(ladder_.back()));
    json doc = batch_document({setting}, backend);
    doc["name"] = name_.substr(0, 100) + "-" + suffix;
    const fs::path f = check_dir / (suffix + ".json");
    write_file_atomic(f, doc.dump(2) + "\n");
    RunOptions ro;
    ro.scenario_file = f.string();
    load_for_run(ro, loader_, backends_);
  };
  for (auto& s : searches_) {
    s.label = setting_label(s.config);
    try {
      check_setting(s.config, "sim", "tune-check");
      valid.push_back(std::move(s));
    } catch (const InputError& e) {
      note(s.label + " is left out: " + e.message());
    }
  }
  searches_ = std::move(valid);
  if (for_guard()) {
    if (const auto why = guard_placement_refusal(src_.points.front().scenario.nodes))
      throw InputError(file, "/nodes", "rosguard guard cannot deploy this scenario: " + *why);
    std::vector<Search> deployable;
    std::map<std::string, std::vector<std::string>> left_out;  // reason -> labels
    for (auto& s : searches_) {
      if (const auto why = guard_refusal(config_paths_, s.config))
        left_out[*why].push_back(s.label);
      else
        deployable.push_back(std::move(s));
    }
    for (const auto& [why, labels] : left_out) {
      std::string text;
      for (const auto& l : labels)
        text += (text.empty() ? "" : "; ") + l;
      note("rosguard guard cannot deploy " + std::to_string(labels.size()) +
           " configuration(s), left out: " + why + " (" + text + ")");
    }
    searches_ = std::move(deployable);
  }
  if (searches_.empty()) {
    std::string why;
    for (const auto& n : notes_)
      why += "; " + n;
    throw InputError(file, "/sweep",
                     "no regulation setting to search" + why +
                         (for_guard() ? " (rosguard guard samples externally: set "
                                        "regulation.sampling to \"external\", or sweep it)"
                                      : ""));
  }
  // --confirm hw: the scenario must run on this machine before the search spends its time.
  if (opt_.confirm == "hw") {
    try {
      check_setting(searches_.front().config, "hw", "confirm-check");
    } catch (const InputError& e) {
      throw InputError(file, e.json_path(), "--confirm hw: on this machine " + e.message());
    }
  }
}

// Unregulated: the policy that does not regulate, a setting of the policy alone (its batch
// has no setting key: unregulated_document).
void Tuner::find_unregulated() {
  for (const auto& p : policies_.all())
    if (!p.traits.regulates) {
      unregulated_setting_ = json::array({p.name});
      break;
    }
  if (!unregulated_setting_)
    note("no registered policy leaves the co-run unregulated: its cost is not reported");
}

std::string Tuner::setting_label(const json& setting) const {
  // setting: config values, optionally followed by the threshold.
  std::ostringstream os;
  const std::string policy = setting[0].get<std::string>();
  const PolicyInfo* info = policies_.find(policy);
  os << policy;
  if (info && !info->traits.regulates) return os.str();
  os << " " << value_text(setting[1]) << " sampling " << value_text(setting[2]) << " us";
  if (!info || info->traits.periodic_windows)
    os << " / regulation " << value_text(setting[3]) << " us";
  for (std::size_t c = 4; c < config_paths_.size(); ++c)
    os << " " << config_paths_[c].substr(std::string("regulation.").size()) << "="
       << value_text(setting[c]);
  if (setting.size() > config_paths_.size()) {
    const double t = setting[config_paths_.size()].get<double>();
    os << ", threshold " << compact_number(t) << " %";
    if (const auto b = budget_mbps(setting)) os << " (" << fmt(*b, 0) << " MB/s)";
  }
  return os.str();
}

std::optional<double> Tuner::budget_mbps(const json& setting) const {
  if (!reference_mbps_ || setting.size() <= config_paths_.size()) return std::nullopt;
  PolicyParams p;
  p.threshold_pct = setting[config_paths_.size()].get<double>();
  p.reference_mbps = *reference_mbps_;
  return account_rate_mbps(p, 0);
}

void Tuner::prepare_folder() {
  std::error_code ec;
  if (fs::exists(dir_, ec) && !fs::is_empty(dir_, ec)) {
    const bool ours = fs::exists(dir_ / "tune.json", ec) || fs::exists(dir_ / "probes", ec);
    if (!ours)
      throw InputError(
          "", "",
          "--out " + dir_.string() + " holds other files than a tune's; choose another folder");
    if (!opt_.overwrite)
      throw InputError("", "",
                       dir_.string() +
                           " already holds a tune; pass --overwrite to replace it, or choose "
                           "another --out");
    fs::remove_all(dir_, ec);
    if (ec) throw RunError("cannot empty " + dir_.string() + ": " + ec.message());
  }
  fs::create_directories(dir_ / "probes", ec);
  if (ec) throw RunError("cannot create " + (dir_ / "probes").string() + ": " + ec.message());
}

json Tuner::batch_document(const std::vector<json>& settings, const std::string& backend) const {
  json doc = base_;
  doc["backend"] = backend;
  json sweep = json::object();
  sweep[setting_key_] = settings;
  for (const auto& [key, values] : case_keys_)
    sweep[key] = values;
  doc["sweep"] = sweep;
  return doc;
}

json Tuner::unregulated_document(const std::string& backend) const {
  json doc = base_;
  doc["backend"] = backend;
  json reg = {{"policy", unregulated_setting_->at(0)}};
  if (base_.contains("regulation"))
    for (const char* k : {"metric", "reference_mbps"})
      if (base_["regulation"].contains(k)) reg[k] = base_["regulation"][k];
  doc["regulation"] = reg;
  json sweep = json::object();
  for (const auto& [key, values] : case_keys_)
    sweep[key] = values;
  if (!sweep.empty()) doc["sweep"] = sweep;
  return doc;
}

int Tuner::run_probe(const std::string& name, json doc, const std::vector<json>& settings,
                     std::map<std::string, Eval>& into) {
  const fs::path out = dir_ / "probes" / name;
  const int rc = run_batch(name, std::move(doc), settings, out, into);
  batch_dirs_.push_back(out);
  if (rc != 0)
    std::cerr << "rosguard: tune interrupted; the batches so far are in "
              << (dir_ / "probes").string()
              << " (tune does not resume: run it again with --overwrite)\n";
  return rc;
}

std::map<std::string, BatchPoint> Tuner::locate_points(const LoadedScenario& batch) {
  std::map<std::string, BatchPoint> where;
  for (const auto& p : batch.points) {
    BatchPoint w;
    std::string key, label;
    for (const auto& q : p.sweep.params) {
      if (q.key == setting_key_) {
        w.setting = q.value_index;
        continue;
      }
      if (q.component == 0) key += (key.empty() ? "" : ",") + std::to_string(q.value_index);
      label += (label.empty() ? "" : " ") + q.path + "=" + value_text(q.value);
    }
    w.case_key = key;
    w.rt = p.scenario.nodes.rt.size();
    w.nrt = p.scenario.nodes.nrt.size();
    where[p.sweep.id] = w;
    if (!case_by_key_.count(key)) {
      case_by_key_[key] = {key, label.empty() ? "the scenario" : label};
      cases_.push_back(case_by_key_[key]);
    }
  }
  return where;
}

int Tuner::run_batch(const std::string& name, json doc, const std::vector<json>& settings,
                     const fs::path& out, std::map<std::string, Eval>& into) {
  const std::string backend = doc.at("backend").get<std::string>();
  doc["name"] = name_.substr(0, 100) + "-" + name;  // names have at most 128 characters
  const fs::path file = out.string() + ".json";
  write_file_atomic(file, doc.dump(2) + "\n");

  RunOptions ro;
  ro.scenario_file = file.string();
  ro.out = out;
  ro.jobs = backend == "sim" ? opt_.jobs : 1;  // hw measures one point at a time
  ro.quiet = opt_.quiet;
  ro.command_line = opt_.command_line + " (" + name + ")";
  const LoadedScenario batch = load_for_run(ro, loader_, backends_);
  int rc = 0;
  {
    MuteStdout mute(!opt_.quiet);
    rc = run_scenario(ro, loader_, backends_);
  }
  if (rc == 1) throw RunError(name + " failed (" + (out / "manifest.json").string() + " says why)");
  if (rc != 0) return rc;

  const std::map<std::string, BatchPoint> where = locate_points(batch);
  // The rows: worst RT and mean nRT slowdown per point over nodes and repetitions.
  const std::map<std::string, PointSlowdowns> acc = read_slowdowns(out / "points.csv", where);
  // An RT slowdown not measured in some run cannot be shown to meet the bound (NaN); an nRT
  // slowdown not measured in some runs (hw: the node did not get through its isolation work
  // while the RT node ran) leaves the mean of the others, with a note.
  std::size_t nrt_missing = 0, nrt_values = 0;
  for (const auto& [id, w] : where) {
    const json& setting = settings.at(w.setting);
    Eval& e = into[setting.dump()];
    e.setting = setting;
    const auto it = acc.find(id);
    CaseResult r;
    r.point = id;
    if (it != acc.end()) {
      const PointSlowdowns& a = it->second;
      r.rt = a.rt_missing || a.rt == -kInf ? kNaN : a.rt;
      r.nrt = a.nrt_n == 0 ? kNaN : a.nrt_sum / static_cast<double>(a.nrt_n);
      nrt_missing += a.nrt_missing;
      nrt_values += a.nrt_missing + a.nrt_n;
    }
    e.cases[w.case_key] = r;
  }
  if (nrt_missing > 0)
    note(name + ": the nRT slowdown was not measured in " + std::to_string(nrt_missing) + " of " +
         std::to_string(nrt_values) +
         " node run(s) (the node did not get through its isolation work); the means are over "
         "the others (" +
         (out / "points.csv").string() + ")");
  score_settings(settings, opt_.rt_slowdown_max, into);
  simulated_points_ += where.size();
  return 0;
}

json Tuner::setting_json(const Eval& e) const {
  json j = json::object();
  const PolicyInfo* info = policies_.find(e.setting[0].get<std::string>());
  const bool regulates = !info || info->traits.regulates;
  // The unregulated setting is the policy alone: the other settings are null (not used).
  const auto value = [&](std::size_t c) { return regulates ? e.setting.at(c) : json(nullptr); };
  j["policy"] = e.setting[0];
  j["sampling"] = value(1);
  j["sampling_period_us"] = value(2);
  j["regulation_period_us"] = value(3);
  for (std::size_t c = 4; c < config_paths_.size(); ++c)
    j[config_paths_[c]] = value(c);
  j["threshold_pct"] = regulates ? e.setting[config_paths_.size()] : json(nullptr);
  const auto b = regulates ? budget_mbps(e.setting) : std::nullopt;
  j["budget_mbps"] = b ? json(std::round(*b * 10.0) / 10.0) : json(nullptr);
  j["label"] = setting_label(e.setting);
  const auto num = [](double v) { return std::isnan(v) ? json(nullptr) : json(v); };
  j["rt_slowdown"] = num(e.rt);
  j["nrt_slowdown"] = num(e.nrt);
  j["meets_bound"] = e.feasible;
  json cases = json::array();
  for (const auto& c : cases_) {
    const auto it = e.cases.find(c.key);
    if (it == e.cases.end()) continue;
    cases.push_back({{"case", c.label},
                     {"point", it->second.point},
                     {"rt_slowdown", num(it->second.rt)},
                     {"nrt_slowdown", num(it->second.nrt)}});
  }
  j["cases"] = cases;
  return j;
}

// DIR/points.csv and samples.csv: every batch's rows; manifest.json: the last batch's, saying
// what the folder is.
void Tuner::merge_results() {
  std::string points, samples;
  std::string samples_header;
  // The columns: the last step's (the setting key's param: columns among them). The unregulated
  // batch sweeps no setting key: its rows have those cells empty.
  const std::string points_header = split_lines(read_file(batch_dirs_.back() / "points.csv")).at(0);
  const std::vector<std::string> columns = csv_split(points_header);
  for (const auto& d : batch_dirs_) {
    auto p = split_lines(read_file(d / "points.csv"));
    if (p.empty()) continue;
    if (p[0] == points_header) {
      for (std::size_t i = 1; i < p.size(); ++i)
        points += p[i] + "\n";
    } else {
      std::vector<std::size_t> from;  // per column of points_header: its index in this batch
      const std::vector<std::string> own = csv_split(p[0]);
      for (const auto& c : own)
        if (std::find(columns.begin(), columns.end(), c) == columns.end())
          throw RunError((d / "points.csv").string() +
                         " has a column the last batch has not: " + c);
      for (const auto& c : columns)
        from.push_back(
            static_cast<std::size_t>(std::find(own.begin(), own.end(), c) - own.begin()));
      for (std::size_t i = 1; i < p.size(); ++i) {
        const auto cells = csv_split(p[i]);
        std::string line;
        for (std::size_t c = 0; c < from.size(); ++c)
          line += (c ? "," : "") +
                  (from[c] < std::min(own.size(), cells.size()) ? csv_escape(cells[from[c]]) : "");
        points += line + "\n";
      }
    }
    std::error_code ec;
    if (!fs::exists(d / "samples.csv", ec)) continue;
    auto s = split_lines(read_file(d / "samples.csv"));
    if (s.empty()) continue;
    if (samples_header.empty()) samples_header = s[0];
    for (std::size_t i = 1; i < s.size(); ++i)
      samples += s[i] + "\n";
  }
  write_file_atomic(dir_ / "points.csv", points_header + "\n" + points);
  if (!samples_header.empty())
    write_file_atomic(dir_ / "samples.csv", samples_header + "\n" + samples);
  json m = json::parse(read_file(batch_dirs_.back() / "manifest.json"));
  m["command"] = opt_.command_line;
  m["status"] = "complete";
  m["tune"] = {{"file", "tune.json"}, {"batches", batch_dirs_.size()}};
  // The folder holds the batches' points, not one scenario's sweep: the scenario as given and
  // expanded, without the per-point list and hash of the last batch.
  m["scenario"] = {
      {"given", src_.given}, {"expanded", src_.expanded}, {"file", opt_.scenario_file}};
  m.erase("scenario_hash");
  m.erase("shards");
  m["counts"] = {{"rows", std::count(points.begin(), points.end(), '\n')},
                 {"points", simulated_points_}};
  write_file_atomic(dir_ / "manifest.json", m.dump(2) + "\n");
}

int Tuner::confirm_hw(const Eval& best, const Eval* unregulated, json& doc) {
  const fs::path out = dir_ / "confirm-hw";
  if (!opt_.quiet) std::cerr << "tune: measuring the winner and the unregulated co-run on hw\n";
  std::map<std::string, Eval> measured;
  const std::size_t simulated = simulated_points_;  // hw points are measured, not simulated
  int rc =
      run_batch("confirm-hw", batch_document({best.setting}, "hw"), {best.setting}, out, measured);
  if (rc == 0 && unregulated)
    rc = run_batch("confirm-hw-unregulated", unregulated_document("hw"), {unregulated->setting},
                   dir_ / "confirm-hw-unregulated", measured);
  simulated_points_ = simulated;
  if (rc != 0) return rc;
  json confirm = json::object();
  std::cout << "\nconfirmed on this machine (hw backend, " << out.string()
            << (unregulated ? ", " + (dir_ / "confirm-hw-unregulated").string() : "") << "):\n";
  std::cout << "  " << std::left << std::setw(14) << "setting" << std::setw(12) << "RT sim"
            << std::setw(12) << "RT hw" << std::setw(12) << "nRT sim" << std::setw(12) << "nRT hw"
            << "\n";
  const auto row = [&](const char* what, const Eval& sim) {
    const Eval& hw = measured.at(sim.setting.dump());
    std::cout << "  " << std::left << std::setw(14) << what << std::setw(12) << fmt(sim.rt)
              << std::setw(12) << fmt(hw.rt) << std::setw(12) << fmt(sim.nrt) << std::setw(12)
              << fmt(hw.nrt) << "\n";
    json j = setting_json(hw);
    j["sim_rt_slowdown"] = std::isnan(sim.rt) ? json(nullptr) : json(sim.rt);
    j["sim_nrt_slowdown"] = std::isnan(sim.nrt) ? json(nullptr) : json(sim.nrt);
    confirm[what] = j;
    return hw.feasible;
  };
  const bool holds = row("best", best);
  if (unregulated) row("unregulated", *unregulated);
  std::cout << "  on hw the winner " << (holds ? "keeps" : "does NOT keep")
            << " every RT node within " << compact_number(opt_.rt_slowdown_max) << "\n";
  if (!holds)
    note(
        "measured on hw, the winner's RT slowdown exceeds the bound: the sim model and this "
        "machine disagree (see confirm_hw in tune.json)");
  doc["confirm_hw"] = confirm;
  return 0;
}

// The search: one batch per step, every configuration's next probes together. Returns the
// exit code of an interrupted batch, else 0.
int Tuner::search() {
  if (!opt_.quiet)
    std::cerr << "tune: " << searches_.size() << " configuration(s) x " << ladder_.size()
              << " thresholds; full grid " << grid_points_ << " point(s)\n";
  const auto rung_text = [&](int r) {
    return compact_number(ladder_[static_cast<std::size_t>(r)]) + " %";
  };
  const auto setting_at = [&](const Search& s, int r) {
    json setting = s.config;
    setting.push_back(number_json(ladder_[static_cast<std::size_t>(r)]));
    return setting;
  };
  const auto add = [&](const std::map<std::string, Eval>& got) {
    for (auto& [k, e] : got) {
      if (!evals_.count(k)) evals_order_.push_back(k);
      evals_[k] = e;
    }
  };
  if (unregulated_setting_) {
    if (!opt_.quiet)
      std::cerr << "tune: unregulated: policy " << value_text(unregulated_setting_->at(0)) << " x "
                << case_count_ << " case(s)\n";
    std::map<std::string, Eval> got;
    if (const int rc =
            run_probe("unregulated", unregulated_document("sim"), {*unregulated_setting_}, got);
        rc != 0)
      return rc;
    add(got);
  }
  while (true) {
    std::vector<json> settings;
    std::vector<std::pair<std::size_t, int>> owners;  // (search, rung) per setting
    std::size_t searching = 0, scanning = 0;
    for (std::size_t i = 0; i < searches_.size(); ++i) {
      const std::vector<int> rungs = searches_[i].search.next();
      if (!rungs.empty()) ++(searches_[i].search.scanning() ? scanning : searching);
      for (int r : rungs) {
        settings.push_back(setting_at(searches_[i], r));
        owners.emplace_back(i, r);
      }
    }
    if (owners.empty()) return 0;
    char name[32];
    std::snprintf(name, sizeof name, "step-%02d", step_);
    if (!opt_.quiet)
      std::cerr << "tune: " << name << ": " << settings.size() << " setting(s) x " << case_count_
                << " case(s) (" << searching << " configuration(s) bisected, " << scanning
                << " scanned); " << simulated_points_ << " point(s) simulated so far\n";
    std::map<std::string, Eval> got;
    if (const int rc = run_probe(name, batch_document(settings, "sim"), settings, got); rc != 0)
      return rc;
    add(got);
    for (const auto& [i, r] : owners) {
      const std::string k = setting_at(searches_[i], r).dump();
      Eval& e = evals_.at(k);
      e.rung = r;
      searches_[i].evals[r] = k;
      searches_[i].search.record(r, {e.rt, e.nrt, e.feasible});
    }
    for (auto& s : searches_)
      if (const std::string why = s.search.update(rung_text); !why.empty())
        note(s.label + ": not monotone in the threshold (" + why +
             "): bisection abandoned, every threshold of this configuration is simulated");
    ++step_;
  }
}

// Per configuration its pick; overall the lowest objective (ties: the lower RT slowdown); the
// runner-up from another configuration, else another setting that meets the bound.
Tuner::Outcome Tuner::choose() {
  Outcome o;
  const auto better = [](const Eval* a, const Eval* b) {
    if (!b) return true;
    if (a->nrt != b->nrt) return a->nrt < b->nrt;
    return a->rt < b->rt;
  };
  o.per_config.assign(searches_.size(), nullptr);
  for (std::size_t i = 0; i < searches_.size(); ++i)
    if (const auto rung = searches_[i].search.pick())
      o.per_config[i] = &evals_.at(searches_[i].evals.at(*rung));
  for (const auto& k : evals_order_) {
    const Eval& e = evals_.at(k);
    if (e.rung >= 0 && !std::isnan(e.rt) && (!o.closest || e.rt < o.closest->rt)) o.closest = &e;
  }
  for (const Eval* e : o.per_config)
    if (e && better(e, o.best)) o.best = e;
  for (const Eval* e : o.per_config)
    if (e && e != o.best && better(e, o.runner_up)) o.runner_up = e;
  if (o.best && !o.runner_up) {  // a single configuration meets the bound: its next best probe
    for (const auto& k : evals_order_) {
      const Eval& e = evals_.at(k);
      if (e.rung >= 0 && &e != o.best && e.feasible && !std::isnan(e.nrt) &&
          better(&e, o.runner_up))
        o.runner_up = &e;
    }
    if (o.runner_up)
      note("only one configuration meets the bound: the runner-up is another threshold of it");
  }
  if (unregulated_setting_) o.unregulated = &evals_.at(unregulated_setting_->dump());
  if (o.unregulated && o.unregulated->feasible)
    note(
        "the unregulated co-run already keeps every RT node within the bound: regulation costs "
        "the nRT nodes progress without being needed");
  return o;
}

void Tuner::print_summary(const Outcome& o) const {
  const std::string x = compact_number(opt_.rt_slowdown_max);
  std::cout << "tune " << name_ << ": every RT node's slowdown <= " << x
            << "; objective nrt-throughput (lowest nRT slowdown: mean over nRT nodes, "
               "repetitions and cases)\n";
  std::cout << "  space        " << searches_.size() << " configuration(s) x " << ladder_.size()
            << " thresholds (" << compact_number(ladder_.front()) << " .. "
            << compact_number(ladder_.back()) << " %) x " << case_count_ << " case(s)\n";
  const std::size_t unregulated_points = o.unregulated ? o.unregulated->cases.size() : 0;
  std::cout << "  simulated    " << simulated_points_ << " point(s) in " << batch_dirs_.size()
            << " batches: " << simulated_points_ - unregulated_points << " of the full grid's "
            << grid_points_;
  if (o.unregulated) std::cout << ", and " << unregulated_points << " unregulated";
  std::cout << "\n";
  const auto line = [&](const char* what, const Eval* e, const char* if_none) {
    std::cout << "  " << std::left << std::setw(13) << what;
    if (!e) {
      std::cout << if_none << "\n";
      return;
    }
    std::cout << setting_label(e->setting) << "\n"
              << "  " << std::setw(13) << ""
              << "RT slowdown " << fmt(e->rt) << " (worst), nRT slowdown " << fmt(e->nrt)
              << " (mean)\n";
  };
  line("best", o.best, "none: no simulated setting meets the bound");
  line("runner-up", o.runner_up, "none: no other simulated setting meets the bound");
  if (o.unregulated)
    std::cout << "  " << std::left << std::setw(13) << "unregulated"
              << "RT slowdown " << fmt(o.unregulated->rt) << " (worst), nRT slowdown "
              << fmt(o.unregulated->nrt) << " (mean)\n";
  if (cases_.size() > 1 && o.best) {
    std::cout << "  per case (best / unregulated: RT, nRT slowdown):\n";
    for (const auto& c : cases_) {
      const CaseResult& b = o.best->cases.at(c.key);
      std::cout << "    " << c.label << ": " << fmt(b.rt) << ", " << fmt(b.nrt);
      if (o.unregulated && o.unregulated->cases.count(c.key))
        std::cout << " / " << fmt(o.unregulated->cases.at(c.key).rt) << ", "
                  << fmt(o.unregulated->cases.at(c.key).nrt);
      std::cout << "\n";
    }
  }
  if (!o.best) {
    std::cout << "  no simulated setting keeps every RT node within " << x;
    if (o.closest)
      std::cout << "; the closest: " << setting_label(o.closest->setting) << " (RT slowdown "
                << fmt(o.closest->rt) << ", nRT slowdown " << fmt(o.closest->nrt) << ")";
    std::cout << "\n";
  }
}

json Tuner::tune_json(const Outcome& o) const {
  json doc;
  doc["rt_slowdown_max"] = opt_.rt_slowdown_max;
  doc["objective"] = opt_.objective;
  doc["best"] = o.best ? setting_json(*o.best) : json(nullptr);
  doc["runner_up"] = o.runner_up ? setting_json(*o.runner_up) : json(nullptr);
  doc["unregulated"] = o.unregulated ? setting_json(*o.unregulated) : json(nullptr);
  doc["simulated_points"] = simulated_points_;
  doc["grid_points"] = grid_points_;
  doc["notes"] = notes_;
  doc["closest"] = !o.best && o.closest ? setting_json(*o.closest) : json(nullptr);
  doc["scenario"] = opt_.scenario_file;
  doc["ladder_pct"] = json::array();
  for (double t : ladder_)
    doc["ladder_pct"].push_back(number_json(t));
  doc["configurations"] = json::array();
  for (std::size_t i = 0; i < searches_.size(); ++i) {
    const Search& s = searches_[i];
    doc["configurations"].push_back(
        {{"label", s.label},
         {"searched", s.search.scanned() ? "scan" : "bisection"},
         {"probes", s.search.probes().size()},
         {"best_threshold_pct", o.per_config[i] ? o.per_config[i]->setting.back() : json()}});
  }
  // Every simulated setting (the trade-off figure draws one point per setting).
  doc["settings"] = json::array();
  for (const auto& k : evals_order_)
    if (evals_.at(k).rung >= 0) doc["settings"].push_back(setting_json(evals_.at(k)));
  doc["cases"] = json::array();
  for (const auto& c : cases_)
    doc["cases"].push_back(c.label);
  return doc;
}

void Tuner::emit_guard(const Eval& best) {
  const Scenario& sc = src_.points.front().scenario;
  TunedSetting t;
  t.paths = config_paths_;
  t.values = json::array();
  for (std::size_t c = 0; c < config_paths_.size(); ++c)
    t.values.push_back(best.setting.at(c));
  t.threshold_pct = best.setting.at(config_paths_.size()).get<double>();
  // The reference and the RT node's time alone as the winner's points ran them.
  std::set<std::string> points;
  for (const auto& [key, c] : best.cases)
    points.insert(c.point);
  const auto rows = split_lines(read_file(dir_ / "points.csv"));
  const std::vector<std::string> head = csv_split(rows.at(0));
  const auto col = [&](const std::string& name) {
    const auto it = std::find(head.begin(), head.end(), name);
    if (it == head.end()) throw ContractError("points.csv has no column " + name);
    return static_cast<std::size_t>(it - head.begin());
  };
  const std::size_t c_point = col("point"), c_ref = col("reference_mbps"), c_rt = col("rt_name"),
                    c_iso = col("rt_isolation_us");
  double iso_us = 0.0;
  for (std::size_t i = 1; i < rows.size(); ++i) {
    const auto cells = csv_split(rows[i]);
    if (!points.count(cells.at(c_point))) continue;
    t.reference_mbps = std::stod(cells.at(c_ref));
    if (cells.at(c_rt) == sc.nodes.rt.front().name && !cells.at(c_iso).empty())
      iso_us = std::max(iso_us, std::stod(cells.at(c_iso)));
  }
  if (iso_us > 0) t.rt_isolation_us = std::llround(iso_us);
  std::ostringstream d;
  d << "From `" << opt_.command_line << "`: " << setting_label(best.setting)
    << ", predicted on platform " << sc.platform.name << ": RT slowdown " << fmt(best.rt)
    << " (worst), nRT slowdown " << fmt(best.nrt) << " (mean)";
  if (t.rt_isolation_us)
    d << "; rt_window_us is " << sc.nodes.rt.front().name << "'s time alone there";
  t.description = d.str();
  const json doc =
      guard_config(name_, sc.nodes, src_.expanded.value("regulation", json::object()), t);
  write_file_atomic(opt_.emit_guard, doc.dump(2) + "\n");
  try {
    loader_.load_guard(opt_.emit_guard.string(), policies_);
  } catch (const InputError& e) {
    throw ContractError("the guard configuration written to " + opt_.emit_guard.string() +
                        " is not valid: " + e.what());
  }
  std::cout << "  guard        " << opt_.emit_guard.string() << " (rosguard guard "
            << opt_.emit_guard.string() << " --check)\n";
}

int Tuner::run() {
  load_source();
  build_space();
  prepare_folder();
  case_count_ = 1;
  for (const auto& [key, values] : case_keys_)
    case_count_ *= values.size();
  grid_points_ = searches_.size() * ladder_.size() * case_count_;

  if (const int rc = search(); rc != 0) return rc;
  const Outcome o = choose();
  merge_results();
  print_summary(o);
  json doc = tune_json(o);
  write_file_atomic(dir_ / "tune.json", doc.dump(2) + "\n");
  int rc = 0;
  if (o.best && opt_.confirm == "hw") {
    rc = confirm_hw(*o.best, o.unregulated, doc);
    doc["notes"] = notes_;
    write_file_atomic(dir_ / "tune.json", doc.dump(2) + "\n");
  }
  if (o.best && !opt_.emit_guard.empty()) emit_guard(*o.best);
  if (!notes_.empty()) {
    std::cout << "  notes:\n";
    for (const auto& n : notes_)
      std::cout << "    - " << n << "\n";
  }
  std::cout << "  results      " << dir_.string() << " (tune.json, points.csv; rosguard plot "
            << dir_.string() << ")\n";
  if (rc != 0) return rc;
  if (!o.best && opt_.confirm == "hw")
    std::cerr << "note: nothing to confirm on hw: no setting meets the bound\n";
  if (!o.best && !opt_.emit_guard.empty())
    std::cerr << "note: no guard configuration written (" << opt_.emit_guard.string()
              << "): no setting meets the bound\n";
  return o.best ? 0 : 1;
}

}  // namespace

ThresholdSearch::ThresholdSearch(int rungs) : rungs_(rungs), hi_(rungs) {
  if (rungs < 1) throw ContractError("ThresholdSearch: a ladder needs at least one rung");
}

std::vector<int> ThresholdSearch::next() {
  std::vector<int> rungs;
  if (mode_ == Mode::Bisect) {
    if (hi_ - lo_ > 1) {
      rungs.push_back(lo_ + (hi_ - lo_) / 2);
    } else if (!verified_ && lo_ >= 1 && !probes_.count(lo_ - 1)) {
      rungs.push_back(lo_ - 1);  // the rung below the pick: does nRT slowdown fall?
      verified_ = true;
    } else {
      mode_ = Mode::Done;
    }
  } else if (mode_ == Mode::Scan) {
    for (int r = 0; r < rungs_; ++r)
      if (!probes_.count(r)) rungs.push_back(r);
    mode_ = Mode::Done;  // the scan is one batch
  }
  return rungs;
}

void ThresholdSearch::record(int rung, const Probe& probe) {
  if (rung < 0 || rung >= rungs_)
    throw ContractError("ThresholdSearch: no rung " + std::to_string(rung));
  probes_[rung] = probe;
}

std::string ThresholdSearch::update(const std::function<std::string(int)>& rung_text) {
  if (mode_ != Mode::Bisect) return "";
  for (const auto& [rung, p] : probes_)
    if (rung > lo_ && rung < hi_) (p.feasible ? lo_ : hi_) = rung;
  // At a higher threshold RT slowdown does not fall (so the rungs that meet the bound are the
  // lowest ones) and, among those, nRT slowdown does not rise (so the highest is the best).
  for (auto a = probes_.begin(); a != probes_.end(); ++a)
    for (auto b = std::next(a); b != probes_.end(); ++b) {
      const Probe& lo = a->second;
      const Probe& hi = b->second;
      std::string why;
      if (lo.rt > hi.rt + tolerance(lo.rt, hi.rt) || (std::isnan(lo.rt) && !std::isnan(hi.rt)))
        why = "RT slowdown " + fmt(lo.rt) + " at " + rung_text(a->first) + " but " + fmt(hi.rt) +
              " at " + rung_text(b->first);
      else if (lo.feasible && hi.feasible && lo.nrt < hi.nrt - tolerance(lo.nrt, hi.nrt))
        why = "nRT slowdown " + fmt(lo.nrt) + " at " + rung_text(a->first) + " but " + fmt(hi.nrt) +
              " at " + rung_text(b->first);
      if (why.empty()) continue;
      mode_ = Mode::Scan;
      scanned_ = true;
      return why;
    }
  return "";
}

std::optional<int> ThresholdSearch::pick() const {
  std::optional<int> best;
  for (const auto& [rung, p] : probes_) {
    if (!p.feasible || std::isnan(p.nrt)) continue;
    const Probe* b = best ? &probes_.at(*best) : nullptr;
    if (!b || p.nrt < b->nrt || (p.nrt == b->nrt && p.rt < b->rt)) best = rung;
  }
  return best;
}

int tune_scenario(const TuneOptions& options, Loader& loader, const BackendRegistry& backends,
                  const PolicyRegistry& policies) {
  Tuner tuner(options, loader, backends, policies);
  return tuner.run();
}

}  // namespace rosguard
