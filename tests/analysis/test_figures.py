"""Every figure kind: which results support it, and that what it draws is readable."""

import io
import math

import pytest
from matplotlib.container import ErrorbarContainer

import resultgen
from analysis import plot
from analysis.figures import isolation, plan_figures
from analysis.results import load_results
from conftest import assert_pdf, png_size

# fixture -> (figure files expected, figure files that must not appear)
EXPECTED = {
    "threshold": ({"slowdown_vs_threshold"},
                  {"rt_nrt_grid", "slowdown_vs_regulation_period", "isolation_table1",
                   "sampling_overhead_vs_sampling_period"}),
    "regulation": ({"slowdown_vs_regulation_period"},
                   {"slowdown_vs_threshold", "rt_nrt_grid", "isolation_table1"}),
    "sampling": ({"slowdown_vs_sampling_period", "slowdown_vs_threshold"},
                 {"slowdown_vs_regulation_period", "isolation_table1"}),
    "delay": ({"activation_delay_vs_sampling_period", "pmc_callback_vs_sampling_period",
               "slowdown_vs_sampling_period"},
              {"sampling_overhead_vs_sampling_period", "isolation_table1"}),
    "overhead": ({"sampling_overhead_vs_sampling_period", "pmc_callback_vs_sampling_period"},
                 {"slowdown_vs_threshold", "slowdown_vs_sampling_period", "rt_nrt_grid"}),
    "grid": ({"rt_nrt_grid_threshold15", "rt_nrt_grid_threshold20", "rt_nrt_grid_threshold30"},
             {"slowdown_vs_regulation_period", "isolation_table1"}),
    "memguard": ({"rt_nrt_grid_threshold20", "rt_nrt_grid_threshold40"},
                 {"isolation_table1"}),
    "rt_alone": ({"isolation_table1"},
                 {"slowdown_vs_threshold", "rt_nrt_grid", "activation_delay_vs_sampling_period"}),
}
POINTS = {
    "threshold": resultgen.threshold_points, "regulation": resultgen.regulation_points,
    "sampling": resultgen.sampling_points, "delay": resultgen.delay_points,
    "overhead": resultgen.overhead_points, "grid": resultgen.grid_points,
    "memguard": resultgen.memguard_points, "rt_alone": resultgen.rt_alone_points,
}


@pytest.mark.parametrize("name", sorted(EXPECTED))
def test_the_registry_picks_the_figures_the_data_support(make_results, name):
    results = load_results(make_results(name, POINTS[name](), reps=2, references=True))
    plans, skipped = plan_figures(results)
    stems = {p.stem for p in plans}
    wanted, unwanted = EXPECTED[name]
    assert wanted <= stems, f"missing {wanted - stems}"
    assert not (unwanted & stems), f"unexpected {unwanted & stems}"
    assert all(s.reason for s in skipped)   # every skip says why


@pytest.mark.parametrize("name", sorted(EXPECTED))
def test_plot_writes_a_png_and_a_pdf_per_figure_and_the_tables(make_results, tmp_path, name):
    folder = make_results(name, POINTS[name](), reps=2, references=True)
    out = tmp_path / "figures"
    stream = io.StringIO()
    assert plot.run(folder, out, stream=stream) == 0
    plans, _ = plan_figures(load_results(folder))
    for p in plans:
        width, height = png_size(out / f"{p.stem}.png")
        assert width >= 600 and height >= 300
        assert_pdf(out / f"{p.stem}.pdf")
        assert f"{p.stem}.png" in stream.getvalue()
    summary = (out / "summary.csv").read_text().splitlines()
    assert len(summary) == 1 + len(POINTS[name]())     # header + one row per point


def _figure(make_results, name, stem, **options):
    results = load_results(make_results(name, POINTS[name](), **options))
    plans, _ = plan_figures(results)
    return next(p for p in plans if p.stem == stem).draw()


def test_slowdown_vs_threshold_has_units_isolation_line_policies_and_error_bars(make_results):
    fig = _figure(make_results, "threshold", "slowdown_vs_threshold", reps=3)
    axes = [ax for ax in fig.axes if ax.get_xlabel()]
    assert {ax.get_xlabel() for ax in axes} == {"threshold (% of reference bandwidth)"}
    assert all("slowdown" in ax.get_ylabel() and "isolation" in ax.get_ylabel() for ax in axes)
    for ax in axes:   # isolation = 1.0 drawn dashed on every panel
        assert any(list(line.get_ydata()) == [1.0, 1.0] and line.get_linestyle() == "--"
                   for line in ax.get_lines())
        assert any(isinstance(c, ErrorbarContainer) for c in ax.containers)
    labels = {t.get_text() for legend in fig.legends for t in legend.get_texts()}
    assert {"interval", "monolithic", "isolation (1.0)"} <= labels


def test_distributions_show_min_median_max_on_a_log_period_axis(make_results):
    fig = _figure(make_results, "delay", "activation_delay_vs_sampling_period", reps=2)
    ax = fig.axes[0]
    assert ax.get_xscale() == "log"
    assert ax.get_xlabel() == "sampling period (µs)"
    assert "µs" in ax.get_ylabel()
    labels = {t.get_text() for legend in fig.legends + [ax.get_legend()] if legend
              for t in legend.get_texts()}
    assert {"min", "median", "max"} <= labels
    assert any("self" in t for t in labels) and any("external" in t for t in labels)


def test_the_grid_has_one_panel_per_rt_and_nrt_workload(make_results):
    fig = _figure(make_results, "grid", "rt_nrt_grid_threshold20", reps=2)
    panels = [ax for ax in fig.axes if ax.get_visible() and ax.patches]
    assert len(panels) == 3 * 4    # RT mser / bandwidth_read / bandwidth_write x 4 nRT


def test_isolation_compares_with_the_reference_when_the_manifest_has_it(make_results):
    results = load_results(make_results("rt_alone", resultgen.rt_alone_points(), reps=1,
                                        references=True))
    figures = isolation.isolation_figures(results)
    refs = isolation.references(results)
    assert set(figures) == {"mser", "sift"}
    assert refs["mser"]["ipc"] == 2.16
    assert isolation.error_pct(2.2, 2.0) == pytest.approx(10.0)
    assert math.isnan(isolation.error_pct(2.2, None))


def test_an_empty_results_folder_is_invalid_input(make_results, tmp_path):
    folder = make_results("empty", resultgen.threshold_points(), reps=1,
                          drop=range(len(resultgen.threshold_points())), status="running")
    with pytest.raises(Exception, match="holds no rows yet"):
        plot.run(folder, tmp_path / "out", stream=io.StringIO())


def test_an_incomplete_run_is_plotted_with_a_note(make_results, tmp_path):
    folder = make_results("partial", resultgen.threshold_points(), reps=1, status="interrupted",
                          drop=[0, 1])
    stream = io.StringIO()
    assert plot.run(folder, tmp_path / "out", stream=stream) == 0
    assert "the run is not complete" in stream.getvalue()
