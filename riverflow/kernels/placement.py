"""Pixel rays of new particles (camera inverse matrix), then the hit written into the pool.

The rays are cast by :func:`riverflow.kernels.raycast.cast_rays_onto_heightfield`; this module
turns screen positions into rays and the hits into particle state: a hit (land or water) gives
a world position and an UNKNOWN flow status (the next advection asks the flow); a ray that
sees the sky gives ON_SKY, a particle with no world position that keeps its screen place in the
Poisson disk at no further cost (Proland re-unprojected those every frame: reference §7.14).
"""
from __future__ import annotations

import math

from numba import njit

from riverflow.kernels._jit import JIT_OPTIONS
from riverflow.kernels.lifecycle import free_particle

STATUS_UNKNOWN = 0
STATUS_ON_SKY = 7


@njit(**JIT_OPTIONS)
def pixel_rays(slots, n, screen_px, world_from_clip, width_px, height_px, out_origin, out_dir):
    """Ray (origin on the near plane, unit direction) through the screen position of each of
    ``slots[:n]``; ``world_from_clip`` (4, 4) float64 column-vector inverse view-projection."""
    m = world_from_clip
    for k in range(n):
        i = slots[k]
        nx = 2.0 * screen_px[i, 0] / max(width_px, 1) - 1.0
        ny = 2.0 * screen_px[i, 1] / max(height_px, 1) - 1.0
        near = unproject(m, nx, ny, -1.0)
        far = unproject(m, nx, ny, 1.0)
        dx = far[0] - near[0]
        dy = far[1] - near[1]
        dz = far[2] - near[2]
        norm = math.sqrt(dx * dx + dy * dy + dz * dz)
        if not norm > 0.0:
            norm = 1.0
        out_origin[k, 0] = near[0]
        out_origin[k, 1] = near[1]
        out_origin[k, 2] = near[2]
        out_dir[k, 0] = dx / norm
        out_dir[k, 1] = dy / norm
        out_dir[k, 2] = dz / norm


@njit(inline="always", **JIT_OPTIONS)
def unproject(m, x, y, z):
    """World point of NDC (x, y, z) through the clip → world matrix ``m``."""
    wx = m[0, 0] * x + m[0, 1] * y + m[0, 2] * z + m[0, 3]
    wy = m[1, 0] * x + m[1, 1] * y + m[1, 2] * z + m[1, 3]
    wz = m[2, 0] * x + m[2, 1] * y + m[2, 2] * z + m[2, 3]
    ww = m[3, 0] * x + m[3, 1] * y + m[3, 2] * z + m[3, 3]
    if ww == 0.0:
        ww = 1e-30
    return wx / ww, wy / ww, wz / ww


@njit(**JIT_OPTIONS)
def place_particles(slots, n, hit_xyz, hit_kind, world_m, has_world, status, first_query):
    """Write the ray hits of ``slots[:n]`` into the pool. Returns the number on the sky."""
    sky = 0
    for k in range(n):
        i = slots[k]
        first_query[i] = True
        if hit_kind[k] == 0:
            has_world[i] = False
            status[i] = STATUS_ON_SKY
            sky += 1
        else:
            world_m[i, 0] = hit_xyz[k, 0]
            world_m[i, 1] = hit_xyz[k, 1]
            world_m[i, 2] = hit_xyz[k, 2]
            has_world[i] = True
            status[i] = STATUS_UNKNOWN
    return sky


@njit(**JIT_OPTIONS)
def select_new_on_ground(slots, n, has_world, world_m, out_index, out_xy):
    """The new particles of ``slots[:n]`` that landed (have a world position), with their
    positions, for their first flow query. Returns their number."""
    k = 0
    for q in range(n):
        i = slots[q]
        if has_world[i]:
            out_index[k] = i
            out_xy[k, 0] = world_m[i, 0]
            out_xy[k, 1] = world_m[i, 1]
            k += 1
    return k


@njit(**JIT_OPTIONS)
def drop_unseen(slots, n, hit_kind, unknown, alive, ids, counters, has_world):
    """Free the new particles of ``slots[:n]`` whose ray met a part of the view with no
    surface tile yet (``hit_kind == unknown``): where they land is not known, so they are not
    placed (the Poisson fill tries again once the tile is there). Returns how many."""
    dropped = 0
    for k in range(n):
        if hit_kind[k] == unknown:
            i = slots[k]
            has_world[i] = False
            free_particle(i, alive, ids, counters)
            dropped += 1
    return dropped
