"""FlowTiles: the flow tiles of a quadtree over the river network (plain data).

Proland: the ``ObjectTileStorage`` of a ``HydroFlowProducer``. A tile at level ``l`` covers a
square of side ``root_size_m / 2**l`` and holds an ``n × n``-cell ψ lattice. The tiles are the
"flow" kind of the tile framework (:mod:`riverflow.tiles`): they live in the flow pool of a
:class:`~riverflow.tiles.cache.TileCache` (shared with every other kind in a river world, under
its memory budget), found through the pool's tile table; ``wet`` holds every tile an axis comes
near, at every level (any other tile is dry: all OUTSIDE, never made). The quadtree has no
depth limit: its finest level follows from the lattice spacing the narrowest river needs.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from riverflow.kernels.flow import CELL_SEGMENTS, CachedTiles
from riverflow.kernels.view_tiles import select_view_tiles
from riverflow.tiles.cache import FieldSpec, TileCache, TilePool
from riverflow.tiles.quadtree import Quadtree
from riverflow.tiles.table import TileTable, codes, tile_code

FLOW_KIND = "flow"


def flow_fields(n_cells: int) -> dict[str, FieldSpec]:
    """The per-tile arrays of a flow tile with ``n_cells`` lattice cells per side."""
    n = int(n_cells)
    return {"psi": FieldSpec((n + 3, n + 3), np.float32, np.nan),         # points −1 … n+1
            "cell_status": FieldSpec((n, n), np.uint8, 0),                 # CELL_*
            "cell_segments": FieldSpec((n, n, CELL_SEGMENTS), np.int32, -1),
            "shore": FieldSpec((n + 3, n + 3), np.float32, 0.0),          # to the nearest bank [m]
            "bank": FieldSpec((n + 3, n + 3), np.float32, 0.0),           # ... a mouth counted
            "inside_points": FieldSpec((), np.int32, 0),                   # lattice points in water
            "in_cut": FieldSpec((), np.uint8, 0)}     # a leaf of this frame's flow cut (tiles system)


@dataclass(eq=False)
class FlowTiles:
    """The flow kind's quadtree, pool and dry/wet marks."""

    quadtree: Quadtree
    n_cells: int
    """Lattice cells per tile side."""
    max_level: int
    cache: TileCache
    wet: TileTable

    def __post_init__(self) -> None:
        self.pool: TilePool = self.cache.pool(FLOW_KIND, flow_fields(self.n_cells))
        self.cut_level = -1
        """The deepest level of this frame's flow cut (:meth:`mark_cut`), −1 before any."""

    # -- geometry -----------------------------------------------------------------------------

    @property
    def root_x_m(self) -> float:
        return self.quadtree.root_x_m

    @property
    def root_y_m(self) -> float:
        return self.quadtree.root_y_m

    @property
    def root_size_m(self) -> float:
        return self.quadtree.root_size_m

    def tile_size_m(self, level: int) -> float:
        return self.quadtree.tile_size_m(level)

    def spacing_m(self, level: int) -> float:
        """Lattice spacing h [m] of a tile at ``level``."""
        return self.quadtree.cell_m(level, self.n_cells)

    def tile_origin_m(self, level: int, tx: int, ty: int) -> tuple[float, float]:
        return self.quadtree.tile_origin_m(level, tx, ty)

    # -- residency ----------------------------------------------------------------------------

    def slot_of(self, level: int, tx: int, ty: int) -> int:
        """The pool slot of a cached tile, −1 if it is not cached."""
        return self.pool.slot(tile_code(level, tx, ty))

    def is_wet(self, level: int, tx: int, ty: int) -> bool:
        """False when no river axis comes near the tile (it is never made)."""
        return tile_code(level, tx, ty) in self.wet

    @property
    def psi(self) -> np.ndarray:
        return self.pool.arrays["psi"]

    @property
    def cell_status(self) -> np.ndarray:
        return self.pool.arrays["cell_status"]

    @property
    def cell_segments(self) -> np.ndarray:
        return self.pool.arrays["cell_segments"]

    @property
    def shore(self) -> np.ndarray:
        """(P, n+3, n+3) float32: distance to the nearest bank or island shore [m] at each
        tile's lattice points −1 … n+1 (0 where dry)."""
        return self.pool.arrays["shore"]

    @property
    def bank(self) -> np.ndarray:
        """(P, n+3, n+3) float32: as :attr:`shore` with a basin's open mouth counted as the
        bank it is for the flow (:data:`riverflow.kernels.flow.OPEN_BANK`)."""
        return self.pool.arrays["bank"]

    @property
    def cached(self) -> int:
        return len(self.pool)

    @property
    def produced(self) -> int:
        """Tiles installed so far (cache misses)."""
        return self.pool.installed

    @property
    def evicted(self) -> int:
        return self.pool.evicted

    @property
    def capacity(self) -> int:
        """How many flow tiles the cache's budget holds."""
        return max(1, self.cache.budget_bytes // self.pool.tile_bytes)

    def mark_cut(self, keys: np.ndarray, key_codes: np.ndarray | None = None) -> None:
        """Mark the resident tiles of ``keys`` (K, 3) (their codes ``key_codes`` if known) as
        this frame's flow cut (``in_cut``: a tile read in their place only stands in for a
        late one; kernels/flow.py CELL_CROWDED)."""
        in_cut = self.pool.arrays["in_cut"]
        in_cut[:] = 0
        slots = self.pool.table.find_many(codes(keys) if key_codes is None else key_codes)
        in_cut[slots[slots >= 0]] = 1
        self.cut_level = int(keys[:, 0].max()) if len(keys) else -1

    @property
    def query_level(self) -> int:
        """The level a frame's queries start from, falling back on coarser tiles: the deepest
        of the cut when one is marked (a lookup then costs as many table probes as the view
        has levels, not as many as the quadtree, which is deeper the larger the map), else
        the finest level."""
        return self.cut_level if self.cut_level >= 0 else self.max_level

    def view(self) -> CachedTiles:
        """The tiles as the query kernels read them (rebuilt per call: the pool may grow)."""
        p = self.pool
        return CachedTiles(self.quadtree.root_x_m, self.quadtree.root_y_m,
                           self.quadtree.root_size_m, self.n_cells, p.table.keys,
                           p.table.values, self.wet.keys, self.wet.values, p.arrays["psi"],
                           p.arrays["cell_status"], p.arrays["cell_segments"], p.last_used,
                           p.arrays["in_cut"])


def flow_view_tiles(view, terrain, field, tile_px: float, out: np.ndarray) -> int:
    """Fill ``out`` (K, 3) int32 with the wet flow tiles of ``field`` (a
    :class:`~riverflow.hydro.flow_field.FlowField`) the view (a
    :class:`~riverflow.components.river.FrameView`, its terrain's
    :class:`~riverflow.components.river.TerrainView` height range) needs at ``tile_px``
    pixels a lattice cell; returns their number (the tiles system each frame, a live edit
    for the tiles it makes wet)."""
    t = field.tiles
    return select_view_tiles(np.asarray(view.clip_from_world, np.float64),
                             *np.asarray(view.eye_m, np.float64), float(view.rad_per_px),
                             tile_px, t.root_x_m, t.root_y_m, t.root_size_m, t.n_cells,
                             field.max_level, terrain.z_min, terrain.z_max, t.wet.keys,
                             t.wet.values, out)
