"""The job of ``pointatlas cloudsurface``: cloud surfaces (thesis Chapter A).

Cuts a point set into clouds with the ball cover of Prop. 4/5 (Algorithm 2; a fixed
scale or a search over scales and seeded rotations), or generates clouds from a mesh
(Algorithm 1, ``from_mesh``), and writes into OUT_DIR:

- ``clouds.ply``: the points with every input field, ``n_clouds`` (number of clouds
  per point) and Example 2 colours (1 grey, 2 blue, 3 orange, 4+ red, 0 black);
- ``complex.ply`` (``complex.obj`` with line elements for a 2-D curve): the
  geometric realisation, one vertex per cloud;
- ``cloudsurface.npz``: the cloud set (CSR), the cloud points and the points, read
  by ``deform``;
- ``report.txt`` (a readable table), ``search.csv`` (with ``--search``,
  ``--rotations`` or ``--offsets``), ``cloudsurface.png`` (clouds beside the
  complex) and, last, ``report.json``.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..._core import PointAtlasError, as_float, as_int
from ...complex import cloud_complex, curve_report, realize_complex, surface_report
from ...cover import ball_cover, cover_radii, search_cover_scale
from .._flag_checks import named_as_typed
from .._outputs import (
    check_outputs,
    check_point_output,
    point_fields,
    write_summary_json,
    write_text,
)
from .._reports import REPORT_EXTENSIONS
from ._cloud_files import (
    out_paths,
    picture,
    search_csv,
    write_clouds,
    write_cloudsurface_report,
    write_curve_obj,
    write_npz,
)
from ._console import progress_bar
from ._inputs import read_input

__all__ = ["CloudSurfaceOptions", "CloudSurfaceResult", "run_cloudsurface", "scale_grid"]

#: The density models of Algorithm 1 (``--density``).
DENSITY_MODELS = ("eta1", "eta2", "eta3")


@dataclass(frozen=True)
class CloudSurfaceOptions:
    """The settings of ``pointatlas cloudsurface`` (the flags of the same names;
    ``density_c*`` are ``--density-c*``, ``radius_position`` ``--radius-position``).

    The ball cover of IN (Algorithm 2): ``scale`` or ``search`` (SMIN, SMAX, STEP),
    ``rotations`` and ``offsets`` tried (seeded by ``seed``), ``accept`` (closed or
    open; None: closed in 3-D, open in 2-D), ``dim`` (3, or 2 for a curve in the
    xy-plane), the 2-D ``layout`` and ``radius``, ``cloud_points`` (centroid or
    center). With ``from_mesh`` IN is a mesh whose clouds Algorithm 1 draws: the
    ``density`` model and its ``density_c``, ``density_c_v``, ``density_c_h``,
    ``radius_position``, ``samples`` and ``curvature``. ``render``: write
    cloudsurface.png; ``report``: an HTML report there.
    """

    scale: float | None = None
    search: tuple[float, float, float] | None = None
    rotations: int = 0
    offsets: int = 0
    accept: str | None = None
    dim: int = 3
    layout: str = "two-radius"
    radius: float | None = None
    cloud_points: str = "centroid"
    from_mesh: bool = False
    density: str = "eta1"
    density_c: float | None = None
    density_c_v: float = 0.5
    density_c_h: float = 0.5
    radius_position: float = 0.5
    samples: int = 10
    curvature: str = "none"
    render: bool = True
    seed: int = 0
    report: Path | None = None


@dataclass(frozen=True)
class CloudSurfaceResult:
    """What `run_cloudsurface` did: report.json's numbers (``payload``), the topology
    ``report`` of the complex, its clouds, ``dim``, the setting ``chosen`` and the
    ``search`` result (None for a fixed setting) of a cover, whether the complex was
    ``accepted``, whether it came ``from_mesh``, and the files ``written``
    (report.json last)."""

    payload: dict
    report: object
    n_clouds: int
    dim: int
    accepted: bool
    written: list
    chosen: dict = field(default_factory=dict)
    search: object | None = None
    from_mesh: bool = False


def run_cloudsurface(in_path, out_dir, options: CloudSurfaceOptions, tiles=None):
    """``pointatlas cloudsurface``: the clouds of IN (a ball cover, or Algorithm 1 on a
    mesh with ``from_mesh``), their complex, its report and the files in OUT_DIR
    (created), report.json last. There is no tiled run: ``tiles`` must be None."""
    o = options
    if tiles is not None:
        raise PointAtlasError("cloudsurface has no tiled run (--tile-size)")
    dim = 3 if o.from_mesh else _check_cover_options(o)
    out = _checked_outputs(in_path, Path(out_dir), dim, o)
    t0 = time.perf_counter()
    if o.from_mesh:
        return _from_mesh(in_path, out, o, t0)
    ps = read_input(in_path, with_normals=False)
    placeholder = {
        "n_clouds": np.zeros(ps.n_points, np.int64),
        "colors": np.zeros((ps.n_points, 3), np.uint8),
    }
    check_point_output(out["clouds"], ps, placeholder)
    cov, res, chosen = _run_cover(ps.points, o, dim)
    K = cov.cloud_complex
    report = surface_report(K) if dim == 3 else curve_report(K)
    written, verts, faces = _write_cover_files(out, ps, cov, chosen, report, res, dim)
    accepted = _is_accepted(report, o.accept, dim)
    if o.render:
        title = f"{ps.name}: s = {chosen['scale']:g}, {cov.n_clouds} clouds, " + (
            ("closed " if report.is_closed else "") + ("cloud surface" if dim == 3 else "curve")
            if accepted
            else "not accepted"
        )
        written.append(
            picture(out["picture"], ps.points, K.n_memberships, verts, faces, K.edges, title)
        )
    payload = _cover_payload(
        in_path, ps, cov, chosen, report, res, accepted, o.seed, placeholder, dim
    )
    payload["seconds"] = round(time.perf_counter() - t0, 3)
    written = _finish(o, in_path, out, payload, ps.points, K, verts, faces, written)
    return CloudSurfaceResult(
        payload, report, cov.n_clouds, dim, accepted, written, chosen=chosen, search=res
    )


def _finish(o, in_path, out, payload, points, K, verts, faces, written) -> list:
    """The HTML report (``--report``) and, last, report.json: every file written."""
    if o.report is not None:
        written.append(
            write_cloudsurface_report(
                o.report, in_path, payload, points, K.n_memberships, verts, faces, written, o.seed
            )
        )
    write_summary_json(out["json"], payload, written)
    return [*written, out["json"]]


def scale_grid(smin: float, smax: float, step: float) -> np.ndarray:
    """Scales smin, smin + step, ... up to smax (inclusive to round-off), as for ``--search``."""
    smin = as_float(smin, "--search SMIN", lo=0.0, lo_open=True)
    smax = as_float(smax, "--search SMAX", lo=smin)
    step = as_float(step, "--search STEP", lo=0.0, lo_open=True)
    n = int(np.floor((smax - smin) / step + 1e-9)) + 1
    if n > 10_000:
        raise PointAtlasError(f"--search gives {n} scales; at most 10000 (raise STEP)")
    return np.round(smin + step * np.arange(n), 12)


def _check_cover_options(o: CloudSurfaceOptions) -> int:
    """The ball cover's flags checked, one error for a bad combination; its dimension."""
    dim = as_int(o.dim, "--dim", lo=2, hi=3)
    if (o.scale is None) == (o.search is None):
        raise PointAtlasError("give exactly one of --scale S and --search SMIN SMAX STEP")
    if o.scale is not None:
        as_float(o.scale, "--scale", lo=0.0, lo_open=True)
    else:
        scale_grid(*o.search)
    as_int(o.rotations, "--rotations", lo=0, hi=1000)
    as_int(o.offsets, "--offsets", lo=0, hi=1000)
    if o.accept not in (None, "closed", "open"):
        raise PointAtlasError(f"--accept must be closed or open; got {o.accept!r}")
    _check_radius(dim, o.layout, o.radius)
    return dim


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


def _checked_outputs(in_path, out_dir: Path, dim: int, o: CloudSurfaceOptions) -> dict:
    """The output paths of a run, checked before any work (OUT_DIR created)."""
    out = out_paths(out_dir, dim)
    searched = o.search or o.rotations or o.offsets
    files = [
        ("clouds", out["clouds"], None),
        ("complex", out["complex"], None),
        ("cloudsurface.npz", out["npz"], None),
        ("report.txt", out["table"], None),
        ("search.csv", out["search"] if searched else None, None),
        ("picture", out["picture"] if o.render else None, None),
        ("report.json", out["json"], None),
    ]
    files.append(("--report", o.report, REPORT_EXTENSIONS))
    check_outputs([in_path], [], [("OUT_DIR", out_dir)])
    check_outputs([in_path], [f for f in files if f[0] == "--report"])
    out_dir.mkdir(exist_ok=True)
    check_outputs([in_path], files)
    return out


def _run_cover(points, o: CloudSurfaceOptions, dim: int):
    """Fixed scale or search; returns (cover, search result or None, chosen setting).

    A fixed scale with ``--rotations``/``--offsets`` searches the placements at that
    scale; the first accepted setting is kept, else the closest (`ScaleSearch.chosen`).
    """
    scale, search, rotations, offsets = o.scale, o.search, o.rotations, o.offsets
    if search is None and not rotations and not offsets:
        cov = ball_cover(
            points,
            scale,
            dim=dim,
            layout=o.layout,
            radius=o.radius,
            cloud_points=o.cloud_points,
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
            rng=o.seed,
            accept=o.accept,
            dim=dim,
            layout=o.layout,
            radius=o.radius,
            callback=lambda _: advance(),
        )
    pick = res.chosen
    cov = ball_cover(
        points,
        dim=dim,
        layout=o.layout,
        radius=o.radius,
        cloud_points=o.cloud_points,
        **res.setting(pick),
    )
    chosen = {
        "scale": float(res.scales[pick]),
        "rotation": int(res.rotation_index[pick]),
        "offset": int(res.offset_index[pick]),
    }
    return cov, res, chosen


def _write_cover_files(out, ps, cov, chosen, report, res, dim):
    """Clouds, complex, cloudsurface.npz, report.txt and search.csv of a cover run.

    Returns the files written and the complex's realisation (vertices, faces).
    """
    K = cov.cloud_complex
    written = []
    verts, faces = realize_complex(K, report) if dim == 3 else (np.asarray(K.cloud_points), None)
    written.append(write_clouds(out["clouds"], ps, K.n_memberships))
    if dim == 3:
        from ...io import write_mesh

        written.append(write_mesh(out["complex"], np.nan_to_num(verts), faces))
    else:
        written.append(write_curve_obj(out["complex"], verts, K.edges))
        faces = np.zeros((0, 3), np.int64)
    meta = {"kind": "cover", "dim": dim, "layout": cov.layout, **chosen}
    written.append(write_npz(out["npz"], K, ps.points, faces, meta))
    written.append(write_text(out["table"], report.table()))
    if res is not None:
        written.append(search_csv(out["search"], res.rows()))
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


def _read_mesh_for(in_path):
    """--from-mesh's mesh: a mesh file or a bundled model's mesh, and its name."""
    from ...io import Mesh, read_mesh

    p = Path(in_path)
    if p.exists():
        mesh = read_mesh(p)
        name = p.stem
    else:
        from ... import data

        if str(in_path) not in data.names():
            raise PointAtlasError(f"{in_path}: no such file and not a bundled model")
        mesh = data.load_mesh(str(in_path))
        name = str(in_path)
    if not isinstance(mesh, Mesh) or mesh.n_faces == 0:
        raise PointAtlasError(f"{in_path}: --from-mesh needs a mesh with faces")
    return mesh, name


def _from_mesh(in_path, out, o: CloudSurfaceOptions, t0: float) -> CloudSurfaceResult:
    """--from-mesh: Algorithm 1 on a mesh file or bundled model; same outputs."""
    from ..._core import PointSet
    from ...io import write_mesh
    from ...synth import clouds_from_mesh

    model, c = o.density, o.density_c
    if c is None:  # the thesis' settings: c = 0 for eta1 (Fig. 2.7), c = 1 for eta2 (Fig. 2.8)
        c = 1.0 if model == "eta2" else 0.0
    if model not in DENSITY_MODELS:
        raise PointAtlasError(
            f"--density must be one of {', '.join(DENSITY_MODELS)}; got {model!r}"
        )
    if o.curvature not in ("none", "gaussian", "mean"):
        raise PointAtlasError(f"--curvature must be none, gaussian or mean; got {o.curvature!r}")
    mesh, name = _read_mesh_for(in_path)
    tri = mesh.triangles
    mc = clouds_from_mesh(
        mesh.vertices,
        tri,
        model=model,
        c=c,
        c_v=o.density_c_v,
        c_h=o.density_c_h,
        t=o.radius_position,
        n_samples=o.samples,
        curvature=None if o.curvature == "none" else o.curvature,
        rng=o.seed,
    )
    K = cloud_complex(mc.clouds, mc.points, cloud_points=mc.cloud_points)
    report = surface_report(K)
    verts, faces = realize_complex(K, report)
    ps = PointSet(mc.points, None, {"source_face": mc.source_face}, name=name)
    written = [write_clouds(out["clouds"], ps, K.n_memberships)]
    written.append(write_mesh(out["complex"], verts, faces))
    meta = {"kind": "mesh", "model": model, "seed": o.seed}
    written.append(write_npz(out["npz"], K, mc.points, faces, meta))
    written.append(write_text(out["table"], report.table()))
    mesh_tri = np.unique(np.sort(tri, axis=1), axis=0)
    same = bool(np.array_equal(K.triangles, mesh_tri))
    if o.render:
        title = f"{name}: {model}, {mc.points.shape[0]:,} points, complex = mesh: {same}"
        written.append(
            picture(out["picture"], mc.points, K.n_memberships, verts, faces, K.edges, title)
        )
    payload = {
        "input": str(in_path),
        "mode": "from-mesh",
        "model": model,
        "c": c,
        "c_v": o.density_c_v,
        "c_h": o.density_c_h,
        "t": o.radius_position,
        "samples": o.samples,
        "curvature": o.curvature,
        "seed": o.seed,
        "n_points": int(mc.points.shape[0]),
        "n_drawn": mc.n_drawn,
        "n_accepted": mc.n_accepted,
        "n_clouds": int(K.n_clouds),
        "complex_equals_mesh": same,
        "points_per_cloud_count": np.bincount(K.n_memberships).tolist(),
        "report": report.summary(),
        "seconds": round(time.perf_counter() - t0, 3),
    }
    written = _finish(o, in_path, out, payload, mc.points, K, verts, faces, written)
    return CloudSurfaceResult(
        payload, report, K.n_clouds, 3, report.is_cloud_surface, written, from_mesh=True
    )
