"""Lifetimes: a RiverWorld dropped without close() gives back its tile worker thread and process, its esper
world (esper's module-level registry held every entity, pool and tile cache of it) and its
memory; ``with`` and close() still work; GPU objects go with the world (tests/render)."""
from __future__ import annotations

import gc
import multiprocessing
import os
import sys
import threading
import time
import weakref

import esper
import numpy as np
import pytest

import riverflow as rf
from riverflow.engine.config import RiverConfig
from riverflow.tiles.cache import TileCache
from riverflow.tiles.scheduler import Producer, TileScheduler
from tests.engine.flight import flight_pose

FRAME_S = 1.0 / 60.0
WORLDS = 50


@pytest.fixture(scope="module")
def scene():
    return rf.default_scene(seed=0)


def _background_world(scene, frames: int = 4) -> rf.RiverWorld:
    world = rf.RiverWorld(scene, size=(160, 90), gl=False, seed=0,
                          config=RiverConfig(tile_production="background",
                                             deterministic=False))
    for f in range(frames):
        world.camera.look_at(*flight_pose(scene, f))
        world.step(FRAME_S)
    return world


def _workers() -> list[threading.Thread]:
    return [t for t in threading.enumerate() if t.name == "riverflow-tiles"]


def _our_esper_worlds() -> set[str]:
    return {name for name in esper.list_worlds() if name.startswith("riverflow-")}


def _rss_mb() -> float:
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 2**20


def _settle(threads: int, timeout_s: float = 10.0) -> int:
    end = time.perf_counter() + timeout_s
    while threading.active_count() > threads and time.perf_counter() < end:
        time.sleep(0.02)
    return threading.active_count()


def test_a_dropped_world_is_freed_at_once_and_releases_its_thread_and_esper_world(scene):
    """No reference cycle holds a world: dropping the last reference frees it (with the
    cyclic collector off), and its finalizer ends the worker and deletes the esper world then,
    on the thread that dropped it."""
    before = set(threading.enumerate())
    esper_before = _our_esper_worlds()
    enabled = gc.isenabled()
    gc.disable()
    try:
        world = _background_world(scene)
        workers = [t for t in threading.enumerate() if t not in before]
        n = world.tiles.scheduler.workers          # (RiverConfig.tile_workers)
        assert [t.name for t in workers] == ["riverflow-tiles"] * n
        assert world.name in esper.list_worlds()
        ref = weakref.ref(world)
        cache = weakref.ref(world.tiles.cache)
        pids = world.tiles.scheduler.worker_pids
        assert len(pids) == n or world.tiles.scheduler.worker == "thread"
        assert sys.getrefcount(world) == 2, gc.get_referrers(world)
        del world
        assert ref() is None, "a reference cycle holds the world"
        assert cache() is None, "a reference cycle holds the world's tiles"
        assert not any(t.is_alive() for t in workers), "a worker outlived its world"
        assert not set(pids) & {p.pid for p in multiprocessing.active_children()}, \
            "a tile process outlived its world"
        assert _our_esper_worlds() == esper_before, "esper still holds the dropped world"
    finally:
        if enabled:
            gc.enable()


@pytest.mark.slow
def test_fifty_dropped_worlds_give_back_their_threads_and_memory(scene):
    if not os.path.exists("/proc/self/statm"):
        pytest.skip("RSS is read from /proc (Linux)")
    _background_world(scene)              # one-time costs: imports, kernels, scene tables
    gc.collect()
    threads = _settle(threading.active_count() - len(_workers()))
    processes = len(multiprocessing.active_children())
    rss = _rss_mb()
    esper_before = _our_esper_worlds()
    for _ in range(WORLDS):
        _background_world(scene)          # made, stepped and dropped without close()
    gc.collect()
    assert _settle(threads) == threads, [t.name for t in threading.enumerate()]
    assert not _workers()
    assert len(multiprocessing.active_children()) == processes
    assert _our_esper_worlds() == esper_before
    grown = _rss_mb() - rss
    assert grown < 50.0, f"RSS grew {grown:.0f} MB over {WORLDS} dropped worlds"


def test_a_world_dropped_after_a_loading_screen_is_freed_at_once(scene):
    """load_view freezes what is alive for the collector (RiverConfig.freeze_gc_on_load):
    a world dropped after it is still freed, by reference counting alone."""
    world = rf.RiverWorld(scene, size=(160, 90), gl=False, seed=0)
    try:
        world.camera.look_at(*flight_pose(scene, 0))
        assert world.load_view(60.0)
        assert gc.get_freeze_count() > 0
        ref, cache = weakref.ref(world), weakref.ref(world.tiles.cache)
        del world
        assert ref() is None and cache() is None
    finally:
        gc.unfreeze()


def test_with_block_and_close_release_everything_once(scene):
    before = set(threading.enumerate())
    with _background_world(scene) as world:
        assert _workers()
        name = world.name
    assert set(threading.enumerate()) <= before
    assert name not in esper.list_worlds()
    world.close()                         # idempotent
    ref = weakref.ref(world)
    del world
    assert ref() is None


def test_closing_from_the_worker_thread_does_not_join_itself():
    """A finalizer runs where the collector ran, possibly in the tile worker itself: its
    scheduler.close() must end the worker without trying to join the current thread."""
    errors: list[BaseException] = []

    class ClosesItsScheduler(Producer):
        kind = "x"

        def produce(self, key, deps):
            try:
                scheduler.close()
            except BaseException as exc:  # noqa: BLE001 - recorded for the assertion
                errors.append(exc)
            return object()

    scheduler = TileScheduler(TileCache(1 << 20), [ClosesItsScheduler()], "background")
    scheduler.request("x", np.array([[0, 0, 0]]))
    (worker,) = scheduler._threads
    worker.join(timeout=10.0)
    assert not errors, errors
    assert not worker.is_alive()
