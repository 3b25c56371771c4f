"""LAS/LAZ via laspy (LAZ through the lazrs backend) (private).

Reading keeps every dimension and the header (``meta["las_header"]``); writing a
point set that came from LAS keeps that header and its dimensions (see
:func:`plan_las`).
"""

from __future__ import annotations

import copy
import os
import struct
from dataclasses import dataclass, field

import numpy as np

from ._errors import describe_exception, fail
from ._raw import RawData

__all__ = ["LasPlan", "check_las_complete", "plan_las", "read_las", "write_las"]

_RGB = ("red", "green", "blue")
_NORMALS = ("nx", "ny", "nz")
_SKIP = {"X", "Y", "Z", *_RGB}
#: Names laspy cannot take for extra bytes (coordinates, either case).
_COORDS = {"x", "y", "z", "X", "Y", "Z"}
#: dtypes extra bytes can hold (LAS 1.4 R15 table 24), and conversions into them.
_EXTRA_KINDS = {"u1", "i1", "u2", "i2", "u4", "i4", "u8", "i8", "f4", "f8"}
_INT32 = np.iinfo(np.int32)
_MAX_EXTRA_NAME = 32
#: Size of the smallest (LAS 1.0-1.2) public header block.
_MIN_HEADER = 227
#: Where the LAS 1.4 header keeps its 64-bit point count, and the header size that holds it.
_COUNT64_AT, _COUNT64_HEADER = 247, 255
#: Bytes of a VLR's header and of an EVLR's header (LAS 1.4 R15, tables 5 and 7).
_VLR_HEADER, _EVLR_HEADER = 54, 60
#: Where LAS 1.4 keeps the start of its first EVLR (uint64) and their count (uint32).
_EVLR_AT = 235
#: lazrs' words for a compressed stream that ends early.
_LAZ_EOF = "failed to fill whole buffer"


@dataclass(frozen=True, slots=True)
class _LasLayout:
    """The public header fields that fix a LAS file's size (LAS 1.0-1.4 spec)."""

    header_size: int
    point_offset: int
    n_points: int
    record_length: int
    compressed: bool

    @property
    def kind(self) -> str:
        return "LAZ" if self.compressed else "LAS"


def _las_layout(head: bytes) -> _LasLayout | None:
    """The size fields of a LAS header, or None if ``head`` is not one (no ``LASF``)."""
    if head[:4] != b"LASF" or len(head) < _MIN_HEADER:
        return None
    major, minor = head[24], head[25]
    header_size, point_offset = struct.unpack_from("<HI", head, 94)
    if major != 1 or minor > 4 or not _MIN_HEADER <= header_size <= point_offset:
        return None  # not a header we can read the sizes from: laspy says what is wrong
    fmt = head[104]
    record_length, n_points = struct.unpack_from("<HI", head, 105)
    if minor >= 4 and header_size >= _COUNT64_HEADER and len(head) >= _COUNT64_HEADER:
        n_points = struct.unpack_from("<Q", head, _COUNT64_AT)[0]
    return _LasLayout(header_size, point_offset, n_points, record_length, bool(fmt & 0x80))


def check_las_complete(path) -> None:
    """Refuse a LAS/LAZ file shorter than its header says, in words.

    The readers call it before laspy (whose errors on a cut file name no size), and
    so does the tiled LAS source (`pointatlas.batch.LasSource`).

    Parameters
    ----------
    path : str or os.PathLike
        The file. One that cannot be opened, or that is not LAS at all, passes: the
        reader reports it (laspy's own error).

    Raises
    ------
    PointAtlasIOError
        Naming the file: a file cut inside its header, before the first point
        record, before the last point record of an uncompressed file, or before the
        end of the compressed points of a LAZ file (the chunk table offset stored at
        the start of the points).
    """
    try:
        size = os.path.getsize(path)
        with open(path, "rb") as fh:
            head = fh.read(_COUNT64_HEADER)
            lay = _las_layout(head)
            if lay is not None and lay.compressed:
                fh.seek(lay.point_offset)
                raw = fh.read(8)
    except OSError:
        return  # the reader reports it
    if head[:4] == b"LASF" and size < _MIN_HEADER:
        raise fail(
            path,
            f"truncated LAS/LAZ file: {size:,} bytes, shorter than the smallest LAS header "
            f"({_MIN_HEADER} bytes)",
        )
    if head[:4] == b"LASF":
        _check_header(path, head, lay)
    if lay is None:
        return
    if size < lay.header_size:
        raise fail(
            path,
            f"truncated {lay.kind} file: {size:,} bytes, shorter than its "
            f"{lay.header_size}-byte header",
        )
    if size < lay.point_offset:
        raise fail(
            path,
            f"truncated {lay.kind} file: the header puts the first point at byte "
            f"{lay.point_offset:,}, but the file has {size:,} bytes",
        )
    _check_records(path, head, size, lay)
    if not lay.compressed:
        need = lay.point_offset + lay.n_points * lay.record_length
        if size < need:
            raise fail(
                path,
                f"truncated LAS file: the header declares {lay.n_points:,} points of "
                f"{lay.record_length} bytes from byte {lay.point_offset:,}, so at least "
                f"{need:,} bytes, but the file has {size:,} bytes",
            )
        return
    table = struct.unpack("<q", raw)[0] if len(raw) == 8 else -1
    if lay.n_points and (len(raw) < 8 or table + 8 > size):
        end = f"to byte {table:,}" if table > 0 else "past the end"
        raise fail(
            path,
            f"truncated LAZ file: the header declares {lay.n_points:,} points whose "
            f"compressed data runs {end}, but the file has {size:,} bytes",
        )


def _check_header(path, head: bytes, lay: _LasLayout | None) -> None:
    """Refuse a ``LASF`` header that is no LAS 1.0-1.4 one or whose sizes contradict
    each other, before laspy reads it (see `_check_records`)."""
    major, minor = head[24], head[25]
    if major != 1 or minor > 4:
        raise fail(
            path, f"cannot read LAS/LAZ: the header says version {major}.{minor} (1.0-1.4 are read)"
        )
    if lay is None:
        header_size, point_offset = struct.unpack_from("<HI", head, 94)
        raise fail(
            path,
            f"cannot read LAS/LAZ: the header's size ({header_size:,} bytes) and first "
            f"point's offset ({point_offset:,}) contradict each other",
        )


def _check_records(path, head: bytes, size: int, lay: _LasLayout) -> None:
    """Refuse a header that declares more (E)VLRs than the file holds: laspy reads a
    declared count of records on past the end of the file (300 random bytes after
    ``LASF`` once ran for minutes and took 19 GB)."""
    header_size, point_offset, minor = lay.header_size, lay.point_offset, head[25]
    n_vlrs = struct.unpack_from("<I", head, 100)[0]
    need = header_size + _VLR_HEADER * n_vlrs
    if need > point_offset:  # (the file holds its first point's offset: checked before)
        raise fail(
            path,
            f"corrupt {lay.kind} file: the header declares {n_vlrs:,} variable-length "
            f"records from byte {header_size:,}, so at least {need:,} bytes, but puts "
            f"the first point at byte {point_offset:,}",
        )
    if minor < 4 or header_size < _COUNT64_HEADER or len(head) < _COUNT64_HEADER:
        return
    start, n_evlrs = struct.unpack_from("<QI", head, _EVLR_AT)
    if n_evlrs and start + _EVLR_HEADER * n_evlrs > size:
        raise fail(
            path,
            f"truncated or corrupt {lay.kind} file: the header declares {n_evlrs:,} extended "
            f"variable-length records from byte {start:,}, but the file has {size:,} bytes",
        )


def read_las(path) -> RawData:
    """Read scaled x, y, z (float64), every other dimension and the header (private).

    RGB becomes the ``colors`` attribute, (N, 3) uint16 exactly as stored.
    Extra-byte dimensions ``nx, ny, nz`` become normals. ``meta["las_header"]`` is
    the ``laspy.LasHeader`` as read (version, point format, scales, offsets, VLRs,
    EVLRs, extra-bytes definitions); it is never modified.
    """
    import laspy

    check_las_complete(path)
    try:
        las = laspy.read(path)
        points = np.column_stack([np.asarray(las[k], dtype=np.float64) for k in ("x", "y", "z")])
        names = list(las.point_format.dimension_names)
        attributes = {}
        for name in names:
            if name in _SKIP or name in _NORMALS:
                continue
            attributes[name] = np.array(las[name])
        normals = None
        if all(k in names for k in _NORMALS):
            normals = np.column_stack([np.asarray(las[k], dtype=np.float64) for k in _NORMALS])
        if all(k in names for k in _RGB):
            attributes["colors"] = np.column_stack([np.asarray(las[k]) for k in _RGB])
        else:
            attributes.update({k: np.array(las[k]) for k in _RGB if k in names})
        # the header object as read (not a deep copy: a corrupt header can hold huge
        # VLR payloads; writers copy what they change, see plan_las)
        meta = {"las_header": las.header}
    except Exception as exc:  # laspy/lazrs raise many types on corrupt input
        if _LAZ_EOF in str(exc):
            raise fail(path, "truncated LAZ file: its compressed data ends early") from None
        raise fail(path, f"cannot read LAS/LAZ ({describe_exception(exc)})") from None
    return RawData(points=points, normals=normals, attributes=attributes, meta=meta)


def _scale_for(values: np.ndarray) -> tuple[float, float]:
    """Offset and a power-of-ten scale keeping the int32 range with the finest step."""
    if values.size == 0:
        return 0.0, 0.001
    lo, hi = float(values.min()), float(values.max())
    span = max(hi - lo, 1e-300)
    scale = 10.0 ** np.ceil(np.log10(span / 2.0e9))
    return lo, max(float(scale), 1e-12)


def _quantise(values: np.ndarray, offset: float, scale: float) -> np.ndarray | None:
    """laspy's rounding ``round((v - offset) / scale)`` as int32, or None if outside int32."""
    q = np.round((values - offset) / scale)
    if q.size and (q.min() < _INT32.min or q.max() > _INT32.max):
        return None
    return q.astype(np.int32)


@dataclass
class LasPlan:
    """Everything a LAS/LAZ write needs, validated (private; see :func:`plan_las`)."""

    header: object
    xyz: list[np.ndarray]
    assign: dict[str, np.ndarray] = field(default_factory=dict)


def plan_las(path, points, normals, attributes, colors, header=None) -> LasPlan:
    """Validate a LAS/LAZ write and build its header (private; nothing is written).

    With ``header`` (a ``laspy.LasHeader`` read from a file): a deep copy keeps its
    version, point format, scales, offsets, VLRs and extra-bytes dimensions; an
    attribute named like one of its dimensions fills that dimension (its values must
    fit the dimension's type exactly); coordinates are quantised with its scales and
    offsets (bit for bit the stored integers when the points did not move), or,
    for an axis that no longer fits int32, with a new offset (the minimum) and,
    if needed, a new power-of-ten scale as for a fresh file. Without ``header``:
    LAS 1.4, point format 6 (7 with colours), offsets the minima, scales the finest
    power of ten keeping int32. Colours go to the RGB dimensions as 16 bits (uint8 x
    257, uint16 as is, floats in [0, 1] x 65535 rounded) or, for a format without
    RGB, to extra bytes red/green/blue (uint16); a fourth channel to extra bytes
    ``alpha``. Normals and every attribute that is no dimension become extra bytes.
    """
    import laspy

    if header is None:
        header = laspy.LasHeader(point_format=7 if colors is not None else 6, version="1.4")
        scales_offsets = [_scale_for(points[:, c])[::-1] for c in range(3)]
        header.scales = np.array([s for s, _ in scales_offsets])
        header.offsets = np.array([o for _, o in scales_offsets])
    else:
        header = copy.deepcopy(header)
    xyz = _plan_xyz(header, points)
    dims = {d.name: d for d in header.point_format.dimensions}
    assign: dict[str, np.ndarray] = {}
    new_extra: dict[str, np.ndarray] = {}
    origin: dict[str, str] = {}

    def put(name: str, value: np.ndarray, what: str, *, exact: bool = True) -> None:
        if name in _COORDS:
            raise fail(
                path, f"{what} cannot be stored in LAS: {name!r} is reserved for the coordinates"
            )
        if name in origin:
            raise fail(
                path, f"LAS dimension {name!r} would be written twice ({origin[name]} and {what})"
            )
        origin[name] = what
        if name in dims:
            assign[name] = _fit_dimension(path, dims[name], value, what, exact=exact)
        else:
            new_extra[name] = _extra_column(path, name, value, what)

    if colors is not None:
        rgb = _colors_16(path, colors[:, :3])
        for c, k in enumerate(_RGB):
            put(k, rgb[:, c], "colors")
        if colors.shape[1] == 4:
            put("alpha", colors[:, 3], "colors (alpha)")
    if normals is not None:
        for c, k in enumerate(_NORMALS):
            put(k, normals[:, c], "normals", exact=False)
    for name, value in attributes.items():
        dim = dims.get(name)
        if value.ndim == 1 or (dim is not None and dim.num_elements == value.shape[1]):
            put(name, value, f"attribute {name!r}")
        else:
            for j in range(value.shape[1]):
                put(f"{name}_{j}", value[:, j], f"attribute {name!r} (column {j})")
    if new_extra:
        header.add_extra_dims(
            [laspy.ExtraBytesParams(name=k, type=v.dtype) for k, v in new_extra.items()]
        )
        assign.update(new_extra)
    return LasPlan(header=header, xyz=xyz, assign=assign)


def _plan_xyz(header, points: np.ndarray) -> list[np.ndarray]:
    """Quantise each axis with the header's scale/offset, re-choosing them when needed."""
    scales, offsets = np.array(header.scales, float), np.array(header.offsets, float)
    out = []
    for c in range(3):
        q = _quantise(points[:, c], offsets[c], scales[c])
        if q is None:  # moved out of int32: offset at the minimum, then a coarser scale
            offsets[c] = float(points[:, c].min())
            q = _quantise(points[:, c], offsets[c], scales[c])
        if q is None:
            offsets[c], scales[c] = _scale_for(points[:, c])
            q = _quantise(points[:, c], offsets[c], scales[c])
        out.append(q)
    header.scales, header.offsets = scales, offsets
    return out


def _colors_16(path, rgb: np.ndarray) -> np.ndarray:
    """RGB as LAS's uint16: uint8 x 257, uint16 as is, floats in [0, 1] x 65535."""
    if rgb.dtype == np.uint16:
        return rgb
    if rgb.dtype == np.uint8:
        return rgb.astype(np.uint16) * np.uint16(257)
    if rgb.size and not (np.isfinite(rgb).all() and rgb.min() >= 0 and rgb.max() <= 1):
        raise fail(
            path,
            f"LAS stores colours as 16-bit integers; float colors must lie in [0, 1], got "
            f"[{np.nanmin(rgb):.6g}, {np.nanmax(rgb):.6g}]",
        )
    return np.rint(rgb.astype(np.float64) * 65535.0).astype(np.uint16)


def _fit_dimension(path, dim, value: np.ndarray, what: str, *, exact: bool) -> np.ndarray:
    """Check that ``value`` fits the dimension ``dim`` without loss; return it cast."""
    if dim.scales is not None or dim.offsets is not None:
        return value.astype(np.float64)  # scaled extra bytes: laspy quantises
    is_bits = dim.kind.name == "BitField"
    if is_bits:
        target = np.dtype(np.uint8)
    else:
        target = np.dtype(dim.dtype.base if dim.dtype.subdtype else dim.dtype)
    if is_bits:
        lo, hi = 0, (1 << dim.num_bits) - 1
    elif target.kind in "iu":
        info = np.iinfo(target)
        lo, hi = info.min, info.max
    else:
        lo = hi = None
    if value.dtype.kind == "b":
        value = value.astype(np.uint8)
    cast = value.astype(target)
    if not exact:
        return cast
    if lo is not None:
        ok = value.dtype.kind in "iu" or (
            np.isfinite(value).all() and np.array_equal(value, np.round(value))
        )
        ok = ok and (value.size == 0 or (value.min() >= lo and value.max() <= hi))
    else:
        ok = np.array_equal(cast.astype(value.dtype), value, equal_nan=True)
    if not ok:
        bits = f", {dim.num_bits} bits" if is_bits else ""
        raise fail(
            path,
            f"{what} ({value.dtype}) does not fit the LAS dimension {dim.name!r} "
            f"({target}{bits}) without loss",
        )
    return cast


def _extra_column(path, name: str, value: np.ndarray, what: str) -> np.ndarray:
    """A new extra-bytes column: bool -> uint8, float16 -> float32; checks the name."""
    if not name.isascii() or not name or len(name) > _MAX_EXTRA_NAME:
        raise fail(
            path,
            f"{what} cannot be a LAS extra-bytes name: {name!r} must be 1 to "
            f"{_MAX_EXTRA_NAME} ASCII characters",
        )
    if value.dtype.kind == "b":
        value = value.astype(np.uint8)
    elif value.dtype == np.float16:
        value = value.astype(np.float32)
    code = value.dtype.newbyteorder("=").str[1:]
    if code not in _EXTRA_KINDS:
        raise fail(path, f"{what} of dtype {value.dtype} cannot be stored as LAS extra bytes")
    return value.astype(value.dtype.newbyteorder("<"))


def write_las(path_or_fh, plan: LasPlan, *, laz: bool) -> None:
    """Write a planned point set (private; see :func:`plan_las`)."""
    import laspy

    header = plan.header
    n = plan.xyz[0].shape[0]
    las = laspy.LasData(header, points=laspy.ScaleAwarePointRecord.zeros(n, header=header))
    las.X, las.Y, las.Z = plan.xyz
    for name, value in plan.assign.items():
        las[name] = value
    las.write(path_or_fh, do_compress=laz)
