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


def _view_level_twin(samples, m, eye, near_m, min_height_m, fallback_level, fallback_share):
    """Plain numpy twin of riverflow.kernels.centre_line.view_level."""
    from riverflow.kernels.centre_line import FRESNEL_F0, REFLECTION_FAINT, VIEW_EDGE_NDC

    def fade(x):
        x = np.clip(x, 0.0, 1.0)
        return x * x * (3.0 - 2.0 * x)
    p = np.c_[samples.xy, samples.level, np.ones(len(samples.level))]
    clip = p @ m.T
    w = clip[:, 3]
    h = eye[2] - min_height_m - samples.level
    ok = (h > 0) & (w > near_m)
    w = np.where(ok, w, 1.0)
    sx, sy = np.linalg.norm(m[0, :3]), np.linalg.norm(m[1, :3])
    r = samples.half_width / w
    fx = fade((1.0 + r * sx - np.abs(clip[:, 0] / w)) / VIEW_EDGE_NDC)
    fy = fade((1.0 + r * sy - np.abs(clip[:, 1] / w)) / VIEW_EDGE_NDC)
    share = samples.area * h / w ** 3 * 0.25 * sx * sy * fx * fy * fade(w / near_m - 1.0)
    d = np.linalg.norm(p[:, :3] - eye, axis=1)
    c = 1.0 - np.minimum((eye[2] - samples.level) / d, 1.0)
    fresnel = FRESNEL_F0 + (1 - FRESNEL_F0) * c ** 5
    weight = np.where(ok, share * fresnel * fade(fresnel / (0.5 * REFLECTION_FAINT) - 1.0), 0.0)
    total = weight.sum() + fallback_share
    if not total > 0:
        return np.nan, 0.0
    if not weight.any():
        return fallback_level, total
    return (weight @ samples.level + fallback_share * fallback_level) / total, total


@pytest.fixture(scope="module")
def default_water():
    from riverflow.scenes.default import default_scene
    return default_scene(seed=0).water


def test_the_level_in_view_is_its_numpy_twin(default_water, rng):
    """view_level (numba) against its plain numpy twin: 200 cameras over the default scene,
    high and low, looking every way, with and without a fallback."""
    from riverflow.kernels.centre_line import view_level
    samples = default_water.level_samples()
    lo, hi = samples.xy.min(axis=0), samples.xy.max(axis=0)
    seen = 0
    for k in range(200):
        xy = rng.uniform(lo, hi)
        eye = np.array([*xy, float(rng.uniform(30.0, 300.0))])
        camera = Camera(eye, eye + rng.normal(0.0, 100.0, 3) - (0, 0, 60.0),
                        size_px=(320, 180), fov_y_deg=float(rng.uniform(30, 90)))
        m, _ = camera.matrices_for_kernels()
        args = (m, eye, camera.near_m, 0.05, 40.0, 1e-4 if k % 2 else 0.0)
        got = view_level(samples, *args)
        want = _view_level_twin(samples, *args)
        np.testing.assert_allclose(got, want, rtol=1e-9, atol=1e-12, equal_nan=True)
        seen += want[1] > 1e-3
    assert seen > 20                                  # many cameras see water


def test_the_mirror_is_the_level_of_the_water_in_view(default_water):
    """With a camera: the mirror is the level of the water the camera sees, not the nearest
    river's. 95 m up, over the land between a tributary (nearest, ~53 m) and the main river
    (~34 m), looking 300 m ahead at the main river: the main river's level; looking at the
    sky: the nearest river's; under the water: the nearest river's (no reflection drawn)."""
    water = default_water
    trib = water.branch == 1
    start = water.samples_m[trib][np.argmin(np.abs(water.levels_m[trib] - 60.0))]
    main = water.samples_m[water.branch == 2]
    d = main[np.argmax(main[:, 0])] - start
    d /= np.linalg.norm(d)
    xy = start + 515.0 * d
    eye = np.array([*xy, 95.0])
    nearest = mirror_level(water, eye)
    main_level = float(water.levels_m[water.branch == 2].min())

    def level(target):
        camera = Camera(eye, target, size_px=(320, 180))
        return mirror_level(water, eye, camera.matrices_for_kernels()[0], camera.near_m)
    assert nearest > main_level + 15.0
    assert level((*(xy + 300.0 * d), 30.0)) == pytest.approx(main_level, abs=1.0)
    assert level(eye + (0.0, 100.0, 80.0)) == nearest      # no water in view
    under = np.array([*start, water.level_at(*start) - 1.0])
    camera = Camera(under, (*(start + 300.0 * d), 30.0), size_px=(320, 180))
    assert mirror_level(water, under, camera.matrices_for_kernels()[0]) == mirror_level(
        water, under)


def test_the_mirror_eases_without_overshoot():
    """ease_level: a step of the target is 90 % done after the settle time, never overshot,
    never faster than 1.43 × step / settle time; the easing of one long step equals that of
    two halves (exact for a constant target), and a mirror at its target stays there."""
    from riverflow.scenes.reflection import MIRROR_SETTLE_S, ease_level
    x, v, t, xs = 0.0, 0.0, 0.0, []
    dt = 1 / 240
    while t < 3 * MIRROR_SETTLE_S:
        x, v = ease_level(x, v, 20.0, dt)
        t += dt
        xs.append((t, x, v))
    t, x, v = np.array(xs).T
    assert np.all(np.diff(x) >= 0) and x.max() <= 20.0
    assert np.interp(MIRROR_SETTLE_S, t, x) == pytest.approx(18.0, abs=0.3)
    assert v.max() <= 1.43 * 20.0 / MIRROR_SETTLE_S * 1.01
    one = ease_level(3.0, -4.0, 10.0, 0.1)
    two = ease_level(*ease_level(3.0, -4.0, 10.0, 0.05), 10.0, 0.05)
    np.testing.assert_allclose(one, two, rtol=1e-12)
    assert ease_level(7.0, 0.0, 7.0, 0.5) == (7.0, 0.0)


def test_the_mirror_is_held_and_the_new_level_faded_in():
    """hold_levels: the drawn level stays put while the eased level is within MIRROR_HOLD_M
    of it; beyond, the eased level of that frame is drawn too and faded in over
    MIRROR_FADE_S (a fixed second level, the fade rising by dt / MIRROR_FADE_S a frame),
    then held. A cut takes the level at once; the same view again (no time) keeps the
    answer; a held or fading level the eye came down to is dropped."""
    from riverflow.scenes.reflection import MIRROR_FADE_S, MIRROR_HOLD_M, hold_levels
    dt = 1 / 30
    state = hold_levels(None, 40.0, 0.0, 100.0)
    assert state == (40.0, None, 0.0)
    state = hold_levels(state, 40.0 + 0.9 * MIRROR_HOLD_M, dt, 100.0)
    assert state == (40.0, None, 0.0)                        # within the hold
    assert hold_levels(state, 45.0, 0.0, 100.0) == state     # no time passed: as it was
    level, fades, seen = 40.0, [], {40.0}
    for _ in range(30):                                      # the level rises 0.3 m a frame
        level += 0.3
        seen.add(level)
        state = hold_levels(state, level, dt, 100.0)
        fades.append(state)
    a = np.array([s[0] for s in fades])
    fade = np.array([s[2] for s in fades])
    assert set(a.tolist()) <= seen                          # levels it was given
    assert np.diff(fade)[np.diff(a) == 0].max() <= dt / MIRROR_FADE_S + 1e-12
    assert all(b is None and f == 0.0 or a0 < 100 and f > 0 for a0, b, f in fades)
    bs = [s[1] for s in fades if s[1] is not None]
    assert len(bs) > 20 and len(set(bs)) < 8                 # a few fixed second levels
    # it follows, a fade or two behind (b is the level where a fade began)
    assert a[-1] > 45.0 and level - a[-1] <= 0.3 / dt * (2 * MIRROR_FADE_S + 2 * dt)
    # the eye came down to the held level: the eased level at once
    assert hold_levels((60.0, 70.0, 0.5), 50.0, dt, 55.0) == (50.0, None, 0.0)
    assert hold_levels((50.0, 70.0, 0.5), 50.0, dt, 60.0) == (50.0, None, 0.0)
    # a long frame: no fade
    assert hold_levels((40.0, None, 0.0), 45.0, MIRROR_FADE_S, 100.0) == (45.0, None, 0.0)
