"""ProduceFlowTiles: the flow tiles for the terrain the camera sees, at the level its distance
needs (Proland UpdateRiversTask). Finished tiles are installed first; tiles that left the view
are no longer touched, so the cache's LRU releases them; one FlowTile entity per cached tile."""
from __future__ import annotations

import esper
import numpy as np

from riverflow.components.river import FlowTile, FrameView, RiverNode, SurfaceGrids
from riverflow.engine.system import System
from riverflow.kernels.view_tiles import select_view_tiles


class ProduceFlowTiles(System):
    name = "flow_tiles"

    def __init__(self) -> None:
        self._keys = np.zeros((0, 3), np.int32)
        self._seen = (-1, -1)
        self._entities: dict[int, int] = {}  # slot → entity
        self._synced = np.zeros((0, 3), np.int32)  # the slot keys the entities stand for
        self.visible = 0
        """Tiles in view at the last frame."""

    def process(self, world, dt_s: float) -> None:
        view = world.resource(FrameView)
        grids = world.resource(SurfaceGrids)
        config = world.config
        for _, node in esper.get_component(RiverNode):
            field = node.field
            tiles = field.tiles
            node.producer.collect()
            if len(self._keys) != tiles.capacity // 2:
                self._keys = np.zeros((max(tiles.capacity // 2, 1), 3), np.int32)
            n = 0
            if view.width_px > 0 and view.height_px > 0:
                n = select_view_tiles(
                    view.clip_from_world, *view.eye_m, view.rad_per_px, config.flow_tile_px,
                    tiles.root_x_m, tiles.root_y_m, tiles.root_size_m, tiles.n_cells,
                    field.max_level, grids.z_min, grids.z_max, tiles.slots_flat,
                    tiles.level_offset, self._keys)
            self.visible = int(n)
            node.producer.request(self._keys[:n])
            self._sync_entities(tiles)

    def _sync_entities(self, tiles) -> None:
        """One FlowTile entity per cached tile: the slots whose key changed since the last
        sync get their entity replaced (a few a second, not every slot each time)."""
        if (tiles.produced, tiles.evicted) == self._seen:
            return
        self._seen = (tiles.produced, tiles.evicted)
        if self._synced.shape != tiles.slot_key.shape:
            self._synced = np.full_like(tiles.slot_key, -1)
        changed = np.flatnonzero((tiles.slot_key != self._synced).any(axis=1))
        for slot in changed.tolist():
            ent = self._entities.pop(slot, None)
            if ent is not None:
                esper.delete_entity(ent)
            level, tx, ty = tiles.slot_key[slot].tolist()
            if level >= 0:
                self._entities[slot] = esper.create_entity(FlowTile(level, tx, ty, slot))
        self._synced[changed] = tiles.slot_key[changed]
