"""Run kernel-vs-reference tests once more with NUMBA_DISABLE_JIT=1 (CONTRIBUTING.md, Tests).

The kernels then run as plain Python, so coverage sees their bodies. numba reads the
switch at import time, so the tests run in a subprocess:

- ``run_module_without_jit(path, select=...)`` runs ordinary pytest tests of a test
  module (the same functions the JIT-compiled suite runs) under ``pytest`` in a
  subprocess with the JIT off. Typical use, at the end of a test module::

      @pytest.mark.skipif(JIT_OFF, reason="already running with the JIT off")
      def test_kernels_without_jit():
          run_module_without_jit(__file__, select="matches_reference")

- ``run_without_jit(script)`` runs a Python source string (older form, kept until the
  rooms that still use it have converted).
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]

# True inside the subprocess started by ``run_module_without_jit`` (and whenever the
# whole suite runs with the JIT off): the test that starts the subprocess skips itself.
JIT_OFF = os.environ.get("NUMBA_DISABLE_JIT", "0") not in ("", "0")


def _jit_off_env() -> dict[str, str]:
    env = dict(os.environ, NUMBA_DISABLE_JIT="1")
    env["PYTHONPATH"] = os.pathsep.join([str(REPO), env.get("PYTHONPATH", "")])
    return env


def run_module_without_jit(
    path: str | os.PathLike,
    *,
    select: str | None = None,
    timeout: int = 300,
) -> str:
    """Run the pytest tests of one module with the JIT off; return pytest's output.

    Parameters
    ----------
    path : str or path-like
        The test module (``__file__`` of the caller, or a path relative to the
        repository root).
    select : str, optional
        A pytest ``-k`` expression choosing the tests to run (all when None). Keep
        the selection to the small kernel-vs-reference tests: without the JIT the
        kernels run as plain Python.
    timeout : int
        Seconds before the subprocess is stopped.

    Fails the calling test with pytest's output when a selected test fails or none is
    selected.
    """
    target = Path(path)
    if not target.is_absolute():
        target = REPO / target
    cmd = [sys.executable, "-m", "pytest", "-q", "-x", "--no-header", str(target)]
    if select is not None:
        cmd += ["-k", select]
    done = subprocess.run(
        cmd,
        cwd=REPO,
        env=_jit_off_env(),
        capture_output=True,
        text=True,
        timeout=timeout,
        check=False,
    )
    out = done.stdout + done.stderr
    assert done.returncode == 0, out[-3000:]
    return out


def run_without_jit(script: str, *, timeout: int = 300) -> str:
    """Run ``script`` with the JIT off from the repository root; return its stdout.

    Fails the calling test with the script's stderr when it exits non-zero.
    """
    done = subprocess.run(
        [sys.executable, "-c", script],
        cwd=REPO,
        env=_jit_off_env(),
        capture_output=True,
        text=True,
        timeout=timeout,
        check=False,
    )
    assert done.returncode == 0, done.stderr[-3000:]
    return done.stdout
