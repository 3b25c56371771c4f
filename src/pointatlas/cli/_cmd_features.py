"""``pointatlas features``: its flags as `FeaturesOptions` for the job
(`pointatlas.cli.jobs.run_features`: eigen-features, optimal neighbourhoods, thesis
5.2-5.4 and 6.1-6.2), what it prints, and the demo step."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import numpy as np
import typer

from ..features import (
    REASON_CODES,
)
from ._app import (
    HaloOption,
    InputArgument,
    MaxMemoryOption,
    ReportOption,
    SchedulerOption,
    TileSizeOption,
    WorkersOption,
    app,
    console,
    demo_step,
    deprecated_option,
    guarded,
    renamed_flag,
    say,
    tile_options,
)
from .jobs import FeaturesOptions, features_files, reason_counts, run_features

__all__ = ["demo_features", "features_command"]


def _print_features(input_path, run) -> None:
    """The console lines of ``features``: size, mode, means, degenerate points, the
    files written."""
    result, mode, elapsed = run.result, run.mode, run.seconds
    n = result.n_points
    say(f"{input_path.name}: {n} points, {mode} ({elapsed:.2f} s)")
    ok = result.is_valid
    if ok.any():
        console.print(
            f"  E_dim mean {np.mean(result.e_dim[ok]):.4f}, flatness mean "
            f"{np.mean(result.flatness[ok]):.4f}"
        )
    for code, count in reason_counts(result):
        console.print(f"  {count} point(s) degenerate: {REASON_CODES[code]} (NaN)")
    say(f"  wrote {run.written}")
    for path in run.pictures:
        say(f"  wrote {path}")
    if run.report is not None:
        say(f"  wrote {run.report}")


#: ``--render PATH.png`` (Fig. 5.3; the other pictures beside it, `feature_picture_paths`)
_RenderOption = Annotated[
    Path | None,
    typer.Option(
        "--render",
        help="PNG of Fig. 5.3; Figs. 6.2/6.5 and the flatness go beside it "
        "(<stem>_fig6_5.png, <stem>_flatness.png).",
    ),
]
_RenderSizeOption = Annotated[
    int, typer.Option("--render-size", min=64, help="Pixels per picture panel.")
]
_NormalsOption = Annotated[
    bool,
    typer.Option(
        "--estimate-normals",
        help="Also estimate PCA normals at --k (default 14), oriented by --orient, from the "
        "same k-NN table as the features (equal weights); written as nx, ny, nz.",
    ),
]
#: ``--orient`` of ``--estimate-normals`` (`NORMALS_ORIENT`; docs/decisions/batch.md, "Tiles —
#: normals and features in one pass")
_OrientOption = Annotated[
    str | None,
    typer.Option(
        "--orient",
        help="With --estimate-normals: mst (default; Hoppe's propagation, as `normals`) or up "
        "(nz >= 0 per point, the lidar convention; by tiles no stitching, cheaper).",
    ),
]


@app.command("features")
@guarded
def features_command(
    input_path: InputArgument,
    output: Annotated[
        Path, typer.Argument(metavar="OUT", help="Output point file (.ply, .las, .laz).")
    ],
    k: Annotated[
        int | None, typer.Option("--k", help="Fixed neighbourhood size (default 14).", min=3)
    ] = None,
    k_range: Annotated[
        tuple[int, int] | None,
        typer.Option("--k-range", help="Search k in KMIN..KMAX (thesis: 6 20)."),
    ] = None,
    weights: Annotated[
        str,
        typer.Option(
            "--weighting",
            help="sigmoid: search the (a, b) grid on normal angles (Eq. 5.9); equal: "
            "unweighted; auto: sigmoid when the input has normals.",
        ),
    ] = "auto",
    a_grid: Annotated[
        str | None,
        typer.Option("--a-grid-deg", help="a values in degrees, e.g. 0,30,60."),
    ] = None,
    b_grid: Annotated[
        str | None,
        typer.Option("--b-grid-deg", help="b values in degrees (default as a)."),
    ] = None,
    flatness: Annotated[
        tuple[int, int], typer.Option("--flatness", help="Even exponents M1 M2 of Eq. 6.1.")
    ] = (8, 8),
    criterion: Annotated[
        str,
        typer.Option("--criterion", help="Equal-weight k search: e_dim or eigenentropy."),
    ] = "e_dim",
    estimate_normals: _NormalsOption = False,
    orient: _OrientOption = None,
    render: _RenderOption = None,
    render_size: _RenderSizeOption = 800,
    report: ReportOption = None,
    tile_size: TileSizeOption = None,
    halo: HaloOption = None,
    workers: WorkersOption = None,
    scheduler: SchedulerOption = None,
    max_memory: MaxMemoryOption = None,
    old_weights: Annotated[str | None, deprecated_option("--weights", "--weighting")] = None,
    old_normals: Annotated[bool, deprecated_option("--normals", "--estimate-normals")] = False,
) -> None:
    """Eigen-features per point (linearity ... flatness) with the optimal neighbourhood.

    Writes OUT with every input field kept and the features added (a feature whose
    name the input already uses gets the prefix ``pa_``); with ``--report`` also an
    HTML report with per-field statistics and a 3-D view. ``--estimate-normals`` does the work
    of ``normals --k K --orient O`` then ``features --k K --weighting equal`` in one pass
    (one k-NN query); the input's normals are kept as ``input_normals``.
    """

    weights = renamed_flag("--weighting", weights, "--weights", old_weights)
    estimate_normals = renamed_flag(
        "--estimate-normals", estimate_normals, "--normals", old_normals
    )
    options = FeaturesOptions(
        k=k,
        k_range=k_range,
        weights=weights,
        a_grid=a_grid,
        b_grid=b_grid,
        flatness=flatness,
        criterion=criterion,
        estimate_normals=estimate_normals,
        orient=orient,
        render=render,
        render_size=render_size,
        report=report,
    )
    tiles = tile_options(tile_size, halo, workers, scheduler, max_memory, render=render)
    result = run_features(input_path, output, options, tiles=tiles)
    if result.tiled is None:
        _print_features(input_path, result)


@demo_step
def demo_features(ps, out_dir: Path, console) -> None:
    """Features: optimal normal-weighted neighbourhoods and the fandisk classification."""
    from rich.table import Table

    stats, seconds = features_files(ps, out_dir)
    table = Table(title=f"Fig. 5.3 on {ps.name} ({seconds:.1f} s)")
    for col in ("weights", "mean E_dim", "degenerate", "linear / planar / scattered"):
        table.add_column(col)
    for title, s in stats.items():
        table.add_row(
            title,
            f"{s['mean_e_dim']:.4f}",
            str(s["n_degenerate"]),
            " / ".join(str(c) for c in s["classes"]),
        )
    console.print(table)
