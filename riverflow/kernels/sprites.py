"""The GPU tables of the per-pixel sprite blending: the CPU sorts, the GPU lists.

Re-does the two tables of Proland's ``DrawRiversTask`` (reference §4.2–4.3). Proland filled
the sprite indirection grid on the CPU, every sprite into every cell its disc touches (~40 cells
of r px each, ~6× the particles); here the CPU only sorts the sprites by screen bin (one
counting sort, :func:`build_sprite_tables`) and a GPU pass (``sprite_lists.glsl``) gathers each
grid cell's list from the bins around it. What the CPU uploads is the sprite table (the rows in
use) and 4 bytes a bin, not the 64 bytes a cell of the grid:

* **sprite table** (RGBA32F, ``PARTICLES_PER_ROW`` entries a row, ``TEXELS_PER_PARTICLE``
  texels each): entry ``e`` is at row ``e // 256``, texels ``4·(e % 256) + 0..3``:

  ====== ============ ============ ============ ============
  texel  R            G            B            A
  ====== ============ ============ ============ ============
  0      screen x px  screen y px  world x m    world y m
  1      offset x m   offset y m   intensity    r px (not ×3)
  2      status       velocity x   velocity y   world z m
  3      foam 0…1     spill c      spill RGB    0
  ====== ============ ============ ============ ============

  The spill tint (issue 24, :func:`riverflow.kernels.spill.sample_tint`) is the concentration
  c [kg/m³] the particle carries and its colour, 8 bits a channel packed into one exact float
  (r·65536 + g·256 + b, r, g, b in 0…255 of linear RGB; ``spill.glsl`` unpacks it).

  The entries are the particles with a usable position (alive, with a world position, finite
  screen, world and intensity values after the cast to float32), in this order: first the
  ``n_drawn`` *drawn* ones (INSIDE or LEAVING, intensity > 0, centre in a bin: the sprites of
  the water), sorted by bin (row-major) and by slot within a bin; then the other usable ones
  (for the particle and arrow overlays), in slot order. Entries after the last, up to the end
  of its row, are free (all zeros but status = −1), so that whole rows can be uploaded. Proland
  kept one row per slot in RGBA16F (~0.25 m steps at 300 m); 256 a row keep the texture within
  GL size limits for any pool, and RGBA32F keeps world positions to ≤ 1 mm steps within ±8 km.
  The layout is written in one place (``_write_entry``) and read in one (``params.glsl``): a
  value per sprite more is a texel more (``TEXELS_PER_PARTICLE``).

* **sprite bins** (R32I, ``bw + 1`` × ``bh``, :class:`SpriteBins`): screen bins of ``bin_w`` ×
  ``bin_h`` px, with ``margin_x``, ``margin_y`` bins more beyond each screen edge (sprites whose
  centre is off screen but whose disc reaches into it); bin (bx, by) covers x in
  [(bx − margin_x)·bin_w, (bx − margin_x + 1)·bin_w), likewise y, row 0 at the bottom (like
  ``gl_FragCoord``). Texel (bx, by) holds the bin's first entry, texel (bw, by) the end of row
  by's entries: the drawn sprites whose centres lie in bins bx0..bx1 of row by are the entries
  [bins[by, bx0], bins[by, bx1 + 1]) (one range: the table is sorted row-major).

* **sprite grid** (made on the GPU: RGBA32I, 4 layers of gw × gh, ``sprite_grid_shape``):
  screen cells of r px; cell (cx, cy) lists in layers 0..3 of texel (cx, cy) up to
  ``MAX_PER_CELL`` (16) entries of the sprite table whose sprite disc (radius
  ``SPRITE_RADIUS_FACTOR``·r) meets the cell, then ``NO_PARTICLE`` (−1); a cell that more
  sprites meet keeps the 16 brightest. The water shader's per-pixel loop reads it as Proland's
  did. Cells of r px, where Proland used r/2: particles sit ~2.14 r apart (Poisson disk, ~0.87
  per (2r)²); a cell of side c is touched by every sprite whose centre lies within 3r of it, an
  area c² + 4·c·3r + π(3r)² = 41.3 r² for c = r, so ~9 sprites on average, safely under 16.
  An integer cell lets the shader find its cell exactly: ``ivec2(gl_FragCoord.xy) / cell``
  (pixel centres are at i + 0.5, as in ``screen_px``), clamped to the grid.
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from riverflow.kernels._jit import JIT_OPTIONS, is_finite
from riverflow.kernels.advection import STATUS_INSIDE, STATUS_LEAVING

PARTICLES_PER_ROW = 256
"""Sprite entries per row of the sprite table."""
TEXELS_PER_PARTICLE = 4
"""RGBA texels per entry of the sprite table."""
SPRITE_RADIUS_FACTOR = 3.0
"""Sprite disc radius in units of the particle radius r (Proland ``riverParticleRadiusFactor``)."""
NO_PARTICLE = -1
"""The grid's list terminator, and the status written into a free entry of the sprite table."""
MAX_PER_CELL = 16
"""Sprite table entries a grid cell lists (4 RGBA32I layers)."""
BIN_W_FACTOR = 1.0
"""Sprite bin width in units of r (at least 1 px)."""
BIN_H_FACTOR = 7.0
"""Sprite bin height in units of r (at least 1 px): the sprites that may meet a grid cell of
r px lie within 7r of rows, so a cell gathers from 2 or 3 bin rows, one range of entries each
(bins of r × 3r, 2r × 2r or r × r cost the GPU pass 10–70 % more on llvmpipe)."""

_TEXELS_PER_ROW = PARTICLES_PER_ROW * TEXELS_PER_PARTICLE


class SpriteSource(NamedTuple):
    """The particle pool's columns that the sprite table is made of (capacity C).

    ``alive``, ``has_world`` (C,) bool; ``screen_px`` (C, 2) float32 [px], origin bottom-left;
    ``world_m`` (C, 3) float64 [m]; ``offset_m`` (C, 2) float32 [m]; ``intensity`` (C,)
    float32; ``status`` (C,) uint8 FlowStatus; ``velocity_mps`` (C, 2) float32 [m/s];
    ``foam`` (C,) float32 in [0, 1] (:mod:`riverflow.kernels.foam`); ``tint`` (C, 4) float32
    the spills' colour and concentration (:func:`riverflow.kernels.spill.sample_tint`).
    """

    alive: np.ndarray
    has_world: np.ndarray
    screen_px: np.ndarray
    world_m: np.ndarray
    offset_m: np.ndarray
    intensity: np.ndarray
    status: np.ndarray
    velocity_mps: np.ndarray
    foam: np.ndarray
    tint: np.ndarray


def sprite_source(pool) -> SpriteSource:
    """The :class:`SpriteSource` of a :class:`~riverflow.components.particles.ParticlePool`."""
    return SpriteSource(pool.alive, pool.has_world, pool.screen_px, pool.world_m, pool.offset_m,
                        pool.intensity, pool.status, pool.velocity_mps, pool.foam, pool.tint)


class SpriteBins(NamedTuple):
    """Shape of the sprite bins: bins of ``bin_w`` × ``bin_h`` px, ``margin_x``, ``margin_y``
    bins beyond each screen edge, ``bw`` × ``bh`` bins in all (margins included); the R32I
    texture is (bw + 1) × bh."""

    bin_w: int
    bin_h: int
    margin_x: int
    margin_y: int
    bw: int
    bh: int


def _side(factor: float, radius_px: float) -> int:
    return max(1, math.floor(factor * radius_px))


def sprite_grid_shape(width_px: float, height_px: float, radius_px: float) -> tuple[int, int, int]:
    """(cell_px, gw, gh) of the sprite grid for a ``width_px`` × ``height_px`` viewport
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


def sprite_bins(width_px: float, height_px: float, radius_px: float) -> SpriteBins:
    """The sprite bins of a ``width_px`` × ``height_px`` viewport and particle radius
    ``radius_px`` (sprites are 3r): bins of ⌊``BIN_W_FACTOR``·r⌋ × ⌊``BIN_H_FACTOR``·r⌋ px
    (at least 1 px each; a non-finite or negative radius counts as 0), margins of ⌈3r / bin⌉ + 1
    bins, ``bw = ⌈W / bin_w⌉ + 2·margin_x`` (likewise ``bh``); a zero-size viewport has no
    screen bins, only margins."""
    r = float(radius_px)
    r = r if is_finite(r) and r > 0 else 0.0
    bin_w = _side(BIN_W_FACTOR, r)
    bin_h = _side(BIN_H_FACTOR, r)
    reach = SPRITE_RADIUS_FACTOR * r
    margin_x = math.ceil(reach / bin_w) + 1
    margin_y = math.ceil(reach / bin_h) + 1
    w = float(width_px)
    h = float(height_px)
    w = w if is_finite(w) and w > 0 else 0.0
    h = h if is_finite(h) and h > 0 else 0.0
    return SpriteBins(bin_w, bin_h, margin_x, margin_y,
                      math.ceil(w / bin_w) + 2 * margin_x, math.ceil(h / bin_h) + 2 * margin_y)


def param_table_rows(n_entries: int) -> int:
    """Rows of the sprite table holding ``n_entries`` entries (0 for none)."""
    return (max(int(n_entries), 0) + PARTICLES_PER_ROW - 1) // PARTICLES_PER_ROW


def empty_sprite_tables(capacity: int, bins: SpriteBins) -> tuple[np.ndarray, np.ndarray,
                                                                  np.ndarray]:
    """Allocate (params, starts, scratch) for a pool of ``capacity`` slots and ``bins``:
    params (rows, 1024, 4) float32 zeros (at least one row); starts (bh·(bw + 1) + 2,) int32
    zeros, whose first bh·(bw + 1) values are the bins texture ((bh, bw + 1) row-major:
    :func:`bin_texels`); scratch (2·capacity,) int32 (the slots that get an entry and their
    bins while the tables are built)."""
    rows = max(param_table_rows(capacity), 1)
    params = np.zeros((rows, _TEXELS_PER_ROW, 4), np.float32)
    starts = np.zeros(bins.bh * (bins.bw + 1) + 2, np.int32)
    return params, starts, np.zeros(2 * max(int(capacity), 1), np.int32)


def bin_texels(starts: np.ndarray, bins: SpriteBins) -> np.ndarray:
    """The (bh, bw + 1) bins texture held by ``starts`` (a view)."""
    return starts[:bins.bh * (bins.bw + 1)].reshape(bins.bh, bins.bw + 1)


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
def _channel8(v):
    """A colour channel in [0, 1] as 0…255 (0 if not finite)."""
    return int(min(max(v, 0.0), 1.0) * 255.0 + 0.5) if is_finite(v) else 0


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
    foam = np.float32(src.foam[i])
    out[row, t + 3, 0] = min(max(foam, np.float32(0.0)), np.float32(1.0)) if is_finite(foam) \
        else np.float32(0.0)
    c = np.float32(src.tint[i, 3])
    if is_finite(c) and c > np.float32(0.0):
        out[row, t + 3, 1] = c
        out[row, t + 3, 2] = np.float32(_channel8(src.tint[i, 0]) * 65536
                                        + _channel8(src.tint[i, 1]) * 256
                                        + _channel8(src.tint[i, 2]))
    else:
        out[row, t + 3, 1] = 0.0
        out[row, t + 3, 2] = 0.0
    out[row, t + 3, 3] = 0.0


@njit(inline="always", **JIT_OPTIONS)
def _usable(src, i):
    """Slot ``i`` holds a particle with finite float32 screen, world and intensity values."""
    if not (src.alive[i] and src.has_world[i]):
        return False
    return (is_finite(np.float32(src.screen_px[i, 0]))
            and is_finite(np.float32(src.screen_px[i, 1]))
            and is_finite(np.float32(src.world_m[i, 0]))
            and is_finite(np.float32(src.world_m[i, 1]))
            and is_finite(np.float32(src.world_m[i, 2]))
            and is_finite(np.float32(src.intensity[i])))


@njit(**JIT_OPTIONS)
def build_sprite_tables(src, radius_px, n_slots, bins, params, starts, scratch, with_tail):
    """Write this frame's sprite table ``params`` and bin starts ``starts`` (module docstring)
    from slots [0, ``n_slots``) of ``src`` (a :class:`SpriteSource`); with ``with_tail`` False
    the table ends after the drawn entries (nothing draws the others: no overlay is on).

    ``radius_px`` r [px] (written into every entry; non-finite → 0); ``bins`` a
    :class:`SpriteBins`; ``params`` (rows, 1024, 4) float32; ``starts`` (≥ bh·(bw + 1) + 2,)
    int32 (:func:`empty_sprite_tables`; texel (bx, by) is ``starts[by·(bw + 1) + bx]``);
    ``scratch`` (≥ 2·n_slots,) int32. ``n_slots`` is clamped to the columns and to half of
    ``scratch``;
    entries beyond ``params``' rows are dropped (the tail first), the bins clamped to them.
    A non-positive bin size or a non-positive or non-finite radius draws nothing (every usable
    entry goes to the tail). Returns (n_drawn, n_entries, rows): the drawn entries
    [0, n_drawn), all entries [0, n_entries), the table rows written (whole rows, the last one
    padded with free entries).

    One stable counting sort: the slots that get an entry listed in slot order with their
    bins (``scratch``: the slots, then the bins; −2: the tail); the bins' starts (a prefix sum
    kept one place ahead, so that the scatter's cursors end as the starts); the listed entries
    scattered. One pass over the slots, one over the bins and one over the list (without
    overlays ~1/4 of the pool: the scatter does not go over the slots again); no per-cell
    work.
    """
    n = min(n_slots, src.alive.shape[0], src.has_world.shape[0], src.screen_px.shape[0],
            src.world_m.shape[0], src.offset_m.shape[0], src.intensity.shape[0],
            src.status.shape[0], src.velocity_mps.shape[0], scratch.shape[0] // 2)
    n = max(n, 0)
    capacity = params.shape[0] * PARTICLES_PER_ROW
    if params.shape[1] < _TEXELS_PER_ROW or params.shape[2] < 4:
        capacity = 0
    bw = bins.bw
    bh = bins.bh
    stride = bw + 1
    size = bh * stride
    if bw <= 0 or bh <= 0 or starts.shape[0] < size + 2:
        bw = bh = stride = size = 0
    radius = np.float64(radius_px)
    r = _finite_or_zero(np.float32(radius_px))
    bin_w = np.float64(bins.bin_w)
    bin_h = np.float64(bins.bin_h)
    drawing = size > 0 and bin_w > 0 and bin_h > 0 and radius > 0 and is_finite(radius)
    for k in range(min(starts.shape[0], size + 2)):
        starts[k] = 0
    listed = scratch[:n]                # the slots that get an entry, in slot order
    keys = scratch[n:2 * n]             # and their bins (−2: the tail); counts at k + 2

    # 1. the slots that get an entry, with their bins
    m = 0
    n_usable = 0
    for i in range(n):
        s = src.status[i]
        drawn = drawing and (s == STATUS_INSIDE or s == STATUS_LEAVING) and src.intensity[i] > 0
        if not (drawn or with_tail) or not _usable(src, i):
            continue                    # (the cheap tests first: ~3/4 of a pool is not drawn)
        n_usable += 1
        k = -2
        if drawn:
            qx = np.float64(np.float32(src.screen_px[i, 0])) / bin_w  # in bins from the
            qy = np.float64(np.float32(src.screen_px[i, 1])) / bin_h  # screen's corner; beyond
            if (-bins.margin_x <= qx < bw - bins.margin_x             # the margins: never on
                    and -bins.margin_y <= qy < bh - bins.margin_y):   # screen
                k = ((int(math.floor(qy)) + bins.margin_y) * stride
                     + int(math.floor(qx)) + bins.margin_x)
                starts[k + 2] += 1
            elif not with_tail:
                continue
        listed[m] = i
        keys[m] = k
        m += 1
    # 2. starts[k + 1] = first entry of bin k (row ends, never counted, get the next row's)
    for k in range(2, size + 2):
        starts[k] += starts[k - 1]
    n_drawn = starts[size + 1] if size > 0 else 0
    # 3. scatter: drawn entries by bin, then the others; the cursors starts[k + 1] end as the
    #    first entries of bin k + 1, so that starts[k] is the first entry of bin k
    rest = n_drawn
    for j in range(m):
        k = keys[j]
        if k >= 0:
            e = starts[k + 1]
            starts[k + 1] = e + 1
        else:
            e = rest
            rest += 1
        if e < capacity:
            _write_entry(params, e, src, listed[j], r)
    if n_drawn > capacity:      # a table too small for the pool: the bins stop at its end
        for k in range(size):
            starts[k] = min(starts[k], capacity)
    if not with_tail:
        n_usable = n_drawn
    n_entries = min(n_usable, capacity)
    n_drawn = min(n_drawn, capacity)
    rows = (n_entries + PARTICLES_PER_ROW - 1) // PARTICLES_PER_ROW
    for e in range(n_entries, rows * PARTICLES_PER_ROW):
        _write_free(params, e)
    return n_drawn, n_entries, rows
