"""Loading a results folder (docs/design.md section 6) into a clean structure.

``load_results(folder)`` reads ``manifest.json``, ``points.csv``, the optional
``samples.csv`` and the optional ``tune.json`` (what ``rosguard tune`` writes beside its
points: the RT slowdown target and the settings it chose). Cells are typed: known text columns stay strings, every other column is a
float; an empty cell ("not applicable") becomes ``None`` in text columns and NaN in numeric
ones. Rows are aggregated per point over repetitions (``Point``), and samples are grouped by
(point, kind) over all repetitions. The grouping is pandas' (``groupby``).

Invalid input raises ``InvalidInput`` (or its subclass ``NotAResultsFolder``) with a one-line
message naming the file and what is wrong; the CLI maps it to exit code 2.
"""

from __future__ import annotations

import csv
import json
import math
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

SCHEMA_VERSION = 1

# The columns docs/design.md fixes, in order (model/results/results.cpp writes them first).
FIXED_COLUMNS = (
    "point", "rep", "backend", "rt_workload", "nrt_workload", "policy", "sampling", "scope",
    "threshold_pct", "sampling_period_us", "regulation_period_us", "rt_time_us",
    "rt_isolation_us", "rt_slowdown", "nrt_time_us", "nrt_isolation_us", "nrt_slowdown",
    "nrt_bandwidth_mbps", "throttle_count", "throttled_us", "activation_delay_p50_us",
    "activation_delay_max_us", "pmc_callback_p50_us", "rt_isolation_ipc", "rt_isolation_mbps",
    "nrt_isolation_ipc", "nrt_isolation_mbps",
)
SAMPLES_COLUMNS = ("point", "rep", "kind", "value_us")

_TEXT_COLUMNS = {"point", "backend", "rt_workload", "nrt_workload", "policy", "sampling",
                 "scope", "platform", "nrt_mode"}
_NODE_WORKLOAD = re.compile(r"^n?rt\d+_workload$")
_NODE_NAME = re.compile(r"^n?rt\d*_name$")
PARAM_PREFIX = "param:"

# Columns that describe a point's configuration (as opposed to what was measured), in the
# order titles and tables mention them. Per-node workloads and sweep parameters that add a
# dimension of their own are appended per folder (Results.config_columns).
BASE_CONFIG_COLUMNS = (
    "platform", "rt_workload", "nrt_workload", "policy", "sampling", "sampling_period_us",
    "regulation_period_us", "threshold_pct", "scope", "nrt_mode", "reference_mbps",
)


class InvalidInput(Exception):
    """Input the analysis cannot use; the message names the file and the problem."""


class NotAResultsFolder(InvalidInput):
    """The folder does not exist or lacks manifest.json / points.csv."""


@dataclass(frozen=True)
class Stat:
    """Summary of one metric over the repetitions of a point (NaN cells ignored)."""

    n: int
    mean: float
    min: float
    max: float
    std: float

    @classmethod
    def of(cls, values) -> "Stat | None":
        """Stat of the finite values, or None when there is none."""
        v = np.asarray([x for x in values if x is not None and math.isfinite(x)], dtype=float)
        if v.size == 0:
            return None
        return cls(int(v.size), float(v.mean()), float(v.min()), float(v.max()),
                   float(v.std(ddof=1)) if v.size > 1 else 0.0)


@dataclass
class Point:
    """One point of the sweep, aggregated over its repetitions."""

    id: str
    config: dict
    reps: int
    stats: dict = field(default_factory=dict)

    def stat(self, metric: str) -> Stat | None:
        """Stat of a metric column, None when every repetition left it empty."""
        return self.stats.get(metric)

    def mean(self, metric: str) -> float:
        """Mean of a metric over repetitions, NaN when not applicable."""
        s = self.stats.get(metric)
        return s.mean if s else math.nan

    @property
    def has_rt(self) -> bool:
        """True when the point has an RT node."""
        return self.config.get("rt_workload") is not None

    @property
    def has_nrt(self) -> bool:
        """True when the point has an nRT node."""
        return self.config.get("nrt_workload") is not None


@dataclass
class Results:
    """A loaded results folder."""

    folder: Path
    manifest: dict
    columns: list
    rows: list
    samples: dict
    points: list
    config_columns: list
    tune: dict = field(default_factory=dict)   # tune.json, {} without one
    # The RT slowdown bound figures draw as a target: tune.json's rt_slowdown_max, or what the
    # user gave (rosguard plot --rt-slowdown-max, set by analysis.plot); None: no target.
    rt_slowdown_max: float | None = None

    @property
    def backend(self) -> str:
        """'sim' or 'hw' (from the manifest, else from the rows)."""
        b = self.manifest.get("backend")
        if not b and self.rows:
            b = self.rows[0].get("backend")
        return str(b or "?")

    @property
    def platform(self) -> str:
        """Platform name of the rows (several joined with '+')."""
        names = sorted({r["platform"] for r in self.rows if r.get("platform")})
        return "+".join(names) if names else "?"

    @property
    def status(self) -> str:
        """Run status from the manifest ('complete', 'interrupted', ...)."""
        return str(self.manifest.get("status", "unknown"))

    @property
    def repetitions(self) -> int:
        """Largest number of repetitions of any point."""
        return max((p.reps for p in self.points), default=0)

    def samples_of(self, point_id: str, kind: str) -> np.ndarray:
        """All values (us) of one kind for one point, over every repetition."""
        return self.samples.get((point_id, kind), np.empty(0))

    def sample_kinds(self) -> set:
        """Kinds present in samples.csv."""
        return {kind for _, kind in self.samples}


def load_results(folder) -> Results:
    """Reads a results folder; raises InvalidInput / NotAResultsFolder with a clear message."""
    folder = Path(folder)
    if not folder.is_dir():
        raise NotAResultsFolder(f"{folder}: no such folder")
    missing = [n for n in ("manifest.json", "points.csv") if not (folder / n).is_file()]
    if missing:
        raise NotAResultsFolder(
            f"{folder} is not a results folder (missing {', '.join(missing)}); "
            f"create one with: rosguard run SCENARIO.json --out {folder}")
    manifest = _read_manifest(folder / "manifest.json")
    columns, rows = _read_points(folder / "points.csv")
    _check_points_belong(folder, manifest, rows)
    samples = _read_samples(folder / "samples.csv")
    config_columns = _config_columns(columns, rows)
    points = _aggregate(rows, columns, config_columns)
    tune = _read_tune(folder / "tune.json")
    return Results(folder, manifest, columns, rows, samples, points, config_columns, tune,
                   tune.get("rt_slowdown_max"))


def _check_points_belong(folder: Path, manifest: dict, rows: list) -> None:
    """Every row of points.csv is a run of a point the manifest lists (its scenario.points):
    a points.csv copied from another run's folder would be drawn as if it were this one's."""
    listed = manifest.get("scenario", {}).get("points")
    if not isinstance(listed, list) or not listed:
        return  # a manifest without the list (nothing to check against)
    ids = {p.get("id") for p in listed if isinstance(p, dict)}
    for number, row in enumerate(rows, start=2):
        if row["point"] not in ids:
            raise InvalidInput(
                f"{folder / 'points.csv'}: line {number}: point '{row['point']}' is not one of "
                f"the {len(ids)} points of the scenario in {folder / 'manifest.json'} "
                f"({manifest.get('scenario_file', 'its scenario')}): the folder holds files of "
                "different runs; run the scenario again into a folder of its own")


TUNE_SETTINGS = ("best", "runner_up", "unregulated")


def _read_tune(path: Path) -> dict:
    """tune.json: {"rt_slowdown_max": X, "best": {...}, "runner_up": {...},
    "unregulated": {...}, ...}; {} when the folder has none. Each setting is an object (what
    analysis.figures.tradeoff matches against the points: a point id, the regulation columns,
    or rt_slowdown / nrt_slowdown); null means none was found."""
    if not path.is_file():
        return {}
    tune = _read_json_object(path)
    bound = tune.get("rt_slowdown_max")
    if bound is not None and (isinstance(bound, bool) or not isinstance(bound, (int, float))
                              or not math.isfinite(bound) or bound <= 0):
        raise InvalidInput(f"{path}: /rt_slowdown_max: expected a positive number, "
                           f"got {json.dumps(bound)}")
    if bound is not None:
        tune["rt_slowdown_max"] = float(bound)
    for key in TUNE_SETTINGS:
        if tune.get(key) is not None and not isinstance(tune[key], dict):
            raise InvalidInput(f"{path}: /{key}: expected an object or null, "
                               f"got {json.dumps(tune[key])}")
    return tune


def _read_json_object(path: Path) -> dict:
    """The JSON object in `path`; InvalidInput naming the file when it cannot be read, is not
    JSON, or is not an object."""
    try:
        doc = json.loads(path.read_text(encoding="utf-8"))
    except json.JSONDecodeError as e:
        raise InvalidInput(f"{path}: invalid JSON (line {e.lineno}: {e.msg})") from None
    except (OSError, UnicodeDecodeError) as e:
        raise InvalidInput(f"{path}: cannot read: {e}") from None
    if not isinstance(doc, dict):
        raise InvalidInput(f"{path}: expected a JSON object")
    return doc


def _read_manifest(path: Path) -> dict:
    manifest = _read_json_object(path)
    version = manifest.get("schema_version", SCHEMA_VERSION)
    if version != SCHEMA_VERSION:
        raise InvalidInput(f"{path}: schema_version {version} is not supported "
                           f"(this analysis reads version {SCHEMA_VERSION})")
    return manifest


def _read_csv(path: Path) -> list:
    try:
        with path.open(newline="", encoding="utf-8") as f:
            return list(csv.reader(f))
    except (OSError, UnicodeDecodeError, csv.Error) as e:
        raise InvalidInput(f"{path}: cannot read: {e}") from None


def _is_text_column(name: str) -> bool:
    return (name in _TEXT_COLUMNS or bool(_NODE_WORKLOAD.match(name))
            or bool(_NODE_NAME.match(name)))


def _parse_float(cell: str) -> float | None:
    try:
        return float(cell)
    except ValueError:
        return None


def _read_points(path: Path):
    lines = _read_csv(path)
    if not lines:
        raise InvalidInput(f"{path}: empty file (no header)")
    header = lines[0]
    missing = [c for c in FIXED_COLUMNS if c not in header]
    if missing:
        raise InvalidInput(f"{path}: not a rosguard points.csv (missing columns: "
                           f"{', '.join(missing)})")
    body = [line for line in lines[1:] if line]
    for number, line in enumerate(body, start=2):
        if len(line) != len(header):
            raise InvalidInput(f"{path}: line {number} has {len(line)} fields, "
                               f"the header has {len(header)}")
    raw_rows = [dict(zip(header, line)) for line in body]
    kinds = {c: _column_kind(c, raw_rows) for c in header}
    rows = []
    for number, raw in enumerate(raw_rows, start=2):
        rows.append({c: _typed(path, number, c, raw[c], kinds[c]) for c in header})
    return header, rows


def _column_kind(name: str, raw_rows) -> str:
    """'text', 'int' (rep), 'number' (fixed numeric) or 'lenient' (unknown columns)."""
    if _is_text_column(name):
        return "text"
    if name == "rep":
        return "int"
    if name in FIXED_COLUMNS:
        return "number"
    cells = [r[name] for r in raw_rows if r[name] != ""]
    return "lenient" if all(_parse_float(c) is not None for c in cells) else "text"


def _typed(path: Path, line: int, column: str, cell: str, kind: str):
    if kind == "text":
        return cell if cell != "" else None
    if cell == "":
        if kind == "int":
            raise InvalidInput(f"{path}: line {line}: column {column} is empty")
        return math.nan
    value = _parse_float(cell)
    if value is None or (kind == "int" and not value.is_integer()):
        raise InvalidInput(f"{path}: line {line}: column {column}: '{cell}' is not a number")
    return int(value) if kind == "int" else value


def _read_samples(path: Path) -> dict:
    if not path.is_file():
        return {}
    lines = _read_csv(path)
    if not lines:
        return {}
    header = lines[0]
    missing = [c for c in SAMPLES_COLUMNS if c not in header]
    if missing:
        raise InvalidInput(f"{path}: not a rosguard samples.csv (missing columns: "
                           f"{', '.join(missing)})")
    at = {c: header.index(c) for c in SAMPLES_COLUMNS}
    grouped: dict = {}
    for number, line in enumerate(lines[1:], start=2):
        if not line:
            continue
        if len(line) != len(header):
            raise InvalidInput(f"{path}: line {number} has {len(line)} fields, "
                               f"the header has {len(header)}")
        value = _parse_float(line[at["value_us"]])
        if value is None:
            raise InvalidInput(f"{path}: line {number}: value_us "
                               f"'{line[at['value_us']]}' is not a number")
        grouped.setdefault((line[at["point"]], line[at["kind"]]), []).append(value)
    return {key: np.asarray(values) for key, values in grouped.items()}


def _config_columns(columns, rows) -> list:
    """Columns that identify a configuration in this folder.

    The base columns, the workloads of second and later nodes, and each ``param:`` column
    that is not already determined by those (a sweep over ``regulation.threshold_pct`` is
    the ``threshold_pct`` column again; a sweep over ``sim.quantum_us`` is a dimension of
    its own).
    """
    known = [c for c in BASE_CONFIG_COLUMNS if c in columns]
    known += [c for c in columns if _NODE_WORKLOAD.match(c)]
    params = [c for c in columns if c.startswith(PARAM_PREFIX)]
    if not params or not rows:
        return known
    frame = pd.DataFrame.from_records(rows, columns=columns)
    return known + [c for c in params if not _determined_by(frame, known, c)]


def _determined_by(frame: pd.DataFrame, keys, column) -> bool:
    """True when each combination of the key columns comes with one value of ``column``
    (NaN / None count as a value of their own)."""
    if not keys:
        return frame[column].nunique(dropna=False) <= 1
    values = frame.groupby(list(keys), dropna=False, sort=False)[column].nunique(dropna=False)
    return bool((values <= 1).all())


def _hashable(value):
    """NaN compares unequal to itself; map it to None so it can be grouped."""
    if isinstance(value, float) and math.isnan(value):
        return None
    return value


def _aggregate(rows, columns, config_columns) -> list:
    """Points in the order of their first row, with Stat per numeric measured column (pandas
    groupby over the point id; NaN / inf cells ignored, as Stat.of does)."""
    metrics = [c for c in columns
               if c not in config_columns and c not in ("point", "rep")
               and not _is_text_column(c) and not c.startswith(PARAM_PREFIX)]
    if not rows:
        return []
    frame = pd.DataFrame.from_records(rows, columns=columns)
    by_point = frame.groupby("point", sort=False)
    firsts = {r["point"]: r for r in by_point.head(1)[["point", *config_columns]]
              .to_dict("records")}
    reps = by_point["rep"].nunique()
    stats_of = {pid: {} for pid in reps.index}
    if metrics:
        # A column the reader kept as text (cells that are not numbers) has no statistics.
        values = frame[metrics].apply(pd.to_numeric, errors="coerce")
        values = values.replace([np.inf, -np.inf], np.nan)
        values["point"] = frame["point"]
        table = values.groupby("point", sort=False).agg(["count", "mean", "min", "max", "std"])
        cells = table.to_numpy(dtype=float)
        at = {key: i for i, key in enumerate(table.columns)}
        for row, pid in zip(cells, table.index):
            for m in metrics:
                n = int(row[at[(m, "count")]])
                if n:
                    stats_of[pid][m] = Stat(n, float(row[at[(m, "mean")]]),
                                            float(row[at[(m, "min")]]),
                                            float(row[at[(m, "max")]]),
                                            float(row[at[(m, "std")]]) if n > 1 else 0.0)
    points = []
    for pid in reps.index:
        config = {c: _hashable(firsts[pid][c]) for c in config_columns}
        stats = stats_of[pid]
        points.append(Point(pid, config, int(reps[pid]), stats))
    return points
