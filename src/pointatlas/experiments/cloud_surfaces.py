"""Thesis Chapter A (cloud surfaces): pictures and numbers.

Density models (Figs 2.2, 2.5, 2.6), Algorithm 1 on the cube with the three
curvature variants (Fig. 2.9), the curve and the ellipse of the 2-D covers (Figs
2.14, 2.15), the noisy sphere and dodecahedron (Fig. 2.17) and the two dynamics
experiments (Figs 2.20, 2.21). Each ``*_figures`` function appends its rows
(figure, quantity, ours, thesis) and returns the PNGs it wrote;
`run_cloud_surfaces` runs them all and writes ``cloudsurfaces.csv`` and, last,
``summary.json``.
"""

from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np

from ..complex import cloud_complex, curve_report, realize_complex, surface_report
from ..cover import ball_cover, search_cover_scale
from ..dynamics import deform_points
from ..io import write_summary_json, write_text
from ..synth import (
    add_normal_noise,
    clouds_from_mesh,
    cube,
    dodecahedron,
    plane_patch,
    sphere,
    sphere_density,
)
from ..viz import membership_colors
from ._files import csv_records, save_figure

__all__ = [
    "FIGURES",
    "curve_figures",
    "density_figures",
    "dynamics_figures",
    "mesh_curvature_figure",
    "noisy_figures",
    "run_cloud_surfaces",
]

#: the PNG files written, in order
FIGURES = (
    "fig2_2_delta_h.png",
    "fig2_5_eta12.png",
    "fig2_6_eta3.png",
    "fig2_9_cube_eta3_mean.png",
    "fig2_14_curve.png",
    "fig2_15_ellipse.png",
    "fig2_17_noisy_sphere.png",
    "fig2_17_noisy_dodecahedron.png",
    "fig2_20_lifted_grid.png",
    "fig2_21_cube_to_sphere.png",
)

_ALPHA = math.pi / 3  # the triangle angle of Figs 2.2, 2.5, 2.6


def _row(rows, figure, quantity, ours, thesis=""):
    rows.append({"figure": figure, "quantity": quantity, "ours": ours, "thesis": thesis})


def density_figures(out: Path, rows: list) -> list[Path]:
    """Figs 2.2 (delta_h of eta1/eta2), 2.5 (eta1, eta2) and 2.6 (eta3), alpha = pi/3."""
    from matplotlib.figure import Figure

    s = np.linspace(0.0, 2 * math.pi, 721)
    ring = np.column_stack([np.cos(s), np.sin(s), np.zeros_like(s)])  # t = pi/2: eta = delta_h
    fig = Figure(figsize=(9, 3.6))
    for k, (model, cs) in enumerate((("eta1", (0.0, 1.0, 3.0)), ("eta2", (1.0, 2.0, 5.0)))):
        ax = fig.add_subplot(1, 2, k + 1)
        for c in cs:
            dh = sphere_density(model, ring, _ALPHA, 1.0, c=c)
            ax.plot(s, dh, label=f"c = {c:g}")
            back = math.pi + _ALPHA / 2  # the direction opposite the sector's bisector
            low = float(
                sphere_density(model, [[math.cos(back), math.sin(back), 0.0]], _ALPHA, 1.0, c=c)[0]
            )
            _row(
                rows,
                "2.2",
                f"{model} delta_h at pi + alpha/2, c = {c:g}",
                round(low, 6),
                "c/(c+1)" if model == "eta1" else "(c-1)/(c+1)",
            )
        ax.axvline(_ALPHA, color="grey", lw=0.8, ls=":")
        ax.axvline(math.pi + _ALPHA / 2, color="grey", lw=0.8, ls="--")
        ax.set_title(f"Fig. 2.2: delta_h of {model} (alpha = pi/3)")
        ax.set_xlabel("azimuth s")
        ax.legend(fontsize=8, loc="upper right")  # fixed: "best" warns when slow
    written = [save_figure(fig, out / FIGURES[0], dpi=80)]
    # Figs 2.5 / 2.6: the densities on the (azimuth, polar angle) sphere and in the xy-plane
    ss, tt = np.meshgrid(np.linspace(0, 2 * math.pi, 181), np.linspace(0, math.pi, 91))
    dirs = np.stack([np.cos(ss) * np.sin(tt), np.sin(ss) * np.sin(tt), np.cos(tt)], -1)
    fig = Figure(figsize=(12, 3.2))
    for k, (model, c) in enumerate((("eta1", 0.0), ("eta1", 1.0), ("eta2", 1.0), ("eta2", 3.0))):
        ax = fig.add_subplot(1, 4, k + 1)
        eta = sphere_density(model, dirs.reshape(-1, 3), _ALPHA, 1.0, c=c).reshape(ss.shape)
        ax.imshow(
            eta, extent=(0, 2 * math.pi, math.pi, 0), cmap="coolwarm", vmin=0, vmax=1, aspect="auto"
        )
        ax.set_title(f"Fig. 2.5: {model}, c = {c:g}", fontsize=9)
        ax.set_xlabel("azimuth s")
        ax.set_ylabel("polar angle t")
        _row(
            rows,
            "2.5",
            f"{model} c = {c:g}: mean of eta over the sphere",
            round(float(np.average(eta, weights=np.sin(tt))), 4),
        )
    written.append(save_figure(fig, out / FIGURES[1], dpi=80))
    xx, yy = np.meshgrid(np.linspace(-1, 1, 161), np.linspace(-1, 1, 161))
    disc = np.column_stack([xx.ravel(), yy.ravel(), np.zeros(xx.size)])
    inside = (xx**2 + yy**2 <= 1.0).ravel()
    fig = Figure(figsize=(12, 3.2))
    for k, (cv, ch) in enumerate(((1.0, 1.0), (0.5, 0.5), (0.0, 0.0), (1.0, 0.0))):
        ax = fig.add_subplot(1, 4, k + 1)
        eta = sphere_density("eta3", disc, _ALPHA, 1.0, c_v=cv, c_h=ch)
        img = np.where(inside, eta, np.nan).reshape(xx.shape)
        ax.imshow(img, extent=(-1, 1, -1, 1), origin="lower", cmap="coolwarm", vmin=0, vmax=1)
        ax.plot([0, math.cos(_ALPHA / 2)], [0, math.sin(_ALPHA / 2)], "k--", lw=0.8)
        ax.plot([0, 1, math.cos(_ALPHA)], [0, 0, math.sin(_ALPHA)], "k-", lw=0.8)
        ax.set_title(f"Fig. 2.6: eta3, c_v = {cv:g}, c_h = {ch:g}", fontsize=9)
        ax.set_axis_off()
        _row(
            rows,
            "2.6",
            f"eta3 c_v = {cv:g}, c_h = {ch:g}: mean of eta over the xy-disc",
            round(float(eta[inside].mean()), 4),
        )
    written.append(save_figure(fig, out / FIGURES[2], dpi=80))
    return written


def mesh_curvature_figure(out: Path, rows: list, *, seed: int) -> list[Path]:
    """Fig. 2.9: Algorithm 1 with eta3 on the 386-vertex cube: plain, Gaussian, mean."""
    from ..viz import PointsPanel, render_side_by_side

    m = cube(8)
    mesh_tri = np.unique(np.sort(m.faces, axis=1), axis=0)
    panels = []
    for kind in (None, "gaussian", "mean"):
        mc = clouds_from_mesh(m.vertices, m.faces, model="eta3", curvature=kind, rng=seed)
        K = cloud_complex(mc.clouds, mc.points, cloud_points=mc.cloud_points)
        rep = surface_report(K)
        same = bool(np.array_equal(K.triangles, mesh_tri))
        label = kind or "plain"
        _row(
            rows,
            "2.9",
            f"cube 386, eta3, {label}: points / complex = mesh / chi",
            f"{mc.points.shape[0]} / {same} / {rep.euler_characteristic}",
            "complex = mesh (pictures)",
        )
        title = f"eta3, {label}: {mc.points.shape[0]:,} points"
        panels.append(
            PointsPanel(mc.points, colors=membership_colors(K.n_memberships), title=title)
        )
    return [
        render_side_by_side(
            out / FIGURES[3],
            panels,
            size=(1200, 430),
            title="Fig. 2.9: cube (386 vertices), eta3 plain / Gaussian / mean curvature",
        )
    ]


def _curve_panel(ax, pts, cov, rep, title):
    from matplotlib.patches import Circle

    for c, r in zip(cov.centers, cov.ball_radius, strict=True):
        ax.add_patch(Circle(c[:2], r, fill=False, lw=0.4, color="0.6"))
    col = membership_colors(cov.cloud_complex.n_memberships) / 255.0
    ax.scatter(pts[:, 0], pts[:, 1], s=1.5, c=col)
    cp = np.asarray(cov.cloud_complex.cloud_points)
    for a, b in cov.cloud_complex.edges:
        ax.plot(cp[[a, b], 0], cp[[a, b], 1], "k-", lw=1.0)
    ax.plot(cp[:, 0], cp[:, 1], "k.", ms=3)
    ax.set_aspect("equal")
    ax.set_title(title, fontsize=9)
    ax.set_axis_off()


def curve_figures(out: Path, rows: list) -> list[Path]:
    """Fig. 2.14 (t -> (cos t, sin 2t), two radii) and Fig. 2.15 (ellipse, s = 0.3, 1.4)."""
    from matplotlib.figure import Figure

    t = np.linspace(0.0, 2 * math.pi, 2000, endpoint=False)
    fig8 = np.column_stack([np.cos(t), np.sin(2 * t)])
    cov = ball_cover(fig8, 0.2, dim=2, radius=0.8)
    rep = curve_report(cov.cloud_complex)
    deg = np.bincount(cov.cloud_complex.edges.ravel(), minlength=cov.n_clouds)
    _row(
        rows,
        "2.14",
        "curve (cos t, sin 2t), s = 0.2, r = 0.8: V / E / triangles",
        f"{rep.n_vertices} / {rep.n_edges} / {rep.n_triangles}",
        "a 1-D complex (picture)",
    )
    _row(
        rows,
        "2.14",
        "vertices of degree != 2 (the crossing at 0) / chi",
        f"{rep.vertices_bad_degree.size} (degree {int(deg.max())}) / {rep.euler_characteristic}",
        "figure eight: chi = -1",
    )
    fig = Figure(figsize=(6, 6))
    _curve_panel(
        fig.add_subplot(),
        fig8,
        cov,
        rep,
        f"Fig. 2.14: s = 0.2, r = 0.8 s: {rep.n_vertices} clouds, {rep.n_edges} edges",
    )
    written = [save_figure(fig, out / FIGURES[4], dpi=80)]
    a, b = 3.0, 1.0
    ell = np.column_stack([a * np.cos(t), b * np.sin(t)])
    fig = Figure(figsize=(10, 4.2))
    for k, s in enumerate((0.3, 1.4)):
        cov = ball_cover(ell, s, dim=2)
        rep = curve_report(cov.cloud_complex)
        deg = np.bincount(cov.cloud_complex.edges.ravel(), minlength=cov.n_clouds)
        what = "missing information" if k == 0 else "false information"
        _row(
            rows,
            "2.15",
            f"ellipse 3 x 1, s = {s}: V / E / endpoints / degree > 2 / 1-manifold",
            f"{rep.n_vertices} / {rep.n_edges} / {rep.n_endpoints} / {int((deg > 2).sum())} / "
            f"{rep.is_one_manifold}",
            what,
        )
        ax = fig.add_subplot(1, 2, k + 1)
        _curve_panel(
            ax,
            ell,
            cov,
            rep,
            f"Fig. 2.15: s = {s}: {rep.n_endpoints} endpoints, "
            f"{int((deg > 2).sum())} branchings ({what})",
        )
        f = a - b * b / a  # the medial axis: the segment between the centres of curvature
        ax.plot([-f, f], [0, 0], "b-", lw=1.2)
    written.append(save_figure(fig, out / FIGURES[5], dpi=80))
    return written


def _cover_picture(path, pts, cov, rep, title):
    from ..viz import MeshPanel, PointsPanel, render_side_by_side

    verts, faces = realize_complex(cov.cloud_complex, rep)
    panels = [
        PointsPanel(
            pts,
            colors=membership_colors(cov.cloud_complex.n_memberships),
            title="points by number of clouds",
        ),
        MeshPanel(np.nan_to_num(verts), faces, title=f"complex: {faces.shape[0]} triangles"),
    ]
    return render_side_by_side(path, panels, size=(1000, 520), title=title)


def noisy_figures(out: Path, rows: list, *, seed: int) -> list[Path]:
    """Fig. 2.17: noisy sphere (10,000 points, 50 %) and dodecahedron (3,842, 25 %)."""
    written = []
    cases = (
        (
            "sphere",
            sphere(10_000),
            0.5,
            np.round(np.arange(0.6, 1.31, 0.1), 2),
            "s = 1 (rotated sphere): closed, genus 0",
            FIGURES[6],
        ),
        (
            "dodecahedron",
            dodecahedron(8),
            0.25,
            np.round(np.arange(0.3, 1.01, 0.1), 2),
            "s = 1.9: closed, genus 0",
            FIGURES[7],
        ),
    )
    for name, m, amp, scales, thesis, fname in cases:
        noisy = add_normal_noise(m.points, m.normals, amp, k=12, rng=seed)
        res = search_cover_scale(noisy, scales, n_rotations=3, rng=seed)
        acc = [f"{res.scales[i]:g}/r{res.rotation_index[i]}" for i in res.accepted]
        i = res.chosen
        cov = ball_cover(noisy, **res.setting(i))
        rep = res.reports[i]
        _row(
            rows,
            "2.17",
            f"noisy {name} ({noisy.shape[0]} points, {amp:.0%}): accepted "
            f"settings of {res.scales.size} (s/rotation)",
            " ".join(acc) or "none",
            thesis,
        )
        _row(
            rows,
            "2.17",
            f"noisy {name}: chosen s / clouds / closed / chi / genus",
            f"{res.scales[i]:g} / {cov.n_clouds} / {rep.is_closed} / "
            f"{rep.euler_characteristic} / {rep.genus}",
            thesis,
        )
        written.append(
            _cover_picture(
                out / fname,
                noisy,
                cov,
                rep,
                f"Fig. 2.17: noisy {name}, s = {res.scales[i]:g}, "
                f"{cov.n_clouds} clouds, genus {rep.genus}",
            )
        )
    return written


def _dynamics_case(points, scale, accept, *, seed, n_offsets=24):
    """Search the lattice offsets at one scale; the chosen cover, its report and search."""
    res = search_cover_scale(points, [scale], n_offsets=n_offsets, rng=seed, accept=accept)
    i = res.chosen
    cov = ball_cover(points, **res.setting(i))
    return cov, res.reports[i], res, i


def _dynamics_rows(rows, fig, name, points, cov, rep, res, i, cp1):
    K = cov.cloud_complex
    fwd = deform_points(points, K, cp1)
    back = deform_points(fwd.points, K, cp1, inverse=True)
    err = float(np.abs(back.points - points).max() / np.abs(points).max())
    c = fwd.counts()
    share = 1.0 - c["unroutable"] / points.shape[0]
    _row(
        rows,
        fig,
        f"{name}: setting (offset of 24 tried) / clouds / triangles / accepted",
        f"offset {res.offset_index[i]} {np.round(res.offsets[res.offset_index[i]], 3).tolist()}"
        f" / {cov.n_clouds} / {rep.n_faces} / {bool(res.is_accepted[i])}",
        "Prop. 4 cover at the bounding box",
    )
    _row(
        rows,
        fig,
        f"{name}: routed share (triangle / edge / vertex / unroutable)",
        f"{share:.4f} ({c['triangle']} / {c['edge']} / {c['vertex']} / {c['unroutable']})",
        "every point moves (pictures)",
    )
    _row(rows, fig, f"{name}: forward then inverse, max relative error", f"{err:.1e}", "reversible")
    return fwd, share


def dynamics_figures(out: Path, rows: list, *, seed: int) -> tuple[list[Path], dict]:
    """Figs 2.20 (4,225-point planar grid, s = 0.25, interior cloud points lifted) and
    2.21 (1,538-point cube, s = 1, cloud points pushed onto the unit sphere)."""
    from ..viz import MeshPanel, PointsPanel, render_side_by_side

    shares = {}
    written = []
    plane = plane_patch(65, 65, width=1.0, height=1.0).vertices
    cube_pts = cube(16, size=2.0).vertices
    for fig, name, pts, s, accept, fname in (
        ("2.20", "planar grid 65 x 65 (unit square)", plane, 0.25, "open", FIGURES[8]),
        ("2.21", "cube 1,538 (edge 2)", cube_pts, 1.0, "closed", FIGURES[9]),
    ):
        cov, rep, res, i = _dynamics_case(pts, s, accept, seed=seed)
        verts, faces = realize_complex(cov.cloud_complex, rep)
        cp0 = np.nan_to_num(verts)
        if fig == "2.20":  # lift every cloud point off the boundary
            inner = np.ones(cov.n_clouds, dtype=bool)
            inner[rep.boundary_edges.ravel()] = False
            cp1 = cp0.copy()
            r2 = ((cp0[:, :2] - 0.5) ** 2).sum(axis=1)
            cp1[inner, 2] += 0.3 * np.exp(-r2[inner] / 0.08)
        else:
            cp1 = cp0 / np.linalg.norm(cp0, axis=1, keepdims=True)
        fwd, share = _dynamics_rows(rows, fig, name, pts, cov, rep, res, i, cp1)
        shares[fig] = share
        col = membership_colors(cov.cloud_complex.n_memberships)
        panels = [
            PointsPanel(pts, colors=col, title="(a) clouds"),
            MeshPanel(cp0, faces, title="(b) complex"),
            MeshPanel(cp1, faces, title="(c) moved cloud points"),
            PointsPanel(fwd.points, colors=col, title=f"(d) moved: {share:.1%} routed"),
        ]
        written.append(
            render_side_by_side(
                out / fname, panels, size=(1400, 400), title=f"Fig. {fig}: {name}, s = {s:g}"
            )
        )
    return written, shares


def run_cloud_surfaces(out: Path, *, seed: int = 0) -> tuple[list[dict], list[Path]]:
    """Every figure of Chapter A into ``out``, then the CSV and, last, ``summary.json``.

    Parameters
    ----------
    out : pathlib.Path
        Existing output folder.
    seed : int
        Seed of sampling, noise and rotations.

    Returns
    -------
    rows : list of dict
        (figure, quantity, ours, thesis) rows.
    written : list of pathlib.Path
        The files written, the summary last.
    """
    csv_path, json_path = out / "cloudsurfaces.csv", out / "summary.json"
    t0 = time.perf_counter()
    rows: list[dict] = []
    written = density_figures(out, rows)
    written += mesh_curvature_figure(out, rows, seed=seed)
    written += curve_figures(out, rows)
    written += noisy_figures(out, rows, seed=seed)
    pics, shares = dynamics_figures(out, rows, seed=seed)
    written += pics
    written.append(
        write_text(csv_path, csv_records(rows, ["figure", "quantity", "ours", "thesis"]))
    )
    payload = {
        "seed": seed,
        "rows": rows,
        "routed_share": shares,
        "seconds": round(time.perf_counter() - t0, 2),
    }
    write_summary_json(json_path, payload, written)
    return rows, [*written, json_path]
