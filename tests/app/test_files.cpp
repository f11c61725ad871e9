// Crash-safe file primitives: atomic replace, torn-tail repair, single-write appends, the lock.
#include <signal.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <catch2/catch.hpp>
#include <filesystem>

#include "load/files.h"

using namespace rosguard;
namespace fs = std::filesystem;

namespace {
fs::path temp_dir() {
  fs::path d = fs::temp_directory_path() / ("rosguard-test-" + std::to_string(::getpid()));
  fs::create_directories(d);
  return d;
}
}  // namespace

TEST_CASE("atomic writes replace the whole file and leave no temporary", "[files]") {
  const fs::path d = temp_dir();
  const fs::path f = d / "a.txt";
  write_file_atomic(f, "first\n");
  write_file_atomic(f, "second\n");
  CHECK(read_file(f) == "second\n");
  std::size_t entries = 0;
  for ([[maybe_unused]] const auto& e : fs::directory_iterator(d))
    ++entries;
  CHECK(entries == 1);
  fs::remove_all(d);
}

TEST_CASE("a torn last row is cut at the last newline", "[files]") {
  const fs::path d = temp_dir();
  const fs::path f = d / "points.csv";
  write_file_atomic(f, "h1,h2\n1,2\n3,");
  CHECK(truncate_torn_tail(f) == 2);
  CHECK(read_file(f) == "h1,h2\n1,2\n");
  CHECK(truncate_torn_tail(f) == 0);
  fs::remove_all(d);
}

TEST_CASE("appends accumulate whole rows", "[files]") {
  const fs::path d = temp_dir();
  const fs::path f = d / "rows.csv";
  {
    AppendFile out(f);
    out.append("a\n");
    out.append(std::string(100000, 'x') + "\n");
  }
  const auto lines = split_lines(read_file(f));
  REQUIRE(lines.size() == 2);
  CHECK(lines[1].size() == 100000);
  fs::remove_all(d);
}

TEST_CASE("a FileLock excludes other processes and is released when its holder dies", "[files]") {
  const fs::path d = temp_dir();
  const fs::path lock = d / ".lock";
  int ready[2];
  REQUIRE(::pipe(ready) == 0);
  const pid_t holder = ::fork();
  REQUIRE(holder >= 0);
  if (holder == 0) {
    FileLock held(lock);
    char c = 'x';
    (void)!::write(ready[1], &c, 1);
    ::pause();  // until SIGKILL: the kernel must release the lock
    ::_exit(0);
  }
  char c = 0;
  REQUIRE(::read(ready[0], &c, 1) == 1);
  const pid_t waiter = ::fork();
  REQUIRE(waiter >= 0);
  if (waiter == 0) {
    FileLock mine(lock);
    ::_exit(7);
  }
  ::usleep(200 * 1000);
  int status = 0;
  CHECK(::waitpid(waiter, &status, WNOHANG) == 0);  // still waiting for the lock
  ::kill(holder, SIGKILL);
  REQUIRE(::waitpid(holder, &status, 0) == holder);
  REQUIRE(::waitpid(waiter, &status, 0) == waiter);
  CHECK(WIFEXITED(status));
  CHECK(WEXITSTATUS(status) == 7);
  ::close(ready[0]);
  ::close(ready[1]);
  fs::remove_all(d);
}

TEST_CASE("FileLock::try_lock does not wait: nullptr while the lock is held, the lock once free",
          "[files]") {
  const fs::path d = temp_dir();
  const fs::path lock = d / ".shard-0-of-1.lock";
  auto held = FileLock::try_lock(lock);
  REQUIRE(held);
  held->write_note("pid 1 on here\n");
  CHECK(read_file(lock) == "pid 1 on here\n");
  CHECK_FALSE(FileLock::try_lock(lock));  // another open file description: refused
  held.reset();
  auto again = FileLock::try_lock(lock);
  REQUIRE(again);
  // Removed by its holder: the path names a fresh file, which a newcomer locks.
  again->remove_file();
  CHECK(FileLock::try_lock(lock));
  fs::remove_all(d);
}

TEST_CASE("an append that fails (the file may not grow) leaves the file as it was", "[files]") {
  const fs::path d = temp_dir();
  const fs::path f = d / "samples.csv";
  write_file_atomic(f, "header\n");
  // In a child: a file size limit of 4 KiB makes the write stop there with EFBIG (SIGXFSZ
  // ignored), as a full disk stops it with ENOSPC.
  const pid_t child = ::fork();
  REQUIRE(child >= 0);
  if (child == 0) {
    ::signal(SIGXFSZ, SIG_IGN);
    rlimit limit{};
    ::getrlimit(RLIMIT_FSIZE, &limit);
    limit.rlim_cur = 4096;
    if (::setrlimit(RLIMIT_FSIZE, &limit) != 0) ::_exit(3);
    AppendFile out(f);
    try {
      out.append(std::string(10000, 'x') + "\n");
    } catch (const std::exception& e) {
      const std::string what = e.what();
      ::_exit(what == "cannot write " + f.string() + ": File too large" ? 0 : 2);
    }
    ::_exit(1);
  }
  int status = 0;
  REQUIRE(::waitpid(child, &status, 0) == child);
  REQUIRE(WIFEXITED(status));
  CHECK(WEXITSTATUS(status) == 0);  // 1: no error, 2: another message, 3: no limit
  CHECK(read_file(f) == "header\n");
  fs::remove_all(d);
}
