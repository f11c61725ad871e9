"""Every nRT node, by name: the tidy per-node table, summary.csv, the printed table, per-node
figure panels and compare's errors per node, on a small folder with one RT and three nRT nodes
(the column layout model/results/results.cpp writes)."""

from __future__ import annotations

import csv
import io
import itertools
import json
import math

import matplotlib.pyplot as plt
import pytest

import resultgen
from analysis import compare, nodes, plot, style
from analysis.figures import plan_figures
from analysis.results import load_results

# (points.csv prefix, name, core, workload); the names differ from the workloads.
NODES = [("rt", "detector", 1, "mser"), ("nrt", "reader", 2, "bandwidth_read"),
         ("nrt1", "stereo", 3, "disparity"), ("nrt2", "tracker", 4, "tracking")]
NAMES = ["rt_name", "rt_core", "nrt_name", "nrt_core", "nrt_throttle_count",
         "nrt_throttled_us"]
NRT_NODE = ["workload", "name", "core", "time_us", "isolation_us", "slowdown", "isolation_n",
            "isolation_cv", "bandwidth_mbps", "throttle_count", "throttled_us",
            "slowdown_ci95_pct", "unregulated_time_us", "unregulated_slowdown"]
# The columns an older rosguard did not write for the second and later nodes.
NEWER = ("name", "core", "unregulated_time_us", "unregulated_slowdown")
THRESHOLDS = (10, 30)
POLICIES = ("interval", "monolithic")
REPS = 2


def slowdown(key: str, threshold: int, policy: str, rep: int, scale: dict) -> float:
    """A toy slowdown: nRT nodes slower at low thresholds and under monolithic, node i by i."""
    if key == "rt":
        return 1.0 + threshold / 300 + 0.001 * rep
    i = int(key[3:] or 0)
    base = 1.0 + (40 - threshold) / 20 * (1.5 if policy == "monolithic" else 1.0)
    return (base + 0.3 * i + 0.01 * rep) * scale.get(key, 1.0)


def unregulated(key: str) -> float:
    """A toy unregulated co-run: the RT node 1.5, nRT node i 2 + i / 4."""
    return 1.5 if key == "rt" else 2.0 + int(key[3:] or 0) / 4


def write_folder(folder, *, scale=None, names=True, first_nrt=("bandwidth_read",)):
    """A results folder of 4 points x 2 repetitions per workload of the first nRT node
    (``first_nrt``); ``scale``: {prefix: factor} on a node's slowdowns (a second side for
    compare); ``names=False``: the layout of an older rosguard (no name / core columns, the
    first node's throttling only as throttle_count)."""
    scale = scale or {}
    folder.mkdir(parents=True)
    header = (resultgen.FIXED_COLUMNS + resultgen.EXTRA_COLUMNS
              + (NAMES if names else []) + resultgen.UNREGULATED_COLUMNS
              + [f"nrt{i}_{c}" for i in (1, 2) for c in NRT_NODE
                 if names or c not in NEWER]
              + ["param:regulation.threshold_pct", "param:regulation.policy"])
    with (folder / "points.csv").open("w", newline="") as f:
        w = csv.writer(f, lineterminator="\n")
        w.writerow(header)
        for first, t, policy in itertools.product(first_nrt, THRESHOLDS, POLICIES):
            pid = f"p{t:02d}{policy[:4]}{first_nrt.index(first)}"
            for rep in range(REPS):
                cells = {"point": pid, "rep": rep, "backend": "sim", "policy": policy,
                         "sampling": "self", "scope": "core", "threshold_pct": t,
                         "sampling_period_us": 1000, "regulation_period_us": 5000,
                         "platform": "orin-agx", "nrt_mode": "loop",
                         "param:regulation.threshold_pct": t,
                         "param:regulation.policy": policy}
                for key, name, core, workload in NODES:
                    workload = first if key == "nrt" else workload
                    s = slowdown(key, t, policy, rep, scale)
                    cells.update({f"{key}_workload": workload, f"{key}_name": name,
                                  f"{key}_core": core, f"{key}_isolation_us": 1000.0,
                                  f"{key}_time_us": 1000.0 * s, f"{key}_slowdown": s,
                                  f"{key}_unregulated_time_us": 1000.0 * unregulated(key),
                                  f"{key}_unregulated_slowdown": unregulated(key)})
                    if key != "rt":
                        throttles = 100 - t + int(key[3:] or 0)
                        cells.update({f"{key}_bandwidth_mbps": 500.0 * t,
                                      f"{key}_throttle_count": throttles,
                                      f"{key}_throttled_us": 10.0 * throttles})
                cells["throttle_count"] = cells["nrt_throttle_count"]
                cells["throttled_us"] = cells["nrt_throttled_us"]
                w.writerow([cells.get(c, "") for c in header])
    (folder / "manifest.json").write_text(json.dumps(
        {"schema_version": 1, "backend": "sim", "status": "complete"}))
    return folder


@pytest.fixture()
def folder(tmp_path):
    return write_folder(tmp_path / "a")


def test_the_nodes_of_a_folder_carry_their_names_and_prefixes(folder):
    found = nodes.nodes_of(load_results(folder))
    assert [(n.role, n.index, n.prefix, n.name) for n in found] == [
        ("rt", 0, "rt_", "detector"), ("nrt", 0, "nrt_", "reader"),
        ("nrt", 1, "nrt1_", "stereo"), ("nrt", 2, "nrt2_", "tracker")]
    assert [n.label for n in found] == ["RT detector", "nRT0 reader", "nRT1 stereo",
                                        "nRT2 tracker"]


def test_the_tidy_table_has_a_row_per_point_repetition_and_node(folder, tmp_path):
    results = load_results(folder)
    path = nodes.write_nodes(results, tmp_path / "nodes.csv")
    with path.open(newline="") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == len(THRESHOLDS) * len(POLICIES) * REPS * len(NODES)
    assert list(rows[0]) == list(nodes.NODE_TABLE_COLUMNS)
    for row in rows:
        key = row["role"] + (row["node"] if row["node"] != "0" else "")
        t, policy, rep = int(row["threshold_pct"]), row["policy"], int(row["rep"])
        (name, core, workload), = [(n, c, w) for k, n, c, w in NODES if k == key]
        assert (row["name"], row["core"], row["workload"]) == (name, str(core), workload)
        assert float(row["slowdown"]) == pytest.approx(slowdown(key, t, policy, rep, {}))
        assert float(row["unregulated_slowdown"]) == unregulated(key)
        if row["role"] == "nrt":
            assert int(row["throttle_count"]) == 100 - t + int(row["node"])
            assert float(row["bandwidth_mbps"]) == 500.0 * t
        else:
            assert row["throttle_count"] == "" and row["bandwidth_mbps"] == ""


def test_summary_and_the_printed_table_name_every_node(folder, tmp_path):
    stream = io.StringIO()
    assert plot.run(folder, tmp_path / "figs", stream=stream) == 0
    printed = stream.getvalue()
    for label in ("RT detector slowdown", "nRT0 reader slowdown", "nRT1 stereo slowdown",
                  "nRT2 tracker slowdown"):
        assert label in printed
    assert (tmp_path / "figs" / "nodes.csv").is_file()
    with (tmp_path / "figs" / "summary.csv").open(newline="") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == len(THRESHOLDS) * len(POLICIES)
    for row in rows:
        t, policy = int(row["threshold_pct"]), row["policy"]
        for key, name, _, _ in NODES:
            assert row[f"{key}_name"] == name
            mean = sum(slowdown(key, t, policy, r, {}) for r in range(REPS)) / REPS
            assert float(row[f"{key}_slowdown_mean"]) == pytest.approx(mean)
        # The first nRT node's throttling under its prefix, like the others'.
        assert float(row["nrt_throttle_count_mean"]) == 100 - t
        assert float(row["nrt2_throttle_count_mean"]) == 100 - t + 2
        assert "throttle_count_mean" not in row
        # Every node's unregulated co-run, the first nodes' under their old names.
        for key, _, _, _ in NODES:
            assert float(row[f"{key}_unregulated_slowdown_mean"]) == unregulated(key)
    assert ("unregulated co-run (the same nodes with policy none; slowdown = time / isolation "
            "time):\n  RT mser / nRT0 bandwidth_read, nRT1 disparity, nRT2 tracking: RT 1.500, "
            "nRT0 reader 2.000, nRT1 stereo 2.250, nRT2 tracker 2.500\n") in printed


def _axes_texts(fig):
    return [(ax.get_title(), ax.get_ylabel()) for ax in fig.axes if ax.get_visible()]


def test_figures_of_nrt_results_have_a_panel_per_node_titled_with_its_name(folder):
    plans, _ = plan_figures(load_results(folder))
    drawn = {p.stem: p for p in plans}
    assert {"slowdown_vs_threshold", "tradeoff", "mechanisms"} <= set(drawn)

    fig = drawn["slowdown_vs_threshold"].draw()
    texts = _axes_texts(fig)
    assert [t for t, _ in texts] == ["RT detector", "nRT0 reader", "nRT1 stereo",
                                     "nRT2 tracker"]
    # Each panel draws its own node: the highest mean on nRT2's panel is its slowdown.
    for ax, key in zip(fig.axes, ("rt", "nrt", "nrt1", "nrt2")):
        top = max(max(c.lines[0].get_ydata()) for c in ax.containers)
        expected = max(sum(slowdown(key, t, p, r, {}) for r in range(REPS)) / REPS
                       for t in THRESHOLDS for p in POLICIES)
        assert top == pytest.approx(expected)
    # The title names the first nRT node as nRT0, as the panels do.
    assert "nRT0 bandwidth_read" in fig._suptitle.get_text()
    assert "nRT1 disparity" in fig._suptitle.get_text()
    plt.close(fig)

    fig = drawn["tradeoff"].draw()
    titles = [t for t, _ in _axes_texts(fig)]
    assert titles == ["nRT0 reader", "nRT1 stereo", "nRT2 tracker"]
    # Each panel marks its own node's unregulated co-run, inside its axes.
    for ax, key in zip(fig.axes, ("nrt", "nrt1", "nrt2")):
        stars = [c.get_offsets()[0] for c in ax.collections
                 if c.get_label() == style.UNREGULATED_LABEL]
        assert [tuple(s) for s in stars] == [(unregulated("rt"), unregulated(key))]
        (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
        assert x0 <= stars[0][0] <= x1 and y0 <= stars[0][1] <= y1
    plt.close(fig)

    fig = drawn["mechanisms"].draw()
    ylabels = [y for _, y in _axes_texts(fig) if y]
    assert [y.split(" slowdown")[0] for y in ylabels] == ["RT", "nRT0 reader", "nRT1 stereo",
                                                          "nRT2 tracker"]
    plt.close(fig)


def test_compare_gives_errors_per_node_and_over_all_nrt_nodes(folder, tmp_path):
    b = write_folder(tmp_path / "b", scale={"nrt1": 1.1, "nrt2": 0.8})
    stream = io.StringIO()
    assert compare.run(folder, b, tmp_path / "cmp", stream=stream) == 0
    doc = json.loads((tmp_path / "cmp" / "summary.json").read_text())
    assert doc["rt"]["mape_pct"] == pytest.approx(0.0)
    assert doc["nrt"]["mape_pct"] == pytest.approx(0.0)
    assert doc["nrt1"]["mape_pct"] == pytest.approx(10.0)
    assert doc["nrt2"]["mape_pct"] == pytest.approx(20.0)
    assert [doc[k]["name"] for k in ("rt", "nrt", "nrt1", "nrt2")] == [
        "detector", "reader", "stereo", "tracker"]
    assert doc["overall"]["nrt"]["pairs"] == 12
    assert doc["overall"]["nrt"]["mape_pct"] == pytest.approx(10.0)
    assert doc["overall"]["rt"]["pairs"] == 4
    printed = stream.getvalue()
    lines = printed.splitlines()
    # A row per node, tagged and named; the nRT row is over all three nRT nodes.
    assert any(line.startswith("nRT1 ") and line.endswith("  stereo") for line in lines)
    overall = [line for line in lines if line.startswith("nRT ")]
    assert len(overall) == 1 and overall[0].endswith("overall: all 3 nRT nodes")
    assert overall[0].split()[1:3] == ["12", "10.000"]
    with (tmp_path / "cmp" / "compare.csv").open(newline="") as f:
        row = next(csv.DictReader(f))
    assert row["nrt2_name"] == "tracker"
    assert float(row["nrt2_error_pct"]) == pytest.approx(-20.0)
    assert float(row["nrt_error_pct"]) == pytest.approx(0.0)


def test_an_older_folder_without_names_labels_nodes_by_index(tmp_path):
    results = load_results(write_folder(tmp_path / "old", names=False))
    found = nodes.nodes_of(results)
    assert [n.label for n in found] == ["RT", "nRT0", "nRT1", "nRT2"]
    rows = nodes.node_rows(results)
    first = [r for r in rows if r["role"] == "nrt" and r["node"] == 0]
    assert all(r["throttle_count"] == 100 - r["threshold_pct"] for r in first)
    assert all(r["name"] == "" and r["core"] is None for r in first)
    assert not math.isnan(first[0]["slowdown"])


def test_the_rt_x_nrt_grid_has_a_cluster_per_node(tmp_path):
    results = load_results(write_folder(tmp_path / "grid", first_nrt=("bandwidth_read", "sift")))
    plans, _ = plan_figures(results)
    grid = [p for p in plans if p.stem.startswith("rt_nrt_grid")]
    assert grid
    fig = grid[0].draw()
    cells = [ax for ax in fig.axes if ax.get_visible() and ax.get_xticklabels()]
    assert [t.get_text() for t in cells[0].get_xticklabels()] == ["RT", "nRT0", "nRT1", "nRT2"]
    notes = " ".join(t.get_text() for t in fig.texts)
    assert "clusters: RT detector, nRT0 reader, nRT1 stereo, nRT2 tracker" in notes
    assert [ax.get_title() for ax in cells] == ["nRT0 bandwidth_read", "nRT0 sift"]
    plt.close(fig)
