"""Command line: ``python3 -m analysis plot|compare|calibration|validate|validate-table ...``.

``rosguard plot|compare`` run the first two, ``rosguard calibrate`` the third;
``tools/validate.sh`` (``make validate``) the others.

Exit codes: 0 success, 2 invalid input (usage, a folder that is not a results folder, two
folders without a common point), 1 runtime failure (e.g. an output folder that cannot be
written, or a Python without numpy, pandas, matplotlib or scipy). Errors are one line on
stderr, without a traceback.
"""

from __future__ import annotations

import argparse
import importlib
import sys

DESCRIPTION = """\
Figures and comparisons of rosguard results folders (what `rosguard run` writes:
manifest.json, points.csv, samples.csv). `rosguard plot` and `rosguard compare` call this.
"""

EPILOG = """\
examples:
  python3 -m analysis plot results/quickstart
      figures (PNG + PDF), summary.csv, nodes.csv and distributions.csv in
      results/quickstart/figures
  python3 -m analysis compare results/exp4-hw results/exp4-sim
      compare.csv, summary.json and compare_scatter.png/pdf in results/exp4-sim/compare
  python3 -m analysis compare results/v/hw/s results/v/sim/s --band results/v/sim-band/X/s ...
      the same, with B's prediction band from its runs on the band platforms

  python3 -m analysis validate results/validation/hw results/validation/sim \
          --out results/validation
      report.md, report.json and validation_scatter.png/pdf in results/validation
  python3 -m analysis validate-table results/validation/report.json
      the README's validation block (markdown) on stdout

exit codes: 0 success, 2 invalid input, 1 runtime failure (also: this Python lacks numpy,
pandas, matplotlib or scipy; `rosguard plot|compare` run /usr/bin/python3, or $ROSGUARD_PYTHON)
"""

# The third-party modules the subcommands import, with the Debian packages that hold them.
MODULES = {"numpy": "python3-numpy", "pandas": "python3-pandas",
           "matplotlib": "python3-matplotlib", "scipy": "python3-scipy"}

PLOT_HELP = """\
Draw every figure the results support: slowdown vs threshold, vs sampling period and vs
regulation period (RT and nRT); RT x nRT grids per threshold and configuration; activation
delay and PMC callback duration (min / median / max per sampling period, self vs external; a
box per series at a single sampling period); sampling overhead vs sampling period; the RT vs
nRT trade-off (one marker per regulation setting, the Pareto front, tune.json's best and
runner-up); the mechanism comparison (bars per policy and sampling mode, per nRT workload and
threshold). Slowdown figures draw the unregulated co-run (rt_/nrt_unregulated_slowdown) and,
with --rt-slowdown-max or a tune.json, the RT target. Figures of nRT results have a panel per
nRT node, titled with its name. Figures the data do not support are skipped with a reason.
Also writes summary.csv (per point: every node's name and mean / min / max / std over
repetitions), nodes.csv (one row per point, repetition and node: its name, core, workload,
slowdown, bandwidth, throttling) and distributions.csv (sample statistics per sampling mode
and period).
"""

COMPARE_HELP = """\
Match the points of two results folders by id (same scenario, e.g. measured on hw vs
simulated) and report per-point slowdown differences (B - A) of every RT and nRT node, and
per node (by name) and over all nodes of a role the mean absolute percentage error, the max
error, the Spearman rank agreement of the configurations; and the points found on one side
only. Writes compare.csv, summary.json and compare_scatter.png/pdf (a panel per node).

--band DIR (repeatable): a run of B's scenario on one of the uncertainty-band platforms of B's
model (`rosguard calibrate` writes them into band/: one prior-dominated parameter one standard
error down or up). B's prediction band per point is min..max over B and the band runs; the
outputs then give it per point (compare.csv <node>_band_low_b / _high_b), how often it covers A
and its median width (summary.json "band", the printed summary), and draw it on B's points.
"""

VALIDATE_HELP = """\
The sim-vs-hw validation report of a suite: HW_ROOT and SIM_ROOT hold one results folder per
scenario, by name. Per scenario and over all points: RT- and nRT-slowdown MAPE, the error on the
excess slowdown (slowdown - 1) where the measured excess is >= 0.05, the hw repetitions' spread,
each against its goal (RT MAPE <= 5 %, nRT MAPE <= 10 %, excess error <= 20 %); and per number
of co-runners k (a scenario's nRT nodes): RT MAPE, nRT MAPE over every co-runner, and the
per-node nRT MAPEs' range. Writes
report.json, report.md and validation_scatter.png/pdf (simulated vs measured slowdown).

--band-root BAND_ROOT: BAND_ROOT/<variant>/<scenario>/ are the sim runs of each scenario on the
band platforms of the sim's model (make validate makes them when the host model has a band/
folder). Each point's prediction band is min..max of the sim mean over the nominal run and the
band runs; the report adds per scenario and overall its coverage of the hw means and its median
width, and the figure draws it on each sim point.

--state-dir DIR (default: OUT/state): DIR/<scenario>.json, the machine's DRAM-interference state
right before and after each scenario's hw run (a DRAM-bound reader's slowdown beside another on
the other CPU, `rosguard platform contention`) and the model's; make validate writes them. The
report's table adds it per scenario, marks the scenarios measured in another state than the
model's and, when some were, adds a row over those measured in the model's state (the goals
stay marked over all).
A scenario without its file (or a missing DIR): "not probed"; a file that is not JSON of that
form is invalid input.
"""

VALIDATE_TABLE_HELP = """\
Print the README's validation block (figure link, host and date, the per-scenario table) from a
report.json; with --readme, replace the block between <!-- validation:begin --> and
<!-- validation:end --> in that file and copy the figure into --figure-dir.
"""


def _slowdown_bound(text: str) -> float:
    """--rt-slowdown-max: a number >= 1 (a slowdown below isolation cannot be asked for)."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{text}' is not a number") from None
    if not value >= 1.0 or value == float("inf"):
        raise argparse.ArgumentTypeError(
            f"{text}: an RT slowdown bound is a finite number >= 1.0 (1.0 = as fast as alone; "
            "e.g. 1.05 for 5 %)")
    return value


def build_parser() -> argparse.ArgumentParser:
    """The argparse parser of the two subcommands."""
    parser = argparse.ArgumentParser(
        prog="python3 -m analysis", description=DESCRIPTION, epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = parser.add_subparsers(dest="command", metavar="{plot,compare,calibration,validate,validate-table}")

    plot = sub.add_parser("plot", help="draw every figure a results folder supports",
                          description=PLOT_HELP)
    plot.add_argument("results", metavar="RESULTS_DIR", help="results folder of a run")
    plot.add_argument("--out", metavar="DIR",
                      help="where figures and tables go (default: RESULTS_DIR/figures)")
    plot.add_argument("--rt-slowdown-max", metavar="X", type=_slowdown_bound,
                      help="an RT slowdown bound (e.g. 1.05): drawn as a target on every RT "
                           "slowdown figure and the trade-off figure (default: "
                           "RESULTS_DIR/tune.json's rt_slowdown_max, if any)")

    compare = sub.add_parser("compare", help="compare two results folders point by point",
                             description=COMPARE_HELP)
    compare.add_argument("results_a", metavar="RESULTS_A",
                         help="reference results folder (e.g. measured on hw)")
    compare.add_argument("results_b", metavar="RESULTS_B",
                         help="results folder compared with it (e.g. simulated)")
    compare.add_argument("--out", metavar="DIR",
                         help="where the comparison goes (default: RESULTS_B/compare)")
    compare.add_argument("--band", metavar="DIR", action="append", default=[],
                         help="results folder of B's scenario on a band platform of B's model "
                              "(repeatable): B's prediction band is min..max over B and these")
    calibration = sub.add_parser(
        "calibration", help="draw a calibration's measured vs fitted figures",
        description="Figures of a `rosguard calibrate` folder (calibration.json, platform.json):"
                    " isolation curves, co-run slowdowns and cost distributions, measured vs"
                    " fitted, into DIR/figures.")
    calibration.add_argument("folder", metavar="DIR", help="output folder of rosguard calibrate")

    validate = sub.add_parser("validate", help="sim-vs-hw validation report of a suite",
                              description=VALIDATE_HELP)
    validate.add_argument("hw_root", metavar="HW_ROOT", help="one hw results folder per scenario")
    validate.add_argument("sim_root", metavar="SIM_ROOT",
                          help="one sim results folder per scenario (same names)")
    validate.add_argument("--out", metavar="DIR", required=True,
                          help="where report.json, report.md and the figure go")
    validate.add_argument("--scenarios", metavar="NAMES",
                          help="comma-separated scenario names (default: every folder of "
                               "HW_ROOT)")
    validate.add_argument("--failed", metavar="NAME=REASON", action="append", default=[],
                          help="a scenario that could not be run, and why (listed in the "
                               "report; repeatable)")
    validate.add_argument("--skipped", metavar="NAME=REASON", action="append", default=[],
                          help="a scenario not run on purpose, and why (e.g. it needs more "
                               "CPUs than the host has; listed in the report; repeatable)")
    validate.add_argument("--note", metavar="TEXT", action="append", default=[],
                          help="a line on the conditions (e.g. the load), printed with the "
                               "host (repeatable)")
    validate.add_argument("--band-root", metavar="BAND_ROOT",
                          help="the sim runs on the model's band platforms, "
                               "BAND_ROOT/<variant>/<scenario>/ (default: no band)")
    validate.add_argument("--cpu", metavar="TEXT",
                          help="the machine's CPU as lscpu names it (its 'Model name'), shown "
                               "with the date in the report and the README block (default: "
                               "the hw manifest's cpu_model, from /proc/cpuinfo)")
    validate.add_argument("--state-dir", metavar="DIR",
                          help="the machine state of each scenario's hw run, DIR/<scenario>.json "
                               "(contention probes before and after it; default: OUT/state; "
                               "none there: not probed)")

    table = sub.add_parser("validate-table", help="the README's validation block",
                           description=VALIDATE_TABLE_HELP)
    table.add_argument("report", metavar="REPORT_JSON", help="report.json of `validate`")
    table.add_argument("--readme", metavar="FILE", help="replace the block in this file")
    table.add_argument("--figure-dir", metavar="DIR", default="docs/figures",
                       help="where --readme copies the figure (default: docs/figures)")
    return parser


def missing_modules() -> list[str]:
    """The names of MODULES that this interpreter cannot import."""
    missing = []
    for name in MODULES:
        try:
            importlib.import_module(name)
        except ImportError:
            missing.append(name)
    return missing


def main(argv=None) -> int:
    """Runs one subcommand; returns the exit code."""
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.command is None:
        parser.print_help(sys.stderr)
        return 2
    # One line instead of a traceback when this interpreter lacks a module (e.g. a python3 of a
    # virtual environment as ROSGUARD_PYTHON).
    missing = missing_modules()
    if missing:
        print(f"error: {sys.executable} cannot import {', '.join(missing)} (Debian: apt-get "
              f"install {' '.join(MODULES[m] for m in missing)}); rosguard runs the analysis "
              "with /usr/bin/python3, or with ROSGUARD_PYTHON when set: point it at a Python "
              f"that has {', '.join(MODULES)}", file=sys.stderr)
        return 1
    # Imported here so that --help, usage errors and the check above need none of them.
    from analysis.results import InvalidInput
    try:
        if args.command == "plot":
            from analysis import plot
            return plot.run(args.results, args.out, rt_slowdown_max=args.rt_slowdown_max)
        if args.command == "calibration":
            from analysis import calibration
            return calibration.run(args.folder)
        if args.command == "compare":
            from analysis import compare
            return compare.run(args.results_a, args.results_b, args.out, bands=args.band)
        from analysis import validation
        if args.command == "validate":
            names = [n for n in args.scenarios.split(",") if n] \
                if args.scenarios is not None else None
            failed = [dict(zip(("scenario", "reason"), f.split("=", 1) + [""]))
                      for f in args.failed]
            skipped = [dict(zip(("scenario", "reason"), f.split("=", 1) + [""]))
                       for f in args.skipped]
            return validation.run(args.hw_root, args.sim_root, args.out, names, failed,
                                  args.note, cpu=args.cpu, band_root=args.band_root,
                                  skipped=skipped, state_dir=args.state_dir)
        return validation.table(args.report, args.readme, args.figure_dir)
    except InvalidInput as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    except OSError as e:
        print(f"error: {e}", file=sys.stderr)
        return 1


if __name__ == "__main__":
    sys.exit(main())
