"""Foam and wakes drawn (issue 12 items 1 and 2), offscreen on Mesa's llvmpipe: the wake
shader against its numpy twin, the Kelvin wedge behind a moving boat in a rendered frame
(and none behind a still one), foam whiter near the hull and the banks, the foam mode."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from riverflow.components.display import DisplayMode
from riverflow.components.wake import MAX_WAKES, TRAIL_POINTS
from riverflow.engine.config import RiverConfig
from riverflow.kernels.wake import TR_FIELDS, advance_trail, pack_trail, wake_texture
from riverflow.scenes.default import default_scene
from tests.engine.test_foam import _start
from tests.kernels.wake_reference import CUSP, wake_slopes

pytestmark = pytest.mark.gl
PROBES = Path(__file__).parent / "shaders"
W, H = 240, 136


def _trail(speed, seconds=12.0, turn_rps=0.1):
    trail = np.zeros((TRAIL_POINTS, 6))
    count, t, heading, p = 0, 0.0, 0.0, np.array([500.0, -200.0])
    for _ in range(int(seconds * 60)):
        t += 1 / 60
        heading += turn_rps / 60
        p = p + speed * np.array([math.cos(heading), math.sin(heading)]) / 60
        count = advance_trail(trail, count, p[0], p[1], speed, 0.3, 0.1, t, 1 / 60, 1 / 3,
                              15.0)
    table = np.zeros((1, TRAIL_POINTS, TR_FIELDS), np.float32)
    pack_trail(trail, count, t, 15.0, 0.5, 0.35, 3.0, 0.5, table[0])
    return table


def test_the_wake_shader_matches_its_numpy_twin(gl_context):
    from riverflow.engine import gl
    from riverflow.systems.draw import shader_defines
    tables = np.concatenate([_trail(5.0), _trail(3.0, turn_rps=-0.2), _trail(0.0)])
    tables[1, :, [0, 1]] += np.array([[20.0], [30.0]], np.float32)    # apart
    rng = np.random.default_rng(0)
    bow = tables[0, 0, :2].astype(float)
    size = (64, 48)
    pts = bow + rng.uniform((-80, -45), (15, 45), (size[1], size[0], 2))
    px = rng.choice([0.02, 0.3, 1.5], (size[1], size[0]))
    points = np.concatenate([pts, px[..., None], np.zeros_like(px)[..., None]], axis=2)
    tex_points = gl.Texture(size, gl.RGBA32F)
    tex_points.upload(points.astype(np.float32))
    packed = np.zeros((MAX_WAKES, 1 + 2 * TRAIL_POINTS, 4), np.float32)
    wake_texture(tables, packed)
    tex_wakes = gl.Texture((1 + 2 * TRAIL_POINTS, MAX_WAKES), gl.RGBA32F)
    tex_wakes.upload(packed)
    target = gl.Texture(size, gl.RGBA32F)
    fb = gl.Framebuffer([target])
    program = gl.Program("probe_wake.glsl", shader_defines(), directory=PROBES)
    fb.bind()
    gl.clear((0, 0, 0, 0), depth=False)
    tex_points.bind(4)
    tex_wakes.bind(5)
    program.use()
    program.set(u_points=4, u_wakes=5, u_wake_count=3)
    empty = gl.Mesh(None, {})
    empty.draw(gl.TRIANGLES, count=3)
    probe = gl.read_texture(target).reshape(-1, 4)
    got, got_crest = probe[:, :2], probe[:, 2]
    gl.check_errors("wake probe")
    for obj in (empty, fb, target, program, tex_points, tex_wakes):
        obj.delete()
    want_crest = np.zeros(len(got))
    want = wake_slopes(points.reshape(-1, 4)[:, :2].astype(np.float32).astype(np.float64),
                       tables, 3, points.reshape(-1, 4)[:, 2].astype(np.float32), want_crest)
    assert np.abs(want).max() > 0.05 and (np.abs(want).sum(axis=1) > 0).mean() > 0.2
    close = np.abs(got - want).max(axis=1) < 2e-3 + 0.02 * np.abs(want).max(axis=1)
    assert close.mean() > 0.99, np.argwhere(~close)[:5]   # float32 and ties between segments
    assert (np.abs(got_crest - want_crest) < 0.02)[close].mean() > 0.99
    assert want_crest.max() > 0.5                        # the cusps near the boats break


@pytest.fixture(scope="module")
def boat_world(gl_context):
    from riverflow.engine.world import RiverWorld
    scene = default_scene(seed=0)
    world = RiverWorld(scene, size=(W, H), gl=True, seed=0,
                       config=RiverConfig(radius_px=5.0, tile_production="blocking"))
    p, heading = _start(scene)
    entity = world.add_boat(p, heading, throttle=0.7)
    yield world, world.boat(entity), entity
    world.close()


def _look_back(world, boat):
    """A camera high behind the boat, looking down at the water it has just crossed."""
    f = np.array([math.cos(boat.heading_rad), math.sin(boat.heading_rad), 0.0])
    c = np.array([*boat.position_m, boat.altitude_m])
    world.camera.look_at(c - 45.0 * f + (0.0, 0.0, 24.0), c - 14.0 * f)


def _drive(world, boat, frames, throttle):
    boat.throttle = throttle
    for _ in range(frames):
        _look_back(world, boat)
        world.step(1 / 60)


def _wedge_masks(world, boat):
    """(inside, outside) (H, W) bool: water pixels inside the Kelvin wedge behind the boat
    (8 … 60 m behind its bow, under 0.8 of the cusp angle) and those well outside it."""
    from tests.render.test_rain_render import _water_mask
    water = _water_mask(world)
    m, inverse = world.camera.matrices_for_kernels()
    ys, xs = np.mgrid[0:H, 0:W]
    ndc = np.stack([(xs + 0.5) / W * 2 - 1, 1 - (ys + 0.5) / H * 2], -1).reshape(-1, 2)
    level = float(boat.altitude_m)
    near = inverse @ np.c_[ndc, -np.ones(len(ndc)), np.ones(len(ndc))].T
    far = inverse @ np.c_[ndc, np.ones(len(ndc)), np.ones(len(ndc))].T
    near, far = (near[:3] / near[3]).T, (far[:3] / far[3]).T
    t = (level - near[:, 2]) / (far[:, 2] - near[:, 2])
    hit = near + t[:, None] * (far - near)
    f = np.array([math.cos(boat.heading_rad), math.sin(boat.heading_rad)])
    bow = boat.position_m + 0.4 * boat.length_m * f
    rel = hit[:, :2] - bow
    X = -(rel @ f)
    Y = np.abs(rel @ np.array([-f[1], f[0]]))
    r = Y / np.maximum(X, 1e-6)
    inside = ((X > 8) & (X < 60) & (r < 0.8 * CUSP) & (r > 0.3 * CUSP)).reshape(H, W)
    outside = ((X > 8) & (X < 60) & (r > 1.5 * CUSP)).reshape(H, W)
    return inside & water, outside & water


def _grey(frame):
    return frame[..., :3].astype(np.float64).mean(axis=2)


def test_the_kelvin_wedge_shows_behind_a_moving_boat_and_not_a_still_one(boat_world):
    """The wake's part of the frame (the frame less the same frame with the wake's slope
    knob at 0) varies inside the 19.47° wedge behind a boat at speed and is nil outside it;
    behind a still boat it is nil everywhere."""
    world, boat, entity = boat_world
    display = world.display
    wake = world.wake(entity)
    display.wave_slope_factor = 0.0           # the wake alone in the water's normal
    world.foam.enabled = False                # and no foam

    def wake_part():
        wake.wave_slope = 0.5
        with_wake = _grey(world.render())
        wake.wave_slope = 0.0
        world.step(0.0)
        without = _grey(world.render())
        wake.wave_slope = 0.5
        world.step(0.0)
        return with_wake - without

    try:
        _drive(world, boat, 420, 0.7)
        assert np.hypot(*(boat.velocity_mps - boat.flow_mps)) > 4.0
        inside, outside = _wedge_masks(world, boat)
        assert inside.sum() > 150 and outside.sum() > 150
        part = wake_part()
        assert part[inside].var() > 0.5, part[inside].var()
        assert part[inside].var() > 20.0 * part[outside].var() + 1e-9
        # the same boat held still in the water: its trail fades, then the water is flat
        wake.life_s = 0.5
        boat.velocity_mps = boat.flow_mps.copy()
        _drive(world, boat, 90, 0.0)
        assert np.hypot(*(boat.velocity_mps - boat.flow_mps)) < 0.5
        inside, outside = _wedge_masks(world, boat)
        assert not wake_part()[inside | outside].any()
    finally:
        display.wave_slope_factor = 0.2
        world.foam.enabled = True
        wake.life_s = 15.0
        wake.wave_slope = 0.5


def test_foam_is_whiter_near_the_hull_and_the_foam_mode_shows_it(boat_world):
    world, boat, entity = boat_world
    _drive(world, boat, 300, 1.0)
    ys, xs, xy = _water_points(world, float(boat.altitude_m))
    f = np.array([math.cos(boat.heading_rad), math.sin(boat.heading_rad)])
    rel = xy - boat.position_m
    behind = -(rel @ f)
    across = np.abs(rel @ np.array([-f[1], f[0]]))
    wash = (behind > 0.6 * boat.length_m) & (behind < 3.0 * boat.length_m) \
        & (across < 0.8 * boat.beam_m)
    far = (across > 15.0) & (behind > -20.0) & (behind < 40.0)
    assert wash.sum() > 20 and far.sum() > 100
    with_foam = _grey(world.render())[ys, xs]
    world.display.mode = DisplayMode.FOAM
    try:
        shown = _grey(world.render())[ys, xs]
    finally:
        world.display.mode = DisplayMode.ADVECTED
    assert shown[wash].mean() > shown[far].mean() + 40.0
    world.foam.enabled = False
    world.step(1 / 60)
    without = _grey(world.render())[ys, xs]
    world.foam.enabled = True
    gain = with_foam[wash].mean() - without[wash].mean()
    assert gain > 25.0, gain                  # visibly whiter (of 255)


def _water_points(world, level_m):
    """(rows, cols, world xy (N, 2)) of the water pixels: each pixel's ray cut with the
    plane at ``level_m``."""
    from tests.render.test_rain_render import _water_mask
    ys, xs = np.nonzero(_water_mask(world))
    _, inverse = world.camera.matrices_for_kernels()
    w, h = world.camera.size_px
    ndc = np.c_[(xs + 0.5) / w * 2 - 1, 1 - (ys + 0.5) / h * 2]
    one = np.ones(len(ndc))
    near = inverse @ np.c_[ndc, -one, one].T
    far = inverse @ np.c_[ndc, one, one].T
    near, far = (near[:3] / near[3]).T, (far[:3] / far[3]).T
    t = (level_m - near[:, 2]) / (far[:, 2] - near[:, 2])
    return ys, xs, (near + t[:, None] * (far - near))[:, :2]


def test_banks_are_whiter_with_foam(gl_context):
    from riverflow.engine.world import RiverWorld
    from tests.engine.flight import river_view
    scene = default_scene(seed=0)
    world = RiverWorld(scene, size=(W, H), gl=True, seed=0,
                       config=RiverConfig(radius_px=5.0, tile_production="blocking"))
    try:
        eye, target = river_view(scene, height_m=12.0, back_m=25.0)
        world.camera.look_at(eye, target)
        world.load_view()
        for _ in range(240):
            world.step(1 / 60)
        ys, xs, xy = _water_points(world, target[2])
        shore = scene.water.distance_to_shore(xy)
        near, middle = shore < 4.0, shore > 12.0
        assert near.sum() > 100 and middle.sum() > 100
        on = _grey(world.render())[ys, xs]
        world.foam.enabled = False
        world.step(1 / 60)
        off = _grey(world.render())[ys, xs]
        gain = on - off
        assert gain[near].mean() > 12.0, gain[near].mean()       # visibly whiter (of 255)
        assert gain[near].mean() > 3.0 * abs(gain[middle].mean()) + 5.0
    finally:
        world.close()
