#!/usr/bin/env python3
"""Fails if C++ under a folder (model/) uses SystemC, Linux/POSIX headers, threads or clocks.

model/ is the pure regulator core: the host passes time and counter values in (docs/design.md,
section 2). This scans every C++ file below ROOT, after removing comments and string literals,
for includes of such headers and for uses of clocks, sleeps and thread primitives that could
reach the code through another header. Prints file:line: what, and exits 1 on any finding.

Usage: model_purity.py ROOT
"""
import pathlib
import re
import sys

CPP_SUFFIXES = {".h", ".hh", ".hpp", ".hxx", ".ipp", ".inl", ".c", ".cc", ".cpp", ".cxx"}

# Header (as written between <> or "") -> why it is not allowed.
FORBIDDEN_HEADERS = [
    (r"systemc(\.h)?|tlm(\.h)?|sysc/.*|tlm_.*", "SystemC"),
    (r"linux/.*|asm/.*|sys/.*|unistd\.h|fcntl\.h|poll\.h|sched\.h|signal\.h|csignal|dirent\.h"
     r"|dlfcn\.h|termios\.h|spawn\.h|semaphore\.h|syscall\.h",
     "a Linux/POSIX header"),
    (r"pthread\.h|thread|mutex|shared_mutex|condition_variable|atomic|future|semaphore|latch"
     r"|barrier|stop_token|execution|threads\.h|stdatomic\.h", "threads"),
    (r"chrono|ctime|time\.h", "clocks"),
]
INCLUDE = re.compile(r'^\s*#\s*include\s*[<"]([^>"]+)[>"]')

# Uses that need no include of their own here (they can arrive through another header).
FORBIDDEN_CALLS = [
    (r"\b(clock_gettime|clock_getres|gettimeofday|timespec_get|nanosleep|usleep|sleep|alarm"
     r"|timer_create|timerfd_create)\s*\(", "calls a clock or sleep function"),
    # std::time(...), ::clock(), time(nullptr): not a member or a function of the project's own
    # that happens to be called time() or clock().
    (r"(\bstd\s*::|(?<![\w>.:])::)\s*(time|clock)\s*\(|(?<![\w>.:])time\s*\(\s*(nullptr|NULL|0|&)",
     "reads the clock"),
    (r"\b(steady_clock|system_clock|high_resolution_clock|utc_clock|tai_clock|gps_clock"
     r"|file_clock)\b", "reads the clock"),
    (r"\bstd\s*::\s*(this_thread|thread|jthread|async|mutex|recursive_mutex|timed_mutex"
     r"|shared_mutex|condition_variable|condition_variable_any|atomic|atomic_ref|atomic_flag"
     r"|counting_semaphore|binary_semaphore|latch|barrier|stop_token|stop_source)\b",
     "uses a thread primitive"),
    (r"\bsc_(core|module|time|start|stop|event|signal|in|out|main)\b|\bSC_(MODULE|METHOD|THREAD|CTOR)\b",
     "uses SystemC"),
]


def strip_comments_and_strings(text):
    """Blanks comments and string / char literals, keeping newlines (line numbers stay right).

    Raw strings R"d(...)d" are blanked too; includes are matched on the unstripped text."""
    def blank(m):
        return re.sub(r"[^\n]", " ", m.group(0))
    token = re.compile(r'//[^\n]*|/\*.*?\*/|R"([^(\s]{0,16})\(.*?\)\1"|"(\\.|[^"\\\n])*"'
                       r"|'(\\.|[^'\\\n])*'", re.S)
    return token.sub(blank, text)


def findings(path):
    text = path.read_text(encoding="utf-8", errors="replace")
    for number, line in enumerate(text.splitlines(), 1):
        m = INCLUDE.match(line)
        if m:
            for pattern, why in FORBIDDEN_HEADERS:
                if re.fullmatch(pattern, m.group(1)):
                    yield number, f"includes <{m.group(1)}> ({why})"
    for number, line in enumerate(strip_comments_and_strings(text).splitlines(), 1):
        if INCLUDE.match(line):
            continue
        for pattern, why in FORBIDDEN_CALLS:
            m = re.search(pattern, line)
            if m:
                yield number, f"{why}: {m.group(0).strip()}"


def main(argv):
    if len(argv) != 2:
        print(__doc__.strip().splitlines()[-1], file=sys.stderr)
        return 2
    root = pathlib.Path(argv[1])
    files = sorted(p for p in root.rglob("*") if p.suffix in CPP_SUFFIXES and p.is_file())
    if not files:
        print(f"no C++ files under {root}", file=sys.stderr)
        return 2
    bad = 0
    for path in files:
        for number, what in findings(path):
            print(f"{path}:{number}: {what}")
            bad += 1
    if bad:
        print(f"{bad} finding(s): {root} must stay free of SystemC, Linux/POSIX headers, threads "
              "and clocks (the host passes time and counters in)")
        return 1
    print(f"{len(files)} files under {root}: no SystemC, Linux/POSIX headers, threads or clocks")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
