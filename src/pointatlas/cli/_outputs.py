"""Output paths of a command: checked before any work, written as a complete set.

One rule for every command (docs/decisions/cli.md, "Outputs"):

- an output file needs a supported extension and a folder that exists and is
  writable; an output folder (``demo --out DIR``, ``cloudsurface IN OUT_DIR``) is
  created when missing, but its parent must exist and be writable;
- an output file as typed does not end in ``/``, no name in a path is longer than
  the file system allows, and an existing output is a regular file its owner has
  not made read-only (it is not replaced, as ``cp`` without ``-f``);
- an output that is a symbolic link is written through: the file it leads to is
  the output (its folder must be writable), the link stays;
- no output is an input (same path, symlink or hard link) and no two outputs of a
  command are the same file;
- temporary files left by a killed earlier run of the same output are removed;
- a command that writes several files writes its JSON summary last, naming each
  file with its size and SHA-256, so a reader can tell a complete set.

All checks run before the input is read, so a bad output path costs nothing.
"""

from __future__ import annotations

import os
from collections.abc import Iterable, Sequence
from pathlib import Path

from .._core import PointAtlasError
from ..io import (
    file_record,
    name_problem,
    output_problem,
    output_target,
    remove_stale_temp_files,
    write_summary_json,
    write_text,
)
from ._typed import typed_spellings

__all__ = [
    "OutputFile",
    "check_outputs",
    "check_point_output",
    "file_record",
    "point_fields",
    "write_point_output",
    "write_summary_json",
    "write_text",
]

#: (what, path or None, allowed extensions or None for any)
OutputFile = tuple[str, "Path | str | None", "Sequence[str] | None"]


def _same_file(a: Path, b: Path) -> bool:
    try:
        if a.exists() and b.exists():
            return os.path.samefile(a, b)
    except OSError:
        pass
    return a.resolve() == b.resolve()


def _check_folder_writable(folder: Path, what: str) -> None:
    if not folder.is_dir():
        raise PointAtlasError(f"{what}: folder does not exist: {str(folder)!r}")
    if not os.access(folder, os.W_OK | os.X_OK):
        raise PointAtlasError(f"{what}: folder is not writable: {str(folder)!r}")


def _check_output_file(what: str, p: Path, extensions) -> None:
    """One output file: its path as typed, its extension, what it is, its folder."""
    for typed in typed_spellings(p) or [str(p)]:
        problem = output_problem(typed)
        if problem is not None:
            raise PointAtlasError(f"{what} {typed!r}: {problem}")
    if extensions is not None and p.suffix.lower() not in extensions:
        raise PointAtlasError(f"{what} must end in one of {', '.join(extensions)}; got {str(p)!r}")
    target = output_target(p)
    _check_folder_writable(target.parent if str(target.parent) else Path("."), what)


def check_outputs(
    inputs: Iterable,
    files: Sequence[OutputFile] = (),
    folders: Sequence[tuple[str, Path | str | None]] = (),
) -> list[Path]:
    """Check every output location of a command before it does any work.

    Parameters
    ----------
    inputs : iterable of str or os.PathLike
        The command's inputs; names that are not existing files (a bundled model)
        are ignored.
    files : sequence of (what, path, extensions)
        Output files; ``what`` names the argument in messages (``"OUT"``,
        ``"--render"``); ``path`` None is skipped; ``extensions`` (lower case, with
        the dot) or None for any.
    folders : sequence of (what, path)
        Output folders, created later when missing.

    Returns
    -------
    paths : list of pathlib.Path
        The output files (not the folders), in order, None entries left out.

    Raises
    ------
    PointAtlasError
        Unsupported extension, missing or read-only folder, an output typed with a
        trailing ``/``, a name too long for the file system, an output that is a
        folder, not a regular file or a read-only file, an output that is an input,
        or two outputs that are the same file.
    """
    in_paths = [Path(os.fspath(p)) for p in inputs if p is not None]
    in_paths = [p for p in in_paths if p.exists()]
    checked: list[tuple[str, Path]] = []
    for what, path, extensions in files:
        if path is None:
            continue
        p = Path(os.fspath(path))
        _check_output_file(what, p, extensions)
        checked.append((what, p))
    for what, folder in folders:
        if folder is None:
            continue
        f = Path(os.fspath(folder))
        problem = name_problem(f)
        if problem is not None:
            raise PointAtlasError(f"{what} {str(f)!r}: {problem}")
        if f.exists():
            if not f.is_dir():
                raise PointAtlasError(f"{what} exists and is not a folder: {str(f)!r}")
            _check_folder_writable(f, what)
        else:
            _check_folder_writable(f.parent if str(f.parent) else Path("."), what)
    for what, p in checked:
        for src in in_paths:
            if _same_file(p, src):
                raise PointAtlasError(
                    f"{what} {str(p)!r} is the input file; write to another file "
                    "(inputs are never overwritten)"
                )
    for i, (what_i, p_i) in enumerate(checked):
        for what_j, p_j in checked[i + 1 :]:
            if _same_file(p_i, p_j):
                raise PointAtlasError(
                    f"{what_i} and {what_j} are the same file {str(p_i)!r}; give different paths"
                )
    for _, p in checked:
        remove_stale_temp_files(p)
    return [p for _, p in checked]


#: Point formats that store only coordinates and normals.
XYZ_EXTENSIONS = (".xyz", ".txt")


def point_fields(ps, ours: dict) -> dict:
    """Our new per-point fields, renamed where they would replace an input field.

    Every attribute of ``ps`` is kept as it is; a field of ``ours`` whose name the
    input already uses gets the prefix of :func:`pointatlas.io.merge_attributes`.
    Our ``colors`` are written as the file's colours when the input has none.
    """
    from ..io import merge_attributes

    base = dict(ps.attributes)
    ours = dict(ours)
    colors = ours.pop("colors", None) if "colors" not in base else None
    merged = merge_attributes(base, ours)
    fields = {k: v for k, v in merged.items() if k not in base}
    if colors is not None:
        fields["colors"] = colors
    return fields


def check_point_output(path: Path, ps, ours: dict) -> None:
    """Fail before computing when ``path`` cannot hold the input's and our fields.

    ``ours`` may hold placeholder arrays of the right shape and dtype. XYZ/TXT keeps
    only coordinates and normals, so with any field to keep it is refused.
    """
    from ..io import check_point_set_writable

    fields = point_fields(ps, ours)
    if Path(path).suffix.lower() in XYZ_EXTENSIONS and (ps.attributes or fields):
        names = ", ".join([*sorted(ps.attributes), *fields])
        raise PointAtlasError(
            f"OUT {str(path)!r}: XYZ keeps only coordinates and normals; the fields "
            f"{names} would be lost; write .ply, .las or .laz"
        )
    check_point_set_writable(path, ps, attributes=fields)


def write_point_output(path: Path, ps, ours: dict) -> Path:
    """Write ``ps`` (its normals and every attribute) with our fields added."""
    from ..io import write_point_set

    return write_point_set(path, ps, attributes=point_fields(ps, ours))
