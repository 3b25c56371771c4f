"""PCA normals as the commands compute them: the ``normals`` job (`run_normals`), the
normals a command estimates when its input has none (`read_with_normals`) and
``features --estimate-normals``."""

from __future__ import annotations

from ..._core import PointAtlasError
from ...neighbors import query_knn
from ...normals import estimate_normals, orient_normals
from ...simplify import NORMAL_K_RANGE, outward_normals, sharpen_normals, surface_normals

__all__ = ["ORIENT_METHODS", "compute_normals", "normals_and_table"]

#: Orientation methods of ``pointatlas normals`` (``none`` keeps PCA signs; ``up``:
#: n_z >= 0 per point, the lidar convention, `pointatlas.normals.orient_normals`).
ORIENT_METHODS = ("mst", "outward", "viewpoint", "up", "none")


def compute_normals(
    points, *, k: int, orient: str, orient_k: int, viewpoint, advance, surface: bool = False
):
    """Normals of ``points`` as the ``normals`` command computes them; ``surface``: as
    ``simplify`` does (`pointatlas.simplify.surface_normals`)."""
    return normals_and_table(
        points,
        k=k,
        orient=orient,
        orient_k=orient_k,
        viewpoint=viewpoint,
        advance=advance,
        surface=surface,
    )[0]


def normals_and_table(
    points,
    *,
    k: int,
    orient: str,
    orient_k: int,
    viewpoint,
    advance,
    min_cols: int = 0,
    surface: bool = False,
):
    """PCA normals at ``k``, oriented by ``orient``, and the k-NN query they came from
    (``(indices, distances)``, at least ``min_cols`` columns: ``features --normals``
    computes its features from the same table). ``surface``: where the
    k-neighbourhood is not flat, the eigenentropy-optimal one's normal
    (`pointatlas.simplify.surface_normals`, the points path's), oriented, then made
    sharp beside edges and thin walls (`pointatlas.simplify.sharpen_normals`), and
    on a closed sample the sheets and patches turned inward turned out
    (`pointatlas.simplify.outward_normals`)."""
    if orient not in ORIENT_METHODS:
        raise PointAtlasError(
            f"--orient must be one of {', '.join(ORIENT_METHODS)}; got {orient!r}"
        )
    if orient == "viewpoint" and viewpoint is None:
        raise PointAtlasError("--orient viewpoint needs --viewpoint X Y Z")
    if viewpoint is not None and orient != "viewpoint":
        raise PointAtlasError("--viewpoint is only used with --orient viewpoint")
    n = points.shape[0]
    if k < 3 or k > n:
        raise PointAtlasError(f"--k must lie in [3, number of points = {n}]; got {k}")
    if orient_k < 2:
        raise PointAtlasError(f"--orient-k must be at least 2; got {orient_k}")
    orient_k = min(orient_k, n)  # tiny inputs: the whole set is the neighbourhood
    graph = orient in ("mst", "outward")
    if surface:  # the sizes searched beside edges and thin walls
        min_cols = max(min_cols, min(NORMAL_K_RANGE[1], n))
    neighbors = query_knn(points, max(max(k, orient_k) if graph else k, min_cols))
    if surface:
        unoriented = surface_normals(points, k, neighbors=neighbors)
    else:
        unoriented = estimate_normals(points, k, neighbors=neighbors)
    advance()
    if orient == "none":
        oriented = unoriented
    elif orient == "viewpoint":
        oriented = orient_normals(points, unoriented, method="viewpoint", viewpoint=viewpoint)
    elif orient == "up":
        oriented = orient_normals(points, unoriented, method="up")
    else:
        oriented = orient_normals(
            points, unoriented, k=orient_k, method=orient, neighbors=neighbors
        )
    if surface:  # sharp beside edges and thin walls, signed as oriented, then out
        oriented = sharpen_normals(points, oriented, k, neighbors=neighbors)
        oriented = outward_normals(points, oriented, neighbors=neighbors)
    advance()
    return oriented, neighbors
