"""ProduceTiles: the tiles of every kind the camera needs, at the level its distance needs
(Proland UpdateRiversTask and the terrain's level of detail; SPEC §8).

Each frame: install what the worker finished; walk the quadtree for the terrain's cut (the
leaves the view needs: node spacing ≤ ``terrain_tile_px`` pixels) and for the flow's (lattice
spacing ≤ ``flow_tile_px``, river tiles only); ask the scheduler for every terrain kind on the
cut's leaves and their ancestors (coarse first: a missing leaf is stood in for by its parent)
and for flow tiles on the flow cut (the resident ones are marked used, so the cache's LRU
releases what left the view); with ``RiverConfig.deterministic`` (the default) make every
leaf of both cuts the worker has not made yet, in the frame
(:meth:`~riverflow.tiles.scheduler.TileScheduler.complete`), so that no frame reads a
stand-in that depends on when the worker ran; publish the
frame's :class:`~riverflow.components.river.TerrainView` (the cut, and the surface the particle
kernels read, with resident ancestors standing in for tiles not made yet); keep one
:class:`~riverflow.components.river.Tile` entity per resident tile.
"""
from __future__ import annotations

import esper
import numpy as np

from riverflow.components.flow_tiles import FLOW_KIND, flow_view_tiles
from riverflow.components.river import FrameView, RiverNode, TerrainView, Tile, Tiles
from riverflow.engine.system import System
from riverflow.kernels.surface_tiles import SurfaceTiles, leaf_standins
from riverflow.kernels.view_tiles import MAX_VIEW_TILES, select_view_tiles
from riverflow.scenes.tile_kinds import HINT_CELLS, HINTS, RAYCAST, TERRAIN_KINDS
from riverflow.tiles.coverage import with_ancestors
from riverflow.tiles.table import TileTable, code_key, codes

_ALL_KEYS = np.zeros(0, np.int64)     # an empty filter: every tile is a candidate
_ALL_VALUES = np.zeros(0, np.int32)
_NO_CODES = np.zeros(0, np.int64)


class ProduceTiles(System):
    name = "tiles"

    def __init__(self) -> None:
        self._keys = np.zeros((MAX_VIEW_TILES, 3), np.int32)
        self._cut = np.zeros((MAX_VIEW_TILES, 3), np.int32)
        self._cut_table = TileTable(2 * MAX_VIEW_TILES)
        self._ancestors = np.zeros((0, 3), np.int32)
        self._ancestors_of = b""
        self._ancestor_codes = np.zeros(0, np.int64)
        self._entities: dict[tuple[str, int], int] = {}  # (kind, slot) → entity
        self._synced: dict[str, tuple[int, np.ndarray]] = {}  # kind → (revision, slot codes)
        self.visible: dict[str, int] = {}
        """Tiles of each kind in view at the last frame."""

    def process(self, world, dt_s: float) -> None:
        tiles = world.resource(Tiles)
        view = world.resource(FrameView)
        terrain = world.resource(TerrainView)
        config = world.config
        tiles.cache.next_tick()
        tiles.scheduler.collect()
        seen = view.width_px > 0 and view.height_px > 0
        q = world.scene.quadtree
        n_cut = 0
        if seen:
            n_cut = select_view_tiles(
                view.clip_from_world, *view.eye_m, view.rad_per_px, config.terrain_tile_px,
                q.root_x_m, q.root_y_m, q.root_size_m, world.scene.terrain.tile_cells,
                world.scene.terrain.max_level, terrain.z_min, terrain.z_max, _ALL_KEYS,
                _ALL_VALUES, self._cut)
            wanted = self._with_ancestors(self._cut[:n_cut])
            for kind in TERRAIN_KINDS:
                tiles.scheduler.request(kind, wanted, self._ancestor_codes)
        self.visible["terrain"] = int(n_cut)
        # what the frame reads: the cut's leaves (with every leaf made, no ancestor stands in;
        # the ancestors stay queued for the worker, a leaf's producer makes what it needs)
        leaves = codes(self._cut[:n_cut]) if seen else _NO_CODES
        wanted = [(kind, leaves) for kind in TERRAIN_KINDS]
        flow_cuts = []
        for _, node in esper.get_component(RiverNode):
            field = node.field
            t = field.tiles
            n = 0
            if seen:
                n = flow_view_tiles(view, terrain, field, config.flow_tile_px, self._keys)
            self.visible[FLOW_KIND] = int(n)
            flow_keys = self._keys[:n].copy()
            flow_codes = codes(flow_keys)
            tiles.scheduler.request(FLOW_KIND, flow_keys, flow_codes)
            wanted.append((FLOW_KIND, flow_codes))
            flow_cuts.append((t, flow_keys, flow_codes))
        if config.deterministic:
            # every tile this frame asked for is read as made, never as a stand-in for a late
            # one: what the frame computes does not depend on when the worker made it
            tiles.scheduler.complete(wanted)
        for t, flow_keys, flow_codes in flow_cuts:
            t.mark_cut(flow_keys, flow_codes)
        terrain.cut = self._cut[:n_cut].copy()
        terrain.surface = self._surface(world, tiles, terrain)
        self._sync_entities(tiles)

    def _with_ancestors(self, cut: np.ndarray) -> np.ndarray:
        """The cut's leaves and every tile above them, coarse first (Proland keeps the whole
        quadtree down to the cut): a leaf not made yet is drawn and queried at its parent's
        level, and the scheduler makes coarse tiles first, so the view is never empty and
        fills in from coarse to fine. Recomputed only when the cut changes."""
        key = cut.tobytes()
        if key != self._ancestors_of:
            code = with_ancestors(codes(cut))
            mask = (1 << 28) - 1
            self._ancestors = np.stack([code >> 56, code & mask, (code >> 28) & mask],
                                       axis=1).astype(np.int32)
            self._ancestor_codes = np.ascontiguousarray(code, np.int64)
            self._ancestors_of = key
        return self._ancestors

    def _surface(self, world, tiles: Tiles, terrain: TerrainView) -> SurfaceTiles:
        """The particle kernels' view of this frame's cut (module docstring)."""
        cut = terrain.cut
        table = self._cut_table
        table.clear()
        table.set_many(codes(cut), np.arange(len(cut), dtype=np.int32))
        raycast = tiles.cache.pools[RAYCAST]
        hints = tiles.cache.pools[HINTS]
        leaf_slot = np.empty(len(cut), np.int32)
        leaf_key = np.zeros((len(cut), 3), np.int32)
        hint_slot = np.empty(len(cut), np.int32)
        hint_key = np.zeros((len(cut), 3), np.int32)
        leaf_standins(cut, len(cut), raycast.table.keys, raycast.table.values, leaf_slot,
                      leaf_key)
        leaf_standins(cut, len(cut), hints.table.keys, hints.table.values, hint_slot, hint_key)
        for pool, slots in ((raycast, leaf_slot), (hints, hint_slot)):
            used = slots[slots >= 0]
            pool.last_used[used] = tiles.cache.tick  # stand-ins stay while they stand in
        q = world.scene.quadtree
        return SurfaceTiles(
            q.root_x_m, q.root_y_m, q.root_size_m, world.scene.terrain.tile_cells, table.keys,
            table.values, int(cut[:, 0].min()) if len(cut) else 0,
            int(cut[:, 0].max()) if len(cut) else 0, leaf_slot, leaf_key,
            raycast.arrays["ground"], raycast.arrays["water"], raycast.arrays["pyramid"],
            terrain.z_min, terrain.z_max, hint_slot, hint_key, hints.arrays["hints"], HINT_CELLS)

    def _sync_entities(self, tiles: Tiles) -> None:
        """One Tile entity per resident tile: the slots whose code changed since the last sync
        get their entity replaced (a few a second, not every slot each frame)."""
        for kind, pool in tiles.cache.pools.items():
            revision, synced = self._synced.get(kind, (-1, np.zeros(0, np.int64)))
            if revision == pool.revision:
                continue
            slot_codes = pool.slot_code
            if len(synced) != len(slot_codes):
                synced = np.concatenate([synced, np.full(len(slot_codes) - len(synced), -1,
                                                         np.int64)])
            for slot in np.flatnonzero(slot_codes != synced).tolist():
                ent = self._entities.pop((kind, slot), None)
                if ent is not None:
                    esper.delete_entity(ent)
                code = int(slot_codes[slot])
                if code >= 0:
                    self._entities[(kind, slot)] = esper.create_entity(
                        Tile(kind, *code_key(code), slot))
            self._synced[kind] = (pool.revision, slot_codes.copy())
