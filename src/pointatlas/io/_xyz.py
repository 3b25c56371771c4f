"""XYZ/TXT point lists: ``x y z [nx ny nz] [more columns]`` (private)."""

from __future__ import annotations

import io as _stdio
import re

import numpy as np

from ._errors import describe_exception, fail, first_non_number
from ._raw import RawData

__all__ = ["read_xyz", "write_xyz"]

#: The first data row: the first line with something other than blanks and a comment.
_FIRST_ROW = re.compile(r"^[ \t]*([^#\s][^\n]*)", re.MULTILINE)


def read_xyz(path) -> RawData:
    """Read a whitespace-, comma- or semicolon-separated point list with ``#`` comments.

    Private. The first data row chooses the separator (``,`` if it has one, else
    ``;`` if it has one, else whitespace; spaces around ``,``/``;`` are allowed) and
    every row must use it with the same number of columns. A row where commas and
    spaces both separate values (``1,5 2,5 3,5``: decimal commas) is refused with its
    line number instead of being split into more columns. Columns: 3 -> x y z; 4 or
    5 -> x y z plus attributes ``column_3``...; 6 or more -> x y z nx ny nz plus
    attributes ``column_6``... .
    """
    with open(path, "rb") as fh:
        data = fh.read()
    if b"\x00" in data:
        raise fail(path, "binary data (NUL bytes) in a text point file")
    text = data.decode("utf-8", errors="replace")
    first = _FIRST_ROW.search(text)
    if first is None:
        raise fail(path, "no points (only comments or blank lines)")
    first_line = text.count("\n", 0, first.start()) + 1
    row = first.group(1).split("#", 1)[0]
    if "," in row and ";" in row:
        raise fail(
            path, f"line {first_line}: both ',' and ';' separate values ({row.strip()[:40]!r})"
        )
    delimiter = "," if "," in row else (";" if ";" in row else None)
    try:
        table = np.loadtxt(
            _stdio.StringIO(text), dtype=np.float64, comments="#", delimiter=delimiter, ndmin=2
        )
    except ValueError as exc:
        problem = _find_bad_row(text, delimiter, first_line)
        raise fail(
            path, problem or f"cannot parse point list ({describe_exception(exc)})"
        ) from None
    width = table.shape[1]
    if width < 3:
        raise fail(path, f"need at least 3 columns (x y z); got {width}")
    points = np.ascontiguousarray(table[:, :3])
    normals = np.ascontiguousarray(table[:, 3:6]) if width >= 6 else None
    first_extra = 6 if width >= 6 else 3
    attributes = {f"column_{c}": table[:, c].copy() for c in range(first_extra, width)}
    return RawData(points=points, normals=normals, attributes=attributes)


def _find_bad_row(text: str, delimiter: str | None, first_line: int) -> str | None:
    """The first row that breaks the first row's layout, described (slow path, on error)."""
    width = None
    style = "whitespace" if delimiter is None else repr(delimiter)
    for lineno, line in enumerate(text.splitlines(), start=1):
        body = line.split("#", 1)[0].strip()
        if not body:
            continue
        shown = body[:40]
        if delimiter is None:
            if "," in body or ";" in body:
                sep = "," if "," in body else ";"
                return (
                    f"line {lineno}: {sep!r} in a row of space-separated values (the first "
                    f"data row, line {first_line}, separates by whitespace): {shown!r}"
                )
            fields = body.split()
        else:
            other = ";" if delimiter == "," else ","
            if other in body:
                return f"line {lineno}: both ',' and ';' separate values ({shown!r})"
            fields = [f.strip() for f in body.split(delimiter)]
            if any(len(f.split()) > 1 for f in fields):
                return (
                    f"line {lineno}: values separated by both {delimiter!r} and spaces "
                    f"({shown!r}); decimal commas are not supported"
                )
        if width is None:
            width = len(fields)
        elif len(fields) != width:
            return (
                f"line {lineno}: {len(fields)} columns, but the first data row "
                f"(line {first_line}) has {width} ({style}-separated)"
            )
        bad = first_non_number(fields)
        if bad is not None:
            return f"line {lineno}: non-numeric value {bad[:40]!r}"
    return None


def write_xyz(fh, points: np.ndarray, normals: np.ndarray | None) -> None:
    """Write ``x y z [nx ny nz]`` rows with shortest round-trip floats to text ``fh``."""
    table = points if normals is None else np.hstack([points, normals])
    fh.write("".join(" ".join(map(repr, row)) + "\n" for row in table.tolist()))
