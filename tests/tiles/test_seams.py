"""Seams of the streamed world (SPEC §8): tiles made by the landscape's producers agree where
they meet, whatever their level, and whatever was made or evicted before.

Two landscapes: the built-in 4 km scene (a power-of-two root square) and a small builder
network with a confluence on procedural hills (a root square of no round size, so node
coordinates are not exact binary fractions). Tiles are made directly by a blocking
scheduler; no world is needed.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

import riverflow as rf
from riverflow.scenes.meshes import (MIN_SKIRT_CELLS, border_loop, level_count,
                                     tile_terrain_mesh)
from riverflow.scenes.tile_kinds import (HEIGHT, HINTS, RAYCAST, TERRAIN_MESH, WATER,
                                         WATER_MESH, WET_REACH_CELLS, terrain_producers)
from riverflow.tiles.cache import TileCache
from riverflow.tiles.quadtree import Quadtree, children, parent
from riverflow.tiles.scheduler import TileScheduler
from riverflow.tiles.table import tile_code
from tests.flow.networks import bending_confluence

MAX_PAIRS = 10
"""Same-level neighbour pairs with water checked per (level, axis); a few dry ones besides."""
DRY_PAIRS = 3


def _network_graph():
    return bending_confluence()


class Made:
    """A landscape, its producers and a blocking scheduler with an unbounded cache; tiles are
    made on first use and kept (copies, so later evictions cannot touch them)."""

    def __init__(self, scene) -> None:
        self.scene = scene
        self.producers = terrain_producers(scene)
        self.tiles = self.producers[0].tiles
        self.quadtree: Quadtree = self.tiles.quadtree
        self.n = self.tiles.n
        self.max_level = self.tiles.max_level
        self.cache = TileCache(1 << 34)
        self.scheduler = TileScheduler(self.cache, self.producers, "blocking")
        self._got: dict = {}

    def get(self, kind: str, key):
        key = tuple(int(v) for v in key)
        got = self._got.get((kind, key))
        if got is None:
            self.cache.next_tick()
            self.scheduler.request(kind, np.array([key]))
            assert not self.scheduler.errors, self.scheduler.errors
            data = self.cache.pools[kind].get(tile_code(*key))
            assert data is not None, (kind, key)
            got = self._got[(kind, key)] = _copy(kind, data)
        return got

    def heights(self, key) -> np.ndarray:
        """(n+3, n+3) float32 with the ring."""
        return self.get(HEIGHT, key)["z"]

    def grid_vertices(self, key) -> np.ndarray:
        """(n+1, n+1, 8) float32 grid vertices of the terrain mesh (row = y)."""
        side = self.n + 1
        return self.get(TERRAIN_MESH, key)["vertices"][:side * side].reshape(side, side, 8)

    def level_tiles(self, level: int) -> list[tuple[int, int, int]]:
        side = 1 << level
        return [(level, i, j) for j in range(side) for i in range(side)]

    def pairs(self, level: int, axis: int) -> list[tuple[tuple, tuple]]:
        """Same-level neighbours (a, b), b one tile on along x (axis 0) or y (axis 1): up to
        MAX_PAIRS with water near (spread along the river), then DRY_PAIRS without."""
        side = 1 << level
        wet, dry = [], []
        for a in self.level_tiles(level):
            i, j = a[1] + (axis == 0), a[2] + (axis == 1)
            if i >= side or j >= side:
                continue
            b = (level, i, j)
            (wet if self.tiles.has_water(a) or self.tiles.has_water(b) else dry).append((a, b))
        pick = np.unique(np.linspace(0, len(wet) - 1, min(MAX_PAIRS, len(wet))).astype(int))
        rng = np.random.default_rng(level * 2 + axis)
        some_dry = rng.choice(len(dry), min(DRY_PAIRS, len(dry)), replace=False)
        return [wet[k] for k in pick] + [dry[k] for k in sorted(some_dry)]

    def family(self, level: int) -> list[tuple[tuple, tuple]]:
        """(parent, child) pairs: children of level ``level`` with water near, spread along
        the river, and a few dry ones."""
        wet = [k for k in self.level_tiles(level) if self.tiles.has_water(k)]
        dry = [k for k in self.level_tiles(level) if not self.tiles.has_water(k)]
        pick = np.unique(np.linspace(0, len(wet) - 1, min(MAX_PAIRS, len(wet))).astype(int))
        rng = np.random.default_rng(100 + level)
        kids = [wet[k] for k in pick] + [dry[k] for k in sorted(
            rng.choice(len(dry), min(DRY_PAIRS, len(dry)), replace=False))]
        return [(parent(k), k) for k in kids]


def _copy(kind: str, data) -> dict:
    if kind == TERRAIN_MESH:
        return {"vertices": data.vertices.copy(), "skirt_m": np.float64(data.skirt_m),
                "bounds_m": data.bounds_m.copy()}
    if kind == WATER_MESH:
        mesh, ground = data
        return {"positions": mesh.positions.copy(), "indices": mesh.indices.copy(),
                "area_m2": np.float64(mesh.area_m2), "cell_m": np.float64(mesh.cell_m),
                "ground": ground.copy()}
    return {name: np.array(value, copy=True) for name, value in data.items()}


@pytest.fixture(scope="module", params=["default", "network"])
def made(request) -> Made:
    if request.param == "default":
        return Made(rf.default_scene(seed=0))
    return Made(rf.landscape(_network_graph(), seed=5))


def _bits(a: np.ndarray) -> np.ndarray:
    """The float32 bit patterns (NaN compared as bits too)."""
    return np.ascontiguousarray(a, np.float32).view(np.uint32)


def _border(a: np.ndarray, axis: int, at: int | slice) -> np.ndarray:
    """Column ``at`` (axis 0: the border x = const) or row ``at`` (axis 1) of a (row = y)
    tile array."""
    return a[:, at] if axis == 0 else a[at, :]


def _levels(made: Made) -> tuple[int, ...]:
    return (made.max_level, made.max_level - 1, made.max_level - 2)


# -- same-level neighbours -------------------------------------------------------------------


def test_the_quadtree_gives_shared_nodes_the_same_coordinates(made):
    q, n = made.quadtree, made.n
    for level in _levels(made):
        for (a, b) in made.pairs(level, 0)[:3]:
            xa, ya = q.node_coords(*a, n, ring=1)
            xb, yb = q.node_coords(*b, n, ring=1)
            assert np.array_equal(xa[n:], xb[:3]) and np.array_equal(ya, yb)
        for kid in children((level - 1, 1, 1)):
            xc, yc = q.node_coords(*kid, n)
            xp, yp = q.node_coords(level - 1, 1, 1, n)
            ox, oy = (kid[1] & 1) * n // 2, (kid[2] & 1) * n // 2
            assert np.array_equal(xc[::2], xp[ox:ox + n // 2 + 1])
            assert np.array_equal(yc[::2], yp[oy:oy + n // 2 + 1])


@pytest.mark.parametrize("axis", [0, 1])
def test_heights_and_their_rings_agree_across_borders(made, axis):
    """The three node lines around a border (the ring of one is the inside of the other) are
    bitwise the same in both tiles."""
    n = made.n
    checked = 0
    for level in _levels(made):
        for a, b in made.pairs(level, axis):
            za, zb = made.heights(a), made.heights(b)
            assert np.isfinite(za).all() and np.isfinite(zb).all()
            assert np.array_equal(_bits(_border(za, axis, slice(n, n + 3))),
                                  _bits(_border(zb, axis, slice(0, 3)))), (a, b)
            checked += 1
    assert checked >= 3 * 4


@pytest.mark.parametrize("axis", [0, 1])
def test_water_levels_and_their_gaps_agree_across_borders(made, axis):
    n = made.n
    mixed = 0
    for level in _levels(made):
        for a, b in made.pairs(level, axis):
            wa, wb = made.get(WATER, a), made.get(WATER, b)
            for name in ("level", "level_seen", "shore"):
                assert np.array_equal(_bits(_border(wa[name], axis, n)),
                                      _bits(_border(wb[name], axis, 0))), (name, a, b)
            line = _border(wa["level"], axis, n)
            mixed += bool(np.isnan(line).any() and np.isfinite(line).any())
            if not (made.tiles.has_water(a) or made.tiles.has_water(b)):
                assert np.isnan(wa["level"]).all() and np.isnan(wb["level"]).all()
    assert mixed >= 2, "no border crosses the shore: the NaN pattern was not tested"


@pytest.mark.parametrize("axis", [0, 1])
def test_mesh_vertices_and_normals_agree_across_borders(made, axis):
    """Position (float32), height, normal and level seen of the border vertices of two
    neighbouring terrain meshes are bitwise the same; the normals are unit and face up."""
    n = made.n
    for level in _levels(made):
        for a, b in made.pairs(level, axis):
            va, vb = made.grid_vertices(a), made.grid_vertices(b)
            ea, eb = _border(va, axis, n), _border(vb, axis, 0)
            assert np.array_equal(_bits(ea), _bits(eb)), (a, b, np.abs(ea - eb).max(axis=0))
            normal = va[..., 3:6].astype(np.float64)
            assert np.allclose(np.linalg.norm(normal, axis=-1), 1.0, atol=1e-6)
            assert (normal[..., 2] > 0.0).all()


def test_water_meshes_share_their_border_vertices(made):
    """Two neighbouring water meshes have the same vertices (x, y and level, float32) on
    their shared border: no T-junction, no step in the water surface there."""
    shared = 0
    for level, axis in [(lv, ax) for lv in (made.max_level, made.max_level - 1) for ax in (0, 1)]:
        for a, b in made.pairs(level, axis):
            if not (made.tiles.has_water(a) and made.tiles.has_water(b)):
                continue
            pa = made.get(WATER_MESH, a)["positions"]
            pb = made.get(WATER_MESH, b)["positions"]
            line = np.float32(made.quadtree.tile_box_m(*a)[2 + axis])
            on_a = {tuple(v) for v in pa[pa[:, axis] == line].tolist()}
            on_b = {tuple(v) for v in pb[pb[:, axis] == line].tolist()}
            assert on_a == on_b, (a, b, sorted(on_a ^ on_b)[:4])
            shared += len(on_a)
    assert shared > 20


def test_hints_agree_across_borders_and_levels(made):
    """Hint nodes shared by neighbours, and a parent's hint nodes (every second one of its
    children's), hold bitwise the same hint."""
    h = made.get(HINTS, (made.max_level, 0, 0))["hints"].shape[0] - 1
    some = 0
    for axis in (0, 1):
        for a, b in made.pairs(made.max_level, axis):
            ha, hb = made.get(HINTS, a)["hints"], made.get(HINTS, b)["hints"]
            assert np.array_equal(_bits(_border(ha, axis, h)), _bits(_border(hb, axis, 0)))
            some += int(np.isfinite(_border(ha, axis, h)).all(axis=-1).sum())
    for up, kid in made.family(made.max_level):
        hc, hp = made.get(HINTS, kid)["hints"], made.get(HINTS, up)["hints"]
        rows, cols = _quadrant(kid, h)
        assert np.array_equal(_bits(hc[::2, ::2]), _bits(hp[rows, cols])), (up, kid)
    assert some > 5


def test_mesh_vertices_are_the_tiles_heights_and_levels(made):
    """A terrain mesh is made of its height and water tiles, not of anything else: its grid
    z is the height tile's inside, its level the water tile's level seen, its normals the
    central differences over the ring (float64 from float32), its x, y the node
    coordinates, its shore distance the water tile's in units of the river's size."""
    n = made.n
    for a, _ in made.pairs(made.max_level, 0)[:4] + made.pairs(made.max_level - 1, 1)[:2]:
        v = made.grid_vertices(a)
        z = made.heights(a).astype(np.float64)
        assert np.array_equal(_bits(v[..., 2]), _bits(z[1:-1, 1:-1]))
        assert np.array_equal(_bits(v[..., 6]), _bits(made.get(WATER, a)["level_seen"]))
        water = made.get(WATER, a)
        assert np.array_equal(_bits(v[..., 7]), _bits(water["shore"] / water["scale"]))
        cell = made.quadtree.cell_m(a[0], n)
        dzdx = (z[1:-1, 2:] - z[1:-1, :-2]) / (2.0 * cell)
        dzdy = (z[2:, 1:-1] - z[:-2, 1:-1]) / (2.0 * cell)
        want = np.stack([-dzdx, -dzdy, np.ones_like(dzdx)], -1)
        want /= np.linalg.norm(want, axis=-1, keepdims=True)
        np.testing.assert_allclose(v[..., 3:6], want, atol=2e-7)
        x, y = made.quadtree.node_coords(*a, n)
        np.testing.assert_allclose(v[..., 0], np.broadcast_to(x[None, :], (n + 1, n + 1)),
                                   rtol=1e-6, atol=0)
        np.testing.assert_allclose(v[..., 1], np.broadcast_to(y[:, None], (n + 1, n + 1)),
                                   rtol=1e-6, atol=0)


# -- parent and child ----------------------------------------------------------------------------


def _quadrant(key, n: int) -> tuple[slice, slice]:
    """The (rows, columns) of the parent's nodes that are the child's even nodes."""
    ox, oy = (key[1] & 1) * n // 2, (key[2] & 1) * n // 2
    return slice(oy, oy + n // 2 + 1), slice(ox, ox + n // 2 + 1)


def test_heights_of_a_parent_are_every_second_node_of_its_children(made):
    n = made.n
    for level in (made.max_level, made.max_level - 1):
        for up, kid in made.family(level):
            zc = made.heights(kid)[1:-1, 1:-1]
            zp = made.heights(up)[1:-1, 1:-1]
            rows, cols = _quadrant(kid, n)
            assert np.array_equal(_bits(zc[::2, ::2]), _bits(zp[rows, cols])), (up, kid)


def test_water_levels_of_a_parent_and_its_children_agree(made):
    """At shared nodes: the level seen is bitwise the same; a node wet in the child is wet in
    the parent with the same level (the parent's wet reach, in its cells, is twice as wide),
    and every shared node inside the water is wet in both."""
    n = made.n
    both_wet = 0
    for level in (made.max_level, made.max_level - 1):
        for up, kid in made.family(level):
            wc, wp = made.get(WATER, kid), made.get(WATER, up)
            rows, cols = _quadrant(kid, n)
            for name in ("level_seen", "shore"):
                assert np.array_equal(_bits(wc[name][::2, ::2]),
                                      _bits(wp[name][rows, cols])), (name, up, kid)
            lc, lp = wc["level"][::2, ::2], wp["level"][rows, cols]
            wet_c, wet_p = np.isfinite(lc), np.isfinite(lp)
            assert not (wet_c & ~wet_p).any(), (up, kid)
            assert np.array_equal(_bits(lc[wet_c]), _bits(lp[wet_c])), (up, kid)
            both_wet += int(wet_c.sum())
            x, y = made.quadtree.node_coords(*kid, n)
            gx, gy = np.meshgrid(x[::2], y[::2])
            inside = made.scene.water.contains(np.c_[gx.ravel(), gy.ravel()]).reshape(gx.shape)
            assert wet_c[inside].all() and wet_p[inside].all(), (up, kid)
            # the extra wet nodes of the parent are within its reach of the shore
            extra = wet_p & ~wet_c
            if extra.any():
                p = np.c_[gx[extra], gy[extra]]
                shore = made.scene.water.distance_to_shore(p)
                reach_p = WET_REACH_CELLS * made.quadtree.cell_m(up[0], n)
                assert (shore < reach_p + 1e-9).all()
    assert both_wet > 50, "too few wet shared nodes: the water was not tested"


def test_normals_of_a_parent_are_its_childrens_heights_at_its_spacing(made):
    """The parent's normal at a shared node is the central difference of the child's heights
    two child cells either side (those nodes are the parent's neighbours): bitwise."""
    n = made.n
    for up, kid in made.family(made.max_level)[:6]:
        z = made.heights(kid).astype(np.float64)[1:-1, 1:-1]     # child inside, (n+1)²
        cell = 2.0 * made.quadtree.cell_m(kid[0], n)              # the parent's spacing
        dzdx = (z[2:-2:2, 4::2] - z[2:-2:2, :-4:2]) / (2.0 * cell)
        dzdy = (z[4::2, 2:-2:2] - z[:-4:2, 2:-2:2]) / (2.0 * cell)
        want = np.stack([-dzdx, -dzdy, np.ones_like(dzdx)], -1)
        want /= np.linalg.norm(want, axis=-1, keepdims=True)
        rows, cols = _quadrant(kid, n)
        got = made.grid_vertices(up)[rows, cols][1:-1, 1:-1, 3:6]
        assert np.array_equal(_bits(got), _bits(want.astype(np.float32))), (up, kid)


# -- skirts: no cracks between levels ----------------------------------------------------------


def _coarse_edge(made: Made, fine, axis: int, up: int):
    """Along the border of tile ``fine`` facing +axis: (the fine mesh's border vertices,
    the border of the neighbour ``up`` levels coarser as drawn, interpolated at the fine
    nodes, the coarse tile's skirt). None at the root's edge or when the neighbour is the
    fine tile's own ancestor."""
    n = made.n
    level, i, j = fine
    ni, nj = i + (axis == 0), j + (axis == 1)
    if max(ni, nj) >= 1 << level:
        return None
    s = 1 << up
    coarse = (level - up, ni >> up, nj >> up)
    if (coarse[1], coarse[2]) == (i >> up, j >> up):
        return None
    vf = made.grid_vertices(fine)
    vc = made.grid_vertices(coarse)
    mf = made.get(TERRAIN_MESH, fine)
    mc = made.get(TERRAIN_MESH, coarse)
    along = j if axis == 0 else i                   # the fine tile's index along the border
    off = (along % s) * n // s                      # its first node on the coarse border
    hf = _border(vf, axis, n)[:, 2].astype(np.float64)
    hc = _border(vc, axis, 0)[off:off + n // s + 1, 2].astype(np.float64)
    pos_f = _border(vf, axis, n)[:, 1 if axis == 0 else 0]
    pos_c = _border(vc, axis, 0)[off:off + n // s + 1, 1 if axis == 0 else 0]
    assert np.array_equal(pos_f[::s], pos_c)
    assert np.array_equal(_bits(hf[::s]), _bits(hc))   # the coarse nodes are fine nodes
    k = np.arange(n + 1)
    a = np.minimum(k // s, n // s - 1)
    t = (k - a * s) / s
    drawn = hc[a] * (1.0 - t) + hc[a + 1] * t
    return hf, drawn, float(mf["skirt_m"]), float(mc["skirt_m"])


@pytest.mark.parametrize("up", [1, 2])
def test_skirts_hide_the_cracks_to_a_coarser_neighbour(made, up):
    """Where a tile meets a neighbour ``up`` levels coarser, its skirt hangs at least as
    deep as the gap between its border and the coarse border as drawn (the promise of
    :func:`tile_skirt_m`), and wherever the coarse border is the higher one, the coarse
    tile's skirt reaches down to the fine border: no crack either way."""
    seen = 0
    for level in (made.max_level, made.max_level - 1):
        for fine in [k for k in made.level_tiles(level) if made.tiles.has_water(k)][::3]:
            for axis in (0, 1):
                got = _coarse_edge(made, fine, axis, up)
                if got is None:
                    continue
                hf, drawn, skirt_f, skirt_c = got
                gap = hf - drawn
                assert skirt_f >= np.abs(gap).max(), (fine, axis)
                assert skirt_f >= MIN_SKIRT_CELLS * made.quadtree.cell_m(level, made.n)
                assert (hf - skirt_f <= np.minimum(hf, drawn)).all()
                assert skirt_c >= np.maximum(-gap, 0.0).max(), (fine, axis)
                seen += 1
    assert seen >= 4


def _rough(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """A rough surface with steep short waves and a cliff (tens of metres across a cell)."""
    return (30.0 * np.sin(x / 3.1) * np.cos(y / 2.3) + 25.0 * np.sin(1.7 * x + 0.3 * y)
            + np.where(x + 0.5 * y > 40.0, 60.0, 0.0))


def _synthetic_mesh(q: Quadtree, key, n: int):
    x, y = q.node_coords(*key, n, ring=1)
    z = _rough(x[None, :], y[:, None]).astype(np.float32)
    x0, y0 = q.tile_origin_m(*key)
    level_seen = np.full((n + 1, n + 1), -1e4, np.float32)
    return tile_terrain_mesh(z, x0, y0, q.cell_m(key[0], n), level_seen)


def test_tile_skirt_covers_any_coarser_neighbour_on_rough_ground():
    """On ground far rougher than any scene (so the gaps, not the minimum depth, set the
    skirt), the skirt of a tile covers the gap to a neighbour 1 … log2(n) levels coarser on
    each of its four sides, and is no deeper than the largest gap between any two of the
    levels its border can be drawn at."""
    n = 16
    q = Quadtree(-3.7, 11.3, 101.9)
    level = 5
    fine = (level, 13, 9)
    mesh = _synthetic_mesh(q, fine, n)
    side = n + 1
    grid = mesh.vertices[:side * side].reshape(side, side, 8)
    largest = 0.0
    for up in range(1, level_count(n)):
        s = 1 << up
        for axis, forward in ((0, True), (0, False), (1, True), (1, False)):
            di, dj = (1 if forward else -1) * (axis == 0), (1 if forward else -1) * (axis == 1)
            ni, nj = fine[1] + di, fine[2] + dj
            coarse = (level - up, ni >> up, nj >> up)
            if (coarse[1], coarse[2]) == (fine[1] >> up, fine[2] >> up):
                continue
            cm = _synthetic_mesh(q, coarse, n)
            cg = cm.vertices[:side * side].reshape(side, side, 8)
            along = fine[2] if axis == 0 else fine[1]
            off = (along % s) * n // s
            hf = _border(grid, axis, n if forward else 0)[:, 2].astype(np.float64)
            hc = _border(cg, axis, 0 if forward else n)[off:off + n // s + 1, 2].astype(
                np.float64)
            assert np.array_equal(_bits(hf[::s]), _bits(hc))
            k = np.arange(n + 1)
            a = np.minimum(k // s, n // s - 1)
            t = (k - a * s) / s
            gap = np.abs(hf - (hc[a] * (1.0 - t) + hc[a + 1] * t)).max()
            assert mesh.skirt_m >= gap, (up, axis, forward, mesh.skirt_m, gap)
            largest = max(largest, gap)
    assert largest > 3.0 * MIN_SKIRT_CELLS * q.cell_m(level, n)   # the gaps set the skirt
    # no deeper than needed: the largest gap between any two drawings of any side
    z = grid[..., 2].astype(np.float64)
    worst = 0.0
    for edge in (z[0, :], z[-1, :], z[:, 0], z[:, -1]):
        drawn = [edge]
        for up in range(1, level_count(n)):
            s = 1 << up
            k = np.arange(n + 1)
            a = np.minimum(k // s, n // s - 1)
            t = (k - a * s) / s
            drawn.append(edge[a * s] * (1.0 - t) + edge[a * s + s] * t)
        d = np.stack(drawn)
        worst = max(worst, float((d.max(axis=0) - d.min(axis=0)).max()))
    assert mesh.skirt_m == pytest.approx(max(worst, MIN_SKIRT_CELLS * q.cell_m(level, n)),
                                         rel=1e-12)
    # the skirt vertices hang exactly skirt_m below their border vertex
    bi, bj = border_loop(n)
    np.testing.assert_allclose(mesh.vertices[side * side:, 2],
                               (z[bj, bi] - mesh.skirt_m).astype(np.float32), rtol=0, atol=1e-4)


def test_a_ravine_under_a_coarse_border_leaves_no_gap_once_stitched():
    """A 30 m ravine crosses the border between coarse nodes: the fine tile's own border dips
    into it, the coarse one's does not; stitched to its coarse neighbour (as the draw does
    it), the fine border lies on the coarse one as drawn, so no crack opens and no skirt need
    reach down into the ravine."""
    from riverflow.scenes.meshes import stitch_tile
    n = 16
    q = Quadtree(0.0, 0.0, 512.0)
    fine, coarse = (3, 2, 2), (2, 0, 1)         # coarse: west of the fine tile, one level up

    def mesh(key):
        x, y = q.node_coords(*key, n, ring=1)
        z = (np.where(np.abs(y - 156.0) < 1.0, -30.0, 0.0)[:, None] + 0.0 * x[None, :])
        return tile_terrain_mesh(z.astype(np.float32), *q.tile_origin_m(*key),
                                 q.cell_m(key[0], n), np.zeros((n + 1, n + 1), np.float32))

    mf, mc = mesh(fine), mesh(coarse)
    side = n + 1
    hc = mc.vertices[:side * side].reshape(side, side, 8)[:, n, 2]     # coarse east border
    off = (fine[2] % 2) * n // 2
    hc = hc[off:off + n // 2 + 1].astype(np.float64)
    drawn = np.repeat(hc, 2)[: n + 1]
    drawn[1::2] = 0.5 * (hc[:-1] + hc[1:])
    own = mf.vertices[:side * side].reshape(side, side, 8)[:, 0, 2]     # fine west border
    assert np.maximum(drawn - own, 0.0).max() > 20.0     # unstitched: the ravine's gap
    stitched = stitch_tile(mf.vertices, fine, mf.skirt_m, [(3, coarse, mc.vertices)])
    hf = stitched[:side * side].reshape(side, side, 8)[:, 0, 2]
    np.testing.assert_allclose(hf, drawn, rtol=0, atol=1e-4)
    assert mc.skirt_m < 20.0 and mf.skirt_m < 31.0      # no skirt hangs into the ravine


# -- results independent of history ------------------------------------------------------------


def _requests(made: Made) -> list[tuple[str, tuple[int, int, int]]]:
    """Every kind on some tiles with water (and their parents) and some dry ones."""
    L = made.max_level
    wet = [k for k in made.level_tiles(L) if made.tiles.has_water(k)]
    dry = [k for k in made.level_tiles(L) if not made.tiles.has_water(k)]
    keys = wet[:: max(1, len(wet) // 5)][:5] + dry[:: max(1, len(dry) // 2)][:2]
    keys += sorted({parent(k) for k in keys})
    kinds = (TERRAIN_MESH, RAYCAST, HINTS, WATER_MESH, WATER, HEIGHT)
    return [(kind, k) for k in keys for kind in kinds]


def _run(scene, requests, budget_bytes: int, mode: str = "blocking", pieces_kept=None):
    producers = terrain_producers(scene)
    for producer in producers:        # each run makes every tile itself: the property tested
        producer.memo = None
    if pieces_kept is not None:
        producers[0].tiles.pieces.keep = pieces_kept
    cache = TileCache(budget_bytes)
    sched = TileScheduler(cache, producers, mode)
    out = {}
    try:
        for kind, key in requests:
            cache.next_tick()
            sched.request(kind, np.array([key]))
            assert sched.wait(60.0)
            got = cache.pools[kind].get(tile_code(*key))
            if kind == WATER_MESH and not _has_water(producers, key):
                assert got is None      # known empty: never made
                out[(kind, key)] = None
                continue
            assert got is not None, (kind, key, sched.errors)
            out[(kind, key)] = _copy(kind, got)
    finally:
        sched.close()
    assert not sched.errors, sched.errors
    return out, cache


def _has_water(producers, key) -> bool:
    return producers[0].tiles.has_water(key)


def _same(a: dict | None, b: dict | None) -> bool:
    if a is None or b is None:
        return a is None and b is None
    return a.keys() == b.keys() and all(
        np.array_equal(a[k], b[k], equal_nan=np.asarray(a[k]).dtype.kind == "f") for k in a)


def test_tiles_do_not_depend_on_what_was_made_or_evicted_before(made):
    requests = _requests(made)
    unbounded, _ = _run(made.scene, requests, 1 << 34)
    raycast_tile = made.cache.pools[RAYCAST].tile_bytes
    rng = np.random.default_rng(7)
    shuffled = [requests[k] for k in rng.permutation(len(requests))]
    tiny, cache = _run(made.scene, shuffled, 2 * raycast_tile, pieces_kept=2)
    stats = cache.stats()
    assert sum(s["evicted"] for s in stats.values()) > len(requests) // 2
    # evicted dependencies were made again
    assert stats[HEIGHT]["installed"] > len({key for _, key in requests})
    background, _ = _run(made.scene, shuffled[::-1], 1 << 34, "background")
    assert unbounded.keys() == tiny.keys() == background.keys()
    for item, value in unbounded.items():
        assert _same(value, tiny[item]), item
        assert _same(value, background[item]), item
    # and they are the tiles the module's own scheduler made, one by one, in another order
    for (kind, key), value in unbounded.items():
        if value is not None and kind in (HEIGHT, WATER, TERRAIN_MESH):
            assert _same(value, made.get(kind, key)), (kind, key)
    made_any_water = [v for (kind, _), v in unbounded.items() if kind == WATER_MESH and v]
    assert any(len(v["indices"]) for v in made_any_water)
    assert math.isfinite(sum(float(v["area_m2"]) for v in made_any_water))


@pytest.mark.parametrize("up", [1, 2, 4, 6])
def test_stitched_borders_follow_a_coarser_neighbour_exactly(up):
    """Stitched to a neighbour ``up`` levels coarser (up to beyond log2(n): the fine tile's
    whole edge then lies inside one coarse cell), a tile's border vertices lie on the coarse
    border as drawn, linear between its nodes (height, normal, level, shore), its corners move
    in height only, and its skirt hangs ``skirt_m`` below the stitched border; the neighbour
    list leaves tiles as fine or finer alone."""
    from riverflow.scenes.meshes import coarser_neighbours, stitch_tile
    n = 4
    q = Quadtree(-3.7, 11.3, 101.9)
    level = 7
    fine = (level, 64, 37)                     # on a border of the level-1 tiles
    west = (level - up, (fine[1] - 1) >> up, fine[2] >> up)     # coarse, across the west edge
    assert (west[1], west[2]) != (fine[1] >> up, fine[2] >> up)
    same = (level, fine[1] + 1, fine[2])                          # as fine, across the east edge
    keys = np.array(sorted([fine, west, same]))
    across = coarser_neighbours(keys)
    row = {tuple(k): r for r, k in enumerate(keys.tolist())}
    assert across[row[fine]].tolist() == [-1, -1, -1, row[west]]
    assert (across[row[west]] == -1).all() and (across[row[same]] == -1).all()

    mesh, coarse = _synthetic_mesh(q, fine, n), _synthetic_mesh(q, west, n)
    out = stitch_tile(mesh.vertices, fine, mesh.skirt_m, [(3, west, coarse.vertices)])
    side = n + 1
    got = out[:side * side].reshape(side, side, 8)
    cg = coarse.vertices[:side * side].reshape(side, side, 8).astype(np.float64)
    # the coarse tile's east column, drawn linear between its nodes, at the fine west nodes
    s = 1 << up
    g = fine[2] * n + np.arange(side)                # fine node rows, as global indices
    c0 = g // s - west[2] * n
    t = (g % s) / s
    c1 = np.minimum(c0 + 1, n)
    want = cg[c0, n, 2:] * (1 - t)[:, None] + cg[c1, n, 2:] * t[:, None]
    want[:, 1:4] /= np.linalg.norm(want[:, 1:4], axis=1, keepdims=True)
    np.testing.assert_allclose(got[:, 0, 2], want[:, 0], rtol=0, atol=1e-3)
    np.testing.assert_allclose(got[1:-1, 0, 2:], want[1:-1], rtol=0, atol=1e-5)
    orig = mesh.vertices[:side * side].reshape(side, side, 8)
    np.testing.assert_array_equal(got[[0, -1], 0, 3:], orig[[0, -1], 0, 3:])   # corners
    np.testing.assert_array_equal(got[:, 1:], orig[:, 1:])                    # the rest
    if up >= 3:
        assert np.abs(got[:, 0, 2] - orig[:, 0, 2]).max() > 0.1    # it did move
    bi, bj = border_loop(n)
    np.testing.assert_allclose(out[side * side:, 2], got[bj, bi, 2] - np.float32(mesh.skirt_m),
                               rtol=0, atol=1e-4)
    np.testing.assert_array_equal(out[side * side:, 3:6], got[bj, bi, 3:6])


@pytest.mark.parametrize("up", [1, 2, 3, 5])
def test_edge_index_variants_meet_a_coarser_neighbour_exactly(up):
    """Drawn through the edge variant of its level difference (:func:`tile_index_parts`,
    the draw system's terrain seams), a tile's edge and its coarser neighbour's facing edge
    are the same line: heights linear between the same nodes, with the fine tile's vertex
    data as made. Beyond log2(n) levels (up = 5 for n = 8) the fine edge is one segment whose
    corners :func:`stitch_tile` moves onto the coarse border, as the draw system does."""
    from riverflow.scenes.meshes import (coarser_neighbours, edge_levels_up, stitch_tile,
                                         tile_index_parts)
    n = 8
    q = Quadtree(-3.7, 11.3, 101.9)
    level = 7
    fine = (level, 64, 37)
    west = (level - up, (fine[1] - 1) >> up, fine[2] >> up)
    keys = np.array(sorted([fine, west]))
    across = coarser_neighbours(keys)
    ups = edge_levels_up(keys, across)
    row = {tuple(k): r for r, k in enumerate(keys.tolist())}
    assert ups[row[fine]].tolist() == [0, 0, 0, up]
    assert ups[row[west]].tolist() == [0, 0, 0, 0]
    mesh, coarse = _synthetic_mesh(q, fine, n), _synthetic_mesh(q, west, n)
    vertices = mesh.vertices
    if up > level_count(n) - 1:
        vertices = stitch_tile(vertices, fine, mesh.skirt_m, [(3, west, coarse.vertices)])
    else:
        np.testing.assert_array_equal(vertices, mesh.vertices)   # nothing re-uploaded
    parts = tile_index_parts(n)
    side = n + 1

    def drawn_edge(v, e, k):
        """(y, z) of the edge-``e`` nodes a variant-k strip draws, along y."""
        tris = parts.edges[e][k][:len(parts.edges[e][k]) - parts.skirt_counts[e][k]]
        col = 0 if e == 3 else n
        used = np.unique(tris[tris % side == col])
        used = used[used < side * side]
        pos = v[used.astype(np.int64)]
        assert np.all(pos[:, 0] == pos[0, 0])                    # on one vertical line
        order = np.argsort(pos[:, 1])
        return pos[order, 0][0], pos[order, 1], pos[order, 2]

    x_f, y_f, z_f = drawn_edge(vertices, 3, min(up, level_count(n) - 1))
    x_c, y_c, z_c = drawn_edge(coarse.vertices, 1, 0)
    assert x_f == x_c
    assert len(y_f) == max(n >> up, 1) + 1
    along = np.linspace(y_f[0], y_f[-1], 97)
    np.testing.assert_allclose(np.interp(along, y_f, z_f), np.interp(along, y_c, z_c),
                               rtol=0, atol=2e-4)
    # without the variant the fine border bends off the coarse line (what the skirts hid)
    _, y0, z0 = drawn_edge(mesh.vertices, 3, 0)
    assert np.abs(np.interp(along, y0, z0) - np.interp(along, y_c, z_c)).max() > 10 * 2e-4
