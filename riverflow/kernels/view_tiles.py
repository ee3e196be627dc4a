"""Which tiles the camera sees, and at which quadtree level (Proland UpdateRiversTask, and
the terrain's level of detail): one walk for every kind of tile (:func:`select_view_tiles`).
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from riverflow.kernels._jit import JIT_OPTIONS
from riverflow.kernels.tile_table import table_find, tile_code

MAX_VIEW_TILES = 4096
"""At most this many tiles of one cut are asked for a frame (the callers' key buffers)."""


@njit(**JIT_OPTIONS)
def _box_outside_frustum(m, x0, y0, x1, y1, z0, z1):
    """True when all 8 corners are beyond one clip plane (clip = m @ [x y z 1])."""
    for plane in range(6):
        axis = plane // 2
        sign = 1.0 if plane % 2 == 0 else -1.0
        all_out = True
        for c in range(8):
            x = x0 if c & 1 == 0 else x1
            y = y0 if c & 2 == 0 else y1
            z = z0 if c & 4 == 0 else z1
            v = m[axis, 0] * x + m[axis, 1] * y + m[axis, 2] * z + m[axis, 3]
            w = m[3, 0] * x + m[3, 1] * y + m[3, 2] * z + m[3, 3]
            # inside means -w <= v <= w; plane 'sign': v <= w (sign +1) or v >= -w (sign -1)
            if sign * v <= w:
                all_out = False
                break
        if all_out:
            return True
    return False


@njit(**JIT_OPTIONS)
def select_view_tiles(
    clip_from_world, cam_x, cam_y, cam_z, rad_per_px, target_px, root_x, root_y, root_size_m,
    n_cells, max_level, z_min, z_max, keep_keys, keep_values, out_keys,
):
    """Fill ``out_keys`` (K, 3) int32 with (level, tx, ty) of the tiles the view needs;
    returns their number (at most K: the walk stops there).

    A depth-first walk of the quadtree from the root: a tile is skipped when its box (the tile
    × [z_min, z_max]) is outside the view frustum, or when ``keep_keys``/``keep_values`` (a
    tile table, :mod:`riverflow.kernels.tile_table`; empty: keep all) does not hold it; it is
    taken when its node spacing (tile side / ``n_cells``), seen from the camera at the tile's
    nearest point, is at most ``target_px`` pixels, or at ``max_level``; otherwise its four
    children are visited. Far tiles are therefore coarser.
    """
    stack = np.empty((4 * (max_level + 1) + 4, 3), np.int64)
    stack[0, 0] = 0
    stack[0, 1] = 0
    stack[0, 2] = 0
    top = 1
    n = 0
    filtered = keep_keys.shape[0] > 0
    while top > 0:
        top -= 1
        level = stack[top, 0]
        tx = stack[top, 1]
        ty = stack[top, 2]
        size = root_size_m / (1 << level)
        x0 = root_x + tx * size
        y0 = root_y + ty * size
        x1 = x0 + size
        y1 = y0 + size
        if filtered and table_find(keep_keys, keep_values, tile_code(level, tx, ty)) < 0:
            continue
        if _box_outside_frustum(clip_from_world, x0, y0, x1, y1, z_min, z_max):
            continue
        dx = max(x0 - cam_x, 0.0, cam_x - x1)
        dy = max(y0 - cam_y, 0.0, cam_y - y1)
        dz = max(z_min - cam_z, 0.0, cam_z - z_max)
        dist = math.sqrt(dx * dx + dy * dy + dz * dz)
        spacing = size / n_cells
        if level >= max_level or spacing <= target_px * rad_per_px * dist:
            if n >= out_keys.shape[0]:
                return n
            out_keys[n, 0] = level
            out_keys[n, 1] = tx
            out_keys[n, 2] = ty
            n += 1
            continue
        for child in range(4):
            stack[top, 0] = level + 1
            stack[top, 1] = 2 * tx + (child & 1)
            stack[top, 2] = 2 * ty + (child >> 1)
            top += 1
    return n
