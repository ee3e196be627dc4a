"""The built-in scene: deterministic, a plausible river network, water that flows downhill
and never floats above the terrain or sinks below its bed."""
from __future__ import annotations

import math
import time

import numpy as np
import pytest
import shapely

from riverflow.hydro._checks import area_loop, graph_problems
from riverflow.scenes.default import Scene, default_scene
from riverflow.scenes.water import JUNCTION_BLEND


@pytest.fixture(scope="module")
def scene() -> Scene:
    t = time.perf_counter()
    s = default_scene(seed=0)
    print(f"\ndefault_scene(0) built in {time.perf_counter() - t:.2f} s")
    return s


def _length_m(line: np.ndarray) -> float:
    return float(np.hypot(*np.diff(line, axis=0).T).sum())


def _outward_shore_points(scene: Scene, offset_m: float) -> tuple[np.ndarray, np.ndarray]:
    """Points offset_m outside the water, one per metre of shore, where no other water is
    within offset_m of them (so they are really 'just outside the banks'), and for each the
    point 1 m inside the water from the same shore point."""
    out, inner = [], []
    for poly in getattr(scene.water.polygon, "geoms", [scene.water.polygon]):
        for ring in [poly.exterior, *poly.interiors]:
            v = shapely.get_coordinates(shapely.segmentize(ring, 1.0))
            d = np.diff(v, axis=0)
            n = np.stack([d[:, 1], -d[:, 0]], axis=1) / np.hypot(*d.T)[:, None]  # right = land
            mid = 0.5 * (v[:-1] + v[1:])
            out.append(mid + offset_m * n)
            inner.append(mid - 1.0 * n)
    p, q = np.vstack(out), np.vstack(inner)
    keep = ~scene.water.contains(p) & (scene.water.distance_to_shore(p) > 0.9 * offset_m)
    keep &= scene.water.contains(q)
    x0, y0, x1, y1 = scene.bounds_m
    keep &= (p[:, 0] > x0) & (p[:, 0] < x1) & (p[:, 1] > y0) & (p[:, 1] < y1)
    return p[keep], q[keep]


def _sample(scene: Scene) -> np.ndarray:
    """Terrain heights on a 40 m grid over the whole scene (the terrain is a function)."""
    x0, y0, x1, y1 = scene.bounds_m
    return scene.terrain.grid(x0, y0, 40.0, int((x1 - x0) // 40) + 1, int((y1 - y0) // 40) + 1)


def test_same_seed_gives_bitwise_same_scene(scene):
    # built afresh, not the test process's shared scene (tests/conftest.py)
    again = getattr(default_scene, "__wrapped__", default_scene)(seed=0)
    assert np.array_equal(_sample(again), _sample(scene))
    assert again.graph == scene.graph
    assert np.array_equal(again.water.levels_m, scene.water.levels_m)
    for a, b in zip(again.branches, scene.branches):
        assert a.name == b.name and a.discharge_m2s == b.discharge_m2s
        assert np.array_equal(a.centerline_m, b.centerline_m)
        assert np.array_equal(a.widths_m, b.widths_m)


def test_other_seed_gives_another_river(scene):
    other = default_scene(seed=1)
    a, b = scene.branch("main_upper").centerline_m, other.branch("main_upper").centerline_m
    assert a.shape != b.shape or not np.allclose(a, b)
    assert not np.array_equal(_sample(other), _sample(scene))
    assert other.seed == 1 and not graph_problems(other.graph)


def test_terrain_is_about_4_km_of_tiles(scene):
    """A 4 km quadtree whose finest height tiles are 256 m (64 cells of 4 m), sampled from the
    terrain function at their nodes (bitwise: a tile is the function, not a resampling)."""
    from riverflow.scenes.tile_kinds import HeightProducer, LandscapeTiles
    x0, y0, x1, y1 = scene.bounds_m
    assert x1 - x0 >= 3500 and y1 - y0 >= 3500
    t = scene.terrain
    assert t.tile_size_m == 256.0 and t.max_level == 4
    q = scene.quadtree
    assert q.tile_size_m(t.max_level) == t.tile_size_m and q.cell_m(t.max_level, 64) == 4.0
    tiles = LandscapeTiles(scene)
    z = HeightProducer(tiles).produce((4, 1, 2), {})["z"]
    assert z.dtype == np.float32 and z.shape == (67, 67) and np.isfinite(z).all()
    origin = np.array(q.tile_origin_m(4, 1, 2))
    assert np.array_equal(origin, [x0 + t.tile_size_m, y0 + 2 * t.tile_size_m])
    corner = origin + t.tile_size_m * np.array([1.0, 1.0])
    assert np.float32(t.height(corner[None])[0]) == z[-2, -2]     # the ring is one node wide
    assert np.isfinite(_sample(scene)).all()


def test_main_river_long_wide_and_widening(scene):
    main = [b for b in scene.branches if b.kind == "main"]
    assert sum(_length_m(b.centerline_m) for b in main) >= 3000.0
    widths = np.concatenate([b.widths_m for b in main])
    assert widths.min() >= 50.0 and widths.max() <= 150.0
    assert np.all(np.diff(widths) >= 0) and widths[-1] > widths[0] + 50.0


def test_tributary_joins_and_island_splits_the_flow(scene):
    by_name = {b.name: b for b in scene.branches}
    trib = [b for b in scene.branches if b.kind == "tributary"]
    assert trib
    for t in trib:  # a confluence: it ends where a main branch ends and another starts
        ends_here = [b for b in scene.branches if b.end_junction == t.end_junction]
        starts_here = [b for b in scene.branches if b.start_junction == t.end_junction]
        assert len(ends_here) >= 2 and len(starts_here) == 1
        assert np.allclose(t.centerline_m[-1], starts_here[0].centerline_m[0])
    arms = [b for b in scene.branches if b.kind == "arm"]
    assert len(arms) == 2 and arms[0].start_junction == arms[1].start_junction
    assert arms[0].end_junction == arms[1].end_junction
    assert sum(a.discharge_m2s for a in arms) == pytest.approx(by_name["main_middle"].discharge_m2s)
    g = scene.graph
    holes = [a for a in range(len(g.areas)) if shapely.Polygon(area_loop(g, a)).exterior.is_ccw is False]
    assert len(holes) >= 2  # the island between the arms and the free island
    assert len(scene.islands) >= 1


def test_graph_is_valid_and_discharges_plausible(scene):
    branches = [(b.centerline_m, b.widths_m, b.discharge_m2s) for b in scene.branches]
    assert graph_problems(scene.graph, branches) == []
    for b in scene.branches:
        speed = b.discharge_m2s / float(np.mean(b.widths_m))
        assert 0.4 <= speed <= 2.0, (b.name, speed)


def test_water_only_goes_downhill(scene):
    for b in scene.branches:
        s, level = scene.water.profiles[b.name]
        assert np.all(np.diff(level) <= 0), b.name
    # surface queried along each centre line, away from junction zones
    for b in scene.branches:
        line = b.centerline_m
        s = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(line, axis=0).T))])
        def margin(j: int) -> float:  # the junction zone, where branch levels are blended
            near = [x for x in scene.branches if j >= 0 and j in (x.start_junction, x.end_junction)]
            return JUNCTION_BLEND * max([float(x.widths_m.max()) for x in near], default=0.0)

        keep = (s > margin(b.start_junction)) & (s < s[-1] - margin(b.end_junction))
        keep &= scene.water.contains(line)  # not on a free island
        h = scene.water.height(line[keep])
        assert np.isfinite(h).all() and keep.sum() >= 3, b.name
        assert np.all(np.diff(h) <= 1e-9), b.name
    drop = scene.water.profiles["main_upper"][1][0] - scene.water.profiles["main_lower"][1][-1]
    assert drop > 1.0


def test_no_seam_in_the_water_at_junctions(scene):
    """Where the nearest branch changes around a junction, the surface stays continuous."""
    for j, centre in enumerate(scene.water.junctions_m):
        ax = np.arange(-120.0, 120.0, 1.0)
        gx, gy = np.meshgrid(ax, ax)
        h = scene.water.height(np.c_[gx.ravel(), gy.ravel()] + centre).reshape(gx.shape)
        step = max(np.nanmax(np.abs(np.diff(h, axis=0))), np.nanmax(np.abs(np.diff(h, axis=1))))
        assert step < 0.1, (j, step)  # metres per metre


def test_junction_levels_agree(scene):
    for j in {b.end_junction for b in scene.branches if b.end_junction >= 0}:
        levels = [scene.water.profiles[b.name][1][-1] for b in scene.branches if b.end_junction == j]
        levels += [scene.water.profiles[b.name][1][0] for b in scene.branches if b.start_junction == j]
        assert np.ptp(levels) == 0.0


def test_banks_above_water_just_outside(scene):
    offset = 2.0 * scene.terrain.cell_m
    p, q = _outward_shore_points(scene, offset)
    assert len(p) > 5000
    above = scene.terrain.height(p) - scene.water.height(q)  # the water of that shore
    assert np.all(above >= 0.0), float(above.min())


def test_bed_below_water_inside(scene, rng):
    x0, y0, x1, y1 = scene.water.polygon.bounds
    p = rng.uniform([x0, y0], [x1, y1], size=(200_000, 2))
    p = p[scene.water.contains(p)]
    p = p[scene.water.distance_to_shore(p) > 2.0 * scene.terrain.cell_m]
    assert len(p) > 1000
    surface = scene.water.height(p)
    assert np.all(scene.terrain.height(p) < surface)
    depth = scene.water.depth(p)
    assert np.all(depth > 0) and depth.max() < 6.0 and depth.max() > 2.0
    assert np.allclose(scene.water.bed(p), surface - depth)
    outside = rng.uniform([x0, y0], [x1, y1], size=(2000, 2))
    outside = outside[~scene.water.contains(outside)]
    assert np.isnan(scene.water.height(outside)).all()


def test_a_rivers_self_clearance_by_chunks_is_the_pairwise_answer():
    """layout._self_clear (chunks r/4 long, compared only when far apart along the river)
    against its twin over every pair within r: the same answer for rivers that meander,
    fold back onto themselves near and far, spiral, and keep clear."""
    from riverflow.scenes import layout

    world = layout._World(50_000.0)
    rng = np.random.default_rng(5)
    answers = []
    for case in range(60):
        n = int(rng.integers(200, 2000))
        t = np.linspace(0.0, 1.0, n)
        turns = rng.uniform(0.1, 2.0)                   # a spiral of many turns folds back
        radius = rng.uniform(500.0, 3000.0) * (1.0 + rng.uniform(0.0, 2.0) * t)
        angle = 2.0 * np.pi * turns * t + rng.uniform(0.0, 0.6) * np.sin(
            2.0 * np.pi * rng.uniform(2.0, 12.0) * t)
        pts = np.stack([radius * np.cos(angle), radius * np.sin(angle)], 1)
        pts, = layout.resample(pts, world.spacing)
        widths = np.linspace(rng.uniform(5.0, 20.0), rng.uniform(20.0, 120.0), len(pts))
        fast = layout._self_clear(pts, widths, world)
        assert fast == layout._self_clear_pairwise(pts, widths, world), case
        answers.append(fast)
    assert 10 <= sum(answers) <= 50          # both answers are exercised


@pytest.fixture(scope="module")
def falls_scene():
    return default_scene(seed=0, falls=True)


def test_falls_true_puts_a_fall_and_a_rapid_on_the_tributary_and_leaves_the_rest(
        scene, falls_scene):
    """``default_scene(falls=True)`` (issue 23): a 6 m fall and a 6 % rapid on the tributary;
    the water above them is raised, so every other branch keeps its levels."""
    from riverflow.scenes.default import FALL_DROP_M, RAPIDS_SLOPE
    falls = falls_scene
    (f,) = falls.graph.falls
    (r,) = falls.graph.rapids
    assert f.branch == r.branch == "tributary" and f.drop_m == FALL_DROP_M
    assert r.slope == pytest.approx(RAPIDS_SLOPE) and r.from_m > f.at_m + f.throw_m
    c = np.asarray(f.centre_m)
    t = np.asarray(f.direction)
    up, above, below = falls.water.level(np.array([c - 12.0 * t, c - 2.0 * t,
                                                   c + (f.throw_m + 2.0) * t]))
    slope = (up - above) / 10.0                        # the river's own, around the fall
    assert above - below - slope * (f.throw_m + 4.0) == pytest.approx(FALL_DROP_M, abs=0.05)
    for b in scene.branches:
        if b.name != "tributary":
            pts = b.centerline_m[::10]
            assert np.allclose(falls.water.level(pts), scene.water.level(pts), atol=1e-9)


def test_the_demos_chase_camera_passes_the_fall(falls_scene):
    """``riverflow demo --falls``: the boat starts FALL_START_M above the fall on its axis,
    heading down the tributary to it, and the chase camera sees the lip from there (that a
    boat carried to a lip goes over it, camera and all, is tests/engine/test_falls_world.py's;
    a BoatDemo world on the 4 km scene would cost this suite seconds)."""
    from riverflow.demo import FALL_START_M, _start_pose
    from riverflow.engine.camera import Camera
    from riverflow.engine.camera_rigs import ChaseCamera
    (f,) = falls_scene.graph.falls
    c, t = np.asarray(f.centre_m), np.asarray(f.direction)
    lip = float(falls_scene.water.level(c[None])[0])
    position, heading = _start_pose(falls_scene)
    assert (position - c) @ t == pytest.approx(-FALL_START_M, abs=2.0)
    assert abs((position - c) @ np.array([-t[1], t[0]])) < 0.25 * f.width_m   # on its axis
    assert math.cos(heading - math.atan2(t[1], t[0])) > 0.99
    assert falls_scene.water.contains(position[None])[0]
    camera = Camera(size_px=(64, 36))
    ChaseCamera().update(camera, (*position, lip), heading, 0.0)
    px, _, front = camera.world_to_screen(np.array([[*c, lip], [*(c + f.throw_m * t),
                                                                lip - f.drop_m]]))
    assert front.all() and np.all((px >= 0) & (px < (64, 36)))
