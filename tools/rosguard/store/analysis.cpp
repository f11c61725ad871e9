#include "store/analysis.h"

#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <iostream>

#include "core/error.h"

namespace rosguard {
namespace fs = std::filesystem;

int run_analysis(const Home& home, const std::vector<std::string>& args) {
  const fs::path package = home.root / "analysis" / "__main__.py";
  std::error_code ec;
  if (!fs::exists(package, ec))
    throw RunError("the analysis package is not in this tree (" + package.string() +
                   " is missing)");
  std::string python = "/usr/bin/python3";
  if (const char* env = std::getenv("ROSGUARD_PYTHON"); env && *env) python = env;

  std::vector<std::string> argv_s = {python, "-m", "analysis"};
  argv_s.insert(argv_s.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (auto& a : argv_s)
    argv.push_back(a.data());
  argv.push_back(nullptr);

  std::cout.flush();
  const pid_t pid = ::fork();
  if (pid < 0) throw RunError(std::string("fork: ") + std::strerror(errno));
  if (pid == 0) {
    const char* old = std::getenv("PYTHONPATH");
    const std::string path = home.root.string() + (old && *old ? ":" + std::string(old) : "");
    ::setenv("PYTHONPATH", path.c_str(), 1);
    ::setenv("MPLBACKEND", "Agg", 0);
    ::setenv("PYTHONDONTWRITEBYTECODE", "1", 0);  // no __pycache__ inside the source tree
    ::execv(argv[0], argv.data());
    std::cerr << "error: cannot start " << python << ": " << std::strerror(errno)
              << " (set ROSGUARD_PYTHON to a Python 3 with numpy, pandas, matplotlib and scipy)\n";
    ::_exit(1);
  }
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  if (WIFEXITED(status)) return WEXITSTATUS(status);
  return 1;
}

}  // namespace rosguard
