"""Command line: ``python3 -m analysis plot|compare|calibration ...`` (what ``rosguard plot``,
``rosguard compare`` and ``rosguard calibrate`` run).

Exit codes: 0 success, 2 invalid input (usage, a folder that is not a results folder, two
folders without a common point), 1 runtime failure (e.g. an output folder that cannot be
written). Errors are one line on stderr, without a traceback.
"""

from __future__ import annotations

import argparse
import sys

from analysis.results import InvalidInput

DESCRIPTION = """\
Figures and comparisons of rosguard results folders (what `rosguard run` writes:
manifest.json, points.csv, samples.csv). `rosguard plot` and `rosguard compare` call this.
"""

EPILOG = """\
examples:
  python3 -m analysis plot results/quickstart
      figures (PNG + PDF), summary.csv and distributions.csv in results/quickstart/figures
  python3 -m analysis compare results/exp4-hw results/exp4-sim
      compare.csv, summary.json and compare_scatter.png/pdf in results/exp4-sim/compare

exit codes: 0 success, 2 invalid input, 1 runtime failure
"""

PLOT_HELP = """\
Draw every figure the results support: slowdown vs threshold, vs sampling period and vs
regulation period (RT and nRT); RT x nRT grids per threshold and configuration; activation
delay and PMC callback duration (min / median / max per sampling period, self vs external);
sampling overhead vs sampling period. Figures the data do not support are skipped with a
reason. Also writes summary.csv (per point: mean / min / max / std over repetitions) and
distributions.csv (sample statistics per sampling mode and period).
"""

COMPARE_HELP = """\
Match the points of two results folders by id (same scenario, e.g. measured on hw vs
simulated) and report per-point RT / nRT slowdown differences (B - A), the mean absolute
percentage error, the max error, the Spearman rank agreement of the configurations, and the
points found on one side only. Writes compare.csv, summary.json and compare_scatter.png/pdf.
"""


def build_parser() -> argparse.ArgumentParser:
    """The argparse parser of the two subcommands."""
    parser = argparse.ArgumentParser(
        prog="python3 -m analysis", description=DESCRIPTION, epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = parser.add_subparsers(dest="command", metavar="{plot,compare,calibration}")

    plot = sub.add_parser("plot", help="draw every figure a results folder supports",
                          description=PLOT_HELP)
    plot.add_argument("results", metavar="RESULTS_DIR", help="results folder of a run")
    plot.add_argument("--out", metavar="DIR",
                      help="where figures and tables go (default: RESULTS_DIR/figures)")

    compare = sub.add_parser("compare", help="compare two results folders point by point",
                             description=COMPARE_HELP)
    compare.add_argument("results_a", metavar="RESULTS_A",
                         help="reference results folder (e.g. measured on hw)")
    compare.add_argument("results_b", metavar="RESULTS_B",
                         help="results folder compared with it (e.g. simulated)")
    compare.add_argument("--out", metavar="DIR",
                         help="where the comparison goes (default: RESULTS_B/compare)")
    calibration = sub.add_parser(
        "calibration", help="draw a calibration's measured vs fitted figures",
        description="Figures of a `rosguard calibrate` folder (calibration.json, platform.json):"
                    " isolation curves, co-run slowdowns and cost distributions, measured vs"
                    " fitted, into DIR/figures.")
    calibration.add_argument("folder", metavar="DIR", help="output folder of rosguard calibrate")
    return parser


def main(argv=None) -> int:
    """Runs one subcommand; returns the exit code."""
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.command is None:
        parser.print_help(sys.stderr)
        return 2
    try:
        # Imported here so that --help and usage errors do not load matplotlib.
        if args.command == "plot":
            from analysis import plot
            return plot.run(args.results, args.out)
        if args.command == "calibration":
            from analysis import calibration
            return calibration.run(args.folder)
        from analysis import compare
        return compare.run(args.results_a, args.results_b, args.out)
    except InvalidInput as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    except OSError as e:
        print(f"error: {e}", file=sys.stderr)
        return 1


if __name__ == "__main__":
    sys.exit(main())
