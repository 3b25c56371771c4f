"""Shared test settings: hypothesis draws the same examples on every run (a CI run must
not fail on a draw the last one did not make; a case a draw found becomes its own
test, e.g. tests/io/test_errors.py)."""

from __future__ import annotations

from hypothesis import settings

settings.register_profile("pointatlas", derandomize=True)
settings.load_profile("pointatlas")
