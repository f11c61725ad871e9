#include "load/files.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <fstream>
#include <sstream>

#include "core/error.h"

namespace rosguard {
namespace fs = std::filesystem;

namespace {

[[noreturn]] void fail(const std::string& what, const fs::path& path) {
  throw RunError(what + " " + path.string() + ": " + std::strerror(errno));
}

void write_all(int fd, const std::string& data, const fs::path& path) {
  const char* p = data.data();
  std::size_t left = data.size();
  while (left > 0) {
    const ssize_t n = ::write(fd, p, left);
    if (n < 0) {
      if (errno == EINTR) continue;
      fail("cannot write", path);
    }
    p += n;
    left -= static_cast<std::size_t>(n);
  }
}

}  // namespace

void write_file_atomic(const fs::path& path, const std::string& content) {
  const fs::path tmp = path.string() + ".tmp." + std::to_string(::getpid());
  const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) fail("cannot create", tmp);
  try {  // the errors name the file replaced, not its temporary
    write_all(fd, content, path);
    if (::fsync(fd) != 0) fail("cannot write", path);
  } catch (...) {
    ::close(fd);
    ::unlink(tmp.c_str());
    throw;
  }
  ::close(fd);
  if (::rename(tmp.c_str(), path.c_str()) != 0) {
    ::unlink(tmp.c_str());
    fail("cannot replace", path);
  }
  const fs::path dir = path.has_parent_path() ? path.parent_path() : fs::path(".");
  if (const int dfd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC); dfd >= 0) {
    ::fsync(dfd);
    ::close(dfd);
  }
}

std::string read_file(const fs::path& path) {
  // read(2) into a string of the file's size (a results file may be hundreds of MB: a
  // stringstream copied it twice and grew it step by step).
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) fail("cannot read", path);
  struct stat st {};
  std::string text;
  if (::fstat(fd, &st) == 0 && st.st_size > 0) text.reserve(static_cast<std::size_t>(st.st_size));
  char buf[1 << 16];
  while (true) {
    const ssize_t n = ::read(fd, buf, sizeof buf);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) {
      ::close(fd);
      fail("cannot read", path);
    }
    if (n == 0) break;
    text.append(buf, static_cast<std::size_t>(n));
  }
  ::close(fd);
  return text;
}

std::size_t truncate_torn_tail(const fs::path& path) {
  // Only the tail is read: back from the end, a block at a time, to the last '\n'.
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return 0;
  struct stat st {};
  if (::fstat(fd, &st) != 0) {
    ::close(fd);
    fail("cannot read", path);
  }
  const auto size = static_cast<std::uint64_t>(st.st_size);
  std::uint64_t keep = 0;  // bytes up to and including the last '\n'
  char buf[1 << 16];
  for (std::uint64_t end = size; end > 0;) {
    const std::uint64_t begin = end > sizeof buf ? end - sizeof buf : 0;
    const ssize_t n =
        ::pread(fd, buf, static_cast<std::size_t>(end - begin), static_cast<off_t>(begin));
    if (n < 0 && errno == EINTR) continue;
    if (n != static_cast<ssize_t>(end - begin)) {
      ::close(fd);
      fail("cannot read", path);
    }
    const void* nl = ::memrchr(buf, '\n', static_cast<std::size_t>(n));
    if (nl) {
      keep = begin + static_cast<std::uint64_t>(static_cast<const char*>(nl) - buf) + 1;
      break;
    }
    end = begin;
  }
  ::close(fd);
  if (keep == size) return 0;
  std::error_code ec;
  fs::resize_file(path, keep, ec);
  if (ec) throw RunError("cannot truncate " + path.string() + ": " + ec.message());
  return static_cast<std::size_t>(size - keep);
}

std::vector<std::string> split_lines(const std::string& text) {
  std::vector<std::string> lines;
  std::size_t start = 0;
  while (start < text.size()) {
    const auto end = text.find('\n', start);
    if (end == std::string::npos) {
      lines.push_back(text.substr(start));
      break;
    }
    lines.push_back(text.substr(start, end - start));
    start = end + 1;
  }
  return lines;
}

AppendFile::AppendFile(const fs::path& path) : path_(path) {
  fd_ = ::open(path.c_str(), O_WRONLY | O_APPEND | O_CREAT | O_CLOEXEC, 0644);
  if (fd_ < 0) fail("cannot open", path);
}

AppendFile::~AppendFile() {
  if (fd_ >= 0) ::close(fd_);
}

void AppendFile::append(const std::string& data) {
  struct stat st {};
  if (::fstat(fd_, &st) != 0) fail("cannot read the size of", path_);
  size_before_ = static_cast<long long>(st.st_size);
  try {
    write_all(fd_, data, path_);
  } catch (const RunError&) {
    undo();
    throw;
  }
}

void AppendFile::undo() const {
  if (::ftruncate(fd_, static_cast<off_t>(size_before_)) != 0) return;  // best effort
}

FileLock::FileLock(const fs::path& path) {
  acquire(path, true);
}

std::unique_ptr<FileLock> FileLock::try_lock(const fs::path& path) {
  std::unique_ptr<FileLock> lock(new FileLock());
  if (!lock->acquire(path, false)) return nullptr;
  return lock;
}

bool FileLock::acquire(const fs::path& path, bool wait) {
  path_ = path;
  while (true) {
    fd_ = ::open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
    if (fd_ < 0) fail("cannot open lock file", path);
    struct flock whole {};  // l_start = l_len = 0: the whole file
    whole.l_type = F_WRLCK;
    whole.l_whence = SEEK_SET;
    while (::fcntl(fd_, wait ? F_OFD_SETLKW : F_OFD_SETLK, &whole) != 0) {
      if (errno == EINTR) continue;
      const int err = errno;
      ::close(fd_);
      fd_ = -1;
      if (!wait && (err == EAGAIN || err == EACCES)) return false;  // held by another
      errno = err;
      fail("cannot lock", path);
    }
    // Still the file the path names? (Its previous holder may have removed it meanwhile.)
    struct stat held {
    }, named{};
    if (::fstat(fd_, &held) == 0 && ::stat(path.c_str(), &named) == 0 &&
        held.st_dev == named.st_dev && held.st_ino == named.st_ino)
      return true;
    ::close(fd_);
    fd_ = -1;
  }
}

void FileLock::write_note(const std::string& note) const {
  if (::ftruncate(fd_, 0) != 0) fail("cannot write", path_);
  const char* p = note.data();
  std::size_t left = note.size();
  for (off_t at = 0; left > 0;) {
    const ssize_t n = ::pwrite(fd_, p, left, at);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) fail("cannot write", path_);
    p += n;
    at += n;
    left -= static_cast<std::size_t>(n);
  }
}

void FileLock::remove_file() {
  std::error_code ec;
  fs::remove(path_, ec);  // gone already is fine
}

FileLock::~FileLock() {
  if (fd_ >= 0) ::close(fd_);
}

}  // namespace rosguard
