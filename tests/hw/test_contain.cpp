// Containment of external commands: nothing a command starts outlives it, whether it stays in
// the command's process group, moves to its own session (setsid) or is double-forked, and
// whether the command exits, is stopped, or rosguard itself is SIGKILLed mid-run. Processes are
// recognised by a marker in their environment, which every descendant inherits.
#include <fcntl.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <catch2/catch.hpp>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "core/error.h"
#include "hw/workload/workload.h"
#include "hw_test_files.h"

using namespace rosguard;
using namespace rosguard::hw;
namespace fs = std::filesystem;

using rosguard::test::slurp;

namespace {

struct Proc {
  pid_t pid = 0;
  pid_t ppid = 0;
  pid_t sid = 0;
  std::string comm;
};

// Live processes whose environment holds the entry `mark` (zombies have no environment left:
// they have ended and only wait to be reaped).
std::vector<Proc> marked_processes(const std::string& mark) {
  std::vector<Proc> out;
  for (const auto& e :
       fs::directory_iterator("/proc", fs::directory_options::skip_permission_denied)) {
    const std::string name = e.path().filename();
    if (name.find_first_not_of("0123456789") != std::string::npos) continue;
    std::stringstream env(slurp(e.path() / "environ"));
    bool marked = false;
    for (std::string entry; std::getline(env, entry, '\0') && !marked;)
      marked = entry == mark;
    if (!marked) continue;
    const std::string stat = slurp(e.path() / "stat");
    const auto open = stat.find('('), close = stat.rfind(')');
    if (open == std::string::npos || close == std::string::npos) continue;
    std::istringstream rest(stat.substr(close + 2));
    char state = 0;
    Proc p;
    pid_t pgrp = 0;
    rest >> state >> p.ppid >> pgrp >> p.sid;
    if (state == 'Z' || state == 'X') continue;
    p.pid = std::stoi(name);
    p.comm = stat.substr(open + 1, close - open - 1);
    out.push_back(p);
  }
  return out;
}

std::string describe(const std::vector<Proc>& ps) {
  std::string s;
  for (const auto& p : ps)
    s += "  pid " + std::to_string(p.pid) + " ppid " + std::to_string(p.ppid) + " sid " +
         std::to_string(p.sid) + " " + p.comm + "\n";
  return s;
}

// Waits up to `limit` for no marked process to be left; returns those still there.
std::vector<Proc> left_after(const std::string& mark, std::chrono::milliseconds limit) {
  const auto deadline = std::chrono::steady_clock::now() + limit;
  auto left = marked_processes(mark);
  while (!left.empty() && std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    left = marked_processes(mark);
  }
  return left;
}

// The test's own leftovers (old behaviour), so that a failing run does not leave them running.
void kill_all(const std::vector<Proc>& ps) {
  for (const auto& p : ps)
    ::kill(p.pid, SIGKILL);
}

// For a failure report: the threads of `pid` (name, state, where they sleep) and its children,
// and every thread of another process on the host under SCHED_FIFO / SCHED_RR (they starve ours).
std::string describe_run(pid_t pid) {
  std::string s;
  const fs::path proc = "/proc/" + std::to_string(pid);
  std::string children;
  std::error_code gone;
  for (const auto& t : fs::directory_iterator(proc / "task", gone)) {
    const std::string stat = slurp(t.path() / "stat");
    const auto close = stat.rfind(')');
    s += "  thread " + stat.substr(0, close + 3) + " wchan " + slurp(t.path() / "wchan") + "\n";
    children += slurp(t.path() / "children");
  }
  s += gone ? "  rosguard has ended\n" : "  children: " + children + "\n";
  for (const auto& e : fs::directory_iterator("/proc")) {
    const std::string name = e.path().filename();
    if (name.find_first_not_of("0123456789") != std::string::npos || name == std::to_string(pid))
      continue;
    std::error_code ec;
    for (const auto& t : fs::directory_iterator(e.path() / "task", ec)) {
      const std::string stat = slurp(t.path() / "stat");
      const auto open = stat.find('('), close = stat.rfind(')');
      if (open == std::string::npos || close == std::string::npos) continue;
      std::istringstream f(stat.substr(close + 2));  // from field 3, the state
      std::vector<std::string> fields;
      for (std::string x; f >> x;)
        fields.push_back(x);
      const std::string comm = stat.substr(open + 1, close - open - 1);
      if (fields.size() > 38 && fields[38] != "0" && comm.find("migration") == std::string::npos)
        s += "  real-time elsewhere: " + name + " " + comm + " policy " + fields[38] + " state " +
             fields[0] + "\n";
    }
  }
  return s;
}

// A shell that leaves a child in its own session, a double-forked one and one in its process
// group, then runs `last`.
std::vector<std::string> daemonising(const std::string& mark, const std::string& last) {
  return {"env", mark, "sh", "-c", "setsid sleep 300 & (sleep 300 &) ; sleep 300 & " + last};
}

}  // namespace

TEST_CASE("everything a command starts ends with it, in its own session or double-forked",
          "[hw][command][contain]") {
  const std::string mark = "ROSGUARD_CONTAIN_TEST=unit-" + std::to_string(::getpid());
  const ThreadSpec spec{"t", -1, SchedClass::Other, prio::kNct};
  SECTION("the command exits: wait() returns once the rest is killed and reaped") {
    CommandProcess proc(daemonising(mark, "sleep 0.3"), spec);
    proc.start();
    REQUIRE(proc.wait(-1));
    CHECK(WIFEXITED(proc.status()));
    CHECK(WEXITSTATUS(proc.status()) == 0);
    const auto left = marked_processes(mark);
    INFO(describe(left));
    CHECK(left.empty());
    kill_all(left);
  }
  SECTION("the command is stopped: kill() returns once the whole tree is gone") {
    CommandProcess proc(daemonising(mark, "exec sleep 300"), spec);
    proc.start();
    const auto sleeps = [&] {
      std::size_t n = 0;
      for (const auto& p : marked_processes(mark))
        n += p.comm == "sleep";
      return n;
    };
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
    while (sleeps() < 4 && std::chrono::steady_clock::now() < deadline)
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    REQUIRE(sleeps() == 4);  // the shell exec'd into the fourth
    proc.kill();
    const auto left = marked_processes(mark);
    INFO(describe(left));
    CHECK(left.empty());
    kill_all(left);
  }
}

TEST_CASE("a command's wait status is its own, through the supervisor", "[hw][command][contain]") {
  const ThreadSpec spec{"t", -1, SchedClass::Other, prio::kNct};
  CommandProcess exits({"sh", "-c", "exit 3"}, spec);
  exits.start();
  REQUIRE(exits.wait(-1));
  CHECK(describe_status(exits.status()) == "exit 3");
  CommandProcess killed({"sh", "-c", "kill -TERM $$"}, spec);
  killed.start();
  REQUIRE(killed.wait(-1));
  CHECK(WIFSIGNALED(killed.status()));
  CHECK(WTERMSIG(killed.status()) == SIGTERM);
  CommandProcess missing({"rosguard-no-such-command"}, spec);
  CHECK_THROWS_WITH(missing.start(),
                    Catch::Contains("rosguard-no-such-command") && Catch::Contains("ENOENT"));
}

TEST_CASE("a command starts in its workload's cwd, or fails naming it", "[hw][command]") {
  const ThreadSpec spec{"t", -1, SchedClass::Other, prio::kNct};
  const fs::path dir = fs::temp_directory_path() / ("rosguard-cwd-" + std::to_string(::getpid()));
  fs::create_directories(dir);
  // The status says where it ran: 0 in the folder given, 1 elsewhere.
  const std::string there = "test \"$(pwd -P)\" = \"" + fs::canonical(dir).string() + "\"";
  CommandProcess in_dir({"sh", "-c", there}, spec, dir.string());
  in_dir.start();
  REQUIRE(in_dir.wait(-1));
  CHECK(describe_status(in_dir.status()) == "exit 0");
  CommandProcess inherited({"sh", "-c", there}, spec);
  inherited.start();
  REQUIRE(inherited.wait(-1));
  CHECK(describe_status(inherited.status()) == "exit 1");
  CommandProcess missing({"true"}, spec, (dir / "gone").string());
  CHECK_THROWS_WITH(missing.start(), Catch::Contains((dir / "gone").string()) &&
                                         Catch::Contains("cwd") && Catch::Contains("ENOENT"));
  fs::remove_all(dir);
}

// The case: rosguard SIGKILLed while an nRT command runs, at several moments (during the
// command's isolation runs, then during the regulated points): within 2 s no process of the
// command may be left, the supervisor included.
TEST_CASE("SIGKILLed mid-run, rosguard leaves no process of its commands behind",
          "[hw][command][contain][sigkill]") {
  const std::string scenario =
      std::string(ROSGUARD_TEST_SOURCE_DIR) + "/tests/hw/scenarios/daemonising-command.json";
  int kills = 0;
  std::size_t total_left = 0;
  // Kill once the k-th command has started its session leader: during the first commands, which
  // come and go within a second of the start, then during the regulated points.
  for (const int k : {1, 2, 4, 7, 9, 11}) {
    const std::string mark =
        "ROSGUARD_CONTAIN_TEST=run-" + std::to_string(::getpid()) + "-" + std::to_string(k);
    const fs::path out =
        fs::temp_directory_path() /
        ("rosguard-contain-" + std::to_string(::getpid()) + "-" + std::to_string(k));
    fs::remove_all(out);
    const pid_t pid = ::fork();
    REQUIRE(pid >= 0);
    if (pid == 0) {
      const int null = ::open("/dev/null", O_WRONLY);
      ::dup2(null, 1);
      ::dup2(null, 2);
      ::putenv(const_cast<char*>(mark.c_str()));
      ::execl(ROSGUARD_BINARY, ROSGUARD_BINARY, "run", scenario.c_str(), "--backend", "hw", "--out",
              out.c_str(), "--quiet", static_cast<char*>(nullptr));
      ::_exit(127);
    }
    std::set<pid_t> leaders;  // one `setsid sleep` per command
    bool running = false;
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
    while (!running && std::chrono::steady_clock::now() < deadline &&
           ::waitpid(pid, nullptr, WNOHANG) == 0) {
      for (const auto& p : marked_processes(mark))
        if (p.comm == "sleep" && p.sid == p.pid) leaders.insert(p.pid);
      running = static_cast<int>(leaders.size()) >= k;
      if (!running) std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    INFO("kill while command " << k << " runs");
    if (!running) {
      UNSCOPED_INFO("no command started; the run:\n" << describe_run(pid));
      ::kill(pid, SIGKILL);
      ::waitpid(pid, nullptr, 0);
      kill_all(marked_processes(mark));  // the old behaviour's leftovers
    }
    REQUIRE(running);
    std::this_thread::sleep_for(std::chrono::milliseconds(20));  // its other children start
    REQUIRE(::kill(pid, SIGKILL) == 0);
    ::waitpid(pid, nullptr, 0);
    ++kills;
    const auto left = left_after(mark, std::chrono::seconds(2));
    INFO("left after 2 s:\n" << describe(left));
    CHECK(left.empty());
    total_left += left.size();
    kill_all(left);
    fs::remove_all(out);
  }
  INFO(kills << " kills, " << total_left << " processes left in all");
  CHECK(total_left == 0);
}
