"""``pointatlas segment``: VSA (thesis 4.2-4.3) or region growing; demo step.

Writes the input points with a ``label`` field and colours, a per-region table
(CSV and JSON beside the output) and optionally a picture.
"""

from __future__ import annotations

import csv
import io
import math
import time
from pathlib import Path
from typing import Annotated

import numpy as np
import typer

from .._core import PointAtlasError, as_int
from ..io import to_json_safe
from ..segment import VSAOptions, region_growing, vsa_segment
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
    read_with_normals,
    run_tiled,
    say,
    tile_options,
    vsa_options,
)
from ._flag_checks import vsa_counts
from ._outputs import (
    check_outputs,
    check_point_output,
    point_fields,
    write_point_output,
    write_summary_json,
)
from ._reports import REPORT_EXTENSIONS, report_layer, report_summary, report_up
from .jobs import normal_job_for, segment_job, segment_side_files

__all__ = ["region_table", "segment_command", "segment_point_set", "table_paths"]

#: ``--min-region-size``: `VSAOptions.min_region_size`; None: k (the command's default).
MinRegionSizeOption = Annotated[
    int | None,
    typer.Option(
        "--min-region-size",
        help="VSA: regions with fewer points join the neighbour that fits them best "
        "(default k; 0 or 1: off).",
    ),
]


def segment_point_set(
    points,
    normals,
    *,
    method: str = "vsa",
    options: VSAOptions | None = None,
    smoothness_deg: float = 15.0,
    curvature_threshold: float | None = None,
    min_cluster_size: int = 1,
    seed: int = 0,
):
    """Run the chosen method; returns (result, summary dict).

    ``options`` holds the VSA settings (default ``VSAOptions()``); region growing
    uses their ``k``; ``seed`` draws VSA's random seeds.
    """
    opts = VSAOptions() if options is None else options
    if method == "vsa":
        res = vsa_segment(points, normals, options=opts, rng=seed)
        summary = {
            "method": "vsa",
            "n_regions": res.n_regions,
            "energy": res.energy,
            "mse": res.mse,
            "n_iter": res.n_iter,
            "converged": res.converged,
            "stop_reason": res.stop_reason,
            "min_region_size": opts.min_region_size,
            "assigned_fraction": 1.0,
        }
        return res, summary
    if method == "region-growing":
        res = region_growing(
            points,
            normals,
            k=opts.k,
            smoothness_angle=math.radians(smoothness_deg),
            curvature_threshold=curvature_threshold,
            min_cluster_size=min_cluster_size,
        )
        summary = {
            "method": "region-growing",
            "n_regions": res.n_regions,
            "mse": res.mse,
            "assigned_fraction": res.assigned_fraction,
            "n_degenerate": res.n_degenerate,
        }
        return res, summary
    raise PointAtlasError(f"--method must be vsa or region-growing; got {method!r}")


def region_table(res) -> list[dict]:
    """One row per region: id, size, proxy normal, centroid, L21 (and seed for VSA)."""
    rows = []
    seeds = getattr(res, "seed_indices", None)
    for r in range(res.n_regions):
        row = {
            "region": r,
            "n_points": int(res.region_counts[r]),
            "l21": float(res.region_l21[r]),
            "nx": float(res.proxy_normals[r, 0]),
            "ny": float(res.proxy_normals[r, 1]),
            "nz": float(res.proxy_normals[r, 2]),
            "cx": float(res.centroids[r, 0]),
            "cy": float(res.centroids[r, 1]),
            "cz": float(res.centroids[r, 2]),
        }
        if seeds is not None:
            row["seed_index"] = int(seeds[r])
        rows.append(row)
    return rows


def table_paths(output: Path) -> tuple[Path, Path]:
    """``OUT_regions.csv`` and ``OUT_regions.json`` beside ``OUT``."""
    stem = output.with_suffix("")
    return Path(f"{stem}_regions.csv"), Path(f"{stem}_regions.json")


def _write_tables(output: Path, rows: list[dict]) -> tuple[Path, dict]:
    """Write the per-region CSV; returns its path and the JSON-ready rows."""
    from ..io import atomic_write

    csv_path, _ = table_paths(output)
    buf = io.StringIO()
    fields = list(rows[0]) if rows else ["region", "n_points"]
    writer = csv.DictWriter(buf, fieldnames=fields, lineterminator="\n")
    writer.writeheader()
    writer.writerows(rows)
    with atomic_write(csv_path, "w") as fh:
        fh.write(buf.getvalue())
    return csv_path, to_json_safe(rows)


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
    json_path = _check_segment_outputs(input_path, output, render, report)
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
    tiles = tile_options(tile_size, halo, workers, scheduler, max_memory, render=render)
    if tiles is not None:
        _segment_tiled(input_path, output, parameters, options, tiles, report)
        return
    t0 = time.perf_counter()
    ps = _read_segment_input(
        input_path, output, estimate=estimate, normal_k=normal_k, options=options
    )
    res, summary = segment_point_set(
        ps.points,
        ps.normals,
        method=method,
        options=options,
        smoothness_deg=smoothness_deg,
        curvature_threshold=curvature_threshold,
        min_cluster_size=min_cluster_size,
        seed=seed,
    )
    summary.update(
        {
            "input": str(input_path),
            "n_points": int(ps.n_points),
            "k": k,
            "seed": seed,
            "seconds": round(time.perf_counter() - t0, 3),
        }
    )
    labels = np.asarray(res.labels)
    written, payload = _write_segment_files(output, ps, res, summary, render=render)
    if report is not None:
        written.append(
            _write_segment_report(
                report, input_path, ps, labels, payload, parameters, seed, render=render
            )
        )
    write_summary_json(json_path, payload, written)
    _print_segment(summary, [*written, json_path])


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


def _check_segment_outputs(input_path: Path, output: Path, render, report) -> Path:
    """Refuse unusable outputs of ``segment`` before any work; returns OUT_regions.json."""
    from ..io import POINT_WRITE_EXTENSIONS

    csv_path, json_path = table_paths(output)
    check_outputs(
        [input_path],
        [
            ("OUT", output, POINT_WRITE_EXTENSIONS),
            ("OUT's region table", csv_path, None),
            ("OUT's summary", json_path, None),
            ("--render", render, (".png",)),
            ("--report", report, REPORT_EXTENSIONS),
        ],
    )
    return json_path


def _segment_tiled(
    input_path: Path, output: Path, parameters: dict, options, tiles, report
) -> None:
    """``segment`` on tiles (`pointatlas.batch`): the command's `VSAOptions`, its
    normal settings from ``parameters``, ``--report`` read back from OUT."""
    from ..viz import label_colors

    job = segment_job(
        method=parameters["method"],
        options=options,
        label_colors=lambda lab: (label_colors(lab) * 255).round().astype(np.uint8),
    )
    normals = normal_job_for(input_path, parameters["estimate_normals"], parameters["normal_k"])
    run_tiled(
        "segment",
        job,
        input_path,
        output,
        tiles,
        normals=normals,
        side_files=segment_side_files,
        report=report,
        parameters=job.vsa,
        color_by="label",
    )


def _read_segment_input(input_path: Path, output: Path, *, estimate, normal_k: int, options):
    """Read IN with normals and check that OUT can hold its fields plus ``label`` and
    colours; ``--k`` and ``--seeds`` are checked against its points before normals
    are estimated."""
    ps = read_with_normals(
        input_path,
        estimate=estimate,
        normal_k=normal_k,
        min_points=2,
        what="segment",
        check=vsa_counts(options),
    )
    n = ps.n_points
    placeholder = {"label": np.zeros(n, np.int64), "colors": np.zeros((n, 3), np.uint8)}
    check_point_output(output, ps, placeholder)
    return ps


def _write_segment_files(output: Path, ps, res, summary: dict, *, render):
    """Write OUT, OUT_regions.csv and the ``--render`` picture.

    Returns the paths written and the JSON payload (summary and region rows); adds
    the names of OUT's new fields to ``summary``.
    """
    from ..viz import label_colors

    labels = np.asarray(res.labels)
    colors = (label_colors(labels) * 255).round().astype(np.uint8)
    fields = point_fields(ps, {"label": labels, "colors": colors})
    summary["fields"] = list(fields)
    written = [write_point_output(output, ps, {"label": labels, "colors": colors})]
    csv_path, json_rows = _write_tables(output, region_table(res))
    written.append(csv_path)
    if render is not None:
        from ..viz import render_points

        written.append(
            render_points(
                render,
                ps.points,
                normals=ps.normals,
                labels=labels,
                title=f"{ps.name}: {summary['method']}, {summary['n_regions']} regions",
            )
        )
    payload = {
        "summary": to_json_safe(summary),
        "regions": json_rows,
    }
    return written, payload


def _write_segment_report(
    report: Path, input_path, ps, labels, payload: dict, parameters: dict, seed: int, *, render
) -> Path:
    """``segment --report``: the summary, the region table and the points coloured by label."""
    from ..viz import write_report

    return write_report(
        report,
        title=f"pointatlas segment: {Path(input_path).name}",
        summary=report_summary(input_path, ps),
        parameters=parameters,
        seed=seed,
        tables={"result": payload["summary"], "regions": payload["regions"]},
        pictures=[render] if render is not None else [],
        layers=[report_layer(ps, {"label": labels}, color_by="label")],
        up=report_up(input_path),
    )


def _print_segment(summary: dict, written) -> None:
    """The console lines of ``segment``: the headline numbers, then the files written."""
    console.print(
        f"{summary['method']}: {summary['n_regions']} regions on {summary['n_points']:,} "
        f"points, MSE {summary['mse']:.3e}, assigned {summary['assigned_fraction']:.1%} "
        f"({summary['seconds']:.1f} s)"
    )
    for path in written:
        say(f"wrote {path}")


@demo_step
def demo_segment(ps, out_dir, console):
    """Segmentation: VSA from every point with split and merge (eta = 25)."""
    from ..io import write_point_set
    from ..viz import label_colors, render_points

    res = vsa_segment(ps.points, ps.normals, k=8, eta=25.0)
    colors = (label_colors(res.labels) * 255).round().astype(np.uint8)
    write_point_set(
        out_dir / f"{ps.name}_segments.ply",
        ps.points,
        normals=ps.normals,
        attributes={"label": np.asarray(res.labels)},
        colors=colors,
    )
    path = render_points(
        out_dir / f"{ps.name}_segments.png",
        ps.points,
        normals=ps.normals,
        labels=res.labels,
        title=f"{ps.name}: VSA, eta = 25, {res.n_regions} regions",
    )
    console.print(
        f"VSA: {res.n_regions} regions, MSE {res.mse:.3e}, {res.n_iter} iterations "
        f"({res.stop_reason}); picture: {path}"
    )
    return ps.with_attributes(segment_label=np.asarray(res.labels))
