#!/usr/bin/env python3
"""How much the paper's findings depend on each guessed number of a platform file.

A platform number with no source of its own says so in its "source": "NAME: guess, plausible
range LOW-HIGH" (NAME a key beside that source) or, in a cost distribution's source, "guess,
plausible range LOW-HIGH" (the distribution's mean or median; its min, max and sd scale with it).
For each such guess this tool writes two variants of the platform file, with the number at LOW
and at HIGH; on each it re-fits the workload profiles to the paper's Table 1
(rosguard-sim-calibrate --fit, as for the shipped profiles), runs the paper's scenarios
(scenarios/paper/) in sim with one repetition each, re-runs the checks of tools/paper_table.py,
and writes a table: per parameter the range and which findings change their verdict at each end
against the unchanged platform. A "guess" without a
range is listed as such and not swept.

    python3 tools/sensitivity.py [--platform scenarios/platforms/orin-agx.json]
        [--out results/sensitivity] [--rosguard build/rosguard]
        [--calibrate build/sim/rosguard-sim-calibrate] [--jobs 2] [--doc docs/sensitivity.md]

With --doc, that page's block between <!-- sensitivity:begin --> and <!-- sensitivity:end --> is
replaced (its markers checked before anything runs); the table also goes to OUT/sensitivity.md.
"""

from __future__ import annotations

import argparse
import copy
import importlib.util
import json
import re
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from analysis.markdown import splice  # noqa: E402
from analysis.results import InvalidInput  # noqa: E402
GUESS = re.compile(r"(?:\b(?P<key>[a-z][a-z0-9_]*): )?guess, plausible range "
                   r"(?P<lo>\d+(?:\.\d+)?)-(?P<hi>\d+(?:\.\d+)?)")
# The central value of a cost distribution and the fields that scale with it.
CENTRAL = ("mean_us", "median_us", "value_us")
SCALED = ("mean_us", "median_us", "value_us", "min_us", "max_us", "sd_us")

_spec = importlib.util.spec_from_file_location("paper_table", ROOT / "tools" / "paper_table.py")
paper_table = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(paper_table)


@dataclass(frozen=True)
class Guess:
    """One guessed number: where it is, its value and its plausible range."""

    path: tuple        # keys from the file's root to the object holding the number
    key: str           # the number's key in that object
    base: float
    low: float
    high: float

    @property
    def name(self) -> str:
        return ".".join(self.path + (self.key,))


def find_guesses(platform: dict):
    """(guesses with a range, names of "guess" mentions without one) in a platform document."""
    guesses, unranged = [], []

    def walk(obj, path):
        if not isinstance(obj, dict):
            return
        source = obj.get("source")
        if isinstance(source, str):
            matched = 0
            for m in GUESS.finditer(source):
                key = m.group("key")
                if key is None or key not in obj:
                    key = next((k for k in CENTRAL if k in obj), None)
                    if m.group("key") is not None and key is None:
                        raise ValueError(f"{'.'.join(path)}: source names '{m.group('key')}', "
                                         f"which is not beside it")
                if key is None or not isinstance(obj.get(key), (int, float)):
                    raise ValueError(f"{'.'.join(path)}: a guess with no number to apply to")
                lo, hi = float(m.group("lo")), float(m.group("hi"))
                if not lo <= obj[key] <= hi:
                    raise ValueError(f"{'.'.join(path + (key,))} = {obj[key]} lies outside its "
                                     f"plausible range {lo:g}-{hi:g}")
                guesses.append(Guess(path, key, float(obj[key]), lo, hi))
                matched += 1
            mentions = len(re.findall(r"\bguess", source))
            if mentions > matched:
                unranged.append(".".join(path) or "(root)")
        for k, v in obj.items():
            walk(v, path + (k,))
    walk(platform, ())
    return guesses, unranged


def variant(platform: dict, guess: Guess, value: float) -> dict:
    """A copy of the platform with the guessed number set to value (a distribution scaled)."""
    doc = copy.deepcopy(platform)
    obj = doc
    for k in guess.path:
        obj = obj[k]
    if guess.key in CENTRAL:
        factor = value / guess.base
        for k in SCALED:
            if k in obj:
                obj[k] = obj[k] * factor
    else:
        obj[guess.key] = type(obj[guess.key])(value) if isinstance(obj[guess.key], int) and \
            float(value).is_integer() else value
    doc["name"] = f"{platform.get('name', 'platform')}-{guess.name}-{value:g}"
    return doc


def refit_workloads(platform_file: Path, folder: Path, calibrate: Path) -> dict:
    """Copies of the workloads with a Table 1 reference, re-fitted to it on this platform.

    The profiles' base IPCs (and miss rates, unless a profile's source says they were kept as
    measured: --ipc-only) are fitted to the paper's Table 1 on the platform
    (rosguard-sim-calibrate --fit), so a variant of the platform gets its own fit, as a new
    platform file would. Returns {workload name: fitted file}.
    """
    folder.mkdir(parents=True, exist_ok=True)
    fitted, modes = {}, {(): [], ("--ipc-only",): []}
    for w in sorted((ROOT / "scenarios" / "workloads").glob("*.json")):
        doc = json.loads(w.read_text())
        if "reference" in doc and "sim" in doc:
            target = folder / w.name
            target.write_text(w.read_text())
            fitted[doc.get("name", w.stem)] = target.resolve()
            # A profile whose rates were kept as measured (fitted with --ipc-only) keeps them.
            ipc_only = "--ipc-only" in doc["sim"].get("source", "")
            modes[("--ipc-only",) if ipc_only else ()].append(str(target))
    for flags, files in modes.items():
        if files:
            subprocess.run([str(calibrate), "--fit", *flags, "--write", str(platform_file)]
                           + files, check=True, stdout=subprocess.DEVNULL)
    return fitted


def use_workloads(scenario: dict, fitted: dict) -> dict:
    """The scenario with every workload name of ``fitted`` (in nodes and sweeps) as its file."""
    def swap(v):
        return str(fitted[v]) if isinstance(v, str) and v in fitted else v
    for role in ("rt", "nrt"):
        for node in scenario.get("nodes", {}).get(role, []):
            node["workload"] = swap(node.get("workload"))
    for key, values in scenario.get("sweep", {}).items():
        if key.endswith(".workload"):
            scenario["sweep"][key] = [swap(v) for v in values]
    return scenario


def run_variant(doc: dict, folder: Path, rosguard: Path, jobs: int, scenarios,
                calibrate: Path) -> dict:
    """Runs the paper scenarios on one platform variant; returns {finding: holds}."""
    folder.mkdir(parents=True, exist_ok=True)
    platform_file = folder / "platform.json"
    platform_file.write_text(json.dumps(doc, indent=2) + "\n")
    fitted = refit_workloads(platform_file, folder / "workloads", calibrate)
    for scenario in scenarios:
        s = use_workloads(json.loads(scenario.read_text()), fitted)
        s.pop("$schema", None)
        s["platform"] = str(platform_file.resolve())
        s["repetitions"] = 1
        file = folder / "scenarios" / scenario.name
        file.parent.mkdir(exist_ok=True)
        file.write_text(json.dumps(s, indent=2) + "\n")
        subprocess.run([str(rosguard), "run", str(file), "--out", str(folder / scenario.stem),
                        "--overwrite", "--quiet", "--jobs", str(jobs)], check=True)
    return {n: ok for n, _, _, ok in paper_table.check_rows(folder)}


def describe(verdicts: dict, base: dict) -> str:
    """The findings whose verdict differs from the base run's, e.g. '7a now holds; 8b fails'."""
    changed = [f"{n} {'holds' if ok else 'fails'}" for n, ok in verdicts.items()
               if base.get(n) != ok]
    return "; ".join(changed) if changed else "same"


def render(platform_file: Path, guesses, unranged, base, ends, seconds) -> str:
    fails = [n for n, ok in base.items() if not ok]
    shown = platform_file.relative_to(ROOT) if platform_file.is_relative_to(ROOT) else platform_file
    lines = [f"Platform `{shown}`, "
             f"every guessed number at each end of its plausible range (the rest unchanged), the "
             f"workload profiles re-fitted to Table 1 on each variant, the paper's scenarios in "
             f"sim with one repetition each. With the file as it is, "
             f"{len(base) - len(fails)} of {len(base)} statements hold"
             + (f" (not: {', '.join(fails)})" if fails else "") +
             "; a cell names the statements whose verdict differs from that, \"same\" if none.",
             "",
             "| parameter | value | plausible range | at the low end | at the high end |",
             "|---|---|---|---|---|"]
    for g in guesses:
        lo, hi = ends[g.name]
        lines.append(f"| `{g.name}` | {g.base:g} | {g.low:g}-{g.high:g} | {describe(lo, base)} "
                     f"| {describe(hi, base)} |")
    if unranged:
        lines += ["", "Marked as guesses but with no range to sweep: "
                  + ", ".join(f"`{u}`" for u in unranged) + "."]
    lines += ["", f"Generated by `make sensitivity` (tools/sensitivity.py) in {seconds / 60:.0f} "
              f"min ({1 + 2 * len(guesses)} runs of the paper's scenarios)."]
    return "\n".join(lines) + "\n"


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--platform", type=Path,
                    default=ROOT / "scenarios" / "platforms" / "orin-agx.json")
    ap.add_argument("--out", type=Path, default=ROOT / "results" / "sensitivity")
    ap.add_argument("--rosguard", type=Path, default=ROOT / "build" / "rosguard")
    ap.add_argument("--calibrate", type=Path,
                    default=ROOT / "build" / "sim" / "rosguard-sim-calibrate")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--doc", type=Path,
                    help="replace this page's block between the sensitivity markers")
    ap.add_argument("--list", action="store_true", help="only list the guesses and exit")
    args = ap.parse_args()
    platform = json.loads(args.platform.read_text())
    try:
        guesses, unranged = find_guesses(platform)
    except ValueError as e:
        sys.exit(f"{args.platform}: {e}")
    if args.list:
        for g in guesses:
            print(f"{g.name} = {g.base:g}, plausible range {g.low:g}-{g.high:g}")
        for u in unranged:
            print(f"{u}: a guess without a range")
        return
    doc_text = args.doc.read_text() if args.doc else None
    if doc_text is not None:  # hours of runs would end in a page without its markers
        try:
            splice(doc_text, "sensitivity", "", str(args.doc))
        except InvalidInput as e:
            sys.exit(str(e))
    scenarios = sorted((ROOT / "scenarios" / "paper").glob("*.json"))
    start = time.monotonic()
    print(f"base ({len(guesses)} guesses to sweep)", flush=True)
    base = run_variant(platform, args.out / "base", args.rosguard, args.jobs, scenarios,
                       args.calibrate)
    ends = {}
    for g in guesses:
        pair = []
        for end, value in (("low", g.low), ("high", g.high)):
            t = time.monotonic()
            verdicts = run_variant(variant(platform, g, value), args.out / f"{g.name}-{end}",
                                   args.rosguard, args.jobs, scenarios, args.calibrate)
            print(f"{g.name} = {value:g}: {describe(verdicts, base)} "
                  f"({time.monotonic() - t:.0f} s)", flush=True)
            pair.append(verdicts)
        ends[g.name] = tuple(pair)
    table = render(args.platform.resolve(), guesses, unranged, base, ends,
                   time.monotonic() - start)
    (args.out / "sensitivity.md").write_text("# Sensitivity of the paper's findings to the "
                                             "platform's guesses\n\n" + table)
    if doc_text is not None:
        args.doc.write_text(splice(doc_text, "sensitivity", table, str(args.doc)))
    sys.stdout.write(table)


if __name__ == "__main__":
    main()
