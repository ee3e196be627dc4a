"""Hashed value noise and its fractal sum (fBm), evaluated point by point.

A terrain streamed in tiles is sampled at arbitrary points, so the noise keeps no state: the
value at a point depends only on (x, y, seed, octaves), never on the batch it comes in.

Lattice
    Octave k of a seed has one value per integer lattice node (ix, iy): a 64-bit hash of
    (ix, iy, k, seed) in wrapping uint64 arithmetic (splitmix64 finaliser; the seed and
    octave give a key, the key and iy a row key, the row key and ix the node's hash). Every
    operand is uint64 (module constants are ``np.uint64``), so numba never promotes to float64.

Lattice value
    The hash's four 16-bit chunks c₀…c₃ are four uniforms (cᵢ + ½) / 2¹⁶ on (0, 1); their sum
    minus 2, times √3, is a roughly standard-normal value (Irwin–Hall, n = 4): mean 0,
    variance :data:`LATTICE_VARIANCE` = 1 − 2⁻³², bounded by :data:`LATTICE_MAX` < 2√3.

Interpolation
    A uniform cubic B-spline over the 4 × 4 nodes around the point (C², weights ≥ 0 summing
    to 1, so ``|noise| ≤ LATTICE_MAX``). It smooths: averaged over the plane the noise has
    variance :data:`NOISE_VARIANCE` = (151/315)² · LATTICE_VARIANCE ≈ 0.2298 (151/315 = ∫B₃²).

Coordinates
    Lattice coordinates are ``x · (1 / scale)``, floored to int64: fine for |x / scale| far
    beyond any map (±2·10⁶ m at a 1 m scale keeps ~1e-10 of the cell in the fraction).
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from riverflow.kernels._jit import JIT_OPTIONS

GOLDEN = np.uint64(0x9E3779B97F4A7C15)
"""splitmix64 increment: the octave index steps the seed by it."""
MIX1 = np.uint64(0xBF58476D1CE4E5B9)
MIX2 = np.uint64(0x94D049BB133111EB)
ROW_PRIME = np.uint64(0xC2B2AE3D27D4EB4F)
"""Odd multiplier of iy (xxhash PRIME64_2)."""
COL_PRIME = np.uint64(0x165667B19E3779F9)
"""Odd multiplier of ix (xxhash PRIME64_3)."""
ONE = np.uint64(1)
MASK16 = np.uint64(0xFFFF)
SHIFT16 = np.uint64(16)
SHIFT27 = np.uint64(27)
SHIFT30 = np.uint64(30)
SHIFT31 = np.uint64(31)
SHIFT32 = np.uint64(32)
SHIFT48 = np.uint64(48)
CHUNK_SUM_MEAN = 131070.0
"""Σ cᵢ at which the lattice value is 0: 4 · (2¹⁶ / 2 − ½)."""
NORMAL_SCALE = math.sqrt(3.0) / 65536.0
"""Lattice value per unit of Σ cᵢ."""
LATTICE_VARIANCE = 1.0 - 2.0 ** -32
"""Variance of a lattice value (four discrete uniforms of variance (1 − 2⁻³²) / 12, times 3)."""
LATTICE_MAX = math.sqrt(3.0) * (2.0 - 2.0 ** -15)
"""Largest |lattice value|, hence the largest |noise|."""
BSPLINE_SQUARE_INTEGRAL = 151.0 / 315.0
"""∫ B₃(t)² dt of the cubic B-spline: the mean of Σᵢ wᵢ(f)² over the fraction f."""
NOISE_VARIANCE = BSPLINE_SQUARE_INTEGRAL ** 2 * LATTICE_VARIANCE
"""Variance of the noise averaged over the plane (≈ 0.2298, std ≈ 0.4794)."""


@njit(**JIT_OPTIONS)
def _mix64(z):
    """splitmix64 finaliser of a uint64 (a bijection)."""
    z = (z ^ (z >> SHIFT30)) * MIX1
    z = (z ^ (z >> SHIFT27)) * MIX2
    return z ^ (z >> SHIFT31)


@njit(**JIT_OPTIONS)
def _octave_key(seed, octave):
    """uint64 key of (seed, octave index); the seed wraps modulo 2⁶⁴."""
    return _mix64(np.uint64(seed) + (np.uint64(octave) + ONE) * GOLDEN)


@njit(**JIT_OPTIONS)
def _row_key(key, iy):
    return _mix64(key ^ (np.uint64(iy) * ROW_PRIME))


@njit(**JIT_OPTIONS)
def _node_hash(row, ix):
    return _mix64(row ^ (np.uint64(ix) * COL_PRIME))


@njit(**JIT_OPTIONS)
def _normal(h):
    """Roughly standard-normal value of a hash: √3 · (sum of its four 16-bit uniforms − 2)."""
    s = (h & MASK16) + ((h >> SHIFT16) & MASK16) + ((h >> SHIFT32) & MASK16) + (h >> SHIFT48)
    return (np.float64(s) - CHUNK_SUM_MEAN) * NORMAL_SCALE


@njit(**JIT_OPTIONS)
def _bspline(f):
    """Cubic B-spline weights of the nodes -1, 0, 1, 2 around fraction f ∈ [0, 1)."""
    f2 = f * f
    f3 = f2 * f
    g = 1.0 - f
    return (g * g * g / 6.0, (3.0 * f3 - 6.0 * f2 + 4.0) / 6.0,
            (-3.0 * f3 + 3.0 * f2 + 3.0 * f + 1.0) / 6.0, f3 / 6.0)


@njit(**JIT_OPTIONS)
def _noise_row(row, ix, w):
    """Σᵢ wᵢ · value(ix + i) along one lattice row."""
    return (w[0] * _normal(_node_hash(row, ix)) + w[1] * _normal(_node_hash(row, ix + 1))
            + w[2] * _normal(_node_hash(row, ix + 2)) + w[3] * _normal(_node_hash(row, ix + 3)))


@njit(**JIT_OPTIONS)
def _noise_at(u, v, key):
    """Value noise of one octave key at lattice coordinates (u, v)."""
    fu = np.floor(u)
    fv = np.floor(v)
    ix = np.int64(fu) - 1
    iy = np.int64(fv) - 1
    wx = _bspline(u - fu)
    wy = _bspline(v - fv)
    return (wy[0] * _noise_row(_row_key(key, iy), ix, wx)
            + wy[1] * _noise_row(_row_key(key, iy + 1), ix, wx)
            + wy[2] * _noise_row(_row_key(key, iy + 2), ix, wx)
            + wy[3] * _noise_row(_row_key(key, iy + 3), ix, wx))


@njit(**JIT_OPTIONS)
def lattice_hash(ix, iy, seed, octave, out):
    """uint64 hashes of lattice nodes: ix, iy (N,) int64, seed and octave integers, out (N,)
    uint64."""
    key = _octave_key(seed, octave)
    for n in range(ix.shape[0]):
        out[n] = _node_hash(_row_key(key, iy[n]), ix[n])


@njit(**JIT_OPTIONS)
def lattice_values(ix, iy, seed, octave, out):
    """Roughly standard-normal lattice values (see the module doc): ix, iy (N,) int64,
    out (N,) float64."""
    key = _octave_key(seed, octave)
    for n in range(ix.shape[0]):
        out[n] = _normal(_node_hash(_row_key(key, iy[n]), ix[n]))


@njit(**JIT_OPTIONS)
def value_noise(u, v, seed, octave, out):
    """One octave of B-spline value noise at lattice coordinates u, v (N,) float64 [cells];
    out (N,) float64, |out| ≤ LATTICE_MAX."""
    key = _octave_key(seed, octave)
    for n in range(u.shape[0]):
        out[n] = _noise_at(u[n], v[n], key)


@njit(**JIT_OPTIONS)
def fbm(x, y, seed, scales_m, amplitudes_m, out):
    """Fractal sum Σₖ amplitudes_m[k] · noise(x / scales_m[k], y / scales_m[k], octave k).

    x, y, out (N,) float64 [m]; scales_m (feature sizes, > 0) and amplitudes_m (K,) float64
    [m]; seed an integer (wraps modulo 2⁶⁴). Pointwise: out[n] depends only on (x[n], y[n],
    seed, octaves). ``|out| ≤ LATTICE_MAX · Σ|amplitudes_m|``; averaged over the plane
    its variance is ``NOISE_VARIANCE · Σ amplitudes_m²`` [m²].
    """
    n_oct = scales_m.shape[0]
    keys = np.empty(n_oct, np.uint64)
    inv = np.empty(n_oct, np.float64)
    for k in range(n_oct):
        keys[k] = _octave_key(seed, k)
        inv[k] = 1.0 / scales_m[k]
    for n in range(x.shape[0]):
        total = 0.0
        for k in range(n_oct):
            total += amplitudes_m[k] * _noise_at(x[n] * inv[k], y[n] * inv[k], keys[k])
        out[n] = total
