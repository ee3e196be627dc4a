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
