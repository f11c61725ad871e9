// File primitives for crash-safe results (Linux).
//
// A killed run must leave only complete rows: every row is appended with one write() of the
// whole line (SIGKILL cannot split a write() of a few KB to a regular file), whole files are
// replaced by write-to-temporary + fsync + rename, and a torn tail left by a power loss is cut
// at the last newline when a run resumes.
#pragma once

#include <filesystem>
#include <memory>
#include <string>
#include <vector>

namespace rosguard {

// Replaces `path` atomically with `content`. Throws RunError naming the file and errno.
void write_file_atomic(const std::filesystem::path& path, const std::string& content);

// Reads a whole file; throws RunError when it cannot.
std::string read_file(const std::filesystem::path& path);

// Cuts everything after the last '\n' (a row torn by a crash). Returns the bytes removed.
std::size_t truncate_torn_tail(const std::filesystem::path& path);

// Splits text into lines without their '\n' (a final line without '\n' is kept).
std::vector<std::string> split_lines(const std::string& text);

// An append-only file; each append() is one write() of the whole buffer. An append that fails
// (a full disk: ENOSPC, EDQUOT, EFBIG) cuts the file back to its size before it and throws
// RunError naming the file and errno: no torn tail, and the space a partial write took is free
// again (for the manifest to record the failure). The caller serialises appends (FileLock).
class AppendFile {
 public:
  explicit AppendFile(const std::filesystem::path& path);
  ~AppendFile();
  AppendFile(const AppendFile&) = delete;
  AppendFile& operator=(const AppendFile&) = delete;

  void append(const std::string& data);
  // Cuts the file back to its size before the last append() (best effort: a tail it leaves is
  // cut when the folder is next opened).
  void undo() const;

 private:
  std::filesystem::path path_;
  int fd_ = -1;
  long long size_before_ = 0;
};

// An exclusive advisory lock on a whole file, held for the object's lifetime, so that writers
// sharing one results folder take turns (also on different machines). It is a POSIX record lock
// owned by the open file description (fcntl F_OFD_SETLKW): NFS forwards POSIX locks to the
// server (flock is only emulated by them there), and unlike classic fcntl locks it is neither
// shared by the threads of a process nor dropped when another descriptor of the file closes.
// The kernel releases it when its holder dies. Waiting for it retries on EINTR.
// The holder may remove the file (remove_file(): a finished run leaves no .lock behind); a
// waiter that then gets the lock of the removed file notices (the path no longer names the file
// it locked) and locks the path afresh.
class FileLock {
 public:
  explicit FileLock(const std::filesystem::path& path);
  ~FileLock();
  FileLock(const FileLock&) = delete;
  FileLock& operator=(const FileLock&) = delete;

  // The lock if nobody holds it now, else nullptr (no waiting).
  static std::unique_ptr<FileLock> try_lock(const std::filesystem::path& path);

  // Replaces the lock file's content with `note` (who holds it, for those refused).
  void write_note(const std::string& note) const;

  // Unlinks the lock file while holding it (its lock is released at destruction as usual).
  void remove_file();

 private:
  FileLock() = default;
  bool acquire(const std::filesystem::path& path, bool wait);

  std::filesystem::path path_;
  int fd_ = -1;
};

}  // namespace rosguard
