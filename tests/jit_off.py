"""Run a kernel-vs-reference script once more with NUMBA_DISABLE_JIT=1 (STYLE section 7).

The kernels then run as plain Python, so coverage sees their bodies. The script runs
in a subprocess because numba reads the switch at import time.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def run_without_jit(script: str, *, timeout: int = 300) -> str:
    """Run ``script`` with the JIT off from the repository root; return its stdout.

    Fails the calling test with the script's stderr when it exits non-zero.
    """
    env = dict(os.environ, NUMBA_DISABLE_JIT="1")
    env["PYTHONPATH"] = os.pathsep.join([str(REPO), env.get("PYTHONPATH", "")])
    done = subprocess.run(
        [sys.executable, "-c", script],
        cwd=REPO,
        env=env,
        capture_output=True,
        text=True,
        timeout=timeout,
        check=False,
    )
    assert done.returncode == 0, done.stderr[-3000:]
    return done.stdout
