"""Core commands: ``normals``, ``demo`` (``info``, ``render``, ``data``: own modules).

Conventions (docs/decisions/cli.md): user errors print one red line and exit
1, usage errors exit 2 (typer); outputs are written atomically; angles on the
command line are degrees (``--*-deg``); long steps show a progress bar on a
terminal.
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer
from rich.markup import escape
from rich.table import Table

from .._core import PointAtlasError, PointSet
from ._app import (
    DEMO_STEPS,
    HaloOption,
    MaxMemoryOption,
    ReportOption,
    SchedulerOption,
    TileSizeOption,
    WorkersOption,
    app,
    console,
    demo_step,
    guarded,
    say,
    tile_options,
)
from .jobs import (
    NormalsOptions,
    info_file,
    info_table,
    normals_files,
    picture_file,
    run_demo_steps,
    run_normals,
)

__all__ = ["DEMO_STEPS", "demo_command", "normals_command", "run_demo", "select_steps", "step_name"]

#: Model used by ``pointatlas demo``.
DEMO_MODEL = "fandisk"


# --------------------------------------------------------------------------- normals


@app.command("normals")
@guarded
def normals_command(
    in_path: Annotated[Path, typer.Argument(metavar="IN", help="Input point set or mesh.")],
    out_path: Annotated[
        Path, typer.Argument(metavar="OUT", help="Output .ply (or .xyz/.las/.laz).")
    ],
    k: Annotated[
        int, typer.Option("--k", help="PCA neighbourhood size (point itself included).")
    ] = 20,
    orient: Annotated[
        str,
        typer.Option(
            "--orient",
            help="Orientation: mst, outward, viewpoint, up (nz >= 0 per point, the lidar "
            "convention) or none.",
        ),
    ] = "mst",
    orient_k: Annotated[
        int, typer.Option("--orient-k", help="k of the orientation graph (capped at N).")
    ] = 10,
    viewpoint: Annotated[
        tuple[float, float, float] | None,
        typer.Option("--viewpoint", help="Sensor position X Y Z for --orient viewpoint."),
    ] = None,
    report: ReportOption = None,
    tile_size: TileSizeOption = None,
    halo: HaloOption = None,
    workers: WorkersOption = None,
    scheduler: SchedulerOption = None,
    max_memory: MaxMemoryOption = None,
):
    """Estimate (PCA) and orient normals; write the points with them.

    Every input field is kept; normals stored in the input are kept as the field
    ``input_normals`` and compared with the new ones (angle error, flipped
    fraction).
    """
    options = NormalsOptions(
        k=k, orient=orient, orient_k=orient_k, viewpoint=viewpoint, report=report
    )
    tiles = tile_options(tile_size, halo, workers, scheduler, max_memory)
    result = run_normals(in_path, out_path, options, tiles=tiles)
    if result.tiled is None:
        _print_normals(in_path, options, result)


def _print_normals(in_path: Path, options: NormalsOptions, result) -> None:
    """The table of ``normals`` (points, settings, time, the comparison with IN's
    normals), then the files written."""
    table = Table(
        title=f"normals of {escape(in_path.name)}", show_header=False, title_justify="left"
    )
    table.add_column("property", style="bold")
    table.add_column("value")
    table.add_row("points", f"{result.n_points:,}")
    table.add_row("k / orientation", f"{options.k} / {options.orient}")
    table.add_row("time", f"{result.seconds:.2f} s")
    stats = result.stats
    if stats is not None:
        table.add_row(
            "mean angle error vs input normals", f"{stats['mean_angle_error_deg']:.2f} deg"
        )
        table.add_row("  ignoring sign", f"{stats['mean_unoriented_error_deg']:.2f} deg")
        table.add_row("flipped fraction", f"{stats['flipped_fraction']:.4f}")
    console.print(table)
    for path in result.written:
        say(f"wrote {path}")


# --------------------------------------------------------------------------- render


# --------------------------------------------------------------------------- data


# --------------------------------------------------------------------------- demo


@demo_step
def demo_info(ps: PointSet, out_dir: Path, console) -> None:
    """The model: size, bounding box, spacing, k-NN components."""
    info = info_file(ps, out_dir)
    console.print(info_table(info, title=f"{escape(ps.name)} (bundled)"))


@demo_step
def demo_normals(ps: PointSet, out_dir: Path, console) -> PointSet:
    """Normals: PCA estimate (k = 20), MST orientation, compared with the mesh normals."""
    stats, error, seconds, path = normals_files(ps, out_dir)
    table = Table(show_header=False)
    table.add_column("property", style="bold")
    table.add_column("value")
    table.add_row("time", f"{seconds:.2f} s")
    table.add_row("mean angle error", f"{stats['mean_angle_error_deg']:.2f} deg")
    table.add_row("median angle error", f"{stats['median_angle_error_deg']:.2f} deg")
    table.add_row("mean error ignoring sign", f"{stats['mean_unoriented_error_deg']:.2f} deg")
    table.add_row("flipped fraction", f"{stats['flipped_fraction']:.4f}")
    table.add_row("written", escape(str(path)))
    console.print(table)
    return ps.with_attributes(normal_error_deg=error)


@demo_step
def demo_picture(ps: PointSet, out_dir: Path, console) -> None:
    """Picture: the model and the normal error of the PCA estimate."""
    path = picture_file(ps, out_dir)
    console.print(f"picture: {escape(str(path))}")


def step_name(step) -> str:
    """Short name of a demo step: its function name without a ``demo_`` prefix."""
    name = step.__name__
    return name[5:] if name.startswith("demo_") else name


def select_steps(only: str | None) -> list:
    """The demo steps to run: all, or those named in a comma-separated ``only``."""
    if only is None:
        return list(DEMO_STEPS)
    wanted = [w.strip() for w in only.split(",") if w.strip()]
    known = [step_name(s) for s in DEMO_STEPS]
    unknown = [w for w in wanted if w not in known]
    if unknown or not wanted:
        raise PointAtlasError(
            f"--only: unknown step(s) {', '.join(unknown) or '(none given)'}; steps: "
            + ", ".join(known)
        )
    return [s for s in DEMO_STEPS if step_name(s) in wanted]


def run_demo(out_dir: Path, *, model: str = DEMO_MODEL, steps=None) -> list[Path]:
    """Run the demo steps (all registered: `DEMO_STEPS`, or ``steps``) on a bundled
    model (`pointatlas.cli.jobs.run_demo_steps`); returns the files written."""
    return run_demo_steps(out_dir, DEMO_STEPS if steps is None else steps, model=model)


@app.command("demo")
@guarded
def demo_command(
    out: Annotated[Path, typer.Option("--out", help="Folder for the outputs.")] = Path(
        "pointatlas-demo"
    ),
    model: Annotated[str, typer.Option("--model", help="Bundled model to use.")] = DEMO_MODEL,
    only: Annotated[
        str | None,
        typer.Option(
            "--only", help="Comma-separated steps to run (default: all), e.g. info,normals."
        ),
    ] = None,
):
    """Run the tour on a bundled model (fandisk): info, normals, pictures, ..."""
    written = run_demo(out, model=model, steps=select_steps(only))
    console.rule("[bold]outputs", align="left")
    for path in written:
        say(f"  {path}")
    say(f"all outputs are in {out.resolve()}")
