"""Table 4.1 and Fig. 4.5 of the thesis (4.3.4): region growing against VSA.

Per model (`vsa_model`, a `pointatlas.batch.run_batch` task), scaled into the unit
cube, mesh vertex normals, k = 8, weights 1, four experiments:

- ``pcl``: region growing of Rabbani et al. (2006) (PCL's ``RegionGrowing``);
- ``no_sm``: VSA of [LB16] (classic loop) seeded with the region-growing region
  count, no split/merge;
- ``local_eta_sm``: every point a seed, split and merge with eta = the
  region-growing L21 divided by its region count;
- ``global_eta_sm``: every point a seed, split and merge with eta = 25.

`aggregate_vsa` gives Table 4.1 (MSE and region count statistics), the Fig. 4.5
histogram of region sizes and the number of failed models; `write_vsa_outputs`
writes them; `run_vsa_experiment` does all three on a folder of models.
"""

from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np

from .._core import PointAtlasError
from ..io import write_json, write_text
from ..segment import region_growing, vsa_segment
from ._files import csv_rows, save_figure
from ._stats import describe

__all__ = [
    "COLUMNS",
    "COLUMN_TITLES",
    "THESIS_TABLE_4_1",
    "aggregate_vsa",
    "format_value",
    "run_vsa_experiment",
    "table_markdown",
    "vsa_model",
    "write_vsa_outputs",
]

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
    """The four Table 4.1 experiments on one model (a `run_batch` task).

    Parameters
    ----------
    path : str
        A mesh (or a point file with normals).
    rng : numpy.random.Generator
        Seeds of the ``no_sm`` run.

    Returns
    -------
    result : dict
        JSON-serialisable: ``n_points``, ``n_dropped`` and per experiment of
        `COLUMNS` the region count ``m``, ``mse``, ``l21``, region ``sizes``.
    """
    from ..io import read_point_set

    ps = read_point_set(path, zero_normals="drop")
    if ps.normals is None:
        raise PointAtlasError(
            f"{path}: experiment vsa needs normals (mesh faces or PLY nx ny nz); the file has none"
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


def aggregate_vsa(results: dict) -> dict:
    """Table 4.1 and the Fig. 4.5 histogram from the per-model results.

    ``valid`` models are those where region growing gave a proxy normal for every
    region (the thesis excluded the others, as PCL "failed" there); ``all`` uses
    every model and, for region growing, the models with a finite MSE.

    Parameters
    ----------
    results : dict of str to dict
        Per model, the result of `vsa_model` (`run_batch`'s results).

    Returns
    -------
    summary : dict
        ``table_4_1`` (``valid`` and ``all``: statistics of MSE and region counts per
        column), ``fig_4_5`` (region-size histograms), ``not_converged`` per column,
        ``n_models``, ``n_valid`` and ``n_points``.
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
                "mse": describe(mse),
                "m": describe([results[s][col]["m"] for s in subset]),
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


def format_value(value, kind):
    """A Table 4.1 cell: MSE in E notation, counts with two decimals, None as -."""
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
                f"{format_value(cols[c][kind][stat], kind)} / "
                f"{format_value(THESIS_TABLE_4_1[key][j], kind)}"
                for j, c in enumerate(COLUMNS)
            ]
            lines.append(f"| {key} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def write_vsa_outputs(summary: dict, out: Path) -> list[Path]:
    """Write table_4_1.{md,csv,json} and fig_4_5.{png,csv} into ``out``.

    Parameters
    ----------
    summary : dict
        `aggregate_vsa`'s summary.
    out : pathlib.Path
        Existing output folder.

    Returns
    -------
    list of pathlib.Path
        The files written, in order.
    """
    from matplotlib.figure import Figure

    written = [write_text(out / "table_4_1.md", table_markdown(summary))]
    rows = [["subset", "statistic", *COLUMNS]]
    for subset in ("valid", "all"):
        cols = summary["table_4_1"][subset]["columns"]
        for stat in ("min", "max", "avg", "sd"):
            for kind in ("mse", "m"):
                rows.append([subset, f"{stat} {kind}", *(cols[c][kind][stat] for c in COLUMNS)])
    written.append(write_text(out / "table_4_1.csv", csv_rows(rows)))
    written.append(write_json(out / "table_4_1.json", summary, indent=1))
    fig45 = summary["fig_4_5"]
    rows = [["size", *COLUMNS]]
    for i in range(fig45["bound"]):
        rows.append([i + 1, *(fig45["counts"][c][i] for c in COLUMNS)])
    written.append(write_text(out / "fig_4_5.csv", csv_rows(rows)))
    fig = Figure(figsize=(9, 4.5))
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
    ax.legend(loc="upper right")  # fixed: "best" warns when slow (load)
    written.append(save_figure(fig, out / "fig_4_5.png"))
    return written


def run_vsa_experiment(
    files, out: Path, *, seed: int = 0, scheduler=None, n_workers: int = 2, models=None
):
    """`vsa_model` on every file (through `run_batch`), then aggregate and write.

    Parameters
    ----------
    files : sequence of path
        The models.
    out : pathlib.Path
        Existing output folder (per-model results go to ``out/results``).
    seed : int
        Root seed of the batch.
    scheduler : str, optional
        Address of a running dask scheduler.
    n_workers : int
        Local dask workers when no scheduler is given.
    models : str, optional
        The folder name recorded in the summary.

    Returns
    -------
    summary : dict
        `aggregate_vsa`'s summary with ``n_failed`` and ``models``.
    written : list of pathlib.Path
        The files of `write_vsa_outputs`.
    failures : dict of str to str
        Failed models and their messages.
    """
    from ..batch import run_batch

    report = run_batch(
        vsa_model, files, out, scheduler=scheduler, n_workers=n_workers, seed=seed, name="vsa"
    )
    summary = aggregate_vsa(dict(report.results))
    summary["n_failed"] = report.n_failed
    summary["models"] = str(models)
    return summary, write_vsa_outputs(summary, out), dict(report.failures)
