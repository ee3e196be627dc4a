"""Open worlds (SPEC §8), end to end and headless (gl=False).

* A world on a ≥ 100 km river network is made and stepped, in a process of its own so that
  its memory figure is that world's alone, with its resident memory under a stated bound.
* Tiles arriving late (background production, a camera flying fast and jumping) never make a
  frame wait and never leave a particle with a NaN or a wrong status; nor does the flow read
  at a resident ancestor's level while a finer tile is late (it must answer as the finest).
* A closed world ends its scheduler's worker thread and lets its tile cache go.
"""
from __future__ import annotations

import gc
import json
import os
import subprocess
import sys
import textwrap
import threading
import time
import weakref

import numpy as np
import numpy.testing as npt
import pytest
import shapely

import riverflow as rf
from riverflow.components.flow_tiles import FLOW_KIND
from riverflow.engine.config import RiverConfig
from riverflow.hydro.flow_field import FlowField
from riverflow.scenes.flight import flight_pose, main_centerline
from riverflow.tiles.table import codes

INSIDE = rf.FlowStatus.INSIDE
W, H = 320, 180
R = 5.0

# -- a world on a ≥ 100 km network, in a subprocess ----------------------------------------

NETWORK_M = 100_000.0
BIG_SEED = 0
BIG_FRAMES = 30
PEAK_RSS_BOUND_MIB = 1536
"""Peak resident memory of the whole process (imports, numba kernels, a small warm-up world,
the big scene and world) [MiB]. Measured: 246 MiB with the kernels in numba's on-disk cache,
616 MiB when the process compiles them (LLVM). The whole-map arrays this replaced took 1.1 GB
at 30 km and ran out of memory at 100 km."""
GROWTH_RSS_BOUND_MIB = 512
"""Resident memory the big world adds to a process that already ran a small one (kernels
compiled or loaded) [MiB]: its scene, its flow network, and tiles up to the cache budget
(RiverConfig.tile_cache_mb = 256 by default; the view needs far less: 24 MB of tiles).
Measured: 43 MiB (1 MiB after a cold compile, whose freed memory the world reuses)."""

_BIG_WORLD = textwrap.dedent("""
    import json, sys, time
    import numpy as np

    def rss_mib():
        out = {}
        with open("/proc/self/status") as f:
            for line in f:
                if line.startswith(("VmRSS:", "VmHWM:")):
                    key, value, _ = line.split()
                    out[key[:-1]] = int(value) / 1024.0
        return out

    import riverflow as rf
    from riverflow.engine.config import RiverConfig
    from riverflow.scenes.flight import flight_pose, main_centerline
    from riverflow.scenes.layout import network_length_m, size_for_network_length

    NETWORK_M, SEED, FRAMES, W, H, R = json.loads(sys.argv[1])
    config = RiverConfig(radius_px=R, tile_production="blocking")
    out = {}

    # warm-up: a small world loads (or compiles) every kernel, so that what follows is the
    # big world's own memory
    small = rf.default_scene(seed=0)
    with rf.RiverWorld(small, size=(W, H), gl=False, seed=0, config=config) as world:
        for f in range(3):
            world.camera.look_at(*flight_pose(small, f))
            world.step(1 / 60)
    del world, small
    import gc; gc.collect()
    out["baseline"] = rss_mib()

    t0 = time.perf_counter()
    scene = rf.default_scene(seed=SEED, size_km=size_for_network_length(NETWORK_M) / 1000.0)
    out["scene_s"] = time.perf_counter() - t0
    out["size_km"] = (scene.bounds_m[2] - scene.bounds_m[0]) / 1000.0
    out["network_m"] = network_length_m(scene.branches)
    out["after_scene"] = rss_mib()

    t0 = time.perf_counter()
    world = rf.RiverWorld(scene, size=(W, H), gl=False, seed=0, config=config)
    out["world_s"] = time.perf_counter() - t0
    line = main_centerline(scene)
    mid = 0.5 * float(np.hypot(*np.diff(line, axis=0).T).sum())   # over the middle of the map
    nan = 0
    t0 = time.perf_counter()
    for f in range(FRAMES):
        world.camera.look_at(*flight_pose(scene, f, start_m=mid, line=line))
        world.step(1 / 60)
        pool = world.pool
        live = pool.alive
        nan += int((~np.isfinite(pool.world_m[live & pool.has_world])).sum()
                   + (~np.isfinite(pool.screen_px[live])).sum()
                   + (~np.isfinite(pool.velocity_mps[live])).sum())
    out["steps_s"] = time.perf_counter() - t0
    out["after_steps"] = rss_mib()
    cache = world.tiles.cache
    out["cache_bytes"] = cache.resident_bytes
    out["cache_budget"] = cache.budget_bytes
    out["nan"] = nan
    p = world.particles
    out["particles"] = len(p)
    inside = p.status == rf.FlowStatus.INSIDE
    out["inside"] = int(inside.sum())
    out["nan_end"] = int((~np.isfinite(p.world_m[p.has_world])).sum())
    # the flow at the finest level (tiles made on demand) where the particles say INSIDE
    status, _ = world.field.query(p.world_m[inside, :2])
    out["inside_but_not_water"] = int((status != rf.FlowStatus.INSIDE).sum())
    out["errors"] = list(world.tiles.scheduler.errors)
    world.close()
    print("RESULT " + json.dumps(out))
""")


@pytest.mark.slow
def test_world_on_a_100_km_network_stays_in_memory_bound():
    args = json.dumps([NETWORK_M, BIG_SEED, BIG_FRAMES, W, H, R])
    env = dict(os.environ, PYGLET_HEADLESS="1")
    proc = subprocess.run([sys.executable, "-c", _BIG_WORLD, args], capture_output=True, text=True,
                          env=env, timeout=900)
    assert proc.returncode == 0, proc.stderr[-4000:]
    lines = [s for s in proc.stdout.splitlines() if s.startswith("RESULT ")]
    assert lines, proc.stdout[-2000:] + proc.stderr[-2000:]
    r = json.loads(lines[-1][len("RESULT "):])
    print(json.dumps(r, indent=1))

    assert r["network_m"] >= NETWORK_M, r["network_m"]
    assert r["particles"] > 0
    assert r["inside"] > 0, "no particle on the river under the camera"
    assert r["nan"] == 0 and r["nan_end"] == 0
    assert r["inside_but_not_water"] == 0, r
    assert r["errors"] == []
    assert r["cache_bytes"] <= r["cache_budget"]
    peak = r["after_steps"]["VmHWM"]
    growth = r["after_steps"]["VmRSS"] - r["baseline"]["VmRSS"]
    assert peak < PEAK_RSS_BOUND_MIB, f"peak RSS {peak:.0f} MiB"
    assert growth < GROWTH_RSS_BOUND_MIB, f"the big world added {growth:.0f} MiB"


# -- tiles arriving late ---------------------------------------------------------------------

LATE_SIZE_KM = 16.0
"""A scene with a deeper quadtree than the 4 km one (flow levels 0-8), so that a fast camera
outruns the worker by several levels."""
LATE_FRAMES = 200
FLY_MPS = 200.0
JUMP_EVERY = 10
"""From frame LATE_FRAMES / 2 on the camera jumps to another branch every this many frames."""
FRAME_S = 1 / 60
LATE_CACHE_MB = 48.0
"""A small budget: tiles are evicted and made again while the camera moves."""


@pytest.fixture(scope="module")
def late_scene():
    return rf.default_scene(seed=0, size_km=LATE_SIZE_KM)


def _oracle(scene, config: RiverConfig) -> FlowField:
    """A flow field of the scene with a cache of its own: the world's tiles are never touched
    (asking the world's field would make tiles in the frame's place), and a tile's content
    depends only on its key (SPEC §8), so it answers as the world's tiles would."""
    q = scene.quadtree
    return FlowField(scene.graph, config.slip, config.search_radius_factor,
                     potential_delta_m=config.potential_delta_m,
                     domain_m=(q.root_x_m, q.root_y_m, q.root_size_m))


DRY = -2


def _read_levels(world, xy: np.ndarray) -> np.ndarray:
    """Level of the flow tile the world's particles read at each point, as the kernels find it
    (kernels.flow._locate): the finest level if resident, else the nearest resident ancestor;
    DRY where a tile on the way is known to hold no river (the world reads OUTSIDE there);
    −1 where none is resident (the particle waits)."""
    field = world.field
    t = field.tiles
    resident = world.tiles.cache.pools[FLOW_KIND].codes()
    wet = t.wet.keys[t.wet.keys >= 0]
    u = (np.asarray(xy, np.float64) - (t.root_x_m, t.root_y_m)) / t.root_size_m
    level = np.full(len(xy), -1)
    todo = np.ones(len(xy), bool)
    for lv in range(field.max_level, -1, -1):
        if not todo.any():
            break
        n = 1 << lv
        rows = np.flatnonzero(todo)
        ij = np.clip((u[rows] * n).astype(np.int64), 0, n - 1)
        c = codes(np.c_[np.full(len(rows), lv), ij[:, 0], ij[:, 1]])
        hit = np.isin(c, resident)
        dry = ~hit & ~np.isin(c, wet)
        level[rows[hit]] = lv
        level[rows[dry]] = DRY
        todo[rows[hit | dry]] = False
    return level


def _check_frame(world, oracle: FlowField, frame: int, rec: dict) -> None:
    pool = world.pool
    live = pool.alive
    for name, col in (("world_m", pool.world_m[live & pool.has_world]),
                      ("screen_px", pool.screen_px[live]),
                      ("velocity_mps", pool.velocity_mps[live])):
        bad = int((~np.isfinite(col)).sum())
        if bad:
            rec["nan"].append((frame, name, bad))
    p = world.particles
    inside = np.flatnonzero(p.status == INSIDE)
    rec["inside"].append(len(inside))
    if not len(inside):
        return
    xy = p.world_m[inside, :2]
    # the truth: the flow at its finest level
    status, _ = oracle.query(xy)
    wrong = status != INSIDE
    if wrong.any():
        rec["not_water"].append((frame, xy[wrong][:3].round(2).tolist(),
                                 status[wrong][:3].tolist()))
    # the tile the world reads there (a resident ancestor while the finest one is late)
    level = _read_levels(world, xy)
    rec["waiting"] += int((level == -1).sum())
    if (level == DRY).any():
        rec["stale"].append((frame, "dry", xy[level == DRY][:3].round(2).tolist()))
    for lv in np.unique(level[level >= 0]).tolist():
        sel = level == lv
        s, _ = oracle.query(xy[sel], level=lv)
        if (s != INSIDE).any():
            rec["stale"].append((frame, lv, xy[sel][s != INSIDE][:3].round(2).tolist()))


def _settle(world, pose, oracle, rec, frames: int = 60) -> int:
    """Hold the camera at ``pose`` and let its tiles arrive; returns the INSIDE particles at
    the end. The first frames run paced, so that the requests of views left behind go stale
    (the worker drops them, SPEC §8) before ``wait`` makes what is still wanted."""
    for k in range(frames):
        if k in (frames // 2, frames - 10):
            assert world.tiles.scheduler.wait(120.0), "tiles still pending after 120 s"
        world.camera.look_at(*pose)
        t0 = time.perf_counter()
        world.step(FRAME_S)
        _check_frame(world, oracle, -1, rec)
        time.sleep(max(0.0, FRAME_S - (time.perf_counter() - t0)))
    return int((world.particles.status == INSIDE).sum())


@pytest.mark.slow
def test_late_tiles_never_stall_a_frame_nor_leave_a_wrong_status(late_scene):
    """A settled view, then a flight at FLY_MPS down the main river and jumps from branch to
    branch: the frames go on while tiles are late, and after every frame no particle has a
    NaN, and every INSIDE particle is in the water."""
    scene = late_scene
    config = RiverConfig(radius_px=R, tile_production="background", tile_cache_mb=LATE_CACHE_MB,
                         deterministic=False)     # the frames must not wait: a game's flight
    oracle = _oracle(scene, config)
    rec = {"nan": [], "inside": [], "not_water": [], "stale": [], "waiting": 0}
    pending = []
    main = main_centerline(scene)
    branches = [b.centerline_m for b in scene.branches]
    with rf.RiverWorld(scene, size=(W, H), gl=False, seed=0, config=config) as world:
        scheduler = world.tiles.scheduler
        assert _settle(world, flight_pose(scene, 0, line=main), oracle, rec) > 0
        line = main
        for f in range(LATE_FRAMES):
            if f >= LATE_FRAMES // 2:
                line = branches[(f // JUMP_EVERY) % len(branches)]
            world.camera.look_at(*flight_pose(scene, f, speed_mps=FLY_MPS, line=line))
            t0 = time.perf_counter()
            world.step(FRAME_S)
            pending.append(scheduler.pending)
            _check_frame(world, oracle, f, rec)
            # pace the frames like a game (no assertion on time): the worker gets its share
            time.sleep(max(0.0, FRAME_S - (time.perf_counter() - t0)))
        print(f"INSIDE per frame (every 10th): {rec['inside'][::10]}; "
              f"tiles pending (every 10th): {pending[::10]}; waiting particle-frames: "
              f"{rec['waiting']}")
        # frames returned with tiles still queued: they did not wait for them
        busy = sum(1 for n in pending if n > 0)
        assert busy >= LATE_FRAMES // 4, f"only {busy} frames left tiles pending: {pending[::10]}"
        assert max(rec["inside"]) > 0, "no particle was ever INSIDE during the flight"
        # the last view, once its tiles have arrived, fills with particles
        final = flight_pose(scene, LATE_FRAMES - 1, speed_mps=FLY_MPS, line=line)
        assert _settle(world, final, oracle, rec) > 0, "the view did not fill"
        assert scheduler.errors == []
    assert rec["nan"] == [], rec["nan"][:5]
    assert rec["stale"] == [], f"INSIDE where the tile the world reads says not: {rec['stale'][:5]}"
    assert rec["not_water"] == [], (
        f"{len(rec['not_water'])} frames with INSIDE particles outside the water "
        f"(finest flow level; frame, places, status): {rec['not_water'][:5]}")


def test_a_late_tile_never_gives_a_wrong_status_at_its_parents_level():
    """While a flow tile is late, the particles' query (``query_flow``: fallback to the
    resident ancestors) answers either what the finest level answers or UNKNOWN (the particle
    waits, docs/deviations.md P10), never the other side of a bank: coarse cells meet more bank
    segments than they keep (CELL_CROWDED) and a stand-in does not guess there. Points 0.5 to
    3 m off the banks, on both sides, with only the tiles of one coarse level resident, for
    every level of the 4 km scene's flow quadtree."""
    from riverflow.systems.advection import query_flow
    scene = rf.default_scene(seed=0)
    field = _oracle(scene, RiverConfig())
    rng = np.random.default_rng(7)
    shore = shapely.get_coordinates(shapely.segmentize(scene.water.polygon.boundary, 10.0))
    shore = shore[rng.choice(len(shore), min(len(shore), 1500), replace=False)]
    angle = rng.uniform(0.0, 2.0 * np.pi, len(shore))
    xy = shore + np.c_[np.cos(angle), np.sin(angle)] * rng.uniform(0.5, 3.0, len(shore))[:, None]
    xy = xy[shapely.distance(scene.water.polygon.boundary, shapely.points(xy)) > 0.5]
    fine, _ = field.query(xy)
    fine_inside = fine == INSIDE
    assert 0.2 < fine_inside.mean() < 0.8           # both sides of the banks are sampled
    centre = np.vstack([b.centerline_m[::20] for b in scene.branches])
    wide = np.concatenate([b.widths_m[::20] for b in scene.branches]) > 60.0
    far = np.vstack([centre[wide], rng.uniform(-1800, 1800, (400, 2))])
    far = far[shapely.distance(scene.water.polygon.boundary, shapely.points(far)) > 30.0]
    far_inside = field.query(far)[0] == INSIDE
    assert 0 < far_inside.sum() < len(far)
    pool = field.tiles.pool
    waited = 0
    for level in range(field.max_level):
        pool.clear()
        # only this level resident (the tiles under the shore and the far points: a far
        # point inland may lie in a tile no shore point falls in), none in the cut
        field.query(np.vstack([xy, far]), level=level)
        assert {k[0] for k in pool.keys()} == {level}
        pool.arrays["in_cut"][:] = 0
        status = np.empty(len(xy), np.uint8)
        velocity = np.empty((len(xy), 2), np.float32)
        query_flow(field, xy, status, velocity)
        known = status != rf.FlowStatus.UNKNOWN
        waited += int((~known).sum())
        wrong = known & ((status == INSIDE) != fine_inside)
        assert not wrong.any(), (level, xy[wrong][:3].round(2).tolist())
        # far from every bank (mid-river, deep inland): never wrong, and answered once the
        # cells are well under the river's width (level 2: 17 m)
        far_status = np.empty(len(far), np.uint8)
        query_flow(field, far, far_status, np.empty((len(far), 2), np.float32))
        far_known = far_status != rf.FlowStatus.UNKNOWN
        npt.assert_array_equal((far_status == INSIDE)[far_known], far_inside[far_known])
        if level >= 2:
            assert far_known.all(), level
    assert waited > 0                               # the crowded coarse cells did wait


# -- closing -----------------------------------------------------------------------------------


def test_closed_world_ends_its_worker_and_releases_its_tiles():
    scene = rf.default_scene(seed=0)
    before = set(threading.enumerate())
    n_before = threading.active_count()
    world = rf.RiverWorld(scene, size=(160, 90), gl=False, seed=0,
                          config=RiverConfig(tile_production="background",
                                             deterministic=False))
    for f in range(5):
        world.camera.look_at(*flight_pose(scene, f))
        world.step(FRAME_S)
    workers = [t for t in threading.enumerate() if t not in before]
    n = world.tiles.scheduler.workers               # (RiverConfig.tile_workers)
    assert [t.name for t in workers] == ["riverflow-tiles"] * n
    assert threading.active_count() == n_before + n
    assert world.tiles.scheduler.wait(60.0)
    cache = weakref.ref(world.tiles.cache)
    assert cache().resident_bytes > 0
    world.close()
    assert not any(t.is_alive() for t in workers)
    assert set(threading.enumerate()) <= before
    del world
    gc.collect()
    assert cache() is None, "the tile cache outlived its closed world"


# -- what keeps a flight smooth on a core the worker shares ------------------------------------


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="a thread's own nice: Linux")
def test_the_tile_worker_runs_at_a_lower_priority_than_the_frame():
    from riverflow.tiles.scheduler import WORKER_NICE

    scene = rf.default_scene(seed=0)
    world = rf.RiverWorld(scene, size=(160, 90), gl=False, seed=0,
                          config=RiverConfig(tile_production="background",
                                             deterministic=False))
    try:
        world.camera.look_at(*flight_pose(scene, 0))
        world.step(FRAME_S)
        worker = next(t for t in threading.enumerate() if t.name == "riverflow-tiles")
        for _ in range(100):      # the worker sets its own priority as it starts
            nice = os.getpriority(os.PRIO_PROCESS, worker.native_id)
            if nice >= WORKER_NICE:
                break
            time.sleep(0.01)
        assert nice == max(WORKER_NICE, os.getpriority(os.PRIO_PROCESS, 0))
        assert os.getpriority(os.PRIO_PROCESS, threading.get_native_id()) < nice
        for pid in world.tiles.scheduler.worker_pids:    # (RiverConfig.tile_worker)
            for _ in range(100):
                if os.getpriority(os.PRIO_PROCESS, pid) >= WORKER_NICE:
                    break
                time.sleep(0.01)
            assert os.getpriority(os.PRIO_PROCESS, pid) == nice
    finally:
        world.close()


@pytest.mark.parametrize("freeze", [True, False])
def test_loading_a_view_freezes_the_collector_only_when_asked(freeze):
    scene = rf.default_scene(seed=0)
    gc.unfreeze()
    world = rf.RiverWorld(scene, size=(160, 90), gl=False, seed=0,
                          config=RiverConfig(freeze_gc_on_load=freeze))
    try:
        world.camera.look_at(*flight_pose(scene, 0))
        assert world.load_view(60.0)
        frozen = gc.get_freeze_count()
        assert (frozen > 0) == freeze
        if freeze:     # what the world holds is left out of collections
            assert frozen > 1000
        world.load_view(60.0)       # a second load collects and freezes again
        assert (gc.get_freeze_count() > 0) == freeze
    finally:
        world.close()
        gc.unfreeze()


def test_loading_a_view_seeds_the_screen_s_particles_with_no_time_passing():
    """The first Poisson fill of an empty screen happens on the loading screen: after
    load_view the screen holds its particles, and no time or frame has passed."""
    scene = rf.default_scene(seed=0)
    world = rf.RiverWorld(scene, size=(320, 180), gl=False, seed=0,
                          config=RiverConfig(radius_px=5.0))
    try:
        world.camera.look_at(*flight_pose(scene, 0))
        assert len(world.particles) == 0
        assert world.load_view(60.0)
        seeded = len(world.particles)
        assert world.clock.now_s == 0.0 and world.clock.frame == 0
        assert (world.particles.intensity >= 0).all()
        for f in range(1, 11):
            world.camera.look_at(*flight_pose(scene, f))
            world.step(FRAME_S)
        assert seeded >= 0.8 * len(world.particles) > 100
    finally:
        world.close()
