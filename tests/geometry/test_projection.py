"""The GL projection built from the intrinsics agrees with NumPy's pinhole projection."""
import numpy as np
from scipy.spatial import ConvexHull

from synthcompose.models import load_model
from synthcompose.placement import pose_matrix
from synthcompose.render import Lighting, Renderer, RenderObject

from ..helpers import make_camera
from ..tolerances import GL_PROJECTION_MATRIX_PX, PROJECTION_PX, SILHOUETTE_AREA_REL


def test_projection_matrix_maps_points_like_the_pinhole_model():
    cam = make_camera()
    rng = np.random.default_rng(0)
    pts = np.column_stack([rng.uniform(-10, 10, 50), rng.uniform(-5, 5, 50), rng.uniform(1, 80, 50)])
    clip = np.column_stack([pts, np.ones(50)]) @ cam.gl_projection(0.5, 500.0).T
    ndc = clip[:, :3] / clip[:, 3:]
    window = (ndc[:, :2] + 1) / 2 * [cam.width, cam.height] - 0.5  # GL pixel centres sit at i + 0.5
    assert np.abs(window - cam.project(pts)).max() < GL_PROJECTION_MATRIX_PX
    assert (np.abs(ndc[:, 2]) <= 1).all()


def test_rendered_box_corners_land_where_numpy_puts_them(gl_clean):
    cam = make_camera()
    model = load_model("builtin:box", (("length", 2.0),))
    m = pose_matrix(np.array([14.0, 1.5, 0.0]), np.array([0.03, -0.02, 1.0]), 0.4)
    renderer = Renderer(gl_clean)
    passes = renderer.render(cam, [RenderObject(model, m, (0.2, 0.2, 0.2))], Lighting.daylight())
    ids = passes.read("id")
    rows, cols = np.nonzero(ids == 1)
    rows, cols = rows + passes.roi.y0, cols + passes.roi.x0
    corners = np.array([[sx, sy, z] for sx in (-1, 1) for sy in (-1, 1) for z in (0, 2)], float)
    corners_v = corners @ m[:3, :3].T + m[:3, 3]
    opt = cam.optical_from_vehicle
    uv = cam.project(corners_v @ opt[:3, :3].T + opt[:3, 3])
    # extreme pixels covered (pixel centres inside the silhouette) vs projected extremes
    assert abs(cols.min() - uv[:, 0].min()) <= PROJECTION_PX
    assert abs(cols.max() - uv[:, 0].max()) <= PROJECTION_PX
    assert abs(rows.min() - uv[:, 1].min()) <= PROJECTION_PX
    assert abs(rows.max() - uv[:, 1].max()) <= PROJECTION_PX
    # every silhouette corner has a covered pixel within 1 px
    hull = ConvexHull(uv)
    for u, v in uv[hull.vertices]:
        d = np.hypot(cols - u, rows - v).min()
        assert d <= PROJECTION_PX * np.sqrt(2), (u, v, d)
    # area agrees with the projected hull's
    assert abs(len(rows) - hull.volume) / hull.volume < SILHOUETTE_AREA_REL
    renderer.release(passes)
