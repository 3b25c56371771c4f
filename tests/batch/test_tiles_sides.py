"""A thin plate's two sides stay apart through the command, untiled and by tiles
(issue 28 item 5): the library's side test (`flatness_with_sides`,
`voting_with_pieces`) runs in ``pointatlas denoise --method flatness`` and in every
tile."""

from __future__ import annotations

import pytest
from typer.testing import CliRunner

distributed = pytest.importorskip("distributed")

from pointatlas.cli import app  # noqa: E402
from pointatlas.io import read_point_set, write_point_set  # noqa: E402

from ..denoise.test_quality import _plate, _plate_rms  # noqa: E402

runner = CliRunner()


@pytest.fixture(scope="module")
def plate(tmp_path_factory):
    """Two noisy squares 2.5 noise sigmas apart, no normals (estimated: one way);
    flatness without the side test ends with each side's mean offset at half the
    true one (0.49, 0.52) and 0.84x the input's distance."""
    pts, side, h, _ = _plate(2.5)
    path = tmp_path_factory.mktemp("plate") / "plate.ply"
    write_point_set(path, pts)
    return path, pts, side, h


def _assert_sides_apart(out, pts, side, h):
    got = read_point_set(out, with_normals=False).points
    assert _plate_rms(got, h) < 0.8 * _plate_rms(pts, h)
    for s in (1.0, -1.0):  # each side on its own side, most of the way
        assert (got[side == s, 2] * s).mean() > 0.7 * (h / 2)


@pytest.mark.parametrize(
    "args",
    [
        ("--method", "flatness"),
        ("--method", "flatness", "--tile-size", "0.5"),
        ("--method", "normal-voting", "--n-iter", "2", "--tile-size", "0.5"),
    ],
    ids=["flatness", "flatness-tiles", "voting-tiles"],
)
def test_thin_plate_sides_stay_apart_through_the_command(tmp_path, plate, scheduler, args):
    path, pts, side, h = plate
    out = tmp_path / "out.ply"
    extra = ("--scheduler", scheduler) if "--tile-size" in args else ()
    result = runner.invoke(app, ["denoise", str(path), str(out), *args, *extra])
    assert result.exit_code == 0, result.output
    _assert_sides_apart(out, pts, side, h)
