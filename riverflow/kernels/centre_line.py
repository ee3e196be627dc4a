"""The water level of the river nearest one point, as :class:`riverflow.scenes.water.WaterSurface`
computes it for many (:meth:`~riverflow.scenes.water.WaterSurface.level_at`: the reflection's
mirror, once a frame).

The nearest centre-line sample by brute force (a few thousand: microseconds, where one
KD-tree query from Python costs tens), then the projection onto the segments on either side
of it, in the same floating-point operations as the vectorised code (no fast-math: the same
numbers bit for bit).
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from riverflow.kernels._jit import EXACT_JIT_OPTIONS


@njit(**EXACT_JIT_OPTIONS)
def nearest_level(samples, levels, branch, x, y):
    """The level [m] at the point of the sampled centre lines (``samples`` (S, 2) [m] with
    their ``levels`` (S,) and ``branch`` (S,), branches consecutive) nearest (x, y), as
    ``_Samples.project`` finds it; NaN where that is not certain to be the same number: two
    samples tie for nearest (a KD-tree may pick either), or no distance is finite."""
    n = samples.shape[0]
    best = math.inf
    k = -1
    tie = False
    for i in range(n):
        dx = x - samples[i, 0]
        dy = y - samples[i, 1]
        d2 = dx * dx + dy * dy
        if d2 < best:
            best = d2
            k = i
            tie = False
        elif d2 == best:
            tie = True
    if k < 0 or tie:
        return np.nan
    best_d = math.inf
    level = np.nan
    for a_off in (-1, 0):
        a = min(max(k + a_off, 0), max(n - 2, 0))
        b = min(a + 1, n - 1)
        sax, say = samples[a, 0], samples[a, 1]
        abx, aby = samples[b, 0] - sax, samples[b, 1] - say
        ab2 = max(abx * abx + aby * aby, 1e-12)
        t = min(max(((x - sax) * abx + (y - say) * aby) / ab2, 0.0), 1.0)
        if branch[a] != branch[b]:
            t = 0.0 if a == k else 1.0
        d = np.hypot(sax + t * abx - x, say + t * aby - y)
        if d < best_d:
            best_d = d
            level = (1 - t) * levels[a] + t * levels[b]
    return level
