"""The fixed orthographic camera shared by every picture of a model."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .._core import as_points, readonly

__all__ = ["Camera", "fit_camera", "resolve_camera"]

#: Default view: azimuth 35 deg around the up axis, 25 deg above the horizon.
DEFAULT_AZIMUTH = math.radians(35.0)
DEFAULT_ELEVATION = math.radians(25.0)

#: Fraction of the half image (smaller side) the fitted square fills.
FILL = 0.94


@dataclass(frozen=True, slots=True)
class Camera:
    """An orthographic camera: view direction, image centre and zoom.

    Parameters
    ----------
    center : ndarray of shape (3,), float64
        The point seen at the image centre.
    radius : float
        Half the side of the square (input units, around ``center`` in the image
        plane) that fills the frame.
    azimuth : float
        Rotation of the eye around the ``up`` axis, radians.
    elevation : float
        Angle of the eye above the plane orthogonal to ``up``, radians.
    up : ndarray of shape (3,), float64
        World direction drawn upwards (default +y, the OBJ/PLY convention).

    Notes
    -----
    The eye direction (from the centre towards the viewer) is
    ``cos(el) cos(az) a + cos(el) sin(az) b + sin(el) up`` where ``(a, b, up)`` is a
    right-handed frame taken cyclically from the axis nearest to ``up``
    (``(a, b) = (z, x)`` for up = y, ``(x, y)`` for up = z): the default view looks
    at the front (+z for y-up models) from the right and above. Screen x is ``right``, screen y is
    the projection of ``up``; depth grows towards the viewer (larger = nearer).
    """

    center: np.ndarray
    radius: float
    azimuth: float = DEFAULT_AZIMUTH
    elevation: float = DEFAULT_ELEVATION
    up: np.ndarray = field(default_factory=lambda: np.array([0.0, 1.0, 0.0]))

    def __post_init__(self):
        center = np.array(self.center, dtype=np.float64).reshape(-1)
        up = np.array(self.up, dtype=np.float64).reshape(-1)
        if center.shape != (3,) or not np.isfinite(center).all():
            raise ValueError(f"center must be 3 finite numbers; got {self.center!r}")
        if up.shape != (3,) or not np.isfinite(up).all() or np.linalg.norm(up) == 0:
            raise ValueError(f"up must be a non-zero 3-vector; got {self.up!r}")
        radius = float(self.radius)
        if not (math.isfinite(radius) and radius > 0):
            raise ValueError(f"radius must be positive and finite; got {self.radius!r}")
        for name in ("azimuth", "elevation"):
            if not math.isfinite(float(getattr(self, name))):
                raise ValueError(f"{name} must be finite; got {getattr(self, name)!r}")
        object.__setattr__(self, "center", readonly(center))
        object.__setattr__(self, "up", readonly(up / np.linalg.norm(up)))
        object.__setattr__(self, "radius", radius)
        object.__setattr__(self, "azimuth", float(self.azimuth))
        object.__setattr__(self, "elevation", float(self.elevation))

    def basis(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Return ``(right, screen_up, toward_eye)``, an orthonormal right-handed frame."""
        up = self.up
        # a, b: a right-handed frame orthogonal to up, chosen cyclically from the
        # axis nearest to up: up = y gives (a, b) = (z, x), up = z gives (x, y)
        k = int(np.argmax(np.abs(up)))
        a = np.eye(3)[(k + 1) % 3]
        a = a - up * (a @ up)
        a /= np.linalg.norm(a)
        b = np.cross(up, a)
        ce, se = math.cos(self.elevation), math.sin(self.elevation)
        eye = ce * math.cos(self.azimuth) * a + ce * math.sin(self.azimuth) * b + se * up
        eye /= np.linalg.norm(eye)
        right = np.cross(up, eye)
        if np.linalg.norm(right) < 1e-9:  # looking straight along up: pick any right
            right = a.copy()
        right /= np.linalg.norm(right)
        screen_up = np.cross(eye, right)
        return right, screen_up, eye

    def scale(self, width: int, height: int) -> float:
        """Pixels per input unit for an image of ``width`` x ``height`` pixels."""
        return FILL * 0.5 * min(width, height) / self.radius

    def project(self, points: np.ndarray, width: int, height: int):
        """Project validated ``points`` (N, 3) to pixel coordinates.

        Returns
        -------
        x, y : ndarray of shape (N,), float64
            Pixel coordinates (x to the right, y downwards, pixel centres at +0.5).
        depth : ndarray of shape (N,), float64
            Signed distance towards the viewer (larger = nearer), input units.
        """
        right, screen_up, eye = self.basis()
        rel = points - self.center
        s = self.scale(width, height)
        x = 0.5 * width + s * (rel @ right)
        y = 0.5 * height - s * (rel @ screen_up)
        depth = rel @ eye
        return x, y, depth

    def light(self) -> np.ndarray:
        """Unit light direction: from the viewer, a little up and to the left."""
        right, screen_up, eye = self.basis()
        vec = eye + 0.55 * screen_up - 0.35 * right
        return vec / np.linalg.norm(vec)


def fit_camera(
    points,
    *,
    azimuth: float = DEFAULT_AZIMUTH,
    elevation: float = DEFAULT_ELEVATION,
    up=(0.0, 1.0, 0.0),
) -> Camera:
    """Fit the default camera to a point set (its bounding sphere fills the frame).

    Parameters
    ----------
    points : array_like of shape (N, 3), float64
        Everything that will be drawn with this camera (N >= 1).
    azimuth, elevation : float
        View direction, radians (default 35 deg and 25 deg).
    up : array_like of shape (3,)
        World direction drawn upwards (default +y; use +z for LiDAR/GIS data).

    Returns
    -------
    camera : Camera
        The centre of the points' projected bounding box is the image centre and
        ``radius`` is half its longer side, so the points fill the frame for this
        view (radius 1.0 when all points coincide).

    Raises
    ------
    ValueError
        Empty or non-finite ``points``.

    Examples
    --------
    >>> cam = fit_camera([[0, 0, 0], [2, 0, 0]])
    >>> cam.center.round(6).tolist(), round(cam.radius, 6)
    ([1.0, 0.0, 0.0], 0.819152)
    """
    pts = as_points(points, min_points=1)
    center = 0.5 * (pts.min(axis=0) + pts.max(axis=0))
    # orient a provisional camera, then fit the projected bounding box (tighter
    # than the bounding sphere, and still one camera for every panel)
    probe = Camera(center=center, radius=1.0, azimuth=azimuth, elevation=elevation, up=up)
    right, screen_up, _ = probe.basis()
    rel = pts - center
    sx, sy = rel @ right, rel @ screen_up
    mid_x, mid_y = 0.5 * (sx.min() + sx.max()), 0.5 * (sy.min() + sy.max())
    center = center + mid_x * right + mid_y * screen_up
    radius = float(max(sx.max() - sx.min(), sy.max() - sy.min()) / 2.0)
    if not radius > 0:
        radius = float(np.sqrt((rel**2).sum(axis=1).max())) or 1.0
    return Camera(center=center, radius=radius, azimuth=azimuth, elevation=elevation, up=up)


def resolve_camera(view, points: np.ndarray) -> Camera:
    """Turn a ``view`` argument into a camera (private; ``points`` validated).

    ``None`` fits the default camera to ``points``; a :class:`Camera` is used as it
    is; a pair ``(azimuth, elevation)`` in radians fits a camera with that view.
    """
    if view is None:
        return fit_camera(points)
    if isinstance(view, Camera):
        return view
    try:
        az, el = (float(v) for v in view)
    except (TypeError, ValueError):
        raise TypeError(
            f"view must be None, a Camera or a pair (azimuth, elevation) in radians; got {view!r}"
        ) from None
    return fit_camera(points, azimuth=az, elevation=el)
