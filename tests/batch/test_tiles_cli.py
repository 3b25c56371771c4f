"""``--tile-size`` on normals, features, segment and denoise: LAS/LAZ streamed, every
dimension and the header kept, results equal to the untiled command's."""

from __future__ import annotations

import json

import numpy as np
import pytest
from typer.testing import CliRunner

distributed = pytest.importorskip("distributed")
laspy = pytest.importorskip("laspy")

from pointatlas.cli import app  # noqa: E402

from .test_tiles import scan  # noqa: E402

runner = CliRunner()


def run(*args):
    return runner.invoke(app, [str(a) for a in args])


def assert_user_error(result, *fragments):
    assert result.exit_code == 1, result.output
    text = result.stderr.strip()
    assert len(text.splitlines()) == 1, text
    assert "Traceback" not in result.output
    for fragment in fragments:
        assert fragment in text, text


@pytest.fixture(scope="module")
def laz(tmp_path_factory):
    """A LAZ 1.4 file (point format 6) with intensity, classification, GPS time, an
    extra-bytes dimension and a VLR, millimetre scales, UTM-like offsets."""
    pts = scan(12_000, seed=3)
    n = pts.shape[0]
    rng = np.random.default_rng(1)
    header = laspy.LasHeader(point_format=6, version="1.4")
    header.scales = np.array([0.001, 0.001, 0.001])
    header.offsets = np.array([512_000.0, 4_100_000.0, 0.0])
    header.add_extra_dims([laspy.ExtraBytesParams(name="reflectance", type=np.float32)])
    header.vlrs.append(
        laspy.VLR(user_id="pointatlas", record_id=7, description="test", record_data=b"xyz")
    )
    las = laspy.LasData(header)
    las.x, las.y, las.z = pts[:, 0], pts[:, 1], pts[:, 2]
    las.intensity = rng.integers(0, 65535, n).astype(np.uint16)
    las.classification = rng.integers(0, 20, n).astype(np.uint8)
    las.return_number = rng.integers(1, 4, n).astype(np.uint8)
    las.number_of_returns = np.full(n, 3, np.uint8)
    las.gps_time = rng.uniform(0, 1e5, n)
    las.reflectance = rng.uniform(0, 1, n).astype(np.float32)
    path = tmp_path_factory.mktemp("tiles") / "scan.laz"
    las.write(path)
    return path


def _kept(src_path, out_path):
    src, out = laspy.read(src_path), laspy.read(out_path)
    assert out.header.version == src.header.version
    assert out.header.point_format.id == src.header.point_format.id
    assert np.array_equal(out.header.scales, src.header.scales)
    assert np.array_equal(out.header.offsets, src.header.offsets)
    assert any(v.user_id == "pointatlas" and v.record_data == b"xyz" for v in out.header.vlrs)
    for name in src.point_format.dimension_names:
        assert np.array_equal(np.asarray(out[name]), np.asarray(src[name])), name
    return out


def test_tiled_features_on_laz_keep_every_dimension_and_equal_untiled(tmp_path, laz, scheduler):
    tiled, plain = tmp_path / "tiled.laz", tmp_path / "plain.laz"
    result = run(
        "features",
        laz,
        tiled,
        "--k",
        16,
        "--weighting",
        "equal",
        "--tile-size",
        10,
        "--scheduler",
        scheduler,
    )
    assert result.exit_code == 0, result.output
    assert "tiles of 10" in result.stdout and f"wrote {tiled}" in result.stdout
    assert run("features", laz, plain, "--k", 16, "--weighting", "equal").exit_code == 0
    out = _kept(laz, tiled)
    ref = laspy.read(plain)
    ours = [d for d in ref.point_format.extra_dimension_names if d != "reflectance"]
    assert "planarity" in ours and "dimension_class" in ours
    for name in ours:
        assert np.array_equal(np.asarray(out[name]), np.asarray(ref[name]), equal_nan=True), name


def test_tiled_normals_on_laz_equal_untiled(tmp_path, laz, scheduler):
    tiled, plain = tmp_path / "tiled.laz", tmp_path / "plain.laz"
    args = ("--k", 12, "--orient", "none")
    result = run("normals", laz, tiled, *args, "--tile-size", 7.5, "--scheduler", scheduler)
    assert result.exit_code == 0, result.output
    assert run("normals", laz, plain, *args).exit_code == 0
    out, ref = _kept(laz, tiled), laspy.read(plain)
    for c in ("nx", "ny", "nz"):
        assert np.array_equal(np.asarray(out[c]), np.asarray(ref[c]))


def test_tiled_segment_on_laz_writes_labels_and_tables(tmp_path, laz, scheduler):
    out_path = tmp_path / "seg.laz"
    result = run("segment", laz, out_path, "--tile-size", 12, "--scheduler", scheduler)
    assert result.exit_code == 0, result.output
    out = _kept(laz, out_path)
    labels = np.asarray(out["label"])
    payload = json.loads((tmp_path / "seg_regions.json").read_text())
    n_regions = payload["summary"]["quality"]["n_regions"]
    assert labels.min() == 0 and labels.max() == n_regions - 1
    assert [r["n_points"] for r in payload["regions"]] == np.bincount(labels).tolist()
    assert (tmp_path / "seg_regions.csv").read_text().startswith("region,n_points,l21")
    # normals were estimated by tiles (the input has none) and written
    assert {"nx", "ny", "nz"} <= set(out.point_format.extra_dimension_names)


def test_tiled_segment_local_reaches_the_tiles(tmp_path, laz, scheduler):
    """``segment --local --tile-size``: the tiles run VSA's local mode, the run of
    `pointatlas.batch.tiled_segment` with ``local`` on the same points and normals
    (docs/decisions/segment.md "Local mode")."""
    from pointatlas.batch import TileOptions, tiled_segment

    labels = {}
    for flag in ([], ["--local"]):
        out = tmp_path / f"seg{len(flag)}.laz"
        result = run("segment", laz, out, *flag, "--tile-size", 12, "--scheduler", scheduler)
        assert result.exit_code == 0, result.output
        las = laspy.read(out)
        labels[bool(flag)] = np.asarray(las["label"])
    pts = np.column_stack([np.asarray(las.x), np.asarray(las.y), np.asarray(las.z)])
    nrm = np.column_stack([np.asarray(las[c], dtype=np.float64) for c in ("nx", "ny", "nz")])
    with distributed.Client(scheduler) as client:
        # the command's default --min-region-size is k
        ref, _, _ = tiled_segment(
            pts,
            nrm,
            TileOptions(tile_size=12, scheduler=client),
            {"k": 8, "local": True, "min_region_size": 8},
        )
    assert np.array_equal(labels[True], ref)
    assert not np.array_equal(labels[True], labels[False])


def test_tiled_flatness_denoise_on_laz_matches_untiled(tmp_path, laz, scheduler):
    tiled, plain = tmp_path / "tiled.laz", tmp_path / "plain.laz"
    args = ("--method", "flatness", "--n-iter", 2, "--k", 14)
    result = run("denoise", laz, tiled, *args, "--tile-size", 15, "--scheduler", scheduler)
    assert result.exit_code == 0, result.output
    assert run("denoise", laz, plain, *args).exit_code == 0
    a, b = laspy.read(tiled), laspy.read(plain)
    src = laspy.read(laz)
    for name in ("intensity", "classification", "gps_time", "reflectance"):
        assert np.array_equal(np.asarray(a[name]), np.asarray(src[name])), name
    # moved points, quantised with the input's scales: the untiled ones to a millimetre
    for c in ("X", "Y", "Z"):
        assert np.abs(np.asarray(a[c]) - np.asarray(b[c])).max() <= 1
    summary = json.loads((tmp_path / "tiled_denoise.json").read_text())
    assert summary["tiles"]["tiles"] > 1


def test_tiled_ply_in_and_out(tmp_path, scheduler):
    from pointatlas.features import covariance_features
    from pointatlas.io import read_point_set, write_point_set

    pts = scan(6_000, seed=5)
    src = tmp_path / "in.ply"
    write_point_set(src, pts, attributes={"intensity": np.arange(6_000, dtype=np.int32)})
    out = tmp_path / "out.ply"
    result = run(
        "features",
        src,
        out,
        "--k",
        14,
        "--weighting",
        "equal",
        "--tile-size",
        9,
        "--scheduler",
        scheduler,
    )
    assert result.exit_code == 0, result.output
    got = read_point_set(out, with_normals=False)
    assert np.array_equal(got.attributes["intensity"], np.arange(6_000))
    ref = covariance_features(got.points, 14)
    assert np.array_equal(got.attributes["planarity"], ref.planarity, equal_nan=True)


@pytest.mark.parametrize(
    ("args", "fragments"),
    [
        (("normals", "--tile-size", 0), ["--tile-size must be > 0"]),
        (("normals", "--tile-size", -2), ["--tile-size must be > 0"]),
        (("features", "--halo", 2.0), ["--halo only apply with --tile-size"]),
        (
            ("normals", "--tile-size", 10, "--halo", 0.001, "--orient", "none"),
            ["--halo 0.001 is too small for k = 20", "or leave --halo out"],
        ),
        (("normals", "--tile-size", 10, "--orient", "outward"), ["needs the whole surface"]),
        (("segment", "--tile-size", 10, "--method", "region-growing"), ["only vsa is stitched"]),
        (("features", "--tile-size", 10, "--render", "r.png"), ["--render needs every point"]),
        (
            ("denoise", "--tile-size", 10, "--halo", 0.01, "--method", "flatness"),
            ["smaller than the reach of 60 denoising iterations"],
        ),
        (
            ("denoise", "--tile-size", 10, "--method", "normal-voting"),
            ["--method normal-voting with --tile-size needs --n-iter"],
        ),
        (
            ("normals", "--tile-size", 10, "--max-memory", "12KB", "--orient", "none"),
            ["over --max-memory; use a smaller --tile-size"],
        ),
    ],
)
def test_bad_tile_options_are_one_line_errors(tmp_path, laz, scheduler, args, fragments):
    cmd, *rest = args
    result = run(cmd, laz, tmp_path / "out.laz", *rest, "--scheduler", scheduler)
    if "--halo" in rest and "--tile-size" not in rest:
        result = run(cmd, laz, tmp_path / "out.laz", *rest)
    assert_user_error(result, *fragments)
    assert not (tmp_path / "out.laz").exists()


def test_unreachable_scheduler_is_one_line_error(tmp_path, laz, monkeypatch):
    from pointatlas.batch import _tiles

    monkeypatch.setattr(_tiles, "CONNECT_TIMEOUT_S", 1)
    result = run(
        "normals", laz, tmp_path / "o.laz", "--tile-size", 10, "--scheduler", "tcp://127.0.0.1:9"
    )
    assert_user_error(result, "--scheduler tcp://127.0.0.1:9: cannot connect within 1 s")


def test_empty_laz_is_a_one_line_error(tmp_path, scheduler):
    # the first pass over the file runs in a thread while the cluster starts: its
    # error still reaches the user as one line, and nothing is written
    empty = tmp_path / "empty.laz"
    laspy.LasData(laspy.LasHeader(point_format=6, version="1.4")).write(empty)
    result = run("features", empty, tmp_path / "o.laz", "--tile-size", 10, "--scheduler", scheduler)
    assert_user_error(result, "no points")
    assert not (tmp_path / "o.laz").exists()
    assert not list(tmp_path.glob(".pointatlas-tiles*"))


def test_bundled_model_name_runs_by_tiles_like_a_file(tmp_path, scheduler):
    from pointatlas.io import read_point_set

    tiled, untiled = tmp_path / "t.ply", tmp_path / "u.ply"
    result = run(
        "normals",
        "fandisk",
        tiled,
        "--k",
        12,
        "--orient",
        "none",
        "--tile-size",
        0.4,
        "--scheduler",
        scheduler,
    )
    assert result.exit_code == 0, result.output
    assert "tiles of 0.4" in result.output
    assert run("normals", "fandisk", untiled, "--k", 12, "--orient", "none").exit_code == 0
    got, ref = read_point_set(tiled), read_point_set(untiled)
    assert np.array_equal(got.points, ref.points)
    assert np.array_equal(got.normals, ref.normals)  # bit for bit, as for a file


def test_render_is_refused_with_the_reason(tmp_path, laz, scheduler):
    result = run(
        "features",
        laz,
        tmp_path / "o.laz",
        "--tile-size",
        10,
        "--render",
        tmp_path / "r.png",
        "--scheduler",
        scheduler,
    )
    assert_user_error(
        result,
        "--render needs every point in one process",
        "a tiled run never holds",
        "leave out --tile-size",
    )


def test_tiled_report_views_every_nth_point_of_out(tmp_path, laz, scheduler, monkeypatch):
    from pointatlas.cli import _reports

    monkeypatch.setattr(_reports, "MAX_TILED_VIEW_POINTS", 5_000)
    out, report = tmp_path / "o.laz", tmp_path / "r.html"
    result = run(
        "segment", laz, out, "--tile-size", 10, "--report", report, "--scheduler", scheduler
    )
    assert result.exit_code == 0, result.output
    assert f"wrote {report}" in result.output
    n = laspy.read(out).header.point_count
    step = -(-n // 5_000)
    points, fields, n_total, got_step = _reports.read_back_view(out, 5_000)
    assert (n_total, got_step) == (n, step)
    ref = laspy.read(out)
    assert np.array_equal(fields["label"], np.asarray(ref["label"])[::step])
    assert np.allclose(points, np.column_stack([ref.x, ref.y, ref.z])[::step])
    html = report.read_text()
    assert f"1 point in {step} of OUT" in html and "<script" in html
    assert "http://" not in html.split("<script", 1)[0]  # self-contained head
