"""MaintainPoissonDisk: cull crowded particles, fill holes by boundary sampling
(Proland ScreenParticleLayer removeOldParticles / addNewParticles)."""
from __future__ import annotations

import esper
import numpy as np

from riverflow.components.particles import ParticlePool
from riverflow.components.river import Clock, FrameView, ScreenGrid
from riverflow.engine.system import System
from riverflow.kernels.poisson_cull import cull_crowded_particles
from riverflow.kernels.poisson_fill import direction_table, fill_poisson_holes


class MaintainPoissonDisk(System):
    name = "poisson"

    SPARSE_FRACTION = 0.75
    """A grid cell holding fewer than this fraction of the particles a Poisson disk puts there
    (0.87 per (2r)²) is searched for holes every frame."""

    @classmethod
    def sparse_below(cls, cell_px: float, radius_px: float) -> int:
        return int(cls.SPARSE_FRACTION * 0.87 * (cell_px / (2.0 * radius_px)) ** 2)

    def __init__(self) -> None:
        self.faded = self.added = 0
        self._table: tuple[float, float, np.ndarray, np.ndarray, float] | None = None

    def _tables(self, radius_px: float, gap_px: float) -> tuple:
        """The direction tables (blocked, touched, cell_px) for this radius and gap."""
        if self._table is None or self._table[:2] != (radius_px, gap_px):
            self._table = (radius_px, gap_px, *direction_table(radius_px, gap_px))
        return self._table[2:]

    def process(self, world, dt_s: float) -> None:
        view = world.resource(FrameView)
        clock = world.resource(Clock)
        c = world.config
        r = c.radius_px
        for _, (pool, grid) in esper.get_components(ParticlePool, ScreenGrid):
            grid.fit(view.width_px, view.height_px, c.grid_cell_factor * r)
            gap = c.spawn_gap_factor * r
            acc = (grid.acc_start, grid.acc_slot, grid.acc_xy)
            tables = self._tables(r, gap)
            self.faded = cull_crowded_particles(
                pool.alive, pool.screen_px, pool.birth_s, pool.fade_reason, pool.status,
                clock.now_s, dt_s, c.fade_in_s, c.active_s, c.fade_out_s,
                c.cull_radius_factor * r,
                grid.cell_px, grid.gw, grid.gh, grid.cell_count, grid.cell_items, *acc,
                grid.removed_cells, grid.dirty, grid.carrier_cells, clock.frame,
                self.sparse_below(grid.cell_px, r),
                int(pool.counters[2]))
            seed = int(world.rng.integers(0, 2**31 - 1))
            lo, hi = c.random_offset_min_m, c.random_offset_max_m
            grid.n_new = self.added = fill_poisson_holes(
                pool.alive, pool.ids, pool.counters, pool.birth_s, pool.intensity,
                pool.screen_px, pool.fade_reason, pool.has_world, pool.velocity_mps, pool.status,
                pool.first_query, pool.offset_m, clock.now_s, c.fade_in_s, c.active_s, r, gap,
                view.width_px, view.height_px, grid.cell_px, grid.gw, grid.gh, grid.cell_count,
                grid.cell_items, *acc, grid.dirty, seed, lo[0], lo[1], hi[0], hi[1],
                grid.candidates, grid.new_slots, *tables)
