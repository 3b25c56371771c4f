"""Attribute names and colours shared by the writers: merging, PLY names, colour dtypes."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from .._core import PointAtlasError
from ._raw import colors_to_uint8

__all__ = ["RESERVED_NAMES", "merge_attributes"]

#: Names that file formats give to coordinates, normals and colours; new fields
#: never take them (see :func:`merge_attributes`).
RESERVED_NAMES = frozenset(
    {"x", "y", "z", "nx", "ny", "nz", "red", "green", "blue", "alpha", "colors"}
)
#: Colour dtypes written as they are (uchar, ushort, float, double in PLY).
COLOR_DTYPES = (np.dtype(np.uint8), np.dtype(np.uint16), np.dtype(np.float32), np.dtype(np.float64))


def merge_attributes(base, ours, *, prefix: str = "pa_") -> dict:
    """Add new per-point fields to existing ones without replacing any of them.

    Parameters
    ----------
    base : mapping of str to array_like
        The fields already there (e.g. ``point_set.attributes`` of a file read);
        every entry is kept unchanged under its own name.
    ours : mapping of str to array_like
        The new fields. An entry keeps its name unless that name (or, for an
        (N, m) array, one of the column names ``name_0 .. name_{m-1}`` the writers
        give it) is in ``base`` or reserved by the file formats (x, y, z, nx, ny,
        nz, red, green, blue, alpha, colors); then ``prefix`` is put in front, repeatedly, until the
        name is free.
    prefix : str
        Non-empty prefix for renamed entries of ``ours``.

    Returns
    -------
    merged : dict of str to array_like
        ``base``'s entries (same objects, same order) followed by ``ours``'s
        entries (same objects, order of ``ours``), some renamed.

    Raises
    ------
    PointAtlasError
        ``base`` or ``ours`` is not a mapping, a key is not a str, or ``prefix``
        is empty or not a str.

    Notes
    -----
    Names of ``ours`` that are free keep their names first, so a renamed entry
    never takes a name that another entry of ``ours`` asked for. The CLI uses this
    so the input's fields survive and a computed field never silently replaces one.

    Examples
    --------
    >>> merged = merge_attributes({"label": [1, 2], "red": [3, 4]}, {"label": [5, 6], "e": [0, 0]})
    >>> list(merged), merged["label"], merged["pa_label"]
    (['label', 'red', 'pa_label', 'e'], [1, 2], [5, 6])
    >>> list(merge_attributes({}, {"nx": [0.0]}))
    ['pa_nx']
    >>> list(merge_attributes({"n_0": [0.0], "n_1": [0.0]}, {"n": [[1.0, 2.0]]}))
    ['n_0', 'n_1', 'pa_n']
    """
    if not isinstance(prefix, str) or not prefix:
        raise PointAtlasError(f"prefix must be a non-empty str; got {prefix!r}")
    for label, mapping in (("base", base), ("ours", ours)):
        if not isinstance(mapping, Mapping):
            raise PointAtlasError(
                f"{label} must be a mapping of str to arrays; got {type(mapping).__name__}"
            )
        bad = [k for k in mapping if not isinstance(k, str)]
        if bad:
            raise PointAtlasError(f"{label} keys must be str; got {bad[0]!r}")
    merged = dict(base)
    taken = set(RESERVED_NAMES)
    for key, value in merged.items():
        taken.update(_written_names(key, value))
    clashing = []
    for key, value in ours.items():
        names = _written_names(key, value)
        if names & taken:
            clashing.append(key)
        else:
            taken.update(names)
    renamed = {}
    for key in clashing:
        new = prefix + key
        while _written_names(new, ours[key]) & taken:
            new = prefix + new
        taken.update(_written_names(new, ours[key]))
        renamed[key] = new
    for key, value in ours.items():
        merged[renamed.get(key, key)] = value
    return merged


def _written_names(key: str, value) -> set[str]:
    """The names a field takes in a file: ``key``, plus ``key_0 .. key_{m-1}`` for an
    (N, m) array (how the PLY and LAS writers spell its columns)."""
    shape = np.shape(value)
    if len(shape) == 2:
        return {key} | {f"{key}_{j}" for j in range(shape[1])}
    return {key}


def ply_name_problem(name: str) -> str | None:
    """Why ``name`` cannot be a PLY property name (plyfile's rule), or None if it can.

    PLY headers are whitespace-separated ASCII, so a name must be non-empty ASCII
    without whitespace; anything else (brackets, parentheses, dots) is allowed.
    """
    if not name:
        return "it is empty"
    for char in name:
        if not 0 <= ord(char) < 128:
            return f"it has the non-ASCII character {char!r}"
        if char.isspace():
            return "it contains whitespace"
    return None


def normalise_colors(value: np.ndarray, *, given: bool) -> np.ndarray | None:
    """Colours as written: uint8/uint16 kept; attribute floats kept; else converted.

    ``given`` (the ``colors=`` argument): uint8 and uint16 kept, other integers
    0..255 -> uint8, floats in [0, 1] -> uint8 (16 bits only by dtype, never
    guessed). Otherwise (a ``colors`` attribute, e.g. as read from a file) uint8,
    uint16, float32 and float64 are kept as they are, float16 becomes float32 and
    other dtypes are converted as for ``given``.
    Returns None when the values fit no convention. Private; ``value`` is (N, k).
    """
    if value.ndim != 2 or value.shape[1] not in (3, 4):
        return None
    if value.dtype in COLOR_DTYPES[:2]:
        return value
    if not given and value.dtype.kind == "f":
        return value if value.dtype in COLOR_DTYPES else value.astype(np.float32)
    return colors_to_uint8(value)
