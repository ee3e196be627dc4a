"""Rays onto terrain + water: the kernel against its brute-force twin, exact cases, edge cases,
and the default scene (hits on water where the scene says water)."""
from __future__ import annotations

import numpy as np
import numpy.testing as npt
import pytest

from riverflow.kernels.raycast import (
    HIT_LAND,
    HIT_NONE,
    HIT_WATER,
    cast_rays_onto_heightfield,
    fill_height_pyramid,
    height_pyramid,
    pyramid_size,
)
from tests import reference


def cast(origins, directions, heights, water=None, origin=(0.0, 0.0), cell=1.0, max_d=1e4):
    """Run the kernel; returns (xyz, hit, count)."""
    heights = np.ascontiguousarray(heights, np.float32)
    water = np.full_like(heights, np.nan) if water is None else np.ascontiguousarray(water, np.float32)
    origins = np.ascontiguousarray(np.reshape(origins, (-1, 3)), np.float64)
    directions = np.ascontiguousarray(np.reshape(directions, (-1, 3)), np.float64)
    xyz = np.full(origins.shape, 123.0)
    hit = np.full(len(origins), 99, np.uint8)
    count = cast_rays_onto_heightfield(origins, directions, heights, water, origin[0], origin[1],
                                       cell, max_d, xyz, hit, height_pyramid(heights, water))
    assert np.isfinite(xyz).all()
    assert count == int((hit != HIT_NONE).sum())
    return xyz, hit, count


def synthetic(nx=57, ny=41, cell=2.0, origin=(-30.0, 12.0)):
    """Wavy terrain with a channel along x and a sloping water band in it; (h, water, origin,
    cell)."""
    x = origin[0] + cell * np.arange(nx)
    y = origin[1] + cell * np.arange(ny)
    gx, gy = np.meshgrid(x, y)
    h = 8.0 + 3.0 * np.sin(gx / 9.0) + 2.0 * np.cos(gy / 7.0) + 0.05 * gx
    d = np.abs(gy - (origin[1] + 0.5 * (ny - 1) * cell))
    h = np.where(d < 14.0, h - 6.0 * (1.0 - (d / 14.0) ** 2), h)
    water = np.where(d < 11.0, 7.0 + 0.01 * gx, np.nan)
    return h.astype(np.float32), water.astype(np.float32), origin, cell


def random_rays(rng, n, origin, cell, shape, z=(-2.0, 40.0)):
    ny, nx = shape
    lo = np.array([origin[0] - 20.0, origin[1] - 20.0, z[0]])
    hi = np.array([origin[0] + (nx - 1) * cell + 20.0, origin[1] + (ny - 1) * cell + 20.0, z[1]])
    o = rng.uniform(lo, hi, (n, 3))
    d = rng.normal(size=(n, 3))
    d[: int(0.8 * n), 2] = -np.abs(d[: int(0.8 * n), 2]) - 0.2  # most rays look down
    return o, d


def assert_matches_reference(o, d, h, water, origin, cell, max_d, step=0.02):
    xyz, hit, _ = cast(o, d, h, water, origin, cell, max_d)
    want_xyz, want_hit = reference.cast_rays_onto_heightfield(o, d, h, water, origin[0],
                                                             origin[1], cell, max_d, step)
    npt.assert_array_equal(hit != HIT_NONE, want_hit != HIT_NONE)
    some = hit != HIT_NONE
    npt.assert_allclose(xyz[some], want_xyz[some], atol=2e-3)
    # water vs land agrees except where water and terrain are at the same height
    g = (xyz[some, :2] - origin) / cell
    terrain, level = reference.surface_at(h, water, g[:, 0], g[:, 1])
    clear = ~(np.abs(level - terrain) < 1e-4)
    npt.assert_array_equal(hit[some][clear], want_hit[some][clear])
    return hit


# -- pyramid --------------------------------------------------------------------------------


@pytest.mark.parametrize("shape", [(2, 2), (2, 9), (9, 2), (17, 17), (41, 57), (33, 20)])
def test_height_pyramid_matches_reference(shape, rng):
    h = rng.uniform(-5, 5, shape).astype(np.float32)
    water = np.where(rng.random(shape) < 0.3, h + rng.uniform(-1, 3, shape), np.nan).astype(np.float32)
    got = height_pyramid(h, water)
    assert got.shape == (pyramid_size(shape[1], shape[0]), 2)
    npt.assert_array_equal(got, reference.height_pyramid(h, water))
    npt.assert_array_equal(got[-1], [h.min(), np.fmax(h, water).max()])


def test_pyramid_size_is_checked():
    h = np.zeros((9, 9), np.float32)
    with pytest.raises(ValueError):
        fill_height_pyramid(h, h, np.zeros((3, 2), np.float32))
    with pytest.raises(ValueError):
        cast_rays_onto_heightfield(np.zeros((1, 3)), np.ones((1, 3)), h, h, 0.0, 0.0, 1.0, 1.0,
                                   np.zeros((1, 3)), np.zeros(1, np.uint8),
                                   np.zeros((3, 2), np.float32))


# -- against the brute-force twin ------------------------------------------------------------


def test_random_rays_match_reference(rng):
    h, water, origin, cell = synthetic()
    o, d = random_rays(rng, 300, origin, cell, h.shape)
    hit = assert_matches_reference(o, d, h, water, origin, cell, 200.0)
    assert (hit == HIT_WATER).sum() > 20 and (hit == HIT_LAND).sum() > 40 and (hit == HIT_NONE).sum() > 20


def test_random_rays_on_an_odd_grid_match_reference(rng):
    h, water, origin, cell = synthetic(nx=23, ny=70, cell=0.75, origin=(3.0, -4.0))
    o, d = random_rays(rng, 200, origin, cell, h.shape)
    assert_matches_reference(o, d, h, water, origin, cell, 120.0)


def test_axis_parallel_and_diagonal_rays_match_reference(rng):
    h, water, origin, cell = synthetic()
    o, _ = random_rays(rng, 60, origin, cell, h.shape, z=(3.0, 14.0))
    dirs = [(1, 0, 0), (-1, 0, 0), (0, 1, 0), (0, -1, 0), (1, 1, 0), (-1, 1, 0),
            (1, 0, -0.2), (0, -1, -0.3), (1, -1, -0.1)]
    d = np.array([dirs[k % len(dirs)] for k in range(len(o))], float)
    o[::3, :2] = origin + cell * np.round((o[::3, :2] - origin) / cell)  # start on grid lines
    assert_matches_reference(o, d, h, water, origin, cell, 200.0)


def test_rays_from_under_the_terrain_match_reference(rng):
    h, water, origin, cell = synthetic()
    o, d = random_rays(rng, 150, origin, cell, h.shape, z=(-4.0, 6.0))
    g = (o[:, :2] - origin) / cell
    inside = (g >= 0).all(1) & (g[:, 0] <= h.shape[1] - 1) & (g[:, 1] <= h.shape[0] - 1)
    terrain, level = reference.surface_at(h, water, *np.clip(g, 0, np.array(h.shape[::-1]) - 1).T)
    assert (inside & (o[:, 2] < np.fmax(terrain, level))).sum() > 30
    assert_matches_reference(o, d, h, water, origin, cell, 200.0)


# -- exact cases ----------------------------------------------------------------------------


def test_flat_plane_hits_are_exact(rng):
    h = np.full((30, 40), 3.0, np.float32)
    o = rng.uniform((5, 5, 4), (30, 20, 50), (200, 3))
    d = rng.normal(size=(200, 3))
    d[:, 2] = -np.abs(d[:, 2]) - 0.05
    xyz, hit, _ = cast(o, d, h, origin=(0.0, 0.0), cell=1.0)
    dn = d / np.linalg.norm(d, axis=1, keepdims=True)
    t = (3.0 - o[:, 2]) / dn[:, 2]
    p = o + t[:, None] * dn
    on_grid = (p[:, 0] >= 0) & (p[:, 0] <= 39) & (p[:, 1] >= 0) & (p[:, 1] <= 29)
    npt.assert_array_equal(hit, np.where(on_grid, HIT_LAND, HIT_NONE))
    npt.assert_allclose(xyz[on_grid], p[on_grid], atol=1e-9)


def test_tilted_plane_hits_are_exact(rng):
    nx, ny, cell, origin = 50, 40, 2.5, (-60.0, 20.0)
    x = origin[0] + cell * np.arange(nx)
    y = origin[1] + cell * np.arange(ny)
    gx, gy = np.meshgrid(x, y)
    a, b, c = 1.0, 0.125, -0.0625  # exactly representable: float32 heights are exact
    h = (a + b * gx + c * gy).astype(np.float32)
    o = rng.uniform((-50, 30, 20), (50, 100, 60), (200, 3))
    d = rng.normal(size=(200, 3))
    d[:, 2] = -np.abs(d[:, 2]) - 0.3
    xyz, hit, _ = cast(o, d, h, origin=origin, cell=cell)
    dn = d / np.linalg.norm(d, axis=1, keepdims=True)
    t = (a + b * o[:, 0] + c * o[:, 1] - o[:, 2]) / (dn[:, 2] - b * dn[:, 0] - c * dn[:, 1])
    p = o + t[:, None] * dn
    g = (p[:, :2] - origin) / cell
    on_grid = (t > 0) & (g >= 0).all(1) & (g[:, 0] <= nx - 1) & (g[:, 1] <= ny - 1)
    assert on_grid.sum() > 100
    npt.assert_array_equal(hit, np.where(on_grid, HIT_LAND, HIT_NONE))
    npt.assert_allclose(xyz[on_grid], p[on_grid], atol=1e-8)


def test_vertical_rays(rng):
    h, water, origin, cell = synthetic()
    xy = origin + rng.uniform(0, 1, (100, 2)) * cell * (np.array(h.shape[::-1]) - 1)
    g = (xy - origin) / cell
    terrain, level = reference.surface_at(h, water, g[:, 0], g[:, 1])
    top = np.fmax(terrain, level)
    down = np.column_stack([xy, np.full(100, 50.0)])
    xyz, hit, _ = cast(down, (0, 0, -1) * np.ones((100, 1)), h, water, origin, cell)
    npt.assert_allclose(xyz[:, 2], top, atol=1e-9)
    npt.assert_array_equal(xyz[:, :2], xy)
    npt.assert_array_equal(hit, np.where(level >= terrain, HIT_WATER, HIT_LAND))
    # Up, from above or from below the surface: the sky.
    for z in (top + 1.0, top - 1.0):
        _, hit, count = cast(np.column_stack([xy, z]), np.tile((0.0, 0.0, 1.0), (100, 1)),
                             h, water, origin, cell)
        assert count == 0
    # Down from below the surface: never comes out, so nothing.
    _, hit, count = cast(np.column_stack([xy, top - 1.0]), np.tile((0.0, 0.0, -1.0), (100, 1)),
                         h, water, origin, cell)
    assert count == 0


def test_horizontal_rays_hit_the_first_slope():
    nx = 101
    x = np.arange(nx, dtype=float)
    h = np.tile(np.where((x >= 40) & (x <= 60), 10.0 - np.abs(x - 50.0), 0.0), (30, 1))  # a ridge
    o = [(5.0, 10.0, 4.0), (95.0, 12.5, 4.0), (5.0, 10.0, 10.5), (50.0, -5.0, 3.0)]
    d = [(1.0, 0.0, 0.0), (-1.0, 0.0, 0.0), (1.0, 0.0, 0.0), (0.0, 1.0, 0.0)]
    xyz, hit, _ = cast(o, d, h)
    npt.assert_array_equal(hit, [HIT_LAND, HIT_LAND, HIT_NONE, HIT_NONE])
    npt.assert_allclose(xyz[0], (44.0, 10.0, 4.0), atol=1e-9)   # rising face: 10 − |x − 50| = 4
    npt.assert_allclose(xyz[1], (56.0, 12.5, 4.0), atol=1e-9)
    # (3) passes above the crest; (4) starts outside, enters the ridge's side below its crest.


def test_camera_under_a_ridge_sees_the_next_ridge():
    x = np.arange(101, dtype=float)
    ridge = np.where((x >= 20) & (x <= 30), 10.0, 0.0) + np.where((x >= 60) & (x <= 70), 10.0, 0.0)
    h = np.tile(ridge, (20, 1))
    xyz, hit, _ = cast([(25.0, 10.0, 5.0), (25.0, 10.0, 5.0), (25.0, 10.0, 5.0)],
                       [(1.0, 0.0, 0.0), (0.0, 0.0, 1.0), (-1.0, 0.0, 0.0)], h)
    npt.assert_array_equal(hit, [HIT_LAND, HIT_NONE, HIT_NONE])
    npt.assert_allclose(xyz[0], (59.5, 10.0, 5.0), atol=1e-9)  # bilinear face from x = 59 to 60


def test_rays_outside_the_grid():
    h = np.zeros((11, 11), np.float32)
    o = [(-10.0, 5.0, 3.0), (-10.0, 5.0, 3.0), (-10.0, 20.0, 3.0), (5.0, 5.0, -3.0),
         (-1e6, 5.0, 1e6), (20.0, 20.0, 1.0)]
    d = [(-1.0, 0.0, -0.5), (1.0, 0.0, -0.25), (1.0, 0.0, -0.25), (1.0, 0.0, 0.0),
         (1.0, 0.0, -1.0), (0.0, 0.0, -1.0)]
    xyz, hit, _ = cast(o, d, h, origin=(0.0, 0.0), cell=1.0)
    npt.assert_array_equal(hit, [HIT_NONE, HIT_LAND, HIT_NONE, HIT_NONE, HIT_NONE, HIT_NONE])
    npt.assert_allclose(xyz[1], (2.0, 5.0, 0.0), atol=1e-9)
    npt.assert_array_equal(xyz[0], o[0])  # a miss reports the ray's origin


def test_max_distance():
    h = np.zeros((11, 11), np.float32)
    o = np.tile((5.0, 5.0, 10.0), (3, 1))
    d = np.tile((0.0, 0.0, -2.0), (3, 1))
    for max_d, want in ((9.0, HIT_NONE), (10.5, HIT_LAND), (np.inf, HIT_LAND)):
        xyz, hit, _ = cast(o, d, h, max_d=max_d)
        npt.assert_array_equal(hit, want)


def test_no_nan_for_degenerate_rays(rng):
    h, water, origin, cell = synthetic()
    o = np.array([(0.0, 40.0, 20.0)] * 8 + [(np.nan, 0.0, 0.0), (0.0, np.inf, 0.0)])
    d = np.array([(1, 0, 0), (0, 1, 0), (0, 0, -1), (0, 0, 1), (1, 1, 0), (0, 1, -1), (1, 0, -1),
                  (0, 0, 0), (0, 0, -1), (0, 0, -1)], float)
    xyz, hit, _ = cast(o, d, h, water, origin, cell)
    assert hit[7] == HIT_NONE and hit[8] == HIT_NONE and hit[9] == HIT_NONE
    assert (hit[[2, 5, 6]] != HIT_NONE).all()
    nan_d = cast(o[:1], [(np.nan, 0.0, -1.0)], h, water, origin, cell)
    assert nan_d[1][0] == HIT_NONE
    # Tiny components and huge ones: still finite; the length of a direction does not matter.
    d2 = rng.normal(size=(200, 3)) * rng.choice([1e-300, 1.0, 1e200], (200, 3))
    o2, _ = random_rays(rng, 200, origin, cell, h.shape)
    cast(o2, d2, h, water, origin, cell)
    d3 = rng.normal(size=(50, 3))
    d3[:, 2] = -np.abs(d3[:, 2])
    base = cast(o2[:50], d3, h, water, origin, cell)
    for factor in (1e-300, 1e300):
        scaled = cast(o2[:50], d3 * factor, h, water, origin, cell)
        npt.assert_array_equal(scaled[1], base[1])
        npt.assert_allclose(scaled[0], base[0], atol=1e-9)


def test_water_is_hit_where_the_water_plane_is_above_the_terrain():
    # Terrain ramp z = 0.5 x − 5 crossing a level-0 water sheet at x = 10; the water ends
    # (NaN) past x = 14, so the cell from 14 to 15 holds water by the fill rule.
    nx = 31
    x = np.arange(nx, dtype=float)
    h = np.tile(0.5 * x - 5.0, (8, 1)).astype(np.float32)
    water = np.tile(np.where(x <= 14, 0.0, np.nan), (8, 1)).astype(np.float32)
    xs = np.array([2.0, 9.9, 10.1, 14.5, 20.0])
    xyz, hit, _ = cast(np.column_stack([xs, np.full(5, 3.0), np.full(5, 50.0)]),
                       np.tile((0.0, 0.0, -1.0), (5, 1)), h, water)
    npt.assert_array_equal(hit, [HIT_WATER, HIT_WATER, HIT_LAND, HIT_LAND, HIT_LAND])
    npt.assert_allclose(xyz[:, 2], [0.0, 0.0, 0.05, 2.25, 5.0], atol=1e-9)


def test_pure_python_matches_jit(rng):
    """The kernel runs with the JIT off too (NUMBA_DISABLE_JIT coverage jobs)."""
    from riverflow.kernels import raycast
    h, water, origin, cell = synthetic(nx=20, ny=15)
    o, d = random_rays(rng, 40, origin, cell, h.shape)
    pyr = height_pyramid(h, water)
    want_xyz, want_hit = np.zeros((40, 3)), np.zeros(40, np.uint8)
    cast_rays_onto_heightfield(o, d, h, water, *origin, cell, 1e3, want_xyz, want_hit, pyr)
    got_xyz, got_hit = np.zeros((40, 3)), np.zeros(40, np.uint8)
    py_pyr = np.empty_like(pyr)
    getattr(raycast.fill_height_pyramid, "py_func", raycast.fill_height_pyramid)(h, water, py_pyr)
    npt.assert_array_equal(py_pyr, pyr)
    kernel = getattr(raycast.cast_rays_onto_heightfield, "py_func", raycast.cast_rays_onto_heightfield)
    kernel(o, d, h, water, *origin, cell, 1e3, got_xyz, got_hit, pyr)
    npt.assert_array_equal(got_hit, want_hit)
    npt.assert_allclose(got_xyz, want_xyz, atol=1e-9)


# -- the default scene ------------------------------------------------------------------------


@pytest.fixture(scope="module")
def scene():
    from riverflow.scenes.default import default_scene
    return default_scene(seed=0)


def test_water_tiles_hold_the_level_in_and_near_the_river(scene):
    """The water tiles the rays read: the scene's level at every node in the river, and a
    little past the banks (so the shore is where the water plane meets the terrain), NaN
    farther out."""
    from riverflow.scenes.tile_kinds import WET_REACH_CELLS, LandscapeTiles, WaterProducer
    tiles = LandscapeTiles(scene)
    producer = WaterProducer(tiles)
    level = tiles.max_level
    keys = [k for k in scene.quadtree.tiles_in_box(level, (-600, -600, 600, 600)).tolist()
            if tiles.has_water(tuple(k))][:6]
    assert len(keys) >= 4
    cell = scene.quadtree.cell_m(level, tiles.n)
    inside_total = 0
    for key in keys:
        w = producer.produce(tuple(key), {})["level"].ravel()
        assert w.dtype == np.float32
        xy = tiles.nodes(tuple(key), tiles.n)
        inside = scene.water.contains(xy)
        inside_total += inside.sum()
        assert np.isfinite(w[inside]).all()                   # water everywhere in the river
        npt.assert_allclose(w[np.isfinite(w)], scene.water.level(xy[np.isfinite(w)]), atol=1e-4)
        shore = scene.water.distance_to_shore(xy)
        assert np.isnan(w[~inside & (shore > WET_REACH_CELLS * cell + 1.0)]).all()
    assert inside_total > 1000


def _camera_over_river(scene, above_m, ahead_m, size=(160, 90)):
    from riverflow.engine.camera import Camera
    main = np.vstack([b.centerline_m for b in scene.branches if b.kind == "main"])
    k = len(main) // 2
    eye_xy, ahead = main[k], main[min(k + int(ahead_m / 10.0), len(main) - 1)]
    level = float(scene.water.level(eye_xy[None])[0])
    cam = Camera(size_px=size, fov_y_deg=60.0)
    cam.look_at((*eye_xy, level + above_m), (*ahead, level))
    return cam


@pytest.mark.parametrize("ahead_m", [20.0, 150.0])
def test_default_scene_rays_find_the_river(scene, ahead_m):
    """Rays cast onto the surface tiles of a real frame's view (the cut of the quadtree the
    camera needs, tiles made at the level their distance needs)."""
    from riverflow.components.river import TerrainView
    from riverflow.engine.config import RiverConfig
    from riverflow.engine.world import RiverWorld
    from riverflow.kernels.raycast_tiles import cast_rays_onto_tiles
    t = scene.terrain
    cam = _camera_over_river(scene, 30.0, ahead_m)
    world = RiverWorld(scene, size=cam.size_px,
                       config=RiverConfig(tile_production="blocking", fov_y_deg=60.0))
    world.camera.look_at(cam.position, cam.target)
    world.step(1 / 60)
    surface = world.resource(TerrainView).surface
    world.close()
    assert surface.cut_keys is not None and (surface.leaf_slot >= 0).all()
    px = np.stack(np.meshgrid(np.arange(0.5, 160, 2.0), np.arange(0.5, 90, 2.0)), -1).reshape(-1, 2)
    origins, directions = cam.screen_to_ray(px)
    xyz, hit = np.empty_like(origins), np.empty(len(origins), np.uint8)
    cast_rays_onto_tiles(origins, directions, surface, 1e4, xyz, hit)
    some = hit != HIT_NONE
    assert (hit == HIT_WATER).sum() > 200
    # Hits lie on the surface that was hit: the tiles' (sampled at the level the distance
    # needs), within a few cm of the scene's exact terrain and water.
    from riverflow.kernels.surface_tiles import sample_surface
    land, wet = hit == HIT_LAND, hit == HIT_WATER
    on = np.array([sample_surface(surface, x, y)[:2] for x, y in xyz[:, :2]])
    npt.assert_allclose(xyz[land, 2], on[land, 0], atol=1e-3)
    npt.assert_allclose(xyz[wet, 2], on[wet, 1], atol=1e-3)
    assert np.percentile(np.abs(xyz[land, 2] - t.height(xyz[land, :2])), 90) < 0.1
    npt.assert_allclose(xyz[wet, 2], scene.water.level(xyz[wet, :2]), atol=0.02)
    # Water where the scene says water, except within a metre of the banks.
    contains = scene.water.contains(xyz[some, :2])
    shore = scene.water.distance_to_shore(xyz[some, :2])
    far = shore > 1.0
    npt.assert_array_equal((hit[some] == HIT_WATER)[far], contains[far])
    # They pass through their pixels.
    screen, _, front = cam.world_to_screen(xyz[some])
    assert front.all()
    npt.assert_allclose(screen, px[some], atol=1e-6)
