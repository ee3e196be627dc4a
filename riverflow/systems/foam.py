"""UpdateFoam: the foam each particle carries (seed 001's flow force) — glue only.

Runs after the particles have moved, aged and been placed (advection … placement), so new
particles get their neighbours' foam in the frame they are born; the kernel is
:func:`riverflow.kernels.foam.update_foam`. Its sources: the flow tiles (shores, strain),
the view's surface tiles (water-surface slope), the hulls in the flow (boats with their speed
through the water; other obstacles by their speed relative to the current) and the boats'
wake trails (:class:`~riverflow.components.wake.Wakes`).
"""
from __future__ import annotations

from typing import TYPE_CHECKING

import esper
import numpy as np

from riverflow.components.foam import FoamSettings
from riverflow.components.particles import ParticlePool
from riverflow.components.river import Clock, RiverNode, ScreenGrid, TerrainView
from riverflow.components.wake import Wakes
from riverflow.engine.system import System
from riverflow.kernels import obstacles as ko
from riverflow.kernels.foam import (HL_FOAM, HL_SPEED, HL_TRAIL, HULL_FIELDS, FoamFlow,
                                    FoamParams, FoamSources, ScreenNeighbours, update_foam)
from riverflow.kernels.sprites import SPRITE_RADIUS_FACTOR
from riverflow.kernels.wake import TR_FIELDS
from riverflow.physics.boat import BOATS_KEY

if TYPE_CHECKING:
    from riverflow.engine.world import RiverWorld

RIVER_EVERY = 64
"""A particle's river terms (shores, pressure, steepness) are recomputed every this many
frames, staggered by slot: they follow the river, along which a particle moves about a metre
meanwhile at 1 m/s (the shore foam band is metres wide; the foam itself is relaxed every
frame)."""
NEAR_EVERY = 8
"""… and its closeness to a hull or its wash every this many frames when it is near one (a
boat at full speed moves a metre meanwhile; hull foam reaches 1.5 beams, and grows with a
time constant of 0.3 s anyway)."""
assert all(k & (k - 1) == 0 for k in (RIVER_EVERY, NEAR_EVERY)), "the kernel staggers by bit masks"

_NO_TRAILS = np.zeros((0, 2, TR_FIELDS), np.float32)


class UpdateFoam(System):
    """Foam sources → each water particle's foam target; foam relaxes toward it."""

    name = "foam"

    def __init__(self) -> None:
        self._scratch = np.zeros(0, np.int32)
        self._params: tuple[tuple, FoamParams] | None = None
        self.computed = self.near_hulls = self.born = 0
        """Of the last frame: river terms computed, hull terms computed, new particles."""

    def _foam_params(self, settings: FoamSettings) -> FoamParams:
        """The kernel's parameters, made again (and checked) only when a knob changes."""
        key = tuple(vars(settings).values())
        if self._params is None or self._params[0] != key:
            settings.validate()
            self._params = (key, foam_params(settings))
        return self._params[1]

    def process(self, world: RiverWorld, dt_s: float) -> None:
        settings = world.resources.get(FoamSettings)
        clock = world.resource(Clock)
        surface = world.resource(TerrainView).surface
        if settings is None or clock.paused or surface is None:
            return
        for _, (node, pool, grid) in esper.get_components(RiverNode, ParticlePool, ScreenGrid):
            if not settings.enabled:
                pool.foam[:] = 0.0
                pool.foam_id[:] = -1
                continue
            if len(self._scratch) < pool.capacity:
                self._scratch = np.zeros(pool.capacity, np.int32)
            field = node.field
            tiles = field.tiles
            level = tiles.query_level
            flow = FoamFlow(tiles.view(), tiles.shore, tiles.bank, level, level,
                            field.fall_table())
            self.computed, self.near_hulls, self.born = update_foam(
                int(pool.counters[2]), pool.arrays, self._foam_params(settings), flow, surface,
                foam_sources(world, field), screen_neighbours(grid, world.config.radius_px),
                float(dt_s), clock.frame, RIVER_EVERY, NEAR_EVERY, self._scratch)


def foam_params(s: FoamSettings) -> FoamParams:
    """The kernel's view of the settings."""
    return FoamParams(float(s.base), float(s.steepness), float(s.distance), float(s.pressure),
                      float(s.shore), float(s.shore_m), float(s.shore_calm), float(s.steep_from),
                      float(s.steep_full), float(s.speed_mps), float(s.impinge_mps),
                      float(s.strain_ps), float(s.hull_beams), float(s.hull_speed_mps),
                      float(s.wash_s), float(s.rise_s), float(s.decay_s))


def foam_sources(world: RiverWorld, field) -> FoamSources:
    """The boats (hull, speed through the water, wake trail: the :class:`Wakes` resource as
    it is) and any other obstacle in the flow (by its speed relative to the current under
    it, from one flow query) as the kernel reads them."""
    wakes = world.resources.get(Wakes)
    if wakes is None:
        wakes = Wakes()
    hulls, trails = wakes.hulls, wakes.table
    others = _other_obstacles(field)
    if len(others):
        _, flow = field.query(others[:, [ko.OB_X, ko.OB_Y]], exclude_obstacles=True)
        rows = np.zeros((len(others), HULL_FIELDS))
        rows[:, :5] = others[:, [ko.OB_X, ko.OB_Y, ko.OB_HEADING, ko.OB_LENGTH, ko.OB_BEAM]]
        rows[:, HL_SPEED] = np.hypot(*(others[:, [ko.OB_VX, ko.OB_VY]] - flow).T)
        rows[:, HL_FOAM] = 1.0
        rows[:, HL_TRAIL] = -1.0
        hulls = np.concatenate([hulls, rows])
    if not len(trails):
        trails = _NO_TRAILS
    return FoamSources(hulls, trails)


def _other_obstacles(field) -> np.ndarray:
    """The field's obstacles that are not the boat system's (those come with their wakes)."""
    obstacles = field.obstacles
    if not len(obstacles):
        return obstacles
    boats = field.obstacle_rows(BOATS_KEY)
    if boats.start == 0 and boats.stop == len(obstacles):
        return obstacles[:0]
    keep = np.ones(len(obstacles), bool)
    keep[boats.start:boats.stop] = False
    return obstacles[keep]


def screen_neighbours(grid: ScreenGrid, radius_px: float) -> ScreenNeighbours:
    return ScreenNeighbours(float(grid.cell_px), int(grid.gw), int(grid.gh), grid.cell_count,
                            grid.cell_items, float(SPRITE_RADIUS_FACTOR * radius_px))
