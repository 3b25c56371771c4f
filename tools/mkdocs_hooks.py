"""MkDocs hooks for ``make docs`` (mkdocs.yml ``hooks:``; docs/decisions/docs.md).

- the README becomes the site's home page (``index.md``) and CONTRIBUTING.md a page,
  their ``docs/...`` links rewritten to the pages they name;
- one API page per room (``api/<room>.md``) and one for ``pointatlas`` itself
  (``api/index.md``), each rendering the room's ``__all__`` through mkdocstrings;
- every public function without a numpydoc docstring, and every public class, method
  or property without a docstring, is logged as a warning, and so is an API page that
  misses a name of its ``__all__`` or shows one that is not in it: the strict build
  fails.
"""

from __future__ import annotations

import importlib
import logging
import pathlib
import re
import sys

from mkdocs.structure.files import File

ROOT = pathlib.Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "tools"))

import docs_api  # noqa: E402

log = logging.getLogger("mkdocs.hooks.pointatlas")

# the repository's own Markdown files that are pages: file -> page. Their links are
# relative to the repository root: those into docs/ are rewritten, one to another of
# these files resolves as it is, and any other fails the build (a missing file)
ROOT_PAGES = {"README.md": "index.md", "CONTRIBUTING.md": "CONTRIBUTING.md"}
# a Markdown link or image target into docs/: ](docs/x.md) -> ](x.md)
README_LINK = re.compile(r"\]\(docs/")
# the anchor of a rendered object: id="pointatlas.segment.vsa_segment"
OBJECT_ID = re.compile(r'id="(pointatlas(?:\.[A-Za-z_]\w*)*)"')


def page_module(src_uri: str) -> str | None:
    """The module an API page documents (``api/segment.md`` -> ``pointatlas.segment``)."""
    if not src_uri.startswith("api/"):
        return None
    stem = src_uri[len("api/") : -len(".md")]
    return "pointatlas" if stem == "index" else f"pointatlas.{stem}"


def api_page(module: str) -> str:
    """The Markdown of one API page: its title and the mkdocstrings directive."""
    return f"# `{module}`\n\n::: {module}\n"


def on_files(files, config):
    for source, page in ROOT_PAGES.items():
        text = (ROOT / source).read_text(encoding="utf-8")
        files.append(File.generated(config, page, content=README_LINK.sub("](", text)))
    files.append(File.generated(config, "api/index.md", content=api_page("pointatlas")))
    for room in docs_api.rooms():
        page = File.generated(config, f"api/{room}.md", content=api_page(f"pointatlas.{room}"))
        files.append(page)
    return files


def on_pre_build(config):
    for problem in docs_api.docstring_problems():
        log.warning("public API docstring: %s", problem)


def on_page_content(html, page, config, files):
    module = page_module(page.file.src_uri)
    if module is None:
        return html
    prefix = module + "."
    shown = {
        name[len(prefix) :]
        for name in OBJECT_ID.findall(html)
        if name.startswith(prefix) and "." not in name[len(prefix) :]
    }
    public = set(importlib.import_module(module).__all__)
    for name in sorted(public - shown):
        log.warning("%s: %s.%s is in __all__ but not on the page", page.file.src_uri, module, name)
    for name in sorted(shown - public):
        log.warning("%s: %s.%s is on the page but not in __all__", page.file.src_uri, module, name)
    return html
