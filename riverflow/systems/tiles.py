"""ProduceTiles: the tiles of every kind the camera needs, at the level its distance needs
(Proland UpdateRiversTask and the terrain's level of detail). Finished tiles are installed
first; tiles that left the view are no longer marked used, so the cache's LRU releases them
under its budget; one :class:`~riverflow.components.river.Tile` entity per resident tile."""
from __future__ import annotations

import esper
import numpy as np

from riverflow.components.flow_tiles import FLOW_KIND
from riverflow.components.river import FrameView, RiverNode, SurfaceGrids, Tile, Tiles
from riverflow.engine.system import System
from riverflow.kernels.view_tiles import select_view_tiles
from riverflow.tiles.table import code_key

MAX_VIEW_TILES = 4096
"""At most this many tiles of one kind are asked for a frame."""


class ProduceTiles(System):
    name = "tiles"

    def __init__(self) -> None:
        self._keys = np.zeros((MAX_VIEW_TILES, 3), np.int32)
        self._entities: dict[tuple[str, int], int] = {}  # (kind, slot) → entity
        self._synced: dict[str, tuple[int, np.ndarray]] = {}  # kind → (revision, slot codes)
        self.visible: dict[str, int] = {}
        """Tiles of each kind in view at the last frame."""

    def process(self, world, dt_s: float) -> None:
        tiles = world.resource(Tiles)
        view = world.resource(FrameView)
        grids = world.resource(SurfaceGrids)
        config = world.config
        tiles.cache.next_tick()
        tiles.scheduler.collect()
        for _, node in esper.get_component(RiverNode):
            field = node.field
            t = field.tiles
            n = 0
            if view.width_px > 0 and view.height_px > 0:
                n = select_view_tiles(
                    view.clip_from_world, *view.eye_m, view.rad_per_px, config.flow_tile_px,
                    t.root_x_m, t.root_y_m, t.root_size_m, t.n_cells, field.max_level,
                    grids.z_min, grids.z_max, t.wet.keys, t.wet.values, self._keys)
            self.visible[FLOW_KIND] = int(n)
            tiles.scheduler.request(FLOW_KIND, self._keys[:n])
        self._sync_entities(tiles)

    def _sync_entities(self, tiles: Tiles) -> None:
        """One Tile entity per resident tile: the slots whose code changed since the last sync
        get their entity replaced (a few a second, not every slot each frame)."""
        for kind, pool in tiles.cache.pools.items():
            revision, synced = self._synced.get(kind, (-1, np.zeros(0, np.int64)))
            if revision == pool.revision:
                continue
            codes = pool.slot_code
            if len(synced) != len(codes):
                synced = np.concatenate([synced, np.full(len(codes) - len(synced), -1, np.int64)])
            for slot in np.flatnonzero(codes != synced).tolist():
                ent = self._entities.pop((kind, slot), None)
                if ent is not None:
                    esper.delete_entity(ent)
                code = int(codes[slot])
                if code >= 0:
                    self._entities[(kind, slot)] = esper.create_entity(
                        Tile(kind, *code_key(code), slot))
            self._synced[kind] = (pool.revision, codes.copy())
