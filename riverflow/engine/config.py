"""RiverConfig: everything a designer may tune, with units in every name (one frozen dataclass).

Proland's parameters (reference §2.2, §3.3, §3.6, §4) under clear names; defaults are the
river1 example's unless a field's docstring says why another value is better here.
Variants: ``dataclasses.replace(config, radius_px=5.0)``; environment overrides:
``RiverConfig.from_env()`` reads ``RIVERFLOW_<FIELD>`` (e.g. ``RIVERFLOW_RADIUS_PX=5``).
"""
from __future__ import annotations

import dataclasses
import math
import numbers
import os
from dataclasses import dataclass

from riverflow.hydro.falls import FALL_MIN_DROP_M, RAPIDS_MIN_SLOPE


@dataclass(frozen=True, slots=True)
class RiverConfig:
    """Tunable parameters of a river world. Units are part of each name."""

    capacity: int = 16384
    """Particle pool size (Proland ParticleStorage capacity; river1: 5000). A full 1920×1080
    screen at r = 5 px needs about 0.87·W·H/(2r)² ≈ 18,000; at r = 10 px about 4,500."""

    radius_px: float = 10.0
    """Poisson-disk radius r of the screen-space particles [px] (Proland ScreenParticleLayer
    radius; river1: 15). New particles are placed 2r from their neighbours."""

    cull_radius_factor: float = 1.9
    """A particle closer than this × r to an accepted one fades out (Proland: sqrt(3.84) =
    1.96, with new particles spawned 2r from all others)."""

    spawn_gap_factor: float = 1.92
    """New particles are placed 2r from a neighbour but need only this × r from all the others
    (Proland: 2). A little under 2 keeps the density of a moving view nearer the Poisson disk's
    0.87 per (2r)²: perspective stretches the particles apart between refills. Must not be
    below ``cull_radius_factor``, or new particles would be culled at once."""

    grid_cell_factor: float = 4.0
    """Cell size of the screen neighbour grid, in units of r (Proland ParticleGrid: 4r)."""

    offscreen_kill_factor: float = 2.0
    """Particles outside the viewport fade out; beyond this × r outside it they die at once."""

    fade_in_s: float = 2.0
    """Seconds a new particle takes to reach full intensity (river1: 2 s)."""

    active_s: float = 30.0
    """Seconds at full intensity before fading out (river1: 30 s)."""

    fade_out_s: float = 2.0
    """Seconds a particle takes to vanish (river1: 2 s)."""

    speed_factor: float = 1.0
    """Multiplier on the flow velocity when advecting (Proland speedFactor; river1 uses 5 with
    its half-curl velocity: ours is the true curl, so 1 moves particles at the real speed)."""

    slip: float = 1.0
    """Exponent p of the bank weights d^-p (Proland slip; river1: 1.3). 1 gives plug flow
    between parallel banks."""

    search_radius_factor: float = 5.0
    """Search radius R = factor × the widest river of a network (Proland searchRadiusFactor;
    its code default 1 makes every profile a peaked no-slip one, reference §2.5)."""

    potential_delta_m: float | None = None
    """ψ-lattice spacing of the finest flow tiles [m]; None: the narrowest river / 24."""

    tile_cache_mb: float = 256.0
    """Memory budget of the tile cache [MiB], shared by every kind of tile (flow, terrain,
    water, meshes, particle tables): least recently used tiles are evicted beyond it (the
    tiles the current view uses always stay)."""

    flow_tile_px: float = 2.0
    """Wanted lattice spacing of the flow tile under a point, in screen pixels: tiles far away
    are coarser (quadtree level chosen per tile from its distance to the camera)."""

    terrain_tile_px: float = 6.0
    """Wanted terrain node spacing in screen pixels: the terrain tiles (and the particles'
    surface tables) are chosen per tile from its distance to the camera, coarser far away."""

    freeze_gc_on_load: bool = True
    """:meth:`RiverWorld.load_view` ends with a collection and ``gc.freeze()``: what is alive
    once a level is loaded (the world's tiles and entities, numba's and the host's objects) is
    left out of later garbage collections, so a full collection over them cannot pause a frame
    (48–66 ms measured in a 100 km flight). The collection is a full one (unfreezing first, so
    the previous level's garbage goes) on the first load after a world was released or when
    much is new; a load of another view of the same level collects only what is new since the
    last. False: the host runs the collector as it likes."""

    tile_production: str = "background"
    """"background": tiles of every kind are made by a worker thread, never stalling a frame
    (until a tile is ready its coarser parent serves); "blocking": made in the frame that
    needs them (deterministic: scripted runs and tests)."""

    deterministic: bool = True
    """Every frame makes the leaf tiles it reads that the worker has not finished yet (in its
    own thread, before any system reads them), so a run's result depends only on the scene,
    seed, camera script and frame times, never on the machine's load or when a tile arrived: scripted and
    headless runs, tests, replays. False: a frame never waits; a tile not made yet is stood in
    for by its coarser parent, so a fast flight never hitches but what particles do near such
    a tile depends on timing (an interactive game that prefers smoothness; the windowed demo
    uses it)."""

    tile_worker: str = "process"
    """Where "background" tiles are made: "process" (a forked process, Linux; elsewhere the
    thread): the producers' Python and numpy never hold the frame's interpreter lock, so a
    fast flight has no lock stalls; "thread": the worker thread itself (a height source that
    cannot be used from a forked process: a callable holding a socket or a GPU context)."""

    tile_workers: int | str = "auto"
    """Background tiles are made by this many worker threads (each with its forked process,
    ``tile_worker="process"``) taking the queue in turn: a live edit's ~300 tiles, a flight's
    new view. "auto": one where this process may use one core (they would share the frame's),
    else one per core but one, at least two and at most four (they run at the lowest
    priority: the frame's thread comes first)."""

    tile_process_pause: bool | str = "auto"
    """With ``tile_worker="process"``: stop the tile processes while a frame runs (SIGSTOP at
    the frame's start, SIGCONT at its end) so they never take the frame's core for a scheduler
    tick. "auto": those beyond one per core but the frame's (the one process where this
    process may use one core: it then shares that core with the frame; a paced host leaves it
    the rest of the frame time), when the host left them 2 ms idle since the last frame; True:
    all, whenever they were left 2 ms; False: never."""

    random_offset_min_m: tuple[float, float] = (-1.0, -1.0)
    """Lower corner of the per-particle random sprite offset box [m] (Proland RandomParticleLayer
    min; river1: -1)."""

    random_offset_max_m: tuple[float, float] = (1.0, 1.0)
    """Upper corner of the random sprite offset box [m]."""

    fall_min_drop_m: float = FALL_MIN_DROP_M
    """A drop of the water level is a fall when it is larger than this [m] over less than its
    own height along the river (issue #23; :func:`riverflow.hydro.falls.find_falls`). Falls
    are found when a graph is built from water levels (GIS bed elevations, a DEM): a builder
    takes it with ``builder.use_config(config)`` (the command line's ``--scene`` does, from
    ``RIVERFLOW_FALL_MIN_DROP_M``); falls placed by hand are kept whatever their height."""

    rapids_min_slope: float = RAPIDS_MIN_SLOPE
    """A reach of water levels steeper than this [m/m] (and no fall) is a rapid (2 %;
    :func:`riverflow.hydro.falls.find_rapids`), found at build time as ``fall_min_drop_m``
    is. In (0, 0.5)."""

    max_step_s: float = 0.1
    """Longest simulation step [s]: a longer frame (a hitch, a debugger pause) is clamped so
    that particles never jump across a river."""

    near_m: float = 0.5
    """Camera near plane [m]."""

    far_m: float = 20000.0
    """Camera far plane [m]; rays longer than this see the sky."""

    fov_y_deg: float = 50.0
    """Vertical field of view of the default camera [degrees]."""

    def __post_init__(self) -> None:
        # an int where a float is meant (RiverConfig(radius_px=8)) reaches the kernels as an
        # int and numba compiles them again for it (~25 s cold for the Poisson fill): floats
        for f in dataclasses.fields(self):    # text or None where a number is meant: say which
            value = getattr(self, f.name)
            if isinstance(f.default, (int, float)) and not isinstance(f.default, bool) and (
                    isinstance(value, bool) or not isinstance(value, numbers.Real)):
                raise TypeError(f"RiverConfig.{f.name} must be a number, got "
                                f"{type(value).__name__} {value!r:.60}")
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            if isinstance(f.default, float) and isinstance(value, numbers.Integral) \
                    and not isinstance(value, bool):
                try:
                    object.__setattr__(self, f.name, float(value))
                except OverflowError:
                    raise ValueError(f"RiverConfig.{f.name} must be finite, got an integer of "
                                     f"{len(str(value))} digits") from None
        for f in dataclasses.fields(self):   # NaN passes "not (x > 0)"-style checks: refuse it
            value = getattr(self, f.name)
            items = value if isinstance(value, tuple) else (value,)
            if any(isinstance(v, float) and not math.isfinite(v) for v in items):
                raise ValueError(f"RiverConfig.{f.name} must be finite, got {value!r}")
        positive = ("capacity", "radius_px", "cull_radius_factor", "spawn_gap_factor",
                    "grid_cell_factor", "fade_in_s", "active_s", "fade_out_s",
                    "search_radius_factor", "slip", "tile_cache_mb", "flow_tile_px", "terrain_tile_px", "max_step_s", "near_m", "far_m", "fall_min_drop_m",
                    "fov_y_deg")
        for name in positive:
            value = getattr(self, name)
            if not (value > 0):
                raise ValueError(f"RiverConfig.{name} must be positive, got {value!r}")
        if self.speed_factor < 0:
            raise ValueError(f"RiverConfig.speed_factor must be ≥ 0, got {self.speed_factor!r}")
        if self.tile_production not in ("background", "blocking"):
            raise ValueError("RiverConfig.tile_production must be 'background' or 'blocking', "
                             f"got {self.tile_production!r}")
        if self.tile_process_pause not in (True, False, "auto"):
            raise ValueError("RiverConfig.tile_process_pause must be True, False or 'auto', "
                             f"got {self.tile_process_pause!r}")
        if isinstance(self.tile_workers, str) and self.tile_workers.strip().isdigit():
            object.__setattr__(self, "tile_workers", int(self.tile_workers))   # from_env
        if not (self.tile_workers == "auto" or (
                isinstance(self.tile_workers, numbers.Integral)
                and not isinstance(self.tile_workers, bool) and self.tile_workers >= 1)):
            raise ValueError("RiverConfig.tile_workers must be a whole number ≥ 1 or 'auto', "
                             f"got {self.tile_workers!r}")
        if self.tile_worker not in ("process", "thread"):
            raise ValueError("RiverConfig.tile_worker must be 'process' or 'thread', "
                             f"got {self.tile_worker!r}")
        if self.spawn_gap_factor < self.cull_radius_factor:
            raise ValueError("RiverConfig.spawn_gap_factor must be ≥ cull_radius_factor")
        if not 0.0 < self.rapids_min_slope < 0.5:
            raise ValueError(f"RiverConfig.rapids_min_slope must lie in (0, 0.5) [m/m], got "
                             f"{self.rapids_min_slope!r}")
        if self.far_m <= self.near_m:
            raise ValueError("RiverConfig.far_m must exceed near_m")

    @classmethod
    def from_env(cls, prefix: str = "RIVERFLOW_", **overrides) -> RiverConfig:
        """Defaults, overridden by ``<prefix><FIELD>`` environment variables, then ``overrides``."""
        values = {}
        for f in dataclasses.fields(cls):
            raw = os.environ.get(prefix + f.name.upper())
            if raw is None:
                continue
            default = f.default
            if isinstance(default, bool):
                values[f.name] = raw.strip().lower() in ("1", "true", "yes", "on")
            elif isinstance(default, int):
                values[f.name] = int(raw)
            elif isinstance(default, float) or default is None:
                values[f.name] = float(raw)
            elif isinstance(default, tuple):
                values[f.name] = tuple(float(v) for v in raw.split(","))
            else:
                values[f.name] = raw
        values.update(overrides)
        return cls(**values)
