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
        [
            "denoise",
            str(files / "noisy_n.ply"),
            str(out),
            "--method",
            method,
            "--n-iter",
            "3",
            "--clean",
            str(files / "clean.obj"),
        ],
    )
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
        app,
        [
            "denoise",
            "synth:cube",
            str(tmp_path / "o.ply"),
            "--n-iter",
            "1",
            "--render",
            str(tmp_path / "o.png"),
        ],
    )
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


def test_cli_gives_the_api_result_with_and_without_planes(files, tmp_path):
    # the command's default is `denoise()`'s: the local denoise, then the planar pieces
    from pointatlas.denoise import denoise

    m = cube(16)  # faces of 225+ points: planar pieces (150 points or more)
    write_point_set(
        tmp_path / "in.ply", add_noise(m.points, m.normals, 0.3, k=6, rng=1), normals=m.normals
    )
    src = read_point_set(tmp_path / "in.ply")
    for flag, planes in ((None, True), ("--no-planes", False)):
        out = tmp_path / f"o_{planes}.ply"
        args = ["denoise", str(tmp_path / "in.ply"), str(out), "--method", "normal-voting"]
        res = runner.invoke(app, args + ([flag] if flag else []))
        assert res.exit_code == 0, res.output
        api = denoise(src.points, src.normals, method="normal-voting", planes=planes)
        assert np.array_equal(read_point_set(out).points, api.points)
        summary = json.loads((tmp_path / f"o_{planes}_denoise.json").read_text())
        assert summary["parameters"]["planes"] is planes
    # the cube's faces are planar pieces: the pieces move points (the two differ)
    a, b = (read_point_set(tmp_path / f"o_{p}.ply").points for p in (True, False))
    assert not np.array_equal(a, b)


def test_planes_with_tiles_is_refused(files, tmp_path):
    res = runner.invoke(
        app,
        [
            "denoise",
            str(files / "noisy_n.ply"),
            str(tmp_path / "t.ply"),
            "--planes",
            "--tile-size",
            "1",
        ],
    )
    assert res.exit_code == 1
    assert "drop --planes or --tile-size" in res.output


def test_xyz_output_holds_the_denoised_points_and_an_input_field_is_still_refused(files):
    """XYZ keeps coordinates and normals: denoise writes its result there and leaves
    its diagnostic fields out with a note; an input field would be lost: refused."""
    ply = files / "out_xyz_reference.ply"
    xyz = files / "out.xyz"
    args = ["--method", "normal-voting", "--n-iter", "2"]
    res = runner.invoke(app, ["denoise", str(files / "noisy.ply"), str(ply), *args])
    assert res.exit_code == 0, res.output
    res = runner.invoke(app, ["denoise", str(files / "noisy.ply"), str(xyz), *args])
    assert res.exit_code == 0, res.output
    assert "fields displacement, feature_class, denoise_k are not written" in res.stderr
    a, b = read_point_set(xyz), read_point_set(ply)
    assert a.n_points == b.n_points == 386 and not a.attributes
    np.testing.assert_allclose(a.points, b.points, rtol=0, atol=1e-12)
    np.testing.assert_allclose(a.normals, b.normals, rtol=0, atol=1e-9)
    assert json.loads((files / "out_denoise.json").read_text())["method"] == "normal-voting"
    refused = files / "tagged.xyz"
    res = runner.invoke(app, ["denoise", str(files / "noisy_n.ply"), str(refused), *args])
    assert res.exit_code == 1 and "tag" in res.stderr and "would be lost" in res.stderr
    assert not refused.exists()
