"""Test shapes as triangle meshes with exact normals (GUIDE "Test models")."""

from __future__ import annotations

import numpy as np
from scipy.spatial import ConvexHull

from .._core import PointSet, as_rng
from ._mesh import SynthMesh, _vertex_normals, subdivide

__all__ = [
    "cube",
    "cylinder",
    "dodecahedron",
    "fibonacci_sphere",
    "icosphere",
    "line",
    "octahedron",
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


def _polyhedron_mesh(vertices, faces, face_labels, face_normals, frequency, *, name):
    """Subdivide a flat-faced polyhedron; exact normals inside faces, area-weighted
    vertex normals on its edges and corners. Private helper."""
    verts, tris, parent = subdivide(vertices, faces, frequency)
    flab = face_labels[parent]
    n_v = verts.shape[0]
    # smallest and largest label of the planar faces each vertex touches
    lo = np.full(n_v, np.iinfo(np.int64).max)
    hi = np.full(n_v, -1)
    for c in range(3):
        np.minimum.at(lo, tris[:, c], flab)
        np.maximum.at(hi, tris[:, c], flab)
    sharp = lo != hi
    normals = face_normals[lo].copy()
    normals[sharp] = _vertex_normals(verts, tris)[sharp]
    return SynthMesh(verts, tris, normals, labels=lo, face_labels=flab, is_sharp=sharp, name=name)


def cube(n: int = 8, *, size: float = 1.0) -> SynthMesh:
    """A sharp cube: a regular n x n grid of squares on each face, triangulated.

    Parameters
    ----------
    n : int
        Grid cells along each edge (>= 1). The mesh has ``6 n**2 + 2`` vertices:
        386 for n = 8 and 1,538 for n = 16 (thesis 2.1.1, 2.3.2); n = 18 gives
        1,946, the closest to the 1,906-vertex noisy cube of 5.4.
    size : float
        Edge length; the cube is centred at the origin.

    Returns
    -------
    mesh : SynthMesh
        ``12 n**2`` triangles; ``labels``/``face_labels`` give the 6 faces (0: -x,
        1: +x, 2: -y, 3: +y, 4: -z, 5: +z); vertices on an edge or corner take the
        smallest label and are flagged ``is_sharp``.

    Raises
    ------
    ValueError, TypeError
        ``n`` not a positive integer, ``size`` not positive.

    Notes
    -----
    Each face is split "union jack" style (diagonals point towards the face centre),
    so every face has the square's symmetries and, for even n, the area-weighted
    normal is exactly the bisector at edge vertices and exactly (+-1, +-1, +-1)/sqrt 3
    at corners. Face-interior normals are the axis directions. Decision logged in
    docs/decisions.md (synth).

    Examples
    --------
    >>> m = cube(8)
    >>> m.n_vertices, m.n_faces
    (386, 768)
    """
    n = _check_int(n, "n", 1)
    size = _check_positive(size, "size")
    side = n + 1
    # lattice points of the cube surface, indexed through a dense (n+1)^3 lookup
    ii, jj, kk = np.meshgrid(np.arange(side), np.arange(side), np.arange(side), indexing="ij")
    on_surface = (ii == 0) | (ii == n) | (jj == 0) | (jj == n) | (kk == 0) | (kk == n)
    lookup = -np.ones((side, side, side), dtype=np.int64)
    lookup[on_surface] = np.arange(int(on_surface.sum()))
    lattice = np.stack([ii[on_surface], jj[on_surface], kk[on_surface]], axis=1)
    verts = (lattice / n - 0.5) * size

    a, b = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    a, b = a.ravel(), b.ravel()
    # union jack: the diagonal of cell (a, b) passes through the corner nearest the centre
    half = n / 2.0
    sa = np.sign(a + 0.5 - half)
    sb = np.sign(b + 0.5 - half)
    main_diag = sa * sb > 0  # diagonal (a, b)-(a+1, b+1) points to the centre
    faces, labels = [], []
    for axis in range(3):
        u_ax, v_ax = (axis + 1) % 3, (axis + 2) % 3
        for sign, label in ((0, 2 * axis), (n, 2 * axis + 1)):

            def vid(da, db, u_ax=u_ax, v_ax=v_ax, axis=axis, sign=sign):
                idx = [None, None, None]
                idx[axis] = np.full(a.shape, sign)
                idx[u_ax] = a + da
                idx[v_ax] = b + db
                return lookup[idx[0], idx[1], idx[2]]

            p00, p10, p11, p01 = vid(0, 0), vid(1, 0), vid(1, 1), vid(0, 1)
            # (u, v, axis) is right-handed, so u x v points along +axis
            t1 = np.where(
                main_diag[:, None], np.stack([p00, p10, p11], 1), np.stack([p00, p10, p01], 1)
            )
            t2 = np.where(
                main_diag[:, None], np.stack([p00, p11, p01], 1), np.stack([p10, p11, p01], 1)
            )
            tri = np.concatenate([t1, t2])
            if sign == 0:
                tri = tri[:, ::-1]
            faces.append(tri)
            labels.append(np.full(tri.shape[0], label, dtype=np.int64))
    faces = np.concatenate(faces)
    face_labels = np.concatenate(labels)
    face_normals = np.repeat(np.eye(3), 2, axis=0) * np.tile([-1.0, 1.0], 3)[:, None]
    # no further subdivision: frequency 1 keeps the grid as built
    mesh = _polyhedron_mesh(
        verts, faces, face_labels, face_normals, 1, name=f"cube_{verts.shape[0]}"
    )
    return mesh


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
            [-1, g, 0], [1, g, 0], [-1, -g, 0], [1, -g, 0],
            [0, -1, g], [0, 1, g], [0, -1, -g], [0, 1, -g],
            [g, 0, -1], [g, 0, 1], [-g, 0, -1], [-g, 0, 1],
        ],
        dtype=np.float64,
    )  # fmt: skip
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


def octahedron(frequency: int = 64, *, radius: float = 1.0) -> SynthMesh:
    """A sharp regular octahedron, each face a regular triangular grid.

    Parameters
    ----------
    frequency : int
        Segments per octahedron edge (>= 1); ``4 f**2 + 2`` vertices. f = 64 gives
        16,386, the closest count of this family to the thesis' 16,395 (5.4).
    radius : float
        Distance of the six corners from the centre (corners at +-radius e_i).

    Returns
    -------
    mesh : SynthMesh
        Vertices on the flat faces; ``labels``/``face_labels`` give the 8 faces
        (label = octant bits: 1 if x < 0, 2 if y < 0, 4 if z < 0); face-interior
        normals exact, edge/corner normals area-weighted (``is_sharp``).

    Raises
    ------
    ValueError, TypeError
        Bad ``frequency`` or ``radius``.

    Notes
    -----
    Any closed triangle mesh of sphere topology has ``V = F/2 + 2``; 16,395 vertices
    need 32,786 triangles, which is not divisible by 8, so no subdivision treating the
    eight faces alike reaches it (decision logged in docs/decisions.md, synth).

    Examples
    --------
    >>> octahedron(4).n_vertices
    66
    """
    f = _check_int(frequency, "frequency", 1)
    radius = _check_positive(radius, "radius")
    base = np.array(
        [[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]], dtype=np.float64
    )
    faces, labels, normals = [], [], []
    for bits in range(8):
        sx = -1 if bits & 1 else 1
        sy = -1 if bits & 2 else 1
        sz = -1 if bits & 4 else 1
        tri = [0 if sx > 0 else 1, 2 if sy > 0 else 3, 4 if sz > 0 else 5]
        if sx * sy * sz < 0:
            tri = tri[::-1]
        faces.append(tri)
        labels.append(bits)
        normals.append(np.array([sx, sy, sz]) / np.sqrt(3.0))
    return _polyhedron_mesh(
        base * radius,
        np.array(faces, dtype=np.int64),
        np.array(labels, dtype=np.int64),
        np.array(normals),
        f,
        name=f"octahedron_{4 * f * f + 2}",
    )


def _dodecahedron_pentagons():
    """Corners (20, 3) of a regular dodecahedron with circumradius 1, its 12
    pentagons (12, 5) counter-clockwise from outside and their unit normals."""
    g, ig = _GOLDEN, 1.0 / _GOLDEN
    corners = [[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)]
    for s1 in (-1, 1):
        for s2 in (-1, 1):
            corners += [[0, s1 * ig, s2 * g], [s1 * ig, s2 * g, 0], [s1 * g, 0, s2 * ig]]
    corners = np.array(corners, dtype=np.float64) / np.sqrt(3.0)
    # face normals: the dual icosahedron's vertices (+-1, 0, +-phi) and cyclic shifts
    normals = []
    for s1 in (-1, 1):
        for s2 in (-1, 1):
            normals += [[s1, 0, s2 * g], [s2 * g, s1, 0], [0, s2 * g, s1]]
    normals = np.array(normals) / np.sqrt(1.0 + g * g)
    pentagons = []
    for nrm in normals:
        d = corners @ nrm
        ring = np.argsort(-d, kind="stable")[:5]
        centre = corners[ring].mean(axis=0)
        e1 = corners[ring[0]] - centre
        e2 = np.cross(nrm, e1)
        ang = np.arctan2((corners[ring] - centre) @ e2, (corners[ring] - centre) @ e1)
        pentagons.append(ring[np.argsort(ang, kind="stable")])
    return corners, np.array(pentagons, dtype=np.int64), normals


def dodecahedron(frequency: int = 4, *, radius: float = 1.0) -> SynthMesh:
    """A sharp regular dodecahedron of 12 flat pentagons, finely triangulated.

    Parameters
    ----------
    frequency : int
        Each pentagon is first cut into 10 triangles (centre to its 5 corners and 5
        edge midpoints), then every triangle is split regularly into
        ``frequency**2``; ``60 f**2 + 2`` vertices: 962 for f = 4 and 3,842 for
        f = 8, the thesis' counts (2.2.2, 4.4.2, 6.2). Must be >= 1.
    radius : float
        Circumradius (distance of the 20 corners from the centre).

    Returns
    -------
    mesh : SynthMesh
        ``labels``/``face_labels`` give the 12 pentagons; face-interior normals are
        exact, edge/corner normals area-weighted (``is_sharp``).

    Raises
    ------
    ValueError, TypeError
        Bad ``frequency`` or ``radius``.

    Notes
    -----
    A closed triangulation with V = 962 has F = 1,920 = 120 * 4**2 triangles and
    V = 3,842 has F = 7,680 = 120 * 8**2, which is what the 10-triangle split of the
    12 pentagons gives (decision logged in docs/decisions.md, synth).

    Examples
    --------
    >>> dodecahedron(4).n_vertices, dodecahedron(8).n_vertices
    (962, 3842)
    """
    f = _check_int(frequency, "frequency", 1)
    radius = _check_positive(radius, "radius")
    corners, pentagons, normals = _dodecahedron_pentagons()
    # edge midpoints of each pentagon (shared between the two pentagons of an edge)
    e_pairs = np.sort(np.stack([pentagons, np.roll(pentagons, -1, axis=1)], axis=2), axis=2)
    edges, inv = np.unique(e_pairs.reshape(-1, 2), axis=0, return_inverse=True)
    inv = inv.reshape(12, 5)
    mids = corners[edges].mean(axis=1)
    centres = corners[pentagons].mean(axis=1)
    verts = np.concatenate([corners, mids, centres])
    mid_id = 20 + inv
    centre_id = 20 + edges.shape[0] + np.arange(12)
    faces, labels = [], []
    for j in range(5):
        c0 = pentagons[:, j]
        m = mid_id[:, j]
        c1 = pentagons[:, (j + 1) % 5]
        faces.append(np.stack([centre_id, c0, m], axis=1))
        faces.append(np.stack([centre_id, m, c1], axis=1))
        labels += [np.arange(12), np.arange(12)]
    return _polyhedron_mesh(
        verts * radius,
        np.concatenate(faces),
        np.concatenate(labels).astype(np.int64),
        normals,
        f,
        name=f"dodecahedron_{60 * f * f + 2}",
    )


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
