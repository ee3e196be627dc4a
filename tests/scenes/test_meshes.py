"""Meshes of the streamed world's tiles for the draw system: terrain tiles (exact samples of
the height tile's nodes, unit central-difference normals that agree across tile borders,
skirts deep enough to hide the crack against any coarser neighbour, one index buffer that tiles
each tile exactly once) and the water surface (exactly the water polygon or a tile's piece of
it, no triangle larger than a grid cell, CCW, at the water level; the pieces of a tile's four
children cover what the tile's piece covers)."""
from __future__ import annotations

import time
from types import SimpleNamespace

import numpy as np
import pytest
import shapely

from riverflow import load_graph
from riverflow.hydro.areas import water_polygon
from riverflow.scenes.default import default_scene
from riverflow.scenes.meshes import (
    MIN_SKIRT_CELLS,
    border_loop,
    level_count,
    tile_indices,
    tile_skirt_m,
    tile_terrain_mesh,
    triangulate_water,
)
from riverflow.scenes.tile_kinds import (
    HEIGHT,
    WATER,
    WATER_MESH_CELLS,
    HeightProducer,
    LandscapeTiles,
    TerrainMeshProducer,
    WaterMeshProducer,
    WaterProducer,
)
from riverflow.tiles.quadtree import Quadtree, children, parent

WATER_CELL_M = 8.0
"""Grid cell [m] of the whole-polygon water cases (a finest default-scene tile's, too)."""


@pytest.fixture(scope="module")
def scene():
    return default_scene(seed=0)


class Made:
    """The default scene's tiles, made by its producers on first use and kept."""

    def __init__(self, scene) -> None:
        self.scene = scene
        self.tiles = LandscapeTiles(scene)
        self.quadtree: Quadtree = self.tiles.quadtree
        self.n = self.tiles.n
        self.max_level = self.tiles.max_level
        self.height_p, self.water_p = HeightProducer(self.tiles), WaterProducer(self.tiles)
        self.mesh_p, self.water_mesh_p = TerrainMeshProducer(self.tiles), WaterMeshProducer(self.tiles)
        self._got: dict = {}

    def _get(self, what, key, make):
        key = tuple(int(v) for v in key)
        if (what, key) not in self._got:
            self._got[(what, key)] = make(key)
        return self._got[(what, key)]

    def height_tile(self, key) -> dict:
        return self._get(HEIGHT, key, lambda k: self.height_p.produce(k, {}))

    def height(self, key) -> np.ndarray:
        """(n + 3, n + 3) float32 heights with the ring."""
        return self.height_tile(key)["z"]

    def water(self, key) -> dict:
        return self._get(WATER, key, lambda k: self.water_p.produce(k, {}))

    def terrain_tile(self, key):
        return self._get("terrain_mesh", key, lambda k: self.mesh_p.produce(
            k, {(HEIGHT, k): self.height_tile(k), (WATER, k): self.water(k)}))

    def water_tile(self, key):
        """(WaterMesh, ground (V,) float32)."""
        return self._get("water_mesh", key, lambda k: self.water_mesh_p.produce(k, {}))

    def grid(self, key) -> np.ndarray:
        """(n + 1, n + 1, 8) float32 grid vertices of the tile's mesh (row = y)."""
        side = self.n + 1
        return self.terrain_tile(key).vertices[:side * side].reshape(side, side, 8)

    def holes(self, key) -> int:
        piece = self.tiles.pieces.piece(key)
        return sum(len(p.interiors) for p in shapely.get_parts(piece) if p.geom_type == "Polygon")


@pytest.fixture(scope="module")
def made(scene) -> Made:
    return Made(scene)


@pytest.fixture(scope="module")
def fine(made) -> tuple[int, int, int]:
    """The finest-level tile with the most water among those holding a whole island."""
    level = made.max_level
    best, area = None, 0.0
    for tx in range(1 << level):
        for ty in range(1 << level):
            key = (level, tx, ty)
            if made.tiles.has_water(key) and made.holes(key):
                a = made.tiles.pieces.piece(key).area
                if a > area:
                    best, area = key, a
    assert best is not None, "the default scene has an island inside a finest tile"
    assert 0 < best[1] < (1 << level) - 1 and 0 < best[2] < (1 << level) - 1
    return best


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


def _drawn(coarse_border: np.ndarray, s: int) -> np.ndarray:
    """A border of n + 1 fine nodes as a neighbour drawing every s-th of them draws it:
    linear between its n / s + 1 nodes ``coarse_border``, at every fine node."""
    k = np.arange(len(coarse_border) * s - s + 1, dtype=np.float64)
    return np.interp(k, k[::s], coarse_border.astype(np.float64))


# -- terrain tiles ---------------------------------------------------------------------------


def test_level_count():
    assert level_count(64) == 7 and level_count(32) == 6 and level_count(48) == 5 and level_count(1) == 1
    with pytest.raises(ValueError):
        level_count(0)


def test_border_loop_is_ccw_and_visits_every_border_sample_once():
    n = 8
    i, j = border_loop(n)
    assert len(set(zip(i.tolist(), j.tolist()))) == 4 * n
    assert ((i == 0) | (i == n) | (j == 0) | (j == n)).all()
    assert (np.abs(np.diff(np.append(i, i[0]))) + np.abs(np.diff(np.append(j, j[0]))) == 1).all()
    assert 0.5 * np.sum(i * np.roll(j, -1) - np.roll(i, -1) * j) == n * n  # shoelace: CCW


def test_terrain_tile_vertices_are_the_height_tiles_nodes(made, fine):
    """Grid vertices: the node positions, the height tile's heights there (exactly), the water
    level seen from there and the distance to the shore (negative in the water: where the
    carved ground lies below the water level); the box holds the tile and its skirt."""
    n, side = made.n, made.n + 1
    mesh = made.terrain_tile(fine)
    assert mesh.vertices.shape == (side * side + 4 * n, 8) and mesh.vertices.dtype == np.float32
    grid = made.grid(fine)
    np.testing.assert_array_equal(grid[..., 2], made.height(fine)[1:-1, 1:-1])
    np.testing.assert_array_equal(grid[..., 6], made.water(fine)["level_seen"])
    np.testing.assert_array_equal(grid[..., 7], made.water(fine)["shore"])
    shore = grid[..., 7]
    assert (shore < 0).any() and (shore > 0).any()               # the tile holds a shore
    assert (grid[..., 2][shore < -2.0] < grid[..., 6][shore < -2.0]).all()   # bed under water
    assert (grid[..., 2][shore > 2.0] > grid[..., 6][shore > 2.0]).all()     # banks above it
    x, y = made.quadtree.node_coords(*fine, n)
    np.testing.assert_allclose(grid[..., 0], np.broadcast_to(x[None, :], (side, side)), rtol=0, atol=1e-3)
    np.testing.assert_allclose(grid[..., 1], np.broadcast_to(y[:, None], (side, side)), rtol=0, atol=1e-3)
    x0, y0, x1, y1 = made.quadtree.tile_box_m(*fine)
    np.testing.assert_allclose(mesh.bounds_m[:, :2], [[x0, y0], [x1, y1]], rtol=0, atol=1e-3)
    np.testing.assert_allclose(mesh.bounds_m[0], mesh.vertices[:, :3].min(axis=0), rtol=0, atol=1e-4)
    np.testing.assert_allclose(mesh.bounds_m[1], mesh.vertices[:, :3].max(axis=0), rtol=0, atol=1e-4)
    assert mesh.nbytes == mesh.vertices.nbytes + mesh.bounds_m.nbytes
    cell = made.quadtree.cell_m(fine[0], n)
    assert MIN_SKIRT_CELLS * cell <= mesh.skirt_m < 50.0


def test_normals_are_unit_central_differences_and_agree_across_tile_borders(made, fine):
    """Two neighbouring tiles (east, north) from HeightProducer → TerrainMeshProducer: unit
    normals, central differences of the heights (the ring's at the border), the same bits
    on both sides of a shared border."""
    n = made.n
    level, tx, ty = fine
    cell = made.quadtree.cell_m(level, n)
    grid = made.grid(fine)
    normals = made.terrain_tile(fine).vertices[:, 3:6]
    np.testing.assert_allclose(np.linalg.norm(normals, axis=-1), 1.0, atol=1e-6)
    z = made.height(fine).astype(np.float64)
    for j, i in ((5, 20), (0, 0), (n, 7), (33, n)):  # an interior node, border nodes (ring)
        want = np.array([-(z[j + 1, i + 2] - z[j + 1, i]) / (2 * cell),
                         -(z[j + 2, i + 1] - z[j, i + 1]) / (2 * cell), 1.0])
        np.testing.assert_allclose(grid[j, i, 3:6], want / np.linalg.norm(want), atol=1e-6)
    east, north = made.grid((level, tx + 1, ty)), made.grid((level, tx, ty + 1))
    np.testing.assert_array_equal(grid[:, n, 2:6], east[:, 0, 2:6])
    np.testing.assert_array_equal(grid[n, :, 2:6], north[0, :, 2:6])
    assert np.abs(grid[..., 3:5]).max() > 0.05  # not flat: the test means something


def test_skirt_hangs_below_the_border_with_its_normal(made, fine):
    n, side = made.n, made.n + 1
    mesh = made.terrain_tile(fine)
    bi, bj = border_loop(n)
    top = mesh.vertices[bj * side + bi]
    skirt = mesh.vertices[side * side:]
    np.testing.assert_array_equal(skirt[:, [0, 1, 3, 4, 5, 7]], top[:, [0, 1, 3, 4, 5, 7]])
    np.testing.assert_allclose(top[:, 2] - skirt[:, 2], mesh.skirt_m, rtol=0, atol=1e-4)
    # as high above the water as its top (shaded alike where a crack shows it)
    np.testing.assert_allclose(top[:, 6] - skirt[:, 6], mesh.skirt_m, rtol=0, atol=2e-3)
    # at least the crack any coarser neighbour leaves (:func:`tile_skirt_m`)
    assert mesh.skirt_m >= tile_skirt_m(made.height(fine)[1:-1, 1:-1], made.quadtree.cell_m(fine[0], n))


def _coarser_neighbours(level: int, tx: int, ty: int):
    """(direction, up, coarse key) for every neighbour 1 … level levels coarser across each
    side of the tile: the coarse tile that meets it there."""
    for direction, (dx, dy) in {"east": (1, 0), "west": (-1, 0), "north": (0, 1),
                                "south": (0, -1)}.items():
        for up in range(1, level + 1):
            side = 1 << (level - up)
            key = (level - up, (tx + dx) >> up, (ty + dy) >> up)
            own = (level - up, tx >> up, ty >> up)
            if key != own and 0 <= key[1] < side and 0 <= key[2] < side:
                yield direction, up, key


def _shared_border(fine_grid, coarse_grid, direction, up, along):
    """The fine tile's border towards ``direction`` (n + 1 nodes) and the coarse tile's
    nodes on it (n / 2**up + 1): ``along`` is the fine tile's index along that border."""
    n = fine_grid.shape[0] - 1
    s = 1 << up
    fine = {"east": fine_grid[:, n], "west": fine_grid[:, 0],
            "north": fine_grid[n, :], "south": fine_grid[0, :]}[direction]
    coarse = {"east": coarse_grid[:, 0], "west": coarse_grid[:, n],
              "north": coarse_grid[0, :], "south": coarse_grid[n, :]}[direction]
    off = (along % s) * n // s
    return fine, coarse[off:off + n // s + 1]


def _check_cracks(fine_mesh, fine_grid, coarse_grid, direction, up, along) -> float:
    """The coarse border's nodes are the fine one's every 2**up-th (the same heights), and
    the fine skirt reaches below both borders all along; returns the largest gap."""
    s = 1 << up
    hf, hc = _shared_border(fine_grid, coarse_grid, direction, up, along)
    np.testing.assert_array_equal(hc[:, :3], hf[::s, :3])
    zf = hf[:, 2].astype(np.float64)
    drawn = _drawn(hc[:, 2], s)
    gap = np.abs(zf - drawn).max()
    assert fine_mesh.skirt_m >= gap, (direction, up, fine_mesh.skirt_m, gap)
    assert (zf - fine_mesh.skirt_m <= np.minimum(zf, drawn)).all()
    return float(gap)


def test_skirt_covers_the_crack_to_coarser_neighbours_in_the_default_scene(made, fine):
    level, tx, ty = fine
    seen = set()
    for direction, up, key in _coarser_neighbours(*fine):
        along = ty if direction in ("east", "west") else tx
        _check_cracks(made.terrain_tile(fine), made.grid(fine), made.grid(key), direction, up, along)
        seen.add(up)
    assert len(seen) >= 3


def test_skirt_covers_the_crack_to_coarser_neighbours_on_bumpy_ground(rng):
    """A rough synthetic height array (tens of metres across a tile): the fine tile (15, 15)
    of 16-cell tiles meets, across its east and north sides, a neighbour 1, 2, 3 and 4
    (= log2 16) levels coarser; both are cut from the same array (coarse nodes every 2**up-th
    fine node)."""
    n, cell, o = 16, 2.0, 16  # o: array index of fine node 0 (rings of coarse tiles below 0)
    size = 33 * n + 2 * o + 1  # fine nodes -o … 33n + o
    y, x = (np.mgrid[0:size, 0:size] - o) * cell
    heights = (20 * np.sin(x / 23.0) * np.cos(y / 17.0) + 3 * rng.standard_normal(x.shape)).astype(np.float32)
    level_seen = np.zeros((n + 1, n + 1), np.float32)

    def tile(up: int, cx: int, cy: int):
        s = 1 << up
        k = np.arange(-1, n + 2) * s
        z = heights[np.ix_(cy * n * s + k + o, cx * n * s + k + o)]
        mesh = tile_terrain_mesh(z, cx * n * s * cell, cy * n * s * cell, s * cell, level_seen)
        return mesh, mesh.vertices[:(n + 1) ** 2].reshape(n + 1, n + 1, 8)

    fine_mesh, fine_grid = tile(0, 15, 15)
    largest, seen = 0.0, []
    for up in range(1, level_count(n)):
        for direction, (cx, cy) in (("east", (16 >> up, 15 >> up)), ("north", (15 >> up, 16 >> up))):
            _, coarse_grid = tile(up, cx, cy)
            largest = max(largest, _check_cracks(fine_mesh, fine_grid, coarse_grid, direction, up, 15))
            seen.append(up)
    assert sorted(set(seen)) == [1, 2, 3, 4]
    # rough enough that the gaps, not the minimum depth, set the skirt
    assert largest > MIN_SKIRT_CELLS * cell and fine_mesh.skirt_m > MIN_SKIRT_CELLS * cell


def test_flat_terrain_gets_the_minimum_skirt():
    n, cell = 16, 4.0
    mesh = tile_terrain_mesh(np.full((n + 3, n + 3), 3.0, np.float32), 100.0, -50.0, cell,
                             np.zeros((n + 1, n + 1), np.float32))
    assert mesh.skirt_m == MIN_SKIRT_CELLS * cell == 8.0
    np.testing.assert_array_equal(mesh.vertices[:, 3:6], np.tile([0.0, 0.0, 1.0], (len(mesh.vertices), 1)))
    np.testing.assert_array_equal(mesh.bounds_m, [[100.0, -50.0, -5.0], [164.0, 14.0, 3.0]])


@pytest.mark.parametrize("n, stride", [(8, 1), (12, 1), (64, 1), (8, 2), (64, 2), (64, 4)])
def test_tile_indices_tile_the_tile_exactly_once_with_outward_skirts(n, stride, rng):
    """Also through every stride-th node only (the reflection's coarser mesh of the same
    vertices): the same ground, the same skirt, stride² fewer triangles."""
    side = n + 1
    idx = tile_indices(n, stride)
    m = n // stride
    assert idx.dtype == np.uint32 and idx.shape == (2 * m * m + 8 * m, 3)
    assert idx.max() == side * side + 4 * n - stride
    used = np.unique(idx)
    grid_used = used[used < side * side]
    assert (grid_used // side % stride == 0).all() and (grid_used % side % stride == 0).all()
    xy = np.stack(np.meshgrid(np.arange(side), np.arange(side)), -1).reshape(-1, 2).astype(np.float64)
    bi, bj = border_loop(n)
    xy = np.vstack([xy, np.stack([bi, bj], 1)])
    grid, skirt = idx[:2 * m * m], idx[2 * m * m:]
    assert (grid < side * side).all()
    t = xy[grid]
    area = _cross(t[:, 0], t[:, 1], t[:, 2])
    assert (area > 0).all() and 0.5 * area.sum() == pytest.approx(n * n)
    pts = rng.uniform(0, n, size=(2000, 2))
    assert (_cover_counts(pts, t, np.zeros(2), float(stride)) == 1).all()
    # skirts: each quad joins two neighbouring border samples to their copies, facing outward
    assert ((skirt >= side * side).sum(axis=1) >= 1).all()
    assert all(len(row[row < side * side]) in (1, 2) for row in skirt)
    p3 = np.concatenate([xy, np.zeros((len(xy), 1))], axis=1)
    p3[side * side:, 2] = -1.0
    tri = p3[skirt]
    normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    outward = tri.mean(axis=1)[:, :2] - n / 2
    assert (np.einsum("ij,ij->i", normal[:, :2], outward) > 0).all()
    assert np.abs(normal[:, 2]).max() == 0
    assert 0.5 * np.linalg.norm(normal, axis=1).sum() == pytest.approx(4 * n)  # 1 deep, 4n round


def test_tile_indices_refuse_a_stride_that_does_not_divide_the_tile():
    with pytest.raises(ValueError, match="stride"):
        tile_indices(12, 5)


# -- water ---------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def default_water(scene):
    """The default scene's whole water polygon, triangulated on 8 m cells."""
    origin = scene.terrain.origin_m
    t = time.perf_counter()
    mesh = triangulate_water(scene.water.polygon, origin, WATER_CELL_M, scene.water.level)
    print(f"\ntriangulate_water(default scene) in {time.perf_counter() - t:.2f} s")
    return SimpleNamespace(polygon=scene.water.polygon, origin=origin, level=scene.water.level,
                           mesh=mesh)


def _tile_case(made, key) -> SimpleNamespace:
    """A tile's piece of the water as WaterMeshProducer triangulates it."""
    q = made.quadtree
    mesh, ground = made.water_tile(key)
    assert mesh.cell_m == q.tile_size_m(key[0]) / WATER_MESH_CELLS
    return SimpleNamespace(polygon=made.tiles.pieces.piece(key), origin=np.array(q.tile_origin_m(*key)),
                           level=made.scene.water.level, mesh=mesh, ground=ground, key=key)


@pytest.fixture(scope="module")
def tile_water(made, fine):
    return _tile_case(made, fine)


@pytest.fixture(params=["default", "tile", "proland"])
def water_case(request, default_water, tile_water):
    """(polygon, origin, level, its triangulation) of the default scene's water, of a finest
    tile's piece of it (with an island) and of the Proland graph's water at one level."""
    if request.param == "default":
        return default_water
    if request.param == "tile":
        return tile_water
    polygon = water_polygon(load_graph(request.getfixturevalue("proland_graph_path")))
    origin = np.array([-3.0, 5.0])

    def level(xy):
        return np.full(len(xy), 0.5)
    return SimpleNamespace(polygon=polygon, origin=origin, level=level,
                           mesh=triangulate_water(polygon, origin, WATER_CELL_M, level))


def test_water_mesh_covers_exactly_the_polygon_area(water_case):
    mesh = water_case.mesh
    p = mesh.positions[:, :2].astype(np.float64)[mesh.indices]
    area = 0.5 * _cross(p[:, 0], p[:, 1], p[:, 2]).sum()
    assert area == pytest.approx(water_case.polygon.area, rel=1e-6)
    assert mesh.area_m2 == pytest.approx(area, rel=1e-9)


def test_water_triangles_are_ccw_nondegenerate_and_inside_one_cell(water_case):
    mesh = water_case.mesh
    assert mesh.positions.dtype == np.float32 and mesh.indices.dtype == np.uint32
    assert mesh.indices.ndim == 2 and mesh.indices.shape[1] == 3 and len(mesh.indices) > 100
    assert mesh.indices.max() < len(mesh.positions)
    p = mesh.positions[:, :2].astype(np.float64)[mesh.indices]
    assert (_cross(p[:, 0], p[:, 1], p[:, 2]) > 0).all()
    edges = np.linalg.norm(p - np.roll(p, 1, axis=1), axis=-1)
    assert edges.max() <= mesh.cell_m * np.sqrt(2) + 1e-3
    origin = water_case.origin
    lo = origin + np.floor((p.mean(axis=1) - origin) / mesh.cell_m) * mesh.cell_m
    assert (p >= lo[:, None] - 1e-3).all() and (p <= lo[:, None] + mesh.cell_m + 1e-3).all()


def test_water_vertices_are_shared_and_edges_meet_without_t_junctions(water_case):
    """Interior edges are used once each way; the edges used once trace the polygon's
    boundary (same total length), so neighbouring cells share their vertices."""
    mesh = water_case.mesh
    assert len(np.unique(mesh.positions[:, :2], axis=0)) == len(mesh.positions)
    e = np.stack([mesh.indices, np.roll(mesh.indices, -1, axis=1)], axis=-1).reshape(-1, 2).astype(np.int64)
    key = e[:, 0] * len(mesh.positions) + e[:, 1]
    assert len(np.unique(key)) == len(key)  # no directed edge twice: no overlap, same winding
    reverse = np.isin(e[:, 1] * len(mesh.positions) + e[:, 0], key)
    outer = mesh.positions[e[~reverse]][..., :2].astype(np.float64)
    length = np.linalg.norm(outer[:, 1] - outer[:, 0], axis=1).sum()
    assert length == pytest.approx(water_case.polygon.length, rel=1e-5)


def test_water_vertices_take_the_water_level(water_case):
    mesh = water_case.mesh
    want = water_case.level(mesh.positions[:, :2].astype(np.float64))
    np.testing.assert_allclose(mesh.positions[:, 2], want, rtol=0, atol=1e-4)


def test_points_in_water_are_covered_once_and_land_and_islands_never(water_case, rng):
    poly, mesh = water_case.polygon, water_case.mesh
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
    counts = _cover_counts(pts, tris, water_case.origin, mesh.cell_m)
    assert wet.sum() > 50 and (~wet).sum() > 50
    assert (counts[wet] == 1).all()
    assert (counts[~wet] == 0).all()
    for hole in holes:
        on_island = shapely.contains_xy(hole, pts[:, 0], pts[:, 1])
        assert on_island.sum() > 10 and (counts[on_island] == 0).all()


def test_the_tile_case_has_an_island_and_its_ground(made, tile_water, scene):
    """The tile's piece keeps a whole island (so the island test bites), and the producer
    gives the terrain height under every water vertex."""
    assert sum(len(g.interiors) for g in shapely.get_parts(tile_water.polygon)) >= 1
    xy = tile_water.mesh.positions[:, :2].astype(np.float64)
    assert tile_water.ground.shape == (len(xy),) and tile_water.ground.dtype == np.float32
    np.testing.assert_array_equal(tile_water.ground, scene.terrain.height(xy).astype(np.float32))
    x0, y0, x1, y1 = made.quadtree.tile_box_m(*tile_water.key)
    assert (xy >= (x0 - 1e-3, y0 - 1e-3)).all() and (xy <= (x1 + 1e-3, y1 + 1e-3)).all()


def test_childrens_water_covers_what_the_parents_covers(made, fine, rng):
    """The water meshes of a tile's four children together cover the parent's piece of the
    water: the same area, every wet point of the parent once, each child within its box."""
    up = parent(fine)
    whole = _tile_case(made, up)
    kids = [_tile_case(made, k) for k in children(up)]
    assert sum(len(k.mesh.indices) > 0 for k in kids) >= 2
    area = sum(k.mesh.area_m2 for k in kids)
    assert area == pytest.approx(whole.mesh.area_m2, rel=1e-6)
    assert area == pytest.approx(whole.polygon.area, rel=1e-6)
    tris = []
    for k in kids:
        x0, y0, x1, y1 = made.quadtree.tile_box_m(*k.key)
        p = k.mesh.positions[:, :2].astype(np.float64)
        assert (p >= (x0 - 1e-3, y0 - 1e-3)).all() and (p <= (x1 + 1e-3, y1 + 1e-3)).all()
        tris.append(p[k.mesh.indices])
    tris = np.concatenate(tris)
    cell = kids[0].mesh.cell_m
    assert cell == 0.5 * whole.mesh.cell_m
    x0, y0, x1, y1 = made.quadtree.tile_box_m(*up)
    pts = rng.uniform((x0, y0), (x1, y1), size=(40_000, 2))
    pts = pts[shapely.distance(whole.polygon.boundary, shapely.points(pts)) > 1e-3]
    wet = shapely.contains_xy(whole.polygon, pts[:, 0], pts[:, 1])
    counts = _cover_counts(pts, tris, whole.origin, cell)  # the children's grids are one grid
    assert wet.sum() > 1000
    assert (counts[wet] == 1).all() and (counts[~wet] == 0).all()


def test_water_at_other_cell_sizes_keeps_the_area(tile_water, proland_graph_path):
    polygon = water_polygon(load_graph(proland_graph_path))
    for poly, origin in ((tile_water.polygon, tile_water.origin), (polygon, np.zeros(2))):
        for cell in (3.0, 16.0):
            mesh = triangulate_water(poly, origin, cell, lambda xy: np.zeros(len(xy)))
            assert mesh.cell_m == cell
            assert mesh.area_m2 == pytest.approx(poly.area, rel=1e-6)
            p = mesh.positions[:, :2].astype(np.float64)[mesh.indices]
            assert np.linalg.norm(p - np.roll(p, 1, axis=1), axis=-1).max() <= cell * np.sqrt(2) + 1e-3


def test_no_water_gives_an_empty_mesh():
    mesh = triangulate_water(shapely.Polygon(), (0.0, 0.0), 8.0, lambda xy: np.zeros(len(xy)))
    assert mesh.positions.shape == (0, 3) and mesh.indices.shape == (0, 3)
    assert mesh.area_m2 == 0.0 and mesh.cell_m == 8.0


def test_default_water_mesh_is_compact(default_water):
    """Fewer vertices than triangles (shared), and not too many triangles."""
    mesh = default_water.mesh
    assert len(mesh.positions) < len(mesh.indices)
    assert 5_000 < len(mesh.indices) < 200_000


def _covers(points, xy, tris):
    """How many triangles (vertex rows ``tris`` (K, 3) into ``xy``) hold each point."""
    t = xy[tris]                                                   # (K, 3, 2)
    p = points[:, None, :]
    inside = np.ones((len(points), len(t)), bool)
    for a, b in ((0, 1), (1, 2), (2, 0)):
        inside &= _cross(t[None, :, a], t[None, :, b], p) >= -1e-12
    return inside.sum(axis=1)


@pytest.mark.parametrize("n, stride", [(8, 1), (16, 1), (8, 2), (16, 4)])
def test_tile_index_parts_tile_the_tile_once_at_every_level_difference(n, stride, rng):
    """Core and edge strips, for any level difference per edge (beyond log2(n / stride) too,
    clamped): counter-clockwise, covering the tile exactly once; toward a neighbour k levels
    coarser the strip touches only every (stride·2^k)-th border node (the ones the neighbour
    has) and its skirt hangs from those, outward; at k = 0 the same triangles as
    :func:`tile_indices` but in two corner cells."""
    from riverflow.scenes.meshes import tile_index_parts
    side = n + 1
    skirts = stride == 1
    parts = tile_index_parts(n, stride, skirts=skirts)
    levels = len(parts.edges[0])
    assert levels == level_count(n // stride)
    gj, gi = np.divmod(np.arange(side * side), side)
    bi, bj = border_loop(n)
    xy = np.vstack([np.stack([gi, gj], 1), np.stack([bi, bj], 1)]).astype(np.float64)
    pts = rng.uniform(0, n, size=(600, 2))
    for combo in [(0, 0, 0, 0), (1, 0, 2, 0), (levels - 1,) * 4,
                  *(tuple(rng.integers(0, levels, 4)) for _ in range(3))]:
        strips = [parts.edges[e][k][:len(parts.edges[e][k]) - parts.skirt_counts[e][k]]
                  for e, k in enumerate(combo)]
        tris = np.concatenate([parts.core, *strips]).astype(np.int64)
        assert (tris < side * side).all()
        assert (_cross(*(xy[tris[:, c]] for c in range(3))) > 0).all()
        assert (_covers(pts, xy, tris) == 1).all(), combo
        for e, (k, strip) in enumerate(zip(combo, strips)):
            step = min(stride << k, n)
            on_edge = np.unique(strip[np.isin(strip, _edge_vertices(n, e))])
            along = (gi if e in (0, 2) else gj)[on_edge]
            assert (along % step == 0).all() and len(on_edge) == n // step + 1
            if skirts:
                skirt = parts.edges[e][k][len(strip):]
                assert len(skirt) == 2 * (n // step)
                tops = skirt[skirt < side * side]
                assert set(tops.tolist()) == set(on_edge.tolist())
                p3 = np.concatenate([xy, np.zeros((len(xy), 1))], axis=1)
                p3[side * side:, 2] = -1.0
                tri = p3[skirt.astype(np.int64)]
                normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
                assert (np.einsum("ij,ij->i", normal[:, :2], tri.mean(axis=1)[:, :2] - n / 2)
                        > 0).all()
    zero = np.concatenate([parts.core, *(parts.edges[e][0] for e in range(4))])
    def as_set(t):
        return {tuple(np.roll(r, -int(np.argmin(r)))) for r in np.asarray(t).tolist()}
    differ = as_set(zero) ^ as_set(tile_indices(n, stride, skirts=skirts))
    assert len(differ) == 8                       # two cells, two triangles each, both ways


def _edge_vertices(n: int, e: int) -> np.ndarray:
    """Grid vertex numbers of edge ``e`` of an n-cell tile (EDGE_OFFSETS order)."""
    side, k = n + 1, np.arange(n + 1)
    return [k, k * side + n, n * side + k, k * side][e]


def test_tile_index_parts_refuse_a_stride_that_leaves_no_core():
    from riverflow.scenes.meshes import tile_index_parts
    with pytest.raises(ValueError, match="stride"):
        tile_index_parts(12, 5)
    with pytest.raises(ValueError, match="stride"):
        tile_index_parts(8, 8)
