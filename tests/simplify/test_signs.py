"""Estimated normals turned outward (`simplify/_signs.py`, `outward_normals`): the
patch signal checked against a plain-numpy winding number of the other points,
inward patches turned back on a sphere, a box and a thin plate (the wall 1.4
spacings thick), right normals and open sheets left as they are, the strided path
of large inputs, determinism, errors."""

from __future__ import annotations

import numpy as np
import pytest

from pointatlas.neighbors import query_knn
from pointatlas.simplify import _signs, outward_normals
from pointatlas.simplify._signs import PATCH_SPACINGS, _patches, patch_signals
from pointatlas.simplify._winding import point_areas
from pointatlas.synth import sample_mesh

from .cad_shapes import box, extrude


def _sphere(n: int = 4000):
    rng = np.random.default_rng(0)
    u = rng.normal(size=(n, 3))
    return u / np.linalg.norm(u, axis=1)[:, None]


def _inward(normals, truth) -> int:
    return int((np.einsum("ij,ij->i", normals, truth) < 0.0).sum())


def patch_signals_reference(q, n, lab, members, probe):
    """`patch_signals` in plain numpy: per patch, the area-weighted mean over its
    members of the winding number of every point outside the patch, at ``probe``
    behind the member less at ``probe`` in front (every term exact)."""
    dip = n * point_areas(q)[:, None]
    out = np.full(int(lab.max()) + 1, np.nan)

    def wind(x, rest):
        e = q[rest][None, :, :] - x[:, None, :]
        r = np.linalg.norm(e, axis=2)
        return (np.einsum("ijk,jk->ij", e, dip[rest]) / r**3).sum(axis=1) / (4 * np.pi)

    for c in np.unique(lab[members]):
        rest = lab != c
        mem = members[lab[members] == c]
        diff = wind(q[mem] - probe * n[mem], rest) - wind(q[mem] + probe * n[mem], rest)
        area = np.linalg.norm(dip[mem], axis=1)
        out[c] = float(np.dot(area, diff) / area.sum())
    return out


def test_patch_signals_match_the_plain_numpy_winding_number():
    u = _sphere(1500)
    n = u.copy()
    n[u[:, 2] > 0.9] *= -1.0  # a cap turned in
    idx = np.asarray(query_knn(u, 10)[0])
    lab = _patches(u, n, idx, 0.02 / PATCH_SPACINGS)  # within 0.02 of the planes
    members = np.flatnonzero(np.isin(lab, np.unique(lab)[:40]))
    ref = patch_signals_reference(u, n, lab, members, 0.01)
    # one cell holding every point: every term exact
    asked = np.unique(lab[members])
    exact = patch_signals(u, n, lab, members, 0.01, 100.0)
    np.testing.assert_allclose(exact[asked], ref[asked], atol=1e-9)
    # cells of a tenth of the sphere: the far cells as dipoles (Barill et al.: a
    # few thousandths off)
    fast = patch_signals(u, n, lab, members, 0.01, 0.2)
    np.testing.assert_allclose(fast[asked], ref[asked], atol=5e-3)


def test_a_cap_turned_inward_on_a_sphere_is_turned_back():
    u = _sphere()
    n = u.copy()
    n[u[:, 2] > 0.95] *= -1.0
    assert _inward(n, u) > 50
    assert _inward(outward_normals(u, n), u) == 0


def _box_points(n: int = 6000):
    v, t = box()
    s = sample_mesh(v, t, n, rng=0)
    return np.asarray(s.points), np.asarray(s.normals)


def test_a_patch_beside_an_edge_of_a_box_is_turned_back():
    p, truth = _box_points()
    n = truth.copy()
    c = p.min(axis=0)
    near_corner = np.linalg.norm(p - c, axis=1) < 0.15 * np.ptp(p[:, 0])
    n[near_corner] *= -1.0  # three faces' patches at a corner, turned in
    assert _inward(n, truth) > 30
    assert _inward(outward_normals(p, n), truth) == 0


def _plate():
    """A 1 x 1 plate 0.015 thick, 4,000 points: its sides about 1.4 spacings apart."""
    v, t = extrude([(0, 0), (1, 0), (1, 1), (0, 1)], height=0.015)
    s = sample_mesh(v, t, 4000, rng=0)
    return np.asarray(s.points), np.asarray(s.normals)


def test_a_patch_on_one_side_of_a_thin_plate_is_turned_back():
    p, truth = _plate()
    spacing = float(np.median(query_knn(p, 2)[1][:, 1]))
    assert 1.0 < 0.015 / spacing < 2.0
    n = truth.copy()
    top_patch = (truth[:, 2] > 0.9) & (np.linalg.norm(p[:, :2] - 0.5, axis=1) < 0.08)
    n[top_patch] *= -1.0
    assert _inward(n, truth) > 30
    assert _inward(outward_normals(p, n), truth) == 0


@pytest.mark.parametrize("shape", ["sphere", "box", "plate"])
def test_outward_normals_are_left_as_they_are(shape):
    if shape == "sphere":
        p = _sphere()
        truth = p.copy()
    elif shape == "box":
        p, truth = _box_points()
    else:
        p, truth = _plate()
    np.testing.assert_array_equal(outward_normals(p, truth), truth)


def test_an_open_sheet_keeps_its_normals():
    # a hemisphere: no inside, so no side is asked for, even of a turned patch
    u = _sphere()
    u = u[u[:, 2] > 0.0]
    n = u.copy()
    n[u[:, 2] > 0.95] *= -1.0
    np.testing.assert_array_equal(outward_normals(u, n), n)


def test_large_inputs_are_decided_on_a_stride(monkeypatch):
    u = _sphere(6000)
    n = u.copy()
    n[u[:, 2] > 0.95] *= -1.0
    monkeypatch.setattr(_signs, "MAX_POINTS", 2500)  # a stride of 3
    assert _inward(outward_normals(u, n), u) == 0


def test_deterministic_and_the_table_reused():
    p, truth = _box_points()
    n = truth.copy()
    n[np.linalg.norm(p - p.min(axis=0), axis=1) < 0.15] *= -1.0
    a = outward_normals(p, n)
    b = outward_normals(p, n, neighbors=query_knn(p, 12))
    np.testing.assert_array_equal(a, outward_normals(p, n))
    np.testing.assert_array_equal(a, b)


def test_errors():
    p = _sphere(200)
    with pytest.raises(ValueError, match="normals"):
        outward_normals(p, p[:10])
    bad = p.copy()
    bad[3, 0] = np.nan
    with pytest.raises(ValueError):
        outward_normals(bad, p)
    tiny = p[:5]
    np.testing.assert_array_equal(outward_normals(tiny, -tiny), -tiny)  # too few: as given
