"""Reports in a real browser: headless Chromium (Debian's) driven by Playwright.

The viewer draws with WebGL (SwiftShader in headless Chromium); each test opens a
generated report from a local file, waits for ``window.pointatlasReady`` and
checks what a person would: pixels drawn, colours that follow the field switch,
the values of a clicked point, the numbers of the JSON result, no console error.
"""

from __future__ import annotations

import io
import json
import math
import os
import shutil
import tempfile

import numpy as np
import pytest
from PIL import Image
from typer.testing import CliRunner

from pointatlas.cli import app
from pointatlas.io import write_point_set
from pointatlas.synth import cube
from pointatlas.viz import MeshLayer, PointsLayer, write_report

sync_api = pytest.importorskip(
    "playwright.sync_api", reason="playwright is not installed (pip install -e '.[dev]')"
)

#: Flags known to work here: no sandbox as root, no network chatter (closed network).
CHROMIUM_FLAGS = [
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
]
#: Parent of the browser's own TMPDIR: Chromium binds its singleton socket under
#: TMPDIR and in its profile folder, and a unix socket path holds at most 107 bytes,
#: so a long TMPDIR (a CI runner's, a nested sandbox's) makes the launch fail.
SHORT_TMP_PARENT = "/tmp"
#: Generous: a loaded 2-core machine renders with SwiftShader on the CPU.
TIMEOUT_MS = 60_000
WHITE = np.array([255, 255, 255])
N_POINTS = 1538  # synth cube(16): shown subsampled to MAX_SHOWN
MAX_SHOWN = 1000


def find_chromium() -> str | None:
    for candidate in (os.environ.get("POINTATLAS_CHROMIUM"), "/usr/bin/chromium"):
        if candidate and os.access(candidate, os.X_OK):
            return candidate
    return shutil.which("chromium") or shutil.which("chromium-browser")


@pytest.fixture(scope="module")
def short_tmpdir():
    """A fresh folder with a short path for the browser's temporary files, removed after."""
    try:
        folder = tempfile.mkdtemp(prefix="pa-chromium-", dir=SHORT_TMP_PARENT)
    except OSError as exc:
        pytest.skip(
            reason=f"Chromium needs a short TMPDIR for its socket; cannot create one in "
            f"{SHORT_TMP_PARENT} ({exc.strerror})"
        )
    yield folder
    shutil.rmtree(folder, ignore_errors=True)


@pytest.fixture(scope="module")
def browser(short_tmpdir):
    path = find_chromium()
    if path is None:
        pytest.skip(
            reason="no Chromium found (install Debian's chromium: apt-get install chromium)"
        )
    # the driver makes the profile folder in its TMPDIR, the browser its socket folder
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("TMPDIR", short_tmpdir)
        pw = sync_api.sync_playwright().start()
        env = dict(os.environ)
    try:
        b = pw.chromium.launch(
            executable_path=path, args=CHROMIUM_FLAGS, timeout=TIMEOUT_MS, env=env
        )
        yield b
        b.close()
    finally:
        pw.stop()


class Page:
    """A report opened in a new page, with its console errors collected."""

    def __init__(self, browser, path):
        self.page = browser.new_page(viewport={"width": 1200, "height": 900})
        self.page.set_default_timeout(TIMEOUT_MS)
        self.errors: list[str] = []
        self.page.on("console", lambda m: self.errors.append(m.text) if m.type == "error" else None)
        self.page.on("pageerror", lambda e: self.errors.append(str(e)))
        self.page.goto(path.as_uri())
        self.page.wait_for_function("window.pointatlasReady === true")

    def canvas_pixels(self, view=0) -> np.ndarray:
        canvas = self.page.locator(".pa-canvas canvas").nth(view)
        image = Image.open(io.BytesIO(canvas.screenshot())).convert("RGB")
        return np.asarray(image, int)[2:-2, 2:-2]  # off the frame's border


@pytest.fixture
def open_report(browser):
    pages = []

    def opener(path):
        pages.append(Page(browser, path))
        return pages[-1]

    yield opener
    for p in pages:
        p.page.close()


@pytest.fixture(scope="module")
def cube_report(tmp_path_factory):
    """A cube cloud (subsampled for the view) with a label and a scalar field, and its mesh."""
    mesh = cube(16)
    assert mesh.n_vertices == N_POINTS
    pts = mesh.vertices
    fields = {"face": mesh.labels, "x": pts[:, 0] * 3.0 + 0.125}
    path = tmp_path_factory.mktemp("report") / "cube.html"
    write_report(
        path,
        title="cube",
        summary={"points": N_POINTS},
        parameters={"k": 8},
        seed=7,
        max_view_points=MAX_SHOWN,
        layers=[PointsLayer(pts, fields), MeshLayer(mesh.vertices, mesh.faces, opacity=0.4)],
    )
    return path, pts, fields


def drawn(pixels: np.ndarray) -> np.ndarray:
    """Mask of pixels that are not the white background."""
    return np.abs(pixels - WHITE).sum(axis=2) > 30


def test_canvas_draws_and_field_switch_changes_colours(open_report, cube_report):
    path, _, _ = cube_report
    page = open_report(path)
    assert page.page.evaluate("document.querySelector('.pa-view').dataset.ready") == "1"
    before = page.canvas_pixels()
    mask = drawn(before)
    assert mask.mean() > 0.05  # the cube covers a good part of the canvas
    assert len(np.unique(before[mask], axis=0)) > 20  # shaded mesh and coloured points
    assert page.page.locator(".pa-legend").inner_text().startswith("face")
    page.page.select_option(".pa-field", "x")
    page.page.wait_for_function("document.querySelector('.pa-legend-title').textContent === 'x'")
    after = page.canvas_pixels()
    changed = np.abs(after - before).sum(axis=2) > 30
    assert changed.sum() > 200  # the points took the colours of the other field
    assert (changed & ~mask).sum() == 0  # nothing is drawn where nothing was
    assert page.page.locator(".pa-colorbar").count() == 1
    assert page.errors == []


def test_clicking_a_point_shows_its_index_and_values(open_report, cube_report):
    path, pts, fields = cube_report
    page = open_report(path)
    # the shown point nearest to the camera: nothing can hide it
    target = page.page.evaluate(
        """() => {
          const v = window.pointatlasViews[0];
          let best = null;
          for (let k = 0; k < v.indices.length; k++) {
            const s = v.screenPosition(k);
            if (s.visible && (best === null || s.z < best.z)) best = {...s, k};
          }
          return best;
        }"""
    )
    page.page.mouse.click(target["x"], target["y"])
    cell = page.page.locator(".pa-pick td[data-field='index']")
    cell.wait_for()
    index = int(cell.inner_text())
    shown = page.page.evaluate("Array.from(window.pointatlasViews[0].indices)")
    assert len(shown) == MAX_SHOWN and index in shown
    # the picked point lies under the cursor (within the pick radius)
    k = shown.index(index)
    where = page.page.evaluate(f"window.pointatlasViews[0].screenPosition({k})")
    assert math.hypot(where["x"] - target["x"], where["y"] - target["y"]) <= 7
    values = {
        name: page.page.locator(f".pa-pick td[data-field='{name}']").inner_text()
        for name in ("face", "x", "x, y, z")
    }
    assert int(values["face"]) == fields["face"][index]
    assert float(values["x"]) == pytest.approx(fields["x"][index], rel=1e-5, abs=1e-6)
    xyz = [float(c) for c in values["x, y, z"].split(",")]
    np.testing.assert_allclose(xyz, pts[index], rtol=1e-5, atol=1e-6)
    assert page.errors == []


def test_segment_report_tables_show_the_json_numbers(open_report, tmp_path):
    mesh = cube(4)
    src = tmp_path / "cube.ply"
    write_point_set(src, mesh.vertices, normals=mesh.normals)
    report = tmp_path / "seg.html"
    args = ["segment", str(src), str(tmp_path / "seg.ply"), "--eta", "10"]
    res = CliRunner().invoke(app, [*args, "--report", str(report)])
    assert res.exit_code == 0, res.output
    result = json.loads((tmp_path / "seg_regions.json").read_text())
    page = open_report(report)
    rows = page.page.evaluate(
        """() => Array.from(
             document.querySelectorAll("table[data-table='regions'] tbody tr"),
             tr => Array.from(tr.querySelectorAll('td'), td => [td.dataset.value, td.innerText]))"""
    )
    assert len(rows) == len(result["regions"]) == result["summary"]["n_regions"]
    for row, expected in zip(rows, result["regions"], strict=True):
        assert len(row) == len(expected)
        for (value, text), want in zip(row, expected.values(), strict=True):
            assert json.loads(value) == want
            assert float(text.replace(",", "")) == pytest.approx(want, rel=1e-5, abs=1e-9)
    summary = page.page.evaluate(
        """() => Object.fromEntries(Array.from(
             document.querySelectorAll("table[data-table='result'] tr"),
             tr => [tr.querySelector('th').innerText, tr.querySelector('td').innerText]))"""
    )
    for key in ("n_regions", "energy", "mse", "n_iter"):
        want = result["summary"][key]
        assert float(summary[key].replace(",", "")) == pytest.approx(want, rel=1e-5)
    # every region's legend colour is drawn: points show exactly their label's colour
    swatches = page.page.evaluate(
        "Array.from(document.querySelectorAll('.pa-legend .pa-swatch'), "
        "s => getComputedStyle(s).backgroundColor)"
    )
    assert len(swatches) == result["summary"]["n_regions"]
    pixels = page.canvas_pixels()
    colours = {tuple(c) for c in pixels[drawn(pixels)].tolist()}
    for swatch in swatches:
        rgb = tuple(int(c) for c in swatch[swatch.index("(") + 1 : -1].split(","))
        assert rgb in colours
    assert page.errors == []


def test_demo_report_has_a_working_view_per_step(open_report, tmp_path):
    from pointatlas.cli._cmd_core import run_demo, select_steps

    run_demo(tmp_path, model="synth:cube", steps=select_steps("info,normals"))
    page = open_report(tmp_path / "report.html")
    states = page.page.evaluate(
        "Array.from(document.querySelectorAll('.pa-view'), v => v.dataset.ready)"
    )
    assert states == ["1", "1"]
    for view in range(2):
        assert drawn(page.canvas_pixels(view)).mean() > 0.005
    fields = page.page.locator(".pa-field").nth(1).locator("option").all_inner_texts()
    assert "normal_error_deg" in fields
    assert page.errors == []


def test_info_report_shows_components_in_the_legend_and_the_json_numbers(open_report, tmp_path):
    # two far-apart grids: two k-NN components, each a legend entry with its colour drawn
    g = np.stack(np.meshgrid(*[np.arange(4.0)] * 3, indexing="ij"), -1).reshape(-1, 3)
    src = tmp_path / "two.ply"
    write_point_set(src, np.concatenate([g, g[:27] * 0.5 + 50.0]))
    report = tmp_path / "info.html"
    res = CliRunner().invoke(app, ["info", str(src), "--json", "--report", str(report)])
    assert res.exit_code == 0, res.output
    info = json.loads(res.stdout)
    page = open_report(report)
    result = page.page.evaluate(
        """() => Object.fromEntries(Array.from(
             document.querySelectorAll("table[data-table='result'] tr"),
             tr => [tr.querySelector('th').innerText, tr.querySelector('td').dataset.value]))"""
    )
    for key in ("points", "knn_components", "largest_component", "mean_spacing"):
        assert json.loads(result[key]) == info[key]
    swatches = page.page.evaluate(
        "Array.from(document.querySelectorAll('.pa-legend .pa-swatch'), "
        "s => getComputedStyle(s).backgroundColor)"
    )
    assert len(swatches) == info["knn_components"] == 2
    pixels = page.canvas_pixels()
    colours = {tuple(c) for c in pixels[drawn(pixels)].tolist()}
    for swatch in swatches:
        assert tuple(int(c) for c in swatch[swatch.index("(") + 1 : -1].split(",")) in colours
    page.page.select_option(".pa-field", "spacing")
    page.page.wait_for_function(
        "document.querySelector('.pa-legend-title').textContent === 'spacing'"
    )
    assert page.page.locator(".pa-colorbar").count() == 1
    assert page.errors == []
