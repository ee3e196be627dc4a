"""The GPU tables of the per-pixel sprite blending, rebuilt on the CPU each frame.

Re-does the two tables of Proland's ``DrawRiversTask`` (reference §4.2–4.3); another module
uploads them to textures and the water fragment shader reads them:

* **sprite parameter table** (RGBA32F, ``PARTICLES_PER_ROW`` particles a row, 3 texels each):
  particle slot ``i`` is at row ``i // 256``, texels ``3·(i % 256) + 0..2``:

  ====== ============ ============ ============ ============
  texel  R            G            B            A
  ====== ============ ============ ============ ============
  0      screen x px  screen y px  world x m    world y m
  1      offset x m   offset y m   intensity    r px (not ×3)
  2      status       velocity x   velocity y   world z m
  ====== ============ ============ ============ ============

  A free slot (not alive, no world position, or a non-finite screen/world/intensity value)
  is all zeros but status = −1: intensity 0 gives it weight f(0) = 0 in the blend.
  Proland used one row per slot and RGBA16F (~0.25 m steps at 300 m); 256 slots a row keep
  the texture within GL size limits for any pool, and RGBA32F keeps world positions to
  ≤ 1 mm steps within ±8 km.

* **sprite indirection grid** (RGBA32I): screen cells of ``cell_px`` pixels, cell row 0 at
  the bottom (like ``gl_FragCoord``); cell (cx, cy) is texels 4cx..4cx+3 of row cy, i.e. 16
  int32 particle slots ``grid[cy, 16cx + k]``, in slot order, ended by ``NO_PARTICLE`` (−1)
  when there are fewer than ``MAX_PER_CELL`` (later entries are stale). The (gh, 16·gw)
  int32 array is the texture's memory as it is (row 0 first). Each drawable particle
  (alive, with a world position, INSIDE or LEAVING, intensity > 0) is in every cell its
  sprite disc (radius ``SPRITE_RADIUS_FACTOR``·r) touches; a full cell keeps the 16
  brightest.

Cell size (``sprite_grid_shape``): ⌊r⌋ px, where Proland used r/2. Particles sit ~2.14 r
apart (Poisson disk, ~0.87 per (2r)²); a cell of side c is touched by every sprite whose
centre lies within 3r of it, an area c² + 4·c·3r + π(3r)² = 41.3 r² for c = r, so ~9
sprites on average, safely under 16 (benchmarks/bench_draw_tables.py: 8 a cell, none full).
Cells of r/2 would hold ~7.5 but be 4× as many (4× the bytes to build and upload: 5.3 MB
instead of 1.3 MB at 1920×1080, r = 10 px). An integer cell lets the shader find its cell
exactly: ``ivec2(gl_FragCoord.xy) / cell`` (pixel centres are at i + 0.5, as in
``screen_px``), clamped to the grid.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from riverflow.components.status import FlowStatus
from riverflow.kernels._jit import JIT_OPTIONS, is_finite

PARTICLES_PER_ROW = 256
"""Particle slots per row of the parameter table."""
TEXELS_PER_PARTICLE = 3
"""RGBA texels per particle in the parameter table."""
MAX_PER_CELL = 16
"""Particle slots per grid cell (4 RGBA32I texels)."""
SPRITE_RADIUS_FACTOR = 3.0
"""Sprite disc radius in units of the particle radius r (Proland ``riverParticleRadiusFactor``)."""
NO_PARTICLE = -1
"""Grid terminator, and the status written into a free slot of the parameter table."""

STATUS_INSIDE = int(FlowStatus.INSIDE)
STATUS_LEAVING = int(FlowStatus.LEAVING)
GRID_BAND_ROWS = 8
"""Cell rows filled together by ``build_sprite_grid`` (keeps the written cells in cache)."""
_TEXELS_PER_ROW = PARTICLES_PER_ROW * TEXELS_PER_PARTICLE
_U_PER_CELL = np.uint64(MAX_PER_CELL)
_U_ONE = np.uint64(1)


def sprite_grid_shape(width_px: float, height_px: float, radius_px: float) -> tuple[int, int, int]:
    """(cell_px, gw, gh) of the indirection grid for a ``width_px`` × ``height_px`` viewport
    and particle radius ``radius_px`` (sprites are 3r): cells of ⌊r⌋ px (at least 1 px; 1 px
    for a zero or non-finite radius), ``gw = ⌈W / cell⌉``, ``gh = ⌈H / cell⌉``, at least 1
    each (a zero-size viewport gets a 1 × 1 grid)."""
    r = float(radius_px)
    cell = math.floor(r) if is_finite(r) and r >= 1.0 else 1
    w = float(width_px)
    h = float(height_px)
    w = w if is_finite(w) and w > 0 else 0.0
    h = h if is_finite(h) and h > 0 else 0.0
    gw = max(1, math.ceil(w / cell))
    gh = max(1, math.ceil(h / cell))
    return cell, gw, gh


def param_table_rows(n_slots: int) -> int:
    """Rows of the parameter table holding ``n_slots`` particle slots (0 for none)."""
    return (max(int(n_slots), 0) + PARTICLES_PER_ROW - 1) // PARTICLES_PER_ROW


def empty_sprite_tables(capacity: int, gw: int,
                        gh: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Allocate (params, counts, grid) for a pool of ``capacity`` slots and a gw × gh grid:
    params (rows, 768, 4) float32 zeros, counts (gh·gw,) int32, grid (gh, 16·gw) int32 of −1."""
    rows = max(param_table_rows(capacity), 1)
    params = np.zeros((rows, _TEXELS_PER_ROW, 4), np.float32)
    counts = np.zeros(gh * gw, np.int32)
    grid = np.full((gh, gw * MAX_PER_CELL), NO_PARTICLE, np.int32)
    return params, counts, grid


@njit(**JIT_OPTIONS)
def slot_span(alive):
    """1 + the highest live slot (0 if none): the ``n_slots`` that covers every particle."""
    for i in range(alive.shape[0] - 1, -1, -1):
        if alive[i]:
            return i + 1
    return 0


@njit(**JIT_OPTIONS)
def _write_free_slot(out, row, t):
    for k in range(TEXELS_PER_PARTICLE):
        for c in range(4):
            out[row, t + k, c] = 0.0
    out[row, t + 2, 0] = NO_PARTICLE


@njit(**JIT_OPTIONS)
def _finite_or_zero(v):
    return v if is_finite(v) else np.float32(0.0)


@njit(**JIT_OPTIONS)
def fill_sprite_params(alive, has_world, screen_px, world_m, offset_m, intensity, status,
                       velocity_mps, radius_px, n_slots, out):
    """Write particle slots [0, n_slots) into the parameter table ``out``.

    ``alive``, ``has_world`` (C,) bool; ``screen_px`` (C, 2) float32 [px]; ``world_m`` (C, 3)
    float64 [m]; ``offset_m`` (C, 2) float32 [m]; ``intensity`` (C,) float32; ``status`` (C,)
    uint8 FlowStatus; ``velocity_mps`` (C, 2) float32 [m/s]; ``radius_px`` r [px] (scalar);
    ``out`` (rows, 768, 4) float32. Layout in the module docstring. Slots that are not alive,
    have no world position, or a non-finite screen, world or intensity value (after the cast
    to float32) are written free; a non-finite offset, velocity or radius is written 0.
    ``n_slots`` is clamped to the arrays; slots after it up to the end of the last row written
    are written free too, so whole rows can be uploaded. Returns the number of rows written.
    """
    n = min(n_slots, alive.shape[0], has_world.shape[0], screen_px.shape[0], world_m.shape[0],
            offset_m.shape[0], intensity.shape[0], status.shape[0], velocity_mps.shape[0],
            out.shape[0] * PARTICLES_PER_ROW)
    if out.shape[1] < _TEXELS_PER_ROW or out.shape[2] < 4:
        n = 0
    n = max(n, 0)
    rows = (n + PARTICLES_PER_ROW - 1) // PARTICLES_PER_ROW
    r = _finite_or_zero(np.float32(radius_px))
    for i in range(rows * PARTICLES_PER_ROW):
        row = i // PARTICLES_PER_ROW
        t = (i % PARTICLES_PER_ROW) * TEXELS_PER_PARTICLE
        if i < n and alive[i] and has_world[i]:
            sx = np.float32(screen_px[i, 0])
            sy = np.float32(screen_px[i, 1])
            wx = np.float32(world_m[i, 0])
            wy = np.float32(world_m[i, 1])
            wz = np.float32(world_m[i, 2])
            level = np.float32(intensity[i])
            if (is_finite(sx) and is_finite(sy) and is_finite(wx)
                    and is_finite(wy) and is_finite(wz) and is_finite(level)):
                out[row, t, 0] = sx
                out[row, t, 1] = sy
                out[row, t, 2] = wx
                out[row, t, 3] = wy
                out[row, t + 1, 0] = _finite_or_zero(np.float32(offset_m[i, 0]))
                out[row, t + 1, 1] = _finite_or_zero(np.float32(offset_m[i, 1]))
                out[row, t + 1, 2] = level
                out[row, t + 1, 3] = r
                out[row, t + 2, 0] = np.float32(status[i])
                out[row, t + 2, 1] = _finite_or_zero(np.float32(velocity_mps[i, 0]))
                out[row, t + 2, 2] = _finite_or_zero(np.float32(velocity_mps[i, 1]))
                out[row, t + 2, 3] = wz
                continue
        _write_free_slot(out, row, t)
    return rows


@njit(**JIT_OPTIONS)
def build_sprite_grid(alive, has_world, screen_px, intensity, status, n_slots, sprite_radius_px,
                      cell_px, gw, gh, counts, grid):
    """Rebuild the sprite indirection grid from particle slots [0, n_slots).

    ``alive``, ``has_world`` (C,) bool; ``screen_px`` (C, 2) float32 [px], origin bottom-left;
    ``intensity`` (C,) float32; ``status`` (C,) uint8 FlowStatus; ``sprite_radius_px`` the
    sprite radius 3r [px]; ``cell_px`` the cell side [px]; ``counts`` (≥ gh·gw,) int32, gets
    each cell's entry count (cell cy·gw + cx); ``grid`` (≥ gh, ≥ 16·gw) int32, C-contiguous.
    Particles alive, with a world position, INSIDE or LEAVING, with intensity > 0 and a finite
    screen position go, in slot order, into every cell whose rectangle [cx·cell, (cx+1)·cell)
    × [cy·cell, (cy+1)·cell) meets their disc of radius ``sprite_radius_px`` (exact
    disc–rectangle test: dx² ≤ R² − dy², dx and dy the distances from the centre to the
    cell's column and row); a full cell swaps its first dimmest entry for a strictly brighter
    particle. Cells with fewer than 16 entries get NO_PARTICLE after the last; later entries
    are left as they were. A non-positive or non-finite radius or cell inserts nothing.
    Returns the number of full cells.

    Work goes band by band (``GRID_BAND_ROWS`` cell rows, each band's particles in slot order)
    so that the cells being written stay in cache: the pool's slot order is spatially random,
    and a plain pass over the slots costs ~1.6× as much at r = 10 px and 2× at r = 5 px.
    """
    gh = min(gh, grid.shape[0])
    gw = min(gw, grid.shape[1] // MAX_PER_CELL)
    if gw <= 0 or gh <= 0:
        return 0
    gh = min(gh, counts.shape[0] // gw)
    if gh <= 0:
        return 0
    for c in range(gw * gh):
        counts[c] = 0
    flat = grid.reshape(grid.size)
    # unsigned cell and entry indices: no negative-index wrap-around in the inner loop
    row_stride = np.uint64(grid.shape[1])
    cells_per_row = np.uint64(gw)
    radius = np.float64(sprite_radius_px)
    cell = np.float64(cell_px)
    n = 0
    if radius > 0 and cell > 0 and is_finite(radius) and is_finite(cell):
        n = max(min(n_slots, alive.shape[0], has_world.shape[0], screen_px.shape[0],
                    intensity.shape[0], status.shape[0]), 0)
    r2 = radius * radius
    n_bands = (gh + GRID_BAND_ROWS - 1) // GRID_BAND_ROWS

    # 1. the bands each drawable slot touches; members per band, in slot order
    first_band = np.empty(n, np.int32)  # −1: not drawn
    last_band = np.empty(n, np.int32)
    band_end = np.zeros(n_bands + 1, np.int64)
    for i in range(n):
        first_band[i] = -1
        if not (alive[i] and has_world[i]):
            continue
        s = status[i]
        if s != STATUS_INSIDE and s != STATUS_LEAVING:
            continue
        if not intensity[i] > 0:
            continue
        px = np.float64(screen_px[i, 0])
        py = np.float64(screen_px[i, 1])
        if not (is_finite(px) and is_finite(py)):
            continue
        y_lo = (py - radius) / cell
        y_hi = (py + radius) / cell
        if (px + radius) / cell < 0 or y_hi < 0 or (px - radius) / cell >= gw or y_lo >= gh:
            continue
        b0 = int(max(y_lo, 0.0)) // GRID_BAND_ROWS
        b1 = int(min(y_hi, gh - 1.0)) // GRID_BAND_ROWS
        first_band[i] = b0
        last_band[i] = b1
        for b in range(b0, b1 + 1):
            band_end[b + 1] += 1
    for b in range(n_bands):
        band_end[b + 1] += band_end[b]
    members = np.empty(band_end[n_bands], np.int32)
    for i in range(n):
        if first_band[i] < 0:
            continue
        for b in range(first_band[i], last_band[i] + 1):
            members[band_end[b]] = i
            band_end[b] += 1  # ends as the end of band b, which starts at band_end[b - 1]

    # 2. insert band by band
    dxx = np.empty(gw, np.float64)  # squared distance to each column of the particle's box
    start = 0
    for band in range(n_bands):
        row_lo = band * GRID_BAND_ROWS
        row_hi = min(row_lo + GRID_BAND_ROWS, gh) - 1
        for p in range(start, band_end[band]):
            i = members[p]
            slot = np.int32(i)
            level = intensity[i]
            px = np.float64(screen_px[i, 0])
            py = np.float64(screen_px[i, 1])
            cx0 = int(max((px - radius) / cell, 0.0))
            n_cols = int(min((px + radius) / cell, gw - 1.0)) - cx0 + 1
            cy0 = max(int(max((py - radius) / cell, 0.0)), row_lo)
            cy1 = min(int(min((py + radius) / cell, gh - 1.0)), row_hi)
            for q in range(n_cols):
                x0 = (cx0 + q) * cell
                dx = max(x0 - px, px - (x0 + cell), 0.0)
                dxx[q] = dx * dx
            for cy in range(cy0, cy1 + 1):
                y0 = cy * cell
                dy = max(y0 - py, py - (y0 + cell), 0.0)
                lim = r2 - dy * dy
                c = np.uint64(cy) * cells_per_row + np.uint64(cx0)
                g = np.uint64(cy) * row_stride + np.uint64(cx0) * _U_PER_CELL
                for q in range(n_cols):
                    inside = dxx[q] <= lim
                    k = counts[c]
                    if k < MAX_PER_CELL:
                        flat[g + np.uint64(k)] = slot  # harmless past the count if outside
                        counts[c] = k + inside
                    elif inside:  # full: replace the first dimmest if strictly brighter
                        dimmest = np.uint64(0)
                        dimmest_level = intensity[flat[g]]
                        for j in range(1, MAX_PER_CELL):
                            v = intensity[flat[g + np.uint64(j)]]
                            if v < dimmest_level:
                                dimmest = np.uint64(j)
                                dimmest_level = v
                        if level > dimmest_level:
                            flat[g + dimmest] = slot
                    c += _U_ONE
                    g += _U_PER_CELL
        start = band_end[band]

    # 3. terminators
    full = 0
    for cy in range(gh):
        for cx in range(gw):
            k = counts[cy * gw + cx]
            if k < MAX_PER_CELL:
                grid[cy, cx * MAX_PER_CELL + k] = NO_PARTICLE
            else:
                full += 1
    return full
