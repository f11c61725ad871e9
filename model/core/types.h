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

// How the regulator learns a regulated core's usage:
// - Self: the nRT node's PMC callback reads its counters and publishes them (ROSGuard);
// - External: the controller reads the core's counters itself every sampling period (ROSGuard);
// - Overflow: the core's PMU raises an interrupt when the budget is crossed and the handler runs
//   on that core (MemGuard): no periodic sampling, no message to or from a controller;
// - Mmio: the controller core polls the cores' counters through memory-mapped debug registers
//   every sampling period (microseconds) and halts a core through the same interface (MemPol):
//   no message, no callback on the regulated core.
enum class Sampling : std::uint8_t { Self, External, Overflow, Mmio };

// What one budget covers: a core, a node, or all nRT entities together.
enum class Scope : std::uint8_t { Core, Node, Group };

// MemGuard's spare-bandwidth sharing once every regulated core has exhausted its budget
// (Yun et al., TC 2016; the memguard module's g_use_exclusive 1 and 2).
enum class Sharing : std::uint8_t {
  Off,   // throttled until the next period
  Last,  // the last core to exhaust its budget keeps running until the period ends
  All,   // every core runs unregulated until the period ends
};

std::string_view to_string(Command c);
std::string_view to_string(Sampling s);
std::string_view to_string(Scope s);
std::string_view to_string(Sharing s);

}  // namespace rosguard
