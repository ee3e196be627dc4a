"""A flat landscape around any hydro graph, so a graph file alone can be simulated.

The terrain is a plane at 0 m around the graph's bounds (padded by a quarter of their size);
the water lies ``water_level_m`` above it, so rays meet water inside the water polygon and
land elsewhere. Used by ``riverflow profile --scene FILE.graph`` and tests.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import shapely

from riverflow.components.terrain import Terrain
from riverflow.hydro.areas import water_polygon
from riverflow.hydro.graph import HydroGraph


@dataclass(eq=False)
class FlatWater:
    """Water at one level inside ``polygon`` (shapely, islands are holes)."""

    polygon: shapely.Geometry
    level_m: float

    def level(self, xy: np.ndarray) -> np.ndarray:
        return np.full(len(np.asarray(xy).reshape(-1, 2)), self.level_m)

    def contains(self, xy: np.ndarray) -> np.ndarray:
        p = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
        return shapely.contains_xy(self.polygon, p[:, 0], p[:, 1])

    def height(self, xy: np.ndarray) -> np.ndarray:
        return np.where(self.contains(xy), self.level_m, np.nan)


@dataclass(eq=False)
class FlatScene:
    """graph, terrain, water and bounds (xmin, ymin, xmax, ymax) [m], like the default scene."""

    graph: HydroGraph
    terrain: Terrain
    water: FlatWater
    bounds_m: tuple[float, float, float, float]
    seed: int = 0
    branches: list = field(default_factory=list)


def flat_scene(graph: HydroGraph, cell_m: float = 4.0, tile_size_m: float = 128.0,
               water_level_m: float = 0.5) -> FlatScene:
    """A flat landscape just large enough for ``graph`` (whole tiles, square)."""
    x0, y0, x1, y1 = graph.bounds()
    size = max(x1 - x0, y1 - y0) * 1.5 + 2 * tile_size_m
    tiles = int(np.ceil(size / tile_size_m))
    size = tiles * tile_size_m
    origin = (0.5 * (x0 + x1) - 0.5 * size, 0.5 * (y0 + y1) - 0.5 * size)
    n = int(round(size / cell_m)) + 1
    terrain = Terrain(np.zeros((n, n), np.float32), origin, cell_m, tile_size_m)
    water = FlatWater(water_polygon(graph), float(water_level_m))
    return FlatScene(graph, terrain, water, terrain.bounds_m)
