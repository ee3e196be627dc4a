"""MoveBoats: step every boat's physics and put the hulls into the flow as moving obstacles
(SPEC §3, system 1: "input / boat") — glue only.

The physics (flow under the hull, motion, shores as walls, floating, the hull as an obstacle
row) is :mod:`riverflow.physics.boat`. Here: each frame, every
:class:`~riverflow.components.boat.Boat` is stepped with the flow read without its own row of
the obstacle set ``BOATS_KEY``, and the rows of all boats replace that set. If the boat entity
has a :class:`~riverflow.components.props.Pose` (``RiverWorld.add_boat`` adds one with a
"boat" prop), it is set from the boat, so the draw system shows it.
"""
from __future__ import annotations

import esper
import numpy as np

from riverflow.components.boat import Boat
from riverflow.components.props import Pose
from riverflow.components.river import TerrainView
from riverflow.engine.system import System
from riverflow.kernels import obstacles as ko
from riverflow.physics.boat import BOATS_KEY, step_boat
from riverflow.physics.hull import Shore


class MoveBoats(System):
    """Drive, collide and float every boat; put the hulls into the flow."""

    name = "boat"

    def __init__(self) -> None:
        self._rows: dict[int, int] = {}
        """entity → its row in this system's obstacle set, as last set."""
        self._shores: dict[int, Shore] = {}
        self._poses: dict[int, tuple[np.ndarray, float]] = {}
        """entity → its last good (position, heading), restored if gameplay writes NaN."""

    def process(self, world, dt_s: float) -> None:
        field = world.field
        boats = esper.get_component(Boat)
        if not boats:
            if self._rows:
                field.set_obstacles(np.zeros((0, ko.OBSTACLE_FIELDS)), key=BOATS_KEY)
                self._rows, self._poses = {}, {}
            return
        water = world.scene.water
        shore = self._shores.get(id(water.polygon))
        if shore is None:
            shore = self._shores[id(water.polygon)] = Shore(water.polygon)
        surface = world.resource(TerrainView).surface
        now_s = world.clock.now_s
        start = field.obstacle_rows(BOATS_KEY).start
        rows = np.empty((len(boats), ko.OBSTACLE_FIELDS))
        poses = {}
        for i, (entity, boat) in enumerate(boats):
            own = self._rows.get(entity)
            rows[i] = step_boat(boat, field, shore, surface, water, dt_s, now_s,
                                self._poses.get(entity, (np.zeros(2), 0.0)),
                                () if own is None else (start + own,))
            if world.flood is not None and world.flood.active:   # a flood raises the water
                boat.altitude_m += float(world.flood.level_rise(boat.position_m[None])[0])
            poses[entity] = (boat.position_m.copy(), boat.heading_rad)
            pose = esper.try_component(entity, Pose)
            if pose is not None:
                pose.position_m = np.array([*boat.position_m, boat.altitude_m])
                pose.yaw_rad = boat.heading_rad
                pose.pitch_rad = boat.pitch_rad
                pose.roll_rad = boat.roll_rad
        field.set_obstacles(rows, key=BOATS_KEY)
        self._rows = {entity: i for i, (entity, _) in enumerate(boats)}
        self._poses = poses
