"""``pointatlas cloudsurface`` and ``pointatlas deform``: cloud surfaces (thesis Chapter A).

``cloudsurface`` cuts a point set into clouds with the ball cover of Prop. 4/5
(Algorithm 2; a fixed scale or a search over scales and seeded rotations), or
generates clouds from a mesh (Algorithm 1, ``--from-mesh``), and writes into OUT_DIR:

- ``clouds.ply``: the points with every input field, ``n_clouds`` (number of clouds
  per point) and Example 2 colours (1 grey, 2 blue, 3 orange, 4+ red, 0 black);
- ``complex.ply`` (``complex.obj`` with line elements for a 2-D curve): the
  geometric realisation, one vertex per cloud;
- ``cloudsurface.npz``: the cloud set (CSR), the cloud points and the points, read
  by ``deform``;
- ``report.txt`` (a readable table), ``search.csv`` (with ``--search``, ``--rotations`` or
  ``--offsets``),
  ``cloudsurface.png`` (clouds beside the complex) and, last, ``report.json``.

``deform`` moves the points of a cloud surface with its cloud points (Algorithm 3).
"""

from __future__ import annotations

import csv
import io
import time
from pathlib import Path
from typing import Annotated

import numpy as np
import typer

from .._core import PointAtlasError, as_float, as_int
from ..complex import cloud_complex, curve_report, realize_complex, surface_report
from ..cover import ball_cover, cover_radii, search_cover_scale
from ._app import (
    app,
    console,
    deprecated_option,
    guarded,
    progress_bar,
    read_input,
    renamed_flag,
    say,
)
from ._flag_checks import named_as_typed
from ._outputs import (
    check_outputs,
    check_point_output,
    point_fields,
    write_point_output,
    write_summary_json,
    write_text,
)
from ._reports import REPORT_EXTENSIONS

__all__ = [
    "cloudsurface_command",
    "scale_grid",
]

_MODELS = ("eta1", "eta2", "eta3")


def scale_grid(smin: float, smax: float, step: float) -> np.ndarray:
    """Scales smin, smin + step, ... up to smax (inclusive to round-off), as for ``--search``."""
    smin = as_float(smin, "--search SMIN", lo=0.0, lo_open=True)
    smax = as_float(smax, "--search SMAX", lo=smin)
    step = as_float(step, "--search STEP", lo=0.0, lo_open=True)
    n = int(np.floor((smax - smin) / step + 1e-9)) + 1
    if n > 10_000:
        raise PointAtlasError(f"--search gives {n} scales; at most 10000 (raise STEP)")
    return np.round(smin + step * np.arange(n), 12)


def _out_paths(out_dir: Path, dim: int) -> dict:
    return {
        "clouds": out_dir / "clouds.ply",
        "complex": out_dir / ("complex.ply" if dim == 3 else "complex.obj"),
        "npz": out_dir / "cloudsurface.npz",
        "table": out_dir / "report.txt",
        "search": out_dir / "search.csv",
        "picture": out_dir / "cloudsurface.png",
        "json": out_dir / "report.json",
    }


def _write_npz(path: Path, K, points: np.ndarray, faces: np.ndarray, meta: dict) -> Path:
    from ..io import atomic_write

    with atomic_write(path, "wb") as fh:
        np.savez(
            fh,
            cloud_indptr=K.cloud_indptr,
            cloud_members=K.cloud_members,
            cloud_points=K.cloud_points,
            points=points,
            faces=faces,
            meta=np.array(repr(meta)),
        )
    return path


def _write_curve_obj(path: Path, vertices: np.ndarray, edges: np.ndarray) -> Path:
    buf = io.StringIO()
    buf.write("# cloud complex of a 2-D cover: one vertex per cloud, one line per 1-simplex\n")
    for v in vertices:
        buf.write(f"v {v[0]:.17g} {v[1]:.17g} {v[2]:.17g}\n")
    for a, b in edges.tolist():
        buf.write(f"l {a + 1} {b + 1}\n")
    return write_text(path, buf.getvalue())


def _picture(path: Path, points, counts, vertices, faces, edges, title: str) -> Path:
    from ..viz import MeshPanel, PointsPanel, membership_colors, render_side_by_side

    colors = membership_colors(counts)
    panels = [PointsPanel(points, colors=colors, title="points by number of clouds (Example 2)")]
    if faces.shape[0]:
        panels.append(MeshPanel(vertices, faces, title=f"complex: {faces.shape[0]} triangles"))
    else:  # a curve: sample the edges densely
        t = np.linspace(0.0, 1.0, 24)[None, :, None]
        a, b = vertices[edges[:, 0]][:, None, :], vertices[edges[:, 1]][:, None, :]
        seg = (a + t * (b - a)).reshape(-1, 3)
        pts = np.concatenate([seg, vertices[np.isfinite(vertices).all(axis=1)]])
        panels.append(PointsPanel(pts, title=f"complex: {edges.shape[0]} edges", lighting=False))
    return render_side_by_side(path, panels, title=title, size=(1200, 600))


def _search_csv(path: Path, rows: list[dict]) -> Path:
    buf = io.StringIO()
    writer = csv.DictWriter(buf, fieldnames=list(rows[0]), lineterminator="\n")
    writer.writeheader()
    writer.writerows(rows)
    return write_text(path, buf.getvalue())


def _run_cover(
    points, *, scale, search, rotations, offsets, accept, dim, layout, radius, seed, cloud_points
):
    """Fixed scale or search; returns (cover, search result or None, chosen setting).

    A fixed scale with ``--rotations``/``--offsets`` searches the placements at that
    scale; the first accepted setting is kept, else the closest (`ScaleSearch.chosen`).
    """
    if search is None and not rotations and not offsets:
        cov = ball_cover(
            points, scale, dim=dim, layout=layout, radius=radius, cloud_points=cloud_points
        )
        return cov, None, {"scale": scale, "rotation": 0, "offset": 0}
    grid = np.array([scale]) if search is None else scale_grid(*search)
    total = grid.size * (rotations + 1) * (offsets + 1)
    with progress_bar("cover search", total=total) as advance:
        res = search_cover_scale(
            points,
            grid,
            n_rotations=rotations,
            n_offsets=offsets,
            rng=seed,
            accept=accept,
            dim=dim,
            layout=layout,
            radius=radius,
            callback=lambda _: advance(),
        )
    pick = res.chosen
    cov = ball_cover(
        points,
        dim=dim,
        layout=layout,
        radius=radius,
        cloud_points=cloud_points,
        **res.setting(pick),
    )
    chosen = {
        "scale": float(res.scales[pick]),
        "rotation": int(res.rotation_index[pick]),
        "offset": int(res.offset_index[pick]),
    }
    return cov, res, chosen


def _cover_arguments(
    paths, from_mesh, *, dim, scale, search, rotations, offsets, accept, layout, radius
):
    """IN, OUT_DIR and the dimension from the arguments; one error for a bad combination."""
    if from_mesh is not None:
        if len(paths) != 1:
            raise PointAtlasError("with --from-mesh give only OUT_DIR (the mesh is the input)")
        in_path, out_dir = from_mesh, paths[0]
        dim = 3
    else:
        if len(paths) != 2:
            raise PointAtlasError(f"give IN and OUT_DIR; got {len(paths)} path(s)")
        in_path, out_dir = paths
        dim = as_int(dim, "--dim", lo=2, hi=3)
        if (scale is None) == (search is None):
            raise PointAtlasError("give exactly one of --scale S and --search SMIN SMAX STEP")
        if scale is not None:
            as_float(scale, "--scale", lo=0.0, lo_open=True)
        else:
            scale_grid(*search)
        as_int(rotations, "--rotations", lo=0, hi=1000)
        as_int(offsets, "--offsets", lo=0, hi=1000)
        if accept not in (None, "closed", "open"):
            raise PointAtlasError(f"--accept must be closed or open; got {accept!r}")
        _check_radius(dim, layout, radius)
    return in_path, out_dir, dim


def _check_radius(dim: int, layout: str, radius) -> None:
    """``--layout`` and ``--radius`` checked by `cover_radii`, named as typed."""
    if radius is not None and dim == 3:
        raise PointAtlasError(
            "--radius is for the 2-D cover (--dim 2); the 3-D cover's radii are fixed (Prop. 4)"
        )
    try:
        cover_radii(dim, layout, radius)
    except (TypeError, ValueError) as exc:
        raise named_as_typed(exc, {"radius": "--radius", "layout": "--layout"}) from None


def _checked_outputs(in_path, out_dir, dim, *, search, rotations, offsets, render, html_report):
    """The output paths of a run, checked before any work (OUT_DIR created)."""
    out = _out_paths(out_dir, dim)
    files = [
        ("clouds", out["clouds"], None),
        ("complex", out["complex"], None),
        ("cloudsurface.npz", out["npz"], None),
        ("report.txt", out["table"], None),
        ("search.csv", out["search"] if (search or rotations or offsets) else None, None),
        ("picture", out["picture"] if render else None, None),
        ("report.json", out["json"], None),
    ]
    files.append(("--report", html_report, REPORT_EXTENSIONS))
    check_outputs([in_path], [], [("OUT_DIR", out_dir)])
    check_outputs([in_path], [f for f in files if f[0] == "--report"])
    out_dir.mkdir(exist_ok=True)
    check_outputs([in_path], files)
    return out


def _write_cover_files(out, ps, cov, chosen, report, res, dim):
    """Clouds, complex, cloudsurface.npz, report.txt and search.csv of a cover run.

    Returns the files written and the complex's realisation (vertices, faces).
    """
    K = cov.cloud_complex
    written = []
    verts, faces = realize_complex(K, report) if dim == 3 else (np.asarray(K.cloud_points), None)
    written.append(_write_clouds(out["clouds"], ps, K.n_memberships))
    if dim == 3:
        from ..io import write_mesh

        written.append(write_mesh(out["complex"], np.nan_to_num(verts), faces))
    else:
        written.append(_write_curve_obj(out["complex"], verts, K.edges))
        faces = np.zeros((0, 3), np.int64)
    meta = {"kind": "cover", "dim": dim, "layout": cov.layout, **chosen}
    written.append(_write_npz(out["npz"], K, ps.points, faces, meta))
    written.append(write_text(out["table"], report.table()))
    if res is not None:
        written.append(_search_csv(out["search"], res.rows()))
    return written, verts, faces


def _is_accepted(report, accept, dim) -> bool:
    """A closed (or, with --accept open, any) cloud surface or 1-manifold curve."""
    closed_only = (accept or ("closed" if dim == 3 else "open")) == "closed"
    return (
        (report.is_cloud_surface and (report.is_closed or not closed_only))
        if dim == 3
        else (report.is_one_manifold and (report.is_closed or not closed_only))
    )


def _cover_payload(in_path, ps, cov, chosen, report, res, accepted, seed, placeholder, dim):
    """The numbers of report.json for a ball-cover run (the seconds are added after)."""
    K = cov.cloud_complex
    payload = {
        "input": str(in_path),
        "n_points": int(ps.n_points),
        "mode": "cover",
        "dim": dim,
        "layout": cov.layout,
        "scale": chosen["scale"],
        "rotation": chosen["rotation"],
        "rotation_matrix": cov.rotation.tolist(),
        "offset": chosen["offset"],
        "offset_vector": cov.offset.tolist(),
        "n_clouds": cov.n_clouds,
        "accepted": bool(accepted),
        "seed": seed,
        "points_per_cloud_count": np.bincount(K.n_memberships).tolist(),
        "fields": list(point_fields(ps, placeholder)),
        "report": report.summary(),
        "search": None
        if res is None
        else {
            "n_settings": int(res.scales.size),
            "accepted": [
                {
                    "scale": float(res.scales[i]),
                    "rotation": int(res.rotation_index[i]),
                    "offset": int(res.offset_index[i]),
                }
                for i in res.accepted
            ],
        },
    }
    return payload


_PathsArgument = Annotated[
    list[Path],
    typer.Argument(
        metavar="IN OUT_DIR",
        help="Point set or mesh file (or a bundled model name) and the output folder; "
        "with --from-mesh only OUT_DIR.",
    ),
]
_ModelOption = Annotated[
    str, typer.Option("--density", help="--from-mesh: density model eta1, eta2 or eta3.")
]
_COption = Annotated[
    float | None,
    typer.Option(
        "--density-c",
        help="--from-mesh: eta1/eta2 parameter c (default 0 for eta1, 1 for eta2).",
    ),
]


@app.command("cloudsurface")
@guarded
def cloudsurface_command(
    paths: _PathsArgument,
    scale: Annotated[
        float | None, typer.Option("--scale", help="Grid scale s of the ball cover.")
    ] = None,
    search: Annotated[
        tuple[float, float, float] | None,
        typer.Option("--search", help="Try scales SMIN SMAX STEP; keeps the first closed one."),
    ] = None,
    rotations: Annotated[
        int, typer.Option("--rotations", help="Random rotations tried (seeded by --seed).")
    ] = 0,
    offsets: Annotated[
        int,
        typer.Option("--offsets", help="Random lattice offsets tried with each rotation."),
    ] = 0,
    accept: Annotated[
        str | None,
        typer.Option("--accept", help="closed (default in 3-D) or open (boundary allowed)."),
    ] = None,
    dim: Annotated[int, typer.Option("--dim", help="3: Prop. 4; 2: a curve in the xy-plane.")] = 3,
    layout: Annotated[
        str, typer.Option("--layout", help="2-D cover: two-radius (Prop. 5 ii) or tiling (5 i).")
    ] = "two-radius",
    radius: Annotated[
        float | None, typer.Option("--radius", help="2-D cover: big radius in units of s.")
    ] = None,
    cloud_points: Annotated[
        str, typer.Option("--cloud-points", help="Realisation: centroid or center (ball).")
    ] = "centroid",
    from_mesh: Annotated[
        Path | None,
        typer.Option("--from-mesh", help="Generate clouds from this mesh (Algorithm 1)."),
    ] = None,
    model: _ModelOption = "eta1",
    c: _COption = None,
    c_v: Annotated[
        float, typer.Option("--density-c-v", help="--from-mesh: eta3 parameter c_v.")
    ] = 0.5,
    c_h: Annotated[
        float, typer.Option("--density-c-h", help="--from-mesh: eta3 parameter c_h.")
    ] = 0.5,
    t: Annotated[
        float,
        typer.Option("--radius-position", help="--from-mesh: ball radius position t in [0, 1)."),
    ] = 0.5,
    samples: Annotated[
        int, typer.Option("--samples", help="--from-mesh: samples per vertex and triangle.")
    ] = 10,
    curvature: Annotated[
        str, typer.Option("--curvature", help="--from-mesh: none, gaussian or mean scaling.")
    ] = "none",
    render: Annotated[
        bool, typer.Option("--render/--no-render", help="Write cloudsurface.png.")
    ] = True,
    seed: Annotated[int, typer.Option("--seed", help="Seed for rotations and sampling.")] = 0,
    html_report: Annotated[
        Path | None,
        typer.Option(
            "--report",
            help="Also write an HTML report with a 3-D view of the clouds and the complex.",
        ),
    ] = None,
    old_model: Annotated[str | None, deprecated_option("--model", "--density")] = None,
    old_c: Annotated[float | None, deprecated_option("--c", "--density-c")] = None,
    old_c_v: Annotated[float | None, deprecated_option("--c-v", "--density-c-v")] = None,
    old_c_h: Annotated[float | None, deprecated_option("--c-h", "--density-c-h")] = None,
    old_t: Annotated[float | None, deprecated_option("--t", "--radius-position")] = None,
):
    """Cloud surface of a point set (ball cover, Algorithm 2) or of a mesh (Algorithm 1).

    Writes into OUT_DIR the clouds (clouds.ply, Example 2 colours), the complex as a
    mesh, cloudsurface.npz (for ``deform``), report.txt, a picture and, last,
    report.json (topology report and the files of this run with their SHA-256).
    """
    model = renamed_flag("--density", model, "--model", old_model)
    c = renamed_flag("--density-c", c, "--c", old_c)
    c_v = renamed_flag("--density-c-v", c_v, "--c-v", old_c_v)
    c_h = renamed_flag("--density-c-h", c_h, "--c-h", old_c_h)
    t = renamed_flag("--radius-position", t, "--t", old_t)
    in_path, out_dir, dim = _cover_arguments(
        paths,
        from_mesh,
        dim=dim,
        scale=scale,
        search=search,
        rotations=rotations,
        offsets=offsets,
        accept=accept,
        layout=layout,
        radius=radius,
    )
    out = _checked_outputs(
        in_path,
        out_dir,
        dim,
        search=search,
        rotations=rotations,
        offsets=offsets,
        render=render,
        html_report=html_report,
    )
    t0 = time.perf_counter()
    if from_mesh is not None:
        _from_mesh(
            in_path,
            out,
            model=model,
            c=c,
            c_v=c_v,
            c_h=c_h,
            t=t,
            samples=samples,
            curvature=curvature,
            render=render,
            seed=seed,
            t0=t0,
            html_report=html_report,
        )
        return
    ps = read_input(in_path, with_normals=False)
    placeholder = {
        "n_clouds": np.zeros(ps.n_points, np.int64),
        "colors": np.zeros((ps.n_points, 3), np.uint8),
    }
    check_point_output(out["clouds"], ps, placeholder)
    cov, res, chosen = _run_cover(
        ps.points,
        scale=scale,
        search=search,
        rotations=rotations,
        offsets=offsets,
        accept=accept,
        dim=dim,
        layout=layout,
        radius=radius,
        seed=seed,
        cloud_points=cloud_points,
    )
    K = cov.cloud_complex
    report = surface_report(K) if dim == 3 else curve_report(K)
    written, verts, faces = _write_cover_files(out, ps, cov, chosen, report, res, dim)
    accepted = _is_accepted(report, accept, dim)
    if render:
        title = f"{ps.name}: s = {chosen['scale']:g}, {cov.n_clouds} clouds, " + (
            ("closed " if report.is_closed else "") + ("cloud surface" if dim == 3 else "curve")
            if accepted
            else "not accepted"
        )
        written.append(
            _picture(out["picture"], ps.points, K.n_memberships, verts, faces, K.edges, title)
        )
    payload = _cover_payload(
        in_path, ps, cov, chosen, report, res, accepted, seed, placeholder, dim
    )
    payload["seconds"] = round(time.perf_counter() - t0, 3)
    if html_report is not None:
        written.append(
            _html_report(
                html_report,
                in_path,
                payload,
                ps.points,
                K.n_memberships,
                verts,
                faces,
                written,
                seed,
            )
        )
    write_summary_json(out["json"], payload, written)
    _print_result(report, cov.n_clouds, chosen, accepted, res, payload["seconds"], dim)
    for path in [*written, out["json"]]:
        say(f"wrote {path}")


def _html_report(path, in_path, payload, points, counts, verts, faces, written, seed):
    """The HTML report: the numbers, the picture, a 3-D view of clouds and complex."""
    from ..viz import MeshLayer, PointsLayer, write_report

    numbers = {k: v for k, v in payload.items() if isinstance(v, int | float | str | bool)}
    numbers.update(
        {k: v for k, v in payload["report"].items() if isinstance(v, int | float | str | bool)}
    )
    layers = [PointsLayer(points, {"n_clouds": np.asarray(counts)}, name="points")]
    if faces is not None and len(faces):
        layers.append(MeshLayer(np.nan_to_num(verts), faces, name="cloud complex", opacity=0.6))
    return write_report(
        path,
        title=f"pointatlas cloudsurface: {Path(str(in_path)).name}",
        summary={"file": str(in_path), "points": int(points.shape[0])},
        parameters={k: payload[k] for k in ("mode", "seed") if k in payload},
        tables={"result": numbers},
        pictures=[p for p in written if Path(p).suffix.lower() == ".png"],
        layers=layers,
        seed=seed,
    )


def _write_clouds(path: Path, ps, counts: np.ndarray) -> Path:
    from ..viz import membership_colors

    return write_point_output(
        path, ps, {"n_clouds": np.asarray(counts, np.int64), "colors": membership_colors(counts)}
    )


def _print_result(report, n_clouds, chosen, accepted, res, seconds, dim):
    if res is not None:
        console.print(
            f"search: {res.accepted.size} of {res.scales.size} settings accepted; "
            f"using s = {chosen['scale']:g}, rotation {chosen['rotation']}, "
            f"offset {chosen['offset']}"
        )
    if dim == 3:
        console.print(
            f"{n_clouds} clouds: V {report.n_vertices}, E {report.n_edges}, "
            f"F {report.n_faces}, chi {report.euler_characteristic}, "
            f"closed {report.is_closed}, boundary loops {report.n_boundary_loops}, "
            f"orientable {report.is_orientable}, genus {report.genus}, "
            f"cloud surface {report.is_cloud_surface} ({seconds:.1f} s)"
        )
    else:
        console.print(
            f"{n_clouds} clouds: V {report.n_vertices}, E {report.n_edges}, "
            f"1-manifold {report.is_one_manifold}, closed {report.is_closed}, "
            f"components {report.n_components} ({seconds:.1f} s)"
        )


def _from_mesh(
    in_path, out, *, model, c, c_v, c_h, t, samples, curvature, render, seed, t0, html_report
):
    if c is None:  # the thesis' settings: c = 0 for eta1 (Fig. 2.7), c = 1 for eta2 (Fig. 2.8)
        c = 1.0 if model == "eta2" else 0.0
    """--from-mesh: Algorithm 1 on a mesh file or bundled model; same outputs."""
    from ..io import Mesh, read_mesh, write_mesh
    from ..synth import clouds_from_mesh

    if model not in _MODELS:
        raise PointAtlasError(f"--density must be one of {', '.join(_MODELS)}; got {model!r}")
    if curvature not in ("none", "gaussian", "mean"):
        raise PointAtlasError(f"--curvature must be none, gaussian or mean; got {curvature!r}")
    p = Path(in_path)
    if p.exists():
        mesh = read_mesh(p)
        name = p.stem
    else:
        from .. import data

        if str(in_path) not in data.names():
            raise PointAtlasError(f"{in_path}: no such file and not a bundled model")
        mesh = data.load_mesh(str(in_path))
        name = str(in_path)
    if not isinstance(mesh, Mesh) or mesh.n_faces == 0:
        raise PointAtlasError(f"{in_path}: --from-mesh needs a mesh with faces")
    tri = mesh.triangles
    mc = clouds_from_mesh(
        mesh.vertices,
        tri,
        model=model,
        c=c,
        c_v=c_v,
        c_h=c_h,
        t=t,
        n_samples=samples,
        curvature=None if curvature == "none" else curvature,
        rng=seed,
    )
    K = cloud_complex(mc.clouds, mc.points, cloud_points=mc.cloud_points)
    report = surface_report(K)
    verts, faces = realize_complex(K, report)
    from .._core import PointSet

    ps = PointSet(mc.points, None, {"source_face": mc.source_face}, name=name)
    written = [_write_clouds(out["clouds"], ps, K.n_memberships)]
    written.append(write_mesh(out["complex"], verts, faces))
    meta = {"kind": "mesh", "model": model, "seed": seed}
    written.append(_write_npz(out["npz"], K, mc.points, faces, meta))
    written.append(write_text(out["table"], report.table()))
    mesh_tri = np.unique(np.sort(tri, axis=1), axis=0)
    same = bool(np.array_equal(K.triangles, mesh_tri))
    if render:
        title = f"{name}: {model}, {mc.points.shape[0]:,} points, complex = mesh: {same}"
        written.append(
            _picture(out["picture"], mc.points, K.n_memberships, verts, faces, K.edges, title)
        )
    payload = {
        "input": str(in_path),
        "mode": "from-mesh",
        "model": model,
        "c": c,
        "c_v": c_v,
        "c_h": c_h,
        "t": t,
        "samples": samples,
        "curvature": curvature,
        "seed": seed,
        "n_points": int(mc.points.shape[0]),
        "n_drawn": mc.n_drawn,
        "n_accepted": mc.n_accepted,
        "n_clouds": int(K.n_clouds),
        "complex_equals_mesh": same,
        "points_per_cloud_count": np.bincount(K.n_memberships).tolist(),
        "report": report.summary(),
        "seconds": round(time.perf_counter() - t0, 3),
    }
    if html_report is not None:
        written.append(
            _html_report(
                html_report,
                in_path,
                payload,
                mc.points,
                K.n_memberships,
                verts,
                faces,
                written,
                seed,
            )
        )
    write_summary_json(out["json"], payload, written)
    console.print(
        f"Algorithm 1 ({model}): {mc.points.shape[0]:,} points in {K.n_clouds} clouds; "
        f"complex equals the mesh: {same}"
    )
    _print_result(report, K.n_clouds, {}, report.is_cloud_surface, None, payload["seconds"], 3)
    for path in [*written, out["json"]]:
        say(f"wrote {path}")
