"""Writing CSV tables with stable number formats (empty cell = not applicable)."""

from __future__ import annotations

import csv
import math
from pathlib import Path


def cell(value) -> str:
    """'' for None/NaN, integers without decimals, other floats with up to 6 decimals."""
    if value is None:
        return ""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        if not math.isfinite(value):
            return ""
        if value.is_integer():
            return str(int(value))
        return f"{value:.6f}".rstrip("0").rstrip(".")
    return str(value)


def write_csv(path: Path, header, rows) -> Path:
    """Writes header and rows (sequences of values) with RFC 4180 quoting; returns path."""
    with path.open("w", newline="", encoding="utf-8") as f:
        writer = csv.writer(f, lineterminator="\n")
        writer.writerow(header)
        for row in rows:
            writer.writerow([cell(v) for v in row])
    return path
