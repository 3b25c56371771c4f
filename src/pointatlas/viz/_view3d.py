"""The data of a report's interactive 3-D view: layers, subsampling, binary encoding.

A view holds at most one point layer and any number of meshes. Arrays travel to
the page as base64 of little-endian float32 / int32 / uint32 / uint8 buffers
(never JSON number lists); the viewer (``assets/viewer.min.js``) decodes them
into typed arrays. Colours are tables, not per-point arrays: a 256-entry
colormap table per scalar field and one colour per distinct label, taken from
:func:`label_colors` and the matplotlib colormaps, so the 3-D view matches the
PNG pictures.
"""

from __future__ import annotations

import base64
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .._core import as_labels, as_points
from ._colors import GREY, NEUTRAL, label_colors, require_matplotlib
from ._mesh import as_faces

__all__ = ["MeshLayer", "PointsLayer", "view_data"]

#: Labels listed in a legend; the rest are counted as "n more".
LEGEND_MAX_LABELS = 24
#: Colours sampled along a colour bar.
COLORBAR_STOPS = 11
#: Entries of a scalar field's colormap table (matplotlib's own resolution).
COLORMAP_LEVELS = 256
#: Viewer axis names.
_AXES = {"x": 0, "y": 1, "z": 2}


@dataclass(frozen=True, slots=True)
class PointsLayer:
    """Points of a 3-D view and the per-point fields the viewer can colour by.

    Parameters
    ----------
    points : array_like of shape (N, 3), float
        Positions, in the input's units.
    fields : mapping of str to array_like of shape (N,)
        Per-point values. Integer and boolean fields are drawn as categories
        (a colour per value, a legend), float fields through ``cmap`` (a colour
        bar); NaN and +-Inf are drawn grey. A ``"height"`` field (the coordinate
        along the view's up axis) is added when ``fields`` is empty.
    name : str
        Layer name (the show/hide switch).
    color_by : str, optional
        Field shown first (default: the first field).
    cmap : str
        Matplotlib colormap of the float fields.
    """

    points: Any
    fields: Mapping[str, Any] = field(default_factory=dict)
    name: str = "points"
    color_by: str | None = None
    cmap: str = "viridis"


@dataclass(frozen=True, slots=True)
class MeshLayer:
    """A surface of a 3-D view: triangles or polygons, one colour or a colour per face.

    Parameters
    ----------
    vertices : array_like of shape (V, 3), float
        Vertex positions.
    faces : array_like of shape (F, 3), int, or a list of polygons
        Triangles, polygons of any length >= 3, or with ``face_offsets`` the flat
        index array (the `pointatlas.io.Mesh` layout); polygons are
        fan-triangulated for drawing.
    face_offsets : array_like of shape (F + 1,), int, optional
        Start of each polygon in the flat ``faces``.
    face_labels : array_like of shape (F,), int, optional
        Region of each face, drawn with the colours of :func:`label_colors`.
    name : str
        Layer name (the show/hide switch).
    color : (float, float, float)
        RGB in [0, 1] of a mesh without ``face_labels``.
    opacity : float
        In (0, 1]; below 1 the points behind show through.
    """

    vertices: Any
    faces: Any
    face_offsets: Any = None
    face_labels: Any = None
    name: str = "mesh"
    color: tuple[float, float, float] = tuple(NEUTRAL.tolist())
    opacity: float = 1.0


def _b64(array: np.ndarray, dtype: str) -> str:
    """Base64 of ``array`` as a little-endian buffer of ``dtype``."""
    buffer = np.ascontiguousarray(array, dtype=np.dtype(dtype).newbyteorder("<"))
    return base64.b64encode(buffer.tobytes()).decode("ascii")


def _rgb8(colors) -> list[int]:
    return [int(c) for c in np.clip(np.round(np.asarray(colors) * 255), 0, 255)]


def _field_values(name: str, values, n: int) -> np.ndarray:
    try:
        arr = np.asarray(values)
    except (TypeError, ValueError):
        raise TypeError(f"field {name!r} must be numeric; got {type(values).__name__}") from None
    if arr.shape != (n,):
        raise ValueError(f"field {name!r} must have shape ({n},); got {arr.shape}")
    if arr.dtype.kind not in "biuf":
        raise TypeError(f"field {name!r} must be numeric; got dtype {arr.dtype}")
    return arr


def _labels_field(name: str, values: np.ndarray, shown: np.ndarray) -> dict:
    """A categorical field: int32 values, a colour per distinct label, a legend."""
    values = values.astype(np.int64)
    info = np.iinfo(np.int32)
    if values.size and (values.min() < info.min or values.max() > info.max):
        raise ValueError(f"field {name!r}: labels must fit in int32; got {values.min()}..")
    ids, counts = np.unique(values, return_counts=True)
    colors = (label_colors(ids) * 255).round().astype(np.uint8)
    order = np.lexsort((ids, -counts))  # most frequent first, smaller label on ties
    top = order[:LEGEND_MAX_LABELS]
    return {
        "name": name,
        "kind": "labels",
        "values": _b64(values[shown], "i4"),
        "colormap": {
            "labels": _b64(ids, "i4"),
            "colors": _b64(colors, "u1"),
            "missing": _rgb8(GREY),
        },
        "legend": {
            "entries": [
                {"label": int(ids[i]), "count": int(counts[i]), "color": colors[i].tolist()}
                for i in top
            ],
            "n_more": int(ids.size - top.size),
        },
    }


def _scalar_field(name: str, values: np.ndarray, shown: np.ndarray, cmap: str) -> dict:
    """A float field: float32 values (non-finite as NaN), a colormap table, a colour bar."""
    mpl = require_matplotlib()
    try:
        colormap = mpl.colormaps[cmap]
    except (KeyError, ValueError, TypeError):
        raise ValueError(f"cmap must be a matplotlib colormap name; got {cmap!r}") from None
    values = values.astype(np.float64)
    finite = np.isfinite(values)
    if finite.any():
        vmin, vmax = float(values[finite].min()), float(values[finite].max())
    else:
        vmin, vmax = 0.0, 1.0
    lut = (colormap(np.linspace(0.0, 1.0, COLORMAP_LEVELS))[:, :3] * 255).round()
    stops = (colormap(np.linspace(0.0, 1.0, COLORBAR_STOPS))[:, :3] * 255).round()
    view = np.where(finite, values, np.nan)[shown]
    return {
        "name": name,
        "kind": "scalar",
        "values": _b64(view, "f4"),
        "colormap": {
            "lut": _b64(lut, "u1"),
            "vmin": vmin,
            "vmax": vmax,
            "missing": _rgb8(GREY),
        },
        "legend": {
            "vmin": vmin,
            "vmax": vmax,
            "n_nan": int((~finite).sum()),
            "stops": stops.astype(int).tolist(),
        },
    }


def _subsample(n: int, max_points: int, rng: np.random.Generator) -> np.ndarray:
    """Sorted indices of at most ``max_points`` of ``n`` points, uniform without replacement."""
    if n <= max_points:
        return np.arange(n, dtype=np.int64)
    return np.sort(rng.choice(n, size=max_points, replace=False))


def _point_size(n_shown: int) -> float:
    """Pixels per point: bigger for sparse views."""
    return 4.0 if n_shown < 10_000 else 3.0 if n_shown < 100_000 else 2.0


def _triangles(layer: MeshLayer) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
    """Validated vertices, fan triangles, the polygon of each triangle, the polygon count."""
    verts = as_points(layer.vertices, name="vertices")
    indptr, flat = as_faces(layer.faces, verts.shape[0], layer.face_offsets)
    sizes = np.diff(indptr)
    owner = np.repeat(np.arange(sizes.size), sizes - 2)
    first = np.repeat(indptr[:-1], sizes - 2)
    # corner j of polygon f gives the triangle (v0, v_j, v_j+1), j = 1 .. size - 2
    step = np.arange(owner.size) - np.repeat(np.cumsum(sizes - 2) - (sizes - 2), sizes - 2)
    tris = np.column_stack([flat[first], flat[first + step + 1], flat[first + step + 2]])
    return verts, tris.astype(np.int64), owner, int(sizes.size)


def view_data(
    layers, *, max_points: int, rng: np.random.Generator, up: str = "y"
) -> tuple[dict, dict]:
    """Encode the layers of one 3-D view for the viewer.

    Parameters
    ----------
    layers : sequence of PointsLayer and MeshLayer
        At most one `PointsLayer`.
    max_points : int
        Points shown at most; more are subsampled uniformly (``rng``).
    rng : numpy.random.Generator
        Draws the subsample.
    up : {"x", "y", "z"}
        The up axis of the initial camera.

    Returns
    -------
    data : dict
        JSON-ready view data (base64 arrays; positions relative to ``offset``).
    about : dict
        ``n_points``, ``n_shown``, ``fields`` (names), ``initial_field`` and
        ``layers`` (``(id, name)`` pairs) for the page around the view.

    Raises
    ------
    ValueError, TypeError
        More than one point layer, no layer, bad arrays, unknown ``up`` or colormap.
    """
    if up not in _AXES:
        raise ValueError(f"up must be 'x', 'y' or 'z'; got {up!r}")
    point_layers = [lay for lay in layers if isinstance(lay, PointsLayer)]
    meshes = [lay for lay in layers if isinstance(lay, MeshLayer)]
    if len(point_layers) + len(meshes) != len(layers):
        bad = next(lay for lay in layers if not isinstance(lay, PointsLayer | MeshLayer))
        raise TypeError(f"layers must be PointsLayer or MeshLayer; got {type(bad).__name__}")
    if len(point_layers) > 1:
        raise ValueError(f"a view holds at most one PointsLayer; got {len(point_layers)}")
    if not layers:
        raise ValueError("a view needs at least one layer")
    axis = np.eye(3)[_AXES[up]]
    about: dict = {"n_points": 0, "n_shown": 0, "fields": [], "initial_field": None, "layers": []}
    geometry = []
    points_data = None
    if point_layers:
        lay = point_layers[0]
        pts = as_points(lay.points)
        n = pts.shape[0]
        fields = dict(lay.fields) or {"height": pts @ axis}
        if lay.color_by is not None and lay.color_by not in fields:
            raise ValueError(
                f"color_by {lay.color_by!r} is not a field; fields: {', '.join(fields)}"
            )
        shown = _subsample(n, max_points, rng)
        encoded = []
        for name, values in fields.items():
            arr = _field_values(str(name), values, n)
            if arr.dtype.kind in "biu":
                encoded.append(_labels_field(str(name), arr, shown))
            else:
                encoded.append(_scalar_field(str(name), arr, shown, lay.cmap))
        initial = lay.color_by if lay.color_by is not None else encoded[0]["name"]
        points_data = {"indices": _b64(shown, "u4"), "fields": encoded, "initial_field": initial}
        points_data["point_size"] = _point_size(shown.size)
        geometry.append(pts[shown])
        about.update(n_points=n, n_shown=int(shown.size), initial_field=initial)
        about["fields"] = [f["name"] for f in encoded]
        about["layers"].append(("points", lay.name))
        positions = pts[shown]
    mesh_data = []
    for i, lay in enumerate(meshes):
        verts, tris, owner, n_faces = _triangles(lay)
        if not 0.0 < float(lay.opacity) <= 1.0:
            raise ValueError(f"opacity must lie in (0, 1]; got {lay.opacity!r}")
        entry = {"id": f"mesh-{i}", "triangles": _b64(tris, "u4"), "face_colors": None}
        entry.update(color=_rgb8(lay.color), opacity=float(lay.opacity), vertices=verts)
        if lay.face_labels is not None:
            labels = as_labels(lay.face_labels, n_faces, name="face_labels")
            colors = (label_colors(labels) * 255).round().astype(np.uint8)[owner]
            entry["face_colors"] = _b64(colors, "u1")
        mesh_data.append(entry)
        geometry.append(verts)
        about["layers"].append((entry["id"], lay.name))
    stacked = np.concatenate(geometry) if geometry else np.zeros((0, 3))
    if stacked.shape[0]:
        lo, hi = stacked.min(axis=0), stacked.max(axis=0)
    else:
        lo = hi = np.zeros(3)
    offset = (lo + hi) / 2.0
    radius = float(np.linalg.norm(hi - lo) / 2.0)
    if points_data is not None:
        points_data["positions"] = _b64(positions - offset, "f4")
    for entry in mesh_data:
        entry["vertices"] = _b64(entry["vertices"] - offset, "f4")
    data = {
        "offset": offset.tolist(),
        "center": [0.0, 0.0, 0.0],
        "radius": radius if radius > 0 else 1.0,
        "up": axis.tolist(),
        "points": points_data,
        "meshes": mesh_data,
    }
    return data, about
