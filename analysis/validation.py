"""``validate HW_ROOT SIM_ROOT --out DIR``: the sim-vs-hw validation report (``make validate``).

HW_ROOT and SIM_ROOT hold one results folder per validation scenario, by the scenario's name
(``tools/validate.sh`` runs ``scenarios/validation/*.json`` into them). Each scenario's folders
are matched point by point as ``compare`` does (``compare.compare_results``: means over
repetitions), and for every RT and nRT node of every common point (a scenario with several
nRT nodes gives one nRT pair per node, all counted under nRT) the report computes:

* slowdown error: ``|s_sim - s_hw| / s_hw`` (MAPE: its mean over points, in %);
* excess-slowdown error, where the measured excess ``s_hw - 1`` is at least ``EXCESS_MIN``:
  ``|(s_sim - 1) - (s_hw - 1)| / (s_hw - 1)`` (mean and max over those points, in %); and the
  same over the points whose excess the hw repetitions resolve (the 95 % confidence interval
  of the hw mean, Student's t, lies above ``1 + EXCESS_MIN``), beside it: a point that reaches
  the bound by noise alone counts in the first (the goal) and not in the second;
* the measured noise: per point, the spread of the hw repetitions ``(max - min) / mean``
  (median over points), to read the errors against;
* the isolation offset: per point, the model's isolation time of the node over the one the hw
  run measured, ``iso_sim / iso_hw - 1`` (mean over points, in %, signed). Both slowdowns
  divide by their own side's isolation time, and a regulated nRT node's co-run time is set by
  its budget rather than by its kernel's speed, so its slowdown error follows this offset with
  the opposite sign: it tells an error of the model's kernel speed (or a host whose speed moved
  since it was calibrated) from one of its interference and regulation;

per scenario, over the whole suite (every point of every scenario pooled) and per number of
co-runners k (the scenario's nRT nodes: every scenario with that k pooled; ``per_k``), and marks
the goals (``GOALS``) met or missed. Every nRT node of a point is a pair (``nrt_slowdown``,
``nrt1_slowdown``, ...): the nRT errors are over every co-runner, and each scenario also has
them per node (``nrt_nodes``: by index and name), per k their min..max. Scenarios not run on
purpose (``--skipped NAME=REASON``: make validate's scale scenarios that need more CPUs than
the host has) are listed with their reason. Per scenario the report also gives the hw run's
precision (``hw_precision``, from its manifest: the CI target of its adaptive repetitions, the
fewest and most repetitions a point took). Writes ``DIR/report.json``, ``DIR/report.md`` and
``DIR/validation_scatter.png`` / ``.pdf`` (``analysis/figures/validation.py``).

With ``--band-root BAND_ROOT`` (``BAND_ROOT/<variant>/<scenario>/``: the sim runs of each
scenario on the band platforms of the host model, which ``rosguard calibrate`` writes for its
prior-dominated parameters) each point's node also has a **prediction band**: min..max of the
sim mean slowdown over the nominal run and every band run (``compare.prediction_band``: the
envelope of one-at-a-time variations). The report then gives per scenario and over the suite,
per node (the first RT and nRT node), the band's median width and its coverage (the share of
points whose hw mean lies in the band), the points their band, and the figure draws it on each
sim point. Without it the report is as before.

The **machine state** (``STATE_DIR/<scenario>.json``, by default ``DIR/state/``):
``tools/validate.sh`` measures the machine's DRAM interference (``rosguard platform
contention``, ``PROBE_WORDS``) right before and right after each scenario's hw run and compares
it with the state the installed host model was calibrated in (a VM's changes over minutes, as
the host moves its vCPUs); the probe also gives the host's speed against the model's (that
reader's time alone), which the state cell shows and the state does not include. The report
gives it per scenario (``machine_state``), says which scenarios were measured in another state
than the model's and, when some were and some were not, the errors over those in the model's
state alone (``in_model_state``); the goals stay marked over every scenario. A missing folder,
file or probe: that scenario's state is not known ("not probed").

``readme_section(report)`` is the README's table (``tools/validate.sh --readme``).
"""

from __future__ import annotations

import json
import math
import os
import sys
from dataclasses import dataclass
from datetime import datetime, timezone
from pathlib import Path

import numpy as np
import scipy.stats

from analysis import compare, style
from analysis.nodes import nodes_of
from analysis.figures import validation as figure
from analysis.markdown import splice
from analysis.results import InvalidInput, Stat, load_results

REPORT_SCHEMA_VERSION = 1
# The goals and the excess threshold live in analysis/goals.json, which rosguard calibrate reads
# too (its verdict).
_GOALS_FILE = json.loads((Path(__file__).parent / "goals.json").read_text())
EXCESS_MIN = float(_GOALS_FILE["excess_min"])
# goal key -> (node, metric in the node's errors, bound in %, words)
GOALS = {key: (g["node"], g["metric"], float(g["bound_pct"]), g["words"])
         for key, g in _GOALS_FILE["goals"].items()}
FIGURE_STEM = "validation_scatter"
NODE_WORDS = {"rt": "RT", "nrt": "nRT"}
PROBE_WORDS = ("a DRAM-bound reader's time per line beside one DRAM-bound reader on the other "
               "CPU over its time alone")
DEFINITIONS = {
    "slowdown": "per point, mean over repetitions of the node's time / its isolation time",
    "mape_pct": "mean over points of |s_sim - s_hw| / s_hw x 100",
    "bias": "mean over points of s_sim - s_hw (positive: sim predicts more slowdown)",
    "excess_error_pct": (f"mean over points with s_hw - 1 >= {EXCESS_MIN} of "
                         "|(s_sim - 1) - (s_hw - 1)| / (s_hw - 1) x 100"),
    "excess_error_max_pct": "the largest of those",
    "excess_error_resolved_pct": ("the excess error over the points whose excess the hw "
                                  "repetitions resolve: the lower end of the 95 % confidence "
                                  "interval of the hw mean (Student's t, n - 1 degrees of "
                                  f"freedom) is at least 1 + {EXCESS_MIN}; not a goal"),
    "excess_resolved_pairs": "how many points those are",
    "hw_spread_pct": ("median over points of (max - min) / mean of the hw repetitions x 100: "
                      "the measurement noise the errors sit on"),
    "isolation_offset_pct": ("mean over points of (the model's isolation time of the node / "
                             "the hw run's - 1) x 100 (positive: the model runs the node's "
                             "kernel slower than the host did during the hw run)"),
    "overall": "every common point of every scenario pooled",
    "k": ("co-runners: the scenario's nRT nodes; per k, every scenario with k of them pooled, "
          "the nRT errors over every co-runner's pairs and the range of the per-node nRT MAPEs"),
    "machine_state": ("per scenario, the probe (before and after its hw run; the model's: "
                      "when it was calibrated): " + PROBE_WORDS + "; matches: true when "
                      "both probes found the model's state, false when either did not, "
                      "null when not known; alike: false when a probe found the two CPUs "
                      "slowed differently (the same probe the other way round, other_way its "
                      "ratio), true when both found them alike, null when not known; "
                      "speed_before / speed_after: the reader's time alone over the model's, "
                      "- 1, in % (the host's speed against the model's: reported, not part of "
                      "matches), null when not known"),
    "in_model_state": "the scenarios whose both probes found the model's state, pooled",
    "hw_precision": ("per scenario, from the hw run's manifest: the target of the 95 % "
                     "confidence interval of each slowdown (hw.precision_pct, in % of the "
                     "slowdown; null: fixed repetitions), the cap (hw.max_repetitions), the "
                     "fewest and most repetitions a point took, and the run's summary line"),
}
STATE_KEYS = ("before", "after", "model", "matches", "waited_s", "attempts", "alike", "other_way",
              "speed_before", "speed_after")


@dataclass
class Pair:
    """One node of one point: its slowdown measured (hw) and simulated (sim)."""

    scenario: str
    point: str
    node: str          # "rt" | "nrt"
    hw: Stat
    sim: Stat
    band_low: float = math.nan    # the sim's prediction band (NaN: none)
    band_high: float = math.nan
    index: int = 0     # which RT / nRT node of the point (nRT: 0 nrt_, 1 nrt1_, ...)
    name: str = ""     # the node's name in the scenario ("" when the manifest does not say)
    corunners: int = 1  # k: the point's nRT nodes
    iso_hw: float = math.nan    # the node's mean isolation time, hw and sim (NaN: not given)
    iso_sim: float = math.nan

    @property
    def has_band(self) -> bool:
        return math.isfinite(self.band_low) and math.isfinite(self.band_high)

    @property
    def error_pct(self) -> float:
        """|s_sim - s_hw| / s_hw x 100 (signed: sim - hw)."""
        return 100.0 * (self.sim.mean - self.hw.mean) / self.hw.mean

    @property
    def excess_error_pct(self) -> float:
        """Signed relative error of the excess slowdown in %, NaN where the measured excess
        is below EXCESS_MIN."""
        excess = self.hw.mean - 1.0
        if excess < EXCESS_MIN:
            return math.nan
        return 100.0 * ((self.sim.mean - 1.0) - excess) / excess

    @property
    def excess_resolved(self) -> bool:
        """Whether the hw repetitions resolve an excess of at least EXCESS_MIN: the lower end
        of the 95 % confidence interval of the hw mean (Student's t) is at least 1 +
        EXCESS_MIN. One repetition resolves nothing."""
        if self.hw.n < 2 or not math.isfinite(self.hw.std):
            return False
        half = float(scipy.stats.t.ppf(0.975, self.hw.n - 1)) * self.hw.std / math.sqrt(self.hw.n)
        return self.hw.mean - half - 1.0 >= EXCESS_MIN

    @property
    def isolation_offset_pct(self) -> float:
        """(the sim's isolation time / the hw run's - 1) x 100, NaN where either is missing."""
        if not (self.iso_hw > 0 and math.isfinite(self.iso_sim)):
            return math.nan
        return 100.0 * (self.iso_sim / self.iso_hw - 1.0)


def node_errors(pairs) -> dict:
    """The error figures of one node's pairs (see DEFINITIONS); NaN / None where empty."""
    summary = compare.error_summary([(p.point, p.hw.mean, p.sim.mean) for p in pairs])
    excess = [abs(p.excess_error_pct) for p in pairs if math.isfinite(p.excess_error_pct)]
    resolved = [abs(p.excess_error_pct) for p in pairs if p.excess_resolved]
    spread = [100.0 * (p.hw.max - p.hw.min) / p.hw.mean for p in pairs if p.hw.n > 1]
    offset = [p.isolation_offset_pct for p in pairs if math.isfinite(p.isolation_offset_pct)]
    return {
        "pairs": summary.pairs,
        "mape_pct": summary.mape_pct,
        "bias": summary.mean_error,
        "max_abs_error": summary.max_abs_error,
        "max_abs_error_point": summary.max_abs_error_point,
        "spearman": summary.spearman,
        "excess_pairs": len(excess),
        "excess_error_pct": float(np.mean(excess)) if excess else math.nan,
        "excess_error_max_pct": float(np.max(excess)) if excess else math.nan,
        "excess_resolved_pairs": len(resolved),
        "excess_error_resolved_pct": float(np.mean(resolved)) if resolved else math.nan,
        "hw_spread_pct": float(np.median(spread)) if spread else math.nan,
        "isolation_offset_pct": float(np.mean(offset)) if offset else math.nan,
    }


def goal_marks(errors: dict) -> dict:
    """goal key -> {'value', 'bound', 'status': 'met' | 'missed' | 'n/a'}."""
    marks = {}
    for key, (node, metric, bound, _) in GOALS.items():
        value = errors[node][metric]
        status = "n/a" if not math.isfinite(value) else ("met" if value <= bound else "missed")
        marks[key] = {"value": value, "bound": bound, "status": status}
    return marks


def scenario_pairs(name: str, hw, sim, band=None) -> tuple:
    """([Pair], Comparison) of one scenario's loaded hw and sim folders: one pair per common
    point and node, every RT and every nRT node (nrt_slowdown, nrt1_slowdown, ...), each with
    its index, its name, the point's number of nRT nodes (k) and the node's mean isolation time
    on each side. ``band`` (compare.Band of the sim folder, or None) gives each pair its
    band."""
    comp = compare.compare_results(hw, sim)
    corunners = sum(1 for n in comp.nodes if n.role == "nrt")
    pairs = []
    for pa, pb in comp.common:
        for n in comp.nodes:   # every node, under its role: nRT errors are over all nRT nodes
            a, b = pa.stat(n.metric), pb.stat(n.metric)
            if a and b and a.mean != 0:
                low, high = band.of(pb.id, n.key) if band is not None else (math.nan, math.nan)
                pairs.append(Pair(name, pa.id, n.role, a, b, low, high, n.index, n.name,
                                  corunners, pa.mean(n.column("isolation_us")),
                                  pb.mean(n.column("isolation_us"))))
    return pairs, comp


def band_variants(band_root) -> list:
    """The band platforms' folders of a band root (BAND_ROOT/<variant>/), sorted by name."""
    band_root = Path(band_root)
    if not band_root.is_dir():
        raise InvalidInput(f"{band_root}: no such folder (the band runs' root)")
    return sorted(p.name for p in band_root.iterdir() if p.is_dir())


def scenario_band(name: str, sim, band_root, variants) -> tuple:
    """(compare.Band or None, [variant names used], [warning lines]) of one scenario: its sim
    runs on the band platforms, BAND_ROOT/<variant>/<name>/; a variant without a usable run of
    the scenario is left out, with a warning."""
    runs, used, warnings = [], [], []
    ids = {p.id for p in sim.points}
    for variant in variants:
        folder = Path(band_root) / variant / name
        if not (folder / "manifest.json").is_file():
            warnings.append(f"{name}: no run on band platform {variant} ({folder} missing); "
                            "the band is made from the others")
            continue
        try:
            run = load_results(folder)
        except InvalidInput as e:
            warnings.append(f"{name}: the run on band platform {variant} cannot be read ({e}); "
                            "the band is made from the others")
            continue
        if not ids & {p.id for p in run.points}:
            warnings.append(f"{name}: the run on band platform {variant} shares no point with "
                            "the sim run; left out")
            continue
        runs.append(run)
        used.append(variant)
    if not runs:
        return None, used, warnings
    band = compare.prediction_band(sim, runs)
    warnings += [f"{name}: {line}" for line in compare.band_warnings(band, len(sim.points))]
    return band, used, warnings


def band_coverage(pairs) -> dict:
    """Per node: compare.band_coverage of the pairs' hw means against their bands."""
    return {node: compare.band_coverage([(p.hw.mean, p.band_low, p.band_high) for p in pairs
                                         if p.node == node]) for node in ("rt", "nrt")}


def _errors(pairs) -> dict:
    return {node: node_errors([p for p in pairs if p.node == node]) for node in ("rt", "nrt")}


def per_node(pairs) -> list:
    """The nRT-slowdown errors of each nRT node of the pairs (one scenario's): [{'index',
    'name', **node_errors}] in node order."""
    indices = sorted({p.index for p in pairs if p.node == "nrt"})
    out = []
    for index in indices:
        mine = [p for p in pairs if p.node == "nrt" and p.index == index]
        out.append({"index": index, "name": mine[0].name, **node_errors(mine)})
    return out


def per_k(scenarios, pairs) -> list:
    """The errors per number of co-runners k (the scenarios' nRT nodes), every scenario with
    that k pooled: [{'k', 'scenarios', 'points', 'rt', 'nrt' (every co-runner's pairs),
    'nrt_nodes' ({'nodes', 'min_mape_pct', 'max_mape_pct', 'worst'}: the nRT MAPE of each
    node of each scenario), 'goals'}], by k."""
    out = []
    for k in sorted({s["corunners"] for s in scenarios}):
        names = [s["name"] for s in scenarios if s["corunners"] == k]
        mine = [p for p in pairs if p.scenario in names]
        errors = _errors(mine)
        nodes = [(s["name"], n) for s in scenarios if s["corunners"] == k
                 for n in s["nrt_nodes"] if math.isfinite(n["mape_pct"])]
        worst = max(nodes, key=lambda sn: sn[1]["mape_pct"]) if nodes else None
        out.append({
            "k": k, "scenarios": names,
            "points": sum(s["common_points"] for s in scenarios if s["corunners"] == k),
            **errors,
            "nrt_nodes": {
                "nodes": len(nodes),
                "min_mape_pct": min(n["mape_pct"] for _, n in nodes) if nodes else math.nan,
                "max_mape_pct": max(n["mape_pct"] for _, n in nodes) if nodes else math.nan,
                "worst": (f"{worst[0]}/{worst[1]['name'] or 'nrt' + str(worst[1]['index'])}"
                          if worst else None)},
            "goals": goal_marks(errors),
        })
    return out


def _is_number(value) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool) and \
        math.isfinite(value)


def _state_problem(data) -> str:
    """What makes ``data`` (a parsed STATE_DIR/<scenario>.json) not a machine-state file; ''
    when nothing does. Any value may be missing or null."""
    if not isinstance(data, dict):
        return "not a JSON object"
    checks = [("waited_s", data.get("waited_s"), (_is_number, "a number")),
              ("attempts", data.get("attempts"),
               (lambda v: isinstance(v, int) and not isinstance(v, bool), "a whole number"))]
    for key in ("before", "after"):
        probe = data.get(key)
        if probe is not None and not isinstance(probe, dict):
            return f"'{key}' is not an object"
        model = (probe or {}).get("model")
        if model is not None and not isinstance(model, dict):
            return f"'{key}.model' is not an object"
        reverse = (probe or {}).get("reverse")
        if reverse is not None and not isinstance(reverse, dict):
            return f"'{key}.reverse' is not an object"
        checks += [(f"{key}.ratio", (probe or {}).get("ratio"), (_is_number, "a number")),
                   (f"{key}.matches", (probe or {}).get("matches"),
                    (lambda v: isinstance(v, bool), "true or false")),
                   (f"{key}.alike", (probe or {}).get("alike"),
                    (lambda v: isinstance(v, bool), "true or false")),
                   (f"{key}.reverse.ratio", (reverse or {}).get("ratio"),
                    (_is_number, "a number")),
                   (f"{key}.speed_offset_pct", (probe or {}).get("speed_offset_pct"),
                    (_is_number, "a number")),
                   (f"{key}.model.ratio", (model or {}).get("ratio"), (_is_number, "a number"))]
    for where, value, (ok, words) in checks:
        if value is not None and not ok(value):
            return f"'{where}' is {json.dumps(value)}, not {words} or null"
    return ""


def machine_state(state_dir, name: str) -> dict:
    """The machine state of scenario ``name`` during its hw run (STATE_KEYS): the contention
    probes' ratios before and after it and the model's, whether both found the model's state
    (True), either did not (False) or that is not known (None), how long validate waited for
    it and how many times it ran the scenario; from STATE_DIR/<name>.json (tools/validate.sh).
    Every value None without the folder or the file; InvalidInput when the file is not one."""
    state = dict.fromkeys(STATE_KEYS)
    path = Path(state_dir) / f"{name}.json" if state_dir is not None else None
    if path is None or not path.is_file():
        return state
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError) as e:
        raise InvalidInput(f"{path}: cannot read a machine-state file ({e})") from e
    problem = _state_problem(data)
    if problem:
        raise InvalidInput(f"{path}: not a machine-state file ({problem}); tools/validate.sh "
                           "writes one per scenario")
    probes = [data.get("before") or {}, data.get("after") or {}]
    flags = [probe.get("matches") for probe in probes]
    models = [(probe.get("model") or {}).get("ratio") for probe in probes]
    alike = [probe.get("alike") for probe in probes]
    # The other way's ratio: of the first probe that found the CPUs slowed differently, else of
    # the first that has one.
    unlike = [p for p in probes if p.get("alike") is False] + probes
    other_way = next(((p.get("reverse") or {}).get("ratio") for p in unlike
                      if (p.get("reverse") or {}).get("ratio") is not None), None)
    state.update(before=probes[0].get("ratio"), after=probes[1].get("ratio"),
                 model=next((r for r in models if r is not None), None),
                 matches=False if False in flags else (True if flags == [True, True] else None),
                 waited_s=data.get("waited_s"), attempts=data.get("attempts"),
                 alike=False if False in alike else (True if alike == [True, True] else None),
                 other_way=other_way, speed_before=probes[0].get("speed_offset_pct"),
                 speed_after=probes[1].get("speed_offset_pct"))
    return state


def _pooled(pairs) -> dict:
    """The errors of the pairs (every scenario's pooled) with their goal marks."""
    errors = _errors(pairs)
    return {**errors, "goals": goal_marks(errors)}


def _description(results) -> str:
    scenario = (results.manifest.get("scenario") or {}).get("given") or {}
    return str(scenario.get("description", "")) if isinstance(scenario, dict) else ""


def _precision(results) -> dict:
    """The hw run's precision (its manifest's ``precision``): the CI target (None: fixed
    repetitions), the cap, the fewest and most repetitions a point took, and the summary line;
    every value None in a run without it."""
    p = results.manifest.get("precision") or {}
    reps = [q.get("repetitions") for q in (p.get("points") or {}).values()
            if isinstance(q, dict) and _is_number(q.get("repetitions"))]
    return {"target_pct": p.get("target_pct"), "max_repetitions": p.get("max_repetitions"),
            "fewest": min(reps) if reps else None, "most": max(reps) if reps else None,
            "summary": p.get("summary")}


def build_report(hw_root, sim_root, names=None, failed=(), notes=(), now=None,
                 cpu=None, band_root=None, skipped=(), state_dir=None) -> tuple:
    """(report dict, [Pair]) for the scenarios in ``names`` (default: every folder of
    hw_root). ``failed``: [{'scenario', 'reason'}] of scenarios that could not be run;
    ``skipped``: [{'scenario', 'reason'}] of those not run on purpose (e.g. more CPUs than
    the host has). A
    scenario whose folders are missing or share no point is added to them; the others are
    compared. ``notes``: lines about the conditions (e.g. the load), shown with the host.
    ``cpu``: the machine's CPU as lscpu names it (default: the hw manifest's cpu_model).
    ``band_root``: BAND_ROOT/<variant>/<scenario>/, the sim runs on the band platforms (see
    the module docstring); None, or a root without variant folders: no band. ``state_dir``:
    STATE_DIR/<scenario>.json, the machine state of each compared scenario's hw run
    (``machine_state``); None: not probed."""
    variants = band_variants(band_root) if band_root is not None else []
    band_warnings = []
    hw_root, sim_root = Path(hw_root), Path(sim_root)
    if names is None:
        if not hw_root.is_dir():
            raise InvalidInput(f"{hw_root}: no such folder")
        names = sorted(p.name for p in hw_root.iterdir() if (p / "manifest.json").is_file())
    failed = list(failed)
    if not names and not failed and not skipped:
        raise InvalidInput(f"{hw_root}: no results folder to validate")
    scenarios, pairs, manifests, sim_manifests = [], [], [], []
    for name in names:
        try:
            hw, sim = load_results(hw_root / name), load_results(sim_root / name)
            band, used, warned = scenario_band(name, sim, band_root, variants) \
                if variants else (None, [], [])
            found, comp = scenario_pairs(name, hw, sim, band)
        except InvalidInput as e:
            failed.append({"scenario": name, "reason": str(e)})
            continue
        state = machine_state(state_dir, name)
        band_warnings += warned
        manifests.append(hw.manifest)
        sim_manifests.append(sim.manifest)
        pairs += found
        errors = _errors(found)
        scenarios.append({
            "name": name,
            "description": _description(hw),
            "corunners": len(nodes_of(hw, "nrt")),
            "nrt_nodes": per_node(found),
            "hw": compare._side(hw),
            "sim": compare._side(sim),
            "repetitions": {"hw": hw.repetitions, "sim": sim.repetitions},
            "hw_precision": _precision(hw),
            "common_points": len(comp.common),
            "only_hw": [p.id for p in comp.only_a],
            "only_sim": [p.id for p in comp.only_b],
            "settings_mismatch": len(comp.mismatches),
            **errors,
            "goals": goal_marks(errors),
            **({"band": {"variants": used, **band_coverage(found)}} if variants else {}),
            "machine_state": state,
        })
    matched = [s["name"] for s in scenarios if s["machine_state"]["matches"] is True]
    manifest = manifests[0] if manifests else {}
    starts = sorted(str(m["start_time"]) for m in manifests if m.get("start_time"))
    ends = sorted(str(m["end_time"]) for m in manifests if m.get("end_time"))
    report = {
        "schema_version": REPORT_SCHEMA_VERSION,
        "generated": (now or datetime.now(timezone.utc)).strftime("%Y-%m-%dT%H:%M:%SZ"),
        "measured_from": starts[0] if starts else None,
        "measured_to": ends[-1] if ends else None,
        "notes": list(notes),
        "host": manifest.get("host") or {},
        "cpu": cpu or (manifest.get("host") or {}).get("cpu_model"),
        "sim_model_machine": _sim_model_machine(sim_manifests),
        "rosguard": manifest.get("tool") or {},
        "platform": {"hw": scenarios[0]["hw"]["platform"] if scenarios else None,
                     "sim": scenarios[0]["sim"]["platform"] if scenarios else None},
        "hw_root": str(hw_root),
        "sim_root": str(sim_root),
        "state_dir": str(state_dir) if state_dir is not None else None,
        "goals": {k: {"node": n, "metric": m, "bound_pct": b, "words": w}
                  for k, (n, m, b, w) in GOALS.items()},
        "excess_min": EXCESS_MIN,
        "definitions": DEFINITIONS,
        "overall": _pooled(pairs),
        "per_k": per_k(scenarios, pairs),
        "scenarios": scenarios,
        "failed": failed,
        "skipped": list(skipped),
        "points": [{"scenario": p.scenario, "point": p.point, "node": p.node,
                    "index": p.index, "name": p.name, "corunners": p.corunners,
                    "hw_mean": p.hw.mean, "hw_min": p.hw.min, "hw_max": p.hw.max,
                    "hw_reps": p.hw.n, "sim_mean": p.sim.mean, "sim_min": p.sim.min,
                    "sim_max": p.sim.max, "sim_reps": p.sim.n, "error_pct": p.error_pct,
                    "excess_error_pct": p.excess_error_pct,
                    "excess_resolved": p.excess_resolved,
                    "isolation_offset_pct": p.isolation_offset_pct,
                    **({"band_low": p.band_low, "band_high": p.band_high} if variants else {})}
                   for p in pairs],
    }
    if variants:
        report["band"] = {"root": str(band_root), "variants": variants,
                          "definition": compare.BAND_DEFINITION,
                          "coverage": ("share of points (with a band) whose hw mean lies in "
                                       "the band, low <= hw <= high, in %"),
                          "median_width": ("median over points of high - low, in slowdown "
                                           "units (x isolation)"),
                          "warnings": band_warnings, **band_coverage(pairs)}
    if matched and any(s["machine_state"]["matches"] is False for s in scenarios):
        report["in_model_state"] = {
            "scenarios": matched,
            "points": sum(s["common_points"] for s in scenarios if s["name"] in matched),
            **_pooled([p for p in pairs if p.scenario in matched])}
    return report, pairs


def _sim_model_machine(manifests):
    """The sim runs' host model against the machine they ran on ("platform": "host": the
    manifest's host_platform.sim.machine, written by rosguard since models record their
    machine): the first run's record, or None when no run used a host model."""
    for m in manifests:
        machine = ((m.get("host_platform") or {}).get("sim") or {}).get("machine")
        if isinstance(machine, dict):
            return machine
    return None


def _model_line(report: dict) -> str:
    """'' when the sim model is of this machine (or no host model was used); else what is
    wrong with it, for the report and the README block."""
    machine = report.get("sim_model_machine")
    if not isinstance(machine, dict) or machine.get("matches") is True:
        return ""
    if machine.get("measured_on") is None:
        return ("the sim's host model does not record which machine it was measured on, so it "
                "may not be this one")
    return ("the sim's host model was measured on another machine: "
            + "; ".join(str(d) for d in machine.get("differences") or []))


def _clean(value):
    """JSON-safe: NaN / inf -> None, recursively."""
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, dict):
        return {k: _clean(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_clean(v) for v in value]
    return value


def pct(value, digits: int = 1) -> str:
    """12.345 -> '12.3 %', None / NaN -> 'n/a'."""
    if value is None or not math.isfinite(value):
        return "n/a"
    return f"{value:.{digits}f} %"


def _mark(goal: dict) -> str:
    return {"met": "met", "missed": "**missed**"}.get(goal["status"], "n/a")


def _cell(errors: dict, goals: dict, node: str, metric: str) -> str:
    key = f"{node}_{'mape' if metric == 'mape_pct' else 'excess'}"
    value = errors[node][metric]
    if value is None or not math.isfinite(value):
        return "n/a"
    extra = f" (n={errors[node]['excess_pairs']})" if metric == "excess_error_pct" else ""
    # Two decimals where one would round onto the bound (5.03 % missed, not "5.0 % missed").
    digits = 2 if abs(value - goals[key]["bound"]) < 0.05 else 1
    return f"{pct(value, digits)}{extra} {_mark(goals[key])}"


def _state_of(scenario: dict) -> dict:
    """A scenario's machine_state (every value None in a report from before the probes)."""
    return scenario.get("machine_state") or dict.fromkeys(STATE_KEYS)


def _probed(state: dict) -> bool:
    return any(state[k] is not None for k in ("before", "after", "matches"))


def _ratio(value) -> str:
    return f"{value:.2f}x" if _finite(value) else "n/a"


def _state_cell(state: dict) -> str:
    """'1.72x / 1.70x, model 1.74x' (before / after the hw run, the model's; then the host's
    speed against the model's, '; speed -24.1 % / -3.0 %', where the probes measured it), in
    bold with ': differs' when the probes found another state, '; the other way 1.05x: CPUs
    unlike' after it when a probe found the two CPUs slowed differently; 'not probed'."""
    if not _probed(state):
        return "not probed"
    text = (f"{_ratio(state['before'])} / {_ratio(state['after'])}, model "
            f"{_ratio(state['model'])}")
    speeds = (state.get("speed_before"), state.get("speed_after"))
    if any(v is not None for v in speeds):
        text += "; speed " + " / ".join(_signed_pct(v) for v in speeds)
    text = f"**{text}: differs**" if state["matches"] is False else text
    if state.get("alike") is False:
        text += f"; the other way {_ratio(state.get('other_way'))}: CPUs unlike"
    return text


def state_summary(report: dict, short: bool = False) -> str:
    """One line on the machine state of the scenarios' hw runs: how many were measured in the
    model's DRAM-interference state, how long validate waited for it, which scenarios were
    measured in another and which are not known; ``short`` (the README): without the probe's
    description and the wait."""
    states = {s["name"]: _state_of(s) for s in report["scenarios"]}
    if not any(_probed(state) for state in states.values()):
        return "machine state: not probed" + ("" if short else (
            " (the DRAM interference between the CPUs during the hw runs is not known)"))
    named = {flag: ", ".join(n for n, state in states.items() if state["matches"] is flag)
             for flag in (False, None)}
    matched = sum(1 for state in states.values() if state["matches"] is True)
    line = (f"machine state: {matched} of {len(states)} scenarios measured in the model's "
            "DRAM-interference state")
    waited = [state["waited_s"] for state in states.values() if _finite(state["waited_s"])]
    if not short:
        line += f" (the probe: {PROBE_WORDS}, before and after each hw run)"
        line += f"; waited {sum(waited):.0f} s for it" if waited else ""
    if named[False]:
        line += (f". In another state: {named[False]}; their errors compare the model with the "
                 "machine in another state")
    if named[None]:
        line += f". Not known for {named[None]}"
    return line


def summary_table(report: dict) -> list:
    """Markdown lines: one row per scenario, one for the whole suite and, when some scenarios
    were measured in the model's machine state and some in another, one for the former."""
    lines = ["| scenario | points | RT MAPE (≤ 5 %) | nRT MAPE (≤ 10 %) | RT excess error "
             "(≤ 20 %) | nRT excess error (≤ 20 %) | hw noise RT / nRT | isolation offset "
             "RT / nRT | DRAM state (beside one reader) |",
             "|---|---:|---:|---:|---:|---:|---:|---:|---|"]
    scenarios = report["scenarios"]
    rows = [(s["name"], s["common_points"], s, _state_cell(_state_of(s))) for s in scenarios]
    matched = sum(1 for s in scenarios if _state_of(s)["matches"] is True)
    rows.append(("**all**", sum(s["common_points"] for s in scenarios), report["overall"],
                 f"{matched} of {len(scenarios)} in the model's state"
                 if any(_probed(_state_of(s)) for s in scenarios) else "not probed"))
    if report.get("in_model_state"):
        mine = report["in_model_state"]
        rows.append(("**in the model's state**", mine["points"], mine,
                     f"{len(mine['scenarios'])} scenario(s)"))
    for name, points, errors, state in rows:
        goals = errors["goals"]
        lines.append(
            f"| {name} | {points} | {_cell(errors, goals, 'rt', 'mape_pct')} | "
            f"{_cell(errors, goals, 'nrt', 'mape_pct')} | "
            f"{_cell(errors, goals, 'rt', 'excess_error_pct')} | "
            f"{_cell(errors, goals, 'nrt', 'excess_error_pct')} | "
            f"{pct(errors['rt']['hw_spread_pct'])} / {pct(errors['nrt']['hw_spread_pct'])} | "
            f"{_signed_pct(errors['rt'].get('isolation_offset_pct'))} / "
            f"{_signed_pct(errors['nrt'].get('isolation_offset_pct'))} | {state} |")
    return lines


def per_k_table(report: dict) -> list:
    """Markdown lines: one row per number of co-runners k."""
    lines = ["| k | scenarios | points | RT MAPE (≤ 5 %) | nRT MAPE, all co-runners (≤ 10 %) | "
             "nRT MAPE per node (min–max) | hw noise RT / nRT |",
             "|---:|---|---:|---:|---:|---:|---:|"]
    for row in report.get("per_k") or []:
        nodes = row["nrt_nodes"]
        spread = (f"{pct(nodes['min_mape_pct'])} – {pct(nodes['max_mape_pct'])} "
                  f"({nodes['nodes']} nodes; worst {nodes['worst']})"
                  if nodes["nodes"] > 1 else pct(nodes["min_mape_pct"]))
        lines.append(
            f"| {row['k']} | {', '.join(row['scenarios'])} | {row['points']} | "
            f"{_cell(row, row['goals'], 'rt', 'mape_pct')} | "
            f"{_cell(row, row['goals'], 'nrt', 'mape_pct')} | {spread} | "
            f"{pct(row['rt']['hw_spread_pct'])} / {pct(row['nrt']['hw_spread_pct'])} |")
    return lines


def _host_line(report: dict) -> str:
    host = report.get("host") or {}
    tool = report.get("rosguard") or {}
    cpu = report.get("cpu") or host.get("cpu_model")
    parts = [str(v) for v in (host.get("hostname"), cpu, host.get("kernel")) if v]
    if host.get("cpus_online"):
        parts.append(f"{host['cpus_online']} CPUs online")
    version = " ".join(str(tool.get(k)) for k in ("version", "git_revision") if tool.get(k))
    notes = "".join(f"; {n}" for n in [*(report.get("notes") or []), _model_line(report)] if n)
    when = report.get("measured_from") or "?"
    if report.get("measured_to"):
        when += f" to {report['measured_to']}"
    return (f"measured {when} on {', '.join(parts) or '?'}; "
            f"rosguard {version or '?'}; platform hw `{report['platform']['hw']}`, "
            f"sim `{report['platform']['sim']}`{notes}")


def resolved_summary(errors: dict) -> str:
    """One sentence: the excess error over the points whose excess the hw repetitions resolve,
    per node, against all the points with a measured excess (``errors``: a node_errors pair)."""
    def part(node):
        e = errors[node]
        return (f"{NODE_WORDS[node]} {pct(e.get('excess_error_resolved_pct'))} "
                f"({e.get('excess_resolved_pairs', 0)} of {e['excess_pairs']} points)")
    return (f"Excess error where the hw repetitions resolve the excess (the 95 % confidence "
            f"interval of the hw mean above {1 + EXCESS_MIN:g}; not a goal): {part('rt')}, "
            f"{part('nrt')}. A point with a measured excess ≥ {EXCESS_MIN:g} that is not "
            "resolved may owe it to the noise alone")


def verdict(report: dict) -> str:
    """One line: goals met / missed over the whole suite."""
    goals = report["overall"]["goals"]
    missed = [GOALS[k][3] for k, g in goals.items() if g["status"] == "missed"]
    met = sum(1 for g in goals.values() if g["status"] == "met")
    if not missed:
        return f"all {met} goals met over the suite"
    return f"{met} of {len(goals)} goals met over the suite; missed: {', '.join(missed)}"


def _hw_repetitions(scenario: dict) -> str:
    """'5' for fixed repetitions; '5-10' where adaptive rounds gave points different counts."""
    p = scenario.get("hw_precision") or {}
    fewest, most = p.get("fewest"), p.get("most")
    if fewest is not None and most is not None and fewest != most:
        return f"{fewest}-{most}"
    return str(scenario["repetitions"]["hw"])


def markdown(report: dict) -> str:
    """report.md."""
    lines = ["# rosguard validation: sim vs hw", "",
             f"**{headline(report)}.** " + _host_line(report)
             + f"; report generated {report['generated']}.", "",
             f"**{verdict(report)}.**", "",
             "Goals: RT-slowdown MAPE ≤ 5 %, nRT-slowdown MAPE ≤ 10 %, and the error on the "
             f"excess slowdown (slowdown − 1) ≤ 20 % where the measured excess is ≥ "
             f"{EXCESS_MIN:g} (mean over those points). hw noise: median spread "
             "(max − min) / mean of a point's hw repetitions. Isolation offset: the model's "
             "isolation time of the node over the one the hw run measured, − 1 (mean over "
             "points; positive: the model runs the kernel slower than the host did). A "
             "regulated nRT node's co-run time is set by its budget, not by its kernel's "
             "speed, so its slowdown error follows this offset with the opposite sign: an "
             "offset beyond the nRT goal misses it however right the interference model is.",
             ""]
    lines += summary_table(report)
    lines += ["", resolved_summary(report["overall"]) + ".", "", state_summary(report) + "."]
    lines += ["", "## Errors per number of co-runners (k)", "",
              "k: the scenario's nRT nodes (co-runners of the RT node). The nRT MAPE pools "
              "every co-runner's pairs; per node: the nRT MAPE of each co-runner of each "
              "scenario with that k, lowest and highest.", "", *per_k_table(report)]
    if report.get("skipped"):
        lines += ["", "## Skipped", ""]
        lines += [f"- **{f['scenario']}**: {f['reason']}" for f in report["skipped"]]
    if report.get("band"):
        lines += ["", "## Prediction band", "", *band_section(report)]
    lines += ["", "## Scenarios", ""]
    for s in report["scenarios"]:
        lines.append(f"- **{s['name']}** ({s['common_points']} points, hw x"
                     f"{_hw_repetitions(s)} / sim x{s['repetitions']['sim']} repetitions; "
                     f"hw status {s['hw']['status']}, sim {s['sim']['status']}): "
                     f"{s['description']}")
        if (s.get("hw_precision") or {}).get("summary"):
            lines.append(f"  - hw precision: {s['hw_precision']['summary']}")
        for node in ("rt", "nrt"):
            e = s[node]
            if e["pairs"]:
                lines.append(f"  - {node.upper() if node == 'rt' else 'nRT'}: bias "
                             f"{e['bias']:+.3f}, max |sim − hw| {e['max_abs_error']:.3f} at "
                             f"{e['max_abs_error_point']}, excess error max "
                             f"{pct(e['excess_error_max_pct'])}")
        if len(s.get("nrt_nodes") or []) > 1:
            lines.append("  - nRT MAPE per node: " + ", ".join(
                f"{n['name'] or 'nrt' + str(n['index'])} {pct(n['mape_pct'])}"
                for n in s["nrt_nodes"]))
        if s["only_hw"] or s["only_sim"] or s["settings_mismatch"]:
            lines.append(f"  - unmatched: {len(s['only_hw'])} point(s) only in hw, "
                         f"{len(s['only_sim'])} only in sim, {s['settings_mismatch']} with "
                         "different settings")
    if report["failed"]:
        lines += ["", "## Not compared", ""]
        lines += [f"- **{f['scenario']}**: {f['reason']}" for f in report["failed"]]
    banded = bool(report.get("band"))
    lines += ["", "## Points", "",
              "Means over repetitions; hw min–max beside the hw mean"
              + ("; the sim's prediction band beside the sim mean." if banded else "."), "",
              "| scenario | point | node | hw | hw min–max | sim | "
              + ("sim band | " if banded else "") + "error | excess error | isolation offset |",
              "|---|---|---|---:|---:|---:|" + ("---:|" if banded else "") + "---:|---:|---:|"]
    for p in report["points"]:
        band = f" {_range(p.get('band_low'), p.get('band_high'))} |" if banded else ""
        node = p["node"] if p.get("corunners", 1) <= 1 or p["node"] == "rt" else \
            f"{p['node']} {p.get('name') or p.get('index')}"
        lines.append(f"| {p['scenario']} | {p['point']} | {node} | "
                     f"{p['hw_mean']:.3f} | {p['hw_min']:.3f}–{p['hw_max']:.3f} | "
                     f"{p['sim_mean']:.3f} |{band} {p['error_pct']:+.1f} % | "
                     f"{_signed_pct(p['excess_error_pct'])} | "
                     f"{_signed_pct(p.get('isolation_offset_pct'))} |")
    lines += ["", f"Figure: [{FIGURE_STEM}.png]({FIGURE_STEM}.png) "
              f"([PDF]({FIGURE_STEM}.pdf)).", "",
              "Definitions: " + "; ".join(f"`{k}`: {v}" for k, v in DEFINITIONS.items()) + "."]
    return "\n".join(lines) + "\n"


def _finite(value) -> bool:
    return isinstance(value, (int, float)) and math.isfinite(value)


def _range(low, high) -> str:
    """'1.020–1.080', or '–' without a band."""
    if not (_finite(low) and _finite(high)):
        return "–"
    return f"{low:.3f}–{high:.3f}"


def _coverage(c: dict) -> str:
    """'4 of 5 (80 %)', or 'n/a' without points with a band."""
    if not c or not c.get("points"):
        return "n/a"
    return f"{c['covered']} of {c['points']} ({c['coverage_pct']:.0f} %)"


def _width(c: dict) -> str:
    value = (c or {}).get("median_width")
    return f"{value:.3f}" if _finite(value) else "n/a"


def band_summary(report: dict) -> str:
    """One sentence on the band over the suite: 'prediction band (6 band platforms): hw inside
    it at RT 30 of 37 points (81 %), median width 0.012; nRT ...'; '' without a band."""
    band = report.get("band")
    if not band:
        return ""
    return (f"prediction band ({len(band['variants'])} band platform(s) of the sim model): hw "
            "inside it at " + "; ".join(
                f"{NODE_WORDS[node]} {_coverage(band[node])} points, median width "
                f"{_width(band[node])}" for node in ("rt", "nrt")))



def band_section(report: dict) -> list:
    """report.md's band section: what the band is, the coverage and width table, warnings."""
    band = report["band"]
    lines = [f"The sim model has prior-dominated parameters; `rosguard calibrate` wrote "
             f"{len(band['variants'])} band platform(s) for them ("
             + ", ".join(f"`{v}`" for v in band["variants"]) + "), and every scenario also ran "
             "in sim on each. The band of a point: " + band["definition"] + ". Coverage: the "
             "points whose hw mean lies inside their band; width: high − low in slowdown units "
             "(× isolation). A narrow band that misses the hw mean says the error lies beyond "
             "what the prior-dominated parameters move, one at a time.", "",
             "| scenario | band runs | RT coverage | RT median width | nRT coverage | "
             "nRT median width |", "|---|---:|---:|---:|---:|---:|"]
    rows = [(s["name"], len(s.get("band", {}).get("variants", [])), s.get("band", {}))
            for s in report["scenarios"]]
    rows.append(("**all**", len(band["variants"]), band))
    for name, runs, b in rows:
        lines.append(f"| {name} | {runs} | {_coverage(b.get('rt'))} | {_width(b.get('rt'))} | "
                     f"{_coverage(b.get('nrt'))} | {_width(b.get('nrt'))} |")
    if band.get("warnings"):
        lines += [""] + [f"- warning: {w}" for w in band["warnings"]]
    return lines


def _signed_pct(value) -> str:
    if value is None or not math.isfinite(value):
        return "–"
    return f"{value:+.1f} %"


def headline(report: dict) -> str:
    """'Validated on 2026-11-26 on AMD EPYC (2 CPUs)': the day the suite ran and the CPU."""
    day = str(report.get("measured_from") or report.get("generated") or "?")[:10]
    host = report.get("host") or {}
    cpu = report.get("cpu") or host.get("cpu_model") or "an unknown CPU"
    cpus = f" ({host['cpus_online']} CPUs)" if host.get("cpus_online") else ""
    return f"Validated on {day} on {cpu}{cpus}"


def readme_section(report: dict, figure_path: str) -> str:
    """The README's validation block (between its markers): figure, the day and the CPU,
    verdict, the machine state, table."""
    band = band_summary(report)
    state = state_summary(report, short=True)
    return "\n".join([
        f"![sim vs hw validation]({figure_path})", "",
        f"**{headline(report)}.** {_host_line(report)}. "
        f"{verdict(report)[0].upper() + verdict(report)[1:]}."
        + (f" The sim's {band} (min..max over the model and the band platforms, one "
           "prior-dominated parameter ±1 standard error at a time)." if band else "")
        + f" {state[0].upper()}{state[1:]}.", "",
        *summary_table(report), "", resolved_summary(report["overall"]) + ".", ""])


def _figure(report: dict, pairs):
    names = [s["name"] for s in report["scenarios"]]
    overall = report["overall"]
    titles = {node: f"MAPE {pct(overall[node]['mape_pct'])} "
                    f"(goal ≤ {GOALS[node + '_mape'][2]:g} %: "
                    f"{overall['goals'][node + '_mape']['status']}), {overall[node]['pairs']} "
                    "points" for node in ("rt", "nrt")}
    titles["excess"] = (f"excess slowdown where measured ≥ {EXCESS_MIN:g}: error RT "
                        f"{pct(overall['rt']['excess_error_pct'])}, nRT "
                        f"{pct(overall['nrt']['excess_error_pct'])} (goal ≤ 20 %)")
    host = _host_line(report).replace("`", "")
    note = (f"{host}. Markers: mean over repetitions; error bars: min–max over "
            "repetitions; shaded: ±5 % / ±10 % (left, middle) and ±20 % (right) of the "
            "measured value.")
    band = report.get("band")
    if band:
        note += (f" Wide pale bars: the sim's prediction band, min..max over the model and its "
                 f"{len(band['variants'])} band platform(s) (one prior-dominated parameter ±1 "
                 "standard error at a time); hw inside it: RT "
                 f"{_coverage(band['rt'])}, nRT {_coverage(band['nrt'])} points.")
    return figure.draw(pairs, names, titles, EXCESS_MIN, note, report.get("per_k") or [],
                       {node: GOALS[node + "_mape"][2] for node in ("rt", "nrt")})


def run(hw_root, sim_root, out, names=None, failed=(), notes=(), stream=sys.stdout,
        cpu=None, band_root=None, skipped=(), state_dir=None) -> int:
    """Builds the report and writes report.json, report.md and the figure into ``out``; the
    machine state from ``state_dir`` (default: ``out``/state)."""
    out = Path(out)
    report, pairs = build_report(hw_root, sim_root, names, failed, notes, cpu=cpu,
                                 band_root=band_root, skipped=skipped,
                                 state_dir=state_dir if state_dir is not None else out / "state")
    out.mkdir(parents=True, exist_ok=True)
    written = style.save(_figure(report, pairs), out, FIGURE_STEM)
    report["figure"] = [p.name for p in written]
    (out / "report.json").write_text(json.dumps(_clean(report), indent=2) + "\n",
                                     encoding="utf-8")
    (out / "report.md").write_text(markdown(_clean(report)), encoding="utf-8")
    print("\n".join(summary_table(_clean(report))), file=stream)
    print("per number of co-runners k:", file=stream)
    print("\n".join(per_k_table(_clean(report))), file=stream)
    print(verdict(report), file=stream)
    print(state_summary(report), file=stream)
    if report.get("band"):
        print(band_summary(report), file=stream)
        for line in report["band"]["warnings"]:
            print(f"warning: {line}", file=stream)
    if _model_line(report):
        print(f"warning: {_model_line(report)}", file=stream)
    for f in report["failed"]:
        print(f"not compared: {f['scenario']}: {f['reason']}", file=stream)
    for f in report["skipped"]:
        print(f"skipped: {f['scenario']}: {f['reason']}", file=stream)
    print(f"written: {out / 'report.md'}, {out / 'report.json'}, "
          + ", ".join(str(p) for p in written), file=stream)
    return 0


def load_report(path) -> dict:
    """A report.json written by ``run``; InvalidInput when it is not one."""
    path = Path(path)
    try:
        report = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError) as e:
        raise InvalidInput(f"{path}: cannot read a validation report ({e})") from e
    if not isinstance(report, dict) or report.get("schema_version") != REPORT_SCHEMA_VERSION:
        raise InvalidInput(f"{path}: not a validation report (schema_version "
                           f"{REPORT_SCHEMA_VERSION} expected); run make validate")
    return _restore(report)


def _restore(value):
    """JSON null in the error figures back to NaN (what the formatting helpers expect)."""
    if isinstance(value, dict):
        return {k: (math.nan if v is None and k.endswith(("_pct", "bias", "spearman",
                                                           "max_abs_error", "value"))
                    else _restore(v)) for k, v in value.items()}
    if isinstance(value, list):
        return [_restore(v) for v in value]
    return value


def table(report_path, readme=None, figure_dir="docs/figures", stream=sys.stdout) -> int:
    """Prints the README block of a report.json; with ``readme``, writes it there between the
    markers and copies the figure (PNG and PDF) into figure_dir (README-relative link)."""
    report_path = Path(report_path)
    report = load_report(report_path)
    if readme is None:
        print(readme_section(report, f"{FIGURE_STEM}.png"), file=stream, end="")
        return 0
    readme = Path(readme)
    figure_dir = Path(figure_dir)
    sources = [report_path.parent / f"{FIGURE_STEM}{suffix}" for suffix in (".png", ".pdf")]
    for source in sources:
        if not source.is_file():
            raise InvalidInput(f"{source}: the report's figure is missing; run make validate")
    link = Path(os.path.relpath(figure_dir.resolve(), readme.resolve().parent)) / \
        f"{FIGURE_STEM}.png"
    # Everything checked (markers included) before anything is written.
    text = splice(readme.read_text(encoding="utf-8"), "validation",
                  readme_section(report, link.as_posix()), str(readme))
    figure_dir.mkdir(parents=True, exist_ok=True)
    for source in sources:
        (figure_dir / source.name).write_bytes(source.read_bytes())
    readme.write_text(text, encoding="utf-8")
    print(f"written: {readme} (validation block), {figure_dir / (FIGURE_STEM + '.png')}",
          file=stream)
    return 0
