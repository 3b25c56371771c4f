"""Faces of the simplified mesh: star-convex ordering and general faces (thesis 4.4.2)."""

from __future__ import annotations

from dataclasses import dataclass

import mapbox_earcut
import numpy as np

__all__ = ["Face", "general_faces", "star_faces"]


@dataclass(frozen=True, slots=True)
class Face:
    """One region's face (private): loops (outer first, CCW about the plane normal;
    holes CW), its triangles (vertex ids), and whether it is valid."""

    region: int
    loops: tuple
    triangles: np.ndarray
    ok: bool
    note: str


def _basis(normal, ref):
    """Orthonormal (u, v) with (u, v, normal) right-handed; u along ``ref`` projected."""
    u = ref - np.dot(ref, normal) * normal
    if np.linalg.norm(u) < 1e-12:
        axis = np.eye(3)[int(np.argmin(np.abs(normal)))]
        u = axis - np.dot(axis, normal) * normal
    u = u / np.linalg.norm(u)
    return u, np.cross(normal, u)


def _signed_area(xy):
    x, y = xy[:, 0], xy[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y))


def plane_deviation(pts: np.ndarray) -> float:
    """Largest distance of points to their least-squares plane (0 for three or fewer)."""
    if pts.shape[0] <= 3:
        return 0.0
    c = pts - pts.mean(axis=0)
    _, _, vt = np.linalg.svd(c, full_matrices=False)
    return float(np.max(np.abs(c @ vt[-1])))


def _inside(pt, poly):
    """Even-odd point-in-polygon test (2-D)."""
    x, y = pt
    xs, ys = poly[:, 0], poly[:, 1]
    xn, yn = np.roll(xs, -1), np.roll(ys, -1)
    cond = (ys > y) != (yn > y)
    with np.errstate(divide="ignore", invalid="ignore"):
        xint = xs + (y - ys) * (xn - xs) / (yn - ys)
    return bool(np.sum(cond & (x < xint)) % 2)


def _undirected(edges):
    return {(min(a, b), max(a, b)) for a, b in edges}


def _loop_edges(loop):
    return [(int(loop[t]), int(loop[(t + 1) % len(loop)])) for t in range(len(loop))]


def _triangulate(loops, coords2d):
    """earcut on an outer loop and holes; returns (T, 3) vertex ids, CCW in 2-D."""
    flat = np.concatenate(loops)
    xy = np.concatenate(coords2d)
    ends = np.cumsum([len(lp) for lp in loops]).astype(np.uint32)
    tri = np.asarray(mapbox_earcut.triangulate_float64(xy, ends), dtype=np.int64).reshape(-1, 3)
    if tri.size == 0:
        return np.zeros((0, 3), dtype=np.int64)
    a, b, c = xy[tri[:, 0]], xy[tri[:, 1]], xy[tri[:, 2]]
    cross = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
    flip = cross < 0
    tri[flip] = tri[flip][:, [0, 2, 1]]
    return flat[tri]


def _boundary_matches(triangles, loops):
    if triangles.size == 0:
        return False
    e = np.sort(
        np.concatenate([triangles[:, [0, 1]], triangles[:, [1, 2]], triangles[:, [2, 0]]]), 1
    )
    uniq, cnt = np.unique(e, axis=0, return_counts=True)
    boundary = {(int(a), int(b)) for a, b in uniq[cnt == 1]}
    want = set()
    for lp in loops:
        want |= _undirected(_loop_edges(lp))
    return boundary == want and bool((cnt <= 2).all())


def _project_loops(loops, positions, normal, origin):
    ref_v = min(int(lp.min()) for lp in loops)
    u, v = _basis(normal, positions[ref_v] - origin)
    return [
        np.stack([(positions[lp] - origin) @ u, (positions[lp] - origin) @ v], 1) for lp in loops
    ]


def _face_from_loops(region, loops, positions, normal, origin):
    """Orient, nest and triangulate one region's loops in the plane (normal, origin)."""
    xy = _project_loops(loops, positions, normal, origin)
    areas = [_signed_area(c) for c in xy]
    outer = int(np.argmax(np.abs(areas)))
    order = [outer] + [t for t in range(len(loops)) if t != outer]
    note = ""
    out_loops, out_xy = [], []
    for t in order:
        lp, c, a = loops[t], xy[t], areas[t]
        want_ccw = t == outer
        if (a > 0) != want_ccw:
            lp, c = lp[::-1].copy(), c[::-1].copy()
        if t != outer and not all(_inside(p, out_xy[0]) for p in c):
            note = "a hole cycle lies outside the outer cycle in the proxy plane; dropped"
            continue
        out_loops.append(lp)
        out_xy.append(c)
    tris = _triangulate(out_loops, out_xy)
    ok = _boundary_matches(tris, out_loops) and not note
    return Face(region, tuple(out_loops), tris, ok, note)


def general_faces(cplx, positions, plane_normals, centroids) -> list[Face]:
    """General faces: each region's cycles mapped to its plane, triangulated with holes.

    The outer loop is the cycle of largest projected area; the others are holes.
    earcut keeps the triangles inside the outer loop and outside the holes, the
    segment bounded exactly by the cycles (Fig. 4.8); the face is valid when the
    triangulation's boundary edges equal the cycle edges. When the projection to
    the proxy plane self-intersects, the plane fitted to the face's own vertices is
    tried; a single loop that still fails is fan-triangulated so the mesh stays
    closed (the face is reported as not ok).
    """
    faces = []
    for i, cyc_ids in enumerate(cplx.region_cycles):
        if not cyc_ids:
            continue
        loops = [np.asarray(cplx.cycles[c], dtype=np.int64) for c in cyc_ids]
        loops = [lp for lp in loops if lp.size >= 3]
        if not loops:
            continue
        face = _face_from_loops(i, loops, positions, plane_normals[i], centroids[i])
        if not face.ok:
            pts = positions[np.concatenate(loops)]
            origin = pts.mean(axis=0)
            _, _, vt = np.linalg.svd(pts - origin, full_matrices=False)
            own = vt[-1] if np.dot(vt[-1], plane_normals[i]) >= 0 else -vt[-1]
            retry = _face_from_loops(i, loops, positions, own, origin)
            if retry.ok:
                face = Face(i, retry.loops, retry.triangles, True, "")
            elif len(face.loops) == 1 and not face.note:
                lp = face.loops[0]
                fan = np.stack([np.full(lp.size - 2, lp[0]), lp[1:-1], lp[2:]], axis=1)
                note = "self-intersecting in the proxy plane; fan-triangulated"
                face = Face(i, face.loops, fan.astype(np.int64), False, note)
            elif not face.note:
                face = Face(
                    i,
                    face.loops,
                    face.triangles,
                    False,
                    "triangulation boundary differs from the cycles (self-intersecting projection)",
                )
        faces.append(face)
    return faces


def star_faces(cplx, positions, plane_normals, centroids) -> list[Face]:
    """Star-convex faces [SZP20]: a region's vertices sorted by angle about its centroid."""
    members: list[list[int]] = [[] for _ in range(cplx.n_regions)]
    used = np.zeros(cplx.n_vertices, dtype=bool)
    for c in cplx.cycles:
        used[c] = True
    for j, regs in enumerate(cplx.vertex_regions):
        if used[j]:
            for i in regs:
                members[i].append(j)
    faces = []
    for i, mem in enumerate(members):
        if len(mem) < 3:
            continue
        vids = np.asarray(sorted(mem), dtype=np.int64)
        nrm = plane_normals[i]
        u, v = _basis(nrm, positions[vids[0]] - centroids[i])
        rel = positions[vids] - centroids[i]
        ang = np.arctan2(rel @ v, rel @ u)
        order = np.lexsort((vids, ang))
        loop = vids[order]
        xy = np.stack([rel[order] @ u, rel[order] @ v], 1)
        tris = _triangulate([loop], [xy])
        ok = _boundary_matches(tris, [loop])
        note = "" if ok else "vertices are not star-convex about the region centroid"
        faces.append(Face(i, (loop,), tris, ok, note))
    return faces
