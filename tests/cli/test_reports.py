"""``--report`` of ``info``, ``deform`` and the ``experiment`` commands: one self-contained
HTML file per run that carries the run's numbers and, where the command has points, a 3-D
view of them."""

from __future__ import annotations

import base64
import json
import re

import numpy as np
import pytest

from pointatlas.io import write_point_set

from .helpers import run

#: every command that computes something and writes no other report
REPORT_COMMANDS = {
    "info": ["{ply}"],
    "deform": ["{tmp}/no-surface", "{ply}", "{tmp}/moved.ply"],
    "experiment vsa": ["--models", "{tmp}"],
    "experiment neighbourhoods": ["--models", "{tmp}"],
    "experiment simplify": [],
    "experiment denoise": [],
    "experiment cloudsurfaces": [],
}


def view_payloads(text: str) -> list[dict]:
    """The JSON data of every 3-D view of a report."""
    found = re.findall(r"<script type='application/json' class='pa-data'>(.*?)</script>", text)
    return [json.loads(s.replace("<\\/", "</")) for s in found]


def decode(b64: str, dtype: str) -> np.ndarray:
    return np.frombuffer(base64.b64decode(b64), dtype=np.dtype(dtype).newbyteorder("<"))


def assert_self_contained(text: str) -> None:
    """Nothing is fetched when the page opens: no remote source, pictures embedded."""
    assert re.search(r"(src|href)=['\"]?(https?:)?//", text) is None
    assert all(
        s.startswith("data:image/png;base64,") for s in re.findall(r"<img src='([^']+)'", text)
    )
    assert text.count("<script>") == 1  # the inlined viewer


def shows(text: str, number) -> bool:
    """The page holds ``number`` exactly, as a table cell's value."""
    return f"data-value='{json.dumps(number)}'" in text


def point_fields(view: dict) -> dict:
    """The point fields of a view, decoded (float32 / int32 as the viewer gets them)."""
    out = {}
    for f in view["points"]["fields"]:
        out[f["name"]] = decode(f["values"], "i4" if f["kind"] == "labels" else "f4")
    return out


@pytest.fixture
def ply(tmp_path):
    path = tmp_path / "in.ply"
    write_point_set(path, np.zeros((4, 3)) + np.arange(4)[:, None])
    return path


@pytest.mark.parametrize("command", sorted(REPORT_COMMANDS))
def test_bad_report_path_fails_before_any_work(command, tmp_path, ply):
    args = [a.format(ply=ply, tmp=tmp_path) for a in REPORT_COMMANDS[command]]
    if command.startswith("experiment"):
        args += ["--out", str(tmp_path / "out")]
    for bad, message in ((tmp_path / "r.pdf", ".html"), (tmp_path / "no" / "r.html", "folder")):
        result = run(*command.split(), *args, "--report", bad)
        assert result.exit_code == 1, result.output
        assert message in result.stderr and len(result.stderr.strip().splitlines()) == 1
        assert not (tmp_path / "out").exists() and not (tmp_path / "moved.ply").exists()


# --------------------------------------------------------------------------- info


def two_clusters():
    """A 5 x 5 x 5 grid (spacing 1) and a 3 x 3 x 3 grid (spacing 0.5) far apart."""
    g5 = np.stack(np.meshgrid(*[np.arange(5.0)] * 3, indexing="ij"), -1).reshape(-1, 3)
    g3 = np.stack(np.meshgrid(*[np.arange(3.0) * 0.5] * 3, indexing="ij"), -1).reshape(-1, 3)
    return np.concatenate([g3 + 100.0, g5])  # the small cluster first


def test_info_report_carries_the_json_numbers_and_colours_by_component(tmp_path):
    pts = two_clusters()
    src = tmp_path / "two.ply"
    intensity = np.arange(len(pts), dtype=np.float64)
    write_point_set(src, pts, attributes={"intensity": intensity})
    report = tmp_path / "info.html"
    result = run("info", src, "--json", "--report", report)
    assert result.exit_code == 0, result.output
    info = json.loads(result.stdout)  # stdout stays pure JSON; "wrote" goes to stderr
    assert f"wrote {report}" in result.stderr
    assert info["knn_components"] == 2 and info["largest_component"] == 125
    text = report.read_text()
    assert_self_contained(text)
    for key in ("points", "knn_components", "largest_component", "mean_spacing", "duplicates"):
        assert shows(text, info[key]), key
    assert "intensity" in text  # the attributes table
    fields = point_fields(view_payloads(text)[0])
    assert list(fields)[:2] == ["knn_component", "spacing"] and "intensity" in fields
    # component 0 is the largest (the 125-point grid), whatever the input order
    np.testing.assert_array_equal(fields["knn_component"], np.repeat([1, 0], [27, 125]))
    # spacing: each point's mean distance to its 12 nearest; its mean is l
    from scipy.spatial import cKDTree

    dist, _ = cKDTree(pts).query(pts, 13)
    np.testing.assert_allclose(fields["spacing"], dist[:, 1:].mean(axis=1), rtol=1e-6)
    assert np.mean(dist[:, 1:].mean(axis=1)) == pytest.approx(info["mean_spacing"], rel=1e-12)


# --------------------------------------------------------------------------- deform


def test_deform_report_shows_routes_displacements_and_the_moved_complex(tmp_path):
    import hashlib

    from pointatlas.io import read_mesh, write_mesh

    surface = tmp_path / "hand"
    result = run(
        "cloudsurface",
        "--from-mesh",
        "hand",
        surface,
        "--density",
        "eta2",
        "--density-c",
        "1",
        "--samples",
        "3",
        "--no-render",
    )
    assert result.exit_code == 0, result.output
    complex_mesh = read_mesh(surface / "complex.ply")
    new_cp = complex_mesh.vertices * 1.5 + 0.1
    write_mesh(tmp_path / "new.ply", new_cp, complex_mesh.triangles)
    out, report = tmp_path / "moved.ply", tmp_path / "moved.html"
    result = run("deform", surface, tmp_path / "new.ply", out, "--report", report)
    assert result.exit_code == 0, result.output
    summary = json.loads((tmp_path / "moved.json").read_text())
    record = next(f for f in summary["files"] if f["path"] == "moved.html")
    assert record["sha256"] == hashlib.sha256(report.read_bytes()).hexdigest()
    text = report.read_text()
    assert_self_contained(text)
    for key, n in summary["routes"].items():
        assert f"routes: {key}" in text and shows(text, n)
    assert shows(text, summary["n_points"])
    # the view: the moved points, first coloured by their displacement
    view = view_payloads(text)[0]
    assert view["points"]["initial_field"] == "displacement"
    before = np.load(surface / "cloudsurface.npz")["points"]
    from pointatlas.io import read_point_set

    moved = read_point_set(out).points
    displacement = np.linalg.norm(moved - before, axis=1)
    fields = point_fields(view)
    np.testing.assert_allclose(fields["displacement"], displacement, rtol=1e-6)
    assert shows(text, float(displacement.max()))
    # and the complex at the new cloud points as a surface
    mesh = view["meshes"][0]
    assert decode(mesh["triangles"], "u4").size == complex_mesh.triangles.size


# --------------------------------------------------------------------------- experiments


def test_experiment_report_embeds_the_pictures_and_carries_the_json_numbers(tmp_path):
    out = tmp_path / "s"
    report = out / "report.html"  # inside the folder the run creates
    result = run(
        "experiment", "simplify", "--case", "dodecahedron", "--out", out, "--report", report
    )
    assert result.exit_code == 0, result.output
    assert f"wrote {report}" in result.stdout
    text = report.read_text()
    assert_self_contained(text)
    pngs = sorted(out.glob("*.png"))
    assert pngs
    embedded = re.findall(r"<img src='data:image/png;base64,([^']+)'", text)
    assert sorted(base64.b64decode(b) for b in embedded) == sorted(p.read_bytes() for p in pngs)
    rows = json.loads((out / "results.json").read_text())
    numbers = [
        v
        for row in rows
        for v in row.values()
        if isinstance(v, int | float) and not isinstance(v, bool)
    ]
    assert len(numbers) > 10
    for value in numbers:
        assert shows(text, value), value
    for row in rows:  # each region table of each mesh
        for region in row["regions_report"]:
            assert shows(text, region["n_points"])
    assert "results.md" in text  # listed with the other files


def test_info_takes_a_bundled_model_name_like_the_other_commands(tmp_path):
    from pointatlas import data

    report = tmp_path / "cube.html"
    result = run("info", "synth:cube", "--json", "--report", report)
    assert result.exit_code == 0, result.output
    info = json.loads(result.stdout)
    mesh = data.load_mesh("synth:cube")
    assert (info["points"], info["faces"]) == (mesh.n_vertices, mesh.n_faces) == (386, 768)
    assert info["normals"] and info["face_kind"] == "triangles"
    assert shows(report.read_text(), 768)
