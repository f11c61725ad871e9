// "platform": "host" and `rosguard platform probe` on this machine: the probe finds usable CPUs
// and sane caches, its platform document validates against the schema (with and without an
// installed model), a host scenario passes check and runs a short hw point, and the manifest
// records the probe.
#include <unistd.h>

#include <algorithm>
#include <catch2/catch.hpp>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <set>

#include "calibration/measurements.h"
#include "core/error.h"
#include "hw/common/sys.h"
#include "hw/host_probe.h"
#include "hw/pmc_source/perf_events.h"
#include "hw_test_files.h"
#include "load/loader.h"

using namespace rosguard;
using namespace rosguard::hw;
namespace fs = std::filesystem;
using json = nlohmann::json;

namespace {

const fs::path kSource = ROSGUARD_TEST_SOURCE_DIR;

const HostProbe& probe_once() {
  static const HostProbe probe = probe_host();
  return probe;
}

// A temporary folder removed on scope exit.
struct Tmp {
  fs::path path = fs::temp_directory_path() / ("rosguard-host-" + std::to_string(::getpid()));
  Tmp() {
    fs::remove_all(path);
    fs::create_directories(path);
  }
  ~Tmp() { fs::remove_all(path); }
};

// `ROSGUARD_HOST_MODEL=<model> rosguard <args>`, stdout in `log`, stderr in `log`.err; returns
// the exit code.
int run_rosguard(const std::string& args, const fs::path& model, const fs::path& log) {
  const std::string cmd = "ROSGUARD_HOST_MODEL='" + model.string() + "' '" + ROSGUARD_BINARY +
                          "' " + args + " > '" + log.string() + "' 2> '" + log.string() + ".err'";
  const int status = std::system(cmd.c_str());
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

}  // namespace

TEST_CASE("the host probe finds usable CPUs, sane caches, a frequency and the reference",
          "[hw][host]") {
  const HostProbe& p = probe_once();
  INFO(to_json(p).dump(2));
  REQUIRE(!p.usable_cpus.empty());
  CHECK(p.usable_cpus == usable_cpus());
  CHECK(std::is_sorted(p.usable_cpus.begin(), p.usable_cpus.end()));
  // The clusters partition the usable CPUs.
  std::vector<int> covered;
  for (const auto& c : p.clusters) {
    CHECK(!c.cpus.empty());
    for (int cpu : c.cpus) {
      covered.push_back(cpu);
      CHECK(std::find(c.all_cpus.begin(), c.all_cpus.end(), cpu) != c.all_cpus.end());
    }
  }
  std::sort(covered.begin(), covered.end());
  CHECK(covered == p.usable_cpus);
  CHECK(p.line_bytes >= 16);
  CHECK(p.line_bytes <= 512);
  CHECK((p.line_bytes & (p.line_bytes - 1)) == 0);
  if (p.cache_source.rfind("sysfs", 0) == 0) {
    // Caches grow with the level; an L1d holds at least a few KB.
    CHECK(p.l1d_kb >= 4);
    CHECK(p.l2_kb >= p.l1d_kb);
    if (p.l3_kb_per_cluster > 0) CHECK(p.l3_kb_per_cluster >= p.l2_kb);
    for (const auto& c : p.clusters)
      CHECK(c.llc_kb >= p.l2_kb);
  } else {
    WARN("no sysfs cache information here: " << p.cache_source);
  }
  CHECK(p.freq_mhz > 100);
  CHECK(p.freq_mhz < 10000);
  CHECK(p.hardware_events.size() == hardware_event_names().size());
  for (const auto& e : p.hardware_events)
    CHECK(!e.detail.empty());  // what it counts, or why it did not open
  CHECK(!p.sched_fifo_detail.empty());
  REQUIRE(p.reference);
  CHECK(p.reference->run_mbps.size() >= 5);
  CHECK(p.reference->mbps >=
        *std::min_element(p.reference->run_mbps.begin(), p.reference->run_mbps.end()));
  CHECK(p.reference->mbps <=
        *std::max_element(p.reference->run_mbps.begin(), p.reference->run_mbps.end()));
  CHECK(p.reference->mbps > 100);  // any machine reads a 2 MB buffer faster than 100 MB/s
  CHECK(p.reference->wall_ms < 5000);
  CHECK(std::find(p.usable_cpus.begin(), p.usable_cpus.end(), p.reference->cpu) !=
        p.usable_cpus.end());

  const auto facts = host_facts(p);
  CHECK(facts.cpus == static_cast<int>(p.usable_cpus.size()));
  CHECK(facts.clusters == static_cast<int>(p.clusters.size()));
  CHECK(facts.clusters * facts.cores_per_cluster <= facts.cpus);
  CHECK(facts.freq_mhz == p.freq_mhz);
  CHECK(facts.l2_kb == p.l2_kb);
  CHECK(facts.date == p.date);
  CHECK(facts.hostname == p.hostname);
}

TEST_CASE("the host platform document validates, with and without an installed model",
          "[hw][host]") {
  const HostProbe& p = probe_once();
  const SchemaSet schemas(kSource / "scenarios" / "schema");

  const json measured = host_platform_document(p, std::nullopt);
  INFO(measured.dump(2));
  CHECK_NOTHROW(schemas.validate(measured, SchemaKind::Platform, "probe"));
  CHECK(measured.at("name") == "host");
  CHECK(!measured.contains("memory"));
  CHECK(!measured.contains("costs"));
  CHECK(measured.at("reference").at("mbps").get<double>() ==
        Approx(p.reference->mbps).margin(0.01));
  CHECK(measured.at("reference").at("source").get<std::string>().find("measured at probe time") !=
        std::string::npos);
  const auto& cpu = measured.at("cpu");
  // Every usable CPU is a core the platform has (scenario cores are Linux CPU numbers on hw).
  CHECK(cpu.at("clusters").get<int>() * cpu.at("cores_per_cluster").get<int>() >=
        p.usable_cpus.back() + 1);
  CHECK(cpu.at("source").get<std::string>().find(p.hostname) != std::string::npos);
  // The events a metric may name: the perf events that opened, and the instrumented source's.
  const auto events = measured.at("pmu").at("events").get<std::vector<std::string>>();
  for (const auto& e : p.hardware_events)
    CHECK((std::find(events.begin(), events.end(), e.name) != events.end()) ==
          (e.opens || e.name == "l2d_cache_refill" || e.name == "l2d_cache_wb"));
  for (const char* section : {"cpu", "caches", "pmu", "reference"})
    CHECK(measured.at(section).at("source").get<std::string>().size() > 20);

  // An installed model provides the reference, the memory model and the costs.
  const json model = json::parse(test::slurp(kSource / "scenarios/platforms/vm-2core.json"));
  const json installed = host_platform_document(p, InstalledModel{model, "model.json"});
  CHECK_NOTHROW(schemas.validate(installed, SchemaKind::Platform, "probe"));
  CHECK(installed.at("memory") == model.at("memory"));
  CHECK(installed.at("costs") == model.at("costs"));
  CHECK(installed.at("reference").at("mbps") == model.at("reference").at("mbps"));
  CHECK(installed.at("reference").at("source").get<std::string>().find("model.json") !=
        std::string::npos);
  CHECK(installed.at("cpu") == measured.at("cpu"));

  HostProbe without = p;
  without.reference.reset();
  CHECK_THROWS_AS(host_platform_document(without, std::nullopt), ContractError);
}

TEST_CASE("unequal clusters and CPUs outside the affinity mask: what is usable, said in cpu.source",
          "[hw][host]") {
  const SchemaSet schemas(kSource / "scenarios" / "schema");
  HostProbe p;
  p.hostname = "h";
  p.cpu_model = "test";
  p.date = "2026-01-01T00:00:00Z";
  p.l1d_kb = 32;
  p.l2_kb = 512;
  p.l3_kb_per_cluster = 8192;
  p.freq_mhz = 2000;
  p.cache_source = "sysfs";
  p.hardware_events = {{"cpu_cycles", true, "cycles"}, {"l3d_cache", false, "ENOENT"}};
  p.reference = ReferenceRun{1000.0, {900.0, 1000.0, 1100.0}, 0, true, 2048, 10, 100};
  const auto doc_of = [&] {
    const json d = host_platform_document(p, std::nullopt);
    INFO(d.dump(2));
    CHECK_NOTHROW(schemas.validate(d, SchemaKind::Platform, "synthetic"));
    return d;
  };

  // Two equal clusters numbered in order: described exactly.
  p.usable_cpus = {0, 1, 2, 3};
  p.clusters = {{{0, 1}, {0, 1}, 3, 8192}, {{2, 3}, {2, 3}, 3, 8192}};
  json d = doc_of();
  CHECK(d["cpu"]["clusters"] == 2);
  CHECK(d["cpu"]["cores_per_cluster"] == 2);
  CHECK(d["pmu"]["events"] == json({"cpu_cycles", "l2d_cache_refill", "l2d_cache_wb"}));
  CHECK(host_facts(p).clusters == 2);
  CHECK(host_facts(p).cores_per_cluster == 2);

  // Unequal clusters (4 + 2): one cluster over every usable CPU, said in the source.
  p.usable_cpus = {0, 1, 2, 3, 4, 5};
  p.clusters = {{{0, 1, 2, 3}, {0, 1, 2, 3}, 3, 8192}, {{4, 5}, {4, 5}, 3, 4096}};
  d = doc_of();
  CHECK(d["cpu"]["clusters"] == 1);
  CHECK(d["cpu"]["cores_per_cluster"] == 6);
  CHECK(d["cpu"]["source"].get<std::string>().find("not 0..n-1 in equal clusters") !=
        std::string::npos);
  CHECK(host_facts(p).clusters == 2);
  CHECK(host_facts(p).cores_per_cluster == 2);  // what every cluster offers
  CHECK(host_facts(p).cpus == 6);

  // CPUs 0-1 outside the affinity mask: cores up to the highest usable CPU, the others named.
  p.usable_cpus = {2, 3};
  p.clusters = {{{2, 3}, {0, 1, 2, 3}, 3, 8192}};
  d = doc_of();
  CHECK(d["cpu"]["clusters"] == 1);
  CHECK(d["cpu"]["cores_per_cluster"] == 4);
  CHECK(d["cpu"]["source"].get<std::string>().find("refuses CPUs outside 2-3") !=
        std::string::npos);
  CHECK(host_facts(p).cpus == 2);
}

TEST_CASE("platform probe prints a valid platform, --out writes it, a bad --out exits 2",
          "[hw][host][cli]") {
  Tmp tmp;
  const fs::path missing_model = tmp.path / "no-model.json";
  const fs::path log = tmp.path / "log";
  REQUIRE(run_rosguard("platform probe", missing_model, log) == 0);
  const json printed = json::parse(test::slurp(log));  // notes go to stderr
  const fs::path out = tmp.path / "host.json";
  REQUIRE(run_rosguard("platform probe --out '" + out.string() + "'", missing_model, log) == 0);
  const json written = json::parse(test::slurp(out));
  const SchemaSet schemas(kSource / "scenarios" / "schema");
  CHECK_NOTHROW(schemas.validate(written, SchemaKind::Platform, out.string()));
  CHECK(written.at("name") == "host");
  CHECK_NOTHROW(schemas.validate(printed, SchemaKind::Platform, "stdout"));
  // Two probes: the same CPUs (the frequency, a current clock on some hosts, and the time in
  // each source may differ).
  for (const char* key : {"clusters", "cores_per_cluster", "model"})
    CHECK(printed.at("cpu").at(key) == written.at("cpu").at(key));

  CHECK(run_rosguard("platform probe --out '" + (tmp.path / "nowhere/host.json").string() + "'",
                     missing_model, log) == 2);
  CHECK(test::slurp(log.string() + ".err").find("does not exist") != std::string::npos);
  CHECK(run_rosguard("platform probe --out '" + tmp.path.string() + "'", missing_model, log) == 2);
  CHECK(run_rosguard("platform", missing_model, log) == 2);  // a subcommand is required

  // A CPU outside the affinity mask: described as unusable, and a note says so.
  const auto cpus = usable_cpus();
  if (cpus.size() >= 2 && std::system("command -v taskset > /dev/null") == 0) {
    const fs::path one = tmp.path / "one.json";
    const std::string last = std::to_string(cpus.back());
    const std::string cmd = "ROSGUARD_HOST_MODEL='" + missing_model.string() + "' taskset -c " +
                            last + " '" + ROSGUARD_BINARY + "' platform probe --out '" +
                            one.string() + "' 2> '" + log.string() + "'";
    REQUIRE(std::system(cmd.c_str()) == 0);
    CHECK(test::slurp(log).find("this process may use 1 of the") != std::string::npos);
    CHECK(json::parse(test::slurp(one))["cpu"]["source"].get<std::string>().find(
              "refuses CPUs outside " + last) != std::string::npos);
  }
}

TEST_CASE("a host scenario passes check and runs a short hw point, the manifest has the probe",
          "[hw][host][integration]") {
  if (usable_cpus().size() < 2 || usable_cpus()[0] != 0 || usable_cpus()[1] != 1) {
    WARN("SKIPPED: needs CPUs 0 and 1");
    return;
  }
  Tmp tmp;
  const fs::path missing_model = tmp.path / "no-model.json";
  const fs::path log = tmp.path / "log";
  const std::string scenario = (kSource / "tests/hw/scenarios/host-tiny.json").string();

  CHECK(run_rosguard("check '" + scenario + "'", missing_model, log) == 0);
  INFO(test::slurp(log.string() + ".err"));
  CHECK(run_rosguard("check '" + (kSource / "scenarios/examples/host.json").string() + "'",
                     missing_model, log) == 0);

  const fs::path out = tmp.path / "run";
  REQUIRE(run_rosguard("run '" + scenario + "' --quiet --out '" + out.string() + "'", missing_model,
                       log) == 0);
  const json manifest = json::parse(test::slurp(out / "manifest.json"));
  CHECK(manifest.at("status") == "complete");
  CHECK(manifest.at("platform").at("doc").at("name") == "host");
  const json& host = manifest.at("host_platform").at("hw");
  CHECK(host.at("probe").at("usable_cpus") == json(usable_cpus()));
  CHECK(host.at("probe").contains("reference"));  // no model installed: measured
  CHECK(!host.contains("model"));
  const auto rows = test::lines_of(test::slurp(out / "points.csv"));
  REQUIRE(rows.size() == 2);  // header + one point

  // The loader in-process: the probed platform is built once per Loader, for every point.
  setenv("ROSGUARD_HOST_MODEL", missing_model.c_str(), 1);
  Loader loader(Home{ROSGUARD_TEST_SOURCE_DIR});
  const auto loaded = loader.load((kSource / "scenarios/examples/host.json").string());
  REQUIRE(loaded.points.size() == 2);
  CHECK(loaded.points[0].scenario.platform.name == "host");
  CHECK(loaded.points[0].scenario.platform.doc == loaded.points[1].scenario.platform.doc);
  CHECK(loaded.host_platform.contains("hw"));
  // --backend sim with no installed model: the InputError at /platform.
  try {
    loader.load((kSource / "scenarios/examples/host.json").string(), std::string("sim"));
    FAIL("sim without an installed host model loaded");
  } catch (const InputError& e) {
    CHECK(e.json_path() == "/platform");
    CHECK(e.message().find("no calibrated model of this host: run `rosguard calibrate "
                           "--install` (or use --backend hw)") != std::string::npos);
  }
}

TEST_CASE("platform contention measures now and says whether it is the model's state",
          "[hw][host][cli]") {
  Tmp tmp;
  const fs::path log = tmp.path / "log";
  const fs::path out = tmp.path / "probe.json";
  const std::string cmd = "platform contention --out '" + out.string() + "'";
  if (usable_cpus().size() < 2) {  // nothing to probe against
    CHECK(run_rosguard(cmd, tmp.path / "no-model.json", log) == 1);
    CHECK(test::slurp(log.string() + ".err").find("needs two CPUs") != std::string::npos);
    return;
  }
  // No model: measured, said, exit 3 (validate calibrates).
  REQUIRE(run_rosguard(cmd, tmp.path / "no-model.json", log) == 3);
  CHECK(test::slurp(log).find("DRAM interference now: ") != std::string::npos);
  CHECK(test::slurp(log).find("no host model installed") != std::string::npos);
  json probe = json::parse(test::slurp(out));
  CHECK(probe.at("ratio").get<double>() > 0.0);
  CHECK(probe.at("rounds").get<int>() >= 1);
  CHECK(probe.at("model").is_null());
  CHECK(probe.at("matches").is_null());
  // The other way round and the first way again, on the same working set: compared only when the
  // first way held its state meanwhile (alike null otherwise).
  CHECK(test::slurp(log).find("the other way round: ") != std::string::npos);
  CHECK(probe.at("reverse").at("cores") == json{probe.at("cores").at(1), probe.at("cores").at(0)});
  CHECK(probe.at("again").at("cores") == probe.at("cores"));
  CHECK(probe.at("reverse").at("working_set_kb") == probe.at("working_set_kb"));
  CHECK(probe.at("reverse").at("ratio").get<double>() > 0.0);
  const double first = probe.at("ratio").get<double>();
  const double again = probe.at("again").at("ratio").get<double>();
  const double reverse = probe.at("reverse").at("ratio").get<double>();
  const auto agree = [](double a, double b) {
    return std::fabs(std::log(a / b)) <= std::log1p(calibration::kContentionTolerance);
  };
  if (agree(first, again))
    CHECK(probe.at("alike") == agree(first, reverse));
  else
    CHECK(probe.at("alike").is_null());

  // A model that records no state (calibrated before rosguard recorded it): exit 3, said.
  json model = json::parse(test::slurp(kSource / "scenarios/platforms/vm-2core.json"));
  const fs::path model_file = tmp.path / "model.json";
  std::ofstream(model_file) << model.dump();
  REQUIRE(run_rosguard(cmd, model_file, log) == 3);
  CHECK(test::slurp(log).find("does not record the DRAM-interference state") != std::string::npos);

  // A recorded state no machine is in (a reader 50x slower beside another, on this machine's
  // first two CPUs, over 20 MB): measured on the model's cores and working set, another state.
  const auto cpus = usable_cpus();
  model["measured_on"]["dram_contention"] = {{"cores", {cpus[0], cpus[1]}},
                                             {"working_set_kb", 20480},
                                             {"ratio", 50.0},
                                             {"ci95_pct", 2.0},
                                             {"rounds", 35},
                                             {"date", "2026-11-28T07:00:00Z"}};
  std::ofstream(model_file) << model.dump();
  REQUIRE(run_rosguard(cmd, model_file, log) == 3);
  CHECK(test::slurp(log).find("a different state from the host model's") != std::string::npos);
  probe = json::parse(test::slurp(out));
  CHECK(probe.at("working_set_kb") == 20480.0);
  CHECK(probe.at("cores") == json{cpus[0], cpus[1]});
  CHECK(probe.at("model").at("ratio") == 50.0);
  CHECK(probe.at("matches") == false);

  // A bad --out: refused before measuring.
  CHECK(run_rosguard("platform contention --out '" + tmp.path.string() + "'", model_file, log) ==
        2);
}
