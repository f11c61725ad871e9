"""A results folder as pandas DataFrames: ``from analysis import load``.

``load(folder)`` returns ``(points, samples)``: ``points`` has one row per point and repetition
(``points.csv``), ``samples`` one row per observation (``samples.csv``; empty when the folder
has none). Text columns stay strings, every other column is numeric; an empty cell is NaN (or
None in text columns). Each frame carries its column dictionary in ``attrs``:
``attrs["units"][column]`` (``"us"``, ``"MiB/s"``, ``"ratio"``, ...) and
``attrs["meanings"][column]``, read from the folder's ``columns.json`` (model/results/columns.cpp
writes it). For ``samples`` the dictionary is per kind: ``attrs["units"]["rt_job"]``.

A folder written before ``columns.json`` existed loads with empty dictionaries and a warning.
Invalid input raises ``InvalidInput`` / ``NotAResultsFolder`` as ``load_results`` does.
"""

from __future__ import annotations

import json
import warnings
from pathlib import Path

import pandas as pd

from analysis.results import (InvalidInput, SAMPLES_COLUMNS, _TEXT_COLUMNS, _NODE_WORKLOAD,
                              load_results)


def _dictionary(folder: Path) -> dict:
    path = folder / "columns.json"
    if not path.is_file():
        warnings.warn(f"{path} is missing (a folder from an older rosguard): no units or "
                      f"meanings in attrs", stacklevel=3)
        return {"points.csv": [], "samples.csv": []}
    try:
        d = json.loads(path.read_text(encoding="utf-8"))
        for part in ("points.csv", "samples.csv"):
            for e in d[part]:
                e["name"], e["unit"], e["meaning"]  # noqa: B018 - shape check
        return d
    except (json.JSONDecodeError, KeyError, TypeError) as e:
        raise InvalidInput(f"{path}: not the column dictionary rosguard writes ({e})") from None


def _attach(frame: pd.DataFrame, entries: list) -> pd.DataFrame:
    frame.attrs["units"] = {e["name"]: e["unit"] for e in entries}
    frame.attrs["meanings"] = {e["name"]: e["meaning"] for e in entries}
    return frame


def load(folder):
    """(points, samples) DataFrames of a results folder, with units in ``attrs``."""
    folder = Path(folder)
    results = load_results(folder)  # validates the folder and types the cells
    text = {c for c in results.columns
            if c in _TEXT_COLUMNS or _NODE_WORKLOAD.match(c) or c.startswith("param:")}
    points = pd.DataFrame(results.rows, columns=list(results.columns))
    for c in results.columns:
        if c not in text:
            points[c] = pd.to_numeric(points[c], errors="coerce")
    if "rep" in points:
        points["rep"] = points["rep"].astype("int64")
    samples_path = folder / "samples.csv"
    if samples_path.is_file():
        samples = pd.read_csv(samples_path, dtype={"point": str, "kind": str})
    else:
        samples = pd.DataFrame({c: [] for c in SAMPLES_COLUMNS})
    d = _dictionary(folder)
    return _attach(points, d["points.csv"]), _attach(samples, d["samples.csv"])
