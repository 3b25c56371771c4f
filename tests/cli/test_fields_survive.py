"""Property: every command, on every bundled model written in the supported formats,
keeps every input field (and LAS dimensions bit for bit through a LAS output). The first
model goes through every format; each other one through one point format and one mesh
format in turn, so that every format meets several models (the whole cross product ran
25 commands per model: 45 s of the suite, for the same property)."""

from __future__ import annotations

import numpy as np
import pytest
from typer.testing import CliRunner

from pointatlas import data
from pointatlas.cli import app
from pointatlas.io import read_point_set, write_mesh, write_point_set

runner = CliRunner()

POINT_FORMATS = (".ply", ".las", ".laz", ".xyz")
MESH_FORMATS = (".obj", ".off", ".stl")
# fast settings: the property is about the fields, not about the numbers
COMMANDS = {
    "segment": ["--max-angle-deg", "20"],
    "features": ["--k", "10", "--weighting", "equal"],
    "normals": ["--k", "10", "--orient", "none"],
}


def _with_fields(ps, seed: int):
    """The model with fields a scan would carry: intensity, classification, colours."""
    rng = np.random.default_rng(seed)
    n = ps.n_points
    return ps.with_attributes(
        intensity=rng.integers(0, 65535, n).astype(np.uint16),
        classification=rng.integers(0, 20, n).astype(np.uint8),
        colors=rng.integers(0, 65535, (n, 3)).astype(np.uint16),
        gps_time=rng.uniform(0, 1e6, n),
    )


def _formats(name):
    """The point and mesh formats ``name`` is written in (`_inputs`)."""
    i = data.names().index(name)
    if i == 0:
        return POINT_FORMATS, MESH_FORMATS
    return (POINT_FORMATS[i % len(POINT_FORMATS)],), (MESH_FORMATS[i % len(MESH_FORMATS)],)


def _inputs(name, tmp_path):
    ps = _with_fields(data.load(name), seed=len(name))
    stem = name.replace(":", "_")
    point_formats, mesh_formats = _formats(name)
    for ext in point_formats:
        path = tmp_path / f"{stem}{ext}"
        if ext == ".xyz":
            write_point_set(path, ps.points, normals=ps.normals)
        else:
            write_point_set(path, ps)
        yield path
    try:
        mesh = data.load_mesh(name)
    except Exception:  # a model without faces
        return
    for ext in mesh_formats:
        path = tmp_path / f"{stem}{ext}"
        write_mesh(path, mesh)
        yield path


def test_every_format_meets_several_models():
    with_mesh = []
    for name in data.names():
        try:
            data.load_mesh(name)
        except Exception:  # a model without faces
            continue
        with_mesh.append(name)
    points = [ext for name in data.names() for ext in _formats(name)[0]]
    meshes = [ext for name in with_mesh for ext in _formats(name)[1]]
    assert min(points.count(ext) for ext in POINT_FORMATS) >= 3
    assert min(meshes.count(ext) for ext in MESH_FORMATS) >= 3


@pytest.mark.parametrize("name", data.names())
def test_every_command_keeps_every_input_field(name, tmp_path):
    for src in _inputs(name, tmp_path):
        given = read_point_set(src, zero_normals="drop")
        outs = [".ply"] + ([src.suffix] if src.suffix in (".las", ".laz") else [])
        for command, options in COMMANDS.items():
            for ext in outs:
                out = tmp_path / f"out_{command}{ext}"
                result = runner.invoke(app, [command, str(src), str(out), *options])
                assert result.exit_code == 0, (src.name, command, result.output)
                got = read_point_set(out, with_normals=False)
                np.testing.assert_allclose(got.points, given.points, rtol=0, atol=1e-6)
                for field, values in given.attributes.items():
                    assert field in got.attributes, (src.name, command, ext, field)
                    np.testing.assert_array_equal(
                        got.attributes[field], values, err_msg=f"{src.name} {command} {field}"
                    )
                if ext in (".las", ".laz"):
                    import laspy

                    before, after = laspy.read(src), laspy.read(out)
                    assert after.header.point_format.id == before.header.point_format.id
                    assert after.header.version == before.header.version
                    np.testing.assert_array_equal(after.header.scales, before.header.scales)
                    np.testing.assert_array_equal(after.header.offsets, before.header.offsets)
                    for dim in before.point_format.dimension_names:
                        if dim in ("nx", "ny", "nz"):
                            continue  # our normals, checked below
                        np.testing.assert_array_equal(
                            np.asarray(after[dim]), np.asarray(before[dim]), err_msg=dim
                        )
                    normals = np.column_stack([np.asarray(after[d]) for d in ("nx", "ny", "nz")])
                    if command == "normals":  # replaced; the input's kept beside them
                        names = [f"input_normals_{j}" for j in range(3)]
                        normals = np.column_stack([np.asarray(after[d]) for d in names])
                    # stored normals are rescaled to unit length on reading (<= 1 ulp)
                    np.testing.assert_allclose(normals, given.normals, rtol=0, atol=4e-16)


def test_chained_normal_estimates_keep_every_earlier_normal(tmp_path):
    """Re-estimating normals on a file that already holds ``input_normals_0..2`` (a PLY
    written by an earlier run) keeps both sets: the new copy is ``pa_`` prefixed."""
    first = tmp_path / "a.ply"
    assert runner.invoke(app, ["normals", "fandisk", str(first), "--k", "10"]).exit_code == 0
    stages = [first]
    for step, args in enumerate(
        (["normals", "--k", "10"], ["segment", "--estimate-normals", "--max-angle-deg", "20"])
    ):
        out = tmp_path / f"s{step}.ply"
        done = runner.invoke(app, [args[0], str(stages[-1]), str(out), *args[1:]])
        assert done.exit_code == 0, done.output
        stages.append(out)
    before = read_point_set(stages[1])
    after = read_point_set(stages[2])
    for key, value in before.attributes.items():
        np.testing.assert_array_equal(after.attributes[key], value)
    for prefix in ("input_normals", "pa_input_normals", "pa_pa_input_normals"):
        assert {f"{prefix}_{j}" for j in range(3)} <= set(after.attributes)
    np.testing.assert_array_equal(
        np.column_stack([after.attributes[f"pa_pa_input_normals_{j}"] for j in range(3)]),
        before.normals,
    )
