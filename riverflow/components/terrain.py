"""Terrain: a heightfield on a regular grid, cut into square tiles (plain data).

``heights_m[j, i]`` is the altitude [m] at ``origin_m + (i, j) * cell_m``. The grid holds
``tiles * (tile_size_m / cell_m) + 1`` samples per side, so tile ``(ix, iy)`` owns
``n + 1`` × ``n + 1`` samples (n = tile_size_m / cell_m) that it shares with its neighbours:
each tile can become one mesh with no cracks between tiles.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(eq=False)
class Terrain:
    """Heightfield (ny, nx) float32 [m] with its grid origin (2,) [m], cell size and tile size [m]."""

    heights_m: np.ndarray
    origin_m: np.ndarray
    cell_m: float
    tile_size_m: float

    def __post_init__(self) -> None:
        self.heights_m = np.ascontiguousarray(self.heights_m, dtype=np.float32)
        self.origin_m = np.asarray(self.origin_m, dtype=np.float64).reshape(2)
        self.cell_m = float(self.cell_m)
        self.tile_size_m = float(self.tile_size_m)
        n = self.tile_size_m / self.cell_m
        if self.heights_m.ndim != 2 or abs(n - round(n)) > 1e-9 or n < 1:
            raise ValueError("heights_m must be 2-D and tile_size_m a whole number of cells")
        ny, nx = self.heights_m.shape
        if (nx - 1) % round(n) or (ny - 1) % round(n):
            raise ValueError(f"a {nx}×{ny} grid is not a whole number of {round(n)}-cell tiles")

    @property
    def cells_per_tile(self) -> int:
        return round(self.tile_size_m / self.cell_m)

    @property
    def tile_count(self) -> tuple[int, int]:
        """(tiles along x, tiles along y)."""
        ny, nx = self.heights_m.shape
        n = self.cells_per_tile
        return (nx - 1) // n, (ny - 1) // n

    @property
    def bounds_m(self) -> tuple[float, float, float, float]:
        """(xmin, ymin, xmax, ymax) [m]."""
        ny, nx = self.heights_m.shape
        x0, y0 = self.origin_m
        return (float(x0), float(y0), float(x0 + (nx - 1) * self.cell_m),
                float(y0 + (ny - 1) * self.cell_m))

    def height(self, xy: np.ndarray) -> np.ndarray:
        """Bilinear altitude [m] at points (N, 2) [m], (N,) float64; clamped at the edges."""
        p = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
        ny, nx = self.heights_m.shape
        gx = np.clip((p[:, 0] - self.origin_m[0]) / self.cell_m, 0.0, nx - 1.0)
        gy = np.clip((p[:, 1] - self.origin_m[1]) / self.cell_m, 0.0, ny - 1.0)
        i = np.minimum(gx.astype(np.int64), nx - 2)
        j = np.minimum(gy.astype(np.int64), ny - 2)
        u, v = gx - i, gy - j
        h = self.heights_m
        return ((1 - v) * ((1 - u) * h[j, i] + u * h[j, i + 1])
                + v * ((1 - u) * h[j + 1, i] + u * h[j + 1, i + 1])).astype(np.float64)

    def tile(self, ix: int, iy: int) -> tuple[np.ndarray, np.ndarray]:
        """Samples of tile (ix, iy): heights (n + 1, n + 1) float32 [m] (a view, row = y) and
        the tile's origin (2,) [m]."""
        tx, ty = self.tile_count
        if not (0 <= ix < tx and 0 <= iy < ty):
            raise IndexError(f"tile ({ix}, {iy}) outside the {tx}×{ty} tiles")
        n = self.cells_per_tile
        heights = self.heights_m[iy * n: iy * n + n + 1, ix * n: ix * n + n + 1]
        return heights, self.origin_m + np.array([ix, iy], dtype=np.float64) * self.tile_size_m
