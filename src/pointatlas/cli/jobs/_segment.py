"""The job of ``pointatlas segment``: VSA (thesis 4.2-4.3) or region growing.

Writes the input points with a ``label`` field and colours, a per-region table
(CSV and JSON beside the output) and optionally a picture and an HTML report.
"""

from __future__ import annotations

import csv
import io
import math
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..._core import PointAtlasError
from ...io import to_json_safe
from ...segment import VSAOptions, region_growing, vsa_segment
from .._flag_checks import normal_k_counts, vsa_counts
from .._outputs import (
    check_outputs,
    check_point_output,
    point_fields,
    write_point_output,
    write_summary_json,
)
from .._reports import REPORT_EXTENSIONS, report_layer, report_summary, report_up
from ._inputs import read_with_normals
from ._tiled import normal_job_for, run_tiled, segment_job, segment_side_files

__all__ = [
    "SegmentOptions",
    "SegmentResult",
    "region_table",
    "run_segment",
    "segment_point_set",
    "table_paths",
]


@dataclass(frozen=True)
class SegmentOptions:
    """The settings of ``pointatlas segment`` (the flags of the same names).

    ``vsa``: the VSA settings (`VSAOptions`, ``min_region_size`` resolved; region
    growing uses its ``k``); ``method``: "vsa" or "region-growing"; region growing's
    ``smoothness_deg``, ``curvature_threshold``, ``min_cluster_size``; normals when
    IN has none (``estimate_normals``, ``normal_k``: `read_with_normals`); ``seed`` of
    VSA's random seeds; ``render`` (PNG) and ``report`` (HTML) paths; ``parameters``:
    the settings as typed, listed by the report.
    """

    vsa: VSAOptions = field(default_factory=VSAOptions)
    method: str = "vsa"
    smoothness_deg: float = 15.0
    curvature_threshold: float | None = None
    min_cluster_size: int = 1
    estimate_normals: bool | None = None
    normal_k: int = 20
    seed: int = 0
    render: Path | None = None
    report: Path | None = None
    parameters: dict = field(default_factory=dict)


@dataclass(frozen=True)
class SegmentResult:
    """What `run_segment` did: the summary (OUT_regions.json's; by tiles the tiled
    run's) and the files written (OUT_regions.json last)."""

    summary: dict
    written: list
    tiled: bool = False


def run_segment(in_path, out_path, options: SegmentOptions, tiles=None) -> SegmentResult:
    """``pointatlas segment``: IN read with normals (estimated when missing),
    segmented, written to OUT with ``label`` and colours beside every input field,
    with OUT_regions.csv, the picture, the report and, last, OUT_regions.json; by
    tiles when ``tiles`` (a `pointatlas.batch.TileOptions`) is given."""
    o = options
    json_path = _check_segment_outputs(in_path, out_path, o.render, o.report)
    if tiles is not None:
        return SegmentResult(_segment_tiled(in_path, out_path, o, tiles), [], tiled=True)
    t0 = time.perf_counter()
    ps = _read_segment_input(
        in_path, out_path, estimate=o.estimate_normals, normal_k=o.normal_k, options=o.vsa
    )
    res, summary = segment_point_set(
        ps.points,
        ps.normals,
        method=o.method,
        options=o.vsa,
        smoothness_deg=o.smoothness_deg,
        curvature_threshold=o.curvature_threshold,
        min_cluster_size=o.min_cluster_size,
        seed=o.seed,
    )
    summary.update(
        {
            "input": str(in_path),
            "n_points": int(ps.n_points),
            "k": o.vsa.k,
            "seed": o.seed,
            "seconds": round(time.perf_counter() - t0, 3),
        }
    )
    labels = np.asarray(res.labels)
    written, payload = _write_segment_files(out_path, ps, res, summary, render=o.render)
    if o.report is not None:
        written.append(
            _write_segment_report(
                o.report, in_path, ps, labels, payload, o.parameters, o.seed, render=o.render
            )
        )
    write_summary_json(json_path, payload, written)
    return SegmentResult(summary, [*written, json_path])


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
    from ...io import atomic_write

    csv_path, _ = table_paths(output)
    buf = io.StringIO()
    fields = list(rows[0]) if rows else ["region", "n_points"]
    writer = csv.DictWriter(buf, fieldnames=fields, lineterminator="\n")
    writer.writeheader()
    writer.writerows(rows)
    with atomic_write(csv_path, "w") as fh:
        fh.write(buf.getvalue())
    return csv_path, to_json_safe(rows)


def _check_segment_outputs(input_path: Path, output: Path, render, report) -> Path:
    """Refuse unusable outputs of ``segment`` before any work; returns OUT_regions.json."""
    from ...io import POINT_WRITE_EXTENSIONS

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


def _segment_tiled(input_path, output, options: SegmentOptions, tiles) -> dict:
    """``segment`` on tiles (`pointatlas.batch`): the command's `VSAOptions`, its
    normal settings, ``--report`` read back from OUT."""
    from ...viz import label_colors

    job = segment_job(
        method=options.method,
        options=options.vsa,
        label_colors=lambda lab: (label_colors(lab) * 255).round().astype(np.uint8),
    )
    normals = normal_job_for(input_path, options.estimate_normals, options.normal_k)
    return run_tiled(
        "segment",
        job,
        input_path,
        output,
        tiles,
        normals=normals,
        side_files=segment_side_files,
        report=options.report,
        parameters=job.vsa,
        color_by="label",
        # --k, --seeds (and --normal-k when normals are estimated) against the input
        checks=(
            vsa_counts(options.vsa),
            None if normals is None else normal_k_counts(options.normal_k),
        ),
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
    from ...viz import label_colors

    labels = np.asarray(res.labels)
    colors = (label_colors(labels) * 255).round().astype(np.uint8)
    fields = point_fields(ps, {"label": labels, "colors": colors})
    summary["fields"] = list(fields)
    written = [write_point_output(output, ps, {"label": labels, "colors": colors})]
    csv_path, json_rows = _write_tables(output, region_table(res))
    written.append(csv_path)
    if render is not None:
        from ...viz import render_points

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
    from ...viz import write_report

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
