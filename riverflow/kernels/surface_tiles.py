"""The ground and water surface as the particle kernels read it: the tiles of this frame's view.

Each frame the tile system picks the terrain tiles the camera needs (a *cut* of the quadtree:
leaves at the level their distance needs, :mod:`riverflow.kernels.view_tiles`). The particle
kernels (ray casts of new particles, altitudes, water hints) read the surface of exactly those
tiles, so particles land on the surface that is drawn, and no whole-map table exists.

:class:`SurfaceTiles` carries, per leaf of the cut, the pool slot of its *raycast* tile (ground
and water heights at the tile's (n + 1)² nodes and their max-mip pyramid) and of its *hints*
tile; when a leaf's own tile is not made yet, the finest resident ancestor's stands in (its key
is in ``leaf_key``), and −1 means no data (the kernels then report UNKNOWN).

Locating the leaf under a point walks the quadtree down from the cut's coarsest leaf level to
its deepest (at most ``max_level − min_level + 1`` table lookups: a number the view sets, not
the map, whose quadtree is deeper the larger it is); a point in no leaf (outside the view's
tiles) has none.
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from riverflow.kernels._jit import JIT_OPTIONS, is_finite
from riverflow.kernels.tile_table import table_find, tile_code

NO_LEAF = -1


class SurfaceTiles(NamedTuple):
    """This frame's surface tiles for the particle kernels (module docstring).

    Geometry: the quadtree root (``root_x``, ``root_y`` [m], side ``root_size`` [m]); raycast
    tiles have ``n`` cells per side (nodes i = 0 … n at ``origin + i · size / n``).

    The cut: ``cut_keys``/``cut_values`` a tile table from a leaf's code to its index l;
    ``min_level``/``max_level`` the coarsest and the deepest leaf level. Per leaf l: ``leaf_slot[l]`` the raycast pool slot
    used (−1: none yet) and ``leaf_key[l]`` (level, tx, ty) of that tile (the leaf's own, or
    an ancestor's standing in); ``hint_slot[l]`` / ``hint_key[l]`` likewise for the hints.

    Raycast pool (P slots): ``ground`` (P, n+1, n+1) float32 terrain altitude [m];
    ``water`` (P, n+1, n+1) float32 water level [m], NaN where dry; ``pyramid`` (P, M, 2)
    float32 per tile, the max-mip pyramid of :func:`riverflow.kernels.raycast.fill_height_pyramid`
    over its own (n+1)² nodes (levels k = 1 … K, rows x fastest: lowest terrain, highest
    surface). ``z_min``/``z_max`` [m] bound the surface of every leaf's tile.

    Hints pool (Q slots): ``hints`` (Q, h+1, h+1, 3) float32: at node (i, j) of a hints tile
    (every size/h), the x, y [m] and water level [m] of deep water near it (x = +inf: none);
    ``hint_cells`` h.
    """

    root_x: float
    root_y: float
    root_size: float
    n: int
    cut_keys: np.ndarray
    cut_values: np.ndarray
    min_level: int
    max_level: int
    leaf_slot: np.ndarray
    leaf_key: np.ndarray
    ground: np.ndarray
    water: np.ndarray
    pyramid: np.ndarray
    z_min: float
    z_max: float
    hint_slot: np.ndarray
    hint_key: np.ndarray
    hints: np.ndarray
    hint_cells: int


@njit(inline="always", **JIT_OPTIONS)
def find_leaf(view, x, y):
    """(index, level, tx, ty) of the cut's leaf holding (x, y) [m]; index NO_LEAF if none.
    On a border between two tiles the one on the higher side (x, y ≥ its lower edge) is
    taken."""
    u = (x - view.root_x) / view.root_size
    v = (y - view.root_y) / view.root_size
    if not (u >= 0.0 and v >= 0.0 and u <= 1.0 and v <= 1.0):
        return NO_LEAF, 0, 0, 0
    for level in range(view.min_level, view.max_level + 1):
        side = 1 << level
        tx = min(int(u * side), side - 1)
        ty = min(int(v * side), side - 1)
        leaf = table_find(view.cut_keys, view.cut_values, tile_code(level, tx, ty))
        if leaf >= 0:
            return leaf, level, tx, ty
    return NO_LEAF, 0, 0, 0


@njit(inline="always", **JIT_OPTIONS)
def locate_leaf(view, x, y):
    """Index of the cut's leaf holding (x, y) [m], NO_LEAF if none (:func:`find_leaf`)."""
    return find_leaf(view, x, y)[0]


@njit(inline="always", **JIT_OPTIONS)
def tile_frame(view, level, tx, ty, n):
    """(x0, y0, cell) [m] of tile (level, tx, ty) sampled with n cells."""
    size = view.root_size / (1 << level)
    return view.root_x + tx * size, view.root_y + ty * size, size / n


@njit(inline="always", **JIT_OPTIONS)
def _tile_cell_sized(view, x, y):
    """(slot, i, j, fu, fv, cell [m]): the raycast tile under (x, y) (slot −1: none yet), the
    cell of its grid holding the point, the point's position in the cell and the cell's side."""
    leaf = locate_leaf(view, x, y)
    if leaf < 0:
        return -1, 0, 0, 0.0, 0.0, 1.0
    slot = view.leaf_slot[leaf]
    if slot < 0:
        return -1, 0, 0, 0.0, 0.0, 1.0
    n = view.n
    x0, y0, cell = tile_frame(view, view.leaf_key[leaf, 0], view.leaf_key[leaf, 1],
                              view.leaf_key[leaf, 2], n)
    gx = min(max((x - x0) / cell, 0.0), float(n))
    gy = min(max((y - y0) / cell, 0.0), float(n))
    i = min(int(gx), n - 1)
    j = min(int(gy), n - 1)
    return slot, i, j, gx - i, gy - j, cell


@njit(inline="always", **JIT_OPTIONS)
def _tile_cell(view, x, y):
    """(slot, i, j, fu, fv): the raycast tile under (x, y) (slot −1: none yet) and the cell of
    its grid holding the point, with the point's position in the cell."""
    slot, i, j, fu, fv, _ = _tile_cell_sized(view, x, y)
    return slot, i, j, fu, fv


@njit(inline="always", **JIT_OPTIONS)
def _bilinear(grid, slot, i, j, fu, fv):
    """Bilinear blend of the four nodes of cell (i, j) of ``grid[slot]`` (NaN if one is)."""
    return ((1.0 - fv) * ((1.0 - fu) * grid[slot, j, i] + fu * grid[slot, j, i + 1])
            + fv * ((1.0 - fu) * grid[slot, j + 1, i] + fu * grid[slot, j + 1, i + 1]))


@njit(**JIT_OPTIONS)
def sample_surface(view, x, y):
    """(ground [m], water level [m] or NaN where dry, found) at (x, y), bilinear over the
    raycast tile of the leaf holding it; found is False where no tile is there yet. The water
    blends its wet corners only (the level at the shore, not NaN)."""
    slot, i, j, fu, fv = _tile_cell(view, x, y)
    if slot < 0:
        return 0.0, np.nan, False
    ground = _bilinear(view.ground, slot, i, j, fu, fv)
    w = view.water
    total = 0.0
    weight = 0.0
    for dj in range(2):
        for di in range(2):
            value = w[slot, j + dj, i + di]
            if not math.isnan(value):
                k = (fu if di else 1.0 - fu) * (fv if dj else 1.0 - fv)
                total += k * value
                weight += k
    if weight <= 0.0:
        return ground, np.nan, True
    return ground, total / weight, True


@njit(**JIT_OPTIONS)
def leaf_standins(leaf_keys, n_leaves, pool_keys, pool_values, out_slot, out_key):
    """For each leaf (level, tx, ty) of ``leaf_keys[:n_leaves]``: the pool slot of its own
    tile, or of its finest resident ancestor (−1: none), and that tile's key."""
    for k in range(n_leaves):
        level = np.int64(leaf_keys[k, 0])
        tx = np.int64(leaf_keys[k, 1])
        ty = np.int64(leaf_keys[k, 2])
        out_slot[k] = -1
        while level >= 0:
            slot = table_find(pool_keys, pool_values, tile_code(level, tx, ty))
            if slot >= 0:
                out_slot[k] = slot
                out_key[k, 0] = level
                out_key[k, 1] = tx
                out_key[k, 2] = ty
                break
            level -= 1
            tx >>= 1
            ty >>= 1


@njit(**JIT_OPTIONS)
def surface_altitude(view, x, y):
    """Altitude [m] a particle at (x, y) rides at: the water level, bilinear, where the four
    nodes around it are wet, else the ground; NaN where no tile is there yet."""
    slot, i, j, fu, fv = _tile_cell(view, x, y)
    if slot < 0:
        return np.nan
    z = _bilinear(view.water, slot, i, j, fu, fv)
    if is_finite(z):
        return z
    return _bilinear(view.ground, slot, i, j, fu, fv)


NO_TILE_YET = -2
"""Slot of :func:`hint_at` where the point is in a leaf whose tile is not made yet (−1: the
point is in no leaf of the view, so none will come)."""


@njit(inline="always", **JIT_OPTIONS)
def hint_at(view, x, y):
    """(slot, j, i) of the hint node nearest (x, y) in the hints tile of the leaf holding it;
    slot NO_LEAF (−1) where the point is in no leaf of the view, NO_TILE_YET (−2) where its
    leaf has no hints tile yet."""
    leaf = locate_leaf(view, x, y)
    if leaf < 0:
        return NO_LEAF, 0, 0
    slot = view.hint_slot[leaf]
    if slot < 0:
        return NO_TILE_YET, 0, 0
    h = view.hint_cells
    x0, y0, cell = tile_frame(view, view.hint_key[leaf, 0], view.hint_key[leaf, 1],
                              view.hint_key[leaf, 2], h)
    i = min(max(int(math.floor((x - x0) / cell + 0.5)), 0), h)
    j = min(max(int(math.floor((y - y0) / cell + 0.5)), 0), h)
    return slot, j, i


@njit(**JIT_OPTIONS)
def water_level_at(view, x, y):
    """Water level [m] at (x, y), bilinear, where the four nodes around it are wet; NaN where
    they are not or no tile is there yet."""
    slot, i, j, fu, fv = _tile_cell(view, x, y)
    if slot < 0:
        return np.nan
    return _bilinear(view.water, slot, i, j, fu, fv)


@njit(inline="always", **JIT_OPTIONS)
def water_slope_at(view, x, y):
    """(∂level/∂x, ∂level/∂y) of the water surface at (x, y): the gradient of the bilinear
    water level over the raycast tile's cell holding the point; (0, 0) where a corner of the
    cell is dry or no tile is there yet."""
    slot, i, j, fu, fv, cell = _tile_cell_sized(view, x, y)
    if slot < 0:
        return 0.0, 0.0
    w = view.water
    z00 = w[slot, j, i]
    z10 = w[slot, j, i + 1]
    z01 = w[slot, j + 1, i]
    z11 = w[slot, j + 1, i + 1]
    if math.isnan(z00 + z10 + z01 + z11):
        return 0.0, 0.0
    gx = ((1.0 - fv) * (z10 - z00) + fv * (z11 - z01)) / cell
    gy = ((1.0 - fu) * (z01 - z00) + fu * (z11 - z10)) / cell
    return gx, gy
