"""Repeated positions (a merged scan's overlap, a mesh's vertices written once per
face) and points on one line, on the points path (`_checks.without_repeats`)."""

from __future__ import annotations

import json

import numpy as np
import pytest
from typer.testing import CliRunner

from pointatlas import PointAtlasError
from pointatlas.cli import app
from pointatlas.simplify import simplify_points, surface_normals
from pointatlas.simplify._checks import distinct_positions
from pointatlas.synth import sample_mesh

from .cad_shapes import l_bracket


def _sampled(n=3000, seed=0):
    v, t = l_bracket()
    s = sample_mesh(v, t, n, rng=seed)
    return np.asarray(s.points), np.asarray(s.normals)


@pytest.mark.parametrize("seed", range(4))
def test_distinct_positions_are_numpys_unique_rows_in_input_order(seed):
    rng = np.random.default_rng(seed)
    p = rng.integers(0, 3, (300, 3)).astype(float)
    p[rng.random(300) < 0.1, 0] *= -1.0  # -0.0 is the position 0.0
    first, inverse = distinct_positions(p)
    _, index, counts = np.unique(p + 0.0, axis=0, return_index=True, return_counts=True)
    assert first.tolist() == sorted(index.tolist())
    assert np.array_equal(p[first][inverse], p)
    assert sorted(np.bincount(inverse).tolist()) == sorted(counts.tolist())


@pytest.mark.parametrize("copies", [2, 6])
def test_repeated_points_give_the_mesh_of_their_distinct_positions(copies):
    p, n = _sampled()
    alone = simplify_points(p, n, path="robust")
    rng = np.random.default_rng(copies)
    extra = rng.choice(p.shape[0], 300, replace=False)
    # every point `copies` times in a row, then 300 of them once more at the end
    q = np.vstack([np.repeat(p, copies, axis=0), p[extra]])
    m = np.vstack([np.repeat(n, copies, axis=0), n[extra]])
    r = simplify_points(q, m, path="robust")
    assert np.array_equal(np.asarray(r.mesh.vertices), np.asarray(alone.mesh.vertices))
    assert np.array_equal(np.asarray(r.mesh.triangles), np.asarray(alone.mesh.triangles))
    assert r.n_repeated == r.n_dropped == q.shape[0] - p.shape[0]
    assert r.point_index.tolist() == (copies * np.arange(p.shape[0])).tolist()
    assert r.summary()["points_repeated"] == r.n_repeated
    assert r.mesh.is_closed and alone.n_repeated == 0


def test_a_repeat_keeps_the_first_usable_normal():
    p, n = _sampled()
    q = np.vstack([p[:1], p])  # the first point twice: its first copy without a normal
    m = np.vstack([np.zeros((1, 3)), n])
    r = simplify_points(q, m, path="robust")
    assert r.n_repeated == 0 and r.n_dropped == 1 and r.point_index[0] == 1


def test_points_on_one_line_are_refused_in_one_line():
    t = np.linspace(0.0, 1.0, 200)[:, None]
    line = np.hstack([t, 2.0 * t, -t]) + np.array([1e3, 0.0, 0.0])
    normals = np.tile([0.0, 0.0, 1.0], (200, 1))
    with pytest.raises(PointAtlasError, match="lie on one line"):
        simplify_points(line, normals)
    with pytest.raises(PointAtlasError, match="the 1 distinct positions given lie on one line"):
        simplify_points(np.zeros((50, 3)), normals[:50])


def test_surface_normals_of_repeats_are_their_positions_normals():
    p, _ = _sampled(1500)
    q = np.repeat(p, 3, axis=0)
    assert np.array_equal(surface_normals(q), np.repeat(surface_normals(p), 3, axis=0))


def test_cli_uses_repeated_points_once_and_says_so(tmp_path):
    p, _ = _sampled(2000)
    path = tmp_path / "merged.xyz"
    np.savetxt(path, np.repeat(p, 10, axis=0))  # raw points, ten copies each
    report = tmp_path / "r.json"
    res = CliRunner().invoke(
        app, ["simplify", str(path), str(tmp_path / "out.obj"), "--report", str(report)]
    )
    assert res.exit_code == 0, res.output
    assert "18,000 points repeat the position of a point before them: used once" in res.output
    info = json.loads(report.read_text())
    assert info["points_repeated"] == 18000 and info["is_closed"]
