"""The placement's last step: faces of flat regions whose vertices sit on planes that
do not quite meet (`_place.settle_planes`)."""

import numpy as np

from pointatlas.simplify._place import plane_fits, settle_planes

from .reference import plane_fits_reference


def _four_quads(delta):
    """A 3 x 3 grid of vertices in four quads (two triangles each) around the centre,
    each quad's region plane z = delta[k]: a corner at its own quad's height, an edge
    midpoint between its two quads', the centre at the mean of all four (where the
    placement's least squares leaves a vertex on four parallel planes)."""
    at = {(x, y): (y + 1) * 3 + (x + 1) for y in (-1, 0, 1) for x in (-1, 0, 1)}
    quads = [
        ((0, 0), (1, 0), (1, 1), (0, 1)),
        ((0, 0), (0, 1), (-1, 1), (-1, 0)),
        ((0, 0), (-1, 0), (-1, -1), (0, -1)),
        ((0, 0), (0, -1), (1, -1), (1, 0)),
    ]
    tri, face = [], []
    for k, q in enumerate(quads):
        a, b, c, d = (at[p] for p in q)
        tri += [(a, b, c), (a, c, d)]
        face += [k, k]
    z = np.zeros(9)
    for k, q in enumerate(quads):
        z[at[q[2]]] = delta[k]
        z[at[q[3]]] = 0.5 * (delta[k] + delta[(k + 1) % 4])
    z[at[(0, 0)]] = np.mean(delta)
    v = np.column_stack([[p[0] for p in at], [p[1] for p in at], z]).astype(float)
    return v, np.array(tri), np.array(face)


def test_bent_faces_on_planes_that_do_not_meet_are_made_planar():
    """Four faces each bent by 4.4e-6 (their centre vertex on four planes that do not
    meet) come out planar within the tolerance, each vertex moved by about the
    faces' bend (well within the bound)."""
    delta = np.array([1e-5, -2e-5, 3e-5, -1e-5])
    v, t, face = _four_quads(delta)
    normals, offsets = np.tile([0.0, 0.0, 1.0], (4, 1)), delta.copy()
    before = plane_fits(v, t, face, 4)[2]
    assert before.min() > 4e-6
    y = settle_planes(v, t, face, normals, offsets, np.ones(4, dtype=bool), 1e-9, 1e-3)
    assert plane_fits(y, t, face, 4)[2].max() <= 1e-9
    assert 0.0 < np.abs(y - v).max() <= 1e-4


def test_planar_faces_and_faces_that_cannot_settle_are_left_as_they_are():
    """Faces already on their planes keep their vertices bit for bit; a bound smaller
    than the moves needed, or faces not flat, leave them where they were."""
    v, t, face = _four_quads(np.zeros(4))
    normals, offsets = np.tile([0.0, 0.0, 1.0], (4, 1)), np.zeros(4)
    flat = np.ones(4, dtype=bool)
    np.testing.assert_array_equal(settle_planes(v, t, face, normals, offsets, flat, 1e-9, 1.0), v)
    delta = np.array([1e-5, -2e-5, 3e-5, -1e-5])
    v, t, face = _four_quads(delta)
    for bound, flags in ((1e-7, flat), (1e-3, np.zeros(4, dtype=bool))):
        y = settle_planes(v, t, face, normals, delta, flags, 1e-9, bound)
        np.testing.assert_array_equal(y, v)


def test_plane_fits_agree_with_a_region_by_region_svd():
    """`plane_fits` (a kernel) against numpy's SVD one region at a time on random
    regions of up to 40 vertices and one on a line: the same planes (normals up to
    sign), offsets and deviations to rounding, the same spanned flags (on the line,
    rounding decides: no plane, or one through it)."""
    rng = np.random.default_rng(5)
    v = rng.normal(size=(300, 3)) * [1.0, 2.0, 0.01]
    v[:4] = [[0, 0, 0], [1, 1, 1], [2, 2, 2], [3, 3, 3]]  # region 0: on a line
    t = np.vstack([[0, 1, 2], [1, 2, 3], rng.integers(4, 300, size=(200, 3))])
    labels = np.r_[0, 0, rng.integers(1, 40, size=200)]
    got = plane_fits(v, t, labels, 42)
    want = plane_fits_reference(v, t, labels, 42)
    sign = np.where(np.einsum("ij,ij->i", got[0], want[0]) < 0.0, -1.0, 1.0)
    np.testing.assert_allclose(got[0] * sign[:, None], want[0], atol=1e-12)
    np.testing.assert_allclose(got[1] * sign, want[1], atol=1e-12)
    np.testing.assert_allclose(got[2], want[2], atol=1e-12)
    assert np.array_equal(got[3][1:], want[3][1:])
    assert not got[3][0] or got[2][0] <= 1e-12  # on a line: no plane, or any through it
    assert np.array_equal(got[3][40:], [False, False])  # no vertex: no plane
