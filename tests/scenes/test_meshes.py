"""Meshes for the draw system: terrain tiles (exact samples, continuous normals, skirts deep
enough to hide level-of-detail cracks, index buffers that tile each tile exactly once) and the
water surface (exactly the water polygon, no triangle larger than a grid cell, CCW, at the
water level)."""
from __future__ import annotations

import time

import numpy as np
import pytest
import shapely

from riverflow import load_graph
from riverflow.components.terrain import Terrain
from riverflow.scenes.default import default_scene
from riverflow.scenes.flat import flat_scene
from riverflow.scenes.meshes import (
    border_loop,
    choose_levels,
    level_count,
    lod_indices,
    terrain_mesh,
    tile_bounds,
    water_mesh,
)


@pytest.fixture(scope="module")
def scene():
    return default_scene(seed=0)


@pytest.fixture(scope="module")
def default_water(scene):
    t = time.perf_counter()
    mesh = water_mesh(scene)
    print(f"\nwater_mesh(default scene) in {time.perf_counter() - t:.2f} s")
    return mesh


@pytest.fixture(scope="module")
def bumpy() -> Terrain:
    """4 × 3 tiles of 16 cells, 2 m cells, rough heights (tens of metres)."""
    rng = np.random.default_rng(7)
    n, tx, ty = 16, 4, 3
    y, x = np.mgrid[0:ty * n + 1, 0:tx * n + 1] * 2.0
    h = 20 * np.sin(x / 23.0) * np.cos(y / 17.0) + 3 * rng.standard_normal(x.shape)
    return Terrain(h, (-50.0, 30.0), 2.0, 32.0)


def _flat(path):
    return flat_scene(load_graph(path))


def _cross(a, b, c):
    """Twice the signed area of triangles (..., 2) points, float64."""
    return (b[..., 0] - a[..., 0]) * (c[..., 1] - a[..., 1]) - (b[..., 1] - a[..., 1]) * (c[..., 0] - a[..., 0])


def _cover_counts(points, tris, origin, cell):
    """How many triangles (K, 3, 2) cover each point (P, 2), counting edges as inside. Each
    triangle must lie in one square cell of the grid (origin, cell) (it is looked up there)."""
    tri_cell = np.floor((tris.mean(axis=1) - origin) / cell).astype(np.int64)
    pt_cell = np.floor((points - origin) / cell).astype(np.int64)
    tkey = tri_cell[:, 1] * 1_000_003 + tri_cell[:, 0]
    pkey = pt_cell[:, 1] * 1_000_003 + pt_cell[:, 0]
    order = np.argsort(tkey, kind="stable")
    start = np.searchsorted(tkey[order], pkey, "left")
    end = np.searchsorted(tkey[order], pkey, "right")
    counts = np.zeros(len(points), np.int64)
    for k in range(int((end - start).max(initial=0))):
        sel = np.flatnonzero(start + k < end)
        t = tris[order[start[sel] + k]]
        p = points[sel]
        eps = -1e-9
        inside = ((_cross(t[:, 0], t[:, 1], p) >= eps) & (_cross(t[:, 1], t[:, 2], p) >= eps)
                  & (_cross(t[:, 2], t[:, 0], p) >= eps))
        counts[sel] += inside
    return counts


# -- water ---------------------------------------------------------------------------------


@pytest.fixture(params=["tiny", "proland", "default"])
def water_case(request, scene, default_water, tiny_channel_path, proland_graph_path):
    """(scene, its 8 m water mesh)."""
    if request.param == "default":
        return scene, default_water
    s = _flat(tiny_channel_path if request.param == "tiny" else proland_graph_path)
    return s, water_mesh(s)


def test_water_mesh_covers_exactly_the_polygon_area(water_case):
    s, mesh = water_case
    p = mesh.positions[:, :2].astype(np.float64)[mesh.indices]
    area = 0.5 * _cross(p[:, 0], p[:, 1], p[:, 2]).sum()
    assert area == pytest.approx(s.water.polygon.area, rel=1e-6)
    assert mesh.area_m2 == pytest.approx(area, rel=1e-9)


def test_water_triangles_are_ccw_nondegenerate_and_inside_one_cell(water_case):
    s, mesh = water_case
    assert mesh.positions.dtype == np.float32 and mesh.indices.dtype == np.uint32
    assert mesh.indices.ndim == 2 and mesh.indices.shape[1] == 3
    assert mesh.indices.max() < len(mesh.positions)
    p = mesh.positions[:, :2].astype(np.float64)[mesh.indices]
    assert (_cross(p[:, 0], p[:, 1], p[:, 2]) > 0).all()
    edges = np.linalg.norm(p - np.roll(p, 1, axis=1), axis=-1)
    assert edges.max() <= mesh.cell_m * np.sqrt(2) + 1e-3
    lo = s.terrain.origin_m + np.floor((p.mean(axis=1) - s.terrain.origin_m) / mesh.cell_m) * mesh.cell_m
    assert (p >= lo[:, None] - 1e-3).all() and (p <= lo[:, None] + mesh.cell_m + 1e-3).all()


def test_water_vertices_are_shared_and_edges_meet_without_t_junctions(water_case):
    """Interior edges are used once each way; the edges used once trace the polygon's
    boundary (same total length), so neighbouring cells share their vertices."""
    s, mesh = water_case
    assert len(np.unique(mesh.positions[:, :2], axis=0)) == len(mesh.positions)
    e = np.stack([mesh.indices, np.roll(mesh.indices, -1, axis=1)], axis=-1).reshape(-1, 2).astype(np.int64)
    key = e[:, 0] * len(mesh.positions) + e[:, 1]
    assert len(np.unique(key)) == len(key)  # no directed edge twice: no overlap, same winding
    reverse = np.isin(e[:, 1] * len(mesh.positions) + e[:, 0], key)
    outer = mesh.positions[e[~reverse]][..., :2].astype(np.float64)
    length = np.linalg.norm(outer[:, 1] - outer[:, 0], axis=1).sum()
    assert length == pytest.approx(s.water.polygon.length, rel=1e-5)


def test_water_vertices_take_the_water_level(water_case):
    s, mesh = water_case
    want = s.water.level(mesh.positions[:, :2].astype(np.float64))
    np.testing.assert_allclose(mesh.positions[:, 2], want, rtol=0, atol=1e-4)


def test_points_in_water_are_covered_once_and_land_and_islands_never(water_case, rng):
    s, mesh = water_case
    poly = s.water.polygon
    x0, y0, x1, y1 = poly.bounds
    pts = rng.uniform((x0 - 20, y0 - 20), (x1 + 20, y1 + 20), size=(40_000, 2))
    holes = [shapely.Polygon(r) for g in shapely.get_parts(poly) for r in g.interiors]
    for hole in holes:  # plus points on every island
        hx0, hy0, hx1, hy1 = hole.bounds
        pts = np.vstack([pts, rng.uniform((hx0, hy0), (hx1, hy1), size=(400, 2))])
    far = shapely.distance(poly.boundary, shapely.points(pts)) > 1e-3
    pts = pts[far]
    wet = shapely.contains_xy(poly, pts[:, 0], pts[:, 1])
    tris = mesh.positions[:, :2].astype(np.float64)[mesh.indices]
    counts = _cover_counts(pts, tris, s.terrain.origin_m, mesh.cell_m)
    assert wet.sum() > 50 and (~wet).sum() > 50
    assert (counts[wet] == 1).all()
    assert (counts[~wet] == 0).all()
    for hole in holes:
        on_island = shapely.contains_xy(hole, pts[:, 0], pts[:, 1])
        assert on_island.sum() > 10 and (counts[on_island] == 0).all()


def test_water_mesh_at_other_cell_sizes_keeps_the_area(tiny_channel_path, proland_graph_path):
    for path in (tiny_channel_path, proland_graph_path):
        s = _flat(path)
        for cell in (3.0, 16.0):
            mesh = water_mesh(s, cell_m=cell)
            assert mesh.area_m2 == pytest.approx(s.water.polygon.area, rel=1e-6)
            p = mesh.positions[:, :2].astype(np.float64)[mesh.indices]
            assert np.linalg.norm(p - np.roll(p, 1, axis=1), axis=-1).max() <= cell * np.sqrt(2) + 1e-3


def test_default_water_mesh_is_compact(default_water):
    """Fewer vertices than triangles (shared), and a few seconds at most to build."""
    assert len(default_water.positions) < len(default_water.indices)
    assert 5_000 < len(default_water.indices) < 200_000


# -- terrain -------------------------------------------------------------------------------


def test_level_count_and_lod_index_counts():
    assert level_count(64) == 7 and level_count(32) == 6 and level_count(48) == 5 and level_count(1) == 1
    for n in (64, 12):
        side = n + 1
        for level, idx in enumerate(lod_indices(n)):
            m = n >> level
            assert idx.dtype == np.uint32 and idx.shape == (2 * m * m + 8 * m, 3)
            assert idx.max() < side * side + 4 * n
    assert len(lod_indices(64, 3)) == 3
    with pytest.raises(ValueError):
        lod_indices(12, 4)


def test_border_loop_is_ccw_and_visits_every_border_sample_once():
    n = 8
    i, j = border_loop(n)
    assert len(set(zip(i.tolist(), j.tolist()))) == 4 * n
    assert ((i == 0) | (i == n) | (j == 0) | (j == n)).all()
    assert (np.abs(np.diff(np.append(i, i[0]))) + np.abs(np.diff(np.append(j, j[0]))) == 1).all()
    assert 0.5 * np.sum(i * np.roll(j, -1) - np.roll(i, -1) * j) == n * n  # shoelace: CCW


def test_terrain_positions_are_the_heightfield_samples(bumpy):
    mesh = terrain_mesh(bumpy)
    n, (tx, ty) = bumpy.cells_per_tile, bumpy.tile_count
    side = n + 1
    assert mesh.positions.shape == (tx * ty, side * side + 4 * n, 3) == mesh.normals.shape
    assert mesh.positions.dtype == np.float32 == mesh.normals.dtype
    for iy in range(ty):
        for ix in range(tx):
            t = iy * tx + ix
            h, origin = bumpy.tile(ix, iy)
            grid = mesh.positions[t, :side * side].reshape(side, side, 3)
            np.testing.assert_array_equal(grid[..., 2], h)
            jj, ii = np.mgrid[0:side, 0:side]
            np.testing.assert_allclose(grid[..., 0], origin[0] + ii * bumpy.cell_m, atol=1e-4)
            np.testing.assert_allclose(grid[..., 1], origin[1] + jj * bumpy.cell_m, atol=1e-4)


def test_skirts_hang_below_their_border_with_its_normal(bumpy):
    mesh = terrain_mesh(bumpy)
    n = bumpy.cells_per_tile
    side = n + 1
    bi, bj = border_loop(n)
    top = mesh.positions[:, bj * side + bi]
    skirt = mesh.positions[:, side * side:]
    np.testing.assert_array_equal(skirt[..., :2], top[..., :2])
    np.testing.assert_allclose(top[..., 2] - skirt[..., 2],
                               np.broadcast_to(mesh.skirt_m[:, None], top.shape[:2]), rtol=1e-5)
    assert (mesh.skirt_m >= 2 * bumpy.cell_m).all()
    np.testing.assert_array_equal(mesh.normals[:, side * side:], mesh.normals[:, bj * side + bi])
    fixed = terrain_mesh(bumpy, skirt_m=5.0)
    np.testing.assert_allclose(fixed.positions[:, bj * side + bi, 2] - fixed.positions[:, side * side:, 2],
                               5.0, rtol=1e-5)


def test_normals_are_unit_central_differences_and_agree_across_tile_borders(bumpy):
    mesh = terrain_mesh(bumpy)
    n, (tx, ty) = bumpy.cells_per_tile, bumpy.tile_count
    side = n + 1
    np.testing.assert_allclose(np.linalg.norm(mesh.normals, axis=-1), 1.0, atol=1e-6)
    grid = mesh.normals[:, :side * side].reshape(ty, tx, side, side, 3)
    np.testing.assert_array_equal(grid[:, :-1, :, -1], grid[:, 1:, :, 0])  # shared columns
    np.testing.assert_array_equal(grid[:-1, :, -1], grid[1:, :, 0])  # shared rows
    h, c = bumpy.heights_m.astype(np.float64), bumpy.cell_m
    j, i = 5, 20  # an interior sample of tile (1, 0)
    want = np.array([-(h[j, i + 1] - h[j, i - 1]) / (2 * c), -(h[j + 1, i] - h[j - 1, i]) / (2 * c), 1.0])
    np.testing.assert_allclose(grid[0, 1, j, i - n], want / np.linalg.norm(want), atol=1e-6)
    want = np.array([-(h[0, 1] - h[0, 0]) / c, -(h[1, 0] - h[0, 0]) / c, 1.0])  # one-sided corner
    np.testing.assert_allclose(grid[0, 0, 0, 0], want / np.linalg.norm(want), atol=1e-6)


@pytest.mark.parametrize("n", [8, 12, 64])
def test_each_level_tiles_the_tile_exactly_once_with_outward_skirts(n, rng):
    side = n + 1
    xy = np.stack(np.meshgrid(np.arange(side), np.arange(side)), -1).reshape(-1, 2).astype(np.float64)
    bi, bj = border_loop(n)
    xy = np.vstack([xy, np.stack([bi, bj], 1)])
    pts = rng.uniform(0, n, size=(2000, 2))
    for level, idx in enumerate(lod_indices(n)):
        s, m = 1 << level, n >> level
        grid, skirt = idx[:2 * m * m], idx[2 * m * m:]
        assert (grid < side * side).all()
        t = xy[grid]
        area = _cross(t[:, 0], t[:, 1], t[:, 2])
        assert (area > 0).all() and 0.5 * area.sum() == pytest.approx(n * n)
        assert (_cover_counts(pts, t, np.zeros(2), float(s)) == 1).all()
        # skirts: each quad joins two border samples s apart to their copies, facing outward
        assert ((skirt >= side * side).sum(axis=1) >= 1).all()
        top = [row[row < side * side] for row in skirt]
        assert all(len(r) in (1, 2) for r in top)
        p3 = np.concatenate([xy, np.zeros((len(xy), 1))], axis=1)
        p3[side * side:, 2] = -1.0
        tri = p3[skirt]
        normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        outward = tri.mean(axis=1)[:, :2] - n / 2
        assert (np.einsum("ij,ij->i", normal[:, :2], outward) > 0).all()
        assert np.abs(normal[:, 2]).max() == 0
        assert 0.5 * np.linalg.norm(normal, axis=1).sum() == pytest.approx(4 * n)  # 1 deep, 4n round


def test_skirts_cover_every_level_of_detail_crack(bumpy):
    """For every shared edge and every pair of levels on its two sides, each tile's skirt
    reaches down to the other tile's edge line."""
    mesh = terrain_mesh(bumpy)
    n, (tx, ty) = bumpy.cells_per_tile, bumpy.tile_count
    side = n + 1
    grid = mesh.positions[:, :side * side, 2].reshape(ty, tx, side, side).astype(np.float64)
    k = np.arange(side, dtype=np.float64)

    def line(edge, level):  # the edge drawn at a level, at every sample
        s = 1 << level
        return np.interp(k, k[::s], edge[::s])

    pairs = [((iy, ix), (iy, ix + 1), grid[iy, ix, :, -1]) for iy in range(ty) for ix in range(tx - 1)]
    pairs += [((iy, ix), (iy + 1, ix), grid[iy, ix, -1, :]) for iy in range(ty - 1) for ix in range(tx)]
    worst = 0.0
    for a, b, edge in pairs:
        sa, sb = mesh.skirt_m[a[0] * tx + a[1]], mesh.skirt_m[b[0] * tx + b[1]]
        for la in range(level_count(n)):
            for lb in range(level_count(n)):
                ea, eb = line(edge, la), line(edge, lb)
                worst = max(worst, np.abs(ea - eb).max())
                assert (ea - sa <= eb + 1e-4).all() and (eb - sb <= ea + 1e-4).all()
    assert worst > 2 * bumpy.cell_m  # the test terrain is rough enough to need deep skirts


def test_flat_terrain_gets_the_minimum_skirt():
    flat = Terrain(np.full((33, 33), 3.0), (0.0, 0.0), 4.0, 64.0)
    mesh = terrain_mesh(flat)
    np.testing.assert_array_equal(mesh.skirt_m, 8.0)
    np.testing.assert_array_equal(mesh.normals[..., 2], 1.0)


def test_tile_bounds_hold_each_tile_and_its_skirt(bumpy):
    mesh = terrain_mesh(bumpy)
    np.testing.assert_array_equal(tile_bounds(bumpy), mesh.bounds_m)
    np.testing.assert_allclose(mesh.bounds_m[:, 0], mesh.positions.min(axis=1), atol=1e-4)
    np.testing.assert_allclose(mesh.bounds_m[:, 1], mesh.positions.max(axis=1), atol=1e-4)
    assert mesh.bounds_m.shape == (12, 2, 3) and mesh.bounds_m.dtype == np.float32


def test_choose_levels_grow_with_distance():
    n, tile, lod = 64, 256.0, 500.0
    x = np.linspace(0.0, 60_000.0, 400)
    centres = np.stack([x, np.zeros_like(x), np.zeros_like(x)], 1)
    levels = choose_levels(centres, np.zeros(3), tile, n, lod)
    assert (np.diff(levels) >= 0).all()
    assert levels[0] == 0 and levels[-1] == level_count(n) - 1
    d = np.maximum(x - tile * np.sqrt(0.5), 0.0)
    assert (levels[d <= lod] == 0).all()
    assert (levels[(d > lod) & (d <= 2 * lod)] == 1).all()
    assert (levels[(d > 2 * lod) & (d <= 4 * lod)] == 2).all()


def test_default_scene_terrain_mesh(scene):
    t = time.perf_counter()
    mesh = terrain_mesh(scene.terrain)
    print(f"\nterrain_mesh(default scene) in {time.perf_counter() - t:.2f} s")
    assert mesh.positions.shape == (256, 65 * 65 + 256, 3)
    assert mesh.tiles == (16, 16) and mesh.cells_per_tile == 64 and mesh.levels == 7
    assert (mesh.skirt_m >= 8.0).all() and mesh.skirt_m.max() < 50.0
    levels = choose_levels(mesh.centres_m, np.array([0.0, 0.0, 100.0]), 256.0, 64)
    assert levels.min() == 0 and levels.max() >= 2
