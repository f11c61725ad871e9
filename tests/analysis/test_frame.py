"""analysis.load: a results folder as pandas DataFrames with units in attrs."""

import json
import math

import pytest

from analysis import InvalidInput, NotAResultsFolder, load
import resultgen


def _dictionary(folder, names):
    units = {"rt_slowdown": "ratio", "nrt_bandwidth_mbps": "MiB/s", "rt_time_us": "us"}
    entries = [{"name": n, "unit": units.get(n, "text"), "meaning": f"meaning of {n}"}
               for n in names]
    samples = [{"name": "activation_delay", "unit": "us", "meaning": "one delay"}]
    (folder / "columns.json").write_text(json.dumps({"points.csv": entries,
                                                     "samples.csv": samples}))


def _header(folder):
    return (folder / "points.csv").read_text().splitlines()[0].split(",")


def test_points_and_samples_with_units(tmp_path):
    folder = resultgen.write_results(tmp_path / "r", resultgen.threshold_points(), reps=2)
    _dictionary(folder, _header(folder))
    points, samples = load(folder)
    assert len(points) == 2 * len(resultgen.threshold_points())
    assert list(points.columns) == _header(folder)
    assert points["rt_slowdown"].dtype.kind == "f" and points["rep"].dtype.kind == "i"
    assert points["policy"].map(type).eq(str).all()
    assert points.attrs["units"]["nrt_bandwidth_mbps"] == "MiB/s"
    assert points.attrs["meanings"]["rt_time_us"] == "meaning of rt_time_us"
    assert set(samples.columns) == {"point", "rep", "kind", "value_us"}
    assert len(samples) > 0 and samples["value_us"].dtype.kind == "f"
    assert samples.attrs["units"] == {"activation_delay": "us"}
    # Grouping as an analyst would: mean RT slowdown per threshold, one value per threshold.
    by = points.groupby("threshold_pct")["rt_slowdown"].mean()
    assert len(by) == points["threshold_pct"].nunique() and not by.isna().any()


def test_empty_cell_is_nan(tmp_path):
    folder = resultgen.write_results(tmp_path / "r", resultgen.threshold_points(), reps=1)
    lines = (folder / "points.csv").read_text().splitlines()
    col = lines[0].split(",").index("activation_delay_p50_us")
    cells = lines[1].split(",")
    cells[col] = ""
    lines[1] = ",".join(cells)
    (folder / "points.csv").write_text("\n".join(lines) + "\n")
    _dictionary(folder, _header(folder))
    points, _ = load(folder)
    assert math.isnan(points["activation_delay_p50_us"].iloc[0])


def test_older_folder_without_dictionary_warns(tmp_path):
    folder = resultgen.write_results(tmp_path / "r", resultgen.threshold_points(), reps=1)
    with pytest.warns(UserWarning, match="columns.json is missing"):
        points, _ = load(folder)
    assert points.attrs["units"] == {}


def test_bad_dictionary_and_missing_folder(tmp_path):
    folder = resultgen.write_results(tmp_path / "r", resultgen.threshold_points(), reps=1)
    (folder / "columns.json").write_text('{"points.csv": [{"name": "x"}]}')
    with pytest.raises(InvalidInput, match="columns.json: not the column dictionary"):
        load(folder)
    with pytest.raises(NotAResultsFolder):
        load(tmp_path / "nowhere")
