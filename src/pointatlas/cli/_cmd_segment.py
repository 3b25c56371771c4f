"""``pointatlas segment``: its flags as `SegmentOptions` for the job
(`pointatlas.cli.jobs.run_segment`: VSA, thesis 4.2-4.3, or region growing); the
demo step."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import numpy as np
import typer

from .._core import PointAtlasError, as_int
from ._app import (
    ClassicOption,
    EstimateNormalsOption,
    EtaOption,
    HaloOption,
    InputArgument,
    LocalOption,
    MaxAngleDegOption,
    MaxIterOption,
    MaxMemoryOption,
    MergeOption,
    NormalKOption,
    ReportOption,
    SchedulerOption,
    SeedsOption,
    SplitOption,
    SwitchOption,
    TileSizeOption,
    VSAKOption,
    VSASeedOption,
    WeightsOption,
    WorkersOption,
    angle_deg_option,
    app,
    console,
    demo_step,
    guarded,
    say,
    tile_options,
    vsa_options,
)
from .jobs import SegmentOptions, run_segment, segment_files

__all__ = ["demo_segment", "segment_command"]

#: ``--min-region-size``: `VSAOptions.min_region_size`; None: k (the command's default).
MinRegionSizeOption = Annotated[
    int | None,
    typer.Option(
        "--min-region-size",
        help="VSA: regions with fewer points join the neighbour that fits them best "
        "(default k; 0 or 1: off).",
    ),
]


@app.command("segment")
@guarded
def segment_command(
    input_path: InputArgument,
    output: Annotated[
        Path,
        typer.Argument(
            metavar="OUT", help="Labelled point set (.ply, .las, .laz), every input field kept."
        ),
    ],
    eta: EtaOption = None,
    max_angle_deg: MaxAngleDegOption = None,
    seeds: SeedsOption = "all",
    k: VSAKOption = 8,
    split: SplitOption = True,
    merge: MergeOption = True,
    switch: SwitchOption = "batch",
    classic: ClassicOption = False,
    max_iter: MaxIterOption = 1000,
    local: LocalOption = False,
    min_region_size: MinRegionSizeOption = None,
    method: Annotated[str, typer.Option("--method", help="vsa or region-growing.")] = "vsa",
    weights: WeightsOption = "uniform",
    smoothness_deg: Annotated[
        float, typer.Option("--smoothness-deg", help="Region growing: smoothness angle.")
    ] = 15.0,
    curvature_threshold: Annotated[
        float | None,
        typer.Option("--curvature-threshold", help="Region growing: seed curvature bound."),
    ] = None,
    min_cluster_size: Annotated[
        int, typer.Option("--min-cluster-size", help="Region growing: smallest region kept.")
    ] = 1,
    estimate: EstimateNormalsOption = None,
    normal_k: NormalKOption = 20,
    render: Annotated[
        Path | None, typer.Option("--render", help="Also write a PNG picture.")
    ] = None,
    report: ReportOption = None,
    seed: VSASeedOption = 0,
    tile_size: TileSizeOption = None,
    halo: HaloOption = None,
    workers: WorkersOption = None,
    scheduler: SchedulerOption = None,
    max_memory: MaxMemoryOption = None,
):
    """Segment a point set into flat regions (VSA, thesis 4.2-4.3) or by region growing.

    Writes OUT (the input points with every input field, plus ``label`` and label
    colours), OUT_regions.csv, with ``--report`` an HTML report with a 3-D view and,
    last, OUT_regions.json (summary, regions and the files of this run with their
    SHA-256).
    """
    parameters = {
        "method": method,
        "eta": eta,
        "max_angle_deg": max_angle_deg,
        "seeds": seeds,
        "k": k,
        "split": split,
        "merge": merge,
        "switch": switch,
        "classic": classic,
        "max_iter": max_iter,
        "local": local,
        "min_region_size": min_region_size,
        "weights": weights,
        "smoothness_deg": smoothness_deg,
        "curvature_threshold": curvature_threshold,
        "min_cluster_size": min_cluster_size,
        "estimate_normals": estimate,
        "normal_k": normal_k,
    }
    options = vsa_options(
        k=k,
        eta=eta,
        max_angle_deg=max_angle_deg,
        seeds=seeds,
        split=split,
        merge=merge,
        switch=switch,
        classic=classic,
        weights=weights,
        max_iter=max_iter,
        local=local,
    )
    if method not in ("vsa", "region-growing"):
        raise PointAtlasError(f"--method must be vsa or region-growing; got {method!r}")
    options = options.replace(min_region_size=_min_region_size(min_region_size, k, method))
    parameters["min_region_size"] = options.min_region_size
    angle_deg_option(smoothness_deg, "--smoothness-deg")
    job_options = SegmentOptions(
        vsa=options,
        method=method,
        smoothness_deg=smoothness_deg,
        curvature_threshold=curvature_threshold,
        min_cluster_size=min_cluster_size,
        estimate_normals=estimate,
        normal_k=normal_k,
        seed=seed,
        render=render,
        report=report,
        parameters=parameters,
    )
    tiles = tile_options(tile_size, halo, workers, scheduler, max_memory, render=render)
    result = run_segment(input_path, output, job_options, tiles=tiles)
    if not result.tiled:
        _print_segment(result.summary, result.written)


def _print_segment(summary: dict, written) -> None:
    """The console lines of ``segment``: the headline numbers, then the files written."""
    console.print(
        f"{summary['method']}: {summary['n_regions']} regions on {summary['n_points']:,} "
        f"points, MSE {summary['mse']:.3e}, assigned {summary['assigned_fraction']:.1%} "
        f"({summary['seconds']:.1f} s)"
    )
    for path in written:
        say(f"wrote {path}")


def _min_region_size(value, k: int, method: str) -> int:
    """``--min-region-size`` checked (None: k); refused with region growing, whose
    ``--min-cluster-size`` drops small regions instead."""
    if value is None:
        return k if method == "vsa" else 0
    if method != "vsa":
        raise PointAtlasError(
            "--min-region-size applies to --method vsa; region growing has --min-cluster-size"
        )
    return as_int(value, "--min-region-size", lo=0, note="0 or 1: off")


@demo_step
def demo_segment(ps, out_dir, console):
    """Segmentation: VSA from every point with split and merge (eta = 25)."""
    res, path = segment_files(ps, out_dir)
    console.print(
        f"VSA: {res.n_regions} regions, MSE {res.mse:.3e}, {res.n_iter} iterations "
        f"({res.stop_reason}); picture: {path}"
    )
    return ps.with_attributes(segment_label=np.asarray(res.labels))
