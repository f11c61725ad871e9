#include "store/results_store.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <limits>
#include <sstream>
#include <string_view>
#include <tuple>

#include "core/error.h"
#include "load/files.h"
#include "load/host_facts.h"
#include "results/columns.h"
#include "results/results.h"
#include "store/trace_writer.h"

namespace rosguard {
namespace fs = std::filesystem;
using json = nlohmann::json;

namespace {

// DIR/columns.json: unit and meaning of every points.csv column of this run and of every
// samples.csv kind (model/results/columns.h).
json columns_json(const std::string& header_line) {
  const auto entry = [](const ColumnInfo& c) {
    return json{{"name", c.name}, {"unit", c.unit}, {"meaning", c.meaning}};
  };
  json points = json::array();
  std::stringstream names(header_line);
  for (std::string name; std::getline(names, name, ',');) {
    const auto info = describe_point_column(name);
    if (!info) throw ContractError("points.csv column '" + name + "' is not in the dictionary");
    points.push_back(entry(*info));
  }
  json samples = json::array();
  for (const auto& c : sample_kind_dictionary())
    samples.push_back(entry(c));
  return json{{"points.csv", points}, {"samples.csv", samples}};
}

using RunKey = std::pair<std::string, int>;  // (point id, rep)

struct CsvRow {
  std::size_t order;  // the point's sweep index (unknown ids last)
  int rep;
  RunKey key;
  std::string line;
};

struct CsvFile {
  std::string header;  // empty for a missing or empty file
  std::vector<CsvRow> rows;
};

// A results CSV (first columns: point, rep) with a torn tail cut; rows without both are skipped.
CsvFile read_csv(const fs::path& path, const std::map<std::string, std::size_t>& order) {
  CsvFile out;
  std::error_code ec;
  if (!fs::exists(path, ec)) return out;
  truncate_torn_tail(path);
  const auto lines = split_lines(read_file(path));
  if (lines.empty()) return out;
  out.header = lines.front();
  for (std::size_t i = 1; i < lines.size(); ++i) {
    const auto cells = csv_split(lines[i]);
    if (cells.size() < 2) continue;
    const auto it = order.find(cells[0]);
    int rep = -1;  // a rep that is not a number matches no run
    std::from_chars(cells[1].data(), cells[1].data() + cells[1].size(), rep);
    out.rows.push_back(
        {it == order.end() ? order.size() : it->second, rep, {cells[0], rep}, lines[i]});
  }
  std::stable_sort(out.rows.begin(), out.rows.end(), [](const CsvRow& a, const CsvRow& b) {
    return std::tie(a.order, a.rep) < std::tie(b.order, b.rep);
  });
  return out;
}

// samples.csv in canonical order: the lines of the runs in `keep`, stably sorted by (sweep
// index, rep), as read_csv would sort them line by line. A run's samples are appended in one
// piece, so the text is handled in blocks of consecutive lines of one run (a 10,000-point sweep
// writes some 10^7 lines); it is rewritten only when that changes it.
void tidy_samples(const fs::path& path, const std::map<std::string, std::size_t>& order,
                  const std::set<RunKey>& keep) {
  const std::string header = std::string(kSamplesHeader) + "\n";
  std::error_code ec;
  if (!fs::exists(path, ec)) {
    write_file_atomic(path, header);
    return;
  }
  truncate_torn_tail(path);
  const std::string text = read_file(path);
  // Rows kept under another header would be read as columns they are not.
  if (const std::size_t nl = text.find('\n');
      nl != std::string::npos && text.compare(0, nl + 1, header) != 0)
    throw InputError("", "",
                     path.string() + " has other columns than this rosguard writes (its header: " +
                         text.substr(0, std::min<std::size_t>(nl, 120)) +
                         "); resume only a folder this rosguard wrote, or choose another --out");
  struct Block {
    std::size_t order;
    int rep;
    std::size_t begin, end;  // bytes of `text`
  };
  std::vector<Block> blocks;
  bool changed = text.compare(0, header.size(), header) != 0;
  std::size_t pos = text.find('\n');
  pos = pos == std::string::npos ? text.size() : pos + 1;
  std::string_view id;  // of the open block
  int rep = -1;
  bool open = false;  // the last line read belongs to a kept block
  while (pos < text.size()) {
    std::size_t end = text.find('\n', pos);
    end = end == std::string::npos ? text.size() : end + 1;
    const std::string_view line(text.data() + pos, end - pos - (text[end - 1] == '\n' ? 1 : 0));
    std::string_view cell0, cell1;
    std::vector<std::string> cells;  // only for a line with quotes
    bool two_cells = false;
    if (line.find('"') == std::string_view::npos) {
      const std::size_t c0 = line.find(',');
      if (c0 != std::string_view::npos) {
        two_cells = true;
        cell0 = line.substr(0, c0);
        cell1 = line.substr(c0 + 1, line.find(',', c0 + 1) - (c0 + 1));
      }
    } else {
      cells = csv_split(std::string(line));
      if ((two_cells = cells.size() >= 2)) {
        cell0 = cells[0];
        cell1 = cells[1];
      }
    }
    int line_rep = -1;  // a rep that is not a number matches no run
    if (two_cells) std::from_chars(cell1.data(), cell1.data() + cell1.size(), line_rep);
    if (open && two_cells && cell0 == id && line_rep == rep && cells.empty()) {
      blocks.back().end = end;  // the open block goes on
    } else {
      open = false;
      const RunKey key{std::string(cell0), line_rep};
      if (two_cells && keep.count(key)) {
        const auto it = order.find(key.first);
        blocks.push_back({it == order.end() ? order.size() : it->second, line_rep, pos, end});
        id = std::string_view(text.data() + pos, cell0.size());
        rep = line_rep;
        open = cells.empty();
      } else {
        changed = true;  // a line dropped
      }
    }
    pos = end;
  }
  const auto before = [](const Block& a, const Block& b) {
    return std::tie(a.order, a.rep) < std::tie(b.order, b.rep);
  };
  if (!std::is_sorted(blocks.begin(), blocks.end(), before)) {
    changed = true;
    std::stable_sort(blocks.begin(), blocks.end(), before);
  }
  if (!text.empty() && text.back() != '\n') changed = true;
  if (!changed) return;
  std::string out = header;
  out.reserve(text.size() + 1);
  for (const Block& b : blocks) {
    out.append(text, b.begin, b.end - b.begin);
    if (out.back() != '\n') out += '\n';
  }
  write_file_atomic(path, out);
}

void append_under_lock(const fs::path& path, const std::string& data) {
  AppendFile file(path);
  file.append(data);
}

// The folder's status from its shards' entries (see ResultsStore::finish). `adaptive`: rows
// alone do not say that the points are done (their rounds are not counted in advance).
std::string folder_status(const json& shards, bool all_rows, bool adaptive) {
  const auto any = [&](const char* status) {
    return std::any_of(shards.begin(), shards.end(),
                       [&](const json& s) { return s.value("status", "") == status; });
  };
  if (any("failed")) return "failed";
  const bool shards_done = std::all_of(shards.begin(), shards.end(), [](const json& s) {
    return s.value("status", "") == "complete";
  });
  if (all_rows && (!adaptive || shards_done)) return "complete";
  for (const char* s : {"interrupted", "running"})
    if (any(s)) return s;
  return "partial";
}

std::string first_error(const json& shards) {
  for (const auto& s : shards)
    if (s.value("status", "") == "failed") return s.value("error", "");
  return "";
}

}  // namespace

double number_or_nan(const json& value) {
  return value.is_null() ? std::numeric_limits<double>::quiet_NaN() : value.get<double>();
}

json baselines_to_json(const Baselines& baselines) {
  json b = json::object();
  for (const auto& [k, runs] : baselines.all()) {
    const IsolationResult m = runs.median();
    json each = json::array();
    for (const auto& [rep, r] : runs.runs)  // NaN is written null
      each.push_back({{"rep", rep}, {"time_us", r.time_us}, {"ipc", r.ipc}, {"mbps", r.mbps}});
    b[k] = {{"time_us", m.time_us},
            {"ipc", m.ipc},
            {"mbps", m.mbps},
            {"time_cv", runs.time_cv()},
            {"runs", each}};
  }
  return b;
}

Baselines baselines_from_json(const json& doc) {
  Baselines out;
  const auto result = [](const json& v) {
    return IsolationResult{number_or_nan(v.at("time_us")), number_or_nan(v.at("ipc")),
                           number_or_nan(v.at("mbps"))};
  };
  for (const auto& [k, v] : doc.items()) {
    if (!v.contains("runs")) {  // one measurement, as rosguard wrote before repeated baselines
      out.put(k, result(v), 0);
      continue;
    }
    for (const auto& r : v.at("runs"))
      out.put(k, result(r), r.at("rep").get<int>());
  }
  return out;
}

ResultsStore::ResultsStore(fs::path dir, std::string header_line,
                           std::map<std::string, std::size_t> order, int repetitions, bool adaptive)
    : dir_(std::move(dir)),
      header_line_(std::move(header_line)),
      order_(std::move(order)),
      repetitions_(repetitions),
      adaptive_(adaptive) {}

ResultsStore::~ResultsStore() {
  if (shard_lock_) shard_lock_->remove_file();  // never opened (an input error), or failed
}

void ResultsStore::claim_shard(const std::string& shard) {
  std::error_code ec;
  fs::create_directories(dir_, ec);
  if (ec) throw RunError("cannot create results folder " + dir_.string() + ": " + ec.message());
  std::string name = shard;
  if (const auto slash = name.find('/'); slash != std::string::npos) name.replace(slash, 1, "-of-");
  const fs::path path = dir_ / (".shard-" + name + ".lock");
  shard_lock_ = FileLock::try_lock(path);
  if (!shard_lock_) {
    std::string holder;
    try {
      holder = read_file(path);  // as its holder wrote it (a moment ago, maybe not yet)
    } catch (const RunError&) {
    }
    while (!holder.empty() && (holder.back() == '\n' || holder.back() == '\0'))
      holder.pop_back();
    std::string index = shard, count = "1";
    if (const auto slash = shard.find('/'); slash != std::string::npos) {
      index = shard.substr(0, slash);
      count = shard.substr(slash + 1);
    }
    throw ShardBusyError("another rosguard" + (holder.empty() ? "" : " (" + holder + ")") +
                         " is writing shard " + index + " of " + count + " into " + dir_.string() +
                         "; two writers of one shard would run and write its runs twice: wait "
                         "for it to finish (rosguard status " +
                         dir_.string() + "), or stop it and run again with --resume");
  }
  const json me = process_facts();
  shard_lock_->write_note("pid " + std::to_string(me.value("pid", 0LL)) + " on " +
                          me.value("host", std::string("?")) + ", since " + iso_time_now() + "\n");
}

void ResultsStore::prepare(bool overwrite, bool joining, const std::string& scenario_hash) const {
  std::error_code ec;
  const fs::path manifest = dir_ / "manifest.json";
  if (!fs::exists(manifest, ec) && !fs::exists(points_path(), ec)) return;
  if (overwrite) {
    for (const char* f : {"manifest.json", "points.csv", "samples.csv", "baselines.json",
                          "trace.json", "columns.json", ".lock"})
      fs::remove(dir_ / f, ec);
  } else if (!joining) {
    throw InputError("", "",
                     "results folder " + dir_.string() +
                         " already holds a run; pass --resume to continue it, "
                         "--overwrite to replace it, or choose another --out");
  } else if (fs::exists(manifest, ec)) {
    const json m = json::parse(read_file(manifest), nullptr, false);
    if (!m.is_object() || m.value("scenario_hash", "") != scenario_hash)
      throw InputError("", "",
                       "results folder " + dir_.string() +
                           " holds a different scenario (or other settings); resume "
                           "only the same scenario, or choose another --out");
  }
}

Baselines ResultsStore::read_baselines() const {
  std::error_code ec;
  const fs::path path = dir_ / "baselines.json";
  if (!fs::exists(path, ec)) return {};
  const json b = json::parse(read_file(path), nullptr, false);
  if (!b.is_object()) return {};
  try {
    return baselines_from_json(b);
  } catch (const json::exception& e) {
    throw RunError(path.string() + ": not the isolation results rosguard writes (" + e.what() +
                   "); remove it to measure them again");
  }
}

json ResultsStore::read_manifest() const {
  std::error_code ec;
  const fs::path path = dir_ / "manifest.json";
  json m = fs::exists(path, ec) ? json::parse(read_file(path), nullptr, false) : json::object();
  return m.is_object() ? m : json::object();
}

// Sorted rows, the first row of each run kept; samples of runs without a row dropped. The caller
// holds the lock, so no writer is between its two appends.
std::set<RunKey> ResultsStore::tidy_csv_files(const RowRefresher& refresh,
                                              const PointRefresher& point_refresh) const {
  // Both files as this store left them (see append_runs), nothing to refresh: tidy already, and
  // not read again (a 10,000-point sweep writes some 150 MB of samples).
  if (tidy_ && !refresh && !point_refresh && sizes() == tidy_sizes_) return done_;
  const CsvFile points = read_csv(points_path(), order_);
  if (!points.header.empty() && points.header != header_line_)
    throw InputError("", "",
                     points_path().string() +
                         " has other columns than this scenario produces; resume "
                         "only the same scenario, or choose another --out");
  std::set<RunKey> done;
  const Baselines baselines = refresh || point_refresh ? read_baselines() : Baselines{};
  std::string text = header_line_ + "\n";
  // The rows of one point are consecutive (sorted by sweep index, then rep).
  std::vector<std::string> group;
  std::string group_id;
  const auto flush = [&] {
    if (group.empty()) return;
    if (point_refresh) group = point_refresh(group_id, group, baselines);
    for (const auto& line : group)
      text += line + "\n";
    group.clear();
  };
  for (const auto& row : points.rows) {
    if (!done.insert(row.key).second) continue;
    const auto fresh = refresh ? refresh(row.key.first, row.line, baselines) : std::nullopt;
    if (row.key.first != group_id) flush();
    group_id = row.key.first;
    group.push_back(fresh ? *fresh : row.line);
  }
  flush();
  write_file_atomic(points_path(), text);

  // samples.csv as this store left it needs no tidying: only points.csv had to be refreshed.
  if (!(tidy_ && sizes().second == tidy_sizes_.second))
    tidy_samples(dir_ / "samples.csv", order_, done);
  tidy_ = true;
  tidy_sizes_ = sizes();
  done_ = done;
  last_run_ = {0, -1};
  for (const auto& [id, rep] : done) {
    const auto it = order_.find(id);
    last_run_ = std::max(last_run_, {it == order_.end() ? order_.size() : it->second, rep});
  }
  return done;
}

std::pair<std::uintmax_t, std::uintmax_t> ResultsStore::sizes() const {
  std::error_code ec;
  const auto size = [&](const fs::path& p) {
    const auto n = fs::file_size(p, ec);
    return ec ? static_cast<std::uintmax_t>(-1) : n;
  };
  return {size(points_path()), size(dir_ / "samples.csv")};
}

ResultsStore::Opened ResultsStore::open(json description, const std::string& shard) {
  std::error_code ec;
  fs::create_directories(dir_, ec);
  if (ec) throw RunError("cannot create results folder " + dir_.string() + ": " + ec.message());
  FileLock lock(dir_ / ".lock");
  json m = read_manifest();
  if (m.contains("scenario_hash") && m["scenario_hash"] != description.at("scenario_hash"))
    throw InputError("", "",
                     "results folder " + dir_.string() +
                         " holds a different scenario (or other settings); resume "
                         "only the same scenario, or choose another --out");
  Opened opened;
  opened.done = tidy_csv_files();
  opened.baselines = read_baselines();
  shard_ = shard;
  for (auto& [key, value] : description.items())  // moved: it lists every point of the sweep
    m[key] = std::move(value);
  m["shard"] = shard;
  m["end_time"] = nullptr;
  m["status"] = "running";
  m["shards"][shard] = {{"status", "running"},
                        {"command", m.value("command", "")},
                        {"start_time", m.value("start_time", "")}};
  m["shards"][shard].update(process_facts());  // host, pid: `rosguard status` checks it runs
  if (!m.contains("fallbacks")) m["fallbacks"] = json::array();
  if (!m.contains("facts")) m["facts"] = json::object();
  for (const auto& f : m["fallbacks"])
    opened.fallbacks.emplace(f.value("what", ""), f.value("detail", ""));
  // The manifest last: a write that fails before it leaves no shard said to run.
  write_file_atomic(dir_ / "columns.json", columns_json(header_line_).dump(2) + "\n");
  manifest_text_ = m.dump(2) + "\n";
  write_file_atomic(dir_ / "manifest.json", manifest_text_);
  manifest_ = std::move(m);
  return opened;
}

json ResultsStore::take_manifest() {
  std::string written = std::move(manifest_text_);
  manifest_text_.clear();
  json m = std::move(manifest_);
  manifest_ = json();
  std::error_code ec;
  const fs::path path = dir_ / "manifest.json";
  if (!written.empty() && fs::file_size(path, ec) == written.size() && !ec &&
      read_file(path) == written)
    return m;
  return read_manifest();
}

void ResultsStore::append_runs(const std::string& samples, const std::string& rows) const {
  FileLock lock(dir_ / ".lock");
  // The files stay tidy (tidy_csv_files would not change them) while only this store appends,
  // each run after the last one in sweep order.
  if (tidy_ && sizes() != tidy_sizes_) tidy_ = false;  // another shard wrote
  for (std::size_t pos = 0; tidy_ && pos < rows.size();) {
    std::size_t end = rows.find('\n', pos);
    end = end == std::string::npos ? rows.size() : end;
    const std::string_view line(rows.data() + pos, end - pos);
    const std::size_t c0 = line.find(',');
    const std::string_view id = line.substr(0, c0);
    const auto it = order_.find(std::string(id));
    int rep = -1;
    if (c0 != std::string_view::npos)
      std::from_chars(line.data() + c0 + 1, line.data() + line.size(), rep);
    const std::pair<std::size_t, int> run{it == order_.end() ? order_.size() : it->second, rep};
    if (line.find('"') != std::string_view::npos || it == order_.end() || run <= last_run_)
      tidy_ = false;
    else
      done_.emplace(std::string(id), rep);
    last_run_ = run;
    pos = end + 1;
  }
  AppendFile samples_file(dir_ / "samples.csv");
  samples_file.append(samples);
  try {
    append_under_lock(points_path(), rows);
  } catch (const RunError&) {
    samples_file.undo();  // no samples without their rows, and their space free again
    tidy_ = false;
    throw;
  }
  tidy_sizes_.first += rows.size();
  tidy_sizes_.second += samples.size();
}

void ResultsStore::save_baselines(const Baselines& baselines) const {
  FileLock lock(dir_ / ".lock");
  Baselines merged = read_baselines();
  for (const auto& [k, runs] : baselines.all())
    for (const auto& [rep, r] : runs.runs)
      if (!merged.all().count(k) || !merged.all().at(k).runs.count(rep)) merged.put(k, r, rep);
  write_file_atomic(dir_ / "baselines.json", baselines_to_json(merged).dump(2) + "\n");
}

void ResultsStore::add_trace(const json& events) const {
  FileLock lock(dir_ / ".lock");
  write_trace(dir_ / "trace.json", events);
}

std::size_t ResultsStore::finish(const InvocationReport& report, const RowRefresher& refresh,
                                 const PointRefresher& point_refresh) {
  FileLock lock(dir_ / ".lock");
  std::size_t rows = 0;
  try {
    rows = finish_locked(report, refresh, point_refresh);
  } catch (const std::exception& e) {
    // A write failed (a full disk): the manifest must not go on saying that this shard runs.
    const std::string error =
        report.status == "failed" && !report.error.empty() ? report.error : e.what();
    try {
      record_failure(error);
    } catch (const std::exception& m) {
      throw ManifestNotUpdatedError(
          // This write's error leads when it is the one to record (the caller has none).
          (error == e.what() ? std::string(e.what()) + "; " : std::string()) +
          "could not record the failure in " + (dir_ / "manifest.json").string() + " (" + m.what() +
          "): it still says that shard " + shard_ + " is running");
    }
    throw;
  }
  lock.remove_file();  // a shard still running locks a fresh one
  if (shard_lock_) {
    shard_lock_->remove_file();
    shard_lock_.reset();
  }
  return rows;
}

void ResultsStore::record_failure(const std::string& error) const {
  json m = read_manifest();
  if (m.empty()) throw RunError("it is missing or unreadable");
  const std::string now = iso_time_now();
  json& entry = m["shards"][shard_];
  entry["status"] = "failed";
  entry["error"] = error;
  entry["end_time"] = now;
  m["status"] = "failed";
  m["error"] = first_error(m["shards"]);
  m["end_time"] = now;
  write_file_atomic(dir_ / "manifest.json", m.dump(2) + "\n");
}

std::size_t ResultsStore::finish_locked(const InvocationReport& report, const RowRefresher& refresh,
                                        const PointRefresher& point_refresh) {
  const std::set<RunKey> done = tidy_csv_files(refresh, point_refresh);
  const std::size_t rows = done.size();
  json m = take_manifest();
  // Every baseline of the folder (all shards): its measurements, their median and spread, and a
  // warning where the spread is too large for the slowdowns measured against it.
  const Baselines baselines = read_baselines();
  json warnings = json::array();  // the loader's; the baselines' own are recomputed below
  if (m["warnings"].is_array())
    for (const auto& w : m["warnings"])
      if (!w.is_string() || w.get<std::string>().rfind("isolation baseline ", 0) != 0)
        warnings.push_back(w);
  m["warnings"] = warnings;
  m["baselines"] = json::object();
  for (const auto& [k, runs] : baselines.all()) {
    json times = json::array();
    for (const auto& [rep, r] : runs.runs)
      times.push_back(r.time_us);
    m["baselines"][k] = {{"measurements", runs.count()},
                         {"time_us", runs.median().time_us},
                         {"time_cv", runs.time_cv()},
                         {"time_us_each", times}};
    if (const std::string w = runs.noise_warning(k); !w.empty()) m["warnings"].push_back(w);
  }
  if (!m["fallbacks"].is_array()) m["fallbacks"] = json::array();
  for (const auto& [what, detail] : report.fallbacks) {
    const json entry{{"what", what}, {"detail", detail}};
    if (std::find(m["fallbacks"].begin(), m["fallbacks"].end(), entry) == m["fallbacks"].end())
      m["fallbacks"].push_back(entry);
  }
  for (const auto& [k, v] : report.facts)
    m["facts"][k] = v;
  for (const auto& w : report.warnings)
    if (std::find(m["warnings"].begin(), m["warnings"].end(), w) == m["warnings"].end())
      m["warnings"].push_back(w);
  for (const auto& [k, v] : report.manifest.items()) {
    if (v.is_object() && m.contains(k) && m[k].is_object())
      m[k].update(v, true);  // objects merged: another shard's entries stay
    else
      m[k] = v;
  }
  const std::string now = iso_time_now();
  json& entry = m["shards"][shard_];
  entry["status"] = report.status;
  entry["end_time"] = now;
  entry["rows_this_invocation"] = report.rows;
  entry["skipped_on_resume"] = report.skipped_on_resume;
  entry["elapsed_s"] = report.elapsed_s;
  if (report.error.empty())
    entry.erase("error");
  else
    entry["error"] = report.error;

  const std::size_t expected = order_.size() * static_cast<std::size_t>(repetitions_);
  // Every point has its first `repetitions_` rows (adaptive points may have more).
  std::map<std::string, int> first_reps;
  for (const auto& [id, rep] : done)
    if (rep >= 0 && rep < repetitions_ && order_.count(id)) ++first_reps[id];
  const bool all_rows = first_reps.size() == order_.size() &&
                        std::all_of(first_reps.begin(), first_reps.end(),
                                    [&](const auto& e) { return e.second == repetitions_; });
  m["end_time"] = now;
  m["status"] = folder_status(m["shards"], all_rows, adaptive_);
  if (const std::string error = first_error(m["shards"]); !error.empty())
    m["error"] = error;
  else
    m.erase("error");
  m["counts"] = {{"points", order_.size()},
                 {"repetitions", repetitions_},
                 {"repetitions_adaptive", adaptive_},
                 {"runs_expected", expected},
                 {"rows", rows},
                 {"rows_this_invocation", report.rows},
                 {"skipped_on_resume", report.skipped_on_resume}};
  m["elapsed_s"] = report.elapsed_s;
  write_file_atomic(dir_ / "manifest.json", m.dump(2) + "\n");
  return rows;
}

}  // namespace rosguard
