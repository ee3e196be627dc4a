"""Spray and mist at the falls' plunge pools (issue #23): a small fixed pool of particles per
fall, born where the nappe lands, rising, carried off by the wind, fading.

Each particle belongs to one fall (its *source*) for good. When its age passes its life it is
born again at its source: at a random point of the impact line (across the lip, ±half_width;
along the river within ±0.5 m of where the nappe lands; at the pool's level) with an upward
speed of (2 + 4·r)·strength [m/s], thrown on downstream at (0.5 + 1.5·r)·strength and sideways
at ±0.5·strength, and a life of 1.5 + 2.5·r seconds (r: uniform randoms given by the caller,
four a particle a frame, so that the kernel is deterministic and has a numpy twin).
Strength is √(drop / 5 m) (the impact speed's share of a 5 m fall's, √(2·g·drop)).

Between births the droplets move under gravity eased by the air (``MIST_GRAVITY``: the mist's
fine droplets fall at a small terminal speed) and are pulled towards the wind's velocity with
``MIST_DRAG`` per second across, ``MIST_LIFT_DRAG`` up and down (``v += ((wind − v)·drag −
(0, 0, g')) · dt``, then ``p += v · dt``);
under the pool's level they stop sinking (they spread over the water). The draw system fades a
particle in over the first tenth of its life and out after (``shaders/spray.glsl``) and grows
it as it spreads.
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from riverflow.kernels._jit import JIT_OPTIONS

MIST_DRAG = 1.6
"""How fast [1/s] a droplet takes the wind's horizontal velocity…"""
MIST_LIFT_DRAG = 0.8
"""…and loses its vertical one [1/s] (the impact's updraft carries the mist up longer)."""
MIST_GRAVITY = 1.0
"""The droplets' downward acceleration [m/s²] against the air's drag (g for a free drop)."""
RANDOMS_PER_PARTICLE = 4


class SprayParticles(NamedTuple):
    """A fixed pool of spray particles (N of them)."""

    position: np.ndarray    # (N, 3) float64 [m]
    velocity: np.ndarray    # (N, 3) float64 [m/s]
    age: np.ndarray         # (N,) float64 [s]
    life: np.ndarray        # (N,) float64 [s]
    source: np.ndarray      # (N,) int32: the fall it belongs to (a row of SpraySources)


class SpraySources(NamedTuple):
    """Where each fall's spray is born (F rows)."""

    impact: np.ndarray      # (F, 3) float64: where the nappe's middle lands, at the pool's level
    direction: np.ndarray   # (F, 2) float64: the unit downstream direction
    half_width: np.ndarray  # (F,) float64: half the lip [m]
    strength: np.ndarray    # (F,) float64: √(drop / 5 m)


@njit(**JIT_OPTIONS)
def step_spray(particles, sources, randoms, dt_s, wind_x, wind_y):
    """Age and move every particle by ``dt_s`` [s]; those past their life are born again at
    their source (module docstring) with the randoms (N, 4) float64 in [0, 1) of their row.
    Returns how many were born."""
    born = 0
    n = particles.age.shape[0]
    pos = particles.position
    vel = particles.velocity
    for i in range(n):
        f = particles.source[i]
        particles.age[i] += dt_s
        if particles.age[i] >= particles.life[i]:
            tx = sources.direction[f, 0]
            ty = sources.direction[f, 1]
            s = sources.strength[f]
            across = (2.0 * randoms[i, 0] - 1.0) * sources.half_width[f]
            along = randoms[i, 1] - 0.5
            pos[i, 0] = sources.impact[f, 0] + along * tx - across * ty
            pos[i, 1] = sources.impact[f, 1] + along * ty + across * tx
            pos[i, 2] = sources.impact[f, 2]
            out = (0.5 + 1.5 * randoms[i, 2]) * s
            side = (randoms[i, 0] - 0.5) * s
            vel[i, 0] = out * tx - side * ty
            vel[i, 1] = out * ty + side * tx
            vel[i, 2] = (2.0 + 4.0 * randoms[i, 3]) * s
            particles.age[i] = 0.0
            particles.life[i] = 1.5 + 2.5 * randoms[i, 2]
            born += 1
            continue
        k = min(MIST_DRAG * dt_s, 1.0)
        vel[i, 0] += (wind_x - vel[i, 0]) * k
        vel[i, 1] += (wind_y - vel[i, 1]) * k
        vel[i, 2] += -vel[i, 2] * min(MIST_LIFT_DRAG * dt_s, 1.0) - MIST_GRAVITY * dt_s
        pos[i, 0] += vel[i, 0] * dt_s
        pos[i, 1] += vel[i, 1] * dt_s
        pos[i, 2] += vel[i, 2] * dt_s
        floor = sources.impact[f, 2]
        if pos[i, 2] < floor:
            pos[i, 2] = floor
            vel[i, 2] = 0.0
    return born


@njit(**JIT_OPTIONS)
def pack_spray(particles, out):
    """The particles as the spray shader reads them, into ``out`` (N, 2, 4) float32: (x, y,
    z, age / life), (size [m], 0, 0, 0); size grows from 1 m to 3.5 m over the life."""
    for i in range(particles.age.shape[0]):
        u = particles.age[i] / max(particles.life[i], 1e-6)
        out[i, 0, 0] = particles.position[i, 0]
        out[i, 0, 1] = particles.position[i, 1]
        out[i, 0, 2] = particles.position[i, 2]
        out[i, 0, 3] = min(max(u, 0.0), 1.0)
        out[i, 1, 0] = 1.0 + 2.5 * math.sqrt(min(max(u, 0.0), 1.0))
    return particles.age.shape[0]


def spray_pool(n_falls: int, per_fall: int) -> SprayParticles:
    """An empty pool of ``per_fall`` particles a fall, every one due to be born (age = life =
    0)."""
    n = int(n_falls) * int(per_fall)
    return SprayParticles(np.zeros((n, 3)), np.zeros((n, 3)), np.zeros(n), np.zeros(n),
                          np.repeat(np.arange(n_falls, dtype=np.int32), per_fall))
