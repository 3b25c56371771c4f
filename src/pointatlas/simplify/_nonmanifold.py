"""Cutting a triangle mesh apart at its non-manifold edges and vertices
(docs/decisions/simplify.md, "Non-manifold and unoriented inputs").

Scans and exports often hold a few edges shared by four (or more) triangles: two
sheets that touch along an edge, like two cubes sharing one. One such edge spoils
the closed-and-manifold checks of the whole output. `split_nonmanifold` pairs the
triangles around every such edge the way a solid's faces pair (each triangle with
its neighbour across the solid's inside, found by the orientation), then gives each
fan of triangles around a vertex its own copy of the vertex. The copies sit at the
same position: the mesh is unchanged geometrically and becomes manifold.
Triangle soups and flat-shaded exports repeat a vertex once per face (STL, PLY and
OBJ written per face): vertices at one position are welded first, and triangles with
a repeated corner or given twice are dropped. Exports also mix triangle orientations
(a shared edge run the same way by both of its triangles); `orient_consistently`
flips the fewest triangles (by area) that make every connected part consistent.
"""

from __future__ import annotations

import dataclasses
import warnings
from dataclasses import dataclass

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from ._vertices import SimplifyWarning

__all__ = ["MeshRepair", "orient_consistently", "repair_mesh_input", "split_nonmanifold"]


@dataclass(frozen=True)
class MeshRepair:
    """The mesh path's input after `repair_mesh_input`, and the way back to the
    input's ids.

    Attributes
    ----------
    vertices : ndarray of shape (V + C, 3)
        The input's vertices, then the C copies made by `split_nonmanifold`.
    triangles : ndarray of shape (T, 3), int64
        Welded, without degenerate or repeated triangles, manifold, consistently
        oriented where the input is orientable.
    source : ndarray of shape (V + C,), int64
        Input vertex of every vertex (a copy: the vertex it copies).
    triangle_of : ndarray of shape (F_in,), int64
        Repaired triangle of every input triangle (a repeat: its first copy's; -1 for
        a degenerate one).
    """

    vertices: np.ndarray
    triangles: np.ndarray
    source: np.ndarray
    triangle_of: np.ndarray

    def back(self, res):
        """``res`` (a `SurfaceSimplification` of the repaired mesh) in the input's
        vertex and triangle ids: a copy or a welded vertex sits where its input vertex
        is (the same distance); a dropped triangle takes its first copy's region, a
        degenerate one -1 (unassigned)."""
        n_in = self.triangle_of.shape[0]
        labels = res.face_labels
        if self.triangles.shape[0] != n_in or not np.array_equal(self.triangle_of, np.arange(n_in)):
            safe = np.maximum(self.triangle_of, 0)
            labels = np.where(self.triangle_of >= 0, labels[safe], -1).astype(np.int64)
        n_vert = int(np.count_nonzero(self.source == np.arange(self.source.shape[0])))
        return dataclasses.replace(
            res,
            vertex_source=self.source[res.vertex_source],
            distances=res.distances[:n_vert],
            face_labels=labels,
        )


def repair_mesh_input(vertices: np.ndarray, triangles: np.ndarray) -> MeshRepair | None:
    """Weld vertices at one position, drop degenerate and repeated triangles,
    `split_nonmanifold`, then `orient_consistently`; one `SimplifyWarning` for each
    repair made.

    Returns
    -------
    repair : MeshRepair or None
        None when the input needs none of these (the mesh path runs on it as given).
    """
    n_vert, n_in = vertices.shape[0], triangles.shape[0]
    notes = []
    tri = triangles
    # vertices at one position (a triangle soup, the seams of a flat-shaded export)
    # become the first of them: a soup of a closed surface is closed again
    if n_vert:
        _, first, inverse = np.unique(vertices, axis=0, return_index=True, return_inverse=True)
        weld = first[inverse.reshape(-1)].astype(np.int64)
        if first.shape[0] < n_vert and (weld[tri] != tri).any():
            tri = weld[tri]
            on = np.unique(triangles)
            n_weld = int(np.count_nonzero(weld[on] != on))
            notes.append(f"{n_weld} vertices at the position of another were welded to it")
    # triangles with a repeated corner, and a triangle given twice (either way round)
    ordered = np.sort(tri, axis=1)
    degenerate = (ordered[:, 0] == ordered[:, 1]) | (ordered[:, 1] == ordered[:, 2])
    triangle_of = np.arange(n_in, dtype=np.int64)
    if n_in:
        if n_vert**3 < 2**63:  # one integer per sorted triangle: the rows' order
            o = ordered.astype(np.int64, copy=False)
            key = (o[:, 0] * n_vert + o[:, 1]) * n_vert + o[:, 2]
            _, uniq, twin = np.unique(key, return_index=True, return_inverse=True)
        else:
            _, uniq, twin = np.unique(ordered, axis=0, return_index=True, return_inverse=True)
        twin = uniq[twin.reshape(-1)]
        keep = ~degenerate & (twin == np.arange(n_in))
        if not keep.all():
            new_id = np.full(n_in, -1, dtype=np.int64)
            new_id[keep] = np.arange(int(keep.sum()))
            triangle_of = np.where(degenerate, -1, new_id[twin])
            tri = tri[keep]
            n_deg, n_rep = int(degenerate.sum()), int((~degenerate & ~keep).sum())
            notes.append(
                f"{n_deg} degenerate triangles (a repeated corner) and {n_rep} repeated "
                "triangles dropped"
            )
    tri, source = split_nonmanifold(vertices, tri)
    if source is None:
        source = np.arange(n_vert, dtype=np.int64)
    else:
        notes.append(
            "the input mesh is not manifold (edges in three or more triangles, pinched "
            f"vertices): cut apart there, {source.shape[0] - n_vert} vertices copied"
        )
        vertices = vertices[source]
    tri, n_flipped = orient_consistently(vertices, tri)
    if n_flipped:
        notes.append(
            f"the input's triangles are not consistently oriented: {n_flipped} of "
            f"{tri.shape[0]} reversed to match their neighbours"
        )
    if not notes:
        return None
    for note in notes:
        warnings.warn(note, SimplifyWarning, stacklevel=3)
    return MeshRepair(vertices, tri, source, triangle_of)


def split_nonmanifold(vertices: np.ndarray, triangles: np.ndarray):
    """Copies of the vertices so that every edge joins at most two triangles.

    Parameters
    ----------
    vertices : ndarray of shape (V, 3), float64
        Mesh vertices.
    triangles : ndarray of shape (F, 3), int64
        Triangles (valid indices).

    Returns
    -------
    triangles : ndarray of shape (F, 3), int64
        The triangles with their corners on the new vertex ids (the input array
        itself when nothing is cut).
    source : ndarray of shape (V + C,), int64 or None
        Input vertex of every new vertex (ids below V are the input's, the C copies
        follow); None when the mesh has no non-manifold edge or vertex.

    Notes
    -----
    An edge in one or two triangles keeps them together (also when the two are
    oriented alike: that input is not oriented, and cutting would open it). Around
    an edge (a, b) in three or more triangles the triangles are sorted by angle
    about a -> b; a triangle that runs b -> a has its inside towards larger angles,
    so it is paired with the next triangle (by angle) that runs a -> b; triangles
    left over (an odd count, or orientations that do not alternate) become boundary
    there. Then each vertex gets one id per fan of its triangles joined by kept
    edges: the first fan (of the lowest triangle) keeps the input id.

    Examples
    --------
    Two tetrahedra on one edge (0, 1): the second gets its own copies 6 and 7.

    >>> v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [0, -1, 0], [0, 0, -1.0]])
    >>> t = np.array([[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2],
    ...               [0, 4, 1], [0, 1, 5], [1, 4, 5], [0, 5, 4]])
    >>> new, source = split_nonmanifold(v, t)
    >>> source.tolist(), new[4:].tolist()
    ([0, 1, 2, 3, 4, 5, 0, 1], [[6, 4, 7], [6, 7, 5], [7, 4, 5], [6, 5, 4]])
    """
    tri = triangles
    n_tri = tri.shape[0]
    n_vert = vertices.shape[0]
    if n_tri == 0:
        return tri, None
    directed = tri[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2)
    und = np.sort(directed, axis=1)
    key = und[:, 0].astype(np.int64) * n_vert + und[:, 1]
    _, inverse, counts = np.unique(key, return_inverse=True, return_counts=True)
    order = np.argsort(inverse, kind="stable")
    starts = np.concatenate([[0], np.cumsum(counts)])
    # pairs of half-edges (slot ids 3 t + j) kept together
    two = np.flatnonzero(counts == 2)
    pairs = [np.stack([order[starts[two]], order[starts[two] + 1]], axis=1)]
    for e in np.flatnonzero(counts > 2):
        pairs.append(_radial_pairs(vertices, tri, directed, order[starts[e] : starts[e + 1]]))
    pairs = np.concatenate(pairs).astype(np.int64)
    # corners (3 t + j: vertex tri[t, j]) joined across each kept edge
    t0, t1 = pairs[:, 0] // 3, pairs[:, 1] // 3
    a0, a1 = pairs[:, 0] % 3, pairs[:, 1] % 3
    b0, b1 = (a0 + 1) % 3, (a1 + 1) % 3
    same = tri[t1, a1] == tri[t0, a0]  # both run u -> w (an unoriented pair)
    links = np.stack(
        [
            np.concatenate([3 * t0 + a0, 3 * t0 + b0]),
            np.concatenate([3 * t1 + np.where(same, a1, b1), 3 * t1 + np.where(same, b1, a1)]),
        ],
        axis=1,
    )
    n_corner = 3 * n_tri
    graph = coo_matrix(
        (np.ones(links.shape[0], dtype=np.int8), (links[:, 0], links[:, 1])),
        shape=(n_corner, n_corner),
    )
    _, comp = connected_components(graph, directed=False)
    corner_vertex = tri.reshape(-1)
    # the first corner of every component, in corner order
    first_of_comp = np.full(comp.max() + 1, n_corner, dtype=np.int64)
    np.minimum.at(first_of_comp, comp, np.arange(n_corner))
    comp_vertex = corner_vertex[first_of_comp]
    by_vertex = np.lexsort((first_of_comp, comp_vertex))
    keeps = np.ones(by_vertex.shape[0], dtype=bool)
    keeps[1:] = comp_vertex[by_vertex[1:]] != comp_vertex[by_vertex[:-1]]
    if keeps.all():
        return tri, None
    new_id = np.empty(comp_vertex.shape[0], dtype=np.int64)
    new_id[by_vertex[keeps]] = comp_vertex[by_vertex[keeps]]
    extra = by_vertex[~keeps]
    extra = extra[np.argsort(first_of_comp[extra], kind="stable")]
    new_id[extra] = n_vert + np.arange(extra.shape[0])
    source = np.concatenate([np.arange(n_vert, dtype=np.int64), comp_vertex[extra]])
    return new_id[comp].reshape(n_tri, 3), source


def _radial_pairs(vertices, tri, directed, slots) -> np.ndarray:
    """Half-edge pairs around one edge in three or more triangles (see
    `split_nonmanifold`)."""
    a, b = sorted(directed[slots[0]])
    p, q = vertices[a], vertices[b]
    d = q - p
    d = d / (np.linalg.norm(d) or 1.0)
    t = slots // 3
    third = tri[t].sum(axis=1) - a - b
    w = vertices[third] - p
    w = w - np.outer(w @ d, d)
    e1 = w[0] / (np.linalg.norm(w[0]) or 1.0)
    e2 = np.cross(d, e1)
    angle = np.arctan2(w @ e2, w @ e1)
    ring = slots[np.lexsort((slots, angle))]
    forward = directed[ring, 0] == a  # runs a -> b
    out, used = [], np.zeros(ring.shape[0], dtype=bool)
    n = ring.shape[0]
    for i in np.flatnonzero(~forward):
        for step in range(1, n):
            j = (i + step) % n
            if forward[j] and not used[j]:
                if not used[i]:
                    out.append((ring[i], ring[j]))
                    used[i] = used[j] = True
                break
            if not forward[j]:
                break  # another b -> a first: the orientations do not alternate
    return np.asarray(out, dtype=np.int64).reshape(-1, 2)


def orient_consistently(vertices: np.ndarray, triangles: np.ndarray):
    """Flip triangles so that every edge in two triangles runs both ways.

    Parameters
    ----------
    vertices : ndarray of shape (V, 3), float64
        Mesh vertices.
    triangles : ndarray of shape (F, 3), int64
        Triangles, each edge in at most two of them (`split_nonmanifold`).

    Returns
    -------
    triangles : ndarray of shape (F, 3), int64
        The triangles, some reversed (the input array itself when none is).
    n_flipped : int
        Number of reversed triangles.

    Notes
    -----
    Each edge in two triangles says whether they agree (the edge runs both ways) or
    not. In the doubled graph (every triangle as itself and as its reverse; agreeing
    triangles joined as themselves, disagreeing ones each to the other's reverse)
    every orientable connected part gives two components, one the reverse of the
    other; the one holding more of the input's own triangles by area is kept, so the
    input's orientation wins where it is the majority. A part that is not
    orientable (a Moebius band: a triangle joined to its own reverse) is left as it
    is. Vectorised (scipy's connected components): trimesh's ``fix_winding`` walks
    the faces with networkx, about 1 s for 25,000 triangles.

    Examples
    --------
    A tetrahedron with one face reversed: that face is turned back.

    >>> v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1.0]])
    >>> tet = np.array([[0, 2, 1], [0, 1, 3], [1, 2, 3], [2, 3, 0]])
    >>> t, n = orient_consistently(v, tet)
    >>> n, t[3].tolist()
    (1, [0, 3, 2])
    """
    tri = triangles
    n_tri = tri.shape[0]
    if n_tri == 0:
        return tri, 0
    n_vert = vertices.shape[0]
    directed = tri[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2)
    und = np.sort(directed, axis=1)
    key = und[:, 0].astype(np.int64) * n_vert + und[:, 1]
    order = np.argsort(key, kind="stable")
    k = key[order]
    # runs of exactly two equal keys: the edges in two triangles
    start = np.r_[True, k[1:] != k[:-1]]
    run_start = np.flatnonzero(start)
    run_len = np.diff(np.r_[run_start, k.shape[0]])
    first = run_start[run_len == 2]
    s0, s1 = order[first], order[first + 1]
    agree = directed[s0, 0] != directed[s1, 0]
    t0, t1 = s0 // 3, s1 // 3
    if agree.all():
        return tri, 0
    # node t: the triangle as given; node t + F: reversed
    flip = np.where(agree, 0, n_tri)
    rows = np.concatenate([t0, t0 + n_tri])
    cols = np.concatenate([t1 + flip, (t1 + n_tri - flip)])
    graph = coo_matrix(
        (np.ones(rows.shape[0], dtype=np.int8), (rows, cols)), shape=(2 * n_tri, 2 * n_tri)
    )
    _, comp = connected_components(graph, directed=False)
    same, rev = comp[:n_tri], comp[n_tri:]
    area = 0.5 * np.linalg.norm(
        np.cross(
            vertices[tri[:, 1]] - vertices[tri[:, 0]], vertices[tri[:, 2]] - vertices[tri[:, 0]]
        ),
        axis=1,
    )
    n_comp = comp.max() + 1
    # area of the input's own triangles in every doubled component
    held = np.bincount(same, weights=area + 1e-300, minlength=n_comp)
    orientable = same != rev
    keep_given = held[same] >= held[rev]
    # ties (equal areas) keep the component of the lowest triangle as given
    tie = held[same] == held[rev]
    if tie.any():
        low = np.full(n_comp, n_tri, dtype=np.int64)
        np.minimum.at(low, same, np.arange(n_tri))
        keep_given[tie] = low[same[tie]] <= low[rev[tie]]
    reverse = orientable & ~keep_given
    if not reverse.any():
        return tri, 0
    out = tri.copy()
    out[reverse] = tri[reverse][:, ::-1]
    return out, int(reverse.sum())
