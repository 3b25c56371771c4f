"""Ball covers of space and clouds from points (thesis 2.2, Props 4-5, Algorithm 2).

Decisions: docs/decisions/cloud_surfaces.md.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .._core import as_float, as_int, check_finite, readonly
from .._core._deprecation import warn_renamed
from .._core.tolerances import COVER_MAX_CELLS_PER_AXIS, COVER_RADIUS_RTOL, COVER_ROTATION_TOL
from ..complex import CloudComplex
from ..complex._clouds import cloud_centroids, complex_from_membership
from . import _kernels

__all__ = [
    "BallCover",
    "ball_cover",
    "cover_radii",
    "as_offset",
    "prepare_points",
    "random_offsets",
    "random_rotations",
]

#: Prop. 4: radius of the balls at even lattice points (half the unit cube's diagonal).
R_EVEN_3D = math.sqrt(3.0) / 2.0
#: Prop. 4: radius of the balls at odd lattice points.
R_ODD_3D = math.sqrt(3.0) / 6.0

LAYOUTS = ("two-radius", "tiling")


def cover_radii(dim: int = 3, layout: str = "two-radius", radius: float | None = None):
    """Ball radii of the covers of Props 4 and 5, in units of the grid scale s.

    Parameters
    ----------
    dim : {2, 3}
        Dimension of the space covered.
    layout : {"two-radius", "tiling"}
        2-D only: Prop. 5 ii) (integer lattice, big balls at even and small balls at
        odd coordinate sums) or Prop. 5 i) (triangular tiling {3, 6}, edge s).
    radius : float, optional
        2-D only: the big radius r in [1/sqrt(2), 1) for "two-radius" (default
        1/sqrt(2), both radii equal, as in Fig. 2.15), or the radius in
        [1/sqrt(3), sqrt(3)/2] for "tiling" (default 1/sqrt(3): three balls meet in
        one point, Remark 4).

    Returns
    -------
    r_even, r_odd : float
        Radius at even and odd lattice points (equal for the tiling).

    Raises
    ------
    PointAtlasError
        ``dim`` not 2 or 3, an unknown layout, a radius outside its range or a
        radius given for the 3-D cover (whose radii are fixed, Prop. 4).

    Examples
    --------
    >>> [round(r, 4) for r in cover_radii(3)]
    [0.866, 0.2887]
    >>> [round(r, 4) for r in cover_radii(2, "two-radius", 0.8)]
    [0.8, 0.3329]
    """
    dim = as_int(dim, "dim", lo=2, hi=3)
    if layout not in LAYOUTS:
        raise ValueError(f"layout must be one of {', '.join(LAYOUTS)}; got {layout!r}")
    if dim == 3:
        if radius is not None:
            raise ValueError("radius is fixed for the 3-D cover (Prop. 4); give radius=None")
        return R_EVEN_3D, R_ODD_3D
    if layout == "two-radius":
        r = (
            1 / math.sqrt(2)
            if radius is None
            else as_float(
                radius,
                "radius",
                lo=1 / math.sqrt(2),
                hi=1.0,
                hi_open=True,
                note="Prop. 5 ii, in units of the grid scale",
            )
        )
        return r, 1 / math.sqrt(2) - math.sqrt(max(r * r - 0.5, 0.0))
    r = (
        1 / math.sqrt(3)
        if radius is None
        else as_float(
            radius,
            "radius",
            lo=1 / math.sqrt(3),
            hi=math.sqrt(3) / 2,
            note="Prop. 5 i, in units of the tiling edge",
        )
    )
    return r, r


def random_rotations(n: int, *, dim: int = 3, rng=None) -> np.ndarray:
    """The identity followed by ``n`` uniformly random rotations (det +1), seeded.

    Parameters
    ----------
    n : int
        Number of random rotations (>= 0).
    dim : {2, 3}
        Rotations of the plane (about z) or of space.
    rng : int, numpy.random.Generator or None
        Seed or generator (``np.random.default_rng(rng)``).

    Returns
    -------
    rotations : ndarray of shape (n + 1, 3, 3), float64
        ``rotations[0]`` is the identity.

    Examples
    --------
    >>> R = random_rotations(2, rng=0)
    >>> R.shape, bool(np.allclose(R[1] @ R[1].T, np.eye(3)))
    ((3, 3, 3), True)
    """
    n = as_int(n, "n_rotations", lo=0)
    dim = as_int(dim, "dim", lo=2, hi=3)
    gen = np.random.default_rng(rng)
    out = np.tile(np.eye(3), (n + 1, 1, 1))
    for i in range(1, n + 1):
        if dim == 2:
            a = gen.uniform(0.0, 2 * math.pi)
            out[i, :2, :2] = [[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]]
        else:
            q, r = np.linalg.qr(gen.normal(size=(3, 3)))
            q = q * np.sign(np.diag(r))
            if np.linalg.det(q) < 0:
                q[:, 0] = -q[:, 0]
            out[i] = q
    return out


def prepare_points(points, dim: int) -> np.ndarray:
    """Validate points for a cover: (N, 3), or (N, 2) in 2-D (z = 0 added); float64 copy."""
    arr = np.asarray(points, dtype=np.float64) if points is not None else None
    if arr is None:
        raise TypeError("points must be an array of shape (N, 3); got None")
    if dim == 2 and arr.ndim == 2 and arr.shape[1] == 2:
        arr = np.column_stack([arr, np.zeros(arr.shape[0])])
    if arr.ndim != 2 or arr.shape[1] != 3:
        shape = "(N, 2) or (N, 3)" if dim == 2 else "(N, 3)"
        raise ValueError(f"points must have shape {shape}; got {arr.shape}")
    if arr.shape[0] < 1:
        raise ValueError("points must hold at least 1 point(s); got 0")
    check_finite(arr, "points")
    return np.ascontiguousarray(arr)


def _as_rotation(rotation, dim: int) -> np.ndarray:
    if rotation is None:
        return np.eye(3)
    R = np.asarray(rotation, dtype=np.float64)
    if R.shape == (2, 2) and dim == 2:
        R3 = np.eye(3)
        R3[:2, :2] = R
        R = R3
    if R.shape != (3, 3):
        raise ValueError(f"rotation must have shape (3, 3); got {R.shape}")
    if not np.isfinite(R).all():
        raise ValueError("rotation must be finite")
    err = float(np.abs(R.T @ R - np.eye(3)).max())
    if err > COVER_ROTATION_TOL or abs(np.linalg.det(R) - 1.0) > COVER_ROTATION_TOL:
        raise ValueError(
            f"rotation must be orthonormal with determinant +1; got |R^T R - I| = {err:.2e}, "
            f"det = {np.linalg.det(R):.6f}"
        )
    if dim == 2 and (
        np.abs(R[2, :2]).max() > COVER_ROTATION_TOL or abs(R[2, 2] - 1) > COVER_ROTATION_TOL
    ):
        raise ValueError("rotation must be about the z axis for a 2-D cover")
    return R


def as_offset(offset, dim: int) -> np.ndarray:
    """Validate a lattice offset: (3,) (or (2,) in 2-D) in [0, 1); returns (3,) float64."""
    if offset is None:
        return np.zeros(3)
    off = np.asarray(offset, dtype=np.float64)
    if dim == 2 and off.shape == (2,):
        off = np.append(off, 0.0)
    if off.shape != (3,):
        raise ValueError(f"offset must have shape (3,); got {off.shape}")
    if not np.isfinite(off).all() or (off < 0).any() or (off >= 1).any():
        raise ValueError(f"offset must hold numbers in [0, 1) (units of the grid scale); got {off}")
    if dim == 2:
        off[2] = 0.0
    return off


def random_offsets(n: int, *, dim: int = 3, rng=None) -> np.ndarray:
    """Zero followed by ``n`` uniform random lattice offsets in [0, 1)^dim, seeded.

    Parameters
    ----------
    n : int
        Number of random offsets (>= 0).
    dim : {2, 3}
        In 2-D the z entry is 0.
    rng : int, numpy.random.Generator or None
        Seed or generator (``np.random.default_rng(rng)``).

    Returns
    -------
    offsets : ndarray of shape (n + 1, 3), float64
        ``offsets[0]`` is 0 (Algorithm 2's lattice at the bounding-box corner).

    Examples
    --------
    >>> off = random_offsets(2, dim=2, rng=0)
    >>> off.shape, off[0].tolist(), off[1:, 2].tolist()
    ((3, 3), [0.0, 0.0, 0.0], [0.0, 0.0])
    """
    n = as_int(n, "n_offsets", lo=0)
    dim = as_int(dim, "dim", lo=2, hi=3)
    gen = np.random.default_rng(rng)
    out = np.zeros((n + 1, 3))
    out[1:, :dim] = gen.random((n, dim))
    return out


@dataclass(frozen=True, slots=True)
class BallCover:
    """Clouds cut out of a point set by a ball cover (Algorithm 2) and their complex.

    Attributes
    ----------
    dim : int
        2 or 3.
    layout : str
        "cubic" (Prop. 4 in 3-D), "two-radius" (Prop. 5 ii) or "tiling" (Prop. 5 i).
    scale : float
        Grid scale s (lattice spacing; the tiling's edge), in the points' units.
    radii : tuple of float
        Ball radii at even and odd lattice points, in the points' units.
    rotation : ndarray of shape (3, 3), float64
        Rotation applied to the points before covering (y = R x).
    offset : ndarray of shape (3,), float64
        Shift of the lattice against the bounding box, in units of s.
    origin : ndarray of shape (3,), float64
        Lattice point 0 in rotated coordinates: the rotated points' bounding-box
        corner minus ``offset`` s.
    centers : ndarray of shape (C, 3), float64
        Center of every non-empty ball (= cloud), in input coordinates (``centres``,
        the former name, still reads it with a `DeprecationWarning`).
    ball_radius : ndarray of shape (C,), float64
        Radius of every cloud's ball.
    lattice_index : ndarray of shape (C, 3), int64
        Lattice coordinates of every ball (tiling: (i, j, 0) with vertex
        (i + j/2, j sqrt(3)/2) s).
    cloud_complex : CloudComplex
        The clouds (non-empty balls, ordered by lattice index) and their cloud
        complex; cloud points are the clouds' centroids (or the ball centers).
    """

    dim: int
    layout: str
    scale: float
    radii: tuple
    rotation: np.ndarray
    offset: np.ndarray
    origin: np.ndarray
    centers: np.ndarray
    ball_radius: np.ndarray
    lattice_index: np.ndarray
    cloud_complex: CloudComplex

    def __post_init__(self):
        for name in ("rotation", "offset", "origin", "centers", "ball_radius", "lattice_index"):
            readonly(getattr(self, name))

    @property
    def n_clouds(self) -> int:
        """Number of clouds (non-empty balls)."""
        return int(self.centers.shape[0])

    @property
    def centres(self) -> np.ndarray:
        """Former name of ``centers`` (deprecated)."""
        warn_renamed("BallCover.centres", "BallCover.centers", stacklevel=3)
        return self.centers


def _membership(y: np.ndarray, dim: int, layout: str, r_even: float, r_odd: float):
    """Lattice codes of the balls holding each point; returns codes, counts, decode."""
    if dim == 3 or layout == "two-radius":
        hi = np.floor(y.max(axis=0)).astype(np.int64) + 2
        shape = np.array([hi[0], hi[1], hi[2] if dim == 3 else 1], dtype=np.int64)
        slack = 1.0 + COVER_RADIUS_RTOL
        codes, counts = _kernels.cubic_membership(
            y, dim, r_even**2 * slack, r_odd**2 * slack, shape
        )

        def decode(c):
            k = c % shape[2]
            j = (c // shape[2]) % shape[1]
            i = c // (shape[1] * shape[2])
            return np.stack([i, j, k], axis=1)

        def centre(idx):
            return idx.astype(np.float64)

        def radius(idx):
            return np.where(idx.sum(axis=1) % 2 == 0, r_even, r_odd)

        return codes, counts, decode, centre, radius
    s3 = math.sqrt(3.0)
    u = y[:, 0] - y[:, 1] / s3
    v = 2.0 * y[:, 1] / s3
    lo = np.array([math.floor(u.min()), math.floor(v.min())], dtype=np.int64)
    hi = np.array([math.floor(u.max()) + 2, math.floor(v.max()) + 2], dtype=np.int64)
    shape = hi - lo
    codes, counts = _kernels.tiling_membership(y, r_even**2 * (1.0 + COVER_RADIUS_RTOL), shape, lo)

    def decode(c):
        i = c // shape[1] + lo[0]
        j = c % shape[1] + lo[1]
        return np.stack([i, j, np.zeros_like(i)], axis=1)

    def centre(idx):
        return np.stack([idx[:, 0] + 0.5 * idx[:, 1], 0.5 * s3 * idx[:, 1], 0 * idx[:, 0]], 1)

    def radius(idx):
        return np.full(idx.shape[0], r_even)

    return codes, counts, decode, centre, radius


def cover_prepared(
    pts: np.ndarray,
    scale: float,
    dim: int,
    layout: str,
    r_even: float,
    r_odd: float,
    R: np.ndarray,
    cloud_points: str,
    offset: np.ndarray | None = None,
) -> BallCover:
    """`ball_cover` on validated input (``offset`` in lattice units, in [0, 1))."""
    x = pts @ R.T
    if dim == 2:
        x[:, 2] = 0.0
    off = np.zeros(3) if offset is None else np.asarray(offset, dtype=np.float64)
    origin = x.min(axis=0) - off * scale  # the lattice point 0, rotated coordinates
    y = (x - origin) / scale
    codes, counts, decode, centre, radius = _membership(y, dim, layout, r_even, r_odd)
    n = pts.shape[0]
    valid = codes >= 0
    flat = codes[valid]  # row-major: point order, ascending codes per point
    ucodes, cloud_of = np.unique(flat, return_inverse=True)
    cloud_of = cloud_of.reshape(-1).astype(np.int64)
    point_of = np.repeat(np.arange(n, dtype=np.int64), counts)
    point_indptr = np.zeros(n + 1, dtype=np.int64)
    np.cumsum(counts, out=point_indptr[1:])
    n_clouds = ucodes.size
    order = np.argsort(cloud_of, kind="stable")
    cloud_members = point_of[order]
    cloud_indptr = np.zeros(n_clouds + 1, dtype=np.int64)
    np.cumsum(np.bincount(cloud_of, minlength=n_clouds), out=cloud_indptr[1:])
    idx = decode(ucodes)
    c_lattice = centre(idx)
    centers = (c_lattice * scale + origin) @ R  # back to input coordinates
    if dim == 2:
        centers[:, 2] = 0.0
    if cloud_points == "center":
        cp = centers.copy()
    else:
        cp = cloud_centroids(cloud_indptr, cloud_members, pts)
    K = complex_from_membership(
        cloud_indptr, cloud_members, n, cp, point_csr=(point_indptr, cloud_of)
    )
    layout_name = "cubic" if dim == 3 else layout
    return BallCover(
        dim=dim,
        layout=layout_name,
        scale=float(scale),
        radii=(r_even * scale, r_odd * scale),
        rotation=R.copy(),
        offset=off.copy(),
        origin=origin,
        centers=centers,
        ball_radius=radius(idx) * scale,
        lattice_index=idx.astype(np.int64),
        cloud_complex=K,
    )


def ball_cover(
    points,
    scale: float,
    *,
    dim: int = 3,
    layout: str = "two-radius",
    radius: float | None = None,
    rotation=None,
    offset=None,
    cloud_points: str = "centroid",
) -> BallCover:
    """Cut a point set into clouds with the ball cover of Prop. 4 or 5 (Algorithm 2).

    Parameters
    ----------
    points : array_like of shape (N, 3), float64
        Coordinates; in 2-D also (N, 2), and the z column of (N, 3) is ignored.
    scale : float
        Grid scale s > 0 (the points' units): lattice spacing, or the tiling edge.
    dim : {2, 3}
        3: Prop. 4 (balls sqrt(3)/2 s at even, sqrt(3)/6 s at odd lattice points);
        2: a cover of the plane by Prop. 5 (curves, Figs 2.14-2.15).
    layout : {"two-radius", "tiling"}
        2-D only, see `cover_radii`.
    radius : float, optional
        2-D only: the big radius in units of s (see `cover_radii`).
    rotation : array_like of shape (3, 3), optional
        Rotation applied to the points before covering (2.2.2: the result depends on
        it); in 2-D a rotation about z, also as (2, 2).
    offset : array_like of shape (3,), float64, optional
        Shift of the lattice against the bounding box, in units of s, each entry in
        [0, 1) (in 2-D also (2,); the z entry is ignored). Default 0: the lattice
        starts at the bounding-box corner (Algorithm 2). A plane or cube face lying in
        a lattice layer gives no triangles; a shift (or a rotation) moves it off.
    cloud_points : {"centroid", "center"}
        Realisation of each cloud: the centroid of its points (the default) or
        its ball center (``"centre"``, the former spelling, still works with a
        `DeprecationWarning`).

    Returns
    -------
    cover : BallCover
        The non-empty balls (= clouds) with centers and radii, and their
        `CloudComplex`; every point lies in at least one cloud.

    Raises
    ------
    ValueError
        Bad shapes, non-finite coordinates, scale <= 0, a bad rotation, an offset
        outside [0, 1), an unknown layout or ``cloud_points``, a radius out of range.

    Notes
    -----
    Algorithm 2: the (rotated) points are translated so their bounding box starts at
    the origin (then by ``offset`` s); balls sit at s * j for integer j >= 0 (the tiling's vertices
    (i + j/2, j sqrt(3)/2) s); each non-empty closed ball is a cloud. Balls are
    closed, as in Props 4-5. Every point of space lies in 1 to d + 1 balls
    (d + 1 only on a null set), so a cloud complex of a cover has dimension <= d
    except at those points. Membership is computed by a numba kernel over the
    2^d corners of each point's lattice cell (the radii are below the lattice
    spacing).

    Examples
    --------
    Points on a circle in the plane give a closed curve of clouds:

    >>> t = np.linspace(0, 2 * np.pi, 400, endpoint=False)
    >>> circle = np.column_stack([4 * np.cos(t), 4 * np.sin(t)])
    >>> cov = ball_cover(circle, 1.0, dim=2)
    >>> from pointatlas.complex import curve_report
    >>> r = curve_report(cov.cloud_complex)
    >>> r.is_one_manifold, r.is_closed, r.n_components
    (True, True, 1)
    """
    dim = as_int(dim, "dim", lo=2, hi=3)
    r_even, r_odd = cover_radii(dim, layout, radius)
    pts = prepare_points(points, dim)
    s = as_float(scale, "scale", lo=0.0, lo_open=True, note="the grid scale")
    if cloud_points == "centre":
        warn_renamed("ball_cover(cloud_points='centre')", "cloud_points='center'")
        cloud_points = "center"
    if cloud_points not in ("centroid", "center"):
        raise ValueError(f"cloud_points must be 'centroid' or 'center'; got {cloud_points!r}")
    R = _as_rotation(rotation, dim)
    off = as_offset(offset, dim)
    extent = float((pts.max(axis=0) - pts.min(axis=0)).max())
    if extent / s > COVER_MAX_CELLS_PER_AXIS:
        raise ValueError(
            f"scale {s} gives more than {COVER_MAX_CELLS_PER_AXIS:g} balls along the bounding "
            f"box ({extent:.3g} long); give a larger scale"
        )
    return cover_prepared(pts, s, dim, layout, r_even, r_odd, R, cloud_points, off)
