// What the loader refuses before it could crash, hang or exhaust memory (found by tests/fuzz/):
// nesting, string lengths, numbers beyond a double, files that are not regular files, and sweeps
// too large to hold; and how `check` samples a large sweep instead of building every point.
#include <sys/stat.h>
#include <unistd.h>

#include <catch2/catch.hpp>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <set>
#include <string>

#include "core/error.h"
#include "load/loader.h"

using namespace rosguard;
namespace fs = std::filesystem;
using json = nlohmann::json;
using Catch::Matchers::Contains;

namespace {

std::string nested(std::size_t levels) {
  return std::string(levels, '[') + "1" + std::string(levels, ']');
}

InputError parse_error(const std::string& text) {
  try {
    parse_json_text(text, "f.json");
  } catch (const InputError& e) {
    return e;
  }
  FAIL("parsing did not fail");
  throw std::logic_error("unreachable");
}

struct ScratchDir {
  fs::path path = fs::temp_directory_path() / ("rosguard-limits-" + std::to_string(::getpid()));
  ScratchDir() { fs::create_directories(path); }
  ~ScratchDir() {
    std::error_code ec;
    fs::remove_all(path, ec);
  }
  std::string write(const std::string& name, const std::string& text) const {
    std::ofstream(path / name) << text;
    return (path / name).string();
  }
};

// A valid hw scenario with `sweep` (a JSON object text).
std::string swept(const std::string& sweep) {
  return R"({"name": "t", "backend": "hw", "nodes": {"controller": {"core": 0},
    "rt": [{"name": "rt0", "core": 1, "workload": "mser"}],
    "nrt": [{"name": "nrt0", "core": 2, "workload": "mser"}]},
    "sweep": )" +
         sweep + "}";
}

std::string list(int from, int to) {
  json l = json::array();
  for (int i = from; i <= to; ++i)
    l.push_back(i);
  return l.dump();
}

}  // namespace

TEST_CASE("parse_json_text: nesting is bounded before anything recurses over it", "[limits]") {
  CHECK_NOTHROW(parse_json_text(nested(kMaxJsonDepth), "f.json"));
  const InputError e = parse_error(nested(kMaxJsonDepth + 1));
  CHECK(e.file() == "f.json");
  CHECK_THAT(e.message(), Contains("nested more than 64 levels"));
  // A few thousand levels (a stack overflow before) end the same way.
  CHECK_THAT(parse_error("{\"a\": " + nested(5000) + "}").json_path(), Contains("/a/0/0"));
}

TEST_CASE("parse_json_text: strings and keys longer than the bound are refused", "[limits]") {
  const std::string ok(kMaxJsonStringChars, 'a');
  const std::string too_long(kMaxJsonStringChars + 1, 'a');
  CHECK_NOTHROW(parse_json_text(json{{"k", ok}}.dump(), "f.json"));
  CHECK(parse_error(json{{"k", too_long}}.dump()).json_path() == "/k");
  CHECK(parse_error(json{{"o", {{too_long, 1}}}}.dump()).json_path() == "/o");
}

TEST_CASE("parse_json_text: a number beyond a double names its path", "[limits]") {
  CHECK(parse_error(R"({"a": {"b": 1e999}})").json_path() == "/a/b");
  CHECK(parse_error(R"({"a": [1, -1e999]})").json_path() == "/a/1");
  CHECK_THAT(parse_error(R"({"a": 1e999})").message(), Contains("beyond the range of a double"));
}

TEST_CASE("read_text_file: FIFOs, devices and folders are refused without reading", "[limits]") {
  ScratchDir dir;
  const fs::path fifo = dir.path / "fifo.json";
  REQUIRE(::mkfifo(fifo.c_str(), 0600) == 0);
  // Opening a FIFO with no writer would block forever; this must return at once.
  CHECK_THROWS_WITH(read_text_file(fifo, "fifo.json"), Contains("not a regular file"));
  CHECK_THROWS_WITH(read_text_file("/dev/zero", "/dev/zero"), Contains("not a regular file"));
  CHECK_THROWS_WITH(read_text_file(dir.path, "d"), Contains("a folder"));
  CHECK(read_text_file(dir.write("ok.json", "{}"), "ok.json") == "{}");
}

TEST_CASE("loader: a FIFO as platform is an error at /platform", "[limits]") {
  ScratchDir dir;
  REQUIRE(::mkfifo((dir.path / "p.json").c_str(), 0600) == 0);
  const std::string file =
      dir.write("s.json", R"({"name": "t", "backend": "hw", "platform": "p.json", "nodes": {
        "controller": {"core": 0}, "rt": [{"name": "rt0", "core": 1, "workload": "mser"}]}})");
  Loader loader(Home::locate());
  try {
    loader.load(file);
    FAIL("loaded");
  } catch (const InputError& e) {
    CHECK(e.file() == file);
    CHECK(e.json_path() == "/platform");
    CHECK_THAT(e.message(), Contains("not a regular file"));
  }
}

TEST_CASE("loader: a sweep above the limit is refused by its count, without building it",
          "[limits]") {
  ScratchDir dir;
  // 1000 x 1000 x 1000 points: building them would take hours and far too much memory.
  const std::string file =
      dir.write("s.json", swept(R"({"seed": )" + list(1, 1000) + R"(, "hw.watchdog_ms": )" +
                                list(1, 1000) + R"(, "repetitions": )" + list(1, 1000) + "}"));
  Loader loader(Home::locate());
  const auto start = std::chrono::steady_clock::now();
  try {
    loader.load(file, std::nullopt, PointSelection::Sample);
    FAIL("loaded");
  } catch (const InputError& e) {
    CHECK(e.json_path() == "/sweep");
    CHECK_THAT(e.message(), Contains("1000000000 points (1000 x 1000 x 1000)") &&
                                Contains(std::to_string(kMaxSweepPoints)));
  }
  CHECK(std::chrono::steady_clock::now() - start < std::chrono::seconds(20));  // not hours
}

TEST_CASE("loader: check samples a large sweep, every value of every key at least once",
          "[limits]") {
  ScratchDir dir;
  const std::string file =
      dir.write("s.json", swept(R"({"seed": )" + list(1, 50) + R"(, "hw.watchdog_ms": )" +
                                list(1, 60) + "}"));  // 3000 points > kCheckAllPoints
  Loader loader(Home::locate());
  const LoadedScenario sample = loader.load(file, std::nullopt, PointSelection::Sample);
  CHECK(sample.point_count == 3000);
  CHECK(sample.points.size() < 3000);
  std::set<std::uint64_t> seeds, watchdogs;
  for (const auto& p : sample.points) {
    seeds.insert(p.scenario.seed);
    watchdogs.insert(static_cast<std::uint64_t>(p.scenario.hw.watchdog_ms));
  }
  CHECK(seeds.size() == 50);
  CHECK(watchdogs.size() == 60);
  CHECK(sample.points.back().sweep.index == 2999);

  const LoadedScenario all = loader.load(file);
  CHECK(all.points.size() == 3000);
  CHECK(all.point_count == 3000);
}
