"""Batch runs over model collections and tiled processing of large scans on dask (layer 5)."""

from .._core._deprecation import deprecated_alias
from ..io import to_json_safe
from ._runner import BatchReport, list_models, run_batch
from ._tiles import ArraySource, TiledRun, TileOptions
from ._tiles_cli import run_tiled_command, tile_options
from ._tiles_denoise import tiled_denoise
from ._tiles_features import tiled_features
from ._tiles_grid import TileGrid, make_grid
from ._tiles_las import LasSource, las_tiled
from ._tiles_normals import tiled_normals
from ._tiles_segment import tiled_segment

__all__ = [
    "ArraySource",
    "BatchReport",
    "LasSource",
    "TileGrid",
    "TileOptions",
    "TiledRun",
    "las_tiled",
    "list_models",
    "make_grid",
    "run_batch",
    "run_tiled_command",
    "tile_options",
    "tiled_denoise",
    "tiled_features",
    "tiled_normals",
    "tiled_segment",
]

# Former name of `pointatlas.io.to_json_safe`, the one JSON rule (NaN -> null; it kept
# NaN): it still works and warns (not in __all__).
to_jsonable = deprecated_alias(to_json_safe, "to_jsonable", new_name="pointatlas.io.to_json_safe")
