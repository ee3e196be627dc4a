"""Quadtree: the one square tree of tiles every kind of tile lives in (SPEC §8).

The root square ``[root_x, root_x + root_size] × [root_y, root_y + root_size]`` is tile
(0, 0, 0); tile (level, tx, ty) covers a square of side ``root_size / 2**level`` whose lower
corner is ``root + (tx, ty) · size``. A kind of tile samples its tile on ``n`` cells per side;
the node (i, j) of tile (level, tx, ty) lies at :meth:`Quadtree.node_x` ``(level, tx·n + i)``,
so two tiles that share a border, and a tile and its children, compute **bitwise the same**
coordinates for their shared nodes (``root_size / (n·2**level)`` halves exactly from one level
to the next, and ``k · cell`` rounds the same real number whichever tile asks).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from riverflow.kernels.tile_table import MAX_LEVEL

TileKey = tuple[int, int, int]
"""(level, tx, ty)."""


@dataclass(frozen=True)
class Quadtree:
    """The root square [m] of a tile quadtree."""

    root_x_m: float
    root_y_m: float
    root_size_m: float

    def __post_init__(self) -> None:
        for name in ("root_x_m", "root_y_m", "root_size_m"):
            value = getattr(self, name)
            if not math.isfinite(value):
                raise ValueError(f"Quadtree.{name} must be finite, got {value!r}")
        if not self.root_size_m > 0.0:
            raise ValueError(f"Quadtree.root_size_m must be positive, got {self.root_size_m!r}")

    @classmethod
    def around(cls, bounds_m: tuple[float, float, float, float], *, pad_m: float = 0.0
               ) -> Quadtree:
        """The square around ``bounds_m`` (xmin, ymin, xmax, ymax) padded by ``pad_m``."""
        x0, y0, x1, y1 = (float(v) for v in bounds_m)
        size = max(x1 - x0, y1 - y0) + 2.0 * pad_m
        return cls(0.5 * (x0 + x1) - 0.5 * size, 0.5 * (y0 + y1) - 0.5 * size, size)

    @property
    def bounds_m(self) -> tuple[float, float, float, float]:
        return (self.root_x_m, self.root_y_m, self.root_x_m + self.root_size_m,
                self.root_y_m + self.root_size_m)

    def tile_size_m(self, level: int) -> float:
        return self.root_size_m / (1 << level)

    def cell_m(self, level: int, n: int) -> float:
        """Node spacing [m] of an n-cell tile at ``level``."""
        return self.root_size_m / (n * (1 << level))

    def tile_origin_m(self, level: int, tx: int, ty: int) -> tuple[float, float]:
        size = self.tile_size_m(level)
        return self.root_x_m + tx * size, self.root_y_m + ty * size

    def tile_box_m(self, level: int, tx: int, ty: int) -> tuple[float, float, float, float]:
        """(xmin, ymin, xmax, ymax) [m] of a tile."""
        x0, y0 = self.tile_origin_m(level, tx, ty)
        size = self.tile_size_m(level)
        return x0, y0, x0 + size, y0 + size

    def node_coords(self, level: int, tx: int, ty: int, n: int, ring: int = 0
                    ) -> tuple[np.ndarray, np.ndarray]:
        """x (n + 1 + 2·ring,) and y (same) [m] of the nodes of an n-cell tile, with ``ring``
        extra nodes on each side (neighbours' nodes, for normals and stencils)."""
        cell = self.cell_m(level, n)
        k = np.arange(-ring, n + 1 + ring, dtype=np.float64)
        return (self.root_x_m + (tx * n + k) * cell, self.root_y_m + (ty * n + k) * cell)

    def level_for_cell(self, cell_m: float, n: int) -> int:
        """The coarsest level whose n-cell tiles have nodes at most ``cell_m`` apart (no
        fixed limit: deep enough for any river, up to the codes' MAX_LEVEL)."""
        if not cell_m > 0.0:
            raise ValueError(f"cell_m must be positive, got {cell_m!r}")
        ratio = math.log2(self.root_size_m / (n * cell_m)) if n * cell_m > 0.0 else math.inf
        level = max(0, math.ceil(ratio - 1e-12)) if math.isfinite(ratio) else MAX_LEVEL + 1
        if level > MAX_LEVEL:
            raise ValueError(f"a {cell_m:g} m cell in a {self.root_size_m:g} m root square needs "
                             f"quadtree level {level}, deeper than {MAX_LEVEL}")
        return level

    def tile_of(self, x_m: float, y_m: float, level: int) -> tuple[int, int] | None:
        """(tx, ty) of the tile of ``level`` holding the point, None outside the root."""
        u = (x_m - self.root_x_m) / self.root_size_m
        v = (y_m - self.root_y_m) / self.root_size_m
        if not (0.0 <= u <= 1.0 and 0.0 <= v <= 1.0):
            return None
        side = 1 << level
        return min(int(u * side), side - 1), min(int(v * side), side - 1)

    def tiles_in_box(self, level: int, box_m: tuple[float, float, float, float]
                     ) -> np.ndarray:
        """(K, 3) int64 keys of the tiles of ``level`` meeting the box (clipped to the root)."""
        side = 1 << level
        size = self.tile_size_m(level)
        x0, y0, x1, y1 = box_m
        i0 = max(int(math.floor((x0 - self.root_x_m) / size)), 0)
        j0 = max(int(math.floor((y0 - self.root_y_m) / size)), 0)
        i1 = min(int(math.floor((x1 - self.root_x_m) / size)), side - 1)
        j1 = min(int(math.floor((y1 - self.root_y_m) / size)), side - 1)
        if i1 < i0 or j1 < j0:
            return np.zeros((0, 3), np.int64)
        jj, ii = np.meshgrid(np.arange(j0, j1 + 1), np.arange(i0, i1 + 1), indexing="ij")
        return np.stack([np.full(ii.size, level), ii.ravel(), jj.ravel()], 1).astype(np.int64)


def parent(key: TileKey) -> TileKey | None:
    level, tx, ty = key
    return None if level == 0 else (level - 1, tx >> 1, ty >> 1)


def children(key: TileKey) -> list[TileKey]:
    level, tx, ty = key
    return [(level + 1, 2 * tx + (c & 1), 2 * ty + (c >> 1)) for c in range(4)]
