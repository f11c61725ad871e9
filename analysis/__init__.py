"""Plots and sim-vs-measured comparison of rosguard results folders.

A results folder is what ``rosguard run`` writes (docs/design.md section 6): ``manifest.json``,
``points.csv`` (one row per point and repetition) and ``samples.csv`` (distributions).

Entry points:

* ``python3 -m analysis plot DIR [--out DIR]``: every figure the results support
  (``analysis.plot``), called by ``rosguard plot``.
* ``python3 -m analysis compare A B [--out DIR]``: per-point slowdown differences, error
  summary and scatter figure (``analysis.compare``), called by ``rosguard compare``.

* ``from analysis import load``: ``points, samples = load(DIR)``, pandas DataFrames with each
  column's unit and meaning in ``attrs`` (``analysis.frame``).
* ``analysis.nodes``: the RT and nRT nodes of a folder by name (``nodes_of``) and the tidy
  per-node table (``node_rows``: one row per point, repetition and node; ``rosguard plot``
  writes it as ``nodes.csv``).

Only the standard library and Debian's numpy, scipy, pandas and matplotlib are used.
"""

from analysis.frame import load
from analysis.results import InvalidInput, NotAResultsFolder, Results, load_results

__all__ = ["InvalidInput", "NotAResultsFolder", "Results", "load", "load_results"]
