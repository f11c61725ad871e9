// Stable 64-bit FNV-1a: ids and seeds that must not change between runs, machines or builds.
#pragma once

#include <cstdint>
#include <string_view>

namespace rosguard {

constexpr std::uint64_t fnv1a(std::string_view text,
                              std::uint64_t h = 0xcbf29ce484222325ULL) noexcept {
  for (char c : text) {
    h ^= static_cast<unsigned char>(c);
    h *= 0x100000001b3ULL;
  }
  return h;
}

}  // namespace rosguard
