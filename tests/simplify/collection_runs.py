"""`simplify_points` on sampled collection models, with a step of it and without."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np

COLLECTION = Path(__file__).resolve().parents[2] / ".." / "shared" / "data" / "collection"


def sampled(path: Path):
    """20,000 points with their face normals sampled on the mesh at ``path`` (seed 0,
    as `benchmarks/bench_simplify_points.py` samples it)."""
    from pointatlas.io import read_mesh
    from pointatlas.synth import sample_mesh

    mesh = read_mesh(path)
    v, t = np.asarray(mesh.vertices), np.asarray(mesh.triangles, dtype=np.int64)
    s = sample_mesh(v, t, 20000, rng=0)
    return np.asarray(s.points), np.asarray(s.normals)


def without_and_with(monkeypatch, module, name: str, stand_in, path: Path):
    """``(plain, stepped)``: the `SurfaceSimplification` of `simplify_points` on the
    points `sampled` at ``path`` with ``module.name`` replaced by ``stand_in``, and
    as it is."""
    from pointatlas.simplify import simplify_points

    p, n = sampled(path)
    out = []
    for step in (False, True):
        if not step:
            monkeypatch.setattr(module, name, stand_in)
        else:
            monkeypatch.undo()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            out.append(simplify_points(p, n).mesh)
    return tuple(out)
