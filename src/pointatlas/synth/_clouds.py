"""Clouds generated from a triangle mesh (thesis 2.1, Examples 3-4, Algorithm 1).

Decisions: docs/decisions/cloud_surfaces.md.

One cloud per mesh vertex. Every triangle's barycentre goes into the clouds of its
three vertices; then, for each vertex v and each incident triangle, points are
drawn in a ball at v (radius R with |v - b| <= R < min edge length at v) and kept
with probability eta (one of three density models); a kept point goes into the
cloud of v and into the clouds of the triangle's other two vertices whose balls
(for that triangle) contain it. The cloud complex therefore equals the mesh's
complex (same vertices, edges and triangles).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .._core import as_float, as_int, as_points, readonly
from .._core.tolerances import MESH_CLOUDS_DEGENERATE_RTOL
from ._mesh import _as_faces

__all__ = ["MeshClouds", "clouds_from_mesh", "sphere_density", "vertex_curvature"]

MODELS = ("eta1", "eta2", "eta3")


def _angular_gap(s: np.ndarray, alpha: np.ndarray) -> np.ndarray:
    """d(s): angular distance of azimuth s in [0, 2 pi) to the sector [0, alpha]."""
    return np.where(s <= alpha, 0.0, np.minimum(s - alpha, 2 * math.pi - s))


def sphere_density(
    model: str, local, alpha, radius, *, c: float = 0.0, c_v: float = 0.5, c_h: float = 0.5
) -> np.ndarray:
    """Combined density eta of a sample in the local frame of a ball (Examples 3-4).

    Parameters
    ----------
    model : {"eta1", "eta2", "eta3"}
        Linear (Example 3 i), trigonometric (Example 3 ii) or conical (Example 4).
    local : array_like of shape (M, 3), float64
        Samples relative to the vertex: first edge along +x, triangle in the
        xy-plane, normal +z.
    alpha : float or array_like of shape (M,)
        Triangle angle at the vertex (radians, in (0, pi)).
    radius : float or array_like of shape (M,)
        Ball radius R (the points' units).
    c : float
        eta1: c >= 0; eta2: c >= 1 (how far the density drops outside the sector).
    c_v, c_h : float
        eta3: values >= 0 of the vertical density at the opposite direction and of
        the horizontal density at distance R.

    Returns
    -------
    eta : ndarray of shape (M,), float64
        Values in [0, 1].

    Raises
    ------
    ValueError
        Unknown model or a parameter out of its range.

    Notes
    -----
    The forms (docs/decisions/cloud_surfaces.md): d(s) is the angular distance of the azimuth to
    [0, alpha] (pi - alpha/2 at the opposite direction); eta1 has
    delta_h = 1 - d / ((c+1)(pi - alpha/2)) and delta_v = 2t/pi (t < pi/2), 2 - 2t/pi;
    eta2 has delta_h = (c + cos(pi d / (pi - alpha/2))) / (c+1) (the printed form is
    garbled) and delta_v = sin t; eta3 uses the angle t to the in-plane bisector:
    delta_v = 1 for t <= alpha/2, then linear to c_v at t = pi, and
    delta_h = 1 - r (1 - c_h) / R.

    Examples
    --------
    >>> p = np.array([[0.1, 0.05, 0.0], [-0.1, 0.0, 0.0], [0.0, 0.0, 0.1]])
    >>> np.round(sphere_density("eta1", p, np.pi / 3, 1.0), 3).tolist()
    [1.0, 0.2, 0.0]
    """
    if model not in MODELS:
        raise ValueError(f"model must be one of {', '.join(MODELS)}; got {model!r}")
    p = np.asarray(local, dtype=np.float64).reshape(-1, 3)
    alpha = np.broadcast_to(np.asarray(alpha, dtype=np.float64), (p.shape[0],))
    R = np.broadcast_to(np.asarray(radius, dtype=np.float64), (p.shape[0],))
    r = np.linalg.norm(p, axis=1)
    safe = np.where(r > 0, r, 1.0)
    half = math.pi - alpha / 2
    if model in ("eta1", "eta2"):
        lo = 0.0 if model == "eta1" else 1.0
        c = as_float(c, "c", lo=lo, note=f"{model} needs c >= {lo:g}")
        s = np.mod(np.arctan2(p[:, 1], p[:, 0]), 2 * math.pi)
        t = np.arccos(np.clip(p[:, 2] / safe, -1.0, 1.0))
        d = _angular_gap(s, alpha)
        if model == "eta1":
            dh = 1.0 - d / ((c + 1.0) * half)
            dv = np.where(t < math.pi / 2, 2 * t / math.pi, 2 - 2 * t / math.pi)
        else:
            dh = (c + np.cos(math.pi * d / half)) / (c + 1.0)
            dv = np.sin(t)
        eta = dh * dv
    else:
        c_v = as_float(c_v, "c_v", lo=0.0)
        c_h = as_float(c_h, "c_h", lo=0.0)
        u = np.stack([np.cos(alpha / 2), np.sin(alpha / 2), np.zeros_like(alpha)], axis=1)
        t = np.arccos(np.clip(np.einsum("ij,ij->i", p, u) / safe, -1.0, 1.0))
        dv = np.where(t <= alpha / 2, 1.0, 1.0 + (c_v - 1.0) * (t - alpha / 2) / half)
        dh = 1.0 - r * (1.0 - c_h) / R
        eta = dv * dh
    return np.clip(np.where(r > 0, eta, 1.0), 0.0, 1.0)


def _corner_geometry(vertices: np.ndarray, faces: np.ndarray):
    """Per corner (F, 3): frames (F, 3, 3, 3) rows x, y, z; alpha; |v - b|; min edge."""
    v = vertices[faces]  # (F, 3, 3)
    nxt = np.roll(v, -1, axis=1)
    prv = np.roll(v, 1, axis=1)
    e1, e2 = nxt - v, prv - v
    l1, l2 = np.linalg.norm(e1, axis=2), np.linalg.norm(e2, axis=2)
    x = e1 / np.where(l1 > 0, l1, 1.0)[..., None]
    n = np.cross(e1, e2)
    ln = np.linalg.norm(n, axis=2)
    z = n / np.where(ln > 0, ln, 1.0)[..., None]
    y = np.cross(z, x)
    cosa = np.einsum("fki,fki->fk", e1, e2) / np.where(l1 * l2 > 0, l1 * l2, 1.0)
    alpha = np.arccos(np.clip(cosa, -1.0, 1.0))
    bary = v.mean(axis=1, keepdims=True)
    r_lo = np.linalg.norm(v - bary, axis=2)
    r_hi = np.minimum(l1, l2)
    frames = np.stack([x, y, z], axis=2)  # (F, 3, 3 rows, 3)
    return frames, alpha, r_lo, r_hi, ln


def vertex_curvature(vertices, faces, kind: str = "gaussian") -> np.ndarray:
    """Discrete Gaussian (angle defect) or mean (dihedral) curvature per vertex.

    Parameters
    ----------
    vertices : array_like of shape (V, 3), float64
        Mesh vertices.
    faces : array_like of shape (F, 3), int64
        Triangles.
    kind : {"gaussian", "mean"}
        Gaussian: (2 pi - angle sum) / (area / 3), boundary vertices pi - sum.
        Mean: sum over edges at v of |e| theta_e / 4 divided by area / 3, theta_e the
        angle between the normals of the two faces of e (0 on boundary edges).

    Returns
    -------
    curvature : ndarray of shape (V,), float64
        Per vertex (0 for a vertex on no face).

    Examples
    --------
    >>> from pointatlas.synth import icosphere
    >>> m = icosphere(2)
    >>> k = vertex_curvature(m.vertices, m.faces)
    >>> bool(np.allclose(k, 1.0, atol=0.2))
    True
    """
    verts = as_points(vertices, name="vertices")
    tri = _as_faces(faces, verts.shape[0])
    if kind not in ("gaussian", "mean"):
        raise ValueError(f"kind must be 'gaussian' or 'mean'; got {kind!r}")
    nv = verts.shape[0]
    _, alpha, _, _, dbl_area = _corner_geometry(verts, tri)
    area = np.bincount(tri.reshape(-1), weights=np.repeat(dbl_area[:, 0] / 6.0, 3), minlength=nv)
    edges = np.sort(np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]]), axis=1)
    face_of = np.tile(np.arange(tri.shape[0]), 3)
    key = edges[:, 0] * nv + edges[:, 1]
    order = np.argsort(key, kind="stable")
    ks = key[order]
    boundary_v = np.zeros(nv, dtype=bool)
    start = np.r_[True, ks[1:] != ks[:-1]]
    sizes = np.diff(np.r_[np.flatnonzero(start), ks.size])
    single = np.flatnonzero(start)[sizes == 1]
    boundary_v[edges[order[single]].reshape(-1)] = True
    safe_area = np.where(area > 0, area, 1.0)
    if kind == "gaussian":
        angle_sum = np.bincount(tri.reshape(-1), weights=alpha.reshape(-1), minlength=nv)
        defect = np.where(boundary_v, math.pi, 2 * math.pi) - angle_sum
        return np.where(area > 0, defect / safe_area, 0.0)
    fn = np.cross(verts[tri[:, 1]] - verts[tri[:, 0]], verts[tri[:, 2]] - verts[tri[:, 0]])
    fn /= np.where(np.linalg.norm(fn, axis=1) > 0, np.linalg.norm(fn, axis=1), 1.0)[:, None]
    pairs = np.flatnonzero(start)[sizes == 2]
    fa, fb = face_of[order[pairs]], face_of[order[pairs + 1]]
    e = edges[order[pairs]]
    theta = np.arccos(np.clip(np.einsum("ij,ij->i", fn[fa], fn[fb]), -1.0, 1.0))
    length = np.linalg.norm(verts[e[:, 1]] - verts[e[:, 0]], axis=1)
    h = np.bincount(e.reshape(-1), weights=np.repeat(length * theta / 4.0, 2), minlength=nv)
    return np.where(area > 0, h / safe_area, 0.0)


@dataclass(frozen=True, slots=True)
class MeshClouds:
    """Points and clouds generated from a mesh (Algorithm 1).

    Attributes
    ----------
    points : ndarray of shape (P, 3), float64
        Barycentres (first F rows, in face order) then the accepted samples.
    cloud_indptr, cloud_members : ndarray of int64
        Cloud -> points CSR; cloud v belongs to mesh vertex v (sorted, distinct).
    cloud_points : ndarray of shape (V, 3), float64
        The mesh vertices (the realisation of the clouds).
    source_face, source_vertex : ndarray of shape (P,), int64
        Triangle and ball vertex each point was generated for (-1 vertex for a
        barycentre).
    radius : ndarray of shape (F, 3), float64
        Ball radius of every corner (face, local vertex).
    n_drawn, n_accepted : int
        Samples drawn and kept (barycentres not counted).
    """

    points: np.ndarray
    cloud_indptr: np.ndarray
    cloud_members: np.ndarray
    cloud_points: np.ndarray
    source_face: np.ndarray
    source_vertex: np.ndarray
    radius: np.ndarray
    n_drawn: int
    n_accepted: int

    def __post_init__(self):
        for name in (
            "points",
            "cloud_indptr",
            "cloud_members",
            "cloud_points",
            "source_face",
            "source_vertex",
            "radius",
        ):
            readonly(getattr(self, name))

    @property
    def clouds(self) -> list[np.ndarray]:
        """The cloud set as a list of point-index arrays (one per mesh vertex)."""
        return np.split(self.cloud_members, self.cloud_indptr[1:-1])


def _ball_radii(verts, tri, t: float, curvature, lo: float, hi: float):
    """Corner frames, angles and ball radii R (F, 3) of Eq. 2.1 (t scaled by curvature)."""
    frames, alpha, r_lo, r_hi, dbl_area = _corner_geometry(verts, tri)
    scale = float(np.linalg.norm(verts.max(axis=0) - verts.min(axis=0))) or 1.0
    bad = (r_hi <= MESH_CLOUDS_DEGENERATE_RTOL * scale).any(axis=1) | (dbl_area[:, 0] <= 0)
    if bad.any():
        from .._core import describe_indices

        raise ValueError(f"faces has degenerate triangles at {describe_indices(bad)}")
    tw = np.full(verts.shape[0], t)
    if curvature in ("gaussian", "mean"):
        k = np.abs(vertex_curvature(verts, tri, curvature))
        span = k.max() - k.min()
        w = (k - k.min()) / span if span > 0 else np.ones_like(k)
        tw = t * (lo + (hi - lo) * w)
    # where a corner's interval of Eq. 2.1 is empty (an edge at v shorter than |v - b|,
    # obtuse triangles) R = |v - b|: the ball must still hold the barycentre
    R = r_lo + tw[tri] * np.maximum(r_hi - r_lo, 0.0)  # (F, 3)
    return frames, alpha, R


def _draw_samples(gen, verts, tri, frames, alpha, R, n_samples: int, *, model, c, c_v, c_h):
    """Kept samples: (face, corner, world position) and the number drawn.

    ``n_samples`` candidates per corner are drawn in one block (face, corner, sample):
    a uniform direction, a radius uniform in [0, R], kept with probability eta.
    """
    F = tri.shape[0]
    m = F * 3 * n_samples
    dirs = gen.normal(size=(m, 3))
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    corner = np.repeat(np.arange(F * 3), n_samples)
    f_of, k_of = corner // 3, corner % 3
    rad = gen.uniform(0.0, 1.0, size=m) * R[f_of, k_of]
    local = dirs * rad[:, None]
    eta = sphere_density(model, local, alpha[f_of, k_of], R[f_of, k_of], c=c, c_v=c_v, c_h=c_h)
    keep = gen.uniform(0.0, 1.0, size=m) < eta
    f_of, k_of, local = f_of[keep], k_of[keep], local[keep]
    world = verts[tri[f_of, k_of]] + np.einsum("pj,pjd->pd", local, frames[f_of, k_of])
    return f_of, k_of, world, m


def _memberships(verts, tri, f_of, k_of, world, R):
    """Clouds as CSR (indptr, members): barycentre -> its three clouds; a sample -> its
    own cloud and the other two corners' clouds when inside their balls."""
    F = tri.shape[0]
    rows = [np.repeat(np.arange(F), 3)]
    cols = [tri.reshape(-1)]
    idx = F + np.arange(world.shape[0])
    rows.append(idx)
    cols.append(tri[f_of, k_of])
    for shift in (1, 2):
        k2 = (k_of + shift) % 3
        other = tri[f_of, k2]
        inside = np.linalg.norm(world - verts[other], axis=1) <= R[f_of, k2]
        rows.append(idx[inside])
        cols.append(other[inside])
    rows, cols = np.concatenate(rows), np.concatenate(cols)
    order = np.lexsort((rows, cols))
    members = rows[order]
    indptr = np.zeros(verts.shape[0] + 1, dtype=np.int64)
    np.cumsum(np.bincount(cols, minlength=verts.shape[0]), out=indptr[1:])
    return indptr, members


def clouds_from_mesh(
    vertices,
    faces,
    *,
    model: str = "eta1",
    c: float = 0.0,
    c_v: float = 0.5,
    c_h: float = 0.5,
    t: float = 0.5,
    n_samples: int = 10,
    curvature: str | None = None,
    curvature_range: tuple = (0.25, 1.0),
    rng=None,
) -> MeshClouds:
    """Generate points and clouds on a triangle mesh (thesis Algorithm 1).

    Parameters
    ----------
    vertices : array_like of shape (V, 3), float64
        Mesh vertices (the pseudo-surface).
    faces : array_like of shape (F, 3), int64
        Triangles; boundaries (the Hand's wrist) are allowed.
    model : {"eta1", "eta2", "eta3"}
        Density model (see `sphere_density`).
    c, c_v, c_h : float
        Model parameters (eta1: c >= 0, eta2: c >= 1, eta3: c_v, c_h >= 0).
    t : float
        Ball radius position in [0, 1): R = |v - b| + t (min edge - |v - b|)
        (Eq. 2.1 with the lower bound read as the distance to the barycentre);
        R = |v - b| where that interval is empty (an edge at v shorter than |v - b|).
    n_samples : int
        Samples drawn per vertex and incident triangle (each kept with probability eta).
    curvature : {None, "gaussian", "mean"}
        Scale t per vertex by its absolute discrete curvature, min-max normalised
        to ``curvature_range`` (2.1.2, Fig. 2.9).
    curvature_range : (float, float)
        [lo, hi] within [0, 1] for the curvature weight.
    rng : int, numpy.random.Generator or None
        Seed or generator.

    Returns
    -------
    clouds : MeshClouds
        Points, the cloud set (CSR) and the mesh vertices as cloud points.

    Raises
    ------
    ValueError
        Bad shapes, indices, non-finite vertices, degenerate triangles (an edge of
        length 0 or collinear corners), parameters out of range.

    Notes
    -----
    Directions are uniform on the sphere and radii uniform in [0, R] (as the thesis
    says, so samples crowd towards the vertex). The curvature weight multiplies t,
    keeping R inside the interval of Eq. 2.1, so the cloud complex still equals the
    mesh (decision in docs/decisions/cloud_surfaces.md).

    Examples
    --------
    >>> from pointatlas.synth import icosphere
    >>> m = icosphere(1)
    >>> mc = clouds_from_mesh(m.vertices, m.faces, model="eta2", c=1.0, rng=0)
    >>> len(mc.clouds), mc.points.shape[1], mc.n_accepted <= mc.n_drawn
    (42, 3, True)
    """
    verts = as_points(vertices, name="vertices")
    tri = _as_faces(faces, verts.shape[0])
    if model not in MODELS:
        raise ValueError(f"model must be one of {', '.join(MODELS)}; got {model!r}")
    t = as_float(t, "t", lo=0.0, hi=1.0, hi_open=True)
    n_samples = as_int(n_samples, "n_samples", lo=0)
    if curvature not in (None, "none", "gaussian", "mean"):
        raise ValueError(f"curvature must be None, 'gaussian' or 'mean'; got {curvature!r}")
    lo, hi = (as_float(x, "curvature_range", lo=0.0, hi=1.0) for x in curvature_range)
    if hi < lo:
        raise ValueError(f"curvature_range must have lo <= hi; got ({lo}, {hi})")
    gen = np.random.default_rng(rng)
    frames, alpha, R = _ball_radii(verts, tri, t, curvature, lo, hi)
    sphere_density(model, np.zeros((1, 3)), 1.0, 1.0, c=c, c_v=c_v, c_h=c_h)  # validates
    F = tri.shape[0]
    f_of, k_of, world, m = _draw_samples(
        gen, verts, tri, frames, alpha, R, n_samples, model=model, c=c, c_v=c_v, c_h=c_h
    )
    bary = verts[tri].mean(axis=1)
    points = np.concatenate([bary, world])
    n_pts = points.shape[0]
    indptr, members = _memberships(verts, tri, f_of, k_of, world, R)
    source_vertex = np.concatenate([np.full(F, -1), tri[f_of, k_of]]).astype(np.int64)
    return MeshClouds(
        points=points,
        cloud_indptr=indptr,
        cloud_members=members.astype(np.int64),
        cloud_points=verts.copy(),
        source_face=np.concatenate([np.arange(F), f_of]).astype(np.int64),
        source_vertex=source_vertex,
        radius=R,
        n_drawn=int(m),
        n_accepted=int(n_pts - F),
    )
