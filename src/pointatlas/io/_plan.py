"""Validating a point-set write before anything is written (one path for check and write)."""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .._core import PointAtlasError, PointSet, as_normals, as_points
from ._attrs import normalise_colors, ply_name_problem
from ._errors import fail
from ._las import LasPlan, plan_las

__all__ = ["POINT_WRITE_EXTENSIONS", "WritePlan", "check_point_set_writable", "plan_write"]

#: Extensions write_point_set understands.
POINT_WRITE_EXTENSIONS = (".las", ".laz", ".ply", ".txt", ".xyz")
_COLOR_CHANNELS = ("red", "green", "blue", "alpha")


@dataclass
class WritePlan:
    """A validated point-set write (private): what goes into the file, by format."""

    path: Path
    ext: str
    points: np.ndarray
    normals: np.ndarray | None
    ply_columns: list[tuple[str, np.ndarray]] | None = None
    las: LasPlan | None = None


def check_point_set_writable(path, data, *, normals=None, attributes=None, colors=None) -> None:
    """Raise the error :func:`write_point_set` would raise, without writing anything.

    Parameters
    ----------
    path : str or os.PathLike
        Destination; only its extension matters (the folder is not checked).
    data : PointSet or array_like of shape (N, 3)
        The points, as for :func:`write_point_set` (a PointSet brings its normals,
        attributes and, from LAS, its header).
    normals : array_like of shape (N, 3), optional
        Normals replacing those of ``data``.
    attributes : mapping of str to array_like of shape (N,) or (N, k), optional
        Extra per-point fields (added to, or replacing, those of ``data``); their
        names and dtypes are what is checked, so placeholder arrays of the right
        shape and dtype will do.
    colors : array_like of shape (N, 3) or (N, 4), optional
        RGB(A) as for :func:`write_point_set`.

    Returns
    -------
    None
        The write would succeed as far as the data goes (the disk may still fail).

    Raises
    ------
    PointAtlasIOError
        Unsupported extension, an attribute name or dtype the format cannot store,
        two fields that would get the same name in the file, values that do not fit
        a LAS dimension, colours LAS cannot store.
    PointAtlasError
        Invalid points, normals, attributes or colours.

    Notes
    -----
    :func:`write_point_set` runs exactly this check before it writes, so a
    command can call it first and fail before doing its work.

    Examples
    --------
    >>> check_point_set_writable("out.ply", [[0, 0, 0]], attributes={"scalar_Intensity(1)": [2.5]})
    >>> try:
    ...     check_point_set_writable("out.ply", [[0, 0, 0]], attributes={"my label": [1]})
    ... except ValueError as exc:
    ...     print(exc)
    out.ply: attribute 'my label' cannot be a PLY property: it contains whitespace
    """
    plan_write(path, data, normals, attributes, colors)


def plan_write(path, data, normals, attributes, colors) -> WritePlan:
    """Validate everything a point-set write needs and prepare it (private)."""
    p = Path(os.fspath(path))
    ext = p.suffix.lower()
    if ext not in POINT_WRITE_EXTENSIONS:
        raise fail(
            p, f"cannot write point sets as {ext or '(none)'!r}; use {POINT_WRITE_EXTENSIONS}"
        )
    points, nrm, attrs, cols = _gather(data, normals, attributes, colors)
    plan = WritePlan(path=p, ext=ext, points=points, normals=nrm)
    if ext == ".ply":
        plan.ply_columns = _ply_columns(p, points, nrm, attrs, cols)
    elif ext in (".las", ".laz"):
        header = _las_header(data)
        plan.las = plan_las(p, points, nrm, attrs, cols, header)
    return plan


def _las_header(data):
    """The laspy header a PointSet read from LAS carries, else None."""
    if not isinstance(data, PointSet):
        return None
    header = data.meta.get("las_header")
    if header is None:
        return None
    import laspy

    return header if isinstance(header, laspy.LasHeader) else None


def _gather(data, normals, attributes, colors):
    """Validated points, normals, attributes (without colours) and colours."""
    if isinstance(data, PointSet):
        points = data.points
        base_normals = data.normals
        attrs = dict(data.attributes)
    else:
        try:
            points = as_points(data, name="data", min_points=0)
        except (TypeError, ValueError) as exc:
            raise PointAtlasError(str(exc)) from None
        base_normals, attrs = None, {}
    n = points.shape[0]
    try:
        nrm = as_normals(normals, n) if normals is not None else base_normals
    except (TypeError, ValueError) as exc:
        raise PointAtlasError(str(exc)) from None
    for key, value in dict(attributes or {}).items():
        attrs[str(key)] = np.asarray(value)
    if colors is not None:
        attrs["colors"] = np.asarray(colors)
    for key, value in attrs.items():
        if value.ndim not in (1, 2) or value.shape[0] != n:
            raise PointAtlasError(
                f"attribute {key!r} must have shape (N,) or (N, k) with N = {n}; got {value.shape}"
            )
        if value.dtype.kind not in "biuf":
            raise PointAtlasError(f"attribute {key!r} must be numeric; got dtype {value.dtype}")
    cols = None
    if "colors" in attrs:
        value = attrs.pop("colors")
        cols = normalise_colors(value, given=colors is not None)
        if cols is None:
            raise PointAtlasError(
                "colors must have shape (N, 3) or (N, 4): uint8, uint16, integers 0..255 or "
                f"floats in [0, 1]; got shape {value.shape}, dtype {value.dtype}"
            )
    return points, nrm, attrs, cols


def _ply_column(path, what: str, values: np.ndarray) -> np.ndarray:
    """Convert one attribute column to a PLY-storable dtype (see io-decisions)."""
    kind, size = values.dtype.kind, values.dtype.itemsize
    if kind == "b":
        return values.astype(np.uint8)
    if kind == "f":
        return values.astype(np.float32 if size <= 4 else np.float64)
    if kind in "iu" and size <= 4:
        return values
    if kind in "iu":
        target = np.int32 if kind == "i" else np.uint32
        info = np.iinfo(target)
        if values.size == 0 or (values.min() >= info.min and values.max() <= info.max):
            return values.astype(target)
        if np.abs(values.astype(np.float64)).max() <= 2.0**53:
            return values.astype(np.float64)
    raise fail(path, f"{what} of dtype {values.dtype} cannot be stored in PLY")


def _ply_columns(path, points, nrm, attrs, cols) -> list[tuple[str, np.ndarray]]:
    """Named PLY vertex columns (coordinates, normals, attributes, colours).

    Every name must be valid in PLY and used once: an attribute may be called
    ``nx`` or ``alpha`` as long as no normals or no fourth colour channel are
    written.
    """
    fixed = [(k, "the coordinates", points[:, c]) for c, k in enumerate("xyz")]
    if nrm is not None:
        fixed += [(k, "the normals", nrm[:, c]) for c, k in enumerate(("nx", "ny", "nz"))]
    colour = []
    if cols is not None:
        colour = [(k, "colors", cols[:, c]) for c, k in enumerate(_COLOR_CHANNELS[: cols.shape[1]])]
    owner = {name: what for name, what, _ in fixed + colour}
    columns = [(name, values) for name, _, values in fixed]
    for key, value in attrs.items():
        what = f"attribute {key!r}"
        if value.ndim == 1:
            parts = [(key, what, value)]
        else:
            parts = [
                (f"{key}_{j}", f"{what} (column {j})", value[:, j]) for j in range(value.shape[1])
            ]
        for name, part_what, values in parts:
            problem = ply_name_problem(name)
            if problem is not None:
                raise fail(path, f"{part_what} cannot be a PLY property: {problem}")
            if name in owner:
                other = owner[name]
                if other in ("the coordinates", "the normals", "colors"):
                    msg = f"cannot be a PLY property: {name!r} is reserved for {other}"
                else:
                    msg = f"would be written as PLY property {name!r} twice (also {other})"
                raise fail(path, f"{part_what} {msg}")
            owner[name] = part_what
            columns.append((name, _ply_column(path, part_what, values)))
    return columns + [(name, values) for name, _, values in colour]
