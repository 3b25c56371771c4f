"""``python -m pointatlas.cli``: the same as the ``pointatlas`` command."""

from . import main

main()
