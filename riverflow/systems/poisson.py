"""MaintainPoissonDisk: cull crowded particles, fill holes by boundary sampling
(Proland ScreenParticleLayer removeOldParticles / addNewParticles)."""
from __future__ import annotations

import esper

from riverflow.components.particles import ParticlePool
from riverflow.components.river import Clock, FrameView, ScreenGrid
from riverflow.engine.system import System
from riverflow.kernels.poisson_cull import cull_crowded_particles
from riverflow.kernels.poisson_fill import DirectionTable, direction_table, fill_poisson_holes


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
        self._table: tuple[float, float, DirectionTable] | None = None

    def _tables(self, radius_px: float, gap_px: float) -> DirectionTable:
        """The direction tables for this radius and gap."""
        if self._table is None or self._table[:2] != (radius_px, gap_px):
            self._table = (radius_px, gap_px, direction_table(radius_px, gap_px))
        return self._table[2]

    def process(self, world, dt_s: float) -> None:
        view = world.resource(FrameView)
        clock = world.resource(Clock)
        c = world.config
        r = c.radius_px
        for _, (pool, grid) in esper.get_components(ParticlePool, ScreenGrid):
            grid.fit(view.width_px, view.height_px, c.grid_cell_factor * r)
            gap = c.spawn_gap_factor * r
            self.faded = cull_crowded_particles(
                pool.arrays, grid.arrays, clock.now_s, dt_s, c.fade_in_s, c.active_s,
                c.fade_out_s, c.cull_radius_factor * r, clock.frame,
                self.sparse_below(grid.cell_px, r))
            seed = int(world.rng.integers(0, 2**31 - 1))
            lo, hi = c.random_offset_min_m, c.random_offset_max_m
            grid.n_new = self.added = fill_poisson_holes(
                pool.arrays, grid.arrays, self._tables(r, gap), clock.now_s, r, gap, seed,
                lo[0], lo[1], hi[0], hi[1])
