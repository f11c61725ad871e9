// Loading scenarios from files: parse -> validate against the schema -> apply defaults ->
// expand the sweep -> resolve platform and workload references -> typed, checked Scenario per
// point. Every problem is an InputError naming the file and the JSON path; nothing is written.
#pragma once

#include <cstdint>
#include <filesystem>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "load/host_model.h"
#include "load/schema.h"
#include "regulator/setup.h"
#include "scenario/scenario.h"
#include "scenario/sweep.h"

namespace rosguard {

// Where rosguard's own files live (scenarios/, analysis/): ROSGUARD_HOME when set (it must hold
// scenarios/schema/); else <bin>/../share/rosguard next to an installed executable; else the
// source tree a build-tree executable was configured from. Throws RunError when none holds them.
struct Home {
  std::filesystem::path root;
  static Home locate();
  std::filesystem::path scenarios() const { return root / "scenarios"; }
  std::filesystem::path schemas() const { return root / "scenarios" / "schema"; }
  std::filesystem::path platforms() const { return root / "scenarios" / "platforms"; }
  std::filesystem::path workloads() const { return root / "scenarios" / "workloads"; }
  // The file a command's argument names: `given` itself when it exists (or is absolute); else,
  // for a relative path that names a file in rosguard's data (root / given, e.g.
  // scenarios/quickstart.json or docs/guard/example.json), that file, so that the examples of
  // the help texts and the docs run from any folder; else `given`, whose error then names it.
  std::string data_file(const std::string& given) const;
};

struct LoadedPoint {
  SweepPoint sweep;
  Scenario scenario;
};

// A sweep may have at most this many points: each is validated and held in memory before the
// first runs (the runner's peak memory grows by about 15 KB per point: 151 MB for the 10,000
// points of scenarios/bench/sweep-10k.json, measured by `make bench-large`).
inline constexpr std::uint64_t kMaxSweepPoints = 200000;
// `check` builds every point of a sweep up to this size, and a sample of a larger one.
inline constexpr std::uint64_t kCheckAllPoints = 2000;

// Which points load() builds: All (run), or Sample (check: all of a sweep of at most
// kCheckAllPoints points; of a larger one, every value of every key at least once).
enum class PointSelection { All, Sample };

// What building any point of a loaded scenario again needs (Loader::point): the expanded
// document, its sweep plan, and where each swept path is. Immutable; defined in loader.cpp.
struct SweepSource;

struct LoadedScenario {
  std::string file;
  std::uint64_t point_count = 0;  // points of the sweep; `points` holds them all unless sampled
  nlohmann::json given;           // as written
  nlohmann::json expanded;        // defaults applied, sweep still in place
  std::vector<std::string> sweep_keys;   // as written (a key may join paths with '+')
  std::vector<std::string> sweep_paths;  // every swept path, in key order
  std::vector<LoadedPoint> points;       // in order; with PointSelection::Sample maybe a subset
  std::vector<std::string> warnings;     // e.g. the controller shares a core with a node
  // Keys a policy's own defaults filled in where points did not set them, each with how many
  // points ("sampling = overflow (memguard's default)" -> 3), in first-seen order.
  std::vector<std::pair<std::string, std::size_t>> policy_defaults;
  // For the manifest, when a point uses "platform": "host": per backend ("hw", "sim"), how the
  // host platform was made (the probe, the installed model's file). Null otherwise.
  nlohmann::json host_platform;
  std::shared_ptr<const SweepSource> source;  // set by Loader::load_base (and load)
};

// A catalogue entry for `rosguard list`.
struct CatalogEntry {
  std::string name;
  std::string summary;
  std::filesystem::path file;
};

// A guard configuration (guard.schema.json) as Loader::load_guard reads it.
struct LoadedGuard {
  std::string file;         // as shown in messages
  nlohmann::json document;  // defaults applied
  RegulationSetup regulation;
};

class Loader {
 public:
  explicit Loader(Home home);

  // `backend` overrides the scenario's "backend" key (rosguard run --backend).
  LoadedScenario load(const std::string& file, const std::optional<std::string>& backend = {},
                      PointSelection selection = PointSelection::All);

  // load() in two steps. load_base: the scenario file itself (schema, defaults, sweep paths and
  // plan): `points`, `warnings` and `host_platform` stay empty. load_points: builds the
  // selected points of a load_base result and fills them in. `rosguard run` starts its task
  // host between the two (it forks a process that holds no point: task_pool.h).
  LoadedScenario load_base(const std::string& file, const std::optional<std::string>& backend = {});
  // `threads`: how many threads build the points (rosguard run: its --jobs).
  void load_points(LoadedScenario& loaded, PointSelection selection = PointSelection::All,
                   unsigned threads = 1);
  // Point `index` of a scenario from load_base or load, built as load_points builds it (an
  // error names the sweep value that caused it). `skip_schema`: the document is not checked
  // against the scenario schema again (only for a point that load_points already built in
  // another process of this run: the same document, so the same answer).
  LoadedPoint point(const LoadedScenario& loaded, std::uint64_t index, bool skip_schema = false);

  // A guard configuration read the way a scenario is: parsed, checked against its schema,
  // defaults applied; its regulation built into the same RegulationSpec as a scenario's
  // (build_regulation; sampling external: the guard's controller reads every core) and set up
  // with `policies` (regulation_setup: the policy's rules, periods in ns). Throws InputError
  // naming the file and the JSON path.
  LoadedGuard load_guard(const std::string& file, const PolicyRegistry& policies);
  std::vector<CatalogEntry> platforms() const;
  std::vector<CatalogEntry> workloads() const;

  const Home& home() const { return home_; }

  // Prints `loaded`'s warnings on stderr ("warning: ..."), each once per Loader: those
  // load_points printed already (a host model of another machine) are not said again. `check`
  // and `run` call it once the points are loaded.
  void print_warnings(const LoadedScenario& loaded);

 private:
  // One point's scenario from its document (defaults applied here): schema, references, rules.
  Scenario build_point(nlohmann::json document, const std::string& file, bool skip_schema = false);
  // The error `e` of point `p`, at the sweep value that caused it; an error the scenario has
  // without any sweep value is reported plainly.
  InputError attribute_to_sweep(const InputError& e, const SweepPoint& p,
                                const LoadedScenario& out);
  PlatformInfo resolve_platform(const nlohmann::json& ref, const std::filesystem::path& base,
                                const std::string& file, const std::string& pointer,
                                const std::string& backend);
  // "platform": "host" on `backend`: probed (hw, once per Loader) or the installed model (sim).
  PlatformInfo host_platform(const std::string& backend, const std::string& file,
                             const std::string& pointer);
  WorkloadInfo resolve_workload(const nlohmann::json& ref, const std::filesystem::path& base,
                                const std::string& file, const std::string& pointer);
  // `w` with hw.working_set sized on `platform` (size_working_set), cached per workload and
  // platform; `pointer`: the node's workload in the scenario `file` (for an inline workload).
  WorkloadInfo sized_workload(const WorkloadInfo& w, const PlatformInfo& platform,
                              const std::string& file, const std::string& pointer);
  std::filesystem::path find_named(const std::string& ref, const std::filesystem::path& dir,
                                   const std::filesystem::path& base, const std::string& file,
                                   const std::string& pointer, const char* what) const;

  Home home_;
  SchemaSet schemas_;
  std::mutex refs_mutex_;  // the caches below (points are built on several threads)
  std::map<std::string, PlatformInfo> platform_cache_;
  std::map<std::string, WorkloadInfo> workload_cache_;
  // "<workload document hash>\n<platform document hash>" -> the workload sized on that platform
  std::map<std::string, WorkloadInfo> sized_cache_;
  // "platform|workload\n<base folder>\n<reference>" -> its cache key (the canonical path)
  std::map<std::string, std::string> resolved_;
  std::map<std::string, PlatformInfo> host_cache_;      // by backend
  std::map<std::string, nlohmann::json> host_records_;  // by backend
  nlohmann::json host_used_;                            // this load's records (manifest)
  std::map<std::string, std::string> host_warnings_;    // by backend: the model's machine
  std::set<std::string> printed_;                       // warnings printed by this Loader
};

// Bounds on what a scenario, platform or workload file may be: past them an input could exhaust
// the stack (deep nesting; std::regex recurses per character of a string) or the memory.
inline constexpr std::size_t kMaxJsonDepth = 64;
inline constexpr std::size_t kMaxJsonStringChars = 4096;
inline constexpr std::size_t kMaxJsonFileBytes = std::size_t{16} << 20;

// Reads a regular file of at most kMaxJsonFileBytes (a FIFO, a device or a folder is an
// InputError: reading one could block or never end).
std::string read_text_file(const std::filesystem::path& path, const std::string& display);

// Parses JSON text. Syntax errors (with line and column), duplicate keys, numbers beyond a
// double, nesting deeper than kMaxJsonDepth and strings or keys longer than kMaxJsonStringChars
// are InputErrors naming `display` and the JSON path.
nlohmann::json parse_json_text(const std::string& text, const std::string& display);

// read_text_file + parse_json_text.
nlohmann::json read_json_file(const std::filesystem::path& path, const std::string& display);

// How a path is shown in messages: relative to the working directory when that is shorter
// (an absolute path stays absolute when the working directory is /).
std::string display_path(const std::filesystem::path& path);

}  // namespace rosguard
