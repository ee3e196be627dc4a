"""Advection kernels: which particles ask the flow, then the terrain-layer status machine.

Re-does Proland's ``TerrainParticleLayer::moveParticles`` (reference §3.3):

| status            | action                                                               |
|-------------------|----------------------------------------------------------------------|
| INSIDE / UNKNOWN  | query. INSIDE → INSIDE, store the velocity. Not inside on the first   |
|                   | query → OUTSIDE (velocity 0), and NEAR + removed if a screen          |
|                   | neighbour is INSIDE. Not inside later → LEAVING, keep the velocity.   |
| LEAVING           | query. INSIDE → INSIDE. Else keep drifting if a neighbour is INSIDE,  |
|                   | otherwise stop: OUTSIDE.                                              |
| OUTSIDE           | no query; NEAR + removed if a neighbour is INSIDE.                    |

Each frame the particles first move (``position += velocity · dt``, explicit Euler, with the
velocity of their last query), then ask the flow at their new position, so a status always
describes where the particle is now. Unlike Proland, the particle's altitude follows the water
surface (or the ground) under it, new particles get their first answer when they are placed,
and a particle whose flow tile is not ready yet waits instead of being treated as outside.
"""
from __future__ import annotations

import math

from numba import njit

from riverflow.kernels._jit import JIT_OPTIONS
from riverflow.kernels.lifecycle import free_particle

STATUS_UNKNOWN = 0
STATUS_INSIDE = 1
STATUS_LEAVING = 2
STATUS_NEAR = 3
STATUS_OUTSIDE = 4
STATUS_OUTSIDE_DOMAIN = 6
STATUS_ON_SKY = 7


@njit(**JIT_OPTIONS)
def select_flow_queries(alive, has_world, status, world_m, out_index, out_xy):
    """Gather the particles that ask the flow this frame (INSIDE, UNKNOWN or LEAVING, with a
    world position). Writes ``out_index`` (C,) int32 and ``out_xy`` (C, 2) float64 [m];
    returns their number. (Each is answered from the finest cached flow tile under it: which
    tiles are cached, at which level, is the view's choice: ``select_view_tiles``.)"""
    n = 0
    for i in range(alive.shape[0]):
        if not alive[i] or not has_world[i]:
            continue
        s = status[i]
        if s != STATUS_INSIDE and s != STATUS_UNKNOWN and s != STATUS_LEAVING:
            continue
        out_index[n] = i
        out_xy[n, 0] = world_m[i, 0]
        out_xy[n, 1] = world_m[i, 1]
        n += 1
    return n


@njit(**JIT_OPTIONS)
def _inside_neighbour(i, screen_px, status, alive, cell_px, gw, gh, cell_count, cell_items,
                      reach_px):
    """Is a live INSIDE particle within ``reach_px`` of particle i on screen (last frame's grid)?"""
    x = screen_px[i, 0]
    y = screen_px[i, 1]
    cx = min(max(int(math.floor(x / cell_px)), 0), gw - 1)
    cy = min(max(int(math.floor(y / cell_px)), 0), gh - 1)
    r2 = reach_px * reach_px
    for ny in range(max(cy - 1, 0), min(cy + 2, gh)):
        for nx in range(max(cx - 1, 0), min(cx + 2, gw)):
            c = ny * gw + nx
            for q in range(cell_count[c]):
                j = cell_items[c, q]
                if j == i or not alive[j] or status[j] != STATUS_INSIDE:
                    continue
                dx = screen_px[j, 0] - x
                dy = screen_px[j, 1] - y
                if dx * dx + dy * dy < r2:
                    return True
    return False


@njit(**JIT_OPTIONS)
def move_particles(alive, has_world, world_m, velocity_mps, status, dt_s, water_m, ground_m,
                   grid_x, grid_y, grid_cell_m):
    """Explicit Euler step of the INSIDE and LEAVING particles with the velocity of their last
    flow query, ``dt_s`` [s] (speed factor included). ``water_m`` / ``ground_m`` (ny, nx)
    float32 are the water level (NaN where dry) and the terrain on a grid at (grid_x, grid_y)
    with ``grid_cell_m`` spacing: a moved particle takes the water altitude (the ground's where
    dry). Returns the number moved."""
    moved = 0
    for i in range(alive.shape[0]):
        if not alive[i] or not has_world[i]:
            continue
        if status[i] != STATUS_INSIDE and status[i] != STATUS_LEAVING:
            continue
        vx = velocity_mps[i, 0]
        vy = velocity_mps[i, 1]
        if vx == 0.0 and vy == 0.0:
            continue
        x = world_m[i, 0] + vx * dt_s
        y = world_m[i, 1] + vy * dt_s
        if not (math.isfinite(x) and math.isfinite(y)):
            velocity_mps[i, 0] = 0.0
            velocity_mps[i, 1] = 0.0
            continue
        world_m[i, 0] = x
        world_m[i, 1] = y
        z = _surface(x, y, water_m, ground_m, grid_x, grid_y, grid_cell_m)
        if math.isfinite(z):
            world_m[i, 2] = z
        moved += 1
    return moved


@njit(**JIT_OPTIONS)
def apply_flow_status(
    alive, velocity_mps, status, first_query, screen_px,
    n_query, query_index, query_status, query_velocity,
    cell_px, gw, gh, cell_count, cell_items, reach_px,
):
    """The status machine, from the flow's answers at the particles' current positions.

    ``query_index[:n_query]`` are the particles that asked, with the answers ``query_status``
    (N,) uint8 and ``query_velocity`` (N, 2) float32 [m/s]. The neighbour grid (``cell_count``,
    ``cell_items``, cells of ``cell_px``) is the last Poisson grid. Returns the number whose
    flow tile is not ready (they wait, unchanged).
    """
    waiting = 0
    for k in range(n_query):
        i = query_index[k]
        qs = query_status[k]
        s = status[i]
        if qs == STATUS_UNKNOWN:  # its flow tile is not ready yet
            waiting += 1
            continue
        if qs == STATUS_INSIDE:
            status[i] = STATUS_INSIDE
            velocity_mps[i, 0] = query_velocity[k, 0]
            velocity_mps[i, 1] = query_velocity[k, 1]
        elif s == STATUS_LEAVING:
            if not _inside_neighbour(i, screen_px, status, alive, cell_px, gw, gh, cell_count,
                                     cell_items, reach_px):
                status[i] = STATUS_OUTSIDE
                velocity_mps[i, 0] = 0.0
                velocity_mps[i, 1] = 0.0
        elif first_query[i] or s == STATUS_UNKNOWN:
            status[i] = STATUS_OUTSIDE
            velocity_mps[i, 0] = 0.0
            velocity_mps[i, 1] = 0.0
        else:  # was INSIDE, now outside: coast on with the last velocity
            status[i] = STATUS_LEAVING
        first_query[i] = False
    return waiting


@njit(**JIT_OPTIONS)
def remove_outside_near_water(alive, ids, counters, status, screen_px, cell_px, gw, gh,
                              cell_count, cell_items, reach_px, wet_cells, removed_cells,
                              frame, every):
    """OUTSIDE particles with an INSIDE neighbour on screen give way (NEAR, removed), so that
    new samples may land in the river (Proland's NEAR rule). A particle is looked at once
    every ``every`` frames (staggered by id): a shore particle that lands on the land again is
    not replaced at every frame (Proland churns the whole shore each frame). ``wet_cells``
    (gw·gh,) uint8 is
    scratch (cells of the grid holding an INSIDE particle); the cells of removed particles are
    marked in ``removed_cells`` (gw·gh,) uint8 for the Poisson pass. Returns the number
    removed."""
    for c in range(gw * gh):
        wet_cells[c] = 0
        for q in range(cell_count[c]):
            j = cell_items[c, q]
            if alive[j] and status[j] == STATUS_INSIDE:
                wet_cells[c] = 1
                break
    removed = 0
    for i in range(alive.shape[0]):
        if not alive[i] or status[i] != STATUS_OUTSIDE or (ids[i] + frame) % every != 0:
            continue
        cx = min(max(int(math.floor(screen_px[i, 0] / cell_px)), 0), gw - 1)
        cy = min(max(int(math.floor(screen_px[i, 1] / cell_px)), 0), gh - 1)
        near_wet = False
        for ny in range(max(cy - 1, 0), min(cy + 2, gh)):
            for nx in range(max(cx - 1, 0), min(cx + 2, gw)):
                if wet_cells[ny * gw + nx]:
                    near_wet = True
        if near_wet and _inside_neighbour(i, screen_px, status, alive, cell_px, gw, gh,
                                          cell_count, cell_items, reach_px):
            status[i] = STATUS_NEAR
            free_particle(i, alive, ids, counters)
            removed_cells[cy * gw + cx] = 1
            removed += 1
    return removed


@njit(**JIT_OPTIONS)
def _bilinear(grid, gx, gy):
    ny, nx = grid.shape
    if not (gx >= 0.0 and gy >= 0.0 and gx <= nx - 1 and gy <= ny - 1):
        return math.nan
    i = min(int(gx), nx - 2)
    j = min(int(gy), ny - 2)
    u = gx - i
    v = gy - j
    return ((1.0 - v) * ((1.0 - u) * grid[j, i] + u * grid[j, i + 1])
            + v * ((1.0 - u) * grid[j + 1, i] + u * grid[j + 1, i + 1]))


@njit(**JIT_OPTIONS)
def _surface(x, y, water_m, ground_m, grid_x, grid_y, grid_cell_m):
    """Water altitude at (x, y) [m]; the ground's where the water grid has no value."""
    gx = (x - grid_x) / grid_cell_m
    gy = (y - grid_y) / grid_cell_m
    z = _bilinear(water_m, gx, gy)
    if math.isfinite(z):
        return z
    return _bilinear(ground_m, gx, gy)
