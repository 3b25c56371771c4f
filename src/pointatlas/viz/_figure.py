"""Compose rendered panels with titles and colour bars; write PNGs atomically."""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ._camera import Camera, resolve_camera
from ._colors import BACKGROUND, ScalarLegend, require_matplotlib
from ._mesh import prepare_mesh, render_mesh_rgb
from ._points import check_size, prepare_points, render_points_rgb

__all__ = [
    "MeshPanel",
    "PointsPanel",
    "render_mesh",
    "render_points",
    "render_side_by_side",
]

#: Figure resolution: sizes are given in pixels, figures in inches at this dpi.
DPI = 100
# layout, in pixels
_PAD = 8
_SUPTITLE_H = 46
_TITLE_H = 32
_NOTE_H = 24
_CBAR_W = 120
_CBAR_BAR_W = 18


@dataclass(frozen=True, slots=True)
class PointsPanel:
    """A point-set panel for :func:`render_side_by_side` (fields as in `render_points`)."""

    points: Any
    normals: Any = None
    labels: Any = None
    scalars: Any = None
    scalar_name: str | None = None
    cmap: str = "viridis"
    title: str | None = None
    point_size: float | None = None
    lighting: bool = True
    clim: Any = None
    colors: Any = None


@dataclass(frozen=True, slots=True)
class MeshPanel:
    """A mesh panel for :func:`render_side_by_side` (fields as in `render_mesh`)."""

    vertices: Any
    faces: Any
    face_labels: Any = None
    face_colors: Any = None
    edges: bool = True
    title: str | None = None
    lighting: bool = True
    face_offsets: Any = None


@dataclass(slots=True)
class _Prepared:
    """A validated panel: how to draw it at a given pixel size."""

    kind: str  # "points", "mesh" or "image"
    data: tuple
    title: str | None
    legend: ScalarLegend | None
    note: str | None
    options: dict


def _prepare(panel) -> _Prepared:
    if isinstance(panel, PointsPanel):
        pts, nrm, base, legend, note = prepare_points(
            panel.points,
            panel.normals,
            panel.labels,
            panel.scalars,
            panel.cmap,
            panel.scalar_name,
            panel.clim,
            panel.colors,
        )
        if panel.point_size is not None and not (
            np.isfinite(panel.point_size) and panel.point_size > 0
        ):
            raise ValueError(f"point_size must be a positive number; got {panel.point_size!r}")
        opts = {"point_size": panel.point_size, "lighting": bool(panel.lighting)}
        return _Prepared("points", (pts, nrm, base), panel.title, legend, note, opts)
    if isinstance(panel, MeshPanel):
        verts, indptr, flat, base, note = prepare_mesh(
            panel.vertices, panel.faces, panel.face_labels, panel.face_colors, panel.face_offsets
        )
        opts = {"edges": bool(panel.edges), "lighting": bool(panel.lighting)}
        return _Prepared("mesh", (verts, indptr, flat, base), panel.title, None, note, opts)
    if isinstance(panel, np.ndarray):
        img = panel
        if img.ndim != 3 or img.shape[2] not in (3, 4) or min(img.shape[:2]) < 1:
            raise ValueError(f"an image panel must have shape (H, W, 3|4); got {img.shape}")
        if img.dtype != np.uint8:
            img = np.asarray(img, dtype=np.float64)
            if not np.isfinite(img).all() or img.min() < 0 or img.max() > 1:
                raise ValueError("an image panel must be uint8 or floats in [0, 1]")
        return _Prepared("image", (img[..., :3],), None, None, None, {})
    raise TypeError(
        f"panels must be PointsPanel, MeshPanel or RGB ndarray items; got {type(panel).__name__}"
    )


def _draw(prep: _Prepared, camera: Camera | None, width: int, height: int) -> np.ndarray:
    if prep.kind == "points":
        pts, nrm, base = prep.data
        return render_points_rgb(
            pts, normals=nrm, base=base, camera=camera, width=width, height=height, **prep.options
        )
    if prep.kind == "mesh":
        verts, indptr, flat, base = prep.data
        return render_mesh_rgb(
            verts, indptr, flat, base, camera=camera, width=width, height=height, **prep.options
        )
    return prep.data[0]


def _shared_camera(view, prepared: list[_Prepared]) -> Camera | None:
    geometry = [p.data[0] for p in prepared if p.kind in ("points", "mesh")]
    if not geometry:
        return None
    return resolve_camera(view, np.concatenate(geometry, axis=0))


def _check_png_path(path) -> Path:
    """Validate the output path before any work: ``.png`` in an existing folder."""
    path = Path(os.fspath(path))
    if path.suffix.lower() != ".png":
        raise ValueError(f"path must end in .png; got {str(path)!r}")
    folder = path.parent if str(path.parent) else Path(".")
    if not folder.is_dir():
        raise FileNotFoundError(f"output folder does not exist: {str(folder)!r}")
    return path


def _atomic_png(fig, path: Path) -> Path:
    """Save ``fig`` as PNG through :func:`pointatlas.io.atomic_write` (umask permissions)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    from ..io import atomic_write

    canvas = FigureCanvasAgg(fig)
    with atomic_write(path, "wb") as fh:
        canvas.print_png(fh, metadata={"Software": "pointatlas"})
    return path


def _compose(path, prepared: list[_Prepared], *, camera, size, title) -> Path:
    """Lay panels out left to right, render each at its on-screen pixel size, save."""
    path = _check_png_path(path)
    require_matplotlib()
    from matplotlib.cm import ScalarMappable
    from matplotlib.colors import Normalize
    from matplotlib.figure import Figure

    width, height = check_size(size)
    fig = Figure(figsize=(width / DPI, height / DPI), dpi=DPI, facecolor=tuple(BACKGROUND))
    top = _SUPTITLE_H if title else 0
    if title:
        fig.text(
            0.5,
            1.0 - 0.5 * _SUPTITLE_H / height,
            str(title),
            ha="center",
            va="center",
            fontsize=17,
            fontweight="bold",
        )
    n = len(prepared)
    col_w = width // n
    # uniform bands, and one image size for every geometric panel so that the
    # shared camera gives the same scale everywhere
    t_h = _TITLE_H if any(p.title for p in prepared) else 0
    n_h = _NOTE_H if any(p.note for p in prepared) else 0
    img_top = top + t_h + _PAD  # pixels from the top
    avail_h = height - top - t_h - n_h - 2 * _PAD
    avail_w = [col_w - 2 * _PAD - (_CBAR_W if p.legend is not None else 0) for p in prepared]
    if min(avail_w) < 16 or avail_h < 16:
        raise ValueError(
            f"size {size!r} is too small for {n} panel(s) with titles/legends; use a larger size"
        )
    geo_w = (
        min(w for w, p in zip(avail_w, prepared, strict=True) if p.kind != "image")
        if any(p.kind != "image" for p in prepared)
        else 0
    )
    for i, prep in enumerate(prepared):
        img_h = avail_h
        img_w = avail_w[i] if prep.kind == "image" else geo_w
        x0 = i * col_w + (avail_w[i] - img_w) // 2
        rgb = _draw(prep, camera, img_w, img_h)
        ax = fig.add_axes(
            (
                (x0 + _PAD) / width,
                1.0 - (img_top + img_h) / height,
                img_w / width,
                img_h / height,
            )
        )
        ax.set_axis_off()
        ax.imshow(rgb, interpolation="nearest" if prep.kind != "image" else "antialiased")
        if prep.title:
            fig.text(
                (i * col_w + 0.5 * col_w) / width,
                1.0 - (top + 0.5 * _TITLE_H) / height,
                str(prep.title),
                ha="center",
                va="center",
                fontsize=13,
            )
        if prep.note:
            fig.text(
                (x0 + _PAD + 0.5 * img_w) / width,
                0.5 * _NOTE_H / height + _PAD / height,
                prep.note,
                ha="center",
                va="center",
                fontsize=10,
                color="0.25",
            )
        if prep.legend is not None:
            lg = prep.legend
            lo, hi = (lg.vmin, lg.vmax) if lg.vmax > lg.vmin else (lg.vmin - 0.5, lg.vmax + 0.5)
            bar_h = 0.7 * img_h
            cax = fig.add_axes(
                (
                    (x0 + _PAD + img_w + 14) / width,
                    1.0 - (img_top + 0.5 * img_h + 0.5 * bar_h) / height,
                    _CBAR_BAR_W / width,
                    bar_h / height,
                )
            )
            bar = fig.colorbar(
                ScalarMappable(norm=Normalize(vmin=lo, vmax=hi), cmap=lg.cmap),
                cax=cax,
                extend=lg.extend,
            )
            bar.set_label(lg.label(), fontsize=11)
            bar.ax.tick_params(labelsize=9)
    return _atomic_png(fig, path)


def render_points(
    path,
    points,
    *,
    normals=None,
    labels=None,
    scalars=None,
    scalar_name: str | None = None,
    cmap: str = "viridis",
    title: str | None = None,
    view=None,
    size=(1024, 1024),
    point_size: float | None = None,
    lighting: bool = True,
    clim=None,
    colors=None,
) -> Path:
    """Write a PNG picture of a point set (with colour bar or label count).

    Parameters
    ----------
    path : str or os.PathLike
        Output ``.png`` file; written atomically (temp file, then rename).
    points : array_like of shape (N, 3), float64
        Coordinates (N >= 1).
    normals : array_like of shape (N, 3), float64, optional
        Normals for two-sided Lambert shading.
    labels : array_like of shape (N,), int, optional
        Region ids (distinct colours; negative = grey); the label count is noted.
    scalars : array_like of shape (N,), float, optional
        Field drawn with ``cmap`` and a colour bar; NaN drawn grey and counted.
    scalar_name : str, optional
        Colour-bar label (default ``"value"``).
    cmap : str
        Matplotlib colormap name.
    title : str, optional
        Title above the picture.
    view : None, Camera or (float, float)
        Camera; ``None`` = default view fitted to the points.
    size : (int, int)
        PNG (width, height) in pixels.
    point_size : float, optional
        Splat diameter in pixels (default from the spacing).
    lighting : bool
        Shading on (default) or flat colours.
    clim : (float, float), optional
        Colormap value range.
    colors : array_like of shape (N, 3) or (N, 4), optional
        Explicit RGB(A) per point (uint8 or floats in [0, 1]).

    Returns
    -------
    path : pathlib.Path
        The file written.

    Raises
    ------
    ValueError
        Bad inputs (see :func:`render_points_array`), a path not ending in .png.
    FileNotFoundError
        The output folder does not exist.

    Notes
    -----
    The image part is drawn by the numpy software renderer at exactly its size
    on the page, then matplotlib (Agg, offscreen) adds title and colour bar.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> out = pathlib.Path(tempfile.mkdtemp()) / "p.png"
    >>> render_points(out, [[0, 0, 0], [1, 1, 1]], size=(64, 64)).exists()
    True
    >>> import shutil; shutil.rmtree(out.parent)
    """
    panel = PointsPanel(
        points,
        normals=normals,
        labels=labels,
        scalars=scalars,
        scalar_name=scalar_name,
        cmap=cmap,
        point_size=point_size,
        lighting=lighting,
        clim=clim,
        colors=colors,
    )
    return render_side_by_side(path, [panel], title=title, view=view, size=size)


def render_mesh(
    path,
    vertices,
    faces,
    *,
    face_labels=None,
    face_colors=None,
    edges: bool = True,
    title: str | None = None,
    view=None,
    size=(1024, 1024),
    lighting: bool = True,
    face_offsets=None,
) -> Path:
    """Write a PNG picture of a triangle or polygon mesh.

    Parameters
    ----------
    path : str or os.PathLike
        Output ``.png`` file; written atomically.
    vertices : array_like of shape (V, 3), float64
        Vertex positions.
    faces : array_like of shape (F, k), int, or sequence of index sequences
        Faces (k >= 3, ragged allowed).
    face_labels : array_like of shape (F,), int, optional
        Region id per face.
    face_colors : array_like of shape (F, 3) or (F, 4), optional
        Explicit colour per face.
    edges : bool
        Draw polygon outlines.
    title : str, optional
        Title above the picture.
    view : None, Camera or (float, float)
        Camera; ``None`` = default view fitted to the vertices.
    size : (int, int)
        PNG (width, height) in pixels.
    lighting : bool
        Flat shading on (default) or base colours.
    face_offsets : array_like of shape (F + 1,), int, optional
        With a flat ``faces`` array: start of each face (`pointatlas.io.Mesh`).

    Returns
    -------
    path : pathlib.Path
        The file written.

    Raises
    ------
    ValueError
        Bad inputs (see :func:`render_mesh_array`), a path not ending in .png.
    FileNotFoundError
        The output folder does not exist.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> out = pathlib.Path(tempfile.mkdtemp()) / "m.png"
    >>> tri = [[0, 0, 0], [1, 0, 0], [0, 1, 0]]
    >>> render_mesh(out, tri, [[0, 1, 2]], size=(64, 64)).exists()
    True
    >>> import shutil; shutil.rmtree(out.parent)
    """
    panel = MeshPanel(
        vertices,
        faces,
        face_labels=face_labels,
        face_colors=face_colors,
        edges=edges,
        lighting=lighting,
        face_offsets=face_offsets,
    )
    return render_side_by_side(path, [panel], title=title, view=view, size=size)


def render_side_by_side(path, panels, *, title: str | None = None, view=None, size=None) -> Path:
    """Write several pictures of one model next to each other, with one camera.

    Parameters
    ----------
    path : str or os.PathLike
        Output ``.png`` file; written atomically.
    panels : sequence of PointsPanel, MeshPanel or ndarray
        Left to right. Arrays are pre-rendered RGB(A) images of shape (H, W, 3|4)
        (uint8, or floats in [0, 1]) and are scaled into their slot.
    title : str, optional
        Title above all panels.
    view : None, Camera or (float, float)
        Camera for every geometric panel; ``None`` fits the default view to the
        union of all panels' points, so they line up.
    size : (int, int), optional
        PNG (width, height); default 800 x 800 pixels per panel.

    Returns
    -------
    path : pathlib.Path
        The file written.

    Raises
    ------
    ValueError
        No panels, a bad panel, too small a size, a path not ending in .png.
    TypeError
        A panel of an unknown type.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> out = pathlib.Path(tempfile.mkdtemp()) / "s.png"
    >>> pts = [[0, 0, 0], [1, 0, 0], [0, 1, 0]]
    >>> panels = [PointsPanel(pts, labels=[0, 1, 1]), MeshPanel(pts, [[0, 1, 2]])]
    >>> render_side_by_side(out, panels, size=(128, 64)).exists()
    True
    >>> import shutil; shutil.rmtree(out.parent)
    """
    if isinstance(panels, (PointsPanel, MeshPanel, np.ndarray)):
        panels = [panels]
    prepared = [_prepare(p) for p in panels]
    if not prepared:
        raise ValueError("panels must hold at least one panel; got 0")
    if size is None:
        size = (800 * len(prepared), 800 + (_SUPTITLE_H if title else 0))
    camera = _shared_camera(view, prepared)
    return _compose(path, prepared, camera=camera, size=size, title=title)
