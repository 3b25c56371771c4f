"""The write pass copies every input dimension of a LAS record (docs/decisions/batch.md,
"Tiles — LAS/LAZ streamed by chunks")."""

from __future__ import annotations

import numpy as np
import pytest

laspy = pytest.importorskip("laspy")

from pointatlas.batch._tiles_las import _copy_input  # noqa: E402


def _record(n, extra=(), seed=0):
    header = laspy.LasHeader(point_format=6, version="1.4")
    if extra:
        header.add_extra_dims([laspy.ExtraBytesParams(name=e, type=np.float64) for e in extra])
    raw = np.random.default_rng(seed).integers(0, 256, (n, header.point_format.size), np.uint8)
    return raw.view(header.point_format.dtype()).ravel(), header


def test_block_copy_equals_field_by_field_copy_with_extra_bytes_appended():
    rec, header = _record(1000, extra=("nx",))
    out_header = laspy.LasHeader(point_format=6, version="1.4")
    out_header.add_extra_dims(
        [laspy.ExtraBytesParams(name=e, type=np.float64) for e in ("nx", "linearity")]
    )
    out = np.zeros(1000, out_header.point_format.dtype())
    out["linearity"] = 7.0
    _copy_input(out, rec)
    for name in rec.dtype.names:
        assert out[name].tobytes() == rec[name].tobytes()
    assert (out["linearity"] == 7.0).all()  # our dimensions untouched
    head = out.view(np.uint8).reshape(1000, -1)[:, : rec.dtype.itemsize]
    assert head.tobytes() == rec.view(np.uint8).tobytes()


def test_other_layouts_are_copied_field_by_field():
    rec, _ = _record(50, extra=("a", "b"), seed=1)
    swapped = np.dtype([(n, rec.dtype.fields[n][0]) for n in ("b", *rec.dtype.names[:-1])])
    out = np.zeros(50, swapped)  # "b" first: not the input's prefix
    _copy_input(out, rec)
    for name in rec.dtype.names:
        assert out[name].tobytes() == rec[name].tobytes()
    strided = np.zeros(100, rec.dtype)[::2]  # not contiguous
    _copy_input(strided, rec)
    assert strided.tobytes() == rec.tobytes()


def _write_laz(path, n, seed=0):
    rec, header = _record(n, extra=("a",), seed=seed)
    header.scales = np.array([0.001, 0.001, 0.001])
    header.offsets = np.array([500000.0, 4100000.0, 0.0])
    points = laspy.ScaleAwarePointRecord(rec, header.point_format, header.scales, header.offsets)
    las = laspy.LasData(header, points)
    las.write(path)
    return path


def test_kept_records_are_the_decoded_records_on_every_pass(tmp_path):
    """A LAZ decoded once (`LasSource.keep_records`): the later passes read the kept raw
    records, byte for byte those the decoder gives, in the same chunks; the bounds,
    subsample and the written file are those of a source that decodes every pass."""
    from pointatlas.batch._tiles_las import LasSource, write_streamed

    path = _write_laz(tmp_path / "in.laz", 2500)
    plain = LasSource(path, chunk_points=700)
    kept = LasSource(path, chunk_points=700)
    (tmp_path / "keep").mkdir()
    kept.keep_records(tmp_path / "keep")
    assert kept.bounds() == plain.bounds()
    assert np.array_equal(kept.sample(100)[0], plain.sample(100)[0])
    assert kept._raw is not None and kept._raw.shape == (2500,)
    for full in (True, False):
        a = list(plain.records(full=full))
        b = list(kept.records(full=full))
        assert [s for s, _ in a] == [s for s, _ in b] == [0, 700, 1400, 2100]
        for (_, ra), (_, rb) in zip(a, b, strict=True):
            if full:  # (x, y, z only decode only those: the kept records hold more)
                assert ra.array.tobytes() == rb.array.tobytes()
            for c in ("x", "y", "z"):
                assert np.asarray(ra[c]).tobytes() == np.asarray(rb[c]).tobytes()
    for (sa, xa, _), (sb, xb, _) in zip(plain.chunks(), kept.chunks(), strict=True):
        assert sa == sb and np.array_equal(xa, xb)
    fields = {"f": np.arange(2500, dtype=np.float32)}
    write_streamed(plain, tmp_path / "a.laz", fields, normals=np.tile([0.0, 0.0, 1.0], (2500, 1)))
    write_streamed(kept, tmp_path / "b.laz", fields, normals=np.tile([0.0, 0.0, 1.0], (2500, 1)))
    assert (tmp_path / "a.laz").read_bytes() == (tmp_path / "b.laz").read_bytes()


def test_uncompressed_las_is_read_directly(tmp_path):
    from pointatlas.batch._tiles_las import LasSource

    path = _write_laz(tmp_path / "in.las", 300)
    src = LasSource(path)
    src.keep_records(tmp_path)
    src.bounds()
    assert src._raw is None and not (tmp_path / "records.npy").exists()
