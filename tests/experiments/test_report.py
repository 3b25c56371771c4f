"""The tables of a study's report: JSON flattened by path, CSV cells parsed exactly."""

from __future__ import annotations

import json

from pointatlas.experiments import experiment_tables
from pointatlas.experiments._report import MAX_TABLE_ROWS


def test_json_is_flattened_by_path_and_keeps_every_number(tmp_path):
    doc = {
        "seed": 3,
        "mse": 0.1 + 0.2,  # not a short decimal: must survive exactly
        "config": {"k": 8, "grid": [0.0, 0.5]},
        "rows": [{"model": "a", "n": 1, "parts": [{"x": 1.5}]}, {"model": "b", "n": 2}],
        "columns": {"pcl": {"mse": {"avg": 0.5, "sd": 0.25}, "m": {"avg": 12, "sd": 1.5}}},
    }
    path = tmp_path / "summary.json"
    path.write_text(json.dumps(doc))
    tables = experiment_tables([path])
    assert tables == {
        "summary.json": {"seed": 3, "mse": 0.1 + 0.2},
        "summary.json / config": {"k": 8, "grid": [0.0, 0.5]},
        "summary.json / rows": [{"model": "a", "n": 1}, {"model": "b", "n": 2}],
        "summary.json / rows / 0 / parts": [{"x": 1.5}],
        "summary.json / columns / pcl": [
            {"key": "mse", "avg": 0.5, "sd": 0.25},
            {"key": "m", "avg": 12, "sd": 1.5},
        ],
    }
    # a top-level list of records (results.json of the simplify study)
    path.write_text(json.dumps([{"a": 1}, {"a": 2}]))
    assert experiment_tables([path]) == {"summary.json": [{"a": 1}, {"a": 2}]}


def test_csv_cells_become_int_float_or_text_and_long_files_are_left_out(tmp_path):
    small, big, other = tmp_path / "t.csv", tmp_path / "big.csv", tmp_path / "x.png"
    small.write_text("model,n,mse,note\ncube,1946,0.30000000000000004,\nfan,7,nan,ok\n")
    big.write_text("v\n" + "".join(f"{i}\n" for i in range(MAX_TABLE_ROWS + 1)))
    other.write_bytes(b"not a table")
    tables = experiment_tables([small, big, other])
    assert list(tables) == ["t.csv"]
    rows = tables["t.csv"]
    assert rows[0] == {"model": "cube", "n": 1946, "mse": 0.1 + 0.2, "note": ""}
    assert rows[1]["note"] == "ok" and rows[1]["mse"] != rows[1]["mse"]  # NaN
    assert isinstance(rows[0]["n"], int)
