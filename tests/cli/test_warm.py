"""The warm-up fills numba's cache; a cold cache is announced (issue 28 item 13)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import threading

import pytest

from pointatlas.cli._compile_notice import COMPILE_NOTICE

#: Runs the ``pointatlas`` entry point (``main``) with the arguments after it.
ENTRY = [sys.executable, "-c", "from pointatlas.cli import main; main()"]


def _env(cache):
    return {**os.environ, "NUMBA_CACHE_DIR": str(cache)}


@pytest.mark.slow
@pytest.mark.timeout(1900)  # its two commands' own limits: 1,200 s and 600 s
def test_warmup_leaves_every_kernel_it_names_in_the_cache(tmp_path):
    cache = tmp_path / "numba-cache"
    listing = tmp_path / "kernels.json"
    cmd = [*ENTRY, "warmup", "info", "--json", str(listing)]
    proc = subprocess.run(cmd, capture_output=True, text=True, env=_env(cache), timeout=1200)
    assert proc.returncode == 0, proc.stderr
    assert "warm-up info:" in proc.stdout
    kernels = json.loads(listing.read_text())["info"]
    assert "pointatlas.neighbors._kernels.knn.knn_grid" in kernels
    # the rings kernel compiles only where the grid block leaves a row: not on the torus
    assert "pointatlas.neighbors._kernels.knn_rings.knn_grid_rings" in kernels
    for name in kernels:
        module, qualname = name.rsplit(".", 1)
        stem = module.rsplit(".", 1)[1]
        assert list(cache.rglob(f"{stem}.{qualname}-*.nbi")), f"{name} not in the cache"
    # a later first run loads them, on an input whose k-NN needs the rings kernel:
    # nothing compiles, nothing is announced
    again = subprocess.run(
        [*ENTRY, "info", "hand"],
        capture_output=True,
        text=True,
        env=_env(cache),
        timeout=600,
    )
    assert again.returncode == 0, again.stderr
    assert COMPILE_NOTICE not in again.stderr


def test_a_cold_cache_is_announced_once_on_stderr(tmp_path):
    # an empty cache: the k-NN kernels of `info` compile for far longer than the
    # notice's few seconds; the process is stopped once the line is seen
    lines = []
    with subprocess.Popen(
        [*ENTRY, "info", "cube"],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
        env=_env(tmp_path / "numba-cache"),
    ) as proc:

        def read():
            for line in proc.stderr:
                lines.append(line.rstrip("\n"))
                if line.startswith("compiling"):
                    return

        reader = threading.Thread(target=read, daemon=True)
        reader.start()
        reader.join(timeout=600)
        proc.kill()
    assert COMPILE_NOTICE in lines, lines


def test_every_warm_up_step_runs_without_error(monkeypatch):
    # cloudsurface asks for --scale or --search: its steps stopped at that error,
    # compiled nothing, and the warm-up said "0 more kernels" with exit status 0
    from pointatlas.cli import _load_app, _warm

    calls = []
    real = _warm._run_quietly

    def run(app, args):
        calls.append(args[0])
        real(app, args)

    monkeypatch.setattr(_warm, "_run_quietly", run)
    _warm.warm(["cloudsurface", "deform", "render"], say=lambda line: None)
    # render reads files only (not a bundled model's name): the model is exported first
    assert calls[:3] == ["cloudsurface", "cloudsurface", "deform"]
    assert calls[3:] == ["data", "render", "data", "render"]
    with pytest.raises(RuntimeError, match="give exactly one of --scale"):
        _warm._run_quietly(_load_app(), ["cloudsurface", "torus_coarse", "x"])
