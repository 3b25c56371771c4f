"""Overhead of ``pointatlas.batch.run_batch``: cluster start, per-model cost, resume.

Runs a trivial task (read a small file, draw three numbers) over ``--n`` models on a
fresh 2-worker ``LocalCluster`` (start-up and shut-down included), then reruns the
batch, which must skip every model without starting a cluster.

Run: ``.venv/bin/python benchmarks/bench_batch.py [--n 149] [--workers 2]``
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

from pointatlas.batch import run_batch


def read_and_draw(path, rng):
    """The trivial task (defined in ``__main__``: dask pickles it by value)."""
    return {"n_chars": len(Path(path).read_text()), "draws": rng.random(3)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=149)
    parser.add_argument("--workers", type=int, default=2)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp) / "models"
        folder.mkdir()
        paths = []
        for i in range(args.n):
            path = folder / f"model_{i:05d}.obj"
            path.write_text("v 0 0 0\n")
            paths.append(path)
        out = Path(tmp) / "out"
        t0 = time.perf_counter()
        first = run_batch(read_and_draw, paths, out, n_workers=args.workers, progress=False)
        t1 = time.perf_counter()
        again = run_batch(read_and_draw, paths, out, n_workers=args.workers, progress=False)
        t2 = time.perf_counter()
    print(f"first run: {first.n_done} models in {t1 - t0:.2f} s ({args.workers} workers)")
    print(f"rerun:     {again.n_skipped} skipped in {t2 - t1:.3f} s")


if __name__ == "__main__":
    main()
