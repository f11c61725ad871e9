// The scenario loader (tools/rosguard/load/loader.h): schema defaults, the platform's reference
// bandwidth, sweep order and error attribution, workload references, duplicate keys, errors in
// referenced files, and the catalogue. Scenarios use backend "hw" (the workloads have no sim
// profiles yet); both backends validate the same way otherwise. The invalid-scenario corpus
// (tests/invalid/) covers the CLI messages; these tests cover what it does not.
#include <unistd.h>

#include <atomic>
#include <catch2/catch.hpp>
#include <filesystem>
#include <fstream>
#include <functional>
#include <string>
#include <vector>

#include "core/error.h"
#include "load/loader.h"

using namespace rosguard;
namespace fs = std::filesystem;
using json = nlohmann::json;
using Catch::Matchers::Contains;
using Catch::Matchers::EndsWith;
using Catch::Matchers::StartsWith;

namespace {

// A fresh directory per use, removed afterwards.
class TempDir {
 public:
  TempDir() {
    static std::atomic<int> counter{0};
    path_ = fs::temp_directory_path() /
            ("rosguard-loader-" + std::to_string(::getpid()) + "-" + std::to_string(counter++));
    fs::remove_all(path_);
    fs::create_directories(path_);
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path_, ec);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;

  // Writes `text` to `relative` (creating folders) and returns its absolute path.
  std::string write(const std::string& relative, const std::string& text) const {
    const fs::path p = path_ / relative;
    fs::create_directories(p.parent_path());
    std::ofstream(p) << text;
    return p.string();
  }
  const fs::path& path() const { return path_; }

 private:
  fs::path path_;
};

// RT node rt0 on core 1 and nRT node nrt0 on core 2, both running `workload`; `extra` adds
// top-level keys (written first, with a trailing comma).
std::string scenario(const std::string& extra = "", const std::string& rt_workload = "\"mser\"",
                     const std::string& nrt_workload = "\"mser\"") {
  return "{" + extra + R"( "name": "t", "backend": "hw",
  "nodes": {
    "controller": { "core": 0 },
    "rt":  [ { "name": "rt0",  "core": 1, "workload": )" +
         rt_workload + R"( } ],
    "nrt": [ { "name": "nrt0", "core": 2, "workload": )" +
         nrt_workload + R"( } ]
  }
})";
}

Loader make_loader() {
  return Loader(Home::locate());
}

// The InputError that loading `file` throws.
InputError load_error(const std::string& file) {
  Loader loader = make_loader();
  try {
    loader.load(file);
  } catch (const InputError& e) {
    return e;
  }
  FAIL("loading " << file << " did not fail");
  throw std::logic_error("unreachable");
}

}  // namespace

// --- defaults ------------------------------------------------------------------------------

TEST_CASE("loader: schema defaults fill what the scenario leaves out", "[loader]") {
  TempDir dir;
  const auto file = dir.write("s.json", scenario("", "\"mser\"", "\"sift\""));
  Loader loader = make_loader();
  const LoadedScenario ls = loader.load(file);
  REQUIRE(ls.points.size() == 1);
  const Scenario& s = ls.points[0].scenario;
  CHECK_FALSE(ls.given.contains("regulation"));

  const RegulationSpec& r = s.regulation;
  CHECK(r.policy == "interval");
  CHECK(r.sampling == Sampling::Self);
  CHECK(r.sampling_period_us == 1000);
  CHECK(r.regulation_period_us == 5000);
  CHECK(r.threshold_pct == 20.0);
  CHECK(r.scope == Scope::Core);
  CHECK(r.metric.line_bytes == 64);
  REQUIRE(r.metric.events.size() == 2);
  CHECK(r.metric.events[0].name == "l2d_cache_refill");
  CHECK(r.metric.events[0].weight == 1.0);
  CHECK(r.metric.events[1].name == "l2d_cache_wb");
  CHECK(r.metric.events[1].weight == 1.0);
  CHECK(r.metric.counter_bits == 64);  // from the platform

  CHECK(s.platform.name == "orin-agx");
  CHECK(s.platform.cores() == 12);
  CHECK(s.seed == 1);
  CHECK(s.repetitions == 1);
  CHECK(s.nodes.rt[0].iterations == 1);
  CHECK_FALSE(s.nodes.rt[0].period_us.has_value());
  CHECK(s.nodes.nrt[0].workload.name == "sift");
  CHECK(s.sim.quantum_us == 10.0);
  CHECK(s.hw.pmc_source == PmcSourceKind::Auto);
  CHECK(s.hw.scheduler == SchedulerKind::Fifo);
  CHECK(s.hw.watchdog_ms == 100);

  // The expanded document carries the defaults too (it goes into the manifest).
  CHECK(ls.expanded["regulation"]["policy"] == "interval");
  CHECK(ls.expanded["regulation"]["metric"]["events"] ==
        json({{"l2d_cache_refill", 1}, {"l2d_cache_wb", 1}}));
  CHECK(ls.expanded["platform"] == "orin-agx");
  CHECK(ls.expanded["sweep"] == json::object());
  CHECK_FALSE(ls.expanded["regulation"].contains("reference_mbps"));
}

TEST_CASE("loader: the seed is read exactly over the whole u64 range", "[loader]") {
  TempDir dir;
  Loader loader = make_loader();
  SECTION("given") {
    const LoadedScenario ls =
        loader.load(dir.write("s.json", scenario(R"("seed": 18446744073709551615,)")));
    CHECK(ls.points[0].scenario.seed == 18446744073709551615ULL);
    CHECK(ls.expanded["seed"].dump() == "18446744073709551615");
  }
  SECTION("swept") {
    const LoadedScenario ls = loader.load(dir.write(
        "s.json",
        scenario(R"("sweep": {"seed": [0, 9223372036854775808, 18446744073709551615]},)")));
    REQUIRE(ls.points.size() == 3);
    CHECK(ls.points[0].scenario.seed == 0);
    CHECK(ls.points[1].scenario.seed == 9223372036854775808ULL);
    CHECK(ls.points[2].scenario.seed == 18446744073709551615ULL);
  }
  SECTION("beyond it: an input error naming the file and the path") {
    const auto file = dir.write("s.json", scenario(R"("seed": 18446744073709551616,)"));
    const InputError e = load_error(file);
    CHECK_THAT(e.what(), Contains(file) && Contains("/seed") &&
                             Contains("must be an integer in [0, 18446744073709551615]"));
  }
}

TEST_CASE("loader: nRT mode defaults to loop with RT nodes and to once without", "[loader]") {
  TempDir dir;
  Loader loader = make_loader();
  SECTION("with an RT node: loop") {
    const auto s = loader.load(dir.write("s.json", scenario())).points.at(0).scenario;
    CHECK(s.nodes.nrt[0].mode == NrtMode::Loop);
  }
  SECTION("with an RT node, once when asked") {
    const auto file = dir.write("s.json", R"({"name": "t", "backend": "hw", "nodes": {
      "controller": {"core": 0}, "rt": [{"name": "rt0", "core": 1, "workload": "mser"}],
      "nrt": [{"name": "nrt0", "core": 2, "workload": "mser", "mode": "once"}]}})");
    CHECK(loader.load(file).points.at(0).scenario.nodes.nrt[0].mode == NrtMode::Once);
  }
  SECTION("without RT nodes: once") {
    const auto file = dir.write("s.json", R"({"name": "t", "backend": "hw", "nodes": {
      "controller": {"core": 0}, "nrt": [{"name": "nrt0", "core": 2, "workload": "mser"}]}})");
    const auto s = loader.load(file).points.at(0).scenario;
    CHECK(s.nodes.rt.empty());
    CHECK(s.nodes.nrt[0].mode == NrtMode::Once);
  }
}

TEST_CASE("loader: absent reference_mbps means the platform's 26271.74 MB/s", "[loader]") {
  TempDir dir;
  Loader loader = make_loader();
  const auto implicit = loader.load(dir.write("a.json", scenario())).points.at(0).scenario;
  CHECK(implicit.regulation.reference_mbps == 26271.74);
  CHECK(implicit.regulation.reference_from_platform);
  CHECK(implicit.platform.reference_mbps == 26271.74);

  const auto explicit_ =
      loader.load(dir.write("b.json", scenario(R"("regulation": {"reference_mbps": 20000},)")))
          .points.at(0)
          .scenario;
  CHECK(explicit_.regulation.reference_mbps == 20000.0);
  CHECK_FALSE(explicit_.regulation.reference_from_platform);
}

TEST_CASE("loader: the backend given on the command line overrides the scenario's", "[loader]") {
  TempDir dir;
  // "sim" in the file; the workloads have no sim profile, so only the override makes it load.
  const auto file = dir.write("s.json", R"({"name": "t", "backend": "sim", "nodes": {
      "controller": {"core": 0}, "rt": [{"name": "rt0", "core": 1, "workload": "mser"}]}})");
  Loader loader = make_loader();
  const auto ls = loader.load(file, std::string("hw"));
  CHECK(ls.points.at(0).scenario.backend == "hw");
  CHECK(ls.expanded["backend"] == "hw");
  CHECK(ls.given["backend"] == "sim");
}

// --- sweeps --------------------------------------------------------------------------------

TEST_CASE("loader: sweep points follow the key order as written, not alphabetical", "[loader]") {
  TempDir dir;
  // "regulation..." is written before "nodes...": the reverse of the sorted order.
  const auto file = dir.write("s.json", scenario(R"("sweep": {
      "regulation.threshold_pct": [10, 30],
      "nodes.nrt[0].workload": ["sift", "tracking"] },)"));
  Loader loader = make_loader();
  const LoadedScenario ls = loader.load(file);
  CHECK(ls.given["sweep"].begin().key() == "nodes.nrt[0].workload");  // JSON objects sort keys
  CHECK(ls.sweep_keys ==
        std::vector<std::string>{"regulation.threshold_pct", "nodes.nrt[0].workload"});
  REQUIRE(ls.points.size() == 4);
  const std::vector<std::pair<double, std::string>> expected = {
      {10, "sift"}, {10, "tracking"}, {30, "sift"}, {30, "tracking"}};
  for (std::size_t i = 0; i < 4; ++i) {
    INFO("point " << i);
    const Scenario& s = ls.points[i].scenario;
    CHECK(s.regulation.threshold_pct == expected[i].first);
    CHECK(s.nodes.nrt[0].workload.name == expected[i].second);
    CHECK(ls.points[i].sweep.params.at(0).path == "regulation.threshold_pct");
    CHECK(ls.points[i].sweep.params.at(1).path == "nodes.nrt[0].workload");
    CHECK(ls.points[i].sweep.index == i);
  }
}

TEST_CASE("loader: a sweep value error is attributed to /sweep/<key>/<index>", "[loader]") {
  TempDir dir;
  SECTION("a reference the value makes: an unknown workload") {
    const auto e = load_error(
        dir.write("s.json", scenario(R"("sweep": {"nodes.rt[0].workload": ["mser", "msre"]},)")));
    CHECK(e.json_path() == "/sweep/nodes.rt[0].workload/1");
    CHECK_THAT(e.message(), StartsWith("unknown workload 'msre' (known: bandwidth_read,"));
    CHECK_THAT(e.message(), !Contains("in sweep point"));
  }
  SECTION("a problem inside an object value names where it is") {
    const auto e = load_error(dir.write(
        "s.json",
        scenario(R"("sweep": {"regulation.metric": [{"line_bytes": 64}, {"line_bytes": 0}]},)")));
    CHECK(e.json_path() == "/sweep/regulation.metric/1");
    CHECK(e.message() == "must be in [1, 4096], not 0 (at /regulation/metric/line_bytes)");
  }
  SECTION("an unknown key inside an object value is the value's fault, not the path's") {
    const auto e = load_error(dir.write(
        "s.json",
        scenario(R"("sweep": {"regulation.metric": [{"line_bytes": 64}, {"line_byte": 64}]},)")));
    CHECK(e.json_path() == "/sweep/regulation.metric/1");
    CHECK(e.message() ==
          "unknown key 'line_byte' (did you mean 'line_bytes'?); allowed here: events, "
          "line_bytes (at /regulation/metric/line_byte)");
  }
  SECTION("a sweep key through an unknown object: the path does not exist") {
    const auto e =
        load_error(dir.write("s.json", scenario(R"("sweep": {"regulation.limits.max": [1, 2]},)")));
    CHECK(e.json_path() == "/sweep/regulation.limits.max");
    CHECK_THAT(e.message(),
               StartsWith("this path does not exist in a scenario: unknown key 'limits'"));
  }
}

TEST_CASE("loader: an error the scenario has without any sweep value is reported plainly",
          "[loader]") {
  TempDir dir;
  // Both nodes on core 1, whatever the threshold.
  const auto file =
      dir.write("s.json", R"({"name": "t", "backend": "hw", "nodes": {"controller": {"core": 0},
      "rt": [{"name": "rt0", "core": 1, "workload": "mser"}],
      "nrt": [{"name": "nrt0", "core": 1, "workload": "mser"}]},
      "sweep": {"regulation.threshold_pct": [10, 20]}})");
  const auto e = load_error(file);
  CHECK(e.file() == file);
  CHECK(e.json_path() == "/nodes/nrt/0/core");
  CHECK(e.message() ==
        "core 1 already runs node 'rt0' (one RT or nRT node per core: a throttled node's idle "
        "loop would starve the other)");
}

TEST_CASE("loader: every node placement problem is reported at once", "[loader]") {
  TempDir dir;
  // A core taken twice, a core the platform lacks, a name used twice: three problems, one report
  // (before, the shared core hid the impossible one).
  const auto file = dir.write(
      "s.json", R"({"name": "t", "platform": "orin-agx", "nodes": {"controller": {"core": 0},
      "rt": [{"name": "rt0", "core": 1, "workload": "mser"}],
      "nrt": [{"name": "n0", "core": 1, "workload": "bandwidth_read"},
              {"name": "n1", "core": 12, "workload": "bandwidth_read"},
              {"name": "n0", "core": 3, "workload": "bandwidth_read"}]}})");
  const auto e = load_error(file);
  const auto problems = e.problems();
  REQUIRE(problems.size() == 3);
  CHECK_THAT(problems[0], Contains("/nodes/nrt/0/core: core 1 already runs node 'rt0'"));
  CHECK_THAT(
      problems[1],
      Contains("/nodes/nrt/1/core: core 12 does not exist on platform orin-agx (cores 0-11)"));
  CHECK_THAT(problems[2],
             Contains("/nodes/nrt/2/name: node name 'n0' is already used at /nodes/nrt/0"));
}

TEST_CASE("loader: an error caused by a combination of sweep values names the sweep point",
          "[loader]") {
  TempDir dir;
  SECTION("one key") {
    // The default 1000 us sampling period is longer than a 500 us regulation period.
    const auto e = load_error(dir.write(
        "s.json", scenario(R"("sweep": {"regulation.regulation_period_us": [5000, 500]},)")));
    CHECK(e.json_path() == "/regulation/sampling_period_us");
    CHECK(e.message() ==
          "sampling period 1000 us is longer than the regulation period 500 us: a budget would "
          "be replenished before it could be checked (in sweep point "
          "regulation.regulation_period_us=500)");
  }
  SECTION("two keys: every parameter of the point, strings unquoted") {
    const auto e = load_error(dir.write("s.json", scenario(R"("sweep": {
        "regulation.policy": ["monolithic", "interval"],
        "regulation.regulation_period_us": [5000, 500]},)")));
    CHECK(e.json_path() == "/regulation/sampling_period_us");
    CHECK_THAT(e.message(), EndsWith("(in sweep point regulation.policy=interval, "
                                     "regulation.regulation_period_us=500)"));
  }
}

// --- references ----------------------------------------------------------------------------

TEST_CASE("loader: a workload given by path is resolved relative to the scenario file",
          "[loader]") {
  TempDir dir;
  dir.write("scen/wl/mine.json",
            R"({"name": "mine", "hw": {"kernel": "bandwidth_read", "working_set_kb": 64}})");
  dir.write("shared/other.json", R"({"name": "other", "hw": {"kernel": "proxy"}})");
  const auto file = dir.write(
      "scen/s.json",
      scenario("", "\"wl/mine.json\"", "\"" + dir.path().string() + "/shared/other.json\""));
  REQUIRE(fs::current_path() != dir.path() / "scen");

  Loader loader = make_loader();
  const Scenario s = loader.load(file).points.at(0).scenario;
  const WorkloadInfo& mine = s.nodes.rt[0].workload;
  CHECK(mine.name == "mine");
  CHECK_THAT(mine.origin, EndsWith("scen/wl/mine.json"));
  CHECK(mine.doc["hw"]["working_set_kb"] == 64);
  CHECK(mine.doc["hw"]["passes"] == 1);  // workload schema default
  const WorkloadInfo& other = s.nodes.nrt[0].workload;
  CHECK(other.name == "other");
  CHECK(other.doc["hw"]["working_set_kb"] == 2048);

  SECTION("a parent folder") {
    const auto up = dir.write("scen/sub/s.json", scenario("", "\"../../shared/other.json\""));
    CHECK(loader.load(up).points.at(0).scenario.nodes.rt[0].workload.name == "other");
  }
  SECTION("a path that exists only relative to the working directory is not found") {
    const auto e = load_error(dir.write("scen/t.json", scenario("", "\"shared/other.json\"")));
    CHECK(e.json_path() == "/nodes/rt/0/workload");
    CHECK_THAT(e.message(), StartsWith("workload file 'shared/other.json' not found (looked at "));
    CHECK_THAT(e.message(), EndsWith("scen/shared/other.json)"));
  }
}

TEST_CASE("loader: inline workload objects", "[loader]") {
  TempDir dir;
  const auto file =
      dir.write("s.json", scenario("", R"({"name": "inl", "hw": {"kernel": "bandwidth_write"}})",
                                   R"({"command": ["sleep", "1"]})"));
  Loader loader = make_loader();
  const Scenario s = loader.load(file).points.at(0).scenario;
  const WorkloadInfo& w = s.nodes.rt[0].workload;
  CHECK(w.name == "inl");
  CHECK(w.origin == "inline");
  CHECK_FALSE(w.is_command());
  CHECK(w.doc["hw"]["kernel"] == "bandwidth_write");
  CHECK(w.doc["hw"]["working_set_kb"] == 2048);  // defaults from the workload schema
  const WorkloadInfo& c = s.nodes.nrt[0].workload;
  CHECK(c.is_command());
  CHECK(c.name == "sleep");  // named after the program when it has no name
  CHECK(c.origin == "inline");
  CHECK(c.doc == json({{"command", {"sleep", "1"}}}));
}

TEST_CASE("loader: hw.working_set is sized from the platform's caches", "[loader]") {
  TempDir dir;
  // orin-agx (the default platform): 256 KB L2 per core, 2048 KB L3 per cluster.
  dir.write("wl/dram.json", R"({"name": "dram", "hw": {"kernel": "bandwidth_read",
    "working_set": {"cache": "l3", "times": 2}}})");
  const auto file =
      dir.write("s.json", scenario("", R"({"name": "llc", "hw": {"kernel": "bandwidth_read",
        "working_set": {"cache": "l2", "times": 4}}})",
                                   "\"wl/dram.json\""));
  Loader loader = make_loader();
  const Scenario s = loader.load(file).points.at(0).scenario;
  CHECK(s.nodes.rt[0].workload.doc["hw"]["working_set_kb"] == 1024);   // 4 x 256 KB
  CHECK(s.nodes.nrt[0].workload.doc["hw"]["working_set_kb"] == 4096);  // 2 x 2048 KB
  CHECK(s.nodes.nrt[0].workload.name == "dram");

  // orin-agx with other caches, written to `name`.
  const auto orin_with = [&](const std::string& name, const std::function<void(json&)>& edit) {
    std::ifstream in(Home::locate().platforms() / "orin-agx.json");
    json p = json::parse(in);
    edit(p["caches"]);
    dir.write(name, p.dump());
  };
  SECTION("on another platform, another size") {
    orin_with("big-l2.json", [](json& c) { c["l2_kb"] = 1024; });
    const auto other = dir.write(
        "other.json", scenario(R"("platform": "big-l2.json",)", R"({"name": "llc", "hw": {"kernel":
          "bandwidth_read", "working_set": {"cache": "l2", "times": 0.5}}})"));
    CHECK(
        loader.load(other).points.at(0).scenario.nodes.rt[0].workload.doc["hw"]["working_set_kb"] ==
        512);
  }
  SECTION("not together with working_set_kb: in a workload file, and inline") {
    dir.write("wl/both.json", R"({"name": "both", "hw": {"kernel": "bandwidth_read",
      "working_set_kb": 64, "working_set": {"cache": "l2", "times": 4}}})");
    auto e = load_error(dir.write("both.json", scenario("", "\"wl/both.json\"")));
    CHECK_THAT(e.file(), EndsWith("wl/both.json"));
    CHECK(e.json_path() == "/hw/working_set");
    CHECK_THAT(e.message(), Contains("not both"));
    e = load_error(dir.write("both-inline.json",
                             scenario("", R"({"name": "b", "hw": {"kernel": "bandwidth_read",
                               "working_set_kb": 64, "working_set": {"cache": "l2", "times": 4}}})")));
    CHECK(e.json_path() == "/nodes/rt/0/workload/hw/working_set");
  }
  SECTION("a platform that reports no L3") {
    orin_with("nol3.json", [](json& c) { c.erase("l3_kb_per_cluster"); });
    const auto e = load_error(dir.write(
        "s-nol3.json", scenario(R"("platform": "nol3.json",)", "\"mser\"", "\"wl/dram.json\"")));
    CHECK_THAT(e.file(), EndsWith("wl/dram.json"));
    CHECK(e.json_path() == "/hw/working_set/cache");
    CHECK_THAT(e.message(), Contains("reports no L3 size (caches.l3_kb_per_cluster)"));
  }
  SECTION("a size outside working_set_kb's bounds") {
    const auto e = load_error(
        dir.write("tiny.json", scenario("", R"({"name": "t", "hw": {"kernel": "bandwidth_read",
          "working_set": {"cache": "l2", "times": 0.001}}})")));
    CHECK(e.json_path() == "/nodes/rt/0/workload/hw/working_set/times");
    CHECK_THAT(e.message(), Contains("is 0 KB, outside 4 .. 16777216 KB"));
  }
}

// --- files ---------------------------------------------------------------------------------

TEST_CASE("read_json_file: duplicate keys are reported with their JSON pointer", "[loader]") {
  TempDir dir;
  const std::vector<std::pair<std::string, std::string>> cases = {
      {R"({"a": 1, "a": 2})", "/a"},
      {R"({"x": {"y": {"z": 1, "z": 2}}})", "/x/y/z"},
      {R"({"l": [1, {"k": 1}, {"k": 1, "k": 2}]})", "/l/2/k"},
      {R"({"l": [[1], [2, {"q": 1, "q": 2}]]})", "/l/1/1/q"},
      {R"({"a": [1, [2]], "o": {"p": 1}, "b": 1, "b": 2})", "/b"},
      {R"([{"a": 1}, {"b": [{}, {"c": 1, "c": 1}]}])", "/1/b/1/c"},
      {R"({"a/b": {"c~d": 1, "c~d": 2}})", "/a~1b/c~0d"},
      {R"({"first": {"k": 1, "k": 2}, "second": 1, "second": 2})", "/first/k"},
  };
  for (const auto& [text, pointer] : cases) {
    INFO(text);
    const auto file = dir.write("d.json", text);
    try {
      read_json_file(file, "shown.json");
      FAIL("no duplicate reported");
    } catch (const InputError& e) {
      CHECK(e.file() == "shown.json");
      CHECK(e.json_path() == pointer);
      CHECK(e.message() == "key written twice (the second would silently win)");
    }
  }
  SECTION("the same key in different objects is fine") {
    const auto file = dir.write("ok.json", R"([{"a": 1}, {"a": 2}, {"o": {"a": 3}, "a": 4}])");
    CHECK(read_json_file(file, "ok.json")[2]["a"] == 4);
  }
  SECTION("a missing file and a syntax error name the file") {
    try {
      read_json_file(dir.path() / "none.json", "none.json");
      FAIL("missing file read");
    } catch (const InputError& e) {
      CHECK(e.file() == "none.json");
      CHECK(e.message() == "cannot read the file (does it exist?)");
    }
    try {
      read_json_file(dir.write("bad.json", "{\"a\": 1,\n}"), "bad.json");
      FAIL("syntax error accepted");
    } catch (const InputError& e) {
      CHECK(e.file() == "bad.json");
      CHECK(e.json_path().empty());
      CHECK_THAT(e.message(), StartsWith("invalid JSON: parse error at line 2, column 1"));
    }
  }
}

TEST_CASE("loader: problems inside platform and workload files name that file", "[loader]") {
  TempDir dir;
  SECTION("invalid JSON in a platform file") {
    dir.write("p/broken.json", R"({"name": "p", "cpu": {)");
    const auto file = dir.write("s.json", scenario(R"("platform": "p/broken.json",)"));
    const auto e = load_error(file);
    CHECK(e.file() != file);
    CHECK_THAT(e.file(), EndsWith("p/broken.json"));
    CHECK(e.json_path().empty());
    CHECK_THAT(e.message(), StartsWith("invalid JSON:"));
  }
  SECTION("a duplicate key in a workload file reached through a sweep value") {
    dir.write("wl/dup.json",
              R"({"name": "w", "hw": {"kernel": "proxy", "kernel": "bandwidth_read"}})");
    const auto file = dir.write(
        "s.json", scenario(R"("sweep": {"nodes.rt[0].workload": ["mser", "wl/dup.json"]},)"));
    const auto e = load_error(file);
    CHECK_THAT(e.file(), EndsWith("wl/dup.json"));
    CHECK(e.json_path() == "/hw/kernel");  // not attributed to the sweep: the file is at fault
    CHECK(e.message() == "key written twice (the second would silently win)");
  }
  SECTION("a schema error in a workload file") {
    dir.write("wl/bad.json", R"({"name": "w", "hw": {"kernel": "stream"}})");
    const auto e = load_error(dir.write("s.json", scenario("", "\"wl/bad.json\"")));
    CHECK_THAT(e.file(), EndsWith("wl/bad.json"));
    CHECK(e.json_path() == "/hw/kernel");
    CHECK(
        e.message() ==
        R"(must be one of "bandwidth_read", "bandwidth_write", "latency", "proxy", not "stream")");
  }
}

// --- catalogue -----------------------------------------------------------------------------

TEST_CASE("Loader::workloads() lists the shipped workloads with their Table 1 figures",
          "[loader]") {
  Loader loader = make_loader();
  const auto workloads = loader.workloads();
  std::vector<std::string> names;
  for (const auto& w : workloads) {
    names.push_back(w.name);
    CHECK(fs::exists(w.file));
    CHECK_THAT(w.summary, !StartsWith("(invalid"));
  }
  CHECK(names == std::vector<std::string>{"bandwidth_read", "bandwidth_read_dram",
                                          "bandwidth_read_llc", "bandwidth_write",
                                          "bandwidth_write_llc", "disparity", "latency", "mser",
                                          "sift", "stitch", "tracking"});
  // The figures as written in the files: no rounding to six significant digits.
  CHECK_THAT(workloads[0].summary, StartsWith("IsolBench; IPC 1.07, 26271.74 MB/s in isolation"));
  CHECK_THAT(workloads[3].summary, StartsWith("IsolBench; IPC 1.61, 25519.15 MB/s in isolation"));
  CHECK_THAT(workloads[7].summary, StartsWith("SD-VBS; IPC 2.16, 3722.43 MB/s in isolation"));

  const auto platforms = loader.platforms();
  std::vector<std::string> platform_names;
  for (const auto& p : platforms)
    platform_names.push_back(p.name);
  CHECK(platform_names == std::vector<std::string>{"orin-agx", "vm-2core", "vm-2core-dds"});
}

TEST_CASE("loader: a controller sharing a core with a node is a warning, said once", "[loader]") {
  TempDir dir;
  const auto file =
      dir.write("s.json", R"({"name": "t", "backend": "hw", "nodes": {"controller": {"core": 1},
      "rt": [{"name": "rt0", "core": 1, "workload": "mser"}]},
      "sweep": {"regulation.threshold_pct": [10, 20]}})");
  Loader loader = make_loader();
  const auto ls = loader.load(file);
  CHECK(ls.points.size() == 2);
  REQUIRE(ls.warnings.size() == 1);
  CHECK_THAT(ls.warnings[0], StartsWith("the controller shares core 1 with node 'rt0'"));
}

TEST_CASE(
    "loader: a budget below one sampling period's traffic is a warning naming the "
    "thresholds it makes alike",
    "[loader]") {
  TempDir dir;
  // bandwidth_read: 26271.74 MiB/s in isolation, so 26.3 MiB per 1 ms sample; the budget of a
  // 5 ms period is 262.7 MiB x threshold_pct / 100: below one sample up to 19 %, not at 25 %.
  const auto file = dir.write("s.json", R"({"name": "t", "backend": "sim",
      "nodes": {"controller": {"core": 0},
        "rt": [{"name": "rt0", "core": 1, "workload": "mser"}],
        "nrt": [{"name": "nrt0", "core": 2, "workload": "bandwidth_read"}]},
      "regulation": {"policy": "interval", "sampling_period_us": 1000,
                     "regulation_period_us": 5000},
      "sweep": {"regulation.threshold_pct": [5, 19, 25]}})");
  Loader loader = make_loader();
  const auto ls = loader.load(file);
  REQUIRE(ls.warnings.size() == 1);
  CHECK_THAT(ls.warnings[0], StartsWith("budget below one sampling period's traffic: nRT node "
                                        "'nrt0' (bandwidth_read) uses about 26.3 MiB per 1000 us"));
  CHECK_THAT(ls.warnings[0], Contains("at threshold_pct 5, 19:"));
  // A shorter sampling period: one sample's traffic fits every budget.
  const auto fine = dir.write("f.json", R"({"name": "t", "backend": "sim",
      "nodes": {"controller": {"core": 0},
        "rt": [{"name": "rt0", "core": 1, "workload": "mser"}],
        "nrt": [{"name": "nrt0", "core": 2, "workload": "bandwidth_read"}]},
      "regulation": {"policy": "interval", "sampling_period_us": 100,
                     "regulation_period_us": 5000, "threshold_pct": 5}})");
  CHECK(loader.load(fine).warnings.empty());
  // An absolute budget is said as such; overflow sampling (memguard) sees the crossing itself.
  const auto absolute = dir.write("a.json", R"({"name": "t", "backend": "sim",
      "nodes": {"controller": {"core": 0},
        "rt": [{"name": "rt0", "core": 1, "workload": "mser"}],
        "nrt": [{"name": "nrt0", "core": 2, "workload": "bandwidth_read"}]},
      "regulation": {"policy": "interval", "sampling_period_us": 1000,
                     "regulation_period_us": 5000, "budget_mbps": 300},
      "sweep": {"regulation.policy+regulation.sampling": [["interval", "self"],
                                                           ["memguard", "overflow"]]}})");
  const auto la = loader.load(absolute);
  REQUIRE(la.warnings.size() == 1);
  CHECK_THAT(la.warnings[0], Contains("at budget_mbps 300:"));
  // A calibrated model of another machine (vm-2core: bandwidth_read alone 101,000 MiB/s there):
  // its own reference, not the Orin's Table 1 figure (26.3 MiB per sample: 5 % alone).
  const auto vm = dir.write("vm.json", R"({"name": "t", "backend": "sim", "platform": "vm-2core",
      "nodes": {"controller": {"core": 1},
        "nrt": [{"name": "nrt0", "core": 0, "workload": "bandwidth_read"},
                {"name": "nrt1", "core": 1, "workload": "mser"}]},
      "regulation": {"policy": "interval", "sampling_period_us": 1000,
                     "regulation_period_us": 5000},
      "sweep": {"regulation.threshold_pct": [5, 19, 25]}})");
  std::vector<std::string> budget;
  for (const auto& w : loader.load(vm).warnings)
    if (w.rfind("budget below", 0) == 0) budget.push_back(w);
  // nrt1 runs mser, which has no figure on vm-2core: left out.
  REQUIRE(budget.size() == 1);
  CHECK_THAT(budget[0], Contains("'nrt0' (bandwidth_read) uses about 101 MiB per 1000 us sample "
                                 "at platform vm-2core's reference (bandwidth_read alone there)"));
  CHECK_THAT(budget[0], Contains("at threshold_pct 5, 19:"));
  CHECK_THAT(budget[0], !Contains("2.63e+04"));
}

TEST_CASE("loader: a policy's defaults fill only the keys a point does not set, and are listed",
          "[loader]") {
  TempDir dir;
  const auto file = dir.write("s.json", R"({"name": "t", "backend": "sim",
      "nodes": {"controller": {"core": 0},
        "rt": [{"name": "rt0", "core": 1, "workload": "mser"}],
        "nrt": [{"name": "nrt0", "core": 2, "workload": "bandwidth_read"}]},
      "regulation": {"threshold_pct": 20},
      "sweep": {"regulation.policy+regulation.sampling_period_us": [["interval", 1000],
                                                                     ["memguard", 100],
                                                                     ["mempol", 10]]}})");
  Loader loader = make_loader();
  const auto ls = loader.load(file);
  REQUIRE(ls.points.size() == 3);
  const RegulationSpec& interval = ls.points[0].scenario.regulation;
  CHECK(interval.sampling == Sampling::Self);
  CHECK(interval.regulation_period_us == 5000);
  CHECK(interval.policy_defaults.empty());  // the generic defaults are not a policy's
  const RegulationSpec& memguard = ls.points[1].scenario.regulation;
  CHECK(memguard.sampling == Sampling::Overflow);
  CHECK(memguard.regulation_period_us == 1000);
  CHECK(memguard.sampling_period_us == 100);  // set by the sweep: kept
  CHECK(memguard.policy_defaults ==
        std::vector<std::string>{"sampling = overflow (memguard's default)",
                                 "regulation_period_us = 1000 (memguard's default)"});
  const RegulationSpec& mempol = ls.points[2].scenario.regulation;
  CHECK(mempol.sampling == Sampling::Mmio);
  CHECK(mempol.sampling_period_us == 10);
  CHECK(mempol.regulation_period_us == 1000);
  REQUIRE(ls.policy_defaults.size() == 4);
  CHECK(ls.policy_defaults[0] ==
        std::pair<std::string, std::size_t>{"sampling = overflow (memguard's default)", 1});
}

TEST_CASE(
    "loader: a profile's placeholders are warnings in sim, once per workload and number, "
    "and a workload with a command runs its program on hw and its profile in sim",
    "[loader]") {
  TempDir dir;
  const std::string profile = R"("sim": {"instructions": 1e6, "footprint_kb": 64, "l3_hit": 0.5,
      "phases": [{"fraction": 1, "base_ipc": 1, "l2_refill_pki": 2, "l2_wb_pki": 1}],
      "placeholder": ["base_ipc", "mlp"], "source": "test"})";
  dir.write("wl/mine.json",
            R"({"name": "mine", "command": ["/bin/true"], "cwd": "/tmp", )" + profile + "}");
  const auto file = dir.write("s.json", scenario("", "\"wl/mine.json\"", "\"wl/mine.json\""));
  Loader loader = make_loader();
  const auto ls = loader.load(file, std::string("sim"));
  // Both nodes run it: each number said once.
  REQUIRE(ls.warnings.size() == 2);
  CHECK_THAT(ls.warnings[0], StartsWith("workload 'mine' ("));
  CHECK_THAT(ls.warnings[0], Contains("base_ipc is a placeholder (1.0)"));
  CHECK_THAT(ls.warnings[1], Contains("mlp was not measured"));
  // On hw the program runs (its command and folder as written), and nothing is said.
  const auto hw = loader.load(file, std::string("hw"));
  CHECK(hw.warnings.empty());
  const WorkloadInfo& w = hw.points.at(0).scenario.nodes.rt[0].workload;
  CHECK(w.is_command());
  CHECK(w.doc["cwd"] == "/tmp");
  // A fitted profile says nothing.
  dir.write("wl/fitted.json",
            R"({"name": "fitted", "sim": {"instructions": 1e6, "footprint_kb": 64, "l3_hit": 0.5,
      "phases": [{"fraction": 1, "base_ipc": 1.3, "l2_refill_pki": 2, "l2_wb_pki": 1}]}})");
  const auto fitted = dir.write("f.json", scenario("", "\"wl/fitted.json\"", "\"wl/fitted.json\""));
  CHECK(loader.load(fitted, std::string("sim")).warnings.empty());
}

TEST_CASE("display_path: relative where shorter, absolute from /", "[loader]") {
  const fs::path here = fs::current_path();
  const fs::path file = here / "sub" / "x.json";
  CHECK(display_path(file) == "sub/x.json");
  CHECK(display_path("/usr/share/x.json") == "/usr/share/x.json");
  fs::current_path("/");
  const std::string from_root = display_path("/root/x.json");
  fs::current_path(here);
  CHECK(from_root == "/root/x.json");
}
