"""``pointatlas experiment vsa``: Table 4.1 and Fig. 4.5 of the thesis (4.3.4).

Per model (through `pointatlas.batch.run_batch`), scaled into the unit cube, mesh
vertex normals, k = 8, weights 1, four experiments:

- ``pcl``: region growing of Rabbani et al. (2006) (PCL's ``RegionGrowing``);
- ``no_sm``: VSA of [LB16] (classic loop) seeded with the region-growing region
  count, no split/merge;
- ``local_eta_sm``: every point a seed, split and merge with eta = the
  region-growing L21 divided by its region count;
- ``global_eta_sm``: every point a seed, split and merge with eta = 25.

The collection summary gives Table 4.1 (MSE and region count statistics), the
Fig. 4.5 histogram of region sizes and the number of failed models.
"""

from __future__ import annotations

import csv
import io
import json
import math
import time
from pathlib import Path
from typing import Annotated

import numpy as np
import typer

from .._core import PointAtlasError
from ..segment import region_growing, vsa_segment
from ._app import console, experiment_app, guarded, say
from ._outputs import check_outputs, write_text

__all__ = ["COLUMNS", "THESIS_TABLE_4_1", "aggregate_vsa", "vsa_command", "vsa_model"]

#: the four experiments of Table 4.1, in the thesis' order
COLUMNS = ("pcl", "no_sm", "local_eta_sm", "global_eta_sm")
COLUMN_TITLES = {
    "pcl": "PCL (region growing)",
    "no_sm": "not s/m",
    "local_eta_sm": "local eta s/m",
    "global_eta_sm": "global eta s/m",
}
#: thesis Table 4.1 (499 of 600 Thingi10K models)
THESIS_TABLE_4_1 = {
    "min MSE": (2.75e-09, 7.31e-07, 6.95e-11, 2.11e-06),
    "max MSE": (1.12e-01, 2.98e-02, 4.15e-02, 1.04e-02),
    "avg MSE": (1.59e-02, 2.88e-04, 6.40e-04, 4.50e-04),
    "sd MSE": (2.12e-02, 1.90e-03, 2.47e-03, 8.15e-04),
    "min m": (1.00, 1.00, 2.00, 1.00),
    "max m": (1103.00, 1103.00, 393.00, 135.00),
    "avg m": (174.17, 174.17, 55.05, 33.20),
    "sd m": (163.10, 163.10, 58.41, 20.69),
}
K = 8
GLOBAL_ETA = 25.0
#: region growing parameters (Rabbani et al. 2006): smoothness angle; the
#: curvature threshold is the 98th percentile of the model's curvatures
RG_SMOOTHNESS_DEG = 15.0


def _unit_cube(points: np.ndarray) -> np.ndarray:
    lo = points.min(axis=0)
    extent = float((points.max(axis=0) - lo).max())
    return (points - lo) / (extent if extent > 0 else 1.0)


def vsa_model(path: str, rng: np.random.Generator) -> dict:
    """The four Table 4.1 experiments on one model (a `run_batch` task)."""
    from ..io import read_point_set

    ps = read_point_set(path, zero_normals="drop")
    if ps.normals is None:
        raise PointAtlasError(
            f"{path}: experiment vsa needs normals (mesh faces or PLY nx ny nz); "
            "the file has none"
        )
    pts = _unit_cube(np.asarray(ps.points))
    nrm = np.asarray(ps.normals)
    kept = ps.attributes.get("source_index")
    # vertices without a usable normal (unreferenced / zero-area) are left out
    n_dropped = 0 if kept is None else int(kept[-1] + 1 - kept.size) if kept.size else 0
    out = {"n_points": int(ps.n_points), "n_dropped": n_dropped}
    t0 = time.perf_counter()
    rg = region_growing(pts, nrm, k=K, smoothness_angle=math.radians(RG_SMOOTHNESS_DEG))
    rg_l21 = float(np.nansum(rg.region_l21))
    out["pcl"] = {
        "m": rg.n_regions,
        "mse": rg.mse,
        "l21": rg_l21,
        "sizes": rg.region_counts.tolist(),
        "assigned": rg.assigned_fraction,
        "degenerate": rg.n_degenerate,
        "seconds": time.perf_counter() - t0,
    }
    m_seed = max(rg.n_regions, 1)
    runs = {
        "no_sm": dict(seeds=m_seed, classic=True, rng=rng),
        "local_eta_sm": dict(eta=rg_l21 / m_seed),
        "global_eta_sm": dict(eta=GLOBAL_ETA),
    }
    for name, kwargs in runs.items():
        t0 = time.perf_counter()
        res = vsa_segment(pts, nrm, k=K, **kwargs)
        out[name] = {
            "m": res.n_regions,
            "mse": res.mse,
            "l21": res.energy,
            "sizes": res.region_counts.tolist(),
            "assigned": 1.0,
            "degenerate": 0,
            "n_iter": res.n_iter,
            "stop_reason": res.stop_reason,
            "seconds": time.perf_counter() - t0,
        }
        if name == "local_eta_sm":
            out[name]["eta"] = rg_l21 / m_seed
    return out


def _stats(values) -> dict:
    v = np.asarray(values, dtype=np.float64)
    if v.size == 0:
        return {"min": None, "max": None, "avg": None, "sd": None, "n": 0}
    return {
        "min": float(v.min()),
        "max": float(v.max()),
        "avg": float(v.mean()),
        "sd": float(v.std(ddof=1)) if v.size > 1 else 0.0,
        "n": int(v.size),
    }


def aggregate_vsa(results: dict) -> dict:
    """Table 4.1 and the Fig. 4.5 histogram from the per-model results.

    ``valid`` models are those where region growing gave a proxy normal for every
    region (the thesis excluded the others, as PCL "failed" there); ``all`` uses
    every model and, for region growing, the models with a finite MSE.
    """
    names = sorted(results)
    valid = [s for s in names if results[s]["pcl"]["degenerate"] == 0]
    table = {}
    for subset_name, subset in (("valid", valid), ("all", names)):
        cols = {}
        for col in COLUMNS:
            mse = [results[s][col]["mse"] for s in subset]
            mse = [v for v in mse if v is not None and math.isfinite(v)]
            cols[col] = {
                "mse": _stats(mse),
                "m": _stats([results[s][col]["m"] for s in subset]),
                "assigned_min": min((results[s][col]["assigned"] for s in subset), default=None),
            }
        table[subset_name] = {"n_models": len(subset), "columns": cols}
    pcl_sizes = np.concatenate([np.asarray(results[s]["pcl"]["sizes"]) for s in valid] or [[]])
    mean, sd = 0.0, 0.0
    if pcl_sizes.size > 1:
        mean, sd = float(pcl_sizes.mean()), float(pcl_sizes.std(ddof=1))
    bound = max(int(math.floor(mean + sd)), 1)
    hist = {}
    avg_size = {}
    for col in COLUMNS:
        sizes = np.concatenate([np.asarray(results[s][col]["sizes"]) for s in valid] or [[]])
        sizes = sizes.astype(np.int64)
        hist[col] = np.bincount(sizes[sizes <= bound], minlength=bound + 1)[1:].tolist()
        avg_size[col] = float(sizes.mean()) if sizes.size else None
    unconverged = {
        col: sum(results[s][col].get("stop_reason") != "converged" for s in names)
        for col in COLUMNS[1:]
    }
    return {
        "n_models": len(names),
        "n_valid": len(valid),
        "table_4_1": table,
        "fig_4_5": {
            "bound": bound,
            "pcl_size_mean": mean,
            "pcl_size_sd": sd,
            "counts": hist,
            "avg_size": avg_size,
        },
        "not_converged": unconverged,
        "n_points": int(sum(results[s]["n_points"] for s in names)),
    }


def _fmt(value, kind):
    if value is None:
        return "-"
    return f"{value:.2E}" if kind == "mse" else f"{value:,.2f}"


def table_markdown(summary: dict, subset: str = "valid") -> str:
    """Table 4.1 as markdown, ours beside the thesis' values."""
    cols = summary["table_4_1"][subset]["columns"]
    head = " | ".join(f"{COLUMN_TITLES[c]} (ours / thesis)" for c in COLUMNS)
    lines = [f"| | {head} |", "|---|" + "---|" * len(COLUMNS)]
    for stat in ("min", "max", "avg", "sd"):
        for kind in ("mse", "m"):
            key = f"{stat} {'MSE' if kind == 'mse' else 'm'}"
            cells = [
                f"{_fmt(cols[c][kind][stat], kind)} / {_fmt(THESIS_TABLE_4_1[key][j], kind)}"
                for j, c in enumerate(COLUMNS)
            ]
            lines.append(f"| {key} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def _write(path: Path, text: str) -> Path:
    return write_text(path, text)


def write_vsa_outputs(summary: dict, out: Path) -> list[Path]:
    """table_4_1.{md,csv,json}, fig_4_5.{png,csv} in ``out``."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    written = [_write(out / "table_4_1.md", table_markdown(summary))]
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(["subset", "statistic", *COLUMNS])
    for subset in ("valid", "all"):
        cols = summary["table_4_1"][subset]["columns"]
        for stat in ("min", "max", "avg", "sd"):
            for kind in ("mse", "m"):
                w.writerow([subset, f"{stat} {kind}", *(cols[c][kind][stat] for c in COLUMNS)])
    written.append(_write(out / "table_4_1.csv", buf.getvalue()))
    written.append(_write(out / "table_4_1.json", json.dumps(summary, indent=1)))
    fig45 = summary["fig_4_5"]
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(["size", *COLUMNS])
    for i in range(fig45["bound"]):
        w.writerow([i + 1, *(fig45["counts"][c][i] for c in COLUMNS)])
    written.append(_write(out / "fig_4_5.csv", buf.getvalue()))
    fig = Figure(figsize=(9, 4.5))
    FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    sizes = np.arange(1, fig45["bound"] + 1)
    for col in COLUMNS:
        counts = np.asarray(fig45["counts"][col], dtype=float)
        counts[counts == 0] = np.nan
        ax.plot(sizes, counts, label=COLUMN_TITLES[col], lw=1.2)
    ax.set_yscale("log")
    ax.set_xlabel("region size (points)")
    ax.set_ylabel("number of regions")
    ax.set_title(f"Fig. 4.5: region sizes up to {fig45['bound']} over {summary['n_valid']} models")
    ax.legend()
    from ..io import atomic_write

    with atomic_write(out / "fig_4_5.png", "wb") as fh:
        fig.savefig(fh, format="png", dpi=120, bbox_inches="tight")
    written.append(out / "fig_4_5.png")
    return written


@experiment_app.command("vsa")
@guarded
def vsa_command(
    models: Annotated[Path, typer.Option("--models", help="Folder of meshes.")],
    out: Annotated[Path, typer.Option("--out", help="Output folder.")] = Path("experiment-vsa"),
    n_workers: Annotated[int, typer.Option("--workers", min=1, help="Dask workers.")] = 2,
    scheduler: Annotated[
        str | None, typer.Option("--scheduler", help="Address of a running dask scheduler.")
    ] = None,
    seed: Annotated[int, typer.Option("--seed", help="Root seed.")] = 0,
) -> None:
    """Table 4.1 and Fig. 4.5: region growing vs VSA with and without split/merge."""
    from ..batch import list_models, run_batch

    if not models.is_dir():
        raise PointAtlasError(f"--models must be a folder; got {models}")
    files = list_models(models)
    if not files:
        raise PointAtlasError(f"no model files in {models}")
    check_outputs([], folders=[("--out", out)])
    out.mkdir(exist_ok=True)
    say(f"{models.name}: {len(files)} models -> {out}")
    report = run_batch(
        vsa_model, files, out, scheduler=scheduler, n_workers=n_workers, seed=seed, name="vsa"
    )
    for stem, msg in report.failures.items():
        console.print(f"  [yellow]failed[/] {stem}: {msg}")
    summary = aggregate_vsa(dict(report.results))
    summary["n_failed"] = report.n_failed
    summary["models"] = str(models)
    written = write_vsa_outputs(summary, out)
    console.print(
        f"  {summary['n_models']} models ({summary['n_points']:,} points), "
        f"{summary['n_valid']} with a valid region-growing result, {report.n_failed} failed"
    )
    cols = summary["table_4_1"]["valid"]["columns"]
    for col in COLUMNS:
        console.print(
            f"  {COLUMN_TITLES[col]:>22s}: avg MSE {_fmt(cols[col]['mse']['avg'], 'mse')}, "
            f"avg m {_fmt(cols[col]['m']['avg'], 'm')}"
        )
    console.print(f"  wrote {len(written)} files")
