"""Output paths the user typed: checked as typed, before any work, in one line.

A trailing ``/``, a name longer than the file system allows and a read-only file
are refused naming the argument; a symbolic link is written through (the file it
leads to is the output) and a link to the input is refused.
"""

from __future__ import annotations

import hashlib
import os
import stat

import pytest

from pointatlas.io import read_point_set, write_point_set

from .helpers import assert_user_error, run, sphere_points


@pytest.fixture
def scan_ply(tmp_path):
    pts = sphere_points(200)
    path = tmp_path / "scan.ply"
    write_point_set(path, pts, normals=pts)
    return path


@pytest.fixture
def broken_ply(tmp_path):
    """An input that fails when read: an output message proves the output came first."""
    path = tmp_path / "broken.ply"
    path.write_text("ply\nformat nonsense\n")
    return path


def digest(path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def test_trailing_slash_on_out_is_refused_as_typed(broken_ply, tmp_path):
    typed = f"{tmp_path}/out.ply/"
    assert_user_error(run("normals", broken_ply, typed), f"OUT {typed!r}", "ends in '/'")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["broken.ply"]


def test_trailing_slash_on_an_option_is_refused_as_typed(broken_ply, tmp_path):
    typed = f"{tmp_path}/r.json/"
    result = run("normals", broken_ply, tmp_path / "n.ply", f"--report={typed}")
    assert_user_error(result, f"--report {typed!r}", "ends in '/'")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["broken.ply"]


@pytest.mark.parametrize("command", ["normals", "segment", "features"])
def test_a_260_character_file_name_is_refused_before_any_work(broken_ply, tmp_path, command):
    name = "n" * 256 + ".ply"
    assert len(name) == 260
    result = run(command, broken_ply, tmp_path / name)
    assert_user_error(result, "OUT ", "a name of 260 bytes is longer than the file system allows")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["broken.ply"]


def test_a_too_long_folder_name_is_refused(tmp_path):
    folder = tmp_path / ("d" * 300)
    assert_user_error(run("demo", "--out", folder), "--out ", "a name of 300 bytes")


def test_a_read_only_out_is_refused_and_kept(broken_ply, tmp_path):
    out = tmp_path / "kept.ply"
    out.write_text("mine\n")
    out.chmod(0o444)
    result = run("normals", broken_ply, out)
    assert_user_error(result, f"OUT {str(out)!r}", "is read-only (mode 0444)")
    assert out.read_text() == "mine\n"
    assert stat.S_IMODE(out.stat().st_mode) == 0o444


def test_out_through_a_symlink_writes_the_target_and_keeps_the_link(scan_ply, tmp_path):
    (tmp_path / "results").mkdir()
    real = tmp_path / "results" / "normals.ply"
    real.write_text("stale\n")
    link = tmp_path / "latest.ply"
    link.symlink_to(os.path.relpath(real, tmp_path))
    result = run("normals", scan_ply, link, "--k", "8")
    assert result.exit_code == 0, result.output
    assert link.is_symlink() and link.resolve() == real.resolve()
    assert read_point_set(real).n_points == 200
    assert sorted(p.name for p in (tmp_path / "results").iterdir()) == ["normals.ply"]


def test_out_a_link_to_a_link_to_the_input_is_refused(scan_ply, tmp_path):
    (tmp_path / "one.ply").symlink_to("scan.ply")
    (tmp_path / "two.ply").symlink_to(tmp_path / "one.ply")
    before = digest(scan_ply)
    assert_user_error(run("normals", scan_ply, tmp_path / "two.ply"), "is the input file")
    assert digest(scan_ply) == before
    assert (tmp_path / "two.ply").is_symlink()
