"""Where an atomic write lands: through symbolic links, never over a read-only file.

Every writer of the package goes through ``atomic_write``; these tests drive it
directly and through the public writers.
"""

from __future__ import annotations

import json
import os
import stat
import tempfile

import numpy as np
import pytest

from pointatlas.io import (
    PointAtlasIOError,
    atomic_write,
    read_mesh,
    read_point_set,
    write_mesh,
    write_point_set,
    write_summary_json,
    write_text,
)
from pointatlas.io._atomic import output_problem, output_target, remove_stale_temp_files

TRIANGLE = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])


def _write_points(path):
    write_point_set(path, TRIANGLE * 2.0)


def _write_mesh(path):
    write_mesh(path, TRIANGLE * 2.0, [[0, 1, 2]])


def _write_text(path):
    write_text(path, "new\n")


def _write_summary(path):
    write_summary_json(path, {"new": True}, [])


def _is_new(path) -> bool:
    if path.suffix == ".json":
        return json.loads(path.read_text()) == {"new": True, "files": []}
    if path.suffix == ".txt":
        return path.read_text() == "new\n"
    if path.suffix == ".obj":
        return np.array_equal(read_mesh(path).vertices, TRIANGLE * 2.0)
    return np.array_equal(read_point_set(path, with_normals=False).points, TRIANGLE * 2.0)


WRITERS = [
    (_write_points, "ply"),
    (_write_mesh, "obj"),
    (_write_text, "txt"),
    (_write_summary, "json"),
]
WRITER_IDS = [ext for _, ext in WRITERS]


def _old_file(path):
    path.write_text("old\n")
    return path


# ------------------------------------------------------------------ symbolic links


@pytest.mark.parametrize(("writer", "ext"), WRITERS, ids=WRITER_IDS)
def test_writing_through_a_symlink_updates_its_target_and_keeps_the_link(tmp_path, writer, ext):
    (tmp_path / "data").mkdir()
    real = _old_file(tmp_path / "data" / f"real.{ext}")
    (tmp_path / "links").mkdir()
    link = tmp_path / "links" / f"link.{ext}"
    link.symlink_to(os.path.relpath(real, link.parent))
    writer(link)
    assert link.is_symlink()
    assert link.resolve() == real.resolve()
    assert _is_new(real)
    # no temporary file left beside the link or the target
    assert sorted(p.name for p in (tmp_path / "links").iterdir()) == [link.name]
    assert sorted(p.name for p in (tmp_path / "data").iterdir()) == [real.name]


def test_temporary_file_goes_beside_the_target_of_a_link(tmp_path, monkeypatch):
    (tmp_path / "data").mkdir()
    real = _old_file(tmp_path / "data" / "real.txt")
    link = tmp_path / "link.txt"
    link.symlink_to(real)
    folders = []
    mkstemp = tempfile.mkstemp

    def spy(*args, **kwargs):
        folders.append(os.path.realpath(kwargs["dir"]))
        return mkstemp(*args, **kwargs)

    monkeypatch.setattr(tempfile, "mkstemp", spy)
    with atomic_write(link, "w") as fh:
        fh.write("new\n")
    assert folders == [os.path.realpath(tmp_path / "data")]
    assert real.read_text() == "new\n" and link.is_symlink()


def test_a_chain_of_links_and_a_dangling_link_lead_to_the_file(tmp_path):
    real = _old_file(tmp_path / "real.txt")
    (tmp_path / "one.txt").symlink_to("real.txt")
    (tmp_path / "two.txt").symlink_to("one.txt")
    write_text(tmp_path / "two.txt", "new\n")
    assert real.read_text() == "new\n"
    assert (tmp_path / "two.txt").is_symlink() and (tmp_path / "one.txt").is_symlink()
    # a link to a file that does not exist yet creates that file
    (tmp_path / "later.txt").symlink_to("created.txt")
    write_text(tmp_path / "later.txt", "made\n")
    assert (tmp_path / "later.txt").is_symlink()
    assert (tmp_path / "created.txt").read_text() == "made\n"
    assert output_target(tmp_path / "later.txt") == (tmp_path / "created.txt").resolve()


def test_the_target_keeps_its_permissions_when_written_through_a_link(tmp_path):
    real = _old_file(tmp_path / "real.txt")
    real.chmod(0o640)
    (tmp_path / "link.txt").symlink_to(real)
    write_text(tmp_path / "link.txt", "new\n")
    assert stat.S_IMODE(real.stat().st_mode) == 0o640


def test_a_symlink_loop_is_refused(tmp_path):
    (tmp_path / "a.txt").symlink_to("b.txt")
    (tmp_path / "b.txt").symlink_to("a.txt")
    with pytest.raises(PointAtlasIOError, match="a.txt"):
        write_text(tmp_path / "a.txt", "new\n")
    assert (tmp_path / "a.txt").is_symlink() and (tmp_path / "b.txt").is_symlink()


def test_stale_temp_files_beside_a_links_target_are_removed(tmp_path):
    (tmp_path / "data").mkdir()
    real = _old_file(tmp_path / "data" / "real.ply")
    link = tmp_path / "link.ply"
    link.symlink_to(real)
    stale = tmp_path / "data" / ".real.ply.pa999999999.abcd1234.tmp"
    stale.write_text("partial")
    assert remove_stale_temp_files(link) == [stale]
    assert not stale.exists()


# ------------------------------------------------------------------ read-only files


@pytest.mark.parametrize(("writer", "ext"), WRITERS, ids=WRITER_IDS)
def test_a_read_only_file_is_not_replaced(tmp_path, writer, ext):
    """Refused whoever runs it (root included): the owner's 0444 says "keep"."""
    old = _old_file(tmp_path / f"kept.{ext}")
    old.chmod(0o444)
    with pytest.raises(PointAtlasIOError, match=r"kept\.\w+: is read-only \(mode 0444\)") as info:
        writer(old)
    assert len(str(info.value).splitlines()) == 1
    assert old.read_text() == "old\n"
    assert stat.S_IMODE(old.stat().st_mode) == 0o444
    assert [p.name for p in tmp_path.iterdir()] == [old.name]


def test_a_link_to_a_read_only_file_is_refused(tmp_path):
    real = _old_file(tmp_path / "real.txt")
    real.chmod(0o444)
    (tmp_path / "link.txt").symlink_to(real)
    with pytest.raises(PointAtlasIOError, match="link.txt: is read-only"):
        write_text(tmp_path / "link.txt", "new\n")
    assert real.read_text() == "old\n"


def test_a_file_of_another_user_that_this_user_may_not_write_is_refused(tmp_path, monkeypatch):
    old = _old_file(tmp_path / "theirs.txt")
    old.chmod(0o644)
    monkeypatch.setattr(os, "access", lambda path, mode, **kw: False)
    with pytest.raises(PointAtlasIOError, match="not writable by this user"):
        write_text(old, "new\n")
    assert old.read_text() == "old\n"


def test_a_writable_file_is_still_replaced(tmp_path):
    old = _old_file(tmp_path / "a.txt")
    old.chmod(0o600)
    write_text(old, "new\n")
    assert old.read_text() == "new\n"
    assert stat.S_IMODE(old.stat().st_mode) == 0o600


# ------------------------------------------------------------------ paths that name no file


def test_a_fifo_is_not_replaced(tmp_path):
    fifo = tmp_path / "pipe.txt"
    os.mkfifo(fifo)
    with pytest.raises(PointAtlasIOError, match="not a regular file"):
        write_text(fifo, "new\n")
    assert stat.S_ISFIFO(os.lstat(fifo).st_mode)


def test_trailing_separator_and_too_long_names_are_refused(tmp_path):
    with pytest.raises(PointAtlasIOError, match="ends in '/'"):
        write_text(f"{tmp_path}/out.txt/", "new\n")
    name = "a" * 260 + ".txt"
    with pytest.raises(PointAtlasIOError, match="a name of 264 bytes is longer than"):
        write_text(tmp_path / name, "new\n")
    assert not list(tmp_path.iterdir())
    assert output_problem(tmp_path / "fine.txt") is None
    assert "is a folder" in output_problem(tmp_path)
