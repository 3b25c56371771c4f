"""XYZ/TXT point lists: ``x y z`` then normals, colours or other columns (private).

Which columns are what: a header row names them (``X Y Z R G B Nx Ny Nz``,
tab- or comma-separated, or CloudCompare's ``//X Y Z ...``); without one, columns
3.. are read three at a time: unit vectors are normals, integers in 0..255 (or
0..65535) are colours, anything else is ``column_<j>``. The choice is recorded in
``meta["columns"]`` (one line the CLI prints) for every file with more than x y z.
"""

from __future__ import annotations

import io as _stdio
import re

import numpy as np

from ._errors import describe_exception, fail, first_non_number
from ._raw import RawData

__all__ = ["read_xyz", "write_xyz"]

#: The first data row: the first line with something other than blanks and a comment.
_FIRST_ROW = re.compile(r"^[ \t]*([^#\s][^\n]*)", re.MULTILINE)
#: Header names (lower case, without ``_``/``-``/spaces) of each role.
_ROLES = {
    "x": ("x",),
    "y": ("y",),
    "z": ("z",),
    "nx": ("nx", "normalx", "normx", "nxx"),
    "ny": ("ny", "normaly", "normy", "nyy"),
    "nz": ("nz", "normalz", "normz", "nzz"),
    "red": ("r", "red"),
    "green": ("g", "green"),
    "blue": ("b", "blue"),
    "alpha": ("a", "alpha"),
}
_BY_NAME = {alias: role for role, aliases in _ROLES.items() for alias in aliases}
#: How far from 1 a row's length may be for a column triple to count as normals
#: (text files often round normals to 3-6 decimals); zero rows are allowed.
_UNIT_TOLERANCE = 0.01


def read_xyz(path) -> RawData:
    """Read a whitespace-, comma- or semicolon-separated point list with ``#`` comments.

    Private. The first data row chooses the separator (``,`` if it has one, else
    ``;`` if it has one, else whitespace; spaces around ``,``/``;`` are allowed) and
    every row must use it with the same number of columns. A row where commas and
    spaces both separate values (``1,5 2,5 3,5``: decimal commas) is refused with its
    line number instead of being split into more columns. A first row of names (or
    one starting ``//``) is a header; the columns' roles are decided by
    :func:`_header_roles` or, without a header, :func:`_guess_roles`.
    """
    with open(path, "rb") as fh:
        data = fh.read()
    if b"\x00" in data:
        raise fail(path, "binary data (NUL bytes) in a text point file")
    text = data.decode("utf-8", errors="replace")
    first = _FIRST_ROW.search(text)
    if first is None:
        raise fail(path, "no points (only comments or blank lines)")
    header, text, first = _split_header(text, first)
    if header is not None and first is None:
        raise fail(path, "no points after the header row")
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
    if header is None:
        roles, note = _guess_roles(table)
    else:
        roles, note = _header_roles(path, header, width)
    return _assemble(table, roles, note)


def _split_header(text: str, first):
    """``(names, text without the header row, first data row match)``; names None if none.

    A header is a first row starting ``//`` (CloudCompare) or made only of
    non-numbers (``X Y Z``, ``x,y,z,r,g,b``). The header row is blanked, not removed,
    so line numbers in later messages stay those of the file.
    """
    line = first.group(1).split("#", 1)[0].strip()
    body = line[2:] if line.startswith("//") else line
    names = [t for t in re.split(r"[\s,;]+", body.strip()) if t]
    words = all(first_non_number([n]) is not None for n in names)
    if not names or not (line.startswith("//") or words):
        return None, text, first
    text = text[: first.start(1)] + text[first.end(1) :]
    return names, text, _FIRST_ROW.search(text)


def _header_roles(path, names: list[str], width: int):
    """Roles of the columns from their header names (see :data:`_ROLES`)."""
    if len(names) != width:
        raise fail(path, f"the header names {len(names)} columns but the rows have {width}")
    roles: list[str] = []
    seen: set[str] = set()
    for j, name in enumerate(names):
        key = re.sub(r"[\s_\-]", "", name.lower())
        role = _BY_NAME.get(key)
        if role is None or role in seen:
            label = name if re.fullmatch(r"[A-Za-z_][\w().\-]*", name) else f"column_{j}"
            if label in seen or label.lower() in _BY_NAME:
                label = f"column_{j}"
            role = label
        seen.add(role)
        roles.append(role)
    for axis in "xyz":
        if axis not in seen:
            raise fail(path, f"the header ({' '.join(names)}) names no {axis!r} column")
    if not {"nx", "ny", "nz"} <= seen and seen & {"nx", "ny", "nz"}:
        raise fail(path, f"the header ({' '.join(names)}) names only some of nx ny nz")
    return roles, "header: " + " ".join(names)


def _guess_roles(table: np.ndarray):
    """Roles of the columns of a file without a header, and the line saying why.

    Columns 0-2 are x y z; then, three at a time: a triple whose rows are unit
    vectors (or zero) is the normals, a triple of integers in 0..255 / 0..65535 the
    colours (a fourth such column right after them is alpha); the rest
    ``column_<j>``.
    """
    width = table.shape[1]
    roles = ["x", "y", "z"] + [f"column_{j}" for j in range(3, width)]
    reasons = []
    c = 3
    while c + 3 <= width:
        block = table[:, c : c + 3]
        if "nx" not in roles and _looks_unit(block):
            roles[c : c + 3] = ["nx", "ny", "nz"]
            reasons.append(f"{c}-{c + 2} normals (unit vectors)")
        elif "red" not in roles and (top := _colour_range(block)) is not None:
            roles[c : c + 3] = ["red", "green", "blue"]
            span = f"{c}-{c + 2}"
            if c + 3 < width and _colour_range(table[:, c + 3 : c + 4]) == top:
                roles[c + 3] = "alpha"
                span = f"{c}-{c + 3}"
            reasons.append(f"{span} colours (integers 0..{top})")
        else:
            break
        c += 4 if roles[c + 3 : c + 4] == ["alpha"] else 3
    if width > 3 and not reasons:
        reasons.append(f"3-{width - 1} kept as column_<j> (neither unit normals nor colours)")
    elif c < width:
        reasons.append(f"{c}-{width - 1} kept as column_<j>")
    if width == 3:
        return roles, None
    return roles, "columns " + ("0-2 x y z" + "".join("; " + r for r in reasons))


def _looks_unit(block: np.ndarray) -> bool:
    """Every row a unit vector (within :data:`_UNIT_TOLERANCE`) or zero, one at least unit."""
    if not np.isfinite(block).all():
        return False
    length = np.sqrt(np.einsum("ij,ij->i", block, block))
    unit = np.abs(length - 1.0) <= _UNIT_TOLERANCE
    return bool(unit.any() and (unit | (length == 0.0)).all())


def _colour_range(block: np.ndarray) -> int | None:
    """255 or 65535 when every value is an integer in that range (255 first), else None."""
    if block.size == 0 or not np.isfinite(block).all() or (block != np.rint(block)).any():
        return None
    lo, hi = block.min(), block.max()
    if lo < 0 or hi > 65535:
        return None
    return 255 if hi <= 255 else 65535


def _assemble(table: np.ndarray, roles: list[str], note: str | None) -> RawData:
    """RawData from the table and the columns' roles."""
    where = {role: j for j, role in enumerate(roles)}
    points = np.ascontiguousarray(table[:, [where["x"], where["y"], where["z"]]])
    normals = None
    if "nx" in where:
        normals = np.ascontiguousarray(table[:, [where["nx"], where["ny"], where["nz"]]])
    attributes = {}
    channels = [where[c] for c in ("red", "green", "blue", "alpha") if c in where]
    if len(channels) >= 3:
        values = table[:, channels]
        dtype = np.uint8 if _colour_range(values) == 255 else np.uint16
        if _colour_range(values) is None:
            dtype = np.float64
        attributes["colors"] = values.astype(dtype)
    else:
        channels = []
    fixed = {"x", "y", "z", "nx", "ny", "nz"}
    for j, role in enumerate(roles):
        if role not in fixed and j not in channels:
            attributes[role if role not in _ROLES else f"column_{j}"] = table[:, j].copy()
    meta = {} if note is None else {"columns": note}
    return RawData(points=points, normals=normals, attributes=attributes, meta=meta)


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
