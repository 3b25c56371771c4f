"""Every command's ``--help`` reads at any terminal width: the description's
paragraphs are wrapped to the terminal (`_typed.reflowed`), not broken again at the
docstring's own line ends."""

from __future__ import annotations

import itertools
import re

import pytest
from typer.main import get_command
from typer.testing import CliRunner

from pointatlas.cli import app
from pointatlas.cli._typed import reflowed

runner = CliRunner()


def _commands(group, path=()):
    """``(words, command)`` of every command under ``group``."""
    for name, command in group.commands.items():
        if hasattr(command, "commands"):
            yield from _commands(command, (*path, name))
        else:
            yield (*path, name), command


COMMANDS = sorted(words for words, _ in _commands(get_command(app)))


def _description(output: str) -> list[str]:
    """The help's lines after the usage line, up to the first panel (colour codes
    left out: typer colours its help where FORCE_COLOR or GITHUB_ACTIONS is set)."""
    lines = re.sub(r"\x1b\[[0-9;]*m", "", output).splitlines()
    start = next(i for i, line in enumerate(lines) if "Usage:" in line) + 1
    end = next(i for i, line in enumerate(lines) if line.lstrip().startswith("╭"))
    return [line.rstrip() for line in lines[start:end]]


@pytest.mark.parametrize("words", COMMANDS, ids=" ".join)
@pytest.mark.parametrize("width", [60, 100])
def test_help_paragraphs_fill_the_terminal(words, width):
    res = runner.invoke(app, [*words, "--help"], env={"COLUMNS": str(width)})
    assert res.exit_code == 0, res.output
    text = _description(res.output)
    for line, after in itertools.pairwise(text):
        assert len(line) <= width
        if line.strip() and after.strip():  # broken inside a paragraph: the next word did not fit
            assert len(line) + 1 + len(after.split()[0]) > width - 2, (line, after)


def test_help_keeps_every_word_of_the_docstring():
    command = dict(_commands(get_command(app)))[("simplify",)]
    res = runner.invoke(app, ["simplify", "--help"], env={"COLUMNS": "60"})
    shown = " ".join(" ".join(_description(res.output)).split())
    assert reflowed(command.help).replace("\n\n", " ") in shown
    assert "``" not in res.output


def test_reflowed_joins_lines_and_keeps_paragraphs():
    text = "First line\n    of the summary.\n\n    A ``--flag``\n    and ``a b``.\n\f\n    hidden"
    assert reflowed(text) == "First line of the summary.\n\nA --flag and 'a b'."
