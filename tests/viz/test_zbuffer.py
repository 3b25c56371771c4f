"""The points' z-buffer kernel against its plain-numpy reference (bit for bit), run
JIT-compiled with the suite and once more with NUMBA_DISABLE_JIT=1 (`tests.jit_off`)."""

from __future__ import annotations

import numpy as np
import pytest

from pointatlas.viz._points import _disc_offsets
from pointatlas.viz._raster import rasterize_triangles
from pointatlas.viz._zbuffer import fill_pinholes, zbuffer
from tests.jit_off import JIT_OFF, run_module_without_jit
from tests.viz.reference import (
    fill_pinholes_reference,
    rasterize_triangles_reference,
    zbuffer_reference,
)


def _splats(seed: int, n: int = 300, width: int = 40, height: int = 30):
    """Points on a small image, some off its edges, repeated depths (ties)."""
    rng = np.random.default_rng(seed)
    ix = rng.integers(-3, width + 3, n)
    iy = rng.integers(-3, height + 3, n)
    depth = np.round(rng.normal(size=n), 1)  # ties between points at a pixel
    radii = rng.uniform(1.0, 3.5, n)
    slopes = (rng.normal(size=n) * 0.3, rng.normal(size=n) * 0.3, float(rng.uniform(1, 9)))
    return ix, iy, depth, width, height, radii, slopes


@pytest.mark.parametrize("seed", range(3))
@pytest.mark.parametrize("mode", ["uniform", "radii", "tilted"])
def test_zbuffer_matches_reference(seed, mode):
    ix, iy, depth, width, height, radii, slopes = _splats(seed)
    if mode == "uniform":
        radii = np.full_like(radii, 2.2)
    if mode != "tilted":
        slopes = None
    offsets = _disc_offsets(float(radii.max()))
    want = zbuffer_reference(ix, iy, depth, width, height, radii, offsets, slopes)
    got = zbuffer(ix, iy, depth, width, height, radii, offsets, slopes)
    np.testing.assert_array_equal(got[0], want[0])
    np.testing.assert_array_equal(got[1], want[1])
    assert (got[0] >= 0).sum() > 100  # most of the image covered, some not
    assert (got[0] < 0).any()


def test_ties_go_to_the_smaller_index_and_the_nearer_wins():
    ix, iy = np.array([5, 5, 5]), np.array([4, 4, 4])
    depth = np.array([1.0, 2.0, 2.0])  # the larger depth is the nearer
    owner, zbuf = zbuffer(ix, iy, depth, 10, 8, np.full(3, 1.0), _disc_offsets(1.0))
    assert owner[4 * 10 + 5] == 1 and zbuf[4 * 10 + 5] == 2.0
    assert (owner >= 0).sum() == 5 and set(owner[owner >= 0]) == {1}


@pytest.mark.parametrize("seed", range(3))
def test_pinholes_match_reference(seed):
    ix, iy, depth, width, height, radii, slopes = _splats(seed, n=120)
    offsets = _disc_offsets(1.2)
    owner, zbuf = zbuffer(ix, iy, depth, width, height, np.full(120, 1.2), offsets, slopes)
    want_o, want_z = owner.copy(), zbuf.copy()
    holes = 0
    for _ in range(3):
        before = want_o.copy()
        fill_pinholes_reference(want_o, want_z, width, height, 0.05)
        fill_pinholes(owner, zbuf, width, height, 0.05)
        np.testing.assert_array_equal(owner, want_o)
        np.testing.assert_array_equal(zbuf, want_z)
        holes += int((before != want_o).sum())
    assert holes > 10  # the passes filled pixels (background ones among them)


@pytest.mark.parametrize("seed", range(3))
def test_triangles_match_reference(seed):
    """Overlapping triangles (pairs sharing an edge, some off the image, repeated
    depths: ties to the smaller owner id) on a 48 x 36 image."""
    rng = np.random.default_rng(seed)
    centre = np.repeat(rng.uniform(-6, 54, (40, 2)), 4, axis=0)
    v = centre + rng.normal(scale=5.0, size=centre.shape)
    z = np.round(rng.normal(size=v.shape[0]), 1)
    quads = np.arange(v.shape[0]).reshape(-1, 4)
    tris = np.concatenate([quads[:, [0, 1, 2]], quads[:, [0, 2, 3]]])
    tris[::7] = tris[::7][:, [0, 0, 1]]  # no area: never drawn
    owner_of_tri = rng.integers(0, 30, tris.shape[0])
    args = (v[:, 0], v[:, 1], z, tris, owner_of_tri, 48, 36)
    want = rasterize_triangles_reference(*args)
    got = rasterize_triangles(*args)
    np.testing.assert_array_equal(got[0], want[0])
    np.testing.assert_array_equal(got[1], want[1])
    assert (got[0] >= 0).sum() > 300 and (got[0] < 0).sum() > 300


@pytest.mark.skipif(JIT_OFF, reason="already running with the JIT off")
def test_kernels_without_jit():
    run_module_without_jit(__file__, select="match_reference or matches_reference or ties_go")
