"""FlowTileCache: the flow tiles of a quadtree over the terrain, in one fixed-capacity pool.

Plain data (Proland: the ``ObjectTileStorage`` of a ``HydroFlowProducer``). A tile at level ``l``
covers a square of side ``root_size_m / 2**l`` and holds an ``n × n``-cell ψ lattice; tiles live
in pool slots, and ``slots[l]`` maps tile (tx, ty) of level ``l`` to its slot (−1: not cached).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from riverflow.kernels.flow import CELL_SEGMENTS


@dataclass(eq=False)
class FlowTileCache:
    """A bounded pool of flow tiles with least-recently-used eviction."""

    root_x_m: float
    root_y_m: float
    root_size_m: float
    n_cells: int
    """Lattice cells per tile side."""
    max_level: int
    capacity: int

    psi: np.ndarray = field(init=False)            # (P, n+3, n+3) float32 ψ [m²/s], points −1…n+1
    cell_status: np.ndarray = field(init=False)    # (P, n, n) uint8 CELL_*
    cell_segments: np.ndarray = field(init=False)  # (P, n, n, CELL_SEGMENTS) int32
    slot_key: np.ndarray = field(init=False)       # (P, 3) int32 level, tx, ty; level −1 = free
    last_used: np.ndarray = field(init=False)      # (P,) int64 tick of the last use
    inside_points: np.ndarray = field(init=False)  # (P,) int32 lattice points in the water
    slots: list[np.ndarray] = field(init=False)    # per level: (2**l, 2**l) int32 slot or −1
    slots_flat: np.ndarray = field(init=False)     # every level's table, level after level
    level_offset: np.ndarray = field(init=False)   # (max_level + 2,) int64 start of each level
    tick: int = 0
    produced: int = 0
    """Tiles computed so far (cache misses)."""
    evicted: int = 0

    def __post_init__(self) -> None:
        n, p = self.n_cells, self.capacity
        self.psi = np.full((p, n + 3, n + 3), np.nan, np.float32)
        self.cell_status = np.zeros((p, n, n), np.uint8)
        self.cell_segments = np.full((p, n, n, CELL_SEGMENTS), -1, np.int32)
        self.slot_key = np.full((p, 3), -1, np.int32)
        self.last_used = np.zeros(p, np.int64)
        self.inside_points = np.zeros(p, np.int32)
        sizes = [1 << (2 * lv) for lv in range(self.max_level + 1)]
        self.level_offset = np.concatenate([[0], np.cumsum(sizes)]).astype(np.int64)
        self.slots_flat = np.full(int(self.level_offset[-1]), -1, np.int32)
        self.slots = [self.slots_flat[self.level_offset[lv]:self.level_offset[lv + 1]]
                      .reshape(1 << lv, 1 << lv) for lv in range(self.max_level + 1)]

    def tile_size_m(self, level: int) -> float:
        return self.root_size_m / (1 << level)

    def spacing_m(self, level: int) -> float:
        """Lattice spacing h [m] of a tile at ``level``."""
        return self.tile_size_m(level) / self.n_cells

    def tile_origin_m(self, level: int, tx: int, ty: int) -> tuple[float, float]:
        size = self.tile_size_m(level)
        return self.root_x_m + tx * size, self.root_y_m + ty * size

    @property
    def cached(self) -> int:
        return int((self.slot_key[:, 0] >= 0).sum())
