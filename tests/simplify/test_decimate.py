"""Structure-aware decimation (`decimate_mesh`): closed stays closed, flat regions come
out as exact planar polygons, and per triangle it is as close to the input as the
quadric decimator users already have (Open3D), measured both ways."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from pointatlas import data
from pointatlas.neighbors import point_mesh_distance
from pointatlas.simplify import decimate_mesh, mesh_checks
from pointatlas.simplify._decimate import decimate
from pointatlas.simplify._distance import PointSurface
from pointatlas.synth import cube, plane_patch, sample_mesh

from . import cad_shapes as C


def _two_sided_mean(v, t, v2, t2) -> float:
    a = np.vstack([v, sample_mesh(v, t, 5000, rng=0).points])
    b = np.vstack([v2, sample_mesh(v2, t2, 5000, rng=0).points])
    return 0.5 * (point_mesh_distance(a, v2, t2).mean() + point_mesh_distance(b, v, t).mean())


def test_box_of_many_triangles_decimates_to_six_quads():
    m = cube(6)
    res = decimate_mesh(m.vertices, m.faces, 12)
    assert [len(p) for p in res.polygons] == [4] * 6
    assert max(res.distance_max, res.back_distance_max) < 1e-12


@pytest.mark.parametrize("name", ["torus", "eight"])
@pytest.mark.parametrize("fraction", [0.1, 0.3])
def test_closed_inputs_stay_closed_at_the_budget(name, fraction):
    m = data.load_mesh(name)
    target = int(fraction * m.n_faces)
    res = decimate_mesh(m.vertices, m.triangles, target)
    assert target - 2 <= len(res.triangles) <= target
    assert (res.is_closed, res.is_manifold, res.is_oriented) == (True, True, True)
    assert res.euler_characteristic == len(m.vertices) - m.n_faces // 2  # V - E + F kept
    assert res.polygon_planarity.max() <= 1e-7 * np.ptp(m.vertices, axis=0).max() * 2


def test_float32_l_bracket_gives_its_eight_planar_faces():
    v, t = C.l_bracket()
    q, _ = np.linalg.qr(np.random.default_rng(1).normal(size=(3, 3)))
    v32 = (v @ q.T + 7.25).astype(np.float32).astype(np.float64)
    res = decimate_mesh(v32, t, 20)
    assert len(res.polygons) == 8 and res.is_closed
    diag = float(np.linalg.norm(np.ptp(v32, axis=0)))
    assert res.polygon_planarity.max() <= 1e-9 * diag
    assert max(res.distance_max, res.back_distance_max) <= 1e-5 * diag


def test_an_open_sheet_keeps_its_outline():
    m = plane_patch()
    v, t = np.asarray(m.vertices), np.asarray(m.faces)
    out_v, out_t, _, _ = decimate(v, t, len(t) // 10)
    assert mesh_checks(len(out_v), out_t)[1:] == (True, True)
    np.testing.assert_allclose(np.ptp(out_v, axis=0)[:2], np.ptp(v, axis=0)[:2], rtol=1e-9)


def test_more_triangles_are_closer():
    m = data.load_mesh("eight")
    v, t = np.asarray(m.vertices), np.asarray(m.triangles)
    errors = []
    for target in (100, 300, 900):
        res = decimate_mesh(v, t, target)
        errors.append(_two_sided_mean(v, t, res.vertices, res.triangles))
    assert errors[0] > errors[1] > errors[2]


def test_as_close_as_open3d_quadric_decimation_at_equal_triangles():
    o3d = pytest.importorskip("open3d")
    for name, target in (("eight", 300), ("torus", 400)):
        m = data.load_mesh(name)
        v, t = np.array(m.vertices, dtype=float), np.array(m.triangles, dtype=np.int32)
        ours = decimate_mesh(v, t, target)
        mesh = o3d.geometry.TriangleMesh(
            o3d.utility.Vector3dVector(v), o3d.utility.Vector3iVector(t)
        )
        peer = mesh.simplify_quadric_decimation(target_number_of_triangles=len(ours.triangles))
        pv, pt = np.asarray(peer.vertices), np.asarray(peer.triangles, dtype=np.int64)
        mine = _two_sided_mean(v, t, ours.vertices, ours.triangles)
        theirs = _two_sided_mean(v, t, pv, pt)
        assert mine <= 1.25 * theirs, (name, mine, theirs)


@pytest.mark.parametrize(("shape", "target"), [("l_bracket", 20), ("cube_with_square_hole", 40)])
def test_a_finely_meshed_cad_part_at_a_small_budget_is_as_close_as_open3d(shape, target):
    # twice subdivided (320 and 512 triangles): the structured decimation alone was
    # 1.62x and 1.59x Open3D's two-sided mean at these budgets (the planes' quadrics
    # steer the last collapses once the flat faces cannot all be kept); the plain
    # decimation, kept when nearer, is 1.10x and 1.06x
    o3d = pytest.importorskip("open3d")
    v, t = C.subdivide(*C.subdivide(*getattr(C, shape)()))
    ours = decimate_mesh(v, t, target)
    assert len(ours.triangles) == target and ours.is_closed and ours.is_oriented
    assert ours.euler_characteristic == len(v) - len(t) // 2  # V - E + F kept
    assert ours.polygon_planarity.max() <= 1e-12
    mesh = o3d.geometry.TriangleMesh(
        o3d.utility.Vector3dVector(v), o3d.utility.Vector3iVector(t.astype(np.int32))
    )
    peer = mesh.simplify_quadric_decimation(target_number_of_triangles=target)
    pv, pt = np.asarray(peer.vertices), np.asarray(peer.triangles, dtype=np.int64)
    assert len(pt) == target
    mine = _two_sided_mean(v, t, ours.vertices, ours.triangles)
    assert mine <= 1.25 * _two_sided_mean(v, t, pv, pt)


def test_a_budget_keeps_the_decimation_of_least_mean_times_largest_distance():
    """At a triangle budget the planes held, the structure term alone and the plain
    quadrics each reach it; the one kept has the least product of its two-sided
    mean and largest distance on the report's first samples, and is reported on
    all of them."""
    from pointatlas.simplify import _decimate_mesh as D

    v, t = C.subdivide(*C.subdivide(*C.cube_with_square_hole()))
    seen = []
    real = D._nearest_within

    def spy(levels, budget):
        chosen = real(levels, budget)
        assert [lv._args["hold"] for lv in levels] == [True, False, False]
        assert [lv._args["structure"] for lv in levels] == [1.0, 1.0, 0.0]
        for level in levels:
            m = level.steps_for(budget, None)
            assert level.seq.n_triangles(m) <= budget
            near = level.near(m, D.CHOICE_SAMPLES)
            there, back = level.distances(m)
            # the choice's samples are the report's first ones (its vertices, then draws)
            first = level.placed(m)[0].shape[0] + D.CHOICE_SAMPLES
            assert near == (
                there.mean() + back[:first].mean(),
                max(there.max(), back[:first].max()),
            )
            seen.append((level is chosen[0], near[0] * near[1], there.mean() + back.mean()))
        return chosen

    D._nearest_within = spy
    try:
        res = decimate_mesh(v, t, 40)
    finally:
        D._nearest_within = real
    kept = [k for k, s in enumerate(seen) if s[0]]
    assert len(kept) == 1 and seen[kept[0]][1] == min(s[1] for s in seen)
    # the one kept is reported on all samples
    assert res.distance_mean + res.back_distance_mean == seen[kept[0]][2]


@pytest.mark.parametrize("seed", range(20))
def test_kernels_agree_with_the_numpy_references(seed):
    from pointatlas.simplify._kernels import collapse_position, turns_over

    from .reference import collapse_position_reference, turns_over_reference

    rng = np.random.default_rng(seed)
    planes = rng.normal(size=(int(rng.integers(1, 5)), 4))  # rank 1..3 (+ degenerate)
    q = sum(np.outer(h, h) for h in planes)
    a, b = rng.normal(size=3), rng.normal(size=3)
    np.testing.assert_allclose(
        collapse_position(q, a, b), collapse_position_reference(q, a, b), rtol=1e-9, atol=1e-12
    )
    v = rng.normal(size=(8, 3))
    faces = np.array([[0, 1, 2], [0, 2, 3], [0, 3, 4], [0, 4, 5]])
    x = v[0] + rng.normal(scale=2.0, size=3)
    assert turns_over(v, faces, 0, x) == turns_over_reference(v, faces, 0, x)


@pytest.mark.parametrize("name", ["eight", "torus"])
def test_collapse_loop_agrees_with_the_python_reference(name):
    from .reference import decimate_reference

    m = data.load_mesh(name)
    v, t = np.asarray(m.vertices, dtype=float), np.asarray(m.triangles, dtype=np.int64)
    for target in (len(t) // 2, len(t) // 20):
        got = decimate(v, t, target)
        want = decimate_reference(v, t, target)
        for g, w in zip(got, want, strict=True):
            np.testing.assert_array_equal(g, w)


def test_open_sheet_loop_agrees_with_the_python_reference():
    from .reference import decimate_reference

    m = plane_patch()
    v, t = np.asarray(m.vertices, dtype=float), np.asarray(m.faces, dtype=np.int64)
    got, want = decimate(v, t, len(t) // 5), decimate_reference(v, t, len(t) // 5)
    for g, w in zip(got, want, strict=True):
        np.testing.assert_array_equal(g, w)


def _noisy_torus_points(n: int, noise: float):
    m = data.load_mesh("torus")
    v, t = np.asarray(m.vertices, dtype=float), np.asarray(m.triangles, dtype=np.int64)
    s = sample_mesh(v, t, n, rng=4)
    rng = np.random.default_rng(5)
    q = np.asarray(s.points) + rng.normal(scale=noise, size=(n, 1)) * np.asarray(s.normals)
    return v, t, PointSurface(q, np.asarray(s.normals))


def test_collapses_bounded_by_points_keep_every_point_within_its_tolerance():
    """Every level of a sequence bounded by points (`collapse_all` with their
    ``surface``) keeps every point within its tolerance of the surface (or as near
    as it was at first), measured exactly; the unbounded sequence takes them past
    it."""
    from pointatlas.simplify._decimate import collapse_all

    v, t, surface = _noisy_torus_points(3000, 0.002)
    q = surface.points
    diag = float(np.linalg.norm(np.ptp(v, axis=0)))
    tol = np.where(np.arange(q.shape[0]) % 3 == 0, 0.004, 0.008) * diag
    start = point_mesh_distance(q, v, t)
    seq = collapse_all(v, t, surface=surface, tolerance=tol)
    free = collapse_all(v, t)
    assert 0 < seq.kept.size < free.kept.size
    n = seq.kept.size
    for m in sorted({1, n // 4, n // 2, 3 * n // 4, n - 1, n}):
        mv, mt = seq.mesh(m)[:2]
        assert np.all(point_mesh_distance(q, mv, mt) <= np.maximum(tol, start) * (1 + 1e-9))
    mv, mt = free.mesh(free.kept.size)[:2]
    assert np.any(point_mesh_distance(q, mv, mt) > np.maximum(tol, start))


def test_collapses_bounded_far_away_are_the_unbounded_ones():
    """With a tolerance no collapse reaches, the points change nothing, bit for bit."""
    from pointatlas.simplify._decimate import collapse_all

    v, t, surface = _noisy_torus_points(500, 0.0)
    seq, free = collapse_all(v, t, surface=surface, tolerance=1e9), collapse_all(v, t)
    for name in ("kept", "gone", "position", "removed", "cost"):
        np.testing.assert_array_equal(getattr(seq, name), getattr(free, name))


def test_a_prefix_of_the_collapses_is_the_decimation_to_its_triangle_count():
    from pointatlas.simplify._decimate import collapse_all

    m = data.load_mesh("torus")
    v, t = np.asarray(m.vertices, dtype=float), np.asarray(m.triangles, dtype=np.int64)
    seq = collapse_all(v, t)
    assert np.all(np.isin(seq.removed, (1, 2)))
    for target in (len(t) - 2, 500, 100):
        steps = seq.steps_for(target)
        assert seq.n_triangles(steps) <= target < seq.n_triangles(steps - 1)
        for g, w in zip(seq.mesh(steps), decimate(v, t, target), strict=True):
            np.testing.assert_array_equal(g, w)
        # stopped at the target: the same collapses, up to the first level within it
        short = collapse_all(v, t, target=target)
        assert short.kept.size == steps and short.steps_for(target) == steps
        for name in ("kept", "gone", "position", "removed", "cost"):
            np.testing.assert_array_equal(getattr(short, name), getattr(seq, name)[:steps])
    assert seq.mesh(0)[1].shape == t.shape and seq.steps_for(len(t)) == 0


def test_default_level_boxes_a_box_into_six_quads_with_no_error():
    m = cube(8)
    res = decimate_mesh(m.vertices, m.faces)
    assert len(res.polygons) == 6 and len(res.triangles) == 12
    assert max(res.distance_max, res.back_distance_max) < 1e-12
    assert res.is_closed and res.is_manifold and res.is_oriented


@pytest.mark.parametrize("fraction", [0.002, 0.01])
def test_a_cylinder_at_max_error_keeps_every_vertex_within_it_both_ways(fraction):
    import trimesh

    tm = trimesh.creation.cylinder(radius=1.0, height=3.0, sections=96).subdivide().subdivide()
    v, t = np.asarray(tm.vertices), np.asarray(tm.faces)
    eps = fraction * float(np.linalg.norm(np.ptp(v, axis=0)))
    res = decimate_mesh(v, t, max_error=eps)
    assert res.distance_max <= eps and res.back_distance_max <= eps
    # independently: every input vertex to the output, output samples to the input
    assert point_mesh_distance(v, res.vertices, res.triangles).max() <= eps
    back = sample_mesh(res.vertices, res.triangles, 20000, rng=7).points
    assert point_mesh_distance(back, v, t).max() <= eps
    assert res.is_closed and res.is_manifold and len(res.triangles) < 0.2 * len(t)
    # the caps are flat: each one planar polygon, to 1e-9 of the diagonal
    assert res.polygon_planarity.max() <= 1e-9 * np.linalg.norm(np.ptp(v, axis=0))


def test_a_soup_decimates_as_its_indexed_mesh():
    m = data.load_mesh("eight")
    v, t = np.asarray(m.vertices), np.asarray(m.triangles)
    soup_v, soup_t = v[t].reshape(-1, 3), np.arange(3 * len(t)).reshape(-1, 3)
    with pytest.warns(UserWarning):
        soup = decimate_mesh(soup_v, soup_t, 200)
    indexed = decimate_mesh(v, t, 200)
    assert len(soup.triangles) == len(indexed.triangles) and soup.is_closed
    assert soup.summary()["hausdorff"] == pytest.approx(indexed.summary()["hausdorff"], rel=1e-9)


@pytest.mark.parametrize("seed", range(4))
def test_placement_agrees_with_the_one_vertex_at_a_time_reference(seed):
    from pointatlas.simplify._place import place_on_planes

    from .reference import place_on_planes_reference

    rng = np.random.default_rng(seed)
    m = data.load_mesh("eight")
    v, t = np.asarray(m.vertices), np.asarray(m.triangles)
    from pointatlas.simplify._place import flat_planes

    centre = v[t].mean(axis=1)
    face = np.digitize(centre @ rng.normal(size=3), np.linspace(-1, 1, 11))
    normals, offsets, _ = flat_planes(v, t, face, 12, 0.0)
    flat = rng.random(12) < 0.7
    want = place_on_planes_reference(v, t, face, normals, offsets, flat, 0.2, 1e-3)
    got = place_on_planes(v, t, face, normals, offsets, flat, 0.2, 1e-3)
    moved = ~np.all(got == v, axis=1)  # the others stayed, or the flip guard put them back
    np.testing.assert_allclose(got[moved], want[moved], rtol=0, atol=1e-12)
    assert moved.sum() > 10


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_output_samples_are_sample_mesh_bit_for_bit(seed):
    from pointatlas.simplify._distance import _samples_in_order, output_samples_on

    rng = np.random.default_rng(seed)
    v = rng.normal(size=(40, 3)) * 10.0 ** rng.uniform(-3, 3)
    t = rng.integers(0, 40, size=(60, 3))
    t[::4] = t[0, [0, 0, 1]]  # zero-area triangles are never drawn
    used = np.unique(t)
    for n in (1, 7, 20_000):
        want = sample_mesh(v, t, n, rng=seed)
        samples, on, order = _samples_in_order(v, t, n, seed)
        np.testing.assert_array_equal(samples[: used.size], v[used])
        np.testing.assert_array_equal(samples[used.size :], want.points)
        np.testing.assert_array_equal(on[used.size :], want.face_index)
        assert np.all(np.any(t[on[: used.size]] == used[:, None], axis=1))
        # the order: a permutation, the vertices first, then the samples by triangle
        np.testing.assert_array_equal(np.sort(order), np.arange(samples.shape[0]))
        np.testing.assert_array_equal(order[: used.size], np.arange(used.size))
        assert np.all(np.diff(on[order[used.size :]]) >= 0)
        got = output_samples_on(v, t, n, seed)
        np.testing.assert_array_equal(got[0], samples)
        # the first k area samples alone: the same points, measured by triangle
        k = min(n, 5)
        part, part_on, part_order = _samples_in_order(v, t, n, seed, first=k)
        np.testing.assert_array_equal(part, samples[: used.size + k])
        np.testing.assert_array_equal(part_on, on[: used.size + k])
        assert np.all(np.diff(part_on[part_order[used.size :]]) >= 0)


@pytest.mark.parametrize(("name", "first"), [("fandisk", 1), ("torus", 1), ("eight", 200)])
def test_the_level_search_on_a_subset_of_the_samples_finds_the_full_search_level(
    monkeypatch, name, first
):
    # the default level searched on `first` area samples back (then the level found
    # measured on all, and the search run again on all where it fails: on the torus
    # and eight, not on fandisk) against the search on all 20,000 every time
    import pointatlas.simplify._decimate_mesh as dm

    m = data.load_mesh(name)
    monkeypatch.setattr(dm, "SEARCH_SAMPLES", None)
    full = decimate_mesh(m.vertices, m.triangles)
    monkeypatch.setattr(dm, "SEARCH_SAMPLES", first)
    sub = decimate_mesh(m.vertices, m.triangles)
    np.testing.assert_array_equal(sub.triangles, full.triangles)
    np.testing.assert_array_equal(sub.vertices, full.vertices)
    assert sub.back_distance_max == full.back_distance_max
    bound = dm.MAX_ERROR * np.linalg.norm(np.ptp(m.vertices, axis=0))
    assert max(sub.distance_max, sub.back_distance_max) <= bound


def test_small_inputs_on_a_busy_machine_run_in_one_thread_with_the_same_output(monkeypatch):
    import numba

    from pointatlas.simplify import _decimate_mesh as D

    threads = numba.get_num_threads()
    seen = []
    real = D._decimate_mesh

    def spy(*args):
        seen.append(numba.get_num_threads())
        return real(*args)

    monkeypatch.setattr(D, "_decimate_mesh", spy)
    v, t = C.subdivide(*C.cube_with_square_hole())
    out = {}
    for busy in (True, False):
        monkeypatch.setattr(D, "machine_busy", lambda busy=busy: busy)
        out[busy] = (decimate_mesh(v, t), decimate_mesh(v, t, 40))
        assert numba.get_num_threads() == threads  # restored
    assert seen == [1, 1, threads, threads]
    for one, par in zip(out[True], out[False], strict=True):
        for name in ("vertices", "triangles", "triangle_face", "distances"):
            np.testing.assert_array_equal(getattr(one, name), getattr(par, name))
        assert [list(p) for p in one.polygons] == [list(p) for p in par.polygons]
    monkeypatch.setattr(D, "machine_busy", lambda: True)
    with D._threads_for(D.PARALLEL_MIN_TRIANGLES):  # large inputs: untouched
        assert numba.get_num_threads() == threads


EINSY = (
    Path(__file__).resolve().parents[2] / ".." / "shared" / "data" / "collection"
) / "prusai3_einsy-doors.stl"


@pytest.mark.skipif(not EINSY.exists(), reason="prusai3_einsy-doors.stl not under ../shared")
def test_vertices_placed_in_a_row_leave_no_zero_area_triangle():
    """A CAD part whose default level places four vertices in a row on the line of
    two planes (two triangles of no area side by side, before caps were flipped on
    the mesh path): every output triangle keeps an area, the mesh stays closed."""
    from pointatlas.io import read_mesh

    m = read_mesh(EINSY)
    res = decimate_mesh(m.vertices, m.triangles)
    v, t = np.asarray(res.vertices), np.asarray(res.triangles)
    diag = float(np.linalg.norm(np.ptp(np.asarray(m.vertices), axis=0)))
    area = 0.5 * np.linalg.norm(np.cross(v[t[:, 1]] - v[t[:, 0]], v[t[:, 2]] - v[t[:, 0]]), axis=1)
    assert area.min() > 1e-12 * diag**2
    assert (res.is_closed, res.is_manifold, res.is_oriented) == (True, True, True)
    assert max(res.distance_max, res.back_distance_max) <= 0.005 * diag * (1 + 1e-9)


@pytest.mark.parametrize("seed", range(30))
def test_planes_position_agrees_with_the_numpy_reference(seed):
    from pointatlas.simplify._plane_kernels import planes_position

    from .reference import planes_position_reference

    rng = np.random.default_rng(seed)
    q = sum(np.outer(h, h) for h in rng.normal(size=(int(rng.integers(1, 5)), 4)))
    k = seed % 5  # 0 to 4 planes; every third seed, the last nearly parallel to the first
    normals = rng.normal(size=(max(k, 1), 3))
    if k >= 2 and seed % 3 == 0:
        normals[k - 1] = normals[0] + rng.normal(scale=1e-3, size=3)
    normals /= np.linalg.norm(normals, axis=1)[:, None]
    offsets = rng.normal(size=max(k, 1))
    a, b = rng.normal(size=3), rng.normal(size=3)
    ids = np.arange(k, dtype=np.int64)
    tol = 10.0 ** rng.uniform(-9, 1)
    got = planes_position(q, a, b, normals, offsets, ids, k, tol, np.empty((12, 3)))
    want = planes_position_reference(q, a, b, normals, offsets, ids, tol)
    np.testing.assert_allclose(got[:4], want[:4], rtol=1e-8, atol=1e-9)
    assert got[4] == want[4]
    near_parallel = k - 1 if k >= 2 and seed % 3 == 0 else -1
    meet = [r for r in range(min(k, 3)) if r != near_parallel]  # each adds a direction
    np.testing.assert_allclose(normals[meet] @ got[1:4], offsets[meet], atol=1e-9)
    if got[4]:  # the others pass within tol
        assert np.all(np.abs(normals[:k] @ got[1:4] - offsets[:k]) <= tol)


def _bracket_by_plane():
    """The L-bracket tessellated finer, each triangle labelled by its plane, and the
    planes (`flat_planes`)."""
    return _by_plane(*C.subdivide(*C.subdivide(*C.l_bracket())))


def _prism_by_plane(sections: int = 24):
    """A cylinder tessellated as a prism (`trimesh.creation.cylinder`: each side a
    quad of two triangles, the caps fans), each triangle labelled by its plane, and
    the planes: every side is a flat region of its own."""
    import trimesh

    m = trimesh.creation.cylinder(radius=1.0, height=1.0, sections=sections)
    return _by_plane(np.asarray(m.vertices, dtype=float), np.asarray(m.faces, dtype=np.int64))


def _by_plane(v, t):
    from pointatlas.simplify._place import flat_planes

    n = np.cross(v[t[:, 1]] - v[t[:, 0]], v[t[:, 2]] - v[t[:, 0]])
    n /= np.linalg.norm(n, axis=1)[:, None]
    key = np.column_stack([n, np.einsum("ij,ij->i", n, v[t[:, 0]])]).round(9)
    labels = np.unique(key, axis=0, return_inverse=True)[1].reshape(-1)
    return v, t, labels, flat_planes(v, t, labels, int(labels.max()) + 1, 1e-9)


@pytest.mark.parametrize("shape", ["bracket", "prism"])
def test_collapse_loop_on_planes_agrees_with_the_python_reference(shape):
    from .reference import decimate_reference

    v, t, labels, planes = _bracket_by_plane() if shape == "bracket" else _prism_by_plane()
    for target in (len(t) // 3, 24):
        got = decimate(v, t, target, labels=labels, planes=planes)
        want = decimate_reference(v, t, target, labels=labels, planes=planes)
        for g, w in zip(got, want, strict=True):
            np.testing.assert_array_equal(g, w)


def test_held_planes_let_a_tessellated_cylinder_lose_sides():
    """A 24-sided prism, each side a flat region of two triangles: a vertex on a side
    and its neighbours' planes and a cap's is held at a point, so with every side's
    plane held no rim edge could collapse (92 triangles at least: the sides and two
    fans of 22). A side left with one triangle is planar wherever its vertices go and
    holds nothing: the prism loses sides, and every level's faces of two or more
    triangles stay on their planes (rounding only)."""
    from pointatlas.simplify._decimate import collapse_all

    v, t, labels, planes = _prism_by_plane()
    normals, offsets, _ = planes
    seq = collapse_all(v, t, labels=labels, planes=planes)
    assert seq.n_triangles(seq.kept.size) < 92 - 8
    for m in range(seq.kept.size + 1):
        out_v, out_t, kept, _ = seq.mesh(m)
        lab = labels[kept]
        held = np.bincount(lab, minlength=offsets.size)[lab] >= 2
        at = out_v[out_t[held]]
        lab3 = np.repeat(lab[held], 3)
        off = np.einsum("ij,ij->i", at.reshape(-1, 3), normals[lab3]) - offsets[lab3]
        assert np.abs(off).max(initial=0.0) <= 1e-12


def test_every_collapse_keeps_its_vertex_on_the_planes_of_its_flat_regions():
    """With the planes held, every vertex of every level lies on the planes of the
    flat regions of its triangles (rounding only), down to the last collapse; with
    the quadrics alone (``hold=False``) some leave them."""
    from pointatlas.simplify._decimate import collapse_all

    v, t, labels, planes = _bracket_by_plane()
    normals, offsets, _ = planes
    for hold, worst in ((True, 1e-12), (False, None)):
        seq = collapse_all(v, t, labels=labels, planes=planes, hold=hold)
        off = 0.0
        for m in np.linspace(0, seq.kept.size, 12).astype(int):
            out_v, out_t, kept, _ = seq.mesh(m)
            lab = np.repeat(labels[kept], 3)
            at = out_v[out_t.reshape(-1)]
            off = max(off, np.abs(np.einsum("ij,ij->i", at, normals[lab]) - offsets[lab]).max())
        assert off <= worst if hold else off > 1e-6
    assert seq.n_triangles(seq.kept.size) == 24 or hold is False


COLLECTION = Path(__file__).resolve().parents[2] / ".." / "shared" / "data" / "collection"


@pytest.mark.parametrize(
    "name",
    [
        "prusai3_spool-holder.stl",
        "prusai3_heatbed-cable-cover.stl",
        "prusamini_mini-fsenzor-cover.stl",
        "voron0_minisb_adxl_mount_generic_15_5mm.stl",
    ],
)
def test_flat_faces_of_cad_parts_are_exactly_planar_at_the_default_level(name):
    """CAD parts whose flat faces came out bent by up to 0.6 % of the diagonal (the
    collapses' vertices off their planes, farther than the placement moves them):
    every face of a flat region is planar within 1e-6 of the diagonal, measured
    here on the face's vertices (numpy's SVD), and the report says the same."""
    from pointatlas.io import read_mesh

    path = COLLECTION / name
    if not path.exists():
        pytest.skip(f"{name} not under ../shared")
    m = read_mesh(path)
    res = decimate_mesh(m.vertices, m.triangles)
    diag = float(np.linalg.norm(np.ptp(np.asarray(m.vertices), axis=0)))
    v, t = np.asarray(res.vertices), np.asarray(res.triangles)
    assert res.face_flat.sum() >= 30
    for f in np.flatnonzero(res.face_flat):
        p = v[np.unique(t[res.triangle_face == f])]
        c = p - p.mean(axis=0)
        bend = np.abs(c @ np.linalg.svd(c)[2][-1]).max()
        assert bend <= 1e-6 * diag
        assert res.planarity_error[f] == pytest.approx(bend, rel=1e-6, abs=1e-12 * diag)
    assert res.summary()["max_flat_planarity_error"] <= 1e-6 * diag
    assert (res.is_closed, res.is_manifold, res.is_oriented) == (True, True, True)
    assert max(res.distance_max, res.back_distance_max) <= 0.005 * diag * (1 + 1e-9)


def test_the_planes_point_never_goes_far_along_nearly_parallel_quadric_planes():
    """On the plane z = 0, a quadric of two planes nearly parallel along it (a thin
    wall's two sides, 1e-4 apart in slope) is least 10,000 units away; the collapse
    takes the cheapest point within an edge length of the edge's midpoint instead."""
    from pointatlas.simplify._plane_kernels import planes_position

    h = np.array([[1.0, 0.0, 0.0, 0.0], [1.0, 1e-4, 0.0, -1.0]])  # x = 0, x + 1e-4 y = 1
    q = sum(np.outer(r, r) for r in h)
    a, b = np.zeros(3), np.array([0.0, 0.1, 0.0])
    ids = np.zeros(1, dtype=np.int64)
    normals, offsets = np.array([[0.0, 0.0, 1.0]]), np.zeros(1)
    free = np.linalg.solve(q[:2, :2], -q[:2, 3])  # the least point on z = 0
    assert np.linalg.norm(free) > 1e3
    cost, x, y, z, ok = planes_position(q, a, b, normals, offsets, ids, 1, 1e-9, np.empty((12, 3)))
    assert ok and z == 0.0
    assert np.linalg.norm(np.array([x, y, z]) - 0.5 * (a + b)) <= np.linalg.norm(a - b)
