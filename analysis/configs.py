"""Grouping points by configuration and describing configurations in words.

Figures split the configuration columns of a folder (``Results.config_columns``) into the
x axis, series (lines, bar colours), groups (panels or files) and what is held fixed (the
title). These helpers do the splitting and write the words a reader of the paper expects
("RT mser / nRT bandwidth_read, self-sampling 1 ms, regulation 5 ms").
"""

from __future__ import annotations

import math
import re

from analysis.style import number, period

POLICY_WORDS = {
    "interval": "interval-based regulation",
    "monolithic": "monolithic regulation",
    "monitor": "monitoring only",
    "none": "no regulation",
}
_WORKLOADS = ("rt_workload", "nrt_workload")
_FURTHER_NODE = re.compile(r"^(n?rt)\d+_workload$")
_SAMPLING = ("sampling", "sampling_period_us")
COLUMN_WORDS = {
    "policy": "policy",
    "sampling": "sampling mode",
    "sampling_period_us": "sampling period",
    "regulation_period_us": "regulation period",
    "threshold_pct": "threshold",
    "rt_workload": "RT workload",
    "nrt_workload": "nRT workload",
    "scope": "scope",
    "platform": "platform",
    "nrt_mode": "nRT mode",
    "reference_mbps": "reference bandwidth",
}


def column_words(column: str) -> str:
    """A reader's name for a config column."""
    return COLUMN_WORDS.get(column, column.replace("param:", ""))


def distinct(points, column) -> list:
    """Distinct values of a config column, numbers ascending, text in order of appearance."""
    values = []
    for p in points:
        v = p.config.get(column)
        if v not in values:
            values.append(v)
    if values and all(isinstance(v, float) for v in values):
        values.sort()
    return values


def varying(points, columns) -> list:
    """The columns (in the given order) that take at least two values among the points."""
    return [c for c in columns if len(distinct(points, c)) > 1]


def group_by(points, columns) -> dict:
    """Ordered {key tuple: [points]} on the values of the columns (stable order)."""
    groups: dict = {}
    for p in points:
        groups.setdefault(key_of(p, columns), []).append(p)
    return dict(sorted(groups.items(), key=lambda kv: _order_key(points, columns, kv[0])))


def keys_in_order(points, columns) -> list:
    """Distinct key tuples of the columns, in order of first appearance (sweep order)."""
    return list(dict.fromkeys(key_of(p, columns) for p in points))


def key_of(point, columns) -> tuple:
    """The values of the columns for one point."""
    return tuple(point.config.get(c) for c in columns)


def _order_key(points, columns, key) -> tuple:
    return tuple(distinct(points, c).index(v) for c, v in zip(columns, key))


def as_config(columns, key) -> dict:
    """{column: value} from a key tuple."""
    return dict(zip(columns, key))


def describe(config: dict, short: bool = False) -> str:
    """Words for the given config values, e.g. 'RT mser / nRT mser, self-sampling 1 ms'.

    ``short`` gives legend-sized words ('interval', 'self 1 ms', '20 %').
    """
    parts = []
    if any(c in config for c in _WORKLOADS):
        parts.append(_workloads(config))
    for c, v in config.items():
        if c.startswith(("rt", "nrt")) and c.endswith("_workload") and c not in _WORKLOADS:
            parts.append(f"{c[:-len('_workload')].upper().replace('NRT', 'nRT')} {v or '-'}")
    if "policy" in config:
        policy = config["policy"]
        parts.append(str(policy) if short else POLICY_WORDS.get(policy, f"policy {policy}"))
    if any(c in config for c in _SAMPLING):
        parts.append(_sampling(config, short))
    if "regulation_period_us" in config:
        reg = period(config["regulation_period_us"])
        parts.append(f"reg. {reg}" if short else f"regulation {reg}")
    if "threshold_pct" in config:
        parts.append(f"threshold {number(config['threshold_pct'])} %")
    for c, v in config.items():
        if c in ("scope", "nrt_mode", "platform", "reference_mbps") or c.startswith("param:"):
            parts.append(_other(c, v))
    return ", ".join(p for p in parts if p)


def _workloads(config: dict) -> str:
    """'RT mser / nRT bandwidth_read'; the first node of a role is 'RT0' / 'nRT0' when the
    config also names a further one ('nrt1_workload'), as that one is 'nRT1'."""
    further = [m.group(1) for m in map(_FURTHER_NODE.match, config) if m]
    rt_word = "RT0" if "rt" in further else "RT"
    nrt_word = "nRT0" if "nrt" in further else "nRT"
    rt, nrt = config.get("rt_workload"), config.get("nrt_workload")
    if "rt_workload" in config and "nrt_workload" in config:
        if rt is None and nrt is None:
            return "no nodes"
        if rt is None:
            return f"{nrt_word} {nrt} alone"
        if nrt is None:
            return f"{rt_word} {rt} alone"
        return f"{rt_word} {rt} / {nrt_word} {nrt}"
    if "rt_workload" in config:
        return f"{rt_word} {rt}" if rt else "no RT node"
    return f"{nrt_word} {nrt}" if nrt else "no nRT node"


def _sampling(config: dict, short: bool) -> str:
    mode = config.get("sampling")
    sp = config.get("sampling_period_us")
    words = []
    if "sampling" in config:
        words.append(str(mode) if short else f"{mode}-sampling")
    else:
        words.append("sampling")
    if "sampling_period_us" in config:
        words.append(period(sp))
    return " ".join(words)


def _other(column: str, value) -> str:
    if column == "scope":
        return f"scope {value}"
    if column == "nrt_mode":
        return f"nRT {value}"
    if column == "reference_mbps":
        return f"reference {number(value)} MB/s"
    if column == "platform":
        return str(value)
    name = column[len("param:"):]
    return f"{name} = {number(value)}"


def held_fixed(points, columns) -> dict:
    """{column: value} for the columns that take a single value among the points."""
    fixed = {}
    for c in columns:
        values = distinct(points, c)
        if len(values) == 1:
            fixed[c] = values[0]
    return fixed


def title(what: str, fixed: dict, results) -> str:
    """Figure title: what it shows, what is held fixed, and how it was obtained
    ('[simulated]' or '[measured]')."""
    hidden = {"reference_mbps", "nrt_mode"}
    if fixed.get("policy") in ("monitor", "none"):
        hidden |= {"threshold_pct", "regulation_period_us"}   # no budget to speak of
    shown = {c: v for c, v in fixed.items() if c not in hidden}
    context = describe(shown)
    head = f"{what} — {context}" if context else what
    return f"{head} [{backend_words(results.backend)}]"


def backend_words(backend: str) -> str:
    """'simulated' for sim results, 'measured' for hw (the ``backend`` column)."""
    return {"sim": "simulated", "hw": "measured"}.get(backend, f"{backend} results")


def finite(value) -> bool:
    """True for a real number that is not NaN/inf."""
    return isinstance(value, (int, float)) and math.isfinite(value)


def slug(config: dict) -> str:
    """File-name fragment for a group, e.g. 'threshold15_mser-bandwidth_read'."""
    parts = []
    for c, v in config.items():
        name = c.replace("param:", "").replace("_pct", "").replace("_us", "")
        if c in _WORKLOADS:
            parts.append(str(v or "none"))
        else:
            parts.append(f"{name}{number(v)}")
    text = "_".join(parts)
    return "".join(ch if ch.isalnum() or ch in "-_." else "-" for ch in text)
