"""Flood system: routes the world's hydrographs (issue 25) up to the world clock.

Glue only: the router (:class:`riverflow.hydro.flood.FloodRouter`, a resource made by the
first ``world.set_hydrograph``) steps in whole fixed steps of its own
(:mod:`riverflow.kernels.flood`) until it is within one step of ``clock.now_s``, so its state
depends on the world time only, never on how frames cut it. With no hydrograph it does nothing.
"""
from __future__ import annotations

from typing import TYPE_CHECKING

from riverflow.engine.system import System

if TYPE_CHECKING:
    from riverflow.engine.world import RiverWorld


class AdvanceFlood(System):
    name = "flood"

    def process(self, world: RiverWorld, dt_s: float) -> None:
        router = world.flood
        if router is not None:
            router.advance_to(world.clock.now_s)
