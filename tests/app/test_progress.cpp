// Progress (tools/rosguard/run/progress.h): the in-place line never wraps; off a terminal, plain
// lines at an interval and one at the end.
#include <catch2/catch.hpp>
#include <sstream>

#include "run/progress.h"

using namespace rosguard;

namespace {

// The segments written after each "\r\033[K" (what the terminal shows at each update).
std::vector<std::string> shown(const std::string& out) {
  std::vector<std::string> parts;
  const std::string clear = "\r\033[K";
  for (std::size_t at = out.find(clear); at != std::string::npos;) {
    const std::size_t next = out.find(clear, at + clear.size());
    parts.push_back(out.substr(at + clear.size(), next == std::string::npos
                                                      ? std::string::npos
                                                      : next - at - clear.size()));
    at = next;
  }
  return parts;
}

}  // namespace

TEST_CASE("progress on a terminal stays within its width and counts runs", "[progress]") {
  std::ostringstream out;
  Progress p(100, Progress::Mode::Terminal, out, 80, 0.0);
  const std::string label(200, 'x');
  for (std::size_t done = 1; done <= 100; ++done)
    p.update(done, "point " + std::to_string(done) + " rep 0 (" + label + ")");
  p.finish();
  const auto parts = shown(out.str());
  REQUIRE(parts.size() == 101);  // 100 updates and the clearing finish
  for (const auto& part : parts) {
    CHECK(part.size() <= 79);
    CHECK(part.find('\n') == std::string::npos);
  }
  CHECK(parts[49].rfind("[50/100 runs] 50%", 0) == 0);
  CHECK(parts.back().empty());

  // Redrawn at most once per interval: here only the first update, then the clearing finish.
  std::ostringstream rare;
  Progress slow(100, Progress::Mode::Terminal, rare, 80, 3600.0);
  for (std::size_t done = 1; done <= 100; ++done)
    slow.update(done, "point");
  slow.finish();
  const auto few = shown(rare.str());
  REQUIRE(few.size() == 2);
  CHECK(few[0].rfind("[1/100 runs] 1%", 0) == 0);
  CHECK(few[1].empty());
}

TEST_CASE("progress off a terminal prints plain lines at its interval and the last one",
          "[progress]") {
  std::ostringstream every;
  Progress all(3, Progress::Mode::Lines, every, 80, 0.0);
  for (std::size_t done = 1; done <= 3; ++done)
    all.update(done, "point");
  all.finish();
  CHECK(every.str().find('\r') == std::string::npos);
  std::istringstream in(every.str());
  std::vector<std::string> lines;
  for (std::string line; std::getline(in, line);)
    lines.push_back(line);
  REQUIRE(lines.size() == 3);  // the final count was the last line printed: not repeated
  CHECK(lines[0].rfind("progress: [1/3 runs]", 0) == 0);
  CHECK(lines[2].rfind("progress: [3/3 runs] 100%", 0) == 0);

  std::ostringstream sparse;
  Progress rare(1000, Progress::Mode::Lines, sparse, 80, 3600.0);
  for (std::size_t done = 1; done <= 1000; ++done)
    rare.update(done, "point");
  rare.finish();
  std::istringstream in2(sparse.str());
  lines.clear();
  for (std::string line; std::getline(in2, line);)
    lines.push_back(line);
  REQUIRE(lines.size() == 2);  // the first update, and the end
  CHECK(lines[0].rfind("progress: [1/1000 runs]", 0) == 0);
  CHECK(lines[1].rfind("progress: [1000/1000 runs] 100%", 0) == 0);

  std::ostringstream none;
  Progress off(5, Progress::Mode::Off, none);
  off.update(5, "point");
  off.finish();
  CHECK(none.str().empty());
}
