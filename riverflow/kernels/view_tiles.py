"""Which flow tiles the camera sees, and at which quadtree level (Proland UpdateRiversTask).

A depth-first walk of the quadtree: a tile is skipped when its box (the tile × the terrain's
height range) is outside the view frustum or holds no river; it is kept when its lattice
spacing, seen from the camera at the tile's nearest point, is at most ``flow_tile_px`` pixels;
otherwise its four children are visited. Far tiles are therefore coarser.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from riverflow.kernels._jit import JIT_OPTIONS


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
    clip_from_world, cam_x, cam_y, cam_z, rad_per_px, flow_tile_px, root_x, root_y,
    root_size_m, n_cells, max_level, z_min, z_max, slots_flat, level_offset, out_keys,
):
    """Fill ``out_keys`` (K, 3) int32 with (level, tx, ty) of the visible river tiles; returns
    their number (at most K: the walk stops there). A tile holds no river when its slot in
    ``slots_flat`` (every level's table, level l from ``level_offset[l]``, row-major) is
    SLOT_DRY (−3: ``riverflow.kernels.flow.mark_dry_tiles`` marked it from every axis's
    coverage box when the field was made)."""
    stack = np.empty((4 * (max_level + 1) + 4, 3), np.int64)
    stack[0, 0] = 0
    stack[0, 1] = 0
    stack[0, 2] = 0
    top = 1
    n = 0
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
        wet = slots_flat[level_offset[level] + ty * (1 << level) + tx] != -3
        if not wet or _box_outside_frustum(clip_from_world, x0, y0, x1, y1, z_min, z_max):
            continue
        dx = max(x0 - cam_x, 0.0, cam_x - x1)
        dy = max(y0 - cam_y, 0.0, cam_y - y1)
        dz = max(z_min - cam_z, 0.0, cam_z - z_max)
        dist = math.sqrt(dx * dx + dy * dy + dz * dz)
        spacing = size / n_cells
        if level >= max_level or spacing <= flow_tile_px * rad_per_px * dist:
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


@njit(**JIT_OPTIONS)
def mark_tiles_used(keys, n, slots_flat, level_offset, last_used, tick, out_missing):
    """Of the tiles ``keys[:n]`` (K, 3) int32 (level, tx, ty): stamp the cached ones used at
    ``tick`` (``last_used`` (P,) int64 by slot) and copy the ones not cached (slot
    SLOT_MISSING, −1; dry tiles are known and never missing) to ``out_missing`` (K, 3) int32;
    returns how many are missing. ``slots_flat`` / ``level_offset`` are the cache's slot
    tables, level after level (row-major 2**level × 2**level each)."""
    m = 0
    for k in range(n):
        level = keys[k, 0]
        side = 1 << level
        slot = slots_flat[level_offset[level] + keys[k, 2] * side + keys[k, 1]]
        if slot >= 0:
            last_used[slot] = tick
        elif slot == -1:
            out_missing[m, 0] = level
            out_missing[m, 1] = keys[k, 1]
            out_missing[m, 2] = keys[k, 2]
            m += 1
    return m
