"""One source for each figure: the README's results quote the docs that hold the commands.

The README's "Results" section has two tables. Every figure of the first (our
measurements against peers) must occur, as written, in ``docs/benchmarks.md``; every
figure of the second (the thesis' own numbers beside ours) in ``docs/reproduction.md``.
A figure is a number as written, with its range and unit when it has them: ``0.90 %``,
``48.1 s``, ``196,400``, ``1.38-1.49x``, ``10^7``. Thesis references (``Eq. 5.9``,
``Fig. 4.1``, ``Table 4.1``) name a place, not a figure, and are left out. Bold markers
(``**``) in the source do not count.
"""

import pathlib
import re

REPO = pathlib.Path(__file__).resolve().parent.parent
README = REPO / "README.md"
BENCHMARKS = REPO / "docs" / "benchmarks.md"
REPRODUCTION = REPO / "docs" / "reproduction.md"

_NUMBER = r"\d+(?:,\d{3})*(?:\.\d+)?"
_FIGURE = re.compile(
    rf"10\^\d+|{_NUMBER}(?:[-–]{_NUMBER})?(?: ?%| (?:s|ms|GiB|MiB)\b|x\b)?",
)
_REFERENCE = re.compile(r"(?:Eq\.|Eqs\.|Fig\.|Figs|Table|Tables) $")


def figures(text: str) -> list[str]:
    """The figures of ``text``, in order, without the thesis references."""
    return [
        m.group()
        for m in _FIGURE.finditer(text)
        if not _REFERENCE.search(text[max(0, m.start() - 7) : m.start()])
    ]


def occurs(figure: str, source: str) -> bool:
    """Whether ``figure`` stands in ``source`` as a whole figure (not inside a longer one)."""
    pattern = rf"(?<![\d.,^])(?<!\d[-–]){re.escape(figure)}(?!\d|[.,–-]\d)"
    if figure[-1].isalpha():
        pattern += r"\b"
    return re.search(pattern, source.replace("**", "")) is not None


def results_tables(text: str) -> list[list[str]]:
    """The tables of the README's "Results" section, each as its list of rows."""
    section = text.split("\n## Results\n", 1)[1].split("\n## ", 1)[0]
    tables, rows = [], []
    for line in section.splitlines() + [""]:
        if line.startswith("|"):
            if not set(line) <= set("|-: "):
                rows.append(line)
        elif rows:
            tables.append(rows)
            rows = []
    return tables


def missing(rows: list[str], source: str) -> list[tuple[str, str]]:
    return [
        (figure, row[:60]) for row in rows for figure in figures(row) if not occurs(figure, source)
    ]


def test_figures_are_read_as_written():
    row = "| k = 20, Eq. 5.9 | 0.90 %, 48.1 s, 196,400, 1.38-1.49x, 28 x 15, 10^7-point |"
    assert figures("2.1–2.3 s") == ["2.1–2.3 s"]
    assert figures(row) == ["20", "0.90 %", "48.1 s", "196,400", "1.38-1.49x", "28", "15", "10^7"]
    assert occurs("0.90 %", "median **0.90 %**, max")
    assert not occurs("0.9 %", "median 0.90 %")
    assert not occurs("96,400", "196,400 points")
    assert not occurs("1.5", "1.5-2.75x")
    assert not occurs("2.75x", "1.5-2.75x")
    assert not occurs("8x", "8 x 15")


def test_the_readme_has_its_two_results_tables():
    tables = results_tables(README.read_text())
    assert len(tables) == 2
    assert all(len(rows) > 2 for rows in tables)


def test_every_figure_of_the_results_table_is_in_benchmarks_md():
    results = results_tables(README.read_text())[0]
    assert missing(results, BENCHMARKS.read_text()) == []


def test_every_thesis_figure_of_the_results_is_in_reproduction_md():
    thesis = results_tables(README.read_text())[1]
    assert missing(thesis, REPRODUCTION.read_text()) == []
