"""Poisson-disk maintenance of the screen-space particles (Proland ScreenParticleLayer).

Re-does ``removeOldParticles`` and ``addNewParticles`` (reference §3.3) on a screen neighbour
grid of cells ``cell_px`` ≈ 4r wide, each particle in the cell of its position (a 3 × 3 cell
lookup finds every neighbour within 4r):

* **cull**: in slot order, a live particle that is not fading out and has an accepted
  neighbour closer than ``cull_px`` (≈ 1.96 r) fades out (reason POISSON_DISK); the others are
  accepted into the grid;
* **fill** (Dunbar & Humphreys boundary sampling): a candidate P gets the arcs of directions in
  which a point 2r away is at least ``spawn_gap_px`` from every neighbour (Proland: 2r); new
  particles are placed at random angles of those arcs (each blocks the angles that would bring
  the next one closer than the gap: ±π/3 for a gap of 2r) and become candidates; a uniform
  random start when the screen is empty; a clean stop when the pool is full.

Proland visits every particle each frame; here only the particles around *dirty* cells are
candidates (cells where particles were removed, cells that are empty or sparse, where a fade
began or a crowded particle was culled, plus a rolling band of rows so that slow stretching is caught
too). That keeps the cost proportional
to what changes (docs/deviations.md).
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from riverflow.kernels._jit import JIT_OPTIONS
from riverflow.kernels.lifecycle import allocate_particle, is_fading_out, start_fade_out

REASON_OUTSIDE_VIEWPORT = 2
REASON_POISSON_DISK = 3
STATUS_UNKNOWN = 0

MAX_ARCS = 64
ROLLING_BANDS = 16
"""The rolling dirty band covers 1/ROLLING_BANDS of the grid rows each frame."""

TWO_PI = 2.0 * math.pi


@njit(**JIT_OPTIONS)
def _cell_of(x, y, cell_px, gw, gh):
    cx = min(max(int(math.floor(x / cell_px)), 0), gw - 1)
    cy = min(max(int(math.floor(y / cell_px)), 0), gh - 1)
    return cx, cy


@njit(**JIT_OPTIONS)
def cull_crowded_particles(
    alive, screen_px, birth_s, fade_reason, status, now_s, dt_s, fade_in_s, active_s, fade_out_s,
    cull_px, cell_px, gw, gh, cell_count, cell_items, removed_cells, dirty, frame, sparse_below,
):
    """Rebuild the neighbour grid with the accepted particles; fade out the crowded ones.

    ``cell_count`` (gw·gh,) int32 and ``cell_items`` (gw·gh, K) int32 are rebuilt;
    ``removed_cells`` (gw·gh,) uint8 marks cells where other systems removed particles since
    the last pass (read, then cleared); ``dirty`` (gw·gh,)
    uint8 is written (bit 1: holes may be here — particles were removed there, it holds fewer than
    ``sparse_below``, or lies in this frame's rolling band; bit 4: the cell is empty, so its
    neighbours' particles are candidates too). Returns the number faded out.
    """
    n_cells = gw * gh
    k_max = cell_items.shape[1]
    for c in range(n_cells):
        cell_count[c] = 0
        dirty[c] = 0
    cull2 = cull_px * cull_px
    faded = 0
    for i in range(alive.shape[0]):
        if not alive[i]:
            continue
        x = screen_px[i, 0]
        y = screen_px[i, 1]
        cx, cy = _cell_of(x, y, cell_px, gw, gh)
        if is_fading_out(i, birth_s, now_s, fade_in_s, active_s):
            if now_s - birth_s[i] - fade_in_s - active_s <= dt_s:  # its fade began this frame
                dirty[cy * gw + cx] = 1
            continue
        close = False
        # only the (at most 2 × 2) cells the disc of radius cull_px overlaps
        x0 = max(int(math.floor((x - cull_px) / cell_px)), 0)
        x1 = min(int(math.floor((x + cull_px) / cell_px)), gw - 1)
        y0 = max(int(math.floor((y - cull_px) / cell_px)), 0)
        y1 = min(int(math.floor((y + cull_px) / cell_px)), gh - 1)
        for ny in range(y0, y1 + 1):
            for nx in range(x0, x1 + 1):
                c = ny * gw + nx
                for q in range(cell_count[c]):
                    j = cell_items[c, q]
                    dx = screen_px[j, 0] - x
                    dy = screen_px[j, 1] - y
                    if dx * dx + dy * dy < cull2:
                        close = True
                        break
                if close:
                    break
            if close:
                break
        c = cy * gw + cx
        if close or cell_count[c] >= k_max:
            if start_fade_out(i, birth_s, now_s, fade_in_s, active_s, fade_out_s):
                fade_reason[i] = REASON_POISSON_DISK
                faded += 1
            dirty[c] = 1
            continue
        cell_items[c, cell_count[c]] = i
        cell_count[c] += 1
    band = frame % ROLLING_BANDS
    for cy in range(gh):
        for cx in range(gw):
            c = cy * gw + cx
            if cell_count[c] == 0:
                dirty[c] = 1 | 4  # a hole: its neighbours' particles border it
            elif (removed_cells[c] or cell_count[c] < sparse_below
                  or cy % ROLLING_BANDS == band):
                dirty[c] = 1
            removed_cells[c] = 0
    return faded


@njit(**JIT_OPTIONS)
def _remove_arc(lo, hi, n, a, b):
    """Remove [a, b) (0 ≤ a < b ≤ 2π) from the free arcs lo[:n], hi[:n]; returns the new n."""
    out = n
    k = 0
    while k < out:
        l0 = lo[k]
        h0 = hi[k]
        if b <= l0 or a >= h0:
            k += 1
            continue
        if a > l0 and b < h0:
            if out < MAX_ARCS:  # split in two
                lo[out] = b
                hi[out] = h0
                out += 1
            hi[k] = a
            k += 1
        elif a > l0:
            hi[k] = a
            k += 1
        elif b < h0:
            lo[k] = b
            k += 1
        else:  # covered: drop it
            out -= 1
            lo[k] = lo[out]
            hi[k] = hi[out]
    return out


@njit(**JIT_OPTIONS)
def _remove_wrapped(lo, hi, n, centre, half):
    """Remove the arc centre ± half (radians, any centre) from the free arcs."""
    if half >= math.pi:
        return 0
    a = (centre - half) % TWO_PI
    b = a + 2.0 * half
    if b <= TWO_PI:
        return _remove_arc(lo, hi, n, a, b)
    n = _remove_arc(lo, hi, n, a, TWO_PI)
    return _remove_arc(lo, hi, n, 0.0, b - TWO_PI)


@njit(**JIT_OPTIONS)
def _grid_insert(i, x, y, cell_px, gw, gh, cell_count, cell_items):
    """Put particle i (at x, y) into its grid cell, if the cell has room."""
    cx, cy = _cell_of(x, y, cell_px, gw, gh)
    c = cy * gw + cx
    if cell_count[c] < cell_items.shape[1]:
        cell_items[c, cell_count[c]] = i
        cell_count[c] += 1


@njit(**JIT_OPTIONS)
def _new_particle(alive, ids, counters, birth_s, intensity, screen_px, fade_reason, has_world,
                  velocity_mps, status, first_query, offset_m, x, y, now_s, off_lo_x, off_lo_y,
                  off_hi_x, off_hi_y):
    i = allocate_particle(alive, ids, counters, 0)
    if i < 0:
        return -1
    birth_s[i] = now_s
    intensity[i] = 0.0
    screen_px[i, 0] = x
    screen_px[i, 1] = y
    fade_reason[i] = 0
    has_world[i] = False
    velocity_mps[i, 0] = 0.0
    velocity_mps[i, 1] = 0.0
    status[i] = STATUS_UNKNOWN
    first_query[i] = True
    offset_m[i, 0] = off_lo_x + (off_hi_x - off_lo_x) * np.random.random()
    offset_m[i, 1] = off_lo_y + (off_hi_y - off_lo_y) * np.random.random()
    return i


@njit(**JIT_OPTIONS)
def fill_poisson_holes(
    alive, ids, counters, birth_s, intensity, screen_px, fade_reason, has_world, velocity_mps,
    status, first_query, offset_m,
    now_s, fade_in_s, active_s, radius_px, spawn_gap_px, width_px, height_px, cell_px, gw, gh,
    cell_count, cell_items, dirty, seed, off_lo_x, off_lo_y, off_hi_x, off_hi_y,
    candidates, new_slots,
):
    """Fill the holes of the Poisson disk around dirty cells by boundary sampling.

    Writes the slots of the new particles into ``new_slots`` (C,) int32 and returns their
    number (they still need a world position). ``candidates`` is (C,) int32 scratch.
    """
    np.random.seed(seed)
    if width_px <= 0 or height_px <= 0:
        return 0
    n_cand = 0
    any_accepted = False
    for cy in range(gh):
        for cx in range(gw):
            c = cy * gw + cx
            if cell_count[c] > 0:
                any_accepted = True
            if not dirty[c] & 1:
                continue
            # the accepted particles of this cell border the hole; of an empty cell, those
            # of its neighbours do
            reach = 1 if dirty[c] & 4 else 0
            for ny in range(max(cy - reach, 0), min(cy + reach + 1, gh)):
                for nx in range(max(cx - reach, 0), min(cx + reach + 1, gw)):
                    d = ny * gw + nx
                    if dirty[d] & 2:
                        continue
                    for q in range(cell_count[d]):
                        j = cell_items[d, q]
                        if 0.0 <= screen_px[j, 0] < width_px and 0.0 <= screen_px[j, 1] < height_px:
                            candidates[n_cand] = j
                            n_cand += 1
                    dirty[d] |= 2  # its particles are queued already
    if not any_accepted:
        # no accepted particle: fading ones that are still on screen, else one at random
        for i in range(alive.shape[0]):
            if (alive[i] and fade_reason[i] != REASON_OUTSIDE_VIEWPORT
                    and 0.0 <= screen_px[i, 0] < width_px and 0.0 <= screen_px[i, 1] < height_px):
                candidates[n_cand] = i
                n_cand += 1
    n_new = 0
    if n_cand == 0:
        if any_accepted:
            return 0  # no hole anywhere
        x = np.random.random() * width_px
        y = np.random.random() * height_px
        i = _new_particle(alive, ids, counters, birth_s, intensity, screen_px, fade_reason,
                          has_world, velocity_mps, status, first_query, offset_m, x, y, now_s,
                          off_lo_x, off_lo_y, off_hi_x, off_hi_y)
        if i < 0:
            return 0
        _grid_insert(i, x, y, cell_px, gw, gh, cell_count, cell_items)
        new_slots[n_new] = i
        n_new += 1
        candidates[0] = i
        n_cand = 1
    lo = np.empty(MAX_ARCS)
    hi = np.empty(MAX_ARCS)
    r2 = 2.0 * radius_px               # new particles are placed 2r from a candidate
    gap = spawn_gap_px                 # and at least this far from every other particle
    reach = r2 + gap
    # a new particle at angle θ blocks θ ± this for the next ones around the same candidate
    self_block = 2.0 * math.asin(min(gap / (2.0 * r2), 1.0))
    while n_cand > 0:
        k = int(np.random.random() * n_cand)
        p = candidates[k]
        n_cand -= 1
        candidates[k] = candidates[n_cand]
        px = screen_px[p, 0]
        py = screen_px[p, 1]
        lo[0] = 0.0
        hi[0] = TWO_PI
        n_arcs = 1
        cx, cy = _cell_of(px, py, cell_px, gw, gh)
        reach_sq = reach * reach
        for ny in range(max(cy - 1, 0), min(cy + 2, gh)):
            for nx in range(max(cx - 1, 0), min(cx + 2, gw)):
                c = ny * gw + nx
                for q in range(cell_count[c]):
                    if n_arcs == 0:
                        break
                    j = cell_items[c, q]
                    dx = screen_px[j, 0] - px
                    dy = screen_px[j, 1] - py
                    d2 = dx * dx + dy * dy
                    if j != p and d2 < reach_sq:
                        # |P + 2r·u − Q| < gap  ⇔  cos∠(u, PQ) > (4r² + d² − gap²) / (4r·d)
                        d = math.sqrt(d2)
                        cos_half = (r2 * r2 + d2 - gap * gap) / (2.0 * r2 * max(d, 1e-9))
                        n_arcs = _remove_wrapped(lo, hi, n_arcs, math.atan2(dy, dx),
                                                 math.acos(min(max(cos_half, -1.0), 1.0)))
        while n_arcs > 0:
            a = int(np.random.random() * n_arcs)
            theta = lo[a] + (hi[a] - lo[a]) * np.random.random()
            n_arcs = _remove_wrapped(lo, hi, n_arcs, theta, self_block)
            x = px + r2 * math.cos(theta)
            y = py + r2 * math.sin(theta)
            if not (0.0 <= x < width_px and 0.0 <= y < height_px):
                continue
            i = _new_particle(alive, ids, counters, birth_s, intensity, screen_px, fade_reason,
                              has_world, velocity_mps, status, first_query, offset_m, x, y,
                              now_s, off_lo_x, off_lo_y, off_hi_x, off_hi_y)
            if i < 0:
                return n_new  # the pool is full: stop cleanly
            _grid_insert(i, x, y, cell_px, gw, gh, cell_count, cell_items)
            new_slots[n_new] = i
            n_new += 1
            candidates[n_cand] = i
            n_cand += 1
    return n_new
