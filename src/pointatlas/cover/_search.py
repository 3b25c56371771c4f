"""Search over grid scales, rotations and lattice offsets for a cover whose complex is a
closed surface (thesis 2.2.2)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from .._core import as_float_array, as_int, readonly
from ..complex import curve_report, surface_report
from ..complex._clouds import unsupported_mask
from ._cover import (
    _as_rotation,
    as_offset,
    cover_prepared,
    cover_radii,
    prepare_points,
    random_offsets,
    random_rotations,
)

__all__ = ["ACCEPT", "ScaleSearch", "search_cover_scale"]

#: what a setting must give to be accepted: "closed" (3-D: a closed cloud surface;
#: 2-D: a closed 1-manifold) or "open" (boundary allowed: a cloud surface, or a
#: 1-manifold with ends)
ACCEPT = ("closed", "open")


def _n_offending(rep, dim: int) -> int:
    """Number of offending simplices of a report (0 for an accepted closed setting)."""
    if dim == 3:
        return int(
            rep.vertices_not_in_face.size
            + rep.edges_in_many_faces.shape[0]
            + rep.vertices_not_fan.size
            + len(rep.simplices_above_2)
            + rep.edges_not_in_face.shape[0]
        )
    return int(rep.vertices_bad_degree.size + rep.n_triangles)


@dataclass(frozen=True, slots=True)
class ScaleSearch:
    """Every setting (scale, rotation, offset) tried and whether its complex is accepted.

    Attributes
    ----------
    dim : int
        2 or 3.
    accept : str
        "closed" or "open" (see `search_cover_scale`).
    scales : ndarray of shape (M,), float64
        Grid scale of every setting (offsets vary fastest, then rotations).
    rotation_index : ndarray of shape (M,), int64
        Row of ``rotations`` used by every setting.
    offset_index : ndarray of shape (M,), int64
        Row of ``offsets`` used by every setting.
    rotations : ndarray of shape (R + 1, 3, 3), float64
        The identity (or the given rotation), then the seeded random rotations.
    offsets : ndarray of shape (O + 1, 3), float64
        Zero, then the seeded random lattice offsets (units of the scale).
    n_clouds : ndarray of shape (M,), int64
        Number of clouds of every setting.
    n_offending : ndarray of shape (M,), int64
        Offending simplices of every setting (Defs 7-8; 2-D: bad-degree vertices and
        triangles); boundary edges are not counted.
    n_unsupported : ndarray of shape (M,), int64
        Points whose clouds form no simplex on a triangle (3-D: in 4+ clouds, or an
        edge or vertex on no triangle; Algorithm 3 cannot route them); 0 in 2-D.
    is_accepted : ndarray of shape (M,), bool
        The complex is what ``accept`` asks for.
    reports : tuple of SurfaceReport or CurveReport
        The topology report of every setting.
    """

    dim: int
    accept: str
    scales: np.ndarray
    rotation_index: np.ndarray
    offset_index: np.ndarray
    rotations: np.ndarray
    offsets: np.ndarray
    n_clouds: np.ndarray
    n_offending: np.ndarray
    n_unsupported: np.ndarray
    is_accepted: np.ndarray
    reports: tuple

    def __post_init__(self):
        for name in (
            "scales",
            "rotation_index",
            "offset_index",
            "rotations",
            "offsets",
            "n_clouds",
            "n_offending",
            "n_unsupported",
            "is_accepted",
        ):
            readonly(getattr(self, name))

    @property
    def accepted(self) -> np.ndarray:
        """Indices of the accepted settings, in the order tried."""
        return np.flatnonzero(self.is_accepted)

    @property
    def chosen(self) -> int:
        """The first accepted setting; without one, the closest: fewest unsupported
        points, then fewest offending simplices, then the first tried."""
        acc = self.accepted
        if acc.size:
            return int(acc[0])
        order = np.lexsort((np.arange(self.scales.size), self.n_offending, self.n_unsupported))
        return int(order[0])

    def setting(self, i: int) -> dict:
        """Keyword arguments of `ball_cover` that rebuild setting ``i``."""
        return {
            "scale": float(self.scales[i]),
            "rotation": self.rotations[self.rotation_index[i]].copy(),
            "offset": self.offsets[self.offset_index[i]].copy(),
        }

    def rows(self) -> list[dict]:
        """One JSON-friendly row per setting: scale, rotation, offset, clouds, accepted,
        topology."""
        out = []
        for i, rep in enumerate(self.reports):
            s = rep.summary()
            row = {
                "scale": float(self.scales[i]),
                "rotation": int(self.rotation_index[i]),
                "offset": int(self.offset_index[i]),
                "n_clouds": int(self.n_clouds[i]),
                "accepted": bool(self.is_accepted[i]),
                "n_offending": int(self.n_offending[i]),
                "n_unsupported": int(self.n_unsupported[i]),
            }
            keys = (
                (
                    "is_cloud_surface",
                    "is_closed",
                    "n_boundary_loops",
                    "n_components",
                    "euler_characteristic",
                    "is_orientable",
                    "genus",
                    "dimension",
                )
                if self.dim == 3
                else (
                    "is_one_manifold",
                    "is_closed",
                    "n_components",
                    "n_endpoints",
                    "n_triangles",
                    "euler_characteristic",
                )
            )
            row.update({k: s[k] for k in keys})
            out.append(row)
        return out


def search_cover_scale(
    points,
    scales,
    *,
    n_rotations: int = 0,
    n_offsets: int = 0,
    rng=None,
    accept: str | None = None,
    dim: int = 3,
    layout: str = "two-radius",
    radius: float | None = None,
    rotation=None,
    callback: Callable[[int], None] | None = None,
) -> ScaleSearch:
    """Try grid scales, rotations and lattice offsets; report which give a cloud surface.

    Parameters
    ----------
    points : array_like of shape (N, 3), float64
        Coordinates ((N, 2) allowed in 2-D).
    scales : array_like of shape (M,), float64
        Grid scales to try (> 0).
    n_rotations : int
        Number of seeded random rotations tried besides the identity (2.2.2: the
        result depends on the placement of the points in the grid).
    n_offsets : int
        Number of seeded random lattice offsets (units of s, uniform in [0, 1)^d)
        tried besides 0, with every rotation.
    rng : int, numpy.random.Generator or None
        Seed for the rotations and offsets (rotations are drawn first).
    accept : {"closed", "open"}, optional
        "closed": a closed cloud surface (3-D) or a closed curve (2-D); "open": a
        cloud surface or curve, boundary allowed (a planar patch). Default
        "closed" in 3-D (2.2.2) and "open" in 2-D (Fig. 2.14's curve may have ends).
    dim, layout, radius : see `ball_cover`.
    rotation : array_like of shape (3, 3), optional
        Replaces the identity as the first rotation.
    callback : callable, optional
        Called with the number of settings done after each one (progress bars).

    Returns
    -------
    search : ScaleSearch
        Every setting with its report; ``accepted`` lists those whose complex is
        what ``accept`` asks for (3-D: Defs 7-8); ``chosen`` is the first of them or,
        without one, the closest; ``setting(i)`` rebuilds one with `ball_cover`.

    Raises
    ------
    ValueError
        As `ball_cover`; empty or non-positive ``scales``; ``n_rotations`` or
        ``n_offsets`` < 0; an unknown ``accept``.

    Notes
    -----
    Settings are tried scale by scale, rotation by rotation, offset by offset, the
    identity and offset 0 first (Algorithm 2 as printed); the same seed gives the
    same settings and so the same result. This is the run-through of 2.2.2 (the
    thesis found s = 1.9 for the noisy dodecahedron this way and rotated the sphere
    beforehand). Offsets are ours: the thesis anchors the lattice at the bounding
    box, so a plane or cube face parallel to the axes lies in a lattice layer,
    where the balls of Prop. 4 meet at most in pairs and give no triangles
    (docs/decisions/cloud_surfaces.md).

    Examples
    --------
    >>> from pointatlas.synth import fibonacci_sphere
    >>> pts = fibonacci_sphere(4000).vertices
    >>> res = search_cover_scale(pts, [0.3, 1.0])
    >>> [bool(x) for x in res.is_accepted], res.reports[1].genus, res.chosen
    ([False, True], 0, 1)
    """
    dim = as_int(dim, "dim", lo=2, hi=3)
    if accept is None:
        accept = "closed" if dim == 3 else "open"
    if accept not in ACCEPT:
        raise ValueError(f"accept must be one of {', '.join(ACCEPT)}; got {accept!r}")
    r_even, r_odd = cover_radii(dim, layout, radius)
    pts = prepare_points(points, dim)
    grid = as_float_array(scales, "scales", lo=0.0, lo_open=True, note="grid scales")
    gen = np.random.default_rng(rng)
    rots = random_rotations(n_rotations, dim=dim, rng=gen)
    offs = random_offsets(n_offsets, dim=dim, rng=gen)
    if rotation is not None:
        rots[0] = _as_rotation(rotation, dim)
    cols: dict[str, list] = {k: [] for k in ("s", "r", "o", "n", "bad", "uns", "ok", "rep")}
    for s in grid.tolist():
        for r in range(rots.shape[0]):
            for o in range(offs.shape[0]):
                off = as_offset(offs[o], dim)
                cov = cover_prepared(pts, s, dim, layout, r_even, r_odd, rots[r], "centroid", off)
                if dim == 3:
                    rep = surface_report(cov.cloud_complex)
                    good = rep.is_cloud_surface and (rep.is_closed or accept == "open")
                    uns = int(unsupported_mask(cov.cloud_complex).sum())
                else:
                    rep = curve_report(cov.cloud_complex)
                    good = rep.is_one_manifold and (rep.is_closed or accept == "open")
                    uns = 0
                for key, val in zip(
                    cols,
                    (s, r, o, cov.n_clouds, _n_offending(rep, dim), uns, good, rep),
                    strict=True,
                ):
                    cols[key].append(val)
                if callback is not None:
                    callback(len(cols["rep"]))
    return ScaleSearch(
        dim=dim,
        accept=accept,
        scales=np.asarray(cols["s"], dtype=np.float64),
        rotation_index=np.asarray(cols["r"], dtype=np.int64),
        offset_index=np.asarray(cols["o"], dtype=np.int64),
        rotations=rots,
        offsets=offs,
        n_clouds=np.asarray(cols["n"], dtype=np.int64),
        n_offending=np.asarray(cols["bad"], dtype=np.int64),
        n_unsupported=np.asarray(cols["uns"], dtype=np.int64),
        is_accepted=np.asarray(cols["ok"], dtype=bool),
        reports=tuple(cols["rep"]),
    )
