"""Batch runs over model collections and tiled processing of large scans on dask (layer 5)."""

from ._runner import BatchReport, list_models, run_batch, to_jsonable
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
    "to_jsonable",
]
