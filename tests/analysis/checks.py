"""Helpers for the analysis tests: file-format checks and running the CLI as rosguard does."""

from __future__ import annotations

import os
import struct
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


def png_size(path: Path) -> tuple:
    """(width, height) of a PNG; AssertionError when the file is not a PNG."""
    data = Path(path).read_bytes()
    assert data[:8] == PNG_SIGNATURE, f"{path} is not a PNG"
    assert data[12:16] == b"IHDR", f"{path} has no IHDR chunk"
    assert data[-8:-4] == b"IEND", f"{path} is truncated"
    return struct.unpack(">II", data[16:24])


def assert_pdf(path: Path) -> None:
    """A complete PDF file: header, at least one page, EOF marker."""
    data = Path(path).read_bytes()
    assert data.startswith(b"%PDF-"), f"{path} is not a PDF"
    assert b"/Type /Page" in data, f"{path} has no page"
    assert data.rstrip().endswith(b"%%EOF"), f"{path} is truncated"


def assert_figure_files(folder: Path, stem: str) -> None:
    """stem.png (readable size) and stem.pdf exist in folder and are valid."""
    width, height = png_size(folder / f"{stem}.png")
    assert width >= 600 and height >= 400, (stem, width, height)
    assert_pdf(folder / f"{stem}.pdf")


def run_cli(*args, command=None) -> subprocess.CompletedProcess:
    """Runs `python3 -m analysis ARGS` (or `command ARGS`) with rosguard's environment."""
    env = dict(os.environ)
    env.update(PYTHONPATH=str(ROOT), MPLBACKEND="Agg", PYTHONDONTWRITEBYTECODE="1")
    argv = (command or [sys.executable, "-m", "analysis"]) + [str(a) for a in args]
    return subprocess.run(argv, env=env, capture_output=True, text=True, timeout=300,
                          check=False)
