"""Wavefront OBJ and OFF reading and writing (private)."""

from __future__ import annotations

import re

import numpy as np

from ._errors import fail
from ._raw import RawData, colors_to_uint8

__all__ = ["read_obj", "read_off", "write_obj", "write_off"]


def _read_text(path) -> str:
    with open(path, "rb") as fh:
        data = fh.read()
    if b"\x00" in data:
        raise fail(path, "binary data (NUL bytes) in a text mesh file")
    return data.decode("utf-8", errors="replace")


def _to_float(path, rows: list, what: str, line_numbers: list[int]) -> np.ndarray:
    try:
        return np.array(rows, dtype=np.float64)
    except ValueError:
        for row, line in zip(rows, line_numbers, strict=True):
            try:
                np.array(row, dtype=np.float64)
            except ValueError:
                raise fail(
                    path, f"line {line}: non-numeric {what}: {' '.join(row)[:60]!r}"
                ) from None
        raise fail(path, f"malformed {what}") from None


_V_RE = re.compile(r"^[ \t]*v[ \t]+([^\r\n]*)", re.MULTILINE)
_F_RE = re.compile(r"^[ \t]*f[ \t]+([^\r\n]*)", re.MULTILINE)
_SLASH_RE = re.compile(r"/[^\s]*")


def read_obj(path) -> RawData:
    """Read ``v`` and ``f`` records of an OBJ file (private; see read_point_set).

    Texture coordinates, normals (``vt``/``vn``), lines, groups and materials are
    ignored; vertices are the ``v`` records in file order.
    """
    text = _read_text(path)
    raw = _read_obj_fast(text)
    return raw if raw is not None else _read_obj_lines(path, text)


def _read_obj_fast(text: str) -> RawData | None:
    """Vectorised parse of the common case (x y z vertices, positive indices).

    Returns None when anything is unusual; the line-by-line parser then handles
    the file and reports errors with line numbers.
    """
    vrows = _V_RE.findall(text)
    frows = _F_RE.findall(text)
    if not vrows:
        return None
    try:
        coords = np.array(" ".join(vrows).split(), dtype=np.float64)
        if coords.size != 3 * len(vrows):
            return None
        joined = " ".join(frows)
        if "/" in joined:
            joined = _SLASH_RE.sub("", joined)
        flat = np.array(joined.split(), dtype=np.int64)
    except (ValueError, OverflowError):
        return None
    sizes = np.fromiter((len(r.split()) for r in frows), dtype=np.int64, count=len(frows))
    if sizes.sum() != flat.size or (flat.size and flat.min() < 1):
        return None
    offsets = np.zeros(len(frows) + 1, dtype=np.int64)
    np.cumsum(sizes, out=offsets[1:])
    return RawData(points=coords.reshape(-1, 3), faces=flat - 1, face_offsets=offsets)


def _read_obj_lines(path, text: str) -> RawData:
    """Line-by-line OBJ parser: colours, negative indices, precise error lines."""
    vrows: list[list[str]] = []
    vlines: list[int] = []
    flat: list[int] = []
    sizes: list[int] = []
    for lineno, line in enumerate(text.splitlines(), 1):
        parts = line.split("#", 1)[0].split()
        if not parts or parts[0] not in ("v", "f"):
            continue
        key = parts[0]
        if key == "v":
            vrows.append(parts[1:])
            vlines.append(lineno)
        elif key == "f":
            n_now = len(vrows)
            try:
                idx = [int(tok.split("/", 1)[0]) for tok in parts[1:]]
            except ValueError:
                raise fail(path, f"line {lineno}: malformed face {line[:60]!r}") from None
            flat.extend(i - 1 if i > 0 else n_now + i for i in idx)
            if 0 in idx:
                raise fail(path, f"line {lineno}: OBJ indices start at 1; got 0")
            sizes.append(len(idx))
    if not vrows:
        raise fail(path, "no vertices ('v' records) in OBJ file")
    widths = {len(r) for r in vrows}
    colors = None
    if widths == {3}:
        points = _to_float(path, vrows, "vertex", vlines)
    else:
        short = [ln for r, ln in zip(vrows, vlines, strict=True) if len(r) < 3]
        if short:
            raise fail(path, f"line {short[0]}: vertex with fewer than 3 coordinates")
        points = _to_float(path, [r[:3] for r in vrows], "vertex", vlines)
        if widths in ({6}, {7}):
            colors = colors_to_uint8(_to_float(path, [r[3:6] for r in vrows], "colour", vlines))
    attributes = {"colors": colors} if colors is not None else {}
    offsets = np.zeros(len(sizes) + 1, dtype=np.int64)
    np.cumsum(np.array(sizes, dtype=np.int64), out=offsets[1:])
    return RawData(
        points=points,
        attributes=attributes,
        faces=np.array(flat, dtype=np.int64),
        face_offsets=offsets,
    )


def read_off(path) -> RawData:
    """Read an ASCII OFF/COFF/NOFF/CNOFF file (private; see read_point_set).

    The header keyword's prefix names the vertex columns after x y z (Geomview's
    order): ``N`` normals (3), ``C`` a colour (RGB or RGBA, integers 0..255 or floats
    in [0, 1]: ``colors``; other values: ``column_<j>``); other columns are kept as
    ``column_<j>``. A face line may end with an RGB(A) colour likewise.
    """
    text = _read_text(path)
    lines = []
    for lineno, line in enumerate(text.splitlines(), 1):
        body = line.split("#", 1)[0].split()
        if body:
            lines.append((lineno, body))
    if not lines or not lines[0][1][0].endswith("OFF"):
        raise fail(path, "missing 'OFF' keyword on the first line")
    head = lines[0][1]
    if "BINARY" in (t.upper() for t in head[1:]):
        raise fail(path, "binary OFF is not supported")
    counts, cursor = head[1:], 1
    if not counts:
        if len(lines) < 2:
            raise fail(path, "missing vertex/face counts line")
        counts, cursor = lines[1][1], 2
    try:
        n_vert, n_face = int(counts[0]), int(counts[1])
    except (ValueError, IndexError):
        raise fail(path, f"malformed counts line {' '.join(counts)[:60]!r}") from None
    if n_vert < 0 or n_face < 0:
        raise fail(path, f"negative vertex/face counts {n_vert}, {n_face}")
    vpart = lines[cursor : cursor + n_vert]
    fpart = lines[cursor + n_vert : cursor + n_vert + n_face]
    if len(vpart) < n_vert or len(fpart) < n_face:
        raise fail(
            path,
            f"file ends early: header declares {n_vert} vertices and {n_face} faces, "
            f"found {len(vpart)} vertex and {len(fpart)} face lines",
        )
    short = [ln for ln, toks in vpart if len(toks) < 3]
    if short:
        raise fail(path, f"line {short[0]}: vertex with fewer than 3 coordinates")
    points = _to_float(path, [t[:3] for _, t in vpart], "vertex", [ln for ln, _ in vpart])
    normals, attributes = _off_vertex_columns(path, head[0][:-3].upper(), vpart)
    flat: list[int] = []
    sizes: list[int] = []
    colors: list[list[str]] = []
    for lineno, toks in fpart:
        try:
            k = int(toks[0])
            idx = [int(t) for t in toks[1 : 1 + k]]
        except (ValueError, IndexError):
            raise fail(path, f"line {lineno}: malformed face {' '.join(toks)[:60]!r}") from None
        if len(idx) != k:
            raise fail(path, f"line {lineno}: face declares {k} vertices, lists {len(idx)}")
        flat.extend(idx)
        sizes.append(k)
        colors.append(toks[1 + k :])
    face_colors = None
    widths = {len(c) for c in colors}
    if colors and widths in ({3}, {4}):
        values = _to_float(path, colors, "face colour", [ln for ln, _ in fpart])
        if (values == np.round(values)).all() and values.max() > 1:
            values = values.astype(np.int64)
        face_colors = colors_to_uint8(values)
    offsets = np.zeros(len(sizes) + 1, dtype=np.int64)
    np.cumsum(np.array(sizes, dtype=np.int64), out=offsets[1:])
    return RawData(
        points=points,
        normals=normals,
        attributes=attributes,
        faces=np.array(flat, dtype=np.int64),
        face_offsets=offsets,
        face_colors=face_colors,
    )


def _off_vertex_columns(path, prefix: str, vpart):
    """Normals and attributes from the vertex columns after x y z (see `read_off`)."""
    widths = {len(t) for _, t in vpart}
    if not vpart or widths == {3}:
        return None, {}
    if len(widths) != 1:
        raise fail(path, f"vertex lines have different numbers of columns: {sorted(widths)}")
    table = _to_float(path, [t[3:] for _, t in vpart], "vertex", [ln for ln, _ in vpart])
    normals, attributes, j = None, {}, 0
    if "N" in prefix and table.shape[1] >= 3:
        normals, j = table[:, :3], 3
    if "C" in prefix and table.shape[1] - j >= 3:
        width = 4 if table.shape[1] - j >= 4 and "ST" not in prefix else 3
        values = table[:, j : j + width]
        if (values == np.round(values)).all() and values.max(initial=0.0) > 1:
            values = values.astype(np.int64)
        converted = colors_to_uint8(values)
        if converted is not None:
            attributes["colors"], j = converted, j + width
    for c in range(j, table.shape[1]):
        attributes[f"column_{c + 3}"] = table[:, c]
    return normals, attributes


def _float_lines(prefix: str, rows: np.ndarray) -> list[str]:
    return [prefix + " ".join(map(repr, row)) for row in rows.tolist()]


def _face_lines(prefix: str, flat, offsets, shift: int, with_count: bool, colors=None) -> list:
    sizes = np.diff(offsets)
    out = []
    if sizes.size and (sizes == sizes[0]).all() and colors is None:
        table = (flat.reshape(-1, int(sizes[0])) + shift).tolist()
        head = f"{prefix}{int(sizes[0])} " if with_count else prefix
        return [head + " ".join(map(str, row)) for row in table]
    for f, face in enumerate(np.split(flat + shift, offsets[1:-1]) if sizes.size else []):
        words = ([str(face.size)] if with_count else []) + list(map(str, face.tolist()))
        if colors is not None:
            words += list(map(str, colors[f].tolist()))
        out.append(prefix + " ".join(words))
    return out


def write_obj(fh, vertices, faces, face_offsets) -> None:
    """Write an OBJ mesh (1-based indices, polygons kept) to text ``fh`` (private)."""
    lines = _float_lines("v ", vertices) + _face_lines("f ", faces, face_offsets, 1, False)
    fh.write("\n".join(lines) + ("\n" if lines else ""))


def write_off(fh, vertices, faces, face_offsets, face_colors=None) -> None:
    """Write an OFF mesh with optional integer RGB(A) face colours to text ``fh`` (private)."""
    n_faces = face_offsets.size - 1
    lines = ["OFF", f"{vertices.shape[0]} {n_faces} 0"]
    lines += _float_lines("", vertices)
    lines += _face_lines("", faces, face_offsets, 0, True, face_colors)
    fh.write("\n".join(lines) + "\n")
