// A mutational scenario fuzzer for the loader and `rosguard check`, bounded in time so that it
// runs in `make test`. Reproducible: input i of a run depends only on --seed and i.
//
//   fuzz_driver --seeds DIR... [--corpus DIR] [--seconds S] [--seed N] [--timeout-ms T]
//               [--save DIR]
//
// First every file of --corpus (found cases, kept as regression tests) is replayed, then mutated
// seeds are tried until --seconds have passed. Each input runs in a forked child (so that a
// crash or a hang is caught and the parent's loaded schemas and platforms are reused) under a
// timeout and a memory limit. A finding: a signal, a hang, an exception other than an InputError
// naming a file. Findings are printed (and written to --save, one file per distinct kind);
// the exit status is 1 when there was any.
#include <fcntl.h>
#include <sys/resource.h>
#include <sys/time.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <csignal>
#include <cstring>
#include <fstream>
#include <iostream>
#include <map>
#include <nlohmann/json.hpp>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "fuzz_target.h"

namespace {
namespace fs = std::filesystem;
using json = nlohmann::json;
using Rng = std::mt19937_64;

std::string read_all(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

std::size_t pick(Rng& rng, std::size_t n) {
  return std::uniform_int_distribution<std::size_t>(0, n - 1)(rng);
}

// Every JSON pointer of `doc` (the seeds are shallow, so recursion is fine here).
void pointers(const json& doc, const std::string& at, std::vector<std::string>& out) {
  out.push_back(at);
  if (doc.is_object())
    for (const auto& [k, v] : doc.items())
      pointers(v, (json::json_pointer(at) / k).to_string(), out);
  if (doc.is_array())
    for (std::size_t i = 0; i < doc.size(); ++i)
      pointers(doc[i], at + "/" + std::to_string(i), out);
}

// Placeholders replaced in the dumped text by what a JSON value cannot hold.
const char* const kNumbers[] = {"1e999",
                                "-1e999",
                                "1e308",
                                "1e300",
                                "1e-300",
                                "-1",
                                "0",
                                "0.5",
                                "-0",
                                "18446744073709551616",
                                "9223372036854775807",
                                "-9223372036854775808",
                                "4294967297",
                                "2147483648",
                                "1e20",
                                "NaN",
                                "100000",
                                "1000000000"};
const char* const kPaths[] = {"/dev/zero",
                              "/",
                              "fifo.json",
                              "dir.json",
                              "/proc/self/status",
                              "no-such.json",
                              "../../../../../../etc/passwd",
                              "",
                              "fixtures/bad-platform.json",
                              "fixtures/bad-workload.json",
                              "/dev/null",
                              "./",
                              "orin-agx",
                              "vm-2core",
                              "mser"};

class Mutator {
 public:
  Mutator(std::vector<std::string> seeds, std::uint64_t seed)
      : seeds_(std::move(seeds)), rng_(seed) {}

  // Input number i: its own generator, so a finding can be reproduced from (seed, i).
  std::string make(std::uint64_t base_seed, std::uint64_t i) {
    rng_.seed(base_seed * 0x9E3779B97F4A7C15ULL + i);
    const std::string& text = seeds_[pick(rng_, seeds_.size())];
    json doc = json::parse(text, nullptr, false);
    subs_.clear();
    if (!doc.is_discarded()) {
      const std::size_t n = 1 + pick(rng_, 3);
      for (std::size_t k = 0; k < n; ++k) {
        try {
          mutate(doc);
        } catch (const json::exception&) {
          // this mutation does not fit this document's shape (its root is no object...)
        }
      }
    }
    std::string out = doc.is_discarded() ? text : doc.dump(pick(rng_, 2) ? 2 : -1);
    for (const auto& [placeholder, value] : subs_) {
      const std::string quoted = "\"" + placeholder + "\"";
      for (auto p = out.find(quoted); p != std::string::npos; p = out.find(quoted, p + 1))
        out.replace(p, quoted.size(), value);
    }
    if (pick(rng_, 6) == 0) mutate_bytes(out);
    return out;
  }

  // Kinds of mutation, for the report.
  static constexpr int kKinds = 11;

 private:
  std::string placeholder(const std::string& text) {
    const std::string p = "@@" + std::to_string(subs_.size()) + "@@";
    subs_.emplace_back(p, text);
    return p;
  }

  json& random_node(json& doc, std::string* where = nullptr) {
    std::vector<std::string> ps;
    pointers(doc, "", ps);
    const std::string p = ps[pick(rng_, ps.size())];
    if (where) *where = p;
    return doc[json::json_pointer(p)];
  }

  json random_subtree() {
    json other = json::parse(seeds_[pick(rng_, seeds_.size())], nullptr, false);
    if (other.is_discarded()) return nullptr;
    return random_node(other);
  }

  std::string long_string() {
    const std::size_t n = std::size_t{1} << (8 + pick(rng_, 11));  // 256 .. 256 Ki
    std::string s(n, 'a');
    if (pick(rng_, 2))
      for (std::size_t i = 1; i < n; i += 2)
        s[i] = '.';
    return s;
  }

  std::string deep(std::size_t levels) {
    const bool arrays = pick(rng_, 2);
    std::string s;
    for (std::size_t i = 0; i < levels; ++i)
      s += arrays ? "[" : "{\"a\":";
    s += "1";
    for (std::size_t i = 0; i < levels; ++i)
      s += arrays ? "]" : "}";
    return s;
  }

  json huge_sweep() {
    const char* const paths[] = {"regulation.threshold_pct",
                                 "seed",
                                 "repetitions",
                                 "regulation.sampling_period_us",
                                 "sim.quantum_us",
                                 "nodes.rt[0].iterations",
                                 "hw.watchdog_ms"};
    json sweep = json::object();
    const std::size_t keys = 1 + pick(rng_, 40);
    const std::size_t per = 1 + pick(rng_, 400);
    for (std::size_t k = 0; k < keys; ++k) {
      json values = json::array();
      for (std::size_t v = 0; v < per; ++v)
        values.push_back(v + 1);
      std::string key = paths[pick(rng_, std::size(paths))];
      for (std::size_t j = 0; j < k; ++j)
        key += "+" + std::string(paths[pick(rng_, std::size(paths))]);
      sweep[k < 7 ? std::string(paths[k]) : key] = values;
    }
    return sweep;
  }

  void mutate(json& doc) {
    std::string where;
    json& node = random_node(doc, &where);
    switch (pick(rng_, kKinds)) {
      case 0:  // delete a key or an element
        if (!where.empty()) {
          json::json_pointer p(where);
          json& parent = doc[p.parent_pointer()];
          if (parent.is_object()) parent.erase(p.back());
          if (parent.is_array()) parent.erase(parent.begin() + std::stol(p.back()));
        }
        break;
      case 1: {  // swap the type
        const json values[] = {
            nullptr, true, "x", 0, -1, json::array(), json::object(), 1.5, json::array({1, 2})};
        node = values[pick(rng_, std::size(values))];
        break;
      }
      case 2:  // an extreme number
        node = placeholder(kNumbers[pick(rng_, std::size(kNumbers))]);
        break;
      case 3:  // deep nesting
        node = placeholder(deep(std::size_t{1} << pick(rng_, 15)));
        break;
      case 4:  // a long string as a value, a key, or a sweep key
        if (pick(rng_, 2) && node.is_object()) {
          node[long_string()] = 1;
        } else if (pick(rng_, 2)) {
          doc["sweep"] = json::object({{long_string(), json::array({1})}});
        } else {
          node = long_string();
        }
        break;
      case 5:  // a huge sweep
        doc["sweep"] = huge_sweep();
        break;
      case 6:  // a bad platform or workload path
        if (pick(rng_, 2))
          doc["platform"] = kPaths[pick(rng_, std::size(kPaths))];
        else if (doc.contains("nodes") && doc["nodes"].is_object() && doc["nodes"].contains("rt") &&
                 doc["nodes"]["rt"].is_array() && !doc["nodes"]["rt"].empty() &&
                 doc["nodes"]["rt"][0].is_object())
          doc["nodes"]["rt"][0]["workload"] = kPaths[pick(rng_, std::size(kPaths))];
        break;
      case 7:  // splice a subtree of another seed
        node = random_subtree();
        break;
      case 8: {  // sweep keys that reshape arrays other keys index into
        const char* const keys[] = {
            "nodes.rt", "nodes.nrt",  "nodes.rt[0].core", "nodes.nrt[0].workload",   "nodes.rt[0]",
            "nodes",    "regulation", "nodes.rt[1].name", "regulation.metric.events"};
        const json values[] = {json::array({json::array()}), json::array({1, 2}),
                               json::array({json::object()}), json::array({"mser"}),
                               json::array({nullptr})};
        if (!doc["sweep"].is_object()) doc["sweep"] = json::object();
        doc["sweep"][keys[pick(rng_, std::size(keys))]] = values[pick(rng_, std::size(values))];
        break;
      }
      case 9:  // a duplicated key
        if (node.is_object() && !node.empty()) {
          const auto it = std::next(node.begin(), static_cast<long>(pick(rng_, node.size())));
          const std::string dup = json(it.key()).dump() + ": " + it.value().dump();
          node[it.key()] = placeholder(it.value().dump() + ", " + dup);
        }
        break;
      default: {  // a sim profile with extreme figures, inline
        const char* const fields[] = {"instructions", "base_ipc", "l2_refill_pki", "mlp"};
        json w = {{"name", "w"},
                  {"sim",
                   {{"instructions", 1e9},
                    {"phases", json::array({{{"fraction", 1},
                                             {"base_ipc", 1},
                                             {"l2_refill_pki", 2},
                                             {"l2_wb_pki", 1}}})}}}};
        const std::string f = fields[pick(rng_, std::size(fields))];
        const std::string v = kNumbers[pick(rng_, std::size(kNumbers))];
        if (f == "instructions")
          w["sim"][f] = placeholder(v);
        else
          w["sim"]["phases"][0][f] = placeholder(v);
        if (doc.contains("nodes") && doc["nodes"].is_object() && doc["nodes"].contains("nrt") &&
            doc["nodes"]["nrt"].is_array() && !doc["nodes"]["nrt"].empty() &&
            doc["nodes"]["nrt"][0].is_object())
          doc["nodes"]["nrt"][0]["workload"] = w;
        break;
      }
    }
  }

  void mutate_bytes(std::string& s) {
    const std::size_t n = 1 + pick(rng_, 8);
    for (std::size_t k = 0; k < n && !s.empty(); ++k) {
      const std::size_t at = pick(rng_, s.size());
      switch (pick(rng_, 3)) {
        case 0:
          s[at] = static_cast<char>(pick(rng_, 256));
          break;
        case 1:
          s.erase(at, 1 + pick(rng_, 16));
          break;
        default:
          s.insert(at, s.substr(pick(rng_, s.size()), 1 + pick(rng_, 64)));
      }
    }
  }

  std::vector<std::string> seeds_;
  Rng rng_;
  std::vector<std::pair<std::string, std::string>> subs_;
};

struct Verdict {
  bool failed = false;
  std::string what;  // the finding, one line
};

// Runs one input in a child: a crash, a hang or a finding there does not stop the fuzzer.
Verdict run_child(const std::string& input, int timeout_ms) {
  int pipefd[2];
  if (::pipe(pipefd) != 0) return {true, "pipe failed"};
  const pid_t pid = ::fork();
  if (pid == 0) {
    ::close(pipefd[0]);
    const rlimit mem{std::size_t{2} << 30, std::size_t{2} << 30};  // bad_alloc, not the OOM killer
    ::setrlimit(RLIMIT_AS, &mem);
    const itimerval t{{0, 0}, {timeout_ms / 1000, (timeout_ms % 1000) * 1000}};
    ::setitimer(ITIMER_REAL, &t, nullptr);           // SIGALRM ends a hang
    const int null = ::open("/dev/null", O_WRONLY);  // check's summary and warnings are noise
    ::dup2(null, STDOUT_FILENO);
    ::dup2(null, STDERR_FILENO);
    const std::string failure = rosguard::fuzz::check_scenario_bytes(
        reinterpret_cast<const std::uint8_t*>(input.data()), input.size());
    if (!failure.empty()) (void)!::write(pipefd[1], failure.data(), failure.size());
    ::_exit(failure.empty() ? 0 : 3);
  }
  ::close(pipefd[1]);
  std::string msg;
  char buf[4096];
  for (ssize_t n; (n = ::read(pipefd[0], buf, sizeof buf)) > 0;)
    msg.append(buf, static_cast<std::size_t>(n));
  ::close(pipefd[0]);
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  if (WIFSIGNALED(status)) {
    const int sig = WTERMSIG(status);
    if (sig == SIGALRM)
      return {true, "hang: no answer within " + std::to_string(timeout_ms) + " ms"};
    return {true, std::string("signal ") + std::to_string(sig) + " (" + strsignal(sig) + ")"};
  }
  if (WEXITSTATUS(status) != 0) return {true, msg};
  return {};
}

// The kind of a finding: its text with figures and quoted parts blanked, so one cause counts once.
std::string kind_of(const std::string& what) {
  std::string k;
  bool quoted = false;
  for (char c : what) {
    if (c == '\'') quoted = !quoted;
    if (quoted) continue;
    if (std::isdigit(static_cast<unsigned char>(c))) {
      if (k.empty() || k.back() != '#') k += '#';
      continue;
    }
    k += c;
  }
  if (const auto colon = k.find("rosguard-fuzz-"); colon != std::string::npos) k.resize(colon);
  return k.substr(0, 100);
}

struct Options {
  std::vector<fs::path> seed_dirs;
  fs::path corpus;
  fs::path save;
  double seconds = 50;
  std::uint64_t seed = 1;
  int timeout_ms = 10000;
};

Options parse(int argc, char** argv) {
  Options o;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    const auto next = [&]() -> std::string {
      if (i + 1 >= argc) throw std::invalid_argument(a + " needs a value");
      return argv[++i];
    };
    if (a == "--seeds") {
      while (i + 1 < argc && std::string(argv[i + 1]).rfind("--", 0) != 0)
        o.seed_dirs.emplace_back(argv[++i]);
    } else if (a == "--corpus") {
      o.corpus = next();
    } else if (a == "--save") {
      o.save = next();
    } else if (a == "--seconds") {
      o.seconds = std::stod(next());
    } else if (a == "--seed") {
      o.seed = std::stoull(next());
    } else if (a == "--timeout-ms") {
      o.timeout_ms = std::stoi(next());
    } else {
      throw std::invalid_argument("unknown option " + a);
    }
  }
  return o;
}

std::vector<fs::path> json_files(const fs::path& dir) {
  std::vector<fs::path> out;
  std::error_code ec;
  for (const auto& e : fs::recursive_directory_iterator(dir, ec))
    if (e.is_regular_file() && e.path().extension() == ".json") out.push_back(e.path());
  std::sort(out.begin(), out.end());
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  Options opt;
  try {
    opt = parse(argc, argv);
  } catch (const std::exception& e) {
    std::cerr << "fuzz_driver: " << e.what() << "\n";
    return 2;
  }
  const fs::path work = rosguard::fuzz::fuzz_setup();
  std::map<std::string, std::string> findings;  // kind -> first input text
  std::size_t failures = 0;
  const auto report = [&](const std::string& label, const std::string& input, const Verdict& v) {
    ++failures;
    const std::string kind = kind_of(v.what);
    std::cout << "FINDING " << label << ": " << v.what.substr(0, 300) << "\n";
    if (findings.emplace(kind, input).second && !opt.save.empty()) {
      fs::create_directories(opt.save);
      std::ofstream(opt.save / ("finding-" + std::to_string(findings.size()) + ".json"),
                    std::ios::binary)
          << input;
    }
  };

  std::size_t replayed = 0;
  if (!opt.corpus.empty())
    for (const auto& f : json_files(opt.corpus)) {
      const std::string input = read_all(f);
      if (const Verdict v = run_child(input, opt.timeout_ms); v.failed)
        report("corpus " + f.filename().string(), input, v);
      ++replayed;
    }

  std::vector<std::string> seeds;
  for (const auto& dir : opt.seed_dirs)
    for (const auto& f : json_files(dir))
      seeds.push_back(read_all(f));
  std::size_t tried = 0;
  if (!seeds.empty() && opt.seconds > 0) {
    Mutator mutator(seeds, opt.seed);
    const auto end = std::chrono::steady_clock::now() +
                     std::chrono::milliseconds(static_cast<long>(opt.seconds * 1000));
    while (std::chrono::steady_clock::now() < end) {
      const std::string input = mutator.make(opt.seed, tried);
      if (const Verdict v = run_child(input, opt.timeout_ms); v.failed)
        report("input " + std::to_string(tried) + " (seed " + std::to_string(opt.seed) + ")", input,
               v);
      ++tried;
    }
  }
  std::error_code ec;
  fs::remove_all(work, ec);
  std::cout << "fuzz: replayed " << replayed << " corpus file(s); tried " << tried
            << " mutated input(s) from " << seeds.size() << " seed(s) (seed " << opt.seed << "); "
            << failures << " finding(s) of " << findings.size() << " distinct kind(s)\n";
  for (const auto& [kind, _] : findings)
    std::cout << "  kind: " << kind << "\n";
  return failures == 0 ? 0 : 1;
}
