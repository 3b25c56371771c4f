"""Which numba kernels the test suite compiles after the warm-up, per test (a pytest plugin).

The suite runs after ``make install``, whose ``pointatlas warmup`` caches the kernels
of every command's default path; whatever the suite compiles beyond them (another
array type of a kernel: a writeable array where the warm-up passed a read-only one; a
path no command's default takes) is CPU time of every CI run. As run on a fresh clone:

    export NUMBA_CACHE_DIR=$(mktemp -d)   # an empty cache, filled by the warm-up
    .venv/bin/pointatlas warmup
    PYTHONPATH=tools SUITE_COMPILES=compiles.json .venv/bin/python -m pytest -q \\
        -p suite_compiles

records numba's ``numba:compile`` events in the pytest process (with
``benchmarks/bench_compile.py``'s listener: CPU seconds of each kernel and signature
without the kernels compiled inside it) under the test that was running, and writes
``SUITE_COMPILES`` (JSON: ``outer_cpu``, the compile CPU in all; ``self``, per kernel
and signature; ``per_test``). Subprocesses the tests start (CLI runs) are not seen.
"""

from __future__ import annotations

import importlib.util
import json
import os
import sys
import time
from pathlib import Path

_BENCH = Path(__file__).resolve().parents[1] / "benchmarks" / "bench_compile.py"
_spec = importlib.util.spec_from_file_location("bench_compile", _BENCH)
_bench = importlib.util.module_from_spec(_spec)
sys.modules["bench_compile"] = _bench  # dataclasses look their module up
_spec.loader.exec_module(_bench)

LOG = _bench.CompileLog()
CURRENT = {"test": "<collection>"}
PER_TEST: dict[str, dict[str, float]] = {}


def _listener():
    """`CompileLog`'s listener, also adding each compile's self CPU to the current test."""
    listener = LOG.listener()
    log_end = listener.on_end

    def on_end(ev):
        frame = LOG.stack[-1]
        log_end(ev)
        spent = time.process_time() - frame.cpu0 - frame.inner_cpu
        key = f"{frame.key[0]} ({frame.key[1]})"
        test = PER_TEST.setdefault(CURRENT["test"], {})
        test[key] = test.get(key, 0.0) + spent

    listener.on_end = on_end
    return listener


def pytest_configure(config):
    from numba.core import event

    event.register("numba:compile", _listener())


def pytest_runtest_setup(item):
    CURRENT["test"] = item.nodeid


def pytest_sessionfinish(session):
    out = {
        "outer_cpu": LOG.outer_cpu,
        "self": {f"{name} ({sig})": cpu for (name, sig), cpu in LOG.self_cpu.items()},
        "per_test": PER_TEST,
    }
    Path(os.environ.get("SUITE_COMPILES", "suite_compiles.json")).write_text(
        json.dumps(out, indent=1)
    )
