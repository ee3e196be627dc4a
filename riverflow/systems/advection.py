"""AdvectParticles: carry the particles along the flow (Proland TerrainParticleLayer)."""
from __future__ import annotations

import esper
import numpy as np

from riverflow.components.particles import ParticlePool
from riverflow.components.river import Clock, RiverNode, ScreenGrid, SurfaceGrids
from riverflow.engine.system import System
from riverflow.hydro.flow_field import FlowField
from riverflow.kernels.advection import (apply_flow_status, move_particles,
                                         remove_outside_near_water, select_flow_queries)
from riverflow.kernels.flow import query_velocity

_NO_LEVELS = np.zeros(0, np.int8)

NEAR_CHECK_EVERY = 4
"""An OUTSIDE particle is checked for INSIDE neighbours (and then replaced) every this many
frames, staggered by id."""


class AdvectParticles(System):
    """Move, then ask the flow where the particles now are; OUTSIDE ones next to the river go."""

    name = "advection"

    def __init__(self) -> None:
        self.moved = self.removed = self.waiting = 0

    def process(self, world, dt_s: float) -> None:
        clock = world.resource(Clock)
        if clock.paused:
            return
        g = world.resource(SurfaceGrids)
        reach_px = world.config.grid_cell_factor * world.config.radius_px
        for _, (node, pool, grid) in esper.get_components(RiverNode, ParticlePool, ScreenGrid):
            self.moved = move_particles(pool.alive, pool.has_world, pool.world_m,
                                        pool.velocity_mps, pool.status,
                                        dt_s * clock.speed_factor, g.water_m, g.ground_m,
                                        g.origin_x, g.origin_y, g.cell_m)
            n = select_flow_queries(pool.alive, pool.has_world, pool.status, pool.world_m,
                                    grid.query_index, grid.query_xy)
            self.waiting = ask_flow(node.field, pool, grid, n, reach_px)
            self.removed = remove_outside_near_water(
                pool.alive, pool.ids, pool.counters, pool.status, pool.screen_px, grid.cell_px,
                grid.gw, grid.gh, grid.cell_count, grid.cell_items, reach_px, grid.wet_cells,
                grid.removed_cells, clock.frame, NEAR_CHECK_EVERY)


def ask_flow(field: FlowField, pool: ParticlePool, grid: ScreenGrid, n: int,
             reach_px: float) -> int:
    """Query the flow for particles ``grid.query_index[:n]`` at ``grid.query_xy[:n]`` (the
    finest cached tile under each), bent around the field's obstacles (boats), and run the
    status machine; returns how many wait for a tile."""
    t = field.tiles
    t.tick += 1
    query_velocity(grid.query_xy[:n], _NO_LEVELS, field.max_level, field.max_level,
                   t.root_x_m, t.root_y_m, t.root_size_m, t.n_cells, t.slots_flat,
                   t.level_offset, t.psi, t.cell_status, t.cell_segments, t.last_used, t.tick,
                   *field.network.geometry_args(), grid.query_status[:n],
                   grid.query_velocity[:n])
    if len(field.obstacles):
        field.apply_obstacles(grid.query_xy[:n], grid.query_status[:n], grid.query_velocity[:n],
                              level=field.max_level, fallback=field.max_level)
    return apply_flow_status(pool.alive, pool.velocity_mps, pool.status, pool.first_query,
                             pool.screen_px, n, grid.query_index, grid.query_status,
                             grid.query_velocity, grid.cell_px, grid.gw, grid.gh,
                             grid.cell_count, grid.cell_items, reach_px)
