"""Small triangulated surfaces built in code: torus, double torus, Moebius strip."""

from __future__ import annotations

import numpy as np


def torus_faces(n: int = 6, m: int = 5) -> np.ndarray:
    """Triangles of an n x m grid with both directions wrapped (a torus, chi = 0)."""
    idx = np.arange(n * m).reshape(n, m)
    faces = []
    for i in range(n):
        for j in range(m):
            a, b = idx[i, j], idx[(i + 1) % n, j]
            c, d = idx[(i + 1) % n, (j + 1) % m], idx[i, (j + 1) % m]
            faces += [[a, b, c], [a, c, d]]
    return np.asarray(faces, dtype=np.int64)


def double_torus_faces(n: int = 6, m: int = 5) -> np.ndarray:
    """Two tori, each with the quad at grid cell (0, 0) removed, glued along its boundary.

    Torus B's grid is read with its two coordinates swapped, so its square hole runs
    the other way round and the glued surface stays orientable (chi = -2, genus 2).
    """
    t = torus_faces(n, m)
    a = t[2:]  # drop the two triangles of cell (0, 0)
    idx = np.arange(n * m).reshape(n, m)
    # B vertex (i, j) -> A vertex (j, i) on the hole's square, a new vertex elsewhere
    corner = {(0, 0), (1, 0), (1, 1), (0, 1)}
    mapping = np.empty(n * m, dtype=np.int64)
    nxt = n * m
    for i in range(n):
        for j in range(m):
            if (i, j) in corner:
                mapping[idx[i, j]] = idx[j, i]
            else:
                mapping[idx[i, j]] = nxt
                nxt += 1
    b = mapping[t[2:]]
    return np.concatenate([a, b])


def moebius_faces(n: int = 8) -> np.ndarray:
    """A Moebius strip: n squares in a ring of width one, glued with a half twist."""
    top = np.arange(n)
    bottom = np.arange(n, 2 * n)
    faces = []
    for i in range(n):
        a, b = top[i], bottom[i]
        if i + 1 < n:
            c, d = bottom[i + 1], top[i + 1]
        else:  # the half twist: top meets bottom
            c, d = top[0], bottom[0]
        faces += [[a, b, c], [a, c, d]]
    return np.asarray(faces, dtype=np.int64)
