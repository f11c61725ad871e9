// libFuzzer entry points (built with clang and -fsanitize=fuzzer, ROSGUARD_LIBFUZZER=ON):
//   build/tests/fuzz/fuzz_loader_libfuzzer -max_len=200000 tests/fuzz/corpus scenarios
#include <fcntl.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>

#include "fuzz_target.h"

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  static const std::filesystem::path work = rosguard::fuzz::fuzz_setup();
  std::atexit([] {
    std::error_code ec;
    std::filesystem::remove_all(work, ec);
  });
  const int null = ::open("/dev/null", O_WRONLY);  // check's summary is noise here
  if (null >= 0) ::dup2(null, STDOUT_FILENO);
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string failure = rosguard::fuzz::check_scenario_bytes(data, size);
  if (!failure.empty()) {
    std::fprintf(stderr, "finding: %s\n", failure.c_str());
    std::abort();
  }
  return 0;
}
