"""PlaceNewParticles: give the particles born this frame their world position by casting their
pixel's ray onto the surface tiles of the view (CPU, numba; no depth-buffer read-back)."""
from __future__ import annotations

import esper
import numpy as np

from riverflow.components.particles import ParticlePool
from riverflow.components.river import FrameView, RiverNode, ScreenGrid, TerrainView
from riverflow.engine.system import System
from riverflow.kernels.placement import (drop_unseen, pixel_rays, place_particles,
                                         select_new_on_ground)
from riverflow.kernels.raycast_tiles import HIT_UNKNOWN, cast_rays_onto_tiles
from riverflow.systems.advection import ask_flow


class PlaceNewParticles(System):
    name = "placement"

    def __init__(self) -> None:
        self._origin = np.zeros((0, 3))
        self._dir = np.zeros((0, 3))
        self._hit_xyz = np.zeros((0, 3))
        self._hit = np.zeros(0, np.uint8)
        self.sky = 0
        self.unseen = 0
        """New particles of the last frame dropped because their surface tile was not made."""

    def process(self, world, dt_s: float) -> None:
        view = world.resource(FrameView)
        surface = world.resource(TerrainView).surface
        for _, (node, pool, grid) in esper.get_components(RiverNode, ParticlePool, ScreenGrid):
            if len(self._hit) != pool.capacity:
                c = pool.capacity
                self._origin = np.zeros((c, 3))
                self._dir = np.zeros((c, 3))
                self._hit_xyz = np.zeros((c, 3))
                self._hit = np.zeros(c, np.uint8)
            n = grid.n_new
            if n == 0 or surface is None:
                self.sky = self.unseen = 0
                continue
            pixel_rays(grid.new_slots, n, pool.screen_px, view.world_from_clip, view.width_px,
                       view.height_px, self._origin, self._dir)
            cast_rays_onto_tiles(self._origin[:n], self._dir[:n], surface, world.config.far_m,
                                 self._hit_xyz[:n], self._hit[:n])
            if world.flood is not None:         # a flood's raised water over the surface
                world.flood.lift_hits(self._dir[:n], self._hit_xyz[:n], self._hit[:n])
            self.sky = place_particles(grid.new_slots, n, self._hit_xyz, self._hit, pool.world_m,
                                       pool.has_world, pool.status, pool.first_query)
            self.unseen = drop_unseen(grid.new_slots, n, self._hit, HIT_UNKNOWN, pool.alive,
                                      pool.ids, pool.counters, pool.has_world)
            # their first flow answer now, so the frame ends with every status up to date
            k = select_new_on_ground(grid.new_slots, n, pool.has_world, pool.world_m,
                                     grid.query_index, grid.query_xy)
            ask_flow(node.field, pool, grid, k,
                     world.config.grid_cell_factor * world.config.radius_px)
