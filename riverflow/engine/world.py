"""RiverWorld: one esper world of rivers, its resources, its ordered systems and ``step``.

Each RiverWorld owns its own esper world (``esper.switch_world``), so two river worlds — or a
host game's own esper world — never see each other's entities: every call that touches esper
switches to this world and back. What a world owns outside itself (that esper world in esper's
module-level registry, the tile worker thread, GPU objects) is released by :meth:`close`, by
the end of a ``with`` block, or, for a world simply dropped, by a finalizer when it is
collected: nothing that outlives the world (esper's registry, the worker thread, the finalizer)
holds a reference to it. Resources (the camera, the clock, the configuration, the
scene, the surface grids, this frame's view) are singletons held in a typed dict, not entities
(reference/aesthetics.md P5).

Example::

    world = RiverWorld(default_scene(seed=0), size=(640, 360), seed=0)
    world.camera.look_at((0, -300, 120), (0, 0, 10))
    for _ in range(60):
        world.step(1 / 60)
    print(len(world.particles), world.timings_ms)
"""
from __future__ import annotations

import contextlib
import functools
import gc
import math
import threading
import time
import uuid
import weakref
from collections.abc import Iterator
from typing import Any, TypeVar

import esper
import numpy as np

from riverflow._validate import (as_points, check_allocation, finite_positive, non_negative,
                                 size_px)
from riverflow._validate import seed as seed_value
from riverflow.components.display import DisplaySettings
from riverflow.components.foam import FoamSettings
from riverflow.components.particles import LiveParticles, ParticlePool
from riverflow.components.rain import Rain
from riverflow.components.spray import Spray
from riverflow.components.river import Clock, FrameView, RiverNode, ScreenGrid, TerrainView, Tiles
from riverflow.components.wake import Wakes
from riverflow.engine.camera import Camera
from riverflow.engine.config import RiverConfig
from riverflow.engine.system import System
from riverflow.hydro.flow_field import FlowField
from riverflow.hydro.tile_producer import FlowProducer
from riverflow.kernels.warmup import compile_kernels
from riverflow.physics.boat import boat_components
from riverflow.scenes.flight import default_view
from riverflow.scenes.tile_kinds import terrain_producers
from riverflow.tiles.cache import TileCache
from riverflow.tiles.scheduler import TileScheduler

T = TypeVar("T")

SPILL_SNAP_M = 50.0
"""A spill released on land is moved to the nearest water within this distance [m]."""


class _SpillSolverKey:
    """The resource key of the world's spill solver (made by the first spill)."""


class _FloodRouterKey:
    """The resource key of the world's flood router (made by the first hydrograph)."""


def _seconds_ahead(seconds, what: str) -> float:
    """``seconds`` as a float for the ``advance_*`` calls: ValueError (naming ``what``) for a
    negative, NaN or infinite time or a value that is not a number."""
    try:
        value = non_negative(seconds, f"{what}: seconds")
    except TypeError as exc:
        raise ValueError(str(exc)) from None
    if value > MAX_AHEAD_S:
        raise ValueError(f"{what}: seconds must be at most {MAX_AHEAD_S:.4g} (a year) a call, "
                         f"got {seconds!r:.40}")
    return value


MAX_AHEAD_S = 366 * 86400.0
"""Longest jump of one ``advance_spills`` / ``advance_flood`` call [s]: a year."""


class RiverWorld:
    """A landscape with rivers, simulated (and, with ``gl=True``, drawn) frame by frame.

    Args:
        scene: what to simulate: ``scene.graph``, ``scene.terrain``, ``scene.water``,
            ``scene.bounds_m`` (the built-in :func:`riverflow.default_scene` or your own).
        size: viewport (W, H) [px].
        gl: draw with OpenGL: True draws into the world's own offscreen framebuffer, with
            the pyglet context current when the world is made (a pyglet window) or else a
            hidden offscreen one (EGL when there is no display); ``"current"`` draws into
            the framebuffer and viewport of whatever OpenGL ≥ 3.3 context the host has
            current (pygame-ce, glfw, moderngl-window, SDL, Qt, arcade), depth-tested
            against what the host drew, leaving the host's GL state as it was (see
            :meth:`draw`); False runs every system but drawing with no OpenGL at all.
        seed: seeds every random choice; the same seed and inputs give bit-identical pools.
        config: :class:`RiverConfig`; default ``RiverConfig()``.
        systems: the ordered systems; default :func:`riverflow.systems.schedule.default_systems`.
    """

    def __init__(self, scene: Any, size: tuple[int, int] = (640, 360), *,
                 gl: bool | str = False, seed: int = 0, config: RiverConfig | None = None,
                 systems: list[System] | None = None) -> None:
        size = size_px(size, "RiverWorld: size")       # (W, H) ≥ 1 px, whole, bounded
        seed = seed_value(seed, "RiverWorld: seed")
        if not (gl is True or gl is False or gl == "current"):
            raise ValueError(f"RiverWorld: gl must be False, True or \"current\", got {gl!r}")
        self.config = config if config is not None else RiverConfig()
        self.gl = bool(gl)
        self.host = gl == "current"
        """Draws into the host's current context and framebuffer (``gl="current"``)."""
        self.context = None
        if self.host:      # before anything is made: no usable context fails at once
            from riverflow.engine import gl as gl_module

            self.context = gl_module.acquire_host_context()
        self.seed = seed
        self.rng = np.random.default_rng(self.seed)
        self.scene = scene
        self.name = f"riverflow-{uuid.uuid4().hex}"
        self.resources: dict[type, Any] = {}
        self.timings_ms: dict[str, float] = {}
        self._view_loaded = False
        self._edits = None          # riverflow.engine.edits.LiveEdits, on the first edit
        self._lock = threading.RLock()
        """Held while the world runs or is read (a frame, a draw, every call of its API,
        :data:`_SERIALIZED`): a background edit is swapped in by the edits' thread only while
        none runs (:meth:`_swap_between_frames`)."""
        self._between_frames = threading.Event()   # the host's frame is over (not drawing)
        self._frames_begun = 0
        self._frame_ended_at = 0.0
        self._closed_world = False
        c = self.config
        if not hasattr(scene, "quadtree"):
            raise TypeError("RiverWorld needs a streamed landscape (riverflow.default_scene(), "
                            f"riverflow.landscape(graph, …)), not a {type(scene).__name__}")
        # the kernels' machine code before the first frame (a progress line on stderr while a
        # cold cache compiles; a host's loading screen calls compile_kernels itself first)
        compile_kernels(*(("world", "draw") if self.gl else ("world",)))
        q = scene.quadtree
        cache = TileCache(int(c.tile_cache_mb * (1 << 20)))
        field = FlowField(scene.graph, c.slip, c.search_radius_factor,
                          potential_delta_m=c.potential_delta_m, cache=cache,
                          domain_m=(q.root_x_m, q.root_y_m, q.root_size_m))
        self.field = field
        producers = [*terrain_producers(scene), FlowProducer(field)]
        self.tiles = Tiles(cache, TileScheduler(cache, producers, c.tile_production,
                                                   worker=c.tile_worker,
                                                   pause_in_frames=c.tile_process_pause,
                                                   workers=c.tile_workers))
        self._owned = _Owned(self.name, self.tiles.scheduler)
        self._finalizer = weakref.finalize(self, _release, self._owned)
        self._finalizer.atexit = False     # at exit the worker is a daemon, GL may be gone
        self.tiles.scheduler.start()       # forked here, not in the first frame
        eye, target = default_view(scene)     # on the scene's main river
        camera = Camera(position=tuple(eye.tolist()), target=tuple(target.tolist()),
                        fov_y_deg=c.fov_y_deg, near_m=c.near_m, far_m=c.far_m,
                        size_px=tuple(int(v) for v in size))
        self.camera = camera
        terrain = TerrainView(z_min=float(scene.z_range_m[0]), z_max=float(scene.z_range_m[1]))
        for resource in (camera, c, Clock(speed_factor=c.speed_factor), FrameView(), terrain,
                         DisplaySettings(), self.tiles, Rain(seed=self.seed), FoamSettings(),
                         Wakes(), Spray(seed=self.seed)):
            self.insert(resource)
        self._river_node = RiverNode(scene.graph, field)     # (an edit swaps without esper)
        with self.active():
            self.river = esper.create_entity(self._river_node, ParticlePool(c.capacity),
                                             ScreenGrid(c.capacity))
            if self.gl:
                _add_wave_tiles(self.seed)
        if systems is None:
            # the one place the engine reaches up to the systems, when it is made, not when
            # it is imported: the systems import the engine (riverflow/systems/schedule.py)
            from riverflow.systems.schedule import default_systems

            systems = default_systems(self.gl)
        self.systems = systems
        self.pool: ParticlePool = self.component(ParticlePool)
        if self.gl:
            from riverflow.engine import gl as gl_module  # pyglet's GL: only when drawing

            if self.context is None:
                with gl_module.keeping_native_current():   # a host's context stays current
                    self.context = gl_module.acquire_context()
            for system in self.systems:
                if hasattr(system, "attach"):
                    system.attach(self.context)

    @property
    def systems(self) -> list[System]:
        """The ordered systems (replace the list to run others; :meth:`close` closes them)."""
        return self._owned.systems

    @systems.setter
    def systems(self, value: list[System]) -> None:
        self._owned.systems = value

    # -- resources -------------------------------------------------------------------------

    def insert(self, resource: Any) -> None:
        """Add or replace the resource of ``type(resource)``."""
        self.resources[type(resource)] = resource

    def resource(self, kind: type[T]) -> T:
        return self.resources[kind]

    def component(self, kind: type[T]) -> T:
        """The river node's component of ``kind`` (e.g. :class:`ParticlePool`)."""
        with self.active():
            return esper.component_for_entity(self.river, kind)

    @contextlib.contextmanager
    def _frame(self, drawn: bool = False) -> Iterator[None]:
        """A frame's step (``drawn``: its draw) runs, holding the world's lock; after it the
        host's frame is over where the world is not drawn, or after its draw
        (:meth:`_swap_between_frames` waits for that)."""
        self._between_frames.clear()
        self._frames_begun += 1
        with self._lock:
            try:
                yield
            finally:
                if drawn or not self.gl:
                    self._frame_ended_at = time.perf_counter()
                    self._between_frames.set()

    @contextlib.contextmanager
    def active(self) -> Iterator[None]:
        """Make this world's esper context current for the block, then restore the caller's."""
        previous = esper.current_world
        esper.switch_world(self.name)
        try:
            yield
        finally:
            esper.switch_world(previous)

    # -- running -----------------------------------------------------------------------------

    @property
    def clock(self) -> Clock:
        return self.resource(Clock)

    @property
    def paused(self) -> bool:
        """Particles frozen (they still age and fade)."""
        return self.clock.paused

    @paused.setter
    def paused(self, value: bool) -> None:
        self.clock.paused = bool(value)

    @property
    def speed_factor(self) -> float:
        return self.clock.speed_factor

    @speed_factor.setter
    def speed_factor(self, value: float) -> None:
        self.clock.speed_factor = non_negative(value, "speed_factor")

    def step(self, dt_s: float) -> None:
        """Advance the world by ``dt_s`` seconds and run every system once, in order.

        A negative, NaN or huge ``dt_s`` (a hitch) is clamped to [0, config.max_step_s];
        anything but a real number (text, None, an array, a bool) is a TypeError naming dt_s.
        """
        if type(dt_s) is not float and (isinstance(dt_s, bool) or not isinstance(
                dt_s, (int, np.integer, np.floating))):
            raise TypeError(f"step: dt_s must be a number of seconds, got "
                            f"{type(dt_s).__name__} {dt_s!r:.80}")
        try:
            dt = float(dt_s) if math.isfinite(dt_s) else 0.0
        except OverflowError:              # an int past float's range: a very long hitch
            dt = self.config.max_step_s if dt_s > 0 else 0.0
        dt = min(max(dt, 0.0), self.config.max_step_s)
        with self._frame():
            self._step(dt)

    def _step(self, dt: float) -> None:
        if self._edits is not None:
            self._land_edit()              # a background edit made meanwhile: swapped in now
        clock = self.clock
        clock.now_s += dt
        timings = self.timings_ms
        scheduler = self.tiles.scheduler
        scheduler.frame_begins()
        try:
            with self.active():
                esper.clear_dead_entities()
                for system in self.systems:
                    if system.phase != "update" or (system.needs_gl and not self.gl):
                        continue
                    t0 = time.perf_counter_ns()
                    system.process(self, dt)
                    timings[system.name] = (time.perf_counter_ns() - t0) * 1e-6
        finally:
            scheduler.frame_ends()
        clock.frame += 1

    def load_view(self, timeout_s: float = 120.0) -> bool:
        """Make every tile the current camera view needs, now (a loading screen: before a
        scripted run, after a teleport). Runs the camera and tile systems with no time passing
        and waits for the scheduler, until no tile of the view is missing; then, with
        ``config.freeze_gc_on_load``, the garbage collector is told to leave what is alive now
        alone. Returns False if that took longer than ``timeout_s``.

        Once the view's tiles are made, the update systems run once more with no time passing,
        so that the particles' first Poisson fill of the screen (tens of milliseconds at
        1080p) happens here, on the loading screen, not in the first frame.

        ``timeout_s``: a number of seconds ≥ 0 (inf: no limit); NaN, negative or not a number
        is a ValueError / TypeError naming it."""
        if isinstance(timeout_s, bool) or not isinstance(timeout_s, (int, float, np.integer,
                                                                      np.floating)):
            raise TypeError(f"load_view: timeout_s must be a number of seconds, got "
                            f"{type(timeout_s).__name__} {timeout_s!r:.80}")
        if not timeout_s >= 0:                       # NaN and negatives
            raise ValueError(f"load_view: timeout_s must be ≥ 0 seconds, got {timeout_s!r}")
        scheduler = self.tiles.scheduler
        end = time.perf_counter() + float(timeout_s) if timeout_s < 1e18 else math.inf
        starts = scheduler.max_starts
        scheduler.max_starts = 1 << 30      # no frame to keep short: queue the whole view
        try:
            return self._load_view(scheduler, end)
        finally:
            scheduler.max_starts = starts

    def _load_view(self, scheduler, end: float) -> bool:
        names = ("camera", "tiles")
        with self.active():
            first = True
            while True:
                for system in self.systems:
                    if system.name in names:
                        system.process(self, 0.0)
                if first:                  # what earlier views asked for is not waited for
                    scheduler.forget_unrequested()
                    first = False
                if scheduler.pending == 0:
                    break
                if not scheduler.wait(max(end - time.perf_counter(), 0.0)):
                    return False
            def seed() -> None:             # the screen's particles: seeded with no time passing
                for system in self.systems:
                    if system.phase == "update" and not (system.needs_gl and not self.gl):
                        system.process(self, 0.0)
            # (the pages a frame writes, learnt on the way: an edit's fork copies them)
            scheduler.learn_frame(seed)
        self._view_loaded = True
        if self.config.freeze_gc_on_load:
            _collect_and_freeze()
        return True

    def add_prop(self, shape: str, size_m: tuple[float, float, float],
                 position_m=(0.0, 0.0, 0.0), yaw_rad: float = 0.0) -> int:
        """Add a prop (``"boat"`` or ``"barrel"``, (length, width, height) [m]) drawn with the
        river; returns its entity. Move it with :meth:`pose`."""
        from riverflow.components.props import Pose, Prop

        with self.active():
            prop = Prop(shape, size_m)           # checks the shape name and the size
            position = np.array(position_m, np.float64)
            if position.shape != (3,) or not np.isfinite(position).all() \
                    or not math.isfinite(yaw_rad):
                raise ValueError(f"add_prop: position_m must be 3 finite numbers [m] and yaw_rad "
                                 f"finite, got {position_m!r}, {yaw_rad!r}")
            return esper.create_entity(prop, Pose(position, float(yaw_rad)))

    def pose(self, entity: int):
        """The :class:`~riverflow.components.props.Pose` of a prop entity (mutable)."""
        from riverflow.components.props import Pose

        return self._component_of(entity, Pose, "pose", "a prop")

    def add_boat(self, position_m, heading_rad: float = 0.0, *, drawn: bool = True,
                 **params) -> int:
        """Add a boat on the water at ``position_m`` (2,) [m], bow towards ``heading_rad``;
        ``params`` set fields of :class:`~riverflow.components.boat.Boat` (length_m, beam_m,
        throttle, max_thrust_mps2…). The "boat" system (first in the frame) moves it with the
        flow and its controls, keeps it in the water and bends the flow around it; its
        :class:`~riverflow.components.wake.Wake` (:meth:`wake`) leaves a Kelvin wake and a
        foam trail behind it when it moves through the water. ``drawn`` also gives it a
        "boat" prop whose pose follows it. Returns its entity.

        Raises:
            ValueError: an unknown or bad parameter, or the hull does not fit in the water.
        """
        from riverflow.components.wake import Wake

        components = boat_components(self.scene, position_m, heading_rad, drawn=drawn, **params)
        with self.active():
            return esper.create_entity(*components, Wake())

    def wake(self, entity: int):
        """The :class:`~riverflow.components.wake.Wake` of a boat entity (mutable: its wave
        slope, foam, minimum speed, life; its trail)."""
        from riverflow.components.wake import Wake

        return self._component_of(entity, Wake, "wake", "a boat")

    @property
    def foam(self) -> FoamSettings:
        """The knobs of the particles' foam (mutable; ``world.particles.foam`` is each live
        particle's amount)."""
        return self.resource(FoamSettings)

    def boat(self, entity: int):
        """The :class:`~riverflow.components.boat.Boat` of a boat entity (mutable: write its
        ``throttle`` and ``rudder``, read its position, heading, altitude, pitch, roll)."""
        from riverflow.components.boat import Boat

        return self._component_of(entity, Boat, "boat", "a boat")

    def _component_of(self, entity, kind: type[T], what: str, holder: str) -> T:
        """The ``kind`` component of ``entity``; a KeyError saying what was asked otherwise."""
        with self.active():
            try:
                return esper.component_for_entity(entity, kind)
            except (KeyError, TypeError):
                pass
        raise KeyError(f"{what}: {entity!r:.80} is not {holder} entity of this world (its "
                       f"{kind.__name__} was never made or the entity was deleted)")

    def set_rain(self, drops_per_s: float, variance: float = 0.1,
                 wind_mps: tuple[float, float] = (0.0, 0.0)) -> None:
        """Rain (seed 002; the "rain" system): ``drops_per_s`` new drops a second in the
        view volume around the camera; each frame makes mean + rand[−1, 1] · variance · mean
        of them, mean = drops_per_s · dt (``variance`` is relative: 0.1 = ±10 %); they fall
        with a constant acceleration, carried by the wind ``wind_mps`` (vx, vy) [m/s], and die
        on the ground or the water (ripple rings there) or out of view. ``set_rain(0)`` stops
        the rain at once: every drop and ripple is removed. See :attr:`rain_drops`."""
        wind = as_points(wind_mps, "set_rain: wind_mps (vx, vy) [m/s]")
        if len(wind) != 1:
            raise ValueError(f"set_rain: wind_mps must be one (vx, vy) [m/s], got {wind_mps!r:.80}")
        values = (non_negative(drops_per_s, "set_rain: drops_per_s"),
                  non_negative(variance, "set_rain: variance"), *map(float, wind[0]))
        check_allocation(values[0] * self.config.max_step_s * (1.0 + values[1]) * 8 * 24,
                         f"set_rain: drops_per_s={drops_per_s!r} (per frame of up to "
                         f"{self.config.max_step_s:g} s)")
        rain = self.resource(Rain)
        rain.drops_per_s, rain.variance, rain.wind_mps = values[0], values[1], values[2:]
        if values[0] == 0.0:
            rain.clear()

    @property
    def rain_drops(self) -> np.ndarray:
        """A copy of the live rain drops' positions, (N, 3) float64 [m]."""
        drops = self.resource(Rain).drops
        return drops.position[:int(drops.counts[0])].copy()

    # -- spills (issue 24) ------------------------------------------------------------------

    @property
    def spill_solver(self):
        """The world's :class:`~riverflow.hydro.spills.SpillSolver`, or None before the first
        :meth:`add_spill` (or :meth:`configure_spills`)."""
        return self.resources.get(_SpillSolverKey)

    def configure_spills(self, dispersion=None, *, dt_s: float | None = None):
        """Make the spill solver now with these settings (a
        :class:`~riverflow.hydro.spill_network.Dispersion`; ``dt_s``: its fixed step [s], at most
        the network's stable step): before the first spill only (ValueError after). Returns it."""
        from riverflow.hydro.spills import SpillSolver

        from riverflow.hydro.spill_network import Dispersion

        if dispersion is not None and not isinstance(dispersion, Dispersion):
            raise TypeError(f"configure_spills: dispersion must be a Dispersion or None, got "
                            f"{type(dispersion).__name__} {dispersion!r:.80}")
        dt = 0.0 if dt_s is None else finite_positive(dt_s, "configure_spills: dt_s")
        if self.spill_solver is not None and self.spill_solver.n_spills:
            raise ValueError("configure_spills: this world has spills already (configure first)")
        network = self._cell_network(dispersion)
        solver = SpillSolver(network, dt_s=dt)
        self.resources[_SpillSolverKey] = solver
        return solver

    def _cell_network(self, dispersion=None):
        """The river network cut into cells along its links (the spills' and the flood's)."""
        from riverflow.hydro.spill_network import build_spill_network, section_discharge_m2s

        branches = self.scene.branches
        qs = [b.discharge_m2s if b.discharge_m2s is not None
              else section_discharge_m2s(self.field.potential, b.centerline_m, b.widths_m)
              for b in branches]
        return build_spill_network(branches, qs, dispersion)

    # -- floods (issue 25) ------------------------------------------------------------------

    @property
    def flood(self):
        """The world's :class:`~riverflow.hydro.flood.FloodRouter`, or None before the first
        :meth:`set_hydrograph` / :meth:`set_discharge`."""
        return self.resources.get(_FloodRouterKey)

    def set_hydrograph(self, link, times_s, discharge_m3s) -> None:
        """Make the inflow at the start of ``link`` (a branch name or index in the flood's
        upstream-first order; None: every source, shared by their base discharges) follow
        the hydrograph ``discharge_m3s`` [m³/s] at times ``times_s`` [s] of the flood's clock
        (:attr:`flood_time_s`; piecewise linear, held beyond its ends; on a link below others it replaces what
        comes from upstream: a dam's release). The discharge is routed downstream by the
        kinematic wave ("flood" system, :mod:`riverflow.hydro.flood`): the flow's speed
        follows it (velocities × (Q/Q₀)^(2/5)) and the water level its rating curve
        (:meth:`water_level`). ``discharge_m3s`` None removes the link's hydrograph
        (``set_hydrograph(None, [], None)`` makes :attr:`flood` and changes nothing).

        Raises:
            ValueError: an unknown link, negative / NaN discharges, times not strictly
                increasing or of another length; the world keeps its old state.
        """
        router = self.flood
        if router is None:
            from riverflow.hydro.flood import FloodRouter

            router = FloodRouter(self._cell_network(), self.clock.now_s)
            router.set_hydrograph(link, times_s, discharge_m3s)    # raises before it is kept
            router.ground = self._flood_ground
            # the level's textures now (~0.2 s, in this call): not in the frame in which
            # the flood first steps and the particles are lifted onto its level
            router.level_textures()
            self.resources[_FloodRouterKey] = router
            self.field.discharge_scale = router.scale_velocity
            return
        router.set_hydrograph(link, times_s, discharge_m3s)

    def _flood_ground(self, xy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The flood's view of the ground at points (P, 2) [m] (``FloodRouter.ground``): the
        terrain height and the base-flow level seen from it as the terrain shader draws them
        (:func:`~riverflow.scenes.tile_kinds.ground_and_level`: the resident height and water
        tiles, bilinear; a few µs a point), the scene's own pointwise functions where no
        tile is resident (the current scene's, after an edit too)."""
        from riverflow.scenes.tile_kinds import ground_and_level

        scene = self.scene
        xy = np.asarray(xy, np.float64).reshape(-1, 2)
        terrain = scene.terrain
        ground, level, missed = ground_and_level(self.tiles.cache, scene.quadtree,
                                                 terrain.tile_cells, terrain.max_level, xy)
        if len(missed):
            ground[missed] = terrain.height(xy[missed])
            level[missed] = scene.water.level(xy[missed])
        return ground, level

    @property
    def flood_time_s(self) -> float:
        """The flood's clock [s]: the world clock's ``now_s`` until the first hydrograph,
        then advanced by each frame's time × ``speed_factor`` (held while paused; as the
        spills') and by :meth:`advance_flood`."""
        router = self.flood
        return router.clock_s if router is not None else self.clock.now_s

    def advance_flood(self, seconds: float) -> None:
        """Run the flood ``seconds`` [s] ahead (hours in one call), nothing else moving
        (ValueError for a negative, NaN or infinite time)."""
        seconds = _seconds_ahead(seconds, "advance_flood")
        if self.flood is not None:
            self.flood.advance(seconds)

    def set_discharge(self, link, q_m3s: float) -> None:
        """A constant inflow ``q_m3s`` [m³/s] at the start of ``link`` from now on
        (:meth:`set_hydrograph` with one point)."""
        q_m3s = non_negative(q_m3s, "set_discharge: q_m3s")
        self.set_hydrograph(link, [self.flood_time_s], [q_m3s])

    # -- live edits (issue 25) ---------------------------------------------------------------

    def edit_network(self, builder_or_graph, *, wait: bool = True):
        """Replace the running network by a whole new one (a
        :class:`~riverflow.hydro.builder.RiverNetworkBuilder`, built here, or a
        :class:`~riverflow.hydro.graph.HydroGraph`) on the same terrain: the tiles near what
        changed are made again (:mod:`riverflow.engine.edits`), the others are kept. See
        :meth:`move_axis` for ``wait`` and what happens to the tiles and particles.

        Raises:
            GraphError: the network cannot carry a flow (the world keeps the old one).
        """
        from riverflow.engine import edits

        def make(scene):
            branches, islands, graph, _ = edits.branches_of_input(builder_or_graph)
            return branches, islands, graph
        return self._edit(make, wait)

    def set_width(self, link, widths_m, *, wait: bool = True):
        """Set the widths [m] of branch ``link`` (a name or an index of
        ``world.scene.branches``): one number, or one per point of its centre line. See
        :meth:`move_axis`."""
        return self._edit_branches("width", link, wait, widths=widths_m)

    def move_axis(self, link, points_m, widths_m=None, *, wait: bool = True):
        """Move the centre line of branch ``link`` (a name or an index of
        ``world.scene.branches``) to ``points_m`` (K, 2) [m], drawn downstream; an end at a
        junction stays where it is. ``widths_m``: one number or one per point (default: the
        old widths, carried along the arc length).

        The changed branches' banks and ψ are rebuilt (the builder, the water surface, the
        flow network); only the tiles within reach of the change (flow: the changed banks'
        search radius; terrain, water, ray-cast, hints, meshes: the carving's reach) are made
        again, in the background, their old versions standing in until then; the other tiles
        are kept. The particles keep flowing: one that finds itself on land once the new
        flow tiles are in leaves the water as at any shore (LEAVING, then OUTSIDE, recycled
        by the NEAR rule). A running flood is carried over (hydrographs by branch name, its
        waves by place along the river), and so are the spills (their mass, conserved), the
        lakes and the falls and rapids placed by hand (moved with their branch; one whose
        branch is removed is dropped: ``world.edits.last["dropped"]``).

        ``wait`` True: made now and in place when this returns. False: made in a background
        thread and swapped in at the start of the first :meth:`step` after it is ready (the
        frames meanwhile are not held up); returns a ``concurrent.futures.Future`` (its result:
        the names of the branches changed; its exception: what the builder raised, also in
        ``world.edit_errors``); a newer edit asked for while one is made replaces any other
        waiting.

        Raises:
            ValueError / TypeError: an unknown branch, points or widths not finite or of the
                wrong shape, an end moved off its junction;
            GraphError: the new network cannot carry a flow (banks crossing, a branch turning
                back on itself…). The world keeps the old network.
        """
        return self._edit_branches("axis", link, wait, points=points_m, widths=widths_m)

    def add_branch(self, points_m, widths_m, discharge_m2s: float | None = None, *,
                   name: str | None = None, wait: bool = True):
        """Add a branch: centre line ``points_m`` (K, 2) [m] drawn downstream, widths [m],
        ``discharge_m2s`` (needed for a source; an end on another branch's end meets it
        there). See :meth:`move_axis`."""
        return self._edit_branches("add", None, wait, points=points_m, widths=widths_m,
                                   discharge_m2s=discharge_m2s, name=name)

    def remove_branch(self, link, *, wait: bool = True):
        """Remove branch ``link`` (a name or an index of ``world.scene.branches``). See
        :meth:`move_axis`."""
        return self._edit_branches("remove", link, wait)

    @property
    def edit_errors(self) -> list[str]:
        """What background edits (``wait=False``) raised (the world kept its network)."""
        return [] if self._edits is None else self._edits.errors

    @property
    def edits(self):
        """The :class:`~riverflow.engine.edits.LiveEdits` state (counters, the last edit), or
        None before the first edit."""
        return self._edits

    def _edit_branches(self, op, link, wait: bool, **args):
        from riverflow.engine import edits

        edits.edited_branches(self.scene, op, link, **args)    # bad arguments raise here, now

        def make(scene):
            return edits.edited_branches(scene, op, link, **args), None, None
        return self._edit(make, wait)

    def _edit(self, make, wait: bool):
        from concurrent.futures import Future

        from riverflow.engine.edits import LiveEdits

        if self._edits is None:
            self._edits = LiveEdits()
        live = self._edits
        if wait:
            while live.busy:                      # the background ones first, in order
                self._land_edit(block=True)
            plan = self._plan(make, self.scene, self.field)
            return self._apply_edit(*plan)
        future = Future()
        if live.queued is not None:               # a newer edit replaces one still waiting
            live.queued[1].cancel()
        live.queued = (make, future)
        self._land_edit()
        return future

    def _plan(self, make, scene, field):
        """The new scene, field and producers, and what changed (any thread)."""
        from riverflow.engine import edits
        from riverflow.hydro.tile_producer import FlowProducer

        import threading

        scheduler = self.tiles.scheduler
        background = threading.current_thread() is not threading.main_thread()

        def between_frames():           # each piece starts in a frame's idle time
            if background:
                scheduler.wait_idle()
        between_frames()                # (started from a frame: its first piece after it)
        edits.fill_discharges(scene, field)
        branches, islands, graph = make(scene)
        between_frames()
        dropped: list[str] = []
        new_scene, graph = edits.edited_scene(scene, branches, islands, graph, dropped)
        between_frames()
        new_field = edits.edited_field(field, graph)
        between_frames()
        plan = edits.plan_edit(scene, field, new_scene, new_field)
        plan.dropped = dropped
        between_frames()
        pool = field.tiles.pool                # the resident flow tiles, renumbered here
        slots = np.flatnonzero(pool.slot_code >= 0)
        codes = pool.slot_code[slots].copy()
        renumber, lists = edits.renumbered_segments(pool.arrays["cell_segments"], slots,
                                                    plan.segment_map)
        plan.renumbered = (renumber, pool.slot_code[renumber].copy(), lists)
        plan.renumbered_all = (slots, codes)
        between_frames()
        # which resident tiles the edit makes again, worked out here for those resident now
        # (the swap works out only those installed since)
        from riverflow.components.flow_tiles import FLOW_KIND
        from riverflow.scenes.tile_kinds import TERRAIN_KINDS

        plan.marked_ahead[FLOW_KIND] = edits.marked_ahead(plan, scene, FLOW_KIND, codes,
                                                          field.tiles.n_cells)
        for kind in TERRAIN_KINDS:
            between_frames()
            plan.marked_ahead[kind] = edits.marked_ahead(
                plan, scene, kind, self.tiles.cache.pools[kind].codes(),
                scene.terrain.tile_cells)
        between_frames()
        if self.flood is not None:              # the flood's cells on the new network
            from riverflow.hydro.spill_network import build_spill_network

            plan.cell_network = build_spill_network(
                new_scene.branches, [b.discharge_m2s for b in new_scene.branches])
            between_frames()
            if self.flood.textures_made:
                # its level's textures, made here as the old router had them: not in the
                # frame that first reads the raised level (draws it, or lifts the particles
                # onto it: ~0.2 s in a frame); from the old router's, where the network is
                # the same (only the texels near the changed links are made)
                from riverflow.hydro.flood import FloodRouter

                plan.flood_router = FloodRouter(plan.cell_network)
                plan.flood_router.level_textures(self.flood)
                between_frames()
        solver = self.spill_solver
        if solver is not None:                   # the spills' cells on the new network
            from riverflow.hydro.spill_network import build_spill_network

            dispersion = solver.network.dispersion
            same = plan.cell_network is not None and plan.cell_network.dispersion == dispersion
            plan.spill_network = plan.cell_network if same else build_spill_network(
                new_scene.branches, [b.discharge_m2s for b in new_scene.branches], dispersion)
            between_frames()
        producers = [*terrain_producers(new_scene), FlowProducer(new_field)]
        between_frames()
        plan.flow_ahead = self._flow_tiles_ahead(new_field, producers[-1])
        between_frames()
        # the source under the drawn height tiles the edit makes again, kept here (the tile
        # process's own go with it): the next edits of a drag read them back
        from riverflow.scenes.tile_kinds import keep_sources
        from riverflow.tiles.table import codes as tile_codes

        cut = tile_codes(self.resource(TerrainView).cut)
        keep_sources(new_scene, cut[edits.tiles_meeting(cut, new_scene.quadtree,
                                                        plan.terrain_boxes,
                                                        new_scene.terrain.tile_cells)],
                     between_frames)
        # the tile processes: forked here with the new producers (the frames go on meanwhile)
        processes = self.tiles.scheduler.fork_for(producers, in_gap=background)
        return plan, producers, processes

    def _flow_tiles_ahead(self, field: FlowField, producer) -> dict:
        """The flow tiles the latest frame's view asks for of ``field`` (an edit's new flow)
        that are not resident (the edit made them wet), made now with ``producer``
        (:attr:`~riverflow.engine.edits.EditPlan.flow_ahead`)."""
        from riverflow.components.flow_tiles import flow_view_tiles
        from riverflow.kernels.view_tiles import MAX_VIEW_TILES
        from riverflow.tiles.table import code_key, codes as tile_codes

        view, terrain = self.resource(FrameView), self.resource(TerrainView)
        if not (view.width_px > 0 and view.height_px > 0):
            return {}
        keys = np.zeros((MAX_VIEW_TILES, 3), np.int32)
        n = flow_view_tiles(view, terrain, field, self.config.flow_tile_px, keys)
        wanted = tile_codes(keys[:n])
        missing = wanted[field.tiles.pool.table.find_many(wanted) < 0]
        return {code: producer.produce(code_key(code), {}) for code in missing.tolist()}

    def _land_edit(self, block: bool = False) -> None:
        """Swap in a background edit that is ready (or, ``block``, wait for it), then start
        the one waiting."""
        live = self._edits
        if live.thread is not None:
            if block:
                live.join()
            if live.running():
                return
            live.thread = None
            result, future = live.result, live.future
            live.result = live.future = None
            if isinstance(result, BaseException):
                live.errors.append(f"{type(result).__name__}: {result}")
                future.set_exception(result)
            elif isinstance(result, _Swapped):  # swapped in by the edits' thread already
                future.set_result(result.changed)
            else:
                try:
                    future.set_result(self._apply_edit(*result))
                except BaseException as exc:    # the swap itself failed: say so, go on
                    live.errors.append(f"{type(exc).__name__}: {exc}")
                    future.set_exception(exc)
        if live.queued is not None and live.thread is None:
            make, future = live.queued
            live.queued = None
            scene, field = self.scene, self.field

            def run():
                try:
                    live.result = live.planned(lambda: self._plan(make, scene, field))
                except BaseException as exc:
                    live.result = exc.with_traceback(None)
                    return
                self._swap_between_frames(live)
            live.future = future
            live.start(run)

    def _swap_between_frames(self, live) -> None:
        """The edits' thread: swap the edit just made (``live.result``) in between the host's
        frames, not in the next frame (~5–10 ms of bookkeeping: over twice a frame's): once
        a frame's step (a drawn world: its draw) has ended and no call of the world has
        begun for SWAP_QUIET_S, if the world's lock is free and still no frame began; else
        the next frame swaps it in at its start, as before (a host that steps back to back,
        a world that is not drawn within SWAP_WAIT_S)."""
        if not self._quiet_lock():
            return
        try:
            plan = live.result
            # the frame after the fork's misses, before the swap writes its own pages
            self.tiles.scheduler.learn_written()
            with self.tiles.scheduler.frame_work():    # the tile process on its core stopped
                try:
                    live.result = _Swapped(self._apply_edit(*plan, between_frames=True))
                except BaseException as exc:   # the swap itself failed: said so by the frame
                    live.result = exc.with_traceback(None)
        finally:
            self._lock.release()

    def _quiet_lock(self, after: int = -1) -> bool:
        """The edits' thread: hold the world's lock in a gap between the host's frames and
        return True: a gap that began (a frame's step ended, a drawn world's draw) at most
        GAP_FRESH_S ago, after frame number ``after``, with no call of the world begun for
        SWAP_QUIET_S; a frame that began meanwhile is waited for and the next gap taken;
        False (without the lock) if none came within SWAP_WAIT_S."""
        end = time.perf_counter() + SWAP_WAIT_S
        while not self._closed_world:
            if not self._between_frames.wait(max(end - time.perf_counter(), 0.0)):
                return False
            begun = self._frames_begun
            fresh = time.perf_counter() - self._frame_ended_at <= GAP_FRESH_S
            time.sleep(SWAP_QUIET_S)          # (a draw right after its step, a blit after it)
            if fresh and begun > after and self._frames_begun == begun \
                    and self._lock.acquire(blocking=False):
                if self._frames_begun == begun and self._between_frames.is_set() \
                        and not self._closed_world:
                    return True
                self._lock.release()
            if time.perf_counter() > end:
                return False
        return False

    def _queue_stale_between_frames(self) -> None:
        """The edits' thread, after an edit it swapped in: the view's stale tiles queued
        between the frames, QUEUE_STALE_BATCH at a time (:meth:`TileScheduler.queue_stale`),
        until none is left (or the host gives no quiet time: the frames queue them then)."""
        after = self._frames_begun
        scheduler = self.tiles.scheduler
        while self._quiet_lock(after):          # a gap of its own for each batch
            after = self._frames_begun
            try:
                with scheduler.frame_work():
                    left = scheduler.queue_stale(QUEUE_STALE_BATCH)
            finally:
                self._lock.release()
            scheduler.learn_written()           # (a frame ran since the swap: its pages)
            if not left:
                return

    def _apply_edit(self, plan, producers, processes=None, *, between_frames: bool = False
                    ) -> list[str]:
        """Swap an edit in (at a frame's start, or ``between_frames`` by the edits' thread
        holding the world's lock): module docstring of :mod:`riverflow.engine.edits`, step 3.
        Returns the changed branches' names."""
        from riverflow.components.flow_tiles import FLOW_KIND
        from riverflow.engine.edits import marked_at_swap, renumbered_segments
        from riverflow.scenes.tile_kinds import TERRAIN_KINDS, WATER, WATER_MESH
        from riverflow.tiles.table import codes as tile_codes

        t0 = time.perf_counter()
        scheduler = self.tiles.scheduler
        cache = self.tiles.cache
        q = self.scene.quadtree
        old = self.field
        stale: dict[str, np.ndarray] = {}
        pool = old.tiles.pool
        slots = np.flatnonzero(pool.slot_code >= 0)
        codes = pool.slot_code[slots].copy()
        if len(slots):
            # the tiles' bank lists, renumbered to the new network (an untouched segment is
            # the same segment, one gone the nearest new one: its tiles are near the change)
            # made in the edit's thread for the tiles resident then (a slot holding the same
            # tile now holds the same lists: a tile of the old network is always the same);
            # the tiles installed since are renumbered here
            segments = pool.arrays["cell_segments"]
            done = np.zeros(0, np.int64)
            if plan.renumbered is not None:
                (ready, ready_codes, lists), (seen, seen_codes) = (plan.renumbered,
                                                                   plan.renumbered_all)
                same = pool.slot_code[ready] == ready_codes
                if same.all():       # (the usual case: no copy of the lists to copy them)
                    segments[ready] = lists
                else:
                    segments[ready[same]] = lists[same]
                done = seen[pool.slot_code[seen] == seen_codes]
            seen_now = np.zeros(len(pool.slot_code), bool)
            seen_now[done] = True
            rest = slots[~seen_now[slots]]
            rest, lists = renumbered_segments(segments, rest, plan.segment_map)
            segments[rest] = lists
        # the tiles the edit makes again, each with its distance to the change (worked out in
        # the edit's thread for the tiles resident then)
        rank: dict[str, np.ndarray] = {}
        n = self.scene.terrain.tile_cells
        for kind, kcodes, cells in [(FLOW_KIND, codes, old.tiles.n_cells)] + [
                (kind, cache.pools[kind].codes(), n) for kind in TERRAIN_KINDS]:
            stale[kind], rank[kind] = marked_at_swap(plan, self.scene, kind, kcodes, cells)
        old_processes = scheduler.replace_producers(producers, processes, close_old=False)
        if old_processes:               # closed in the edits' thread, not in this frame
            from riverflow.tiles.scheduler import close_all

            self._edits.run_later(lambda: close_all(old_processes, 5.0))
        # the river's kinds first, each kind's tiles nearest the change first; of the terrain
        # kinds, the leaves of the view's cut (drawn) before their ancestors (drawn only
        # where a leaf is missing: the leaves stand in resident)
        cut = tile_codes(self.resource(TerrainView).cut)
        later = {kind: stale[kind][~np.isin(stale[kind], cut)] for kind in TERRAIN_KINDS}
        scheduler.invalidate(stale, first=(FLOW_KIND, WATER, WATER_MESH), rank=rank,
                             later=later)
        flow_pool = cache.pools[FLOW_KIND]
        for code, tile in plan.flow_ahead.items():     # the view's newly wet flow tiles
            if code not in flow_pool:
                scheduler.install(FLOW_KIND, code, tile)
        if between_frames:      # the view's stale tiles queued by the edits' thread
            self._edits.run_later(self._queue_stale_between_frames)
        self.scene = plan.scene
        self.field = plan.field
        node = self._river_node          # (no esper world switch: any thread may swap)
        node.graph, node.field = plan.scene.graph, plan.field
        terrain = self.resource(TerrainView)
        terrain.z_min = min(terrain.z_min, float(plan.scene.z_range_m[0]))
        terrain.z_max = max(terrain.z_max, float(plan.scene.z_range_m[1]))
        router = self.flood
        if router is not None:
            self._carry_flood(router, plan.cell_network, plan.flood_router)
        solver = self.spill_solver
        if solver is not None:      # the spills' mass carried to the new cells (conserved)
            self.resources[_SpillSolverKey] = solver.carried_to(
                plan.spill_network or self._cell_network(solver.network.dispersion))
        live = self._edits
        live.applied += 1
        live.last = {"changed": list(plan.changed), "dropped": list(plan.dropped),
                     "marked": {k: len(v) for k, v in stale.items()},
                     "applied_s": time.perf_counter(), "between_frames": between_frames,
                     "swap_ms": (time.perf_counter() - t0) * 1e3}
        return list(plan.changed)

    def _carry_flood(self, old, network=None, prepared=None) -> None:
        """A flood router on the edited network (``network``: its cells, made in the edit's
        thread; ``prepared``: a router on them made there too, its drawn level's textures
        made), with the old one's hydrographs of the branches still there (by name), its
        clock and its state: each new cell's cross-section ratio and wet-looking rise are
        the old cell's at the same place along the river
        (:func:`~riverflow.hydro.spill_network.cell_map`)."""
        from riverflow.hydro.flood import FloodRouter
        from riverflow.hydro.spill_network import cell_map

        if prepared is not None:
            router = prepared
            router.time_s = router.clock_s = old.clock_s
        else:
            router = FloodRouter(network or self._cell_network(), old.clock_s)
        names = old.network.names
        for b, (t, q) in old.hydrographs.items():
            if names[b] in router.network.names:
                router.set_hydrograph(names[b], t, q)
        source = cell_map(router.network, old.network)     # each new cell's old cell
        router.a[:] = old.a[source]
        router.wet_rise_m[:] = old.wet_rise_m[source]
        router.time_s = old.time_s
        router.dt_s = min(router.dt_s, router._step_for(1.0))     # a's highest counts
        router.ground = old.ground
        self.resources[_FloodRouterKey] = router
        self.field.discharge_scale = router.scale_velocity

    def water_level(self, xy_m) -> np.ndarray:
        """(N,) water level [m] of the nearest river point to each (N, 2) [m]: the scene's
        base-flow level plus the flood's rise there."""
        xy = as_points(xy_m, "water_level: xy_m")
        level = np.asarray(self.scene.water.level(xy), np.float64)
        router = self.flood
        return level + router.level_rise(xy) if router is not None else level

    def add_spill(self, xy_m, mass_kg: float, duration_s: float = 0.0, *, name: str | None = None,
                  decay_per_s: float = 0.0) -> int:
        """Release ``mass_kg`` [kg] of a tracer at ``xy_m`` (2,) [m], at once (``duration_s``
        0) or at a constant rate over ``duration_s`` [s], from the spills' next step on; it
        decays at ``decay_per_s`` [1/s] (first order). Carried by the "spill" system, by
        :meth:`advance_spills`; read with :meth:`concentration` and :meth:`spill`. Returns the
        spill's entity (a :class:`~riverflow.components.spill.Spill` component).

        A point on land is moved to the nearest water if that is within 50 m
        (``world.spill(entity).moved_m`` says how far).

        Raises:
            ValueError: a point on land farther than 50 m from water, not two finite numbers;
                a negative, NaN or infinite mass, duration or decay.
        """
        from riverflow.components.spill import SPILL_COLOURS, Spill

        values = {"mass_kg": mass_kg, "duration_s": duration_s, "decay_per_s": decay_per_s}
        for key, v in values.items():
            try:
                values[key] = non_negative(v, f"add_spill: {key}")
            except TypeError as exc:
                raise ValueError(str(exc)) from None
        mass_kg, duration_s, decay_per_s = values.values()
        if not mass_kg > 0:
            raise ValueError(f"add_spill: mass_kg must be > 0, got {mass_kg!r}")
        solver = self.spill_solver or self.configure_spills()
        source = self._spill_source(xy_m, solver.network)
        row = solver.n_spills
        name = str(name) if name is not None else f"spill {row}"
        solver.add(source, name, float(mass_kg), float(duration_s), float(decay_per_s))
        with self.active():
            return esper.create_entity(Spill(row, name, float(mass_kg), float(duration_s),
                                             float(decay_per_s),
                                             SPILL_COLOURS[row % len(SPILL_COLOURS)]))

    def _spill_source(self, xy_m, network):
        from riverflow.hydro.spill_network import section_psi_range
        from riverflow.hydro.spills import SpillSource

        try:
            xy = as_points(xy_m, "add_spill: xy_m")
        except TypeError as exc:
            raise ValueError(str(exc)) from None
        if len(xy) != 1:
            raise ValueError(f"add_spill: xy_m must be two finite numbers [m], got {xy_m!r:.80}")
        xy = xy[0]
        psi = self.field.potential(xy[None, :])[0]
        moved = 0.0
        if not np.isfinite(psi):
            import shapely
            from shapely.ops import nearest_points

            water = self.scene.water.polygon
            shore = np.array(nearest_points(water, shapely.Point(*xy))[0].coords[0])
            moved = float(np.hypot(*(shore - xy)))
            if moved > SPILL_SNAP_M:
                raise ValueError(f"add_spill: ({xy[0]:.1f}, {xy[1]:.1f}) m is on land, "
                                 f"{moved:.1f} m from the nearest water (at most "
                                 f"{SPILL_SNAP_M:g} m is moved to)")
            direction = (shore - xy) / max(moved, 1e-9)
            for step in (0.5, 1.0, 2.0, 4.0, 8.0):       # just inside the shore
                p = shore + direction * step
                psi = self.field.potential(p[None, :])[0]
                if np.isfinite(psi):
                    break
            if not np.isfinite(psi):
                raise ValueError(f"add_spill: ({xy[0]:.1f}, {xy[1]:.1f}) m is on land and no "
                                 "water was found at the nearest shore")
            xy = p
            moved = float(np.hypot(*(xy - np.asarray(xy_m, np.float64))))
        if network.link_psi_m2s is None:     # (for the mixing below junctions)
            network.link_psi_m2s = np.array([
                section_psi_range(self.field.potential, line, 0.5 * length,
                                  float(np.median(network.cell_width_m[network.cell_link == k])))
                for k, (line, length) in enumerate(zip(network.lines, network.link_length_m))])
        link, s, _ = network.locate(xy[None, :])
        link, s = int(link[0]), float(s[0])
        lo, hi = section_psi_range(self.field.potential, network.lines[link], s,
                                   float(np.interp(s, network.cell_s_m[network.cell_link == link],
                                                   network.cell_width_m[network.cell_link == link])))
        cell = int(network.cell_of(np.array([link]), np.array([s]))[0])
        eta = float(np.clip((psi - lo) / (hi - lo), 0.0, 1.0)) if hi > lo else 0.5
        return SpillSource(xy.copy(), moved, link, s, cell, eta, lo, hi)

    def advance_spills(self, seconds: float) -> None:
        """Run the spills ``seconds`` [s] ahead (hours in one call), nothing else moving
        (ValueError for a negative, NaN or infinite time)."""
        seconds = _seconds_ahead(seconds, "advance_spills")
        solver = self.spill_solver
        if solver is not None:
            solver.advance(seconds)

    def concentration(self, xy_m, *, per_spill: bool = False) -> np.ndarray:
        """Tracer concentration [kg/m³] at points (N, 2) [m]: (N,) summed over the spills
        (0 on land and with no spill), or (S, N) per spill in order of release."""
        xy = as_points(xy_m, "concentration: xy_m", finite=False)
        solver = self.spill_solver
        if solver is None or not solver.n_spills:
            n = solver.n_spills if (per_spill and solver is not None) else 0
            return np.zeros((n, len(xy))) if per_spill else np.zeros(len(xy))
        return solver.concentration(xy, self.field.potential(xy), per_spill)

    def spill(self, entity: int):
        """A :class:`~riverflow.hydro.spills.SpillReport` of a spill entity: mass released, in
        the water, out per outlet, decayed; its front and tail along the river; its peak."""
        from riverflow.components.spill import Spill

        component = self._component_of(entity, Spill, "spill", "a spill")
        return self.spill_solver.report(component.row)

    @property
    def display(self) -> DisplaySettings:
        """What is drawn: mode, overlays, shading knobs (mutable)."""
        return self.resource(DisplaySettings)

    def draw(self, view=None, projection=None, *, framebuffer: int | None = None,
             sky: bool = True) -> None:
        """Run the draw systems: draw the current frame into the world's offscreen framebuffer
        (CPU time in ``timings_ms["draw"]``). Drawn before the world was ever stepped or
        loaded, it makes the view's tiles and particles first (:meth:`load_view`): never a
        frame of fog. See :meth:`render` and :meth:`blit_to_window`.

        ``view``, ``projection``: the host's camera, each 16 numbers in OpenGL's column-major
        order (world → eye, eye → clip: :meth:`Camera.set_matrices`, which says what they may
        be); the camera then stays so (the next :meth:`step` simulates with it).

        A world made with ``gl="current"`` (a host's own context) draws with the context
        current now (:class:`~riverflow.engine.gl.ContextError` if there is none, it is
        another thread's, or not the one the world was made with) into the host's bound draw
        framebuffer (or ``framebuffer``, a framebuffer object name) at the host's viewport
        (the camera's viewport follows it), each pixel depth-tested (``<=``) against the
        host's depth buffer and written to it; ``sky`` false leaves the pixels of sky to the
        host. Every piece of GL state the draw touches is put back as it was
        (:class:`~riverflow.engine.gl.HostState`); ``timings_ms["host_frame"]`` is the whole
        draw's CPU time."""
        if not self.gl:
            raise RuntimeError("drawing needs a world made with gl=True")
        if not self.host and framebuffer is not None:
            raise ValueError("draw(framebuffer=...) is for a world made with gl=\"current\"")
        with self._frame(drawn=True):
            self._draw(view, projection, framebuffer, sky)

    def _draw(self, view, projection, framebuffer, sky: bool) -> None:
        if not self.host:
            if view is not None or projection is not None:
                self.camera.set_matrices(view, projection)
            with self._offscreen():
                self._draw_systems()
            return
        from riverflow.engine import gl as gl_module

        t0 = time.perf_counter_ns()
        with gl_module.host_frame(self.context) as host:
            x, y, w, h = host.viewport
            if (w, h) != self.camera.size_px:
                self.camera.set_viewport(w, h)
            if view is not None or projection is not None:
                self.camera.set_matrices(view, projection)
            if self.camera.is_empty:
                return
            self._draw_systems()
            target = host.framebuffer if framebuffer is None else int(framebuffer)
            self._drawer().composite(target, (x, y, w, h), bool(sky))
        self.timings_ms["host_frame"] = (time.perf_counter_ns() - t0) * 1e-6

    def _draw_systems(self) -> None:
        if self.camera.is_empty:
            return
        if self.clock.frame == 0 and not self._view_loaded:
            self.load_view()       # drawn before any step: the view's tiles first, not fog
        with self.active():
            for system in self.systems:
                if system.phase != "draw":
                    continue
                t0 = time.perf_counter_ns()
                system.process(self, 0.0)
                self.timings_ms[system.name] = (time.perf_counter_ns() - t0) * 1e-6

    def _drawer(self):
        for system in self.systems:
            if hasattr(system, "read_rgba8"):
                return system
        raise RuntimeError("this world has no draw system")

    @property
    def particles(self) -> LiveParticles:
        """A copy of the live particles (screen_px, world_m, intensity, status, …)."""
        p = self.pool
        live = np.flatnonzero(p.alive)
        c = self.config
        now = self.clock.now_s
        fading = now - p.birth_s[live] >= c.fade_in_s + c.active_s
        return LiveParticles(p.ids[live].copy(), p.screen_px[live].copy(),
                             p.world_m[live].copy(), p.intensity[live].copy(),
                             p.status[live].copy(), p.velocity_mps[live].copy(), fading,
                             p.has_world[live].copy(),
                             np.where(p.foam_id[live] == p.ids[live], p.foam[live], 0.0)
                             .astype(np.float32))

    def render(self) -> np.ndarray:
        """Draw the current frame and return it as (H, W, 4) uint8 RGBA, row 0 at the top
        (needs ``gl=True``): the numpy hand-off to a host that cannot share OpenGL with
        riverflow (Panda3D: ``demos/panda3d_host.py``). A ``gl="current"`` world draws it
        offscreen in the host's context, not into the host's framebuffer, and leaves the
        host's state as it was."""
        if not self.gl:
            raise RuntimeError("render() needs a world made with gl=True")
        if self.camera.is_empty:                    # a minimised window: nothing to draw
            w, h = self.camera.size_px
            return np.zeros((h, w, 4), np.uint8)
        with self._frame(drawn=True), self._offscreen():
            self._draw_systems()
            return self._drawer().read_rgba8()

    def render_to_texture(self) -> int:
        """Draw the current frame offscreen and return the GL name of its RGBA8 colour
        texture (``GL_TEXTURE_2D``, the camera's viewport size, row 0 at the bottom) in the
        world's context: a host whose context shares objects with it (a pyglet window, a
        host's context with ``gl="current"``, a context made sharing with it) samples it
        as its own texture. The name stays valid until the viewport changes or the world
        closes; its contents until the next draw. A ``gl="current"`` world leaves the
        host's state as it was."""
        if not self.gl:
            raise RuntimeError("render_to_texture() needs a world made with gl=True")
        with self._frame(drawn=True), self._offscreen():
            self._draw_systems()
            return self._drawer().colour_texture()

    @contextlib.contextmanager
    def _offscreen(self):
        """Offscreen drawing: a host world's in the host's context, its state put back; a
        ``gl=True`` world's in its own context, the context the thread had current before
        (a host's that shares nothing with riverflow: Panda3D's) current again after."""
        from riverflow.engine import gl as gl_module

        if not self.host:
            with gl_module.keeping_native_current():
                yield
            return
        with gl_module.host_frame(self.context):
            yield

    def blit_to_window(self, width_px: int | None = None, height_px: int | None = None) -> None:
        """Copy the last drawn frame onto the current window's framebuffer (a host game calls
        this in its ``on_draw`` after :meth:`draw`), scaled to ``width_px`` × ``height_px``
        (default: the camera's viewport)."""
        w, h = self.camera.size_px
        if not self.host and self.context is not None:
            from riverflow.engine import gl as gl_module

            gl_module.check_blit_target(self.context)
        with self._frame(drawn=True):
            self._drawer().blit_to_window(width_px or w, height_px or h)

    def close(self) -> None:
        """Stop the tile worker thread, release GPU objects (while their OpenGL context lives)
        and delete the esper world. Idempotent; a world dropped without it does the same
        when it is collected."""
        self._closed_world = True
        if self._edits is not None:
            self._edits.stop()
        self._finalizer()

    def __enter__(self) -> RiverWorld:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


class _Swapped:
    """An edit the edits' thread swapped in (:meth:`RiverWorld._swap_between_frames`): the
    changed branches' names, for its future."""

    __slots__ = ("changed",)

    def __init__(self, changed: list[str]) -> None:
        self.changed = changed


SWAP_WAIT_S = 0.1
"""The edits' thread waits this long [s] for a gap between the host's frames before leaving
an edit it made to the next frame to swap in."""
SWAP_QUIET_S = 0.001
"""…and swaps it in only if no call of the world began this long [s] after the frame
ended."""
GAP_FRESH_S = 0.003
"""…in a gap that began at most this long [s] before (the rest of it may be too short)."""
QUEUE_STALE_BATCH = 30
"""Stale tiles the edits' thread queues in a gap between two frames after an edit's swap
(~40 µs each)."""

_SERIALIZED = ("load_view", "close", "add_prop", "pose", "add_boat", "wake", "boat",
               "set_rain", "configure_spills", "set_hydrograph", "advance_flood",
               "set_discharge", "edit_network", "set_width", "move_axis", "add_branch",
               "remove_branch", "water_level", "add_spill", "advance_spills", "concentration",
               "spill", "component", "insert")
"""RiverWorld's calls that hold its lock (a frame's step and draws hold it too): none runs
while the edits' thread swaps an edit in."""


def _serialized(method):
    @functools.wraps(method)
    def holding_lock(self, *args, **kwargs):
        lock = getattr(self, "_lock", None)      # (none before __init__ made it)
        if lock is None:
            return method(self, *args, **kwargs)
        with lock:
            return method(self, *args, **kwargs)
    return holding_lock


for _name in _SERIALIZED:
    setattr(RiverWorld, _name, _serialized(getattr(RiverWorld, _name)))
del _name


class _Owned:
    """What a world owns outside itself, released by :func:`_release`. Holds no reference to
    the world (the world's finalizer holds this), so a dropped world is collected."""

    __slots__ = ("name", "scheduler", "systems")

    def __init__(self, name: str, scheduler: TileScheduler) -> None:
        self.name = name
        self.scheduler = scheduler
        self.systems: list[System] = []


def _release(owned: _Owned) -> None:
    """Close the systems (GPU objects), stop the tile worker, delete the esper world (from
    esper's module-level registry, which otherwise keeps every entity, pool and tile cache
    of the world alive). Runs once: from :meth:`RiverWorld.close` or the world's finalizer."""
    try:
        for system in owned.systems:
            system.close()
    finally:
        owned.scheduler.close()
        _FrozenHeap.full_due = True          # its garbage may be frozen: the next load looks
        name = owned.name
        # the active context cannot be deleted (only if the host switched to it by hand)
        if esper.current_world != name and name in esper.list_worlds():
            esper.delete_world(name)


class _FrozenHeap:
    """Whether the next :func:`_collect_and_freeze` must be a full collection."""

    full_due = True
    frozen = 0                  # objects frozen (``gc.get_freeze_count()`` walks them all)


def _collect_and_freeze() -> None:
    """The end of a loading screen (``RiverConfig.freeze_gc_on_load``): collect, then freeze
    what survives, so later collections leave it alone. A full collection (unfreezing first,
    so garbage an earlier load froze can go) runs when a world was released since the last
    one, or when what is new since the last freeze is over a quarter of what is frozen
    (CPython's own rule for its full collections): a new level. Otherwise only what is new is
    collected and frozen, so loading view after view of one world (teleports, scripted views)
    costs what those views made, not a scan of the whole heap (78 ms each in a test process)."""
    heap = _FrozenHeap
    if not heap.full_due:
        gc.collect()                               # frozen objects are not scanned
        new = len(gc.get_objects())
        heap.full_due = new > 0.25 * heap.frozen
    if heap.full_due:
        gc.unfreeze()
        gc.collect()
        new = len(gc.get_objects())
        heap.frozen = 0
    gc.freeze()
    heap.frozen += new
    heap.full_due = False


def _add_wave_tiles(seed: int) -> None:
    """The three wave-tile entities (the display settings pick one to draw with)."""
    from riverflow.components.waves import (animated_wave_tile, default_static_wave_tile,
                                            perlin_wave_tile)

    esper.create_entity(default_static_wave_tile())
    esper.create_entity(perlin_wave_tile())
    esper.create_entity(animated_wave_tile(seed=seed))
