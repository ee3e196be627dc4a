"""A surface of one tile: the :class:`~riverflow.kernels.surface_tiles.SurfaceTiles` the
particle, rain and foam kernels read, made from one heightfield instead of a landscape's tiles
(tests, tools, and the rain's empty surface before any tile exists)."""
from __future__ import annotations

import numpy as np

from riverflow.kernels.raycast import height_pyramid
from riverflow.kernels.surface_tiles import SurfaceTiles
from riverflow.tiles.table import TileTable, tile_code


def one_tile_surface(ground: np.ndarray, water: np.ndarray, origin_x: float, origin_y: float,
                     cell_m: float, hints: np.ndarray | None = None) -> SurfaceTiles:
    """A :class:`SurfaceTiles` whose cut is one tile: a square grid of (n + 1)² nodes
    ``cell_m`` apart from (``origin_x``, ``origin_y``) (ground [m]; water level [m], NaN where
    dry), with ``hints`` (h + 1, h + 1, 3) float32 over the same square (None: no hints). For
    tests and tools that have one heightfield, not a landscape's tiles."""
    ground = np.ascontiguousarray(ground, np.float32)
    water = np.ascontiguousarray(water, np.float32)
    if ground.ndim != 2 or ground.shape[0] != ground.shape[1] or ground.shape != water.shape:
        raise ValueError(f"one_tile_surface needs two equal square grids, got {ground.shape} "
                         f"and {water.shape}")
    n = ground.shape[0] - 1
    if hints is None:
        hints = np.full((2, 2, 3), np.inf, np.float32)
    hints = np.ascontiguousarray(hints, np.float32)
    table = TileTable(4)
    table.set(tile_code(0, 0, 0), 0)
    key = np.zeros((1, 3), np.int32)
    finite = np.concatenate([ground.ravel(), water[np.isfinite(water)]])
    return SurfaceTiles(
        float(origin_x), float(origin_y), float(n * cell_m), n, table.keys, table.values, 0, 0,
        np.zeros(1, np.int32), key, ground[None], water[None],
        height_pyramid(ground, water)[None], float(finite.min()), float(finite.max()),
        np.zeros(1, np.int32), key.copy(), hints[None], hints.shape[0] - 1)
