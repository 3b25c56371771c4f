"""``pointatlas experiment ...``: thin wrappers of the thesis reproductions.

Each command checks its options and output folder, calls `pointatlas.experiments`
(one module per study) and prints the headline numbers. The studies are imported
inside the commands, so ``pointatlas --help`` stays fast.
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Annotated

import typer

from .._core import PointAtlasError
from ._app import console, experiment_app, guarded, progress_bar, say
from ._outputs import check_outputs
from ._reports import REPORT_EXTENSIONS

__all__ = [
    "cloudsurfaces_command",
    "denoise_experiment_command",
    "neighbourhoods_command",
    "simplify_experiment_command",
    "vsa_command",
]

_SIMPLIFY_CASES = ("sphere", "fandisk", "torus", "two_torus", "dodecahedron")
_TABLE_5_3_MODELS = (
    "cube",
    "bearing",
    "fandisk",
    "sharp_sphere",
    "fertility",
    "octahedron",
    "rockerarm",
)

_Workers = Annotated[int, typer.Option("--workers", min=1, help="Dask workers.")]
_Scheduler = Annotated[
    str | None, typer.Option("--scheduler", help="Address of a running dask scheduler.")
]
_Report = Annotated[
    Path | None,
    typer.Option(
        "--report",
        help="Also write an HTML report of the study's tables and pictures (.html).",
    ),
]


def _model_files(models: Path, patterns=None) -> list:
    """The model files of ``--models`` (a folder), or one precise error."""
    from ..batch import list_models

    if not models.is_dir():
        raise PointAtlasError(f"--models must be a folder; got {models}")
    files = list_models(models, patterns=tuple(patterns)) if patterns else list_models(models)
    if not files:
        raise PointAtlasError(f"no model files in {models}")
    return files


def _output_folder(out: Path) -> Path:
    check_outputs([], folders=[("--out", out)])
    out.mkdir(exist_ok=True)
    return out


def _check_report(report: Path | None, out: Path) -> None:
    """Check ``--report`` before any work; inside a ``--out`` the run creates, only its
    name is checked here (the folder is made by the run)."""
    if report is None:
        return
    made_by_the_run = not out.exists() and report.parent.resolve() == out.resolve()
    if made_by_the_run and report.suffix.lower() in REPORT_EXTENSIONS:
        return
    check_outputs([], [("--report", report, REPORT_EXTENSIONS)])


def _files_since(out: Path, start: float) -> list[Path]:
    """The files in ``out`` written since ``start`` (time.time()), by name."""
    return sorted(p for p in out.iterdir() if p.is_file() and p.stat().st_mtime >= start)


def _write_report(report, study, out, files, summary, parameters, seed=0) -> None:
    """``--report`` of an experiment command (`pointatlas.experiments.write_experiment_report`)."""
    if report is None:
        return
    from ..experiments import write_experiment_report

    files = [Path(f) for f in files if Path(f).resolve() != report.resolve()]
    write_experiment_report(
        report, study=study, out=out, files=files, summary=summary, parameters=parameters, seed=seed
    )
    say(f"wrote {report}")


def _print_failures(failures: dict) -> None:
    for stem, msg in failures.items():
        console.print(f"  [yellow]failed[/] {stem}: {msg}")


@experiment_app.command("vsa")
@guarded
def vsa_command(
    models: Annotated[Path, typer.Option("--models", help="Folder of meshes.")],
    out: Annotated[Path, typer.Option("--out", help="Output folder.")] = Path("experiment-vsa"),
    n_workers: _Workers = 2,
    scheduler: _Scheduler = None,
    seed: Annotated[int, typer.Option("--seed", help="Root seed.")] = 0,
    report: _Report = None,
) -> None:
    """Table 4.1 and Fig. 4.5: region growing vs VSA with and without split/merge."""
    from ..experiments.table_4_1 import COLUMN_TITLES, COLUMNS, format_value, run_vsa_experiment

    _check_report(report, out)
    files = _model_files(models)
    _output_folder(out)
    say(f"{models.name}: {len(files)} models -> {out}")
    summary, written, failures = run_vsa_experiment(
        files, out, seed=seed, scheduler=scheduler, n_workers=n_workers, models=models
    )
    _print_failures(failures)
    console.print(
        f"  {summary['n_models']} models ({summary['n_points']:,} points), "
        f"{summary['n_valid']} with a valid region-growing result, {summary['n_failed']} failed"
    )
    cols = summary["table_4_1"]["valid"]["columns"]
    for col in COLUMNS:
        console.print(
            f"  {COLUMN_TITLES[col]:>22s}: avg MSE {format_value(cols[col]['mse']['avg'], 'mse')}, "
            f"avg m {format_value(cols[col]['m']['avg'], 'm')}"
        )
    console.print(f"  wrote {len(written)} files")
    _write_report(
        report,
        "vsa",
        out,
        written,
        {"models": str(models), "files": len(files)},
        {"workers": n_workers, "scheduler": scheduler},
        seed,
    )


@experiment_app.command("neighbourhoods")
@guarded
def neighbourhoods_command(
    models: Annotated[
        Path, typer.Option("--models", help="Folder of meshes / point files with normals.")
    ],
    out: Annotated[Path, typer.Option("--out", help="Output folder.")] = Path(
        "experiment-neighbourhoods"
    ),
    pattern: Annotated[
        list[str] | None,
        typer.Option("--glob", help="File patterns inside --models (repeatable)."),
    ] = None,
    label: Annotated[
        str | None, typer.Option("--label", help="Collection name in the tables.")
    ] = None,
    n_workers: _Workers = 2,
    scheduler: _Scheduler = None,
    dodecahedron: Annotated[
        bool, typer.Option(help="Also run Figs. 6.7/6.8 on the noisy dodecahedron.")
    ] = True,
    report: _Report = None,
) -> None:
    """Tables 5.1/5.2, Figs. 5.4-5.6 and the flatness histograms on a collection."""
    from ..experiments.neighborhoods import run_neighborhoods

    _check_report(report, out)
    files = _model_files(models, pattern)
    name = label or models.name
    _output_folder(out)
    say(f"{name}: {len(files)} models -> {out}")
    summary, written, failures = run_neighborhoods(
        files,
        out,
        label=name,
        scheduler=scheduler,
        n_workers=n_workers,
        dodecahedron=dodecahedron,
    )
    _print_failures(failures)
    t1 = summary["table_5_1"]
    console.print(f"  {summary['n_models']} models, {summary['n_points']} points")
    for key in ("equal", "optimal"):
        s = t1[key]
        console.print(
            f"  Table 5.1 {key:8s}: min {s['min']:.6g} mean {s['mean']:.6g} "
            f"max {s['max']:.6g} sd {s['sd']:.6g}"
        )
    t2 = summary["table_5_2"]
    console.print(
        "  Table 5.2: "
        + ", ".join(f"{c} {t2[c]:.2f}%" for c in ("a=0", "a-", "not a-", "b=a", "b-", "not b-"))
    )
    console.print(f"  k*: mean {summary['k_mean']:.3f}, sd {summary['k_sd']:.3f}")
    console.print(f"  wrote {len(written)} files")
    _write_report(
        report,
        "neighbourhoods",
        out,
        written,
        {"models": str(models), "files": len(files), "collection": name},
        {
            "glob": pattern,
            "workers": n_workers,
            "scheduler": scheduler,
            "dodecahedron": dodecahedron,
        },
    )


@experiment_app.command("simplify")
@guarded
def simplify_experiment_command(
    out: Annotated[Path, typer.Option("--out", help="Folder for pictures and numbers.")] = Path(
        "experiment-simplify"
    ),
    case: Annotated[
        list[str] | None,
        typer.Option("--case", help=f"Run only these: {', '.join(_SIMPLIFY_CASES)}."),
    ] = None,
    seed: Annotated[int, typer.Option("--seed", help="Seed for random VSA seeds/noise.")] = 0,
    report: _Report = None,
):
    """Reproduce thesis 4.4.3: sphere eta sweep, Fandisk, torus with a hole, 2-torus,
    noisy dodecahedron."""
    from ..experiments.simplify_cases import CASES, run_case, write_simplify_outputs

    _check_report(report, Path(out))
    out = _output_folder(Path(out))
    start = time.time() - 1.0
    rows = []
    for name in case or list(CASES):
        console.rule(f"[bold]{name}", align="left")
        t0 = time.perf_counter()
        case_rows = run_case(name, out, seed)
        rows.extend(case_rows)
        console.print(f"{name}: {len(case_rows)} meshes in {time.perf_counter() - t0:.1f} s")
    console.print(write_simplify_outputs(rows, out))
    say(f"outputs in {out.resolve()}")
    _write_report(
        report,
        "simplify",
        out,
        _files_since(out, start),
        {"cases": ", ".join(case or list(CASES))},
        {},
        seed,
    )


@experiment_app.command("denoise")
@guarded
def denoise_experiment_command(
    out: Annotated[Path, typer.Option("--out", help="Output folder.")] = Path("experiment-denoise"),
    data: Annotated[
        Path, typer.Option("--data", help="The shared data folder (models/ inside).")
    ] = Path("../shared/data"),
    models: Annotated[
        list[str] | None, typer.Option("--model", help="Table 5.3 models (repeatable).")
    ] = None,
    table: Annotated[bool, typer.Option(help="Run Table 5.3.")] = True,
    figures: Annotated[bool, typer.Option(help="Run Figs. 6.7-6.9.")] = True,
    seed: Annotated[int, typer.Option("--seed", help="Seed of the noise.")] = 0,
    report: _Report = None,
) -> None:
    """Table 5.3 (normal filtering, fixed vs adaptive k) and Figs. 6.7-6.9 (flatness)."""
    _check_report(report, out)
    chosen = tuple(models) if models else _TABLE_5_3_MODELS
    unknown = [m for m in chosen if m not in _TABLE_5_3_MODELS]
    if unknown:
        raise PointAtlasError(
            f"--model must be among {', '.join(_TABLE_5_3_MODELS)}; got {', '.join(unknown)}"
        )
    _output_folder(out)
    from ..experiments.denoise import write_denoise_outputs

    summary, written = write_denoise_outputs(
        out, data, models=chosen, table=table, figures=figures, seed=seed, progress=progress_bar
    )
    for r in summary.get("table_5_3", []):
        console.print(
            f"  {r['model']:13s} {r['noise']}: noise {r['mse_noise']:.5f} "
            f"[YRS+18] {r['mse_yrs18']:.5f} ours {r['mse_ours']:.5f}   (thesis "
            f"{r['thesis_noise']:.5f} {r['thesis_yrs18']:.5f} {r['thesis_ours']:.5f})"
        )
    for r in summary.get("fig_6_9", []):
        console.print(
            f"  Fig. 6.9 {r['setting']:28s} p2m mean {r['p2m_mean']:.5f} "
            f"max {r['p2m_max']:.5f} Chamfer {r['chamfer']:.2e} drift {r['drift_share']:.3f}"
        )
    for path in written:
        say(f"wrote {path}")
    _write_report(
        report,
        "denoise",
        out,
        written,
        {"data": str(data), "models": ", ".join(chosen)},
        {"table": table, "figures": figures},
        seed,
    )


@experiment_app.command("cloudsurfaces")
@guarded
def cloudsurfaces_command(
    out: Annotated[Path, typer.Option("--out", help="Output folder.")] = Path(
        "experiment-cloudsurfaces"
    ),
    seed: Annotated[int, typer.Option("--seed", help="Seed of sampling, noise, rotations.")] = 0,
    report: _Report = None,
) -> None:
    """Chapter A: density models, Fig. 2.9 curvature, curves, noisy covers, dynamics."""
    from ..experiments.cloud_surfaces import FIGURES, run_cloud_surfaces

    _check_report(report, out)
    _output_folder(out)
    check_outputs(
        [],
        [(name, out / name, (".png",)) for name in FIGURES]
        + [
            ("cloudsurfaces.csv", out / "cloudsurfaces.csv", None),
            ("summary.json", out / "summary.json", None),
        ],
    )
    rows, written = run_cloud_surfaces(out, seed=seed)
    for r in rows:
        console.print(
            f"  Fig. {r['figure']:5s} {r['quantity']}: {r['ours']}   (thesis: "
            f"{r['thesis'] or '-'})",
            markup=False,
            highlight=False,
        )
    for path in written:
        say(f"wrote {path}")
    _write_report(report, "cloudsurfaces", out, written, {"figures": len(FIGURES)}, {}, seed)
