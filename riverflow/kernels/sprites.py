"""The GPU tables of the per-pixel sprite blending, rebuilt on the CPU each frame.

Re-does the two tables of Proland's ``DrawRiversTask`` (reference §4.2–4.3) in a form that
costs the CPU one counting sort instead of inserting every sprite in every cell it touches;
another module uploads them to textures and the water fragment shader reads them:

* **sprite table** (RGBA32F, ``PARTICLES_PER_ROW`` sprites a row, ``TEXELS_PER_PARTICLE``
  texels each): entry ``e`` is at row ``e // 256``, texels ``3·(e % 256) + 0..2``:

  ====== ============ ============ ============ ============
  texel  R            G            B            A
  ====== ============ ============ ============ ============
  0      screen x px  screen y px  world x m    world y m
  1      offset x m   offset y m   intensity    r px (not ×3)
  2      status       velocity x   velocity y   world z m
  ====== ============ ============ ============ ============

  The entries are the particles with a usable position (alive, with a world position, finite
  screen, world and intensity values after the cast to float32), in this order: first the
  ``n_drawn`` *drawn* ones (INSIDE or LEAVING, intensity > 0, centre in the sprite grid below:
  the sprites of the water), sorted by grid cell (row-major) and by slot within a cell; then
  the other usable ones (for the particle and arrow overlays), in slot order. Entries after
  the last, up to the end of its row, are free (all zeros but status = −1), so that whole rows
  can be uploaded. Proland kept one row per slot in RGBA16F (~0.25 m steps at 300 m); 256 a row
  keep the texture within GL size limits for any pool, and RGBA32F keeps world positions to
  ≤ 1 mm steps within ±8 km. The layout is written in one place (``_write_entry``) and read in
  one (``params.glsl``): a value per sprite more is a texel more (``TEXELS_PER_PARTICLE``).

* **sprite grid** (R32I, ``gw + 1`` × ``gh``): screen cells of ``cell_w`` × ``cell_h`` pixels,
  with ``margin_x``, ``margin_y`` cells more on each side (drawn sprites whose centre is off
  screen but whose disc reaches into it); cell (cx, cy) covers x in
  [(cx − margin_x)·cell_w, (cx − margin_x + 1)·cell_w), likewise y, row 0 at the bottom (like
  ``gl_FragCoord``). Texel (cx, cy) holds the first entry of cell (cx, cy), texel (gw, cy) the
  end of row cy's entries: the drawn sprites whose centres lie in cells cx0..cx1 of row cy are
  the entries [grid[cy, cx0], grid[cy, cx1 + 1]) (one range: the table is sorted row-major).

A pixel finds the sprites that cover it (disc of radius ``SPRITE_RADIUS_FACTOR``·r around
their centre) by visiting the cell rows within that radius and, in each, the range of the
cells that the disc's chord at that row meets (``sprites.glsl``'s ``sprite_rows`` /
``sprite_range``). Proland inserted each sprite in every cell its disc touches, up to 16 a
cell, and the CPU paid per touched cell (~40 at Proland-like cells of r, ~6× the particles):
here it pays per particle, every covering sprite is found (no cap of 16), and what the upload
carries is the sprite table plus 4 bytes a cell. Cells of ``CELL_W_FACTOR``·r ×
``CELL_H_FACTOR``·r px (``sprite_grid``): wide rows cost the shader fewer range look-ups (two
texel fetches a row, ~3 rows), narrow columns fewer candidates tested (~12 centres a pixel,
~6 of them covering; Poisson disk ~0.87 particles per (2r)²).
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from riverflow.components.status import FlowStatus
from riverflow.kernels._jit import JIT_OPTIONS, is_finite

PARTICLES_PER_ROW = 256
"""Sprite entries per row of the sprite table."""
TEXELS_PER_PARTICLE = 3
"""RGBA texels per entry of the sprite table."""
SPRITE_RADIUS_FACTOR = 3.0
"""Sprite disc radius in units of the particle radius r (Proland ``riverParticleRadiusFactor``)."""
NO_PARTICLE = -1
"""The status written into a free entry of the sprite table."""
CELL_W_FACTOR = 1.0
"""Sprite grid cell width in units of r (at least 1 px)."""
CELL_H_FACTOR = 3.0
"""Sprite grid cell height in units of r (at least 1 px)."""
MAX_CANDIDATES = 128
"""Sprite centres a pixel looks at, at most (~12 in a Poisson disk of radius r; the bound only
keeps a pathological pile of particles from stalling the GPU: the coverage and grid modes
show where it was reached)."""
COVERAGE_FULL = 16
"""The coverage mode's red is the covering sprites / this (Proland's 16 a cell)."""

STATUS_INSIDE = int(FlowStatus.INSIDE)
STATUS_LEAVING = int(FlowStatus.LEAVING)
_TEXELS_PER_ROW = PARTICLES_PER_ROW * TEXELS_PER_PARTICLE


class SpriteSource(NamedTuple):
    """The particle pool's columns that the sprite table is made of (capacity C).

    ``alive``, ``has_world`` (C,) bool; ``screen_px`` (C, 2) float32 [px], origin bottom-left;
    ``world_m`` (C, 3) float64 [m]; ``offset_m`` (C, 2) float32 [m]; ``intensity`` (C,)
    float32; ``status`` (C,) uint8 FlowStatus; ``velocity_mps`` (C, 2) float32 [m/s].
    """

    alive: np.ndarray
    has_world: np.ndarray
    screen_px: np.ndarray
    world_m: np.ndarray
    offset_m: np.ndarray
    intensity: np.ndarray
    status: np.ndarray
    velocity_mps: np.ndarray


def sprite_source(pool) -> SpriteSource:
    """The :class:`SpriteSource` of a :class:`~riverflow.components.particles.ParticlePool`."""
    return SpriteSource(pool.alive, pool.has_world, pool.screen_px, pool.world_m, pool.offset_m,
                        pool.intensity, pool.status, pool.velocity_mps)


class SpriteGrid(NamedTuple):
    """Shape of the sprite grid: cells of ``cell_w`` × ``cell_h`` px, ``margin_x``,
    ``margin_y`` cells beyond each screen edge, ``gw`` × ``gh`` cells in all (margins
    included); the R32I texture is (gw + 1) × gh."""

    cell_w: int
    cell_h: int
    margin_x: int
    margin_y: int
    gw: int
    gh: int


def _cell_side(factor: float, radius_px: float) -> int:
    return max(1, math.floor(factor * radius_px)) if is_finite(radius_px) else 1


def sprite_grid(width_px: float, height_px: float, radius_px: float) -> SpriteGrid:
    """The sprite grid of a ``width_px`` × ``height_px`` viewport and particle radius
    ``radius_px`` (sprites are 3r): cells of ⌊``CELL_W_FACTOR``·r⌋ × ⌊``CELL_H_FACTOR``·r⌋
    px (at least 1 px each; 1 px for a non-finite radius), margins of ⌈3r / cell⌉ + 1 cells,
    ``gw = ⌈W / cell_w⌉ + 2·margin_x`` (likewise ``gh``); a zero-size viewport has no screen
    cells, only margins."""
    r = float(radius_px)
    r = r if is_finite(r) and r > 0 else 0.0
    cell_w = _cell_side(CELL_W_FACTOR, r)
    cell_h = _cell_side(CELL_H_FACTOR, r)
    reach = SPRITE_RADIUS_FACTOR * r
    margin_x = math.ceil(reach / cell_w) + 1
    margin_y = math.ceil(reach / cell_h) + 1
    w = float(width_px)
    h = float(height_px)
    w = w if is_finite(w) and w > 0 else 0.0
    h = h if is_finite(h) and h > 0 else 0.0
    return SpriteGrid(cell_w, cell_h, margin_x, margin_y,
                      math.ceil(w / cell_w) + 2 * margin_x, math.ceil(h / cell_h) + 2 * margin_y)


def param_table_rows(n_entries: int) -> int:
    """Rows of the sprite table holding ``n_entries`` entries (0 for none)."""
    return (max(int(n_entries), 0) + PARTICLES_PER_ROW - 1) // PARTICLES_PER_ROW


def empty_sprite_tables(capacity: int, grid: SpriteGrid) -> tuple[np.ndarray, np.ndarray,
                                                                  np.ndarray]:
    """Allocate (params, cells, scratch) for a pool of ``capacity`` slots and ``grid``:
    params (rows, 768, 4) float32 zeros (at least one row); cells (gh·(gw + 1) + 2,) int32
    zeros, whose first gh·(gw + 1) values are the grid texture ((gh, gw + 1) row-major:
    :func:`grid_texels`); scratch (capacity,) int32 (each slot's cell while the tables are
    built)."""
    rows = max(param_table_rows(capacity), 1)
    params = np.zeros((rows, _TEXELS_PER_ROW, 4), np.float32)
    cells = np.zeros(grid.gh * (grid.gw + 1) + 2, np.int32)
    return params, cells, np.zeros(max(int(capacity), 1), np.int32)


def grid_texels(cells: np.ndarray, grid: SpriteGrid) -> np.ndarray:
    """The (gh, gw + 1) grid texture held by ``cells`` (a view)."""
    return cells[:grid.gh * (grid.gw + 1)].reshape(grid.gh, grid.gw + 1)


@njit(**JIT_OPTIONS)
def slot_span(alive):
    """1 + the highest live slot (0 if none): the ``n_slots`` that covers every particle."""
    for i in range(alive.shape[0] - 1, -1, -1):
        if alive[i]:
            return i + 1
    return 0


@njit(inline="always", **JIT_OPTIONS)
def _finite_or_zero(v):
    return v if is_finite(v) else np.float32(0.0)


@njit(inline="always", **JIT_OPTIONS)
def _write_free(out, e):
    row = e // PARTICLES_PER_ROW
    t = (e % PARTICLES_PER_ROW) * TEXELS_PER_PARTICLE
    for k in range(TEXELS_PER_PARTICLE):
        for c in range(4):
            out[row, t + k, c] = 0.0
    out[row, t + 2, 0] = NO_PARTICLE


@njit(inline="always", **JIT_OPTIONS)
def _write_entry(out, e, src, i, r):
    """Entry ``e`` of the table ``out`` from slot ``i`` of ``src`` (usable: see ``_usable``)."""
    row = e // PARTICLES_PER_ROW
    t = (e % PARTICLES_PER_ROW) * TEXELS_PER_PARTICLE
    out[row, t, 0] = np.float32(src.screen_px[i, 0])
    out[row, t, 1] = np.float32(src.screen_px[i, 1])
    out[row, t, 2] = np.float32(src.world_m[i, 0])
    out[row, t, 3] = np.float32(src.world_m[i, 1])
    out[row, t + 1, 0] = _finite_or_zero(np.float32(src.offset_m[i, 0]))
    out[row, t + 1, 1] = _finite_or_zero(np.float32(src.offset_m[i, 1]))
    out[row, t + 1, 2] = np.float32(src.intensity[i])
    out[row, t + 1, 3] = r
    out[row, t + 2, 0] = np.float32(src.status[i])
    out[row, t + 2, 1] = _finite_or_zero(np.float32(src.velocity_mps[i, 0]))
    out[row, t + 2, 2] = _finite_or_zero(np.float32(src.velocity_mps[i, 1]))
    out[row, t + 2, 3] = np.float32(src.world_m[i, 2])


@njit(inline="always", **JIT_OPTIONS)
def _usable(src, i):
    """Slot ``i`` holds a particle with finite float32 screen, world and intensity values."""
    if not (src.alive[i] and src.has_world[i]):
        return False
    return (is_finite(np.float32(src.screen_px[i, 0])) and is_finite(np.float32(src.screen_px[i, 1]))
            and is_finite(np.float32(src.world_m[i, 0])) and is_finite(np.float32(src.world_m[i, 1]))
            and is_finite(np.float32(src.world_m[i, 2]))
            and is_finite(np.float32(src.intensity[i])))


@njit(**JIT_OPTIONS)
def build_sprite_tables(src, radius_px, n_slots, grid, params, cells, scratch):
    """Write this frame's sprite table ``params`` and sprite grid ``cells`` (module docstring)
    from slots [0, ``n_slots``) of ``src`` (a :class:`SpriteSource`).

    ``radius_px`` r [px] (written into every entry; non-finite → 0); ``grid`` a
    :class:`SpriteGrid`; ``params`` (rows, 768, 4) float32; ``cells`` (≥ gh·(gw + 1) + 2,)
    int32 (:func:`empty_sprite_tables`; texel (cx, cy) is ``cells[cy·(gw + 1) + cx]``);
    ``scratch`` (≥ n_slots,) int32. ``n_slots`` is clamped to the columns and to ``scratch``;
    entries beyond ``params``' rows are dropped (undrawn ones first), the grid clamped to them.
    A non-positive cell size or a non-positive or non-finite radius draws nothing (every
    usable entry goes to the tail). Returns (n_drawn, n_entries, rows): the drawn entries
    [0, n_drawn), all entries [0, n_entries), the table rows written (whole rows, the last one
    padded with free entries).

    One counting sort: each slot's cell, the cells' starts (an exclusive prefix sum, kept
    one place ahead so that the scatter's cursors end as the starts), the entries scattered
    in slot order (stable).
    """
    n = min(n_slots, src.alive.shape[0], src.has_world.shape[0], src.screen_px.shape[0],
            src.world_m.shape[0], src.offset_m.shape[0], src.intensity.shape[0],
            src.status.shape[0], src.velocity_mps.shape[0], scratch.shape[0])
    n = max(n, 0)
    capacity = params.shape[0] * PARTICLES_PER_ROW
    if params.shape[1] < _TEXELS_PER_ROW or params.shape[2] < 4:
        capacity = 0
    gw = grid.gw
    gh = grid.gh
    stride = gw + 1
    size = gh * stride
    if gw <= 0 or gh <= 0 or cells.shape[0] < size + 2:
        gw = gh = stride = size = 0
    radius = np.float64(radius_px)
    r = _finite_or_zero(np.float32(radius_px))
    cw = np.float64(grid.cell_w)
    ch = np.float64(grid.cell_h)
    drawing = size > 0 and cw > 0 and ch > 0 and radius > 0 and is_finite(radius)
    for k in range(min(cells.shape[0], size + 2)):
        cells[k] = 0

    # 1. each slot's cell (≥ 0: drawn; −1: not usable; −2: usable, not drawn); counts at k + 2
    n_usable = 0
    for i in range(n):
        if not _usable(src, i):
            scratch[i] = -1
            continue
        n_usable += 1
        scratch[i] = -2
        if not drawing:
            continue
        s = src.status[i]
        if (s != STATUS_INSIDE and s != STATUS_LEAVING) or not src.intensity[i] > 0:
            continue
        fx = math.floor(np.float64(np.float32(src.screen_px[i, 0])) / cw) + grid.margin_x
        fy = math.floor(np.float64(np.float32(src.screen_px[i, 1])) / ch) + grid.margin_y
        if fx < 0 or fy < 0 or fx >= gw or fy >= gh:
            continue
        k = int(fy) * stride + int(fx)
        scratch[i] = k
        cells[k + 2] += 1
    # 2. cells[k + 1] = start of cell k (row ends, never counted, get the next row's start)
    for k in range(2, size + 2):
        cells[k] += cells[k - 1]
    n_drawn = cells[size + 1] if size > 0 else 0
    # 3. scatter: drawn entries by cell, then the others; cursors cells[k + 1] end as the
    #    starts of cell k + 1, so that cells[k] is the start of cell k
    tail = n_drawn
    for i in range(n):
        k = scratch[i]
        if k == -1:
            continue
        if k >= 0:
            e = cells[k + 1]
            cells[k + 1] = e + 1
        else:
            e = tail
            tail += 1
        if e < capacity:
            _write_entry(params, e, src, i, r)
    if n_drawn > capacity:      # a table too small for the pool: the grid stops at its end
        for k in range(size):
            cells[k] = min(cells[k], capacity)
    n_entries = min(n_usable, capacity)
    n_drawn = min(n_drawn, capacity)
    rows = (n_entries + PARTICLES_PER_ROW - 1) // PARTICLES_PER_ROW
    for e in range(n_entries, rows * PARTICLES_PER_ROW):
        _write_free(params, e)
    return n_drawn, n_entries, rows
