"""``pointatlas segment`` and its demo step (``experiment vsa``: tests/experiments)."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from pointatlas.cli import app
from pointatlas.io import read_point_set, write_point_set
from pointatlas.synth import cube

DATA = Path(__file__).resolve().parents[2] / ".." / "shared" / "data"
runner = CliRunner()


@pytest.fixture
def cube_file(tmp_path):
    mesh = cube(4)
    path = tmp_path / "cube.ply"
    write_point_set(path, mesh.vertices, normals=mesh.normals)
    return path


def test_segment_writes_labels_colours_and_tables(cube_file, tmp_path):
    out = tmp_path / "seg.ply"
    png = tmp_path / "seg.png"
    result = runner.invoke(
        app, ["segment", str(cube_file), str(out), "--eta", "10", "--render", str(png)]
    )
    assert result.exit_code == 0, result.output
    ps = read_point_set(out)
    labels = np.asarray(ps.attributes["label"])
    assert labels.shape == (ps.n_points,) and labels.min() == 0
    assert "colors" in ps.attributes
    with (tmp_path / "seg_regions.csv").open() as fh:
        rows = list(csv.DictReader(fh))
    assert len(rows) == labels.max() + 1
    assert sum(int(r["n_points"]) for r in rows) == ps.n_points
    payload = json.loads((tmp_path / "seg_regions.json").read_text())
    assert payload["summary"]["n_regions"] == len(rows)
    assert payload["summary"]["converged"] is True
    assert png.stat().st_size > 0


def test_segment_region_growing_and_options(cube_file, tmp_path):
    out = tmp_path / "rg.ply"
    result = runner.invoke(
        app,
        ["segment", str(cube_file), str(out), "--method", "region-growing"]
        + ["--smoothness-deg", "10", "--min-cluster-size", "5"],
    )
    assert result.exit_code == 0, result.output
    labels = np.asarray(read_point_set(out).attributes["label"])
    assert labels.max() + 1 == 6 and (labels < 0).any()
    out2 = tmp_path / "fixed.ply"
    result = runner.invoke(
        app,
        ["segment", str(cube_file), str(out2), "--seeds", "6", "--no-split", "--no-merge"]
        + ["--switch", "single", "--max-angle-deg", "20"],
    )
    assert result.exit_code == 0, result.output


def test_segment_estimates_normals_when_the_input_has_none(tmp_path):
    mesh = cube(4)
    raw = tmp_path / "raw.xyz"
    write_point_set(raw, mesh.vertices)
    result = runner.invoke(
        app, ["segment", str(raw), str(tmp_path / "o.ply"), "--no-estimate-normals"]
    )
    assert result.exit_code == 1
    assert "--no-estimate-normals" in result.output
    result = runner.invoke(app, ["segment", str(raw), str(tmp_path / "o.ply"), "--eta", "5"])
    assert result.exit_code == 0, result.output
    assert "estimating normals" in result.stderr


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--seeds", "many"], "--seeds"),
        (["--switch", "fast"], "--switch"),
        (["--method", "magic"], "--method"),
        (["--eta", "1", "--max-angle-deg", "5"], "not both"),
    ],
)
def test_segment_bad_options(cube_file, tmp_path, args, message):
    result = runner.invoke(app, ["segment", str(cube_file), str(tmp_path / "o.ply"), *args])
    assert result.exit_code == 1
    assert message in result.output


def test_demo_step_registered():
    from pointatlas.cli._app import DEMO_STEPS
    from pointatlas.cli._cmd_segment import demo_segment

    assert demo_segment in DEMO_STEPS


#: The VSA flags of ``segment`` and ``simplify`` (declared once in cli/_app.py).
VSA_FLAGS = (
    "--k",
    "--eta",
    "--max-angle-deg",
    "--seeds",
    "--split",
    "--merge",
    "--switch",
    "--classic",
    "--weights",
    "--max-iter",
    "--seed",
)


def _flags(command: str) -> dict:
    import typer

    params = typer.main.get_command(app).commands[command].params
    return {opt: p for p in params for opt in p.opts}


def test_segment_and_simplify_share_the_vsa_flags():
    seg, simp = _flags("segment"), _flags("simplify")
    for flag in VSA_FLAGS:
        a, b = seg[flag], simp[flag]
        assert (a.opts, a.secondary_opts, a.default, a.help) == (
            b.opts,
            b.secondary_opts,
            b.default,
            b.help,
        ), flag
    # degree flags end in -deg and have no alias
    for flags in (seg, simp):
        assert "--max-angle" not in flags
        assert all(p.opts == [opt] for opt, p in flags.items() if "deg" in opt)


def test_segment_max_iter_and_classic_reach_vsa(cube_file, tmp_path):
    out = tmp_path / "seg.ply"
    args = ["segment", str(cube_file), str(out), "--seeds", "5", "--classic", "--max-iter", "1"]
    result = runner.invoke(app, args)
    assert result.exit_code == 0, result.output
    summary = json.loads((tmp_path / "seg_regions.json").read_text())["summary"]
    assert summary["n_iter"] == 1


def test_vsa_options_of_the_cli_flags():
    import math

    from pointatlas.cli._app import vsa_options
    from pointatlas.segment import VSAOptions

    flags = {
        "k": 10,
        "eta": None,
        "max_angle_deg": 12.0,
        "seeds": "3,7",
        "split": False,
        "merge": True,
        "switch": "single",
        "classic": False,
        "weights": "area",
        "max_iter": 5,
    }
    opts = vsa_options(**flags)
    assert opts == VSAOptions(
        k=10,
        max_angle=math.radians(12.0),
        seeds=[3, 7],
        split=False,
        switch="single",
        weights="area",
        max_iter=5,
    )
    assert vsa_options(**flags, local=True) == opts.replace(local=True)
    with pytest.raises(ValueError, match=r"^--max-angle-deg must be a finite angle in \[0, 180\]"):
        vsa_options(**{**flags, "max_angle_deg": 200.0})


def test_segment_local_reaches_vsa(tmp_path):
    """``--local`` runs VSA's local mode (docs/decisions/segment.md "Local mode")."""
    from pointatlas.segment import vsa_segment

    from .test_vsa_local import rolling_ground

    pts, nrm = rolling_ground(3_000, seed=1)
    path = tmp_path / "ground.ply"
    write_point_set(path, pts, normals=nrm)
    ps = read_point_set(path)
    labels = {}
    for flag in ([], ["--local"]):
        out = tmp_path / f"seg{len(flag)}.ply"
        result = runner.invoke(app, ["segment", str(path), str(out), *flag])
        assert result.exit_code == 0, result.output
        labels[bool(flag)] = np.asarray(read_point_set(out).attributes["label"])
        # the command's default --min-region-size is k
        ref = vsa_segment(ps.points, ps.normals, local=bool(flag), min_region_size=8)
        assert np.array_equal(labels[bool(flag)], ref.labels)
    assert not np.array_equal(labels[True], labels[False])


def test_segment_joins_regions_below_the_minimum_size(tmp_path):
    """Issue 28 item 6: on a noisy cube at 10 degrees the regions of a few points
    join their best neighbour (default: fewer than k = 8 points); 0 turns it off."""
    from pointatlas.segment import vsa_segment

    from .test_small_regions import noisy_cube_cloud

    points, normals = noisy_cube_cloud()
    path = tmp_path / "noisy.ply"
    write_point_set(path, points, normals=normals)
    ps = read_point_set(path)
    counts = {}
    for size in (None, "0", "20"):
        out = tmp_path / f"seg_{size}.ply"
        flag = [] if size is None else ["--min-region-size", size]
        args = ["segment", str(path), str(out), "--max-angle-deg", "10", *flag]
        result = runner.invoke(app, args)
        assert result.exit_code == 0, result.output
        labels = np.asarray(read_point_set(out).attributes["label"])
        counts[size] = np.bincount(labels)
        summary = json.loads(out.with_name(f"{out.stem}_regions.json").read_text())["summary"]
        assert summary["min_region_size"] == (8 if size is None else int(size))
        ref = vsa_segment(
            ps.points,
            ps.normals,
            max_angle=np.radians(10.0),
            min_region_size=summary["min_region_size"],
        )
        assert np.array_equal(labels, ref.labels)
    assert counts[None].min() >= 8 and counts["20"].min() >= 20
    assert (counts["0"] < 8).sum() > 50


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--min-region-size", "-1"], "--min-region-size must be"),
        (["--method", "region-growing", "--min-region-size", "5"], "applies to --method vsa"),
    ],
)
def test_segment_min_region_size_refused(cube_file, tmp_path, args, message):
    result = runner.invoke(app, ["segment", str(cube_file), str(tmp_path / "o.ply"), *args])
    assert result.exit_code == 1
    assert message in result.output
    assert not (tmp_path / "o.ply").exists()
