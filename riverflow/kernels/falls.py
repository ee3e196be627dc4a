"""The flow over falls: the velocity speeds up toward each lip, keeps the lip speed along the
nappe and slows back to the river's flow in the plunge pool (:mod:`riverflow.hydro.falls`).

Like the obstacles, a fall is applied *after* the cached query, to the velocities it answered:
each fall multiplies the velocity of the points near it by

    k = 1 + (gain − 1) · r(d) · l(e)

with d [m] the distance past the lip along its downstream direction, e [m] the distance from
the lip's centre across the river, gain = lip speed / the river's speed at the lip's centre,
and

    r(d) = S((d + approach) / approach)  for −approach ≤ d < 0   (speeding up to the lip)
           1                             for 0 ≤ d ≤ throw        (the nappe: the lip speed)
           1 − S((d − throw) / plunge)   for throw < d ≤ throw + plunge (slowing in the pool)
           0                             elsewhere
    l(e) = 1 − S((e − half_lip) / fade)  (1 along the lip, 0 beyond it by ``fade``)

where S(t) = 3t² − 2t³ clamped to [0, 1]. The 2-D field is then no longer divergence-free
there: the water's depth changes instead (it thins as it speeds up), which a depth-averaged
2-D flow does not carry (docs/deviations.md). Velocities keep their direction, so water still
never flows across a bank.

The plunge pool foams (:func:`plunge_closeness`, the foam's pressure term,
:mod:`riverflow.kernels.foam`): from halfway down the nappe, where the water starts to break
up, to where it lands, the closeness rises to 1, then fades over the plunge pool as the flow
slows back (the water decelerating there is the pressure).

A fall is a row of a :class:`FallTable` (one array per field, F rows).
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit

from riverflow.kernels._jit import JIT_OPTIONS

STATUS_INSIDE = 1


class FallTable(NamedTuple):
    """The falls of a field, one row each (lengths [m])."""

    centre: np.ndarray      # (F, 2) float64: the lip's middle
    direction: np.ndarray   # (F, 2) float64: unit downstream tangent at the lip
    half_lip: np.ndarray    # (F,) float64: half the lip's length
    fade: np.ndarray        # (F,) float64: how far beyond the lip's ends the speed-up fades
    approach: np.ndarray    # (F,) float64
    throw: np.ndarray       # (F,) float64: horizontal length of the nappe
    plunge: np.ndarray      # (F,) float64
    gain: np.ndarray        # (F,) float64: lip speed / river speed at the lip's centre


def empty_table() -> FallTable:
    z1 = np.zeros(0)
    return FallTable(np.zeros((0, 2)), np.zeros((0, 2)), z1, z1.copy(), z1.copy(), z1.copy(),
                     z1.copy(), z1.copy())


@njit(inline="always", **JIT_OPTIONS)
def _smooth(t):
    if t <= 0.0:
        return 0.0
    if t >= 1.0:
        return 1.0
    return t * t * (3.0 - 2.0 * t)


@njit(inline="always", **JIT_OPTIONS)
def fall_factor(table, f, x, y):
    """The speed factor k of fall ``f`` at (x, y) [m] (module docstring)."""
    rx = x - table.centre[f, 0]
    ry = y - table.centre[f, 1]
    tx = table.direction[f, 0]
    ty = table.direction[f, 1]
    d = rx * tx + ry * ty
    a = table.approach[f]
    throw = table.throw[f]
    plunge = table.plunge[f]
    if d < -a or d > throw + plunge:
        return 1.0
    e = abs(ry * tx - rx * ty)
    lat = 1.0 - _smooth((e - table.half_lip[f]) / table.fade[f])
    if lat <= 0.0:
        return 1.0
    if d < 0.0:
        r = _smooth((d + a) / a)
    elif d <= throw:
        r = 1.0
    else:
        r = 1.0 - _smooth((d - throw) / plunge)
    return 1.0 + (table.gain[f] - 1.0) * r * lat


@njit(inline="always", **JIT_OPTIONS)
def plunge_closeness(table, x, y):
    """How much (x, y) [m] is in a plunge pool, in [0, 1], the largest over the falls:
    S((d − throw/2) / (throw/2)) up to the landing (d = throw), 1 − S((d − throw) / plunge)
    after it, times the lateral fade (module docstring)."""
    best = 0.0
    for f in range(table.gain.shape[0]):
        rx = x - table.centre[f, 0]
        ry = y - table.centre[f, 1]
        tx = table.direction[f, 0]
        ty = table.direction[f, 1]
        d = rx * tx + ry * ty
        throw = table.throw[f]
        plunge = table.plunge[f]
        if d < 0.5 * throw or d > throw + plunge:
            continue
        e = abs(ry * tx - rx * ty)
        lat = 1.0 - _smooth((e - table.half_lip[f]) / table.fade[f])
        if d <= throw:
            r = _smooth((d - 0.5 * throw) / max(0.5 * throw, 1e-9))
        else:
            r = 1.0 - _smooth((d - throw) / plunge)
        best = max(best, r * lat)
    return best


@njit(**JIT_OPTIONS)
def accelerate_falls(xy, status, velocity, n, table):
    """Multiply the velocities (N, 2) float32 of the first ``n`` points xy (N, 2) float64
    [m] whose status is INSIDE by every fall's factor, in place; returns how many changed."""
    changed = 0
    n_falls = table.gain.shape[0]
    for i in range(n):
        if status[i] != STATUS_INSIDE:
            continue
        k = 1.0
        for f in range(n_falls):
            k *= fall_factor(table, f, xy[i, 0], xy[i, 1])
        if k != 1.0:
            velocity[i, 0] = velocity[i, 0] * k
            velocity[i, 1] = velocity[i, 1] * k
            changed += 1
    return changed
