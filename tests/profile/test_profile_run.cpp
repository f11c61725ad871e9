// `rosguard profile` on a program built here (stream_read.cpp) under valgrind's lackey: the
// refills per load land where the loop's shape puts them, the MRC shows the working set, and
// the command's exits and output follow its contract. SKIPPED without valgrind.
#include <sys/wait.h>

#include <catch2/catch.hpp>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <utility>

#include "host/profile.h"
#include "load/files.h"
#include "load/schema.h"

namespace fs = std::filesystem;
using namespace rosguard;

namespace {

bool have_valgrind() {
  return std::system("command -v valgrind >/dev/null 2>&1") == 0;
}

profile::SliceCounts profile_stream(const std::string& kb, const std::string& passes,
                                    std::vector<std::uint64_t>& capacities) {
  ProfileOptions o;
  o.command = {STREAM_READ, kb, passes};
  profile::Profiler profiler(profile_config(o));
  trace_program(o, profiler, nullptr);
  capacities = profiler.capacities_kb();
  return profiler.total();
}

int run(const std::string& command) {
  const int status = std::system(command.c_str());
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

}  // namespace

TEST_CASE("profile of a sequential read: one L1 and one L2 refill per 8 loads, MRC of 1 MB") {
  if (!have_valgrind()) {
    WARN("SKIPPED: valgrind is not installed (Debian package valgrind)");
    return;
  }
  // The difference of 4 and 2 passes over 1 MB is two passes of the loop alone (the program's
  // start-up and exit cancel).
  std::vector<std::uint64_t> caps;
  const profile::SliceCounts a = profile_stream("1024", "2", caps);
  const profile::SliceCounts b = profile_stream("1024", "4", caps);
  const double loads = static_cast<double>(b.loads - a.loads);
  const double l1 = static_cast<double>(b.l1_refills - a.l1_refills);
  const double l2 = static_cast<double>(b.l2_refills - a.l2_refills);
  CHECK(loads == Approx(2.0 * 1024 * 1024 / 8).epsilon(0.01));
  // 1 MB is beyond both the 64 KB L1 and the 256 KB L2: every line refills both, per pass.
  CHECK(1000.0 * l1 / loads == Approx(125).epsilon(0.02));
  CHECK(1000.0 * l2 / loads == Approx(125).epsilon(0.02));
  CHECK(b.stores - a.stores < 100);
  // LRU behind the L2: a 1 MB cycle misses in 256 and 512 KB, hits from 2 MB on.
  for (std::size_t i = 0; i < caps.size(); ++i) {
    const double missed = static_cast<double>(b.l3_misses[i] - a.l3_misses[i]) / l2;
    INFO("capacity " << caps[i] << " KB: miss ratio " << missed);
    if (caps[i] <= 512) CHECK(missed > 0.98);
    if (caps[i] >= 2048) CHECK(missed < 0.02);
  }
}

#ifdef HW_KERNEL
TEST_CASE("profile of the built-in bandwidth_read kernel: one L2 refill per line, no write-back") {
  if (!have_valgrind()) {
    WARN("SKIPPED: valgrind is not installed (Debian package valgrind)");
    return;
  }
  // rosguard-hw-kernel bandwidth_read 512 KB: one 8-byte load per 64-byte line. 6 passes minus 2
  // passes is 4 passes of the kernel's loop (start-up, the buffer's pre-fault and exit cancel).
  const auto kernel = [](const char* passes) {
    ProfileOptions o;
    o.command = {HW_KERNEL, "bandwidth_read", "512", passes};
    profile::Profiler profiler(profile_config(o));
    trace_program(o, profiler, nullptr);
    return std::make_pair(profiler.total(), profiler.capacities_kb());
  };
  const auto [a, caps] = kernel("2");
  const auto [b, caps_b] = kernel("6");
  const double lines = 4.0 * 512 * 1024 / 64;
  const double instructions = static_cast<double>(b.instructions - a.instructions);
  INFO("instructions per line " << instructions / lines);
  // One load per line, plus the kernel's bookkeeping once per 64 lines (progress counters
  // written, the overflow watches' flag and the stop flag read): a few loads and stores per 64
  // lines, all in the L1.
  const double loads = static_cast<double>(b.loads - a.loads);
  const double stores = static_cast<double>(b.stores - a.stores);
  CHECK(loads >= lines);
  CHECK(loads < lines * (1.0 + 8.0 / 64));
  CHECK(stores < lines * 4.0 / 64);
  // 512 KB is beyond the 64 KB L1 and the 256 KB L2: one refill of each per line, and the lines
  // are never written, so nothing is written back.
  CHECK(static_cast<double>(b.l1_refills - a.l1_refills) == Approx(lines).epsilon(0.01));
  CHECK(static_cast<double>(b.l2_refills - a.l2_refills) == Approx(lines).epsilon(0.01));
  CHECK(b.l2_writebacks - a.l2_writebacks < 10);
  // A handful of instructions per line: the loop is a load, an add, the index step and branch.
  CHECK(instructions / lines > 2.0);
  CHECK(instructions / lines < 20.0);
  // LRU behind the L2: the 512 KB cycle misses in 256 KB and hits from 1 MB on.
  const double l2 = static_cast<double>(b.l2_refills - a.l2_refills);
  for (std::size_t i = 0; i < caps.size(); ++i) {
    const double missed = static_cast<double>(b.l3_misses[i] - a.l3_misses[i]) / l2;
    INFO("capacity " << caps[i] << " KB: miss ratio " << missed);
    if (caps[i] <= 256) CHECK(missed > 0.98);
    if (caps[i] >= 1024) CHECK(missed < 0.02);
  }
}
#endif

TEST_CASE(
    "rosguard profile writes a valid workload, exits 1 when the program fails, 2 on bad "
    "arguments") {
  if (!have_valgrind()) {
    WARN("SKIPPED: valgrind is not installed (Debian package valgrind)");
    return;
  }
  const fs::path dir =
      fs::temp_directory_path() / ("rosguard-profile-" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const std::string bin = ROSGUARD_BINARY;
  const fs::path out = dir / "stream.json";
  const std::string prof =
      bin + " profile --quiet --slice-instructions 100000 --out " + out.string() + " ";

  REQUIRE(run(prof + "--name stream -- " STREAM_READ " 512 3 2>" + (dir / "err").string()) == 0);
  const auto doc = nlohmann::json::parse(read_file(out));
  SchemaSet schemas(fs::path(ROSGUARD_TEST_SOURCE_DIR) / "scenarios" / "schema");
  schemas.validate(doc, SchemaKind::Workload, out.string());
  CHECK(doc["name"] == "stream");
  const auto& sim = doc["sim"];
  CHECK(sim["footprint_kb"].get<double>() >= 512);
  CHECK(sim["footprint_kb"].get<double>() < 1024);
  double fractions = 0, refills = 0;
  for (const auto& ph : sim["phases"]) {
    fractions += ph["fraction"].get<double>();
    refills += ph["fraction"].get<double>() * ph["l2_refill_pki"].get<double>();
    CHECK(ph["base_ipc"] == 1.0);  // the placeholder the source says must be fitted
  }
  CHECK(fractions == Approx(1.0).epsilon(1e-9));
  CHECK(refills > 5);  // a 512 KB stream refills the L2 throughout
  CHECK(sim["source"].get<std::string>().find("placeholder") != std::string::npos);
  CHECK(sim["source"].get<std::string>().find("lackey") != std::string::npos);

  // The program fails: exit 1 with its status, the old file left as it was.
  const std::string before = read_file(out);
  CHECK(run(prof + "-- " STREAM_READ " 64 1 7 2>" + (dir / "err").string()) == 1);
  CHECK(read_file(dir / "err").find("exit status 7") != std::string::npos);
  CHECK(read_file(out) == before);

  // --skip-instructions beyond the program's end: exit 1, nothing written; within it, the
  // source says what was skipped.
  CHECK(run(prof + "--skip-instructions 1000000000 -- " STREAM_READ " 64 1 2>" +
            (dir / "err").string()) == 1);
  CHECK(read_file(dir / "err").find("before the 1000000000 of --skip-instructions") !=
        std::string::npos);
  CHECK(read_file(out) == before);
  const fs::path skipped = dir / "skipped.json";
  REQUIRE(run(bin + " profile --quiet --skip-instructions 200000 --out " + skipped.string() +
              " -- " STREAM_READ " 512 2 2>/dev/null") == 0);
  const auto sdoc = nlohmann::json::parse(read_file(skipped));
  CHECK(sdoc["sim"]["source"].get<std::string>().find("first 200000 instructions run through "
                                                      "the caches uncounted") != std::string::npos);

  // Bad arguments: exit 2, nothing written.
  const fs::path other = dir / "other.json";
  CHECK(run(bin + " profile --out " + other.string() +
            " --caches 64,256 -- " STREAM_READ " 64 1 2>/dev/null") == 2);
  CHECK(run(bin + " profile --out " + other.string() +
            " --ways 4,8,0 -- " STREAM_READ " 64 1 2>/dev/null") == 2);
  CHECK(run(bin + " profile --out " + other.string() + " -- /no/such/program 2>/dev/null") == 2);
  CHECK_FALSE(fs::exists(other));

  // No valgrind on PATH: said plainly, exit 1.
  CHECK(run("PATH=/nonexistent " + bin + " profile --out " + other.string() +
            " -- " STREAM_READ " 64 1 2>" + (dir / "err").string()) == 1);
  CHECK(read_file(dir / "err").find("valgrind is not installed") != std::string::npos);
  fs::remove_all(dir);
}

TEST_CASE(
    "rosguard profile --tracer callgrind: the stream's refills and MRC, the whole run as hw "
    "command, the same counts as lackey") {
  if (!have_valgrind()) {
    WARN("SKIPPED: valgrind is not installed (Debian package valgrind)");
    return;
  }
  const fs::path dir =
      fs::temp_directory_path() / ("rosguard-profile-cg-" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const std::string bin = ROSGUARD_BINARY;
  // 1 MB read 8 times, one 8-byte load per element: past the 256 KB L2, inside a 2 MB L3.
  const auto profile = [&](const std::string& tracer) {
    const fs::path out = dir / (tracer + ".json");
    REQUIRE(run("cd " + dir.string() + " && " + bin + " profile --quiet --tracer " + tracer +
                " --out " + out.string() + " -- " STREAM_READ " 1024 8 2>" +
                (dir / "err").string()) == 0);
    return nlohmann::json::parse(read_file(out));
  };
  const auto cg = profile("callgrind");
  SchemaSet schemas(fs::path(ROSGUARD_TEST_SOURCE_DIR) / "scenarios" / "schema");
  schemas.validate(cg, SchemaKind::Workload, "callgrind.json");
  const auto& sim = cg["sim"];
  // The loop's loads: 8 x 1 MB / 8 bytes = 1 M loads, an L2 refill per 8 (125 pki of loads).
  double refill_pki = 0, instructions = sim["instructions"].get<double>();
  for (const auto& ph : sim["phases"]) {
    refill_pki += ph["fraction"].get<double>() * ph["l2_refill_pki"].get<double>();
    CHECK_FALSE(ph.contains("mlp"));  // not measured: the sim's default
  }
  const double refills = refill_pki * instructions / 1000;
  CHECK(refills == Approx(8.0 * 1024 * 1024 / 64).epsilon(0.05));
  // The 1 MB cycle misses a 512 KB L3 and hits one of 2 MB: the share of refills that miss.
  for (const auto& point : sim["phases"][0]["mrc"]) {
    INFO("capacity " << point["capacity_kb"] << " KB");
    if (point["capacity_kb"] <= 512) CHECK(point["miss_ratio"].get<double>() > 0.95);
    if (point["capacity_kb"] >= 2048) CHECK(point["miss_ratio"].get<double>() < 0.2);
  }
  CHECK(sim["footprint_kb"].get<double>() >= 1024);
  CHECK(sim["footprint_kb"].get<double>() < 1024 + 512);
  CHECK(sim["placeholder"] == nlohmann::json::array({"base_ipc", "mlp"}));
  // A whole run: the program and the folder it ran in, for the hw backend.
  CHECK(cg["command"] == nlohmann::json::array({STREAM_READ, "1024", "8"}));
  CHECK(cg["cwd"] == dir.string());

  // lackey on the same run: the same instructions and refills within a few percent.
  const auto lk = profile("lackey");
  CHECK(lk["sim"]["instructions"].get<double>() == Approx(instructions).epsilon(0.02));
  double lk_refill_pki = 0;
  for (const auto& ph : lk["sim"]["phases"])
    lk_refill_pki += ph["fraction"].get<double>() * ph["l2_refill_pki"].get<double>();
  CHECK(lk_refill_pki == Approx(refill_pki).epsilon(0.05));
  CHECK(lk["sim"]["placeholder"] == nlohmann::json::array({"base_ipc"}));
  fs::remove_all(dir);
}

#ifdef SIM_CALIBRATE
TEST_CASE(
    "rosguard profile --fit-ipc / --measure-ipc: base_ipc fitted on the platform, the "
    "placeholder gone, the reference written, and its refusals") {
  if (!have_valgrind()) {
    WARN("SKIPPED: valgrind is not installed (Debian package valgrind)");
    return;
  }
  const fs::path dir =
      fs::temp_directory_path() / ("rosguard-profile-fit-" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const std::string bin = ROSGUARD_BINARY;
  const fs::path out = dir / "fit.json";
  REQUIRE(run(bin + " profile --quiet --platform orin-agx --fit-ipc 0.2 --out " + out.string() +
              " -- " STREAM_READ " 512 2 2>" + (dir / "err").string()) == 0);
  const auto doc = nlohmann::json::parse(read_file(out));
  CHECK(doc["reference"]["ipc"] == 0.2);
  CHECK_FALSE(doc["sim"].contains("placeholder"));
  CHECK(doc["sim"]["phases"][0]["base_ipc"].get<double>() != 1.0);
  CHECK(doc["sim"]["source"].get<std::string>().find("fitted") != std::string::npos);
  // rosguard-sim-calibrate, the same steady state, finds the fitted IPC.
  const std::string calibrate = std::string(SIM_CALIBRATE) + " " + ROSGUARD_TEST_SOURCE_DIR +
                                "/scenarios/platforms/orin-agx.json " + out.string() + " > " +
                                (dir / "cal").string();
  REQUIRE(run(calibrate) == 0);
  // Its line: workload, ipc, reference ipc, error in % (the header line first).
  std::istringstream cal(read_file(dir / "cal"));
  std::string header, name;
  double ipc = 0, ref = 0, err = 100;
  std::getline(cal, header);
  cal >> name >> ipc >> ref >> err;
  CHECK(ref == 0.2);
  CHECK(std::abs(err) < 0.5);

  // --measure-ipc: the program's own runs, on a named platform.
  const fs::path measured = dir / "measured.json";
  REQUIRE(run(bin + " profile --quiet --platform vm-2core --measure-ipc --repeat 2 --out " +
              measured.string() + " -- " STREAM_READ " 512 2 2>/dev/null") == 0);
  const auto m = nlohmann::json::parse(read_file(measured));
  CHECK(m["reference"]["source"].get<std::string>().find("median of 2 native runs") !=
        std::string::npos);
  CHECK(m["reference"]["ipc"].get<double>() > 0.01);

  // Refused before anything runs: exit 2, nothing written.
  const fs::path other = dir / "other.json";
  CHECK(run(bin + " profile --fit-ipc 1 --platform no-such-platform --out " + other.string() +
            " -- " STREAM_READ " 64 1 2>" + (dir / "err").string()) == 2);
  CHECK(read_file(dir / "err").find("--platform 'no-such-platform'") != std::string::npos);
  CHECK(run(bin + " profile --measure-ipc --max-instructions 100000 --out " + other.string() +
            " -- " STREAM_READ " 64 1 2>" + (dir / "err").string()) == 2);
  CHECK(read_file(dir / "err").find("cannot fit a window") != std::string::npos);
  // An IPC the stream's memory stalls on the Orin forbid: refused, with the most it could be.
  CHECK(run(bin + " profile --quiet --platform orin-agx --fit-ipc 1.5 --out " + other.string() +
            " -- " STREAM_READ " 512 2 2>" + (dir / "err").string()) == 2);
  CHECK(read_file(dir / "err").find("cannot fit base_ipc to IPC 1.5") != std::string::npos);
  CHECK(run(bin + " profile --measure-ipc --fit-ipc 1 --out " + other.string() +
            " -- " STREAM_READ " 64 1 2>/dev/null") == 2);
  CHECK(run(bin + " profile --tracer perf --out " + other.string() +
            " -- " STREAM_READ " 64 1 2>/dev/null") == 2);
  CHECK_FALSE(fs::exists(other));
  fs::remove_all(dir);
}
#endif
