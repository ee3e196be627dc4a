"""Flood system: routes the world's hydrographs (issue 25) by the frame's simulated time.

Glue only: the router (:class:`riverflow.hydro.flood.FloodRouter`, a resource made by the
first ``world.set_hydrograph``) steps in whole fixed steps of its own
(:mod:`riverflow.kernels.flood`), so its state depends on the flood's time only, never on how
frames cut it. The frame's time counts ``clock.speed_factor`` times (as the spills'); a
paused clock holds the flood too. With no hydrograph it does nothing.
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
        clock = world.clock
        if router is None or clock.paused or dt_s <= 0.0:
            return
        router.advance(dt_s * clock.speed_factor)
