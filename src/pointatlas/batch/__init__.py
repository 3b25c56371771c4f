"""Batch runs over model collections and tiled processing of large scans on dask (layer 5)."""

from ._runner import BatchReport, list_models, run_batch, to_jsonable
from ._tiles import (
    ArraySource,
    TiledRun,
    TileOptions,
    tiled_denoise,
    tiled_features,
    tiled_normals,
    tiled_segment,
)
from ._tiles_cli import run_tiled_command, tile_options
from ._tiles_grid import TileGrid, make_grid
from ._tiles_las import LasSource, las_tiled

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
