"""Shared fixtures: results folders generated into a temporary directory (never the tree)."""

from __future__ import annotations

import os
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))
sys.dont_write_bytecode = True
os.environ.setdefault("MPLBACKEND", "Agg")

import matplotlib.pyplot as plt  # noqa: E402  (after MPLBACKEND)
import resultgen  # noqa: E402  (beside this file; pytest puts its folder on sys.path)

# name -> (points function, write_results options)
FIXTURES = {
    "threshold": (resultgen.threshold_points, {}),
    "regulation": (resultgen.regulation_points, {"with_samples": False}),
    "sampling": (resultgen.sampling_points, {}),
    "delay": (resultgen.delay_points, {}),
    "overhead": (resultgen.overhead_points, {}),
    "grid": (resultgen.grid_points, {"reps": 2}),
    "memguard": (resultgen.memguard_points, {}),
    "rt_alone": (resultgen.rt_alone_points, {}),
    "mechanisms": (resultgen.mechanism_points, {}),
    "tune": (resultgen.tune_points, {"tune": resultgen.TUNE}),
    "no_unregulated": (resultgen.threshold_points, {"unregulated": False}),
}


@pytest.fixture(scope="session")
def results_dir(tmp_path_factory):
    """results_dir(name) -> a generated results folder (written once per session)."""
    made = {}

    def make(name: str) -> Path:
        if name not in made:
            points, options = FIXTURES[name]
            made[name] = resultgen.write_results(
                tmp_path_factory.mktemp("results") / name, points(), **options)
        return made[name]

    return make


@pytest.fixture(scope="session")
def loaded(results_dir):
    """loaded(name) -> the Results of a generated folder."""
    from analysis.results import load_results
    cache = {}

    def load(name: str):
        if name not in cache:
            cache[name] = load_results(results_dir(name))
        return cache[name]

    return load


@pytest.fixture
def drawn():
    """drawn(plan) -> its Figure, closed after the test."""
    figures = []

    def draw(plan):
        figures.append(plan.draw())
        return figures[-1]

    yield draw
    for fig in figures:
        plt.close(fig)
