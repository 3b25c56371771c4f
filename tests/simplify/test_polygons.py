"""What OUT holds: simple, exactly planar polygons that other readers turn into the
same closed surface; vertices placed on the planes of flat regions; the output
measured both ways (a spike shows only output -> input)."""

from __future__ import annotations

import collections

import mapbox_earcut
import numpy as np
import pytest

from pointatlas import data
from pointatlas.io import read_mesh
from pointatlas.simplify import simplify_mesh
from pointatlas.simplify._polygons import planar_pieces
from pointatlas.simplify._readers import ear_clip_triangles, fan_triangles
from pointatlas.synth import cube
from tests.cli.helpers import run
from tests.jit_off import JIT_OFF, run_module_without_jit

from . import cad_shapes as C


def _diag(v) -> float:
    return float(np.linalg.norm(np.ptp(np.asarray(v), axis=0)))


def _closed_and_oriented(triangles) -> bool:
    """Every directed edge once and its reverse once (a plain count)."""
    count = collections.Counter()
    for a, b, c in np.asarray(triangles).tolist():
        count.update([(a, b), (b, c), (c, a)])
    return all(n == 1 and count.get((e[1], e[0]), 0) == 1 for e, n in count.items())


def _rotated_to_float32(v, seed=0):
    """A rigid motion of ``v`` stored as float32: faces planar only to ~1e-7."""
    q, _ = np.linalg.qr(np.random.default_rng(seed).normal(size=(3, 3)))
    return (np.asarray(v) @ q.T + 12.5).astype(np.float32).astype(np.float64)


def test_box_of_many_triangles_is_six_planar_quads_at_zero_distance():
    m = cube(6)  # 6 x 6 quads a side
    res = simplify_mesh(m.vertices, m.faces)
    assert [len(p) for p in res.polygons] == [4] * 6
    assert res.triangles.shape == (12, 3) and _closed_and_oriented(res.triangles)
    assert max(res.distance_max, res.back_distance_max) < 1e-12
    assert res.polygon_planarity.max() < 1e-12


def test_cylinder_at_max_error_is_within_it_both_ways():
    v, t = C.cylinder(64)
    eps = 0.01 * _diag(v)
    res = simplify_mesh(v, t, max_error=eps)
    assert res.distance_max <= eps and res.back_distance_max <= eps
    coarse = simplify_mesh(v, t, max_error=4 * eps)
    assert len(coarse.triangles) < len(res.triangles)  # a looser bound simplifies more


def test_float32_l_bracket_comes_out_exactly_planar():
    v, t = C.l_bracket()
    v32 = _rotated_to_float32(v)
    flat = np.abs(v32 - np.round(v32, 3)).max()
    assert flat > 1e-7  # the stored faces are not exactly planar
    res = simplify_mesh(v32, t)
    assert res.n_faces == 8 and len(res.polygons) == 8  # two L caps, six sides
    assert res.polygon_planarity.max() <= 1e-9 * _diag(v32)
    assert res.distance_max <= 1e-5 * _diag(v32)
    sizes = sorted(len(p) for p in res.polygons)
    assert sizes == [4] * 6 + [6, 6] and _closed_and_oriented(res.triangles)


def test_a_spike_shows_only_output_to_input():
    v, t = C.box()
    res = simplify_mesh(v, t)
    assert res.back_distance_max < 1e-12
    from pointatlas.simplify._distance import back_distances

    spiked = res.vertices.copy()
    spiked[0] += [0.0, 0.0, 3.0]
    assert back_distances(spiked, res.triangles, v, t).max() > 2.0


def _random_face(seed):
    """Earcut triangles of a random star-shaped outline with a square hole, in a tilted
    plane: a face with a hole, as the mesh path builds it."""
    rng = np.random.default_rng(seed)
    k = int(rng.integers(8, 30))
    angle = np.sort(rng.uniform(0, 2 * np.pi, k))
    radius = rng.uniform(2.0, 4.0, k)
    outer = np.column_stack([radius * np.cos(angle), radius * np.sin(angle)])
    hole = np.array([[-0.5, -0.5], [-0.5, 0.5], [0.5, 0.5], [0.5, -0.5]])  # clockwise
    xy = np.vstack([outer, hole])
    ends = np.array([k, k + 4], dtype=np.uint32)
    tri = np.asarray(mapbox_earcut.triangulate_float64(xy, ends), dtype=np.int64).reshape(-1, 3)
    a, b, c = xy[tri[:, 0]], xy[tri[:, 1]], xy[tri[:, 2]]
    ccw = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
    tri[ccw < 0] = tri[ccw < 0][:, [0, 2, 1]]
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    return np.column_stack([xy, np.zeros(len(xy))]) @ q.T, tri


@pytest.mark.parametrize("seed", range(6))
def test_pieces_are_simple_and_cover_the_face_once(seed):
    v, tri = _random_face(seed)
    pieces = planar_pieces(v, tri, 1e-9)
    assert len(pieces) >= 2  # a hole needs two simple polygons at least
    assert all(len(set(p.tolist())) == len(p) for p in pieces)
    # the pieces' boundaries together are the face's boundary plus shared cuts
    boundary = collections.Counter()
    for p in pieces:
        boundary.update(zip(p.tolist(), np.roll(p, -1).tolist(), strict=True))
    face = collections.Counter()
    for a, b, c in tri.tolist():
        face.update([(a, b), (b, c), (c, a)])
    outline = {e for e in face if (e[1], e[0]) not in face}
    cuts = {e for e in boundary if (e[1], e[0]) in boundary}
    assert set(boundary) == outline | cuts
    assert sum(len(p) - 2 for p in pieces) == len(tri)  # every triangle once


@pytest.mark.parametrize("seed", range(4))
def test_what_readers_make_of_random_parts_is_closed(seed):
    rng = np.random.default_rng(seed)
    k = int(rng.integers(8, 24))
    angle = np.sort(rng.uniform(0, 2 * np.pi, k))
    outer = np.column_stack([np.cos(angle), np.sin(angle)]) * rng.uniform(2.0, 4.0, (k, 1))
    holes = [C.circle((0.0, 0.0), 0.8, int(rng.integers(5, 12)))]
    v, t = C.extrude(outer, holes, height=float(rng.uniform(0.3, 2.0)))
    res = simplify_mesh(_rotated_to_float32(v, seed), t)
    assert res.is_closed and res.polygon_planarity.max() <= 1e-7 * _diag(v)
    pts = res.vertices
    for make in (fan_triangles, lambda p: ear_clip_triangles(pts[p], p)):
        tris = [tri for p in res.polygons for tri in make(p)]
        assert len(tris) == len(res.triangles) and _closed_and_oriented(tris)


@pytest.mark.parametrize("how", [(), ("--regions",)], ids=["decimate", "regions"])
@pytest.mark.parametrize("model", ["fandisk", "plate", "cube_hole", "torus"])
def test_polygon_files_read_as_closed_meshes_by_trimesh_and_open3d(tmp_path, model, how):
    import trimesh

    from pointatlas.io import write_mesh

    shapes = {"plate": C.plate_with_two_holes, "cube_hole": C.cube_with_square_hole}
    src = model
    if model in shapes:
        src = tmp_path / f"{model}.stl"
        write_mesh(src, *shapes[model]())
    out_obj, out_ply = tmp_path / "out.obj", tmp_path / "out.ply"
    for out in (out_obj, out_ply):
        result = run("simplify", src, out, *how)
        assert result.exit_code == 0, result.output
    ours = read_mesh(out_obj)
    assert all(len(set(f.tolist())) == len(f) for f in ours.face_list())
    tm = trimesh.load(out_obj, process=False)
    assert tm.is_watertight and tm.is_winding_consistent
    assert len(tm.faces) == int((ours.face_sizes - 2).sum())
    # the PLY too (ASCII where its faces' sizes differ: trimesh's binary reader
    # refuses list rows of mixed lengths)
    tp = trimesh.load(out_ply, process=False)
    assert tp.is_watertight and tp.is_winding_consistent and len(tp.faces) == len(tm.faces)
    o3d = pytest.importorskip("open3d")
    om = o3d.io.read_triangle_mesh(str(out_ply))
    assert len(om.triangles) == len(tm.faces)
    assert _closed_and_oriented(np.asarray(om.triangles))


def test_bundled_models_write_closed_polygons():
    for name in ("fandisk", "torus", "eight"):
        m = data.load_mesh(name)
        res = simplify_mesh(m.vertices, m.triangles)
        assert res.polygon_planarity.max() <= 1e-6 * _diag(m.vertices)
        assert _closed_and_oriented([t for p in res.polygons for t in fan_triangles(p)])


@pytest.mark.parametrize("seed", range(30))
def test_ear_clipping_kernel_agrees_with_the_numpy_reference(seed):
    from pointatlas.simplify._readers import ear_clip_triangles

    from .reference import ear_clip_reference

    rng = np.random.default_rng(seed)
    n = int(rng.integers(3, 40))
    angle = np.sort(rng.uniform(0, 2 * np.pi, n))
    radius = rng.uniform(0.2, 1.0, n)  # star-shaped, often not convex
    flat = np.column_stack([radius * np.cos(angle), radius * np.sin(angle), np.zeros(n)])
    if seed % 3 == 0:
        flat = flat[::-1]  # clockwise
    rot, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    points = flat @ rot.T if seed % 2 else flat
    ids = rng.permutation(1000)[:n]
    assert ear_clip_triangles(points, ids) == ear_clip_reference(points, ids)


def _star_polygon(seed):
    """A random polygon star-shaped about the origin (convex for seeds 1, 4, 7, ...)
    in a tilted plane, counter-clockwise about the normal returned, with a corner
    halfway between two others."""
    rng = np.random.default_rng(seed)
    n = int(rng.integers(3, 30))
    angle = np.sort(rng.uniform(0, 2 * np.pi, n))
    radius = rng.uniform(0.2, 1.0, n) if seed % 3 != 1 else np.ones(n)  # 1: convex
    flat = np.column_stack([radius * np.cos(angle), radius * np.sin(angle), np.zeros(n)])
    if n > 4:  # a corner halfway along an edge: flat fan triangles
        flat[2] = 0.5 * (flat[1] + flat[3])
    rot, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    return flat @ rot.T, rot[:, 2]


@pytest.mark.parametrize("seed", range(30))
def test_fan_kind_kernel_matches_reference(seed):
    from pointatlas.simplify._polygon_kernels import fan_kind

    from .reference import fan_kind_reference

    p, normal = _star_polygon(seed)
    if seed % 3 == 0:
        p = p[::-1].copy()  # clockwise: fans from most starts turn against the normal
    kinds = [fan_kind(p, normal, s, 1e-12) for s in range(len(p))]
    assert kinds == [fan_kind_reference(p, normal, s, 1e-12) for s in range(len(p))]
    if seed % 3 == 1:  # convex: every fan covers it; flat where it has corners 1, 2, 3
        assert kinds == [1 if len(p) > 4 and s in (1, 3) else 2 for s in range(len(p))]


@pytest.mark.skipif(JIT_OFF, reason="already running with the JIT off")
def test_kernels_without_jit():
    run_module_without_jit(__file__, select="kernel_matches_reference or kernel_agrees")
