"""AgeParticles: intensities from age; removal at the end of life (Proland LifeCycleParticleLayer)."""
from __future__ import annotations

import esper

from riverflow.components.particles import ParticlePool
from riverflow.components.river import Clock
from riverflow.engine.system import System
from riverflow.kernels.lifecycle import age_particles


class AgeParticles(System):
    name = "lifecycle"

    def __init__(self) -> None:
        self.removed = 0

    def process(self, world, dt_s: float) -> None:
        clock = world.resource(Clock)
        c = world.config
        for _, pool in esper.get_component(ParticlePool):
            self.removed = age_particles(pool.alive, pool.ids, pool.counters, pool.birth_s,
                                         pool.intensity, clock.now_s, c.fade_in_s, c.active_s,
                                         c.fade_out_s)
