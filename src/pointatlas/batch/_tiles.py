"""Tiled processing of point sets too large for one process (dask.distributed).

Points are cut into an x/y grid of tiles (`TileGrid`), every tile is sent with a
halo of neighbouring points to a dask worker, and the owned points' results are
gathered (normals and features bit for bit those of the untiled run; decisions in
docs/decisions/batch.md). This module holds what every method shares: options,
sources (in-memory arrays, `ArraySource`; LAS/LAZ files streamed by chunks are in
`pointatlas.batch._tiles_las`), spilling, the cluster and the dask loop. The
methods are in ``_tiles_normals``, ``_tiles_features``, ``_tiles_denoise`` and
``_tiles_segment``.
"""

from __future__ import annotations

import contextlib
import logging
import math
import mmap
import os
import warnings
from collections import defaultdict
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .._core import PointAtlasError, interrupts_deferred
from ._tiles_grid import TileGrid, make_grid
from ._tiles_tasks import run_task

__all__ = [
    "ArraySource",
    "TileOptions",
    "TiledRun",
    "release_pages",
    "parse_memory",
    "sent_as",
    "run_tiles",
    "tile_client",
]

#: Seconds to wait for ``--scheduler ADDRESS`` before giving up.
CONNECT_TIMEOUT_S = 10
#: Automatic halos grow by at least this factor when a tile asks for more.
_HALO_GROWTH = 1.25
#: A halo never grows past this many tile sizes (then the input is refused).
_MAX_HALO_TILES = 64
#: Points per chunk of the in-memory source when spilling (bounds temporary masks).
_ARRAY_CHUNK = 1 << 22


def _allocate(store, name, n, like):
    """A zeroed (N, ...) array for a result field, or the store's own allocation."""
    width = None if like.ndim == 1 else like.shape[1]
    if hasattr(store, "new"):
        return store.new(name, like.dtype, width)
    store[name] = np.zeros((n,) if width is None else (n, width), dtype=like.dtype)
    return store[name]


def sent_as(params: dict, store) -> dict:
    """Feature ``params`` with the type the ``store`` keeps float64 results in
    (``float_type`` of an `_Alloc`, float32 for LAS/LAZ): tiles send them in that type
    (`_tiles_tasks.owned_fields`)."""
    ft = getattr(store, "float_type", None)
    return params if ft is None else {**params, "float_type": np.dtype(ft).str}


def release_pages(*arrays) -> None:
    """Drop the pages of result memory maps from this process's resident memory.

    The maps are shared file mappings: their pages (written or not) stay in the
    page cache and in the file, and come back on the next access; unmapping them
    keeps the client's resident memory at one tile's results instead of N rows of
    every field (``MADV_DONTNEED``; a no-op for plain arrays).
    """
    for arr in arrays:
        mm = getattr(arr, "_mmap", None) if isinstance(arr, np.memmap) else None
        if mm is not None and hasattr(mm, "madvise"):
            mm.madvise(mmap.MADV_DONTNEED)


def _chunked(n: int):
    for s in range(0, n, _ARRAY_CHUNK):
        yield slice(s, min(n, s + _ARRAY_CHUNK))


@dataclass(frozen=True, slots=True)
class TileOptions:
    """How to tile and where to run.

    Parameters
    ----------
    tile_size : float
        Edge of the square x/y tiles (coordinate units), > 0.
    halo : float, optional
        Halo width around every tile. None: chosen from the data and grown per tile
        until every owned point's neighbourhood is inside (automatic). A given halo
        is never grown: a tile that needs more raises a one-line error naming the
        halo that would do.
    workers : int
        Worker processes of the local cluster (>= 1; ignored with ``scheduler``).
    scheduler : str or distributed.Client, optional
        Address of a running dask scheduler, or a Client (tests use one with
        ``processes=False``). Default: a local cluster closed at the end.
    max_memory : str or int, optional
        Memory limit per worker (``"2GB"``, bytes); also refuses tiles whose
        estimated working memory exceeds it.
    progress : bool
        Show a rich progress bar of tiles done on stderr.
    tmp_dir : str or path-like, optional
        Folder for spilled tiles and result arrays of file runs (default: the
        output's folder).
    """

    tile_size: float
    halo: float | None = None
    workers: int = 2
    scheduler: object = None
    max_memory: object = None
    progress: bool = False
    tmp_dir: object = None

    def __post_init__(self):
        ts = self.tile_size
        if isinstance(ts, bool) or not isinstance(ts, int | float) or not math.isfinite(ts):
            raise PointAtlasError(f"--tile-size must be a finite number > 0; got {ts!r}")
        if ts <= 0:
            raise PointAtlasError(f"--tile-size must be > 0; got {ts:g}")
        h = self.halo
        if h is not None and (
            isinstance(h, bool) or not isinstance(h, int | float) or not math.isfinite(h) or h < 0
        ):
            raise PointAtlasError(f"--halo must be a finite number >= 0; got {h!r}")
        w = self.workers
        if isinstance(w, bool) or not isinstance(w, int | np.integer) or w < 1:
            raise PointAtlasError(f"--workers must be an integer >= 1; got {w!r}")
        if self.max_memory is not None:
            parse_memory(self.max_memory)


@dataclass
class TiledRun:
    """What a tiled run did (for summaries and benchmarks).

    Attributes
    ----------
    n_points : int
        Points processed.
    n_tiles : int
        Non-empty tiles.
    grid : TileGrid
        The tile grid.
    halos : dict of int to float
        Final halo of every tile (automatic halos may have grown).
    n_retries : int
        Tiles recomputed with a wider halo.
    tile_points : dict of int to int
        Points sent per tile (owned + halo).
    scheduler : str
        Where the tiles ran.
    extra : dict
        Method-specific results (segment quality measures, sign flips, ...).
    """

    n_points: int
    n_tiles: int
    grid: TileGrid
    halos: dict = field(default_factory=dict)
    n_retries: int = 0
    tile_points: dict = field(default_factory=dict)
    scheduler: str = ""
    extra: dict = field(default_factory=dict)

    @property
    def halo_overhead(self) -> float:
        """Points sent to workers / points (1.0 = no halo cost)."""
        return sum(self.tile_points.values()) / max(1, self.n_points)

    def summary(self) -> dict:
        """JSON-ready description."""
        halos = list(self.halos.values())
        return {
            "tile_size": self.grid.size,
            "tiles": self.n_tiles,
            "grid": [self.grid.nx, self.grid.ny],
            "halo_min": min(halos) if halos else None,
            "halo_max": max(halos) if halos else None,
            "halo_retries": self.n_retries,
            "points_sent_per_point": round(self.halo_overhead, 4),
            "scheduler": self.scheduler,
        }


def parse_memory(value) -> int:
    """``--max-memory``: bytes from ``"4GB"``, ``"512MiB"`` or an integer (> 0)."""
    from dask.utils import parse_bytes

    try:
        n = parse_bytes(value) if isinstance(value, str) else int(value)
    except (ValueError, TypeError):
        raise PointAtlasError(
            f"--max-memory must be a size such as 4GB or 512MiB; got {value!r}"
        ) from None
    if n <= 0:
        raise PointAtlasError(f"--max-memory must be > 0; got {value!r}")
    return int(n)


# --------------------------------------------------------------------------- sources


class ArraySource:
    """Points in memory as a tile source.

    Parameters
    ----------
    points : ndarray of shape (N, 3)
        Coordinates (float64, finite).
    normals : ndarray of shape (N, 3), optional
        Normals sent with the points.
    """

    def __init__(self, points, normals=None):
        from .._core import as_points

        self.points = as_points(points, min_points=1)
        self.normals = None if normals is None else np.asarray(normals, dtype=np.float64)
        self.n = int(self.points.shape[0])

    @property
    def has_normals(self) -> bool:
        """Whether normals travel with the points."""
        return self.normals is not None

    def bounds(self):
        """Minima and maxima of the coordinates, as two (x, y, z) tuples."""
        from .._core.kernels import bounds

        lo, hi = bounds(self.points)
        return tuple(lo.tolist()), tuple(hi.tolist())

    def sample(self, max_points: int):
        """(every stride-th point, stride) with at most about ``max_points`` points."""
        stride = max(1, self.n // max(1, int(max_points)))
        return self.points[::stride], stride

    def chunks(self):
        """(start, xyz float64, normals or None) chunks of at most 2**22 points."""
        for s in range(0, self.n, _ARRAY_CHUNK):
            e = min(self.n, s + _ARRAY_CHUNK)
            yield s, self.points[s:e], None if self.normals is None else self.normals[s:e]


class _Spill:
    """Per-tile pieces: kept in memory, or as .npy files in a folder."""

    def __init__(self, folder: Path | None):
        self.folder = folder
        self.pieces: dict[int, list] = defaultdict(list)

    def add(self, tile: int, arrays: dict) -> None:
        if self.folder is None:
            self.pieces[tile].append(arrays)
            return
        base = self.folder / f"t{tile}_{len(self.pieces[tile])}"
        names = []
        for name, arr in arrays.items():
            np.save(f"{base}_{name}.npy", arr)
            names.append(name)
        self.pieces[tile].append((base, names))

    def load(self, tile: int) -> dict:
        parts = self.pieces.get(tile, [])
        if self.folder is not None:
            parts = [{n: np.load(f"{b}_{n}.npy") for n in names} for b, names in parts]
        if not parts:
            return {}
        return {name: np.concatenate([p[name] for p in parts]) for name in parts[0]}

    def drop(self, tile: int) -> None:
        for item in self.pieces.pop(tile, []):
            if self.folder is not None:
                base, names = item
                for n in names:
                    with contextlib.suppress(FileNotFoundError):
                        os.unlink(f"{base}_{n}.npy")


def _near_border(grid: TileGrid, xy, i, j, halo: float) -> np.ndarray:
    """Points within ``halo`` (plus a rounding slack) of the border of their own cell
    (``i, j``, `TileGrid.cell`): the only ones that can lie in another tile's halo box
    (a point of cell c inside the box of tile t != c is within ``halo`` of c's side
    facing t), a superset of them."""
    slack = 1e-9 * (max(map(abs, (*grid.lo[:2], *grid.hi[:2]))) + grid.size + halo)
    h = halo + slack
    x0 = grid.lo[0] + i * grid.size
    y0 = grid.lo[1] + j * grid.size
    x, y = xy[:, 0], xy[:, 1]
    return (x - x0 <= h) | (x0 + grid.size - x <= h) | (y - y0 <= h) | (y0 + grid.size - y <= h)


def _spill(source, grid: TileGrid, halos: dict, spill: _Spill, normals_array=None):
    """One pass over the source: every requested tile's points (owned + halo),
    in increasing global index order. Returns owned and sent counts per tile.

    A tile's candidates are its own points and the points of its neighbour tiles near
    their cell's border (`_near_border`); `TileGrid.members` decides among them, so
    the pieces are those of testing every point of the neighbour tiles."""
    owned_counts = defaultdict(int)
    sent = defaultdict(int)
    rings = {t: max(1, math.ceil(h / grid.size)) if h > 0 else 0 for t, h in halos.items()}
    reach = max(halos.values(), default=0.0)
    for start, xyz, nrm in source.chunks():
        xy = xyz[:, :2]
        i, j = grid.cell(xy)
        owner = j * grid.nx + i  # `TileGrid.owner`
        order = np.argsort(owner, kind="stable")
        starts = np.searchsorted(owner[order], np.arange(grid.n_tiles + 1))
        edge = order[_near_border(grid, xy, i, j, reach)[order]]  # by owner, then index
        e_starts = np.searchsorted(owner[edge], np.arange(grid.n_tiles + 1))
        for t, h in halos.items():
            near = [u for u in grid.neighbors(t, rings[t]) if starts[u + 1] > starts[u]]
            if not near:
                continue
            parts = [
                order[starts[u] : starts[u + 1]] if u == t else edge[e_starts[u] : e_starts[u + 1]]
                for u in near
            ]
            cand = np.sort(np.concatenate(parts))
            sel = cand[grid.members(xy[cand], owner[cand], t, h)]
            if not sel.size:
                continue
            piece = {"gidx": (start + sel).astype(np.int64), "xyz": np.ascontiguousarray(xyz[sel])}
            if normals_array is not None:
                piece["normals"] = np.asarray(normals_array[start + sel], dtype=np.float64)
            elif nrm is not None:
                piece["normals"] = np.ascontiguousarray(nrm[sel], dtype=np.float64)
            spill.add(t, piece)
            owned_counts[t] += int(np.count_nonzero(owner[sel] == t))
            sent[t] += int(sel.size)
    return owned_counts, sent


# --------------------------------------------------------------------------- cluster


@contextlib.contextmanager
def tile_client(options: TileOptions):
    """A dask Client for the tiles: the given one, one connected to
    ``options.scheduler``, or a fresh local cluster (closed at the end).

    Yields ``(client, label, threads)``: ``threads`` is the numba threads per
    tile (cores / workers on a local cluster, None elsewhere).
    """
    import dask
    import distributed

    from ._runner import NO_PROFILER

    sched = options.scheduler
    if sched is not None and hasattr(sched, "submit"):
        yield sched, "client", None
        return
    stack = contextlib.ExitStack()
    # a signal acts once the cluster is up, or closed: never half-way, which leaves
    # processes and semaphores behind; its worker processes start with SIGINT and
    # SIGTERM blocked (a Ctrl-C reaches the whole process group), the client stops them
    with interrupts_deferred(children=True), warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            if sched is None:
                kwargs = {}
                if options.max_memory is not None:
                    kwargs["memory_limit"] = parse_memory(options.max_memory)
                stack.enter_context(dask.config.set(NO_PROFILER))
                cluster = stack.enter_context(
                    distributed.LocalCluster(
                        n_workers=int(options.workers),
                        threads_per_worker=1,
                        processes=True,
                        dashboard_address=None,
                        silence_logs=logging.CRITICAL,
                        **kwargs,
                    )
                )
                client = stack.enter_context(distributed.Client(cluster))
                label = f"LocalCluster(n_workers={options.workers})"
                threads = max(1, (os.cpu_count() or 1) // int(options.workers))
            else:
                try:
                    client = stack.enter_context(
                        distributed.Client(str(sched), timeout=CONNECT_TIMEOUT_S)
                    )
                except (OSError, TimeoutError) as exc:
                    raise PointAtlasError(
                        f"--scheduler {sched}: cannot connect within {CONNECT_TIMEOUT_S} s "
                        f"({type(exc).__name__})"
                    ) from None
                label = str(sched)
                threads = None
        except BaseException:
            stack.close()
            raise
    try:
        yield client, label, threads
    finally:
        with interrupts_deferred(), warnings.catch_warnings():
            warnings.simplefilter("ignore")
            stack.close()


def _tile_progress(enabled: bool, label: str):
    from ._runner import _progress

    return _progress(enabled, label, 0)


# --------------------------------------------------------------------------- the loop


def _estimate_spacing(source, k: int, *, sample: int = 100_000, typical: bool = False, client=None):
    """(mean 6-NN spacing, a high k-NN distance, or with ``typical`` the median one) of
    the full point set, estimated on a
    regular subsample of every ``stride``-th point.

    In a 1/stride subsample the ceil(k / stride)-th neighbour lies about as far as the
    k-th neighbour of the full set, whatever the local dimension (surface, line,
    volume); the 99.99th percentile of that distance over the subsample keeps sparse
    regions (vegetation, edges) in and isolated outliers out (their tiles grow their
    halo when certified). The spacing is exact when the subsample is all points.
    With a dask ``client`` the k-NN query runs on a worker (`_spacing_of`, the same
    computation: the command's own process then never loads the k-NN kernels).
    """
    pts, stride = source.sample(sample)
    if pts.shape[0] < 8:
        return 0.0, 0.0
    if client is None:
        return _spacing_of(pts, k, stride, typical)
    (data,) = client.scatter([pts], hash=False)
    return client.submit(_spacing_of, data, k, stride, typical, pure=False).result()


def _spacing_of(pts, k: int, stride: int, typical: bool):
    """`_estimate_spacing` of the subsample ``pts`` (every ``stride``-th point)."""
    from ..neighbors import query_knn

    m = pts.shape[0]
    kk = min(m - 1, max(1, math.ceil(k / stride)))
    _, dist = query_knn(pts, min(m, max(kk, 6) + 1))
    spacing = float(dist[:, 1:7].mean())
    if stride > 1:
        spacing /= math.sqrt(stride)  # a surface sampled 1/stride as densely (estimate)
    if typical:
        return spacing, float(np.median(dist[:, kk]))
    return spacing, float(np.quantile(dist[:, kk], 0.9999))


def run_tiles(
    kind,
    source,
    grid,
    params,
    options,
    client_info,
    on_result,
    *,
    halo0,
    fixed,
    label,
    normals_array=None,
    spill_dir=None,
    memory_per_point=0.0,
):
    """Spill, submit and collect every tile; grow automatic halos where needed."""
    client, where, threads = client_info
    halos = dict.fromkeys(range(grid.n_tiles), float(halo0))
    pending = list(range(grid.n_tiles))
    run = TiledRun(n_points=source.n, n_tiles=0, grid=grid, scheduler=where)
    n_workers = max(1, len(client.nthreads()) if hasattr(client, "nthreads") else 1)
    limit = parse_memory(options.max_memory) if options.max_memory is not None else None
    first = True
    with _tile_progress(options.progress, label) as bar:
        task = bar.add_task(label, total=None)
        while pending:
            spill = _Spill(spill_dir)
            owned, sent = _spill(source, grid, {t: halos[t] for t in pending}, spill, normals_array)
            pending = [t for t in pending if owned.get(t, 0) > 0]
            for t in list(spill.pieces):
                if t not in pending:
                    spill.drop(t)
            if first:
                run.n_tiles = len(pending)
                bar.update(task, total=len(pending))
                first = False
            if limit is not None and memory_per_point:
                big = max(pending, key=lambda t: sent[t], default=None)
                if big is not None and sent[big] * memory_per_point > limit:
                    raise PointAtlasError(
                        f"tile {big} holds {sent[big]:,} points (with its halo), about "
                        f"{sent[big] * memory_per_point / 2**30:.2f} GiB of working memory, "
                        f"over --max-memory; use a smaller --tile-size"
                    )
            run.tile_points.update({t: sent[t] for t in pending})
            retry, errors = [], []
            specs = {
                t: {"grid": grid, "tile": t, "halo": halos[t], "params": params, "threads": threads}
                for t in pending
            }
            for t, res in _round(client, kind, specs, spill, 2 * n_workers):
                if res["status"] == "halo":
                    if fixed:
                        errors.append(res)
                    else:
                        grown = halos[t] * _HALO_GROWTH
                        if math.isfinite(res["needed"]):
                            grown = max(grown, res["needed"] * 1.05)
                        if grown > _MAX_HALO_TILES * grid.size:
                            raise PointAtlasError(
                                f"tile {t}: the neighbourhoods of k = {res['k']} reach beyond "
                                f"{_MAX_HALO_TILES} tiles; use a larger --tile-size"
                            )
                        halos[t] = grown
                        retry.append(t)
                else:
                    on_result(t, res)
                    bar.advance(task)
            if errors:
                need = max(e["needed"] for e in errors)
                k = errors[0]["k"]
                hint = (
                    f"--halo {need * 1.05:.4g} or more" if math.isfinite(need) else "a wider --halo"
                )
                raise PointAtlasError(
                    f"--halo {halo0:g} is too small for k = {k}: {len(errors)} tile(s) have points "
                    f"whose {k}-th neighbour may lie outside the halo; use {hint}, or leave "
                    "--halo out (automatic)"
                )
            run.n_retries += len(retry)
            pending = sorted(retry)
    run.halos = {t: halos[t] for t in run.tile_points}
    return run


def _round(client, kind, specs, spill, in_flight):
    """Submit the tiles of ``specs`` (at most ``in_flight`` at once, in tile order) and
    yield ``(tile, result)`` as they finish; a tile's spilled points are dropped then.
    ``kind``: a name of `run_task`'s, or a task function ``(spec, data) -> dict``."""
    from distributed import as_completed

    queue = iter(sorted(specs))
    futures = {}
    ac = as_completed()

    def submit_next():
        t = next(queue, None)
        if t is not None:
            # the points go to the cluster as data (scatter), not inside the task graph
            (data,) = client.scatter([spill.load(t)], hash=False)
            if callable(kind):  # a task function of its own (module-level, picklable)
                fut = client.submit(kind, specs[t], data, pure=False)
            else:
                fut = client.submit(run_task, kind, specs[t], data, pure=False)
            futures[fut] = t
            ac.add(fut)

    for _ in range(max(1, in_flight)):
        submit_next()
    for fut in ac:
        t = futures.pop(fut)
        res = fut.result()
        spill.drop(t)
        yield t, res
        submit_next()


def _auto_halo(source, k: int, options: TileOptions, extra: float = 0.0, client=None):
    """(halo, fixed): the given halo, or an estimate from a subsample (grown later;
    on a worker of ``client`` when given, `_estimate_spacing`)."""
    if options.halo is not None:
        return float(options.halo), True
    _, r_k = _estimate_spacing(source, k, client=client)
    return max(1.25 * r_k, extra, 1e-12), False


def _grid_for(source, options: TileOptions):
    lo, hi = source.bounds()
    return make_grid(lo, hi, options.tile_size)


@contextlib.contextmanager
def _maybe_client(options, client_info):
    if client_info is not None:
        yield client_info
        return
    with tile_client(options) as ci:
        yield ci
