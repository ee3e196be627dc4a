"""Rain kernels (seed 002: a particle system of rain drops drawn as short line segments).

The seed's algorithm, frame by frame:

1. **New drops**: ``ParticleNum = MeanNum + rand() · VarNum`` with rand() uniform in [−1, 1]
   (:func:`drops_this_frame`; our reading of MeanNum and VarNum is in its docstring).
2. **Motion**: constant acceleration over a drop's life, uniform motion between two frames:
   ``v += a · dt`` then ``p += v · dt`` (the seed's equations 4–6); the horizontal velocity is
   the wind's, the vertical one starts at ``fall_mps`` downwards and grows by ``gravity_mps2``.
3. **End of life**: a drop dies when it leaves the view volume (outside any of the six frustum
   planes, tested in clip space: −w ≤ x, y, z ≤ w, Gribb–Hartmann's planes of the camera's
   clip matrix) or the box around the camera, or when it reaches the surface (the seed's
   simplification: its altitude is at or below the ground or water under it, read from the
   frame's surface tiles, :func:`riverflow.kernels.surface_tiles.sample_surface`). Where no
   tile is made yet the drop keeps falling. A drop that dies on water leaves a *hit*
   (x, y, water level, time) in a small ring buffer, when a ring is free: the water shader
   draws a ripple ring there.

New drops are born inside the view volume ∩ the box (so the work is proportional to what the
camera sees, never to the map): a random point of the frustum between the near plane and the
box's depth, uniform in volume (random NDC x, y; forward distance with density ∝ d²), retried
up to ``SPAWN_TRIES`` times while it falls outside the box or under the surface.

The pool is packed: live drops are rows 0 … n − 1 (a dead drop is replaced by the last one).
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from riverflow.kernels._jit import JIT_OPTIONS, is_finite
from riverflow.kernels.placement import unproject
from riverflow.kernels.surface_tiles import sample_surface

SPAWN_TRIES = 8
"""Random points tried per new drop before it is given up (a view mostly under the ground)."""


class RainDrops(NamedTuple):
    """The drop pool's columns (capacity C) and its counters.

    ``position`` (C, 3) float64 [m]; ``velocity`` (C, 3) float64 [m/s]; ``counts`` (4,) int64:
    live drops n (rows 0 … n − 1), drops born last frame, drops asked for last frame, hits
    written in total; ``hits`` (H, 4) float64 ring buffer of water hits: x, y [m], water level
    [m], time [s] (row ``counts[3] % H`` is the next one written).
    """

    position: np.ndarray
    velocity: np.ndarray
    counts: np.ndarray
    hits: np.ndarray


def empty_drops(capacity: int, ring: int) -> RainDrops:
    """A drop pool with room for ``capacity`` drops and ``ring`` remembered hits."""
    hits = np.zeros((ring, 4), np.float64)
    hits[:, 3] = -np.inf                     # never hit: no ripple
    return RainDrops(np.zeros((capacity, 3), np.float64), np.zeros((capacity, 3), np.float64),
                     np.zeros(4, np.int64), hits)


@njit(**JIT_OPTIONS)
def drops_this_frame(drops_per_s, variance, dt_s, u, carry):
    """(number of drops to make this frame, new carry).

    MeanNum = ``drops_per_s · dt_s`` (drops per second times the frame's seconds); VarNum =
    ``variance · MeanNum`` (``variance`` is *relative*: 0.1 = ±10 % of the mean; an absolute
    variance of 0.1 drop would be no variation at all). ``u`` is rand() in [−1, 1]. The
    fractional part is carried to the next frame (``carry`` in [0, 1)), so a low rate still
    gives drops_per_s a second on average; the count is within
    [floor(MeanNum − VarNum), ceil(MeanNum + VarNum)].
    """
    if not (drops_per_s > 0.0 and dt_s > 0.0) or not is_finite(drops_per_s * dt_s):
        return 0, 0.0
    mean = drops_per_s * dt_s
    x = max(carry + mean * (1.0 + u * variance), 0.0)
    n = int(x)
    return n, x - n


@njit(inline="always", **JIT_OPTIONS)
def _in_frustum(m, x, y, z):
    """Inside the six planes of the column-vector clip matrix ``m`` (−w ≤ x, y, z ≤ w)."""
    cx = m[0, 0] * x + m[0, 1] * y + m[0, 2] * z + m[0, 3]
    cy = m[1, 0] * x + m[1, 1] * y + m[1, 2] * z + m[1, 3]
    cz = m[2, 0] * x + m[2, 1] * y + m[2, 2] * z + m[2, 3]
    cw = m[3, 0] * x + m[3, 1] * y + m[3, 2] * z + m[3, 3]
    return (-cw <= cx <= cw) and (-cw <= cy <= cw) and (-cw <= cz <= cw)


@njit(inline="always", **JIT_OPTIONS)
def _in_box(eye, half, x, y, z):
    return abs(x - eye[0]) <= half and abs(y - eye[1]) <= half and abs(z - eye[2]) <= half


@njit(inline="always", **JIT_OPTIONS)
def _surface_top(surface, x, y):
    """(top of the ground or water at (x, y) [m], water level or NaN where dry, found)."""
    ground, water, found = sample_surface(surface, x, y)
    if not found:
        return 0.0, np.nan, False
    if not math.isnan(water) and water > ground:
        return water, water, True
    return ground, np.nan, True


@njit(**JIT_OPTIONS)
def step_rain(drops, n_new, randoms, dt_s, now_s, fall_mps, gravity_mps2, wind_x, wind_y,
              clip_from_world, world_from_clip, eye, half_box_m, surface, has_surface,
              ripple_life_s):
    """One frame of rain: move and kill the live drops, then make ``n_new`` new ones.

    ``randoms`` (n_new · SPAWN_TRIES, 3) float64 uniform in [0, 1) (the world's seeded
    generator: the same seed gives the same rain); ``clip_from_world`` / ``world_from_clip``
    (4, 4) float64 column-vector matrices; ``eye`` (3,) [m]; the box is the cube of half-side
    ``half_box_m`` around the eye; ``surface`` the frame's
    :class:`~riverflow.kernels.surface_tiles.SurfaceTiles` (read only if ``has_surface``).
    A drop landing on water writes a hit into the ring only if the row it would replace is
    ``ripple_life_s`` old (the ring holds at most its length of live ripples; heavy rain
    draws that many rings at a time, never a ring cut short). Returns (died on the surface, died out of view or box, born).
    """
    pos = drops.position
    vel = drops.velocity
    counts = drops.counts
    hits = drops.hits
    ring = hits.shape[0]
    m = clip_from_world
    n = counts[0]
    landed = 0
    culled = 0
    i = 0
    while i < n:
        vel[i, 0] = wind_x
        vel[i, 1] = wind_y
        vel[i, 2] -= gravity_mps2 * dt_s
        x = pos[i, 0] + vel[i, 0] * dt_s
        y = pos[i, 1] + vel[i, 1] * dt_s
        z = pos[i, 2] + vel[i, 2] * dt_s
        dead = False
        if not (is_finite(x) and is_finite(y) and is_finite(z)):
            dead = True
            culled += 1
        else:
            if has_surface:
                top, water, found = _surface_top(surface, x, y)
                if found and z <= top:
                    dead = True
                    landed += 1
                    k = counts[3] % ring if ring > 0 else 0
                    # a ripple only where the ring's oldest has run its life (none cut short)
                    if not math.isnan(water) and ring > 0 and now_s - hits[k, 3] >= ripple_life_s:
                        hits[k, 0] = x
                        hits[k, 1] = y
                        hits[k, 2] = water
                        hits[k, 3] = now_s
                        counts[3] += 1
            if not dead and not (_in_box(eye, half_box_m, x, y, z) and _in_frustum(m, x, y, z)):
                dead = True
                culled += 1
        if dead:
            n -= 1
            for c in range(3):
                pos[i, c] = pos[n, c]
                vel[i, c] = vel[n, c]
            continue                     # row i now holds the last drop: not moved yet
        pos[i, 0] = x
        pos[i, 1] = y
        pos[i, 2] = z
        i += 1
    # new drops, in the view volume ∩ the box, above the surface
    inv = world_from_clip
    ex, ey, ez = eye[0], eye[1], eye[2]
    fx, fy, fz = unproject(inv, 0.0, 0.0, -1.0)
    fx -= ex
    fy -= ey
    fz -= ez
    near = math.sqrt(fx * fx + fy * fy + fz * fz)
    born = 0
    if near > 0.0 and half_box_m > near:
        fx /= near
        fy /= near
        fz /= near
        far = half_box_m * math.sqrt(3.0)    # the box's corner: the farthest a drop can be
        n3 = near * near * near
        f3 = far * far * far
        tries = randoms.shape[0]
        t = 0
        for _ in range(n_new):
            if n >= pos.shape[0]:
                break
            while t < tries:
                r = randoms[t]
                t += 1
                nx = 2.0 * r[0] - 1.0
                ny = 2.0 * r[1] - 1.0
                d = (n3 + r[2] * (f3 - n3)) ** (1.0 / 3.0)    # forward distance, pdf ∝ d²
                px, py, pz = unproject(inv, nx, ny, -1.0)    # on the near plane
                rx, ry, rz = px - ex, py - ey, pz - ez
                along = rx * fx + ry * fy + rz * fz
                if not along > 0.0:
                    continue
                s = d / along
                x = ex + rx * s
                y = ey + ry * s
                z = ez + rz * s
                if not (_in_box(eye, half_box_m, x, y, z) and _in_frustum(m, x, y, z)):
                    continue
                if has_surface:
                    top, _, found = _surface_top(surface, x, y)
                    if found and z <= top:
                        continue
                pos[n, 0] = x
                pos[n, 1] = y
                pos[n, 2] = z
                vel[n, 0] = wind_x
                vel[n, 1] = wind_y
                vel[n, 2] = -fall_mps
                n += 1
                born += 1
                break
    counts[0] = n
    counts[1] = born
    counts[2] = n_new
    return landed, culled, born
