"""UpdateWakes: each boat's trail moved on and every wake packed for the foam and the water
shader — glue only (the trail maths: :mod:`riverflow.kernels.wake`).

Runs right after the boats have moved ("boat"): a boat without a
:class:`~riverflow.components.wake.Wake` gets one (``RiverWorld.add_boat`` adds it; a host
that makes boat entities itself gets the defaults). The :class:`Wakes` resource lists the
boats nearest the camera first (the shader draws the first ``MAX_WAKES``).
"""
from __future__ import annotations

import math
from typing import TYPE_CHECKING

import esper
import numpy as np

from riverflow.components.boat import Boat
from riverflow.components.wake import TR_FIELDS, TRAIL_POINTS, Wake, Wakes
from riverflow.engine.system import System
from riverflow.kernels.foam import HL_TRAIL
from riverflow.kernels.wake import advance_trail, pack_trail

if TYPE_CHECKING:
    from riverflow.engine.world import RiverWorld

BOW_FRACTION = 0.4
"""The trail follows the point this far forward of the hull centre, × length (the bow wave's
origin, where the Kelvin wedge starts)."""


class UpdateWakes(System):
    """Advance every boat's trail and fill the :class:`Wakes` resource."""

    name = "wake"

    def process(self, world: RiverWorld, dt_s: float) -> None:
        wakes = world.resources.get(Wakes)
        if wakes is None:
            wakes = Wakes()
            world.insert(wakes)
        boats = esper.get_component(Boat)
        if not boats:
            if wakes.count:
                world.insert(Wakes())
            return
        now_s = world.clock.now_s
        eye = world.camera.position
        rows = []
        for entity, boat in boats:
            wake = esper.try_component(entity, Wake)
            if wake is None:
                wake = Wake()
                esper.add_component(entity, wake)
            heading = float(boat.heading_rad)
            arm = BOW_FRACTION * float(boat.length_m)
            x = float(boat.position_m[0]) + arm * math.cos(heading)
            y = float(boat.position_m[1]) + arm * math.sin(heading)
            flow = np.asarray(boat.flow_mps, np.float64)
            speed = float(np.hypot(*(np.asarray(boat.velocity_mps, np.float64) - flow)))
            wake.count = advance_trail(wake.trail, wake.count, x, y, speed, float(flow[0]),
                                       float(flow[1]), now_s, dt_s, float(wake.sample_s),
                                       float(wake.life_s))
            table = np.empty((TRAIL_POINTS, TR_FIELDS), np.float32)
            pack_trail(wake.trail, wake.count, now_s, float(wake.life_s),
                       float(wake.min_speed_mps), float(wake.spread_mps), float(boat.beam_m),
                       float(wake.wave_slope), table)
            hull = [float(boat.position_m[0]), float(boat.position_m[1]), heading,
                    float(boat.length_m), float(boat.beam_m), speed, float(wake.foam), 0.0]
            distance = math.hypot(hull[0] - eye[0], hull[1] - eye[1])
            rows.append((distance, table, hull))
        rows.sort(key=lambda r: r[0])
        wakes.table = np.stack([r[1] for r in rows])
        wakes.hulls = np.array([r[2] for r in rows], np.float64)
        wakes.hulls[:, HL_TRAIL] = np.arange(len(rows))
