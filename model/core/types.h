// Domain types shared by every layer. Pure C++: no clocks, no OS.
#pragma once

#include <cstdint>
#include <string_view>

namespace rosguard {

// Time is integer nanoseconds everywhere in the core; the host supplies it.
using TimeNs = std::int64_t;
inline constexpr TimeNs kNsPerUs = 1'000;
inline constexpr TimeNs kNsPerMs = 1'000'000;
inline constexpr TimeNs kNsPerS = 1'000'000'000;

// Eq. 1 of the paper divides by 1024 * 1024: "MB/s" in this project means MiB/s.
inline constexpr double kBytesPerMb = 1024.0 * 1024.0;

// Commands the controller sends to a regulated entity (nRT node) over the control topic.
enum class Command : std::uint8_t { On, Off, Thr, Replenish };

// Who takes the PMC samples: the nRT node itself (PMC callback) or the controller.
enum class Sampling : std::uint8_t { Self, External };

// What one budget covers: a core, a node, or all nRT entities together.
enum class Scope : std::uint8_t { Core, Node, Group };

std::string_view to_string(Command c);
std::string_view to_string(Sampling s);
std::string_view to_string(Scope s);

}  // namespace rosguard
