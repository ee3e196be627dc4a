"""Life-cycle kernels: ageing, intensity, fading out without a pop, freeing and allocating slots.

Re-does Proland's ``LifeCycleParticleLayer`` (reference §3.3): intensity ramps linearly in over
``fade_in_s``, stays 1 for ``active_s``, ramps out over ``fade_out_s``; a particle told to fade
out keeps its current intensity (its birth time is moved back onto the fade-out ramp); it is
removed when its life is over. Slots are Proland's ``ParticleStorage`` with ``pack``: a new
particle takes the lowest free slot.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit

from riverflow.kernels._jit import JIT_OPTIONS


class Pool(NamedTuple):
    """The particle pool's columns as the particle kernels take them (made once per pool:
    ``ParticlePool.arrays``; shapes and meaning there)."""

    alive: np.ndarray
    ids: np.ndarray
    counters: np.ndarray
    birth_s: np.ndarray
    intensity: np.ndarray
    screen_px: np.ndarray
    fade_reason: np.ndarray
    world_m: np.ndarray
    has_world: np.ndarray
    velocity_mps: np.ndarray
    status: np.ndarray
    first_query: np.ndarray
    water_hint_m: np.ndarray
    hint_id: np.ndarray
    offset_m: np.ndarray
    foam: np.ndarray
    foam_flow: np.ndarray
    foam_shore: np.ndarray
    foam_near: np.ndarray
    foam_id: np.ndarray
    tint: np.ndarray
    tint_id: np.ndarray


@njit(**JIT_OPTIONS)
def intensity_at(age_s, fade_in_s, active_s, fade_out_s):
    """Intensity in [0, 1] of a particle of age ``age_s`` [s]."""
    if age_s < fade_in_s:
        return max(age_s / fade_in_s, 0.0)
    if age_s < fade_in_s + active_s:
        return 1.0
    return min(max(1.0 - (age_s - fade_in_s - active_s) / fade_out_s, 0.0), 1.0)


@njit(**JIT_OPTIONS)
def start_fade_out(i, birth_s, now_s, fade_in_s, active_s, fade_out_s):
    """Move particle i onto its fade-out ramp at its current intensity (no pop).
    Returns True if it was not fading out yet."""
    age = now_s - birth_s[i]
    if age >= fade_in_s + active_s:
        return False
    level = intensity_at(age, fade_in_s, active_s, fade_out_s)
    birth_s[i] = now_s - (fade_in_s + active_s + (1.0 - level) * fade_out_s)
    return True


@njit(**JIT_OPTIONS)
def is_fading_out(i, birth_s, now_s, fade_in_s, active_s):
    return now_s - birth_s[i] >= fade_in_s + active_s


@njit(**JIT_OPTIONS)
def free_particle(i, alive, ids, counters):
    """Remove particle i from the pool."""
    if alive[i]:
        alive[i] = False
        ids[i] = -1
        counters[1] -= 1


@njit(**JIT_OPTIONS)
def allocate_particle(alive, ids, counters, start):
    """Lowest free slot at or after ``start``, marked alive with a new id; −1 if the pool is full.
    ``counters`` (3,) int64: next id, live count, slot bound (every live slot is below it)."""
    for i in range(start, alive.shape[0]):
        if not alive[i]:
            alive[i] = True
            ids[i] = counters[0]
            counters[0] += 1
            counters[1] += 1
            if i >= counters[2]:
                counters[2] = i + 1
            return i
    return -1


@njit(**JIT_OPTIONS)
def age_particles(alive, ids, counters, birth_s, intensity, now_s, fade_in_s, active_s,
                  fade_out_s):
    """Update every live particle's intensity at clock ``now_s`` [s]; free those whose life is
    over. ``alive`` (C,) bool, ``ids`` (C,) int64, ``counters`` (3,) int64 (its slot bound is
    lowered to the last live slot + 1), ``birth_s`` (C,) float64 [s], ``intensity`` (C,)
    float32. Returns the number removed."""
    removed = 0
    total = fade_in_s + active_s + fade_out_s
    last = -1
    for i in range(min(counters[2], alive.shape[0])):
        if not alive[i]:
            continue
        age = now_s - birth_s[i]
        if age >= total or age != age:  # NaN birth: never keep a corrupt particle
            free_particle(i, alive, ids, counters)
            removed += 1
            continue
        intensity[i] = intensity_at(age, fade_in_s, active_s, fade_out_s)
        last = i
    counters[2] = last + 1
    return removed
