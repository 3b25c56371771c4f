"""Which numba kernels a command compiles on an empty cache, and for how long.

Runs one command of the warm-up (``pointatlas warmup``: info, normals, features,
segment, simplify, denoise, cloudsurface, deform) in this process with
``NUMBA_CACHE_DIR`` set to a fresh empty folder, so every kernel its path calls is
compiled (what a bare ``pip install`` of the wheel meets), and records numba's
``numba:compile`` events. Prints, per kernel and signature, the CPU seconds (user +
system, all threads) of its compile without the kernels it compiled inside it
(``self``) and with them (``total``), then the kernels compiled for more than one
signature, the compile CPU in all and the process's CPU and wall time.

Run: ``.venv/bin/python benchmarks/bench_compile.py [COMMAND] [--model fandisk]``
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path


@dataclass
class _Frame:
    key: tuple[str, str]
    cpu0: float
    wall0: float
    inner_cpu: float = 0.0


@dataclass
class CompileLog:
    """A ``numba:compile`` listener: per (kernel, signature), self and total CPU s."""

    stack: list[_Frame] = field(default_factory=list)
    self_cpu: dict[tuple[str, str], float] = field(default_factory=dict)
    total_cpu: dict[tuple[str, str], float] = field(default_factory=dict)
    caller: dict[tuple[str, str], str] = field(default_factory=dict)  # numba's own, by whom
    outer_cpu: float = 0.0  # CPU of the outermost compiles: the compile CPU in all
    outer_wall: float = 0.0

    def listener(self):
        from numba.core import event

        log = self

        class _Listener(event.Listener):
            def on_start(self, ev):
                disp = ev.data["dispatcher"]
                func = disp.py_func
                name = f"{func.__module__}.{func.__qualname__}"
                sig = ", ".join(str(a) for a in ev.data["args"])
                if not name.startswith("pointatlas."):
                    ours = [f.key[0] for f in log.stack if f.key[0].startswith("pointatlas.")]
                    log.caller.setdefault((name, sig), ours[-1] if ours else "?")
                log.stack.append(_Frame((name, sig), time.process_time(), time.perf_counter()))

            def on_end(self, ev):
                frame = log.stack.pop()
                spent = time.process_time() - frame.cpu0
                key = frame.key
                log.total_cpu[key] = log.total_cpu.get(key, 0.0) + spent
                log.self_cpu[key] = log.self_cpu.get(key, 0.0) + spent - frame.inner_cpu
                if log.stack:
                    log.stack[-1].inner_cpu += spent
                else:
                    log.outer_cpu += spent
                    log.outer_wall += time.perf_counter() - frame.wall0

        return _Listener()


def _short(name: str) -> str:
    return name.removeprefix("pointatlas.")


def report(log: CompileLog, *, top: int) -> None:
    """Print the per-kernel table, the kernels with several signatures and the sums."""
    rows = sorted(log.self_cpu.items(), key=lambda kv: -kv[1])
    print(f"{'self CPU':>9} {'total CPU':>9}  kernel (signature)")
    for key, spent in rows[:top]:
        name, sig = key
        by = f" in {_short(log.caller[key])}" if key in log.caller else ""
        print(f"{spent:>8.2f}s {log.total_cpu[key]:>8.2f}s  {_short(name)} ({sig}){by}")
    if len(rows) > top:
        rest = sum(spent for _, spent in rows[top:])
        print(f"{rest:>8.2f}s {'':>9}  {len(rows) - top} more")
    per_kernel: dict[str, list[str]] = {}
    for name, sig in log.self_cpu:
        per_kernel.setdefault(name, []).append(sig)
    several = {name: sigs for name, sigs in per_kernel.items() if len(sigs) > 1}
    print(f"{len(per_kernel)} kernels, {len(log.self_cpu)} signatures compiled")
    for name, sigs in sorted(several.items()):
        print(f"  {len(sigs)} signatures: {_short(name)}")
        for sig in sigs:
            print(f"      ({sig})")
    ours = sum(spent for (name, _), spent in log.self_cpu.items() if name.startswith("pointatlas."))
    print(
        f"compile CPU {log.outer_cpu:.1f} s (pointatlas kernels {ours:.1f} s, numba's own "
        f"functions they call {log.outer_cpu - ours:.1f} s), compile wall {log.outer_wall:.1f} s"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("command", nargs="?", default="segment")
    parser.add_argument("--model", default="fandisk", help="bundled model (default fandisk)")
    parser.add_argument("--top", type=int, default=25, help="kernels listed (default 25)")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="pointatlas-compile-") as tmp:
        # numba reads NUMBA_CACHE_DIR when it is first imported: set it before
        os.environ["NUMBA_CACHE_DIR"] = str(Path(tmp) / "numba-cache")
        cpu0, wall0 = time.process_time(), time.perf_counter()
        from numba.core import event

        from pointatlas.cli import _load_app
        from pointatlas.cli._warm import WARM_MODEL, WARM_STEPS, _run_quietly

        log = CompileLog()
        event.register("numba:compile", log.listener())
        app = _load_app()
        for step in WARM_STEPS[args.command]:
            argv = [args.model if a == WARM_MODEL else a.format(tmp=tmp) for a in step]
            print("pointatlas", " ".join(argv), flush=True)
            _run_quietly(app, argv)
        cpu, wall = time.process_time() - cpu0, time.perf_counter() - wall0
    print(f"model {args.model}; {os.cpu_count()} CPUs; empty NUMBA_CACHE_DIR")
    report(log, top=args.top)
    print(f"process CPU {cpu:.1f} s, wall {wall:.1f} s (imports and the run included)")


if __name__ == "__main__":
    main()
