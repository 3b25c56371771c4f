"""XYZ/TXT point lists: ``x y z [nx ny nz] [more columns]`` (private)."""

from __future__ import annotations

import io as _stdio
import re

import numpy as np

from ._errors import describe_exception, fail
from ._raw import RawData

__all__ = ["read_xyz", "write_xyz"]


def read_xyz(path) -> RawData:
    """Read a whitespace- or comma-separated point list with ``#`` comments (private).

    Columns: 3 -> x y z; 4 or 5 -> x y z plus attributes ``column_3``...; 6 or
    more -> x y z nx ny nz plus attributes ``column_6``... . Every row must have the
    same number of columns.
    """
    with open(path, "rb") as fh:
        data = fh.read()
    if b"\x00" in data:
        raise fail(path, "binary data (NUL bytes) in a text point file")
    text = data.decode("utf-8", errors="replace").replace(",", " ").replace(";", " ")
    if not re.search(r"^[ \t]*[^#\s]", text, re.MULTILINE):
        raise fail(path, "no points (only comments or blank lines)")
    try:
        table = np.loadtxt(_stdio.StringIO(text), dtype=np.float64, comments="#", ndmin=2)
    except ValueError as exc:
        raise fail(path, f"cannot parse point list ({describe_exception(exc)})") from None
    width = table.shape[1]
    if width < 3:
        raise fail(path, f"need at least 3 columns (x y z); got {width}")
    points = np.ascontiguousarray(table[:, :3])
    normals = np.ascontiguousarray(table[:, 3:6]) if width >= 6 else None
    first_extra = 6 if width >= 6 else 3
    attributes = {f"column_{c}": table[:, c].copy() for c in range(first_extra, width)}
    return RawData(points=points, normals=normals, attributes=attributes)


def write_xyz(fh, points: np.ndarray, normals: np.ndarray | None) -> None:
    """Write ``x y z [nx ny nz]`` rows with shortest round-trip floats to text ``fh``."""
    table = points if normals is None else np.hstack([points, normals])
    fh.write("".join(" ".join(map(repr, row)) + "\n" for row in table.tolist()))
