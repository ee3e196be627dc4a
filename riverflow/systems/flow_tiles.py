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
        if (tiles.produced, tiles.evicted) == self._seen:
            return
        self._seen = (tiles.produced, tiles.evicted)
        used = {int(s) for s in np.flatnonzero(tiles.slot_key[:, 0] >= 0)}
        for slot, ent in list(self._entities.items()):
            tile = esper.try_component(ent, FlowTile)
            key = tuple(int(v) for v in tiles.slot_key[slot])
            if slot not in used or tile is None or (tile.level, tile.tx, tile.ty) != key:
                esper.delete_entity(ent)
                del self._entities[slot]
        for slot in used - set(self._entities):
            level, tx, ty = (int(v) for v in tiles.slot_key[slot])
            self._entities[slot] = esper.create_entity(FlowTile(level, tx, ty, slot))
