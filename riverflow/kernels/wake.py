"""Wake trails: the recent path of a boat's bow through the water, drifting with the current.

Each frame, per boat (a handful of numbers; :mod:`riverflow.systems.wake` is the glue):

* :func:`advance_trail`: every kept point drifts with the current it was left in, row 0 is
  the bow now, and a new point is kept every ``sample_s`` seconds; points older than the
  wake's life are dropped;
* :func:`pack_trail`: the trail as the water shader and the foam kernel read it (columns
  ``riverflow.components.wake.TR_*``): the distance along the trail from the bow, the speed
  through the water there, a strength (a speed gate × a fade with age) and the foam trail's
  half-width.

The Kelvin pattern itself is drawn by ``shaders/wake.glsl`` (its numpy twin is in the tests).
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from riverflow.kernels._jit import JIT_OPTIONS, is_finite

# a trail point as the wake system keeps it (Wake.trail), float64
TP_X, TP_Y, TP_TIME, TP_SPEED, TP_VX, TP_VY = range(6)
"""x, y [m] where the bow was (drifted since), time [s], the boat's speed through the water
[m/s], the current there [m/s] (the point drifts with it)."""
TRAIL_STATE_FIELDS = 6

# a packed trail point (Wakes.table), float32: two RGBA texels for the water shader
TR_X, TR_Y, TR_ARC, TR_SPEED, TR_STRENGTH, TR_HALF_WIDTH, TR_AGE, TR_SLOPE = range(8)
"""x, y [m]; distance along the trail from the bow [m]; speed through the water [m/s];
strength 0 … 1 (speed gate × fade with age; −1 past the last point); half-width of the foam
trail [m]; age [s]; the wake's wave-slope knob (the same on every point)."""
TR_FIELDS = 8
WEDGE_HALF_WIDTH = 1.0 / math.sqrt(8.0)
"""tan(19.47°): a Kelvin wedge is this many times as wide on each side as it is long."""
SPEED_RAMP_MPS = 1.5
"""A wake rises from nothing at ``min_speed_mps`` to full strength this much faster."""


@njit(**JIT_OPTIONS)
def advance_trail(trail, count, x, y, speed, vx, vy, now_s, dt_s, sample_s, life_s):
    """Move a trail on by one frame; returns its new point count.

    ``trail`` (K, 6) float64 rows x, y [m], time [s], speed [m/s], drift vx, vy [m/s], newest
    first; (``x``, ``y``) the bow now, ``speed`` the boat's speed through the water, (``vx``,
    ``vy``) the current under it. Kept points drift by their own current × ``dt_s``; row 0
    becomes the bow now; a copy of it is kept (pushing the others down) when the newest kept
    point is ``sample_s`` old or there is none; points older than ``life_s`` are dropped. A
    non-finite bow empties the trail.
    """
    k_max = trail.shape[0]
    count = min(max(count, 0), k_max)
    if not (is_finite(x) and is_finite(y) and is_finite(speed)):
        return 0
    if not (is_finite(vx) and is_finite(vy)):
        vx = 0.0
        vy = 0.0
    if not (is_finite(dt_s) and dt_s > 0.0):
        dt_s = 0.0
    for i in range(1, count):
        trail[i, TP_X] += trail[i, TP_VX] * dt_s
        trail[i, TP_Y] += trail[i, TP_VY] * dt_s
    trail[0, TP_X] = x
    trail[0, TP_Y] = y
    trail[0, TP_TIME] = now_s
    trail[0, TP_SPEED] = speed
    trail[0, TP_VX] = vx
    trail[0, TP_VY] = vy
    if count <= 1 or now_s - trail[1, TP_TIME] >= sample_s:
        last = min(count + 1, k_max)
        for i in range(last - 1, 0, -1):
            for c in range(trail.shape[1]):
                trail[i, c] = trail[i - 1, c]
        count = last
    while count > 1 and not now_s - trail[count - 1, TP_TIME] <= life_s:
        count -= 1
    return max(count, 1)


@njit(inline="always", **JIT_OPTIONS)
def _smoothstep(e0, e1, v):
    t = min(max((v - e0) / (e1 - e0), 0.0), 1.0)
    return t * t * (3.0 - 2.0 * t)


@njit(**JIT_OPTIONS)
def pack_trail(trail, count, now_s, life_s, min_speed_mps, spread_mps, beam_m, wave_slope,
               out):
    """Write trail rows [0, count) into ``out`` (K, 8) float32 (columns TR_*) and mark the
    rest with strength and arc −1. Strength = smoothstep(min_speed, min_speed + SPEED_RAMP_MPS,
    speed) × (1 − age / life)² (0 for a still boat: no waves, no foam); half-width = beam / 2
    + spread · age; ``wave_slope`` goes on every row."""
    arc = 0.0
    n = min(count, trail.shape[0], out.shape[0])
    for i in range(out.shape[0]):
        if i >= n:
            for c in range(out.shape[1]):
                out[i, c] = 0.0
            out[i, TR_STRENGTH] = -1.0
            out[i, TR_ARC] = -1.0
            continue
        if i > 0:
            arc += math.hypot(trail[i, TP_X] - trail[i - 1, TP_X],
                              trail[i, TP_Y] - trail[i - 1, TP_Y])
        age = max(now_s - trail[i, TP_TIME], 0.0)
        fade = max(1.0 - age / life_s, 0.0) if life_s > 0.0 else 0.0
        speed = trail[i, TP_SPEED]
        out[i, TR_X] = trail[i, TP_X]
        out[i, TR_Y] = trail[i, TP_Y]
        out[i, TR_ARC] = arc
        out[i, TR_SPEED] = speed
        out[i, TR_STRENGTH] = _smoothstep(min_speed_mps, min_speed_mps + SPEED_RAMP_MPS,
                                          speed) * fade * fade
        out[i, TR_HALF_WIDTH] = 0.5 * beam_m + spread_mps * age
        out[i, TR_AGE] = age
        out[i, TR_SLOPE] = wave_slope


def wake_texture(table: np.ndarray, out: np.ndarray) -> int:
    """Pack wakes (B, K, TR_FIELDS) float32 into the water shader's wake table ``out`` (≥ B,
    1 + 2K, 4) float32; returns the rows written. Row b: texel 0 the box (xmin, ymin, xmax,
    ymax) [m] outside which wake b is flat (its points widened by the wedge's half-width at
    the trail's end); texel 1 + j (x, y, arc, speed) of point j; texel 1 + K + j (strength,
    half-width, age, wave slope). Points past the end have arc −1 (the shader stops there)."""
    b = min(table.shape[0], out.shape[0])
    k = table.shape[1]
    for i in range(b):
        rows = table[i]
        used = rows[:, TR_ARC] >= 0.0
        out[i, 1:1 + k] = rows[:, :4]
        out[i, 1 + k:1 + 2 * k] = rows[:, 4:8]
        if used.any():
            xy = rows[used][:, :2]
            reach = 1.1 * float(rows[used][:, TR_ARC].max()) * WEDGE_HALF_WIDTH + 1.0
            out[i, 0, :2] = xy.min(axis=0) - reach
            out[i, 0, 2:] = xy.max(axis=0) + reach
        else:
            out[i, 0] = (np.inf, np.inf, -np.inf, -np.inf)
    return b
