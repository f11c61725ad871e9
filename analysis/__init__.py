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

import importlib

# Name -> the module that defines it, imported on first use (PEP 562): ``python3 -m analysis``
# imports this package first, and checks for numpy, pandas, matplotlib and scipy before any of
# them is loaded.
_EXPORTS = {"InvalidInput": "analysis.results", "NotAResultsFolder": "analysis.results",
            "Results": "analysis.results", "load": "analysis.frame",
            "load_results": "analysis.results"}

__all__ = sorted(_EXPORTS)


def __getattr__(name: str):
    if name in _EXPORTS:
        return getattr(importlib.import_module(_EXPORTS[name]), name)
    raise AttributeError(f"module 'analysis' has no attribute {name!r}")
