"""Never a frame of fog (issue #29 item 5): a world drawn before it was ever stepped makes
its view's tiles and particles first, and a new world looks at its river."""
from __future__ import annotations

import numpy as np
import pytest

import riverflow as rf

pytestmark = pytest.mark.gl


def test_render_before_any_step_shows_the_river(gl_context):
    scene = rf.default_scene(seed=0)
    with rf.RiverWorld(scene, size=(160, 90), gl=True, seed=0) as world:
        frame = world.render()                   # no camera call, no step, no load_view
        assert world.tiles.scheduler.pending == 0
        p = world.particles
        assert len(p) > 20 and np.mean(p.status == rf.FlowStatus.INSIDE) >= 0.5
        world.display.mode = rf.DisplayMode.COVERAGE   # water: red covered, green not yet
        covered = world.render()                  # (new particles fade in over fade_in_s)
    assert frame[..., :3].std() > 10                       # not a frame of haze
    r, g, b = (covered[..., k].astype(int) for k in range(3))
    water = ((r > 2 * g) & (r > 60)) | ((g > 2 * r) & (g > 2 * b) & (g > 200))
    assert water.mean() > 0.3                              # the river fills the view


def _frames(scene, **config) -> list[np.ndarray]:
    with rf.RiverWorld(scene, size=(160, 90), gl=True, seed=0,
                       config=rf.RiverConfig(**config)) as world:
        out = []
        for f in range(40):
            world.camera.look_at((-1770 + 2.0 * f, -130, 75), (-1715 + 2.0 * f, -110, 45))
            world.step(1 / 60)
            if f % 13 == 0:
                out.append(world.render())
        return out


def test_drawn_frames_do_not_depend_on_when_tiles_were_made(gl_context):
    """The same script drawn with background and with blocking production: the same
    frames, byte for byte (a deterministic frame reads no stand-in, drawn or simulated);
    the second world takes the scene's array tiles from its memo, and a world over a scene
    that keeps none makes every tile itself: the same frames again."""
    from riverflow.tiles.memo import TileMemo

    scene = rf.default_scene(seed=0)
    scene.tile_memo = TileMemo()           # its own: the first world makes the tiles
    background = _frames(scene)
    memo = scene.tile_memo
    kept, hits = len(memo), memo.hits
    assert kept > 20 and 0 < memo.bytes <= memo.budget_bytes
    blocking = _frames(scene, tile_production="blocking")
    assert memo.hits - hits >= kept // 2
    alone = rf.default_scene(seed=0)
    alone.tile_memo = TileMemo(0)
    made = _frames(alone, tile_production="blocking")
    assert len(alone.tile_memo) == 0
    for a, b, c in zip(background, blocking, made, strict=True):
        assert np.array_equal(a, b)
        assert np.array_equal(a, c)
