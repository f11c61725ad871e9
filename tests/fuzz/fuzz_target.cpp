#include "fuzz_target.h"

#include <sys/stat.h>
#include <unistd.h>

#include <fstream>
#include <memory>

#include "backends.h"
#include "commands/check.h"
#include "core/error.h"

namespace rosguard::fuzz {
namespace fs = std::filesystem;

namespace {

struct State {
  fs::path dir;
  std::unique_ptr<Loader> loader;
  PolicyRegistry policies;  // registered once, as main() does; the backends keep a reference
  BackendRegistry backends;
};

State& state() {
  static State s;
  return s;
}

}  // namespace

fs::path fuzz_setup() {
  State& s = state();
  if (s.loader) return s.dir;
  s.dir = fs::temp_directory_path() / ("rosguard-fuzz-" + std::to_string(::getpid()));
  fs::create_directories(s.dir / "dir.json");
  ::mkfifo((s.dir / "fifo.json").c_str(), 0600);
  const Home home = Home::locate();
  std::error_code ec;
  fs::copy(home.root / "tests" / "invalid" / "fixtures", s.dir / "fixtures",
           fs::copy_options::recursive | fs::copy_options::overwrite_existing, ec);
  s.loader = std::make_unique<Loader>(home);
  register_builtin(s.policies);
  register_backends(s.backends, s.policies);
  s.loader->load((home.scenarios() / "quickstart.json").string());  // caches the shipped files
  return s.dir;
}

std::string check_scenario_bytes(const std::uint8_t* data, std::size_t size) {
  State& s = state();
  const fs::path file = s.dir / "scenario.json";
  {
    std::ofstream out(file, std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  }
  try {
    check_scenario(*s.loader, s.backends, file.string(), std::nullopt, false, false);
  } catch (const InputError& e) {
    if (e.file().empty()) return std::string("input error without a file: ") + e.what();
  } catch (const RunError& e) {
    return std::string("runtime error (exit 1) on an input: ") + e.what();
  } catch (const std::exception& e) {
    return std::string("internal: ") + e.what();
  }
  return "";
}

}  // namespace rosguard::fuzz
