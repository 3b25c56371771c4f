"""Plain-numpy surface samples with exact outward normals (test inputs only)."""

from __future__ import annotations

import numpy as np


def sphere(n, *, radius=1.0, center=(0.0, 0.0, 0.0)):
    """Fibonacci sample of a sphere; returns points and exact outward normals."""
    i = np.arange(n) + 0.5
    z = 1.0 - 2.0 * i / n
    phi = np.pi * (1.0 + 5.0**0.5) * i
    r = np.sqrt(1.0 - z * z)
    nrm = np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=1)
    return radius * nrm + np.asarray(center, dtype=float), nrm


def torus(n_u, n_v, *, major=1.0, minor=0.35, rng=None, jitter=0.3):
    """Jittered parameter grid on a torus around the z axis; points and outward normals."""
    rng = np.random.default_rng(rng)
    u, v = np.meshgrid(np.arange(n_u), np.arange(n_v), indexing="ij")
    u = (u.ravel() + jitter * rng.uniform(-0.5, 0.5, u.size)) * 2 * np.pi / n_u
    v = (v.ravel() + jitter * rng.uniform(-0.5, 0.5, v.size)) * 2 * np.pi / n_v
    nrm = np.stack([np.cos(v) * np.cos(u), np.cos(v) * np.sin(u), np.sin(v)], axis=1)
    centre = np.stack([major * np.cos(u), major * np.sin(u), np.zeros_like(u)], axis=1)
    return centre + minor * nrm, nrm


def cube(n, *, noise=0.0, rng=None):
    """Regular n x n grid on each face of [-1, 1]^3 (cell centres), optional noise.

    Noise is Gaussian along the face normal with standard deviation ``noise``
    times the grid spacing. Returns points and exact (face) outward normals.
    """
    rng = np.random.default_rng(rng)
    g = (np.arange(n) + 0.5) / n * 2.0 - 1.0
    a, b = np.meshgrid(g, g, indexing="ij")
    a, b = a.ravel(), b.ravel()
    pts, nrms = [], []
    for axis in range(3):
        for sign in (-1.0, 1.0):
            p = np.empty((a.size, 3))
            others = [c for c in range(3) if c != axis]
            p[:, axis] = sign
            p[:, others[0]] = a
            p[:, others[1]] = b
            nn = np.zeros((a.size, 3))
            nn[:, axis] = sign
            pts.append(p)
            nrms.append(nn)
    pts = np.concatenate(pts)
    nrms = np.concatenate(nrms)
    pts = pts + nrms * rng.normal(scale=noise * 2.0 / n, size=(pts.shape[0], 1))
    return pts, nrms


def cylinder(n_theta, n_z, *, radius=1.0, height=2.0):
    """Open cylinder around the z axis (grid); points and outward normals."""
    t, z = np.meshgrid(
        np.arange(n_theta) * 2 * np.pi / n_theta, np.linspace(0, height, n_z), indexing="ij"
    )
    nrm = np.stack([np.cos(t.ravel()), np.sin(t.ravel()), np.zeros(t.size)], axis=1)
    pts = radius * nrm + np.stack([np.zeros(t.size), np.zeros(t.size), z.ravel()], axis=1)
    return pts, nrm


def random_flips(normals, rng=None):
    """Multiply each normal by a random sign."""
    rng = np.random.default_rng(rng)
    return normals * np.where(rng.random(normals.shape[0]) < 0.5, -1.0, 1.0)[:, None]
