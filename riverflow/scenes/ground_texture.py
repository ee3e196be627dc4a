"""The ground's detail texture: one small tileable noise texture, made once (plain numpy,
seeded, deterministic), that the terrain shader samples at several scales and turns.

Channels (RGBA8: a software rasteriser samples 8-bit textures several times faster than float
ones; every level of a full mip chain, so that the GPU's trilinear filtering does the
anti-aliasing: a scale whose detail shrinks under a pixel fades to its mean):

* r: value noise in [0, 1], mean about 0.5, four octaves of periods TEXELS / 4 … TEXELS / 32
  texels, every one periodic over the texture (no seam when it repeats);
* g, b: 0.5 + GRADIENT_SCALE × the gradient of r [per texel] (central differences, periodic),
  for the bump of the normal;
* a: pebbles: stones of about PEBBLE_CELL texels (a jittered point per cell, the texels
  nearest it within a radius), each of its own brightness in (0.35, 1], 0 between them.

Sampled with ``texture(u_ground, uv)``: a tile of ``tile_m`` metres per repeat gives the value
at ``uv = p / tile_m`` and its gradient per metre as ``(gb - 0.5) / GRADIENT_SCALE · TEXELS /
tile_m``. A mip level is the mean of 2 × 2 texels of the level above (made in float, then
rounded); the mean of the gradient is the gradient of the mean, so the bump fades with the
value.
"""
from __future__ import annotations

import numpy as np

TEXELS = 256
"""Side of the texture [texels] (a power of two)."""
NOISE_PERIODS = (64, 32, 16, 8)
"""Feature sizes of the octaves of r [texels]; their amplitudes fall by NOISE_GAIN each."""
NOISE_GAIN = 0.6
PEBBLE_CELL = 16
"""Texels per pebble cell of a."""
GRADIENT_SCALE = 6
"""The gradient's encoding in g, b (|gradient| stays under 0.08 per texel)."""


def ground_texture(seed: int = 0, size: int = TEXELS) -> list[np.ndarray]:
    """The texture's mip levels, ``size`` × ``size`` down to 1 × 1: [(s, s, 4) uint8]."""
    if size < 32 or size & (size - 1):
        raise ValueError(f"ground_texture: size must be a power of two ≥ 32, got {size}")
    rng = np.random.default_rng(seed)
    value = np.zeros((size, size))
    amp_total = 0.0
    for k, period in enumerate(NOISE_PERIODS):
        amp = NOISE_GAIN ** k
        value += amp * (_periodic_value_noise(rng, size, max(1, size * period // TEXELS)) - 0.5)
        amp_total += amp
    value = np.clip(0.5 + 1.7 * value / amp_total, 0.0, 1.0)
    grad_x = 0.5 * (np.roll(value, -1, axis=1) - np.roll(value, 1, axis=1))
    grad_y = 0.5 * (np.roll(value, -1, axis=0) - np.roll(value, 1, axis=0))
    pebbles = _pebbles(rng, size, max(2, size * PEBBLE_CELL // TEXELS))
    levels = [np.stack([value, 0.5 + GRADIENT_SCALE * grad_x, 0.5 + GRADIENT_SCALE * grad_y,
                        pebbles], axis=-1)]
    while levels[-1].shape[0] > 1:
        a = levels[-1]
        levels.append(0.25 * (a[0::2, 0::2] + a[1::2, 0::2] + a[0::2, 1::2] + a[1::2, 1::2]))
    return [np.clip(np.rint(level * 255.0), 0, 255).astype(np.uint8) for level in levels]


def _periodic_value_noise(rng: np.random.Generator, size: int, cell: int) -> np.ndarray:
    """(size, size) value noise in [0, 1]: random values on a lattice of ``cell`` texels,
    periodic over ``size``, interpolated with the quintic fade (as the shader's own)."""
    nodes = size // cell
    lattice = rng.random((nodes, nodes))
    t = (np.arange(size) + 0.5) / cell
    i0 = np.floor(t).astype(np.int64) % nodes
    f = t - np.floor(t)
    u = f * f * f * (f * (f * 6.0 - 15.0) + 10.0)
    i1 = (i0 + 1) % nodes
    rows0 = lattice[i0][:, i0] * (1 - u)[None, :] + lattice[i0][:, i1] * u[None, :]
    rows1 = lattice[i1][:, i0] * (1 - u)[None, :] + lattice[i1][:, i1] * u[None, :]
    return rows0 * (1 - u)[:, None] + rows1 * u[:, None]


def _pebbles(rng: np.random.Generator, size: int, cell: int) -> np.ndarray:
    """(size, size) stones: the texels within 0.3–0.42 cells of their cell's jittered point
    (a soft edge), bright by the stone's random value; 30 % of the cells hold none."""
    nodes = size // cell
    jitter = 0.15 + 0.7 * rng.random((nodes, nodes, 2))
    shade = rng.random((nodes, nodes))
    t = (np.arange(size) + 0.5) / cell
    gx, gy = np.meshgrid(t, t)
    ix, iy = np.floor(gx).astype(np.int64), np.floor(gy).astype(np.int64)
    best = np.full((size, size), np.inf)
    pick = np.zeros((size, size))
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            cx, cy = ix + dx, iy + dy
            j = jitter[cy % nodes, cx % nodes]
            d = np.hypot(cx + j[..., 0] - gx, cy + j[..., 1] - gy)
            closer = d < best
            best = np.where(closer, d, best)
            pick = np.where(closer, shade[cy % nodes, cx % nodes], pick)
    edge = np.clip((0.42 - best) / 0.12, 0.0, 1.0)
    stone = edge * edge * (3 - 2 * edge) * (pick > 0.3)
    return stone * (0.35 + 0.65 * (pick - 0.3) / 0.7)
