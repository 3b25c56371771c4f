"""The small frozen point-set container."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from types import MappingProxyType

import numpy as np

from ._validation import as_normals, as_points

__all__ = ["PointSet", "readonly", "readonly_view"]


def readonly(arr: np.ndarray | None) -> np.ndarray | None:
    """Return ``arr`` with its writeable flag cleared (None passes through).

    Parameters
    ----------
    arr : array_like or None
        The array (made an ndarray with `numpy.asarray`, not copied when it is one).

    Returns
    -------
    ndarray or None
        The same array, read-only.
    """
    if arr is None:
        return None
    arr = np.asarray(arr)
    arr.flags.writeable = False
    return arr


def readonly_view(arr: np.ndarray) -> np.ndarray:
    """A read-only view of ``arr`` (no copy; ``arr``'s own flag is left as it is).

    Kernel inputs pass through it where callers hand both writeable and read-only
    arrays (a numpy array from the Python API, a `PointSet`'s or a tile's from the
    command line): numba compiles a kernel once per array type, and the read-only
    one is what the warm-up caches (docs/decisions/cli.md, "First run").

    Parameters
    ----------
    arr : ndarray
        Any array.

    Returns
    -------
    ndarray
        A view of ``arr``, read-only.
    """
    view = arr.view()
    view.flags.writeable = False
    return view


def _as_meta(meta) -> MappingProxyType:
    """Read-only shallow copy of a meta mapping (keys must be str)."""
    if meta is None:
        return MappingProxyType({})
    if not isinstance(meta, Mapping):
        raise TypeError(f"meta must be a mapping of str to objects; got {type(meta).__name__}")
    out = dict(meta)
    bad = [k for k in out if not isinstance(k, str)]
    if bad:
        raise TypeError(f"meta keys must be str; got {type(bad[0]).__name__} {bad[0]!r}")
    return MappingProxyType(out)


@dataclass(frozen=True, slots=True)
class PointSet:
    """Points with optional unit normals and per-point attributes.

    Parameters
    ----------
    points : ndarray of shape (N, 3), float64
        Coordinates.
    normals : ndarray of shape (N, 3), float64, optional
        Normals; rescaled to unit length. Zero-length or non-finite normals raise.
    attributes : mapping of str to ndarray of shape (N, ...)
        Per-point scalar or vector fields (labels, colours, features).
    name : str
        A name for reports and file names.
    meta : mapping of str to object, optional
        Format details (not per-point arrays) that a reader records so a later
        write can keep them, e.g. ``"las_header"`` (a ``laspy.LasHeader``) from
        ``pointatlas.io.read_point_set``. Carried unchanged by :meth:`replace` and
        :meth:`with_attributes`; shallow-copied into a read-only mapping.

    Examples
    --------
    >>> ps = PointSet([[0, 0, 0], [1, 0, 0]], normals=[[0, 0, 1], [0, 0, 3]])
    >>> ps.n_points, ps.has_normals, float(ps.normals[1, 2])
    (2, True, 1.0)
    """

    points: np.ndarray
    normals: np.ndarray | None = None
    attributes: Mapping[str, np.ndarray] = field(default_factory=dict)
    name: str = ""
    meta: Mapping[str, object] = field(default_factory=dict)

    def __post_init__(self):
        pts = np.array(as_points(self.points, min_points=0), copy=True)
        object.__setattr__(self, "points", readonly(pts))
        if self.normals is not None:
            nrm = as_normals(self.normals, pts.shape[0])
            object.__setattr__(self, "normals", readonly(nrm))
        attrs = {}
        for key, value in dict(self.attributes).items():
            arr = np.array(value, copy=True)
            if arr.ndim == 0 or arr.shape[0] != pts.shape[0]:
                raise ValueError(
                    f"attribute {key!r} must have one entry per point ({pts.shape[0]}); "
                    f"got shape {arr.shape}"
                )
            attrs[str(key)] = readonly(arr)
        object.__setattr__(self, "attributes", MappingProxyType(attrs))
        object.__setattr__(self, "meta", _as_meta(self.meta))

    @classmethod
    def _from_validated(
        cls, points, normals=None, attributes=None, name: str = "", meta=None
    ) -> PointSet:
        """Wrap arrays the caller has already validated and owns (private to pointatlas).

        No checks and no copies (used by ``pointatlas.io`` readers on fresh arrays):
        ``points`` must be C-contiguous finite float64 (N, 3), ``normals`` unit
        float64 (N, 3) or None, ``attributes`` a dict of arrays with N rows. The
        arrays are made read-only; ``meta`` is checked and copied as in the constructor.
        """
        obj = object.__new__(cls)
        object.__setattr__(obj, "points", readonly(points))
        object.__setattr__(obj, "normals", readonly(normals))
        attrs = {str(k): readonly(v) for k, v in dict(attributes or {}).items()}
        object.__setattr__(obj, "attributes", MappingProxyType(attrs))
        object.__setattr__(obj, "name", str(name))
        object.__setattr__(obj, "meta", _as_meta(meta))
        return obj

    @property
    def n_points(self) -> int:
        """Number of points N."""
        return int(self.points.shape[0])

    @property
    def has_normals(self) -> bool:
        """Whether normals are present."""
        return self.normals is not None

    def replace(self, **changes) -> PointSet:
        """Return a copy with some fields replaced (points, normals, attributes, name, meta).

        Fields not named keep their values; ``meta`` is carried unless replaced.
        """
        fields = {
            "points": self.points,
            "normals": self.normals,
            "attributes": dict(self.attributes),
            "name": self.name,
            "meta": self.meta,
        }
        fields.update(changes)
        return PointSet(**fields)

    def with_attributes(self, **attributes) -> PointSet:
        """Return a copy with the given per-point attributes added or replaced (meta kept)."""
        attrs = dict(self.attributes)
        attrs.update(attributes)
        return self.replace(attributes=attrs)
