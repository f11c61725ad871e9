// A sequential read for the `rosguard profile` tests: PASSES passes over KB kilobytes, one
// 8-byte load per element (volatile: the compiler neither vectorises nor drops them), so 8 loads
// per 64-byte line. Exits with EXIT_STATUS (default 0).
//   profile_stream_read KB PASSES [EXIT_STATUS]
#include <cstdint>
#include <cstdio>
#include <cstdlib>

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: %s KB PASSES [EXIT_STATUS]\n", argv[0]);
    return 2;
  }
  const std::size_t kb = std::strtoul(argv[1], nullptr, 10);
  const long passes = std::strtol(argv[2], nullptr, 10);
  const int status = argc > 3 ? std::atoi(argv[3]) : 0;
  const std::size_t n = kb * 1024 / sizeof(std::uint64_t);
  // calloc: zero pages, never written here, so the loop below has loads only.
  auto* data = static_cast<std::uint64_t*>(std::calloc(n, sizeof(std::uint64_t)));
  if (!data) return 3;
  const volatile std::uint64_t* p = data;
  std::uint64_t sum = 0;
  for (long pass = 0; pass < passes; ++pass)
    for (std::size_t i = 0; i < n; ++i)
      sum += p[i];
  std::free(data);
  return sum == 0 ? status : 4;
}
