"""FoamSettings: the knobs of the foam the particles carry — plain data (``world.foam``).

Seed 001 (notes on river effects, after Godot's Waterways) drives foam by a "flow force"

    force = base + steepness · k₁ + distance · k₂ + pressure · k₃

from a steepness map, a distance map and a pressure map. riverflow computes each from what the
flow field and the tiles already know, per particle (:mod:`riverflow.kernels.foam`):

* **steepness** ∈ [0, 1]: the water surface's slope (the water-level tiles), from 0 at
  ``steep_from`` (a lowland river) to 1 at ``steep_full`` (a mountain stream, rapids);
* **distance** ∈ [0, 1]: closeness to what the water runs along or past — banks and island
  shores (the flow tiles' distance lattice, ``shore`` · e^(−d / ``shore_m``), stronger where
  the water is fast), moving hulls (within ``hull_beams`` beams, by their speed through the
  water) and the wash behind them (their wake trails, ``Wake``, up to ``wash_s`` old);
* **pressure** ∈ [0, 1]: the water running into a shore (island noses, outer bends, the tip
  of a bifurcation) at ``impinge_mps``, or turning sharply (the strain rate of the velocity
  beyond a quarter of ``strain_ps``, × the speed / ``speed_mps``).

The particle's foam relaxes toward force clamped to [0, 1]: quickly up (``rise_s``), slowly
down (``decay_s``), so foam made at a shore, a hull or an island nose is carried downstream
as a streak. A new particle starts with its neighbours' foam.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, fields


@dataclass
class FoamSettings:
    """Weights, scales and time constants of the particles' foam (mutable: tune it live)."""

    base: float = 0.0
    """Foam everywhere (seed 001 ``flow_base``)."""
    steepness: float = 0.5
    """k₁: weight of the water-surface slope term (``flow_steepness``)."""
    distance: float = 0.85
    """k₂: weight of the closeness to shores, hulls and wakes (``flow_distance``)."""
    pressure: float = 0.6
    """k₃: weight of the strain × speed term (``flow_pressure``)."""
    shore: float = 0.6
    """Closeness to a shore at the bank itself where the water runs at ``speed_mps``: the
    particles' shore foam is broad and soft (they are metres apart; the waterline's own thin
    line is ``shoreline``)."""
    shore_m: float = 5.0
    """Shore foam falls off as e^(−distance / shore_m) from the bank [m]."""
    shore_calm: float = 0.35
    """Shore foam where the water is still, as a fraction of that where it runs at
    ``speed_mps`` (a lazy bank gathers less)."""
    steep_from: float = 0.01
    """Water-surface slope below which steepness is 0 (1 %: a lowland river)."""
    steep_full: float = 0.04
    """Water-surface slope from which steepness is 1 (4 %: a mountain stream, rapids)."""
    speed_mps: float = 2.0
    """Flow speed [m/s] at which shore foam and the strain pressure are full."""
    impinge_mps: float = 0.5
    """Speed [m/s] of the water towards a shore that gives pressure 1."""
    strain_ps: float = 0.3
    """Strain rate [1/s] of the velocity that gives pressure 1 (at full speed); a quarter of
    it gives none (the bank polylines' corners leave a few hundredths everywhere)."""
    hull_beams: float = 1.5
    """Hull foam reaches this many beams from the hull."""
    hull_speed_mps: float = 3.0
    """Speed of a hull through the water [m/s] at which its foam is full."""
    wash_s: float = 2.0
    """Foam is made along the last ``wash_s`` seconds of a boat's path (the wash behind the
    stern); the particles carry it on from there."""
    rise_s: float = 0.3
    """Time constant [s] of foam growing toward a higher target."""
    decay_s: float = 15.0
    """Time constant [s] of foam fading toward a lower one (long: streaks downstream)."""
    shoreline: float = 0.8
    """Foam drawn along the waterline itself, per pixel where the water is under 1.2 m deep
    (the particles are metres apart), × 0.55 … 1 as the particles there carry foam; 0: none.
    A drawing knob (the water shader reads it); ``world.particles.foam`` is not affected."""
    enabled: bool = True
    """False: every particle's foam is 0 (and the kernel is not run)."""

    def validate(self) -> None:
        """Raise ValueError naming the field if a value is not usable."""
        for f in fields(self):
            if f.name == "enabled":
                continue
            value = getattr(self, f.name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value >= 0):
                raise ValueError(f"FoamSettings.{f.name} must be a finite number ≥ 0, "
                                 f"got {value!r}")
        for name in ("shore_m", "speed_mps", "impinge_mps", "strain_ps", "hull_beams",
                     "hull_speed_mps", "wash_s", "rise_s", "decay_s"):
            if getattr(self, name) <= 0:
                raise ValueError(f"FoamSettings.{name} must be positive")
        if not self.steep_full > self.steep_from:
            raise ValueError("FoamSettings.steep_full must exceed steep_from")
