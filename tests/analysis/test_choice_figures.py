"""The figures that answer "which setting?" (issue 14, item 4): the unregulated co-run on every
slowdown figure, the RT slowdown target, the RT-vs-nRT trade-off with its Pareto front and
tune.json's choices, the mechanism comparison, single-period distributions as boxes, and
grids that say whether they were simulated or measured. Each test inspects what is drawn."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from matplotlib.collections import LineCollection, PathCollection
from matplotlib.container import BarContainer
from matplotlib.patches import PathPatch

import resultgen
from analysis.figures import plan_figures, tradeoff
from analysis.results import InvalidInput, Point, Stat, load_results
from checks import run_cli

UNREGULATED = "unregulated co-run"


def _plans(results):
    return {p.stem: p for p in plan_figures(results)[0]}


def _skipped(results):
    return {s.kind: s.reason for s in plan_figures(results)[1]}


def _legend_labels(fig):
    return [t.get_text() for legend in fig.legends for t in legend.get_texts()]


def _lines(ax, label):
    return [line for line in ax.get_lines() if line.get_label() == label]


def _segments(ax, label):
    """y of the horizontal segments (hlines) labelled ``label``."""
    return [float(seg[0][1]) for c in ax.collections
            if isinstance(c, LineCollection) and c.get_label() == label
            for seg in c.get_segments()]


def _fresh(results_dir, name):
    """A Results of its own (tests change rt_slowdown_max; the session's stay untouched)."""
    return load_results(results_dir(name))


# --- the unregulated co-run and the target on line figures ------------------------------------

def test_slowdown_lines_draw_the_unregulated_corun_of_each_pair(loaded, drawn):
    results = loaded("threshold")
    fig = drawn(_plans(results)["slowdown_vs_threshold"])
    assert UNREGULATED in _legend_labels(fig)
    rows = {0: "bandwidth_read", 1: "mser"}            # one panel row per workload pair
    for i, ax in enumerate(fig.axes):
        metric = ("rt", "nrt")[i % 2]
        pair = [p for p in results.points if p.config["rt_workload"] == rows[i // 2]]
        expected = {round(p.mean(f"{metric}_unregulated_slowdown"), 9) for p in pair}
        assert len(expected) == 1                      # measured once per pair, not per point
        lines = _lines(ax, UNREGULATED)
        assert len(lines) == 1 and lines[0].get_linestyle() == "--"
        assert lines[0].get_ydata()[0] == pytest.approx(expected.pop())
        # it is what regulation protects from: the lowest threshold keeps the RT node faster
        if metric == "rt":
            assert lines[0].get_ydata()[0] > min(p.mean("rt_slowdown") for p in pair)
    assert "unregulated co-run" in " ".join(t.get_text() for t in fig.texts)


def test_plot_prints_what_the_unregulated_corun_costs_per_pair(results_dir, tmp_path):
    import io
    from analysis import plot
    stream = io.StringIO()
    plot.run(results_dir("threshold"), tmp_path / "figs", stream=stream)
    printed = stream.getvalue()
    results = load_results(results_dir("threshold"))
    assert "unregulated co-run (the same nodes with policy none" in printed
    for w in ("bandwidth_read", "mser"):
        p = next(p for p in results.points if p.config["rt_workload"] == w)
        assert (f"  RT {w} / nRT {w}: RT {p.mean('rt_unregulated_slowdown'):.3f}, "
                f"nRT {p.mean('nrt_unregulated_slowdown'):.3f}\n") in printed


def test_no_unregulated_line_without_the_columns(loaded, drawn):
    fig = drawn(_plans(loaded("no_unregulated"))["slowdown_vs_threshold"])
    assert UNREGULATED not in _legend_labels(fig)
    assert not any(_lines(ax, UNREGULATED) for ax in fig.axes)


def test_the_target_is_drawn_on_rt_panels_only(results_dir, drawn):
    results = _fresh(results_dir, "threshold")
    results.rt_slowdown_max = 1.05
    fig = drawn(_plans(results)["slowdown_vs_threshold"])
    label = "target: RT slowdown ≤ 1.05"
    assert label in _legend_labels(fig)
    for i, ax in enumerate(fig.axes):
        lines = _lines(ax, label)
        if i % 2 == 0:                                   # RT panels
            assert len(lines) == 1 and list(lines[0].get_ydata()) == [1.05, 1.05]
            assert lines[0].get_linestyle() == ":"
        else:
            assert not lines


# --- grids: the unregulated co-run per cluster, "simulated" vs "measured" ---------------------

def test_grid_cells_mark_the_unregulated_corun_over_each_cluster(loaded, drawn):
    results = loaded("grid")
    fig = drawn(_plans(results)["rt_nrt_grid_threshold20"])
    cell = fig.axes[0]                                   # RT mser / nRT bandwidth_read
    point = next(p for p in results.points if p.config["rt_workload"] == "mser"
                 and p.config["nrt_workload"] == "bandwidth_read")
    assert _segments(cell, UNREGULATED) == pytest.approx(
        [point.mean("rt_unregulated_slowdown"), point.mean("nrt_unregulated_slowdown")])


@pytest.mark.parametrize("backend, words", [("sim", "simulated"), ("hw", "measured")])
def test_a_grid_with_one_configuration_says_how_it_was_obtained(tmp_path, drawn, backend,
                                                                 words):
    points = resultgen.sweep({}, {"nodes.rt[0].workload": ["mser", "bandwidth_read"],
                                  "nodes.nrt[0].workload": ["sift", "disparity"]})
    results = load_results(resultgen.write_results(tmp_path / backend, points, reps=2,
                                                   backend=backend))
    plan = _plans(results)["rt_nrt_grid"]
    assert f"(1: {words})" in plan.summary
    fig = drawn(plan)
    assert _legend_labels(fig)[0] == words
    assert fig._suptitle.get_text().endswith(f"[{words}]")
    assert ("measured" in fig._suptitle.get_text()) == (backend == "hw")


# --- the trade-off figure ---------------------------------------------------------------------

def _point(pid, rt, nrt, policy="interval"):
    return Point(pid, {"policy": policy}, 1, {"rt_slowdown": Stat(1, rt, rt, rt, 0.0),
                                              "nrt_slowdown": Stat(1, nrt, nrt, nrt, 0.0)})


def test_pareto_front_keeps_the_settings_nothing_beats_on_both():
    pts = [_point("a", 1.0, 5.0), _point("b", 1.1, 3.0), _point("c", 1.2, 3.5),
           _point("d", 1.3, 2.0), _point("e", 1.1, 4.0), _point("f", 1.5, 2.0)]
    assert [p.id for p in tradeoff.pareto_front(pts)] == ["a", "b", "d"]


def _dominated(p, others):
    return any(q.mean("rt_slowdown") <= p.mean("rt_slowdown")
               and q.mean("nrt_slowdown") <= p.mean("nrt_slowdown")
               and (q.mean("rt_slowdown"), q.mean("nrt_slowdown"))
               != (p.mean("rt_slowdown"), p.mean("nrt_slowdown")) for q in others)


def test_tradeoff_draws_every_setting_the_front_the_target_and_tune_choices(loaded, drawn):
    results = loaded("tune")
    assert results.rt_slowdown_max == 1.05               # from tune.json
    plan = _plans(results)["tradeoff"]
    assert "target RT slowdown ≤ 1.05" in plan.summary and "tune.json" in plan.summary
    fig = drawn(plan)
    ax = fig.axes[0]
    assert ax.get_xlabel() == "RT slowdown (× isolation)"
    assert ax.get_ylabel() == "nRT slowdown (× isolation)"
    by_label = {c.get_label(): c.get_offsets() for c in ax.collections
                if isinstance(c, PathCollection)}
    # one marker per setting, a series per mechanism (policy, sampling)
    settings = np.concatenate([by_label["interval, self"], by_label["monolithic, self"]])
    assert len(settings) == len(results.points) == 16
    expected = sorted((p.mean("rt_slowdown"), p.mean("nrt_slowdown")) for p in results.points)
    assert sorted(map(tuple, settings)) == pytest.approx(expected)
    # the front: exactly the settings no other one beats on both slowdowns
    front = _lines(ax, "Pareto front")[0]
    xs, ys = front.get_data()
    undominated = sorted((p.mean("rt_slowdown"), p.mean("nrt_slowdown"))
                         for p in results.points if not _dominated(p, results.points))
    assert sorted(zip(xs, ys)) == pytest.approx(undominated)
    assert front.get_drawstyle() == "steps-post"
    # the target: a vertical dotted line
    target = _lines(ax, "target: RT slowdown ≤ 1.05")[0]
    assert list(target.get_xdata()) == [1.05, 1.05] and target.get_linestyle() == ":"
    # tune.json: best by its regulation keys, runner-up by its point id
    best = next(p for p in results.points if p.config["policy"] == "interval"
                and p.config["threshold_pct"] == 10 and p.config["sampling_period_us"] == 500)
    runner_up = next(p for p in results.points
                     if p.id == resultgen.point_id(resultgen.TUNE_RUNNER_UP))
    assert tuple(by_label["best (tune)"][0]) == pytest.approx(
        (best.mean("rt_slowdown"), best.mean("nrt_slowdown")))
    assert tuple(by_label["runner-up (tune)"][0]) == pytest.approx(
        (runner_up.mean("rt_slowdown"), runner_up.mean("nrt_slowdown")))
    # the unregulated co-run from the columns (they win over tune.json's own numbers)
    assert tuple(by_label[UNREGULATED][0]) == pytest.approx(
        (best.mean("rt_unregulated_slowdown"), best.mean("nrt_unregulated_slowdown")))
    assert {"best (tune)", "runner-up (tune)", UNREGULATED, "Pareto front"} \
        <= set(_legend_labels(fig))


def test_tradeoff_takes_the_unregulated_corun_from_tune_json_without_columns(tmp_path, drawn):
    folder = resultgen.write_results(tmp_path / "t", resultgen.tune_points(), unregulated=False,
                                     tune=resultgen.TUNE)
    fig = drawn(_plans(load_results(folder))["tradeoff"])
    star = [c for c in fig.axes[0].collections if c.get_label() == UNREGULATED]
    assert [tuple(c.get_offsets()[0]) for c in star] == [(1.2, 1.03)]


def test_tradeoff_has_a_panel_per_workload_pair(loaded, drawn):
    fig = drawn(_plans(loaded("grid"))["tradeoff"])
    visible = [ax for ax in fig.axes if ax.get_visible()]
    assert len(visible) == 12                            # 3 RT x 4 nRT workloads
    assert visible[0].get_title() == "RT mser / nRT bandwidth_read"


def test_tradeoff_is_skipped_without_two_settings(loaded):
    assert "no trade-off" in _skipped(loaded("overhead"))["RT vs nRT trade-off"]


def test_command_line_target_overrides_tune_json(results_dir, tmp_path):
    out = tmp_path / "figs"
    r = run_cli("plot", results_dir("tune"), "--out", out, "--rt-slowdown-max", "1.1")
    assert r.returncode == 0, r.stderr
    assert "target RT slowdown ≤ 1.1;" in r.stdout and "not tune.json's 1.05" in r.stdout
    assert (out / "tradeoff.png").is_file()


@pytest.mark.parametrize("value", ["0.9", "abc", "inf"])
def test_a_target_below_isolation_is_refused(results_dir, value):
    r = run_cli("plot", results_dir("threshold"), "--rt-slowdown-max", value)
    assert r.returncode == 2 and "--rt-slowdown-max" in r.stderr


@pytest.mark.parametrize("doc, words", [
    ({"rt_slowdown_max": "5"}, "/rt_slowdown_max: expected a positive number"),
    ({"best": [1]}, "/best: expected an object or null"),
    ([], "expected a JSON object"),
])
def test_an_invalid_tune_json_names_the_file_and_path(tmp_path, doc, words):
    folder = resultgen.write_results(tmp_path / "bad", resultgen.tune_points(), reps=1)
    (folder / "tune.json").write_text(json.dumps(doc))
    with pytest.raises(InvalidInput, match="tune.json") as e:
        load_results(folder)
    assert words in str(e.value)


# --- the mechanism comparison -----------------------------------------------------------------

def test_mechanisms_compare_every_policy_and_sampling_mode_per_threshold(loaded, drawn):
    results = loaded("mechanisms")
    plan = _plans(results)["mechanisms"]
    assert "memguard, overflow" in plan.summary
    fig = drawn(plan)
    assert len(fig.axes) == 2 * 3                        # (RT, nRT) x thresholds 20, 30, 40
    assert [ax.get_title() for ax in fig.axes[:3]] == [
        "threshold 20 %", "threshold 30 %", "threshold 40 %"]
    assert fig.axes[0].get_ylabel() == "RT slowdown (× isolation)"
    assert fig.axes[3].get_ylabel() == "nRT slowdown (× isolation)"
    assert _legend_labels(fig)[:3] == ["interval, self", "interval, external",
                                       "memguard, overflow"]
    for ax in fig.axes:
        bars = [b for c in ax.containers if isinstance(c, BarContainer) for b in c]
        assert len(bars) == 3 * 3                        # nRT workloads x mechanisms
        assert [t.get_text() for t in ax.get_xticklabels()] == ["disparity", "mser", "sift"]
        assert len(_segments(ax, UNREGULATED)) == 3      # one per nRT workload
    # the nRT bar of memguard against mser at 30 %: its mean, from isolation
    nrt_30 = fig.axes[4]
    bars = [b for c in nrt_30.containers if isinstance(c, BarContainer) for b in c]
    point = next(p for p in results.points if p.config["policy"] == "memguard"
                 and p.config["nrt_workload"] == "mser" and p.config["threshold_pct"] == 30)
    bar = bars[1 * 3 + 2]                                # group mser, third mechanism
    assert bar.get_y() == 1.0
    assert bar.get_height() == pytest.approx(point.mean("nrt_slowdown") - 1.0)


def test_mechanisms_carry_the_target_on_the_rt_row(results_dir, drawn):
    results = _fresh(results_dir, "mechanisms")
    results.rt_slowdown_max = 1.02
    fig = drawn(_plans(results)["mechanisms"])
    label = "target: RT slowdown ≤ 1.02"
    assert [bool(_lines(ax, label)) for ax in fig.axes] == [True] * 3 + [False] * 3


def test_mechanisms_are_skipped_with_a_single_one(loaded):
    assert "fewer than two mechanisms" in _skipped(loaded("regulation"))[
        "mechanism comparison"]


# --- distributions at a single sampling period ------------------------------------------------

def test_a_single_sampling_period_gives_a_box_per_series(loaded, drawn):
    results = loaded("threshold")                        # every point at 1 ms
    plan = _plans(results)["activation_delay_vs_sampling_period"]
    assert "distribution (box) at sampling period 1 ms" in plan.summary
    fig = drawn(plan)
    ax = fig.axes[0]
    boxes = [p for p in ax.patches if isinstance(p, PathPatch)]
    assert len(boxes) == 2                               # interval, monolithic
    assert [t.get_text() for t in ax.get_xticklabels()] == ["interval, self",
                                                            "monolithic, self"]
    for i, policy in enumerate(("interval", "monolithic")):
        values = np.concatenate([results.samples_of(p.id, "activation_delay")
                                 for p in results.points if p.config["policy"] == policy])
        medians = [line for line in ax.get_lines()
                   if len(line.get_xdata()) == 2 and line.get_linewidth() == 1.4
                   and math.isclose(np.mean(line.get_xdata()), i)]
        assert medians and medians[0].get_ydata()[0] == pytest.approx(np.median(values))
    assert ax.get_ylabel() == "activation delay (µs)"
    assert "box: quartiles" in " ".join(t.get_text() for t in fig.texts)


def test_several_sampling_periods_keep_the_min_median_max_markers(loaded, drawn):
    fig = drawn(_plans(loaded("delay"))["activation_delay_vs_sampling_period"])
    assert not [p for p in fig.axes[0].patches if isinstance(p, PathPatch)]
    assert fig.axes[0].get_xscale() == "log"


def test_policy_none_points_stand_in_as_one_line_only_without_a_measured_corun(tmp_path,
                                                                               drawn):
    # A hw sweep of policy none alone (an older folder: no co-run of its own measured): the
    # none points' slowdowns vary a little per threshold; one line at their mean.
    points = resultgen.sweep({"policy": "none"}, {"regulation.threshold_pct": [10, 20, 30]})
    results = load_results(resultgen.write_results(tmp_path / "none", points, backend="hw"))
    fig = drawn(_plans(results)["slowdown_vs_threshold"])
    rt_panel = fig.axes[0]
    lines = _lines(rt_panel, UNREGULATED)
    assert len(lines) == 1
    assert lines[0].get_ydata()[0] == pytest.approx(
        np.mean([p.mean("rt_slowdown") for p in results.points]))


def test_tradeoff_front_labels_name_their_mechanism_where_the_front_mixes_them(loaded, drawn):
    # The quickstart's figure labelled "25 %" twice: interval's and monolithic's 25 %.
    results = loaded("tune")
    front = [p for p in results.points if not _dominated(p, results.points)]
    assert len({(p.config["policy"], p.config["sampling"]) for p in front}) > 1
    ax = drawn(_plans(results)["tradeoff"]).axes[0]
    labels = [t.get_text() for t in ax.texts]
    assert labels
    for label in labels:
        assert label.split(" / ")[0].startswith(("interval, self: ", "monolithic, self: ")), label
