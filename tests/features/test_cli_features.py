"""``pointatlas features`` end to end on small synthetic inputs."""

import math

import numpy as np
import pytest
from typer.testing import CliRunner

from pointatlas.cli import app
from pointatlas.features import FEATURE_NAMES, optimal_neighborhood
from pointatlas.io import read_point_set, write_point_set
from pointatlas.synth import cube

runner = CliRunner()


@pytest.fixture(scope="module")
def cube_file(tmp_path_factory):
    m = cube(5)
    path = tmp_path_factory.mktemp("feat") / "cube.ply"
    write_point_set(path, m.points, normals=m.normals)
    return path, m


def test_optimal_search_writes_all_fields(cube_file, tmp_path):
    path, m = cube_file
    out = tmp_path / "out.ply"
    res = runner.invoke(
        app, ["features", str(path), str(out), "--k-range", "6", "10", "--a-grid-deg", "0,30,180"]
    )
    assert res.exit_code == 0, res.output
    assert "optimal (a, b, k)" in res.output
    ps = read_point_set(out)
    for name in (*FEATURE_NAMES, "k", "a", "b", "reason", "dimension_class", "eigenvalue_3"):
        assert name in ps.attributes, name
    want = optimal_neighborhood(
        m.points,
        m.normals,
        a_grid=[0, math.pi / 6, math.pi],
        b_grid=[0, math.pi / 6, math.pi],
        k_range=(6, 10),
    )
    np.testing.assert_array_equal(ps.attributes["k"], want.k)
    np.testing.assert_allclose(ps.attributes["e_dim"], want.e_dim)
    assert set(np.unique(ps.attributes["a"])) <= {0.0, math.pi / 6, math.pi}


def test_equal_weights_fixed_k_and_render(tmp_path):
    pts = np.random.default_rng(0).random((300, 3)) * [1, 1, 0.01]
    src = tmp_path / "slab.ply"
    write_point_set(src, pts)
    out = tmp_path / "o.ply"
    pics = tmp_path / "pics"
    pics.mkdir()
    res = runner.invoke(
        app,
        [
            "features",
            str(src),
            str(out),
            "--k",
            "9",
            "--render",
            str(pics / "slab.png"),
            "--render-size",
            "160",
        ],
    )
    assert res.exit_code == 0, res.output
    assert "fixed k = 9" in res.output
    ps = read_point_set(out)
    assert (ps.attributes["k"] == 9).all()
    assert np.nanmean(ps.attributes["planarity"]) > 0.4
    names = sorted(p.name for p in pics.iterdir())
    assert names == ["slab.png", "slab_fig6_5.png", "slab_flatness.png"]


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--weighting", "sigmoid"], "needs normals"),
        (["--k", "8", "--k-range", "6", "9"], "not both"),
        (["--weighting", "odd"], "--weighting must be"),
        (["--a-grid-deg", "0,x"], "comma-separated"),
        (["--flatness", "3", "8"], "even"),
    ],
)
def test_user_errors_are_one_line(tmp_path, args, message):
    src = tmp_path / "p.ply"
    write_point_set(src, np.random.default_rng(1).random((50, 3)))
    res = runner.invoke(app, ["features", str(src), str(tmp_path / "o.ply"), *args])
    assert res.exit_code == 1
    assert message in res.output


def test_las_input_without_normals(tmp_path):
    rng = np.random.default_rng(2)
    pts = rng.random((400, 3)) * [50.0, 50.0, 0.5] + [5e5, 5.2e6, 100.0]  # UTM-like
    src = tmp_path / "scan.las"
    write_point_set(src, pts)
    out = tmp_path / "scan_features.ply"
    res = runner.invoke(app, ["features", str(src), str(out), "--k-range", "8", "16"])
    assert res.exit_code == 0, res.output
    assert "equal weights" in res.output
    ps = read_point_set(out)
    assert np.isfinite(ps.attributes["planarity"]).all()
    assert ((ps.attributes["k"] >= 8) & (ps.attributes["k"] <= 16)).all()
