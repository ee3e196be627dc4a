"""Wave-tile kernels: periodic Perlin height tiles, slopes, and their mip chains (CPU only).

Re-does Proland's ``PerlinWaveTile`` and ``AnimatedPerlinWaveTile`` (reference §4.5). A wave tile
is a periodic slope texture that the river shader samples at ``world offset / wave_length_m``;
these kernels only make the numbers (the GL upload lives elsewhere).

Layout and units
    Heights are ``(F, n, n)`` float64, slopes ``(F, n, n, 2)`` float32, both ``[frame, row, col]``:
    the column is the texture's u axis, the row its v axis (row 0 is uploaded first, v = 0).
    ``slopes[..., 0] = ∂h/∂u`` and ``slopes[..., 1] = ∂h/∂v``, central differences with
    wrap-around on both axes, per *level-0 texel*: level k (spacing 2ᵏ level-0 texels) divides
    by 2·2ᵏ, so every level's slopes are in the same units and a mip chain stays consistent.

Noise
    Sum of :data:`OCTAVES` octaves of gradient noise; octave k has ``base_cells · 2ᵏ`` lattice
    cells across the tile and amplitude ``0.5ᵏ``, the quintic fade ``6t⁵ − 15t⁴ + 10t³``, and
    lattice indices taken modulo the octave's cell count before hashing, so the tile is exactly
    periodic. Texel (r, c) samples the noise at its centre, ``((c + ½)/S, (r + ½)/S)`` of the tile.
    Proland used ``32 · 2ᵏ`` cells and sampled texel corners: at 256 px its octaves of 128 and 256
    cells have a lattice point on every (second) texel, where gradient noise is zero, so they
    vanish or alias. Our default ``base_cells = 8`` (8, 16, 32, 64 cells) keeps at least 4 texels
    per cell at 256 px (2 at 128 px); callers refuse fewer than 2.

Hashing
    ``perm`` is a seeded permutation of 0…255 (:func:`permutation`, a Fisher–Yates shuffle driven
    by an integer hash, so numba and numpy agree bit for bit); the gradient of lattice point
    (i, j) of octave k is ``grad[perm[(perm[(perm[k] + i) & 255] + j) & 255]]`` (one more level for
    z in 3-D). 2-D gradients are 256 unit vectors at angles 2πi/256 (as Proland); 3-D ones are
    256 unit vectors of a Fibonacci sphere (Proland drew random ones; these are evenly spread).
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from riverflow.kernels._jit import JIT_OPTIONS

PERM_SIZE = 256
"""Entries of the permutation and of each gradient table; octaves may have at most this many
cells across the tile."""
OCTAVES = 4
MASK32 = 0xFFFFFFFF


# ---- tables -----------------------------------------------------------------------------------

@njit(**JIT_OPTIONS)
def hash32(x):
    """A 32-bit integer hash (Wellons' lowbias32) of the low 32 bits of ``x``; in [0, 2³²)."""
    x = x & MASK32
    x ^= x >> 16
    x = (x * 0x7FEB352D) & MASK32
    x ^= x >> 15
    x = (x * 0x846CA68B) & MASK32
    x ^= x >> 16
    return x


@njit(**JIT_OPTIONS)
def permutation(seed):
    """(256,) int64: a permutation of 0…255, shuffled by Fisher–Yates from ``seed`` (an int)."""
    perm = np.arange(PERM_SIZE).astype(np.int64)
    s = hash32(seed)
    for i in range(PERM_SIZE - 1, 0, -1):
        j = hash32(s + i) % (i + 1)
        t = perm[i]
        perm[i] = perm[j]
        perm[j] = t
    return perm


@njit(**JIT_OPTIONS)
def gradients_2d():
    """(256, 2) float64 unit vectors at angles 2πi/256."""
    g = np.empty((PERM_SIZE, 2))
    for i in range(PERM_SIZE):
        a = 2.0 * math.pi * i / PERM_SIZE
        g[i, 0] = math.cos(a)
        g[i, 1] = math.sin(a)
    return g


@njit(**JIT_OPTIONS)
def gradients_3d():
    """(256, 3) float64 unit vectors evenly spread on the sphere (Fibonacci lattice)."""
    g = np.empty((PERM_SIZE, 3))
    golden = math.pi * (3.0 - math.sqrt(5.0))
    for i in range(PERM_SIZE):
        z = 1.0 - (2.0 * i + 1.0) / PERM_SIZE
        r = math.sqrt(1.0 - z * z)
        g[i, 0] = r * math.cos(golden * i)
        g[i, 1] = r * math.sin(golden * i)
        g[i, 2] = z
    return g


# ---- noise ------------------------------------------------------------------------------------

@njit(**JIT_OPTIONS)
def fade(t):
    """Quintic fade 6t⁵ − 15t⁴ + 10t³ (zero first and second derivatives at 0 and 1)."""
    return t * t * t * (t * (t * 6.0 - 15.0) + 10.0)


@njit(**JIT_OPTIONS)
def noise_2d(x, y, cells, octave, perm, grad):
    """Gradient noise at (x, y) [lattice cells], periodic with ``cells`` cells on both axes."""
    xf = math.floor(x)
    yf = math.floor(y)
    fx = x - xf
    fy = y - yf
    i0 = int(xf) % cells
    j0 = int(yf) % cells
    i1 = (i0 + 1) % cells
    j1 = (j0 + 1) % cells
    off = perm[octave & 255]
    a0 = perm[(off + i0) & 255]
    a1 = perm[(off + i1) & 255]
    g00 = perm[(a0 + j0) & 255]
    g10 = perm[(a1 + j0) & 255]
    g01 = perm[(a0 + j1) & 255]
    g11 = perm[(a1 + j1) & 255]
    n00 = grad[g00, 0] * fx + grad[g00, 1] * fy
    n10 = grad[g10, 0] * (fx - 1.0) + grad[g10, 1] * fy
    n01 = grad[g01, 0] * fx + grad[g01, 1] * (fy - 1.0)
    n11 = grad[g11, 0] * (fx - 1.0) + grad[g11, 1] * (fy - 1.0)
    u = fade(fx)
    v = fade(fy)
    nx0 = n00 + u * (n10 - n00)
    nx1 = n01 + u * (n11 - n01)
    return nx0 + v * (nx1 - nx0)


@njit(**JIT_OPTIONS)
def _plane_3d(perm, grad, a0, a1, j0, j1, k, fx, fy, dz, u, v):
    """Bilinear blend of the four corner terms of one z plane (k: its lattice index, dz: the
    point's z offset from it); ``a0``, ``a1`` are the hashes of the two x indices."""
    h00 = perm[(perm[(a0 + j0) & 255] + k) & 255]
    h10 = perm[(perm[(a1 + j0) & 255] + k) & 255]
    h01 = perm[(perm[(a0 + j1) & 255] + k) & 255]
    h11 = perm[(perm[(a1 + j1) & 255] + k) & 255]
    n00 = grad[h00, 0] * fx + grad[h00, 1] * fy + grad[h00, 2] * dz
    n10 = grad[h10, 0] * (fx - 1.0) + grad[h10, 1] * fy + grad[h10, 2] * dz
    n01 = grad[h01, 0] * fx + grad[h01, 1] * (fy - 1.0) + grad[h01, 2] * dz
    n11 = grad[h11, 0] * (fx - 1.0) + grad[h11, 1] * (fy - 1.0) + grad[h11, 2] * dz
    nx0 = n00 + u * (n10 - n00)
    nx1 = n01 + u * (n11 - n01)
    return nx0 + v * (nx1 - nx0)


@njit(**JIT_OPTIONS)
def noise_3d(x, y, z, cells, cells_z, octave, perm, grad):
    """Gradient noise at (x, y, z) [lattice cells], periodic with ``cells`` cells on x and y and
    ``cells_z`` on z."""
    xf = math.floor(x)
    yf = math.floor(y)
    zf = math.floor(z)
    fx = x - xf
    fy = y - yf
    fz = z - zf
    i0 = int(xf) % cells
    j0 = int(yf) % cells
    k0 = int(zf) % cells_z
    i1 = (i0 + 1) % cells
    j1 = (j0 + 1) % cells
    k1 = (k0 + 1) % cells_z
    off = perm[octave & 255]
    a0 = perm[(off + i0) & 255]
    a1 = perm[(off + i1) & 255]
    u = fade(fx)
    v = fade(fy)
    n0 = _plane_3d(perm, grad, a0, a1, j0, j1, k0, fx, fy, fz, u, v)
    n1 = _plane_3d(perm, grad, a0, a1, j0, j1, k1, fx, fy, fz - 1.0, u, v)
    return n0 + fade(fz) * (n1 - n0)


@njit(**JIT_OPTIONS)
def perlin_height_2d(x_px, y_px, size, base_cells, octaves, perm, grad):
    """Height at tile coordinate (x_px, y_px) [level-0 texels, any real value; period ``size``].
    Texel (r, c) is at (c + ½, r + ½)."""
    h = 0.0
    amp = 1.0
    for k in range(octaves):
        cells = base_cells << k
        scale = cells / size
        h += amp * noise_2d(x_px * scale, y_px * scale, cells, k, perm, grad)
        amp *= 0.5
    return h


@njit(**JIT_OPTIONS)
def perlin_height_3d(x_px, y_px, z, size, base_cells, octaves, period_z, perm, grad):
    """Height at tile coordinate (x_px, y_px) [level-0 texels; period ``size``] and time
    coordinate ``z`` [lattice cells; period ``period_z``]. Every octave shares z."""
    h = 0.0
    amp = 1.0
    for k in range(octaves):
        cells = base_cells << k
        scale = cells / size
        h += amp * noise_3d(x_px * scale, y_px * scale, z, cells, period_z, k, perm, grad)
        amp *= 0.5
    return h


@njit(**JIT_OPTIONS)
def perlin_tile_2d(size, base_cells, octaves, perm, grad):
    """(1, S, S) float64 heights of a periodic Perlin tile of side ``size`` texels."""
    h = np.empty((1, size, size))
    for r in range(size):
        for c in range(size):
            h[0, r, c] = perlin_height_2d(c + 0.5, r + 0.5, size, base_cells, octaves, perm, grad)
    return h


def loop_z(frames: int, period_z: int) -> np.ndarray:
    """(F,) float64 time coordinates [lattice cells] of an F-frame loop: frame f is at
    z = period_z · f / F, so frame F would be frame 0 again (the noise has period ``period_z``)."""
    return period_z * np.arange(frames, dtype=np.float64) / frames


@njit(**JIT_OPTIONS)
def perlin_frames_3d(size, z, base_cells, octaves, period_z, perm, grad):
    """(F, S, S) float64 heights of the animated tile at time coordinates ``z`` (F,) float64
    [lattice cells] (:func:`loop_z` for a loop)."""
    # Loops inline rather than through a per-frame helper: the nested call chain made numba's
    # first compile take 8 s instead of 1.5 s.
    h = np.empty((z.shape[0], size, size))
    for f in range(z.shape[0]):
        for r in range(size):
            for c in range(size):
                h[f, r, c] = perlin_height_3d(c + 0.5, r + 0.5, z[f], size, base_cells, octaves,
                                              period_z, perm, grad)
    return h


@njit(**JIT_OPTIONS)
def ripple_heights(size, waves):
    """(1, S, S) float64 sum of periodic sine ripples. ``waves`` (N, 4) float64 rows
    (kx, ky, amplitude, phase [rad]); kx, ky are integer wave numbers [cycles per tile], so the
    tile is periodic: h = Σ a · sin(2π (kx·x + ky·y) / S + phase) at texel centres."""
    h = np.zeros((1, size, size))
    w = 2.0 * math.pi / size
    for i in range(waves.shape[0]):
        kx = waves[i, 0] * w
        ky = waves[i, 1] * w
        a = waves[i, 2]
        p = waves[i, 3]
        for r in range(size):
            for c in range(size):
                h[0, r, c] += a * math.sin(kx * (c + 0.5) + ky * (r + 0.5) + p)
    return h


# ---- slopes and mips --------------------------------------------------------------------------

@njit(**JIT_OPTIONS)
def slopes_from_heights(h, spacing_px):
    """(F, n, n, 2) float32 slopes (∂h/∂u, ∂h/∂v) of heights ``h`` (F, n, n) float64 whose texels
    are ``spacing_px`` level-0 texels apart: central differences, wrapping on both axes."""
    frames, n = h.shape[0], h.shape[1]
    out = np.empty((frames, n, n, 2), np.float32)
    inv = 0.5 / spacing_px
    for f in range(frames):
        for r in range(n):
            rn = (r + 1) % n
            rp = (r - 1 + n) % n
            for c in range(n):
                cn = (c + 1) % n
                cp = (c - 1 + n) % n
                out[f, r, c, 0] = (h[f, r, cn] - h[f, r, cp]) * inv
                out[f, r, c, 1] = (h[f, rn, c] - h[f, rp, c]) * inv
    return out


@njit(**JIT_OPTIONS)
def downsample_2x2(a):
    """(F, n/2, n/2, C) mean of each 2×2 block of ``a`` (F, n, n, C), same dtype (summed in
    float64)."""
    frames, m, ch = a.shape[0], a.shape[1] // 2, a.shape[3]
    out = np.empty((frames, m, m, ch), a.dtype)
    for f in range(frames):
        for r in range(m):
            for c in range(m):
                for k in range(ch):
                    s = (np.float64(a[f, 2 * r, 2 * c, k]) + a[f, 2 * r, 2 * c + 1, k]
                         + a[f, 2 * r + 1, 2 * c, k] + a[f, 2 * r + 1, 2 * c + 1, k])
                    out[f, r, c, k] = 0.25 * s
    return out


def normalise_heights(heights: np.ndarray) -> np.ndarray:
    """``heights`` (F, S, S) scaled so that its level-0 slopes have RMS 1 over both components
    and all frames (each component ≈ 1 for isotropic noise); unchanged if they are all zero."""
    s = slopes_from_heights(heights, 1.0)
    rms = math.sqrt(float(np.mean(np.square(s, dtype=np.float64))))
    return heights / rms if rms > 0.0 else heights.copy()


def slope_mip_chain(heights: np.ndarray) -> list[np.ndarray]:
    """Slopes of every mip level of ``heights`` (F, S, S) float64, S a power of two: level k is
    (F, S>>k, S>>k, 2) float32, recomputed from the 2×2 box-filtered heights of that level
    (Proland's way, not averaged slopes), per level-0 texel. log2 S + 1 levels, down to 1×1."""
    h = np.ascontiguousarray(heights, np.float64)
    levels = [slopes_from_heights(h, 1.0)]
    k = 0
    while h.shape[1] > 1:
        h = downsample_2x2(h.reshape(h.shape + (1,)))[..., 0]
        k += 1
        levels.append(slopes_from_heights(h, float(1 << k)))
    return levels


def box_mip_chain(slopes: np.ndarray) -> list[np.ndarray]:
    """Mip chain of ``slopes`` (F, S, S, 2) by 2×2 box filtering (for images that have no
    heights): log2 S + 1 float32 levels, down to 1×1."""
    level = np.ascontiguousarray(slopes, np.float32)
    levels = [level]
    while level.shape[1] > 1:
        level = downsample_2x2(level)
        levels.append(level)
    return levels
