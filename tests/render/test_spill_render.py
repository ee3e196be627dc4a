"""Spills drawn (issue 24): the water at a plume is discoloured towards the spill's colour in
the normal look, and tinted by the concentration ramp in the "concentration" mode; land is
untouched; with no spill the frame is the frame without spills."""
from __future__ import annotations

import numpy as np
import pytest

from riverflow.components.display import DisplayMode, concentration_colour
from riverflow.engine.config import RiverConfig
from riverflow.scenes.default import default_scene

pytestmark = pytest.mark.gl
W, H = 96, 54


@pytest.fixture(scope="module")
def setup(gl_context):
    from riverflow.engine.world import RiverWorld
    scene = default_scene(seed=0)
    j = scene.water.junctions_m[0]
    w = RiverWorld(scene, size=(W, H), gl=True, seed=0,
                   config=RiverConfig(tile_production="blocking"))
    w.camera.look_at((j[0] - 60.0, j[1] - 320.0, 260.0), (j[0] + 60.0, j[1], 0.0))
    w.load_view()
    w.step(1 / 60)
    yield w, scene
    w.close()


def _frames(world, mode):
    world.display.mode = mode
    image = world.render()
    world.display.mode = DisplayMode.ADVECTED
    return image.astype(np.int32)


def test_a_plume_discolours_the_water_and_only_the_water(setup):
    world, scene = setup
    world.paused = True                        # the particles hold still: only the tint changes
    world.display.concentration_legend = False     # (its own test below)
    before = _frames(world, DisplayMode.ADVECTED)
    ramp_before = _frames(world, DisplayMode.CONCENTRATION)
    mesh = _frames(world, DisplayMode.MESH)
    ground = _frames(world, DisplayMode.NONE)
    water = (mesh != ground).any(axis=2)
    assert water.mean() > 0.1
    trib = scene.branch("tributary").centerline_m
    e = world.add_spill(trib[int(len(trib) * 0.8)], 500.0, 600.0)
    world.advance_spills(600.0)
    after = _frames(world, DisplayMode.ADVECTED)
    ramp_after = _frames(world, DisplayMode.CONCENTRATION)
    changed = (after != before).any(axis=2)
    assert changed.sum() > 50 and not (changed & ~water).any()
    assert world.spill(e).in_water_kg > 0
    # towards the spill's colour (the first one, mud: red over blue)
    diff = after[changed] - before[changed]
    assert np.mean(diff[:, 0] - diff[:, 2]) > 10
    # the concentration mode: dark water without spills, the ramp's colours at the plume
    dark = np.round(255 * concentration_colour(0.0, world.display)).astype(int)
    assert np.abs(ramp_before[water][:, :3] - dark).max() <= 40      # fog and sRGB aside
    tinted = (np.abs(ramp_after[:, :, :3] - ramp_before[:, :, :3]).sum(axis=2) > 60)
    assert tinted.sum() > 50 and not (tinted & ~water).any()
    world.paused = False
    world.display.concentration_legend = True


def test_the_concentration_mode_draws_its_colour_bar_with_values(setup):
    """The legend in the frame (lower right): only there does the frame change; the bar's
    pixels are the mode's ramp (the numpy twin) at the value of their row, also at each
    labelled decade; a white tick beside the bar at each decade."""
    from riverflow.systems.legend import concentration_bar
    world, _ = setup
    world.paused = True
    world.display.concentration_legend = False
    bare = _frames(world, DisplayMode.CONCENTRATION)
    world.display.concentration_legend = True
    shown = _frames(world, DisplayMode.CONCENTRATION)
    world.paused = False
    bar = concentration_bar(world.display.concentration_range_kg_m3, (W, H))
    x0, y0, pw, ph = bar.panel_px
    inside = np.zeros((H, W), bool)
    inside[H - y0 - ph:H - y0, x0:x0 + pw] = True
    changed = (shown[:, :, :3] != bare[:, :, :3]).any(axis=2)
    assert changed[inside].mean() > 0.5 and not changed[~inside].any()
    bx, by, bw, bh = bar.bar_px
    column = x0 + bx + bw // 2
    rows = range(by, by + bh)
    got = np.array([shown[H - 1 - (y0 + r), column, :3] for r in rows])
    want = np.array([255 * concentration_colour(bar.row_value(r) * (1 + 1e-9), world.display)
                     for r in rows])
    assert np.abs(got - want).max() <= 2
    assert len(bar.ticks) == 5                                  # 1e-6 … 1e-2: a tick a decade
    step = np.abs(np.diff(want, axis=0)).max()                  # the ramp's change in a row
    for value, row in bar.ticks:
        y = H - 1 - (y0 + row)
        at = 255 * concentration_colour(value * (1 + 1e-9), world.display)
        assert np.abs(shown[y, column, :3] - at).max() <= step + 2
        tick = shown[y, x0 + bx - 2, :3]
        assert tick.min() > 200                                 # white, left of the bar
