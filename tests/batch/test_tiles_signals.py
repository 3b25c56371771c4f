"""A tiled run stopped by Ctrl-C, SIGTERM or SIGKILL, tried as a user would: the real
command in a subprocess on a generated LAS, the signal sent once its tiles are being
written (issue 28 items 8 and 9)."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

distributed = pytest.importorskip("distributed")
laspy = pytest.importorskip("laspy")

from pointatlas.cli import app  # noqa: E402

from .test_tiles import scan  # noqa: E402

#: Points of the generated input: several seconds of tiles on two workers.
N_POINTS = 300_000
#: Seconds a run may take to reach its tiles (a first run compiles numba kernels).
START_TIMEOUT_S = 600


@pytest.fixture(scope="module")
def big_las(tmp_path_factory):
    rng = np.random.default_rng(0)
    xy = rng.uniform(0.0, 500.0, size=(N_POINTS, 2))
    z = 5.0 * np.sin(xy[:, 0] / 30.0) + rng.normal(scale=0.05, size=N_POINTS)
    header = laspy.LasHeader(point_format=3, version="1.2")
    header.scales = np.full(3, 0.001)
    header.offsets = np.zeros(3)
    las = laspy.LasData(header)
    las.x, las.y, las.z = xy[:, 0], xy[:, 1], z
    path = tmp_path_factory.mktemp("signals") / "big.las"
    las.write(path)
    return path


@pytest.fixture(scope="module")
def small_las(tmp_path_factory):
    pts = scan(4_000, seed=5)
    header = laspy.LasHeader(point_format=3, version="1.2")
    header.scales = np.full(3, 0.001)
    header.offsets = np.floor(pts.min(axis=0))
    las = laspy.LasData(header)
    las.x, las.y, las.z = pts[:, 0], pts[:, 1], pts[:, 2]
    path = tmp_path_factory.mktemp("signals_small") / "small.las"
    las.write(path)
    return path


def _start_tiled(src: Path, out: Path) -> subprocess.Popen:
    """``pointatlas features SRC OUT --tile-size 100 --workers 2`` in a session of its
    own (its process group is what a terminal's Ctrl-C reaches)."""
    cmd = [
        sys.executable,
        "-m",
        "pointatlas.cli",
        "features",
        str(src),
        str(out),
        "--tile-size",
        "100",
        "--workers",
        "2",
    ]
    return subprocess.Popen(
        cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True
    )


def _wait_for_tiles(proc: subprocess.Popen, folder: Path) -> Path:
    """The run's temporary folder, once the first tile's points are in it."""
    deadline = time.monotonic() + START_TIMEOUT_S
    while time.monotonic() < deadline:
        pieces = sorted(folder.glob(".pointatlas-tiles*/t*.npy"))
        if pieces:
            return pieces[0].parent
        if proc.poll() is not None:
            _, stderr = proc.communicate()
            pytest.fail(f"the run ended (rc {proc.returncode}) before its tiles: {stderr}")
        time.sleep(0.02)
    proc.kill()
    pytest.fail(f"no tiles within {START_TIMEOUT_S} s")


def _session_members(sid: int) -> list[int]:
    """Processes still in session ``sid`` (Linux ``/proc``)."""
    members = []
    for entry in os.scandir("/proc"):
        if not entry.name.isdigit():
            continue
        try:
            stat = Path(entry.path, "stat").read_text()
        except OSError:
            continue
        fields = stat[stat.rindex(")") + 2 :].split()
        # state, ppid, pgrp, session: a zombie has exited (a container's init may
        # never reap it)
        if int(fields[3]) == sid and fields[0] != "Z":
            members.append(int(entry.name))
    return members


def _members_gone(sid: int, within_s: float = 10.0) -> list[int]:
    """`_session_members` once they are gone, or after ``within_s`` seconds (a worker
    told to stop may take a moment to exit on a loaded machine: a fresh-clone run
    saw one still there as the command returned)."""
    end = time.monotonic() + within_s
    while (left := _session_members(sid)) and time.monotonic() < end:
        time.sleep(0.2)
    return left


@pytest.mark.slow
@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="reads /proc (Linux)")
@pytest.mark.parametrize(
    ("signum", "to_group", "code", "line"),
    [
        (signal.SIGINT, True, 130, "error: interrupted"),  # Ctrl-C in a terminal
        (signal.SIGINT, False, 130, "error: interrupted"),  # kill -INT PID
        (signal.SIGTERM, True, 143, "error: terminated"),  # a service manager, timeout(1)
    ],
    ids=["sigint-group", "sigint-pid", "sigterm-group"],
)
def test_a_signal_stops_a_tiled_run_cleanly(big_las, tmp_path, signum, to_group, code, line):
    out = tmp_path / "out.las"
    out.write_bytes(b"previous")
    proc = _start_tiled(big_las, out)
    try:
        _wait_for_tiles(proc, tmp_path)
        if to_group:
            os.killpg(proc.pid, signum)
        else:
            proc.send_signal(signum)
        stdout, stderr = proc.communicate(timeout=120)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
    assert proc.returncode == code, stderr
    assert "leaked semaphore" not in stderr
    assert stderr.strip() == line, stderr
    assert out.read_bytes() == b"previous"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.las"]  # nothing left behind
    assert _members_gone(proc.pid) == []  # the workers stopped with it


@pytest.mark.slow
@pytest.mark.skipif(not hasattr(os, "killpg"), reason="POSIX process groups")
def test_sigkill_leaves_a_folder_the_next_run_removes(big_las, small_las, tmp_path, scheduler):
    out = tmp_path / "out.las"
    proc = _start_tiled(big_las, out)
    try:
        left = _wait_for_tiles(proc, tmp_path)
    finally:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.communicate(timeout=120)
    assert left.exists() and f".pa{proc.pid}." in left.name  # the owner is in the name
    runner = CliRunner()
    result = runner.invoke(
        app,
        [
            "features",
            str(small_las),
            str(tmp_path / "again.las"),
            "--tile-size",
            "10",
            "--scheduler",
            scheduler,
        ],
    )
    assert result.exit_code == 0, result.output
    assert not left.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["again.las"]


def test_only_dead_processes_tiles_folders_are_removed(small_las, tmp_path, scheduler):
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    stale = tmp_path / f".pointatlas-tiles.pa{dead.pid}.abcd1234.tmp"
    alive = tmp_path / f".pointatlas-tiles.pa{os.getpid()}.efgh5678.tmp"
    legacy = tmp_path / ".pointatlas-tiles-k3j9a2zq"  # no owner in the name: not known dead
    others = tmp_path / f"results.pa{dead.pid}.abcd1234.tmp"  # not named as ours
    for folder in (stale, alive, legacy, others):
        folder.mkdir()
        (folder / "t0_0_xyz.npy").write_bytes(b"piece")
    result = CliRunner().invoke(
        app,
        [
            "features",
            str(small_las),
            str(tmp_path / "f.las"),
            "--tile-size",
            "10",
            "--scheduler",
            scheduler,
        ],
    )
    assert result.exit_code == 0, result.output
    assert not stale.exists()
    for kept in (alive, legacy, others):
        assert (kept / "t0_0_xyz.npy").read_bytes() == b"piece", kept
