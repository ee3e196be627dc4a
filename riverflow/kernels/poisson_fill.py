"""Poisson-disk maintenance of the screen-space particles, part 2: the fill (Proland
ScreenParticleLayer ``addNewParticles``, reference §3.3); part 1, the cull, is
:mod:`riverflow.kernels.poisson_cull`, which hands this the accepted particles by cell and the
dirty cells whose particles are candidates.

Dunbar & Humphreys boundary sampling: a candidate P gets the arcs of directions in which a
point 2r away is at least ``spawn_gap_px`` from every neighbour (Proland: 2r); new particles
are placed at random angles of those arcs (each blocks the angles that would bring the next
one closer than the gap: ±π/3 for a gap of 2r) and become candidates; a uniform random start
when the screen is empty; a clean stop when the pool is full. A table of the directions a
neighbour surely blocks, by where it is (:func:`blocked_direction_table`), rejects most
candidates (where the disk is whole) without trigonometry.
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from riverflow.kernels._jit import JIT_OPTIONS
from riverflow.kernels.lifecycle import allocate_particle

REASON_OUTSIDE_VIEWPORT = 2
STATUS_UNKNOWN = 0

MAX_ARCS = 64

TWO_PI = 2.0 * math.pi

DIRECTION_BINS = 64
"""Directions of the blocked-direction table: bit k of an entry is [k, k + 1) · 2π/64."""
ALL_DIRECTIONS = np.uint64(0xFFFFFFFFFFFFFFFF)
TABLE_CELLS_PER_R = 16
"""Cells of the blocked-direction table per radius r (r/16 px squares)."""
_BIN_COS = np.cos(TWO_PI * np.arange(DIRECTION_BINS + 1) / DIRECTION_BINS)
_BIN_SIN = np.sin(TWO_PI * np.arange(DIRECTION_BINS + 1) / DIRECTION_BINS)
"""cos, sin of the direction bins' ends (bin k is [k, k + 1) · 2π/64)."""
_EDGE_MARGIN = 1e-6
"""Relative margin [of 2r] by which a bin's ends must lie off screen to count as blocked."""


@njit(**JIT_OPTIONS)
def blocked_direction_table(radius_px, spawn_gap_px, cell_px, out, out_touched):
    """Which directions around a candidate P a neighbour Q surely blocks, and which it may
    block, by where Q is.

    ``out`` (n, n) uint64 is written: entry [iy, ix] covers Q − P in the square
    [ix·cell − n·cell/2, (ix + 1)·cell − n·cell/2) × (the same in y) [px]; its bit k is set
    when, for every Q of the square and every direction θ of [k, k + 1)·2π/64, the point
    P + 2r·(cos θ, sin θ) is closer than the gap to Q (with a 10⁻⁶ relative margin, so no
    rounding of the exact arcs can leave such a direction free). The farthest pair of a
    square and an arc of that size is a corner of one and an end of the other, so 4 × 2
    distances decide a bit. ``out_touched`` (n, n) uint64 gets the bins where *some* Q of the
    square may block *some* θ (a lower bound of their distance, from the arc's middle and the
    square's centre, is under the gap): a neighbour blocks nothing outside them. n·cell must
    exceed 2·(2r + gap). Returns n.
    """
    n = out.shape[0]
    r2 = 2.0 * radius_px
    g2 = spawn_gap_px * spawn_gap_px * (1.0 - 1e-6)
    half = 0.5 * n * cell_px
    ax = np.empty(DIRECTION_BINS + 1)
    ay = np.empty(DIRECTION_BINS + 1)
    for k in range(DIRECTION_BINS + 1):
        theta = TWO_PI * k / DIRECTION_BINS
        ax[k] = r2 * math.cos(theta)
        ay[k] = r2 * math.sin(theta)
    # every point of a bin's arc lies within rho of its middle, every point of a square within
    # sigma of its centre
    rho = 2.0 * r2 * math.sin(0.25 * TWO_PI / DIRECTION_BINS)
    sigma = cell_px * math.sqrt(0.5)
    reach = spawn_gap_px * (1.0 + 1e-6) + rho + sigma
    for iy in range(n):
        for ix in range(n):
            bits = np.uint64(0)
            touched = np.uint64(0)
            for k in range(DIRECTION_BINS):
                ok = True
                for e in range(k, k + 2):
                    for corner in range(4):
                        sx = (ix + (corner & 1)) * cell_px - half
                        sy = (iy + (corner >> 1)) * cell_px - half
                        dx = ax[e] - sx
                        dy = ay[e] - sy
                        if not dx * dx + dy * dy < g2:
                            ok = False
                if ok:
                    bits |= np.uint64(1) << np.uint64(k)
                mid = TWO_PI * (k + 0.5) / DIRECTION_BINS
                dx = r2 * math.cos(mid) - ((ix + 0.5) * cell_px - half)
                dy = r2 * math.sin(mid) - ((iy + 0.5) * cell_px - half)
                if dx * dx + dy * dy < reach * reach:
                    touched |= np.uint64(1) << np.uint64(k)
            out[iy, ix] = bits
            out_touched[iy, ix] = touched
    return n


class DirectionTable(NamedTuple):
    """:func:`blocked_direction_table`'s two tables (n, n) uint64 and their cells' side [px]."""

    blocked: np.ndarray
    touched: np.ndarray
    cell_px: float


def direction_table(radius_px: float, spawn_gap_px: float) -> DirectionTable:
    """:func:`blocked_direction_table` for a radius and a gap, with cells of r/16 px, large
    enough for every neighbour within 2r + gap."""
    cell = radius_px / TABLE_CELLS_PER_R
    n = 2 * int(math.ceil((2.0 * radius_px + spawn_gap_px) / cell)) + 2
    out = np.zeros((n, n), np.uint64)
    touched = np.zeros((n, n), np.uint64)
    blocked_direction_table(radius_px, spawn_gap_px, cell, out, touched)
    return DirectionTable(out, touched, cell)


# _remove_arc and _remove_wrapped are ordinary calls, not inlined in numba's IR: inlined at
# their ~20 call sites they made fill_poisson_holes the slowest kernel to compile (about 60 %
# of its ~20 s cold); as calls the fill runs as fast (0.264 vs 0.265 ms a call, 1080p r = 5).
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
    a = centre - half  # (centre − half) mod 2π, for centre − half in (−4π, 4π): ± 2π is exact
    while a < 0.0:
        a += TWO_PI
    while a >= TWO_PI:
        a -= TWO_PI
    b = a + 2.0 * half
    if b <= TWO_PI:
        return _remove_arc(lo, hi, n, a, b)
    n = _remove_arc(lo, hi, n, a, TWO_PI)
    return _remove_arc(lo, hi, n, 0.0, b - TWO_PI)


@njit(inline="always", **JIT_OPTIONS)
def _offscreen_bits(px, py, r2, width_px, height_px):
    """The direction bins in which P + r2·(cos θ, sin θ) is off screen for every θ of the bin
    (both ends beyond the same edge: the extremes of cos and sin are bin ends, so that holds
    for the whole bin), as a 64-bit mask."""
    m = _EDGE_MARGIN * r2
    bits = np.uint64(0)
    for k in range(DIRECTION_BINS):
        xa = px + r2 * _BIN_COS[k]
        xb = px + r2 * _BIN_COS[k + 1]
        ya = py + r2 * _BIN_SIN[k]
        yb = py + r2 * _BIN_SIN[k + 1]
        if ((xa < -m and xb < -m) or (ya < -m and yb < -m) or (xa >= width_px + m
                and xb >= width_px + m) or (ya >= height_px + m and yb >= height_px + m)):
            bits |= np.uint64(1) << np.uint64(k)
    return bits


@njit(inline="always", **JIT_OPTIONS)
def _remove_offscreen(lo, hi, n, px, py, r2, width_px, height_px):
    """Remove from the free arcs the directions θ in which P + r2·(cos θ, sin θ) leaves the
    screen [0, W) × [0, H), edge by edge; returns the new n."""
    if px < r2:  # x + r2 cos θ < 0 ⇔ θ within acos(x / r2) of π
        n = _remove_wrapped(lo, hi, n, math.pi, math.acos(px / r2))
    if width_px - px <= r2:  # x + r2 cos θ ≥ W ⇔ θ within acos((W − x) / r2) of 0
        n = _remove_wrapped(lo, hi, n, 0.0, math.acos((width_px - px) / r2))
    if py < r2:
        n = _remove_wrapped(lo, hi, n, 1.5 * math.pi, math.acos(py / r2))
    if height_px - py <= r2:
        n = _remove_wrapped(lo, hi, n, 0.5 * math.pi, math.acos((height_px - py) / r2))
    return n


@njit(inline="always", **JIT_OPTIONS)
def _block_mask(mask, row, a, b, acc_start, acc_xy, new_head, new_next, new_xy, px, py, t_half,
                t_inv, t_last, blocked):
    """``mask`` or-ed with the blocked-direction table entries of the particles of cells
    [a, b) of grid row ``row`` (its first cell's index): the accepted ones and the fill's new
    ones."""
    for m in range(acc_start[row + a], acc_start[row + b]):
        ix = min(max(int((acc_xy[m, 0] - px + t_half) * t_inv), 0), t_last)
        iy = min(max(int((acc_xy[m, 1] - py + t_half) * t_inv), 0), t_last)
        mask |= blocked[iy, ix]
    for nx in range(a, b):
        m = new_head[row + nx]
        while m >= 0:
            ix = min(max(int((new_xy[m, 0] - px + t_half) * t_inv), 0), t_last)
            iy = min(max(int((new_xy[m, 1] - py + t_half) * t_inv), 0), t_last)
            mask |= blocked[iy, ix]
            m = new_next[m]
    return mask


@njit(**JIT_OPTIONS)
def _cell_of(x, y, cell_px, gw, gh):
    cx = min(max(int(math.floor(x / cell_px)), 0), gw - 1)
    cy = min(max(int(math.floor(y / cell_px)), 0), gh - 1)
    return cx, cy


@njit(inline="always", **JIT_OPTIONS)
def _grid_insert(i, x, y, cell_px, gw, gh, cell_count, cell_items, new_head, new_next, new_xy,
                 n_new):
    """Put new particle i (at x, y), the fill's n_new-th, into its grid cell if the cell has
    room, and into the list of the fill's new particles of that cell (``new_head`` per cell,
    ``new_next`` and ``new_xy`` per new particle)."""
    cx, cy = _cell_of(x, y, cell_px, gw, gh)
    c = cy * gw + cx
    q = cell_count[c]
    if q < cell_items.shape[1]:
        cell_items[c, q] = i
        cell_count[c] = q + 1
    new_xy[n_new, 0] = x
    new_xy[n_new, 1] = y
    new_next[n_new] = new_head[c]
    new_head[c] = n_new


@njit(inline="always", **JIT_OPTIONS)
def _new_particle(alive, ids, counters, birth_s, intensity, screen_px, fade_reason, has_world,
                  velocity_mps, status, first_query, offset_m, x, y, now_s, off_lo_x, off_lo_y,
                  off_hi_x, off_hi_y, first_free):
    """A new particle at (x, y) in the lowest free slot (none below ``first_free``)."""
    i = allocate_particle(alive, ids, counters, first_free)
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
def fill_poisson_holes(pool, grid, table, now_s, radius_px, spawn_gap_px, seed, off_lo_x,
                       off_lo_y, off_hi_x, off_hi_y):
    """Fill the holes of the Poisson disk around dirty cells by boundary sampling, with new
    particles of ``pool`` (:class:`~riverflow.kernels.lifecycle.Pool`) born at ``now_s`` [s],
    their sprite offsets [m] uniform in the box ``off_lo`` … ``off_hi``.

    Of ``grid`` (:class:`~riverflow.kernels.poisson_cull.Grid`): ``acc_start``, ``acc_slot``,
    ``acc_xy`` are the accepted particles by cell, as
    :func:`~riverflow.kernels.poisson_cull.cull_crowded_particles` wrote them (the new ones
    go into the grid, ``cell_count``/``cell_items``, too). Writes the slots of the new
    particles into ``new_slots`` (C,) int32 and returns their number (they still need a world
    position). ``candidates`` is (C,) int32 scratch. ``table`` (:class:`DirectionTable`) is
    :func:`direction_table`'s for this radius and gap: a candidate whose neighbours surely
    block every direction (most of them, where the disk is whole) is rejected from its
    ``blocked``, without trigonometry; for the others the exact arcs start from the bins left
    free, and a neighbour whose ``touched`` bins miss all of those is skipped.
    """
    alive, ids, counters, birth_s = pool.alive, pool.ids, pool.counters, pool.birth_s
    intensity, screen_px, fade_reason = pool.intensity, pool.screen_px, pool.fade_reason
    has_world, velocity_mps, status = pool.has_world, pool.velocity_mps, pool.status
    first_query, offset_m = pool.first_query, pool.offset_m
    width_px, height_px, cell_px, gw, gh = (grid.width_px, grid.height_px, grid.cell_px,
                                            grid.gw, grid.gh)
    cell_count, cell_items, dirty = grid.cell_count, grid.cell_items, grid.dirty
    acc_start, acc_slot, acc_xy = grid.acc_start, grid.acc_slot, grid.acc_xy
    candidates, new_slots = grid.candidates, grid.new_slots
    blocked, touched, blocked_cell_px = table
    np.random.seed(seed)
    if width_px <= 0 or height_px <= 0:
        return 0
    n_cells = gw * gh
    n_cand = 0
    any_accepted = acc_start[n_cells] > 0
    for cy in range(gh):
        for cx in range(gw):
            c = cy * gw + cx
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
                    for k in range(acc_start[d], acc_start[d + 1]):
                        if 0.0 <= acc_xy[k, 0] < width_px and 0.0 <= acc_xy[k, 1] < height_px:
                            candidates[n_cand] = acc_slot[k]
                            n_cand += 1
                    dirty[d] |= 2  # its particles are queued already
    if not any_accepted:
        # no accepted particle: fading ones that are still on screen, else one at random
        for i in range(alive.shape[0]):
            if (alive[i] and fade_reason[i] != REASON_OUTSIDE_VIEWPORT
                    and 0.0 <= screen_px[i, 0] < width_px and 0.0 <= screen_px[i, 1] < height_px):
                candidates[n_cand] = i
                n_cand += 1
    # the new particles by cell (a list per cell), next to the accepted ones' rows
    new_head = np.full(n_cells, -1, np.int32)
    new_next = np.empty(alive.shape[0], np.int32)
    new_xy = np.empty((alive.shape[0], 2), np.float32)
    n_new = 0
    if n_cand == 0:
        if any_accepted:
            return 0  # no hole anywhere
        x = np.random.random() * width_px
        y = np.random.random() * height_px
        i = _new_particle(alive, ids, counters, birth_s, intensity, screen_px, fade_reason,
                          has_world, velocity_mps, status, first_query, offset_m, x, y, now_s,
                          off_lo_x, off_lo_y, off_hi_x, off_hi_y, 0)
        if i < 0:
            return 0
        _grid_insert(i, screen_px[i, 0], screen_px[i, 1], cell_px, gw, gh, cell_count,
                     cell_items, new_head, new_next, new_xy, n_new)
        new_slots[n_new] = i
        n_new += 1
        candidates[0] = i
        n_cand = 1
    lo = np.empty(MAX_ARCS)
    hi = np.empty(MAX_ARCS)
    r2 = 2.0 * radius_px               # new particles are placed 2r from a candidate
    gap = spawn_gap_px                 # and at least this far from every other particle
    reach = r2 + gap
    reach_sq = reach * reach
    # a new particle at angle θ blocks θ ± this for the next ones around the same candidate
    self_block = 2.0 * math.asin(min(gap / (2.0 * r2), 1.0))
    t_inv = 1.0 / blocked_cell_px
    t_half = 0.5 * blocked.shape[0] * blocked_cell_px
    t_last = blocked.shape[0] - 1
    first_free = 0
    k_max = 9 * cell_items.shape[1] + 1
    nb_dx = np.empty(k_max, np.float32)
    nb_dy = np.empty(k_max, np.float32)
    nb_d2 = np.empty(k_max, np.float32)
    while n_cand > 0:
        k = int(np.random.random() * n_cand)
        p = candidates[k]
        n_cand -= 1
        candidates[k] = candidates[n_cand]
        px = screen_px[p, 0]
        py = screen_px[p, 1]
        cx, cy = _cell_of(px, py, cell_px, gw, gh)
        x_lo = max(cx - 1, 0)
        x_hi = min(cx + 2, gw)
        near_edge = px < r2 or py < r2 or width_px - px <= r2 or height_px - py <= r2
        # pre-test: the directions each neighbour surely blocks, from the table (branch-free:
        # an entry for a square out of reach is 0, and so is the one of P itself), and those
        # that leave the screen; all of them blocked means no arc is left (the exact arcs
        # below would find none): most candidates stop here, most of them after the 2 × 2
        # cells nearest P (every neighbour within 2r of P is there)
        mask = np.uint64(0)
        if near_edge:
            mask = _offscreen_bits(px, py, r2, width_px, height_px)
        qx = 1 if px >= (cx + 0.5) * cell_px else -1
        qy = 1 if py >= (cy + 0.5) * cell_px else -1
        a = min(max(min(cx, cx + qx), 0), gw - 1)
        b = min(max(cx, cx + qx), gw - 1) + 1
        mask = _block_mask(mask, cy * gw, a, b, acc_start, acc_xy, new_head, new_next, new_xy,
                           px, py, t_half, t_inv, t_last, blocked)
        if 0 <= cy + qy < gh:
            mask = _block_mask(mask, (cy + qy) * gw, a, b, acc_start, acc_xy, new_head,
                               new_next, new_xy, px, py, t_half, t_inv, t_last, blocked)
        if mask != ALL_DIRECTIONS:
            if 0 <= cy - qy < gh:
                mask = _block_mask(mask, (cy - qy) * gw, x_lo, x_hi, acc_start, acc_xy,
                                   new_head, new_next, new_xy, px, py, t_half, t_inv, t_last,
                                   blocked)
            if 0 <= cx - qx < gw:
                mask = _block_mask(mask, cy * gw, cx - qx, cx - qx + 1, acc_start, acc_xy,
                                   new_head, new_next, new_xy, px, py, t_half, t_inv, t_last,
                                   blocked)
                if 0 <= cy + qy < gh:
                    mask = _block_mask(mask, (cy + qy) * gw, cx - qx, cx - qx + 1, acc_start,
                                       acc_xy, new_head, new_next, new_xy, px, py, t_half,
                                       t_inv, t_last, blocked)
        if mask == ALL_DIRECTIONS:
            continue
        # the neighbours within reach, for the exact arcs
        n_nb = 0
        for ny in range(max(cy - 1, 0), min(cy + 2, gh)):
            row = ny * gw
            for m in range(acc_start[row + x_lo], acc_start[row + x_hi]):
                dx = acc_xy[m, 0] - px
                dy = acc_xy[m, 1] - py
                d2 = dx * dx + dy * dy
                nb_dx[n_nb] = dx
                nb_dy[n_nb] = dy
                nb_d2[n_nb] = d2
                n_nb += (d2 < reach_sq) & (d2 > 0.0)  # (d2 = 0: P itself)
            for nx in range(x_lo, x_hi):
                m = new_head[row + nx]
                while m >= 0:
                    dx = new_xy[m, 0] - px
                    dy = new_xy[m, 1] - py
                    d2 = dx * dx + dy * dy
                    nb_dx[n_nb] = dx
                    nb_dy[n_nb] = dy
                    nb_d2[n_nb] = d2
                    n_nb += (d2 < reach_sq) & (d2 > 0.0)
                    m = new_next[m]
        # the free arcs start as the bins the pre-test left free (the others are surely
        # blocked), and only the neighbours that may block one of those take the exact arcs
        free = ~mask
        n_arcs = 0
        k = 0
        while k < DIRECTION_BINS:
            if (free >> np.uint64(k)) & np.uint64(1):
                first = k
                while k < DIRECTION_BINS and (free >> np.uint64(k)) & np.uint64(1):
                    k += 1
                lo[n_arcs] = TWO_PI * first / DIRECTION_BINS
                hi[n_arcs] = TWO_PI * k / DIRECTION_BINS
                n_arcs += 1
            else:
                k += 1
        if near_edge:
            n_arcs = _remove_offscreen(lo, hi, n_arcs, px, py, r2, width_px, height_px)
        for m in range(n_nb):
            if n_arcs == 0:
                break
            dx = nb_dx[m]
            dy = nb_dy[m]
            ix = min(max(int((dx + t_half) * t_inv), 0), t_last)
            iy = min(max(int((dy + t_half) * t_inv), 0), t_last)
            if touched[iy, ix] & free == 0:
                continue
            d2 = nb_d2[m]
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
                              now_s, off_lo_x, off_lo_y, off_hi_x, off_hi_y, first_free)
            if i < 0:
                return n_new  # the pool is full: stop cleanly
            first_free = i + 1  # slots are only taken during the fill: none frees below
            _grid_insert(i, screen_px[i, 0], screen_px[i, 1], cell_px, gw, gh, cell_count,
                         cell_items, new_head, new_next, new_xy, n_new)
            new_slots[n_new] = i
            n_new += 1
            candidates[n_cand] = i
            n_cand += 1
    return n_new
