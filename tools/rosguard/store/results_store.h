// The results folder of a run (docs/design.md, results): manifest.json, points.csv, samples.csv,
// baselines.json and, with --trace, trace.json.
//
// Several writers may use one folder at the same time: shards of one scenario, on one machine
// or on several sharing it over NFS (Slurm arrays); but one writer per shard, as two would run
// and append the same runs (claim_shard refuses the second: ShardBusyError). Every
// read-modify-write of a shared file happens under an exclusive lock on DIR/.lock (FileLock: a
// POSIX lock, which NFS forwards to the server, released by the kernel when its holder dies). A
// run's rows are appended under that lock, samples first and then the point's row, each file
// opened by its path for every append: a file that another writer replaced (when it sorted at
// its end) is never written through a stale descriptor, and while nobody holds the lock every
// row has all its samples. A killed writer leaves at most samples without their row; the next
// open or finish drops them. Each writer sorts both files when it finishes, so the last one
// leaves points.csv byte-identical to a single-process run, whatever the shards and their timing.
// "Not measured" (NaN) is written as null in JSON and read back as NaN.
// baselines.json holds every measurement of every isolation baseline:
//   {KEY: {"time_us", "ipc", "mbps" (medians), "time_cv", "runs": [{"rep", "time_us", "ipc",
//   "mbps"}, ...]}}; an entry without "runs" (rosguard before repeated baselines) reads back as
// one measurement.
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "backend/backend.h"
#include "core/error.h"

namespace rosguard {

class FileLock;

// Another live rosguard writes the shard of the results folder that this invocation would write
// (ResultsStore::claim_shard). main() exits 4 for it (rosguard run --help): a status that a
// script or a requeued Slurm task can tell from a failed run.
class ShardBusyError : public RunError {
 public:
  using RunError::RunError;
};

// ResultsStore::finish could not record a failure in manifest.json (a full disk), which still
// says that the shard runs.
class ManifestNotUpdatedError : public RunError {
 public:
  using RunError::RunError;
};

// A JSON number, or NaN for null (a value that was not measured).
double number_or_nan(const nlohmann::json& value);

// baselines.json's document and back. from_json throws nlohmann::json::exception on a
// document of another shape.
nlohmann::json baselines_to_json(const Baselines& baselines);
Baselines baselines_from_json(const nlohmann::json& doc);

// A points.csv row (point id, line) with its baseline cells brought up to date from the
// baselines of the whole folder; nullopt leaves it as it is (refresh_isolation_cells).
using RowRefresher = std::function<std::optional<std::string>(
    const std::string& point_id, const std::string& line, const Baselines& baselines)>;
// The rows of one point (all its repetitions, in order, after RowRefresher) with the cells that
// depend on all of them (the slowdown CIs: fill_ci_cells) brought up to date.
using PointRefresher = std::function<std::vector<std::string>(const std::string& point_id,
                                                              const std::vector<std::string>& lines,
                                                              const Baselines& baselines)>;

// What one invocation (one shard, or a whole run) did, for the manifest.
struct InvocationReport {
  std::string status;  // "complete" (its tasks all ran), "interrupted" or "failed"
  std::string error;   // when failed
  std::size_t rows = 0;
  std::size_t skipped_on_resume = 0;
  double elapsed_s = 0.0;
  std::vector<std::pair<std::string, std::string>> fallbacks;  // (what, detail)
  std::map<std::string, std::string> facts;
  std::vector<std::string> warnings;  // added to the manifest's (once each)
  // Entries for the manifest's top level; an object is merged into one already there (another
  // shard's per-point entries are kept).
  nlohmann::json manifest = nlohmann::json::object();
};

class ResultsStore {
 public:
  // `header_line`: points.csv's header for this scenario; `order`: point id -> sweep index (the
  // canonical row order, one entry per point of the scenario); `repetitions` per point: every
  // point has that many rows when the folder is complete. `adaptive`: points run a variable
  // number of rounds (hw.precision_pct), at least `repetitions`; the folder is then complete when
  // they all have their rows and every shard's invocation completed (its points reached their
  // precision or their cap).
  ResultsStore(std::filesystem::path dir, std::string header_line,
               std::map<std::string, std::size_t> order, int repetitions, bool adaptive = false);
  ~ResultsStore();
  ResultsStore(const ResultsStore&) = delete;
  ResultsStore& operator=(const ResultsStore&) = delete;

  const std::filesystem::path& dir() const { return dir_; }
  std::filesystem::path points_path() const { return dir_ / "points.csv"; }

  // First of all: makes this invocation the one writer of `shard` ("I/N") in the folder (created
  // if need be) until finish() or the store's end, by a lock on DIR/.shard-I-of-N.lock that
  // names this process (FileLock::try_lock; the kernel drops it when its holder dies). Throws
  // ShardBusyError, naming the holder, when another process holds it; nothing is written then.
  // Other shards may write into the folder at the same time.
  void claim_shard(const std::string& shard);

  // Before anything is written: a folder that holds a run may be joined (`joining`: --resume or
  // --shard) only by the same scenario (`scenario_hash`), or emptied first with `overwrite`.
  // Throws InputError otherwise.
  void prepare(bool overwrite, bool joining, const std::string& scenario_hash) const;

  struct Opened {
    std::set<std::pair<std::string, int>> done;  // (point id, rep) rows already written
    Baselines baselines;                         // isolation results already measured
    std::set<std::pair<std::string, std::string>> fallbacks;  // already in the manifest
  };
  // Creates the folder and, under the lock: checks the scenario hash and points.csv's header
  // (InputError, nothing written), tidies both CSV files, reads what is already done, and
  // writes the manifest: `description` merged over it, this invocation's `shard` ("I/N")
  // marked running.
  Opened open(nlohmann::json description, const std::string& shard);

  // Appends runs' samples.csv lines and their points.csv rows (the same runs, in one order).
  void append_runs(const std::string& samples, const std::string& rows) const;
  // Merges `baselines` into baselines.json: measurements it does not hold yet are added, those
  // it holds (another shard's of the same index) are kept.
  void save_baselines(const Baselines& baselines) const;
  // Adds trace events to trace.json.
  void add_trace(const nlohmann::json& events) const;

  // Under the lock: sorts both CSV files, refreshes every row's baseline cells from
  // baselines.json (`refresh`, when given), and merges `report` into the manifest (this shard's
  // entry, fallbacks, facts, counts, the baselines' measurements and spread with a warning for
  // each too noisy one, and the folder's status: complete once every run of the scenario has
  // its row, else failed / interrupted / running when a shard says so, else partial). Returns
  // the rows now in points.csv.
  // `points`: each point's rows refreshed together after `refresh` (PointRefresher).
  // When a write fails (a full disk), the manifest records this shard as failed (with the
  // report's error, or else the write's) before the error is thrown on; when the manifest cannot
  // record it either, ManifestNotUpdatedError says so. Releases claim_shard's lock.
  std::size_t finish(const InvocationReport& report, const RowRefresher& refresh = {},
                     const PointRefresher& points = {});

 private:
  std::set<std::pair<std::string, int>> tidy_csv_files(const RowRefresher& refresh = {},
                                                       const PointRefresher& points = {}) const;
  Baselines read_baselines() const;
  nlohmann::json read_manifest() const;
  // The manifest this store wrote at open() while the file still holds exactly that text (no
  // other shard wrote since: the usual case, and parsing a 10,000-point manifest again took
  // longer than the rest of finish), else read_manifest(). Once: the document is moved out.
  nlohmann::json take_manifest();
  std::size_t finish_locked(const InvocationReport& report, const RowRefresher& refresh,
                            const PointRefresher& points);
  // The manifest with this shard (and so the folder) failed with `error`, nothing else changed.
  void record_failure(const std::string& error) const;

  std::filesystem::path dir_;
  std::string header_line_;
  std::map<std::string, std::size_t> order_;
  int repetitions_;
  bool adaptive_;
  std::string shard_;
  std::unique_ptr<FileLock> shard_lock_;  // claim_shard's
  std::string manifest_text_;             // what open() wrote (take_manifest)
  nlohmann::json manifest_;
  // The sizes of points.csv and samples.csv (-1 for one that is missing).
  std::pair<std::uintmax_t, std::uintmax_t> sizes() const;
  // Whether both files are as tidy_csv_files left them plus this store's appends, each of a run
  // after the last (sweep index, rep): their sizes then, the runs they hold, and the last one.
  mutable bool tidy_ = false;
  mutable std::pair<std::uintmax_t, std::uintmax_t> tidy_sizes_;
  mutable std::set<std::pair<std::string, int>> done_;
  mutable std::pair<std::size_t, int> last_run_{0, -1};
};

}  // namespace rosguard
