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
from typing import NamedTuple

import numpy as np
from numba import njit

from riverflow.kernels._jit import JIT_OPTIONS, is_finite
from riverflow.kernels.lifecycle import allocate_particle, free_particle
from riverflow.kernels.surface_tiles import NO_TILE_YET, hint_at, surface_altitude

STATUS_UNKNOWN = 0
STATUS_INSIDE = 1
STATUS_LEAVING = 2
STATUS_NEAR = 3
STATUS_OUTSIDE = 4
STATUS_OUTSIDE_DOMAIN = 6
STATUS_ON_SKY = 7
HIT_WATER = 2
"""riverflow.kernels.raycast.HIT_WATER"""


class Probes(NamedTuple):
    """Screen points whose rays were cast (:func:`place_at_seen_water`), P of them."""

    xy: np.ndarray              # (P, 2) float32 [px]
    hit: np.ndarray             # (P,) uint8 what the ray hit (HIT_WATER: water)
    hit_xyz: np.ndarray         # (P, 3) float64 [m] where
    flow_status: np.ndarray     # (P,) uint8 FlowStatus there
    flow_velocity: np.ndarray   # (P, 2) float32 [m/s] the flow's velocity there


@njit(inline="always", **JIT_OPTIONS)
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
def move_particles(n_slots, alive, has_world, world_m, velocity_mps, status, dt_s, surface,
                   frame, z_every, velocity_every, always_box, z_box, out_index, out_xy):
    """Explicit Euler step of the INSIDE and LEAVING particles with the velocity of their last
    flow query, ``dt_s`` [s] (speed factor included), and the list of the particles that ask
    the flow this frame, in the same pass over slots [0, ``n_slots``) (the pool's slot bound).

    ``surface`` is the view's :class:`~riverflow.kernels.surface_tiles.SurfaceTiles`: a moved
    particle takes the water altitude (the ground's where dry) once every ``z_every`` frames
    (a power of two), staggered by slot, and every frame inside ``z_box`` (4,) [m] xmin,
    ymin, xmax, ymax (over a fall, where the water's level changes by metres a second) (the lookups miss the cache; over 16 frames the level
    under a particle changes by at most 1.6 cm in the test flight, against a 0.25 m bound);
    where no tile is there yet it keeps its altitude.

    The particles that ask the flow (INSIDE, UNKNOWN or LEAVING, with a world position) go to
    ``out_index`` (C,) int32 and, at their new positions, ``out_xy`` (C, 2) float64 [m]: first
    the ``n_velocity`` that need a velocity (UNKNOWN, LEAVING, and INSIDE ones once every
    ``velocity_every`` frames (a power of two), staggered by slot, or always inside
    ``always_box`` (4,) [m] xmin, ymin, xmax, ymax: moving obstacles, falls), then from the end of
    the arrays backwards the ``n_status`` INSIDE ones that ask only whether they are still
    inside (the velocity field changes over metres, they over centimetres a frame). Each is
    answered from the finest cached flow tile under it (which tiles are cached, at which
    level, is the view's choice: ``select_view_tiles``). Returns (moved, n_velocity,
    n_status).
    """
    moved = 0
    n = 0
    n_status = 0
    last = out_index.shape[0] - 1
    for i in range(min(n_slots, alive.shape[0])):
        if not alive[i] or not has_world[i]:
            continue
        s = status[i]
        if s != STATUS_INSIDE and s != STATUS_LEAVING:
            if s == STATUS_UNKNOWN:
                out_index[n] = i
                out_xy[n, 0] = world_m[i, 0]
                out_xy[n, 1] = world_m[i, 1]
                n += 1
            continue
        x = world_m[i, 0]
        y = world_m[i, 1]
        vx = velocity_mps[i, 0]
        vy = velocity_mps[i, 1]
        if vx != 0.0 or vy != 0.0:
            nx = x + vx * dt_s
            ny = y + vy * dt_s
            if is_finite(nx) and is_finite(ny):
                x = nx
                y = ny
                world_m[i, 0] = x
                world_m[i, 1] = y
                if ((i + frame) & (z_every - 1) == 0
                        or (z_box[0] <= x <= z_box[2] and z_box[1] <= y <= z_box[3])):
                    z = surface_altitude(surface, x, y)
                    if is_finite(z):
                        world_m[i, 2] = z
                moved += 1
            else:
                velocity_mps[i, 0] = 0.0
                velocity_mps[i, 1] = 0.0
        if (s == STATUS_INSIDE and (i + frame) & (velocity_every - 1) != 0
                and not (always_box[0] <= x <= always_box[2]
                         and always_box[1] <= y <= always_box[3])):
            k = last - n_status
            n_status += 1
        else:
            k = n
            n += 1
        out_index[k] = i
        out_xy[k, 0] = x
        out_xy[k, 1] = y
    return moved, n, n_status


@njit(**JIT_OPTIONS)
def apply_flow_status(
    alive, velocity_mps, status, first_query, screen_px,
    n_query, query_index, query_status, query_velocity, keep_velocity_from,
    cell_px, gw, gh, cell_count, cell_items, reach_px,
):
    """The status machine, from the flow's answers at the particles' current positions.

    ``query_index[:n_query]`` are the particles that asked, with the answers ``query_status``
    (N,) uint8 and ``query_velocity`` (N, 2) float32 [m/s]; those from ``keep_velocity_from``
    on asked for their status alone and keep their velocity. The neighbour grid (``cell_count``,
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
            if k < keep_velocity_from:
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


@njit(inline="always", **JIT_OPTIONS)
def _to_screen(m, x, y, z, width_px, height_px):
    """(screen x, screen y [px], in front of the eye) of world point (x, y, z) [m] through the
    column-vector clip-from-world matrix ``m`` (as ``project_particles``)."""
    cw = m[3, 0] * x + m[3, 1] * y + m[3, 2] * z + m[3, 3]
    if not cw > 1e-9:
        return 0.0, 0.0, False
    px = ((m[0, 0] * x + m[0, 1] * y + m[0, 2] * z + m[0, 3]) / cw * 0.5 + 0.5) * width_px
    py = ((m[1, 0] * x + m[1, 1] * y + m[1, 2] * z + m[1, 3]) / cw * 0.5 + 0.5) * height_px
    return px, py, True


HINT_TRACK = np.array([0.0, -0.03, 0.03, -0.1, 0.1, -0.3, 0.3, 1.0])
"""Where the water hint of a land particle is looked for: the nearest deep water to points
of its ray's ground track, at these fractions of its horizontal distance from the eye
beyond (+) or before (−) it; the one that projects nearest the particle wins. Seen at a
grazing angle, the water a few pixels from the particle lies far along its line of sight,
not next to it in the world."""


@njit(inline="always", **JIT_OPTIONS)
def _water_hint(x, y, sx, sy, eye_x, eye_y, m, width_px, height_px, surface, out, k):
    """Write into ``out[k]`` the water hint (x, y, level) [m] of a land particle at world
    (x, y) and screen (sx, sy): of the hints (deep water near a hint node: the view's hints
    tiles, :class:`~riverflow.kernels.surface_tiles.SurfaceTiles`) at the nodes nearest the
    points of :data:`HINT_TRACK`, the one whose projection by ``m`` (clip from world) lies
    nearest (sx, sy); x = +inf when there is none. Returns False when a track point lies in a
    leaf of the view whose hints tile is not made yet (the hint is looked for again later);
    points outside the view's leaves have no hints and never will."""
    hints = surface.hints
    complete = True
    dx = x - eye_x
    dy = y - eye_y
    best = math.inf
    out[k, 0] = math.inf
    out[k, 1] = 0.0
    out[k, 2] = 0.0
    last = -1
    for s in range(HINT_TRACK.shape[0]):
        f = HINT_TRACK[s]
        slot, j, i = hint_at(surface, x + f * dx, y + f * dy)
        if slot < 0:
            complete = complete and slot != NO_TILE_YET
            continue
        t = (slot * hints.shape[1] + j) * hints.shape[2] + i
        if t == last or not hints[slot, j, i, 0] < math.inf:
            continue
        last = t
        hx = hints[slot, j, i, 0]
        hy = hints[slot, j, i, 1]
        hz = hints[slot, j, i, 2]
        px, py, in_front = _to_screen(m, hx, hy, hz, width_px, height_px)
        if not in_front:
            continue
        d = (px - sx) * (px - sx) + (py - sy) * (py - sy)
        if d < best:
            best = d
            out[k, 0] = hx
            out[k, 1] = hy
            out[k, 2] = hz
    return complete


@njit(inline="always", **JIT_OPTIONS)
def _carrier_near(x, y, radius2, inside_only, cell_px, gw, gh, acc_start, acc_slot, acc_xy,
                  carrier_cells, status, alive):
    """Is a live INSIDE (``inside_only``) or INSIDE-or-LEAVING particle of the accepted ones
    (by cell, pruned by ``carrier_cells``) closer to (x, y) than √``radius2`` (≤ ``cell_px``)?"""
    bit = 1 if inside_only else 2
    cx = min(max(int(math.floor(x / cell_px)), 0), gw - 1)
    cy = min(max(int(math.floor(y / cell_px)), 0), gh - 1)
    for ny in range(max(cy - 1, 0), min(cy + 2, gh)):
        for nx in range(max(cx - 1, 0), min(cx + 2, gw)):
            c = ny * gw + nx
            if not carrier_cells[c] & bit:
                continue
            for k in range(acc_start[c], acc_start[c + 1]):
                j = acc_slot[k]
                st = status[j]
                carrier = st == STATUS_INSIDE or (st == STATUS_LEAVING and not inside_only)
                dx = acc_xy[k, 0] - x
                dy = acc_xy[k, 1] - y
                if carrier and alive[j] and dx * dx + dy * dy < radius2:
                    return True
    return False


@njit(**JIT_OPTIONS)
def check_outside_near_water(pool, grid, now_s, fade_at_s, reach_px, frame, probe_every,
                             replace_every, cover_px, width_px, height_px, clip_from_world,
                             eye_x, eye_y, surface, out_xy, out_owner):
    """Where should the river get particles that it has not? Proland's NEAR rule, plus probes
    guided by where the water is in the world.

    The river's particles here (of ``pool``, :class:`~riverflow.kernels.lifecycle.Pool`) are
    those the last Poisson pass accepted, by cell of ``grid``
    (:class:`~riverflow.kernels.poisson_cull.Grid`: rows ``acc_start[c]`` …
    ``acc_start[c + 1]`` of ``acc_slot`` and ``acc_xy``, their screen positions, which the
    screen positions still are), with their status now; ``carrier_cells`` (bit 1: an INSIDE
    one, bit 2: an INSIDE or LEAVING one, as that pass saw them) prunes the cells to look in.
    The viewport is ``width_px`` × ``height_px`` (this frame's: the grid's may be the last
    one's).

    Each steady (age below ``fade_at_s``) OUTSIDE particle is looked at once every
    ``probe_every`` frames, staggered by slot (slots ≡ −frame mod ``probe_every``;
    ``probe_every`` and ``replace_every`` are powers of two), in slot order:

    * when an INSIDE particle lies within ``reach_px`` (≤ ``cell_px``) on screen and
      (slot + frame) % ``replace_every`` == 0, it gives way (NEAR, removed; its cell marked in
      ``removed_cells``), as Proland replaces it every frame: the refill may land on water,
      and freshly packed shores keep the Poisson disk dense;
    * otherwise it *probes* its water hint: deep water near its line of sight from the eye
      at (``eye_x``, ``eye_y``) (:func:`_water_hint`; ``water_hint_m`` (C, 3) float32 x, y,
      level [m], found once per particle from the hints tiles of ``surface`` and kept while
      ``hint_id`` equals its id: an OUTSIDE particle never moves; x = +inf: none). Projected with
      ``clip_from_world`` (the view the screen positions were projected with), a hint on
      screen within ``reach_px`` of the particle and farther than ``cover_px`` (≤
      ``cell_px``) from every INSIDE or LEAVING particle is a probe: its ray is cast next,
      and a probe that sees water gets a particle (:func:`place_at_seen_water`). This finds
      water that no particle has landed on, with no INSIDE particle nearby.

    Probes go to ``out_xy`` (P, 2) float32 and their particle's slot to ``out_owner`` (P,)
    int32. Returns (removed, probes).
    """
    alive, ids, counters, status = pool.alive, pool.ids, pool.counters, pool.status
    screen_px, world_m, birth_s = pool.screen_px, pool.world_m, pool.birth_s
    water_hint_m, hint_id = pool.water_hint_m, pool.hint_id
    cell_px, gw, gh = grid.cell_px, grid.gw, grid.gh
    acc_start, acc_slot, acc_xy = grid.acc_start, grid.acc_slot, grid.acc_xy
    carrier_cells, removed_cells = grid.carrier_cells, grid.removed_cells
    cap = min(counters[2], alive.shape[0])  # (no live slot beyond the pool's slot bound)
    reach2 = reach_px * reach_px
    cover2 = cover_px * cover_px
    m = clip_from_world
    replace_mask = replace_every - 1
    removed = 0
    n = 0
    first = (probe_every - (frame & (probe_every - 1))) & (probe_every - 1)
    for i in range(first, cap, probe_every):
        if not alive[i] or status[i] != STATUS_OUTSIDE or now_s - birth_s[i] >= fade_at_s:
            continue
        x = screen_px[i, 0]
        y = screen_px[i, 1]
        if (i + frame) & replace_mask == 0:
            # an INSIDE particle within reach: give way
            if _carrier_near(x, y, reach2, True, cell_px, gw, gh, acc_start, acc_slot, acc_xy,
                             carrier_cells, status, alive):
                cx = min(max(int(math.floor(x / cell_px)), 0), gw - 1)
                cy = min(max(int(math.floor(y / cell_px)), 0), gh - 1)
                status[i] = STATUS_NEAR
                free_particle(i, alive, ids, counters)
                removed_cells[cy * gw + cx] = 1
                removed += 1
                continue
        if hint_id[i] != ids[i]:
            if _water_hint(world_m[i, 0], world_m[i, 1], x, y, eye_x, eye_y, m, width_px,
                           height_px, surface, water_hint_m, i):
                hint_id[i] = ids[i]
        hx = water_hint_m[i, 0]
        if not hx < math.inf:
            continue
        px, py, in_front = _to_screen(m, hx, water_hint_m[i, 1], water_hint_m[i, 2], width_px,
                                      height_px)
        if not in_front:
            continue
        if (px - x) * (px - x) + (py - y) * (py - y) >= reach2:
            continue
        if not (0.0 <= px < width_px and 0.0 <= py < height_px):
            continue
        if _carrier_near(px, py, cover2, False, cell_px, gw, gh, acc_start, acc_slot, acc_xy,
                         carrier_cells, status, alive):
            continue  # covered: an INSIDE or LEAVING particle closer than cover_px
        out_xy[n, 0] = px
        out_xy[n, 1] = py
        out_owner[n] = i
        n += 1
    return removed, n


@njit(**JIT_OPTIONS)
def place_at_seen_water(pool, grid, probes, n, now_s, fade_in_s, active_s, gap_px, seed,
                        off_lo_x, off_lo_y, off_hi_x, off_hi_y):
    """A new particle of ``pool`` (:class:`~riverflow.kernels.lifecycle.Pool`) at each of the
    first ``n`` ``probes`` (:class:`Probes`) whose ray hit water inside the flow: the steady
    particles of ``grid``'s cells (:class:`~riverflow.kernels.poisson_cull.Grid`) closer than
    ``gap_px`` to it give way (NEAR, removed, cells marked in ``removed_cells``) unless one of
    them is in the water (INSIDE, LEAVING) or still waiting for its flow tile (UNKNOWN), or a
    particle placed here this frame is that close; then the probe is skipped. The new particle
    starts INSIDE with the flow's velocity, fading in, a random sprite offset in the box
    ``off_lo`` … ``off_hi`` [m] (seeded by ``seed``). Writes the grid's ``new_slots`` and
    returns (placed, removed)."""
    alive, ids, counters, birth_s = pool.alive, pool.ids, pool.counters, pool.birth_s
    intensity, screen_px, fade_reason = pool.intensity, pool.screen_px, pool.fade_reason
    has_world, world_m, velocity_mps = pool.has_world, pool.world_m, pool.velocity_mps
    status, first_query, offset_m = pool.status, pool.first_query, pool.offset_m
    cell_px, gw, gh = grid.cell_px, grid.gw, grid.gh
    cell_count, cell_items = grid.cell_count, grid.cell_items
    removed_cells, new_slots = grid.removed_cells, grid.new_slots
    probe_xy, hit, hit_xyz, flow_status, flow_velocity = probes
    np.random.seed(seed)
    gap2 = gap_px * gap_px
    fade_at = fade_in_s + active_s
    placed = 0
    removed = 0
    first_free = 0
    for k in range(n):
        if hit[k] != HIT_WATER or flow_status[k] != STATUS_INSIDE:
            continue
        x = probe_xy[k, 0]
        y = probe_xy[k, 1]
        ok = True
        for m in range(placed):
            j = new_slots[m]
            dx = screen_px[j, 0] - x
            dy = screen_px[j, 1] - y
            if dx * dx + dy * dy < gap2:
                ok = False
                break
        if not ok:
            continue
        cx = min(max(int(math.floor(x / cell_px)), 0), gw - 1)
        cy = min(max(int(math.floor(y / cell_px)), 0), gh - 1)
        for ny in range(max(cy - 1, 0), min(cy + 2, gh)):
            for nx in range(max(cx - 1, 0), min(cx + 2, gw)):
                c = ny * gw + nx
                for q in range(cell_count[c]):
                    j = cell_items[c, q]
                    s = status[j]
                    if not alive[j] or now_s - birth_s[j] >= fade_at:
                        continue
                    if s != STATUS_INSIDE and s != STATUS_LEAVING and s != STATUS_UNKNOWN:
                        continue
                    dx = screen_px[j, 0] - x
                    dy = screen_px[j, 1] - y
                    if dx * dx + dy * dy < gap2:
                        ok = False
        if not ok:
            continue
        for ny in range(max(cy - 1, 0), min(cy + 2, gh)):
            for nx in range(max(cx - 1, 0), min(cx + 2, gw)):
                c = ny * gw + nx
                for q in range(cell_count[c]):
                    j = cell_items[c, q]
                    if not alive[j] or now_s - birth_s[j] >= fade_at:
                        continue
                    dx = screen_px[j, 0] - x
                    dy = screen_px[j, 1] - y
                    if dx * dx + dy * dy < gap2:
                        status[j] = STATUS_NEAR
                        free_particle(j, alive, ids, counters)
                        removed_cells[c] = 1
                        removed += 1
        i = allocate_particle(alive, ids, counters, first_free)
        if i < 0:
            break  # the pool is full
        first_free = i + 1
        birth_s[i] = now_s
        intensity[i] = 0.0
        screen_px[i, 0] = x
        screen_px[i, 1] = y
        fade_reason[i] = 0
        has_world[i] = True
        world_m[i, 0] = hit_xyz[k, 0]
        world_m[i, 1] = hit_xyz[k, 1]
        world_m[i, 2] = hit_xyz[k, 2]
        velocity_mps[i, 0] = flow_velocity[k, 0]
        velocity_mps[i, 1] = flow_velocity[k, 1]
        status[i] = STATUS_INSIDE
        first_query[i] = False
        offset_m[i, 0] = off_lo_x + (off_hi_x - off_lo_x) * np.random.random()
        offset_m[i, 1] = off_lo_y + (off_hi_y - off_lo_y) * np.random.random()
        new_slots[placed] = i
        placed += 1
    return placed, removed
