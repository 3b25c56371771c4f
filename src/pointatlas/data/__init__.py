"""Bundled demo models (redistributable meshes) and named synthetic shapes.

``load("fandisk")`` gives the default demo point set; ``names()`` lists what is
available; licences and attributions are in ``LICENSES.md`` beside this file.
"""

from ._registry import DEFAULT_MODEL, ModelInfo, info, load, load_mesh, names, path

__all__ = ["DEFAULT_MODEL", "ModelInfo", "info", "load", "load_mesh", "names", "path"]
