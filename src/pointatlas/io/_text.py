"""Text outputs: a text file and a JSON summary naming the files of a set, atomically."""

from __future__ import annotations

import hashlib
import json
import math
import os
from collections.abc import Sequence
from pathlib import Path

from ._atomic import atomic_write

__all__ = ["file_record", "write_summary_json", "write_text"]


def write_text(path, text: str) -> Path:
    """Write a text file atomically (umask permissions, ``\\n`` line ends).

    Parameters
    ----------
    path : str or os.PathLike
        Destination file; its folder must exist.
    text : str
        The whole content.

    Returns
    -------
    path : pathlib.Path
        ``path``.

    Examples
    --------
    >>> import tempfile
    >>> from pathlib import Path
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     write_text(Path(tmp) / "a.txt", "one\\n").read_text()
    'one\\n'
    """
    with atomic_write(path, "w", newline="\n") as fh:
        fh.write(text)
    return Path(path)


def file_record(path, relative_to) -> dict:
    """Name (relative to ``relative_to`` when possible), size and SHA-256 of a file.

    Parameters
    ----------
    path : str or os.PathLike
        An existing file.
    relative_to : str or os.PathLike
        The folder the name is given relative to.

    Returns
    -------
    record : dict
        ``{"path": str, "bytes": int, "sha256": str}``.
    """
    path = Path(path)
    digest = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            digest.update(block)
    try:
        name = os.path.relpath(path, relative_to)
    except ValueError:  # another drive (Windows)
        name = str(path)
    return {"path": name, "bytes": path.stat().st_size, "sha256": digest.hexdigest()}


def _finite(value):
    """JSON-ready copy: NaN/Inf become None, numpy scalars plain numbers, tuples lists."""
    if isinstance(value, dict):
        return {str(k): _finite(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_finite(v) for v in value]
    if hasattr(value, "item") and not isinstance(value, str | bytes):
        value = value.item()
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def write_summary_json(path, payload: dict, written: Sequence) -> Path:
    """Write a JSON summary last, naming the files of the set it completes.

    Parameters
    ----------
    path : str or os.PathLike
        The summary file.
    payload : dict
        The summary; non-finite numbers are written as null.
    written : sequence of path
        The files of the set; each gets a record (path relative to the summary,
        bytes, sha256) in the summary's ``"files"`` list, so a reader that finds the
        summary and matching files knows the set is complete and from one run.

    Returns
    -------
    path : pathlib.Path
        ``path``.
    """
    path = Path(path)
    folder = path.parent if str(path.parent) else Path(".")
    body = _finite(dict(payload))
    body["files"] = [file_record(p, folder) for p in written]
    text = json.dumps(body, indent=1, allow_nan=False)
    with atomic_write(path, "w") as fh:
        fh.write(text)
        fh.write("\n")
    return path
