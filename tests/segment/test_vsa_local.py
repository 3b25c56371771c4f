"""VSA's local mode, ``VSAOptions.local`` (docs/decisions/segment.md "Local mode"):
leaving out far points leaves the regions elsewhere unchanged; default off."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pointatlas.segment import VSAOptions, vsa_segment
from pointatlas.segment._kernels import canonical_labels


def rolling_ground(n=12_000, seed=0, amp=1.5, noise=0.05):
    """A 60 x 30 m rolling ground z = amp sin(x/6) cos(y/7) (slopes up to 14 degrees)
    with exact normals tilted by Gaussian noise: smooth, so regions end where the
    threshold says, and the default VSA's regions depend on the whole input."""
    rng = np.random.default_rng(seed)
    xy = rng.uniform(0, [60.0, 30.0], (n, 2))
    z = amp * np.sin(xy[:, 0] / 6) * np.cos(xy[:, 1] / 7)
    gx = amp / 6 * np.cos(xy[:, 0] / 6) * np.cos(xy[:, 1] / 7)
    gy = -amp / 7 * np.sin(xy[:, 0] / 6) * np.sin(xy[:, 1] / 7)
    nrm = np.column_stack([-gx, -gy, np.ones(n)]) + rng.normal(0, noise, (n, 3))
    return np.column_stack([xy, z]), nrm / np.linalg.norm(nrm, axis=1)[:, None]


def near_partition_change(local: bool) -> float:
    """Share of the points with x < 20 whose region (as a partition) changes when
    the 3 points of largest x (40 m away and more) are left out."""
    pts, nrm = rolling_ground()
    keep = np.setdiff1d(np.arange(pts.shape[0]), np.argsort(-pts[:, 0])[:3])
    near = pts[keep, 0] < 20.0
    whole = vsa_segment(pts, nrm, local=local).labels[keep][near]
    part = vsa_segment(pts[keep], nrm[keep], local=local).labels[near]
    return float(np.mean(canonical_labels(whole)[0] != canonical_labels(part)[0]))


def test_local_mode_leaves_far_regions_unchanged():
    assert near_partition_change(local=True) == 0.0
    # the default mode is not local on this scene: a third of the near points
    # change region (measured 28.5 %)
    assert near_partition_change(local=False) > 0.1


@pytest.mark.parametrize("eta", [2.0, 5.0])
def test_local_mode_never_goes_over_eta(eta):
    """No region is ever over the threshold: merges stay within 0.7 eta, the switch
    never pushes a region over eta, so nothing is split, and every final region
    (a connected piece of one that held) has L21 <= eta."""
    pts, nrm = rolling_ground(4_000, seed=1)
    res = vsa_segment(pts, nrm, eta=eta, local=True)
    assert "split" not in res.step_names and res.converged
    assert res.region_l21.max() <= eta * (1 + 1e-9)
    assert np.array_equal(np.bincount(res.labels), res.region_counts)
    assert res.n_regions != vsa_segment(pts, nrm, eta=eta).n_regions  # not the default


def test_local_mode_angle_regions_under_threshold_without_splits():
    pts, nrm = rolling_ground(4_000, seed=2)
    res = vsa_segment(pts, nrm, local=True)
    assert "split" not in res.step_names and res.converged
    # mean deviation of every region <= 10 degrees (connected pieces included here)
    s = np.stack([np.bincount(res.labels, weights=nrm[:, d]) for d in range(3)], 1)
    mean_cos = np.linalg.norm(s, axis=1) / res.region_counts
    assert mean_cos.min() >= math.cos(math.radians(10.0)) - 1e-12


def test_local_is_an_opt_in_field():
    assert VSAOptions().local is False
    assert VSAOptions(local=True) != VSAOptions()
    assert VSAOptions().replace(local=True).local is True
    with pytest.raises(TypeError, match=r"^local must be True or False; got 1$"):
        VSAOptions(local=1)
    pts, nrm = rolling_ground(2_000, seed=3)
    a = vsa_segment(pts, nrm)
    b = vsa_segment(pts, nrm, options=VSAOptions(local=False))
    assert np.array_equal(a.labels, b.labels) and a.energy == b.energy


def veg_ground(n=6_000, n_veg=80, seed=0, extent=(40.0, 30.0)):
    """A gently curved ground z = 0.8 sin(x/15) (1 cm noise) and scattered
    vegetation points 2-6 m above it whose normals are the ground's (all normals
    tilted by 0.03 Gaussian noise): by normals alone the vegetation is ground.
    The last ``n_veg`` points are the vegetation."""
    rng = np.random.default_rng(seed)
    xy = rng.uniform(0, extent, (n + n_veg, 2))
    z = 0.8 * np.sin(xy[:, 0] / 15)
    z[:n] += rng.normal(0, 0.01, n)
    z[n:] += rng.uniform(2.0, 6.0, n_veg)
    nrm = np.column_stack(
        [-0.8 / 15 * np.cos(xy[:, 0] / 15), np.zeros(n + n_veg), np.ones(n + n_veg)]
    )
    nrm += rng.normal(0, 0.03, nrm.shape)
    return np.column_stack([xy, z]), nrm / np.linalg.norm(nrm, axis=1)[:, None]


@pytest.mark.parametrize("seed", [0, 1])
def test_local_mode_vegetation_leaves_the_ground(seed):
    """Points off their region's local surface leave it: the vegetation, which the
    default run puts in the ground region, is in it in the local run at no point,
    and the ground is one region of every ground point."""
    n = 6_000
    pts, nrm = veg_ground(n=n, seed=seed)
    default = vsa_segment(pts, nrm)
    ground = np.argmax(np.bincount(default.labels))
    assert np.all(default.labels[n:] == ground)
    res = vsa_segment(pts, nrm, local=True)
    ground = np.argmax(np.bincount(res.labels))
    assert np.all(res.labels[:n] == ground) and not np.any(res.labels[n:] == ground)
    assert "off_surface" in res.step_names and res.mse < 0.5 * default.mse
    # every region under the threshold, numbered and counted as usual
    s = np.stack([np.bincount(res.labels, weights=nrm[:, d]) for d in range(3)], 1)
    min_cos = math.cos(math.radians(10.0))
    assert (np.linalg.norm(s, axis=1) / res.region_counts).min() >= min_cos - 1e-12
    assert np.array_equal(np.bincount(res.labels), res.region_counts)


def off_surface_reference(indptr, indices, points, labels, prox, limit):
    """Plain-Python `off_surface_moves`: per point the median |N (p - q)| over its
    neighbours q in its region; leavers go to the neighbouring region of least
    such median within the limit (ties: smaller id), else -1."""
    moved, target = [], []
    for p in range(labels.shape[0]):
        nb = indices[indptr[p] : indptr[p + 1]]
        by_region = {}
        for q in nb.tolist():
            r = int(labels[q])
            by_region.setdefault(r, []).append(abs(float(prox[r] @ (points[p] - points[q]))))
        own = by_region.pop(int(labels[p]), None)
        if own is None or np.median(own) <= limit:
            continue
        fits = sorted((np.median(v), r) for r, v in by_region.items() if np.median(v) <= limit)
        moved.append(p)
        target.append(fits[0][1] if fits else -1)
    return np.array(moved, dtype=np.int64), np.array(target, dtype=np.int64)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_off_surface_moves_matches_reference(seed):
    from pointatlas.segment._graph import neighbor_graph
    from pointatlas.segment._vsa_run import off_surface_moves

    rng = np.random.default_rng(seed)
    pts = rng.uniform(0, 4, (400, 3)) * [1.0, 1.0, 0.5]
    pts = np.round(pts, 1)  # many tied offsets
    indptr, indices, _ = neighbor_graph(pts, 8)
    labels = rng.integers(0, 6, 400)
    prox = rng.normal(size=(6, 3))
    prox /= np.linalg.norm(prox, axis=1)[:, None]
    targets = []
    for limit in (0.05, 0.1, 0.3, 0.6):
        got = off_surface_moves(indptr, indices, pts, labels, prox, limit)
        ref = off_surface_reference(indptr, indices, pts, labels, prox, limit)
        assert np.array_equal(got[0], ref[0]) and np.array_equal(got[1], ref[1])
        targets.append(got[1])
    targets = np.concatenate(targets)  # both outcomes occur
    assert (targets >= 0).sum() > 5 and (targets < 0).sum() > 5
