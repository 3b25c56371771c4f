"""Compile every command's numeric kernels into numba's cache ahead of use.

The hidden command ``pointatlas warmup [COMMAND]...`` (``make install`` runs it)
runs each command's default path on a small bundled model in a temporary folder:
numba compiles the kernels that path runs and writes them to its cache
(``__pycache__`` beside the sources, or ``NUMBA_CACHE_DIR``), so a later first run
loads them in a second or two instead of compiling for a minute or more. One line
per command says how many kernels it added and how long it took.

The kernels of a command are the numba dispatchers of ``pointatlas`` that hold a
compiled signature after it ran (`compiled_kernels`); inlined helpers have none and
need no cache entry.
"""

from __future__ import annotations

import contextlib
import io
import sys
import tempfile
import time
from pathlib import Path
from typing import Annotated

import typer

from ._app import app as _app
from ._app import guarded, say

__all__ = ["WARM_STEPS", "compiled_kernels", "warm", "warmup_command"]

#: The model the warm-up runs on: small (2,304 points), so the run after the
#: compile takes well under a second, yet large enough for the grid k-NN path.
WARM_MODEL = "torus_coarse"

#: A k-NN whose grid block cannot answer every row (the hand's 810 points at k = 12:
#: 60 rows), so that the rings kernel (`knn_grid_rings`), which compiles only when a
#: row needs it, is cached too: the torus never needs it, a scan does.
_RINGS = ["info", "hand"]

#: Per command, the argument lists run in order ({tmp}: the temporary folder).
#: ``simplify`` runs twice: a mesh takes the mesh path, a point set the points path
#: (and once more with its normals estimated: `pointatlas.simplify.surface_normals`).
#: Besides the defaults, the options whose kernels are their own and that the README,
#: the demo or the thesis' experiments run: ``info --report`` (the k-NN graph's
#: components; a step of its own, ``report``), ``features --weighting equal``,
#: ``segment --eta`` (the merge step's candidates: the torus merges nothing) and the
#: points path on a CAD model (its non-convex faces are split for other readers by
#: ear clipping: `make demo` runs it).
WARM_STEPS: dict[str, list[list[str]]] = {
    "info": [["info", WARM_MODEL], _RINGS],
    "normals": [["normals", WARM_MODEL, "{tmp}/normals.ply"], _RINGS],
    "features": [
        ["features", WARM_MODEL, "{tmp}/features.ply"],
        _RINGS,
        ["features", WARM_MODEL, "{tmp}/features_equal.ply", "--weighting", "equal"],
    ],
    "segment": [
        ["segment", WARM_MODEL, "{tmp}/segment.ply"],
        _RINGS,
        ["segment", "fandisk", "{tmp}/segment_eta.ply", "--eta", "25"],
    ],
    "simplify": [
        ["simplify", WARM_MODEL, "{tmp}/simplify_mesh.obj"],
        ["data", "export", WARM_MODEL, "{tmp}/points.ply", "--points"],
        ["simplify", "{tmp}/points.ply", "{tmp}/simplify_points.obj"],
        ["simplify", "{tmp}/points.ply", "{tmp}/simplify_raw.obj", "--estimate-normals"],
        ["data", "export", "fandisk", "{tmp}/cad_points.ply", "--points"],
        ["simplify", "{tmp}/cad_points.ply", "{tmp}/simplify_cad.obj"],
    ],
    # the adaptive method too (the README's tour runs it; its kernels are its own)
    # and a model with planar pieces (the torus has none: their kernels stay cold)
    "denoise": [
        ["denoise", WARM_MODEL, "{tmp}/denoise.ply"],
        ["denoise", WARM_MODEL, "{tmp}/denoise_adaptive.ply", "--method", "normal-voting-adaptive"],
        ["denoise", "fandisk", "{tmp}/denoise_planes.ply"],
    ],
    # the pictures of every command's --render: the points' z-buffer kernels
    "render": [
        ["data", "export", WARM_MODEL, "{tmp}/render_points.ply", "--points"],
        ["render", "{tmp}/render_points.ply", "{tmp}/render.png"],
        ["data", "export", WARM_MODEL, "{tmp}/render_mesh.obj"],
        ["render", "{tmp}/render_mesh.obj", "{tmp}/render_mesh.png"],
    ],
    "cloudsurface": [["cloudsurface", WARM_MODEL, "{tmp}/cloudsurface", "--scale", "1"]],
    # apart from info's default path, which tests/cli/test_warm.py warms from nothing
    "report": [["info", WARM_MODEL, "--report", "{tmp}/info.html"]],
    "deform": [
        ["cloudsurface", WARM_MODEL, "{tmp}/deform_cs", "--scale", "1"],
        ["deform", "{tmp}/deform_cs", "{tmp}/deform_cs/complex.ply", "{tmp}/deform.ply"],
    ],
}


def compiled_kernels() -> dict[str, int]:
    """Every ``pointatlas`` numba dispatcher with a compiled (or cache-loaded)
    signature: ``module.qualname`` -> number of signatures."""
    from numba.core.registry import CPUDispatcher

    found: dict[str, int] = {}
    for name, module in list(sys.modules.items()):
        if not name.startswith("pointatlas.") or module is None:
            continue
        for obj in list(vars(module).values()):
            if isinstance(obj, CPUDispatcher) and obj.signatures:
                func = obj.py_func
                found[f"{func.__module__}.{func.__qualname__}"] = len(obj.signatures)
    return found


def _run_quietly(app, args: list[str]) -> None:
    """Run one command in process, its output swallowed; a failure raises (an error
    the command reports is its exit code, which click returns without
    ``standalone_mode``: a warm-up step that stopped at its error compiled nothing)."""
    out = io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(out):
        try:
            code = app(args, standalone_mode=False)
        except SystemExit as exc:  # typer.Exit from a command
            code = exc.code
    if code not in (0, None):
        raise RuntimeError(f"pointatlas {' '.join(args)}: {out.getvalue().strip()}")


def warm(commands=None, *, say=print) -> dict[str, list[str]]:
    """Run the warm-up steps of ``commands`` (default: all of `WARM_STEPS`).

    Returns, per command, the kernels it was the first to run (sorted
    ``module.qualname``); each is in numba's cache afterwards. ``say`` gets one
    line per command.
    """
    from . import _load_app

    app = _load_app()
    names = list(WARM_STEPS) if commands is None else list(commands)
    unknown = [c for c in names if c not in WARM_STEPS]
    if unknown:
        raise ValueError(f"no warm-up for {', '.join(unknown)}; known: {', '.join(WARM_STEPS)}")
    held: dict[str, list[str]] = {}
    with tempfile.TemporaryDirectory(prefix="pointatlas-warm-") as tmp:
        for name in names:
            before = set(compiled_kernels())
            t0 = time.perf_counter()
            for step in WARM_STEPS[name]:
                _run_quietly(app, [a.format(tmp=tmp) for a in step])
            now = compiled_kernels()
            held[name] = sorted(set(now) - before)
            seconds = time.perf_counter() - t0
            say(f"warm-up {name}: {len(held[name])} more kernels ready ({seconds:.1f} s)")
    return held


@_app.command("warmup", hidden=True)
@guarded
def warmup_command(
    commands: Annotated[
        list[str] | None,
        typer.Argument(metavar="[COMMAND]...", help="Commands to warm (default: all)."),
    ] = None,
    json_path: Annotated[
        Path | None,
        typer.Option("--json", help="Also write the kernels of each command to this file."),
    ] = None,
):
    """Compile every command's numeric kernels into numba's cache (``make install``
    runs this; a first run then starts at once)."""
    held = warm(commands or None, say=say)
    if json_path is not None:
        from ..io import write_json

        write_json(json_path, held, indent=2)
