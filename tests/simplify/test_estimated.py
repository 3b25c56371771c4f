"""`simplify_estimated`: estimated normals estimated again where the output misses the
points, the output nearest to them kept."""

from __future__ import annotations

import numpy as np
import pytest

from pointatlas.simplify import RETRY_K, simplify_estimated
from pointatlas.simplify._estimated import retry_over, two_sided
from pointatlas.synth import sample_mesh

from .cad_shapes import extrude


@pytest.fixture(scope="module")
def box():
    """3,000 points of a 2 x 1 x 1 box with their true normals, and the same normals
    but those of half the top face tilted 60 degrees towards x: a surface that misses
    the points there."""
    v, t = extrude(np.array([[0.0, 0.0], [2.0, 0.0], [2.0, 1.0], [0.0, 1.0]]), height=1.0)
    s = sample_mesh(v, t, 3000, rng=0)
    p, n = np.asarray(s.points), np.asarray(s.normals)
    bad = n.copy()
    tilt = np.radians(60.0)
    bad[(n[:, 2] > 0.9) & (p[:, 0] > 1.0)] = [np.sin(tilt), 0.0, np.cos(tilt)]
    return p, n, bad


def _diag(p) -> float:
    return float(np.linalg.norm(np.ptp(p, axis=0)))


def test_a_far_output_is_estimated_again_and_the_nearest_kept(box):
    p, n, bad = box
    bound = 0.005 * _diag(p)  # the default: the retry past 1 % of the diagonal
    asked, said = [], []

    def estimate(k):
        asked.append(k)
        return n

    out = simplify_estimated(
        p,
        estimate,
        normals=bad,
        on_retry=lambda d, sizes: said.append((d, sizes)),
        path="robust",
    )
    first = out.tried[0]
    assert first[0] == 20 and first[1] > 2.0 * bound  # the first output missed the points
    assert asked == list(RETRY_K) and said == [(first[1], RETRY_K)]
    # both later estimates are the true normals: equally near, the first of them kept
    assert out.tried[1][1] == out.tried[2][1] < first[1]
    assert out.k == RETRY_K[0] and np.array_equal(out.normals, n)
    assert two_sided(out.result) == min(d for _, d in out.tried)
    assert not out.normals.flags.writeable


def test_the_estimates_stop_at_the_first_output_near_enough(box):
    """Asked for 1 % of the diagonal, the tilted normals' output lies past twice it;
    the second estimate (the true normals) comes within that: the third size is not
    asked, and the second estimate's output is kept."""
    p, n, bad = box
    bound = 0.01 * _diag(p)
    asked = []
    out = simplify_estimated(
        p, lambda k: asked.append(k) or n, normals=bad, path="robust", max_error=bound
    )
    assert out.tried[0][1] > 2.0 * bound  # the first output missed the points
    assert asked == [RETRY_K[0]] and [k for k, _ in out.tried] == [20, RETRY_K[0]]
    assert out.tried[1][1] <= 2.0 * bound and out.result.mesh.is_closed
    assert out.k == RETRY_K[0] and np.array_equal(out.normals, n)


def test_a_near_output_is_kept_without_a_second_estimate(box):
    p, n, _ = box
    bound = 0.015 * _diag(p)
    out = simplify_estimated(p, lambda k: n, path="robust", max_error=bound)
    assert out.k == 20 and len(out.tried) == 1 and out.tried[0][1] <= 2.0 * bound
    # the bound of the retry: twice the one asked, at least twice the default one
    assert retry_over(out.result, p, bound) == pytest.approx(2.0 * bound)
    assert retry_over(out.result, p, None) == pytest.approx(0.01 * _diag(p))
    assert retry_over(out.result, p, 1e-9) == pytest.approx(0.01 * _diag(p))


def test_a_triangle_budget_is_not_estimated_again(box):
    p, n, bad = box
    asked = []
    out = simplify_estimated(
        p, lambda k: asked.append(k) or n, normals=bad, path="robust", max_triangles=200
    )
    assert asked == [] and len(out.tried) == 1
    assert out.tried[0][1] > 0.01 * _diag(p)  # far, but the budget sets the distance


def test_a_first_estimate_at_one_of_the_sizes_is_not_estimated_again_there(box):
    """At the default bound (0.5 % of the diagonal) the box's 3,000 points, true
    normals and all, come out past twice it (corners a spacing wide): a first
    estimate at k = 30 is estimated again at 40 only."""
    p, n, _ = box
    asked = []
    out = simplify_estimated(
        p, lambda k: asked.append(k) or n, normal_k=30, normals=n, path="robust"
    )
    assert out.tried[0][1] > 0.01 * _diag(p)
    assert asked == [40] and [k for k, _ in out.tried] == [30, 40]
    assert out.k == 30  # the same normals again: the same output, the first kept


def test_points_with_strays_left_out_are_not_estimated_again(box):
    """Strays a diagonal off are left out (`n_off_surface`); those left in would set
    the distance, so a far output is kept as it is."""
    p, n, bad = box
    rng = np.random.default_rng(0)
    strays = p[:8] + rng.normal(0.0, 1.0, (8, 3)) * _diag(p)
    q = np.vstack([p, strays])
    asked = []
    out = simplify_estimated(
        q,
        lambda k: asked.append(k) or n,
        normals=np.vstack([bad, n[:8]]),
        path="robust",
    )
    assert out.result.n_off_surface > 0 and out.tried[0][1] > 0.01 * _diag(p)
    assert asked == [] and len(out.tried) == 1


def test_an_open_output_is_not_estimated_again():
    """A sheet (an open sample) whose normals lean 60 degrees on half of it: its
    output is far from the points but open, where the outline sets the distance as
    much as the normals, and is kept as it is."""
    rng = np.random.default_rng(1)
    p = np.column_stack([rng.random(4000) * 2.0, rng.random(4000), np.zeros(4000)])
    n = np.tile([0.0, 0.0, 1.0], (4000, 1))
    tilt = np.radians(60.0)
    bad = n.copy()
    bad[p[:, 0] > 1.0] = [np.sin(tilt), 0.0, np.cos(tilt)]
    asked = []
    out = simplify_estimated(p, lambda k: asked.append(k) or n, normals=bad)
    assert not out.result.mesh.is_closed and out.tried[0][1] > 0.01 * _diag(p)
    assert asked == [] and len(out.tried) == 1
