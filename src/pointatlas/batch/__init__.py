"""Batch runs over model collections and tiled processing of large scans on dask (layer 5)."""

from .._core import deprecated_alias
from ..io import to_json_safe
from ._runner import BatchReport, list_models, run_batch
from ._tiles import ArraySource, TiledRun, TileOptions
from ._tiles_denoise import tiled_denoise
from ._tiles_features import tiled_features
from ._tiles_files import input_has_normals, input_point_count, run_tile_job
from ._tiles_grid import TileGrid, make_grid
from ._tiles_jobs import (
    DenoiseTileJob,
    FeaturesTileJob,
    NormalsTileJob,
    SegmentTileJob,
)
from ._tiles_las import LasSource, las_feature_fields
from ._tiles_normals import tiled_normals
from ._tiles_segment import tiled_segment

__all__ = [
    "ArraySource",
    "BatchReport",
    "DenoiseTileJob",
    "FeaturesTileJob",
    "LasSource",
    "NormalsTileJob",
    "SegmentTileJob",
    "TileGrid",
    "TileOptions",
    "TiledRun",
    "input_has_normals",
    "input_point_count",
    "las_feature_fields",
    "list_models",
    "make_grid",
    "run_batch",
    "run_tile_job",
    "tiled_denoise",
    "tiled_features",
    "tiled_normals",
    "tiled_segment",
]

# Former name of `pointatlas.io.to_json_safe`, the one JSON rule (NaN -> null; it kept
# NaN): it still works and warns (not in __all__).
to_jsonable = deprecated_alias(to_json_safe, "to_jsonable", new_name="pointatlas.io.to_json_safe")
