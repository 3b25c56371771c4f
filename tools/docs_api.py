"""The public API that the reference documents, and what its docstrings must have.

The public API is ``pointatlas.__all__`` and each room's ``__all__``
(``src/pointatlas/<room>/__init__.py``). Every public function needs a numpydoc
docstring with at least one section (``Parameters``, ``Returns``, ...); every public
class, and every public method and property defined in one, needs a docstring.
``tests/test_docs.py`` and the ``make docs`` build (``tools/mkdocs_hooks.py``) both
fail on what :func:`docstring_problems` returns (docs/decisions/docs.md).
"""

from __future__ import annotations

import importlib
import inspect
import pathlib
import re

SRC = pathlib.Path(__file__).resolve().parent.parent / "src" / "pointatlas"

# a numpydoc section: its title, then a line of dashes
SECTION = re.compile(
    r"^(Parameters|Returns|Yields|Receives|Raises|Warns|Warnings|Other Parameters|"
    r"Attributes|Methods|See Also|Notes|References|Examples)\n-{3,}$",
    re.M,
)


def rooms() -> list[str]:
    """The rooms: the packages directly under ``src/pointatlas``, in name order."""
    return sorted(p.parent.name for p in SRC.glob("*/__init__.py"))


def modules() -> list[str]:
    """``pointatlas`` and its rooms, as dotted module names."""
    return ["pointatlas"] + [f"pointatlas.{room}" for room in rooms()]


def _members(cls: type):
    # public methods and properties defined in the class itself (not inherited)
    for name, value in vars(cls).items():
        if name.startswith("_"):
            continue
        if isinstance(value, property):
            yield name, "property", value.fget.__doc__ if value.fget else None
            continue
        func = value.__func__ if isinstance(value, staticmethod | classmethod) else value
        if inspect.isfunction(func):
            yield name, "method", func.__doc__


def docstring_problems() -> list[str]:
    """One line for each public object whose docstring is missing or has no section."""
    problems = []
    seen: set[int] = set()
    for module_name in modules():
        module = importlib.import_module(module_name)
        for name in module.__all__:
            obj = getattr(module, name)
            where = f"{module_name}.{name}"
            if inspect.isclass(obj):
                if id(obj) in seen:
                    continue
                seen.add(id(obj))
                if not (vars(obj).get("__doc__") or "").strip():
                    problems.append(f"{where}: class without a docstring")
                for member, kind, doc in _members(obj):
                    if not (doc or "").strip():
                        problems.append(f"{where}.{member}: {kind} without a docstring")
            elif inspect.isroutine(obj):
                if id(obj) in seen:
                    continue
                seen.add(id(obj))
                doc = inspect.getdoc(obj)
                if not (doc or "").strip():
                    problems.append(f"{where}: function without a docstring")
                elif not SECTION.search(doc):
                    problems.append(f"{where}: function docstring without a numpydoc section")
    return problems
