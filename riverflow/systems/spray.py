"""Spray and mist (issue #23): the falls' spray particles born, moved, faded — glue only.

The kernel is :func:`riverflow.kernels.spray.step_spray`; the pool is made on the first frame
from the scene's falls (where each nappe lands, at the pool's level: the lip's water level
less the drop). Cost: per_fall particles a fall, whatever the view.
"""
from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from riverflow.components.spray import Spray
from riverflow.engine.system import System
from riverflow.kernels.spray import (RANDOMS_PER_PARTICLE, SpraySources, spray_pool,
                                     step_spray)
from riverflow.scenes.fall_sheets import lip_levels

if TYPE_CHECKING:
    from riverflow.engine.world import RiverWorld


def spray_sources(falls, water) -> SpraySources:
    """Where each of ``falls`` sprays (:class:`~riverflow.kernels.spray.SpraySources`):
    the nappe's landing, at the lip's level (``water.level``) less the drop."""
    lips = lip_levels(falls, water)
    impact = np.array([[*(np.asarray(f.centre_m) + f.throw_m * np.asarray(f.direction)),
                        lip - f.drop_m] for f, lip in zip(falls, lips)], np.float64)
    return SpraySources(impact.reshape(-1, 3),
                        np.array([f.direction for f in falls], np.float64).reshape(-1, 2),
                        np.array([0.5 * f.lip_m for f in falls], np.float64),
                        np.sqrt(np.array([f.drop_m for f in falls], np.float64) / 5.0))


class MakeSpray(System):
    """Step the :class:`Spray` resource (``last_born``: particles born this frame)."""

    name = "spray"

    def __init__(self) -> None:
        self.last_born = 0
        self._randoms = np.zeros((0, RANDOMS_PER_PARTICLE))

    def process(self, world: RiverWorld, dt_s: float) -> None:
        spray = world.resources.get(Spray)
        self.last_born = 0
        if spray is None or not spray.enabled or world.clock.paused:
            return
        if spray.particles is None:
            falls = list(getattr(getattr(world.scene, "graph", None), "falls", ()) or ())
            water = getattr(world.scene, "water", None)
            if not falls or water is None:
                spray.particles = spray_pool(0, spray.per_fall)
                return
            spray.sources = spray_sources(falls, water)
            spray.particles = p = spray_pool(len(falls), spray.per_fall)
            # all born at once, then aged by a random share of their lives (no first puff)
            step_spray(p, spray.sources, spray.rng.random((spray.count, RANDOMS_PER_PARTICLE)),
                       0.0, 0.0, 0.0)
            p.age[:] = spray.rng.uniform(0.0, 1.0, spray.count) * p.life
        if spray.count == 0:
            return
        randoms = self._randoms
        if randoms.shape[0] != spray.count:
            randoms = self._randoms = np.zeros((spray.count, RANDOMS_PER_PARTICLE))
        spray.rng.random(out=randoms)
        wind = spray.wind_mps
        self.last_born = step_spray(spray.particles, spray.sources, randoms,
                                    float(dt_s) * world.clock.speed_factor, float(wind[0]),
                                    float(wind[1]))
