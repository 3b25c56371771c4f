"""Colours: a categorical palette for labels and colormaps for scalar fields."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._core import as_labels

__all__ = [
    "BACKGROUND",
    "GREY",
    "NEUTRAL",
    "ScalarLegend",
    "label_colors",
    "membership_colors",
    "require_matplotlib",
    "scalar_colors",
]

#: Colour of label -1 (unassigned) and of NaN scalars.
GREY = np.array([0.62, 0.62, 0.62])
#: Base colour of geometry without labels or scalars (a light steel blue).
NEUTRAL = np.array([0.70, 0.77, 0.88])
#: Image background (white).
BACKGROUND = np.array([1.0, 1.0, 1.0])

#: Example 2 colours by number of clouds: 0 black, 1 light grey, 2 blue, 3 orange, 4+ red.
_EXAMPLE2 = np.array(
    [[0, 0, 0], [205, 205, 205], [50, 110, 220], [245, 150, 30], [220, 20, 20]], dtype=np.uint8
)

_GOLDEN = 0.6180339887498949
_SATURATION = np.array([0.78, 0.55, 0.92])
_VALUE = np.array([0.95, 0.78, 0.86])


def require_matplotlib():
    """Import matplotlib (Agg, no pyplot) or raise an ImportError naming the fix."""
    try:
        import matplotlib  # noqa: F401
        from matplotlib.backends.backend_agg import FigureCanvasAgg  # noqa: F401
    except ImportError as exc:  # pragma: no cover - matplotlib is a dependency
        raise ImportError(
            "pointatlas.viz needs matplotlib (a pointatlas dependency); "
            "install it with `pip install 'matplotlib>=3.8'`"
        ) from exc
    return matplotlib


def _hsv_to_rgb(h: np.ndarray, s: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Vectorised HSV -> RGB for arrays in [0, 1]."""
    i = np.floor(h * 6.0).astype(np.int64) % 6
    f = h * 6.0 - np.floor(h * 6.0)
    p = v * (1 - s)
    q = v * (1 - f * s)
    t = v * (1 - (1 - f) * s)
    table = np.stack(
        [
            np.stack([v, t, p], -1),
            np.stack([q, v, p], -1),
            np.stack([p, v, t], -1),
            np.stack([p, q, v], -1),
            np.stack([t, p, v], -1),
            np.stack([v, p, q], -1),
        ],
        axis=0,
    )
    return table[i, np.arange(h.shape[0])]


def label_colors(labels) -> np.ndarray:
    """Distinct colours for integer labels (negative labels are grey).

    Parameters
    ----------
    labels : array_like of shape (N,), int
        Region ids; any negative value means "unassigned".

    Returns
    -------
    colors : ndarray of shape (N, 3), float64
        RGB in [0, 1]. The colour depends only on the label value, so the same id
        gets the same colour in every picture (points and mesh faces).

    Notes
    -----
    Hue steps by the golden ratio (137.5 deg between consecutive ids) and
    saturation/value cycle with periods 3 and 9, so neighbouring ids never look
    alike and hundreds of regions stay distinguishable.

    Examples
    --------
    >>> c = label_colors([0, 1, -1])
    >>> c.shape, bool((c[0] != c[1]).any()), c[2].tolist()
    ((3, 3), True, [0.62, 0.62, 0.62])
    """
    lab = as_labels(labels)
    out = np.empty((lab.shape[0], 3), dtype=np.float64)
    neg = lab < 0
    ids = lab[~neg]
    hue = (0.03 + ids * _GOLDEN) % 1.0
    sat = _SATURATION[ids % 3]
    val = _VALUE[(ids // 3) % 3]
    out[~neg] = _hsv_to_rgb(hue, sat, val)
    out[neg] = GREY
    return out


@dataclass(frozen=True, slots=True)
class ScalarLegend:
    """What a colour bar needs: colormap, value range, field name, NaN count, and
    which ends values were clipped at (``extend``: neither/min/max/both)."""

    cmap: str
    vmin: float
    vmax: float
    name: str
    n_nan: int
    extend: str = "neither"

    def label(self) -> str:
        """Colour-bar label, e.g. ``"curvature (12 NaN, grey)"``."""
        text = self.name
        if self.n_nan:
            text += f" ({self.n_nan} NaN, grey)"
        return text


def membership_colors(n_memberships) -> np.ndarray:
    """Thesis Example 2 colours of points by their number of clouds.

    Parameters
    ----------
    n_memberships : array_like of shape (N,), int
        Number of clouds of every point.

    Returns
    -------
    colors : ndarray of shape (N, 3), uint8
        RGB: 0 clouds black, 1 light grey, 2 blue, 3 orange, 4 or more red.

    Examples
    --------
    >>> membership_colors([0, 1, 5]).tolist()
    [[0, 0, 0], [205, 205, 205], [220, 20, 20]]
    """
    return _EXAMPLE2[np.minimum(np.asarray(n_memberships), 4)]


def scalar_colors(scalars, *, cmap: str = "viridis", name: str = "value", clim=None):
    """Map a scalar field through a matplotlib colormap; NaN becomes grey.

    Parameters
    ----------
    scalars : array_like of shape (N,), float
        Field values; NaN allowed (drawn grey), +-Inf rejected.
    cmap : str
        A matplotlib colormap name.
    name : str
        Field name for the colour bar.
    clim : (float, float), optional
        Value range mapped to the ends of the colormap (default: finite min/max).

    Returns
    -------
    colors : ndarray of shape (N, 3), float64
        RGB in [0, 1].
    legend : ScalarLegend
        Range, name and NaN count for the colour bar.

    Raises
    ------
    ValueError
        Wrong shape, infinite values, unknown colormap or bad ``clim``.

    Examples
    --------
    >>> colors, legend = scalar_colors([0.0, 1.0, float("nan")], name="h")
    >>> colors.shape, legend.n_nan, legend.label()
    ((3, 3), 1, 'h (1 NaN, grey)')
    """
    mpl = require_matplotlib()
    try:
        values = np.asarray(scalars, dtype=np.float64)
    except (TypeError, ValueError):
        raise TypeError(f"scalars must be numeric; got {type(scalars).__name__}") from None
    if values.ndim != 1:
        raise ValueError(f"scalars must have shape (N,); got {values.shape}")
    if np.isinf(values).any():
        raise ValueError("scalars must not contain +-Inf (NaN is allowed and drawn grey)")
    try:
        colormap = mpl.colormaps[cmap]
    except (KeyError, ValueError, TypeError):
        raise ValueError(f"cmap must be a matplotlib colormap name; got {cmap!r}") from None
    nan = np.isnan(values)
    finite = values[~nan]
    if clim is not None:
        vmin, vmax = (float(v) for v in clim)
        if not (np.isfinite(vmin) and np.isfinite(vmax) and vmin <= vmax):
            raise ValueError(f"clim must be two finite numbers lo <= hi; got {clim!r}")
    elif finite.size:
        vmin, vmax = float(finite.min()), float(finite.max())
    else:
        vmin, vmax = 0.0, 1.0
    span = vmax - vmin
    t = np.clip((values - vmin) / span, 0.0, 1.0) if span > 0 else np.full_like(values, 0.5)
    out = np.empty((values.shape[0], 3), dtype=np.float64)
    out[~nan] = colormap(t[~nan])[:, :3]
    out[nan] = GREY
    below = bool(finite.size and finite.min() < vmin)
    above = bool(finite.size and finite.max() > vmax)
    extend = {(False, False): "neither", (True, False): "min", (False, True): "max"}.get(
        (below, above), "both"
    )
    legend = ScalarLegend(
        cmap=str(cmap), vmin=vmin, vmax=vmax, name=str(name), n_nan=int(nan.sum()), extend=extend
    )
    return out, legend
