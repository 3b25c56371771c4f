"""What a tiled run of a file computes: one job object per method.

`run_tile_job` (``_tiles_files.py``) reads the file, sets up the source, the cluster
and the result arrays, calls the job's ``compute`` and writes what it returns; a job
knows its method's task and which of the input's normals it reads, nothing about
files. Decisions in docs/decisions/batch.md ("Tiles — jobs").
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ._tiles import TiledRun, release_pages
from ._tiles_combined import normals_features_over
from ._tiles_denoise import denoise_over
from ._tiles_features import features_over
from ._tiles_las import LAS_FEATURE_FLOAT
from ._tiles_normals import check_normal_options, normals_over
from ._tiles_segment import segment_over, vsa_options
from ._tiles_tasks import feature_kmax

__all__ = [
    "DenoiseTileJob",
    "FeaturesTileJob",
    "NormalsTileJob",
    "SegmentTileJob",
    "TileContext",
    "TileOutput",
]


@dataclass
class TileOutput:
    """What a job's tiles produced, for the writer.

    ``fields``: our per-point fields (N rows); ``normals``: new normals (the
    input's are kept as ``input_normals`` when ``replaces_input_normals``; a
    streamed LAS always keeps them); ``points``: moved points; ``summary``:
    entries for the run's summary.
    """

    run: TiledRun
    fields: dict = field(default_factory=dict)
    normals: object = None
    points: object = None
    summary: dict = field(default_factory=dict)
    replaces_input_normals: bool = False


@dataclass
class TileContext:
    """Where a job's tiles run and put their results.

    ``client_info``: the cluster (`tile_client`); ``store``: makes the result
    arrays (N rows; memory maps in the run's temporary folder when streamed);
    ``spill_dir``: that folder, or None; ``normals``: normals estimated first,
    sent with the tiles instead of the source's; ``normal_job``: normals asked of
    the job's own pass (`FeaturesTileJob`, streamed).
    """

    client_info: tuple
    store: object
    spill_dir: object = None
    normals: object = None
    normal_job: NormalsTileJob | None = None


@dataclass(frozen=True)
class NormalsTileJob:
    """PCA normals by tiles (`tiled_normals`): ``k``, ``orient`` (mst, viewpoint, up
    or none; mst is stitched across tiles), ``orient_k``, ``viewpoint``."""

    k: int = 20
    orient: str = "mst"
    orient_k: int = 10
    viewpoint: tuple | None = None
    #: the job reads no input normals
    uses_normals = False
    #: features never need to be written as float32 here
    las_float_type = None

    def check(self, n_points: int) -> None:
        """One-line errors for these options on ``n_points`` points."""
        check_normal_options(n_points, self.k, self.orient)

    def compute(self, source, options, ctx: TileContext, label: str = "normals") -> TileOutput:
        """The normals of every point of ``source`` (N, 3)."""
        out = ctx.store.new("normals", np.float64, 3)
        normals, run = normals_over(
            source,
            options,
            k=self.k,
            orient=self.orient,
            orient_k=self.orient_k,
            viewpoint=self.viewpoint,
            out=out,
            spill_dir=ctx.spill_dir,
            client_info=ctx.client_info,
            label=label,
        )
        return TileOutput(run, normals=normals, replaces_input_normals=True)


@dataclass(frozen=True)
class FeaturesTileJob:
    """Covariance features by tiles (`tiled_features`; ``params`` as there). With
    normals estimated by a streamed run and equal weights, both come from one k-NN
    per tile (`normals_features_over`)."""

    params: dict

    #: float features are written to LAS/LAZ as float32
    las_float_type = LAS_FEATURE_FLOAT

    @property
    def uses_normals(self) -> bool:
        """Sigmoid weights (mode "optimal") read the normals."""
        return self.params["mode"] == "optimal"

    @property
    def kmax(self) -> int:
        """The largest neighbourhood of the features."""
        return feature_kmax(self.params)

    def fuses_normals(self) -> bool:
        """Whether normals estimated for this job come from the features' own k-NN."""
        return not self.uses_normals

    def compute(self, source, options, ctx: TileContext) -> TileOutput:
        """The features of every point (and its normals with ``ctx.normal_job``)."""
        store = ctx.store.typed(self.las_float_type)
        if ctx.normal_job is not None:
            normals, _, run = normals_features_over(
                source,
                options,
                self.params,
                {
                    "k": ctx.normal_job.k,
                    "orient_k": ctx.normal_job.orient_k,
                    "orient": ctx.normal_job.orient,
                },
                normals_out=ctx.store.new("normals", np.float64, 3),
                fields_out=store,
                spill_dir=ctx.spill_dir,
                client_info=ctx.client_info,
            )
            return TileOutput(run, fields=dict(store), normals=normals)
        _, run = features_over(
            source,
            options,
            self.params,
            out=store,
            spill_dir=ctx.spill_dir,
            client_info=ctx.client_info,
            normals_array=ctx.normals,
        )
        return TileOutput(run, fields=dict(store))


@dataclass(frozen=True)
class SegmentTileJob:
    """VSA by tiles, stitched (`tiled_segment`): ``vsa`` a `VSAOptions` that can be
    stitched (refused in one line otherwise, when the job is made); ``label_colors``
    (``labels -> (M, 3) uint8``) adds the colours of the labels."""

    vsa: object
    label_colors: object = None
    uses_normals = True
    las_float_type = None

    def __post_init__(self):
        object.__setattr__(self, "vsa", vsa_options(self.vsa))

    def compute(self, source, options, ctx: TileContext) -> TileOutput:
        """Labels (and colours) of every point; the regions' quality in the summary."""
        labels, quality, run = segment_over(
            source,
            options,
            self.vsa,
            labels_out=ctx.store.new("label", np.int64),
            spill_dir=ctx.spill_dir,
            client_info=ctx.client_info,
            normals_array=ctx.normals,
        )
        fields = {"label": labels}
        if self.label_colors is not None:
            fields["colors"] = ctx.store.mapped("colors", labels, self.label_colors, np.uint8, 3)
        summary = {"quality": {k: quality[k] for k in ("n_regions", "energy", "mse")}}
        summary["regions"] = quality
        return TileOutput(run, fields=fields, summary=summary)


@dataclass(frozen=True)
class DenoiseTileJob:
    """Denoising by tiles (`tiled_denoise`; ``params`` as there): moved points, their
    normals and the per-point fields; the global spacing l in the summary."""

    params: dict
    uses_normals = True
    las_float_type = None

    def compute(self, source, options, ctx: TileContext) -> TileOutput:
        """The moved points and normals of every point, and the fields."""
        outs = ctx.store.typed(None)
        outs.new("points", np.float64, 3)
        outs.new("normals", np.float64, 3)
        out, run = denoise_over(
            source,
            options,
            self.params,
            spill_dir=ctx.spill_dir,
            client_info=ctx.client_info,
            outs=outs,
            normals_array=ctx.normals,
        )
        fields = {k: v for k, v in out.items() if k not in ("points", "normals", "spacing")}
        return TileOutput(
            run,
            fields=fields,
            points=out["points"],
            normals=out["normals"],
            summary={"spacing": out["spacing"]},
        )


class ArrayStore(dict):
    """The result arrays of a run read whole: zeroed arrays of N rows, by name.

    ``float_type`` is None: float64 results stay float64 (a LAS output gets its
    float32 features when written).
    """

    float_type = None

    def __init__(self, n: int):
        super().__init__()
        self.n = n

    def typed(self, float_type):
        """A fresh store for one set of results (float types as the class says)."""
        return type(self)(self.n)

    def new(self, name, dtype, width=None):
        """A zeroed (N,) or (N, width) array named ``name``."""
        shape = (self.n,) if width is None else (self.n, width)
        self[name] = np.zeros(shape, dtype=dtype)
        return self[name]

    def mapped(self, name, values, func, dtype, width):
        """``func(values)`` (N rows) as the array ``name``."""
        self[name] = func(values)
        return self[name]


class MappedStore(ArrayStore):
    """The result arrays of a streamed run: memory maps in its temporary folder
    (``out_<name>.npy`` for a job's typed results, ``<name>.npy`` otherwise);
    ``float_type``: float64 results are kept (and rounded) as that type."""

    def __init__(self, folder, n: int, float_type=None, prefix: str = ""):
        super().__init__(n)
        self.folder = folder
        self.float_type = float_type
        self.prefix = prefix

    def typed(self, float_type):
        """The store of one job's results, kept as ``float_type``."""
        return MappedStore(self.folder, self.n, float_type, prefix="out_")

    def new(self, name, dtype, width=None):
        """A memory map of N rows (float64 as ``float_type`` when set)."""
        shape = (self.n,) if width is None else (self.n, width)
        if self.float_type is not None and np.dtype(dtype) == np.float64:
            dtype = self.float_type
        path = self.folder / f"{self.prefix}{name}.npy"
        self[name] = np.lib.format.open_memmap(path, mode="w+", dtype=dtype, shape=shape)
        return self[name]

    def mapped(self, name, values, func, dtype, width):
        """``func(values)`` computed by blocks into a memory map (resident memory stays
        one block)."""
        out = self.new(name, dtype, width)
        step = 1 << 22
        for s in range(0, self.n, step):
            out[s : s + step] = func(np.asarray(values[s : s + step]))
            release_pages(out, values)
        return out
