"""The API reference's rules, checked without building it (docs/decisions/docs.md).

``make docs`` (CI) fails on the same docstring problems; these tests say so at once,
in ``make test``, without the docs extra.
"""

from __future__ import annotations

import importlib.util
import pathlib
import re

REPO = pathlib.Path(__file__).resolve().parent.parent
_spec = importlib.util.spec_from_file_location("docs_api", REPO / "tools" / "docs_api.py")
docs_api = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(docs_api)


def test_every_public_function_has_a_numpydoc_docstring():
    # every public function: a docstring with a section; every public class, and each
    # public method or property it defines: a docstring
    assert docs_api.docstring_problems() == []


def test_a_section_is_a_title_over_dashes():
    assert docs_api.SECTION.search("Sum.\n\nParameters\n----------\nx : int\n")
    assert docs_api.SECTION.search("Sum.\n\nReturns\n-------\nint\n")
    assert not docs_api.SECTION.search("Sum of ``x`` and ``y`` (Parameters: none).")


def test_every_room_and_decision_is_a_page_of_the_reference():
    nav = (REPO / "mkdocs.yml").read_text()
    pages = set(re.findall(r"^\s*- (?:[^:\n]+: )?(\S+\.md)$", nav, flags=re.M))
    rooms = {f"api/{room}.md" for room in docs_api.rooms()} | {"api/index.md"}
    decisions = {f"decisions/{p.name}" for p in (REPO / "docs" / "decisions").glob("*.md")}
    others = {"index.md", "CONTRIBUTING.md", "decisions.md", "benchmarks.md", "reproduction.md"}
    assert rooms | decisions | others <= pages
    # a page in the nav is a docs/ file or one the build makes (tools/mkdocs_hooks.py)
    made = rooms | {"index.md", "CONTRIBUTING.md"}
    assert {p for p in pages - made if not (REPO / "docs" / p).is_file()} == set()
