"""Pictures: sizes, colours, depth order, NaN, atomic writes, degenerate inputs."""

from __future__ import annotations

import numpy as np
import pytest
from PIL import Image

from pointatlas.viz import (
    Camera,
    MeshPanel,
    PointsPanel,
    fit_camera,
    label_colors,
    render_mesh,
    render_mesh_array,
    render_points,
    render_points_array,
    render_side_by_side,
    scalar_colors,
)

WHITE = np.array([255, 255, 255])


def sphere(n=2000, seed=0):
    """Uniform sample of the unit sphere; normals = positions."""
    rng = np.random.default_rng(seed)
    p = rng.normal(size=(n, 3))
    return p / np.linalg.norm(p, axis=1, keepdims=True)


def cube_quads():
    """The unit cube as 6 quads (polygon mesh)."""
    v = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)], dtype=float)
    faces = [[0, 1, 3, 2], [4, 6, 7, 5], [0, 4, 5, 1], [2, 3, 7, 6], [0, 2, 6, 4], [1, 5, 7, 3]]
    return v, faces


def square_facing(camera, offset, n=41):
    """A grid square orthogonal to the view, ``offset`` along the eye direction."""
    right, up, eye = camera.basis()
    s = np.linspace(-0.5, 0.5, n)
    a, b = np.meshgrid(s, s)
    return camera.center + offset * eye + a.reshape(-1, 1) * right + b.reshape(-1, 1) * up


def distinct_colors(rgb):
    flat = rgb.reshape(-1, 3)
    flat = flat[(flat != WHITE).any(axis=1)]
    return np.unique(flat, axis=0)


def read_png(path):
    with Image.open(path) as im:
        return np.asarray(im.convert("RGB"))


# ------------------------------------------------------------------ files


def test_render_points_writes_png_of_requested_size(tmp_path):
    pts = sphere()
    out = render_points(tmp_path / "s.png", pts, normals=pts, title="sphere", size=(320, 240))
    assert out == tmp_path / "s.png"
    img = read_png(out)
    assert img.shape == (240, 320, 3)
    # not blank: many shades from the Lambert shading
    assert len(distinct_colors(img)) > 50
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s.png"]  # no temp left


def test_render_is_deterministic(tmp_path):
    pts = sphere(500)
    a = render_points(tmp_path / "a.png", pts, labels=np.arange(500) % 7, size=(200, 200))
    b = render_points(tmp_path / "b.png", pts, labels=np.arange(500) % 7, size=(200, 200))
    assert a.read_bytes() == b.read_bytes()


def test_failed_write_leaves_old_file_and_no_temp(tmp_path, monkeypatch):
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    out = tmp_path / "keep.png"
    out.write_bytes(b"old")

    def boom(self, *args, **kwargs):
        raise OSError("disk full")

    monkeypatch.setattr(FigureCanvasAgg, "print_png", boom)
    with pytest.raises(OSError, match="disk full"):
        render_points(out, sphere(100), size=(100, 100))
    assert out.read_bytes() == b"old"
    assert [p.name for p in tmp_path.iterdir()] == ["keep.png"]


def test_bad_paths(tmp_path):
    with pytest.raises(ValueError, match=r"\.png"):
        render_points(tmp_path / "x.jpg", sphere(10))
    with pytest.raises(FileNotFoundError, match="folder"):
        render_points(tmp_path / "missing" / "x.png", sphere(10))


# ------------------------------------------------------------------ colours


def test_labels_give_distinct_colors():
    pts = sphere(3000)
    labels = (pts[:, 0] > 0) * 1 + (pts[:, 1] > 0) * 2 + (pts[:, 2] > 0) * 4  # 8 octants
    rgb = render_points_array(pts, labels=labels, lighting=False, size=(200, 200))
    colors = distinct_colors(rgb)
    assert len(colors) >= 5  # the octants facing the viewer (at least 5 of 8)
    expected = np.round(label_colors(np.arange(8)) * 255).astype(np.uint8)
    # every drawn colour is one of the label colours (flat, no shading)
    assert all((expected == c).all(axis=1).any() for c in colors)


def test_label_palette_neighbours_differ():
    c = label_colors(np.arange(400))
    step = np.linalg.norm(np.diff(c, axis=0), axis=1)
    assert step.min() > 0.25  # consecutive ids are never look-alikes
    assert len(np.unique(np.round(c, 6), axis=0)) == 400
    assert np.allclose(label_colors([-1, -5]), 0.62)
    assert np.array_equal(label_colors([3, 3]), label_colors([3, 3])[::-1])


def test_nan_scalars_are_grey_and_counted(tmp_path):
    pts = sphere(2000)
    values = pts[:, 2].copy()
    values[pts[:, 0] > 0] = np.nan
    _, legend = scalar_colors(values, name="height")
    assert legend.n_nan == int((pts[:, 0] > 0).sum())
    assert legend.label() == f"height ({legend.n_nan} NaN, grey)"
    all_nan = np.full(pts.shape[0], np.nan)
    rgb = render_points_array(pts, scalars=all_nan, lighting=False, size=(120, 120))
    colors = distinct_colors(rgb)
    assert colors.tolist() == [[158, 158, 158]]
    out = render_points(tmp_path / "nan.png", pts, scalars=values, scalar_name="height")
    assert read_png(out).shape == (1024, 1024, 3)


def test_scalar_errors():
    with pytest.raises(ValueError, match="cmap"):
        scalar_colors([0.0, 1.0], cmap="no-such-map")
    with pytest.raises(ValueError, match="Inf"):
        scalar_colors([0.0, np.inf])
    with pytest.raises(ValueError, match="shape"):
        render_points_array(sphere(10), scalars=np.zeros(9))
    with pytest.raises(ValueError, match="not both"):
        render_points_array(sphere(10), scalars=np.zeros(10), labels=np.zeros(10, int))
    with pytest.raises(ValueError, match="colors must"):
        render_points_array(sphere(10), colors=np.full((10, 3), 2.0))


def test_explicit_colors_and_csr_faces():
    pts = sphere(500)
    red = np.tile(np.array([[255, 0, 0]], dtype=np.uint8), (500, 1))
    rgb = render_points_array(pts, colors=red, lighting=False, size=(64, 64))
    assert distinct_colors(rgb).tolist() == [[255, 0, 0]]
    v, faces = cube_quads()
    flat = np.concatenate(faces)
    offsets = np.arange(7) * 4
    a = render_mesh_array(v, flat, face_offsets=offsets, size=(64, 64))
    b = render_mesh_array(v, faces, size=(64, 64))
    assert np.array_equal(a, b)
    with pytest.raises(ValueError, match="face_offsets"):
        render_mesh_array(v, flat, face_offsets=[0, 4, 30])


# ------------------------------------------------------------------ geometry


@pytest.mark.parametrize("near_first", [True, False])
def test_points_depth_order_near_square_wins(near_first):
    camera = fit_camera(np.eye(3))
    near = square_facing(camera, +0.5)
    far = square_facing(camera, -0.5)
    pts = np.vstack([near, far] if near_first else [far, near])
    red_blue = np.r_[np.ones(len(near)), np.zeros(len(far))]
    values = red_blue if near_first else red_blue[::-1]
    rgb = render_points_array(
        pts, scalars=values, cmap="bwr", lighting=False, size=(101, 101), view=camera
    )
    r, g, b = rgb[50, 50].astype(int)
    assert r > 200 and b < 60, rgb[50, 50]


@pytest.mark.parametrize("near_first", [True, False])
def test_mesh_depth_order_near_quad_wins(near_first):
    camera = fit_camera(np.eye(3))
    quads = []
    for offset in (+0.5, -0.5) if near_first else (-0.5, +0.5):
        right, up, eye = camera.basis()
        c = camera.center + offset * eye
        quads.append(
            [
                c + sx * 0.5 * right + sy * 0.5 * up
                for sx, sy in ((-1, -1), (1, -1), (1, 1), (-1, 1))
            ]
        )
    verts = np.array(quads).reshape(-1, 3)
    faces = [[0, 1, 2, 3], [4, 5, 6, 7]]
    colors = [[1.0, 0.0, 0.0], [0.0, 0.0, 1.0]] if near_first else [[0, 0, 1.0], [1.0, 0, 0]]
    rgb = render_mesh_array(
        verts, faces, face_colors=colors, lighting=False, edges=False, view=camera, size=(101, 101)
    )
    assert rgb[50, 50].tolist() == [255, 0, 0]


def test_polygon_outline_not_triangle_diagonal():
    fitted = fit_camera(np.eye(3))
    camera = Camera(  # zoomed out: the unit quad spans the middle half of the image
        center=fitted.center,
        radius=2.2 * fitted.radius,
        azimuth=fitted.azimuth,
        elevation=fitted.elevation,
        up=fitted.up,
    )
    right, up, eye = camera.basis()
    corners = np.array(
        [camera.center + sx * right + sy * up for sx, sy in ((-1, -1), (1, -1), (1, 1), (-1, 1))]
    )
    quad = render_mesh_array(corners, [[0, 1, 2, 3]], lighting=False, view=camera, size=(81, 81))
    tris = render_mesh_array(
        corners, [[0, 1, 2], [0, 2, 3]], lighting=False, view=camera, size=(81, 81)
    )
    # the centre lies on the diagonal: face colour for the quad, edge ink for triangles
    assert quad[40, 40].min() > 150
    assert tris[40, 40].max() < 120
    # the quad's own outline is drawn: a dark ring around the face colour
    row = quad[40, :, 0].astype(int)
    face = row[40]
    assert row[0] == 255 and row.min() < face - 50
    assert (row < face - 20).sum() <= 6  # only the two borders, not the interior


def test_polygon_mesh_ragged_faces_and_labels(tmp_path):
    v, faces = cube_quads()
    # split one quad into two triangles: faces of mixed size
    faces = faces[:-1] + [[1, 5, 7], [1, 7, 3]]
    out = render_mesh(tmp_path / "cube.png", v, faces, face_labels=np.arange(7), size=(300, 300))
    img = read_png(out)
    assert img.shape == (300, 300, 3)
    assert len(distinct_colors(img)) > 20


def test_mesh_errors():
    v, faces = cube_quads()
    with pytest.raises(ValueError, match="out-of-range"):
        render_mesh_array(v, [[0, 1, 99]])
    with pytest.raises(ValueError, match="at least 3"):
        render_mesh_array(v, [[0, 1]])
    with pytest.raises(ValueError, match="at least 1 face"):
        render_mesh_array(v, [])
    with pytest.raises(ValueError, match="face_colors"):
        render_mesh_array(v, faces, face_colors=np.zeros((2, 3)))


def test_points_and_mesh_share_the_camera():
    v, faces = cube_quads()
    # dense sample of the cube surface, so the point picture has the cube's outline
    g = np.linspace(0, 1, 25)
    a, b = (x.ravel() for x in np.meshgrid(g, g))
    zero, one = np.zeros_like(a), np.ones_like(a)
    pts = np.vstack(
        [
            np.c_[a, b, zero],
            np.c_[a, b, one],
            np.c_[a, zero, b],
            np.c_[a, one, b],
            np.c_[zero, a, b],
            np.c_[one, a, b],
        ]
    )
    normals = np.repeat(
        np.array([[0, 0, 1], [0, 0, 1], [0, 1, 0], [0, 1, 0], [1, 0, 0], [1, 0, 0]]), a.size, axis=0
    )
    cam = fit_camera(np.vstack([v, pts]))
    p_img = render_points_array(pts, normals=normals, view=cam, size=(200, 200))
    m_img = render_mesh_array(v, faces, view=cam, size=(200, 200))
    p_mask = (p_img != 255).any(axis=2)
    m_mask = (m_img != 255).any(axis=2)
    iou = (p_mask & m_mask).sum() / (p_mask | m_mask).sum()
    assert iou > 0.9


def test_fit_camera_frames_any_pose():
    rng = np.random.default_rng(3)
    pts = sphere(500) * [3.0, 1.0, 0.2] @ np.linalg.qr(rng.normal(size=(3, 3)))[0] + 100.0
    cam = fit_camera(pts)
    x, y, _ = cam.project(pts, 300, 200)
    assert x.min() >= 0 and x.max() <= 300 and y.min() >= 0 and y.max() <= 200
    # it fills the frame: the projected extent uses most of the smaller side
    assert max(x.max() - x.min(), y.max() - y.min()) > 0.9 * 200
    right, up, eye = cam.basis()
    assert np.allclose(np.c_[right, up, eye].T @ np.c_[right, up, eye], np.eye(3))
    assert np.isclose(np.linalg.det(np.c_[right, up, eye]), 1.0)


def test_camera_validation():
    with pytest.raises(ValueError, match="radius"):
        Camera(center=[0, 0, 0], radius=0.0)
    with pytest.raises(TypeError, match="view"):
        render_points_array(sphere(10), view="top")
    with pytest.raises(ValueError, match="size"):
        render_points_array(sphere(10), size=(8, 8))


# ------------------------------------------------------------------ degenerate


def test_empty_input_is_a_clear_error(tmp_path):
    with pytest.raises(ValueError, match="at least 1"):
        render_points(tmp_path / "e.png", np.zeros((0, 3)))
    assert list(tmp_path.iterdir()) == []


def test_single_point_draws_a_centred_dot():
    rgb = render_points_array([[1.0, 2.0, 3.0]], size=(101, 101))
    mask = (rgb != 255).any(axis=2)
    assert mask[50, 50]
    assert 1 < mask.sum() < 101 * 101 / 4


def test_side_by_side(tmp_path):
    pts = sphere(800)
    v, faces = cube_quads()
    pre = render_points_array(pts, size=(64, 48))
    out = render_side_by_side(
        tmp_path / "sbs.png",
        [
            PointsPanel(pts, labels=(pts[:, 2] > 0).astype(int), title="segments"),
            MeshPanel(v, faces, title="mesh"),
            PointsPanel(pts, scalars=pts[:, 0], scalar_name="x"),
            pre,
        ],
        title="model",
        size=(1200, 400),
    )
    assert read_png(out).shape == (400, 1200, 3)
    with pytest.raises(ValueError, match="at least one"):
        render_side_by_side(tmp_path / "none.png", [])
    with pytest.raises(TypeError, match="panels"):
        render_side_by_side(tmp_path / "bad.png", ["not a panel"])


def test_inputs_not_modified():
    pts = sphere(200)
    before = pts.copy()
    render_points_array(pts, normals=pts, size=(64, 64))
    assert np.array_equal(pts, before)


def test_large_cloud_runs():
    pts = sphere(250_000, seed=1)  # above PER_POINT_MAX: the sampled-spacing path
    rgb = render_points_array(pts, normals=pts, size=(256, 256))
    mask = (rgb != 255).any(axis=2)
    # a sphere's disc: covered area close to pi r^2 of the fitted frame
    assert mask.sum() > 0.6 * np.pi * (0.94 * 128) ** 2


def facing_grid(camera, spacing, lo, hi):
    """A jittered grid patch facing the camera, in screen units [lo, hi] x [-1, 1]."""
    right, up, _ = camera.basis()
    a, b = np.meshgrid(np.arange(lo, hi, spacing), np.arange(-1, 1, spacing))
    rng = np.random.default_rng(0)
    a = a.ravel() + rng.uniform(-0.3, 0.3, a.size) * spacing
    b = b.ravel() + rng.uniform(-0.3, 0.3, b.size) * spacing
    return camera.center + a[:, None] * right + b[:, None] * up


def test_uneven_density_and_duplicates_leave_no_holes():
    camera = Camera(center=[0, 0, 0], radius=1.2)
    # left half 4x denser than the right half: per-point splat sizes close both
    pts = np.vstack([facing_grid(camera, 0.01, -1, 0), facing_grid(camera, 0.04, 0, 1)])
    rgb = render_points_array(pts, view=camera, size=(200, 200), lighting=False)
    inner = (rgb[40:160, 40:160] == 255).all(axis=2)  # well inside the patch
    assert inner.mean() < 0.01
    # exact duplicates (meshes split per texture coordinate) do not shrink splats
    sparse = facing_grid(camera, 0.04, -1, 1)
    once = render_points_array(sparse, view=camera, size=(200, 200), lighting=False)
    thrice = render_points_array(
        np.vstack([sparse] * 3), view=camera, size=(200, 200), lighting=False
    )
    assert np.array_equal(once != 255, thrice != 255)


def test_tangent_plane_splats_keep_the_silhouette():
    # a unit sphere: its picture should be a disc of radius 1 (in pixels: scale)
    pts = sphere(2000)
    cam = fit_camera(pts)
    ideal = np.pi * cam.scale(200, 200) ** 2
    with_normals = render_points_array(pts, normals=pts, view=cam, size=(200, 200))
    facing = render_points_array(pts, view=cam, size=(200, 200))
    area_tilted = (with_normals != 255).any(axis=2).sum() / ideal
    area_facing = (facing != 255).any(axis=2).sum() / ideal
    assert 0.97 < area_tilted < 1.07  # splats in the tangent plane: true outline
    assert area_facing > area_tilted  # screen-facing discs bulge past it
    # flipping normals (orientation) does not change the picture
    flipped = render_points_array(pts, normals=-pts, view=cam, size=(200, 200))
    assert np.array_equal(flipped, with_normals)


def test_mesh_zbuffer_beats_painters_order():
    # a small red quad in front of a large blue quad that slopes away in depth;
    # the blue quad's mean depth is nearer than the red one's, so a painter's
    # algorithm (sort by mean depth) would paint blue over red
    cam = Camera(center=[0, 0, 0], radius=2.0)
    right, up, eye = cam.basis()

    def quad(xs, ys, depth_of_x):
        return [x * right + y * up + depth_of_x(x) * eye for x, y in zip(xs, ys, strict=True)]

    small = quad([-0.2, 0.2, 0.2, -0.2], [-0.2, -0.2, 0.2, 0.2], lambda x: 1.0)
    big = quad([-1, 3, 3, -1], [-1, -1, 1, 1], lambda x: 5 * x - 1)
    verts = np.array(small + big)
    colors = [[1.0, 0, 0], [0, 0, 1.0]]
    rgb = render_mesh_array(
        verts,
        [[0, 1, 2, 3], [4, 5, 6, 7]],
        face_colors=colors,
        lighting=False,
        edges=False,
        view=cam,
        size=(101, 101),
    )
    assert rgb[50, 50].tolist() == [255, 0, 0]
    assert rgb[50, 75].tolist() == [0, 0, 255]  # right of it: the big quad


def test_non_convex_polygon_matches_point_in_polygon_reference():
    from matplotlib.path import Path

    cam = Camera(center=[0, 0, 0], radius=1.1)
    right, up, _ = cam.basis()
    ell = [(-1, -1), (1, -1), (1, 0), (0, 0), (0, 1), (-1, 1)]  # an L, notch top right
    verts = np.array([x * right + y * up for x, y in ell])
    size = 120
    rgb = render_mesh_array(
        verts, [list(range(6))], lighting=False, edges=False, view=cam, size=(size, size)
    )
    drawn = (rgb != 255).any(axis=2)
    x, y, _ = cam.project(verts, size, size)
    centres = np.stack(np.meshgrid(np.arange(size) + 0.5, np.arange(size) + 0.5), -1)
    inside = Path(np.c_[x, y]).contains_points(centres.reshape(-1, 2)).reshape(size, size)
    # away from the outline (anti-aliased pixels) the fill is exact
    pad = np.pad(inside, 1, mode="edge")
    band = np.zeros_like(inside)
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            band |= pad[1 + dy : 1 + dy + size, 1 + dx : 1 + dx + size] != inside
    assert np.array_equal(drawn[~band], inside[~band])
    assert inside.sum() > 0.7 * (0.75 * size * 0.94) ** 2  # the L covers 3/4 of its box
    assert not drawn[int(y[3]) - 10, int(x[3]) + 10]  # inside the notch


def test_point_order_does_not_matter():
    pts = sphere(3000, seed=4)
    labels = np.arange(3000) % 11
    perm = np.random.default_rng(1).permutation(3000)
    a = render_points_array(pts, normals=pts, labels=labels, size=(160, 120))
    b = render_points_array(pts[perm], normals=pts[perm], labels=labels[perm], size=(160, 120))
    assert np.array_equal(a, b)
