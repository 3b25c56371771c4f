"""Batch runs over model collections on dask (resumable, seeded per model; layer 5)."""

from ._runner import BatchReport, list_models, run_batch, to_jsonable

__all__ = ["BatchReport", "list_models", "run_batch", "to_jsonable"]
