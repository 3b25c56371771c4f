"""``pointatlas denoise`` end to end."""

import json

import numpy as np
import pytest
from typer.testing import CliRunner

from pointatlas.cli import app
from pointatlas.denoise import add_noise
from pointatlas.io import read_point_set, write_mesh, write_point_set
from pointatlas.synth import cube

runner = CliRunner()


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("denoise")
    m = cube(8)
    noisy = add_noise(m.points, m.normals, 0.6, k=6, rng=0)
    write_mesh(tmp / "clean.obj", m.points, m.faces)
    write_point_set(
        tmp / "noisy_n.ply", noisy, normals=m.normals, attributes={"tag": np.arange(386)}
    )
    write_point_set(tmp / "noisy.ply", noisy)
    return tmp


@pytest.mark.parametrize("method", ["normal-voting", "normal-voting-adaptive", "flatness"])
def test_methods_with_clean_measures(files, method):
    out = files / f"out_{method}.ply"
    res = runner.invoke(
        app,
        ["denoise", str(files / "noisy_n.ply"), str(out), "--method", method, "--n-iter", "3",
         "--clean", str(files / "clean.obj")],
    )  # fmt: skip
    assert res.exit_code == 0, res.output
    assert "point-to-mesh mean" in res.output and f"wrote {out}" in res.output
    ps = read_point_set(out)
    assert ps.n_points == 386 and "tag" in ps.attributes and "displacement" in ps.attributes
    summary = json.loads((files / f"out_{method}_denoise.json").read_text())
    before, after = summary["measures_input"], summary["measures_denoised"]
    assert after["p2m_mean"] < before["p2m_mean"]
    assert summary["method"] == method and len(summary["files"]) == 1


def test_points_without_normals_get_them_estimated(files):
    out = files / "est.ply"
    res = runner.invoke(
        app, ["denoise", str(files / "noisy.ply"), str(out), "--method", "normal-voting"]
    )
    assert res.exit_code == 0, res.output
    assert "estimating normals: PCA with k = 20" in res.output
    assert read_point_set(out).normals is not None


def test_auto_and_render_and_bundled_model(tmp_path):
    res = runner.invoke(
        app, ["denoise", "synth:cube", str(tmp_path / "o.ply"), "--n-iter", "1",
              "--render", str(tmp_path / "o.png")],
    )  # fmt: skip
    assert res.exit_code == 0, res.output
    assert "normal-voting" in res.output and (tmp_path / "o.png").stat().st_size > 0
    assert "normal-voting-adaptive" not in res.output  # auto: fixed neighbourhoods


def test_bad_options_fail_before_work(files, tmp_path):
    res = runner.invoke(app, ["denoise", "synth:cube", str(tmp_path / "o.ply"), "--method", "x"])
    assert res.exit_code == 1 and "--method must be one of" in res.output
    res = runner.invoke(app, ["denoise", "synth:cube", str(tmp_path / "o.ply"), "--rho", "3"])
    assert res.exit_code == 1 and "--rho must be a finite number in [-1, 1]" in res.output
    src = files / "noisy_n.ply"
    res = runner.invoke(app, ["denoise", str(src), str(src)])
    assert res.exit_code == 1 and "is the input file" in res.output
