"""Floods drawn (issue 25): the drawn water surface rises by the flood's level rise (the
rating curve, ``FloodRouter.cell_level_rise_m``), read back from the water's world-position
pass; with no flood running the surface stays at its base level."""
from __future__ import annotations

import numpy as np
import pytest

from riverflow.components.display import DisplayMode
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
    yield w
    w.close()


def _surface(world) -> np.ndarray:
    """(H, W, 4) the world position (x, y, z, 1) of the water drawn at each pixel (w = 0: no
    water), from the pre-advected mode's position pass."""
    from riverflow.engine import gl
    world.display.mode = DisplayMode.PRE_ADVECTED
    try:
        world.render()
    finally:
        world.display.mode = DisplayMode.ADVECTED
    drawer = next(s for s in world.systems if s.name == "draw")
    return gl.read_texture(drawer.gpu.position).astype(np.float64)


def test_the_drawn_surface_rises_by_the_rating_curve_and_falls_back(setup):
    """The surface, the reflections' mirror and a boat rise with the flood, and fall back."""
    world = setup
    line = world.scene.branch("main_middle").centerline_m
    boat = world.add_boat(line[len(line) // 2], drawn=False)
    world.step(1 / 60)
    world.paused = True
    before = _surface(world)
    drawer = next(s for s in world.systems if s.name == "draw")
    mirror0 = drawer.last_mirror_level_m
    boat0 = world.boat(boat).altitude_m
    water = before[..., 3] > 0
    assert water.sum() > 100
    world.set_hydrograph(None, [], None)
    router = world.flood
    sources = [b for b in range(len(router.network.names)) if router.net.link_start[b] < 0]
    q0 = float(router.net.link_q0[sources].sum())
    t = world.flood_time_s
    world.set_hydrograph(None, [t, t + 1.0], [q0, 2.0 * q0])
    world.advance_flood(4 * 3600.0)                        # steady at twice the base flow
    after = _surface(world)
    eye = np.array([world.camera.position[:2]], np.float64)
    assert mirror0 is not None and drawer.last_mirror_level_m == pytest.approx(
        mirror0 + float(router.level_rise(eye)[0]), abs=1e-6)
    world.paused = False
    world.step(1e-4)                                           # the boat system runs
    world.paused = True
    b = world.boat(boat)
    assert b.altitude_m - boat0 == pytest.approx(
        float(router.level_rise(b.position_m[None])[0]), abs=0.1)   # (and its bob)
    both = water & (after[..., 3] > 0)
    xy = after[both][:, :2]
    rise = router.level_rise(xy)      # the rating curve's rise there, blended across links
    nearest = router._at(router.cell_level_rise_m(), xy, 0.0)      # the nearest cell's
    assert np.median(np.abs(rise - nearest)) < 0.01       # the same but where links meet
    assert rise.min() > 0.3                               # a real rise, everywhere in view
    # the same water seen at a pixel moves in x, y as it rises: compare with the base level
    # at the point now drawn (the base mesh's level, read before at the nearest pixel)
    base_xyz = before[water][:, :3]
    from scipy.spatial import cKDTree
    d, k = cKDTree(base_xyz[:, :2]).query(xy)
    near = d < 2.0
    assert near.sum() > 50
    drawn_rise = after[both][near, 2] - base_xyz[k[near], 2]
    # away from the junctions (there the links' rises differ, and the mesh's triangles blend
    # them between their vertices)
    ends = np.array([line[[0, -1]] for line in router.network.lines]).reshape(-1, 2)
    far = cKDTree(ends).query(xy[near])[0] > 80.0
    assert far.sum() > 50 and len(np.unique(np.round(rise[near][far], 2))) >= 2
    np.testing.assert_allclose(drawn_rise[far], rise[near][far], atol=0.05)
    # back to base flow: the surface falls back
    t = world.flood_time_s
    world.set_hydrograph(None, [t, t + 1.0], [2.0 * q0, q0])
    world.advance_flood(8 * 3600.0)
    back = _surface(world)
    same = water & (back[..., 3] > 0)
    assert np.abs(back[same][:, 2] - before[same][:, 2]).max() < 0.02
    world.paused = False
