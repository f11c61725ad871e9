#include "run/slurm.h"

#include <fcntl.h>
#include <spawn.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cstdlib>
#include <cstring>
#include <iostream>
#include <sstream>

#include "core/error.h"
#include "load/files.h"
#include "load/host_facts.h"
#include "store/results_store.h"
#include "store/run_manifest.h"

extern char** environ;

namespace rosguard {
namespace fs = std::filesystem;
using json = nlohmann::json;

namespace {

// A program on PATH (as execvp would find it), or nullopt.
std::optional<fs::path> find_program(const std::string& name) {
  const char* env = std::getenv("PATH");
  std::stringstream dirs(env && *env ? env : "/usr/local/bin:/usr/bin:/bin");
  for (std::string dir; std::getline(dirs, dir, ':');) {
    const fs::path candidate = fs::path(dir.empty() ? "." : dir) / name;
    struct stat st {};
    if (::stat(candidate.c_str(), &st) == 0 && S_ISREG(st.st_mode) &&
        ::access(candidate.c_str(), X_OK) == 0)
      return candidate;
  }
  return std::nullopt;
}

struct Captured {
  int exit_code = 0;  // the program's exit status, or 128 + the signal that ended it
  std::string out;    // its stdout (and stderr with merge_stderr)
};

// Runs argv[0] (a path) with argv, capturing stdout; stderr goes to ours unless merged.
Captured run_captured(const std::vector<std::string>& args, bool merge_stderr) {
  std::vector<char*> argv;
  for (const auto& a : args)
    argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  int fds[2];
  if (::pipe2(fds, O_CLOEXEC) != 0) throw RunError(std::string("pipe: ") + std::strerror(errno));
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_adddup2(&actions, fds[1], STDOUT_FILENO);
  if (merge_stderr) posix_spawn_file_actions_adddup2(&actions, fds[1], STDERR_FILENO);
  std::cout.flush();
  pid_t pid = 0;
  const int rc = ::posix_spawn(&pid, argv[0], &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  ::close(fds[1]);
  if (rc != 0) {
    ::close(fds[0]);
    throw RunError("cannot start " + args[0] + ": " + std::strerror(rc));
  }
  Captured c;
  char buf[4096];
  while (true) {
    const ssize_t n = ::read(fds[0], buf, sizeof buf);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) break;
    c.out.append(buf, static_cast<std::size_t>(n));
  }
  ::close(fds[0]);
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  c.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  return c;
}

std::string trimmed(std::string s) {
  while (!s.empty() && (s.back() == '\n' || s.back() == '\r' || s.back() == ' '))
    s.pop_back();
  return s;
}

// A Slurm job name from a scenario name: letters, digits, '.', '_' and '-'.
std::string job_name_of(const std::string& scenario_name) {
  std::string name = "rosguard-";
  for (const char c : scenario_name)
    name +=
        (std::isalnum(static_cast<unsigned char>(c)) || c == '.' || c == '_' || c == '-') ? c : '_';
  return name.substr(0, 64);
}

std::string plural(std::size_t n, const char* word) {
  return std::to_string(n) + " " + word + (n == 1 ? "" : "s");
}

}  // namespace

std::string shell_quote(const std::string& word) {
  const bool plain = !word.empty() && std::all_of(word.begin(), word.end(), [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || std::strchr("_./:=@%+,-", c);
  });
  if (plain) return word;
  std::string q = "'";
  for (const char c : word)
    q += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return q + "'";
}

void check_sbatch_word(const std::string& what, const std::string& word, bool is_path) {
  const auto bad = std::find_if(word.begin(), word.end(), [&](char c) {
    return std::isspace(static_cast<unsigned char>(c)) ||
           std::iscntrl(static_cast<unsigned char>(c)) || c == '"' || c == '\'' || c == '\\' ||
           (is_path && c == '%');
  });
  if (word.empty() || bad != word.end())
    throw InputError("", "",
                     what + " '" + word +
                         "' cannot be written into an #SBATCH line (sbatch splits those lines "
                         "at whitespace and takes no quotes" +
                         (is_path ? std::string(", and '%' in a log path is a pattern") : "") +
                         ")" + (is_path ? "; choose a results folder (--out) without them" : ""));
}

std::string sbatch_script(const SbatchScriptInputs& in) {
  const std::string script = (in.out / "slurm" / "run.sbatch").string();
  std::ostringstream s;
  s << "#!/bin/bash\n"
    << "# rosguard: " << in.summary << "\n"
    << "# One array task per shard, every task writing into one results folder (on a filesystem\n"
    << "# the nodes share). A task skips the runs already in points.csv (--resume): re-run the\n"
    << "# shards that failed with\n"
    << "#   sbatch --array=I[,J...] " << script << "\n"
    << "# and follow the run with\n"
    << "#   rosguard status " << in.out.string() << "\n"
    << "#SBATCH --job-name=" << in.job_name << "\n"
    << "#SBATCH --array=0-" << (in.shards - 1) << "\n"
    << "#SBATCH --ntasks=1\n"
    << "#SBATCH --output=" << (in.out / "slurm" / "%A_%a.out").string() << "\n";
  for (const auto& arg : in.sbatch_args)
    s << "#SBATCH " << arg << "\n";
  s << "set -u\n"
    << "if [ -z \"${SLURM_ARRAY_TASK_ID:-}\" ]; then\n"
    << "  echo \"$0: submit this script with sbatch (each array task runs one shard)\" >&2\n"
    << "  exit 2\n"
    << "fi\n"
    << "exec " << shell_quote(in.rosguard.string()) << " run " << shell_quote(in.scenario.string())
    << " --out " << shell_quote(in.out.string()) << " --shard \"$SLURM_ARRAY_TASK_ID/" << in.shards
    << "\" --resume";
  if (in.jobs)
    s << " --jobs " << *in.jobs;
  else
    s << " --jobs \"${SLURM_CPUS_PER_TASK:-1}\"";
  if (in.backend) s << " --backend " << shell_quote(*in.backend);
  if (in.trace) s << " --trace";
  if (!in.unregulated) s << " --no-unregulated";
  s << "\n";
  return s.str();
}

namespace {

// The array tasks: --array, else one per point up to kDefaultSlurmShards.
int shard_count(const SlurmOptions& slurm, std::size_t points, const std::string& scenario_file) {
  if (slurm.array > 0 && static_cast<std::size_t>(slurm.array) > points)
    throw InputError("", "",
                     "--array " + std::to_string(slurm.array) + " exceeds the " +
                         plural(points, "point") + " of " + scenario_file +
                         " (a shard holds whole points); choose at most " + std::to_string(points));
  return slurm.array > 0 ? slurm.array
                         : static_cast<int>(std::min<std::size_t>(
                               points, static_cast<std::size_t>(kDefaultSlurmShards)));
}

// Each --sbatch-arg is one sbatch option the script may carry (not the array: rosguard's).
void check_sbatch_args(const std::vector<std::string>& sbatch_args) {
  for (const auto& arg : sbatch_args) {
    check_sbatch_word("--sbatch-arg", arg, false);
    const std::string name = arg.substr(0, arg.find('='));
    if (arg.front() != '-')
      throw InputError("", "",
                       "--sbatch-arg takes one sbatch option, e.g. --sbatch-arg=--partition=short "
                       "(got '" +
                           arg + "')");
    if (name == "--array" || name.rfind("-a", 0) == 0 || name == "--wrap")
      throw InputError("", "",
                       "--sbatch-arg " + arg +
                           ": rosguard sets the array itself (one task per shard: use --array N)");
  }
}

// Submits the script; returns sbatch --parsable's answer, "JOB" or "JOB;CLUSTER".
std::string sbatch_submit(const fs::path& sbatch, const fs::path& script_path) {
  const Captured sub = run_captured({sbatch.string(), "--parsable", script_path.string()}, false);
  if (sub.exit_code != 0)
    throw RunError("sbatch refused the job (exit " + std::to_string(sub.exit_code) +
                   "; its message is above); the script is " + script_path.string());
  const std::string reply = trimmed(sub.out);
  const std::string job_id = reply.substr(0, reply.find(';'));
  long long id_number = 0;
  const auto [end, parse_ec] =
      std::from_chars(job_id.data(), job_id.data() + job_id.size(), id_number);
  if (job_id.empty() || parse_ec != std::errc() || end != job_id.data() + job_id.size())
    throw RunError("sbatch --parsable answered '" + reply + "', not a job id; the script is " +
                   script_path.string());
  return reply;
}

}  // namespace

int submit_to_slurm(const RunOptions& run, const SlurmOptions& slurm, Loader& loader,
                    const BackendRegistry& backends) {
  // 1. Everything the tasks will check, checked here first: nothing is written on an error.
  const LoadedScenario loaded = load_for_run(run, loader, backends);
  const Scenario& first = loaded.points.front().scenario;
  const std::size_t points = loaded.points.size();
  const int shards = shard_count(slurm, points, run.scenario_file);
  check_sbatch_args(slurm.sbatch_args);
  std::error_code ec;
  const fs::path out = fs::absolute(results_folder(run, loaded), ec).lexically_normal();
  check_sbatch_word("results folder", out.string(), true);
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  if (ec) throw RunError("cannot find this rosguard executable (/proc/self/exe): " + ec.message());
  const fs::path scenario = fs::absolute(run.scenario_file).lexically_normal();

  SbatchScriptInputs in;
  in.rosguard = exe;
  in.scenario = scenario;
  in.out = out;
  in.job_name = job_name_of(first.name);
  in.shards = shards;
  if (run.jobs > 0) in.jobs = run.jobs;
  in.backend = run.backend;
  in.trace = run.trace;
  in.unregulated = run.unregulated;
  in.sbatch_args = slurm.sbatch_args;
  in.summary = "run " + first.name + " (" + plural(points, "point") + " x " +
               plural(static_cast<std::size_t>(first.repetitions), "repetition") + ") as " +
               plural(static_cast<std::size_t>(shards), "shard") + " into " + out.string();
  const std::string script = sbatch_script(in);

  ResultsStore store(out, "", {}, first.repetitions);
  const std::string hash = scenario_hash(loaded);
  if (!run.overwrite) store.prepare(false, run.resume, hash);
  if (slurm.dry_run) {
    std::cout << script;
    if (!run.quiet)
      std::cerr << "rosguard: dry run: nothing written or submitted (the script would be "
                << (out / "slurm" / "run.sbatch").string() << ")\n";
    return 0;
  }
  const auto sbatch = find_program("sbatch");
  if (!sbatch)
    throw RunError(
        "sbatch is not on PATH: --slurm submits the run with Slurm's sbatch (Debian package "
        "slurm-client); --dry-run prints the script without it, and --shard I/N runs one shard "
        "here");

  // 2. The folder (emptied with --overwrite), the script, the submission.
  if (run.overwrite) store.prepare(true, false, hash);
  const fs::path dir = out / "slurm";
  fs::create_directories(dir, ec);
  if (ec) throw RunError("cannot create " + dir.string() + ": " + ec.message());
  const fs::path script_path = dir / "run.sbatch";
  write_file_atomic(script_path, script);
  fs::permissions(script_path, fs::perms::owner_exec | fs::perms::group_exec, fs::perm_options::add,
                  ec);

  const std::string reply = sbatch_submit(*sbatch, script_path);
  const std::string job_id = reply.substr(0, reply.find(';'));
  json job{{"job_id", job_id},
           {"shards", shards},
           {"script", script_path.string()},
           {"scenario_file", scenario.string()},
           {"out", out.string()},
           {"points", points},
           {"repetitions", first.repetitions},
           {"sbatch_args", slurm.sbatch_args},
           {"command", run.command_line},
           {"submitted", iso_time_now()}};
  if (const auto semi = reply.find(';'); semi != std::string::npos)
    job["cluster"] = reply.substr(semi + 1);
  write_file_atomic(dir / "job.json", job.dump(2) + "\n");

  if (run.quiet) {
    std::cout << job_id << "\n";
    return 0;
  }
  const std::string shown = shell_quote(out.string());
  std::cout << "rosguard: submitted Slurm job " << job_id << ": "
            << plural(static_cast<std::size_t>(shards), "array task") << " (shards 0/" << shards
            << " .. " << shards - 1 << "/" << shards << ") of " << first.name << ", "
            << plural(points, "point") << " x "
            << plural(static_cast<std::size_t>(first.repetitions), "repetition") << ", into "
            << out.string() << "\n"
            << "  follow:  rosguard status " << shown << "   (or: squeue -j " << job_id << ")\n"
            << "  logs:    " << (dir / (job_id + "_TASK.out")).string() << "\n"
            << "  cancel:  scancel " << job_id << "\n";
  return 0;
}

std::optional<std::vector<SlurmTask>> slurm_queue(std::string& why) {
  const auto squeue = find_program("squeue");
  if (!squeue) {
    why = "squeue is not on PATH";
    return std::nullopt;
  }
  // The command last: it may hold '|'.
  const Captured q =
      run_captured({squeue->string(), "-h", "-r", "-t", "all", "-o", "%i|%T|%r|%o"}, true);
  if (q.exit_code != 0) {
    why = "squeue failed: " + trimmed(q.out);
    return std::nullopt;
  }
  std::vector<SlurmTask> tasks;
  for (const auto& line : split_lines(q.out)) {
    std::vector<std::string> f;
    std::size_t start = 0;
    for (int i = 0; i < 3; ++i) {
      const auto bar = line.find('|', start);
      if (bar == std::string::npos) break;
      f.push_back(line.substr(start, bar - start));
      start = bar + 1;
    }
    if (f.size() != 3) continue;
    SlurmTask t{f[0], 0, -1, f[1], f[2], line.substr(start)};
    const auto us = t.id.find('_');
    const std::string job = t.id.substr(0, us);
    if (std::from_chars(job.data(), job.data() + job.size(), t.job).ec != std::errc()) continue;
    if (us != std::string::npos) {
      const std::string index = t.id.substr(us + 1);
      int value = 0;
      const auto [end, ec] = std::from_chars(index.data(), index.data() + index.size(), value);
      if (ec == std::errc() && end == index.data() + index.size()) t.index = value;
    }
    tasks.push_back(std::move(t));
  }
  return tasks;
}

bool slurm_state_live(const std::string& state) {
  for (const char* s :
       {"PENDING", "CONFIGURING", "RUNNING", "COMPLETING", "SUSPENDED", "REQUEUED", "REQUEUE_HOLD",
        "REQUEUE_FED", "RESIZING", "SIGNALING", "STAGE_OUT", "STOPPED", "RESV_DEL_HOLD"})
    if (state == s) return true;
  return false;
}

}  // namespace rosguard
