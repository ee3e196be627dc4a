"""The terrain's shading (issue 12, item 5), drawn for real (offscreen, the water off so that
the ground itself is seen): grass on the flat, rock on a steep slope, sand on the shore, wet
ground darker just above the water line, the river bed darker with depth, detail at close
range that fades far away without shimmering.

The scene: a straight channel 40 m wide across a flat plain, and 250 m north of it a ridge
rising 40 m over 25 m (58°), out of reach of the river's carving. Each probe looks straight
down on its spot from close above and reads the pixels there.
"""
from __future__ import annotations

import numpy as np
import pytest

import riverflow as rf

pytestmark = pytest.mark.gl
W, H = 160, 96
HALF_WIDTH_M = 20.0


def _ground(x, y):
    x, y = np.broadcast_arrays(np.asarray(x, float), np.asarray(y, float))
    return 20.0 + 40.0 * np.clip((y - 260.0) / 25.0, 0.0, 1.0)


@pytest.fixture(scope="module")
def world(gl_context):
    b = rf.RiverNetworkBuilder()
    b.add_branch([(-600.0, 0.0), (600.0, 0.0)], 2 * HALF_WIDTH_M, discharge_m2s=40.0)
    scene = rf.landscape(b.build(), terrain=_ground, cell_m=1.0)
    w = rf.RiverWorld(scene, size=(W, H), gl=True, seed=0,
                      config=rf.RiverConfig(tile_production="blocking"))
    w.display.mode = rf.DisplayMode.NONE
    yield w
    w.close()


def _look_down(world, xy, height_m: float = 25.0) -> tuple[np.ndarray, np.ndarray]:
    """The frame (H, W, 3) float 0-1 seen from ``height_m`` above the ground at ``xy``, and
    the pixel (row, column) of ``xy``."""
    z = float(world.scene.terrain.height(np.array([xy], float))[0])
    target = np.array([xy[0], xy[1], z])
    world.camera.look_at(target + (0.0, -0.01 * height_m, height_m), target, up=(0.0, 1.0, 0.0))
    world.load_view()
    frame = world.render()[..., :3].astype(float) / 255.0
    px, _, _ = world.camera.world_to_screen(target[None])
    return frame, np.array([H - 1 - int(px[0, 1]), int(px[0, 0])])


def _colour_at(world, xy, height_m: float = 25.0, r: int = 2) -> np.ndarray:
    frame, (row, col) = _look_down(world, xy, height_m)
    return frame[row - r:row + r + 1, col - r:col + r + 1].reshape(-1, 3).mean(axis=0)


def _luma(c) -> float:
    return float(np.dot(c, (0.299, 0.587, 0.114)))


def test_grass_on_the_flat_rock_on_the_steep_slope(world):
    grass = np.mean([_colour_at(world, (x, 120.0)) for x in (-40.0, 0.0, 40.0)], axis=0)
    rock = np.mean([_colour_at(world, (x, 272.0)) for x in (-40.0, 0.0, 40.0)], axis=0)
    assert grass[1] > grass[0] + 0.05 and grass[1] > grass[2] + 0.1     # green
    spread = lambda c: float(c.max() - c.min())                          # noqa: E731
    assert spread(rock) < 0.5 * spread(grass)                            # grey
    top = np.mean([_colour_at(world, (x, 300.0)) for x in (-40.0, 0.0, 40.0)], axis=0)
    assert top[1] > top[0] + 0.05                                        # flat top: grass again


@pytest.mark.slow
def test_shore_sand_wet_line_and_a_bed_darker_with_depth(world):
    """Mean colours along both shores (the north one faces the sun, the south one away: their
    mean is lit about as the flat), at distances from the water line."""
    xs = np.linspace(-150.0, 150.0, 7)
    level = float(world.scene.water.level(np.array([[0.0, 0.0]]))[0])

    def across(offset_m):
        return np.mean([_colour_at(world, (x, s * (HALF_WIDTH_M + offset_m)), 12.0, r=1)
                        for x in xs for s in (1.0, -1.0)], axis=0)

    grass, dry, wet = across(40.0), across(1.5), across(0.3)
    shallow, deep = across(-0.5), across(-HALF_WIDTH_M)
    # the carving: ground 0.3 m out lies a few centimetres above the water, 1.5 m out
    # ~0.3 m, the middle of the river well under it
    z = world.scene.terrain.height(np.array([[0.0, HALF_WIDTH_M + 0.3],
                                             [0.0, HALF_WIDTH_M + 1.5], [0.0, 0.0]]))
    assert 0.0 < z[0] - level < 0.1 and 0.2 < z[1] - level < 0.5 and z[2] < level - 1.0
    sandy = lambda c: c[0] > 0.95 * c[1] and c[1] > c[2] + 0.05           # noqa: E731
    assert grass[1] > 1.2 * grass[0] and sandy(dry)                      # green, then tan
    assert _luma(dry) > _luma(grass) + 0.05                              # sand is lighter
    assert _luma(wet) < 0.85 * _luma(dry)                                # wet is darker
    assert sandy(shallow)                                                # a sandy bed …
    assert _luma(deep) < 0.8 * _luma(shallow)                            # … darker with depth


def test_detail_close_up_fades_far_away_and_does_not_shimmer(world):
    near, _ = _look_down(world, (0.0, 140.0), 4.0)          # 4 m up: a pixel ~3 cm
    far, (row, col) = _look_down(world, (0.0, 140.0), 400.0)   # 400 m up: a pixel ~3 m
    far = far[row - 8:row + 8, col - 8:col + 8]             # ~50 m of grass, nothing else
    assert np.std(near[..., 1]) > 0.02                      # grass detail up close
    # far away a 1/4-pixel move must not change the picture much (no aliased detail)
    z = float(world.scene.terrain.height(np.array([[0.0, 140.0]]))[0])
    moved = []
    for dx in (0.0, 0.8):
        target = np.array([dx, 140.0, z])
        world.camera.look_at(target + (0.0, -30.0, 300.0), target, up=(0.0, 1.0, 0.0))
        world.load_view()
        moved.append(world.render()[..., :3].astype(float) / 255.0)
    diff = np.abs(moved[0] - moved[1])
    assert np.mean(diff) < 0.02 and np.percentile(diff, 99) < 0.1, (np.mean(diff),
                                                                   np.percentile(diff, 99))
    assert np.std(far[..., 1]) < np.std(near[..., 1])
