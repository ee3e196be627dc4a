"""Water over its banks (issue 25): with the flood's level 1 m above the bank top, the ground
drawn flooded (the terrain shader's under-water material, ``shaders/flood.glsl``) across a
section of the valley is as wide as the section's terrain below that level, within one
terrain cell; it falls back with the water."""
from __future__ import annotations

import numpy as np
import pytest

from riverflow.components.display import DisplayMode
from riverflow.engine.config import RiverConfig
from riverflow.scenes.default import default_scene
from tests.engine.cell_networks import flood_over_the_banks

pytestmark = pytest.mark.gl
W, H = 256, 256
UNDER_AT_M = -0.05
"""The debug material's 'under' weight (1 − smoothstep(−0.12, 0.02, height above the level))
crosses ½ this far above the level [m]."""


@pytest.fixture(scope="module")
def setup(gl_context):
    from riverflow.engine.world import RiverWorld
    scene = default_scene(seed=0)
    line = scene.branch("tributary").centerline_m
    k = len(line) // 2
    centre = line[k]
    t = line[k + 1] - line[k - 1]
    t = t / np.hypot(*t)
    w = RiverWorld(scene, size=(W, H), gl=True, seed=0,
                   config=RiverConfig(tile_production="blocking"))
    w.camera.look_at((centre[0], centre[1], 420.0), (centre[0], centre[1], 0.0),
                     up=(t[0], t[1], 0.0))
    w.load_view()
    w.step(1 / 60)
    w.paused = True
    yield w, scene, centre, np.array([-t[1], t[0]])
    w.close()


def _wet_width(world, centre, normal, level_m):
    """(drawn, expected) wetted width [m] across the section through ``centre`` along
    ``normal``: the pixels drawn 'under' water (debug materials, water not drawn) against the
    terrain's heights below ``level_m`` at the same points."""
    drawer = next(s for s in world.systems if s.name == "draw")
    drawer.debug_materials = True
    world.display.mode = DisplayMode.NONE
    try:
        image = world.render()
    finally:
        drawer.debug_materials = False
        world.display.mode = DisplayMode.ADVECTED
    off = np.arange(-130.0, 130.0, 0.25)
    pts = centre[None, :] + off[:, None] * normal[None, :]
    z = world.scene.terrain.height(pts)
    clip = np.column_stack([pts, z, np.ones(len(pts))]) @ world.camera.view_projection(np.float64)
    ndc = clip[:, :2] / clip[:, 3:4]
    px = np.clip(((ndc[:, 0] + 1) * 0.5 * W).astype(int), 0, W - 1)
    py = np.clip(((1 - ndc[:, 1]) * 0.5 * H).astype(int), 0, H - 1)
    assert np.all(np.abs(ndc) < 1)                          # the whole section is in view
    drawn = image[py, px, 2] > 127
    expected = z - level_m < UNDER_AT_M
    return 0.25 * drawn.sum(), 0.25 * expected.sum()


def test_the_flooded_width_matches_the_valley_section(setup):
    world, scene, centre, normal = setup
    base = float(scene.water.level(centre[None])[0])
    cell = float(scene.terrain.cell_m)                    # the finest terrain cell [m]
    dry, dry_expected = _wet_width(world, centre, normal, base)
    rise, ratio, q0 = flood_over_the_banks(world)          # 1 m above the bank top
    router = world.flood
    assert float(router.level_rise(centre[None])[0]) == pytest.approx(rise, rel=0.02)
    level = float(world.water_level(centre[None])[0])
    drawn, expected = _wet_width(world, centre, normal, level)
    assert expected > dry_expected + 10.0                 # the water is over its banks
    assert drawn == pytest.approx(expected, abs=cell)
    # back to base flow: the drawn extent falls back
    t = world.flood_time_s
    world.set_hydrograph(None, [t, t + 1.0], [ratio * q0, q0])
    world.advance_flood(12 * 3600.0)
    back, _ = _wet_width(world, centre, normal, base)
    assert back == pytest.approx(dry, abs=1.0)

