"""AdvectParticles: carry the particles along the flow (Proland TerrainParticleLayer)."""
from __future__ import annotations

import esper
import numpy as np

from riverflow.components.particles import ParticlePool
from riverflow.components.river import Clock, RiverNode, ScreenGrid, SurfaceGrids
from riverflow.engine.system import System
from riverflow.kernels.advection import advance_particles, select_flow_queries
from riverflow.kernels.flow import query_velocity

_NO_LEVELS = np.zeros(0, np.int8)


class AdvectParticles(System):
    name = "advection"

    def __init__(self) -> None:
        self.moved = self.removed = self.waiting = 0

    def process(self, world, dt_s: float) -> None:
        clock = world.resource(Clock)
        if clock.paused:
            return
        grids = world.resource(SurfaceGrids)
        config = world.config
        for _, (node, pool, grid) in esper.get_components(RiverNode, ParticlePool, ScreenGrid):
            field = node.field
            t = field.tiles
            n = select_flow_queries(pool.alive, pool.has_world, pool.status, pool.world_m,
                                    grid.query_index, grid.query_xy)
            t.tick += 1
            query_velocity(grid.query_xy[:n], _NO_LEVELS, field.max_level, field.max_level,
                           t.root_x_m, t.root_y_m, t.root_size_m, t.n_cells, t.slots_flat,
                           t.level_offset, t.psi, t.cell_status, t.cell_segments, t.last_used,
                           t.tick, *field.network.geometry_args(), grid.query_status[:n],
                           grid.query_velocity[:n])
            self.moved, self.removed, self.waiting = advance_particles(
                pool.alive, pool.ids, pool.counters, pool.has_world, pool.world_m,
                pool.velocity_mps, pool.status, pool.first_query, pool.screen_px, n,
                grid.query_index, grid.query_status, grid.query_velocity,
                dt_s * clock.speed_factor, grid.cell_px, grid.gw, grid.gh, grid.cell_count,
                grid.cell_items, config.grid_cell_factor * config.radius_px, grids.water_m,
                grids.ground_m, grids.origin_x, grids.origin_y, grids.cell_m)
