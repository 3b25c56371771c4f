"""Tiled processing of point sets too large for one process (dask.distributed).

Points are cut into an x/y grid of tiles (`TileGrid`), every tile is sent with a
halo of neighbouring points to a dask worker, and the owned points' results are
gathered (normals and features bit for bit those of the untiled run; decisions in
docs/decisions/batch.md). Sources are in-memory arrays (`ArraySource`) or LAS/LAZ
files streamed by chunks (`pointatlas.batch._tiles_las`).
"""

from __future__ import annotations

import contextlib
import heapq
import logging
import math
import os
import shutil
import tempfile
import warnings
from collections import defaultdict
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .._core import PointAtlasError
from ._tiles_grid import TileGrid, make_grid
from ._tiles_tasks import denoise_halo, feature_kmax, run_task

__all__ = [
    "ArraySource",
    "TileOptions",
    "TiledRun",
    "parse_memory",
    "tile_client",
    "tiled_denoise",
    "tiled_features",
    "tiled_normals",
    "tiled_segment",
]

#: Seconds to wait for ``--scheduler ADDRESS`` before giving up.
CONNECT_TIMEOUT_S = 10
#: Automatic halos grow by at least this factor when a tile asks for more.
_HALO_GROWTH = 1.25
#: A halo never grows past this many tile sizes (then the input is refused).
_MAX_HALO_TILES = 64
#: Points per chunk of the in-memory source when spilling (bounds temporary masks).
_ARRAY_CHUNK = 1 << 22
#: Automatic segmentation halos are at least this many typical (median) k-NN halos
#: wide: VSA near a tile edge sees truncated regions; wider context makes the owned
#: labels those of the untiled run more often.
SEGMENT_HALO_FACTOR = 15.0
#: Normal voting's l is the mean 6-NN spacing over at most this many points.
SPACING_SAMPLE = 4_000_000


def _allocate(store, name, n, like):
    """A zeroed (N, ...) array for a result field, or the store's own allocation."""
    width = None if like.ndim == 1 else like.shape[1]
    if hasattr(store, "new"):
        return store.new(name, like.dtype, width)
    store[name] = np.zeros((n,) if width is None else (n, width), dtype=like.dtype)
    return store[name]


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
        return self.normals is not None

    def bounds(self):
        from ..neighbors._kernels import bounds

        lo, hi = bounds(self.points)
        return tuple(lo.tolist()), tuple(hi.tolist())

    def sample(self, max_points: int):
        """(every stride-th point, stride) with at most about ``max_points`` points."""
        stride = max(1, self.n // max(1, int(max_points)))
        return self.points[::stride], stride

    def chunks(self):
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


def _spill(source, grid: TileGrid, halos: dict, spill: _Spill, normals_array=None):
    """One pass over the source: every requested tile's points (owned + halo),
    in increasing global index order. Returns owned and sent counts per tile."""
    owned_counts = defaultdict(int)
    sent = defaultdict(int)
    rings = {t: max(1, math.ceil(h / grid.size)) if h > 0 else 0 for t, h in halos.items()}
    for start, xyz, nrm in source.chunks():
        xy = xyz[:, :2]
        owner = grid.owner(xy)
        order = np.argsort(owner, kind="stable")
        starts = np.searchsorted(owner[order], np.arange(grid.n_tiles + 1))
        for t, h in halos.items():
            near = [u for u in grid.neighbours(t, rings[t]) if starts[u + 1] > starts[u]]
            if not near:
                continue
            cand = np.sort(np.concatenate([order[starts[u] : starts[u + 1]] for u in near]))
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
    import distributed

    sched = options.scheduler
    if sched is not None and hasattr(sched, "submit"):
        yield sched, "client", None
        return
    stack = contextlib.ExitStack()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            if sched is None:
                kwargs = {}
                if options.max_memory is not None:
                    kwargs["memory_limit"] = parse_memory(options.max_memory)
                cluster = stack.enter_context(
                    distributed.LocalCluster(
                        n_workers=int(options.workers),
                        threads_per_worker=1,
                        processes=True,
                        dashboard_address=None,
                        silence_logs=logging.ERROR,
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
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            stack.close()


def _tile_progress(enabled: bool, label: str):
    from ._runner import _progress

    return _progress(enabled, label, 0)


# --------------------------------------------------------------------------- the loop


def _estimate_spacing(source, k: int, *, sample: int = 100_000, typical: bool = False):
    """(mean 6-NN spacing, a high k-NN distance, or with ``typical`` the median one) of
    the full point set, estimated on a
    regular subsample of every ``stride``-th point.

    In a 1/stride subsample the ceil(k / stride)-th neighbour lies about as far as the
    k-th neighbour of the full set, whatever the local dimension (surface, line,
    volume); the 99.99th percentile of that distance over the subsample keeps sparse
    regions (vegetation, edges) in and isolated outliers out (their tiles grow their
    halo when certified). The spacing is exact when the subsample is all points.
    """
    from ..neighbors import query_knn

    pts, stride = source.sample(sample)
    m = pts.shape[0]
    if m < 8:
        return 0.0, 0.0
    kk = min(m - 1, max(1, math.ceil(k / stride)))
    _, dist = query_knn(pts, min(m, max(kk, 6) + 1))
    spacing = float(dist[:, 1:7].mean())
    if stride > 1:
        spacing /= math.sqrt(stride)  # a surface sampled 1/stride as densely (estimate)
    if typical:
        return spacing, float(np.median(dist[:, kk]))
    return spacing, float(np.quantile(dist[:, kk], 0.9999))


def _run(kind, source, grid, params, options, client_info, on_result, *, halo0, fixed, label,
         normals_array=None, spill_dir=None, memory_per_point=0.0):  # fmt: skip
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
                t: {"grid": grid, "tile": t, "halo": halos[t], "params": params,
                    "threads": threads}
                for t in pending
            }  # fmt: skip
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
    yield ``(tile, result)`` as they finish; a tile's spilled points are dropped then."""
    from distributed import as_completed

    queue = iter(sorted(specs))
    futures = {}
    ac = as_completed()

    def submit_next():
        t = next(queue, None)
        if t is not None:
            fut = client.submit(run_task, kind, specs[t], spill.load(t), pure=False)
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


def _auto_halo(source, k: int, options: TileOptions, extra: float = 0.0):
    """(halo, fixed): the given halo, or an estimate from a subsample (grown later)."""
    if options.halo is not None:
        return float(options.halo), True
    _, r_k = _estimate_spacing(source, k)
    return max(1.25 * r_k, extra, 1e-12), False


def _grid_for(source, options: TileOptions):
    lo, hi = source.bounds()
    return make_grid(lo, hi, options.tile_size)


# --------------------------------------------------------------------------- normals


#: Weight of a tile's links between pieces across sharp edges (below any halo vote).
_SHARP_WEIGHT = 1e-6


def _piece_key(tile, comp):
    """Key of a tile's orientation component (tile in the high bits)."""
    return (np.int64(tile) << np.int64(32)) + np.asarray(comp, dtype=np.int64)


def _normal_signs(halo_parts, tops, piece_of, normals, tile_links):
    """Sign flips of the tiles' MST components making orientations agree across tiles.

    A piece is one smooth component of one tile's orientation graph (its signs are
    consistent). Every halo point votes between the piece it lies in and its
    owner's piece (+1 when the two normals agree, -1 when opposed); the tile's MST
    links between its pieces across sharp edges count ``_SHARP_WEIGHT`` times their
    summed dot products, so they only join what no halo joins (as an MST prefers
    smooth edges). Pieces are joined along a maximum spanning forest of |vote| and,
    in every tree, signs are
    fixed so that its topmost owned point (largest z, then smallest index) has
    nz >= 0: Hoppe's root rule of `orient_normals`, applied to the stitched
    component. Returns sorted piece keys and their flips (+1 / -1).
    """
    votes = defaultdict(float)
    for b, (hg, _ho, hn, hp) in halo_parts.items():
        if not hg.size:
            continue
        mine = _piece_key(b, hp)
        theirs = np.asarray(piece_of[hg])
        s = np.sign(np.einsum("ij,ij->i", hn, normals[hg]))
        pairs = np.column_stack([np.minimum(mine, theirs), np.maximum(mine, theirs)])
        uniq, inv = np.unique(pairs, axis=0, return_inverse=True)
        sums = np.bincount(inv.ravel(), weights=s, minlength=uniq.shape[0])
        for (a, c), v in zip(uniq.tolist(), sums.tolist(), strict=True):
            votes[(a, c)] += v
    for t, links in tile_links.items():
        for a, b, v in links.tolist():
            key = (int(_piece_key(t, int(a))), int(_piece_key(t, int(b))))
            votes[key] += _SHARP_WEIGHT * v
    keys = sorted(tops)
    parent = {key: key for key in keys}

    def find(x):
        while parent[x] != x:
            parent[x] = parent[parent[x]]
            x = parent[x]
        return x

    adj = defaultdict(list)
    for (a, b), v in sorted(votes.items(), key=lambda kv: (-abs(kv[1]), kv[0])):
        if a not in parent or b not in parent or v == 0.0:
            continue
        ra, rb = find(a), find(b)
        if ra != rb:
            parent[rb] = ra
            sign = 1.0 if v > 0 else -1.0
            adj[a].append((b, sign))
            adj[b].append((a, sign))
    flips = {}
    for key in keys:
        if key in flips:
            continue
        comp, stack, rel = [], [key], {key: 1.0}
        while stack:
            u = stack.pop()
            comp.append(u)
            for w, s in adj[u]:
                if w not in rel:
                    rel[w] = rel[u] * s
                    stack.append(w)
        best = max(comp, key=lambda u: (tops[u][0], -tops[u][1]))
        root_sign = 1.0 if tops[best][2] * rel[best] >= 0.0 else -1.0
        for u in comp:
            flips[u] = rel[u] * root_sign
    return np.array(keys, dtype=np.int64), np.array([flips[k] for k in keys])


def tiled_normals(points, options: TileOptions, *, k=20, orient="mst", orient_k=10,
                  viewpoint=None):  # fmt: skip
    """PCA normals by tiles, bit for bit those of the untiled ``pointatlas normals``.

    Parameters
    ----------
    points : array_like of shape (N, 3)
        Coordinates.
    options : TileOptions
        Tiling and cluster.
    k : int
        PCA neighbourhood size (the point itself included).
    orient : {"mst", "viewpoint", "none"}
        Orientation; "mst" orients every tile and makes signs agree across tiles
        (see Notes). "outward" needs the whole closed surface and is refused.
    orient_k : int
        k of the orientation graph.
    viewpoint : array_like of shape (3,), optional
        Sensor position for "viewpoint".

    Returns
    -------
    normals : ndarray of shape (N, 3)
    run : TiledRun

    Raises
    ------
    PointAtlasError
        Bad options, a given halo too narrow, an unreachable scheduler.

    Notes
    -----
    Unoriented normals, "none" and "viewpoint" equal the untiled ones bit for bit.
    With "mst" every tile is oriented by Hoppe's MST propagation and tiles are
    flipped as wholes to agree on the points they share (`_normal_signs`); the
    unoriented direction is still bit for bit the untiled one, the sign agrees
    with the untiled MST wherever the untiled propagation itself is consistent.
    """
    source = ArraySource(points)
    return _normals_over(source, options, k=k, orient=orient, orient_k=orient_k,
                         viewpoint=viewpoint)  # fmt: skip


def _normals_over(source, options, *, k, orient, orient_k, viewpoint, out=None, spill_dir=None,
                  client_info=None, label="normals"):  # fmt: skip
    if orient not in ("mst", "viewpoint", "none"):
        raise PointAtlasError(
            f"--orient {orient} needs the whole surface at once; with --tile-size use mst, "
            "viewpoint or none"
        )
    n = source.n
    if k < 3 or k > n:
        raise PointAtlasError(f"--k must lie in [3, number of points = {n}]; got {k}")
    grid = _grid_for(source, options)
    halo0, fixed = _auto_halo(source, k, options)
    normals = np.zeros((n, 3)) if out is None else out
    halo_parts, tops, tile_links = {}, {}, {}
    piece_of = None
    if orient == "mst":
        piece_of = (
            np.zeros(n, dtype=np.int64)
            if spill_dir is None
            else np.lib.format.open_memmap(spill_dir / "piece.npy", "w+", np.int64, (n,))
        )

    def on_result(t, res):
        normals[res["gidx"]] = res["normals"]
        if piece_of is not None:
            piece_of[res["gidx"]] = _piece_key(t, res["piece"])
            halo_parts[t] = (res["halo_gidx"], res["halo_owner"], res["halo_normals"],
                             res["halo_piece"])  # fmt: skip
            tops.update({int(_piece_key(t, c)): v for c, v in res["tops"].items()})
            tile_links[t] = res["links"]

    params = {"k": int(k), "orient": orient, "orient_k": int(orient_k), "viewpoint": viewpoint}
    with _maybe_client(options, client_info) as ci:
        run = _run("normals", source, grid, params, options, ci, on_result, halo0=halo0,
                   fixed=fixed, label=label, spill_dir=spill_dir,
                   memory_per_point=8.0 * (3 * (k + 8) + 40))  # fmt: skip
    if orient == "mst":
        keys, flips = _normal_signs(halo_parts, tops, piece_of, normals, tile_links)
        run.extra["orientation_pieces"] = int(keys.size)
        run.extra["flipped_pieces"] = int(np.count_nonzero(flips < 0))
        for sl in _chunked(n):
            f = flips[np.searchsorted(keys, piece_of[sl])]
            normals[sl] = normals[sl] * f[:, None]
    return normals, run


@contextlib.contextmanager
def _maybe_client(options, client_info):
    if client_info is not None:
        yield client_info
        return
    with tile_client(options) as ci:
        yield ci


# --------------------------------------------------------------------------- features


def tiled_features(points, normals, options: TileOptions, params: dict):
    """Features by tiles, bit for bit those of the untiled run.

    Parameters
    ----------
    points : array_like of shape (N, 3)
        Coordinates.
    normals : array_like of shape (N, 3) or None
        Oriented normals (needed by ``mode="optimal"``).
    options : TileOptions
        Tiling and cluster.
    params : dict
        ``mode`` "fixed" (``k``), "optimal_k" (``k_range``, ``criterion``) or
        "optimal" (``k_range``, ``a_grid``, ``b_grid``), and ``flatness``.

    Returns
    -------
    fields : dict of str to ndarray
        The ``FeatureResult.scalar_fields()`` and ``dimension_class``.
    run : TiledRun
    """
    return _features_over(ArraySource(points, normals), options, params)


def _features_over(source, options, params, *, out=None, spill_dir=None, client_info=None,
                   normals_array=None, label="features"):  # fmt: skip
    kmax = feature_kmax(params)
    if kmax > source.n:
        raise PointAtlasError(f"k = {kmax} exceeds the number of points ({source.n})")
    if params["mode"] == "optimal" and not source.has_normals and normals_array is None:
        raise PointAtlasError("sigmoid weights need normals; the input has none")
    grid = _grid_for(source, options)
    halo0, fixed = _auto_halo(source, kmax, options)
    fields = {} if out is None else out

    def on_result(t, res):
        for name, v in res["fields"].items():
            if name not in fields:
                _allocate(fields, name, source.n, v)
            fields[name][res["gidx"]] = v

    with _maybe_client(options, client_info) as ci:
        run = _run("features", source, grid, params, options, ci, on_result, halo0=halo0,
                   fixed=fixed, label=label, spill_dir=spill_dir, normals_array=normals_array,
                   memory_per_point=8.0 * (kmax + 60))  # fmt: skip
    return fields, run


# --------------------------------------------------------------------------- denoise


def tiled_denoise(points, normals, options: TileOptions, params: dict):
    """Denoising by tiles with a halo covering every iteration's reach.

    Parameters
    ----------
    points, normals : ndarray of shape (N, 3)
        Noisy points and (for normal voting) oriented normals.
    options : TileOptions
        Tiling and cluster; an automatic halo is `denoise_halo` of the parameters
        (a given smaller halo is refused).
    params : dict
        ``method`` "flatness" (``k``, ``eta``, ``eps``, ``n_iter``, ``schedule``,
        ``k_start``) or "normal-voting[-adaptive]" (``rho``, ``tau``, ``n_iter``,
        ``filter_iter``, ``max_step``).

    Returns
    -------
    result : dict
        ``points``, ``normals`` and the per-point fields (``displacement``,
        ``feature_class``, ``denoise_k``, ``flatness``), ``spacing`` (global l).
    run : TiledRun
    """
    return _denoise_over(ArraySource(points, normals), options, params)


def _denoise_over(source, options, params, *, spill_dir=None, client_info=None, outs=None,
                  normals_array=None, label="denoise"):  # fmt: skip
    # l of normal voting: the mean 6-NN spacing (exact below SPACING_SAMPLE points)
    spacing, _ = _estimate_spacing(source, 6, sample=SPACING_SAMPLE)
    p = dict(params)
    if p["method"] == "flatness":
        kk = max(int(p["k"]), int(p.get("k_start") or 0))
        _, r_k = _estimate_spacing(source, kk)
    else:
        r_k = 0.0
        p["spacing"] = spacing
    need = denoise_halo(p, spacing, r_k)
    if options.halo is not None and options.halo < need:
        raise PointAtlasError(
            f"--halo {options.halo:g} is smaller than the reach of {p['n_iter']} denoising "
            f"iterations ({need:.4g}); use --halo {need * 1.05:.4g} or more, or leave it out"
        )
    halo = float(options.halo) if options.halo is not None else need * 1.05
    grid = _grid_for(source, options)
    n = source.n
    out = outs or {"points": np.zeros((n, 3)), "normals": np.zeros((n, 3))}
    n_fallback = [0]

    def on_result(t, res):
        out["points"][res["gidx"]] = res["points"]
        out["normals"][res["gidx"]] = res["normals"]
        for name, v in res["fields"].items():
            if name not in out:
                _allocate(out, name, n, v)
            out[name][res["gidx"]] = v
        n_fallback[0] += res["n_fallback"]

    with _maybe_client(options, client_info) as ci:
        run = _run("denoise", source, grid, p, options, ci, on_result, halo0=halo, fixed=True,
                   label=label, spill_dir=spill_dir, normals_array=normals_array,
                   memory_per_point=8.0 * 200)  # fmt: skip
    out["spacing"] = spacing
    run.extra["n_fallback"] = n_fallback[0]
    return out, run


# --------------------------------------------------------------------------- segment


class _Regions:
    """Stitched regions: union-find over tile regions with summed statistics."""

    def __init__(self, stats, first, eta, min_cos, tau2=0.0):
        self.st = stats.copy()
        self.first = first.copy()
        self.parent = np.arange(stats.shape[0])
        self.eta = eta
        self.min_cos = min_cos
        self.tau2 = tau2

    def find(self, x):
        p = self.parent
        root = x
        while p[root] != root:
            root = p[root]
        while p[x] != root:
            p[x], x = root, p[x]
        return root

    @staticmethod
    def l21(st):
        return max(0.0, 2.0 * (st[0] - math.sqrt(st[1] ** 2 + st[2] ** 2 + st[3] ** 2)))

    @staticmethod
    def plane_mse(st) -> float:
        """Mean squared distance to the region's proxy plane (through the centroid)."""
        length = math.sqrt(st[1] ** 2 + st[2] ** 2 + st[3] ** 2)
        if st[0] <= 0 or length == 0.0:
            return 0.0
        nrm = st[1:4] / length
        mean = st[4:7] / st[0]
        cov = np.empty((3, 3))
        c = 7
        for i in range(3):
            for j in range(i, 3):
                cov[i, j] = cov[j, i] = st[c] - st[0] * mean[i] * mean[j]
                c += 1
        return max(0.0, float(nrm @ cov @ nrm) / st[0])

    def ok(self, a, b) -> bool:
        """The VSA merge test on the union (eta: L21 < eta; else mean deviation <=
        max angle and the two proxies within the max angle), and the union's plane
        no worse than 4 x its parts' plus tau^2 (parallel but offset planes, a roof
        and the ground, pass the normal tests: they must not join)."""
        sa, sb = self.st[a], self.st[b]
        u = sa + sb
        mse_u = self.plane_mse(u)
        if mse_u > 4.0 * max(self.plane_mse(sa), self.plane_mse(sb)) + self.tau2:
            return False
        if self.eta is not None:
            return self.l21(u) < self.eta
        la = math.sqrt(sa[1] ** 2 + sa[2] ** 2 + sa[3] ** 2)
        lb = math.sqrt(sb[1] ** 2 + sb[2] ** 2 + sb[3] ** 2)
        lu = math.sqrt(u[1] ** 2 + u[2] ** 2 + u[3] ** 2)
        if la == 0.0 or lb == 0.0:
            return False
        cos_ab = (sa[1] * sb[1] + sa[2] * sb[2] + sa[3] * sb[3]) / (la * lb)
        return cos_ab >= self.min_cos and lu >= self.min_cos * u[0]

    def union(self, a, b):
        ra, rb = self.find(a), self.find(b)
        if ra == rb:
            return ra
        if rb < ra:
            ra, rb = rb, ra
        self.parent[rb] = ra
        self.st[ra] += self.st[rb]
        self.first[ra] = min(self.first[ra], self.first[rb])
        return ra


def _greedy_merge(regions: _Regions, pairs: np.ndarray) -> int:
    """Cheapest-first merging of neighbouring stitched regions (energy increase
    first) while the VSA test holds; returns the number of merges."""
    heap = []
    l21 = regions.l21
    for a, b in pairs.tolist():
        ra, rb = regions.find(a), regions.find(b)
        if ra != rb:
            cost = l21(regions.st[ra] + regions.st[rb]) - l21(regions.st[ra]) - l21(regions.st[rb])
            heapq.heappush(heap, (cost, min(ra, rb), max(ra, rb)))
    merged = 0
    while heap:
        cost, a, b = heapq.heappop(heap)
        ra, rb = regions.find(a), regions.find(b)
        if ra == rb:
            continue
        now = l21(regions.st[ra] + regions.st[rb]) - l21(regions.st[ra]) - l21(regions.st[rb])
        if (min(ra, rb), max(ra, rb)) != (a, b) or now != cost:  # stale entry
            heapq.heappush(heap, (now, min(ra, rb), max(ra, rb)))
            continue
        if regions.ok(ra, rb):
            regions.union(ra, rb)
            merged += 1
    return merged


def _quality(st) -> dict:
    """n_regions, energy (sum of L21) and plane MSE of stitched region statistics."""
    w = st[:, 0]
    s = st[:, 1:4]
    length = np.sqrt((s * s).sum(axis=1))
    energy = float(np.maximum(2.0 * (w - length), 0.0).sum())
    prox = np.where(length[:, None] > 0, s / np.where(length > 0, length, 1.0)[:, None], 0.0)
    mean = st[:, 4:7] / w[:, None]
    cov = np.empty((st.shape[0], 3, 3))
    c = 7
    for a in range(3):
        for b in range(a, 3):
            cov[:, a, b] = cov[:, b, a] = st[:, c] - w * mean[:, a] * mean[:, b]
            c += 1
    sq = np.einsum("ri,rij,rj->r", prox, cov, prox)
    return {
        "n_regions": int(st.shape[0]),
        "energy": energy,
        "mse": float(np.maximum(sq, 0.0).sum() / w.sum()),
        "proxy_normals": prox,
        "centroids": mean,
        "region_l21": np.maximum(2.0 * (w - length), 0.0),
        "region_counts": w.astype(np.int64),
    }


def tiled_segment(points, normals, options: TileOptions, params: dict):
    """VSA segmentation by tiles, stitched across tile borders.

    Parameters
    ----------
    points, normals : ndarray of shape (N, 3)
        Coordinates and oriented normals.
    options : TileOptions
        Tiling and cluster.
    params : dict
        ``k``, ``eta`` or ``max_angle`` (radians; neither: 10 degrees), ``split``,
        ``merge``, ``switch`` (the `pointatlas.segment.vsa_segment` options; seeds
        are every point, weights uniform).

    Returns
    -------
    labels : ndarray of shape (N,), int64
        Regions numbered by smallest member index.
    quality : dict
        ``n_regions``, ``energy`` (total L21), ``mse`` (plane MSE), per region
        ``proxy_normals``, ``centroids``, ``region_l21``, ``region_counts``.
    run : TiledRun

    Notes
    -----
    Each tile runs `vsa_segment` on its points and halo with the owned points'
    exact k-NN graph. A halo point carries two labels, its owner's and the
    neighbour tile's: these pairs join regions by a union-find when the union
    passes the VSA merge test (and, in angle mode, the two proxy normals lie
    within the max angle). With ``eta``, a final cheapest-first merge pass over all
    neighbouring regions (tile adjacency and halo links) then applies the same
    test, as VSA's own final merge does (VSA runs none in angle mode).
    """
    return _segment_over(ArraySource(points, normals), options, params)


def _segment_over(source, options, params, *, labels_out=None, spill_dir=None, client_info=None,
                  normals_array=None, label="segment"):  # fmt: skip
    k = int(params["k"])
    grid = _grid_for(source, options)
    halo0, fixed = _auto_halo(source, k, options)
    if not fixed:  # context for VSA near the tile edges: a multiple of the typical r_k
        typical = _estimate_spacing(source, k, typical=True)[1]
        halo0 = max(halo0, SEGMENT_HALO_FACTOR * 1.25 * typical)
    n = source.n
    labels = np.zeros(n, dtype=np.int64) if labels_out is None else labels_out
    per_tile = {}

    def on_result(t, res):
        per_tile[t] = res

    with _maybe_client(options, client_info) as ci:
        run = _run("segment", source, grid, params, options, ci, on_result, halo0=halo0,
                   fixed=fixed, label=label, spill_dir=spill_dir, normals_array=normals_array,
                   memory_per_point=8.0 * (4 * k + 80))  # fmt: skip
    tiles = sorted(per_tile)
    offsets, total = {}, 0
    for t in tiles:
        offsets[t] = total
        total += per_tile[t]["n_regions"]
    stats = np.zeros((total, 14))
    first = np.full(total, np.iinfo(np.int64).max, dtype=np.int64)
    for t in tiles:
        r = per_tile[t]
        o = offsets[t]
        stats[o : o + r["n_regions"]] = r["stats"]
        first[o : o + r["n_regions"]] = r["first"]
        labels[r["gidx"]] = o + r["labels"]
    # links: a halo point's label in its neighbour tile and in its owner tile
    links, adjacency = [], []
    for t in tiles:
        r = per_tile[t]
        if r["halo_gidx"].size:
            links.append(np.column_stack([labels[r["halo_gidx"]], offsets[t] + r["halo_labels"]]))
        if r["adjacency"].size:
            adjacency.append(offsets[t] + r["adjacency"])
    eta = params.get("eta")
    max_angle = params.get("max_angle")
    if eta is None and max_angle is None:
        from .._core.tolerances import VSA_DEFAULT_MAX_ANGLE

        max_angle = VSA_DEFAULT_MAX_ANGLE
    tau2 = float(_estimate_spacing(source, k, typical=True)[1]) ** 2
    regions = _Regions(stats, first, eta, None if eta is not None else math.cos(max_angle), tau2)
    has_points = stats[:, 0] > 0
    n_links = 0
    if links:
        pairs, counts = np.unique(np.concatenate(links), axis=0, return_counts=True)
        keep = has_points[pairs[:, 0]] & has_points[pairs[:, 1]] & (pairs[:, 0] != pairs[:, 1])
        pairs, counts = pairs[keep], counts[keep]
        order = np.lexsort((pairs[:, 1], pairs[:, 0], -counts))
        for a, b in pairs[order].tolist():
            if regions.find(a) != regions.find(b) and regions.ok(regions.find(a), regions.find(b)):
                regions.union(a, b)
                n_links += 1
    else:
        pairs = np.zeros((0, 2), dtype=np.int64)
    cand = [pairs]
    if adjacency:
        adj = np.concatenate(adjacency)
        cand.append(adj[has_points[adj[:, 0]] & has_points[adj[:, 1]]])
    # VSA's own final merge runs only with eta (in angle mode the mean-deviation test
    # lets a large region absorb a small perpendicular one); so does this one
    final_pass = params.get("merge", True) and eta is not None
    n_final = _greedy_merge(regions, np.concatenate(cand)) if final_pass else 0
    roots = np.array([regions.find(i) for i in range(total)], dtype=np.int64)
    live = np.unique(roots[has_points])
    live = live[np.argsort(regions.first[live], kind="stable")]
    rank = np.full(total, -1, dtype=np.int64)
    rank[live] = np.arange(live.size)
    final = rank[roots]
    for sl in _chunked(n):
        labels[sl] = final[labels[sl]]
    quality = _quality(regions.st[live])
    run.extra.update(tile_regions=int(has_points.sum()), halo_unions=n_links, final_merges=n_final)
    return labels, quality, run


def clean_tmp(folder: Path) -> None:
    """Remove a run's temporary folder."""
    shutil.rmtree(folder, ignore_errors=True)


def make_tmp(options: TileOptions, near: Path) -> Path:
    """A fresh temporary folder for spilled tiles and result arrays."""
    base = Path(options.tmp_dir) if options.tmp_dir is not None else Path(near).parent
    return Path(tempfile.mkdtemp(prefix=".pointatlas-tiles-", dir=base))
