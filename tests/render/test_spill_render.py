"""Spills drawn (issue 24): the water at a plume is discoloured towards the spill's colour in
the normal look, carried by the wave sprites (each particle's tint, blended with the sprites'
weights), and tinted by the concentration ramp in the "concentration" mode; land is
untouched; with no spill the frame is the frame without spills."""
from __future__ import annotations

import numpy as np
import pytest

from riverflow.components.display import DisplayMode, concentration_colour
from riverflow.components.status import FlowStatus
from riverflow.engine.config import RiverConfig
from riverflow.scenes.default import default_scene

pytestmark = pytest.mark.gl
W, H = 96, 54
R = 4.0


@pytest.fixture(scope="module")
def setup(gl_context):
    from riverflow.engine.world import RiverWorld
    scene = default_scene(seed=0)
    j = scene.water.junctions_m[0]
    # small sprites that fade in at once: the particles' tint shows from the first frames
    w = RiverWorld(scene, size=(W, H), gl=True, seed=0,
                   config=RiverConfig(tile_production="blocking", radius_px=R, fade_in_s=0.01))
    w.camera.look_at((j[0] - 60.0, j[1] - 320.0, 260.0), (j[0] + 60.0, j[1], 0.0))
    w.load_view()
    w.step(1 / 60)
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


def test_the_tint_is_carried_by_the_sprites(setup):
    """The normal look's discolouring is the particles' tint: with the particles' tint
    cleared the frame is clean water, put back it is the tinted frame again (bit for bit); a
    tint changed on the particles alone changes the water towards its colour; it reaches no
    further than a sprite's disc from a tinted particle, the tinted particles are in the plume
    (the exact query, within a texel of the spills' grid), and it fades out smoothly at its
    edge (no jump from tinted to clean water between neighbouring pixels)."""
    world, scene = setup
    world.paused = True
    if world.spill_solver is None or not world.spill_solver.n_spills:
        trib = scene.branch("tributary").centerline_m
        world.add_spill(trib[int(len(trib) * 0.8)], 500.0, 600.0)
        world.advance_spills(600.0)
    tinted = _frames(world, DisplayMode.ADVECTED)           # (the particles sample the tint)
    pool = world.pool
    live = np.flatnonzero(pool.alive & pool.has_world)
    drawn = live[np.isin(pool.status[live], (FlowStatus.INSIDE, FlowStatus.LEAVING))
                 & (pool.intensity[live] > 0)]              # the sprites on the water
    on = drawn[pool.tint[drawn, 3] > 0]
    assert len(on) >= 5 and len(on) < len(drawn)
    saved = pool.tint.copy()
    pool.tint[:, 3] = 0.0                                   # no particle carries a tint
    clean = _frames(world, DisplayMode.ADVECTED)
    pool.tint[on, :3] = (0.0, 1.0, 0.0)                     # … a green one
    pool.tint[on, 3] = saved[on, 3]
    green = _frames(world, DisplayMode.ADVECTED)
    pool.tint[:] = saved
    again = _frames(world, DisplayMode.ADVECTED)
    water = (_frames(world, DisplayMode.MESH) != _frames(world, DisplayMode.NONE)).any(axis=2)
    world.paused = False
    np.testing.assert_array_equal(again, tinted)
    mesh_water = (tinted != clean).any(axis=2)
    assert mesh_water.sum() > 50
    # towards the spill's colour (mud: red over blue), and green for the green tint
    d = tinted[mesh_water] - clean[mesh_water]
    assert np.mean(d[:, 0] - d[:, 2]) > 10
    g = green[mesh_water] - clean[mesh_water]
    assert np.mean(g[:, 1] - g[:, 0]) > 10 and np.mean(g[:, 1] - g[:, 2]) > 10
    # no further than a sprite's disc (3 r) from a tinted particle's centre
    yy, xx = np.mgrid[0:H, 0:W]
    centres = pool.screen_px[on]
    near = np.zeros((H, W), bool)
    for cx, cy in centres:                                   # screen y up, image row 0 at top
        near |= np.hypot(xx + 0.5 - cx, (H - 1 - yy) + 0.5 - cy) <= 3 * R + 1
    assert not (mesh_water & ~near).any()
    # the tinted particles are in the plume: the exact concentration within a texel of them
    side = world._drawer().gpu.spill_tint.rect_m[2]
    texel = side / 256
    xy = pool.world_m[on, :2]
    around = np.concatenate([xy + o for o in ((0, 0), (texel, 0), (-texel, 0), (0, texel),
                                              (0, -texel))])
    c = world.concentration(around).reshape(5, -1).max(axis=0)
    assert (c > 0).all()
    # smooth at its edge: where the tint ends, the neighbouring pixel was hardly tinted
    mag = np.abs(tinted - clean)[:, :, :3].sum(axis=2).astype(float)
    jumps = []
    for a, b, wet in ((mag[:, 1:], mag[:, :-1], water[:, 1:] & water[:, :-1]),
                      (mag[1:, :], mag[:-1, :], water[1:, :] & water[:-1, :])):
        edge = ((a == 0) != (b == 0)) & wet                 # between two water pixels
        jumps.append(np.maximum(a, b)[edge])
    jumps = np.concatenate(jumps)
    assert jumps.max() <= 0.25 * mag.max()
