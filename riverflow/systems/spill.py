"""Spill system: advances the world's spills (issue 24) by the frame's simulated time.

Glue only: the solver (:class:`riverflow.hydro.spills.SpillSolver`, a resource made by the
first ``world.add_spill``) steps in whole fixed steps of its own (:mod:`riverflow.kernels.spill`),
so a run's concentrations depend on the simulated time only, never on the frame times' cut or
on the camera. The frame's time counts ``clock.speed_factor`` times (a spill over hours runs
fast); a paused clock holds the spills too. With no spill the system does nothing.
"""
from __future__ import annotations

from typing import TYPE_CHECKING

from riverflow.engine.system import System

if TYPE_CHECKING:
    from riverflow.engine.world import RiverWorld


class AdvanceSpills(System):
    name = "spill"

    def process(self, world: RiverWorld, dt_s: float) -> None:
        solver = world.spill_solver
        clock = world.clock
        if solver is None or clock.paused or dt_s <= 0.0:
            return
        solver.advance(dt_s * clock.speed_factor)
