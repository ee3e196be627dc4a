"""The sprite pipeline under stress, drawn for real: a pool with every slot live (some of them
garbage), an empty one, and the grid the GPU makes read back against its twin in a real frame."""
from __future__ import annotations

import numpy as np
import pytest

from riverflow.components.display import DisplayMode
from riverflow.components.status import FlowStatus
from riverflow.engine.config import RiverConfig
from riverflow.kernels.sprites import SPRITE_RADIUS_FACTOR, TEXELS_PER_PARTICLE
from riverflow.scenes.default import default_scene
from riverflow.scenes.flight import fly
from tests.kernels import sprites_reference as ref

pytestmark = pytest.mark.gl
W, H, R = 160, 90, 5.0


@pytest.fixture(scope="module")
def world(gl_context):
    from riverflow.engine.world import RiverWorld
    w = RiverWorld(default_scene(seed=0), size=(W, H), gl=True, seed=0,
                   config=RiverConfig(radius_px=R, tile_production="blocking"))
    fly(w, 120)
    yield w
    w.close()


def _render(world, mode):
    from riverflow.engine import gl
    world.display.mode = mode
    frame = world.render()
    gl.check_errors(f"rendering {mode.name}")
    return frame


def _saved(pool):
    return {name: column.copy() for name, column in pool.columns().items()}


def _restore(pool, saved):
    for name, column in saved.items():
        getattr(pool, name)[...] = column


def test_the_grid_of_a_real_frame_matches_its_twin(world):
    from riverflow.engine import gl
    _render(world, DisplayMode.ADVECTED)
    drawer = world._drawer()
    gpu = drawer.gpu
    n = drawer.last_sprites
    table = gpu.params.read().reshape(-1, TEXELS_PER_PARTICLE, 4)[:n]
    cell, gw, gh = gpu.grid_shape
    yes = np.ones(n, bool)
    want, _ = ref.build_sprite_grid(yes, yes, table[:, 0, :2], table[:, 1, 2],
                                    table[:, 2, 0].astype(np.uint8), n,
                                    SPRITE_RADIUS_FACTOR * R, float(cell), gw, gh)
    got = ref.grid_lists(gl.read_texture(gpu.grid))
    assert n > 30 and sum(map(len, want)) > 10 * n
    assert [sorted(c) for c in got] == [sorted(c) for c in want]


def test_a_full_pool_with_garbage_draws_a_sane_frame(world, rng):
    pool = world.pool
    saved = _saved(pool)
    before = _render(world, DisplayMode.ADVECTED)
    try:
        live = np.flatnonzero(pool.alive & pool.has_world)
        c = pool.capacity
        donor = rng.choice(live, c)                 # every slot live, at a real particle's place
        for name in ("world_m", "offset_m", "velocity_mps"):
            getattr(pool, name)[...] = getattr(pool, name)[donor]
        pool.screen_px[...] = pool.screen_px[donor] + rng.normal(0, 0.5, (c, 2))
        pool.alive[:] = True
        pool.has_world[:] = True
        pool.status[:] = FlowStatus.INSIDE
        pool.intensity[:] = rng.uniform(0.05, 1.0, c).astype(np.float32)
        pool.counters[1] = pool.counters[2] = c
        bad = rng.choice(c, 40, replace=False)
        pool.screen_px[bad[:10], 0] = np.nan
        pool.world_m[bad[10:20], 2] = np.inf
        pool.intensity[bad[20:30]] = np.nan
        pool.screen_px[bad[30:], 1] = 1e30
        frames = {mode: _render(world, mode) for mode in (DisplayMode.ADVECTED,
                                                          DisplayMode.COVERAGE,
                                                          DisplayMode.PRE_ADVECTED)}
        drawer = world._drawer()
        assert drawer.last_sprites > 2 * len(live)
        for mode, frame in frames.items():
            assert (frame[..., 3] == 255).all() and frame[..., :3].std() > 5.0, mode
        cover = frames[DisplayMode.COVERAGE]
        assert (cover[..., 2] == 255).any()          # piled-up cells are full (blue)
        water = (before != _render(world, DisplayMode.NONE)).any(axis=2)
        assert np.abs(frames[DisplayMode.ADVECTED][water].astype(int)
                      - before[water].astype(int)).mean() < 60    # still water, not noise
    finally:
        _restore(pool, saved)
    assert np.array_equal(_render(world, DisplayMode.ADVECTED), before)


def test_an_empty_pool_falls_back_to_the_plain_texture_in_every_sprite_mode(world):
    pool = world.pool
    saved = _saved(pool)
    try:
        pool.clear()
        plain = _render(world, DisplayMode.NON_ADVECTED)
        assert np.array_equal(_render(world, DisplayMode.ADVECTED), plain)
        assert np.array_equal(_render(world, DisplayMode.PRE_ADVECTED), plain)
        cover = _render(world, DisplayMode.COVERAGE)
        water = (plain != _render(world, DisplayMode.NONE)).any(axis=2)
        assert (cover[water][:, 1] == 255).all() and not cover[water][:, 0].any()
        assert world._drawer().last_sprites == 0
    finally:
        _restore(pool, saved)
