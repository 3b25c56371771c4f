"""LAS/LAZ via laspy (LAZ through the lazrs backend) (private)."""

from __future__ import annotations

import numpy as np

from ._errors import describe_exception, fail
from ._raw import RawData

__all__ = ["read_las", "write_las"]

_SKIP = {"X", "Y", "Z", "red", "green", "blue"}
_NORMALS = ("nx", "ny", "nz")


def read_las(path) -> RawData:
    """Read scaled x, y, z (float64) and every other dimension as an attribute (private).

    RGB becomes the ``colors`` attribute (uint8; 16-bit values are shifted down by 8
    bits when any exceeds 255). Extra-byte dimensions ``nx, ny, nz`` become normals.
    """
    import laspy

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
        if all(k in names for k in ("red", "green", "blue")):
            rgb = np.column_stack([np.asarray(las[k]) for k in ("red", "green", "blue")])
            if rgb.size and rgb.max() > 255:
                rgb = rgb >> 8
            attributes["colors"] = rgb.astype(np.uint8)
    except Exception as exc:  # laspy/lazrs raise many types on corrupt input
        raise fail(path, f"cannot read LAS/LAZ ({describe_exception(exc)})") from None
    return RawData(points=points, normals=normals, attributes=attributes)


def _scale_for(values: np.ndarray) -> tuple[float, float]:
    """Offset and a power-of-ten scale keeping the int32 range with the finest step."""
    if values.size == 0:
        return 0.0, 0.001
    lo, hi = float(values.min()), float(values.max())
    span = max(hi - lo, 1e-300)
    scale = 10.0 ** np.ceil(np.log10(span / 2.0e9))
    return lo, max(float(scale), 1e-12)


def write_las(path_or_fh, points, normals, attributes, colors, *, laz: bool) -> None:
    """Write LAS 1.4, point format 6 (7 with colours); attributes as extra bytes (private)."""
    import laspy

    header = laspy.LasHeader(point_format=7 if colors is not None else 6, version="1.4")
    offsets, scales = zip(*(_scale_for(points[:, c]) for c in range(3)), strict=True)
    header.offsets = np.array(offsets)
    header.scales = np.array(scales)
    standard = set(header.point_format.dimension_names)
    extra = {}
    for name, value in attributes.items():
        if name in standard and value.ndim == 1:
            continue
        extra[name] = value
    if normals is not None:
        extra.update({k: normals[:, c] for c, k in enumerate(_NORMALS)})
    for name, value in extra.items():
        if value.ndim != 1:
            raise fail(path_or_fh, f"LAS attribute {name!r} must be one value per point")
        header.add_extra_dim(laspy.ExtraBytesParams(name=name, type=value.dtype))
    las = laspy.LasData(header)
    las.x, las.y, las.z = points[:, 0], points[:, 1], points[:, 2]
    for name, value in attributes.items():
        if name in standard and value.ndim == 1:
            las[name] = value
    for name, value in extra.items():
        las[name] = value
    if colors is not None:
        for c, k in enumerate(("red", "green", "blue")):
            las[k] = colors[:, c].astype(np.uint16) * 257
    las.write(path_or_fh, do_compress=laz)
