"""Rays cast onto the view's cut of surface tiles (kernels/raycast_tiles.py) against a twin:
the same nodes assembled into one grid and cast by kernels/raycast.py; cuts with mixed
levels, missing tiles and ancestors standing in; degenerate rays."""
from __future__ import annotations

import math

import numpy as np
import numpy.testing as npt
import pytest

import riverflow as rf
from riverflow.kernels.raycast import (HIT_LAND, HIT_NONE, HIT_WATER,
                                       cast_rays_onto_heightfield, height_pyramid)
from riverflow.kernels.raycast_tiles import HIT_UNKNOWN, cast_rays_onto_tiles
from riverflow.kernels.surface_tiles import SurfaceTiles, leaf_standins
from riverflow.scenes.tile_kinds import HINT_CELLS, RAYCAST, terrain_producers
from riverflow.tiles.cache import TileCache
from riverflow.tiles.scheduler import TileScheduler
from riverflow.tiles.table import TileTable, codes
from tests.flow.networks import bending_confluence

BLOCK = 4
"""The region is BLOCK × BLOCK tiles of the finest level (2 × 2 of the next, 1 of the one
after)."""


def _network_graph():
    return bending_confluence()


class Region:
    """Raycast tiles of three levels over one square region with river in it, in one pool
    (as the world's cache holds them), and helpers to make SurfaceTiles of any cut of it."""

    def __init__(self, scene, i0: int, j0: int) -> None:
        producers = terrain_producers(scene)
        tiles = producers[0].tiles
        self.scene = scene
        self.q = tiles.quadtree
        self.n = tiles.n
        self.L = tiles.max_level
        assert i0 % BLOCK == 0 and j0 % BLOCK == 0
        self.i0, self.j0 = i0, j0
        self.cache = TileCache(1 << 34)
        sched = TileScheduler(self.cache, producers, "blocking")
        self.keys = {}
        for up in range(3):
            m = BLOCK >> up
            self.keys[up] = np.array([(self.L - up, (i0 >> up) + a, (j0 >> up) + b)
                                      for b in range(m) for a in range(m)], np.int64)
            sched.request(RAYCAST, self.keys[up])
        assert not sched.errors, sched.errors
        self.pool = self.cache.pools[RAYCAST]
        self.wet = any(tiles.has_water(tuple(k)) for k in self.keys[0].tolist())
        self.x0, self.y0 = self.q.tile_origin_m(self.L, i0, j0)
        self.size = BLOCK * self.q.tile_size_m(self.L)
        self.grids = {up: self._grid(up) for up in range(3)}
        g = self.grids[0]
        self.z_lo, self.z_hi = float(g[2][-1, 0]), float(g[2][-1, 1])

    def slot(self, key) -> int:
        return int(self.pool.table.find_many(codes(np.array([key])))[0])

    def tile(self, key) -> tuple[np.ndarray, np.ndarray]:
        s = self.slot(key)
        assert s >= 0, key
        return self.pool.arrays["ground"][s], self.pool.arrays["water"][s]

    def _grid(self, up: int):
        """(ground, water, pyramid, cell) of the region's tiles of level L − up as one grid;
        shared nodes are checked to agree."""
        n, m = self.n, BLOCK >> up
        ground = np.full((m * n + 1, m * n + 1), np.nan, np.float32)
        water = np.full_like(ground, np.nan)
        for key in self.keys[up].tolist():
            a, b = key[1] - (self.i0 >> up), key[2] - (self.j0 >> up)
            g, w = self.tile(key)
            win = np.s_[b * n:b * n + n + 1, a * n:a * n + n + 1]
            seen = ~np.isnan(ground[win])
            assert np.array_equal(ground[win][seen], g[seen]), key  # bitwise-shared borders
            assert np.array_equal(water[win][seen], w[seen], equal_nan=True), key
            ground[win], water[win] = g, w
        return ground, water, height_pyramid(ground, water), self.q.cell_m(self.L - up, n)

    def surface(self, leaves, table: TileTable | None = None, slot_of=None, z=None
                ) -> SurfaceTiles:
        """SurfaceTiles of the cut ``leaves`` (K, 3): each leaf's tile found as the world finds
        it (:func:`leaf_standins` over ``table``, by default the pool's), or as ``slot_of``
        (leaf → (slot, key)) says."""
        leaves = np.ascontiguousarray(leaves, np.int32).reshape(-1, 3)
        cut = TileTable(2 * len(leaves))
        cut.set_many(codes(leaves), np.arange(len(leaves), dtype=np.int32))
        table = table or self.pool.table
        slot = np.empty(len(leaves), np.int32)
        key = np.zeros((len(leaves), 3), np.int32)
        leaf_standins(leaves, len(leaves), table.keys, table.values, slot, key)
        for k, leaf in enumerate(leaves.tolist()):
            if slot_of is not None and tuple(leaf) in slot_of:
                slot[k], key[k] = slot_of[tuple(leaf)]
        zlo, zhi = (self.z_lo, self.z_hi) if z is None else z
        return SurfaceTiles(
            self.q.root_x_m, self.q.root_y_m, self.q.root_size_m, self.n, cut.keys,
            cut.values, int(leaves[:, 0].min()), int(leaves[:, 0].max()), slot, key, self.pool.arrays["ground"],
            self.pool.arrays["water"], self.pool.arrays["pyramid"], float(zlo), float(zhi),
            np.full(len(leaves), -1, np.int32), np.zeros((len(leaves), 3), np.int32),
            np.full((1, HINT_CELLS + 1, HINT_CELLS + 1, 3), np.inf, np.float32), HINT_CELLS)

    def on_grid(self, o, d, up: int = 0, max_d=np.inf):
        ground, water, pyramid, cell = self.grids[up]
        xyz = np.full(o.shape, np.nan)
        hit = np.full(len(o), 99, np.uint8)
        cast_rays_onto_heightfield(o, d, ground, water, self.x0, self.y0, cell, max_d, xyz,
                                   hit, pyramid)
        return xyz, hit


def on_tiles(surface: SurfaceTiles, o, d, max_d=np.inf):
    o = np.ascontiguousarray(o, np.float64)
    d = np.ascontiguousarray(d, np.float64)
    xyz = np.full(o.shape, np.nan)
    hit = np.full(len(o), 99, np.uint8)
    count = cast_rays_onto_tiles(o, d, surface, max_d, xyz, hit)
    assert np.isfinite(xyz).all()
    assert set(np.unique(hit).tolist()) <= {HIT_NONE, HIT_LAND, HIT_WATER, HIT_UNKNOWN}
    assert count == int(((hit == HIT_LAND) | (hit == HIT_WATER)).sum())
    return xyz, hit


@pytest.fixture(scope="module", params=["default", "network"])
def region(request) -> Region:
    if request.param == "default":
        r = Region(rf.default_scene(seed=0), 4, 8)
    else:
        r = Region(rf.landscape(_network_graph(), seed=5), 8, 16)
    assert r.wet
    return r


def looking_down(region: Region, rng, count: int, margin: float = 0.0):
    """Cameras 5 … 300 m above the region's highest point, anywhere over it (``margin``
    beyond), looking down 3° … 89° in any direction."""
    lo = np.array([region.x0 - margin, region.y0 - margin])
    xy = rng.uniform(lo, lo + region.size + 2 * margin, (count, 2))
    o = np.c_[xy, region.z_hi + rng.uniform(5.0, 300.0, count)]
    yaw = rng.uniform(0.0, 2.0 * np.pi, count)
    pitch = np.radians(rng.uniform(3.0, 89.0, count))
    d = np.c_[np.cos(pitch) * np.cos(yaw), np.cos(pitch) * np.sin(yaw), -np.sin(pitch)]
    return o, d


def edge_rays(region: Region, rng, count: int):
    """Rays along tile borders, through tile corners, straight down onto them, and grazing."""
    tile = region.q.tile_size_m(region.L)
    k = rng.integers(1, BLOCK, (count, 2))
    line = np.c_[region.x0 + tile * k[:, 0], region.y0 + tile * k[:, 1]]
    free = rng.uniform([region.x0, region.y0], [region.x0 + region.size, region.y0 + region.size],
                       (count, 2))
    sign = rng.choice([-1.0, 1.0], (count, 2))
    dip = -rng.uniform(0.02, 1.0, count)
    high = region.z_hi + rng.uniform(5.0, 200.0, count)
    parts = [
        (np.c_[line[:, 0], free[:, 1], high], np.c_[np.zeros(count), sign[:, 1], dip]),
        (np.c_[free[:, 0], line[:, 1], high], np.c_[sign[:, 0], np.zeros(count), dip]),
        (np.c_[line - 50.0 * sign, high], np.c_[sign, dip]),
        (np.c_[line, high], np.tile([0.0, 0.0, -1.0], (count, 1))),
        (np.c_[free, region.z_lo + rng.uniform(0.0, region.z_hi - region.z_lo, count)],
         np.c_[sign * rng.uniform(0.2, 1.0, (count, 2)), -rng.uniform(0.0, 0.05, count)]),
    ]
    return np.concatenate([p[0] for p in parts]), np.concatenate([p[1] for p in parts])


def assert_same_hits(got, want, size_m: float):
    xyz, hit = got
    want_xyz, want_hit = want
    bad = np.flatnonzero(hit != want_hit)
    assert not len(bad), f"{len(bad)} rays differ: got {hit[bad[:5]]}, want {want_hit[bad[:5]]}"
    npt.assert_allclose(xyz, want_xyz, rtol=1e-6, atol=1e-6 * size_m)


# -- a cut of one level against one grid ---------------------------------------------------------


@pytest.mark.parametrize("up", [0, 1, 2])
def test_one_level_cut_gives_the_hits_of_one_grid(region, up):
    rng = np.random.default_rng(10 + up)
    surface = region.surface(region.keys[up])
    o, d = looking_down(region, rng, 300)
    got = on_tiles(surface, o, d)
    assert_same_hits(got, region.on_grid(o, d, up), region.size)
    hit = got[1]
    assert (hit == HIT_LAND).sum() > 60 and (hit == HIT_WATER).sum() > 3
    assert (hit == HIT_NONE).sum() > 20       # rays leaving the region see nothing beyond
    # from outside the region (not in the cut), and with a distance limit
    o, d = looking_down(region, rng, 150, margin=0.5 * region.size)
    assert_same_hits(on_tiles(surface, o, d), region.on_grid(o, d, up), region.size)
    assert_same_hits(on_tiles(surface, o, d, 150.0), region.on_grid(o, d, up, 150.0),
                     region.size)


def test_rays_along_borders_through_corners_and_grazing_give_the_hits_of_one_grid(region):
    rng = np.random.default_rng(3)
    o, d = edge_rays(region, rng, 60)
    got = on_tiles(region.surface(region.keys[0]), o, d)
    assert_same_hits(got, region.on_grid(o, d), region.size)
    assert (got[1] != HIT_NONE).sum() > 100


def test_rays_meeting_the_surface_right_on_a_tile_border_hit_there(region):
    """Aimed at points of the surface on borders between leaves, from the leaf before the
    border: the crossing falls where one leaf's walk ends and the next begins (whether the
    ray was above the surface is carried across), and is found, as on one grid."""
    rng = np.random.default_rng(12)
    count = 150
    tile = region.q.tile_size_m(region.L)
    k = rng.integers(1, BLOCK, count)
    along = rng.uniform(0.05, 0.95, count) * region.size
    vertical = rng.random(count) < 0.5
    x = np.where(vertical, region.x0 + tile * k, region.x0 + along)
    y = np.where(vertical, region.y0 + along, region.y0 + tile * k)
    leaves = [tuple(key) for key in region.keys[0].tolist()]
    t, w, found = _surface_at(region, {key: key for key in leaves}, x, y)
    assert found.all()
    target = np.c_[x, y, np.maximum(t, w)]
    back = rng.uniform(20.0, 200.0, count)
    side = rng.uniform(-0.5, 0.5, count)
    step = np.where(vertical[:, None], np.c_[np.full(count, -1.0), side],
                    np.c_[side, np.full(count, -1.0)])            # from the lower leaf
    o = np.c_[target[:, :2] + back[:, None] * step, target[:, 2] + rng.uniform(5.0, 80.0, count)]
    d = target - o
    got = on_tiles(region.surface(region.keys[0]), o, d)
    want = region.on_grid(o, d)
    assert_same_hits(got, want, region.size)
    xyz, hit = got
    reached = np.linalg.norm(xyz - target, axis=1) < 1e-3
    assert reached.sum() > 0.9 * count, (hit[~reached][:5], xyz[~reached][:3], target[~reached][:3])


def test_rays_from_under_the_ground_and_upwards_give_the_hits_of_one_grid(region):
    rng = np.random.default_rng(4)
    count = 200
    xy = rng.uniform([region.x0, region.y0], [region.x0 + region.size, region.y0 + region.size],
                     (count, 2))
    o = np.c_[xy, rng.uniform(region.z_lo - 5.0, region.z_hi, count)]
    d = rng.normal(size=(count, 3))
    surface = region.surface(region.keys[0])
    assert_same_hits(on_tiles(surface, o, d), region.on_grid(o, d), region.size)
    assert_same_hits(on_tiles(surface, o, d, 80.0), region.on_grid(o, d, 0, 80.0), region.size)


def test_hits_do_not_depend_on_the_height_range_given(region):
    """A wider z range (the scene's, as the world gives) only starts the march earlier."""
    rng = np.random.default_rng(5)
    o, d = looking_down(region, rng, 200)
    lo, hi = region.scene.z_range_m
    assert lo <= region.z_lo and hi >= region.z_hi
    wide = region.surface(region.keys[0], z=(lo - 10.0, hi + 10.0))
    assert_same_hits(on_tiles(wide, o, d), region.on_grid(o, d), region.size)


# -- mixed levels, missing tiles, ancestors standing in --------------------------------------------


def _surface_at(region: Region, leaves: dict, x: np.ndarray, y: np.ndarray):
    """(terrain, water or −inf, found) at points, from the tile each point's leaf reads
    (``leaves``: leaf key → the key of the tile it reads), as kernels/raycast.py defines the
    surface of a grid (bilinear patches, dry corners of a wet cell at the wet ones' mean);
    on a border the leaf on the higher side."""
    q, n = region.q, region.n
    terrain = np.full(len(x), np.nan)
    water = np.full(len(x), -np.inf)
    found = np.zeros(len(x), bool)
    u = (x - q.root_x_m) / q.root_size_m
    v = (y - q.root_y_m) / q.root_size_m
    for leaf, key in leaves.items():
        side = 1 << leaf[0]
        tx = np.minimum((u * side).astype(np.int64), side - 1)
        ty = np.minimum((v * side).astype(np.int64), side - 1)
        sel = np.flatnonzero((tx == leaf[1]) & (ty == leaf[2]) & (u >= 0) & (v >= 0))
        if not len(sel):
            continue
        ground, wet = (a.astype(np.float64) for a in region.tile(key))
        size = q.root_size_m / (1 << key[0])
        cell = size / n
        gx = np.clip((x[sel] - (q.root_x_m + key[1] * size)) / cell, 0.0, n)
        gy = np.clip((y[sel] - (q.root_y_m + key[2] * size)) / cell, 0.0, n)
        i = np.minimum(gx.astype(np.int64), n - 1)
        j = np.minimum(gy.astype(np.int64), n - 1)
        fu, fv = gx - i, gy - j
        corner = lambda a: np.stack([a[j, i], a[j, i + 1], a[j + 1, i], a[j + 1, i + 1]])
        weights = np.stack([(1 - fu) * (1 - fv), fu * (1 - fv), (1 - fu) * fv, fu * fv])
        terrain[sel] = (corner(ground) * weights).sum(axis=0)
        w = corner(wet)
        some = np.isfinite(w).any(axis=0)
        mean = np.nanmean(np.where(some, w, 0.0), axis=0)
        w = np.where(np.isnan(w), mean, w)
        water[sel] = np.where(some, (w * weights).sum(axis=0), -np.inf)
        found[sel] = True
    return terrain, water, found


def _mixed_cut(region: Region):
    """The finest tiles of the region but two 2 × 2 blocks, which are one leaf a level up."""
    L, i0, j0 = region.L, region.i0, region.j0
    coarse = [(L - 1, (i0 >> 1) + 1, j0 >> 1), (L - 1, i0 >> 1, (j0 >> 1) + 1)]
    fine = [tuple(k) for k in region.keys[0].tolist()
            if (L - 1, k[1] >> 1, k[2] >> 1) not in coarse]
    return fine + coarse


def _check_on_leaf_surfaces(region: Region, leaves: dict, o, d, xyz, hit):
    """Every hit lies on the surface of the leaf it is in (or on the step between two leaves
    of different levels, where a skirt hangs), on water exactly where the water is above the
    terrain; sampled every 0.5 m before it, the ray is above every leaf's surface (no earlier
    crossing was missed), and so is a missed ray all through the region."""
    tol = 1e-6 * region.size
    some = (hit == HIT_LAND) | (hit == HIT_WATER)
    t, w, found = _surface_at(region, leaves, xyz[some, 0], xyz[some, 1])
    assert found.all()
    top = np.maximum(t, w)
    on = np.abs(xyz[some, 2] - top) <= 1e-6 * (1.0 + np.abs(top))
    if not on.all():     # a step at a level change: between the surfaces either side
        back = xyz[some][~on] - 1e-4 * d[some][~on] / np.linalg.norm(d[some][~on], axis=1,
                                                                     keepdims=True)
        t2, w2, _ = _surface_at(region, leaves, back[:, 0], back[:, 1])
        lo = np.minimum(top[~on], np.maximum(t2, w2)) - tol
        hi = np.maximum(top[~on], np.maximum(t2, w2)) + tol
        z = xyz[some][~on, 2]
        assert ((z >= lo) & (z <= hi)).all()
        assert (~on).sum() <= 3
    clear = on & (np.abs(w - t) > 1e-4)
    water = hit[some] == HIT_WATER
    npt.assert_array_equal(water[clear], (w >= t)[clear])
    # sampled before the hit: above every surface
    unit = d / np.linalg.norm(d, axis=1, keepdims=True)
    for r in range(len(o)):
        end = np.linalg.norm(xyz[r] - o[r]) if some[r] else 3.0 * region.size
        s = np.arange(0.0, end - 1e-3, 0.5)
        p = o[r] + s[:, None] * unit[r]
        t, w, found = _surface_at(region, leaves, p[:, 0], p[:, 1])
        below = found & (p[:, 2] < np.maximum(t, w) - tol)
        assert not below.any(), (r, hit[r], s[below][:3])


def test_a_cut_of_mixed_levels_hits_each_leafs_own_surface(region):
    leaves = _mixed_cut(region)
    surface = region.surface(leaves)
    assert (surface.leaf_slot >= 0).all()
    npt.assert_array_equal(surface.leaf_key, np.array(leaves, np.int32))
    rng = np.random.default_rng(6)
    o, d = looking_down(region, rng, 250)
    xyz, hit = on_tiles(surface, o, d)
    assert (hit == HIT_LAND).sum() > 50
    assert not (hit == HIT_UNKNOWN).any()
    _check_on_leaf_surfaces(region, {k: k for k in leaves}, o, d, xyz, hit)
    # rays that hit a fine leaf having only crossed fine leaves are the one-grid hits
    fine_xyz, fine_hit = region.on_grid(o, d)
    coarse = np.array([k for k in leaves if k[0] < region.L])
    tile = region.q.tile_size_m(region.L - 1)
    cx0 = region.q.root_x_m + coarse[:, 1] * tile
    cy0 = region.q.root_y_m + coarse[:, 2] * tile
    same = 0
    unit = d / np.linalg.norm(d, axis=1, keepdims=True)
    for r in range(len(o)):
        end = xyz[r] if hit[r] != HIT_NONE else o[r] + 3.0 * region.size * unit[r]
        s = np.linspace(0.0, 1.0, 4000)[:, None]
        p = o[r] + s * (end - o[r])
        inside = ((p[:, None, 0] >= cx0 - 1.0) & (p[:, None, 0] <= cx0 + tile + 1.0)
                  & (p[:, None, 1] >= cy0 - 1.0) & (p[:, None, 1] <= cy0 + tile + 1.0)
                  & (p[:, None, 2] <= region.z_hi + 1.0))
        if not inside.any():
            assert hit[r] == fine_hit[r], r
            npt.assert_allclose(xyz[r], fine_xyz[r], rtol=1e-6, atol=1e-6 * region.size)
            same += 1
    assert same > 30


def test_a_leaf_without_a_tile_makes_rays_over_it_unknown(region):
    """A leaf with no tile (slot −1) that a ray crosses within the surface's height range
    before any hit: HIT_UNKNOWN, never a land or water hit beyond it; rays that hit before
    reaching it, or pass it above the height range, are unchanged."""
    keys = region.keys[0]
    gone = tuple(keys[5].tolist())
    leaves = [tuple(k) for k in keys.tolist()]
    full = region.surface(leaves)
    holed = region.surface(leaves, slot_of={gone: (-1, (0, 0, 0))})
    assert holed.leaf_slot[5] == -1 and (np.delete(holed.leaf_slot, 5) >= 0).all()
    rng = np.random.default_rng(8)
    o, d = looking_down(region, rng, 300)
    # some looking at points of the missing leaf, some passing high over it, coming down only
    # beyond it
    tile = region.q.tile_size_m(region.L)
    gx0, gy0 = region.q.tile_origin_m(*gone)
    aim = np.c_[rng.uniform([gx0, gy0], [gx0 + tile, gy0 + tile], (60, 2)),
                np.full(60, region.z_lo)]
    o2, _ = looking_down(region, rng, 60)
    o = np.concatenate([o, o2])
    d = np.concatenate([d, aim - o2])
    k = 40
    start = np.c_[gx0 - 20.0 + rng.uniform(0, 5, k), gy0 + rng.uniform(0.2, 0.8, k) * tile]
    o = np.concatenate([o, np.c_[start, np.full(k, region.z_hi + 30.0)]])
    d = np.concatenate([d, np.c_[np.ones(k), rng.normal(0, 0.1, k),
                                 np.full(k, -30.0 / (tile + 60.0))]])
    want_xyz, want_hit = on_tiles(full, o, d)
    xyz, hit = on_tiles(holed, o, d)
    # where the ray is over the missing leaf before its hit (or at all, if it misses)
    unit = d / np.linalg.norm(d, axis=1, keepdims=True)
    over = np.zeros(len(o), bool)
    unsure = np.zeros(len(o), bool)
    for r in range(len(o)):
        end = (np.linalg.norm(want_xyz[r] - o[r]) if want_hit[r] != HIT_NONE
               else 10.0 * region.size)
        s = np.linspace(0.0, end, 20001)
        p = o[r] + s[:, None] * unit[r]
        seen = []
        for e in (-0.5, 0.0, 0.5):          # the leaf and its height range, shrunk or grown
            seen.append(((p[:, 0] >= gx0 - e) & (p[:, 0] < gx0 + tile + e)
                         & (p[:, 1] >= gy0 - e) & (p[:, 1] < gy0 + tile + e)
                         & (p[:, 2] >= region.z_lo - e) & (p[:, 2] <= region.z_hi + e)).any())
        over[r] = seen[1]
        unsure[r] = seen[0] != seen[2]
    sure = ~unsure
    npt.assert_array_equal(hit[sure] == HIT_UNKNOWN, over[sure])
    kept = sure & ~over
    npt.assert_array_equal(hit[kept], want_hit[kept])
    npt.assert_allclose(xyz[kept], want_xyz[kept], rtol=1e-6, atol=1e-6 * region.size)
    assert (sure & over).sum() > 20
    # hits that were inside the missing leaf are all unknown now
    inside_hit = ((want_xyz[:, 0] >= gx0) & (want_xyz[:, 0] < gx0 + tile)
                  & (want_xyz[:, 1] >= gy0) & (want_xyz[:, 1] < gy0 + tile)
                  & (want_hit != HIT_NONE))
    assert inside_hit.sum() > 3 and (hit[inside_hit] == HIT_UNKNOWN).all()
    # passing high above it changes nothing
    high = np.arange(len(o)) >= len(o) - k
    assert (high & sure & ~over).sum() > 20
    assert (high & (want_hit != HIT_NONE)).sum() > 10 and (hit[high] != HIT_UNKNOWN).all()
    # an unknown ray's output is its origin, never NaN
    npt.assert_array_equal(xyz[hit == HIT_UNKNOWN], o[hit == HIT_UNKNOWN])


def test_an_ancestor_standing_in_gives_hits_on_its_surface(region):
    """Leaves whose tiles are not resident read their finest resident ancestor's tile
    (:func:`leaf_standins`): the hits of four leaves reading their parent are those of the
    parent as one leaf, and lie on the parent's surface."""
    L, i0, j0 = region.L, region.i0, region.j0
    up = (L - 1, (i0 >> 1) + 1, (j0 >> 1) + 1)
    kids = {(L, 2 * up[1] + a, 2 * up[2] + b) for b in range(2) for a in range(2)}
    leaves = [tuple(k) for k in region.keys[0].tolist()]
    # a table of the resident tiles without the four children
    resident = TileTable(64)
    for k in list(region.keys[0].tolist()) + list(region.keys[1].tolist()):
        if tuple(k) not in kids:
            resident.set(int(codes(np.array([k]))[0]), region.slot(k))
    standing = region.surface(leaves, table=resident)
    for k, leaf in enumerate(leaves):
        want = up if leaf in kids else leaf
        assert tuple(standing.leaf_key[k].tolist()) == want
        assert standing.leaf_slot[k] == region.slot(want)
    as_leaf = region.surface([k for k in leaves if k not in kids] + [up])
    rng = np.random.default_rng(9)
    o, d = looking_down(region, rng, 300)
    got = on_tiles(standing, o, d)
    assert_same_hits(got, on_tiles(as_leaf, o, d), region.size)
    xyz, hit = got
    tile = region.q.tile_size_m(L - 1)
    ux0, uy0 = region.q.tile_origin_m(*up)
    inside = ((xyz[:, 0] > ux0) & (xyz[:, 0] < ux0 + tile) & (xyz[:, 1] > uy0)
              & (xyz[:, 1] < uy0 + tile) & ((hit == HIT_LAND) | (hit == HIT_WATER)))
    assert inside.sum() > 10
    t, w, found = _surface_at(region, {up: up}, xyz[inside, 0], xyz[inside, 1])
    assert found.all()
    npt.assert_allclose(xyz[inside, 2], np.maximum(t, w), rtol=1e-6, atol=1e-6)
    # not the children's own surface (else this proved nothing)
    t2, w2, _ = _surface_at(region, {k: k for k in kids}, xyz[inside, 0], xyz[inside, 1])
    assert np.abs(np.maximum(t2, w2) - np.maximum(t, w)).max() > 1e-3


def test_every_leaf_reading_one_ancestor_gives_the_hits_of_its_grid(region):
    """The region's finest leaves all standing in with the one tile two levels up: the hits
    are those of that tile's grid."""
    top = tuple(region.keys[2][0].tolist())
    resident = TileTable(4)
    resident.set(int(codes(np.array([top]))[0]), region.slot(top))
    surface = region.surface(region.keys[0], table=resident)
    assert (surface.leaf_key == np.array(top, np.int32)).all()
    rng = np.random.default_rng(11)
    o, d = looking_down(region, rng, 300)
    assert_same_hits(on_tiles(surface, o, d), region.on_grid(o, d, 2), region.size)


# -- degenerate rays -----------------------------------------------------------------------------


def test_rays_with_nan_or_infinite_input_see_nothing_and_write_no_nan(region):
    surface = region.surface(region.keys[0])
    c = np.array([region.x0 + 0.5 * region.size, region.y0 + 0.5 * region.size,
                  region.z_hi + 50.0])
    o = np.array([(np.nan, c[1], c[2]), (c[0], np.nan, c[2]), (c[0], c[1], np.nan),
                  (np.inf, c[1], c[2]), (c[0], -np.inf, c[2]), tuple(c), tuple(c), tuple(c),
                  tuple(c), tuple(c)])
    d = np.array([(0, 0, -1), (0, 0, -1), (0, 0, -1), (0, 0, -1), (0, 0, -1),
                  (np.nan, 0, -1), (0, np.inf, -1), (0, 0, 0), (1e-300, 0, -1e-300),
                  (0.0, 0.0, -1.0)], float)
    xyz, hit = on_tiles(surface, o, d)                  # finite output, checked there
    npt.assert_array_equal(hit[:8], HIT_NONE)
    assert hit[9] in (HIT_LAND, HIT_WATER)            # the sane ray does hit
    assert hit[8] in (HIT_LAND, HIT_WATER)            # a tiny direction is a direction
    npt.assert_array_equal(xyz[:5], 0.0)              # non-finite origin: 0
    assert all((xyz[r] == 0.0).all() or (xyz[r] == o[r]).all() for r in range(5, 8))
    xyz2, hit2 = on_tiles(surface, o[8:], d[8:] * 1e300)  # length does not matter
    npt.assert_array_equal(hit2, hit[8:])
    npt.assert_allclose(xyz2, xyz[8:], rtol=1e-12)
    # an empty cut sees nothing
    empty = surface._replace(cut_keys=np.zeros(0, np.int64), cut_values=np.zeros(0, np.int32))
    xyz3, hit3 = on_tiles(empty, o[9:], d[9:])
    assert hit3[0] == HIT_NONE and math.isfinite(xyz3[0, 0])
