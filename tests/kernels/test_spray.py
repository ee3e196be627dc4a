"""Spray and mist at the falls (issue #23, :mod:`riverflow.kernels.spray`): the kernel against
its numpy twin, and what the particles do — born on the impact line at the pool's level,
rising, carried off with the wind, never under the pool."""
from __future__ import annotations

import numpy as np
import pytest

from riverflow.kernels.spray import (MIST_DRAG, MIST_GRAVITY, MIST_LIFT_DRAG,
                                     RANDOMS_PER_PARTICLE, SpraySources, pack_spray, spray_pool,
                                     step_spray)

WIND = (2.0, -1.0)


def _sources():
    d = np.array([[1.0, 0.0], [0.6, 0.8]])
    return SpraySources(np.array([[10.0, 0.0, 5.0], [50.0, 20.0, -2.0]]), d,
                        np.array([6.0, 3.0]), np.sqrt(np.array([5.0, 2.0]) / 5.0))


def _twin(p, src, r, dt, wx, wy):
    """Numpy twin of step_spray (module docstring), on copies; returns (particles, born)."""
    pos, vel, age, life = (a.copy() for a in (p.position, p.velocity, p.age, p.life))
    f = p.source
    age = age + dt
    born = age >= life
    t, s = src.direction[f], src.strength[f]
    across = (2 * r[:, 0] - 1) * src.half_width[f]
    along = r[:, 1] - 0.5
    n = np.stack([-t[:, 1], t[:, 0]], 1)
    new_pos = src.impact[f].copy()
    new_pos[:, :2] += along[:, None] * t + across[:, None] * n
    out = (0.5 + 1.5 * r[:, 2]) * s
    side = (r[:, 0] - 0.5) * s
    new_vel = np.zeros_like(vel)
    new_vel[:, :2] = out[:, None] * t + side[:, None] * n
    new_vel[:, 2] = (2.0 + 4.0 * r[:, 3]) * s
    k = min(MIST_DRAG * dt, 1.0)
    mv = vel.copy()
    mv[:, 0] += (wx - mv[:, 0]) * k
    mv[:, 1] += (wy - mv[:, 1]) * k
    mv[:, 2] += -mv[:, 2] * min(MIST_LIFT_DRAG * dt, 1.0) - MIST_GRAVITY * dt
    mp = pos + mv * dt
    floor = src.impact[f, 2]
    under = mp[:, 2] < floor
    mp[under, 2] = floor[under]
    mv[under, 2] = 0.0
    pos = np.where(born[:, None], new_pos, mp)
    vel = np.where(born[:, None], new_vel, mv)
    age = np.where(born, 0.0, age)
    life = np.where(born, 1.5 + 2.5 * r[:, 2], life)
    return (pos, vel, age, life), int(born.sum())


def test_the_spray_kernel_matches_its_numpy_twin_and_the_particles_rise_and_drift():
    rng = np.random.default_rng(7)
    src = _sources()
    p = spray_pool(2, 64)
    p.life[:] = rng.uniform(0.0, 2.0, len(p.life))       # staggered first births
    young_vz, old_v, born_total = [], [], 0
    for frame in range(150):
        r = rng.random((len(p.age), RANDOMS_PER_PARTICLE))
        dt = 1 / 30 if frame % 3 else 1 / 20
        want, want_born = _twin(p, src, r, dt, *WIND)
        born = step_spray(p, src, r, dt, *WIND)
        assert born == want_born
        for got, w in zip((p.position, p.velocity, p.age, p.life), want):
            assert np.allclose(got, w, rtol=1e-9, atol=1e-9)
        born_total += born
        f = p.source
        # never under the pool's level; just born: on the impact line at that level
        assert np.all(p.position[:, 2] >= src.impact[f, 2] - 1e-12)
        new = p.age == 0.0
        rel = p.position[new, :2] - src.impact[f[new], :2]
        t = src.direction[f[new]]
        assert np.all(np.abs(np.einsum("ij,ij->i", rel, t)) <= 0.5 + 1e-9)
        assert np.all(np.abs(rel[:, 0] * t[:, 1] - rel[:, 1] * t[:, 0])
                      <= src.half_width[f[new]] + 1e-9)
        assert np.allclose(p.position[new, 2], src.impact[f[new], 2])
        young_vz += p.velocity[(p.age > 0) & (p.age < 0.3), 2].tolist()
        old_v += p.velocity[p.age > 1.5, :2].tolist()
    assert born_total > 2 * 128                           # every particle born again
    assert np.mean(young_vz) > 1.0                          # rising at the impact
    drift = np.mean(old_v, 0)                               # carried off with the wind
    assert np.hypot(*(drift - WIND)) < 0.35 * np.hypot(*WIND), drift
    out = np.zeros((len(p.age), 2, 4), np.float32)
    assert pack_spray(p, out) == len(p.age)
    u = np.clip(p.age / p.life, 0, 1)
    assert np.allclose(out[:, 0, :3], p.position, atol=1e-3)
    assert np.allclose(out[:, 0, 3], u, atol=1e-6)
    assert np.allclose(out[:, 1, 0], 1.0 + 2.5 * np.sqrt(u), atol=1e-5)


def test_no_falls_no_spray():
    p = spray_pool(0, 64)
    assert len(p.age) == 0
    assert step_spray(p, _sources(), np.zeros((0, RANDOMS_PER_PARTICLE)), 0.1, 0.0, 0.0) == 0
