"""Thesis 5.4 and 6.2 on model collections: Tables 5.1/5.2, Figs. 5.4-5.6, 6.3, 6.6-6.8.

Per model (`neighborhood_model`, a `pointatlas.batch.run_batch` task): the optimal
(a, b, k) of Eq. 5.9 over the thesis' grid, the equal-weight baseline (E_dim
minimised over k = 6..20 with a = b = pi, "Weights [WJM14]"), the Table 5.2 cases
(`decrease_cases`), and the k = 14 equal-weight energies of 6.2. The collection
summary (`aggregate_neighborhoods`) gives Table 5.1, Table 5.2, Figs. 5.4-5.6 and
the energy histograms of Figs. 6.3/6.6, written by `write_neighborhood_outputs` as
PNG, CSV and JSON; `noisy_dodecahedron_flatness` adds Figs. 6.7/6.8.
"""

from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np

from .._core import PointAtlasError
from ..features import (
    THESIS_ANGLE_GRID,
    THESIS_K_RANGE,
    angle_pairs,
    covariance_features,
    decrease_cases,
    eigen_features,
    optimal_k_features,
    optimal_neighborhood,
)
from ..io import write_json, write_text
from ..neighbors import query_knn
from ._files import csv_rows, save_figure
from ._stats import moments, pooled

__all__ = [
    "ENERGY_K",
    "ENERGY_NAMES",
    "FLATNESS_EXPONENTS",
    "aggregate_neighborhoods",
    "decrease_cases",
    "energy_histogram",
    "neighborhood_model",
    "noisy_dodecahedron_flatness",
    "run_neighborhoods",
    "write_neighborhood_outputs",
]

#: the four (m1, m2) of Fig. 6.2/6.3
FLATNESS_EXPONENTS = ((2, 2), (2, 8), (8, 2), (8, 8))


#: the energies of Fig. 6.5/6.6
ENERGY_NAMES = ("flatness", "omnivariance", "anisotropy", "change_of_curvature")


#: neighbourhood size of chapter 6's experiments
ENERGY_K = 14


N_ENERGY_BINS = 11  # [0, .1), ..., [.9, 1), and "equal to 1" (Figs. 6.3, 6.6, 6.8)


def energy_histogram(values) -> np.ndarray:
    """Counts of values / max(values) in [0, .1), ..., [.9, 1) and == 1 (Figs. 6.3/6.6/6.8).

    Parameters
    ----------
    values : array_like of shape (n,)
        Energies of one model; NaN and infinities are left out.

    Returns
    -------
    counts : ndarray of shape (11,), int64
        Ten bins of width 0.1 and the values equal to the maximum.

    Examples
    --------
    >>> energy_histogram([0.0, 0.5, 1.0]).tolist()
    [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]
    """
    v = np.asarray(values, dtype=np.float64)
    v = v[np.isfinite(v)]
    counts = np.zeros(N_ENERGY_BINS, dtype=np.int64)
    if v.size == 0 or v.max() <= 0:
        counts[0] = v.size
        return counts
    r = v / v.max()
    b = np.minimum(np.floor(r * 10).astype(np.int64), 9)
    b[r >= 1.0] = 10
    np.add.at(counts, b, 1)
    return counts


def neighborhood_model(path: str, rng) -> dict:
    """Per-model part of the experiment (module level, so the batch runner can ship it).

    Parameters
    ----------
    path : str
        A mesh or point file with normals (meshes: area-weighted vertex normals).
    rng : numpy.random.Generator
        Unused (the experiment is deterministic); part of the batch contract.

    Returns
    -------
    result : dict
        JSON-serialisable counts and sums (see `aggregate_neighborhoods`).
    """
    from ..io import read_point_set

    t0 = time.perf_counter()
    # vertices without a usable area-weighted normal (unreferenced / zero-area faces)
    # are left out, as the thesis' pipeline needs a normal at every point
    ps = read_point_set(path, zero_normals="drop")
    if ps.normals is None:
        raise PointAtlasError(f"{Path(path).name} has no normals (needed for Eq. 5.2)")
    # thesis 5.3.2 i): the evaluation requires distinct points
    _, first = np.unique(ps.points, axis=0, return_index=True)
    keep = np.sort(first)
    pts = ps.points[keep]
    nrm = ps.normals[keep]
    kmin, kmax = THESIS_K_RANGE
    if pts.shape[0] < max(kmax, ENERGY_K):
        raise PointAtlasError(f"{Path(path).name}: {pts.shape[0]} distinct points; need {kmax}")
    idx = query_knn(pts, max(kmax, ENERGY_K))[0]
    opt = optimal_neighborhood(pts, nrm, neighbors=idx)
    eq = optimal_k_features(pts, k_range=THESIS_K_RANGE, criterion="e_dim", neighbors=idx)
    a_case, b_case = decrease_cases(pts, nrm, opt, neighbors=idx)
    fixed = covariance_features(pts, ENERGY_K, neighbors=idx, flatness=(8, 8))

    pairs = angle_pairs()
    ok = opt.reason == 0
    pair_idx = np.full(pts.shape[0], -1)
    for j, (a, b) in enumerate(pairs):
        pair_idx[ok & np.isclose(opt.a, a) & np.isclose(opt.b, b)] = j
    hist = np.zeros((len(pairs), kmax - kmin + 1), dtype=np.int64)
    np.add.at(hist, (pair_idx[ok], opt.k[ok] - kmin), 1)
    k_ok = opt.k[ok].astype(np.float64)
    flat_m = {
        f"{m1},{m2}": energy_histogram(
            eigen_features(fixed.eigenvalues, flatness=(m1, m2))["flatness"]
        ).tolist()
        for m1, m2 in FLATNESS_EXPONENTS
    }
    energies = {name: getattr(fixed, name) for name in ENERGY_NAMES}
    return {
        "model": Path(path).name,
        "n_points": int(pts.shape[0]),
        "n_duplicates_removed": int(ps.n_points - pts.shape[0]),
        "e_dim_equal": moments(eq.e_dim),
        "e_dim_optimal": moments(opt.e_dim),
        "n_degenerate_equal": int((eq.reason != 0).sum()),
        "n_degenerate_optimal": int((opt.reason != 0).sum()),
        "pair_k_histogram": hist.tolist(),
        "k_mean": float(k_ok.mean()) if k_ok.size else None,
        "k_sd": float(k_ok.std(ddof=1)) if k_ok.size > 1 else None,
        "a_cases": np.bincount(a_case[a_case >= 0], minlength=3).tolist(),
        "b_cases": np.bincount(b_case[b_case >= 0], minlength=3).tolist(),
        "energy_histograms": {n: energy_histogram(v).tolist() for n, v in energies.items()},
        "energy_max": {n: float(np.nanmax(v)) for n, v in energies.items()},
        "flatness_histograms": flat_m,
        "flatness_raw_histogram": np.histogram(
            fixed.flatness[np.isfinite(fixed.flatness)], bins=20, range=(0, 2)
        )[0].tolist(),
        "seconds": round(time.perf_counter() - t0, 3),
    }


def aggregate_neighborhoods(results: dict[str, dict]) -> dict:
    """Collection-level Tables 5.1/5.2 and the data of Figs. 5.4-5.6, 6.3, 6.6.

    Parameters
    ----------
    results : dict of str to dict
        Per-model outputs of `neighborhood_model` (the batch report's results).

    Returns
    -------
    summary : dict
        ``table_5_1``, ``table_5_2`` (percentages), ``pair_k_histogram`` (28 x 15),
        ``k_histogram`` (percent per k), ``k_mean``/``k_sd`` (pooled), ``k_sd_per_model``,
        ``energy_histograms``, ``flatness_histograms``, counts.
    """
    res = [results[s] for s in sorted(results)]
    if not res:
        raise PointAtlasError("no model finished; nothing to aggregate")
    kmin, kmax = THESIS_K_RANGE
    n_points = sum(r["n_points"] for r in res)
    hist = np.sum([np.asarray(r["pair_k_histogram"]) for r in res], axis=0)
    k_counts = hist.sum(axis=0)
    ks = np.arange(kmin, kmax + 1)
    n_k = int(k_counts.sum())
    k_mean = float((k_counts * ks).sum() / n_k) if n_k else None
    k_sd = (
        float(math.sqrt(((k_counts * (ks - k_mean) ** 2).sum()) / (n_k - 1))) if n_k > 1 else None
    )
    a_cases = np.sum([r["a_cases"] for r in res], axis=0)
    b_cases = np.sum([r["b_cases"] for r in res], axis=0)
    n_cases = max(int(a_cases.sum()), 1)
    pct = lambda c: [float(100.0 * v / n_cases) for v in c]  # noqa: E731
    a_pct = pct(a_cases)
    b_pct = pct(b_cases)
    return {
        "n_models": len(res),
        "n_points": n_points,
        "n_duplicates_removed": sum(r["n_duplicates_removed"] for r in res),
        "table_5_1": {
            "equal": pooled([r["e_dim_equal"] for r in res]),
            "optimal": pooled([r["e_dim_optimal"] for r in res]),
        },
        "n_degenerate_equal": sum(r["n_degenerate_equal"] for r in res),
        "n_degenerate_optimal": sum(r["n_degenerate_optimal"] for r in res),
        "table_5_2": {
            "a=0": a_pct[0],
            "a-": a_pct[1],
            "not a-": a_pct[2],
            "b=a": b_pct[0],
            "b-": b_pct[1],
            "not b-": b_pct[2],
            "n_points": int(a_cases.sum()),
        },
        "pairs_deg": [[round(math.degrees(a)), round(math.degrees(b))] for a, b in angle_pairs()],
        "pair_k_histogram": hist.tolist(),
        "k_values": ks.tolist(),
        "k_histogram_percent": (100.0 * k_counts / max(n_k, 1)).tolist(),
        "k_mean": k_mean,
        "k_sd": k_sd,
        "k_sd_per_model": [r["k_sd"] for r in res if r["k_sd"] is not None],
        "equal_weights_chosen_percent": float(100.0 * hist[-1].sum() / max(n_k, 1)),
        "energy_histograms": {
            n: np.sum([r["energy_histograms"][n] for r in res], axis=0).tolist()
            for n in ENERGY_NAMES
        },
        "flatness_histograms": {
            key: np.sum([r["flatness_histograms"][key] for r in res], axis=0).tolist()
            for key in res[0]["flatness_histograms"]
        },
        "flatness_raw_histogram": np.sum(
            [r["flatness_raw_histogram"] for r in res], axis=0
        ).tolist(),
    }


def _bin_labels():
    return [f"[{i / 10:.1f},{(i + 1) / 10:.1f})" for i in range(10)] + ["=1"]


def _energy_figure(title: str, series: dict[str, list], path: Path, note: str = "") -> Path:
    from matplotlib.figure import Figure

    fig = Figure(figsize=(9, 4))
    ax = fig.add_subplot()
    width = 0.8 / max(len(series), 1)
    x = np.arange(N_ENERGY_BINS)
    for j, (name, counts) in enumerate(series.items()):
        ax.bar(x + (j - (len(series) - 1) / 2) * width, counts, width, label=name)
    ax.set_xticks(x, _bin_labels(), rotation=45, fontsize=8)
    ax.set_xlabel("energy / max energy of the model" + note)
    ax.set_ylabel("points")
    ax.set_title(title)
    ax.legend(fontsize=8, loc="upper right")  # fixed: "best" warns when slow (load)
    return save_figure(fig, path)


def write_neighborhood_outputs(summary: dict, out: Path, *, label: str) -> list[Path]:
    """Write Tables 5.1/5.2, Figs. 5.4-5.6 and 6.3/6.6 as CSV/JSON/PNG into ``out``.

    Parameters
    ----------
    summary : dict
        `aggregate_neighborhoods`'s summary.
    out : pathlib.Path
        Output folder (made when missing).
    label : str
        Collection name in the tables and figures.

    Returns
    -------
    list of pathlib.Path
        The files written, ``neighbourhoods.json`` first.
    """
    from matplotlib import colormaps
    from matplotlib.figure import Figure

    out.mkdir(parents=True, exist_ok=True)
    written = [write_json(out / "neighbourhoods.json", summary, indent=1)]
    t1 = summary["table_5_1"]
    rows = [["collection", "weights", "n_points", "min", "mean", "max", "sd"]]
    for key, name in (("equal", "equal weights [WJM14]"), ("optimal", "ours Eq. 5.9")):
        s = t1[key]
        rows.append([label, name, s["n"], s["min"], s["mean"], s["max"], s["sd"]])
    written.append(write_text(out / "table_5_1.csv", csv_rows(rows)))
    t2 = summary["table_5_2"]
    cols = ["a=0", "a-", "not a-", "b=a", "b-", "not b-"]
    written.append(
        write_text(
            out / "table_5_2.csv",
            csv_rows(
                [["collection", *cols, "n_points"], [label, *[t2[c] for c in cols], t2["n_points"]]]
            ),
        )
    )
    # Fig. 5.4: (a*, b*) histogram, bars stacked by k*
    hist = np.asarray(summary["pair_k_histogram"])
    ks = summary["k_values"]
    pairs = summary["pairs_deg"]
    fig = Figure(figsize=(12, 4.5))
    ax = fig.add_subplot()
    cmap = colormaps["viridis"]
    bottom = np.zeros(len(pairs))
    for j, k in enumerate(ks):
        ax.bar(
            np.arange(len(pairs)),
            hist[:, j],
            bottom=bottom,
            color=cmap(j / max(len(ks) - 1, 1)),
            label=f"k={k}" if j in (0, len(ks) // 2, len(ks) - 1) else None,
        )
        bottom += hist[:, j]
    ax.set_xticks(np.arange(len(pairs)), [f"{a},{b}" for a, b in pairs], rotation=90, fontsize=7)
    ax.set_xlabel("(a*, b*) in degrees")
    ax.set_ylabel("points")
    ax.set_title(f"Fig. 5.4 ({label}): optimal (a*, b*), stacked by k* (6 bottom ... 20 top)")
    ax.legend(fontsize=8, loc="upper right")  # fixed: "best" warns when slow (load)
    written.append(save_figure(fig, out / "fig5_4.png"))
    written.append(
        write_text(
            out / "fig5_4.csv",
            csv_rows(
                [["a_deg", "b_deg", *[f"k{k}" for k in ks]]]
                + [[*p, *h] for p, h in zip(pairs, hist.tolist(), strict=True)]
            ),
        )
    )
    # Fig. 5.5: k* histogram in percent
    fig = Figure(figsize=(7, 4))
    ax = fig.add_subplot()
    ax.bar(ks, summary["k_histogram_percent"], color="tab:blue")
    ax.set_xlabel("k*")
    ax.set_ylabel("% of points")
    ax.set_title(f"Fig. 5.5 ({label}): k* (mean {summary['k_mean']:.2f}, sd {summary['k_sd']:.2f})")
    written.append(save_figure(fig, out / "fig5_5.png"))
    written.append(
        write_text(
            out / "fig5_5.csv",
            csv_rows(
                [["k", "percent"]]
                + [[k, p] for k, p in zip(ks, summary["k_histogram_percent"], strict=True)]
            ),
        )
    )
    # Fig. 5.6: box plot of the per-model sd of k*
    fig = Figure(figsize=(4, 4.5))
    ax = fig.add_subplot()
    sds = summary["k_sd_per_model"]
    if sds:
        ax.boxplot([sds], tick_labels=[f"{label}\n({len(sds)} models)"])
    ax.set_ylabel("sd of k* within a model")
    ax.set_title("Fig. 5.6")
    written.append(save_figure(fig, out / "fig5_6.png"))
    written.append(write_text(out / "fig5_6.csv", csv_rows([["k_sd"]] + [[v] for v in sds])))
    # Figs. 6.3 / 6.6
    flat = {f"(m1,m2)=({k})": v for k, v in summary["flatness_histograms"].items()}
    written.append(
        _energy_figure(f"Fig. 6.3 ({label}): flatness, k = {ENERGY_K}", flat, out / "fig6_3.png")
    )
    written.append(
        _energy_figure(
            f"Fig. 6.6 ({label}): energies, k = {ENERGY_K}",
            summary["energy_histograms"],
            out / "fig6_6.png",
        )
    )
    rows = [["series", *_bin_labels()]]
    rows += [[k, *v] for k, v in flat.items()]
    rows += [[k, *v] for k, v in summary["energy_histograms"].items()]
    written.append(write_text(out / "fig6_3_6_6.csv", csv_rows(rows)))
    return written


def noisy_dodecahedron_flatness(out: Path, *, rng=0) -> list[Path]:
    """Figs. 6.7/6.8: flatness on the noisy dodecahedron (3,842 points, 25 %), k = 14, 28, 56."""
    from ..synth import add_normal_noise, dodecahedron
    from ..viz import PointsPanel, render_side_by_side

    m = dodecahedron(8)
    pts = add_normal_noise(m.points, m.normals, 0.25, k=12, rng=rng)
    series = {}
    panels = []
    maxima = {}
    for k in (14, 28, 56):
        f = covariance_features(pts, k, flatness=(8, 8)).flatness
        series[f"k = {k}"] = energy_histogram(f).tolist()
        maxima[k] = float(np.nanmax(f))
        panels.append(
            PointsPanel(pts, scalars=f, scalar_name="flatness", cmap="Blues", title=f"k = {k}")
        )
    note = ", maxima " + ", ".join(f"{v:.3f}" for v in maxima.values())
    written = [
        _energy_figure(
            "Fig. 6.8: flatness on the noisy dodecahedron (3,842 points)",
            series,
            out / "fig6_8.png",
            note,
        ),
        render_side_by_side(
            out / "fig6_7.png", panels, title="Fig. 6.7: flatness (m1 = m2 = 8), noisy dodecahedron"
        ),
    ]
    rows = [["k", "max", *_bin_labels()]]
    rows += [[k, maxima[k], *series[f"k = {k}"]] for k in maxima]
    written.append(write_text(out / "fig6_8.csv", csv_rows(rows)))
    return written


def run_neighborhoods(
    files,
    out: Path,
    *,
    label: str,
    scheduler=None,
    n_workers: int = 2,
    dodecahedron: bool = True,
):
    """`neighborhood_model` on every file (through `run_batch`), then aggregate and write.

    Parameters
    ----------
    files : sequence of path
        The models (meshes or point files with normals).
    out : pathlib.Path
        Existing output folder (per-model results go to ``out/results``).
    label : str
        Collection name in the tables and figures.
    scheduler : str, optional
        Address of a running dask scheduler.
    n_workers : int
        Local dask workers when no scheduler is given.
    dodecahedron : bool
        Also write Figs. 6.7/6.8 (`noisy_dodecahedron_flatness`).

    Returns
    -------
    summary : dict
        `aggregate_neighborhoods`'s summary with ``label``, ``n_failed``, ``grid_deg``.
    written : list of pathlib.Path
        The files written.
    failures : dict of str to str
        Failed models and their messages.
    """
    from ..batch import run_batch

    report = run_batch(
        neighborhood_model,
        files,
        out,
        scheduler=scheduler,
        n_workers=n_workers,
        name="neighbourhoods",
    )
    summary = aggregate_neighborhoods(report.results)
    summary["label"] = label
    summary["n_failed"] = report.n_failed
    summary["grid_deg"] = [round(math.degrees(v)) for v in THESIS_ANGLE_GRID]
    written = write_neighborhood_outputs(summary, out, label=label)
    if dodecahedron:
        written += noisy_dodecahedron_flatness(out)
    return summary, written, dict(report.failures)
