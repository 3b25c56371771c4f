"""Parts thinner than the grid made solid again (`_solid.half_balls`, `solid_retry`)."""

from __future__ import annotations

import numpy as np

from pointatlas.simplify._reconstruct import Reconstruction
from pointatlas.simplify._solid import SOLID_LOST, half_balls, solid_retry
from pointatlas.simplify._voxel_grid import LOST_LINK
from pointatlas.synth import cube


def _reference(f, origin, step, p, n, radius):
    """Every inner node against every point given (plain numpy): the least of
    max(|x - p| - radius, n . (x - p)) over the points within ``radius``."""
    out = f.copy()
    for ijk in np.ndindex(*f.shape):
        if min(ijk) == 0 or any(i == s - 1 for i, s in zip(ijk, f.shape, strict=True)):
            continue
        x = origin + np.array(ijk) * step
        best = np.inf
        for pj, nj in zip(p, n, strict=True):
            d = np.sqrt(((x - pj) ** 2).sum())
            if d < radius:
                best = min(best, max(d - radius, float(((x - pj) * nj).sum())))
        out[ijk] = min(out[ijk], best)
    return out


def test_half_balls_match_the_plain_reference_and_leave_buried_points_out():
    rng = np.random.default_rng(3)
    step, origin = 0.1, np.zeros(3)
    f = np.full((14, 14, 14), 0.5)  # every node outside: a part the grid lost
    p = rng.uniform(0.4, 0.9, size=(6, 3))
    n = rng.normal(size=(6, 3))
    n /= np.linalg.norm(n, axis=1)[:, None]
    radius = 1.25 * step
    got = half_balls(f.copy(), origin, step, p, n, radius)
    want = _reference(f, origin, step, p, n, radius)
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-12)
    assert (got < 0).any()  # behind the points: inside
    assert (got[[0, -1]] == 0.5).all() and (got[:, :, [0, -1]] == 0.5).all()  # the border
    # a point whose front the field already puts inside (a pocket the surface
    # bridged) gives nothing: the same field as without it
    f2 = f.copy()
    f2[:, :, :4] = -0.5
    q = np.array([[0.7, 0.7, 0.2]])
    up = np.array([[0.0, 0.0, -1.0]])  # its front towards z = 0: inside
    assert np.array_equal(half_balls(f2.copy(), origin, step, q, up, radius), f2)


def _surface(vertices, triangles, step=0.1):
    return Reconstruction(
        vertices=vertices, triangles=triangles, step=step, shape=(1, 1, 1), n_trimmed=0
    )


def test_the_solid_surface_is_kept_only_where_it_brings_the_points_near_with_its_topology():
    box = cube(4)  # the unit cube [0, 1]^3, Euler characteristic 2
    v, t = np.asarray(box.vertices) + 0.5, np.asarray(box.faces)
    rng = np.random.default_rng(0)
    side = np.column_stack([np.zeros(200), rng.uniform(0, 1, size=(200, 2))])  # x = 0
    fin = np.column_stack([rng.uniform(0.2, 0.8, 40), np.full(40, 0.5), rng.uniform(1.3, 1.5, 40)])
    q = np.vstack([side, fin])  # a fin standing 0.3-0.5 above the top: lost
    normals = np.tile([0.0, 0.0, 1.0], (q.shape[0], 1))
    first = _surface(v, t)
    step = 0.1
    assert SOLID_LOST * step < 0.3
    taller = v * [1.0, 1.0, 1.4]  # over the fin: the same topology, its points near
    calls = []

    def build(points, point_normals):
        calls.append(points.shape[0])
        return _surface(taller, t)

    assert solid_retry(q, normals, first, build, step, 0.05) is not first
    assert calls == [40]  # only the fin's points are made solid
    # a surface that brings them near but changes the topology (a second box beside):
    # the first is kept
    two = np.vstack([taller, taller + 3.0]), np.vstack([t, t + v.shape[0]])
    assert solid_retry(q, normals, first, lambda *a: _surface(*two), step, 0.05) is first
    # one that leaves them off: the first is kept
    assert solid_retry(q, normals, first, lambda *a: _surface(v * 1.01, t), step, 0.05) is first
    # nothing lost: nothing built
    assert solid_retry(side, normals[:200], first, build, step, 0.05) is first
    # points lost each alone (no other within `LOST_LINK` spacings) and off their
    # neighbours' planes (``off``): stray returns, nothing built; on them (a part the
    # grid lost), built
    lone = np.column_stack([np.linspace(0.1, 0.9, 6), np.full(6, 0.5), np.full(6, 1.4)])
    assert np.diff(lone[:, 0]).min() > LOST_LINK * 0.05
    alone, off = np.vstack([side, lone]), np.arange(206) >= 200
    assert solid_retry(alone, normals[:206], first, build, step, 0.05, off) is first
    assert calls == [40]
    solid_retry(alone, normals[:206], first, build, step, 0.05, np.zeros(206, dtype=bool))
    assert calls == [40, 6]


def test_a_surfaces_distance_index_is_built_once_and_measures_as_point_mesh_distance():
    """`Reconstruction.distance_index`: one `MeshDistanceIndex` per surface (a copy by
    `replace` shares it), and the lost points counted with it are those counted
    without it."""
    from dataclasses import replace

    from pointatlas.neighbors import point_mesh_distance
    from pointatlas.simplify._voxel_grid import lost_points, lost_strays

    box = cube(4)
    v, t = np.asarray(box.vertices) + 0.5, np.asarray(box.faces)
    rec = _surface(v, t)
    index = rec.distance_index()
    assert rec.distance_index() is index and replace(rec, uneven=2.0).distance_index() is index
    rng = np.random.default_rng(5)
    q = rng.uniform(-0.5, 1.5, size=(300, 3))
    np.testing.assert_array_equal(index.distance(q), point_mesh_distance(q, v, t))
    far = 0.3
    assert lost_points(q, v, t, far, index=index) == lost_points(q, v, t, far) > 0
    off = rng.random(300) < 0.3
    np.testing.assert_array_equal(
        lost_strays(q, v, t, 0.15, off, 0.2, index=index), lost_strays(q, v, t, 0.15, off, 0.2)
    )
