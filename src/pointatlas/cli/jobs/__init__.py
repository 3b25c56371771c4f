"""The commands' jobs, below every interface: reading IN (normals estimated when
missing), computing, writing, printing.

The typer commands (``cli/_cmd_*.py``) map their flags onto these functions and the
application (``cli/_app.py``) shares their consoles; nothing here imports the
commands or the application (docs/decisions/cli.md, "Layout").
"""

from ._cloud_files import load_cloudsurface
from ._cloudsurface import CloudSurfaceOptions, CloudSurfaceResult, run_cloudsurface, scale_grid
from ._console import PIPE_WIDTH, console, err_console, progress_bar, say, warn
from ._deform import DeformOptions, DeformResult, run_deform
from ._demo import (
    DEMO_ETA,
    features_files,
    info_file,
    normals_files,
    picture_file,
    segment_files,
    simplify_files,
)
from ._demo_run import bundled_data, run_demo_steps, write_demo_report
from ._denoise import DenoiseOptions, DenoiseResult, run_denoise
from ._features import FeaturesOptions, FeaturesResult, reason_counts, run_features
from ._info import InfoOptions, InfoResult, info_fields, info_table, run_info
from ._inputs import fill_unusable_normals, read_input, read_keeping_normals, read_with_normals
from ._normals import ORIENT_METHODS, compute_normals, normals_and_table
from ._normals_job import NormalsOptions, NormalsResult, run_normals
from ._segment import SegmentOptions, SegmentResult, run_segment
from ._simplify import SimplifyOptions, SimplifyResult, run_simplify, simplify_quietly
from ._simplify_report import render_simplification, simplification_table, surface_table
from ._tiled import (
    denoise_job,
    denoise_side_files,
    feature_job,
    feature_weighting,
    normal_job_for,
    run_tiled,
    segment_job,
    segment_side_files,
    tile_options,
)

__all__ = [
    "DEMO_ETA",
    "CloudSurfaceOptions",
    "CloudSurfaceResult",
    "DeformOptions",
    "DeformResult",
    "DenoiseOptions",
    "DenoiseResult",
    "FeaturesOptions",
    "InfoOptions",
    "InfoResult",
    "FeaturesResult",
    "ORIENT_METHODS",
    "NormalsOptions",
    "NormalsResult",
    "PIPE_WIDTH",
    "SegmentOptions",
    "SegmentResult",
    "SimplifyOptions",
    "SimplifyResult",
    "compute_normals",
    "console",
    "denoise_job",
    "bundled_data",
    "denoise_side_files",
    "err_console",
    "feature_job",
    "feature_weighting",
    "features_files",
    "load_cloudsurface",
    "fill_unusable_normals",
    "info_fields",
    "info_file",
    "info_table",
    "normal_job_for",
    "normals_and_table",
    "normals_files",
    "picture_file",
    "progress_bar",
    "reason_counts",
    "render_simplification",
    "read_input",
    "read_keeping_normals",
    "read_with_normals",
    "run_cloudsurface",
    "run_deform",
    "run_demo_steps",
    "run_denoise",
    "run_features",
    "run_info",
    "run_normals",
    "run_segment",
    "run_simplify",
    "run_tiled",
    "say",
    "scale_grid",
    "segment_job",
    "segment_files",
    "segment_side_files",
    "simplification_table",
    "simplify_files",
    "simplify_quietly",
    "surface_table",
    "tile_options",
    "warn",
    "write_demo_report",
]
