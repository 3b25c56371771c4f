"""Vertices, faces and the assembled mesh of the thesis path (thesis 4.4.1-4.4.2).

The steps of `simplify_segmentation` after the regions are cleaned: place the
vertices (`place_vertices`: guarded least squares, Eq. 4.12, or the plane fit
through common vertices with its anchor-weight schedule), build the faces, and
assemble the `SimplifiedMesh` in input coordinates (`assemble_mesh`) with its
per-region report (`regions_report`). Decisions in docs/decisions/simplify.md
("The thesis path").
"""

from __future__ import annotations

import dataclasses
import warnings

import numpy as np

from .._core import PointAtlasError
from ..neighbors import point_mesh_distance
from ._distance import PointSurface, back_distances
from ._faces import general_faces, plane_deviation, star_faces
from ._mesh import SimplifiedMesh, mesh_checks
from ._polygons import PLANAR_RTOL, face_polygons
from ._vertices import (
    MeshVertices,
    SimplifyWarning,
    fit_vertices,
    lsq_vertices,
    optimize_vertices,
)

__all__ = ["FIT_ANCHOR_WEIGHTS", "assemble_mesh", "place_vertices", "regions_report"]


#: anchor weights tried by ``vertices="fit"`` with ``anchor_weight=None``, loosest first
FIT_ANCHOR_WEIGHTS = (0.01, 0.1, 1.0, 10.0)


def _fit_with_valid_faces(
    cplx, points, labels, pn, ctr, lsq, anchor_weight, max_iter, builder, centroids
):
    """``fit_vertices`` and faces; with ``anchor_weight=None`` the loosest weight of
    `FIT_ANCHOR_WEIGHTS` whose faces are all valid and whose mesh is closed, manifold
    and oriented (else the best by: no fallback, closed/manifold/oriented, fewest
    invalid faces, looser weight). Returns (MeshVertices, faces, weight used)."""
    schedule = FIT_ANCHOR_WEIGHTS if anchor_weight is None else (float(anchor_weight),)
    best = None
    caught_best: list = []
    for aw in schedule:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", SimplifyWarning)
            mv = fit_vertices(cplx, points, labels, pn, ctr, lsq=lsq, weight=aw, max_iter=max_iter)
        face_list = builder(cplx, np.asarray(mv.positions), np.asarray(mv.plane_normals), centroids)
        tris = [f.triangles for f in face_list if f.triangles.size]
        good = bool(tris) and all(mesh_checks(cplx.n_vertices, np.concatenate(tris)))
        key = (mv.fallback, not good, sum(not f.ok for f in face_list))
        if best is None or key < best[0]:
            best, caught_best = (key, mv, face_list, aw), caught
        if key == (False, False, 0):
            break
    for w in caught_best:  # the chosen solve's warnings (a fallback to plane intersection)
        warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
    _, mv, face_list, aw = best
    return mv, face_list, (float("nan") if mv.fallback else aw)


def place_vertices(
    clean, q, *, vertices, faces, weight, anchor_weight, max_distance, max_iter
) -> tuple[MeshVertices, list, float]:
    """Vertices by the chosen method and the faces (working coordinates)."""
    cplx, pn, ctr = clean.surface_complex, clean.proxy_normals, clean.centers
    lsq = lsq_vertices(cplx, q, pn, ctr, max_distance=max_distance)
    builder = general_faces if faces == "general" else star_faces
    if vertices == "fit":
        return _fit_with_valid_faces(
            cplx,
            q[clean.fit_mask],
            clean.labels[clean.fit_mask],
            pn,
            ctr,
            lsq,
            anchor_weight,
            max_iter,
            builder,
            clean.centroids,
        )
    mv = lsq
    if vertices == "optimize":
        mv = optimize_vertices(cplx, q, pn, ctr, weight=weight, max_iter=max_iter, lsq=lsq)
    face_list = builder(
        cplx, np.asarray(mv.positions), np.asarray(mv.plane_normals), clean.centroids
    )
    return mv, face_list, float("nan")


def assemble_mesh(frame, q, clean, mv, face_list, faces, used_weight, inp):
    """The SimplifiedMesh in input coordinates from the working-frame results.

    ``inp`` (`simplify_segmentation`'s checked input): ``keep`` (N_input,) marks the
    points used, ``labels`` are their input regions (for `regions_report`),
    ``normals`` (of the points used, or None) give the points' surface the output is
    measured back to (`PointSurface`)."""
    keep, labels, normals = inp.keep, inp.labels, inp.normals
    cplx = clean.surface_complex
    if not face_list:
        raise PointAtlasError(
            "no region has a closed boundary cycle; cannot build faces "
            f"({cplx.n_vertices} vertices, {cplx.n_edges} edges)"
        )
    point_index = np.flatnonzero(keep)
    positions = np.asarray(mv.positions)
    plane_n = np.asarray(mv.plane_normals)
    used = np.unique(np.concatenate([np.concatenate(f.loops) for f in face_list]))
    remap = np.full(cplx.n_vertices, -1, dtype=np.int64)
    remap[used] = np.arange(used.size)
    verts = positions[used]
    face_loops, tris, tri_face = [], [], []
    for fi, f in enumerate(face_list):
        face_loops.append(tuple(remap[lp] for lp in f.loops))
        t = remap[f.triangles] if f.triangles.size else np.zeros((0, 3), np.int64)
        tris.append(t)
        tri_face.append(np.full(t.shape[0], fi, dtype=np.int64))
    triangles = np.concatenate(tris).astype(np.int64) if tris else np.zeros((0, 3), np.int64)
    triangle_face = np.concatenate(tri_face) if tri_face else np.zeros(0, np.int64)
    diag = float(np.linalg.norm(np.ptp(verts, axis=0)))
    polygons, polygon_face, polygon_planarity = face_polygons(
        verts, triangles, triangle_face, face_loops, PLANAR_RTOL * diag
    )
    closed, manifold, oriented = mesh_checks(verts.shape[0], triangles)
    if triangles.shape[0]:
        dist = point_mesh_distance(q, verts, triangles) * frame.scale
        back = back_distances(verts, triangles, PointSurface(q, normals)) * frame.scale
    else:
        dist, back = np.full(q.shape[0], np.inf), np.full(1, np.inf)
    with_face = {f.region for f in face_list}
    n_regions = plane_n.shape[0]
    return SimplifiedMesh(
        vertices=frame.to_input(verts),
        vertex_ids=used.astype(np.int64),
        polygons=polygons,
        polygon_face=polygon_face,
        polygon_planarity=polygon_planarity * frame.scale,
        face_region=np.array([f.region for f in face_list], dtype=np.int64),
        face_loops=tuple(face_loops),
        face_ok=np.array([f.ok for f in face_list], dtype=bool),
        planarity_error=np.array([_planarity(verts, lp) for lp in face_loops]) * frame.scale,
        triangles=triangles,
        triangle_face=triangle_face,
        is_closed=closed,
        is_manifold=manifold,
        is_oriented=oriented,
        distances=dist,
        distance_mean=float(dist.mean()),
        distance_max=float(dist.max()),
        back_distance_mean=float(back.mean()),
        back_distance_max=float(back.max()),
        vertex_method=mv.method,
        face_method=faces,
        fallback=mv.fallback,
        constraint_violation=float(mv.constraint_violation),
        n_guarded=int(mv.guarded[used].sum()),
        regions_without_face=np.array(
            [i for i in range(n_regions) if i not in with_face], dtype=np.int64
        ),
        plane_normals=plane_n,
        plane_offsets=frame.offsets_to_input(plane_n, mv.plane_offsets),
        labels=clean.labels,
        region_map=clean.input_map,
        surface_complex=dataclasses.replace(cplx, vertex_anchor=frame.to_input(cplx.vertex_anchor)),
        anchor_weight=used_weight,
        point_index=point_index,
        n_dropped=int(keep.size - point_index.size),
        regions_report=regions_report(labels, clean, face_list),
    )


def _planarity(vertices, loops):
    return plane_deviation(vertices[np.concatenate(loops)])


def regions_report(labels, clean, face_list) -> tuple:
    """Which input regions became faces and why the others did not.

    An input region becomes a face when the final region holding most of its points
    has a face and the region is that final region's largest input region; a region
    merged into another keeps the first reason recorded by `clean_regions`.
    """
    n_in = int(labels.max()) + 1
    n_fin = int(clean.labels.max()) + 1
    both = np.zeros((n_in, n_fin), dtype=np.int64)
    np.add.at(both, (labels, clean.labels), 1)
    n_points = np.bincount(labels, minlength=n_in)
    final = np.where(both.any(axis=1), both.argmax(axis=1), -1)
    # main input region of every final region: most points, then smaller id
    main = np.argmax(both, axis=0)
    faces = {f.region: f for f in face_list}
    cplx = clean.surface_complex
    reasons = clean.input_reasons or ("",) * n_in
    out = []
    for r in range(n_in):
        f = int(final[r])
        face = faces.get(f) if f >= 0 else None
        became = face is not None and int(main[f]) == r
        if f < 0:
            why = "every point was relabelled by the majority filter (smooth)"
        elif became:
            merged = [int(x) for x in np.flatnonzero(both[:, f]) if x != r]
            why = "face" + (f" (with points of input regions {merged})" if merged else "")
            if not face.ok:
                why += "; not valid: " + (face.note or "triangulation differs from its cycles")
        elif reasons[r]:
            why = reasons[r]
        elif face is not None:
            why = f"merged into the face of input region {int(main[f])}"
        elif not cplx.region_cycles[f]:
            why = "no closed boundary cycle in the complex"
        else:
            why = "no valid boundary loop"
        out.append(
            {
                "region": r,
                "n_points": int(n_points[r]),
                "became_face": bool(became),
                "final_region": f,
                "reason": why,
            }
        )
    return tuple(out)
