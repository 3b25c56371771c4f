"""The one JSON rule (`pointatlas.io.to_json_safe`, `write_json`, `json_text`).

It replaced three sanitisers with different NaN rules: the batch runner's
``to_jsonable`` (NaN kept, written as ``NaN``), the summaries' ``_finite`` and the
region tables' ``_json_safe`` (NaN -> null), and the HTML report's ``_plain`` (NaN ->
null, but NaN in a numpy float kept). The cases each handled are checked here;
docs/decisions/io.md says which outputs changed.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from pointatlas.io import json_text, to_json_safe, write_json, write_summary_json

NON_FINITE = [float("nan"), float("inf"), -math.inf, np.float64("nan"), np.float32("-inf")]


@pytest.mark.parametrize("value", NON_FINITE, ids=repr)
def test_nan_and_infinities_are_null(value):
    assert to_json_safe(value) is None
    assert to_json_safe({"x": [value, 1.5]}) == {"x": [None, 1.5]}
    assert to_json_safe(np.array([value, 2.0])) == [None, 2.0]


def test_the_batch_runners_cases():
    # numpy arrays of every stored kind, numpy keys, sets, paths; other types refused
    value = {
        "a": np.arange(3, dtype=np.int16),
        np.int64(2): np.float64(0.25),
        "s": {3, 1},
        "f": frozenset({"b", "a"}),
        "p": Path("x/y"),
        "t": (1, (2, 3)),
        "u": np.array(["a", "b"]),
        "b": np.array([True, False]),
        "m": np.arange(4.0).reshape(2, 2),
    }
    plain = to_json_safe(value)
    assert plain == {
        "a": [0, 1, 2],
        "2": 0.25,
        "s": [1, 3],
        "f": ["a", "b"],
        "p": "x/y",
        "t": [1, [2, 3]],
        "u": ["a", "b"],
        "b": [True, False],
        "m": [[0.0, 1.0], [2.0, 3.0]],
    }
    assert type(plain["a"][0]) is int and type(plain["b"][0]) is bool
    json.dumps(plain, allow_nan=False)
    with pytest.raises(TypeError, match=r"result\['k'\]: cannot store object"):
        to_json_safe({"k": object()})
    with pytest.raises(TypeError, match="dtype complex128"):
        to_json_safe({"z": np.array([1j])})


def test_the_summaries_and_tables_cases():
    # numpy scalars -> Python numbers, tuples -> lists, keys -> str, non-finite -> null
    value = {
        1: np.int32(4),
        "x": np.float32(0.5),
        "ok": np.bool_(True),
        "nested": {"d": (np.float64(np.nan), np.int64(-1))},
        "none": None,
        "s": "text",
    }
    plain = to_json_safe(value)
    assert plain == {
        "1": 4,
        "x": 0.5,
        "ok": True,
        "nested": {"d": [None, -1]},
        "none": None,
        "s": "text",
    }
    assert type(plain["1"]) is int and type(plain["x"]) is float and type(plain["ok"]) is bool
    assert to_json_safe(np.array(2.5)) == 2.5  # a 0-d array is its scalar


def test_the_report_cells_cases():
    # the HTML report writes other objects as their text (default=str)
    class Thing:
        def __str__(self):
            return "thing"

    plain = to_json_safe({"t": Thing(), "v": [np.float64("nan"), 2]}, default=str)
    assert plain == {"t": "thing", "v": [None, 2]}


def test_write_json_is_strict_atomic_and_ends_with_a_newline(tmp_path):
    path = write_json(tmp_path / "a.json", {"d": np.float64("inf"), "n": np.int64(3)}, indent=2)
    assert path == tmp_path / "a.json"
    text = path.read_text()
    assert text == '{\n  "d": null,\n  "n": 3\n}\n'
    assert json.loads(text) == {"d": None, "n": 3}
    with pytest.raises(TypeError):
        write_json(tmp_path / "b.json", {"k": object()})
    assert not (tmp_path / "b.json").exists()
    assert json_text([math.nan], indent=None) == "[null]"


def test_write_summary_json_follows_the_rule(tmp_path):
    (tmp_path / "f.txt").write_text("x")
    path = write_summary_json(
        tmp_path / "s.json", {"e": np.float32("nan"), "k": np.arange(2)}, [tmp_path / "f.txt"]
    )
    body = json.loads(path.read_text())
    assert body["e"] is None and body["k"] == [0, 1] and body["files"][0]["path"] == "f.txt"


def test_to_jsonable_is_a_deprecated_alias_with_the_one_rule():
    from pointatlas import batch

    with pytest.warns(DeprecationWarning, match=r"to_jsonable is deprecated; use .*to_json_safe"):
        plain = batch.to_jsonable({"a": np.float64("nan"), "b": np.arange(2)})
    assert plain == {"a": None, "b": [0, 1]}  # NaN was kept (written as NaN) before
