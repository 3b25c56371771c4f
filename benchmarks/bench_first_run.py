"""First run of each command with an empty numba cache vs a warm one.

For every command of the warm-up (``pointatlas warmup``: info, normals, features,
segment, simplify, denoise, cloudsurface, deform) runs its steps on a bundled model
as separate ``pointatlas`` processes, twice, with ``NUMBA_CACHE_DIR`` set to a
fresh empty folder: the first run compiles the command's kernels (what a bare
``pip install`` of the wheel meets), the second loads them from the cache (what
``make install``, which runs the warm-up, leaves). Prints wall and CPU seconds
(user + system of the child processes) and whether the compile notice was printed.

Run: ``.venv/bin/python benchmarks/bench_first_run.py [--model fandisk] [COMMAND ...]``
"""

from __future__ import annotations

import argparse
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from pointatlas.cli._compile_notice import COMPILE_NOTICE
from pointatlas.cli._warm import WARM_MODEL, WARM_STEPS

ENTRY = [sys.executable, "-c", "from pointatlas.cli import main; main()"]


def _children_cpu() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def run_steps(steps, *, model: str, tmp: Path, cache: Path) -> tuple[float, float, bool]:
    """Run one command's steps; (wall s, CPU s, notice printed)."""
    env = {**os.environ, "NUMBA_CACHE_DIR": str(cache)}
    wall0, cpu0 = time.perf_counter(), _children_cpu()
    noticed = False
    for step in steps:
        args = [a.format(tmp=tmp) for a in step]
        args = [model if a == WARM_MODEL else a for a in args]
        proc = subprocess.run([*ENTRY, *args], capture_output=True, text=True, env=env)
        if proc.returncode != 0:
            raise SystemExit(f"pointatlas {' '.join(args)} failed:\n{proc.stderr}")
        noticed = noticed or COMPILE_NOTICE in proc.stderr
    return time.perf_counter() - wall0, _children_cpu() - cpu0, noticed


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("commands", nargs="*", default=list(WARM_STEPS))
    parser.add_argument("--model", default="fandisk", help="bundled model (default fandisk)")
    args = parser.parse_args()
    print(f"model {args.model}; {os.cpu_count()} CPUs; numba cache emptied per command")
    head = ("command", "cold wall", "cold CPU", "warm wall", "warm CPU")
    print(f"{head[0]:<13} {head[1]:>10} {head[2]:>9} {head[3]:>10} {head[4]:>9}  notice")
    for name in args.commands:
        with tempfile.TemporaryDirectory(prefix="pointatlas-first-run-") as tmp:
            cache = Path(tmp) / "numba-cache"
            steps = WARM_STEPS[name]
            cold = run_steps(steps, model=args.model, tmp=Path(tmp), cache=cache)
            warm = run_steps(steps, model=args.model, tmp=Path(tmp), cache=cache)
        notice = "cold" if cold[2] else "none"
        notice += ", warm too" if warm[2] else ""
        print(
            f"{name:<13} {cold[0]:>9.1f}s {cold[1]:>8.1f}s {warm[0]:>9.1f}s {warm[1]:>8.1f}s"
            f"  {notice}",
            flush=True,
        )


if __name__ == "__main__":
    main()
