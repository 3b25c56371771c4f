"""Output helpers shared by the studies: PNG figures and CSV text, written atomically."""

from __future__ import annotations

import csv
import io
from pathlib import Path

__all__ = ["csv_records", "csv_rows", "save_figure"]


def save_figure(fig, path: Path, *, dpi: int = 120) -> Path:
    """Write a matplotlib ``Figure`` (Agg, no pyplot) as PNG atomically; returns ``path``."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    from ..io import atomic_write

    FigureCanvasAgg(fig)
    with atomic_write(path, "wb") as fh:
        fig.savefig(fh, format="png", dpi=dpi, bbox_inches="tight")
    return path


def csv_rows(rows: list[list]) -> str:
    """CSV text of a list of rows (``\\n`` line ends)."""
    buf = io.StringIO()
    csv.writer(buf, lineterminator="\n").writerows(rows)
    return buf.getvalue()


def csv_records(records: list[dict], fieldnames=None) -> str:
    """CSV text of a list of dicts with a header (the first record's keys by default)."""
    buf = io.StringIO()
    writer = csv.DictWriter(buf, fieldnames=list(fieldnames or records[0]), lineterminator="\n")
    writer.writeheader()
    writer.writerows(records)
    return buf.getvalue()
