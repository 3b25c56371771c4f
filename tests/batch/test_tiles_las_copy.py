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
