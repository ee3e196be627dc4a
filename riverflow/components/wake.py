"""Wake: a boat's recent path through the water and the knobs of its Kelvin wake and foam trail.

Plain data. The "wake" system (:mod:`riverflow.systems.wake`) keeps each boat's trail: a
point where its bow was every ``sample_s`` seconds, each point drifting with the current it
was left in (so the trail bends where the boat turned and is carried downstream), and packs
every trail into the :class:`Wakes` resource each frame. Two readers:

* the water shader (``shaders/wake.glsl``) draws the Kelvin wake from it: the waves of a
  source moving at the boat's speed through the water, inside the ~19.47° half-angle wedge
  behind the bow, transverse and diverging waves of wavelength 2πU²/g and shorter;
* the foam kernel (:mod:`riverflow.kernels.foam`) makes foam along it behind the stern, which
  the particles then carry away with the current.

A boat slower through the water than ``min_speed_mps`` leaves none of either.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from riverflow.kernels.foam import HULL_FIELDS
from riverflow.kernels.wake import (TP_SPEED, TP_TIME, TP_VX, TP_VY, TP_X,  # noqa: F401
                                    TP_Y, TR_AGE, TR_ARC, TR_FIELDS, TR_HALF_WIDTH, TR_SLOPE,
                                    TR_SPEED, TR_STRENGTH, TR_X, TR_Y, TRAIL_STATE_FIELDS)

TRAIL_POINTS = 48
"""Points of a trail (the water shader loops over them: keep it small)."""
MAX_WAKES = 4
"""Wakes the water shader draws (the boats nearest the camera); the foam sees them all."""


@dataclass(eq=False)
class Wake:
    """One boat's wake: the knobs of its look and its trail (the wake system's state).

    ``RiverWorld.add_boat`` gives every boat one; ``world.wake(entity)`` returns it to tune.
    """

    wave_slope: float = 0.5
    """Peak slope of the Kelvin waves just behind the boat at full strength (the water's own
    wave sprites have an RMS slope of ``DisplaySettings.wave_slope_factor``, 0.2)."""
    foam: float = 1.0
    """Foam made along the trail, × ``FoamSettings.distance`` (0: a trail with no foam)."""
    min_speed_mps: float = 0.5
    """Below this speed through the water the boat makes no wake (waves and foam rise to
    full over the next 1.5 m/s)."""
    life_s: float = 15.0
    """A trail point's waves and foam fade out over this many seconds (at 8 m/s the
    transverse waves are 41 m long: a long trail shows a few of them)."""
    sample_s: float = 1.0 / 3.0
    """A trail point every this many seconds (TRAIL_POINTS of them: life_s / sample_s
    should not exceed it)."""
    spread_mps: float = 0.35
    """The foam trail widens by this much a second on each side (from half a beam)."""
    trail: np.ndarray = field(default_factory=lambda: np.zeros((TRAIL_POINTS,
                                                                 TRAIL_STATE_FIELDS)))
    """(TRAIL_POINTS, 6) float64 x, y [m], time [s], speed through the water [m/s], drift
    vx, vy [m/s] (the current where it was left), newest first; row 0 is the bow now."""
    count: int = 0
    """Rows of ``trail`` in use."""

    def clear(self) -> None:
        """Forget the trail (a boat moved by hand: no wake across the jump)."""
        self.count = 0


@dataclass(eq=False)
class Wakes:
    """Every boat's wake this frame, packed for the kernels and the shader (a resource the
    wake system fills).

    ``table`` (B, TRAIL_POINTS, TR_FIELDS) float32: each boat's trail, bow first (columns
    TR_*; TR_STRENGTH = −1 past its last point), boats nearest the camera first; ``hulls``
    (B, HULL_FIELDS) float64: per boat, as the foam kernel reads hulls
    (:data:`riverflow.kernels.foam.HL_X` …): x, y [m] of the hull centre, heading [rad],
    length, beam [m], speed through the water [m/s], its wake's foam knob, its row in
    ``table``.
    """

    table: np.ndarray = field(default_factory=lambda: np.zeros((0, TRAIL_POINTS, TR_FIELDS),
                                                               np.float32))
    hulls: np.ndarray = field(default_factory=lambda: np.zeros((0, HULL_FIELDS)))

    @property
    def count(self) -> int:
        return int(self.table.shape[0])
