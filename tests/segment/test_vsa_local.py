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
