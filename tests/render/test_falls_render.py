"""A fall drawn (issue #23), offscreen on Mesa's llvmpipe, tiny frames: seen from the side, the
water covers the band between lip and pool where the ground shows without it; the plunge pool
is whiter than the river 50 m below it (the foam mode)."""
from __future__ import annotations

import numpy as np
import pytest

import riverflow as rf
from riverflow.components.display import DisplayMode
from riverflow.engine.config import RiverConfig
from tests.hydro.test_falls import DROP, LIP_X, _straight

pytestmark = pytest.mark.gl
W, H = 160, 90


@pytest.fixture(scope="module")
def world(gl_context):
    scene = rf.landscape(_straight().build(), seed=0)
    w = rf.RiverWorld(scene, size=(W, H), gl=True, seed=0,
                      config=RiverConfig(radius_px=5.0, tile_production="blocking"))
    yield w
    w.close()


def _lip(world) -> float:
    return float(world.scene.water.level(np.array([[LIP_X, 0.0]]))[0])


def test_a_fall_seen_from_the_side_is_a_sheet_of_water(world):
    (f,) = world.scene.graph.falls
    lip = _lip(world)
    # from the pool's side, obliquely, a little above the pool
    world.camera.look_at((LIP_X + 25.0, -14.0, lip - DROP + 2.0),
                         (LIP_X + 0.5 * f.throw_m, 0.0, lip - 0.5 * DROP))
    for _ in range(10):
        world.step(1 / 30)
    frames = {}
    for mode in (DisplayMode.NONE, DisplayMode.MESH):
        world.display.mode = mode
        frames[mode] = world.render()[..., :3].astype(int)
    world.display.mode = DisplayMode.ADVECTED
    # the band the nappe spans on screen: between the lip and the pool, across the river
    corners = np.array([[LIP_X + 0.3 * f.throw_m, -6.0, lip - 0.09 * DROP],
                        [LIP_X + 0.7 * f.throw_m, 6.0, lip - 0.49 * DROP]])
    px, _, front = world.camera.world_to_screen(corners)
    assert front.all()
    x0, x1 = sorted(px[:, 0].astype(int))
    y0, y1 = sorted((H - px[:, 1]).astype(int))          # rows from the top
    band = (slice(max(y0, 0), min(y1 + 1, H)), slice(max(x0, 0), min(x1 + 1, W)))
    changed = np.abs(frames[DisplayMode.MESH][band] - frames[DisplayMode.NONE][band]).sum(-1)
    assert changed.size >= 20
    assert (changed > 30).mean() > 0.8        # water where the ground showed


def test_the_plunge_pool_is_whiter_than_the_river_below(world):
    (f,) = world.scene.graph.falls
    lip = _lip(world)
    pool_x = LIP_X + f.throw_m + 4.0
    world.camera.look_at((pool_x + 25.0, -45.0, lip + 25.0), (pool_x + 25.0, 0.0, lip - DROP))
    for _ in range(60):
        world.step(1 / 30)
    world.render()      # the foam mode shows what the last water frame drew (as in
    world.display.mode = DisplayMode.FOAM   # tests/render/test_foam_wake_render.py)
    image = world.render()[..., :3].astype(float).mean(-1)
    world.display.mode = DisplayMode.ADVECTED
    probes = np.array([[pool_x + dx, dy, lip - DROP] for dx in (0.0, 50.0)
                       for dy in (-4.0, 0.0, 4.0)])
    px, _, front = world.camera.world_to_screen(probes)
    assert front.all()
    cols = px[:, 0].astype(int)
    rows = (H - px[:, 1]).astype(int)
    assert ((cols >= 0) & (cols < W) & (rows >= 0) & (rows < H)).all()
    bright = np.array([image[max(r - 1, 0):r + 2, max(c - 1, 0):c + 2].mean()
                       for r, c in zip(rows, cols)])
    pool, below = bright[:3].mean(), bright[3:].mean()
    assert pool > below + 20.0, (pool, below)
