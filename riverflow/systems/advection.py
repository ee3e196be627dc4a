"""AdvectParticles: carry the particles along the flow (Proland TerrainParticleLayer)."""
from __future__ import annotations

import esper
import numpy as np

from riverflow.components.particles import ParticlePool
from riverflow.components.river import Clock, FrameView, RiverNode, ScreenGrid, TerrainView
from riverflow.components.status import FlowStatus
from riverflow.engine.system import System
from riverflow.hydro.flow_field import FlowField
from riverflow.kernels.advection import (HIT_WATER, Probes, apply_flow_status,
                                         check_outside_near_water, move_particles,
                                         place_at_seen_water)
from riverflow.kernels.flow import query_velocity
from riverflow.kernels.obstacles import OB_BEAM, OB_LENGTH, OB_REACH, OB_X, OB_Y
from riverflow.kernels.placement import pixel_rays
from riverflow.kernels.raycast_tiles import cast_rays_onto_tiles

_NO_LEVELS = np.zeros(0, np.int8)
_NO_BOX = np.array([np.inf, np.inf, -np.inf, -np.inf])

NEAR_CHECK_EVERY = 8
"""An OUTSIDE particle is looked at every this many frames, staggered by slot: it probes its
water hint (deep water near its line of sight) when that is on screen nearby and no particle
covers it."""
NEAR_REPLACE_EVERY = 32
"""… and every this many frames one with an INSIDE particle nearby is replaced instead
(Proland replaces it every frame)."""
NEAR_COVER = 2.0
"""A probe point closer than this · r to an INSIDE or LEAVING particle is covered."""
ALTITUDE_EVERY = 16
"""A moving particle's altitude is looked up again every this many frames, staggered."""
VELOCITY_EVERY = 4
"""An INSIDE particle asks the flow for its velocity every this many frames, staggered (and
every frame near a moving obstacle); the other frames it asks only whether it is still
inside (docs/deviations.md)."""

for _every in (NEAR_CHECK_EVERY, NEAR_REPLACE_EVERY, ALTITUDE_EVERY, VELOCITY_EVERY):
    assert _every > 0 and _every & (_every - 1) == 0, "the kernels stagger by bit masks"


class AdvectParticles(System):
    """Move, then ask the flow where the particles now are; OUTSIDE ones next to the river
    probe for water that no particle covers, and give way to it."""

    name = "advection"

    def __init__(self) -> None:
        self.moved = self.removed = self.waiting = self.probes = self.placed = 0
        self._view: tuple[np.ndarray, np.ndarray] | None = None
        self._probe_xy = np.zeros((0, 2), np.float32)
        self._owner = np.zeros(0, np.int32)
        self._rows = np.zeros(0, np.int32)

    def process(self, world, dt_s: float) -> None:
        clock = world.resource(Clock)
        view = world.resource(FrameView)
        if clock.paused:
            self._view = (view.clip_from_world.copy(), view.world_from_clip.copy())
            return
        surface = world.resource(TerrainView).surface
        if surface is None:
            return
        reach_px = world.config.grid_cell_factor * world.config.radius_px
        for _, (node, pool, grid) in esper.get_components(RiverNode, ParticlePool, ScreenGrid):
            cap = len(grid.query_index)
            self.moved, n_velocity, n_status = move_particles(
                int(pool.counters[2]), pool.alive, pool.has_world, pool.world_m,
                pool.velocity_mps, pool.status, dt_s * clock.speed_factor, surface, clock.frame,
                ALTITUDE_EVERY,
                VELOCITY_EVERY, always_velocity_box(node.field),
                node.field.falls_box() if node.field.falls else _NO_BOX, grid.query_index,
                grid.query_xy)
            if n_status:  # the status-only askers, listed from the end, after the others
                tail = slice(cap - n_status, cap)
                grid.query_index[n_velocity:n_velocity + n_status] = grid.query_index[tail][::-1]
                grid.query_xy[n_velocity:n_velocity + n_status] = grid.query_xy[tail][::-1]
            self.waiting = ask_flow(node.field, pool, grid, n_velocity + n_status, reach_px,
                                    n_velocity)
            router = world.flood
            if router is not None and router.active:   # the altitudes just read: onto the
                self._flood_altitude(router, pool, grid, clock.frame, n_velocity, n_status)
            self._near_water(world, node.field, pool, grid, surface, reach_px)
        # the screen positions the next frame starts from were projected with this view
        self._view = (view.clip_from_world.copy(), view.world_from_clip.copy())

    @staticmethod
    def _flood_altitude(router, pool: ParticlePool, grid: ScreenGrid, frame: int,
                        n_velocity: int, n_status: int) -> None:
        """The moving particles whose altitude ``move_particles`` read from the base surface
        this frame (every ALTITUDE_EVERY frames, staggered by slot) raised onto the flood's
        water (:meth:`~riverflow.hydro.flood.FloodRouter.lift_altitudes`)."""
        rows = grid.query_index[:n_velocity + n_status]
        rows = rows[((rows + frame) & (ALTITUDE_EVERY - 1)) == 0]
        moving = pool.status[rows]
        rows = rows[(moving == FlowStatus.INSIDE) | (moving == FlowStatus.LEAVING)]
        router.lift_altitudes(pool.world_m, rows)

    def _near_water(self, world, field: FlowField, pool: ParticlePool, grid: ScreenGrid,
                    surface, reach_px: float) -> None:
        """The NEAR rule and the water-hint probes (:func:`check_outside_near_water`), then a
        particle at each probe that sees uncovered water inside the flow
        (:func:`place_at_seen_water`); a particle whose hint did not is not asked again."""
        c = world.config
        r = c.radius_px
        view = world.resource(FrameView)
        clock = world.resource(Clock)
        forward, inverse = self._view or (view.clip_from_world, view.world_from_clip)
        if len(self._probe_xy) < pool.capacity:
            self._probe_xy = np.zeros((pool.capacity, 2), np.float32)
            self._owner = np.zeros(pool.capacity, np.int32)
        self.removed, n = check_outside_near_water(
            pool.arrays, grid.arrays, clock.now_s, c.fade_in_s + c.active_s, reach_px,
            clock.frame, NEAR_CHECK_EVERY, NEAR_REPLACE_EVERY, NEAR_COVER * r, view.width_px,
            view.height_px, forward, view.eye_m[0], view.eye_m[1], surface, self._probe_xy,
            self._owner)
        self.probes = n
        self.placed = 0
        if n == 0:
            return
        if len(self._rows) < n:
            self._rows = np.arange(max(n, 2 * len(self._rows)), dtype=np.int32)
        origin = np.empty((n, 3))
        direction = np.empty((n, 3))
        pixel_rays(self._rows, n, self._probe_xy, inverse, view.width_px, view.height_px,
                   origin, direction)
        hit_xyz = np.empty((n, 3))
        hit = np.empty(n, np.uint8)
        cast_rays_onto_tiles(origin, direction, surface, c.far_m, hit_xyz, hit)
        water = np.flatnonzero(hit == HIT_WATER)
        flow_status = np.zeros(len(water), np.uint8)
        velocity = np.empty((len(water), 2), np.float32)
        if len(water):
            query_flow(field, np.ascontiguousarray(hit_xyz[water, :2]), flow_status, velocity)
        seen = np.zeros(n, bool)
        seen[water[flow_status == FlowStatus.INSIDE]] = True
        missed = self._owner[:n][~seen]
        pool.water_hint_m[missed, 0] = np.inf  # hidden from here, or not in the river
        if not len(water):
            return
        lo, hi = c.random_offset_min_m, c.random_offset_max_m
        probes = Probes(self._probe_xy[water], hit[water], hit_xyz[water], flow_status,
                        velocity)
        self.placed, removed = place_at_seen_water(
            pool.arrays, grid.arrays, probes, len(water), clock.now_s, c.fade_in_s, c.active_s,
            c.spawn_gap_factor * r, int(world.rng.integers(0, 2**31 - 1)), lo[0], lo[1], hi[0],
            hi[1])
        self.removed += removed


def always_velocity_box(field: FlowField) -> np.ndarray:
    """(4,) [m] xmin, ymin, xmax, ymax around every obstacle's influence and every fall's
    lip and nappe (empty when there is none): particles there get a velocity every frame, as
    the hulls move and as the water speeds up and falls (over a fall, their altitude too:
    ``FlowField.falls_box``)."""
    obstacles = field.obstacles
    box = field.falls_box() if field.falls else _NO_BOX
    if not len(obstacles):
        return box
    half = (0.5 * np.maximum(obstacles[:, OB_LENGTH], obstacles[:, OB_BEAM])
            + obstacles[:, OB_REACH])
    x, y = obstacles[:, OB_X], obstacles[:, OB_Y]
    return np.array([min((x - half).min(), box[0]), min((y - half).min(), box[1]),
                     max((x + half).max(), box[2]), max((y + half).max(), box[3])])


def query_flow(field: FlowField, xy: np.ndarray, status: np.ndarray, velocity: np.ndarray,
               n_velocity: int | None = None) -> None:
    """Flow status (N,) uint8 and velocity (N, 2) float32 [m/s] at ``xy`` (N, 2) float64 [m]
    from the tile of the frame's flow cut under each (a coarser cached one standing in where
    that one is late; ``kernels.flow._locate``), bent around the field's obstacles; the points from
    ``n_velocity`` on get their status alone."""
    n = len(xy)
    n_velocity = n if n_velocity is None else n_velocity
    level = field.tiles.query_level
    query_velocity(xy, _NO_LEVELS, level, level, field.tiles.view(), field.tiles.cache.tick,
                   field.segments, n_velocity, status[:n], velocity[:n])
    if (field.falls or field.rapids) and n_velocity:     # sped up over falls and rapids
        field.apply_falls(xy, status, velocity, n_velocity)
    if field.discharge_scale is not None and n:   # (the status-only askers: the floodplain)
        field.discharge_scale(xy, status, velocity, n_velocity, n)
    if len(field.obstacles) and n_velocity:
        field.apply_obstacles(xy[:n_velocity], status[:n_velocity], velocity[:n_velocity],
                              level=level, fallback=level)


def ask_flow(field: FlowField, pool: ParticlePool, grid: ScreenGrid, n: int,
             reach_px: float, n_velocity: int | None = None) -> int:
    """Query the flow for particles ``grid.query_index[:n]`` at ``grid.query_xy[:n]`` (the
    finest cached tile under each), bent around the field's obstacles (boats), and run the
    status machine; those from ``n_velocity`` on ask for their status alone and keep their
    velocity. Returns how many wait for a tile."""
    n_velocity = n if n_velocity is None else n_velocity
    query_flow(field, grid.query_xy[:n], grid.query_status[:n], grid.query_velocity[:n],
               n_velocity)
    return apply_flow_status(pool.alive, pool.velocity_mps, pool.status, pool.first_query,
                             pool.screen_px, n, grid.query_index, grid.query_status,
                             grid.query_velocity, n_velocity, grid.cell_px, grid.gw, grid.gh,
                             grid.cell_count, grid.cell_items, reach_px)
