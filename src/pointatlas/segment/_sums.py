"""Per-region sums W = sum w_j, S = sum w_j n_j and what follows from them:
proxy normals and L21 energies (thesis Eqs. 4.4-4.5). Private; inputs validated."""

from __future__ import annotations

import hashlib

import numpy as np

from .._core.tolerances import NORMAL_ZERO_LENGTH
from ._kernels import canonical_labels


def row_norms(v):
    """Euclidean norms of the rows of an (m, 3) array: ``np.linalg.norm(v, axis=1)``
    bit for bit (the same sum (x^2 + y^2) + z^2), without its overhead."""
    return np.sqrt(v[:, 0] * v[:, 0] + v[:, 1] * v[:, 1] + v[:, 2] * v[:, 2])


def region_sums(labels, m, w, wn):
    """Per-region W = sum w_j, S = sum w_j n_j and point counts."""
    wsum = np.bincount(labels, weights=w, minlength=m)
    ssum = np.empty((m, 3))
    for d in range(3):
        ssum[:, d] = np.bincount(labels, weights=wn[:, d], minlength=m)
    counts = np.bincount(labels, minlength=m).astype(np.int64)
    return wsum, ssum, counts


def proxy_normals(labels, wsum, ssum, counts, normals):
    """Optimal unit proxy normals; degenerate regions (|S| ~ 0) take a member's normal.

    With |S| = 0 every unit N gives the same energy 2 W, so the normal of the
    region's smallest-index point is as good as any and keeps results
    deterministic. Empty regions get (0, 0, 1); no point refers to them.
    """
    m = wsum.shape[0]
    length = row_norms(ssum)
    bad = length <= NORMAL_ZERO_LENGTH * np.maximum(wsum, 1.0)
    prox = np.zeros_like(ssum)
    prox[:, 2] = 1.0
    ok = ~bad & (counts > 0)
    prox[ok] = ssum[ok] / length[ok, None]
    fix = bad & (counts > 0)
    if fix.any():
        first = np.full(m, labels.shape[0], dtype=np.int64)
        np.minimum.at(first, labels, np.arange(labels.shape[0]))
        prox[fix] = normals[first[fix]]
    return np.ascontiguousarray(prox)


def region_costs(wsum, ssum):
    """L21 of every region at its optimal normal: 2 (W_i - |S_i|)."""
    return 2.0 * (wsum - row_norms(ssum))


def energy_opt(wsum, ssum):
    """Total L21 at optimal normals: sum 2 (W_i - |S_i|)."""
    return float(np.maximum(region_costs(wsum, ssum), 0.0).sum())


def energy_fixed(wsum, ssum, prox):
    """Total L21 with given proxy normals: sum 2 (W_i - S_i . N_i)."""
    return float(np.maximum(2.0 * (wsum - np.einsum("ij,ij->i", ssum, prox)), 0.0).sum())


def over_threshold(wsum, ssum, eta, min_cos):
    """Regions to split: L21 > eta, or (``eta`` None) mean cosine |S|/W < min_cos."""
    length = row_norms(ssum)
    if eta is not None:
        return 2.0 * (wsum - length) > eta
    return length < min_cos * wsum


def labels_key(labels):
    """Digest of a labelling up to renumbering (cycle detection).

    The canonical labels go to the hash as int32 when they fit (half the bytes);
    only equality of digests is used.
    """
    canon, m = canonical_labels(labels)
    if m <= np.iinfo(np.int32).max:
        canon = canon.astype(np.int32)
    return hashlib.sha256(canon.tobytes()).digest()
