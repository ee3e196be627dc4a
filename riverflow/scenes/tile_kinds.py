"""The tile kinds of a landscape: producers for the tile framework (SPEC §8).

Every kind samples the landscape's pointwise functions (:mod:`riverflow.scenes.landscape`) on
the nodes of its tile (:meth:`Quadtree.node_coords`: shared nodes are bitwise the same points,
so neighbours and parents agree there), so a tile depends only on its key:

==============  =========================================================  ====================
kind            content                                                    made from
==============  =========================================================  ====================
height          carved terrain heights, (n+3)² nodes (a ring for normals)   the source + rivers
water           water level at wet nodes (NaN dry), the level seen from     the river network
                every node and its signed distance to the shore
raycast         ground, water and their max-mip pyramid: what particle     height, water
                rays, altitudes and the NEAR rule read
hints           per (h+1)² nodes, deep water near them (x, y, level)       the river network
terrain_mesh    vertices (position, normal, water level, shore distance),   height, water
                skirt, bounds
water_mesh      the water polygon's piece in the tile, triangulated        the river network
==============  =========================================================  ====================

n = 64 cells per terrain tile; the finest level has the landscape's ``cell_m`` between nodes.
"""
from __future__ import annotations

import math
import threading
from collections import OrderedDict
from collections.abc import Mapping

import numpy as np
import shapely

from riverflow.kernels.raycast import fill_height_pyramid, pyramid_size
from riverflow.scenes.landscape import Landscape
from riverflow.scenes.meshes import (TerrainTileMesh, WaterMesh, river_scale, tile_terrain_mesh,
                                     triangulate_water)
from riverflow.tiles.cache import FieldSpec
from riverflow.tiles.coverage import coverage_table
from riverflow.tiles.quadtree import Quadtree, TileKey
from riverflow.tiles.scheduler import Producer
from riverflow.tiles.table import tile_code

HEIGHT = "height"
WATER = "water"
RAYCAST = "raycast"
HINTS = "hints"
TERRAIN_MESH = "terrain_mesh"
WATER_MESH = "water_mesh"
TERRAIN_KINDS = (HEIGHT, WATER, RAYCAST, HINTS, TERRAIN_MESH, WATER_MESH)
"""Every terrain kind, dependencies first (the order the view asks for them)."""

HINT_CELLS = 8
"""Hint nodes per tile side − 1 (32 m apart on 256 m tiles)."""
DRY_LEVEL_M = -1.0e4
"""The level 'seen' from land farther than LEVEL_REACH_M from any shore (never shown)."""
LEVEL_REACH_M = 200.0
WET_REACH_CELLS = math.sqrt(2.0)
"""Nodes this close to the water [cells] get a water level: every cell the water touches then
has four wet corners, and rays put the shoreline where the water plane meets the terrain,
not on the cell grid."""
DEEP_M = 4.0
"""Water hints point this far inside the water from its edge (where the river is wide enough
to keep any)."""
SHORE_KEEP = 256
"""Tiles whose nodes' shore distances :meth:`LandscapeTiles.shore` keeps for their second
producer (36 KB each at 64 cells: 9 MB at most; a view's terrain kinds are made kind by kind,
~300 tiles of each at 1080p)."""
WATER_MESH_CELLS = 32
"""Grid cells per tile side of the water mesh (8 m on the finest 256 m tiles)."""


class LandscapeTiles:
    """What every terrain producer of one landscape shares: the quadtree, the tile size, the
    tiles the water comes near, and the water polygon cut per tile."""

    def __init__(self, scene: Landscape, n: int | None = None) -> None:
        self.scene = scene
        self.quadtree: Quadtree = scene.quadtree
        self.n = int(n or scene.terrain.tile_cells)
        self.max_level = scene.terrain.max_level
        water = scene.water
        boundary = shapely.get_coordinates(shapely.get_rings(shapely.get_parts(water.polygon)),
                                           return_index=True)
        xy, ring = boundary
        same = ring[1:] == ring[:-1]
        segs = np.concatenate([xy[:-1][same], xy[1:][same]], axis=1)
        reach = WET_REACH_CELLS * self.quadtree.cell_m(self.max_level, self.n) + 1.0
        centre = np.concatenate([water.samples_m[:-1], water.samples_m[1:]], axis=1)
        centre = centre[water.branch[:-1] == water.branch[1:]]
        radius = np.concatenate([np.full(len(segs), reach),
                                 0.5 * water.widths_m[:-1][water.branch[:-1] == water.branch[1:]]
                                 + reach])
        self.water_cover = coverage_table(self.quadtree, np.concatenate([segs, centre]), radius,
                                          self.max_level)
        self.pieces = PolygonPieces(water.polygon, self.quadtree)
        self._shores: OrderedDict[TileKey, np.ndarray] = OrderedDict()
        self._shore_lock = threading.Lock()

    def shore(self, key: TileKey) -> TileShore:
        """The tile's nodes with their one-node ring ((n + 3)², 2) [m], their distance to the
        shore [m] (inf beyond the carving's reach or LEVEL_REACH_M, the larger), whether they
        are in the water, and the centre line's level and width where asked
        (:meth:`TileShore.centre`), made once for the height and water producers of a tile
        (one KD-tree query, not two: the water tile's nodes are the inner ones): kept from the
        first producer's call to the second's (at most SHORE_KEEP tiles', oldest out first)."""
        with self._shore_lock:
            got = self._shores.pop(key, None)     # each producer asks once: handed on
        if got is None:
            p = self.nodes(key, self.n, ring=1)
            reach = max(self.scene.terrain.carving.reach_m, LEVEL_REACH_M)
            water = self.scene.water
            shore = water.distance_to_shore(p, upper_bound_m=reach)
            shore.flags.writeable = False
            got = TileShore(p, shore, water.contains(p, shore), water)
            with self._shore_lock:
                self._shores[key] = got
                while len(self._shores) > SHORE_KEEP:
                    self._shores.popitem(last=False)
        return got

    def has_water(self, key: TileKey) -> bool:
        """False when no water comes within reach of the tile."""
        return tile_code(*key) in self.water_cover

    def nodes(self, key: TileKey, n: int, ring: int = 0) -> np.ndarray:
        """(m², 2) float64 [m] node positions of the tile, m = n + 1 + 2·ring, x fastest."""
        x, y = self.quadtree.node_coords(*key, n, ring)
        gx, gy = np.meshgrid(x, y)
        return np.stack([gx.ravel(), gy.ravel()], axis=1)


class TileShore:
    """What a tile's height and water producers both read at its nodes with their ring
    (:meth:`LandscapeTiles.shore`): ``nodes`` ((n + 3)², 2) [m], ``shore`` their distance to
    the shore [m] (inf beyond reach), ``inside`` (bool: in the water) and, made for the nodes
    either producer asks for and kept for the other, the centre line's level and width
    (:meth:`~riverflow.scenes.water.WaterSurface.nearest`, a function of the point alone)."""

    def __init__(self, nodes: np.ndarray, shore: np.ndarray, inside: np.ndarray,
                 water) -> None:
        self.nodes, self.shore, self.inside, self._water = nodes, shore, inside, water
        self._level = np.full(len(nodes), np.nan)
        self._width = np.full(len(nodes), np.nan)
        self._known = np.zeros(len(nodes), bool)
        self._lock = threading.Lock()

    def centre(self, idx: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The nearest centre line's level and width [m] at the nodes ``idx`` (K,), those not
        asked for before made now."""
        idx = np.asarray(idx, np.intp)
        with self._lock:
            missing = idx[~self._known[idx]]
            if len(missing):
                _, self._level[missing], self._width[missing] = \
                    self._water.nearest(self.nodes[missing])
                self._known[missing] = True
            return self._level[idx], self._width[idx]


class PolygonPieces:
    """The water polygon cut to tiles, each piece cut from its parent's (cached, least
    recently used pieces dropped): a tile costs the size of its neighbourhood's water, not of
    the whole network's."""

    def __init__(self, polygon, quadtree: Quadtree, keep: int = 256) -> None:
        self.polygon = polygon
        self.quadtree = quadtree
        self.keep = keep
        self._pieces: OrderedDict[TileKey, object] = OrderedDict()
        self._lock = threading.Lock()

    def piece(self, key: TileKey):
        """The water in tile ``key`` (a shapely geometry, maybe empty)."""
        with self._lock:
            return self._piece(key)

    def _piece(self, key: TileKey):
        got = self._pieces.get(key)
        if got is not None:
            self._pieces.move_to_end(key)
            return got
        level, tx, ty = key
        parent = self.polygon if level == 0 else self._piece((level - 1, tx >> 1, ty >> 1))
        box = shapely.box(*self.quadtree.tile_box_m(level, tx, ty))
        piece = parent if parent.is_empty else shapely.intersection(parent, box)
        self._pieces[key] = piece
        while len(self._pieces) > self.keep:
            self._pieces.popitem(last=False)
        return piece


class TerrainProducer(Producer):
    """Base of the landscape's producers."""

    def __init__(self, tiles: LandscapeTiles) -> None:
        self.tiles = tiles
        self.scene = tiles.scene
        self.max_level = tiles.max_level


class HeightProducer(TerrainProducer):
    """Carved terrain heights at the tile's nodes and a one-node ring (float32). A finer
    neighbour's border may dip below this tile's between its nodes (a gully crossing the
    border): the draw stitches that neighbour's border onto this one's
    (:func:`riverflow.scenes.meshes.stitch_tile`), so no crack opens there and no skirt need
    reach down to it."""

    kind = HEIGHT

    def __init__(self, tiles: LandscapeTiles) -> None:
        super().__init__(tiles)
        n = tiles.n
        self.fields = {"z": FieldSpec((n + 3, n + 3), np.float32, np.nan)}

    def produce(self, key: TileKey, deps: Mapping) -> dict:
        n = self.tiles.n
        got = self.tiles.shore(key)
        terrain = self.scene.terrain
        kept = terrain.source_tiles if n == terrain.tile_cells else None
        z = terrain.height(got.nodes, got.shore, got.inside, got.centre,
                           None if kept is None else kept.heights(key, got.nodes))
        return {"z": z.reshape(n + 3, n + 3).astype(np.float32)}


class WaterProducer(TerrainProducer):
    """``level``: the water level at wet nodes (within WET_REACH_CELLS of the water), NaN on
    dry ones; ``level_seen``: the level of the nearest river from every node within
    LEVEL_REACH_M of a shore (DRY_LEVEL_M beyond), ``shore``: the node's distance to the
    nearest shore [m], negative in the water, LEVEL_REACH_M beyond it, and ``scale``: the
    size of that river (:func:`~riverflow.scenes.meshes.river_scale` of its width; 1 beyond
    reach): what the terrain is shaded by (wet and dry sand, the bed)."""

    kind = WATER

    def __init__(self, tiles: LandscapeTiles) -> None:
        super().__init__(tiles)
        n = tiles.n
        self.fields = {"level": FieldSpec((n + 1, n + 1), np.float32, np.nan),
                       "level_seen": FieldSpec((n + 1, n + 1), np.float32, DRY_LEVEL_M),
                       "shore": FieldSpec((n + 1, n + 1), np.float32, LEVEL_REACH_M),
                       "scale": FieldSpec((n + 1, n + 1), np.float32, 1.0)}

    def produce(self, key: TileKey, deps: Mapping) -> dict:
        n = self.tiles.n
        got = self.tiles.shore(key)        # the inner nodes are the tile's
        index = np.arange((n + 3) ** 2).reshape(n + 3, n + 3)[1:-1, 1:-1].reshape(-1)
        shore = got.shore[index]
        shore = np.where(shore < LEVEL_REACH_M, shore, np.inf)
        level = np.full(len(index), np.nan, np.float32)
        seen = np.full(len(index), DRY_LEVEL_M, np.float32)
        signed = np.full(len(index), LEVEL_REACH_M, np.float32)
        scale = np.ones(len(index), np.float32)
        near = np.flatnonzero(np.isfinite(shore))
        if len(near):
            value, width = got.centre(index[near])
            seen[near] = value
            scale[near] = river_scale(width)
            reach = WET_REACH_CELLS * self.tiles.quadtree.cell_m(key[0], n)
            inside = got.inside[index[near]]
            wet = (shore[near] < reach) | inside
            level[near[wet]] = value[wet]
            signed[near] = np.where(inside, -shore[near], shore[near])
        side = (n + 1, n + 1)
        return {"level": level.reshape(side), "level_seen": seen.reshape(side),
                "shore": signed.reshape(side), "scale": scale.reshape(side)}


class RaycastProducer(TerrainProducer):
    """The particles' view of a tile: ground and water at its nodes and their max-mip
    pyramid (:func:`riverflow.kernels.raycast.fill_height_pyramid`)."""

    kind = RAYCAST

    def __init__(self, tiles: LandscapeTiles) -> None:
        super().__init__(tiles)
        n = tiles.n
        self.fields = {"ground": FieldSpec((n + 1, n + 1), np.float32, np.nan),
                       "water": FieldSpec((n + 1, n + 1), np.float32, np.nan),
                       "pyramid": FieldSpec((int(pyramid_size(n + 1, n + 1)), 2), np.float32,
                                            np.nan)}

    def dependencies(self, key: TileKey):
        return [(HEIGHT, key), (WATER, key)]

    def produce(self, key: TileKey, deps: Mapping) -> dict:
        # copies, never views of the dependencies (a pool's slot, which the cache gives to
        # another tile once it evicts this one: the memo's ray-cast tile then read another
        # tile's water, particles metres off the surface in the next world of the level)
        ground = np.array(deps[(HEIGHT, key)]["z"][1:-1, 1:-1], np.float32, order="C")
        water = np.array(deps[(WATER, key)]["level"], np.float32, order="C")
        pyramid = np.empty(self.fields["pyramid"].shape, np.float32)
        fill_height_pyramid(ground, water, pyramid)
        return {"ground": ground, "water": water, "pyramid": pyramid}


class HintsProducer(TerrainProducer):
    """Water hints: at (h+1)² nodes of the tile, deep water near them — the node itself when
    it lies DEEP_M inside the water, else the point DEEP_M inside the bank on the way from
    the nearest centre-line point towards the node (x, y, level [m]; x = +inf: none)."""

    kind = HINTS

    def __init__(self, tiles: LandscapeTiles) -> None:
        super().__init__(tiles)
        self.fields = {"hints": FieldSpec((HINT_CELLS + 1, HINT_CELLS + 1, 3), np.float32,
                                          np.inf)}

    def produce(self, key: TileKey, deps: Mapping) -> dict:
        water = self.scene.water
        p = self.tiles.nodes(key, HINT_CELLS)
        centre, width = water.nearest_sample(p)
        away = p - centre
        length = np.hypot(*away.T)
        reach = np.clip(0.5 * width - DEEP_M, 0.0, None)
        step = np.where(length > 1e-9, np.minimum(length, reach) / np.maximum(length, 1e-9), 0.0)
        hint = centre + away * step[:, None]
        # (a distance counts in the water only, which is nearer than water.contains looks)
        shore = water.distance_to_shore(p, upper_bound_m=max(water.contains_reach_m, DEEP_M))
        deep = water.contains(p, shore) & (shore >= DEEP_M)
        hint[deep] = p[deep]
        ok = water.contains(hint)
        hint[~ok] = centre[~ok]
        ok |= water.contains(hint)
        out = np.full((len(p), 3), np.inf, np.float32)
        out[ok, :2] = hint[ok]
        out[ok, 2] = water.level(hint[ok]) if ok.any() else 0.0
        return {"hints": out.reshape(HINT_CELLS + 1, HINT_CELLS + 1, 3)}


class TerrainMeshProducer(TerrainProducer):
    """The terrain tile's mesh (:func:`riverflow.scenes.meshes.tile_terrain_mesh`); the draw
    system uploads it and releases the GPU buffers when the tile leaves the cache."""

    kind = TERRAIN_MESH

    def dependencies(self, key: TileKey):
        return [(HEIGHT, key), (WATER, key)]

    def produce(self, key: TileKey, deps: Mapping) -> TerrainTileMesh:
        q = self.tiles.quadtree
        x0, y0 = q.tile_origin_m(*key)
        height = deps[(HEIGHT, key)]
        water = deps[(WATER, key)]
        return tile_terrain_mesh(height["z"], x0, y0, q.cell_m(key[0], self.tiles.n),
                                 water["level_seen"], shore_m=water["shore"], scale=water["scale"])

    def nbytes(self, data: TerrainTileMesh) -> int:
        return data.nbytes


class WaterMeshProducer(TerrainProducer):
    """The water in the tile, triangulated on a grid of WATER_MESH_CELLS cells per side
    (:func:`riverflow.scenes.meshes.triangulate_water`), with the terrain height under each
    vertex (for the water's depth): ``(mesh, ground (V,) float32)``."""

    kind = WATER_MESH

    def is_empty(self, key: TileKey) -> bool:
        return not self.tiles.has_water(key)

    def empty_mask(self, codes: np.ndarray) -> np.ndarray:
        return self.tiles.water_cover.find_many(codes) < 0

    def produce(self, key: TileKey, deps: Mapping) -> tuple[WaterMesh, np.ndarray]:
        q = self.tiles.quadtree
        piece = self.tiles.pieces.piece(key)
        cell = q.tile_size_m(key[0]) / WATER_MESH_CELLS
        if piece.is_empty or piece.area <= 0.0:
            mesh = WaterMesh(np.zeros((0, 3), np.float32), np.zeros((0, 3), np.uint32), 0.0, cell)
            return mesh, np.zeros(0, np.float32)
        mesh = triangulate_water(piece, q.tile_origin_m(*key), cell, self.scene.water.level)
        ground = self.scene.terrain.height(mesh.positions[:, :2].astype(np.float64))
        return mesh, ground.astype(np.float32)

    def nbytes(self, data) -> int:
        mesh, ground = data
        return int(mesh.positions.nbytes + mesh.indices.nbytes + ground.nbytes)


def keep_sources(scene: Landscape, codes: np.ndarray, between=None) -> int:
    """Make and keep the source's heights at the nodes of the height tiles ``codes``
    (:class:`~riverflow.scenes.landscape.SourceTiles`) that are not kept yet: a live edit does
    before it forks the tile process for its new tiles, so the next edits of a drag find them
    there (a tile process's own are lost with it). ``between``: called before each tile made
    (an edit's thread waits for the frame in progress to end). Returns how many were made."""
    from riverflow.tiles.table import code_key

    terrain = scene.terrain
    kept = terrain.source_tiles
    n = terrain.tile_cells
    made = 0
    for code in np.asarray(codes, np.int64).tolist():
        key = code_key(code)
        if key in kept:
            continue
        if between is not None:
            between()
        x, y = scene.quadtree.node_coords(*key, n, 1)
        gx, gy = np.meshgrid(x, y)
        kept.heights(key, np.stack([gx.ravel(), gy.ravel()], axis=1))
        made += 1
    return made


def ground_and_level(cache, quadtree: Quadtree, n: int, max_level: int, xy: np.ndarray
                     ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The terrain height and the level seen from it [m] at points xy (N, 2) [m] as the
    terrain is drawn: bilinear between the nodes of the finest resident height and water
    tiles (n cells) of ``cache`` over each point (their ``z`` and ``level_seen``; a stale
    tile standing in after an edit counts; DRY_LEVEL_M far from the water). Returns
    (ground (N,), level (N,), the indices of the points no resident pair covers: NaN and
    DRY_LEVEL_M there)."""
    p = np.asarray(xy, np.float64).reshape(-1, 2)
    ground = np.full(len(p), np.nan)
    level = np.full(len(p), DRY_LEVEL_M)
    todo = np.flatnonzero(np.isfinite(p).all(axis=1))
    missed = [np.flatnonzero(~np.isfinite(p).all(axis=1))]
    heights, waters = cache.pools.get(HEIGHT), cache.pools.get(WATER)
    if heights is None or waters is None:
        return ground, level, np.arange(len(p))
    for lv in range(int(max_level), -1, -1):
        if not len(todo):
            break
        cell = quadtree.cell_m(lv, n)
        u = (p[todo, 0] - quadtree.root_x_m) / cell
        v = (p[todo, 1] - quadtree.root_y_m) / cell
        tx, ty = np.floor(u / n).astype(np.int64), np.floor(v / n).astype(np.int64)
        inside = (tx >= 0) & (ty >= 0) & (tx < (1 << lv)) & (ty < (1 << lv))
        codes = (np.int64(lv) << 56) | (np.where(inside, ty, 0) << 28) | np.where(inside, tx, 0)
        hs, ws = heights.table.find_many(codes), waters.table.find_many(codes)
        ok = np.flatnonzero(inside & (hs >= 0) & (ws >= 0))
        if len(ok):
            fu, fv = u[ok] - tx[ok] * n, v[ok] - ty[ok] * n
            i = np.clip(np.floor(fu).astype(np.int64), 0, n - 1)
            j = np.clip(np.floor(fv).astype(np.int64), 0, n - 1)
            fu, fv = fu - i, fv - j
            for out, arr, slots, off in ((ground, heights.z, hs[ok], 1),
                                         (level, waters.level_seen, ws[ok], 0)):
                a = arr[slots, j + off, i + off]
                b = arr[slots, j + off, i + off + 1]
                c = arr[slots, j + off + 1, i + off]
                d = arr[slots, j + off + 1, i + off + 1]
                out[todo[ok]] = ((1 - fv) * ((1 - fu) * a + fu * b)
                                 + fv * ((1 - fu) * c + fu * d))
        keep = np.ones(len(todo), bool)
        keep[ok] = False
        todo = todo[keep]
    return ground, level, np.concatenate(missed + [todo])


def terrain_producers(scene: Landscape) -> list[Producer]:
    """The producers of every terrain kind of ``scene`` (TERRAIN_KINDS order)."""
    tiles = LandscapeTiles(scene)
    producers = [HeightProducer(tiles), WaterProducer(tiles), RaycastProducer(tiles),
                 HintsProducer(tiles), TerrainMeshProducer(tiles), WaterMeshProducer(tiles)]
    for producer in producers:           # the array kinds' tiles, for every world over it
        producer.memo, producer.memo_tag = scene.tile_memo, tiles.n
    return producers
