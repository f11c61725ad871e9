// The fuzz target: one input is the bytes of a scenario file, checked exactly as
// `rosguard check` does (load, validate every point with its backend, summarise).
//
// Contract: call fuzz_setup() once per process, then check_scenario_bytes() per input, from one
// thread. An input passes when it is valid or is refused with an InputError that names a file;
// anything else (another exception type, an InputError without a file) is a finding. Crashes and
// hangs are findings the caller detects (the driver forks per input; libFuzzer watches itself).
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string>

namespace rosguard::fuzz {

// Creates the work folder (a scenario file, a FIFO `fifo.json`, a folder `dir.json`, and a
// copy of tests/invalid/fixtures as `fixtures/`, so inputs can name them) and the loader.
// Returns the work folder.
std::filesystem::path fuzz_setup();

// Empty when the input passes, else what went wrong (one line).
std::string check_scenario_bytes(const std::uint8_t* data, std::size_t size);

}  // namespace rosguard::fuzz
