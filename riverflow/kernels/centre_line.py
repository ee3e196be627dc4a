"""Water levels from the sampled centre lines for the reflection's mirror (once a view).

:func:`nearest_level`: the level of the river nearest one point, as
:class:`riverflow.scenes.water.WaterSurface` computes it for many
(:meth:`~riverflow.scenes.water.WaterSurface.level_at`). The nearest centre-line sample by
brute force (a few thousand: microseconds, where one KD-tree query from Python costs tens),
then the projection onto the segments on either side of it, in the same floating-point
operations as the vectorised code (no fast-math: the same numbers bit for bit).

:func:`view_level`: the mean level of the water a camera sees, weighted by the share of the
screen each piece of it covers (:func:`riverflow.scenes.reflection.mirror_level`).
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from riverflow.kernels._jit import EXACT_JIT_OPTIONS, JIT_OPTIONS

VIEW_EDGE_NDC = 0.25
"""A sample's weight fades out over this much of normalised device coordinates up to the
screen's edge (moved out by the river's half width there): water entering the view weighs
in gradually, never at once, and water off the screen does not weigh."""


FRESNEL_F0 = 0.02
"""Water's reflectance seen from straight above (Schlick's approximation, as
``shaders/water.glsl``)."""
REFLECTION_FAINT = 0.05
"""The reflectance under which the water shader shows no land in the water (its
REFLECTION_FAINT, ``shaders/reflection.glsl``: faded in from half of it): water seen more
steeply than that does not look into the mirror, and its level does not weigh."""


class LevelSamples(NamedTuple):
    """Centre-line samples as :func:`view_level` reads them (S of them, float64)."""

    xy: np.ndarray          # (S, 2) position [m]
    level: np.ndarray       # (S,) water level [m]
    area: np.ndarray        # (S,) the water each stands for: width × length along the line [m²]
    half_width: np.ndarray  # (S,) half the river's width [m]


@njit(inline="always", **JIT_OPTIONS)
def _fade(x):
    """0 for x ≤ 0, 1 for x ≥ 1, smoothstep between (continuous, with its slope)."""
    x = min(max(x, 0.0), 1.0)
    return x * x * (3.0 - 2.0 * x)


@njit(**JIT_OPTIONS)
def view_level(samples, clip_from_world, eye, near_m, min_height_m, fallback_level,
               fallback_share):
    """The water level [m] the camera sees: the centre-line samples' levels weighted by the
    share of the screen their water covers times its Fresnel reflectance there (where the
    reflection shows), and the sum of those weights: (level, weight); level NaN when nothing
    weighs (no sample in view and ``fallback_share`` 0).

    ``clip_from_world`` (4, 4) is the column-vector world → clip matrix of a perspective
    camera at ``eye`` (3,) [m] (:meth:`riverflow.engine.camera.Camera.matrices_for_kernels`:
    row 3 the view direction, so clip w is the depth along it; rows 0 and 1 its right and up
    axes scaled by the projection's x and y scales). A horizontal patch of area A whose
    water lies h below the eye, at depth w, covers A·h / w³ × sx·sy / 4 of the screen (the
    solid angle it subtends, A·h / d³, times the pixels per steradian, ∝ 1 / cos³ of its
    angle off the view axis, d·cos = w); its reflectance is Schlick's F0 + (1 − F0)(1 − h/d)⁵
    (seen from above, 2 %: the water right under a camera shows little reflection), faded
    out as the water shader fades out the land in it (from REFLECTION_FAINT down to half of
    it: that water does not look into the mirror, so its level must not move it). Only
    water more than ``min_height_m`` below the eye weighs (h measured from there for the
    share). A sample fades in over VIEW_EDGE_NDC inside the screen's edges moved out by its
    river's half width, and between the near plane ``near_m`` and twice it: the result is
    continuous in the camera's pose. ``fallback_level`` joins with the weight
    ``fallback_share`` (≥ 0): what the level tends to where little water is in view.
    Occlusion by the terrain is not looked at."""
    m = clip_from_world
    sx = math.sqrt(m[0, 0] * m[0, 0] + m[0, 1] * m[0, 1] + m[0, 2] * m[0, 2])
    sy = math.sqrt(m[1, 0] * m[1, 0] + m[1, 1] * m[1, 1] + m[1, 2] * m[1, 2])
    screen = 0.25 * sx * sy
    top = eye[2] - min_height_m
    total = fallback_share
    acc = fallback_share * fallback_level if fallback_share > 0.0 else 0.0
    xy, level, area, half_width = samples.xy, samples.level, samples.area, samples.half_width
    for i in range(level.shape[0]):
        z = level[i]
        h = top - z
        if not h > 0.0:
            continue
        x, y = xy[i, 0], xy[i, 1]
        w = m[3, 0] * x + m[3, 1] * y + m[3, 2] * z + m[3, 3]
        if not w > near_m:
            continue
        # off the screen widened by the half width (fx or fy 0): no division, no weight
        px = m[0, 0] * x + m[0, 1] * y + m[0, 2] * z + m[0, 3]
        if not abs(px) < w + half_width[i] * sx:
            continue
        py = m[1, 0] * x + m[1, 1] * y + m[1, 2] * z + m[1, 3]
        if not abs(py) < w + half_width[i] * sy:
            continue
        inv = 1.0 / w
        r = half_width[i] * inv
        fx = _fade((1.0 + r * sx - abs(px * inv)) / VIEW_EDGE_NDC)
        fy = _fade((1.0 + r * sy - abs(py * inv)) / VIEW_EDGE_NDC)
        share = area[i] * h * inv * inv * inv * screen * fx * fy * _fade(w / near_m - 1.0)
        dx, dy, dz = x - eye[0], y - eye[1], z - eye[2]
        c = 1.0 - min((eye[2] - z) / math.sqrt(dx * dx + dy * dy + dz * dz), 1.0)
        c2 = c * c
        fresnel = FRESNEL_F0 + (1.0 - FRESNEL_F0) * c2 * c2 * c
        weight = share * fresnel * _fade(fresnel / (0.5 * REFLECTION_FAINT) - 1.0)
        total += weight
        acc += weight * z
    if not total > 0.0:
        return np.nan, 0.0
    if total == fallback_share:           # no water weighed: the fallback itself, exactly
        return fallback_level, total
    return acc / total, total


@njit(inline="always", **EXACT_JIT_OPTIONS)
def _nearer_segment(xy, branch, k, x, y):
    """The nearer of the two centre-line segments on either side of sample ``k`` (not across
    a branch's end) to (x, y): (distance, its samples a and b, the projection's t along a → b);
    an infinite distance where neither is finite."""
    n = xy.shape[0]
    best_d, best_a, best_b, best_t = math.inf, 0, 0, 0.0
    for a_off in (-1, 0):
        a = min(max(k + a_off, 0), max(n - 2, 0))
        b = min(a + 1, n - 1)
        sax, say = xy[a, 0], xy[a, 1]
        abx, aby = xy[b, 0] - sax, xy[b, 1] - say
        ab2 = max(abx * abx + aby * aby, 1e-12)
        t = min(max(((x - sax) * abx + (y - say) * aby) / ab2, 0.0), 1.0)
        if branch[a] != branch[b]:
            t = 0.0 if a == k else 1.0
        d = np.hypot(sax + t * abx - x, say + t * aby - y)
        if d < best_d:
            best_d, best_a, best_b, best_t = d, a, b, t
    return best_d, best_a, best_b, best_t


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
    d, a, b, t = _nearer_segment(samples, branch, k, x, y)
    if not d < math.inf:
        return np.nan
    return (1 - t) * levels[a] + t * levels[b]


class CentreSamples(NamedTuple):
    """Centre-line samples as :func:`project_to_centre` reads them (S of them; the samples of
    a branch consecutive, upstream first)."""

    xy: np.ndarray          # (S, 2) float64 position [m]
    level: np.ndarray       # (S,) float64 water level [m]
    width: np.ndarray       # (S,) float64 river width [m]
    branch: np.ndarray      # (S,) int64 branch index


@njit(**EXACT_JIT_OPTIONS)
def project_to_centre(samples, nearest, p, out_d, out_level, out_width):
    """The nearest point on the sampled centre lines of points ``p`` (N, 2) [m] whose nearest
    sample is ``nearest`` (N,) (a KD-tree's answer): the segments on either side of that
    sample (not across a branch's end), the nearer projection; its distance, level and width
    (linear along the segment) into ``out_d``, ``out_level``, ``out_width`` (N,). The same
    floating-point operations as the vectorised ``_Samples.project`` (no fast-math: the same
    numbers bit for bit)."""
    xy, levels, widths, branch = samples.xy, samples.level, samples.width, samples.branch
    for i in range(p.shape[0]):
        d, a, b, t = _nearer_segment(xy, branch, nearest[i], p[i, 0], p[i, 1])
        out_d[i] = d
        if d < math.inf:
            out_level[i] = (1 - t) * levels[a] + t * levels[b]
            out_width[i] = (1 - t) * widths[a] + t * widths[b]
        else:
            out_level[i] = np.nan
            out_width[i] = np.nan
