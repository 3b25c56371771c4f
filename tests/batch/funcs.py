"""Module-level task functions for the batch tests (workers import this module)."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np


def measure(path, rng):
    """Count the call in ``<path>.calls``, read the file, draw from rng."""
    p = Path(path)
    with open(p.with_suffix(".calls"), "a", encoding="utf-8") as fh:
        fh.write(f"{os.getpid()}\n")
    text = p.read_text(encoding="utf-8")
    return {
        "n_chars": len(text),
        "draws": rng.random(3),
        "integer": np.int64(7),
        "scalar": np.float32(1.5),
        "flag": np.bool_(True),
        "nested": {"pair": (1, 2), "grid": np.eye(2, dtype=np.int32)},
    }


def fail_on_bad(path, rng):
    """Raise for inputs whose name contains "bad"; otherwise like `measure`."""
    if "bad" in Path(path).name:
        raise ValueError(f"cannot handle {Path(path).name}")
    return measure(path, rng)


def not_a_dict(path, rng):
    """Return a list (a contract violation that must be recorded)."""
    return [1, 2]


def crash_on_bad(path, rng):
    """Kill the worker process for inputs named "bad" (worker death)."""
    if "bad" in Path(path).name:
        os._exit(13)
    return {"draw": float(rng.random())}
