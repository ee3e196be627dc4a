"""The scheduler: dependencies first, blocking and background production, identical results
whatever the cache size or the order tiles are asked in, failures that never crash a frame."""
from __future__ import annotations

import multiprocessing
import os
import threading
import time

import numpy as np
import pytest

from riverflow.tiles.cache import FieldSpec, TileCache
from riverflow.tiles.quadtree import Quadtree, parent
from riverflow.tiles.scheduler import Producer, TileScheduler, close_all
from riverflow.tiles.table import code_key, tile_code

N = 8


class Heights(Producer):
    kind = "h"
    fields = {"z": FieldSpec((N + 1, N + 1), np.float64, np.nan)}

    def __init__(self) -> None:
        self.quadtree = Quadtree(0.0, 0.0, 1024.0)
        self.made = 0
        self.threads: set[str] = set()

    def produce(self, key, deps):
        self.made += 1
        self.threads.add(threading.current_thread().name)
        x, y = self.quadtree.node_coords(*key, N)
        return {"z": np.sin(x[None, :] / 37.0) + np.cos(y[:, None] / 53.0)}


class Slopes(Producer):
    """Reads the height tile of the same key and of its parent."""

    kind = "s"
    fields = {"dz": FieldSpec((N + 1, N + 1), np.float64, np.nan)}

    def dependencies(self, key):
        up = parent(key)
        return [("h", key)] + ([("h", up)] if up else [])

    def is_empty(self, key):
        return key == (1, 1, 1)

    def produce(self, key, deps):
        z = deps[("h", key)]["z"]
        up = parent(key)
        base = 0.0 if up is None else float(deps[("h", up)]["z"][0, 0])
        return {"dz": np.gradient(z, axis=1) + base}


class Broken(Producer):
    kind = "b"

    def produce(self, key, deps):
        raise FloatingPointError("a NaN in the source")


def _keys(level: int) -> np.ndarray:
    side = 1 << level
    j, i = np.mgrid[0:side, 0:side]
    return np.stack([np.full(side * side, level), i.ravel(), j.ravel()], 1)


def _run(budget_bytes: int, mode: str, order: np.ndarray) -> dict:
    cache = TileCache(budget_bytes)
    sched = TileScheduler(cache, [Heights(), Slopes()], mode)
    out = {}
    for key in order:
        cache.next_tick()
        sched.request("s", key[None])
        assert sched.wait(10.0)
        pool = cache.pools["s"]
        got = pool.get(tile_code(*key))
        if tuple(key) == (1, 1, 1):
            assert got is None  # empty: never made
            continue
        out[tuple(key)] = got["dz"].copy()
    sched.close()
    return out


def test_dependencies_are_made_first_and_results_do_not_depend_on_history():
    keys = np.concatenate([_keys(0), _keys(1), _keys(2), _keys(3)])
    tile = Heights().fields["z"].nbytes
    unbounded = _run(1 << 30, "blocking", keys)
    rng = np.random.default_rng(1)
    shuffled = keys[rng.permutation(len(keys))]
    tiny = _run(3 * tile, "blocking", shuffled)          # tiles evicted and made again
    background = _run(1 << 30, "background", shuffled[::-1])
    assert unbounded.keys() == tiny.keys() == background.keys()
    for key, value in unbounded.items():
        assert np.array_equal(value, tiny[key]) and np.array_equal(value, background[key]), key


def test_background_mode_makes_tiles_in_the_worker_and_installs_in_collect():
    cache = TileCache(1 << 30)
    heights = Heights()
    sched = TileScheduler(cache, [heights, Slopes()], "background")
    sched.max_starts = 16
    assert sched.request("s", _keys(2)) > 16        # slope tiles and their height tiles
    assert len(cache.pools["s"]) == 0                 # nothing installed before a collect
    assert sched.wait(10.0)
    assert len(cache.pools["s"]) == 16 and len(cache.pools["h"]) == 16 + 4
    assert heights.threads == {"riverflow-tiles"}
    assert sched.request("s", _keys(2)) == 0          # resident: nothing more to do
    assert cache.pools["h"].pins.sum() == 0           # dependencies unpinned once used
    sched.close()


def _hold(producer) -> threading.Event:
    """Make ``producer`` wait for the returned event before each tile (a busy worker)."""
    gate = threading.Event()
    original = producer.produce

    def held(key, deps):
        gate.wait(5.0)
        return original(key, deps)

    producer.produce = held
    return gate


def test_requests_no_frame_repeats_are_dropped_unmade():
    cache = TileCache(1 << 30)
    heights = Heights()
    sched = TileScheduler(cache, [heights], "background", stale_frames=2)
    gate = _hold(heights)
    sched.request("h", _keys(3))                      # 64 queued, the worker waits on the first
    for _ in range(5):
        sched.collect()                               # frames that no longer ask for them
    gate.set()
    assert sched.wait(10.0)
    assert heights.made < 8
    sched.close()


def test_a_failing_producer_is_reported_not_raised_and_not_retried():
    cache = TileCache(1 << 30)
    for mode in ("blocking", "background"):
        sched = TileScheduler(cache if mode == "blocking" else TileCache(1 << 20), [Broken()], mode)
        sched.request("b", [(0, 0, 0)])
        assert sched.wait(5.0)
        assert len(sched.errors) == 1 and "FloatingPointError" in sched.errors[0]
        assert "(0, 0, 0)" in sched.errors[0]
        assert sched.request("b", [(0, 0, 0)]) == 0
        sched.close()


def test_the_worker_ends_when_the_scheduler_is_dropped():
    import gc
    import time

    sched = TileScheduler(TileCache(1 << 20), [Heights()], "background")
    sched.request("h", [(0, 0, 0)])
    sched.wait(5.0)
    (thread,) = sched._threads
    del sched
    gc.collect()
    thread.join(timeout=5.0)
    assert not thread.is_alive()
    time.sleep(0)


def test_bad_mode_and_duplicate_kinds_are_refused():
    with pytest.raises(ValueError, match="mode"):
        TileScheduler(TileCache(1 << 20), [], "sometimes")
    with pytest.raises(ValueError, match="already"):
        TileScheduler(TileCache(1 << 20), [Heights(), Heights()])


def test_forget_unrequested_lets_wait_make_only_the_latest_frame_s_tiles():
    """After a teleport: the requests of earlier frames are let go, the latest frame's are
    made (a loading screen waits for the current view only)."""
    cache = TileCache(1 << 30)
    heights = Heights()
    sched = TileScheduler(cache, [heights], "background", stale_frames=1000)
    sched.max_starts = 1000
    gate = _hold(heights)
    sched.request("h", _keys(3))                      # the old view: 64 tiles
    sched.collect()
    new = np.array([[1, 0, 0], [1, 1, 0]])
    sched.request("h", new)                           # the new view, this frame
    assert sched.forget_unrequested() >= 60
    gate.set()
    assert sched.wait(10.0)
    assert heights.made <= 4                          # the new view (+ the one in the worker)
    assert all(tile_code(*k) in cache.pools["h"] for k in new.tolist())
    sched.close()


class _Base(Producer):
    kind = "base"
    fields = {"z": FieldSpec((4,), np.float64, 0.0)}

    def __init__(self, gate: threading.Event) -> None:
        self.gate = gate
        self.made = 0

    def produce(self, key, deps):
        self.gate.wait(5.0)
        self.made += 1
        return {"z": np.full(4, float(key[1]))}


class _Top(Producer):
    kind = "top"
    fields = {"z": FieldSpec((4,), np.float64, 0.0)}

    def __init__(self) -> None:
        self.made = 0

    def dependencies(self, key):
        return [("base", key)]

    def produce(self, key, deps):
        self.made += 1
        return {"z": deps[("base", key)]["z"] + 1.0}


def test_the_dependencies_of_stale_requests_are_not_made_and_come_back_when_asked():
    """A dependency is made only while a tile that waits for it is still wanted: after a fast
    flight the worker does not make the heights of views long passed. A tile dropped that way
    is not failed: asked for again, it is made (its dependency first)."""
    gate = threading.Event()
    base, top = _Base(gate), _Top()
    cache = TileCache(1 << 30)
    sched = TileScheduler(cache, [base, top], "background", stale_frames=30)
    keys = np.array([[7, i, 0] for i in range(100)])
    sched.request("top", keys)
    for _ in range(40):
        sched.collect()                               # 40 frames that ask for something else
    gate.set()
    assert sched.wait(20.0)
    assert base.made <= 2 and top.made == 0 and not sched.errors
    sched.request("top", keys[:3])                    # the view comes back
    assert sched.wait(20.0)
    assert top.made == 3 and not sched.errors
    assert cache.pools["top"].get(tile_code(7, 2, 0))["z"][0] == 3.0
    sched.close()


def test_pools_are_made_for_the_budget_and_do_not_grow_under_it():
    cache = TileCache(1 << 20)
    heights = Heights()
    sched = TileScheduler(cache, [heights], "blocking")
    pool = cache.pools["h"]
    assert pool.capacity >= (1 << 20) // pool.tile_bytes
    sched.request("h", _keys(4))                      # 256 tiles of 648 B: under the budget
    assert pool.grown == 0 and len(pool) == 256


def test_a_frame_queues_a_bounded_number_of_new_tiles_coarse_first():
    """Background mode: at most max_starts new tiles of a kind are queued a frame (the worker
    makes tens a second; the view asks again next frame), the coarsest first."""
    cache = TileCache(1 << 30)
    heights = Heights()
    sched = TileScheduler(cache, [heights], "background")
    gate = _hold(heights)
    keys = np.concatenate([_keys(3), [[1, 0, 0], [2, 1, 1]]])   # 64 fine, 2 coarse, last
    sched.max_starts = 16
    assert sched.request("h", keys) == sched.max_starts == 16
    queued = sorted(k[0] for (kind, code) in sched._pending for k in [code_key(code)])
    assert queued[:2] == [1, 2]                       # the coarse ones made it in
    sched.collect()
    assert sched.request("h", keys) == 16             # the next frame: 16 more
    gate.set()
    assert sched.wait(10.0)
    sched.close()


# -- the worker process (RiverConfig.tile_worker = "process") ------------------------------------

needs_fork = pytest.mark.skipif(not __import__("riverflow.tiles.remote", fromlist=["x"])
                                .fork_available(), reason="a forked tile process: Linux")


class WhereMade(Producer):
    """Records in its tile which process made it."""

    kind = "p"
    fields = {"pid": FieldSpec((1,), np.int64, 0), "z": FieldSpec((N + 1, N + 1), np.float64,
                                                                    np.nan)}

    def dependencies(self, key):
        return [("h", key)]

    def produce(self, key, deps):
        import os

        return {"pid": np.array([os.getpid()]), "z": deps[("h", key)]["z"] * 2.0}


@needs_fork
def test_a_worker_process_makes_the_same_tiles_as_the_thread_and_the_frame_process_none():

    keys = np.concatenate([_keys(0), _keys(1), _keys(2), _keys(3)])
    made = {}
    for worker in ("thread", "process"):
        cache = TileCache(1 << 30)
        heights = Heights()
        sched = TileScheduler(cache, [heights, WhereMade()], "background", worker=worker)
        sched.max_starts = 1000
        sched.request("p", keys)
        assert sched.wait(20.0)
        pool = cache.pools["p"]
        made[worker] = {k: pool.get(tile_code(*k))["z"].copy() for k in map(tuple, keys)}
        pids = {int(pool.get(tile_code(*k))["pid"][0]) for k in map(tuple, keys)}
        pid = sched.worker_pid
        if worker == "process":
            assert pid is not None and pids == {pid} and pid != os.getpid()
            assert heights.made == 0          # this process's producer made nothing
        else:
            assert pid is None and pids == {os.getpid()} and heights.made == len(keys)
        sched.close()
    for key, z in made["thread"].items():
        assert np.array_equal(z, made["process"][key]), key


class SlowWhereMade(WhereMade):
    def produce(self, key, deps):
        threading.Event().wait(0.002)          # long enough for the workers to take turns
        return super().produce(key, deps)


@needs_fork
def test_several_worker_processes_share_the_queue_and_make_the_same_tiles(monkeypatch):
    """workers=3 (RiverConfig.tile_workers): three threads, each with its forked process,
    take the queued tiles in turn; a tile whose dependency another process is making now
    waits for it (none is let go: all are made for one request); the tiles are the one
    worker's, bit for bit. (The wait's bound is the scheduler's policy, not what is tested:
    raised here, so that a loaded machine, where the nice-19 processes get little of a
    core, does not let a tile go.)"""
    import riverflow.tiles.scheduler as scheduler

    monkeypatch.setattr(scheduler, "DEPENDENCY_WAIT_S", 120.0)
    keys = np.concatenate([_keys(0), _keys(1), _keys(2), _keys(3)])
    made = {}
    for workers in (1, 3):
        cache = TileCache(1 << 30)
        sched = TileScheduler(cache, [Heights(), SlowWhereMade()], "background",
                              worker="process", workers=workers)
        sched.max_starts = 1000
        pool = cache.pools["p"]
        sched.request("p", keys)                 # once: nothing let go, nothing asked again
        assert sched.wait(20.0)
        assert all(pool.get(tile_code(*k)) is not None for k in map(tuple, keys))
        made[workers] = {k: pool.get(tile_code(*k))["z"].copy() for k in map(tuple, keys)}
        pids = {int(pool.get(tile_code(*k))["pid"][0]) for k in map(tuple, keys)}
        assert len(sched.worker_pids) == workers and pids <= set(sched.worker_pids)
        assert len(pids) == workers and os.getpid() not in pids
        threads = sched._threads
        assert len(threads) == workers
        sched.close()
        assert not any(t.is_alive() for t in threads) and not sched.worker_pids
    for key, z in made[1].items():
        assert np.array_equal(z, made[3][key]), key


def test_worker_counts_auto_and_bad_ones():
    from riverflow.engine.config import RiverConfig
    from riverflow.tiles.scheduler import MAX_WORKERS, worker_count

    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    assert worker_count("auto") == (1 if cores <= 1 else min(max(cores - 1, 2), MAX_WORKERS))
    assert worker_count(3) == 3
    for bad in (0, -1, 1.5, True, "two", None):
        with pytest.raises(ValueError, match="workers"):
            worker_count(bad)
        with pytest.raises(ValueError, match="tile_workers"):
            RiverConfig(tile_workers=bad)
    assert RiverConfig(tile_workers="2").tile_workers == 2            # as from_env gives it


@needs_fork
def test_a_producer_error_in_the_process_is_reported_and_the_process_keeps_working():
    sched = TileScheduler(TileCache(1 << 20), [Broken(), Heights()], "background",
                          worker="process")
    sched.request("b", [(0, 0, 0)])
    sched.request("h", [(0, 0, 0)])
    assert sched.wait(10.0)
    assert len(sched.errors) == 1 and "FloatingPointError" in sched.errors[0]
    assert "(0, 0, 0)" in sched.errors[0] and "a NaN in the source" in sched.errors[0]
    assert tile_code(0, 0, 0) in sched.cache.pools["h"]
    assert sched.worker_pid is not None
    sched.close()


@needs_fork
def test_a_killed_process_is_reported_and_the_thread_makes_the_rest():
    import signal

    cache = TileCache(1 << 20)
    sched = TileScheduler(cache, [Heights()], "background", worker="process")
    sched.request("h", [(0, 0, 0)])
    assert sched.wait(10.0)
    pid = sched.worker_pid
    os.kill(pid, signal.SIGKILL)
    sched.request("h", _keys(1))
    assert sched.wait(10.0)
    assert all(tile_code(*k) in cache.pools["h"] for k in _keys(1).tolist())
    assert any("tile process ended" in e for e in sched.errors), sched.errors
    assert sched.worker_pid is None
    sched.close()


@needs_fork
def test_closing_the_scheduler_ends_its_process():

    sched = TileScheduler(TileCache(1 << 20), [Heights()], "background", worker="process")
    sched.request("h", [(0, 0, 0)])
    assert sched.wait(10.0)
    pid = sched.worker_pid
    assert pid in {p.pid for p in multiprocessing.active_children()}
    sched.close()
    assert pid not in {p.pid for p in multiprocessing.active_children()}
    sched.close()                                      # idempotent


class Stuck(Heights):
    """A tile that takes forever (a process starved at its low priority on a busy machine)."""

    kind = "stuck"

    def produce(self, key, deps):
        import time

        time.sleep(3600.0)


@needs_fork
def test_closing_while_the_process_makes_a_tile_ends_both_at_once():
    """close() does not wait for the tile under way (a nice-19 process on a loaded machine
    took 10 s + 5 s of joins per dropped world): the process is ended first, the thread
    sees it go, drops the tile rather than making it itself, and ends."""
    sched = TileScheduler(TileCache(1 << 20), [Stuck()], "background", worker="process")
    sched.request("stuck", [(0, 0, 0)])
    (thread,) = sched._threads
    while sched.worker_pid is None:
        threading.Event().wait(0.01)
    pid = sched.worker_pid
    threading.Event().wait(0.3)                        # the job is in the process
    sched.close()
    assert not thread.is_alive(), "close() left the worker thread waiting for the tile"
    assert pid not in {p.pid for p in multiprocessing.active_children()}
    assert not sched.errors                            # dropped, neither failed nor made here


def test_a_bad_worker_is_refused():
    with pytest.raises(ValueError, match="worker"):
        TileScheduler(TileCache(1 << 20), [], "background", worker="fiber")


def test_collect_installs_within_its_time_budget_and_the_rest_next_frame():
    """A burst of finished tiles is installed over several frames (at least one a frame),
    never lost; wait() installs all at once."""
    cache = TileCache(1 << 30)
    sched = TileScheduler(cache, [Heights()], "background")
    sched.max_starts = 1000
    keys = _keys(3)
    sched.request("h", keys)
    while len(sched._done) < len(keys):                # every tile made, none installed
        threading.Event().wait(0.005)
    sched.install_budget_s = 0.0
    assert sched.collect() == 1 and len(cache.pools["h"]) == 1
    assert sched.collect() == 1 and sched.pending == len(keys) - 2
    sched.install_budget_s = 1.0
    assert sched.collect() == len(keys) - 2 and sched.pending == 0
    sched.close()
    again = TileScheduler(TileCache(1 << 30), [Heights()], "background")
    again.max_starts = 1000
    again.install_budget_s = 0.0
    again.request("h", keys)
    assert again.wait(10.0) and len(again.cache.pools["h"]) == len(keys)
    again.close()


def test_a_producer_without_empty_tiles_says_so_without_a_call_per_code():
    codes = np.array([tile_code(3, i, i) for i in range(8)], np.int64)
    assert not Heights().empty_mask(codes).any() and len(Heights().empty_mask(codes)) == 8
    slopes = Slopes()                                  # overrides is_empty: asked per code
    assert slopes.empty_mask(np.array([tile_code(1, 1, 1), tile_code(1, 0, 1)])).tolist() == [
        True, False]


def _state(pid: int) -> str:
    """The process's state letter (T: stopped)."""
    with open(f"/proc/{pid}/stat") as f:
        return f.read().rsplit(")", 1)[1].split()[0]


@needs_fork
def test_the_tile_process_is_paused_in_frames_on_one_core_and_tiles_are_still_made():
    """pause_in_frames: stopped from frame_begins to frame_ends (never given the frame's core),
    only after an idle gap, only on one core with "auto"; tiles come out identical; a paused
    process still closes."""
    import time

    cache = TileCache(1 << 30)
    sched = TileScheduler(cache, [Heights()], "background", worker="process",
                          pause_in_frames=True)
    sched.max_starts = 1000
    sched.request("h", _keys(2))
    assert sched.wait(20.0)
    pid = sched.worker_pid
    time.sleep(0.005)                                   # the host left the process idle time
    sched.frame_begins()
    deadline = time.perf_counter() + 2.0
    while _state(pid) != "T" and time.perf_counter() < deadline:
        time.sleep(0.001)
    assert _state(pid) == "T"
    sched.request("h", _keys(3))                        # asked in the frame: made after it
    sched.frame_ends()
    assert _state(pid) != "T"
    assert sched.wait(20.0) and len(cache.pools["h"]) == 16 + 64
    sched.frame_ends()
    sched.frame_begins()                                # no idle gap: left running
    assert not sched._paused and _state(pid) != "T"
    sched.frame_ends()
    time.sleep(0.005)
    sched.frame_begins()
    sched.close()                                       # closes a paused process too
    assert pid not in {p.pid for p in multiprocessing.active_children()}
    sched.frame_ends()

    auto = TileScheduler(TileCache(1 << 30), [Heights()], "background", worker="process")
    auto.request("h", [(0, 0, 0)])
    assert auto.wait(20.0)
    cores = os.sched_getaffinity(0)
    try:
        for allowed, paused in ((cores, len(cores) == 1), ({min(cores)}, True)):
            os.sched_setaffinity(0, allowed)
            time.sleep(0.005)
            auto.frame_begins()
            assert bool(auto._paused) == paused
            auto.frame_ends()
    finally:
        os.sched_setaffinity(0, cores)
    auto.close()
    # several workers: "auto" stops those beyond one per core but the frame's
    two = TileScheduler(TileCache(1 << 30), [Heights()], "background", worker="process",
                        workers=2)
    two.request("h", [(0, 0, 0)])
    assert two.wait(20.0)
    try:
        for allowed in ({min(cores)}, set(sorted(cores)[:2])):
            os.sched_setaffinity(0, allowed)
            time.sleep(0.005)
            two.frame_begins()
            want = max(2 - (len(allowed) - 1), 0)
            assert two._paused == two._processes[2 - want:]
            two.frame_ends()
    finally:
        os.sched_setaffinity(0, cores)
    two.close()
    with pytest.raises(ValueError, match="pause_in_frames"):
        TileScheduler(TileCache(1 << 20), [], "background", pause_in_frames="sometimes")


@needs_fork
def test_frame_work_stops_the_process_whatever_the_idle_time_before():
    """The world's own work between frames (a live edit's swap, by the edits' thread) stops
    the process sharing the frame's core as a frame does, even right after a frame (no idle
    gap), and lets it go on after; the worker threads start no tile meanwhile."""
    import time

    sched = TileScheduler(TileCache(1 << 30), [Heights()], "background", worker="process",
                          pause_in_frames=True)
    sched.request("h", [(0, 0, 0)])
    assert sched.wait(20.0)
    pid = sched.worker_pid
    sched.frame_begins()
    sched.frame_ends()                                  # no idle gap after it
    with sched.frame_work():
        deadline = time.perf_counter() + 2.0
        while _state(pid) != "T" and time.perf_counter() < deadline:
            time.sleep(0.001)
        assert _state(pid) == "T" and not sched._idle.is_set()
    assert _state(pid) != "T" and sched._idle.is_set() and not sched._paused
    sched.close()


@needs_fork
def test_the_pages_a_frame_writes_are_copied_by_the_fork_not_the_frame():
    """After a fork every page is shared with the child until written: ``written_pages``
    lists those this process wrote since (and not the others); ``copy_ahead`` copies pages
    without writing them (their bytes unchanged), so a frame writing them after the fork
    takes no page fault, and stops where ``stop`` says a frame began (a prefix of the
    list); ``learn_written`` lists the frame's misses (written, not copied) first, then
    the pages copied, drops those neither copied nor written, the pages of mappings made
    since the fork and the lot where there are too many to be a frame's."""
    from riverflow.tiles import remote, scheduler as sched_module

    if not os.path.exists("/proc/self/pagemap"):
        pytest.skip("no /proc/self/pagemap here")
    page = remote.PAGE
    block = np.zeros(256 * page // 8 + page // 8, np.float64)
    start = -block.ctypes.data % page // 8            # 256 whole pages of it
    data = block[start:start + 256 * page // 8]
    data[:] = np.arange(len(data))
    first = data.ctypes.data
    ours = first + page * np.arange(256, dtype=np.int64)

    def listed():
        got = remote.written_pages()
        return ours[np.isin(ours, got)]

    assert len(listed()) == 256                          # no child shares them
    ctx = multiprocessing.get_context("fork")
    go = ctx.Event()
    child = ctx.Process(target=go.wait, args=(20.0,), daemon=True)
    child.start()
    try:
        assert len(listed()) == 0                        # shared with the child
        data[:64 * page // 8][::page // 8 * 2] += 0.5     # even pages of the first 64 written
        assert listed().tolist() == ours[:64:2].tolist()
        before = data.copy()
        copied = remote.copy_ahead(ours[1:64:2][::-1].copy())   # any order
        if copied == 0:
            pytest.skip("no MADV_POPULATE_WRITE here (Linux < 5.14)")
        assert copied == 32 and len(listed()) == 64
        assert np.array_equal(data, before)
        assert remote.copy_ahead(np.array([page], np.int64)) == 1    # unmapped: skipped
        # a frame begins after the first call: the copy stops there, a prefix copied
        asked = []
        rest = ours[64:].copy()
        n = remote.copy_ahead(rest, stop=lambda: asked.append(1) or len(asked) > 1)
        assert n == remote.COPY_CHUNK and listed().tolist() == ours[:64 + n].tolist()
        assert np.array_equal(data, before)
    finally:
        go.set()
        child.join(10.0)
    regions = remote.writable_regions()
    assert len(remote.within(ours, regions)) == 256 and not len(
        remote.within(np.array([0, page], np.int64), regions))
    # learning: the misses first, then the pages copied; at most FRAME_PAGES
    sched = TileScheduler(TileCache(1 << 20), [Heights()], "blocking")
    top = remote.WRITTEN_MAX_PAGES + 10
    sched._fork_regions = np.array([[5 * page, top * page]], np.int64)
    seen = iter([np.array([10, 20, 30, top]) * page, np.array([5, 10, 20, 40]) * page,
                 np.arange(top) * page])
    real = sched_module.written_pages
    sched_module.written_pages = lambda: next(seen)
    try:
        for copied, expected in ((0, [10, 20, 30]),     # (page top: mapped since the fork)
                                 (2, [5, 40, 10, 20]),   # 30: neither copied nor written
                                 (0, [])):
            sched._copied = sched._frame_pages[:copied]
            sched._learn_from = sched.frame
            sched.learn_written()
            assert (sched._frame_pages // page).tolist() == expected
            sched.learn_written()                         # once a fork: nothing more
        assert sched._learn_from == -1
    finally:
        sched_module.written_pages = real
    sched.close()


class Shifted(Heights):
    """An edit's new producer: the same kind, other heights."""

    def produce(self, key, deps):
        return {"z": super().produce(key, deps)["z"] + 1.0}


@needs_fork
def test_an_edits_processes_are_forked_in_the_gap_after_a_frame():
    """``fork_for(..., in_gap=True)`` (a live edit's thread) forks once the frame running
    when it is called has ended, and the processes it hands back make the new producer's
    tiles once they replace the old ones."""
    sched = TileScheduler(TileCache(1 << 24), [Heights()], "background", worker="process",
                          pause_in_frames=False)
    sched.start()
    sched.frame_begins()
    ends = threading.Timer(0.1, sched.frame_ends)
    ends.start()
    t0 = time.perf_counter()
    processes = sched.fork_for([Shifted()], in_gap=True)
    assert time.perf_counter() - t0 >= 0.09 and processes and all(p.alive for p in processes)
    ends.join()
    old = sched.replace_producers([Shifted()], processes, close_old=False)
    sched.request("h", [(0, 0, 0)])
    assert sched.wait(20.0)
    z = sched.cache.pools["h"].get(tile_code(0, 0, 0))["z"]
    assert np.array_equal(z, Shifted().produce((0, 0, 0), {})["z"])
    close_all(old, 5.0)
    sched.close()


@needs_fork
def test_a_loading_frames_pages_are_learnt_for_the_first_fork():
    """``learn_frame(run)`` (a world's loading screen) runs ``run`` with a child forked
    beside it and lists the pages ``run`` wrote: the first edit's fork copies them ahead."""
    from riverflow.tiles import remote

    if not os.path.exists("/proc/self/pagemap"):
        pytest.skip("no /proc/self/pagemap here")
    page = remote.PAGE
    block = np.zeros(32 * page // 8 + page // 8, np.float64)
    start = -block.ctypes.data % page // 8
    data = block[start:start + 32 * page // 8]
    data[:] = 1.0                                         # mapped before the child
    ours = data.ctypes.data + page * np.arange(32, dtype=np.int64)
    sched = TileScheduler(TileCache(1 << 20), [Heights()], "background", worker="process")
    sched.start()

    def run():
        data[::page // 8 * 4] += 1.0                      # every fourth page written

    sched.learn_frame(run)
    learnt = sched._frame_pages
    assert set(ours[::4].tolist()) <= set(learnt.tolist())
    assert not set(ours[1::4].tolist()) & set(learnt.tolist())
    assert (data[::page // 8 * 4] == 2.0).all()
    sched.close()
    done = []
    TileScheduler(TileCache(1 << 20), [Heights()], "blocking").learn_frame(
        lambda: done.append(1))                           # no processes: just run
    assert done == [1]


def test_wait_gap_waits_for_a_frame_to_end():
    """``wait_gap`` returns once a frame that ends after the call has ended (a fork then
    has the gap's whole time), or False when none does within its time."""
    sched = TileScheduler(TileCache(1 << 20), [Heights()], "blocking")
    assert not sched.wait_gap(0.05)                      # no frame: it gives up
    sched.frame_begins()
    ended = threading.Timer(0.05, sched.frame_ends)
    ended.start()
    t0 = time.perf_counter()
    assert sched.wait_gap(20.0) and sched._idle.is_set()
    assert time.perf_counter() - t0 >= 0.04
    ended.join()
    sched.close()


@needs_fork
def test_the_process_is_handed_tiles_while_a_frame_runs_the_thread_waits_for_its_end(
        monkeypatch):
    """The worker thread starts a tile of its own between frames only (it would take the
    interpreter from the frame); a tile the process makes is handed to it at once (a live
    edit's tiles were each held back a frame's time)."""
    import riverflow.tiles.scheduler as scheduler_module

    monkeypatch.setattr(scheduler_module, "IDLE_WAIT_S", 30.0)   # a frame that never ends
    for worker, made in (("process", True), ("thread", False)):
        sched = TileScheduler(TileCache(1 << 24), [Heights()], "background", worker=worker,
                              pause_in_frames=False)
        sched.frame_ends()
        sched.frame_begins()
        sched.request("h", [(0, 0, 0)])
        assert sched.wait(0.5 if not made else 20.0) == made, worker
        sched.frame_ends()
        assert sched.wait(20.0) and len(sched.cache.pools["h"]) == 1
        sched.close()
