"""PlaceNewParticles: give the particles born this frame their world position by casting their
pixel's ray onto the terrain and water surface (CPU, numba; no depth-buffer read-back)."""
from __future__ import annotations

import esper
import numpy as np

from riverflow.components.particles import ParticlePool
from riverflow.components.river import FrameView, RiverNode, ScreenGrid, SurfaceGrids
from riverflow.engine.system import System
from riverflow.kernels.placement import pixel_rays, place_particles, select_new_on_ground
from riverflow.kernels.raycast import cast_rays_onto_heightfield
from riverflow.systems.advection import ask_flow, surface_tables


class PlaceNewParticles(System):
    name = "placement"

    def __init__(self) -> None:
        self._origin = np.zeros((0, 3))
        self._dir = np.zeros((0, 3))
        self._hit_xyz = np.zeros((0, 3))
        self._hit = np.zeros(0, np.uint8)
        self.sky = 0

    def process(self, world, dt_s: float) -> None:
        view = world.resource(FrameView)
        grids = world.resource(SurfaceGrids)
        pyramid = surface_tables(grids)[0]
        for _, (node, pool, grid) in esper.get_components(RiverNode, ParticlePool, ScreenGrid):
            if len(self._hit) != pool.capacity:
                c = pool.capacity
                self._origin = np.zeros((c, 3))
                self._dir = np.zeros((c, 3))
                self._hit_xyz = np.zeros((c, 3))
                self._hit = np.zeros(c, np.uint8)
            n = grid.n_new
            if n == 0:
                self.sky = 0
                continue
            pixel_rays(grid.new_slots, n, pool.screen_px, view.world_from_clip, view.width_px,
                       view.height_px, self._origin, self._dir)
            cast_rays_onto_heightfield(self._origin[:n], self._dir[:n], grids.ground_m,
                                       grids.water_m, grids.origin_x, grids.origin_y,
                                       grids.cell_m, world.config.far_m, self._hit_xyz[:n],
                                       self._hit[:n], pyramid)
            self.sky = place_particles(grid.new_slots, n, self._hit_xyz, self._hit, pool.world_m,
                                       pool.has_world, pool.status, pool.first_query)
            # their first flow answer now, so the frame ends with every status up to date
            k = select_new_on_ground(grid.new_slots, n, pool.has_world, pool.world_m,
                                     grid.query_index, grid.query_xy)
            ask_flow(node.field, pool, grid, k,
                     world.config.grid_cell_factor * world.config.radius_px)
