"""The planar reflection's mirror (riverflow.scenes.reflection, no GL): the mirrored camera
draws every point where the camera sees its mirror image; the mirror sits at the level of
the river nearest the eye; the texture's size follows the viewport and the scale."""
from __future__ import annotations

import numpy as np
import pytest

from riverflow.engine.camera import Camera
from riverflow.scenes.reflection import (mirror_level, mirror_matrix, mirrored_view_projection,
                                         reflection_size)


def _clip(vp_row: np.ndarray, points: np.ndarray) -> np.ndarray:
    homogeneous = np.concatenate([points, np.ones((len(points), 1))], axis=1)
    c = homogeneous @ vp_row.astype(np.float64)
    return c[:, :3] / c[:, 3:]


@pytest.mark.parametrize("level", [0.0, 37.5, -12.0])
def test_the_mirrored_camera_draws_each_point_where_its_mirror_image_is_seen(level, rng):
    camera = Camera((10.0, -40.0, level + 8.0), (30.0, 50.0, level), size_px=(320, 180))
    vp = camera.view_projection(np.float64)
    mirrored = mirrored_view_projection(vp, level)
    points = rng.uniform((-50, 0, level), (80, 120, level + 30), size=(200, 3))
    images = points * (1, 1, -1) + (0, 0, 2 * level)
    np.testing.assert_allclose(_clip(mirrored, points), _clip(vp, images), atol=1e-4)
    m = mirror_matrix(level)
    np.testing.assert_allclose(m @ m, np.eye(4))                 # a mirror twice: nothing
    np.testing.assert_allclose((np.array([[1.0, 2.0, level, 1.0]]) @ m)[0, 2], level)


class _Water:
    """A river whose level falls 1 m per 100 m eastwards."""

    def level(self, xy):
        return 50.0 - 0.01 * np.asarray(xy, np.float64)[:, 0]


def test_the_mirror_sits_at_the_level_of_the_river_nearest_the_eye():
    assert mirror_level(_Water(), (200.0, 5.0, 60.0)) == pytest.approx(48.0)
    assert mirror_level(_Water(), (-100.0, 0.0, 0.0)) == pytest.approx(51.0)
    assert mirror_level(None, (0.0, 0.0, 10.0)) is None             # a scene with no water
    assert mirror_level(_Water(), (np.nan, 0.0, 10.0)) is None       # a bad eye: no mirror


def test_the_reflection_texture_follows_the_viewport_and_the_scale():
    assert reflection_size(1920, 1080, 0.5) == (960, 540)
    assert reflection_size(641, 361, 0.5) == (320, 180)
    assert reflection_size(1, 1, 0.25) == (1, 1)
    assert reflection_size(0, 0, 1.0) == (1, 1)


def test_the_level_of_one_point_is_the_vectorised_level_bit_for_bit(rng):
    """WaterSurface.level_at (the mirror's level, in Python floats) against level(): around
    the centre lines, at the samples themselves, far away, near the junctions (blended)."""
    from riverflow.scenes.default import default_scene
    water = default_scene(seed=0).water
    samples = water.samples_m
    lo, hi = samples.min(axis=0) - 300.0, samples.max(axis=0) + 300.0
    junctions = np.repeat(water.junctions_m, 200, axis=0)
    points = np.concatenate([
        samples[rng.integers(0, len(samples), 3000)] + rng.normal(0.0, 30.0, (3000, 2)),
        samples[rng.integers(0, len(samples), 500)],
        rng.uniform(lo, hi, (500, 2)),
        junctions + rng.normal(0.0, 20.0, junctions.shape)])
    want = water.level(points)
    got = np.array([water.level_at(x, y) for x, y in points.tolist()])
    np.testing.assert_array_equal(got, want)
    assert mirror_level(water, (*points[0], 500.0)) == want[0]


def test_the_mirrored_matrix_is_the_mirror_times_the_view_projection(rng):
    """mirrored_view_projection writes the product out: the same float32 numbers."""
    for k in range(300):
        eye = rng.uniform((-3000, -3000, 1), (3000, 3000, 300))
        camera = Camera(eye, eye + rng.normal(0.0, 100.0, 3), size_px=(1920, 1080))
        vp = camera.view_projection(np.float64) if k % 2 else camera.matrices_for_kernels()[0].T
        level = float(rng.uniform(-50, 150)) if k % 3 else float(rng.integers(-5, 100))
        want = (mirror_matrix(level) @ vp).astype(np.float32)
        got = mirrored_view_projection(vp, level)
        assert got.dtype == np.float32 and got.shape == (4, 4)
        np.testing.assert_array_equal(got, want)
