"""WaveTile: a periodic slope texture and its mip chain, the pattern the river's sprites advect.

Plain data, one entity per wave tile (Proland's ``WaveTile``, ``PerlinWaveTile`` and
``AnimatedPerlinWaveTile``, reference §4.5). The shader samples it at ``world offset /
wave_length_m`` and multiplies the slopes by its slope factor; every kind is normalised so its
level-0 slopes have RMS 1, so one slope factor means the same for all. The arrays are made here,
on the CPU (:mod:`riverflow.kernels.waves`); the GL side uploads ``levels`` and re-uploads when
``revision`` changes.

Layout: level k is (F, S>>k, S>>k, 2) float32 C-contiguous, ``[frame, row (v), col (u), (∂h/∂u,
∂h/∂v)]``, slopes per level-0 texel on every level (height units per texel of level 0).
"""
from __future__ import annotations

import math
import os
from dataclasses import dataclass
from functools import lru_cache
from enum import IntEnum

import numpy as np

from riverflow.kernels import waves as kw


class WaveKind(IntEnum):
    """How a wave tile was made."""

    STATIC = 0
    """From an image or an array (Proland ``waveTile``), or :func:`default_static_wave_tile`."""
    PERLIN = 1
    """One periodic Perlin slope texture (Proland ``perlinWaveTile``)."""
    ANIMATED = 2
    """A seamless loop of Perlin frames (Proland ``animatedPerlinWaveTile``), cross-faded."""


@dataclass(eq=False)
class WaveTile:
    """A wave tile: its mip chain of slopes and the clock of its animation."""

    kind: WaveKind
    wave_length_m: float
    """World size of one texture period [m] (Proland ``waveLength``)."""
    levels: list[np.ndarray]
    """Mip chain: level k is (F, S>>k, S>>k, 2) float32 slopes (F = 1 unless animated)."""
    frame_s: float = 0.25
    """Seconds per animated frame."""
    time_s: float = 0.0
    """Clock [s], advanced by the wave-tile animation system."""
    revision: int = 0
    """Bumped when ``levels`` change (the GL side re-uploads)."""

    def __post_init__(self) -> None:
        _check_positive("wave_length_m", self.wave_length_m)
        _check_positive("frame_s", self.frame_s)
        _check_levels(self.levels)

    @property
    def size_px(self) -> int:
        """Side S of level 0 [texels]."""
        return int(self.levels[0].shape[1])

    @property
    def frames(self) -> int:
        """Number of animation frames F (1 for a still tile)."""
        return int(self.levels[0].shape[0])

    @property
    def loop_s(self) -> float:
        """Duration of one animation loop [s] (F · frame_s)."""
        return self.frames * self.frame_s

    def advance(self, dt_s: float) -> None:
        """Move the clock on by ``dt_s`` [s]; a negative or non-finite step is ignored."""
        if math.isfinite(dt_s) and dt_s >= 0.0:
            self.time_s += dt_s

    def frame_blend(self) -> tuple[int, int, float]:
        """(frame a, frame b = (a + 1) mod F, weight of b in [0, 1)) at ``time_s``: the shader
        shows ``(1 − w)·a + w·b``. Loops: time F·frame_s is time 0. (0, 0, 0.0) when F = 1."""
        n = self.frames
        if n == 1 or not math.isfinite(self.time_s):
            return 0, 0, 0.0
        u = (self.time_s / self.frame_s) % n
        a = math.floor(u)
        if a >= n:  # u rounded up to n (tiny negative time)
            return 0, 1, 0.0
        return a, (a + 1) % n, u - a

    def set_levels(self, levels: list[np.ndarray]) -> None:
        """Replace the mip chain (checked) and bump ``revision``."""
        _check_levels(levels)
        self.levels = levels
        self.revision += 1


def perlin_wave_tile(size: int = 256, wave_length_m: float = 20.0, seed: int = 171717,
                     base_cells: int = 8) -> WaveTile:
    """A static periodic Perlin slope tile of ``size``² texels (Proland ``perlinWaveTile``, whose
    fixed seed is 171717). Octaves have ``base_cells · 2ᵏ`` cells across the tile, k = 0…3."""
    _check_size("size", size)
    _check_cells(base_cells, size)
    _check_positive("wave_length_m", wave_length_m)
    levels = list(_perlin_levels(int(size), int(base_cells), _seed32(seed)))
    return WaveTile(WaveKind.PERLIN, float(wave_length_m), levels)


@lru_cache(maxsize=4)
def _perlin_levels(size: int, base_cells: int, seed32: int) -> tuple[np.ndarray, ...]:
    """The static Perlin tile's slope mips, read-only, made once a process per argument."""
    perm = kw.permutation(seed32)
    heights = kw.perlin_tile_2d(size, base_cells, kw.OCTAVES, perm, kw.gradients_2d())
    return _read_only(kw.slope_mip_chain(kw.normalise_heights(heights)))


@lru_cache(maxsize=4)
def _animated_levels(size: int, frames: int, base_cells: int, period_z: int,
                     seed32: int) -> tuple[np.ndarray, ...]:
    """The animated tile's slope mips, read-only, made once a process per argument (every
    world has one: 0.1 s of CPU each)."""
    perm = kw.permutation(seed32)
    z = kw.loop_z(frames, period_z)
    heights = kw.perlin_frames_3d(size, z, base_cells, kw.OCTAVES, period_z, perm,
                                  kw.gradients_3d())
    return _read_only(kw.slope_mip_chain(kw.normalise_heights(heights)))


def _read_only(levels) -> tuple[np.ndarray, ...]:
    for level in levels:
        level.flags.writeable = False
    return tuple(levels)


def animated_wave_tile(size: int = 128, frames: int = 32, frame_s: float = 0.25,
                       wave_length_m: float = 20.0, seed: int = 171717, base_cells: int = 8,
                       period_z: int = 4) -> WaveTile:
    """A seamless loop of ``frames`` Perlin slope tiles (Proland ``animatedPerlinWaveTile``):
    3-D noise, frame f at z = period_z · f / frames with the noise periodic in z. All frames
    share one normalisation. Side 128 by default (Proland: 256) to keep memory (5.6 MB with
    mips) and start-up time low; the loop lasts ``frames · frame_s`` seconds."""
    _check_size("size", size)
    _check_cells(base_cells, size)
    if isinstance(frames, bool) or not isinstance(frames, (int, np.integer)) or frames < 2:
        raise ValueError(f"frames must be an integer >= 2, got {frames!r}")
    if isinstance(period_z, bool) or not isinstance(period_z, (int, np.integer)) or period_z < 1:
        raise ValueError(f"period_z must be a positive integer, got {period_z!r}")
    _check_positive("frame_s", frame_s)
    _check_positive("wave_length_m", wave_length_m)
    levels = list(_animated_levels(int(size), int(frames), int(base_cells), int(period_z),
                                   _seed32(seed)))
    return WaveTile(WaveKind.ANIMATED, float(wave_length_m), levels, frame_s=float(frame_s))


def static_wave_tile(slopes_or_path: np.ndarray | str | os.PathLike,
                     wave_length_m: float = 20.0) -> WaveTile:
    """A still tile from an (S, S, 2) slope array or a PNG (Proland ``waveTile``), S a power of
    two. PNG: R and G (0…255) map linearly to slopes −1…1 (rows as stored, no flip). Either way
    the slopes are scaled to RMS 1 (an all-zero array stays zero), and since there are no heights
    the mips box-filter the slopes."""
    if isinstance(slopes_or_path, (str, os.PathLike)):
        slopes = _read_slope_png(slopes_or_path)
    else:
        slopes = np.asarray(slopes_or_path, np.float64)
        if slopes.ndim != 3 or slopes.shape[2] != 2 or slopes.shape[0] != slopes.shape[1]:
            raise ValueError(f"slopes must have shape (S, S, 2), got {slopes.shape}")
        if not np.all(np.isfinite(slopes)):
            raise ValueError("slopes must be finite")
    _check_size("slopes size", slopes.shape[0])
    _check_positive("wave_length_m", wave_length_m)
    rms = math.sqrt(float(np.mean(np.square(slopes))))
    if rms > 0.0:
        slopes = slopes / rms
    levels = kw.box_mip_chain(slopes[None].astype(np.float32))
    return WaveTile(WaveKind.STATIC, float(wave_length_m), levels)


def default_static_wave_tile(size: int = 256, seed: int = 7,
                             wave_length_m: float = 20.0) -> WaveTile:
    """A still tile that is not Perlin noise: 12 seeded periodic sine ripples (integer wave
    numbers of 3…12 cycles per tile, fewer on tiles under 48 texels, random directions and
    phases, amplitudes ∝ 1/|k| so each adds comparable slope); heights → slopes → mips as for
    Perlin tiles."""
    _check_size("size", size)
    _check_positive("wave_length_m", wave_length_m)
    rng = np.random.default_rng(seed)
    max_k = min(12.0, size / 4.0)
    waves: list[tuple[float, float, float, float]] = []
    seen: set[tuple[int, int]] = set()
    for attempt in range(1000):
        m = rng.uniform(min(3.0, max_k), max_k)
        theta = rng.uniform(0.0, 2.0 * math.pi)
        k = (round(m * math.cos(theta)), round(m * math.sin(theta)))
        if k == (0, 0) or ((k in seen or (-k[0], -k[1]) in seen) and attempt < 500):
            continue  # distinct ripples while small tiles still allow it
        seen.add(k)
        amp = rng.uniform(0.5, 1.0) / math.hypot(*k)
        waves.append((float(k[0]), float(k[1]), amp, rng.uniform(0.0, 2.0 * math.pi)))
        if len(waves) == 12:
            break
    heights = kw.ripple_heights(size, np.array(waves, np.float64))
    return WaveTile(WaveKind.STATIC, float(wave_length_m),
                    kw.slope_mip_chain(kw.normalise_heights(heights)))


# ---- checks -----------------------------------------------------------------------------------

def _check_positive(name: str, value: float) -> None:
    if isinstance(value, bool) or not isinstance(value, (int, float, np.number)) \
            or not math.isfinite(value) or value <= 0:
        raise ValueError(f"{name} must be a positive finite number, got {value!r}")


def _check_size(name: str, size: int) -> None:
    if isinstance(size, bool) or not isinstance(size, (int, np.integer)) or size < 4 \
            or size & (size - 1):
        raise ValueError(f"{name} must be a power of two >= 4, got {size!r}")


def _check_cells(base_cells: int, size: int) -> None:
    if isinstance(base_cells, bool) or not isinstance(base_cells, (int, np.integer)) \
            or base_cells < 1:
        raise ValueError(f"base_cells must be a positive integer, got {base_cells!r}")
    finest = base_cells << (kw.OCTAVES - 1)
    if finest > kw.PERM_SIZE or 2 * finest > size:
        raise ValueError(
            f"base_cells={base_cells} gives {finest} cells across the finest octave; it must be "
            f"at most {min(kw.PERM_SIZE, size // 2)} for size {size} (>= 2 texels per cell)")


def _check_levels(levels: list[np.ndarray]) -> None:
    if not levels:
        raise ValueError("levels must hold at least level 0")
    f, s = levels[0].shape[0], levels[0].shape[1]
    for k, lv in enumerate(levels):
        n = max(s >> k, 1)
        if lv.shape != (f, n, n, 2) or lv.dtype != np.float32 or not lv.flags.c_contiguous:
            raise ValueError(f"levels[{k}] must be a C-contiguous float32 array of shape "
                             f"{(f, n, n, 2)}, got {lv.dtype} {lv.shape}")


def _seed32(seed: int) -> int:
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)):
        raise ValueError(f"seed must be an integer, got {seed!r}")
    return int(seed) & kw.MASK32


def _read_slope_png(path: str | os.PathLike) -> np.ndarray:
    from PIL import Image  # only needed for image tiles

    with Image.open(path) as image:
        rgb = np.asarray(image.convert("RGB"), np.float64)
    if rgb.shape[0] != rgb.shape[1]:
        raise ValueError(f"wave image {os.fspath(path)!r} must be square, got "
                         f"{rgb.shape[1]}×{rgb.shape[0]}")
    return rgb[..., :2] / 255.0 * 2.0 - 1.0
