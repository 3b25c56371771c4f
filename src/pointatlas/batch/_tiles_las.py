"""LAS/LAZ streamed by chunks through tiled processing (never the whole file at once).

Reading: ``laspy.open(path).chunk_iterator(n)``, decoding only x, y, z (and the
``nx, ny, nz`` extra bytes when used) for the scan and spill passes; a LAZ file
run by `run_tile_job` is decoded once, its raw records kept in a memory map of the
temporary folder for the later passes (`LasSource.keep_records`). Writing:
``laspy.open(fh, mode="w", header=...)`` with a copy of the input header plus our
fields as extra-bytes dimensions; every input dimension is copied record by record
(the raw bytes, so bit fields and extra bytes survive unchanged). Results between
the passes live in ``.npy`` memory maps in a temporary folder beside the output.
"""

from __future__ import annotations

import copy
import time
from pathlib import Path

import numpy as np

from .._core import PointAtlasError, as_normals
from ..io import check_las_complete
from ._tiles import release_pages

__all__ = ["LAS_EXTENSIONS", "LAS_FEATURE_FLOAT", "LasSource", "las_feature_fields"]

#: Extensions streamed by chunks.
LAS_EXTENSIONS = (".las", ".laz")
#: Points per chunk read or written.
CHUNK_POINTS = 1_000_000
#: Points kept by the scan pass for halo and spacing estimates.
SAMPLE_POINTS = 4_000_000
_NORMALS = ("nx", "ny", "nz")
#: Names our fields never take (as `pointatlas.io.merge_attributes`).
_RESERVED = {"x", "y", "z", "nx", "ny", "nz", "red", "green", "blue", "alpha", "colors"}


class LasSource:
    """A LAS/LAZ file as a tile source, read by chunks.

    Parameters
    ----------
    path : str or path-like
        The file.
    chunk_points : int
        Points per chunk.
    """

    def __init__(self, path, chunk_points: int = CHUNK_POINTS):
        import laspy

        self.path = Path(path)
        self.chunk_points = int(chunk_points)
        check_las_complete(self.path)  # a cut file is refused in words, not mid-run
        try:
            with laspy.open(self.path) as reader:
                self.header = reader.header
        except Exception as exc:  # laspy raises many types on a corrupt file
            raise PointAtlasError(f"{self.path}: cannot read LAS/LAZ ({exc})") from None
        self.n = int(self.header.point_count)
        self.dims = list(self.header.point_format.dimension_names)
        self.has_normals = all(d in self.dims for d in _NORMALS)
        self.use_normals = self.has_normals
        self._bounds = None
        self.decode_seconds = 0.0
        self._keep_in = None  # folder of the raw records (`keep_records`)
        self._raw = None  # their memory map, once the first pass wrote it

    def keep_records(self, folder) -> None:
        """Decode a compressed file once: the first pass (`bounds`) keeps every raw
        record in ``folder/records.npy`` (a memory map, the point format's bytes) and
        the later passes (spill, write) read them from there instead of decoding the
        file again (docs/decisions/batch.md, "Tiles — LAS/LAZ streamed by chunks").
        Records from the map are those the decoder gives, byte for byte. No effect
        on uncompressed LAS (read directly) or once the first pass is done."""
        if getattr(self.header, "are_points_compressed", False) and self._bounds is None:
            self._keep_in = Path(folder)

    def _open(self, full: bool, normals: bool):
        import laspy

        sel = laspy.DecompressionSelection
        what = None
        if not full:
            what = sel.XY_RETURNS_CHANNEL | sel.Z
            if normals:
                what |= sel.ALL_EXTRA_BYTES
        kwargs = {} if what is None else {"decompression_selection": what}
        return laspy.open(self.path, **kwargs)

    def records(self, full: bool = True, *, normals: bool | None = None):
        """(start, laspy point record) chunks in file order (``full``: every
        dimension; else x, y, z and, with ``normals`` (default `use_normals`),
        the extra bytes)."""
        if self._raw is not None:
            yield from self._kept_records()
            return
        start = 0
        normals = self.use_normals if normals is None else normals
        with self._open(full, normals) as reader:
            it = reader.chunk_iterator(self.chunk_points)
            while True:
                t0 = time.perf_counter()
                rec = next(it, None)
                self.decode_seconds += time.perf_counter() - t0
                if rec is None or len(rec) == 0:
                    break
                yield start, rec
                start += len(rec)

    def _kept_records(self):
        """(start, record) chunks of the raw records kept by the first pass."""
        import laspy

        fmt, scales, offsets = self.header.point_format, self.header.scales, self.header.offsets
        raw = self._raw
        for start in range(0, raw.shape[0], self.chunk_points):
            block = raw[start : start + self.chunk_points]
            yield start, laspy.ScaleAwarePointRecord(block, fmt, scales, offsets)
            release_pages(raw)

    def _keeping_pass(self):
        """`records` of every dimension from the file, each chunk also copied into
        the memory map of `keep_records`; the map is used from then on."""
        path = self._keep_in / "records.npy"
        mm = None
        filled = 0
        for start, rec in self.records(full=True):
            if mm is None:
                mm = np.lib.format.open_memmap(path, "w+", rec.array.dtype, (self.n,))
            mm[start : start + len(rec)] = rec.array
            filled = start + len(rec)
            release_pages(mm)
            yield start, rec
        if mm is not None:
            mm.flush()
            del mm
            self._raw = np.load(path, mmap_mode="r")[:filled]

    @staticmethod
    def xyz_of(rec) -> np.ndarray:
        """(m, 3) float64 scaled coordinates: laspy's ``X * scale + offset`` (the same
        two operations, hence the same bits as ``rec.x``), written in place."""
        xyz = np.empty((len(rec), 3))
        for c, name in enumerate(("X", "Y", "Z")):
            col = xyz[:, c]
            np.multiply(rec.array[name], rec.scales[c], out=col)
            col += rec.offsets[c]
        return xyz

    @staticmethod
    def extremes_of(rec) -> tuple[np.ndarray, np.ndarray]:
        """Minima and maxima of `xyz_of`'s columns, bit for bit, from the integer
        columns' extremes: ``X * scale + offset`` rounded is monotone in X."""
        lo, hi = np.empty(3), np.empty(3)
        for c, name in enumerate(("X", "Y", "Z")):
            raw = rec.array[name]
            ends = np.array([raw.min(), raw.max()], dtype=raw.dtype) * rec.scales[c]
            ends += rec.offsets[c]
            lo[c], hi[c] = ends.min(), ends.max()  # a negative scale swaps them
        return lo, hi

    def chunks(self):
        """(start, xyz float64, normals or None) chunks."""
        for start, rec in self.records(full=False):
            nrm = None
            if self.use_normals:
                nrm = np.column_stack([np.asarray(rec[c], dtype=np.float64) for c in _NORMALS])
            yield start, self.xyz_of(rec), nrm

    def bounds(self):
        """Exact minima and maxima of the scaled coordinates (one pass, cached; the
        same pass keeps a regular subsample for `sample`)."""
        if self._bounds is None:
            lo = np.full(3, np.inf)
            hi = np.full(3, -np.inf)
            stride = max(1, self.n // SAMPLE_POINTS)
            parts = []
            keeping = self._keep_in is not None and self._raw is None
            passes = self._keeping_pass() if keeping else self.records(full=False, normals=False)
            for s, rec in passes:
                c_lo, c_hi = self.extremes_of(rec)
                lo = np.minimum(lo, c_lo)
                hi = np.maximum(hi, c_hi)
                parts.append(self.xyz_of(rec[(-s) % stride :: stride]))
            if not np.isfinite(lo).all():
                raise PointAtlasError(f"{self.path}: no points")
            self._bounds = (tuple(lo.tolist()), tuple(hi.tolist()))
            self._sample = (np.concatenate(parts), stride)
        return self._bounds

    def sample(self, max_points: int):
        """(every stride-th point, stride) with at most about ``max_points`` points."""
        self.bounds()
        pts, stride = self._sample
        step = max(1, pts.shape[0] // max(1, int(max_points)))
        return pts[::step], stride * step


#: Type of the float feature fields in LAS/LAZ extra bytes (docs/decisions/io.md,
#: "LAS/LAZ: feature fields as float32").
LAS_FEATURE_FLOAT = np.float32


def las_feature_fields(fields: dict, float_type=LAS_FEATURE_FLOAT) -> dict:
    """``pointatlas features``'s fields as written to LAS/LAZ.

    Parameters
    ----------
    fields : dict of str to ndarray
        Per-point fields.
    float_type : numpy dtype
        The type of float64 fields in the file (float32, `LAS_FEATURE_FLOAT`).

    Returns
    -------
    fields : dict of str to ndarray
        float64 fields as ``float_type`` (the rounding of ``astype``), integer and
        uint8 fields unchanged.
    """
    return {k: v.astype(float_type) if v.dtype == np.float64 else v for k, v in fields.items()}


def _free_name(name: str, taken: set) -> str:
    new = name
    while new in taken or new in _RESERVED:
        new = "pa_" + new
    return new


def _plan_fields(
    src: LasSource, fields: dict, *, normals: bool, keep_input_normals: bool, float_type=None
):
    """Output header and the (name, array, column) list of new dimensions
    (``float_type``: the type of float64 fields, default float64)."""
    import laspy

    header = copy.deepcopy(src.header)
    taken = set(src.dims) | {d.lower() for d in src.dims}
    extra = []  # (dimension name, source array, column or None)
    if normals and not src.has_normals:
        for c, name in enumerate(_NORMALS):
            extra.append((name, None, c))
    if normals and src.has_normals and keep_input_normals:
        base = _free_name("input_normals", taken)
        for c in range(3):
            extra.append((f"{base}_{c}", "input_normals", c))
    for key, arr in fields.items():
        if key == "colors":
            rgb_dims = all(d in src.dims for d in ("red", "green", "blue"))
            if not rgb_dims:
                for c, name in enumerate(("red", "green", "blue")):
                    extra.append((name, key, c))
                continue
        name = _free_name(key, taken)
        taken.add(name)
        if arr.ndim == 1:
            extra.append((name, key, None))
        else:
            for c in range(arr.shape[1]):
                extra.append((f"{name}_{c}", key, c))
    params = []
    for name, key, _c in extra:
        if key is None:  # new normals
            dtype = np.float64
        elif key == "input_normals":
            dtype = np.float64
        elif key == "colors" and name in ("red", "green", "blue"):
            dtype = np.uint16
        else:
            dtype = fields[key].dtype
            if dtype.kind == "b":
                dtype = np.dtype(np.uint8)
            elif dtype == np.float64 and float_type is not None:
                dtype = np.dtype(float_type)
        params.append(laspy.ExtraBytesParams(name=name, type=np.dtype(dtype)))
    if params:
        header.add_extra_dims(params)
    return header, extra


def _copy_input(out: np.ndarray, rec: np.ndarray) -> None:
    """Every input dimension of ``rec`` into ``out`` (structured point arrays).

    The output's point format is the input's with our extra bytes appended, so the
    input record is the first bytes of every output record: one strided block copy
    of the raw bytes (bit fields and extra bytes unchanged); a field-by-field copy
    where the layouts differ.
    """
    fin, fout = rec.dtype.fields, out.dtype.fields
    if (
        rec.flags.c_contiguous
        and out.flags.c_contiguous
        and all(fout.get(name) == fin[name] for name in fin)
    ):
        m, size = rec.shape[0], rec.dtype.itemsize
        raw = out.view(np.uint8).reshape(m, out.dtype.itemsize)
        raw[:, :size] = rec.view(np.uint8).reshape(m, size)
        return
    for name in rec.dtype.names:
        out[name] = rec[name]


def write_streamed(
    src: LasSource,
    out_path,
    fields: dict,
    *,
    normals=None,
    points=None,
    keep_input_normals: bool = True,
    float_type=None,
) -> Path:
    """Write ``src``'s records with our fields (arrays or memory maps of N rows).

    ``normals`` (N, 3) replace the input's ``nx, ny, nz`` (whose values go to
    ``input_normals_0..2``) or are added; ``points`` (N, 3) move the points
    (quantised with the header's scales and offsets); ``float_type`` is the type of
    float64 fields in the file (features: `LAS_FEATURE_FLOAT`). Atomic (temporary
    file and rename).
    """
    import laspy

    from ..io import atomic_write

    out_path = Path(out_path)
    header, extra = _plan_fields(
        src,
        fields,
        normals=normals is not None,
        keep_input_normals=keep_input_normals,
        float_type=float_type,
    )
    laz = out_path.suffix.lower() == ".laz"
    with atomic_write(out_path, "wb") as fh:
        with laspy.open(fh, mode="w", header=header, do_compress=laz, closefd=False) as writer:
            for start, rec in src.records(full=True):
                m = len(rec)
                sl = slice(start, start + m)
                out = laspy.ScaleAwarePointRecord.zeros(m, header=header)
                _copy_input(out.array, rec.array)
                if points is not None:
                    p = np.asarray(points[sl])
                    out.x, out.y, out.z = p[:, 0], p[:, 1], p[:, 2]
                if normals is not None:
                    # unit length exactly as a PointSet stores them (the untiled writer)
                    nv = as_normals(np.asarray(normals[sl]))
                    if src.has_normals:
                        old = {c: np.asarray(rec[c], dtype=np.float64) for c in _NORMALS}
                    for c, name in enumerate(_NORMALS):
                        out[name] = nv[:, c]
                for name, key, c in extra:
                    if key is None:
                        continue
                    if key == "input_normals":
                        out[name] = old[_NORMALS[c]]
                        continue
                    v = np.asarray(fields[key][sl])
                    if c is not None:
                        v = v[:, c]
                    if key == "colors" and name in ("red", "green", "blue"):
                        v = v.astype(np.uint16) * 257 if v.dtype == np.uint8 else v
                    if v.dtype.kind == "b":
                        v = v.astype(np.uint8)
                    out[name] = v
                writer.write_points(out)
                release_pages(*fields.values(), normals, points)
    return out_path
