"""The benchmark scripts' command lines: every ``--help`` prints (argparse expands each
argument's help with ``%``, so a bare percent sign in one made ``--help`` raise)."""

from __future__ import annotations

import argparse
import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _help_strings():
    """(script, help text) of every ``add_argument(..., help="...")`` in benchmarks/."""
    for path in sorted((ROOT / "benchmarks").glob("*.py")):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Call) and getattr(node.func, "attr", "") == "add_argument":
                for kw in node.keywords:
                    if kw.arg == "help" and isinstance(kw.value, ast.Constant):
                        yield path.name, kw.value.value


def _formats(text):
    """Whether a parser with one argument of this help text prints its ``--help``."""
    parser = argparse.ArgumentParser(prog="bench")
    parser.add_argument("--x", help=text)
    try:
        parser.format_help()
    except (TypeError, ValueError, KeyError):
        return False
    return True


def test_every_benchmark_help_text_expands_as_argparse_does():
    texts = list(_help_strings())
    assert len(texts) > 20
    assert [f"{script}: {text!r}" for script, text in texts if not _formats(text)] == []


def test_a_bare_percent_sign_in_a_help_text_is_caught():
    assert not _formats("sigma in % of the diagonal")
    assert _formats("sigma in %% of the diagonal (default: %(default)s)")
