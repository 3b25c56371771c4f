"""``pointatlas experiment denoise``: thesis Table 5.3 and Figs. 6.7-6.9.

Table 5.3: normal MSE (Eq. 5.10) of the noisy normals, of the normal voting
filter of [YRS+18] (reconstructed) and of the thesis' adaptive-k variant, on seven
models at 0.3 l and 0.6 l noise along the normals (l: mean 6-NN spacing; normals:
area-weighted vertex normals of the clean and of the noisy mesh). Figs. 6.7/6.8:
flatness on the noisy dodecahedron (shared with ``experiment neighbourhoods``).
Fig. 6.9: flatness denoising (Eq. 6.3) of the noisy dodecahedron, three (k, eta)
settings and the decreasing schedule, with distances to the clean model.
"""

from __future__ import annotations

import csv
import io
import json
import time
from pathlib import Path
from typing import Annotated

import numpy as np
import typer

from .._core import PointAtlasError
from ..denoise import (
    THESIS_FILTER_PARAMETERS,
    add_noise,
    denoise_measures,
    filter_normals,
    flatness_denoise,
    normal_mse,
)
from ._app import console, experiment_app, guarded, progress_bar, say
from ._outputs import check_outputs, write_text

__all__ = [
    "FIG_6_9_SETTINGS",
    "TABLE_5_3_MODELS",
    "THESIS_TABLE_5_3",
    "denoise_experiment_command",
    "fig_6_9",
    "table_5_3",
]

#: model -> file under DATA/models (None: pointatlas.synth); thesis sizes in 5.4
TABLE_5_3_MODELS = {
    "cube": None,  # synth cube(18): 1,946 vertices (thesis 1,906)
    "bearing": "thrust_bearing_6340.obj",
    "fandisk": "fandisk_6475.obj",
    "sharp_sphere": "sharp_sphere_10443.obj",
    "fertility": "fertility_13971.obj",
    "octahedron": None,  # synth octahedron(64): 16,386 vertices (thesis 16,395)
    "rockerarm": "rockerarm_13910.obj",
}

#: thesis Table 5.3: (noise, [YRS+18], ours) at 0.3 l and at 0.6 l
THESIS_TABLE_5_3 = {
    "cube": ((0.01817, 0.00472, 0.00381), (0.06778, 0.04101, 0.01718)),
    "bearing": ((0.01914, 0.09220, 0.06311), (0.08796, 0.10588, 0.09971)),
    "fandisk": ((0.01598, 0.04710, 0.03304), (0.05907, 0.06702, 0.05285)),
    "sharp_sphere": ((0.03395, 0.15219, 0.12499), (0.09194, 0.16233, 0.14309)),
    "fertility": ((0.13404, 0.22036, 0.19741), (0.23215, 0.25364, 0.25100)),
    "octahedron": ((0.28785, 0.28234, 0.27533), (0.30471, 0.27754, 0.27162)),
    "rockerarm": ((0.01715, 0.08137, 0.06715), (0.06368, 0.08407, 0.07817)),
}

#: Fig. 6.9: (k, eta, schedule) of panels (b)-(d), then our decreasing schedule
FIG_6_9_SETTINGS = ((14, 0.5, "constant"), (8, 0.5, "constant"), (28, 1.0, "constant"),
                    (14, 0.5, "decreasing"))  # fmt: skip


def _load_model(name: str, data: Path):
    """(vertices, triangles) of a Table 5.3 model."""
    from ..io import read_mesh
    from ..synth import cube, octahedron

    if name == "cube":
        m = cube(18)
        return np.asarray(m.vertices), np.asarray(m.faces)
    if name == "octahedron":
        m = octahedron(64)
        return np.asarray(m.vertices), np.asarray(m.faces)
    path = data / "models" / TABLE_5_3_MODELS[name]
    if not path.is_file():
        raise PointAtlasError(f"{name}: missing {path} (give --data, the shared data folder)")
    mesh = read_mesh(path)
    return np.asarray(mesh.vertices), np.asarray(mesh.triangles)


def table_5_3(data: Path, *, models=tuple(TABLE_5_3_MODELS), seed: int = 0) -> list[dict]:
    """Rows of Table 5.3 (one per model and noise level), with timings."""
    from ..synth import vertex_normals

    rows = []
    with progress_bar("Table 5.3", total=2 * len(models)) as advance:
        for name in models:
            verts, faces = _load_model(name, data)
            keep = np.zeros(len(verts), dtype=bool)
            keep[np.unique(faces)] = True
            clean_n = vertex_normals(verts, faces)
            p, rho, tau = THESIS_FILTER_PARAMETERS[name]
            for level, amp in enumerate((0.3, 0.6)):
                noisy = verts.copy()
                noisy[keep] = add_noise(verts[keep], clean_n[keep], amp, k=6, rng=seed + level)
                noisy_n = vertex_normals(noisy, faces)
                ok = keep & np.isfinite(noisy_n).all(axis=1)
                pts, nn, cn = noisy[ok], noisy_n[ok], clean_n[ok]
                t0 = time.perf_counter()
                fixed = filter_normals(pts, nn, rho=rho, tau=tau, n_iter=p)
                t1 = time.perf_counter()
                ours = filter_normals(pts, nn, rho=rho, tau=tau, n_iter=p, adaptive=True)
                t2 = time.perf_counter()
                thesis = THESIS_TABLE_5_3[name][level]
                rows.append(
                    {
                        "model": name,
                        "n_points": int(ok.sum()),
                        "noise": f"{amp} l",
                        "p": p,
                        "rho": rho,
                        "tau": tau,
                        "mse_noise": normal_mse(nn, cn),
                        "mse_yrs18": normal_mse(fixed.normals, cn),
                        "mse_ours": normal_mse(ours.normals, cn),
                        "thesis_noise": thesis[0],
                        "thesis_yrs18": thesis[1],
                        "thesis_ours": thesis[2],
                        "mean_default_k": float(fixed.default_k.mean()),
                        "mean_chosen_k": float(ours.k.mean()),
                        "n_fallback": int(ours.is_fallback.sum()),
                        "seconds_yrs18": round(t1 - t0, 3),
                        "seconds_ours": round(t2 - t1, 3),
                    }
                )
                advance()
    return rows


def fig_6_9(out: Path, *, seed: int = 0, size=(1250, 330)) -> tuple[list[dict], list[Path]]:
    """Flatness denoising of the noisy dodecahedron (3,842 points, 25 %, 60 iterations)."""
    from ..synth import dodecahedron
    from ..viz import MeshPanel, PointsPanel, render_side_by_side

    m = dodecahedron(8)
    noisy = add_noise(m.points, m.normals, 0.25, k=12, rng=seed)
    results = [("(a) noisy", noisy, None)]
    rows = []
    base = denoise_measures(noisy, m.points, clean_normals=m.normals, clean_faces=m.faces)
    rows.append({"setting": "noisy", **base.as_dict(), "seconds": 0.0})
    for k, eta, schedule in FIG_6_9_SETTINGS:
        t0 = time.perf_counter()
        r = flatness_denoise(noisy, k=k, eta=eta, eps=0.1, n_iter=60, schedule=schedule,
                             normals=m.normals)  # fmt: skip
        sec = time.perf_counter() - t0
        label = f"k = {k}, eta = {eta}" + (", decreasing" if schedule == "decreasing" else "")
        meas = denoise_measures(r.points, m.points, normals=r.normals, clean_normals=m.normals,
                                clean_faces=m.faces)  # fmt: skip
        rows.append({"setting": label, **meas.as_dict(), "seconds": round(sec, 3)})
        results.append((label, r.points, r.energy))
    panels = [PointsPanel(p, scalars=e, scalar_name="flatness", cmap="Blues", title=t, clim=(0, 2))
              if e is not None else PointsPanel(p, title=t) for t, p, e in results]  # fmt: skip
    meshes = [MeshPanel(p, m.faces, title=t) for t, p, _ in results]
    written = [
        render_side_by_side(out / "fig6_9_points.png", panels, size=size,
                            title="Fig. 6.9: flatness denoising, 60 iterations, eps = 0.1"),
        render_side_by_side(out / "fig6_9_mesh.png", meshes, size=size,
                            title="Fig. 6.9: the same points with the clean connectivity"),
    ]  # fmt: skip
    return rows, written


def _csv(rows: list[dict]) -> str:
    buf = io.StringIO()
    writer = csv.DictWriter(buf, fieldnames=list(rows[0]), lineterminator="\n")
    writer.writeheader()
    writer.writerows(rows)
    return buf.getvalue()


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
) -> None:
    """Table 5.3 (normal filtering, fixed vs adaptive k) and Figs. 6.7-6.9 (flatness)."""
    from ._exp_features import noisy_dodecahedron_flatness

    chosen = tuple(models) if models else tuple(TABLE_5_3_MODELS)
    unknown = [m for m in chosen if m not in TABLE_5_3_MODELS]
    if unknown:
        raise PointAtlasError(
            f"--model must be among {', '.join(TABLE_5_3_MODELS)}; got {', '.join(unknown)}"
        )
    check_outputs([], folders=[("--out", out)])
    out.mkdir(exist_ok=True)
    written: list[Path] = []
    summary: dict = {"seed": seed}
    if table:
        rows = table_5_3(data, models=chosen, seed=seed)
        summary["table_5_3"] = rows
        written.append(write_text(out / "table5_3.csv", _csv(rows)))
        for r in rows:
            console.print(
                f"  {r['model']:13s} {r['noise']}: noise {r['mse_noise']:.5f} "
                f"[YRS+18] {r['mse_yrs18']:.5f} ours {r['mse_ours']:.5f}   (thesis "
                f"{r['thesis_noise']:.5f} {r['thesis_yrs18']:.5f} {r['thesis_ours']:.5f})"
            )
    if figures:
        written += noisy_dodecahedron_flatness(out, rng=seed)
        rows, pics = fig_6_9(out, seed=seed)
        summary["fig_6_9"] = rows
        written += pics
        written.append(write_text(out / "fig6_9.csv", _csv(rows)))
        for r in rows:
            console.print(
                f"  Fig. 6.9 {r['setting']:28s} p2m mean {r['p2m_mean']:.5f} "
                f"max {r['p2m_max']:.5f} Chamfer {r['chamfer']:.2e} drift {r['drift_share']:.3f}"
            )
    written.append(write_text(out / "summary.json", json.dumps(summary, indent=1) + "\n"))
    for path in written:
        say(f"wrote {path}")
