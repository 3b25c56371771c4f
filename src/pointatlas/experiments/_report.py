"""The HTML report of a study (``pointatlas experiment ... --report``): the tables and
pictures the study wrote, in one self-contained page."""

from __future__ import annotations

import csv
import json
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

__all__ = ["MAX_TABLE_ROWS", "experiment_tables", "write_experiment_report"]

#: CSV files with more rows are listed (name and size), not shown as tables.
MAX_TABLE_ROWS = 500


def _value(text: str):
    """A CSV cell as int, float or text (empty cells stay empty text)."""
    for kind in (int, float):
        try:
            return kind(text)
        except ValueError:
            continue
    return text


def _csv_table(path: Path) -> list[dict] | None:
    """Rows of a CSV file with a header, numbers parsed; None above `MAX_TABLE_ROWS`."""
    with open(path, newline="") as fh:
        rows = list(csv.reader(fh))
    if not rows or len(rows) - 1 > MAX_TABLE_ROWS:
        return None
    header = rows[0]
    return [
        {name: _value(cell) for name, cell in zip(header, row, strict=False)} for row in rows[1:]
    ]


def _is_nested(value) -> bool:
    return isinstance(value, Mapping) or (
        isinstance(value, list) and bool(value) and all(isinstance(v, Mapping) for v in value)
    )


def _json_tables(name: str, value, tables: dict) -> None:
    """Flatten a JSON document: a mapping's plain values make one table, a mapping of
    flat records one grid (a row per key, its key in column ``key``), a list of records
    one table of their plain values; nested mappings and lists of records get their own
    tables, named by their path (``name / key``, ``name / row / key``)."""
    if (
        isinstance(value, Mapping)
        and value
        and all(
            isinstance(v, Mapping) and v and not any(_is_nested(x) for x in v.values())
            for v in value.values()
        )
    ):  # a mapping of flat records: one grid, a row per key
        tables[name] = [
            {"key": str(k), **{str(c): x for c, x in v.items()}} for k, v in value.items()
        ]
    elif isinstance(value, Mapping):
        plain = {str(k): v for k, v in value.items() if not _is_nested(v)}
        if plain:
            tables[name] = plain
        for key, sub in value.items():
            if _is_nested(sub):
                _json_tables(f"{name} / {key}", sub, tables)
    elif isinstance(value, list) and value and all(isinstance(v, Mapping) for v in value):
        tables[name] = [{str(k): v for k, v in row.items() if not _is_nested(v)} for row in value]
        for i, row in enumerate(value):
            for key, sub in row.items():
                if _is_nested(sub):
                    _json_tables(f"{name} / {i} / {key}", sub, tables)
    else:
        tables[name] = {"value": value}


def experiment_tables(files: Sequence[Path]) -> dict[str, Any]:
    """The tables of a study's output files: every JSON document (flattened) and every
    CSV file of at most `MAX_TABLE_ROWS` rows, named by file name, in file order.

    Parameters
    ----------
    files : sequence of pathlib.Path
        The files the study wrote; other kinds are skipped.

    Returns
    -------
    tables : dict
        Name to a mapping (one row per key) or a list of row mappings, as
        `pointatlas.viz.write_report` takes them. Numbers keep their exact values
        (JSON floats as written; CSV cells parsed as int, else float).

    Examples
    --------
    >>> import pathlib, tempfile
    >>> folder = pathlib.Path(tempfile.mkdtemp())
    >>> _ = (folder / "s.json").write_text('{"n": 3, "rows": [{"a": 0.5}]}')
    >>> experiment_tables([folder / "s.json"])
    {'s.json': {'n': 3}, 's.json / rows': [{'a': 0.5}]}
    """
    tables: dict[str, Any] = {}
    for path in files:
        suffix = path.suffix.lower()
        if suffix == ".json":
            _json_tables(path.name, json.loads(path.read_text()), tables)
        elif suffix == ".csv":
            rows = _csv_table(path)
            if rows:
                tables[path.name] = rows
    return tables


def write_experiment_report(
    path,
    *,
    study: str,
    out: Path,
    files: Sequence[Path],
    summary: Mapping[str, Any],
    parameters: Mapping[str, Any],
    seed: int = 0,
) -> Path:
    """Write the HTML report of a study: its tables, its pictures and its files.

    Parameters
    ----------
    path : str or os.PathLike
        The ``.html`` file to write (atomically).
    study : str
        The study's name (the ``experiment`` subcommand), in the title.
    out : pathlib.Path
        The study's output folder.
    files : sequence of pathlib.Path
        The files the study wrote, in order: PNGs are embedded, JSON and CSV shown
        as tables (`experiment_tables`), every file listed with its size.
    summary : mapping
        The inputs (models, cases, ...) as a two-column table.
    parameters : mapping
        The options of the run; ``seed`` is added.
    seed : int
        The run's seed.

    Returns
    -------
    path : pathlib.Path
        The file written.

    Notes
    -----
    The page is self-contained (`pointatlas.viz.write_report`); the studies' own
    figures are the thesis' (their captions cite its tables and figures).
    """
    from ..viz import write_report

    files = [Path(f) for f in files]
    tables = experiment_tables(files)
    tables["files"] = [
        {"file": f.name if f.parent == out else str(f), "bytes": f.stat().st_size}
        for f in files
        if f.exists()
    ]
    return write_report(
        path,
        title=f"pointatlas experiment {study}",
        summary={"output folder": str(out), **summary},
        parameters=parameters,
        tables=tables,
        pictures=[f for f in files if f.suffix.lower() == ".png"],
        seed=seed,
    )
