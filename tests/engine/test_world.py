"""RiverWorld end to end, headless (gl=False): a 1,000-frame scripted flight and its invariants."""
from __future__ import annotations

import esper
import numpy as np
import pytest
import shapely
from scipy.spatial import cKDTree

import riverflow as rf
from riverflow.components.river import TerrainView
from riverflow.components.status import FlowStatus
from riverflow.engine.config import RiverConfig
from riverflow.engine.world import RiverWorld
from riverflow.kernels.raycast import HIT_WATER
from riverflow.kernels.raycast_tiles import cast_rays_onto_tiles
from riverflow.systems.schedule import SYSTEM_ORDER, default_systems
from tests.engine.flight import fly, flight_pose, make_world

R = 5.0
W, H = 320, 180
WARM = 150


@pytest.fixture(scope="module")
def scene():
    return rf.default_scene(seed=0)


def _water_pixels(world, step=2):
    """Screen positions (M, 2) of a lattice of pixels that see water (on the surface tiles of
    the frame's view, the ones the particles are placed on)."""
    surface = world.resource(TerrainView).surface
    xs, ys = np.meshgrid(np.arange(0.5, W, step), np.arange(0.5, H, step))
    px = np.c_[xs.ravel(), ys.ravel()]
    origin, direction = world.camera.screen_to_ray(px)
    xyz = np.zeros((len(px), 3))
    hit = np.zeros(len(px), np.uint8)
    cast_rays_onto_tiles(origin, direction, surface, 1e5, xyz, hit)
    return px[hit == HIT_WATER], xyz[hit == HIT_WATER]


@pytest.fixture(scope="module")
def flight(scene):
    """Fly 1,000 frames at 1/60 s; record what the tests check."""
    world = make_world(scene, size=(W, H), radius_px=R)
    water = scene.water.polygon
    shapely.prepare(water)
    rec = {"count": [], "min_gap": [], "bad_inside": 0, "inside_seen": 0, "z_err": [],
           "nan": 0, "intensity_out": 0, "coverage_gap": [], "water_pixels": 0, "density": []}

    def check(frame, w):
        pool = w.pool
        live = pool.alive
        cols = (pool.screen_px[live], pool.intensity[live], pool.velocity_mps[live],
                pool.world_m[live & pool.has_world])
        rec["nan"] += sum(int((~np.isfinite(c)).sum()) for c in cols)
        it = pool.intensity[live]
        rec["intensity_out"] += int(((it < 0) | (it > 1)).sum())
        p = w.particles
        rec["count"].append(len(p))
        steady = ~p.fading
        if steady.sum() > 1:
            d, _ = cKDTree(p.screen_px[steady]).query(p.screen_px[steady], k=2)
            rec["min_gap"].append(float(d[:, 1].min()))
        inside = p.status == FlowStatus.INSIDE
        if inside.any():
            xy = p.world_m[inside, :2]
            ok = shapely.contains_xy(water, xy[:, 0], xy[:, 1])
            rec["bad_inside"] += int((~ok).sum())
            rec["inside_seen"] += int(inside.sum())
            z_at.append((xy, p.world_m[inside, 2]))
        if frame >= WARM:
            rec["density"].append(steady.sum() / (W * H / (2 * R) ** 2))
        if frame >= WARM and frame % 50 == 0:
            pixels, _ = _water_pixels(w)
            carriers = p.screen_px[(p.status == FlowStatus.INSIDE)
                                   | (p.status == FlowStatus.LEAVING)]
            rec["water_pixels"] += len(pixels)
            if len(pixels):
                gap, _ = cKDTree(carriers).query(pixels) if len(carriers) else (
                    np.full(len(pixels), np.inf), None)
                rec["coverage_gap"].append(float(gap.max()))

    z_at = []        # (xy, z) of the particles INSIDE, per frame
    fly(world, 1000, callback=check)
    # the exact water level of all frames' particles in one query (per point: the same
    # numbers as a query per frame, ten times faster)
    level = scene.water.level(np.concatenate([xy for xy, _ in z_at] or [np.zeros((0, 2))]))
    ends = np.cumsum([len(z) for _, z in z_at])
    rec["z_err"] = [float(np.abs(z - lv).max())
                    for (_, z), lv in zip(z_at, np.split(level, ends[:-1]))]
    rec["world"] = world
    yield rec
    world.close()


def test_flight_keeps_the_poisson_disk(flight):
    # screen positions are float32: 1e-4 px of rounding at the bound
    assert min(flight["min_gap"]) >= 1.9 * R - 1e-4


def test_flight_covers_every_water_pixel(flight):
    assert flight["water_pixels"] > 1000, "the flight should look at the river"
    assert max(flight["coverage_gap"]) <= 3 * R, flight["coverage_gap"]


def test_flight_particle_count_is_stable_and_poisson_dense(flight):
    counts = np.array(flight["count"][WARM:], float)
    change = np.abs(np.diff(counts)) / counts[:-1]
    assert change.max() < 0.10, change.max()
    density = float(np.mean(flight["density"]))
    assert 0.87 * 0.85 <= density <= 0.87 * 1.15, density


def test_flight_particles_never_leave_the_water(flight):
    assert flight["inside_seen"] > 10_000
    assert flight["bad_inside"] == 0
    assert max(flight["z_err"]) < 0.25  # altitude follows the water surface


def test_flight_has_no_nan_and_intensities_in_range(flight):
    assert flight["nan"] == 0
    assert flight["intensity_out"] == 0


def test_flight_timings_are_recorded_per_system(flight):
    world = flight["world"]
    # a gl=False world runs every system but drawing
    assert list(world.timings_ms) == [n for n in SYSTEM_ORDER if n != "draw"]
    assert all(v >= 0 for v in world.timings_ms.values())


@pytest.mark.slow
def test_same_seed_and_script_give_bit_identical_pools(scene):
    worlds = [make_world(scene, seed=7) for _ in range(2)]
    for world in worlds:
        fly(world, 150)
    a, b = (w.pool.columns() for w in worlds)
    for name in a:
        np.testing.assert_array_equal(a[name], b[name], err_msg=name)
    other = make_world(scene, seed=8)
    fly(other, 150)
    assert not np.array_equal(other.pool.screen_px, worlds[0].pool.screen_px)
    for world in (*worlds, other):
        world.close()


def _assert_clean(world):
    pool = world.pool
    live = pool.alive
    for col in (pool.screen_px, pool.intensity, pool.velocity_mps, pool.birth_s):
        assert np.isfinite(col[live]).all()
    assert np.isfinite(pool.world_m[live & pool.has_world]).all()
    assert ((pool.intensity[live] >= 0) & (pool.intensity[live] <= 1)).all()
    assert pool.count == int(live.sum())


def test_bad_frames_never_crash_or_leave_nan(scene):
    world = make_world(scene)
    fly(world, 30)
    eye, target = flight_pose(scene, 30)
    for dt in (1.0, float("nan"), -1.0, 0.0, float("inf")):
        world.step(dt)
        _assert_clean(world)
    world.camera.set_viewport(0, 0)  # a window resized to nothing
    for _ in range(5):
        world.step(1 / 60)
        _assert_clean(world)
    assert world.pool.count == 0
    world.camera.set_viewport(W, H)
    ground = float(scene.terrain.height(eye[None, :2])[0])
    world.camera.look_at((eye[0], eye[1], ground - 20.0), target)  # under the terrain
    for _ in range(5):
        world.step(1 / 60)
        _assert_clean(world)
    world.camera.look_at(eye, eye + np.array([0.0, 1.0, 3.0]))  # at the sky
    for _ in range(5):
        world.step(1 / 60)
        _assert_clean(world)
    sky = world.particles
    assert len(sky) > 0 and np.all(sky.status == FlowStatus.ON_SKY)
    world.close()


def test_a_full_pool_stops_cleanly(scene):
    world = make_world(scene, capacity=64)
    fly(world, 60)
    assert world.pool.count == 64
    _assert_clean(world)
    world.close()


def test_paused_particles_do_not_move_but_still_age(scene):
    world = make_world(scene)
    world.camera.look_at(*flight_pose(scene, 0))
    for _ in range(90):
        world.step(1 / 60)
    def inside_positions():
        p = world.particles
        keep = p.status == FlowStatus.INSIDE
        return dict(zip(p.ids[keep].tolist(), p.world_m[keep].tolist()))

    before = inside_positions()
    assert before
    clock = world.clock.now_s
    world.paused = True
    world.step(1 / 60)
    after = inside_positions()
    common = set(before) & set(after)
    assert len(common) > 0.9 * len(before)
    assert all(before[i] == after[i] for i in common)
    assert world.clock.now_s > clock  # the clock (and so ageing) goes on
    world.paused = False
    world.speed_factor = 2.0
    world.step(1 / 60)
    moved = inside_positions()
    assert any(moved[i] != before[i] for i in set(before) & set(moved))
    with pytest.raises(ValueError):
        world.speed_factor = float("nan")
    world.close()


def test_worlds_do_not_see_each_others_entities(scene):
    esper.switch_world("host-game")
    host_entity = esper.create_entity("player")
    a = make_world(scene)
    b = make_world(scene)
    fly(a, 5)
    b.step(1 / 60)
    assert esper.current_world == "host-game"
    assert [e for e, _ in esper.get_component(str)] == [host_entity]
    with a.active():
        assert not esper.get_component(str)
    assert a.river != b.river or a.name != b.name
    a.close()
    b.close()
    esper.switch_world("default")
    esper.delete_world("host-game")


def test_system_order_is_the_one_list():
    assert [s.name for s in default_systems()] == list(SYSTEM_ORDER)
    assert SYSTEM_ORDER == ("boat", "wake", "flood", "camera", "tiles", "advection",
                            "screen", "lifecycle", "poisson", "placement", "foam", "spill",
                            "waves", "rain", "spray", "draw")
    assert [s.name for s in default_systems(gl=False)] == list(SYSTEM_ORDER[:-1])
    assert [s.phase for s in default_systems()] == ["update"] * 15 + ["draw"]


def test_background_tile_production_fills_in(scene):
    world = RiverWorld(scene, size=(W, H), config=RiverConfig(radius_px=R), seed=0)
    world.camera.look_at(*flight_pose(scene, 0))
    world.step(1 / 60)
    assert world.tiles.scheduler.wait()
    for _ in range(30):
        world.step(1 / 60)
    assert world.field.tiles.cached > 0
    assert (world.particles.status == FlowStatus.INSIDE).any()
    world.close()


def test_tile_entities_follow_the_cache(flight):
    """One Tile entity per resident tile of every kind, with its key and slot, after 1,000
    frames of tiles made and evicted."""
    from riverflow.components.river import Tile
    from riverflow.tiles.table import tile_code

    world = flight["world"]
    with world.active():
        got = sorted((t.kind, t.slot, t.level, t.tx, t.ty)
                     for _, t in esper.get_component(Tile))
    want = sorted((kind, pool.slot(tile_code(*key)), *key)
                  for kind, pool in world.tiles.cache.pools.items() for key in pool.keys())
    assert got == want and sum(1 for g in got if g[0] == "flow") > 10


def test_config_is_validated_and_reads_the_environment(monkeypatch):
    with pytest.raises(ValueError, match="radius_px"):
        RiverConfig(radius_px=0)
    with pytest.raises(ValueError, match="tile_production"):
        RiverConfig(tile_production="sometimes")
    monkeypatch.setenv("RIVERFLOW_RADIUS_PX", "7.5")
    monkeypatch.setenv("RIVERFLOW_CAPACITY", "123")
    cfg = RiverConfig.from_env()
    assert cfg.radius_px == 7.5 and cfg.capacity == 123
