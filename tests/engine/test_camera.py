"""Camera: pyrr's conventions pinned, projections and rays, empty viewports."""
from __future__ import annotations

import re
import subprocess
import sys

import numpy as np
import numpy.testing as npt
import pytest
import pyglet.math as pm
from pyrr import Matrix44, Quaternion, Vector3, matrix44

from riverflow.engine.camera import Camera

EYE = np.array([10.0, -40.0, 30.0])
TARGET = np.array([25.0, 60.0, 2.0])


@pytest.fixture
def cam() -> Camera:
    c = Camera(size_px=(320, 180), fov_y_deg=50.0, near_m=0.5, far_m=5000.0)
    c.look_at(EYE, TARGET)
    return c


# -- pyrr's conventions, pinned --------------------------------------------------------------


def test_pyrr_is_row_major_for_row_vectors():
    t = matrix44.create_from_translation([1.0, 2.0, 3.0], dtype=np.float32)
    npt.assert_array_equal(t[3, :3], [1, 2, 3])
    npt.assert_array_equal(np.array([0.0, 0, 0, 1]) @ t, [1, 2, 3, 1])


def test_projection_ravel_is_pyglet_mat4(cam):
    p = cam.projection_matrix()
    assert p.dtype == np.float32 and p.shape == (4, 4)
    expected = pm.Mat4.perspective_projection(320 / 180, 0.5, 5000.0, 50.0)
    npt.assert_allclose(p.ravel(), np.array(expected), rtol=1e-6, atol=1e-6)


def test_view_ravel_is_pyglet_look_at(cam):
    v = cam.view_matrix()
    assert v.dtype == np.float32
    expected = pm.Mat4.look_at(pm.Vec3(*EYE), pm.Vec3(*TARGET), pm.Vec3(0, 0, 1))
    npt.assert_allclose(v.ravel(), np.array(expected), rtol=1e-5, atol=1e-5)


def test_view_projection_ravel_is_glsl_projection_times_view(cam):
    p = pm.Mat4.perspective_projection(320 / 180, 0.5, 5000.0, 50.0)
    v = pm.Mat4.look_at(pm.Vec3(*EYE), pm.Vec3(*TARGET), pm.Vec3(0, 0, 1))
    npt.assert_allclose(cam.view_projection().ravel(), np.array(p @ v), rtol=1e-5, atol=1e-5)


def test_kernel_matrices_are_column_vector_transpose(cam):
    m, m_inv = cam.matrices_for_kernels()
    assert m.dtype == np.float64 and m.flags.c_contiguous and m_inv.flags.c_contiguous
    npt.assert_allclose(m, cam.view_projection(np.float64).T, rtol=1e-7, atol=1e-12)
    npt.assert_allclose(m @ m_inv, np.eye(4), atol=1e-9)
    clip = m @ np.append(TARGET, 1.0)
    npt.assert_allclose(clip[:2] / clip[3], [0.0, 0.0], atol=1e-9)


def test_matrix44_class_multiplies_in_reverse():
    """``Matrix44 * Matrix44`` reads like GLSL; the numpy path applies its left operand first."""
    p = matrix44.create_perspective_projection(60.0, 1.5, 0.5, 100.0)
    v = matrix44.create_look_at([0.0, 0, 0], [0.0, 1, 0], [0.0, 0, 1])
    npt.assert_allclose(matrix44.multiply(v, p), np.asarray(Matrix44(p) * Matrix44(v)))
    npt.assert_allclose(v @ p, matrix44.multiply(v, p))


def test_matrix_and_quaternion_rotations_turn_opposite_ways():
    q = Quaternion.from_y_rotation(np.pi / 2)
    m = Matrix44.from_y_rotation(np.pi / 2)
    npt.assert_allclose(np.asarray(q * Vector3([1.0, 0.0, 0.0])), [0, 0, -1], atol=1e-12)  # right-handed
    npt.assert_allclose(np.asarray(m * Vector3([1.0, 0.0, 0.0])), [0, 0, 1], atol=1e-6)    # the other way
    npt.assert_allclose(matrix44.create_from_quaternion(q), matrix44.create_from_y_rotation(np.pi / 2),
                        atol=1e-12)


def test_integer_vectors_silently_rotate_to_zero():
    """Pyrr issue #96: always build pyrr vectors from floats."""
    q = Quaternion.from_y_rotation(np.pi / 2)
    npt.assert_array_equal(np.asarray(q * Vector3([0, 0, 1])), [0, 0, 0])
    npt.assert_allclose(np.asarray(q * Vector3([0.0, 0.0, 1.0])), [1, 0, 0], atol=1e-12)


def test_pyrr_smoke_under_numpy2_with_warnings_as_errors():
    code = (
        "import warnings, numpy as np\n"
        "warnings.simplefilter('error')\n"
        "warnings.filterwarnings('ignore', category=DeprecationWarning, module='pyrr')\n"
        "import pyrr\n"
        "from riverflow.engine.camera import Camera\n"
        "c = Camera(size_px=(64, 48)); c.look_at((0, -10, 5), (0, 0, 0))\n"
        "m = c.view_projection(); c.matrices_for_kernels(); c.world_to_screen(np.zeros((2, 3)))\n"
        "pyrr.Matrix44.from_translation([1.0, 2.0, 3.0]); pyrr.Quaternion.from_z_rotation(0.3)\n"
        "assert np.all(np.isfinite(m))\n"
    )
    subprocess.run([sys.executable, "-c", code], check=True)


@pytest.mark.skipif(np.lib.NumpyVersion(np.__version__) < "2.0.0", reason="numpy 1 still has np.math")
def test_pyrr_sphere_helpers_are_broken_under_numpy2():
    """Why the camera never calls pyrr's geometric tests (np.math is gone in numpy 2)."""
    from pyrr import geometric_tests, ray
    with pytest.raises(AttributeError):
        geometric_tests.ray_intersect_sphere(ray.create([0.0, 0, -5], [0.0, 0, 1]),
                                             np.array([0.0, 0, 0, 1]))


def test_only_camera_imports_pyrr():
    from pathlib import Path
    root = Path(__file__).resolve().parents[2] / "riverflow"
    imports = re.compile(r"^\s*(import|from)\s+pyrr\b", re.MULTILINE)
    users = sorted(str(p.relative_to(root)) for p in root.rglob("*.py")
                   if imports.search(p.read_text(encoding="utf-8")))
    assert users == ["engine/camera.py"], users


# -- projections ----------------------------------------------------------------------------


def test_target_projects_to_viewport_centre(cam):
    screen, depth, front = cam.world_to_screen(TARGET[None])
    npt.assert_allclose(screen[0], [160.0, 90.0], atol=1e-6)
    assert front[0] and -1.0 < depth[0] < 1.0


def test_right_and_up_of_the_view_go_right_and_up(cam):
    right = TARGET + 5.0 * cam.right
    above = TARGET + np.array([0.0, 0.0, 5.0])
    screen, _, front = cam.world_to_screen(np.stack([right, above]))
    assert front.all()
    assert screen[0, 0] > 160.0 and abs(screen[0, 1] - 90.0) < 1e-6
    assert screen[1, 1] > 90.0
    # East of a camera looking north is screen right.
    c = Camera(size_px=(100, 100))
    c.look_at((0.0, 0.0, 10.0), (0.0, 100.0, 10.0))
    s, _, _ = c.world_to_screen(np.array([[10.0, 100.0, 10.0], [0.0, 100.0, 20.0]]))
    assert s[0, 0] > 50 and s[1, 1] > 50


def test_depth_is_ndc_z(cam):
    near_point = cam.position + cam.near_m * cam.forward
    far_point = cam.position + cam.far_m * cam.forward
    _, depth, _ = cam.world_to_screen(np.stack([near_point, far_point]))
    npt.assert_allclose(depth, [-1.0, 1.0], atol=1e-6)


def test_screen_to_ray_inverts_world_to_screen(cam, rng):
    points = rng.uniform([-200, -100, -20], [300, 400, 80], (200, 3))
    screen, _, front = cam.world_to_screen(points)
    origin, direction = cam.screen_to_ray(screen[front])
    npt.assert_allclose(np.linalg.norm(direction, axis=1), 1.0)
    npt.assert_allclose(origin, np.broadcast_to(cam.position, origin.shape))
    rel = points[front] - origin
    along = (rel * direction).sum(1)
    assert (along > 0).all()
    miss = np.linalg.norm(rel - along[:, None] * direction, axis=1)
    npt.assert_array_less(miss, 1e-6 * np.linalg.norm(rel, axis=1) + 1e-9)


def test_centre_pixel_ray_is_forward(cam):
    _, d = cam.screen_to_ray([[160.0, 90.0]])
    npt.assert_allclose(d[0], cam.forward, atol=1e-12)


def test_points_behind_are_flagged(cam):
    behind = cam.position - 10.0 * cam.forward
    on_plane = cam.position + 5.0 * cam.right
    screen, depth, front = cam.world_to_screen(np.stack([behind, on_plane, TARGET]))
    npt.assert_array_equal(front, [False, False, True])
    assert np.isfinite(screen).all() and np.isfinite(depth).all()


# -- empty viewports and degenerate views ---------------------------------------------------


def test_zero_viewport_gives_no_nan():
    c = Camera(size_px=(0, 0))
    c.look_at(EYE, TARGET)
    assert c.is_empty and c.aspect == 1.0
    for m in (c.view_matrix(), c.projection_matrix(), c.view_projection(), *c.matrices_for_kernels()):
        assert np.isfinite(m).all()
    screen, depth, front = c.world_to_screen(np.stack([TARGET, EYE, EYE - 1.0]))
    assert np.isfinite(screen).all() and np.isfinite(depth).all()
    npt.assert_array_equal(screen, 0.0)
    origin, direction = c.screen_to_ray(np.array([[0.0, 0.0], [10.0, 5.0]]))
    npt.assert_allclose(direction, [c.forward, c.forward])
    c.set_viewport(640, 0)
    assert c.is_empty and np.isfinite(c.world_to_screen(TARGET[None])[0]).all()
    c.set_viewport(-5, 3)
    assert c.size_px == (0, 3)


def test_looking_straight_down_is_finite():
    c = Camera(size_px=(64, 64))
    c.look_at((5.0, 5.0, 100.0), (5.0, 5.0, 0.0))
    assert np.isfinite(c.view_projection()).all()
    npt.assert_allclose(c.screen_up, [0.0, 1.0, 0.0], atol=1e-12)  # north up when looking down
    screen, _, _ = c.world_to_screen(np.array([[5.0, 5.0, 0.0], [15.0, 5.0, 0.0], [5.0, 15.0, 0.0]]))
    npt.assert_allclose(screen[0], [32.0, 32.0], atol=1e-9)
    assert screen[1, 0] > 32.0 and screen[2, 1] > 32.0


def test_bad_input_raises_and_changes_nothing():
    c = Camera(size_px=(64, 64))
    c.look_at(EYE, TARGET)
    rev = c.revision
    with pytest.raises(ValueError):
        c.look_at(EYE, EYE)
    with pytest.raises(ValueError):
        c.look_at((np.nan, 0.0, 0.0), TARGET)
    with pytest.raises(ValueError):
        c.set_projection(60.0, 10.0, 1.0)
    assert c.revision == rev
    npt.assert_array_equal(c.position, EYE)
    with pytest.raises(ValueError):
        c.position[0] = 3.0  # read-only: changes must go through look_at (and the revision)


def test_revision_counts_changes():
    c = Camera()
    assert c.revision == 0
    c.look_at(EYE, TARGET)
    c.set_viewport(10, 10)
    c.fov_y_deg = 45.0
    c.near_m = 1.0
    c.far_m = 200.0
    c.position = (0.0, -50.0, 20.0)
    c.target = (0.0, 0.0, 5.0)
    c.size_px = (20, 10)
    assert c.revision == 8
    assert (c.fov_y_deg, c.near_m, c.far_m, c.size_px) == (45.0, 1.0, 200.0, (20, 10))


def test_set_matrices_takes_a_hosts_camera():
    """A host's column-major view and projection (pyglet's Mat4, numpy written as in maths
    and transposed) give the camera that makes them: the same world → clip matrix; the same
    matrices again change nothing; what riverflow's camera cannot be is a ValueError."""
    host = Camera(position=(30.0, -240.0, 90.0), target=(-20.0, 10.0, 12.0), fov_y_deg=47.0,
                  near_m=0.8, far_m=6000.0, size_px=(320, 200))
    aspect = 320 / 200
    view = pm.Mat4.look_at(pm.Vec3(30.0, -240.0, 90.0), pm.Vec3(-20.0, 10.0, 12.0),
                           pm.Vec3(0.0, 0.0, 1.0))
    projection = pm.Mat4.perspective_projection(aspect, 0.8, 6000.0, 47.0)
    c = Camera(size_px=(320, 200))
    c.set_matrices(view, projection)                       # pyglet: column-major tuples
    npt.assert_allclose(c.matrices_for_kernels()[0], host.matrices_for_kernels()[0],
                        rtol=1e-5, atol=1e-5)
    npt.assert_allclose(c.position, host.position, atol=1e-3)
    assert abs(c.fov_y_deg - 47.0) < 1e-4 and abs(c.near_m - 0.8) < 1e-4
    revision = c.revision
    c.set_matrices(view, projection)
    assert c.revision == revision
    maths_view = np.asarray(view, np.float64).reshape(4, 4).T      # clip = M @ [x, y, z, 1]
    c2 = Camera(size_px=(320, 200))
    c2.set_matrices(maths_view.T, np.asarray(projection).reshape(4, 4))
    npt.assert_allclose(c2.matrices_for_kernels()[0], c.matrices_for_kernels()[0], atol=1e-9)
    scaled = maths_view.copy()
    scaled[:3, :3] *= 2.0
    with pytest.raises(ValueError, match="rotation and a translation"):
        c.set_matrices(scaled.T, projection)
    off_centre = np.asarray(projection, np.float64).reshape(4, 4).T.copy()
    off_centre[0, 2] = 0.2
    with pytest.raises(ValueError, match="symmetric OpenGL perspective"):
        c.set_matrices(view, off_centre.T)
    with pytest.raises(ValueError, match="aspect"):
        c.set_matrices(view, pm.Mat4.perspective_projection(1.0, 0.8, 6000.0, 47.0))
    with pytest.raises(ValueError, match="16 finite numbers"):
        c.set_matrices(np.eye(3), projection)
    assert c.revision == revision                           # unchanged by the errors
