"""The one JSON rule of pointatlas: plain JSON types, NaN and infinities as null.

Every JSON file the library and the CLI write (summaries, per-region tables, batch
results, experiment outputs, the data of HTML reports) goes through `to_json_safe`,
and files through `write_json` (docs/decisions/io.md, "One JSON rule").
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Callable, Mapping
from pathlib import Path

import numpy as np

from ._atomic import atomic_write

__all__ = ["json_text", "to_json_safe", "write_json"]

#: numpy array kinds stored as (nested) lists: bool, integers, floats, strings, objects
_ARRAY_KINDS = "biufUO"


def to_json_safe(value, *, default: Callable | None = None):
    """Convert a result into plain JSON types by the one rule of pointatlas.

    Parameters
    ----------
    value : object
        Dicts (any mapping), lists, tuples, sets, numbers, strings, None, numpy
        scalars and arrays, paths.
    default : callable, optional
        Called on a value of any other type; its return value is converted in turn.
        None (default) raises `TypeError` for such a value.

    Returns
    -------
    plain : object
        The same structure in JSON types: NaN and +-infinity -> None (JSON ``null``);
        numpy scalars -> Python numbers (``np.bool_`` -> bool); numpy arrays -> nested
        lists (a 0-d array -> its scalar); tuples -> lists; sets -> lists sorted by
        ``repr``; paths -> str; mapping keys -> ``str(key)`` (numpy scalars first as
        Python numbers).

    Raises
    ------
    TypeError
        A value of another type without ``default``, or an array of another dtype
        (complex, datetime); the message names its position (``result['a'][2]``).

    Notes
    -----
    One rule for every JSON output: a JSON reader of any language reads ``null``,
    while ``NaN`` / ``Infinity`` are not JSON (Python's reader takes them, most others
    refuse them). A number that was not finite reads back as None.

    Examples
    --------
    >>> to_json_safe({"a": np.arange(2), 3: np.float32(0.5), "p": (1, float("nan"))})
    {'a': [0, 1], '3': 0.5, 'p': [1, None]}
    >>> to_json_safe([np.inf, np.bool_(True), {2, 1}])
    [None, True, [1, 2]]
    """
    return _plain(value, "result", default)


def _plain(value, where: str, default):
    if value is None or isinstance(value, bool | str):
        return value
    if isinstance(value, float | np.floating):
        value = float(value)
        return value if math.isfinite(value) else None
    if isinstance(value, int):
        return int(value)
    if isinstance(value, np.generic):
        return _plain(value.item(), where, default)
    if isinstance(value, np.ndarray):
        if value.dtype.kind not in _ARRAY_KINDS:
            raise TypeError(f"{where}: cannot store an array of dtype {value.dtype} as JSON")
        if value.ndim == 0:
            return _plain(value.item(), where, default)
        return [_plain(v, f"{where}[{i}]", default) for i, v in enumerate(value.tolist())]
    if isinstance(value, Mapping):
        return {
            str(k.item() if isinstance(k, np.generic) else k): _plain(v, f"{where}[{k!r}]", default)
            for k, v in value.items()
        }
    if isinstance(value, list | tuple | set | frozenset):
        items = sorted(value, key=repr) if isinstance(value, set | frozenset) else value
        return [_plain(v, f"{where}[{i}]", default) for i, v in enumerate(items)]
    if isinstance(value, os.PathLike):
        return os.fspath(value)
    if default is not None:
        return _plain(default(value), where, None)
    raise TypeError(f"{where}: cannot store {type(value).__name__} as JSON")


def json_text(value, *, indent: int | None = 1) -> str:
    """The JSON text of ``to_json_safe(value)`` (strict JSON: no NaN, no Infinity).

    Parameters
    ----------
    value : object
        What `to_json_safe` takes.
    indent : int or None
        Indentation of nested values; None writes one line.

    Returns
    -------
    text : str
        The JSON text, without a final newline.

    Examples
    --------
    >>> json_text({"spacing": float("nan"), "n": np.int64(3)}, indent=None)
    '{"spacing": null, "n": 3}'
    """
    return json.dumps(to_json_safe(value), indent=indent, allow_nan=False)


def write_json(path, value, *, indent: int | None = 1) -> Path:
    """Write ``value`` as a JSON file atomically, by the rule of `to_json_safe`.

    Parameters
    ----------
    path : str or os.PathLike
        Destination file; its folder must exist.
    value : object
        What `to_json_safe` takes.
    indent : int or None
        Indentation of nested values; None writes one line.

    Returns
    -------
    path : pathlib.Path
        ``path``.

    Raises
    ------
    TypeError
        A value `to_json_safe` cannot convert (nothing is written).

    Examples
    --------
    >>> import tempfile
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     write_json(Path(tmp) / "a.json", {"d": np.float64("inf")}).read_text()
    '{\\n "d": null\\n}\\n'
    """
    text = json_text(value, indent=indent)
    with atomic_write(path, "w", newline="\n") as fh:
        fh.write(text)
        fh.write("\n")
    return Path(path)
