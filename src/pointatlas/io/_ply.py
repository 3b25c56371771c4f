"""PLY reading (header by plyfile, data by numpy) and writing (private)."""

from __future__ import annotations

import mmap
import warnings

import numpy as np
from numpy.lib import recfunctions as rfn
from plyfile import PlyData, PlyListProperty

from ._errors import describe_exception, fail, first_non_number
from ._raw import RawData, colors_to_uint8

__all__ = ["read_ply", "write_ply", "ply_type_name"]

#: numpy dtype -> PLY type name written in headers (the names CloudCompare,
#: MeshLab and plyfile all read).
_PLY_NAMES = {
    "i1": "char",
    "u1": "uchar",
    "i2": "short",
    "u2": "ushort",
    "i4": "int",
    "u4": "uint",
    "f4": "float",
    "f8": "double",
}

_NORMAL_NAMES = (("nx", "ny", "nz"), ("normal_x", "normal_y", "normal_z"))
_COLOR_NAMES = ("red", "green", "blue", "alpha")
_FACE_LIST_NAMES = ("vertex_indices", "vertex_index")
#: The element of triangle strips (Stanford scans, e.g. the Happy Buddha).
_STRIPS = "tristrips"
#: Colour channel types read into ``colors`` as they are.
_KEPT_COLOR_DTYPES = tuple(np.dtype(t) for t in ("u1", "u2", "f4", "f8"))
#: Longest run of records read at once when list lengths repeat (binary lists).
_MAX_RUN = 1 << 20


def ply_type_name(dtype: np.dtype) -> str:
    """PLY type name for a numpy dtype (private; dtype must be one of _PLY_NAMES)."""
    return _PLY_NAMES[np.dtype(dtype).newbyteorder("=").str[1:]]


# --------------------------------------------------------------------------- reading


def read_ply(path) -> RawData:
    """Read the vertex (and face) element of a PLY file (private; see read_point_set)."""
    with open(path, "rb") as fh:
        try:
            header = PlyData._parse_header(fh)
        except Exception as exc:  # plyfile raises several types on garbage headers
            raise fail(path, f"not a valid PLY header ({describe_exception(exc)})") from None
        body = _body(fh, header.text)
    names = [e.name for e in header.elements]
    if "vertex" not in names:
        raise fail(path, f"PLY file has no 'vertex' element (elements: {names})")
    vertex_elt = header["vertex"]
    props = {p.name: p for p in vertex_elt.properties}
    for axis in "xyz":
        if axis not in props or isinstance(props[axis], PlyListProperty):
            raise fail(path, f"PLY 'vertex' element has no scalar property {axis!r}")
    face_name = "face" if "face" in names else ("faces" if "faces" in names else None)
    kept = {"vertex", face_name, _STRIPS} - {None}
    last = max(names.index(k) for k in kept if k in names)
    reader = _AsciiBody(path, body) if header.text else _BinaryBody(path, body, header.byte_order)
    columns = {}
    for elt in header.elements[: last + 1]:
        cols = reader.element(elt)
        if elt.name in kept:
            columns[elt.name] = cols
    for elt in header.elements[last + 1 :]:
        reader.skip(elt)
    reader.finish(header.elements)
    ignored = [
        f"element {e.name!r} ({e.count} records)" for e in header.elements if e.name not in kept
    ]
    raw = _vertex_raw(path, columns["vertex"], ignored)
    if face_name is not None:
        _face_raw(path, header[face_name], columns[face_name], raw, ignored)
    if _STRIPS in columns:
        _strips_raw(path, header[_STRIPS], columns[_STRIPS], raw, ignored)
    if ignored:
        warnings.warn(
            f"{path}: not read (pointatlas keeps vertex properties, faces and tristrips): "
            + ", ".join(ignored),
            UserWarning,
            stacklevel=4,  # read_ply < _load < read_point_set/read_mesh < caller
        )
    return raw


def _body(fh, text: bool):
    """The bytes after the header: memory-mapped for binary files when possible."""
    if text:
        return fh.read()
    start = fh.tell()
    try:
        if hasattr(mmap, "MAP_POPULATE"):  # Linux: fault all pages in one call
            flags = mmap.MAP_SHARED | mmap.MAP_POPULATE
            mapped = mmap.mmap(fh.fileno(), 0, flags=flags, prot=mmap.PROT_READ)
        else:
            mapped = mmap.mmap(fh.fileno(), 0, access=mmap.ACCESS_READ)
    except (OSError, ValueError):
        return fh.read()
    return memoryview(mapped)[start:]


def _stack(cols, names) -> np.ndarray:
    """(N, 3) float64 copy of three columns (one strided cast for binary records)."""
    if isinstance(cols, np.ndarray):
        return rfn.structured_to_unstructured(cols[list(names)], dtype=np.float64, copy=True)
    return np.column_stack([cols[k] for k in names]).astype(np.float64)


def _vertex_raw(path, table, ignored: list[str]) -> RawData:
    """Split the vertex element (a record array or a dict of columns) into RawData."""
    names = list(table.dtype.names) if isinstance(table, np.ndarray) else list(table)
    points = _stack(table, ("x", "y", "z"))
    used = {"x", "y", "z"}
    normals = None
    for triple in _NORMAL_NAMES:
        if all(k in names and not isinstance(table[k], tuple) for k in triple):
            normals = _stack(table, triple)
            used.update(triple)
            break
    cols = {k: table[k] for k in names if k not in used}
    attributes = {}
    colors, used = _vertex_colors(cols)
    if colors is not None:
        attributes["colors"] = colors
        for k in used:
            del cols[k]
    for name, value in cols.items():
        if isinstance(value, tuple):
            attributes[name] = _fixed_list(path, name, *value)
            continue
        attributes[name] = np.array(value, dtype=value.dtype.newbyteorder("="), copy=True)
    return RawData(points=points, normals=normals, attributes=attributes)


def _fixed_list(path, name: str, flat, sizes) -> np.ndarray:
    """A vertex list property as an (N, L) attribute (written back as ``name_0`` ...
    ``name_{L-1}``); lists of different lengths cannot be kept: refused by name."""
    sizes = np.asarray(sizes)
    if sizes.size and (sizes != sizes[0]).any():
        raise fail(
            path,
            f"vertex list property {name!r} has lists of {int(sizes.min())} to "
            f"{int(sizes.max())} values: pointatlas keeps lists of one length only "
            "(drop the property, or make its lists one length)",
        )
    flat = np.asarray(flat)
    width = int(sizes[0]) if sizes.size else 0
    return np.array(flat, dtype=flat.dtype.newbyteorder("="), copy=True).reshape(-1, width)


def _vertex_colors(cols) -> tuple[np.ndarray | None, list[str]]:
    """``colors`` from scalar red/green/blue(/alpha) of one dtype, and the names used.

    uint8, uint16, float32 and float64 channels are kept as they are (so they are
    written back with the same type); other integer types become uint8 when their
    values lie in 0..255. Channels of different types, or out of range, stay
    separate attributes. alpha joins only when it has the colours' dtype.
    """
    scalar = {k: cols[k] for k in _COLOR_NAMES if k in cols and not isinstance(cols[k], tuple)}
    if not all(k in scalar for k in _COLOR_NAMES[:3]):
        return None, []
    dtypes = {k: np.dtype(v.dtype).newbyteorder("=") for k, v in scalar.items()}
    dt = dtypes["red"]
    if dtypes["green"] != dt or dtypes["blue"] != dt:
        return None, []
    used = [k for k in _COLOR_NAMES if k in scalar and dtypes[k] == dt]
    stacked = np.stack([scalar[k] for k in used], axis=1).astype(dt)
    if dt in _KEPT_COLOR_DTYPES:
        return stacked, used
    if dt.kind in "iu":
        converted = colors_to_uint8(stacked)
        if converted is not None:
            return converted, used
    return None, []


def _index_list(path, elt, cols):
    """The element's vertex index list ``(flat int64, sizes)`` and the property's name."""
    lists = [p.name for p in elt.properties if isinstance(p, PlyListProperty)]
    chosen = next((k for k in _FACE_LIST_NAMES if k in lists), None)
    if chosen is None and len(lists) == 1:
        chosen = lists[0]
    if chosen is None:
        raise fail(path, f"PLY '{elt.name}' element has no vertex index list property")
    flat, sizes = cols[chosen]
    if flat.dtype.kind not in "iu":
        if flat.size and (~np.isfinite(flat) | (flat != np.round(flat))).any():
            raise fail(path, f"PLY {elt.name} indices in {chosen!r} are not integers")
    return flat.astype(np.int64), sizes, chosen


def _face_raw(path, elt, cols, raw: RawData, ignored: list[str]) -> None:
    if isinstance(cols, np.ndarray):
        cols = {k: cols[k] for k in cols.dtype.names}
    flat, sizes, chosen = _index_list(path, elt, cols)
    offsets = np.zeros(sizes.size + 1, dtype=np.int64)
    np.cumsum(sizes, out=offsets[1:])
    raw.faces = flat
    raw.face_offsets = offsets
    channels = [k for k in _COLOR_NAMES if k in cols and not isinstance(cols[k], tuple)]
    used = {chosen}
    if channels[:3] == ["red", "green", "blue"]:
        raw.face_colors = colors_to_uint8(np.stack([cols[k] for k in channels], axis=1))
        used.update(channels)
    ignored.extend(f"{elt.name} property {p.name!r}" for p in elt.properties if p.name not in used)


def _strips_raw(path, elt, cols, raw: RawData, ignored: list[str]) -> None:
    """Append the triangles of a ``tristrips`` element to ``raw``'s faces.

    Each record is a strip of vertex ids, ``-1`` restarting it; triangle i of a
    strip is (s_i, s_i+1, s_i+2), every second one reversed (s_i+1, s_i, s_i+2) so
    all keep the strip's orientation; triangles with a repeated id (the joins of
    stitched strips) are left out. Face colours, if any, are dropped (strips have none).
    """
    if isinstance(cols, np.ndarray):
        cols = {k: cols[k] for k in cols.dtype.names}
    flat, sizes, chosen = _index_list(path, elt, cols)
    ignored.extend(f"{elt.name} property {p.name!r}" for p in elt.properties if p.name != chosen)
    tri = strip_triangles(flat, sizes)
    if raw.face_offsets is None:
        raw.faces, raw.face_offsets = np.zeros(0, np.int64), np.zeros(1, np.int64)
    if raw.face_colors is not None and len(tri):
        ignored.append("face colours (the tristrips' triangles have none)")
        raw.face_colors = None
    raw.faces = np.concatenate([raw.faces, tri.reshape(-1)])
    more = raw.face_offsets[-1] + 3 * np.arange(1, len(tri) + 1, dtype=np.int64)
    raw.face_offsets = np.concatenate([raw.face_offsets, more])


def strip_triangles(flat: np.ndarray, sizes: np.ndarray) -> np.ndarray:
    """(T, 3) int64 triangles of triangle strips: each record a strip, ``-1`` restarts.

    Examples
    --------
    >>> strip_triangles(np.array([0, 1, 2, 3, -1, 4, 5, 6]), np.array([8])).tolist()
    [[0, 1, 2], [2, 1, 3], [4, 5, 6]]
    """
    n = flat.size
    index = np.arange(n)
    starts = np.zeros(n, dtype=bool)
    starts[:1] = True
    record_starts = np.cumsum(sizes)[:-1]
    starts[record_starts[record_starts < n]] = True
    starts[1:] |= flat[:-1] < 0
    pos = index - np.maximum.accumulate(np.where(starts, index, 0))
    j = np.flatnonzero((pos >= 2) & (flat >= 0))
    a, b, c = flat[j - 2], flat[j - 1], flat[j]
    odd = pos[j] % 2 == 1
    tri = np.column_stack([np.where(odd, b, a), np.where(odd, a, b), c])
    keep = (tri[:, 0] != tri[:, 1]) & (tri[:, 1] != tri[:, 2]) & (tri[:, 0] != tri[:, 2])
    return tri[keep]


def _element_specs(elt, order: str):
    specs = []
    for p in elt.properties:
        if isinstance(p, PlyListProperty):
            len_dt, val_dt = (np.dtype(d) for d in p.list_dtype(order))
            specs.append((p.name, len_dt, val_dt))
        else:
            specs.append((p.name, None, np.dtype(p.dtype(order))))
    return specs


class _BinaryBody:
    """Sequential reader of binary PLY elements from the bytes after the header."""

    def __init__(self, path, body: bytes, order: str):
        self.path, self.buf, self.order, self.pos = path, body, order, 0

    def _truncated(self, elt, done: int):
        return fail(
            self.path,
            f"truncated binary PLY: element {elt.name!r} declares {elt.count} records but "
            f"the file ends after {done}",
        )

    def element(self, elt) -> dict:
        specs = _element_specs(elt, self.order)
        if all(s[1] is None for s in specs):
            dtype = np.dtype([(name, val) for name, _, val in specs])
            available = (len(self.buf) - self.pos) // max(dtype.itemsize, 1)
            if dtype.itemsize and available < elt.count:
                raise self._truncated(elt, available)
            arr = np.frombuffer(self.buf, dtype=dtype, count=elt.count, offset=self.pos)
            self.pos += dtype.itemsize * elt.count
            return arr
        return self._list_element(elt, specs)

    def skip(self, elt) -> None:
        """Step over an element that is not kept (its records must still be there)."""
        self.element(elt)

    def finish(self, elements) -> None:
        """Refuse bytes after the declared elements (a header count that is too small).

        Up to two trailing line-break bytes (written by some exporters) are allowed.
        """
        extra = len(self.buf) - self.pos
        if extra == 0 or (extra <= 2 and bytes(self.buf[self.pos :]).strip(b"\r\n") == b""):
            return
        raise fail(
            self.path,
            f"binary PLY has {extra} bytes after the declared elements "
            f"({_describe_counts(elements)}); the header declares fewer records than "
            f"the file holds",
        )

    def _list_element(self, elt, specs) -> dict:
        buf, end = self.buf, len(self.buf)
        done, run, pieces = 0, 256, []
        while done < elt.count:
            lengths, q = [], self.pos
            for _, len_dt, val_dt in specs:
                if len_dt is None:
                    q += val_dt.itemsize
                    continue
                if q + len_dt.itemsize > end:
                    raise self._truncated(elt, done)
                n = int(np.frombuffer(buf, dtype=len_dt, count=1, offset=q)[0])
                if n < 0:
                    raise fail(self.path, f"negative list length in PLY element {elt.name!r}")
                lengths.append(n)
                q += len_dt.itemsize + n * val_dt.itemsize
            if q > end:
                raise self._truncated(elt, done)
            fields, it = [], iter(lengths)
            for name, len_dt, val_dt in specs:
                if len_dt is None:
                    fields.append((name, val_dt))
                else:
                    fields.append((name + "\n", len_dt))
                    fields.append((name, val_dt, (next(it),)))
            dtype = np.dtype(fields)
            m = min(elt.count - done, run, (end - self.pos) // dtype.itemsize)
            arr = np.frombuffer(buf, dtype=dtype, count=m, offset=self.pos)
            same = np.ones(m, dtype=bool)
            for (name, _len_dt, _), n in zip(
                (s for s in specs if s[1] is not None), lengths, strict=True
            ):
                same &= arr[name + "\n"] == n
            j = m if same.all() else int(np.argmin(same))
            run = min(run * 4, _MAX_RUN) if j == m else 16
            pieces.append((lengths, arr[:j]))
            self.pos += j * dtype.itemsize
            done += j
        return _assemble(specs, pieces)


def _assemble(specs, pieces) -> dict:
    """Join runs of records into columns: scalar -> (N,), list -> (flat, sizes)."""
    out = {}
    list_no = 0
    for name, len_dt, val_dt in specs:
        if len_dt is None:
            parts = [arr[name] for _, arr in pieces]
            out[name] = np.concatenate(parts) if parts else np.zeros(0, val_dt)
            continue
        flats = [arr[name].reshape(-1) for _, arr in pieces]
        sizes = [np.full(arr.shape[0], lens[list_no], dtype=np.int64) for lens, arr in pieces]
        flat = np.concatenate(flats) if flats else np.zeros(0, val_dt)
        out[name] = (flat, np.concatenate(sizes) if sizes else np.zeros(0, np.int64))
        list_no += 1
    return out


class _AsciiBody:
    """Sequential reader of ASCII PLY elements (one record per non-empty line)."""

    def __init__(self, path, body: bytes):
        self.path = path
        try:
            text = body.decode("ascii")
        except UnicodeDecodeError as exc:
            raise fail(path, f"ASCII PLY body holds non-ASCII bytes (offset {exc.start})") from None
        self.lines = [line for line in text.splitlines() if line.strip()]
        self.pos = 0

    def _take(self, elt) -> list[str]:
        rows = self.lines[self.pos : self.pos + elt.count]
        if len(rows) < elt.count:
            raise fail(
                self.path,
                f"truncated ASCII PLY: element {elt.name!r} declares {elt.count} records but "
                f"the file has {len(rows)} more lines",
            )
        self.pos += elt.count
        return rows

    def skip(self, elt) -> None:
        """Step over an element that is not kept (one line per record)."""
        self._take(elt)

    def finish(self, elements) -> None:
        """Warn about non-empty lines after the declared elements (they are ignored)."""
        extra = len(self.lines) - self.pos
        if extra > 0:
            warnings.warn(
                f"{self.path}: ASCII PLY has {extra} non-empty lines after the declared "
                f"elements ({_describe_counts(elements)}); they are ignored",
                UserWarning,
                stacklevel=5,  # finish < read_ply < _load < read_point_set/read_mesh < caller
            )

    def element(self, elt) -> dict:
        specs = _element_specs(elt, "=")
        rows = self._take(elt)
        if all(s[1] is None for s in specs):
            return self._scalar_element(elt, specs, rows)
        return self._list_element(elt, specs, rows)

    def _numbers(self, elt, tokens) -> np.ndarray:
        try:
            return np.array(tokens, dtype=np.float64)
        except ValueError:
            bad = first_non_number(tokens)
            raise fail(
                self.path, f"non-numeric value {bad[:40]!r} in PLY element {elt.name!r}"
            ) from None

    def _scalar_element(self, elt, specs, rows) -> dict:
        width = len(specs)
        tokens = " ".join(rows).split()
        if len(tokens) != width * elt.count:
            for k, row in enumerate(rows):
                if len(row.split()) != width:
                    raise fail(
                        self.path,
                        f"PLY element {elt.name!r} record {k} has {len(row.split())} values; "
                        f"expected {width}",
                    )
        values = self._numbers(elt, tokens).reshape(elt.count, width)
        return {
            name: self._cast(elt, name, values[:, c], val) for c, (name, _, val) in enumerate(specs)
        }

    def _cast(self, elt, name, column, dtype):
        if dtype.kind in "iu":
            if column.size and (~np.isfinite(column) | (column != np.round(column))).any():
                raise fail(self.path, f"PLY property {elt.name}.{name} must be integers")
            info = np.iinfo(dtype)
            if column.size and (column.min() < info.min or column.max() > info.max):
                raise fail(self.path, f"PLY property {elt.name}.{name} is out of {dtype} range")
        return column.astype(dtype)

    def _list_element(self, elt, specs, rows) -> dict:
        split = [row.split() for row in rows]
        scalars = {name: [] for name, len_dt, _ in specs if len_dt is None}
        lists = {name: ([], []) for name, len_dt, _ in specs if len_dt is not None}
        for k, tokens in enumerate(split):
            q = 0
            try:
                for name, len_dt, _ in specs:
                    if len_dt is None:
                        scalars[name].append(tokens[q])
                        q += 1
                    else:
                        n = int(tokens[q])
                        if n < 0 or q + 1 + n > len(tokens):
                            raise IndexError
                        lists[name][0].extend(tokens[q + 1 : q + 1 + n])
                        lists[name][1].append(n)
                        q += 1 + n
            except (IndexError, ValueError):
                raise fail(
                    self.path, f"PLY element {elt.name!r} record {k} is malformed: {rows[k][:60]!r}"
                ) from None
            if q != len(tokens):
                raise fail(
                    self.path, f"PLY element {elt.name!r} record {k} has extra values"
                ) from None
        out = {}
        for name, len_dt, val in specs:
            if len_dt is None:
                out[name] = self._cast(elt, name, self._numbers(elt, scalars[name]), val)
            else:
                flat = self._cast(elt, name, self._numbers(elt, lists[name][0]), val)
                out[name] = (flat, np.array(lists[name][1], dtype=np.int64))
        return out


def _describe_counts(elements) -> str:
    """``"vertex: 50 declared, face: 10 declared"`` for an error message."""
    return ", ".join(f"{e.name}: {e.count} declared" for e in elements)


# --------------------------------------------------------------------------- writing


def write_ply(
    fh,
    columns: list[tuple[str, np.ndarray]],
    *,
    faces: np.ndarray | None = None,
    face_offsets: np.ndarray | None = None,
    face_colors: np.ndarray | None = None,
    binary: bool = True,
    comments: tuple[str, ...] = (),
) -> None:
    """Write a vertex element (named 1-D columns) and optional faces to binary ``fh``.

    Private: columns are validated 1-D arrays of equal length with dtypes from
    ``_PLY_NAMES``; faces in compressed-row form with valid indices.
    """
    n = columns[0][1].shape[0] if columns else 0
    fmt = "binary_little_endian" if binary else "ascii"
    lines = ["ply", f"format {fmt} 1.0"]
    lines += [f"comment {c}" for c in comments]
    lines.append(f"element vertex {n}")
    lines += [f"property {ply_type_name(col.dtype)} {name}" for name, col in columns]
    sizes = None
    if face_offsets is not None:
        sizes = np.diff(face_offsets)
        len_type = "uchar" if sizes.size == 0 or sizes.max() <= 255 else "uint"
        lines.append(f"element face {sizes.size}")
        lines.append(f"property list {len_type} int vertex_indices")
        if face_colors is not None:
            lines += [f"property uchar {k}" for k in _COLOR_NAMES[: face_colors.shape[1]]]
    lines.append("end_header")
    fh.write(("\n".join(lines) + "\n").encode("ascii"))
    if binary:
        _write_binary_vertices(fh, columns, n)
        if sizes is not None:
            _write_binary_faces(fh, faces, sizes, face_colors, len_type == "uchar")
    else:
        _write_ascii_vertices(fh, columns, n)
        if sizes is not None:
            _write_ascii_faces(fh, faces, face_offsets, face_colors)


def _write_binary_vertices(fh, columns, n: int) -> None:
    if not columns:
        return
    dtype = np.dtype([(name, col.dtype.newbyteorder("<")) for name, col in columns])
    rec = np.empty(n, dtype=dtype)
    for name, col in columns:
        rec[name] = col
    fh.write(rec.tobytes())


def _write_binary_faces(fh, flat, sizes, colors, small_len: bool) -> None:
    len_bytes = 1 if small_len else 4
    n_col = 0 if colors is None else colors.shape[1]
    rec_size = len_bytes + 4 * sizes + n_col
    start = np.zeros(sizes.size, dtype=np.int64)
    np.cumsum(rec_size[:-1], out=start[1:])
    buf = np.zeros(int(rec_size.sum()), dtype=np.uint8)
    len_raw = sizes.astype("<u1" if small_len else "<u4").view(np.uint8).reshape(-1, len_bytes)
    for k in range(len_bytes):
        buf[start + k] = len_raw[:, k]
    face_of = np.repeat(np.arange(sizes.size), sizes)
    first = np.zeros(sizes.size, dtype=np.int64)
    np.cumsum(sizes[:-1], out=first[1:])
    local = np.arange(flat.size) - first[face_of]
    where = start[face_of] + len_bytes + 4 * local
    idx_raw = flat.astype("<i4").view(np.uint8).reshape(-1, 4)
    for k in range(4):
        buf[where + k] = idx_raw[:, k]
    if n_col:
        cpos = start + len_bytes + 4 * sizes
        for k in range(n_col):
            buf[cpos + k] = colors[:, k]
    fh.write(buf.tobytes())


def _write_ascii_vertices(fh, columns, n: int) -> None:
    if not columns or n == 0:
        return
    table = np.column_stack([col.astype(np.float64) for _, col in columns])
    fmt = ["%d" if col.dtype.kind in "iu" else "%.17g" for _, col in columns]
    np.savetxt(fh, table, fmt=fmt, delimiter=" ", newline="\n")


def _write_ascii_faces(fh, flat, offsets, colors) -> None:
    parts = np.split(flat, offsets[1:-1]) if offsets.size > 1 else []
    out = []
    for f, face in enumerate(parts):
        words = [str(face.size), *map(str, face.tolist())]
        if colors is not None:
            words += map(str, colors[f].tolist())
        out.append(" ".join(words))
    if out:
        fh.write(("\n".join(out) + "\n").encode("ascii"))
