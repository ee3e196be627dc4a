"""Plain-numpy twins of the wave-tile kernels (riverflow.kernels.waves): slow, obvious, the spec."""
from __future__ import annotations

import math

import numpy as np

MASK32 = 0xFFFFFFFF


def hash32(x: int) -> int:
    """lowbias32 of the low 32 bits of x, with Python integers."""
    x &= MASK32
    x ^= x >> 16
    x = (x * 0x7FEB352D) & MASK32
    x ^= x >> 15
    x = (x * 0x846CA68B) & MASK32
    x ^= x >> 16
    return x


def permutation(seed: int) -> np.ndarray:
    perm = list(range(256))
    s = hash32(seed)
    for i in range(255, 0, -1):
        j = hash32(s + i) % (i + 1)
        perm[i], perm[j] = perm[j], perm[i]
    return np.array(perm, np.int64)


def gradients_2d() -> np.ndarray:
    a = 2 * np.pi * np.arange(256) / 256
    return np.c_[np.cos(a), np.sin(a)]


def gradients_3d() -> np.ndarray:
    i = np.arange(256)
    z = 1 - (2 * i + 1) / 256
    r = np.sqrt(1 - z * z)
    golden = np.pi * (3 - np.sqrt(5))
    return np.c_[r * np.cos(golden * i), r * np.sin(golden * i), z]


def fade(t):
    return 6 * t**5 - 15 * t**4 + 10 * t**3


def noise_2d(x, y, cells, octave, perm, grad):
    """Periodic gradient noise at arrays x, y [lattice cells]."""
    x0, y0 = np.floor(x), np.floor(y)
    fx, fy = x - x0, y - y0
    out = 0.0
    for di in (0, 1):
        for dj in (0, 1):
            i = (x0.astype(np.int64) + di) % cells
            j = (y0.astype(np.int64) + dj) % cells
            g = grad[perm[(perm[(perm[octave % 256] + i) % 256] + j) % 256]]
            dot = g[..., 0] * (fx - di) + g[..., 1] * (fy - dj)
            wx = fade(fx) if di else 1 - fade(fx)
            wy = fade(fy) if dj else 1 - fade(fy)
            out = out + wx * wy * dot
    return out


def noise_3d(x, y, z, cells, cells_z, octave, perm, grad):
    x0, y0, z0 = np.floor(x), np.floor(y), np.floor(z)
    fx, fy, fz = x - x0, y - y0, z - z0
    out = 0.0
    for di in (0, 1):
        for dj in (0, 1):
            for dk in (0, 1):
                i = (x0.astype(np.int64) + di) % cells
                j = (y0.astype(np.int64) + dj) % cells
                k = (np.int64(z0) + dk) % cells_z
                h = perm[(perm[(perm[(perm[octave % 256] + i) % 256] + j) % 256] + k) % 256]
                g = grad[h]
                dot = g[..., 0] * (fx - di) + g[..., 1] * (fy - dj) + g[..., 2] * (fz - dk)
                w = ((fade(fx) if di else 1 - fade(fx)) * (fade(fy) if dj else 1 - fade(fy))
                     * (fade(fz) if dk else 1 - fade(fz)))
                out = out + w * dot
    return out


def perlin_height_2d(x_px, y_px, size, base_cells, octaves, perm, grad):
    x_px, y_px = np.asarray(x_px, float), np.asarray(y_px, float)
    return sum(0.5**k * noise_2d(x_px * (base_cells << k) / size, y_px * (base_cells << k) / size,
                                 base_cells << k, k, perm, grad) for k in range(octaves))


def perlin_height_3d(x_px, y_px, z, size, base_cells, octaves, period_z, perm, grad):
    x_px, y_px = np.asarray(x_px, float), np.asarray(y_px, float)
    return sum(0.5**k * noise_3d(x_px * (base_cells << k) / size, y_px * (base_cells << k) / size,
                                 z, base_cells << k, period_z, k, perm, grad)
               for k in range(octaves))


def _centres(size):
    r, c = np.mgrid[0:size, 0:size]
    return c + 0.5, r + 0.5


def perlin_tile_2d(size, base_cells, octaves, perm, grad):
    x, y = _centres(size)
    return perlin_height_2d(x, y, size, base_cells, octaves, perm, grad)[None]


def perlin_frame_3d(size, z, base_cells, octaves, period_z, perm, grad):
    x, y = _centres(size)
    return perlin_height_3d(x, y, z, size, base_cells, octaves, period_z, perm, grad)


def loop_z(frames, period_z):
    return np.array([period_z * f / frames for f in range(frames)])


def perlin_frames_3d(size, z, base_cells, octaves, period_z, perm, grad):
    return np.stack([perlin_frame_3d(size, zf, base_cells, octaves, period_z, perm, grad)
                     for zf in z])


def ripple_heights(size, waves):
    x, y = _centres(size)
    h = sum(a * np.sin(2 * np.pi * (kx * x + ky * y) / size + p) for kx, ky, a, p in waves)
    return np.asarray(h, float)[None]


def slopes_from_heights(h, spacing_px):
    """Central differences with np.roll (wrap on both axes), per level-0 texel."""
    du = (np.roll(h, -1, axis=2) - np.roll(h, 1, axis=2)) / (2 * spacing_px)
    dv = (np.roll(h, -1, axis=1) - np.roll(h, 1, axis=1)) / (2 * spacing_px)
    return np.stack([du, dv], axis=-1).astype(np.float32)


def downsample_2x2(a):
    f, n, _, c = a.shape
    return a.astype(float).reshape(f, n // 2, 2, n // 2, 2, c).mean(axis=(2, 4)).astype(a.dtype)


def box_heights(h):
    f, n, _ = h.shape
    return h.reshape(f, n // 2, 2, n // 2, 2).mean(axis=(2, 4))


def normalise_heights(h):
    s = slopes_from_heights(h, 1.0).astype(float)
    rms = math.sqrt(np.mean(s * s))
    return h / rms if rms > 0 else h.copy()


def slope_mip_chain(h):
    levels, k = [slopes_from_heights(h, 1.0)], 0
    while h.shape[1] > 1:
        h, k = box_heights(h), k + 1
        levels.append(slopes_from_heights(h, 2.0**k))
    return levels


def box_mip_chain(slopes):
    levels = [slopes.astype(np.float32)]
    while levels[-1].shape[1] > 1:
        levels.append(downsample_2x2(levels[-1]))
    return levels
