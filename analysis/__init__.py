"""Plots and sim-vs-measured comparison of rosguard results folders.

A results folder is what ``rosguard run`` writes (docs/design.md section 6): ``manifest.json``,
``points.csv`` (one row per point and repetition) and ``samples.csv`` (distributions).

Entry points:

* ``python3 -m analysis plot DIR [--out DIR]``: every figure the results support
  (``analysis.plot``), called by ``rosguard plot``.
* ``python3 -m analysis compare A B [--out DIR]``: per-point slowdown differences, error
  summary and scatter figure (``analysis.compare``), called by ``rosguard compare``.

Only the standard library, numpy and matplotlib (Debian packages) are used.
"""

from analysis.results import InvalidInput, NotAResultsFolder, Results, load_results

__all__ = ["InvalidInput", "NotAResultsFolder", "Results", "load_results"]
