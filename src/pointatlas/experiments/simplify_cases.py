"""The simplification experiments of thesis 4.4.3 (Figs. 4.10-4.14).

Cases: the sphere (5,122 points) for eta in {500, 200, 100, 50, 25} from the same
six random seeds, both vertex methods; the Fandisk (36 seeds, eta = 75, no
split/merge; star and general faces); the torus with 11 seeds whose top face has a
hole; a genus-2 shape; the noisy dodecahedron (962 points, 25 % noise, k = 12,
eta = 50, 12 random seeds, split and merge). Each case (`run_case`) writes a picture
(segmentation | mesh by plane intersection | mesh by optimisation | mesh by the
default constrained plane fit, ``vertices="fit"``) and returns its numbers;
`write_simplify_outputs` writes the numbers of all cases.
"""

from __future__ import annotations

import math
import time
import warnings
from pathlib import Path

import numpy as np

from .._core import PointAtlasError
from ..io import write_json, write_text
from ..segment import vsa_segment
from ..simplify import SimplifyWarning, simplify_segmentation

__all__ = ["CASES", "results_markdown", "run_case", "write_simplify_outputs"]


def _sphere_points():
    from ..synth import sphere

    m = sphere(5122)
    return m.vertices, m.normals, "sphere_5122"


def _torus_points():
    from ..synth import torus

    m = torus(1.0, 0.4, n_major=150, n_minor=90)  # 13,500 points (thesis: 13,503)
    return m.vertices, m.normals, "torus_13500"


def _noisy_dodecahedron(seed):
    from ..io import vertex_normals
    from ..synth import add_normal_noise, dodecahedron

    m = dodecahedron(4)  # 962 points
    noisy = add_normal_noise(m.vertices, m.normals, 0.25, k=12, rng=seed)
    return noisy, vertex_normals(noisy, m.faces), "dodecahedron_962_noise25"


def _bundled(name):
    from .. import data

    ps = data.load(name)
    return np.asarray(ps.points), np.asarray(ps.normals), ps.name


def _torus_seeds(points, normals):
    """11 seeds like Fig. 4.12: top, bottom, 4 on the outside, 5 on the inside."""
    ang = np.arctan2(points[:, 1], points[:, 0])

    def pick(target_normal, angle):
        score = normals @ target_normal - 0.3 * np.abs(np.angle(np.exp(1j * (ang - angle))))
        return int(np.argmax(score))

    seeds = [pick(np.array([0, 0, 1.0]), 0.0), pick(np.array([0, 0, -1.0]), 0.0)]
    for a in np.arange(4) * np.pi / 2:
        seeds.append(pick(np.array([math.cos(a), math.sin(a), 0.0]), a))
    for a in np.arange(5) * 2 * np.pi / 5 + 0.3:
        seeds.append(pick(-np.array([math.cos(a), math.sin(a), 0.0]), a))
    return np.array(sorted(set(seeds)), dtype=np.int64)


def _simplify(points, normals, seg, *, k, vertices, faces="general", weight=1.0):
    t0 = time.perf_counter()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", SimplifyWarning)
        mesh = simplify_segmentation(
            points,
            normals,
            seg.labels,
            k=k,
            vertices=vertices,
            faces=faces,
            centers=seg.centroids,
            proxy_normals=seg.proxy_normals,
            weight=weight,
        )
    row = mesh.summary()
    row["seconds"] = time.perf_counter() - t0
    row["warnings"] = [str(w.message) for w in caught]
    return mesh, row


def _picture(path, title, points, normals, seg_labels, meshes):
    from ..viz import MeshPanel, PointsPanel, fit_camera, render_side_by_side

    # colour the points by the regions that were meshed (VSA labels after clean-up),
    # so points and faces share colours; the VSA region count is in the numbers
    shown = meshes[0][1].labels if meshes else seg_labels
    panels = [PointsPanel(points, normals=normals, labels=shown, title="regions")]
    for name, mesh in meshes:
        panels.append(
            MeshPanel(
                mesh.vertices,
                [p.tolist() for p in mesh.polygons],
                face_labels=mesh.face_region[mesh.polygon_face],
                title=f"{name}: {mesh.n_faces} faces",
            )
        )
    return render_side_by_side(
        path, panels, title=title, view=fit_camera(points), size=(700 * len(panels), 700)
    )


_METHOD_LABEL = {"lsq": "plane intersection", "optimize": "optimisation", "fit": "plane fit"}


def _case_sphere(out: Path, seed: int) -> list[dict]:
    pts, nrm, name = _sphere_points()
    seeds = np.random.default_rng(seed).choice(pts.shape[0], 6, replace=False)
    rows = []
    for eta in (500.0, 200.0, 100.0, 50.0, 25.0):
        seg = vsa_segment(pts, nrm, k=8, seeds=seeds, eta=eta, split=True, merge=True)
        meshes = []
        for method in ("lsq", "optimize", "fit"):
            w = 3.0 if (method == "optimize" and eta == 500.0) else 1.0
            mesh, row = _simplify(pts, nrm, seg, k=8, vertices=method, weight=w)
            row.update(case="sphere", eta=eta, vsa_regions=seg.n_regions)
            if method == "optimize":
                row["weight"] = w
            rows.append(row)
            meshes.append((_METHOD_LABEL[method], mesh))
        _picture(
            out / f"sphere_eta{int(eta)}.png",
            f"{name}, eta = {eta:g}",
            pts,
            nrm,
            seg.labels,
            meshes,
        )
    return rows


def _case_fandisk(out: Path, seed: int) -> list[dict]:
    pts, nrm, name = _bundled("fandisk")
    seeds = np.random.default_rng(seed).choice(pts.shape[0], 36, replace=False)
    seg = vsa_segment(pts, nrm, k=8, seeds=seeds, eta=75.0, split=False, merge=False)
    rows, meshes = [], []
    for faces, method in (("star", "lsq"), ("general", "lsq"), ("general", "fit")):
        mesh, row = _simplify(pts, nrm, seg, k=8, vertices=method, faces=faces)
        row.update(case="fandisk", faces=faces, vsa_regions=seg.n_regions)
        rows.append(row)
        meshes.append((f"{faces} faces, {_METHOD_LABEL[method]}", mesh))
    _picture(
        out / "fandisk.png",
        f"{name}: 36 seeds, eta = 75, no split/merge",
        pts,
        nrm,
        seg.labels,
        meshes,
    )
    return rows


def _case_torus(out: Path, seed: int) -> list[dict]:
    pts, nrm, name = _torus_points()
    seeds = _torus_seeds(pts, nrm)
    seg = vsa_segment(pts, nrm, k=8, seeds=seeds, split=False, merge=False)
    rows, meshes = [], []
    # w~ = 1 (thesis default) shrinks the torus; w~ = 10 keeps it (see the docs)
    for method, w in (("lsq", 1.0), ("optimize", 1.0), ("optimize", 10.0), ("fit", 1.0)):
        mesh, row = _simplify(pts, nrm, seg, k=8, vertices=method, weight=w)
        row.update(case="torus", vsa_regions=seg.n_regions, n_seeds=int(seeds.size))
        if method == "optimize":
            row["weight"] = w
        rows.append(row)
        if method != "optimize" or w > 1.0:
            label = _METHOD_LABEL[method] + (f" (w = {w:g})" if method == "optimize" else "")
            meshes.append((label, mesh))
    _picture(
        out / "torus.png",
        f"{name}: {seeds.size} seeds, no split/merge",
        pts,
        nrm,
        seg.labels,
        meshes,
    )
    return rows


def _two_torus_points():
    """The 3,838-point stand-in of the shared data when present, else bundled 'eight'."""
    shared = Path(__file__).resolve().parents[3] / "../shared/data/models/double_torus_2174.obj"
    if shared.exists():
        from ..io import read_point_set

        ps = read_point_set(shared)
        return np.asarray(ps.points), np.asarray(ps.normals), ps.name
    return _bundled("eight")


def _manual_regions(points, normals, n_sectors=6, threshold=0.7):
    """Regions chosen by hand as in Fig. 4.13: top and bottom (normal within 45 deg of
    the thin axis) and the side walls by sectors of the horizontal normal direction
    (connected pieces become separate regions in `simplify_segmentation`)."""
    up_axis = int(np.argmin(np.ptp(points, axis=0)))
    a, b = [d for d in range(3) if d != up_axis]
    up = normals[:, up_axis]
    ang = np.arctan2(normals[:, b], normals[:, a])
    sector = np.floor((ang + np.pi) / (2 * np.pi) * n_sectors + 0.5).astype(np.int64) % n_sectors
    lab = np.where(up > threshold, n_sectors, np.where(up < -threshold, n_sectors + 1, sector))
    return np.unique(lab, return_inverse=True)[1].astype(np.int64)


def _case_two_torus(out: Path, seed: int) -> list[dict]:
    pts, nrm, name = _two_torus_points()
    rows = []
    # manually selected regions, as in the thesis (Fig. 4.13)
    manual = _manual_regions(pts, nrm)
    meshes = []
    for method, w in (("lsq", 1.0), ("optimize", 10.0), ("fit", 1.0)):
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", SimplifyWarning)
            mesh = simplify_segmentation(pts, nrm, manual, k=8, vertices=method, weight=w)
        row = mesh.summary()
        row.update(
            case="two_torus",
            regions="manual",
            vsa_regions=int(manual.max()) + 1,
            warnings=[str(x.message) for x in caught],
        )
        if method == "optimize":
            row["weight"] = w
        rows.append(row)
        label = _METHOD_LABEL[method] + (f" (w = {w:g})" if method == "optimize" else "")
        meshes.append((label, mesh))
    _picture(
        out / "two_torus.png",
        f"{name}: manual regions (top, bottom, 6 wall sectors)",
        pts,
        nrm,
        manual,
        meshes,
    )
    # VSA regions from random seeds
    shown = None
    for rng in range(seed, seed + 4):
        seg = vsa_segment(pts, nrm, k=8, seeds=12, rng=rng, split=False, merge=False)
        pair = []
        for method in ("lsq", "fit"):
            try:
                mesh, row = _simplify(pts, nrm, seg, k=8, vertices=method)
            except PointAtlasError as exc:  # degenerate segmentation: recorded, not fatal
                rows.append({"case": "two_torus", "rng": rng, "error": str(exc)})
                break
            row.update(case="two_torus", regions="VSA", vsa_regions=seg.n_regions, rng=rng)
            rows.append(row)
            pair.append((_METHOD_LABEL[method], mesh))
        if len(pair) == 2 and (shown is None or (pair[0][1].is_closed and not shown[2].is_closed)):
            shown = (rng, seg, pair[0][1], pair)
    if shown is not None:
        rng, seg, _, pair = shown
        _picture(
            out / "two_torus_vsa.png",
            f"{name}: 12 random seeds (rng {rng}), no split/merge",
            pts,
            nrm,
            seg.labels,
            pair,
        )
    return rows


def _case_dodecahedron(out: Path, seed: int) -> list[dict]:
    pts, nrm, name = _noisy_dodecahedron(seed)
    rows = []
    for eta in (50.0, 30.0):
        seg = vsa_segment(pts, nrm, k=12, seeds=12, eta=eta, split=True, merge=True, rng=seed)
        meshes = []
        for method in ("lsq", "optimize", "fit"):
            mesh, row = _simplify(pts, nrm, seg, k=12, vertices=method)
            row.update(
                case="dodecahedron", eta=eta, vsa_regions=seg.n_regions, vsa_iterations=seg.n_iter
            )
            rows.append(row)
            meshes.append((_METHOD_LABEL[method], mesh))
        _picture(
            out / f"dodecahedron_eta{int(eta)}.png",
            f"{name}: k = 12, eta = {eta:g}, 12 seeds, split+merge",
            pts,
            nrm,
            seg.labels,
            meshes,
        )
    return rows


CASES = {
    "sphere": _case_sphere,
    "fandisk": _case_fandisk,
    "torus": _case_torus,
    "two_torus": _case_two_torus,
    "dodecahedron": _case_dodecahedron,
}


def run_case(name: str, out: Path, seed: int = 0) -> list[dict]:
    """Run one reproduction case, writing its pictures into ``out``.

    Parameters
    ----------
    name : str
        One of `CASES`.
    out : pathlib.Path
        Existing folder of the pictures.
    seed : int
        Seed of the random VSA seeds and the noise.

    Returns
    -------
    rows : list of dict
        One per mesh: `SimplifiedMesh.summary` with the case's settings.
    """
    if name not in CASES:
        raise PointAtlasError(f"unknown case {name!r}; choose from {', '.join(CASES)}")
    return CASES[name](Path(out), seed)


def results_markdown(rows: list[dict]) -> str:
    """The result rows of `run_case` as a markdown table."""
    head = (
        "| case | setting | VSA regions | faces | vertices | holes | method | closed | "
        "oriented | max planarity | mean dist | max dist |"
    )
    lines = [head, "|" + "---|" * 12]
    for r in rows:
        setting = ", ".join(
            f"{key}={r[key]}"
            for key in ("regions", "eta", "faces", "weight", "anchor_weight", "rng")
            if r.get(key) is not None
        )
        if "error" in r:
            lines.append(f"| {r['case']} | {setting} | - | - | - | - | - | error: {r['error']} |")
            continue
        method = r["vertex_method"] + (" (fallback)" if r["fallback"] else "")
        lines.append(
            f"| {r['case']} | {setting} | {r['vsa_regions']} | {r['n_faces']} | "
            f"{r['n_vertices']} | {r['n_faces_with_holes']} | {method} | {r['is_closed']} | "
            f"{r['is_oriented']} | {r['max_planarity_error']:.2g} | {r['distance_mean']:.4f} | "
            f"{r['distance_max']:.4f} |"
        )
    return "\n".join(lines) + "\n"


def write_simplify_outputs(rows: list[dict], out: Path) -> str:
    """Write ``results.json`` and ``results.md`` into ``out``.

    Parameters
    ----------
    rows : list of dict
        The result rows of `run_case`.
    out : pathlib.Path
        Existing output folder.

    Returns
    -------
    str
        The markdown table (`results_markdown`).
    """
    write_json(out / "results.json", rows, indent=2)
    md = results_markdown(rows)
    write_text(out / "results.md", md)
    return md
