"""Fixtures for the analysis tests: generated results folders in a temporary directory."""

import os
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(Path(__file__).resolve().parent))
os.environ.setdefault("MPLBACKEND", "Agg")

import resultgen  # noqa: E402


@pytest.fixture
def make_results(tmp_path):
    """make_results(name, points, **options) -> a results folder written by resultgen."""
    def make(name, points, **options):
        return resultgen.write_results(tmp_path / name, points, **options)
    return make


def png_size(path: Path):
    """(width, height) of a PNG file; fails the test when it is not a PNG."""
    data = path.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n", f"{path} is not a PNG"
    assert data[12:16] == b"IHDR"
    return int.from_bytes(data[16:20], "big"), int.from_bytes(data[20:24], "big")


def assert_pdf(path: Path):
    """Fails the test unless the file is a complete PDF."""
    data = path.read_bytes()
    assert data.startswith(b"%PDF-"), f"{path} is not a PDF"
    assert b"%%EOF" in data[-64:], f"{path} is truncated"
