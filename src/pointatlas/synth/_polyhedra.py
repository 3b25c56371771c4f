"""Polyhedra with flat faces: cube, octahedron, dodecahedron (docs/decisions/synth.md).

Each face is a regular triangular grid (the cube's "union jack"), so the vertex
counts are those of the thesis' models; at vertices on a sharp edge or corner the
normal is the mesh's area-weighted vertex normal, flagged by ``is_sharp``.
"""

from __future__ import annotations

import numpy as np

from ._mesh import SynthMesh, _vertex_normals, subdivide
from ._shapes import _GOLDEN, _check_int, _check_positive

__all__ = ["cube", "dodecahedron", "octahedron"]


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
    docs/decisions/synth.md.

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
    eight faces alike reaches it (docs/decisions/synth.md).

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
    12 pentagons gives (docs/decisions/synth.md).

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
