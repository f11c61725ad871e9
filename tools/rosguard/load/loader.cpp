#include "load/loader.h"

#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <map>
#include <mutex>
#include <set>
#include <sstream>
#include <tuple>

#include "core/error.h"
#include "policy/rules.h"
#include "run/parallel.h"

#if !defined(ROSGUARD_SOURCE_DIR) || !defined(ROSGUARD_DATA_FROM_BIN)
#error "ROSGUARD_SOURCE_DIR and ROSGUARD_DATA_FROM_BIN (bin -> share/rosguard) must be defined"
#endif

namespace rosguard {
namespace fs = std::filesystem;
using json = nlohmann::json;

namespace {

bool has_schemas(const fs::path& root) {
  std::error_code ec;
  return fs::exists(root / "scenarios" / "schema" / "scenario.schema.json", ec);
}

// A reference is a path when it names a file; otherwise it is a name in a catalogue folder.
bool looks_like_path(const std::string& ref) {
  return ref.find('/') != std::string::npos ||
         (ref.size() > 5 && ref.compare(ref.size() - 5, 5, ".json") == 0);
}

std::string escape_token(const std::string& t) {
  std::string out;
  for (char c : t)
    out += c == '~' ? "~0" : c == '/' ? "~1" : std::string(1, c);
  return out;
}

std::string params_text(const SweepPoint& p) {
  std::string s;
  for (const auto& param : p.params)
    s += (s.empty() ? "" : ", ") + param.path + "=" +
         (param.value.is_string() ? param.value.get<std::string>() : param.value.dump());
  return s;
}

std::vector<CatalogEntry> catalogue(const fs::path& dir, const char* kind) {
  std::vector<CatalogEntry> out;
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(dir, ec)) {
    if (entry.path().extension() != ".json") continue;
    CatalogEntry c{entry.path().stem().string(), "", entry.path()};
    try {
      const json doc = read_json_file(entry.path(), display_path(entry.path()));
      std::string summary = doc.value("description", "");
      if (std::string(kind) == "workload" && doc.contains("reference")) {
        const auto& r = doc["reference"];
        std::ostringstream os;
        os << doc.value("suite", "") << (doc.contains("suite") ? "; " : "");
        // dump() prints the figures as written (an ostream would round 26271.74 to 26271.7).
        if (r.contains("ipc")) os << "IPC " << r["ipc"].dump() << ", ";
        if (r.contains("mbps")) os << r["mbps"].dump() << " MB/s in isolation";
        summary = os.str() + (summary.empty() ? "" : " - " + summary);
      }
      c.summary = summary;
    } catch (const InputError& e) {
      c.summary = std::string("(invalid: ") + e.what() + ")";
    }
    out.push_back(std::move(c));
  }
  std::sort(out.begin(), out.end(),
            [](const CatalogEntry& a, const CatalogEntry& b) { return a.name < b.name; });
  return out;
}

// The points `check` builds: all of a small sweep; of a large one, every value of every key
// (each with the first value of the other keys) and the last point, at most kCheckAllPoints.
std::vector<std::uint64_t> selected_points(std::uint64_t count,
                                           const std::vector<std::uint64_t>& sizes,
                                           PointSelection selection) {
  std::vector<std::uint64_t> out;
  if (selection == PointSelection::All || count <= kCheckAllPoints) {
    for (std::uint64_t i = 0; i < count; ++i)
      out.push_back(i);
    return out;
  }
  std::set<std::uint64_t> chosen = {0, count - 1};
  std::uint64_t stride = count;  // index step of one value of key k (the last key: 1)
  for (const std::uint64_t size : sizes) {
    stride /= size;
    for (std::uint64_t v = 0; v < size && chosen.size() < kCheckAllPoints; ++v)
      chosen.insert(v * stride);
  }
  return {chosen.begin(), chosen.end()};
}

// The order the sweep's keys were written in (JSON objects here are sorted by key; the sweep
// runs in the written order).
std::vector<std::string> sweep_key_order(const std::string& text) {
  std::vector<std::string> keys;
  const auto ordered = nlohmann::ordered_json::parse(text, nullptr, false);
  if (ordered.is_object() && ordered.contains("sweep"))
    for (const auto& [k, _] : ordered["sweep"].items())
      keys.push_back(k);
  return keys;
}

// A model error (it names no file) placed in the scenario `file`.
InputError in_file(const std::string& file, const InputError& e) {
  return InputError(file, e.json_path(), e.message());
}

// Each sweep path must name a place in a scenario: tries it on the base document `expanded`.
// Returns each dotted path's JSON pointer.
std::map<std::string, std::string> check_sweep_paths(const json& expanded,
                                                     const std::vector<std::string>& keys,
                                                     const std::string& file) {
  std::map<std::string, std::string> pointers;
  for (const auto& key : keys) {
    const std::string where = "/sweep/" + escape_token(key);
    const auto paths = split_sweep_key(key);
    const json& values = expanded.at("sweep").at(key);
    for (std::size_t i = 0; paths.size() > 1 && i < values.size(); ++i)
      if (!values[i].is_array() || values[i].size() != paths.size())
        throw InputError(file, where + "/" + std::to_string(i),
                         "this key joins " + std::to_string(paths.size()) +
                             " paths, so each value must be a list of " +
                             std::to_string(paths.size()) + " values, one per path");
    for (std::size_t c = 0; c < paths.size(); ++c) {
      std::vector<PathSegment> path;
      try {
        path = parse_sweep_path(paths[c]);
      } catch (const InputError& e) {
        throw InputError(file, where, e.message());
      }
      const json& first = values.at(0);
      json trial = expanded;
      try {
        set_at_path(trial, path,
                    paths.size() > 1 && first.is_array() && c < first.size() ? first[c] : first);
      } catch (const InputError& e) {
        throw InputError(file, where, "this path does not exist: " + e.message());
      }
      pointers[paths[c]] = to_json_pointer(path);
    }
  }
  return pointers;
}

// The plan of the sweep in `expanded`; refuses more than kMaxSweepPoints points.
SweepPlan plan_sweep(const json& expanded, const std::vector<std::string>& keys,
                     const std::string& file) {
  SweepPlan plan = [&] {
    try {
      return SweepPlan(expanded, keys);
    } catch (const InputError& e) {
      throw in_file(file, e);
    }
  }();
  if (plan.count() > kMaxSweepPoints) {
    std::string product;
    for (const auto n : plan.sizes())
      product += (product.empty() ? "" : " x ") + std::to_string(n);
    throw InputError(file, "/sweep",
                     "the sweep has " + std::to_string(plan.count()) + " points (" + product +
                         "), more than the " + std::to_string(kMaxSweepPoints) +
                         " one scenario may have (every point is validated and held in memory "
                         "before the first one runs); split it into several scenarios");
  }
  return plan;
}

// The controller may share a core with an application node (2-CPU machines): allowed, said
// once per node and core.
// A fitted platform (rosguard calibrate) some of whose parameters rest mostly on their priors:
// sim predictions on it carry their uncertainty. Said once per platform, for sim points.
std::vector<std::string> prior_dominated_warnings(const std::vector<LoadedPoint>& points) {
  std::vector<std::string> warnings;
  std::set<std::string> said;
  for (const auto& lp : points) {
    const Scenario& s = lp.scenario;
    if (s.backend != "sim") continue;
    const nlohmann::json& doc = s.platform.doc.get();
    if (!doc.contains("fit") || doc["fit"]["prior_dominated"].empty()) continue;
    if (!said.insert(s.platform.name).second) continue;
    std::ostringstream w;
    w << "platform '" << s.platform.name << "': " << doc["fit"]["prior_dominated"].size()
      << " fitted parameter(s) rest mostly on their priors, not on measurements:";
    for (const auto& q : doc["fit"]["prior_dominated"])
      w << " " << q["parameter"].get<std::string>() << " " << q["value"].get<double>() << " (x/ "
        << std::setprecision(3) << std::exp(q["log_std_error"].get<double>())
        << std::setprecision(6) << ")";
    w << "; sim results that depend on them are that uncertain";
    warnings.push_back(w.str());
  }
  return warnings;
}

// A sim point's workload profile with numbers that were never measured (rosguard profile writes
// "placeholder": base_ipc until fitted, mlp from callgrind): said once per workload and number.
std::vector<std::string> placeholder_warnings(const std::vector<LoadedPoint>& points) {
  std::vector<std::string> warnings;
  std::set<std::string> said;
  for (const auto& lp : points) {
    if (lp.scenario.backend != "sim") continue;
    std::vector<const WorkloadInfo*> workloads;
    for (const auto& n : lp.scenario.nodes.rt)
      workloads.push_back(&n.workload);
    for (const auto& n : lp.scenario.nodes.nrt)
      workloads.push_back(&n.workload);
    for (const WorkloadInfo* w : workloads) {
      const nlohmann::json& sim = w->doc.value("sim", nlohmann::json::object());
      for (const auto& field : sim.value("placeholder", nlohmann::json::array())) {
        const std::string f = field.get<std::string>();
        const std::string key = w->origin + "\n" + f;
        if (!said.insert(key).second) continue;
        warnings.push_back(
            "workload '" + w->name + "' (" + w->origin + "): " +
            (f == "base_ipc"
                 ? "base_ipc is a placeholder (1.0), not fitted to a measured IPC, so the sim's "
                   "times for it mean nothing: fit it with rosguard profile --platform P "
                   "--fit-ipc IPC (or --measure-ipc on this machine's model)"
                 : "mlp was not measured (rosguard profile --tracer callgrind): the sim takes 1, "
                   "so its memory stalls under contention are an upper bound; a lackey profile "
                   "(--tracer lackey, a window with --max-instructions) measures it"));
      }
    }
  }
  return warnings;
}

std::vector<std::string> controller_sharing_warnings(const std::vector<LoadedPoint>& points) {
  std::vector<std::string> warnings;
  std::set<std::string> said;
  for (const auto& lp : points) {
    const auto& n = lp.scenario.nodes;
    const auto warn = [&](const std::string& name) {
      const std::string w = "the controller shares core " + std::to_string(n.controller_core) +
                            " with node '" + name +
                            "' (fine on small machines; its callbacks compete with the node)";
      if (said.insert(w).second) warnings.push_back(w);
    };
    for (const auto& r : n.rt)
      if (r.core == n.controller_core) warn(r.name);
    for (const auto& r : n.nrt)
      if (r.core == n.controller_core) warn(r.name);
  }
  return warnings;
}

// Interval regulation samples every sampling period and compares what a period used so far with
// the budget. A budget below the traffic of one sampling period is spent at the first sample of
// every regulation period, whatever it is: the nRT core then runs one sampling period in each
// regulation period, and every threshold below that point acts alike. Said once per (nRT node,
// sampling period, regulation period), with the thresholds it affects; the traffic is the
// workload's reference (isolation) bandwidth, so a node slowed by contention may stay a little
// under it.
std::vector<std::string> ineffective_budget_warnings(const std::vector<LoadedPoint>& points) {
  struct Case {
    double traffic_mib = 0.0, reference = 0.0;
    std::string whose;                     // where the bandwidth comes from
    std::set<double> thresholds, budgets;  // threshold_pct, or budget_mbps where given
  };
  std::map<std::tuple<std::string, std::int64_t, std::int64_t>, Case> cases;
  for (const auto& lp : points) {
    const RegulationSpec& r = lp.scenario.regulation;
    // Periodic sampling against a budget per regulation period (not overflow sampling, which
    // sees the crossing itself; not per-event budgets, which this estimate does not cover).
    const PolicyInfo* info = find_builtin_policy(r.policy);
    if (!info || !info->traits.throttles || !info->traits.periodic_windows ||
        r.sampling == Sampling::Overflow || !r.event_budget_mbps.empty() || r.reference_mbps <= 0.0)
      continue;
    const PolicyParams params = policy_params(r);
    const auto& nodes = lp.scenario.nodes.nrt;
    // The workloads' references are isolation figures of the paper's machine (Table 1, the
    // Orin). A model rosguard calibrate fitted, or "host", is another machine: there a bandwidth
    // kernel's traffic is the platform's own reference (bandwidth_read alone on it), and a
    // workload without such a figure is left out.
    const PlatformInfo& platform = lp.scenario.platform;
    const bool other_machine = platform.name == kHostPlatform || platform.doc.contains("fit");
    for (std::size_t i = 0; i < nodes.size(); ++i) {
      const auto& n = nodes[i];
      const double rate_mbps = account_rate_mbps(params, i);
      const double budget_mib =
          budget_bytes(100.0, rate_mbps, params.regulation_period_ns) / kBytesPerMb;
      double mbps = 0.0;
      std::string whose = "its reference";
      if (other_machine) {
        const auto& hw = n.workload.doc.value("hw", nlohmann::json::object());
        const std::string kernel = n.workload.is_command() ? "" : hw.value("kernel", "");
        if (kernel != "bandwidth_read" && kernel != "bandwidth_write") continue;
        mbps = platform.reference_mbps;
        whose = "platform " + platform.name + "'s reference (bandwidth_read alone there)";
      } else {
        const auto& ref = n.workload.doc.value("reference", nlohmann::json::object());
        if (!ref.contains("mbps") || !ref["mbps"].is_number()) continue;
        mbps = ref["mbps"].get<double>();
      }
      const double traffic_mib = mbps * static_cast<double>(r.sampling_period_us) / 1e6;
      if (budget_mib >= traffic_mib) continue;
      Case& c =
          cases[{n.name + "' (" + n.workload.name, r.sampling_period_us, r.regulation_period_us}];
      c.traffic_mib = traffic_mib;
      c.whose = whose;
      c.reference = mbps;
      if (r.budget_mbps.empty())
        c.thresholds.insert(r.threshold_pct);
      else
        c.budgets.insert(rate_mbps);
    }
  }
  std::vector<std::string> warnings;
  for (const auto& [key, c] : cases) {
    const auto& [node, sampling, regulation] = key;
    std::ostringstream t;
    std::size_t k = 0;
    if (!c.thresholds.empty()) t << "threshold_pct ";
    for (double th : c.thresholds)
      t << (k++ ? ", " : "") << th;
    if (!c.budgets.empty()) t << (k ? "; " : "") << "budget_mbps ";
    k = 0;
    for (double b : c.budgets)
      t << (k++ ? ", " : "") << b;
    std::ostringstream w;
    w.precision(3);
    w << "budget below one sampling period's traffic: nRT node '" << node << ") uses about "
      << c.traffic_mib << " MiB per " << sampling << " us sample at " << c.whose << " "
      << c.reference << " MiB/s, more than the budget of a " << regulation
      << " us regulation period at " << t.str()
      << ": it is throttled at its first sample of every period, so these budgets act "
         "alike (a shorter sampling period or a longer regulation period lets them differ)";
    warnings.push_back(w.str());
  }
  return warnings;
}

}  // namespace

struct SweepSource {
  SweepSource(const json& expanded, const std::vector<std::string>& keys, const std::string& file)
      : document(expanded),
        sweep_pointers(check_sweep_paths(document, keys, file)),
        plan(plan_sweep(document, keys, file)) {}
  json document;                                      // the plan refers to it
  std::map<std::string, std::string> sweep_pointers;  // dotted path -> JSON pointer
  SweepPlan plan;
};

Home Home::locate() {
  if (const char* env = std::getenv("ROSGUARD_HOME"); env && *env) {
    if (!has_schemas(env))
      throw RunError(std::string("ROSGUARD_HOME=") + env +
                     " holds no scenarios/schema/scenario.schema.json (point it at rosguard's "
                     "data: an install's share/rosguard or a source tree)");
    return {fs::path(env)};
  }
  std::vector<fs::path> tried;
  std::error_code ec;
  if (const fs::path exe = fs::read_symlink("/proc/self/exe", ec); !ec) {
    tried.push_back((exe.parent_path() / ROSGUARD_DATA_FROM_BIN).lexically_normal());
    if (has_schemas(tried.back())) return {tried.back()};  // installed: <prefix>/share/rosguard
  }
  tried.emplace_back(ROSGUARD_SOURCE_DIR);  // a build tree: the sources it was configured from
  if (has_schemas(tried.back())) return {tried.back()};
  std::string where;
  for (const auto& dir : tried)
    where += (where.empty() ? "" : ", ") + dir.string();
  throw RunError("cannot find rosguard's data (scenarios/schema/) in " + where +
                 "; set ROSGUARD_HOME to an install's share/rosguard or a source tree");
}

std::string Home::data_file(const std::string& given) const {
  const fs::path path(given);
  std::error_code ec;
  if (given.empty() || path.is_absolute() || fs::exists(path, ec)) return given;
  const fs::path in_data = (root / path).lexically_normal();
  if (!fs::is_regular_file(in_data, ec)) return given;
  return fs::absolute(in_data, ec).string();
}

std::string display_path(const fs::path& path) {
  std::error_code ec;
  // From / a relative path ("root/x.json" for /root/x.json) reads as a mistake: absolute.
  if (path.is_absolute() && fs::current_path(ec) == "/") return path.string();
  const fs::path rel = fs::proximate(path, ec);
  if (ec) return path.string();
  const std::string r = rel.string();
  return r.size() <= path.string().size() ? r : path.string();
}

std::string read_text_file(const fs::path& path, const std::string& display) {
  // stat() first: opening a FIFO blocks, and /dev/zero never ends.
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0)
    throw InputError(display, "",
                     errno == ENOENT
                         ? std::string("cannot read the file (does it exist?)")
                         : std::string("cannot read the file: ") + std::strerror(errno));
  if (!S_ISREG(st.st_mode))
    throw InputError(display, "",
                     std::string("not a regular file (") +
                         (S_ISDIR(st.st_mode) ? "a folder" : "a device, FIFO or socket") +
                         "); give the path of a JSON file");
  if (static_cast<std::uintmax_t>(st.st_size) > kMaxJsonFileBytes)
    throw InputError(display, "",
                     "the file has " + std::to_string(st.st_size) + " bytes, more than the " +
                         std::to_string(kMaxJsonFileBytes) +
                         " a scenario, platform or workload file may have");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(display, "", "cannot read the file (does it exist?)");
  // Read in blocks up to the bound: the file may have grown since stat().
  std::string text;
  text.reserve(static_cast<std::size_t>(st.st_size));
  std::array<char, 65536> block{};
  while (in.read(block.data(), block.size()) || in.gcount() > 0) {
    text.append(block.data(), static_cast<std::size_t>(in.gcount()));
    if (text.size() > kMaxJsonFileBytes)
      throw InputError(display, "",
                       "the file is larger than " + std::to_string(kMaxJsonFileBytes) + " bytes");
  }
  return text;
}

json parse_json_text(const std::string& text, const std::string& display) {
  // Duplicate keys are silently merged by JSON parsers; here they are an error with a path.
  // Nesting and string lengths are bounded while parsing, before anything recurses over the
  // document (copies, the schema validator, std::regex in its "pattern" checks).
  struct Frame {
    bool array = false;
    long index = -1;
    std::string key;
    std::set<std::string> keys;
  };
  std::vector<Frame> stack;
  std::string duplicate;
  const auto pointer = [&stack](std::size_t frames) {
    std::string p;
    for (std::size_t i = 0; i < frames && i < stack.size(); ++i)
      p += "/" + (stack[i].array ? std::to_string(stack[i].index) : escape_token(stack[i].key));
    return p;
  };
  const auto enter_element = [&stack]() {
    if (!stack.empty() && stack.back().array) ++stack.back().index;
  };
  const auto too_long = [&](const std::string& what, std::size_t size, const std::string& at) {
    throw InputError(display, at,
                     what + " of " + std::to_string(size) + " characters is longer than the " +
                         std::to_string(kMaxJsonStringChars) +
                         " allowed (names, keys and paths need far fewer)");
  };
  const json::parser_callback_t cb = [&](int, json::parse_event_t ev, json& parsed) {
    switch (ev) {
      case json::parse_event_t::object_start:
      case json::parse_event_t::array_start:
        enter_element();
        if (stack.size() >= kMaxJsonDepth)
          throw InputError(display, pointer(8) + "/...",
                           "nested more than " + std::to_string(kMaxJsonDepth) +
                               " levels deep (scenarios need about 10)");
        stack.push_back({ev == json::parse_event_t::array_start, -1, "", {}});
        break;
      case json::parse_event_t::object_end:
      case json::parse_event_t::array_end:
        stack.pop_back();
        break;
      case json::parse_event_t::key: {
        const std::string k = parsed.get<std::string>();
        stack.back().key = k;
        if (k.size() > kMaxJsonStringChars) too_long("a key", k.size(), pointer(stack.size() - 1));
        if (!stack.back().keys.insert(k).second && duplicate.empty())
          duplicate = pointer(stack.size());
        break;
      }
      case json::parse_event_t::value:
        enter_element();
        if (parsed.is_string() && parsed.get_ref<const std::string&>().size() > kMaxJsonStringChars)
          too_long("a string", parsed.get_ref<const std::string&>().size(), pointer(stack.size()));
        break;
    }
    return true;
  };
  json doc;
  try {
    doc = json::parse(text, cb);
  } catch (const json::parse_error& e) {
    std::string what = e.what();
    if (const auto p = what.find("] "); p != std::string::npos) what = what.substr(p + 2);
    throw InputError(display, "", "invalid JSON: " + what);
  } catch (const json::exception& e) {
    // A number outside double's range (1e999): the value being read.
    if (!stack.empty() && stack.back().array) ++stack.back().index;
    std::string what = e.what();
    if (const auto p = what.find("] "); p != std::string::npos) what = what.substr(p + 2);
    throw InputError(display, pointer(stack.size()),
                     "invalid JSON: " + what + " (beyond the range of a double)");
  }
  if (!duplicate.empty())
    throw InputError(display, duplicate, "key written twice (the second would silently win)");
  return doc;
}

json read_json_file(const fs::path& path, const std::string& display) {
  return parse_json_text(read_text_file(path, display), display);
}

Loader::Loader(Home home) : home_(std::move(home)), schemas_(home_.schemas()) {}

fs::path Loader::find_named(const std::string& ref, const fs::path& dir, const fs::path& base,
                            const std::string& file, const std::string& pointer,
                            const char* what) const {
  std::error_code ec;
  if (looks_like_path(ref)) {
    const fs::path p = fs::path(ref).is_absolute() ? fs::path(ref) : base / ref;
    if (!fs::exists(p, ec))
      throw InputError(file, pointer,
                       std::string(what) + " file '" + ref + "' not found (looked at " +
                           display_path(p.lexically_normal()) + ")");
    if (!fs::is_regular_file(p, ec))
      throw InputError(file, pointer,
                       std::string(what) + " file '" + ref + "' is not a regular file (" +
                           (fs::is_directory(p, ec) ? "a folder" : "a device, FIFO or socket") +
                           "); give the path of a " + what + " JSON file");
    return p.lexically_normal();
  }
  const fs::path p = dir / (ref + ".json");
  if (fs::exists(p, ec)) return p;
  std::string known;
  for (const auto& e : catalogue(dir, what))
    known += (known.empty() ? "" : ", ") + e.name;
  throw InputError(file, pointer,
                   "unknown " + std::string(what) + " '" + ref + "' (known: " + known +
                       "; or give a path to a " + what + " JSON file)");
}

namespace {

// A workload document (before its defaults) gives its working set one way: working_set_kb or
// working_set (sized from the platform's caches), not both. `pointer`: where the document is in
// `file` ("" for a workload file).
void check_one_working_set(const json& doc, const std::string& file, const std::string& pointer) {
  if (!doc.is_object() || !doc.contains("hw") || !doc["hw"].is_object()) return;
  const auto& hw = doc["hw"];
  if (hw.contains("working_set") && hw.contains("working_set_kb"))
    throw InputError(file, pointer + "/hw/working_set",
                     "give the working set one way: working_set_kb (fixed) or working_set "
                     "(sized from the platform's caches), not both");
}

}  // namespace

PlatformInfo Loader::host_platform(const std::string& backend, const std::string& file,
                                   const std::string& pointer) {
  if (auto it = host_cache_.find(backend); it != host_cache_.end()) {
    host_used_[backend] = host_records_.at(backend);
    return it->second;
  }
  host_warnings_.erase(backend);
  HostPlatform host;
  if (backend == "hw") {
#ifdef ROSGUARD_WITH_HW
    host = probed_host_platform(schemas_);
#else
    throw InputError(file, pointer,
                     "platform \"host\" on the hw backend needs a rosguard built with it "
                     "(ROSGUARD_WITH_HW=ON); this one is not, so only --backend sim with an "
                     "installed host model can use \"host\"");
#endif
  } else {
    auto installed = installed_host_model(schemas_);
    if (!installed)
      throw InputError(file, pointer,
                       "no calibrated model of this host: run `rosguard calibrate --install` (or "
                       "use --backend hw); looked for " +
                           host_model_path().string() +
                           " ($ROSGUARD_HOST_MODEL, else $XDG_DATA_HOME or "
                           "~/.local/share/rosguard/host/platform.json)");
    host = std::move(*installed);
  }
  PlatformInfo info = build_platform(host.doc, host.origin);
  // A model of another machine (or of an unknown one) is used, with a warning.
  if (host.machine && !host.machine->warning.empty())
    host_warnings_[backend] =
        (backend == "hw" ? "platform \"host\" on hw takes its reference bandwidth, memory model "
                           "and costs from the installed host model, but "
                         : "platform \"host\" in sim runs the installed host model, but ") +
        host.machine->warning;
  host_cache_[backend] = info;
  host_records_[backend] = host.record;
  host_used_[backend] = host.record;
  return info;
}

PlatformInfo Loader::resolve_platform(const json& ref, const fs::path& base,
                                      const std::string& file, const std::string& pointer,
                                      const std::string& backend) {
  if (ref.get<std::string>() == kHostPlatform) return host_platform(backend, file, pointer);
  // Every point names its platform: a reference seen before skips the file system.
  const std::string ref_key = "platform\n" + base.string() + "\n" + ref.get<std::string>();
  if (auto seen = resolved_.find(ref_key); seen != resolved_.end())
    return platform_cache_.at(seen->second);
  const fs::path path =
      find_named(ref.get<std::string>(), home_.platforms(), base, file, pointer, "platform");
  const std::string key = fs::weakly_canonical(path).string();
  if (auto it = platform_cache_.find(key); it != platform_cache_.end()) {
    resolved_[ref_key] = key;
    return it->second;
  }
  const std::string shown = display_path(path);
  json doc = read_json_file(path, shown);
  schemas_.validate(doc, SchemaKind::Platform, shown);
  schemas_.apply_defaults(doc, SchemaKind::Platform);
  PlatformInfo info = build_platform(doc, shown);
  platform_cache_[key] = info;
  resolved_[ref_key] = key;
  return info;
}

WorkloadInfo Loader::resolve_workload(const json& ref, const fs::path& base,
                                      const std::string& file, const std::string& pointer) {
  if (ref.is_object()) {
    // Inline: validated by the scenario schema already; defaults from the workload schema.
    WorkloadInfo w;
    json doc = ref;
    check_one_working_set(doc, file, pointer);
    if (!doc.contains("command")) schemas_.apply_defaults(doc, SchemaKind::Workload);
    w.doc = std::move(doc);
    w.name = ref.value("name", w.is_command() ? ref["command"][0].get<std::string>() : "inline");
    w.origin = "inline";
    return w;
  }
  const std::string ref_key = "workload\n" + base.string() + "\n" + ref.get<std::string>();
  if (auto seen = resolved_.find(ref_key); seen != resolved_.end())
    return workload_cache_.at(seen->second);
  const fs::path path =
      find_named(ref.get<std::string>(), home_.workloads(), base, file, pointer, "workload");
  const std::string key = fs::weakly_canonical(path).string();
  if (auto it = workload_cache_.find(key); it != workload_cache_.end()) {
    resolved_[ref_key] = key;
    return it->second;
  }
  const std::string shown = display_path(path);
  json doc = read_json_file(path, shown);
  schemas_.validate(doc, SchemaKind::Workload, shown);
  check_one_working_set(doc, shown, "");
  schemas_.apply_defaults(doc, SchemaKind::Workload);
  WorkloadInfo w{doc.at("name").get<std::string>(), shown, doc};
  workload_cache_[key] = w;
  resolved_[ref_key] = key;
  return w;
}

WorkloadInfo Loader::sized_workload(const WorkloadInfo& w, const PlatformInfo& platform,
                                    const std::string& file, const std::string& pointer) {
  if (w.is_command() || !w.doc.contains("hw") || !w.doc.at("hw").contains("working_set")) return w;
  // One sized copy per workload and platform, shared by the points (a sweep holds every point).
  const std::string key = std::to_string(w.doc.hash()) + "\n" + std::to_string(platform.doc.hash());
  if (auto it = sized_cache_.find(key); it != sized_cache_.end()) return it->second;
  const bool inline_workload = w.origin == "inline";
  WorkloadInfo sized = size_working_set(w, platform, inline_workload ? file : w.origin,
                                        (inline_workload ? pointer : "") + "/hw/working_set");
  sized_cache_[key] = sized;
  return sized;
}

Scenario Loader::build_point(json document, const std::string& file, bool skip_schema) {
  const fs::path base = fs::path(file).parent_path();
  // Before the schema's defaults: sampling and the periods default by policy (memguard samples
  // by overflow with a 1 ms period), and only where this point does not set them.
  std::vector<std::string> policy_defaults;
  if (document.is_object() && document.contains("regulation"))
    policy_defaults = apply_policy_defaults(document["regulation"]);
  schemas_.apply_defaults(document, SchemaKind::Scenario);
  if (document.is_object() && document.contains("regulation"))  // "regulation" was absent
    apply_policy_defaults(document["regulation"]);
  if (!skip_schema)
    if (auto err = schemas_.first_error(document, SchemaKind::Scenario))
      throw InputError(file, err->first, err->second);
  ResolvedRefs refs;
  {
    const std::lock_guard<std::mutex> lock(refs_mutex_);  // the caches (load_points' threads)
    refs.platform = resolve_platform(document["platform"], base, file, "/platform",
                                     document["backend"].get<std::string>());
    const auto& nodes = document["nodes"];
    for (std::size_t i = 0; i < nodes["rt"].size(); ++i)
      refs.rt_workloads.push_back(resolve_workload(nodes["rt"][i]["workload"], base, file,
                                                   "/nodes/rt/" + std::to_string(i) + "/workload"));
    for (std::size_t i = 0; i < nodes["nrt"].size(); ++i)
      refs.nrt_workloads.push_back(
          resolve_workload(nodes["nrt"][i]["workload"], base, file,
                           "/nodes/nrt/" + std::to_string(i) + "/workload"));
    for (std::size_t i = 0; i < refs.rt_workloads.size(); ++i)
      refs.rt_workloads[i] = sized_workload(refs.rt_workloads[i], refs.platform, file,
                                            "/nodes/rt/" + std::to_string(i) + "/workload");
    for (std::size_t i = 0; i < refs.nrt_workloads.size(); ++i)
      refs.nrt_workloads[i] = sized_workload(refs.nrt_workloads[i], refs.platform, file,
                                             "/nodes/nrt/" + std::to_string(i) + "/workload");
  }
  Scenario s = build_scenario(document, std::move(refs), file);
  s.regulation.policy_defaults = std::move(policy_defaults);
  return s;
}

InputError Loader::attribute_to_sweep(const InputError& e, const SweepPoint& p,
                                      const LoadedScenario& out) {
  const std::map<std::string, std::string>& sweep_pointers = out.source->sweep_pointers;
  const std::string& file = out.file;
  const std::string& path = e.json_path();
  const std::string& msg = e.message();
  for (const SweepParam& q : p.params) {
    const std::string& sp = sweep_pointers.at(q.path);
    if (path == sp || path.rfind(sp + "/", 0) == 0 || sp.rfind(path + "/", 0) == 0) {
      const std::string where = "/sweep/" + escape_token(q.key);
      // An unknown key on the sweep path means the path is wrong; one inside the swept value
      // (an object) is that value's fault.
      const bool inside_value = path.rfind(sp + "/", 0) == 0;
      if (msg.rfind("unknown key", 0) == 0 && !inside_value)
        return InputError(file, where, "this path does not exist in a scenario: " + msg);
      std::string at = where + "/" + std::to_string(q.value_index);
      if (q.key != q.path) at += "/" + std::to_string(q.component);
      return InputError(file, at, msg + (path == sp ? "" : " (at " + path + ")"));
    }
  }
  json unswept = out.expanded;
  unswept.erase("sweep");
  try {
    build_point(unswept, file);
  } catch (const InputError& b) {
    if (b.json_path() == path && b.message() == msg) return b;
  }
  return InputError(file, path, msg + " (in sweep point " + params_text(p) + ")");
}

LoadedGuard Loader::load_guard(const std::string& file, const PolicyRegistry& policies) {
  LoadedGuard out;
  out.file = display_path(file);
  out.document = read_json_file(file, out.file);
  schemas_.validate(out.document, SchemaKind::Guard, out.file);
  schemas_.apply_defaults(out.document, SchemaKind::Guard);
  const json& doc = out.document;
  json reg = doc.at("regulation");
  // The guard's controller reads every core's counters; what it counts is its PMC source's
  // choice at start (the metric the guard puts in the setup), so the configuration has none.
  reg["sampling"] = "external";
  reg["metric"] = {{"line_bytes", 64}, {"events", json::object()}};
  NodesSpec nodes;
  for (const auto& n : doc.at("nrt")) {
    NrtNodeSpec spec;
    spec.core = n.at("core").get<int>();
    spec.name = n.value("name", "core" + std::to_string(spec.core));
    nodes.nrt.push_back(std::move(spec));
  }
  const bool monolithic = reg.at("policy") == "monolithic";
  if (monolithic != reg.contains("rt_window_us"))
    throw InputError(out.file, "/regulation/rt_window_us",
                     monolithic ? "policy \"monolithic\" needs the RT execution its budget covers "
                                  "(rt_window_us: the RT node's time alone, in us)"
                                : "only policy \"monolithic\" uses rt_window_us (this is \"" +
                                      reg.at("policy").get<std::string>() + "\")");
  const RegulationSpec spec = build_regulation(reg, PlatformInfo{}, nodes, out.file);
  out.regulation =
      regulation_setup(spec, {doc.at("rt").size(), nodes.nrt.size()}, policies, out.file);
  if (monolithic)
    out.regulation.params.monolithic_window_ns = reg.at("rt_window_us").get<TimeNs>() * kNsPerUs;
  return out;
}

LoadedScenario Loader::load(const std::string& file, const std::optional<std::string>& backend,
                            PointSelection selection) {
  LoadedScenario out = load_base(file, backend);
  load_points(out, selection);
  return out;
}

LoadedScenario Loader::load_base(const std::string& file,
                                 const std::optional<std::string>& backend) {
  LoadedScenario out;
  out.file = file;
  host_used_ = json();
  // The installed model is re-read by every load (cheap; it may have been reinstalled); the
  // probe of the host is kept for the Loader's life (one run).
  host_cache_.erase("sim");
  host_records_.erase("sim");
  host_warnings_.erase("sim");
  const std::string text = read_text_file(file, file);
  out.given = parse_json_text(text, file);
  schemas_.validate(out.given, SchemaKind::Scenario, file);
  out.sweep_keys = sweep_key_order(text);

  out.expanded = out.given;
  if (backend) out.expanded["backend"] = *backend;
  schemas_.apply_defaults(out.expanded, SchemaKind::Scenario);
  schemas_.validate(out.expanded, SchemaKind::Scenario, file);

  out.source = std::make_shared<const SweepSource>(out.expanded, out.sweep_keys, file);
  out.point_count = out.source->plan.count();
  for (const auto& key : out.sweep_keys)
    for (const auto& path : split_sweep_key(key))
      out.sweep_paths.push_back(path);
  return out;
}

LoadedPoint Loader::point(const LoadedScenario& loaded, std::uint64_t index, bool skip_schema) {
  if (!loaded.source) throw ContractError("Loader::point: a scenario without its sweep source");
  SweepPoint p;
  try {
    p = loaded.source->plan.point(index);
  } catch (const SweepPathError& e) {
    throw in_file(loaded.file, e);
  }
  try {
    Scenario s = build_point(p.document, loaded.file, skip_schema);
    // The point's document lives on in the Scenario (with its defaults); one copy is enough
    // (a sweep of 10,000 points is held in memory).
    p.document = nullptr;
    return {std::move(p), std::move(s)};
  } catch (const InputError& e) {
    if (e.file() != loaded.file) throw;
    throw attribute_to_sweep(e, p, loaded);
  }
}

void Loader::load_points(LoadedScenario& out, PointSelection selection, unsigned threads) {
  // An error in one point names the sweep value that caused it (a problem inside a platform or
  // workload file is reported as it is), on several threads the first point's that has one.
  const std::vector<std::uint64_t> indexes =
      selected_points(out.point_count, out.source->plan.sizes(), selection);
  std::vector<std::optional<LoadedPoint>> built(indexes.size());
  parallel_for(indexes.size(), threads, [&](std::size_t i) { built[i] = point(out, indexes[i]); });
  out.points.reserve(indexes.size());
  for (auto& p : built)
    out.points.push_back(std::move(*p));
  for (const auto& p : out.points)
    for (const auto& d : p.scenario.regulation.policy_defaults) {
      auto it = std::find_if(out.policy_defaults.begin(), out.policy_defaults.end(),
                             [&](const auto& e) { return e.first == d; });
      if (it == out.policy_defaults.end())
        out.policy_defaults.emplace_back(d, 1);
      else
        ++it->second;
    }
  for (auto& w : controller_sharing_warnings(out.points))
    out.warnings.push_back(std::move(w));
  for (auto& w : ineffective_budget_warnings(out.points))
    out.warnings.push_back(std::move(w));
  for (auto& w : prior_dominated_warnings(out.points))
    out.warnings.push_back(std::move(w));
  for (auto& w : placeholder_warnings(out.points))
    out.warnings.push_back(std::move(w));
  out.host_platform = host_used_;
  // "platform": "host" with a model of another machine: in the manifest (the warnings) and
  // printed once per Loader (a tune runs many loads).
  if (host_used_.is_object())
    for (const auto& [backend, _] : host_used_.items())
      if (auto it = host_warnings_.find(backend); it != host_warnings_.end()) {
        if (std::find(out.warnings.begin(), out.warnings.end(), it->second) == out.warnings.end())
          out.warnings.push_back(it->second);
        if (printed_.insert(it->second).second) std::cerr << "warning: " << it->second << "\n";
      }
}

void Loader::print_warnings(const LoadedScenario& loaded) {
  for (const auto& w : loaded.warnings)
    if (printed_.insert(w).second) std::cerr << "warning: " << w << "\n";
}

std::vector<CatalogEntry> Loader::platforms() const {
  return catalogue(home_.platforms(), "platform");
}

std::vector<CatalogEntry> Loader::workloads() const {
  return catalogue(home_.workloads(), "workload");
}

}  // namespace rosguard
