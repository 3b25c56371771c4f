"""Smooth and flat test shapes: spheres, torus, plane patch, cylinder, line.

Triangle meshes with exact normals (docs/decisions/synth.md); the polyhedra (cube,
octahedron, dodecahedron) are in `_polyhedra`.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import ConvexHull

from .._core import PointSet, as_rng
from ._mesh import SynthMesh, _vertex_normals, subdivide

__all__ = [
    "cylinder",
    "fibonacci_sphere",
    "icosphere",
    "line",
    "plane_patch",
    "sphere",
    "torus",
]

_GOLDEN = (1.0 + np.sqrt(5.0)) / 2.0


def _check_int(value, name: str, minimum: int) -> int:
    if isinstance(value, bool) or not isinstance(value, int | np.integer):
        raise TypeError(f"{name} must be an integer; got {type(value).__name__} {value!r}")
    if value < minimum:
        raise ValueError(f"{name} must be >= {minimum}; got {value}")
    return int(value)


def _check_positive(value, name: str) -> float:
    try:
        val = float(value)
    except (TypeError, ValueError):
        raise TypeError(f"{name} must be a number; got {type(value).__name__}") from None
    if not np.isfinite(val) or val <= 0:
        raise ValueError(f"{name} must be a positive finite number; got {value!r}")
    return val


def _grid_faces(n_rows: int, n_cols: int, *, wrap_cols: bool = False, wrap_rows: bool = False):
    """Two triangles per cell of a (n_rows, n_cols) vertex grid (row-major ids).

    Triangles are counter-clockwise in the (col, row) parameter plane, i.e. the normal
    is d(col) x d(row). Private helper.
    """
    rows = n_rows if wrap_rows else n_rows - 1
    cols = n_cols if wrap_cols else n_cols - 1
    r, c = np.meshgrid(np.arange(rows), np.arange(cols), indexing="ij")
    r, c = r.ravel(), c.ravel()
    r1, c1 = (r + 1) % n_rows, (c + 1) % n_cols
    v00, v01 = r * n_cols + c, r * n_cols + c1
    v10, v11 = r1 * n_cols + c, r1 * n_cols + c1
    t1 = np.stack([v00, v01, v11], axis=1)
    t2 = np.stack([v00, v11, v10], axis=1)
    return np.concatenate([t1, t2]).astype(np.int64)


def icosphere(subdivisions: int = 4, *, radius: float = 1.0) -> SynthMesh:
    """A geodesic sphere from the icosahedron, with exact normals.

    Parameters
    ----------
    subdivisions : int
        Each icosahedron triangle is split into ``4**subdivisions`` triangles
        (frequency ``2**subdivisions``), giving ``10 * 4**subdivisions + 2``
        vertices: 2,562 for 4 and 10,242 for 5. Must be in 0..9.
    radius : float
        Sphere radius; centred at the origin.

    Returns
    -------
    mesh : SynthMesh
        Vertices on the sphere; normals are ``vertices / radius`` exactly.

    Raises
    ------
    ValueError, TypeError
        Bad ``subdivisions`` or ``radius``.

    Notes
    -----
    The frequency-``2**s`` grid on each face is projected to the sphere in one step
    (the vertex counts equal those of s repeated midpoint subdivisions).

    Examples
    --------
    >>> icosphere(4).n_vertices
    2562
    """
    s = _check_int(subdivisions, "subdivisions", 0)
    if s > 9:
        raise ValueError(f"subdivisions must be <= 9 (10 * 4**9 + 2 vertices); got {s}")
    radius = _check_positive(radius, "radius")
    g = _GOLDEN
    base = np.array(
        [
            [-1, g, 0],
            [1, g, 0],
            [-1, -g, 0],
            [1, -g, 0],
            [0, -1, g],
            [0, 1, g],
            [0, -1, -g],
            [0, 1, -g],
            [g, 0, -1],
            [g, 0, 1],
            [-g, 0, -1],
            [-g, 0, 1],
        ],
        dtype=np.float64,
    )
    hull = ConvexHull(base)
    faces = _outward(base, hull.simplices.astype(np.int64), np.zeros(3))
    verts, tris, _ = subdivide(base, faces, 2**s)
    unit = verts / np.linalg.norm(verts, axis=1, keepdims=True)
    return SynthMesh(unit * radius, tris, unit, name=f"icosphere_{unit.shape[0]}")


def _outward(vertices, faces, center):
    """Flip triangles of a convex mesh whose normal points towards ``center``."""
    a = vertices[faces[:, 0]]
    nrm = np.cross(vertices[faces[:, 1]] - a, vertices[faces[:, 2]] - a)
    inward = np.einsum("ij,ij->i", nrm, a - center) < 0
    out = faces.copy()
    out[inward] = out[inward][:, ::-1]
    return out


def fibonacci_sphere(n_points: int, *, radius: float = 1.0, triangulate: bool = True) -> SynthMesh:
    """n points spread evenly on a sphere by the golden-angle (Fibonacci) spiral.

    Parameters
    ----------
    n_points : int
        Number of points (>= 4); any count is possible.
    radius : float
        Sphere radius; centred at the origin.
    triangulate : bool
        Compute faces (the convex hull). Set False for large point sets that need
        no faces (the hull of 10**6 points takes seconds); faces is then (0, 3).

    Returns
    -------
    mesh : SynthMesh
        Points ``z_i = 1 - (2i + 1)/n``, azimuth ``i * 2 pi / phi**2``; normals are
        ``points / radius``; faces are the convex hull (the spherical Delaunay
        triangulation), oriented outward.

    Raises
    ------
    ValueError, TypeError
        Bad ``n_points`` or ``radius``.

    Examples
    --------
    >>> m = fibonacci_sphere(10000)
    >>> m.n_vertices, m.n_faces
    (10000, 19996)
    """
    n = _check_int(n_points, "n_points", 4)
    radius = _check_positive(radius, "radius")
    i = np.arange(n, dtype=np.float64)
    z = 1.0 - (2.0 * i + 1.0) / n
    rho = np.sqrt(np.clip(1.0 - z * z, 0.0, None))
    phi = i * (2.0 * np.pi / _GOLDEN**2)
    unit = np.stack([rho * np.cos(phi), rho * np.sin(phi), z], axis=1)
    unit /= np.linalg.norm(unit, axis=1, keepdims=True)
    if triangulate:
        hull = ConvexHull(unit)
        faces = _outward(unit, hull.simplices.astype(np.int64), np.zeros(3))
    else:
        faces = np.zeros((0, 3), dtype=np.int64)
    return SynthMesh(unit * radius, faces, unit, name=f"fibonacci_sphere_{n}")


def sphere(n_points: int = 2562, *, radius: float = 1.0) -> SynthMesh:
    """A sphere mesh with exactly ``n_points`` vertices and exact normals.

    Parameters
    ----------
    n_points : int
        Number of vertices (>= 4). Icosphere counts ``10 * 4**s + 2`` (42, 162, 642,
        2,562, 10,242, ...) give `icosphere`; any other count gives
        `fibonacci_sphere`.
    radius : float
        Sphere radius; centred at the origin.

    Returns
    -------
    mesh : SynthMesh
        Normals are ``vertices / radius``.

    Raises
    ------
    ValueError, TypeError
        Bad ``n_points`` or ``radius``.

    Examples
    --------
    >>> sphere(2562).name, sphere(10000).name
    ('icosphere_2562', 'fibonacci_sphere_10000')
    """
    n = _check_int(n_points, "n_points", 4)
    for s in range(10):
        if 10 * 4**s + 2 == n:
            return icosphere(s, radius=radius)
    return fibonacci_sphere(n, radius=radius)


def torus(
    major_radius: float = 1.0,
    minor_radius: float = 0.25,
    *,
    n_major: int = 64,
    n_minor: int = 32,
) -> SynthMesh:
    """A ring torus around the z-axis with exact normals.

    Parameters
    ----------
    major_radius : float
        Distance R from the z-axis to the tube centre line.
    minor_radius : float
        Tube radius r (0 < r < R).
    n_major : int
        Vertices around the z-axis (>= 3).
    n_minor : int
        Vertices around the tube (>= 3).

    Returns
    -------
    mesh : SynthMesh
        ``n_major * n_minor`` vertices ((R + r cos v) cos u, (R + r cos v) sin u,
        r sin v) with normals (cos v cos u, cos v sin u, sin v).

    Raises
    ------
    ValueError, TypeError
        Bad counts or radii (r >= R would self-intersect).

    Examples
    --------
    >>> torus(2.0, 0.5, n_major=32, n_minor=16).n_vertices
    512
    """
    big = _check_positive(major_radius, "major_radius")
    small = _check_positive(minor_radius, "minor_radius")
    if small >= big:
        raise ValueError(f"minor_radius must be smaller than major_radius ({big}); got {small}")
    nu = _check_int(n_major, "n_major", 3)
    nv = _check_int(n_minor, "n_minor", 3)
    u = 2.0 * np.pi * np.arange(nu) / nu
    v = 2.0 * np.pi * np.arange(nv) / nv
    uu, vv = np.meshgrid(u, v, indexing="ij")  # row = u, column = v
    uu, vv = uu.ravel(), vv.ravel()
    nrm = np.stack([np.cos(vv) * np.cos(uu), np.cos(vv) * np.sin(uu), np.sin(vv)], axis=1)
    centre = np.stack([big * np.cos(uu), big * np.sin(uu), np.zeros_like(uu)], axis=1)
    verts = centre + small * nrm
    # the grid triangles have normal d/dv x d/du (inward): reverse them
    faces = _grid_faces(nu, nv, wrap_rows=True, wrap_cols=True)[:, ::-1]
    return SynthMesh(verts, faces, nrm, name=f"torus_{verts.shape[0]}")


def plane_patch(
    n_u: int = 32, n_v: int = 32, *, width: float = 1.0, height: float = 1.0
) -> SynthMesh:
    """A flat rectangular grid in the z = 0 plane, normal +z.

    Parameters
    ----------
    n_u, n_v : int
        Vertices along x and y (>= 2 each); ``n_u * n_v`` vertices (65 x 65 = 4,225
        is the thesis' quadrilateral of 2.3.2). A "long thin" patch is e.g.
        ``plane_patch(200, 3, width=10, height=0.1)``.
    width, height : float
        Extent along x and y; the patch is centred at the origin.

    Returns
    -------
    mesh : SynthMesh
        An open mesh (with boundary); normals all (0, 0, 1), ``labels`` all 0.

    Raises
    ------
    ValueError, TypeError
        Bad counts or extents.

    Examples
    --------
    >>> m = plane_patch(65, 65)
    >>> m.n_vertices, m.n_faces
    (4225, 8192)
    """
    nu = _check_int(n_u, "n_u", 2)
    nv = _check_int(n_v, "n_v", 2)
    width = _check_positive(width, "width")
    height = _check_positive(height, "height")
    x = np.linspace(-width / 2, width / 2, nu)
    y = np.linspace(-height / 2, height / 2, nv)
    yy, xx = np.meshgrid(y, x, indexing="ij")  # row = y, column = x
    verts = np.stack([xx.ravel(), yy.ravel(), np.zeros(xx.size)], axis=1)
    faces = _grid_faces(nv, nu)
    normals = np.tile([0.0, 0.0, 1.0], (verts.shape[0], 1))
    labels = np.zeros(verts.shape[0], dtype=np.int64)
    face_labels = np.zeros(faces.shape[0], dtype=np.int64)
    return SynthMesh(
        verts, faces, normals, labels=labels, face_labels=face_labels, name=f"plane_patch_{nu * nv}"
    )


def cylinder(
    radius: float = 1.0,
    height: float = 2.0,
    *,
    n_around: int = 64,
    n_height: int = 33,
    capped: bool = False,
    n_radial: int | None = None,
) -> SynthMesh:
    """A circular cylinder around the z-axis, open or closed by flat caps.

    Parameters
    ----------
    radius : float
        Cylinder radius.
    height : float
        Length along z; centred at the origin.
    n_around : int
        Vertices around each ring (>= 3).
    n_height : int
        Rings along the axis (>= 2), including the two rims.
    capped : bool
        Add flat triangulated discs at both ends (a closed mesh).
    n_radial : int, optional
        Rings per cap including the rim (default: about ``radius`` divided by the
        ring spacing along z, at least 1). Each cap ring has ``n_around`` vertices,
        plus one centre vertex.

    Returns
    -------
    mesh : SynthMesh
        Side normals are exactly radial, cap normals exactly -+z; rim vertices of a
        capped cylinder get the area-weighted normal (``is_sharp``). ``labels``: 0
        side, 1 bottom cap, 2 top cap (a rim vertex takes 0).

    Raises
    ------
    ValueError, TypeError
        Bad sizes or counts.

    Examples
    --------
    >>> cylinder(n_around=16, n_height=5).n_vertices
    80
    >>> cylinder(n_around=16, n_height=5, capped=True, n_radial=2).n_vertices
    114
    """
    radius = _check_positive(radius, "radius")
    height = _check_positive(height, "height")
    na = _check_int(n_around, "n_around", 3)
    nh = _check_int(n_height, "n_height", 2)
    theta = 2.0 * np.pi * np.arange(na) / na
    z = np.linspace(-height / 2, height / 2, nh)
    zz, tt = np.meshgrid(z, theta, indexing="ij")  # row = z, column = theta
    radial = np.stack([np.cos(tt.ravel()), np.sin(tt.ravel()), np.zeros(tt.size)], axis=1)
    verts = [radial * radius + np.stack([0 * zz.ravel(), 0 * zz.ravel(), zz.ravel()], 1)]
    normals = [radial]
    # d(theta) x dz points outward
    faces = [_grid_faces(nh, na, wrap_cols=True)]
    labels = [np.zeros(nh * na, dtype=np.int64)]
    face_labels = [np.zeros(faces[0].shape[0], dtype=np.int64)]
    sharp = [np.zeros(nh * na, dtype=bool)]
    if capped:
        if n_radial is None:
            nr = max(1, round(radius / (height / (nh - 1))))
        else:
            nr = _check_int(n_radial, "n_radial", 1)
        offset = nh * na
        for label, (ring0, zc, sgn) in enumerate(
            ((0, -height / 2, -1.0), ((nh - 1) * na, height / 2, 1.0)), start=1
        ):
            # inner rings j = 1..nr-1 (ring nr is the rim, shared with the side)
            frac = np.arange(1, nr) / nr
            inner = (frac[:, None, None] * radial[None, :na] * radius).reshape(-1, 3)
            inner[:, 2] = zc
            centre = np.array([[0.0, 0.0, zc]])
            cap_v = np.concatenate([inner, centre])
            centre_id = offset + cap_v.shape[0] - 1
            ring_ids = [offset + np.arange(j * na, (j + 1) * na) for j in range(nr - 1)]
            ring_ids.append(ring0 + np.arange(na))  # the rim
            col = np.arange(na)
            nxt = (col + 1) % na
            tris = [np.stack([np.full(na, centre_id), ring_ids[0][col], ring_ids[0][nxt]], 1)]
            for j in range(nr - 1):
                r0, r1 = ring_ids[j], ring_ids[j + 1]
                tris.append(np.stack([r0[col], r1[col], r1[nxt]], 1))
                tris.append(np.stack([r0[col], r1[nxt], r0[nxt]], 1))
            tris = np.concatenate(tris)
            if sgn < 0:
                tris = tris[:, ::-1]
            verts.append(cap_v)
            normals.append(np.tile([0.0, 0.0, sgn], (cap_v.shape[0], 1)))
            faces.append(tris)
            labels.append(np.full(cap_v.shape[0], label, dtype=np.int64))
            face_labels.append(np.full(tris.shape[0], label, dtype=np.int64))
            sharp.append(np.zeros(cap_v.shape[0], dtype=bool))
            offset += cap_v.shape[0]
    verts = np.concatenate(verts)
    normals = np.concatenate(normals)
    faces = np.concatenate(faces)
    sharp = np.concatenate(sharp)
    if capped:
        rims = np.concatenate([np.arange(na), (nh - 1) * na + np.arange(na)])
        sharp[rims] = True
        normals[rims] = _vertex_normals(verts, faces)[rims]
    return SynthMesh(
        verts,
        faces,
        normals,
        labels=np.concatenate(labels),
        face_labels=np.concatenate(face_labels),
        is_sharp=sharp,
        name=f"cylinder_{verts.shape[0]}",
    )


def line(
    n_points: int = 100,
    *,
    start=(0.0, 0.0, 0.0),
    end=(1.0, 0.0, 0.0),
    jitter: float = 0.0,
    rng=None,
) -> PointSet:
    """Evenly spaced points along a segment, optionally jittered.

    Parameters
    ----------
    n_points : int
        Number of points (>= 2), including both end points.
    start, end : array_like of shape (3,)
        Segment end points (distinct).
    jitter : float
        Standard deviation of isotropic Gaussian noise added to every coordinate,
        as a fraction of the point spacing ``|end - start| / (n_points - 1)``.
    rng : None, int or numpy.random.Generator
        Randomness for the jitter (``np.random.default_rng(rng)``).

    Returns
    -------
    point_set : PointSet
        Points without normals (a curve has no surface normal); attribute
        ``parameter`` holds each point's position t in [0, 1] along the segment.

    Raises
    ------
    ValueError, TypeError
        Bad count, coincident or non-finite end points, negative jitter.

    Examples
    --------
    >>> line(3, end=(2, 0, 0)).points[:, 0].tolist()
    [0.0, 1.0, 2.0]
    """
    n = _check_int(n_points, "n_points", 2)
    p0 = np.asarray(start, dtype=np.float64)
    p1 = np.asarray(end, dtype=np.float64)
    for name, p in (("start", p0), ("end", p1)):
        if p.shape != (3,) or not np.all(np.isfinite(p)):
            raise ValueError(f"{name} must be 3 finite numbers; got {p.tolist()}")
    length = float(np.linalg.norm(p1 - p0))
    if length == 0:
        raise ValueError("start and end must differ; got the same point")
    jitter = float(jitter)
    if not np.isfinite(jitter) or jitter < 0:
        raise ValueError(f"jitter must be a finite number >= 0; got {jitter}")
    t = np.linspace(0.0, 1.0, n)
    pts = p0 + t[:, None] * (p1 - p0)
    if jitter > 0:
        gen = as_rng(rng)
        pts = pts + gen.normal(scale=jitter * length / (n - 1), size=pts.shape)
    return PointSet(pts, attributes={"parameter": t}, name=f"line_{n}")
