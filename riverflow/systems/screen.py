"""ProjectParticles: world → screen, fading what leaves the view (Proland ScreenParticleLayer)."""
from __future__ import annotations

import esper

from riverflow.components.particles import ParticlePool
from riverflow.components.river import Clock, FrameView
from riverflow.engine.system import System
from riverflow.kernels.screen import project_particles


class ProjectParticles(System):
    name = "screen"

    def __init__(self) -> None:
        self.killed = self.faded = 0

    def process(self, world, dt_s: float) -> None:
        view = world.resource(FrameView)
        clock = world.resource(Clock)
        c = world.config
        for _, pool in esper.get_component(ParticlePool):
            self.killed, self.faded = project_particles(
                pool.alive, pool.ids, pool.counters, pool.has_world, pool.world_m,
                pool.screen_px, pool.birth_s, pool.fade_reason, view.clip_from_world,
                view.width_px, view.height_px, c.offscreen_kill_factor * c.radius_px,
                clock.now_s, c.fade_in_s, c.active_s, c.fade_out_s)
