"""Cloud dynamics: points follow their clouds' triangle, edge or vertex (thesis 2.3, Algorithm 3).

Decisions: docs/decisions/cloud_surfaces.md. Points are routed by the number of
clouds containing them: three -> the triangle of those clouds, two -> the edge, one
-> the vertex. Every update is built from intrinsic coordinates of the time-0
realisation and rebuilt in the time-1 one, so the same function with the two
realisations swapped is the inverse map.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._core import as_points, readonly
from .._core.tolerances import DEFORM_ANTIPODAL_TOL, DEFORM_DEGENERATE_RTOL
from ..complex import CloudComplex, realize_complex

__all__ = ["DeformResult", "deform_points"]


ROUTE_NONE, ROUTE_VERTEX, ROUTE_EDGE, ROUTE_TRIANGLE = 0, 1, 2, 3
_REASONS = (
    "routed",
    "in no cloud",
    "in four or more clouds",
    "its two clouds span no edge of a triangle",
    "its vertex is on no triangle",
    "degenerate triangle, edge or normal at time 0 or 1",
    "vertex normal reversed (no minimal rotation)",
)


@dataclass(frozen=True, slots=True)
class DeformResult:
    """Moved points and how each was routed (Algorithm 3).

    Attributes
    ----------
    points : ndarray of shape (N, 3), float64
        New positions; unroutable points keep their position.
    route : ndarray of shape (N,), int8
        3 triangle, 2 edge, 1 vertex, 0 not routed.
    simplex : ndarray of shape (N, 3), int64
        The clouds of the simplex each point followed (padded with -1).
    unroutable : ndarray of int64
        Points that could not be routed (reported, never dropped).
    reason : ndarray of shape (N,), int8
        Index into ``reasons`` (0 = routed).
    reasons : tuple of str
        The texts of ``reason``.
    """

    points: np.ndarray
    route: np.ndarray
    simplex: np.ndarray
    unroutable: np.ndarray
    reason: np.ndarray
    reasons: tuple = _REASONS

    def __post_init__(self):
        for name in ("points", "route", "simplex", "unroutable", "reason"):
            readonly(getattr(self, name))

    def counts(self) -> dict:
        """Number of points per route and per reason."""
        out = {
            "triangle": int((self.route == ROUTE_TRIANGLE).sum()),
            "edge": int((self.route == ROUTE_EDGE).sum()),
            "vertex": int((self.route == ROUTE_VERTEX).sum()),
            "unroutable": int(self.unroutable.size),
        }
        for i, text in enumerate(self.reasons[1:], start=1):
            k = int((self.reason == i).sum())
            if k:
                out[text] = k
        return out


def _unit(v: np.ndarray, eps: float):
    n = np.linalg.norm(v, axis=-1)
    ok = n > eps
    return v / np.where(ok, n, 1.0)[..., None], ok


def _rotation_between(a: np.ndarray, b: np.ndarray):
    """Minimal rotations (M, 3, 3) taking unit a to unit b; ok False when b = -a."""
    v = np.cross(a, b)
    cos = np.einsum("ij,ij->i", a, b)
    ok = cos > -1.0 + DEFORM_ANTIPODAL_TOL
    k = 1.0 / np.where(ok, 1.0 + cos, 1.0)
    vx = np.zeros((a.shape[0], 3, 3))
    vx[:, 0, 1], vx[:, 0, 2] = -v[:, 2], v[:, 1]
    vx[:, 1, 0], vx[:, 1, 2] = v[:, 2], -v[:, 0]
    vx[:, 2, 0], vx[:, 2, 1] = -v[:, 1], v[:, 0]
    R = np.eye(3)[None] + vx + np.einsum("mij,mjk->mik", vx, vx) * k[:, None, None]
    return R, ok


class _Frame:
    """Area-weighted normals of one realisation (triangles oriented, validated input)."""

    def __init__(self, cp: np.ndarray, faces: np.ndarray, edges: np.ndarray, eps: float):
        a, b, c = cp[faces[:, 0]], cp[faces[:, 1]], cp[faces[:, 2]]
        cross = np.cross(b - a, c - a)  # 2 * area * normal (Eq. 2.2)
        self.area2 = np.linalg.norm(cross, axis=1)
        self.normal, self.face_ok = _unit(cross, eps * eps)
        n_v = cp.shape[0]
        vsum = np.zeros((n_v, 3))
        for j in range(3):
            np.add.at(vsum, faces[:, j], cross)
        self.vertex_normal, self.vertex_ok = _unit(vsum, eps * eps)
        # edges of K (sorted pairs); each triangle contributes to its three edges
        codes = edges[:, 0] * n_v + edges[:, 1]
        esum = np.zeros((edges.shape[0], 3))
        for i, j in ((0, 1), (1, 2), (0, 2)):
            lo = np.minimum(faces[:, i], faces[:, j])
            hi = np.maximum(faces[:, i], faces[:, j])
            np.add.at(esum, np.searchsorted(codes, lo * n_v + hi), cross)
        self.edge_normal, self.edge_ok = _unit(esum, eps * eps)


def deform_points(
    points,
    cloud_complex: CloudComplex,
    new_cloud_points,
    *,
    cloud_points=None,
    faces=None,
    inverse: bool = False,
) -> DeformResult:
    """Move points with the cloud points of their cloud surface (thesis Algorithm 3).

    Parameters
    ----------
    points : array_like of shape (N, 3), float64
        The points of the cloud set (point i has the clouds of ``cloud_complex`` point i).
    cloud_complex : CloudComplex
        The cloud set and its complex (a closed oriented cloud surface in the thesis;
        boundaries are accepted).
    new_cloud_points : array_like of shape (C, 3), float64
        Cloud points at time 1.
    cloud_points : array_like of shape (C, 3), float64, optional
        Cloud points at time 0 (default ``cloud_complex.cloud_points``).
    faces : array_like of shape (F, 3), int64, optional
        The triangles of ``cloud_complex`` with a coherent orientation (default: from
        `pointatlas.complex.realize_complex`).
    inverse : bool
        Map points at time 1 back to time 0 (the two realisations swap roles).

    Returns
    -------
    result : DeformResult
        New positions, the route of every point and the unroutable points with the
        reason (they keep their position).

    Raises
    ------
    ValueError
        Shapes that do not match the complex, non-finite coordinates, faces that are
        not the complex's triangles.

    Notes
    -----
    Triangle points: q, the projection onto the triangle's plane, and the *signed*
    height h along n (Eq. 2.2; the thesis' |p - q| would flip points below the
    surface). The ratios of Eq. 2.4 are the barycentric coordinates of q in the
    sub-triangle (b, v_i, v_k); as b is the barycentre this is the affine map of
    the triangle, q~ = sum lambda v~. Then p~ = q~ + omega h n~ with
    omega = area / area~. Edge points: q on the edge line with the signed ratio to
    the half-length, the perpendicular offset kept at its angle around the edge
    relative to the area-weighted edge normal, scaled by omega = length~ / length.
    Vertex points: translation v -> v~ and the minimal rotation taking the
    area-weighted vertex normal n to n~. Each step is invertible with the
    realisations swapped, so forward then inverse restores the points to round-off.

    Examples
    --------
    One triangle of three clouds; point 0 lies in all three, point 1 in clouds 0
    and 1 (the edge), point 2 in cloud 0 only (the vertex):

    >>> from pointatlas.complex import cloud_complex
    >>> cp = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0]])
    >>> pts = np.array([[0.2, 0.2, 0.0], [0.5, 0.0, -0.1], [-0.1, -0.1, 0.1]])
    >>> K = cloud_complex([[0, 1, 2], [0, 1], [0]], pts, cloud_points=cp)
    >>> res = deform_points(pts, K, cp * 2.0)
    >>> res.route.tolist(), np.round(res.points[0], 6).tolist()
    ([3, 2, 1], [0.4, 0.4, 0.0])
    >>> back = deform_points(res.points, K, cp * 2.0, inverse=True)
    >>> bool(np.allclose(back.points, pts, rtol=0, atol=1e-12))
    True
    """
    if not isinstance(cloud_complex, CloudComplex):
        raise TypeError(f"cloud_complex must be a CloudComplex; got {type(cloud_complex).__name__}")
    K = cloud_complex
    p = as_points(points, min_points=0)
    if p.shape[0] != K.n_points:
        raise ValueError(f"points must have shape ({K.n_points}, 3); got {p.shape}")
    cp1 = as_points(new_cloud_points, name="new_cloud_points", min_points=0)
    if cp1.shape[0] != K.n_clouds:
        raise ValueError(f"new_cloud_points must have shape ({K.n_clouds}, 3); got {cp1.shape}")
    if cloud_points is None:
        cp0 = np.asarray(K.cloud_points, dtype=np.float64)
        used = np.setdiff1d(np.arange(K.n_clouds), K.empty_clouds)
        if not np.isfinite(cp0[used]).all():
            raise ValueError("complex has no cloud points; give cloud_points")
        cp0 = np.nan_to_num(cp0)
    else:
        cp0 = as_points(cloud_points, name="cloud_points", min_points=0)
        if cp0.shape[0] != K.n_clouds:
            raise ValueError(f"cloud_points must have shape ({K.n_clouds}, 3); got {cp0.shape}")
    if faces is None:
        faces = realize_complex(K)[1]
    else:
        faces = np.asarray(faces)
        if faces.dtype.kind not in "iu" or faces.shape != K.triangles.shape:
            raise ValueError(
                f"faces must be integer triangles of shape {K.triangles.shape}; "
                f"got {faces.dtype} {faces.shape}"
            )
        faces = faces.astype(np.int64)
        if not np.array_equal(np.unique(np.sort(faces, axis=1), axis=0), K.triangles):
            raise ValueError("faces must be the triangles of complex (any orientation)")
    if inverse:
        cp0, cp1 = cp1, cp0
    return _deform(p, K, cp0, cp1, faces)


def _deform(p, K: CloudComplex, cp0, cp1, faces) -> DeformResult:
    n, n_c = p.shape[0], K.n_clouds
    span = np.concatenate([cp0, cp1])
    diag = float(np.linalg.norm(span.max(axis=0) - span.min(axis=0))) if span.size else 1.0
    eps = DEFORM_DEGENERATE_RTOL * (diag or 1.0)
    f0 = _Frame(cp0, faces, K.edges, eps)
    f1 = _Frame(cp1, faces, K.edges, eps)
    counts = K.n_memberships
    out = p.copy()
    route = np.zeros(n, dtype=np.int8)
    reason = np.zeros(n, dtype=np.int8)
    simplex = np.full((n, 3), -1, dtype=np.int64)
    reason[counts == 0] = 1
    reason[counts >= 4] = 2
    first = K.point_indptr[:-1]
    # ---- triangles
    idx = np.flatnonzero(counts == 3)
    if idx.size:
        tri = np.stack([K.point_clouds[first[idx] + j] for j in range(3)], axis=1)
        fs = np.sort(faces, axis=1)
        fcode = (fs[:, 0] * n_c + fs[:, 1]) * n_c + fs[:, 2]
        forder = np.argsort(fcode)
        key = (tri[:, 0] * n_c + tri[:, 1]) * n_c + tri[:, 2]
        t = forder[np.searchsorted(fcode[forder], key)]  # every triple is a triangle of K
        ok = f0.face_ok[t] & f1.face_ok[t]
        F = faces[t]
        a0, b0, c0 = cp0[F[:, 0]], cp0[F[:, 1]], cp0[F[:, 2]]
        n0 = f0.normal[t]
        h = np.einsum("ij,ij->i", p[idx] - a0, n0)
        q = p[idx] - h[:, None] * n0
        lam = _barycentric(q, a0, b0, c0)
        q1 = lam[:, :1] * cp1[F[:, 0]] + lam[:, 1:2] * cp1[F[:, 1]] + lam[:, 2:] * cp1[F[:, 2]]
        omega = f0.area2[t] / np.where(ok, f1.area2[t], 1.0)
        new = q1 + (omega * h)[:, None] * f1.normal[t]
        good = idx[ok]
        out[good] = new[ok]
        route[good] = 3
        simplex[good] = tri[ok]
        reason[idx[~ok]] = 5
    # ---- edges
    idx = np.flatnonzero(counts == 2)
    if idx.size:
        ed = np.stack([K.point_clouds[first[idx]], K.point_clouds[first[idx] + 1]], axis=1)
        codes = K.edges[:, 0] * n_c + K.edges[:, 1]
        e = np.searchsorted(codes, ed[:, 0] * n_c + ed[:, 1])
        has = np.zeros(K.edges.shape[0], dtype=bool)
        for i, j in ((0, 1), (1, 2), (0, 2)):
            lo = np.minimum(faces[:, i], faces[:, j])
            hi = np.maximum(faces[:, i], faces[:, j])
            has[np.searchsorted(codes, lo * n_c + hi)] = True
        on_tri = has[e]
        ok = on_tri & f0.edge_ok[e] & f1.edge_ok[e]
        vi0, vj0 = cp0[ed[:, 0]], cp0[ed[:, 1]]
        vi1, vj1 = cp1[ed[:, 0]], cp1[ed[:, 1]]
        u0, ok0 = _unit(vj0 - vi0, eps)
        u1, ok1 = _unit(vj1 - vi1, eps)
        ok &= ok0 & ok1
        L0 = np.linalg.norm(vj0 - vi0, axis=1)
        L1 = np.linalg.norm(vj1 - vi1, axis=1)
        b0, b1 = (vi0 + vj0) / 2, (vi1 + vj1) / 2
        s = np.einsum("ij,ij->i", p[idx] - b0, u0)
        rho = s / np.where(ok, L0 / 2, 1.0)
        w = p[idx] - (b0 + s[:, None] * u0)
        n0, n1 = f0.edge_normal[e], f1.edge_normal[e]
        m0, m1 = np.cross(u0, n0), np.cross(u1, n1)
        wn, wm = np.einsum("ij,ij->i", w, n0), np.einsum("ij,ij->i", w, m0)
        omega = L1 / np.where(ok, L0, 1.0)
        new = (
            b1
            + (rho * L1 / 2)[:, None] * u1
            + omega[:, None] * (wn[:, None] * n1 + wm[:, None] * m1)
        )
        good = idx[ok]
        out[good] = new[ok]
        route[good] = 2
        simplex[good, :2] = ed[ok]
        reason[idx[~on_tri]] = 3
        reason[idx[on_tri & ~ok]] = 5
    # ---- vertices
    idx = np.flatnonzero(counts == 1)
    if idx.size:
        v = K.point_clouds[first[idx]]
        on_tri = np.zeros(n_c, dtype=bool)
        on_tri[faces.reshape(-1)] = True
        ok_n = f0.vertex_ok[v] & f1.vertex_ok[v]
        R, ok_r = _rotation_between(f0.vertex_normal[v], f1.vertex_normal[v])
        ok = on_tri[v] & ok_n & ok_r
        new = cp1[v] + np.einsum("mij,mj->mi", R, p[idx] - cp0[v])
        good = idx[ok]
        out[good] = new[ok]
        route[good] = 1
        simplex[good, 0] = v[ok]
        reason[idx[~on_tri[v]]] = 4
        reason[idx[on_tri[v] & ~ok_n]] = 5
        reason[idx[on_tri[v] & ok_n & ~ok_r]] = 6
    return DeformResult(
        points=out,
        route=route,
        simplex=simplex,
        unroutable=np.flatnonzero(route == 0),
        reason=reason,
    )


def _barycentric(q, a, b, c) -> np.ndarray:
    """Barycentric coordinates (M, 3) of q in the planes of triangles (a, b, c)."""
    v0, v1, v2 = b - a, c - a, q - a
    d00 = np.einsum("ij,ij->i", v0, v0)
    d01 = np.einsum("ij,ij->i", v0, v1)
    d11 = np.einsum("ij,ij->i", v1, v1)
    d20 = np.einsum("ij,ij->i", v2, v0)
    d21 = np.einsum("ij,ij->i", v2, v1)
    den = d00 * d11 - d01 * d01
    den = np.where(den != 0, den, 1.0)
    lb = (d11 * d20 - d01 * d21) / den
    lc = (d00 * d21 - d01 * d20) / den
    return np.stack([1.0 - lb - lc, lb, lc], axis=1)
