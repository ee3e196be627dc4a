"""The water surface of a scene sampled on its terrain grid, for casting rays onto it.

Proland found where a new particle lands by reading the depth buffer of the rendered terrain,
water included (reference §3.5). We cast rays on the CPU instead
(:func:`riverflow.kernels.raycast.cast_rays_onto_heightfield`), which needs the water as a
heightfield beside the terrain: this module makes it once per scene.
"""
from __future__ import annotations

import math

import numpy as np
import shapely

REACH_CELLS = math.sqrt(2.0)
"""Nodes this close to the water [cells] get a level: then every cell the water polygon touches
has four wet corners, and the ray caster puts the shoreline where that water plane meets the
terrain, not on the cell grid (default scene: within 0.6 m of the true bank at 4 m cells, since
its banks rise above the water outside it). Where a scene's terrain outside the water lies below
the water level, the water shows up to this far past the bank."""

_BLOCK = 16  # candidate nodes are found per block of _BLOCK² cells first


def water_level_grid(scene, reach_cells: float = REACH_CELLS) -> np.ndarray:
    """Water level [m] at the nodes of ``scene.terrain``, NaN where dry.

    A node is wet when it lies within ``reach_cells`` cells of ``scene.water.polygon`` (so wet
    nodes reach a little past the banks, and past island shores); its level is
    ``scene.water.level`` (that of the nearest river point, continuous across the banks).
    Only blocks of the grid near the water are tested (shapely 2, vectorised).

    Returns:
        (ny, nx) float32, ``heights_m``'s shape and layout (``[j, i]`` at
        ``origin_m + (i, j) * cell_m``).
    """
    terrain = scene.terrain
    ny, nx = terrain.heights_m.shape
    x0, y0 = (float(v) for v in terrain.origin_m)
    cell = float(terrain.cell_m)
    out = np.full((ny, nx), np.nan, np.float32)
    reach = float(reach_cells) * cell
    water = scene.water.polygon
    if water.is_empty:
        return out

    # Blocks of nodes whose box comes within ``reach`` of the water.
    nbx, nby = -(-nx // _BLOCK), -(-ny // _BLOCK)
    bi, bj = np.meshgrid(np.arange(nbx), np.arange(nby))
    bi, bj = bi.ravel(), bj.ravel()
    boxes = shapely.box(x0 + bi * _BLOCK * cell, y0 + bj * _BLOCK * cell,
                        x0 + np.minimum(bi * _BLOCK + _BLOCK - 1, nx - 1) * cell,
                        y0 + np.minimum(bj * _BLOCK + _BLOCK - 1, ny - 1) * cell)
    shapely.prepare(water)
    near = shapely.dwithin(water, boxes, reach)
    if not near.any():
        return out

    # Their nodes, then the exact test per node.
    offsets = np.arange(_BLOCK)
    ii = (bi[near, None, None] * _BLOCK + offsets[None, None, :]).repeat(_BLOCK, 1)
    jj = (bj[near, None, None] * _BLOCK + offsets[None, :, None]).repeat(_BLOCK, 2)
    keep = (ii < nx) & (jj < ny)
    ii, jj = ii[keep], jj[keep]
    x = x0 + ii * cell
    y = y0 + jj * cell
    wet = shapely.dwithin(water, shapely.points(x, y), reach)
    xy = np.stack([x[wet], y[wet]], axis=1)
    out[jj[wet], ii[wet]] = scene.water.level(xy)
    return out
