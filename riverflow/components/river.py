"""Plain-data components of a river world besides the particle pool and the flow tiles."""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from riverflow.kernels.poisson_cull import Grid
from riverflow.kernels.surface_tiles import SurfaceTiles
from riverflow.tiles.cache import TileCache
from riverflow.tiles.scheduler import TileScheduler

if TYPE_CHECKING:      # components are plain data: the river's types name the layer above
    from riverflow.hydro.flow_field import FlowField
    from riverflow.hydro.graph import HydroGraph


@dataclass(eq=False)
class RiverNode:
    """A river network and its flow (Proland: the rivers scene node)."""

    graph: HydroGraph
    field: FlowField


@dataclass(eq=False)
class Tile:
    """A resident tile of any kind ("flow", "height", …): one entity per tile in the cache,
    with its quadtree key and its slot in the kind's pool."""

    kind: str
    level: int
    tx: int
    ty: int
    slot: int


@dataclass(eq=False)
class Tiles:
    """The world's tile framework (a resource): one cache under one memory budget, and the
    scheduler that makes the tiles the view needs (SPEC §8)."""

    cache: TileCache
    scheduler: TileScheduler


@dataclass(eq=False)
class TerrainView:
    """The terrain tiles of this frame's view (a resource the tiles system fills each frame).

    ``cut`` (L, 3) int32: the leaves (level, tx, ty) of the quadtree the view needs (near
    ones fine, far ones coarse); ``surface``: what the particle kernels read of them
    (:class:`~riverflow.kernels.surface_tiles.SurfaceTiles`: ray casts, altitudes, water
    hints), None before the first frame; ``z_min``/``z_max`` [m] bound every terrain and water
    height of the scene.
    """

    cut: np.ndarray = field(default_factory=lambda: np.zeros((0, 3), np.int32))
    surface: SurfaceTiles | None = None
    z_min: float = 0.0
    z_max: float = 0.0


@dataclass(eq=False)
class ScreenGrid:
    """The screen neighbour grid of the Poisson maintenance and the per-frame scratch arrays.

    Cells are ``cell_px`` ≈ 4r wide, ``gw`` × ``gh`` of them for the current viewport, each
    holding up to K particle slots. Rebuilt (reallocated) only when the viewport or r changes.
    """

    capacity: int
    width_px: int = 0
    height_px: int = 0
    cell_px: float = 1.0
    gw: int = 1
    gh: int = 1
    per_cell: int = 32
    cell_count: np.ndarray = field(default_factory=lambda: np.zeros(1, np.int32))
    cell_items: np.ndarray = field(default_factory=lambda: np.zeros((1, 32), np.int32))
    removed_cells: np.ndarray = field(default_factory=lambda: np.zeros(1, np.uint8))
    dirty: np.ndarray = field(default_factory=lambda: np.zeros(1, np.uint8))
    # the accepted particles by cell, compact (the cull writes them): rows acc_start[c] …
    # acc_start[c + 1] of acc_slot (C,) int32 and acc_xy (C, 2) float32 [px]; carrier_cells
    # (gw·gh,) uint8 bit 1: an INSIDE one among them, bit 2: an INSIDE or LEAVING one
    acc_start: np.ndarray = field(default_factory=lambda: np.zeros(2, np.int32))
    carrier_cells: np.ndarray = field(default_factory=lambda: np.zeros(1, np.uint8))
    acc_slot: np.ndarray = field(init=False)
    acc_xy: np.ndarray = field(init=False)
    candidates: np.ndarray = field(init=False)     # (C,) int32 scratch
    new_slots: np.ndarray = field(init=False)      # (C,) int32 particles placed this frame
    n_new: int = 0
    query_index: np.ndarray = field(init=False)    # (C,) int32 particles asking the flow
    query_xy: np.ndarray = field(init=False)       # (C, 2) float64 [m]
    query_status: np.ndarray = field(init=False)   # (C,) uint8
    query_velocity: np.ndarray = field(init=False)  # (C, 2) float32 [m/s]
    arrays: Grid = field(init=False, repr=False)
    """The grid as the Poisson kernels take it (remade with the grid)."""

    def __post_init__(self) -> None:
        c = self.capacity
        self.candidates = np.zeros(c, np.int32)
        self.new_slots = np.zeros(c, np.int32)
        self.query_index = np.zeros(c, np.int32)
        self.query_xy = np.zeros((c, 2), np.float64)
        self.query_status = np.zeros(c, np.uint8)
        self.query_velocity = np.zeros((c, 2), np.float32)
        self.acc_slot = np.zeros(c, np.int32)
        self.acc_xy = np.zeros((c, 2), np.float32)
        self._remake_arrays()

    def fit(self, width_px: int, height_px: int, cell_px: float) -> bool:
        """Resize for a viewport; True if the grid was rebuilt (its contents are then empty)."""
        if (width_px, height_px, cell_px) == (self.width_px, self.height_px, self.cell_px):
            return False
        self.width_px, self.height_px, self.cell_px = int(width_px), int(height_px), cell_px
        self.gw = max(1, int(np.ceil(max(width_px, 1) / cell_px)))
        self.gh = max(1, int(np.ceil(max(height_px, 1) / cell_px)))
        n = self.gw * self.gh
        self.cell_count = np.zeros(n, np.int32)
        self.cell_items = np.zeros((n, self.per_cell), np.int32)
        self.removed_cells = np.zeros(n, np.uint8)
        self.dirty = np.zeros(n, np.uint8)
        self.acc_start = np.zeros(n + 1, np.int32)
        self.carrier_cells = np.zeros(n, np.uint8)
        self._remake_arrays()
        return True

    def _remake_arrays(self) -> None:
        self.arrays = Grid(self.width_px, self.height_px, self.cell_px, self.gw, self.gh,
                           self.cell_count, self.cell_items, self.removed_cells, self.dirty,
                           self.acc_start, self.acc_slot, self.acc_xy, self.carrier_cells,
                           self.candidates, self.new_slots)


@dataclass
class Clock:
    """Simulation time: ``now_s`` [s] since the world started, frames stepped, and the
    runtime controls a game toggles (pause the particles, flow speed factor)."""

    now_s: float = 0.0
    frame: int = 0
    paused: bool = False
    speed_factor: float = 1.0


@dataclass(eq=False)
class FrameView:
    """The camera as the kernels need it this frame (filled by the camera system)."""

    clip_from_world: np.ndarray = field(default_factory=lambda: np.eye(4))
    world_from_clip: np.ndarray = field(default_factory=lambda: np.eye(4))
    eye_m: np.ndarray = field(default_factory=lambda: np.zeros(3))
    width_px: int = 0
    height_px: int = 0
    rad_per_px: float = 0.0
    """View angle of one pixel [rad]."""
    revision: int = -1
