"""The model/ purity check finds what it must and nothing else (planted files in a temp tree)."""
import pathlib
import subprocess
import sys

import pytest

SCRIPT = pathlib.Path(__file__).with_name("model_purity.py")

CLEAN = """// Comments may name <thread>, std::chrono::steady_clock and clock_gettime().
#include <string>
#include <vector>
#include "core/types.h"
const char* kText = "std::this_thread::sleep_for(1s); #include <unistd.h>";
struct Timeline { long time() const { return 0; } long clock() const { return 1; } };
long when(const Timeline& t) { return t.time() + t.clock(); }
inline constexpr long kNsPerMs = 1'000'000;
"""


def check(tmp_path, files):
    for name, text in files.items():
        (tmp_path / name).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / name).write_text(text)
    return subprocess.run([sys.executable, SCRIPT, tmp_path], capture_output=True, text=True)


def test_clean_tree_passes(tmp_path):
    done = check(tmp_path, {"core/clean.h": CLEAN})
    assert done.returncode == 0, done.stdout
    assert "1 files" in done.stdout


@pytest.mark.parametrize("line, why", [
    ("#include <systemc>", "SystemC"),
    ('#include "systemc.h"', "SystemC"),
    ("#include <unistd.h>", "Linux/POSIX"),
    ("#include <sys/mman.h>", "Linux/POSIX"),
    ("#include <linux/perf_event.h>", "Linux/POSIX"),
    ("#include <pthread.h>", "threads"),
    ("#include <thread>", "threads"),
    ("  #  include <mutex>", "threads"),
    ("#include <atomic>", "threads"),
    ("#include <condition_variable>", "threads"),
    ("#include <chrono>", "clocks"),
    ("#include <ctime>", "clocks"),
    ("timespec ts; clock_gettime(CLOCK_MONOTONIC, &ts);", "clock"),
    ("auto t0 = std::chrono::steady_clock::now();", "clock"),
    ("auto t0 = std::time(nullptr);", "clock"),
    ("auto t0 = time(nullptr);", "clock"),
    ("std::this_thread::yield();", "thread primitive"),
    ("std::atomic<int> counter{0};", "thread primitive"),
    ("SC_MODULE(Node) {};", "SystemC"),
])
def test_planted_use_fails(tmp_path, line, why):
    done = check(tmp_path, {"core/clean.h": CLEAN, "policy/planted.cpp": f"// planted\n{line}\n"})
    assert done.returncode == 1, done.stdout
    findings = [l for l in done.stdout.splitlines() if ": " in l and "finding(s)" not in l]
    assert len(findings) == 1, done.stdout
    assert findings[0].startswith(f"{tmp_path / 'policy/planted.cpp'}:2: ")
    assert why in findings[0]


def test_empty_tree_is_an_error(tmp_path):
    assert check(tmp_path, {}).returncode == 2
