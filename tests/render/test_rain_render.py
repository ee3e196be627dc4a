"""Rain drawn (issue 12 item 4): a drop hitting the water changes water pixels only, around the
hit (a ripple ring in the water normal); drops are drawn as streaks; with the rain off the frame
is exactly the frame without rain (no golden image changes)."""
from __future__ import annotations

import numpy as np
import pytest

from riverflow.components.display import DisplayMode
from riverflow.components.rain import Rain
from riverflow.engine.config import RiverConfig
from riverflow.scenes.default import default_scene
from tests.engine.flight import river_view

pytestmark = pytest.mark.gl
W, H = 160, 90


@pytest.fixture(scope="module")
def setup(gl_context):
    from riverflow.engine.world import RiverWorld
    scene = default_scene(seed=0)
    eye, target = river_view(scene, height_m=4.0, back_m=12.0)
    p, level = np.asarray(target[:2]), float(target[2])
    d = (p - np.asarray(eye[:2])) / np.linalg.norm(p - np.asarray(eye[:2]))
    p = p - 5 * d                                    # the river point the view is built on
    w = RiverWorld(scene, size=(W, H), gl=True, seed=0,
                   config=RiverConfig(tile_production="blocking"))
    w.camera.look_at(eye, target)
    w.load_view()
    for _ in range(10):
        w.step(1 / 60)
    yield w, p - 4 * d, level
    w.close()


def _water_mask(world) -> np.ndarray:
    mode = world.display.mode
    world.display.mode = DisplayMode.MESH
    mesh = world.render()
    world.display.mode = DisplayMode.NONE
    ground = world.render()
    world.display.mode = mode
    return (mesh != ground).any(axis=2)


def test_a_drop_hit_changes_water_pixels_only_around_it(setup):
    world, hit_xy, level = setup
    rain = world.resource(Rain)
    rain.clear()
    base = world.render()
    water = _water_mask(world)
    assert water.mean() > 0.3
    rain.add_hit(hit_xy[0], hit_xy[1], level, world.clock.now_s - 0.4)
    hit = world.render()
    changed = (hit != base).any(axis=2)
    assert changed.sum() > 20                          # a ring, not a speck
    assert not (changed & ~water).any()                # land and sky untouched
    # around the hit's pixel
    m, _ = world.camera.matrices_for_kernels()
    c = m @ np.array([hit_xy[0], hit_xy[1], level, 1.0])
    sx, sy = (c[0] / c[3] * 0.5 + 0.5) * W, (1.0 - (c[1] / c[3] * 0.5 + 0.5)) * H
    ys, xs = np.nonzero(changed)
    assert np.hypot(xs - sx, ys - sy).max() < 0.35 * W
    rain.clear()
    assert np.array_equal(world.render(), base)        # rain off: exactly the old frame


def test_drops_are_drawn_as_streaks_and_leave_nothing_when_off(setup):
    world, _, _ = setup
    rain = world.resource(Rain)
    rain.clear()
    base = world.render()
    world.set_rain(4000.0)
    system = next(s for s in world.systems if s.name == "rain")
    for _ in range(20):                     # the rain alone: the rest of the frame stands still
        system.process(world, 1 / 60)
    rain.drops.hits[:, 3] = -np.inf         # streaks only, no ripples
    assert rain.count > 50
    on = world.render()
    changed = (on != base).any(axis=2)
    assert changed.sum() > 30
    # streaks are light: where they are drawn the frame gets brighter, not darker
    lum_on, lum_base = (f[..., :3].astype(int).sum(axis=2) for f in (on, base))
    assert (lum_on[changed] > lum_base[changed]).mean() > 0.8
    world.set_rain(0)
    assert np.array_equal(world.render(), base)
