"""``pointatlas denoise``: its flags as `DenoiseOptions` for the job
(`pointatlas.cli.jobs.run_denoise`: normal voting, thesis 5.4, or flatness, 6.2), and
what it prints."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Annotated

import typer

from ._app import (
    EstimateNormalsOption,
    HaloOption,
    InputArgument,
    MaxMemoryOption,
    NormalKOption,
    SchedulerOption,
    TileSizeOption,
    WorkersOption,
    app,
    console,
    deprecated_option,
    guarded,
    renamed_flag,
    say,
    tile_options,
)
from .jobs import DenoiseOptions, run_denoise

__all__ = ["denoise_command"]

#: what `pointatlas denoise` prints with --clean (attribute, label)
MEASURE_ROWS = (
    ("chamfer", "Chamfer (unit sphere, squared)"),
    ("p2m_mean", "point-to-mesh mean"),
    ("p2m_max", "point-to-mesh max"),
    ("normal_mse", "normal MSE (Eq. 5.10)"),
    ("distance_mean", "distance to clean point, mean"),
    ("distance_max", "distance to clean point, max"),
    ("drift_share", "tangential drift > l, share"),
)


def _print_measures(before: dict, after: dict) -> None:
    from rich.table import Table

    table = Table(title="against --clean")
    table.add_column("measure")
    table.add_column("input", justify="right")
    table.add_column("denoised", justify="right")
    for key, label in MEASURE_ROWS:
        a, b = before[key], after[key]
        if isinstance(a, float) and math.isnan(a):
            continue
        table.add_row(label, f"{a:.4g}", f"{b:.4g}")
    console.print(table)


_MethodOption = Annotated[
    str,
    typer.Option(
        "--method",
        help="normal-voting, normal-voting-adaptive, flatness or auto (normal-voting; "
        "normals are estimated when IN has none).",
    ),
]
_NIterOption = Annotated[
    int | None,
    typer.Option(
        "--n-iter",
        help="Rounds (voting; default: until the points settle, at most 4) or "
        "iterations (flatness; default: until the points moved about the noise, at most 60).",
    ),
]
_CleanOption = Annotated[
    Path | None,
    typer.Option("--clean", help="Clean mesh (or point set): print and record the measures."),
]
_RenderOption = Annotated[
    Path | None, typer.Option("--render", help="Also write a PNG: input beside result.")
]
_PlanesOption = Annotated[
    bool | None,
    typer.Option(
        "--planes/--no-planes",
        help="Normal voting: points on planar pieces of 150+ points take the piece's "
        "plane (normal and position). Default: on, off with --tile-size (global step).",
    ),
]
_ReportOption = Annotated[
    Path | None,
    typer.Option("--report", help="Also write an HTML report with a 3-D view of input and result."),
]


@app.command("denoise")
@guarded
def denoise_command(
    input_path: InputArgument,
    output: Annotated[
        Path,
        typer.Argument(
            metavar="OUT", help="Denoised point set (.ply, .las, .laz), every input field kept."
        ),
    ],
    method: _MethodOption = "auto",
    rho: Annotated[float, typer.Option("--rho", help="Normal voting: cut-off on n_i . n_j.")] = 0.9,
    tau: Annotated[
        float,
        typer.Option("--tau", help="Normal voting: eigenvalue threshold (and feature classes)."),
    ] = 0.3,
    n_iter: _NIterOption = None,
    n_filter_iter: Annotated[
        int | None,
        typer.Option(
            "--filter-iter",
            help="Normal voting: filter steps per round (default: 1 when the normals are "
            "estimated, 5 when IN has them).",
        ),
    ] = None,
    max_step: Annotated[
        float, typer.Option("--max-step", help="Normal voting: largest move per iteration, in l.")
    ] = 0.5,
    k: Annotated[
        int, typer.Option("--k", help="Flatness: neighbours, the point itself included.")
    ] = 28,
    eta: Annotated[
        float,
        typer.Option("--plane-weight", help="Flatness: weight of the plane term (eta of Eq. 6.3)."),
    ] = 1.0,
    eps: Annotated[float, typer.Option("--eps", help="Flatness: step scale.")] = 0.1,
    schedule: Annotated[
        str, typer.Option("--schedule", help="Flatness: constant or decreasing (large k first).")
    ] = "constant",
    k_start: Annotated[
        int | None, typer.Option("--k-start", help="Flatness, decreasing: first k (default 4 k).")
    ] = None,
    clean: _CleanOption = None,
    estimate: EstimateNormalsOption = None,
    normal_k: NormalKOption = 20,
    render: _RenderOption = None,
    report: _ReportOption = None,
    planes: _PlanesOption = None,
    tile_size: TileSizeOption = None,
    halo: HaloOption = None,
    workers: WorkersOption = None,
    scheduler: SchedulerOption = None,
    max_memory: MaxMemoryOption = None,
    old_eta: Annotated[float | None, deprecated_option("--eta", "--plane-weight")] = None,
):
    """Denoise a point set: normal voting with adaptive k (thesis 5.4) or flatness (Eq. 6.3).

    Writes OUT (moved points, filtered normals, every input field, plus
    ``displacement``, ``feature_class``, ``denoise_k`` and, for flatness, ``flatness``)
    and, last, OUT_denoise.json (parameters, timings, measures, files with SHA-256).
    """

    eta = renamed_flag("--plane-weight", eta, "--eta", old_eta)
    options = DenoiseOptions(
        method=method,
        rho=rho,
        tau=tau,
        n_iter=n_iter,
        n_filter_iter=n_filter_iter,
        max_step=max_step,
        k=k,
        eta=eta,
        eps=eps,
        schedule=schedule,
        k_start=k_start,
        clean=clean,
        estimate_normals=estimate,
        normal_k=normal_k,
        render=render,
        report=report,
        planes=planes,
    )
    tiles = tile_options(
        tile_size, halo, workers, scheduler, max_memory, clean=clean, render=render
    )
    result = run_denoise(input_path, output, options, tiles=tiles)
    if not result.tiled:
        _print_denoise(result, clean is not None)


def _print_denoise(result, measured: bool) -> None:
    """The console lines of ``denoise``: the headline, the measures against --clean,
    the files written."""
    summary = result.summary
    spacing = summary["spacing"]
    console.print(
        f"{summary['method']}: {summary['n_points']:,} points, {summary['n_iter']} "
        f"iterations, mean move {summary['displacement_mean'] / spacing if spacing else 0:.2f} l "
        f"({result.seconds:.2f} s)"
    )
    if measured:
        _print_measures(summary["measures_input"], summary["measures_denoised"])
    for path in result.written:
        say(f"wrote {path}")
