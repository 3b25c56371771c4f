"""run_batch on a real 2-worker LocalCluster: per-model results, resume, failures, seeds."""

from __future__ import annotations

import json
import logging
import random
import warnings
from pathlib import Path

import numpy as np
import pytest

from pointatlas.batch import BatchReport, list_models, run_batch
from pointatlas.batch._runner import NO_PROFILER

from . import funcs

distributed = pytest.importorskip("distributed")


@pytest.fixture(scope="module")
def address():
    """One LocalCluster for the module (start-up costs seconds); a dead worker is
    reported at once (allowed-failures 0)."""
    import dask

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with dask.config.set({"distributed.scheduler.allowed-failures": 0, **NO_PROFILER}):
            cluster = distributed.LocalCluster(
                n_workers=2,
                threads_per_worker=1,
                processes=True,
                dashboard_address=None,
                silence_logs=logging.ERROR,
            )
    yield cluster.scheduler_address
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        cluster.close()


def make_models(folder: Path, names, content="v 0 0 0\n"):
    folder.mkdir(parents=True, exist_ok=True)
    paths = []
    for name in names:
        p = folder / name
        p.write_text(content + name, encoding="utf-8")
        paths.append(p)
    return paths


def n_calls(path: Path) -> int:
    calls = path.with_suffix(".calls")
    return len(calls.read_text().splitlines()) if calls.exists() else 0


def expected_draws(seed, n, i):
    return np.random.default_rng(np.random.SeedSequence(seed).spawn(n)[i]).random(3).tolist()


def test_results_written_and_rerun_skips(address, tmp_path):
    paths = make_models(tmp_path / "models", ["b.obj", "a.off", "c.ply", "d.stl"])
    out = tmp_path / "out"
    report = run_batch(funcs.measure, paths, out, scheduler=address, seed=3, progress=False)
    assert isinstance(report, BatchReport)
    assert (report.n_done, report.n_skipped, report.n_failed) == (4, 0, 0)
    assert list(report.results) == ["a", "b", "c", "d"]
    for p in paths:
        stored = json.loads((out / "results" / f"{p.stem}.json").read_text())
        assert stored == report.results[p.stem]
        assert stored["n_chars"] == len(p.read_text())
        assert stored["integer"] == 7 and stored["scalar"] == 1.5 and stored["flag"] is True
        assert stored["nested"] == {"pair": [1, 2], "grid": [[1, 0], [0, 1]]}
        assert n_calls(p) == 1
    summary = json.loads((out / "summary.json").read_text())
    assert summary["n_done"] == 4 and summary["complete"] is True and summary["seed"] == 3
    assert summary["scheduler"] == address
    assert {m["status"] for m in summary["models"].values()} == {"done"}
    assert not list((out / "results").glob(".*")), "no temporary files left"

    # rerun: only the model whose result was removed is computed again
    (out / "results" / "c.json").unlink()
    again = run_batch(funcs.measure, paths, out, scheduler=address, seed=3, progress=False)
    assert (again.n_done, again.n_skipped, again.n_failed) == (1, 3, 0)
    assert [n_calls(p) for p in paths] == [1, 1, 2, 1]
    assert dict(again.results) == dict(report.results), "same seed -> same result on rerun"
    summary = json.loads((out / "summary.json").read_text())
    assert summary["models"]["c"]["status"] == "done"
    assert summary["models"]["a"]["status"] == "skipped"


def test_failures_recorded_and_retried(address, tmp_path):
    paths = make_models(tmp_path / "models", ["good1.obj", "bad.obj", "good2.obj"])
    out = tmp_path / "out"
    report = run_batch(funcs.fail_on_bad, paths, out, scheduler=address, progress=False)
    assert (report.n_done, report.n_skipped, report.n_failed) == (2, 0, 1)
    assert report.failures == {"bad": "ValueError: cannot handle bad.obj"}
    assert sorted(report.results) == ["good1", "good2"]
    err = json.loads((out / "results" / "bad.error.json").read_text())
    assert err["type"] == "ValueError" and err["message"] == "cannot handle bad.obj"
    assert "fail_on_bad" in err["traceback"] and err["input"] == str(paths[1])
    assert not (out / "results" / "bad.json").exists()

    # a rerun retries the failure only; once the function is fixed it succeeds
    again = run_batch(funcs.fail_on_bad, paths, out, scheduler=address, progress=False)
    assert (again.n_done, again.n_skipped, again.n_failed) == (0, 2, 1)
    assert [n_calls(p) for p in paths] == [1, 0, 1]
    third = run_batch(funcs.measure, paths, out, scheduler=address, progress=False)
    assert (third.n_done, third.n_skipped, third.n_failed) == (1, 2, 0)
    assert (out / "results" / "bad.json").exists()
    assert not (out / "results" / "bad.error.json").exists()


def test_contract_violation_recorded(address, tmp_path):
    paths = make_models(tmp_path / "models", ["x.obj"])
    report = run_batch(funcs.not_a_dict, paths, tmp_path / "out", scheduler=address, progress=False)
    assert report.failures == {"x": "TypeError: func must return a dict; got list"}


def test_seeds_independent_of_order_and_scheduling(address, tmp_path):
    names = [f"m{i:02d}.obj" for i in range(8)]
    paths = make_models(tmp_path / "models", names)
    shuffled = list(paths)
    random.Random(1).shuffle(shuffled)
    first = run_batch(
        funcs.measure, paths, tmp_path / "o1", scheduler=address, seed=11, progress=False
    )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        client = distributed.Client(address)
    try:
        second = run_batch(
            funcs.measure, shuffled, tmp_path / "o2", scheduler=client, seed=11, progress=True
        )
    finally:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            client.close()
    assert dict(first.results) == dict(second.results)
    for i, name in enumerate(sorted(names)):
        assert first.results[Path(name).stem]["draws"] == expected_draws(11, 8, i)
    other = run_batch(
        funcs.measure, paths, tmp_path / "o3", scheduler=address, seed=12, progress=False
    )
    assert other.results["m00"]["draws"] != first.results["m00"]["draws"]
    # every model ran once per batch, on the cluster's worker processes
    assert [n_calls(p) for p in paths] == [3] * 8


def test_worker_death_recorded(address, tmp_path):
    paths = make_models(tmp_path / "models", ["ok1.obj", "bad.obj", "ok2.obj"])
    report = run_batch(
        funcs.crash_on_bad, paths, tmp_path / "out", scheduler=address, progress=False
    )
    assert sorted(report.results) == ["ok1", "ok2"]
    assert list(report.failures) == ["bad"]
    assert report.failures["bad"].startswith("KilledWorker")
    err = json.loads((tmp_path / "out" / "results" / "bad.error.json").read_text())
    assert err["type"] == "KilledWorker"


def test_default_local_cluster_matches_scheduler_mode(address, tmp_path):
    paths = make_models(tmp_path / "models", ["p.obj", "q.obj", "r.obj"])
    local = run_batch(funcs.measure, paths, tmp_path / "local", n_workers=2, seed=5, progress=False)
    remote = run_batch(
        funcs.measure, paths, tmp_path / "remote", scheduler=address, seed=5, progress=False
    )
    assert local.n_done == 3
    assert dict(local.results) == dict(remote.results)
    summary = json.loads((tmp_path / "local" / "summary.json").read_text())
    assert summary["scheduler"] == "LocalCluster(n_workers=2)"


def test_nothing_to_do_starts_no_cluster(tmp_path):
    paths = make_models(tmp_path / "models", ["a.obj"])
    (tmp_path / "out" / "results").mkdir(parents=True)
    (tmp_path / "out" / "results" / "a.json").write_text('{"x": 1}')
    # an unreachable scheduler proves no connection is attempted
    report = run_batch(
        funcs.measure, paths, tmp_path / "out", scheduler="tcp://0.0.0.0:1", progress=False
    )
    assert (report.n_done, report.n_skipped) == (0, 1)
    assert report.results == {"a": {"x": 1}}
    assert n_calls(paths[0]) == 0


@pytest.mark.parametrize(
    ("kwargs", "error", "match"),
    [
        ({"func": 3}, TypeError, "func must be callable"),
        ({"inputs": "a.obj"}, TypeError, "single path"),
        ({"inputs": ["x/a.obj", "y/a.ply"]}, ValueError, "distinct file stems"),
        ({"n_workers": 0}, ValueError, "n_workers must be >= 1"),
        ({"seed": -1}, ValueError, "seed must be an integer >= 0"),
    ],
)
def test_bad_arguments(tmp_path, kwargs, error, match):
    args = {"func": funcs.measure, "inputs": [], "out_dir": tmp_path}
    args.update(kwargs)
    with pytest.raises(error, match=match):
        run_batch(args.pop("func"), args.pop("inputs"), args.pop("out_dir"), **args)


def test_list_models(tmp_path):
    make_models(tmp_path, ["b.obj", "a.PLY", "c.txt", "d.off", "e.stl"])
    (tmp_path / "sub").mkdir()
    make_models(tmp_path / "sub", ["f.obj"])
    assert [p.name for p in list_models(tmp_path)] == ["a.PLY", "b.obj", "d.off", "e.stl"]
    assert [p.name for p in list_models(tmp_path, patterns="*.obj")] == ["b.obj"]
    assert [p.name for p in list_models(tmp_path, recursive=True)][-1] == "f.obj"
    with pytest.raises(FileNotFoundError, match="directory not found"):
        list_models(tmp_path / "missing")
    with pytest.raises(NotADirectoryError):
        list_models(tmp_path / "b.obj")


def test_list_models_shared_collection():
    folder = Path(__file__).resolve().parents[2] / ".." / "shared" / "data" / "collection"
    if not folder.is_dir():
        pytest.skip(reason="shared test data not present")
    models = list_models(folder)
    assert len(models) == 149
    assert models == sorted(models)
