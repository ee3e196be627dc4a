"""ParticlePool: the screen-space particles, a fixed-capacity structure of arrays.

Particles are entities of a packed archetype (SPEC §3): each is a row (slot) with a stable id,
and its components are the pool's columns, one group per Proland particle layer
(reference §3.3): LifeCycle (birth time, intensity), Screen (screen position, fade reason),
World (world position, velocity), Terrain (flow status, first-query flag), Random (sprite
offset), and ours, Foam (the foam it carries) and Tint (the spills' colour it carries).
Nothing is allocated per frame; a new particle
takes the lowest free slot (Proland's ``pack``), so live rows stay dense at the front and a
slot is the particle's GPU row.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from enum import IntEnum

import numpy as np

from riverflow.components.status import FlowStatus
from riverflow.kernels.lifecycle import Pool


class FadeReason(IntEnum):
    """Why a particle is fading out (Proland ScreenParticleLayer reason, plus our own)."""

    NONE = 0
    AGE = 1
    OUTSIDE_VIEWPORT = 2
    POISSON_DISK = 3


@dataclass(eq=False)
class ParticlePool:
    """Columns of every particle slot; ``alive`` says which slots hold a particle.

    ``counters[0]`` is the next id to hand out, ``counters[1]`` the number of live particles,
    ``counters[2]`` a slot bound: no slot at or above it is alive, so passes over the pool stop
    there (raised by each allocation, lowered by the life-cycle pass; with the lowest free
    slot always taken it sits near the live count, ~60 % of a 1.5× capacity). An array, so
    numba kernels can update them in place.
    """

    capacity: int
    alive: np.ndarray = field(init=False)        # (C,) bool
    ids: np.ndarray = field(init=False)          # (C,) int64 stable id, -1 for a free slot
    counters: np.ndarray = field(init=False)     # (3,) int64 next id, live count, slot bound
    # LifeCycle
    birth_s: np.ndarray = field(init=False)      # (C,) float64 clock time [s] (moved back when
                                                 # a fade-out starts, so intensity never jumps)
    intensity: np.ndarray = field(init=False)    # (C,) float32 in [0, 1]
    # Screen
    screen_px: np.ndarray = field(init=False)    # (C, 2) float32 [px], origin bottom-left
    fade_reason: np.ndarray = field(init=False)  # (C,) uint8 FadeReason
    # World
    world_m: np.ndarray = field(init=False)      # (C, 3) float64 [m]
    has_world: np.ndarray = field(init=False)    # (C,) bool: world_m is known
    velocity_mps: np.ndarray = field(init=False)  # (C, 2) float32 [m/s]
    # Terrain (flow)
    status: np.ndarray = field(init=False)       # (C,) uint8 FlowStatus
    first_query: np.ndarray = field(init=False)  # (C,) bool
    water_hint_m: np.ndarray = field(init=False)  # (C, 3) float32 nearest deep water to an
                                                 # OUTSIDE particle (x, y, level) [m]; x = inf:
                                                 # none (kernels.advection.check_outside_near_water)
    hint_id: np.ndarray = field(init=False)      # (C,) int64 id whose hint water_hint_m holds
    # Random
    offset_m: np.ndarray = field(init=False)     # (C, 2) float32 sprite texture offset [m]
    # Foam (kernels/foam.py)
    foam: np.ndarray = field(init=False)         # (C,) float32 foam amount in [0, 1]
    foam_flow: np.ndarray = field(init=False)    # (C,) float32 the river's part of its target
    foam_shore: np.ndarray = field(init=False)   # (C,) float32 its closeness to a shore
    foam_near: np.ndarray = field(init=False)    # (C,) float32 … to a hull or its wash
    foam_id: np.ndarray = field(init=False)      # (C,) int64 id whose foam the slot holds
    # Spill tint (kernels/spill.py sample_tint, issue 24)
    tint: np.ndarray = field(init=False)         # (C, 4) float32 the spills' colour (r, g, b)
                                                 # and concentration [kg/m³] where it sampled
    tint_id: np.ndarray = field(init=False)      # (C,) int64 id whose tint the slot holds
    arrays: Pool = field(init=False, repr=False)
    """These columns as one tuple, for the kernels (the arrays are never replaced)."""

    def __post_init__(self) -> None:
        c = int(self.capacity)
        if c < 1:
            raise ValueError(f"ParticlePool capacity must be ≥ 1, got {c}")
        self.capacity = c
        self.alive = np.zeros(c, np.bool_)
        self.ids = np.full(c, -1, np.int64)
        self.counters = np.zeros(3, np.int64)
        self.birth_s = np.zeros(c, np.float64)
        self.intensity = np.zeros(c, np.float32)
        self.screen_px = np.zeros((c, 2), np.float32)
        self.fade_reason = np.zeros(c, np.uint8)
        self.world_m = np.zeros((c, 3), np.float64)
        self.has_world = np.zeros(c, np.bool_)
        self.velocity_mps = np.zeros((c, 2), np.float32)
        self.status = np.full(c, FlowStatus.UNKNOWN, np.uint8)
        self.first_query = np.zeros(c, np.bool_)
        self.water_hint_m = np.zeros((c, 3), np.float32)
        self.hint_id = np.full(c, -1, np.int64)
        self.offset_m = np.zeros((c, 2), np.float32)
        self.foam = np.zeros(c, np.float32)
        self.foam_flow = np.zeros(c, np.float32)
        self.foam_shore = np.zeros(c, np.float32)
        self.foam_near = np.zeros(c, np.float32)
        self.foam_id = np.full(c, -1, np.int64)
        self.tint = np.zeros((c, 4), np.float32)
        self.tint_id = np.full(c, -1, np.int64)
        self.arrays = Pool(**self.columns())

    @property
    def count(self) -> int:
        """Live particles."""
        return int(self.counters[1])

    def clear(self) -> None:
        """Drop every particle (Proland ParticleStorage::clear), e.g. when r changes."""
        self.alive[:] = False
        self.ids[:] = -1
        self.counters[1] = 0
        self.counters[2] = 0

    def columns(self) -> dict[str, np.ndarray]:
        """Every column by name (for snapshots and bit-identity tests)."""
        names = ("alive", "ids", "counters", "birth_s", "intensity", "screen_px", "fade_reason",
                 "world_m", "has_world", "velocity_mps", "status", "first_query", "water_hint_m",
                 "hint_id", "offset_m", "foam", "foam_flow", "foam_shore", "foam_near",
                 "foam_id", "tint", "tint_id")
        return {n: getattr(self, n) for n in names}


@dataclass(eq=False)
class LiveParticles:
    """A read-only view of the live particles (``world.particles``), copied out of the pool."""

    ids: np.ndarray          # (N,) int64
    screen_px: np.ndarray    # (N, 2) float32 [px]
    world_m: np.ndarray      # (N, 3) float64 [m]
    intensity: np.ndarray    # (N,) float32
    status: np.ndarray       # (N,) uint8 FlowStatus
    velocity_mps: np.ndarray  # (N, 2) float32 [m/s]
    fading: np.ndarray       # (N,) bool: fading out
    has_world: np.ndarray    # (N,) bool
    foam: np.ndarray = field(default_factory=lambda: np.zeros(0, np.float32))
    """(N,) float32 foam amount in [0, 1] (:mod:`riverflow.kernels.foam`)."""

    def __len__(self) -> int:
        return int(self.ids.shape[0])
