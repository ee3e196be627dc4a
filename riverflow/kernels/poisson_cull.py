"""Poisson-disk maintenance of the screen-space particles, part 1: the cull (Proland
ScreenParticleLayer ``removeOldParticles``, reference §3.3); part 2, the fill, is
:mod:`riverflow.kernels.poisson_fill`.

The particles live on a screen neighbour grid of cells ``cell_px`` ≈ 4r wide, each particle in
the cell of its position (a 3 × 3 cell lookup finds every neighbour within 4r). In slot order,
a live particle that is not fading out and has an accepted neighbour closer than ``cull_px``
(≈ 1.96 r) fades out (reason POISSON_DISK); the others are accepted into the grid.

The cull hands the fill the accepted particles by cell (``acc_start``, ``acc_slot``,
``acc_xy``) and marks the cells whose particles are the fill's candidates (``dirty``): Proland
visits every particle each frame; here only the particles around *dirty* cells are candidates
(cells where particles were removed, cells that are empty or sparse, where a fade began or a
crowded particle was culled, plus a rolling band of rows so that slow stretching is caught
too). That keeps the cost proportional to what changes (docs/deviations.md).
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from riverflow.kernels._jit import JIT_OPTIONS

REASON_POISSON_DISK = 3
STATUS_INSIDE = 1
STATUS_LEAVING = 2

ROLLING_BANDS = 32
"""The rolling dirty band covers 1/ROLLING_BANDS of the grid rows each frame."""
SPARSE_EVERY = 4
"""A sparse cell is searched for holes every this many frames (a power of two)."""
_PAIR_WINDOW_RIGHT = 3
"""Rows after a particle that the cull's pair scan compares without a loop (its fine cell and
the next hold ~1.7 steady particles on average, at most 8)."""
_PAIR_WINDOW_BELOW = 7
"""Rows of the run of 3 fine cells below that it compares without a loop (~2.6 on average)."""
_FAR_PX = 1e18
"""Screen position of the padding rows: no particle is ever that close to one."""


class Grid(NamedTuple):
    """The screen neighbour grid and the Poisson pass's scratch, as the cull and the fill
    take them (``ScreenGrid.arrays``, remade when the grid is): ``gw`` × ``gh`` cells of
    ``cell_px`` over ``width_px`` × ``height_px``; the arrays as
    :func:`cull_crowded_particles` (which writes them) and
    :func:`~riverflow.kernels.poisson_fill.fill_poisson_holes` describe them."""

    width_px: int
    height_px: int
    cell_px: float
    gw: int
    gh: int
    cell_count: np.ndarray
    cell_items: np.ndarray
    removed_cells: np.ndarray
    dirty: np.ndarray
    acc_start: np.ndarray
    acc_slot: np.ndarray
    acc_xy: np.ndarray
    carrier_cells: np.ndarray
    candidates: np.ndarray
    new_slots: np.ndarray


@njit(**JIT_OPTIONS)
def cull_crowded_particles(pool, grid, now_s, dt_s, fade_in_s, active_s, fade_out_s, cull_px,
                           frame, sparse_below):
    """Rebuild the neighbour grid with the accepted particles of ``pool``
    (:class:`~riverflow.kernels.lifecycle.Pool`); fade out the crowded ones.

    Of ``grid`` (:class:`Grid`): ``cell_count`` (gw·gh,) int32 and ``cell_items`` (gw·gh, K)
    int32 are rebuilt, and the same compactly for the fill's scans: the accepted particles of cell c are rows
    ``acc_start[c]`` … ``acc_start[c + 1]`` (gw·gh + 1,) int32 of ``acc_slot`` (C,) int32 and
    ``acc_xy`` (C, 2) float32 (their screen positions); ``removed_cells`` (gw·gh,) uint8 marks
    cells where other systems removed particles since the last pass (read, then cleared);
    ``dirty`` (gw·gh,) uint8 is written (bit 1: holes may be here — particles were removed
    there, it holds fewer than ``sparse_below`` (looked at every :data:`SPARSE_EVERY` frames,
    staggered: most such cells are sparse by chance and stay so), or lies in this frame's
    rolling band; bit 4: the cell is empty, so its neighbours' particles are candidates too).
    ``carrier_cells`` (gw·gh,) uint8 is written: bit 1 when the cell's accepted particles
    include an INSIDE one (``status``), bit 2 an INSIDE or LEAVING one (the NEAR check's
    pruning). Returns the number faded out.

    The result is the greedy pass in slot order (a particle is accepted when no accepted one
    is closer than ``cull_px``), found without visiting the particles in slot order: a
    counting sort by half cells, one scan of each pair of neighbours in that order to find
    the few that have a neighbour that close, and the greedy pass over those alone.
    """
    alive, screen_px, status = pool.alive, pool.screen_px, pool.status
    birth_s, n_slots = pool.birth_s, pool.counters[2]
    cell_px, gw, gh = grid.cell_px, grid.gw, grid.gh
    cell_count, cell_items, dirty = grid.cell_count, grid.cell_items, grid.dirty
    acc_start, acc_slot, acc_xy = grid.acc_start, grid.acc_slot, grid.acc_xy
    removed_cells, carrier_cells = grid.removed_cells, grid.carrier_cells
    n_cells = gw * gh
    k_max = cell_items.shape[1]
    cap = min(n_slots, alive.shape[0])  # the pool's slot bound: no live slot beyond it
    for c in range(n_cells):
        cell_count[c] = 0
        dirty[c] = 0
    fade_at = fade_in_s + active_s
    # 1. fine cell (half a cell when that is ≥ cull_px) of each steady (not fading) particle;
    # its cell is the fine one's halved (floor(x / (c/2)) // 2 = floor(x / c) exactly). Fades
    # that began this frame dirty their cell.
    sub = 2 if 0.5 * cell_px >= cull_px else 1
    half = cell_px / sub
    fw = sub * gw
    n_fine = fw * sub * gh
    cell_of = np.empty(cap, np.int32)
    start = np.zeros(n_fine + 1, np.int32)
    for i in range(cap):
        cell_of[i] = -1
        if not alive[i]:
            continue
        fx = min(max(int(math.floor(screen_px[i, 0] / half)), 0), fw - 1)
        fy = min(max(int(math.floor(screen_px[i, 1] / half)), 0), sub * gh - 1)
        age = now_s - birth_s[i]
        if age >= fade_at:  # fading out already
            if age - fade_at < 0.5 * dt_s:  # its fade began this frame (not the last one)
                dirty[(fy // sub) * gw + fx // sub] = 1
            continue
        f = fy * fw + fx
        cell_of[i] = f
        start[f + 1] += 1
    for f in range(n_fine):
        start[f + 1] += start[f]
    crowded_cell = not (half >= cull_px)  # (the pair scan below needs half ≥ cull_px)
    for cy in range(gh):
        for cx in range(gw):
            f = sub * cy * fw + sub * cx
            held = 0
            for run in range(sub):
                held += start[f + run * fw + sub] - start[f + run * fw]
            if held > k_max:
                crowded_cell = True
    n = start[n_fine]
    # 2. counting sort by fine cell: slots ascending within each (the rows past n are far
    # away, for the fixed windows of the pair scan)
    slot = np.empty(n, np.int32)
    xy = np.full((n + _PAIR_WINDOW_BELOW + 1, 2), _FAR_PX, np.float32)
    fine = np.empty(n, np.int32)
    fill = start[:n_fine].copy()
    for i in range(cap):
        f = cell_of[i]
        if f < 0:
            continue
        k = fill[f]
        fill[f] = k + 1
        slot[k] = i
        fine[k] = f
        xy[k, 0] = screen_px[i, 0]
        xy[k, 1] = screen_px[i, 1]
    if crowded_cell:  # which come first decides which a full cell keeps: the plain pass
        for i in range(cap):
            f = cell_of[i]
            if f >= 0:
                cell_of[i] = ((f // fw) // sub) * gw + (f % fw) // sub
        faded = _greedy_in_slot_order(pool, grid, now_s, fade_in_s, active_s, fade_out_s,
                                      cull_px, cell_of)
        acc_start[0] = 0
        for c in range(n_cells):
            k = acc_start[c]
            flags = 0
            for q in range(cell_count[c]):
                i = cell_items[c, q]
                acc_slot[k] = i
                acc_xy[k, 0] = screen_px[i, 0]
                acc_xy[k, 1] = screen_px[i, 1]
                k += 1
                s = status[i]
                flags |= 3 if s == STATUS_INSIDE else (2 if s == STATUS_LEAVING else 0)
            acc_start[c + 1] = k
            carrier_cells[c] = flags
    else:
        faded = _cull_sorted(pool, grid, now_s, fade_in_s, active_s, fade_out_s, cull_px, half,
                             sub, start, slot, xy, fine)
    band = frame % ROLLING_BANDS
    for cy in range(gh):
        in_band = cy % ROLLING_BANDS == band
        for cx in range(gw):
            c = cy * gw + cx
            if cell_count[c] == 0:
                dirty[c] = 1 | 4  # a hole: its neighbours' particles border it
            elif (removed_cells[c] or in_band or (cell_count[c] < sparse_below
                                                  and (c + frame) & (SPARSE_EVERY - 1) == 0)):
                dirty[c] = 1
            removed_cells[c] = 0
    return faded


@njit(**JIT_OPTIONS)
def _cull_sorted(pool, grid, now_s, fade_in_s, active_s, fade_out_s, cull_px, half, sub, start,
                 slot, xy, fine):
    """Steps 3–5 of the cull on the particles sorted by fine cell (``start``, ``slot``,
    ``xy`` with far rows past the end, ``fine`` the cell of each; fine cells of ``half`` =
    cell_px / ``sub`` ≥ cull_px, sub·gw a row); the carrier flags of the cells too."""
    birth_s, fade_reason, status = pool.birth_s, pool.fade_reason, pool.status
    gw, gh, cell_count, cell_items = grid.gw, grid.gh, grid.cell_count, grid.cell_items
    dirty = grid.dirty
    acc_start, acc_slot, acc_xy = grid.acc_start, grid.acc_slot, grid.acc_xy
    carrier_cells = grid.carrier_cells
    fade_at = fade_in_s + active_s
    cull2 = cull_px * cull_px
    fw = sub * gw
    fh = sub * gh
    n_fine = fw * fh
    n = start[n_fine]
    # 3. which particles have a steady neighbour closer than cull_px (usually a few): each
    # pair once, a particle against the later ones of its fine cell and its right neighbour
    # (one run of the sorted array) and the 3 fine cells below (another). At a row's end these
    # runs take in cells of the next row too: farther than cull_px, they change nothing.
    # Fixed windows (the next _PAIR_WINDOW_RIGHT rows, the first _PAIR_WINDOW_BELOW of the run
    # below), masked by the run ends: the only branches that depend on the data are the rare
    # close pairs, so few mispredictions; a longer run (rare) takes the loop.
    close = np.zeros(n + _PAIR_WINDOW_BELOW + 1, np.uint8)
    n_close = 0
    for k in range(n):
        f = fine[k]
        e1 = start[min(f + 2, n_fine)]
        b2 = start[min(f + fw - 1, n_fine)]
        e2 = start[min(f + fw + 2, n_fine)]
        x = xy[k, 0]
        y = xy[k, 1]
        any_close = False
        for w in range(1, _PAIR_WINDOW_RIGHT + 1):
            m = k + w
            dx = xy[m, 0] - x
            dy = xy[m, 1] - y
            if (dx * dx + dy * dy < cull2) & (m < e1):  # rare: well predicted
                close[m] = 1
                any_close = True
        for w in range(_PAIR_WINDOW_BELOW):
            m = b2 + w
            dx = xy[m, 0] - x
            dy = xy[m, 1] - y
            if (dx * dx + dy * dy < cull2) & (m < e2):
                close[m] = 1
                any_close = True
        if e1 - k - 1 > _PAIR_WINDOW_RIGHT or e2 - b2 > _PAIR_WINDOW_BELOW:
            for m in range(k + 1 + _PAIR_WINDOW_RIGHT, e1):
                dx = xy[m, 0] - x
                dy = xy[m, 1] - y
                if dx * dx + dy * dy < cull2:
                    close[m] = 1
                    any_close = True
            for m in range(b2 + _PAIR_WINDOW_BELOW, e2):
                dx = xy[m, 0] - x
                dy = xy[m, 1] - y
                if dx * dx + dy * dy < cull2:
                    close[m] = 1
                    any_close = True
        if any_close:
            close[k] = 1
            n_close += 1
    # 4. the greedy pass in slot order over those: one is rejected (2) when a lower slot that
    # was accepted is closer than cull_px; every other particle is accepted
    if n_close > 0:
        order = np.empty(n, np.int32)
        n_order = 0
        for k in range(n):
            if close[k]:
                order[n_order] = k
                n_order += 1
        by_slot = np.argsort(slot[order[:n_order]])
        for o in range(n_order):
            k = order[by_slot[o]]
            i = slot[k]
            x = xy[k, 0]
            y = xy[k, 1]
            x0 = max(int(math.floor((x - cull_px) / half)), 0)
            x1 = min(int(math.floor((x + cull_px) / half)), fw - 1)
            y0 = max(int(math.floor((y - cull_px) / half)), 0)
            y1 = min(int(math.floor((y + cull_px) / half)), fh - 1)
            for ny in range(y0, y1 + 1):
                for m in range(start[ny * fw + x0], start[ny * fw + x1 + 1]):
                    if slot[m] >= i or close[m] == 2:  # a later slot, or rejected itself
                        continue
                    dx = xy[m, 0] - x
                    dy = xy[m, 1] - y
                    if dx * dx + dy * dy < cull2:
                        close[k] = 2
                        break
                if close[k] == 2:
                    break
    # 5. the grid of the accepted ones (no cell is over its capacity): a cell's sub × sub fine
    # cells, sub runs; the rejected fade out
    faded = 0
    a = 0
    for c in range(gw * gh):
        acc_start[c] = a
        cy = c // gw  # (one division a cell)
        f0 = sub * cy * fw + sub * (c - cy * gw)
        q = 0
        flags = 0
        for run in range(sub):
            f = f0 + run * fw
            for k in range(start[f], start[f + sub]):
                i = slot[k]
                if close[k] != 2:
                    cell_items[c, q] = i
                    q += 1
                    acc_slot[a] = i
                    acc_xy[a, 0] = xy[k, 0]
                    acc_xy[a, 1] = xy[k, 1]
                    a += 1
                    s = status[i]
                    flags |= 3 if s == STATUS_INSIDE else (2 if s == STATUS_LEAVING else 0)
                    continue
                age = now_s - birth_s[i]
                level = max(age / fade_in_s, 0.0) if age < fade_in_s else 1.0
                birth_s[i] = now_s - (fade_at + (1.0 - level) * fade_out_s)  # start_fade_out
                fade_reason[i] = REASON_POISSON_DISK
                faded += 1
                dirty[c] = 1
        cell_count[c] = q
        carrier_cells[c] = flags
    acc_start[gw * gh] = a
    return faded


@njit(**JIT_OPTIONS)
def _greedy_in_slot_order(pool, grid, now_s, fade_in_s, active_s, fade_out_s, cull_px, cell_of):
    """The plain greedy cull in slot order (when a cell holds more steady particles than it
    can keep, which order they come in decides which are kept)."""
    screen_px, birth_s, fade_reason = pool.screen_px, pool.birth_s, pool.fade_reason
    cell_px, gw, gh = grid.cell_px, grid.gw, grid.gh
    cell_count, cell_items, dirty = grid.cell_count, grid.cell_items, grid.dirty
    k_max = cell_items.shape[1]
    fade_at = fade_in_s + active_s
    cull2 = cull_px * cull_px
    for c in range(gw * gh):
        cell_count[c] = 0
    faded = 0
    for i in range(cell_of.shape[0]):
        c = cell_of[i]
        if c < 0:
            continue
        x = screen_px[i, 0]
        y = screen_px[i, 1]
        close = False
        x0 = max(int(math.floor((x - cull_px) / cell_px)), 0)
        x1 = min(int(math.floor((x + cull_px) / cell_px)), gw - 1)
        y0 = max(int(math.floor((y - cull_px) / cell_px)), 0)
        y1 = min(int(math.floor((y + cull_px) / cell_px)), gh - 1)
        for ny in range(y0, y1 + 1):
            for nx in range(x0, x1 + 1):
                d = ny * gw + nx
                for q in range(cell_count[d]):
                    dx = screen_px[cell_items[d, q], 0] - x
                    dy = screen_px[cell_items[d, q], 1] - y
                    if dx * dx + dy * dy < cull2:
                        close = True
                        break
                if close:
                    break
            if close:
                break
        if close or cell_count[c] >= k_max:
            age = now_s - birth_s[i]
            level = max(age / fade_in_s, 0.0) if age < fade_in_s else 1.0
            birth_s[i] = now_s - (fade_at + (1.0 - level) * fade_out_s)  # start_fade_out
            fade_reason[i] = REASON_POISSON_DISK
            faded += 1
            dirty[c] = 1
            continue
        q = cell_count[c]
        cell_items[c, q] = i
        cell_count[c] = q + 1
    return faded
