"""HTML reports without a browser: embedded arrays, subsampling, validation, CLI wiring."""

from __future__ import annotations

import base64
import hashlib
import html
import json
import re

import numpy as np
import pytest
from typer.testing import CliRunner

from pointatlas.cli import app
from pointatlas.io import write_point_set
from pointatlas.synth import cube
from pointatlas.viz import MeshLayer, PointsLayer, ReportSection, render_points, write_report

runner = CliRunner()


def view_payloads(text: str) -> list[dict]:
    """The JSON data of every 3-D view of a report."""
    found = re.findall(r"<script type='application/json' class='pa-data'>(.*?)</script>", text)
    return [json.loads(s.replace("<\\/", "</")) for s in found]


def decode(b64: str, dtype: str) -> np.ndarray:
    return np.frombuffer(base64.b64decode(b64), dtype=np.dtype(dtype).newbyteorder("<"))


def cloud(n=5000, seed=0):
    rng = np.random.default_rng(seed)
    pts = rng.normal(size=(n, 3)) + np.array([1000.0, -2000.0, 50.0])  # far from 0: offset
    labels = (pts[:, 0] > 1000).astype(np.int64) + 2 * (pts[:, 1] > -2000)
    return pts, labels


def test_points_travel_as_binary_arrays_and_decode_exactly(tmp_path):
    pts, labels = cloud()
    height = pts[:, 2].copy()
    height[7] = np.nan
    out = write_report(
        tmp_path / "r.html",
        title="t",
        summary={"points": len(pts)},
        parameters={},
        layers=[PointsLayer(pts, {"label": labels, "height": height})],
    )
    data = view_payloads(out.read_text())[0]
    shown = decode(data["points"]["indices"], "u4")
    np.testing.assert_array_equal(shown, np.arange(len(pts)))  # small: every point
    pos = decode(data["points"]["positions"], "f4").reshape(-1, 3) + np.array(data["offset"])
    # float32 relative to the offset keeps sub-micrometre precision far from the origin
    np.testing.assert_allclose(pos, pts, atol=1e-5)
    fields = {f["name"]: f for f in data["points"]["fields"]}
    assert fields["label"]["kind"] == "labels" and fields["height"]["kind"] == "scalar"
    np.testing.assert_array_equal(decode(fields["label"]["values"], "i4"), labels)
    h = decode(fields["height"]["values"], "f4")
    assert np.isnan(h[7]) and np.allclose(np.delete(h, 7), np.delete(height, 7), rtol=1e-6)
    legend = fields["height"]["legend"]
    assert legend["n_nan"] == 1 and legend["vmin"] == np.nanmin(height)
    counts = {e["label"]: e["count"] for e in fields["label"]["legend"]["entries"]}
    assert counts == dict(zip(*np.unique(labels, return_counts=True), strict=True))
    assert "[" not in data["points"]["positions"]  # base64, not a JSON list


def test_large_clouds_are_subsampled_for_the_view_only_and_seeded(tmp_path):
    pts, labels = cloud(3000)

    def shown(seed, name):
        out = write_report(
            tmp_path / name,
            title="t",
            summary={},
            parameters={},
            seed=seed,
            max_view_points=500,
            tables={"counts": {"points": len(pts)}},
            layers=[PointsLayer(pts, {"label": labels})],
        )
        text = out.read_text()
        data = view_payloads(text)[0]
        return text, decode(data["points"]["indices"], "u4"), data

    text, a, data = shown(4, "a.html")
    _, b, _ = shown(4, "b.html")
    _, c, _ = shown(5, "c.html")
    assert a.size == 500 and np.all(np.diff(a.astype(np.int64)) > 0)
    np.testing.assert_array_equal(a, b)
    assert not np.array_equal(a, c)
    assert "Showing 500 of 3,000 points" in text and "seed 4" in text
    # the legend counts every point, not only the shown ones
    entries = data["points"]["fields"][0]["legend"]["entries"]
    assert sum(e["count"] for e in entries) == len(pts)
    values = decode(data["points"]["fields"][0]["values"], "i4")
    np.testing.assert_array_equal(values, labels[a])


def test_page_is_self_contained(tmp_path):
    mesh = cube(4)
    png = render_points(tmp_path / "p.png", mesh.vertices, size=(64, 64))
    out = write_report(
        tmp_path / "r.html",
        title="a <b> title",
        summary={"file": "x.ply"},
        parameters={"k": 8},
        pictures=[png, ("bytes", png.read_bytes())],
        layers=[PointsLayer(mesh.vertices), MeshLayer(mesh.vertices, mesh.faces)],
    )
    text = out.read_text()
    assert "a &lt;b&gt; title" in text
    assert re.search(r"(src|href)=['\"]?(https?:)?//", text) is None  # nothing fetched
    imgs = re.findall(r"<img src='([^']+)'", text)
    assert len(imgs) == 2 and all(s.startswith("data:image/png;base64,") for s in imgs)
    assert base64.b64decode(imgs[0].split(",", 1)[1]) == png.read_bytes()
    # one inline viewer script plus the view's data; the bundle cannot close its element
    assert text.count("<script>") == 1 and text.count("</script>") == 2
    data = view_payloads(text)[0]
    assert [f["name"] for f in data["points"]["fields"]] == ["height"]  # y up by default
    tris = decode(data["meshes"][0]["triangles"], "u4").reshape(-1, 3)
    assert tris.shape == mesh.faces.shape


def test_polygon_mesh_is_fan_triangulated_with_face_colours(tmp_path):
    v = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)], dtype=float)
    quads = [[0, 1, 3, 2], [4, 6, 7, 5], [0, 4, 5, 1], [2, 3, 7, 6], [0, 2, 6, 4], [1, 5, 7, 3]]
    out = write_report(
        tmp_path / "r.html",
        title="t",
        summary={},
        parameters={},
        layers=[MeshLayer(v, quads, face_labels=np.arange(6))],
    )
    mesh = view_payloads(out.read_text())[0]["meshes"][0]
    tris = decode(mesh["triangles"], "u4").reshape(-1, 3)
    assert tris.shape == (12, 3)
    # the two triangles of each quad cover exactly its four corners
    for f, quad in enumerate(quads):
        assert set(tris[2 * f : 2 * f + 2].ravel()) == set(quad)
    colors = decode(mesh["face_colors"], "u1").reshape(-1, 3)
    assert colors.shape == (12, 3)
    assert (colors[0::2] == colors[1::2]).all() and len({tuple(c) for c in colors[0::2]}) == 6


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"layers": [PointsLayer(np.zeros((3, 3))), PointsLayer(np.zeros((3, 3)))]}, "at most one"),
        ({"layers": [PointsLayer(np.zeros((3, 3)), {"a": np.zeros(4)})]}, "shape (3,)"),
        ({"layers": [PointsLayer(np.zeros((3, 3)), {"a": np.zeros(3)}, color_by="b")]}, "'b'"),
        ({"layers": ["points"]}, "PointsLayer or MeshLayer"),
        ({"pictures": [("x", b"GIF89a")]}, "not a PNG"),
        ({"tables": {"t": [1, 2]}}, "mapping"),
        ({"max_view_points": 0}, "at least 1"),
        ({"up": "w", "layers": [PointsLayer(np.zeros((3, 3)))]}, "'x', 'y' or 'z'"),
    ],
)
def test_bad_arguments_are_refused_with_a_clear_message(tmp_path, kwargs, message):
    with pytest.raises((ValueError, TypeError), match=re.escape(message)):
        write_report(tmp_path / "r.html", title="t", summary={}, parameters={}, **kwargs)
    assert not (tmp_path / "r.html").exists()


def test_sections_are_linked_and_each_gets_a_view(tmp_path):
    pts, labels = cloud(200)
    sections = [
        ReportSection("one", layers=[PointsLayer(pts, {"l": labels})], links=["a.ply"]),
        ReportSection("two", tables={"t": [{"x": 1.5}]}),
    ]
    text = write_report(
        tmp_path / "r.html", title="t", summary={}, parameters={}, sections=sections
    ).read_text()
    assert "<a href='#section-1'>one</a>" in text and "<a href='#section-2'>two</a>" in text
    assert text.count("class='pa-view'") == 1 and "<a href='a.ply'>" in text


@pytest.fixture
def cube_file(tmp_path):
    mesh = cube(4)
    path = tmp_path / "cube.ply"
    write_point_set(path, mesh.vertices, normals=mesh.normals, attributes={"faces": mesh.labels})
    return path


def test_segment_report_is_named_in_the_summary_and_shows_its_numbers(cube_file, tmp_path):
    out, report = tmp_path / "seg.ply", tmp_path / "seg.html"
    res = runner.invoke(
        app, ["segment", str(cube_file), str(out), "--eta", "10", "--report", str(report)]
    )
    assert res.exit_code == 0, res.output
    summary = json.loads((tmp_path / "seg_regions.json").read_text())
    record = next(f for f in summary["files"] if f["path"] == "seg.html")
    assert record["sha256"] == hashlib.sha256(report.read_bytes()).hexdigest()
    text = report.read_text()
    for row in summary["regions"]:
        for value in row.values():
            assert f"data-value='{json.dumps(value)}'" in text
    assert f"data-value='{summary['summary']['energy']!r}'" in text
    data = view_payloads(text)[0]
    names = [f["name"] for f in data["points"]["fields"]]
    assert names[0] == "label" and "input faces" not in names and "faces" in names
    assert data["points"]["initial_field"] == "label"


@pytest.mark.parametrize("command", ["segment", "features", "normals"])
def test_bad_report_path_fails_before_any_work(cube_file, tmp_path, command):
    out = tmp_path / "out.ply"
    for bad, message in ((tmp_path / "r.pdf", ".html"), (tmp_path / "no" / "r.html", "folder")):
        res = runner.invoke(app, [command, str(cube_file), str(out), "--report", str(bad)])
        assert res.exit_code == 1 and message in res.output, res.output
        assert not out.exists()


@pytest.mark.parametrize("command", ["features", "normals"])
def test_features_and_normals_reports_hold_their_fields(cube_file, tmp_path, command):
    report = tmp_path / "r.html"
    res = runner.invoke(
        app, [command, str(cube_file), str(tmp_path / "o.ply"), "--report", str(report)]
    )
    assert res.exit_code == 0, res.output
    text = report.read_text()
    names = [f["name"] for f in view_payloads(text)[0]["points"]["fields"]]
    expected = {"features": {"e_dim", "dimension_class", "k"}, "normals": {"nx", "ny", "nz"}}
    assert expected[command] <= set(names)
    assert html.escape(f"pointatlas {command}: cube.ply") in text


@pytest.mark.parametrize("vertices_only", [False, True], ids=["mesh path", "points path"])
def test_simplify_report_shows_its_numbers_and_the_mesh(tmp_path, vertices_only):
    from pointatlas.io import read_mesh

    out, report = tmp_path / "c.obj", tmp_path / "c.html"
    extra = ["--vertices-only", "--max-angle-deg", "20"] if vertices_only else []
    res = runner.invoke(app, ["simplify", "synth:cube", str(out), "--report", str(report), *extra])
    assert res.exit_code == 0, res.output
    text = report.read_text()
    mesh = read_mesh(out)
    assert f"data-value='{mesh.n_faces}'" in text  # n_faces in the result table
    data = view_payloads(text)[0]
    assert data["meshes"], "the view holds the simplified mesh"
    assert html.escape("pointatlas simplify: synth:cube") in text


def test_cloudsurface_report_shows_the_clouds_and_the_complex(tmp_path):
    out, report = tmp_path / "cs", tmp_path / "cs.html"
    res = runner.invoke(
        app, ["cloudsurface", "synth:sphere", str(out), "--scale", "0.9", "--report", str(report)]
    )
    assert res.exit_code == 0, res.output
    summary = json.loads((out / "report.json").read_text())
    assert any(f["path"].endswith("cs.html") for f in summary["files"])
    text = report.read_text()
    data = view_payloads(text)[0]
    assert [f["name"] for f in data["points"]["fields"]] == ["n_clouds"]
    assert data["meshes"]
    assert f"data-value='{summary['n_clouds']}'" in text


def test_denoise_report_shows_result_input_and_measures(tmp_path):
    from pointatlas import data
    from pointatlas.io import write_mesh

    clean = write_mesh(tmp_path / "cube.obj", data.load_mesh("synth:cube"))
    out, report = tmp_path / "d.ply", tmp_path / "d.html"
    res = runner.invoke(
        app, ["denoise", "synth:cube", str(out), "--clean", str(clean), "--report", str(report)]
    )
    assert res.exit_code == 0, res.output
    summary = json.loads((tmp_path / "d_denoise.json").read_text())
    assert any(f["path"] == "d.html" for f in summary["files"])
    text = report.read_text()
    views = view_payloads(text)
    assert len(views) == 2  # the result, then the input
    assert "displacement" in [f["name"] for f in views[0]["points"]["fields"]]
    chamfer = summary["measures_denoised"]["chamfer"]
    assert f"data-value='{chamfer!r}'" in text
