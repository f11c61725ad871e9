"""The nodes of a results folder, each by its name, and the tidy per-node table.

``points.csv`` is wide: one row per point and repetition, the first RT / nRT node's columns
prefixed ``rt_`` / ``nrt_`` (``nrt_slowdown``) and the others ``rt<i>_`` / ``nrt<i>_``
(``nrt2_slowdown``); ``<prefix>name`` and ``<prefix>core`` say which node of the scenario a
prefix is. ``nodes_of(results)`` lists the nodes the folder has; ``node_rows(results)`` is the
tidy view (``nodes.csv``, written by ``rosguard plot``): one row per point, repetition and node,
with its role, index, name, core, workload, the point's regulation settings and the node's
times, slowdown, bandwidth and throttling.

Folders written before the name columns existed have no node names (labels say "nRT1");
before ``nrt_throttle_count`` existed, the first nRT node's throttling is ``throttle_count`` /
``throttled_us``.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from pathlib import Path

from analysis.tables import write_csv

ROLES = (("rt", "RT"), ("nrt", "nRT"))
_PREFIX = re.compile(r"^(n?rt)(\d*)_workload$")
# The first nRT node's throttle columns under their fixed names (DESIGN section 7).
_FIXED_NAMES = {"nrt_throttle_count": "throttle_count", "nrt_throttled_us": "throttled_us"}

# The tidy table's columns: the row, the node, the point's regulation, the node's figures.
NODE_TABLE_SETTINGS = ("policy", "sampling", "scope", "threshold_pct", "sampling_period_us",
                       "regulation_period_us")
NODE_TABLE_VALUES = ("time_us", "isolation_us", "slowdown", "slowdown_ci95_pct",
                     "bandwidth_mbps", "throttle_count", "throttled_us",
                     "unregulated_slowdown")
NODE_TABLE_COLUMNS = ("point", "rep", "role", "node", "name", "core", "workload",
                      *NODE_TABLE_SETTINGS, *NODE_TABLE_VALUES)


@dataclass(frozen=True)
class Node:
    """One RT or nRT node of a folder: its place in the scenario and its points.csv prefix."""

    role: str          # "rt" or "nrt"
    index: int         # position in nodes.rt / nodes.nrt, from 0
    prefix: str        # "rt_", "nrt_", "nrt1_", ...
    name: str          # the scenario's node name ("" in folders without name columns)
    several: bool      # the folder has more than one node of this role

    def column(self, what: str) -> str:
        """The points.csv column of this node's ``what`` ("slowdown" -> "nrt2_slowdown")."""
        return self.prefix + what

    @property
    def metric(self) -> str:
        """Its slowdown column."""
        return self.column("slowdown")

    @property
    def key(self) -> str:
        """Its prefix without the underscore ("nrt", "nrt1"): how output columns name it."""
        return self.prefix[:-1]

    @property
    def tag(self) -> str:
        """'nRT1'; 'nRT' when it is the folder's only nRT node."""
        return f"{dict(ROLES)[self.role]}{self.index if self.several else ''}"

    @property
    def label(self) -> str:
        """'nRT1 disparity'; 'nRT bandwidth_read' when it is the folder's only nRT node."""
        return f"{self.tag} {self.name}".strip()


def nodes_of(results, role: str | None = None) -> list:
    """The folder's nodes (RT ones first, each role in scenario order), or those of one role.
    A node is there when some row has its workload."""
    found = {}
    for c in results.columns:
        m = _PREFIX.match(c)
        if m and any(r.get(c) is not None for r in results.rows):
            found.setdefault(m.group(1), []).append(int(m.group(2) or 0))
    nodes = []
    for r, _ in ROLES:
        if role not in (None, r):
            continue
        indexes = sorted(found.get(r, []))
        for i in indexes:
            prefix = f"{r}_" if i == 0 else f"{r}{i}_"
            nodes.append(Node(r, i, prefix, _name(results, prefix), len(indexes) > 1))
    return nodes


def _name(results, prefix: str) -> str:
    """The node's name over the rows ('/'-joined should a sweep change it); '' without names."""
    column = prefix + "name"
    if column not in results.columns:
        return ""
    return "/".join(dict.fromkeys(str(r[column]) for r in results.rows
                                  if r.get(column) is not None))


def cell_column(results, node: Node, what: str) -> str | None:
    """The column holding a node's ``what`` in this folder (older folders: the first nRT node's
    throttling under its fixed name); None when the folder has none."""
    column = node.column(what)
    if column in results.columns:
        return column
    fixed = _FIXED_NAMES.get(column)
    return fixed if fixed in results.columns else None


def node_rows(results) -> list:
    """The tidy table: one dict per point, repetition and node (the row's nodes whose workload
    cell is filled), with NODE_TABLE_COLUMNS; NaN / None where a value does not apply (older
    folders have ``unregulated_slowdown`` for the first node of each role only)."""
    nodes = nodes_of(results)
    columns = {n: {what: cell_column(results, n, what)
                   for what in ("name", "core", "workload", *NODE_TABLE_VALUES)}
               for n in nodes}
    out = []
    for row in results.rows:
        for n in nodes:
            col = columns[n]
            if row.get(col["workload"]) is None:
                continue
            entry = {"point": row["point"], "rep": row["rep"], "role": n.role, "node": n.index,
                     "name": row.get(col["name"]) if col["name"] else n.name,
                     "core": _integer(row.get(col["core"])) if col["core"] else None,
                     "workload": row[col["workload"]]}
            entry.update({c: row.get(c) for c in NODE_TABLE_SETTINGS})
            entry.update({v: row.get(col[v], math.nan) if col[v] else math.nan
                          for v in NODE_TABLE_VALUES})
            out.append(entry)
    return out


def _integer(value):
    """A core number read as a float (points.csv cells are typed by column) back to an int."""
    if isinstance(value, float) and math.isfinite(value) and value.is_integer():
        return int(value)
    return None if isinstance(value, float) else value


def write_nodes(results, path: Path) -> Path:
    """nodes.csv: node_rows as CSV (NODE_TABLE_COLUMNS)."""
    rows = [[r[c] for c in NODE_TABLE_COLUMNS] for r in node_rows(results)]
    return write_csv(path, NODE_TABLE_COLUMNS, rows)
