// Typed errors. Libraries throw these with their context; only main() maps them to an exit code:
// InputError -> 2 (the user can fix the input), everything else -> 1.
#pragma once

#include <exception>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace rosguard {

// Invalid input: a scenario, platform or workload file, or a command-line argument.
class InputError : public std::runtime_error {
 public:
  // `file` may be empty (command-line input); `json_path` is a JSON pointer ("/regulation/x")
  // or empty when the whole document is at fault.
  InputError(std::string file, std::string json_path, std::string message)
      : std::runtime_error(format(file, json_path, message)),
        file_(std::move(file)),
        json_path_(std::move(json_path)),
        message_(std::move(message)) {}

  // Several problems in one document (a schema validation): the first is this error's path and
  // message; what() adds "(and N more problems)"; problems() lists every one in full.
  InputError(std::string file, std::vector<std::pair<std::string, std::string>> problems)
      : InputError(file, problems.at(0).first,
                   problems.at(0).second + more_suffix(problems.size() - 1)) {
    message_ = problems.front().second;
    for (const auto& [path, message] : problems)
      problems_.push_back(format(file_, path, message));
  }

  const std::string& file() const { return file_; }
  const std::string& json_path() const { return json_path_; }
  const std::string& message() const { return message_; }
  // " (and N more problems)", or "" for none.
  static std::string more_suffix(std::size_t more) {
    if (more == 0) return "";
    return " (and " + std::to_string(more) + " more problem" + (more > 1 ? "s" : "") + ")";
  }

  // Every problem, each as "file: path: message"; one entry (what()) for a single problem.
  std::vector<std::string> problems() const {
    return problems_.empty() ? std::vector<std::string>{what()} : problems_;
  }

 private:
  static std::string format(const std::string& file, const std::string& path,
                            const std::string& message) {
    std::string out;
    if (!file.empty()) out += file + ": ";
    if (!path.empty()) out += path + ": ";
    return out + message;
  }

  std::string file_, json_path_, message_;
  std::vector<std::string> problems_;
};

// The message of a caught exception: what() of a std::exception, "unknown error" otherwise.
inline std::string exception_text(const std::exception_ptr& e) {
  try {
    std::rethrow_exception(e);
  } catch (const std::exception& x) {
    return x.what();
  } catch (...) {
    return "unknown error";
  }
}

// A failure while running (a backend, a counter, a worker). Exit code 1.
class RunError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// A caller broke an interface's contract (time going backwards, an entity or RT node that does
// not exist, a policy without a positive period): a bug in the host, not bad input. Exit code 1.
class ContractError : public std::logic_error {
 public:
  using std::logic_error::logic_error;
};

// A task stopped early because the user asked (SIGINT / SIGTERM); its partial result is dropped.
class Interrupted : public std::runtime_error {
 public:
  Interrupted() : std::runtime_error("interrupted") {}
};

}  // namespace rosguard
