"""The temporary folder of a tiled run on files: spilled tiles and result arrays.

Named with the process id, as `pointatlas.io.atomic_write` names its temporary
files, so that a later run can tell the folders of killed runs (SIGKILL, power
loss) from those of runs still going, and remove the former.
"""

from __future__ import annotations

import shutil
import tempfile
from pathlib import Path

from .._core import interrupts_deferred
from ..io import remove_stale_temp_files, temp_prefix

__all__ = ["TMP_NAME", "clean_tmp", "make_tmp"]

#: Temporary folders of tiled runs are the temporary files of this name in their folder
#: (`pointatlas.io.atomic_write`'s naming: ``.pointatlas-tiles.pa<pid>.<random>.tmp``).
TMP_NAME = "pointatlas-tiles"


def clean_tmp(folder: Path) -> None:
    """Remove a run's temporary folder (a signal meanwhile acts once it is gone)."""
    with interrupts_deferred():
        shutil.rmtree(folder, ignore_errors=True)


def make_tmp(options, near: Path) -> Path:
    """A fresh temporary folder for spilled tiles and result arrays, named with this
    process's id; the folders that runs killed earlier (SIGKILL, power loss) left in
    the same place are removed first (`pointatlas.io.remove_stale_temp_files`).
    ``options``: a `TileOptions` (its ``tmp_dir``, or beside ``near``)."""
    base = Path(options.tmp_dir) if options.tmp_dir is not None else Path(near).parent
    remove_stale_temp_files(base / TMP_NAME)
    return Path(tempfile.mkdtemp(prefix=temp_prefix(base / TMP_NAME), suffix=".tmp", dir=base))
