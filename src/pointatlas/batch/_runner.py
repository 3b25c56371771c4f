"""Run one function over many model files on a dask cluster, resumably."""

from __future__ import annotations

import contextlib
import fnmatch
import json
import logging
import math
import os
import time
import traceback
import warnings
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType

import numpy as np

from .._core import interrupts_deferred
from ..io import to_json_safe, write_json

__all__ = ["BatchReport", "list_models", "run_batch"]

#: The workers of the clusters we start keep no statistical profile: dask's profiler
#: calls ``sys._current_frames()`` every 10 ms from a thread of its own, and on
#: Python 3.11 that can deadlock a thread that takes the GIL back at the same moment
#: (CPython issue 106883: a tiled segment's worker thread stopped in ``hashlib``
#: while the profiler held the runtime's lock; seen twice in the test suite).
NO_PROFILER = {"distributed.worker.profile.enabled": False}

#: default model patterns of `list_models`
MODEL_PATTERNS = ("*.obj", "*.off", "*.ply", "*.stl")

_RESULT_SUFFIX = ".json"
_ERROR_SUFFIX = ".error.json"


@dataclass(frozen=True, slots=True)
class BatchReport:
    """Outcome of `run_batch`.

    Parameters
    ----------
    results : mapping of str to dict
        Model stem -> result of every model with a result, computed now or read
        back from an earlier run (plain JSON types).
    failures : mapping of str to str
        Model stem -> ``"ErrorType: message"`` for the models that failed this run.
    n_done : int
        Models computed successfully in this run.
    n_skipped : int
        Models whose result existed already (not recomputed).
    n_failed : int
        Models that failed in this run.
    out_dir : pathlib.Path
        The output folder (``results/`` and ``summary.json`` inside).
    elapsed_s : float
        Wall-clock seconds of the run.
    """

    results: Mapping[str, dict]
    failures: Mapping[str, str]
    n_done: int
    n_skipped: int
    n_failed: int
    out_dir: Path = field(default_factory=Path)
    elapsed_s: float = 0.0

    def __post_init__(self):
        object.__setattr__(self, "results", MappingProxyType(dict(self.results)))
        object.__setattr__(self, "failures", MappingProxyType(dict(self.failures)))


def _read_json(path: Path):
    """The stored object, or None if the file is missing or unreadable."""
    try:
        with open(path, encoding="utf-8") as fh:
            return json.load(fh)
    except (OSError, ValueError):
        return None


def _error_record(exc: BaseException, tb_text: str | None = None) -> dict:
    if tb_text is None:
        tb_text = "".join(traceback.format_exception(type(exc), exc, exc.__traceback__))
    return {"type": type(exc).__name__, "message": str(exc), "traceback": tb_text}


def _run_task(func, path: str, seed_seq):
    """Executed on a worker: call func(path, rng), never raise.

    Returns ``("ok", plain_result, seconds)`` or ``("error", error_record, seconds)``.
    """
    start = time.perf_counter()
    try:
        rng = np.random.default_rng(seed_seq)
        result = func(path, rng)
        if not isinstance(result, Mapping):
            raise TypeError(f"func must return a dict; got {type(result).__name__}")
        # JSON types now (a failure is recorded here rather than when writing)
        return "ok", to_json_safe(result), time.perf_counter() - start
    except Exception as exc:  # any failure of one model is recorded, never fatal
        return "error", _error_record(exc), time.perf_counter() - start


def _validate_inputs(inputs) -> list[tuple[str, str]]:
    """Sorted ``(path, stem)`` pairs; stems must be unique (they name the outputs)."""
    if isinstance(inputs, str | os.PathLike):
        raise TypeError("inputs must be a list of paths; got a single path (use list_models)")
    try:
        paths = sorted({os.fspath(p) for p in inputs})
    except TypeError as exc:
        raise TypeError(f"inputs must be an iterable of paths; {exc}") from None
    stems: dict[str, str] = {}
    for p in paths:
        stem = Path(p).stem
        if not stem or stem.startswith("."):
            raise ValueError(f"inputs: cannot name an output after {p!r}")
        if stem in stems:
            raise ValueError(
                f"inputs must have distinct file stems (outputs are named after them); "
                f"{stems[stem]!r} and {p!r} share {stem!r}"
            )
        stems[stem] = p
    return [(p, Path(p).stem) for p in paths]


def _import_dask():
    try:
        import distributed  # noqa: F401
    except ImportError as exc:  # pragma: no cover - dask is a core dependency
        raise ImportError(
            "pointatlas.batch needs dask.distributed: pip install 'dask[distributed]'"
        ) from exc
    return distributed


@contextlib.contextmanager
def _client(scheduler, n_workers: int):
    """A dask Client: to ``scheduler`` (an address or a Client) or to a fresh
    LocalCluster of ``n_workers`` single-threaded processes, closed afterwards."""
    distributed = _import_dask()
    import dask

    if scheduler is not None and hasattr(scheduler, "submit"):
        yield scheduler, getattr(getattr(scheduler, "scheduler", None), "address", None)
        return
    stack = contextlib.ExitStack()
    # dask's start-up/shut-down chatter must not reach a warnings-as-errors run; the
    # user's own warning filters stay in force while tasks run; a signal acts once the
    # cluster is up or closed (`pointatlas.batch._tiles.tile_client`)
    with interrupts_deferred(children=True), warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            if scheduler is None:
                # a dead worker is retried once on another, then reported KilledWorker
                stack.enter_context(dask.config.set({"distributed.scheduler.allowed-failures": 1}))
                stack.enter_context(dask.config.set(NO_PROFILER))
                cluster = stack.enter_context(
                    distributed.LocalCluster(
                        n_workers=n_workers,
                        threads_per_worker=1,
                        processes=True,
                        dashboard_address=None,
                        silence_logs=logging.CRITICAL,
                    )
                )
                client = stack.enter_context(distributed.Client(cluster))
                label = f"LocalCluster(n_workers={n_workers})"
            else:
                client = stack.enter_context(distributed.Client(str(scheduler)))
                label = str(scheduler)
        except BaseException:
            stack.close()
            raise
    try:
        yield client, label
    finally:
        with interrupts_deferred(), warnings.catch_warnings():
            warnings.simplefilter("ignore")
            stack.close()


def _progress(enabled: bool, description: str, total: int):
    from rich.console import Console
    from rich.progress import (
        BarColumn,
        MofNCompleteColumn,
        Progress,
        TextColumn,
        TimeElapsedColumn,
        TimeRemainingColumn,
    )

    return Progress(
        TextColumn("[bold]{task.description}"),
        BarColumn(),
        MofNCompleteColumn(),
        TimeElapsedColumn(),
        TimeRemainingColumn(),
        console=Console(stderr=True),
        transient=True,
        disable=not enabled,
    )


def _check_arguments(func, n_workers, seed) -> None:
    """The argument checks of `run_batch` (one precise error each)."""
    if not callable(func):
        raise TypeError(f"func must be callable; got {type(func).__name__}")
    if isinstance(n_workers, bool) or not isinstance(n_workers, int | np.integer):
        raise TypeError(f"n_workers must be an integer; got {type(n_workers).__name__}")
    if n_workers < 1:
        raise ValueError(f"n_workers must be >= 1; got {n_workers}")
    if isinstance(seed, bool) or not isinstance(seed, int | np.integer) or seed < 0:
        raise ValueError(f"seed must be an integer >= 0; got {seed!r}")


def _stored_results(items, results_dir: Path):
    """Results of an earlier run read back; the (index, path, stem) still to compute."""
    results: dict[str, dict] = {}
    models: dict[str, dict] = {}
    todo = []
    for index, (path, stem) in enumerate(items):
        stored = _read_json(results_dir / f"{stem}{_RESULT_SUFFIX}")
        if isinstance(stored, dict):
            results[stem] = stored
            models[stem] = {"input": path, "index": index, "status": "skipped"}
        else:
            todo.append((index, path, stem))
    return results, models, todo


def run_batch(
    func: Callable,
    inputs: Iterable,
    out_dir,
    *,
    scheduler=None,
    n_workers: int = 2,
    seed: int = 0,
    name: str | None = None,
    progress: bool = True,
) -> BatchReport:
    """Run ``func(path, rng) -> dict`` over model files on a dask cluster, resumably.

    Parameters
    ----------
    func : callable
        A module-level (picklable) function ``func(path: str, rng:
        numpy.random.Generator) -> dict`` whose result is JSON-serialisable after
        numpy values are converted (`pointatlas.io.to_json_safe`: NaN and infinities
        become None). Workers import its module, so it
        must be importable there (functions from ``__main__`` are pickled by value).
    inputs : iterable of str or path-like
        Model files. They are sorted; their file stems (names without extension)
        must be distinct, as they name the outputs.
    out_dir : str or path-like
        Output folder (created): ``results/<stem>.json`` per model,
        ``results/<stem>.error.json`` per failure, ``summary.json``.
    scheduler : str or distributed.Client, optional
        Address of a running dask scheduler (``"tcp://host:8786"``) or a Client to
        use. Default: a fresh ``LocalCluster`` of ``n_workers`` single-threaded
        worker processes, closed at the end.
    n_workers : int
        Worker processes of the local cluster (>= 1; ignored with ``scheduler``).
    seed : int
        Root seed (>= 0). The model at position i of the sorted inputs gets
        ``np.random.default_rng(np.random.SeedSequence(seed).spawn(n)[i])``,
        independent of scheduling, of the number of workers and of resuming.
    name : str, optional
        Label for the progress bar and the summary (default: ``func.__name__``).
    progress : bool
        Show a transient progress bar of models done on stderr.

    Returns
    -------
    report : BatchReport
        ``results`` (stem -> result, including results read back from an earlier
        run), ``failures`` (stem -> ``"Type: message"``), ``n_done``,
        ``n_skipped``, ``n_failed``.

    Raises
    ------
    TypeError
        ``func`` not callable, ``inputs`` not an iterable of paths.
    ValueError
        Duplicate stems, ``n_workers`` < 1, negative ``seed``.

    Notes
    -----
    Each result is written the moment its task finishes (temporary file, then
    ``os.replace``), so an interrupted batch loses only running models; a rerun skips
    models whose ``<stem>.json`` exists and retries failed ones. An exception in
    ``func`` (or a worker dying twice on a model) is recorded in
    ``<stem>.error.json`` with type, message and traceback, and the batch goes on.
    Decisions in docs/decisions/batch.md.

    Examples
    --------
    >>> import tempfile
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     run_batch(len, [], tmp, progress=False).n_done
    0
    """
    _check_arguments(func, n_workers, seed)
    items = _validate_inputs(inputs)
    label = name or getattr(func, "__name__", "batch")
    out = Path(out_dir)
    results_dir = out / "results"
    results_dir.mkdir(parents=True, exist_ok=True)
    start = time.perf_counter()
    children = np.random.SeedSequence(int(seed)).spawn(len(items))

    failures: dict[str, str] = {}
    results, models, todo = _stored_results(items, results_dir)
    n_skipped = len(results)
    n_done = 0
    where = None
    complete = False
    try:
        with _progress(progress, label, len(items)) as bar:
            task = bar.add_task(label, total=len(items), completed=n_skipped)
            if todo:
                with _client(scheduler, int(n_workers)) as (client, where):
                    n_done = _consume(
                        client,
                        func,
                        todo,
                        children,
                        results_dir,
                        results,
                        failures,
                        models,
                        lambda: bar.advance(task),
                    )
            complete = True
    finally:
        elapsed = time.perf_counter() - start
        counts = {"n_inputs": len(items), "n_done": n_done, "n_skipped": n_skipped}
        _write_summary(out, label, seed, where, complete, counts, elapsed, failures, models)
    return BatchReport(
        results=dict(sorted(results.items())),
        failures=dict(sorted(failures.items())),
        n_done=n_done,
        n_skipped=n_skipped,
        n_failed=len(failures),
        out_dir=out,
        elapsed_s=elapsed,
    )


def _write_summary(out, label, seed, where, complete, counts, elapsed, failures, models):
    """``summary.json``: name, seed, scheduler, counts, seconds, failures, per model."""
    summary = {
        "name": label,
        "seed": int(seed),
        "scheduler": where,
        "complete": complete,
        **counts,
        "n_failed": len(failures),
        "elapsed_s": round(elapsed, 3),
        "failures": dict(sorted(failures.items())),
        "models": dict(sorted(models.items())),
    }
    write_json(out / "summary.json", summary, indent=2)


def _consume(client, func, todo, children, results_dir, results, failures, models, advance):
    """Submit one task per model and store each outcome as soon as it arrives."""
    from distributed import as_completed

    futures = {}
    for index, path, stem in todo:
        fut = client.submit(_run_task, func, path, children[index], pure=False)
        futures[fut] = (index, path, stem)
    n_done = 0
    for fut in as_completed(list(futures)):
        index, path, stem = futures.pop(fut)
        try:
            status, payload, seconds = fut.result()
        except Exception as exc:  # the task itself failed: worker death, unpicklable func
            status, payload, seconds = "error", _error_record(exc), math.nan
        record = {"input": path, "index": index}
        if status == "ok":
            write_json(results_dir / f"{stem}{_RESULT_SUFFIX}", payload, indent=2)
            with contextlib.suppress(FileNotFoundError):
                os.unlink(results_dir / f"{stem}{_ERROR_SUFFIX}")
            results[stem] = payload
            record["status"] = "done"
            n_done += 1
        else:
            write_json(results_dir / f"{stem}{_ERROR_SUFFIX}", {**record, **payload}, indent=2)
            failures[stem] = f"{payload['type']}: {payload['message']}"
            record["status"] = "failed"
        record["elapsed_s"] = None if math.isnan(seconds) else round(seconds, 4)
        models[stem] = record
        advance()
    return n_done


def list_models(directory, patterns: Iterable[str] = MODEL_PATTERNS, *, recursive: bool = False):
    """The model files of a folder, sorted.

    Parameters
    ----------
    directory : str or path-like
        Folder to list.
    patterns : iterable of str
        Shell patterns matched case-insensitively against file names (default
        ``*.obj``, ``*.off``, ``*.ply``, ``*.stl``).
    recursive : bool
        Also list sub-folders.

    Returns
    -------
    paths : list of pathlib.Path
        Matching regular files, sorted by path.

    Raises
    ------
    FileNotFoundError
        ``directory`` does not exist.
    NotADirectoryError
        ``directory`` is a file.

    Examples
    --------
    >>> import tempfile
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     _ = (Path(tmp) / "b.OBJ").write_text(""), (Path(tmp) / "a.txt").write_text("")
    ...     [p.name for p in list_models(tmp)]
    ['b.OBJ']
    """
    folder = Path(directory)
    if not folder.exists():
        raise FileNotFoundError(f"directory not found: {folder}")
    if not folder.is_dir():
        raise NotADirectoryError(f"directory is not a folder: {folder}")
    pats = [patterns] if isinstance(patterns, str) else list(patterns)
    pats = [p.lower() for p in pats]
    found = folder.rglob("*") if recursive else folder.iterdir()
    return sorted(
        p
        for p in found
        if p.is_file() and any(fnmatch.fnmatchcase(p.name.lower(), pat) for pat in pats)
    )
