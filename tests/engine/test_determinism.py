"""A run's result depends only on the scene, seed, camera script and frame times (SPEC §6):
never on the machine's load, on when the tile worker finished a tile, or on the production
mode (issue #27 item 1)."""
from __future__ import annotations

import subprocess
import sys
from contextlib import contextmanager

import numpy as np
import pytest

import riverflow as rf


@contextmanager
def cpu_load(processes: int = 1):
    """Busy processes for the block (another program hogging the machine: one is enough to
    take the worker's idle core, and more would slow the suite's other test worker). They run
    at the tile worker's own priority (nice 19): each takes the idle time the worker would
    have had, and leaves the suite's other test worker its core."""
    hogs = [subprocess.Popen([sys.executable, "-c", "import os; os.nice(19)\nwhile True: pass"])
            for _ in range(processes)]
    try:
        yield
    finally:
        for hog in hogs:
            hog.kill()
            hog.wait()


def readme_run(scene, **config) -> dict[str, np.ndarray]:
    """The README's "Particles, headless" snippet; every column of the live particles."""
    world = rf.RiverWorld(scene, size=(640, 360), seed=0,
                          config=rf.RiverConfig(radius_px=8, **config))
    try:
        world.camera.look_at((-1770, -130, 75), (-1715, -110, 45))
        for _ in range(120):
            world.step(1 / 60)
        p = world.particles
        assert not world.tiles.scheduler.errors
        return {name: np.asarray(getattr(p, name)).copy() for name in
                ("ids", "screen_px", "world_m", "intensity", "status", "velocity_mps", "foam")}
    finally:
        world.close()


def assert_same(a: dict, b: dict) -> None:
    for name in a:
        assert a[name].dtype == b[name].dtype and a[name].shape == b[name].shape, name
        assert a[name].tobytes() == b[name].tobytes(), f"{name} differs"


@pytest.fixture(scope="module")
def scene():
    from riverflow.tiles.memo import TileMemo

    scene = rf.default_scene(seed=0)
    scene.tile_memo = TileMemo(0)      # every run makes its own tiles, late or not, under load
    return scene


@pytest.fixture(scope="module")
def blocking(scene):
    return readme_run(scene, tile_production="blocking")


@pytest.mark.slow
def test_background_runs_are_the_same_under_load(scene, blocking):
    """Stepped back to back (no idle time for the worker) with another process busy, twice: the
    same particles bit for bit as each other and as blocking production, and on the water."""
    with cpu_load():
        first = readme_run(scene)
        second = readme_run(scene, tile_worker="thread")
    assert len(first["ids"]) > 300
    assert np.mean(first["status"] == rf.FlowStatus.INSIDE) >= 0.5   # not starved of tiles
    assert_same(first, second)
    assert_same(first, blocking)


def test_a_frame_never_reads_a_stand_in_by_default(scene):
    """Each deterministic frame finds every tile it asked for resident (the worker was
    waited for), so no particle reads a coarser parent standing in for a late tile."""
    from riverflow.components.river import TerrainView

    world = rf.RiverWorld(scene, size=(320, 180), seed=0)
    try:
        assert world.config.deterministic and world.config.tile_production == "background"
        system = next(s for s in world.systems if s.name == "tiles")
        for _ in range(3):
            world.step(1 / 60)
            flow = world.field.tiles
            assert system.visible["flow"] > 0
            assert int(flow.pool.arrays["in_cut"].sum()) == system.visible["flow"]
            terrain = world.resource(TerrainView)
            surface = terrain.surface
            assert len(terrain.cut) > 0
            assert (surface.leaf_slot >= 0).all() and (surface.hint_slot >= 0).all()
            assert np.array_equal(surface.leaf_key, terrain.cut)
            assert np.array_equal(surface.hint_key, terrain.cut)
        # the leaves' ancestors may still be queued for the worker: no frame reads them
    finally:
        world.close()


def test_a_frame_reads_its_cut_not_what_the_cache_still_holds(scene):
    """Finer flow tiles left in the cache (a gameplay query, an earlier closer view) do not
    change what a frame reads: from the cut's deepest level down, the tile of the frame's cut
    answers (``kernels.flow._locate``), not the first cached one."""
    from riverflow.kernels.flow import query_velocity
    from riverflow.scenes.flight import main_centerline

    field = rf.FlowField.for_scene(scene)
    line = main_centerline(scene)
    xy = np.ascontiguousarray(line[::5] + (0.25, 0.25))
    t = field.tiles
    coarse = field.max_level - 2
    field.query(xy, level=coarse)
    field.query(xy, level=coarse + 1)        # finer tiles cached under every point too
    keys = np.unique(field.tile_of(xy, coarse), axis=0)
    t.mark_cut(np.column_stack([np.full(len(keys), coarse), keys]).astype(np.int32))
    none = np.zeros(0, np.int8)

    def ask(level, fallback):
        status = np.empty(len(xy), np.uint8)
        velocity = np.empty((len(xy), 2), np.float32)
        query_velocity(xy, none, level, fallback, t.view(), t.cache.tick, field.segments,
                       len(xy), status, velocity)
        return status, velocity

    frame = ask(coarse + 1, coarse + 1)       # a frame's query, as if its cut went deeper
    cut = ask(coarse, 0)                      # the cut's own tiles
    finer = ask(coarse + 1, 0)
    assert (cut[0] == rf.FlowStatus.INSIDE).sum() > 50
    assert frame[0].tobytes() == cut[0].tobytes() and frame[1].tobytes() == cut[1].tobytes()
    assert finer[1].tobytes() != cut[1].tobytes()           # the cached finer tiles differ
