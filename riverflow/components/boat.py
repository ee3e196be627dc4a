"""Boat: the player's (or an AI's) boat on the river — plain data, moved by the "boat" system.

Gameplay writes ``throttle`` and ``rudder``; each frame the "boat" system
(:class:`riverflow.systems.boat.MoveBoats`, its physics :mod:`riverflow.physics.boat`) reads the
flow under the hull, integrates the motion, keeps the hull in the water, floats it on the
surface and puts it into the flow as a moving obstacle. Everything else here is its state
(read it to draw, to chase it with a camera, for a HUD) and its tunables.

Frames and signs: world x/y horizontal, z up; ``heading_rad`` counter-clockwise from +x (the
bow's direction); ``rudder`` > 0 turns to port (counter-clockwise); ``pitch_rad`` > 0 raises
the bow; ``roll_rad`` > 0 lowers starboard (the right side): the conventions of
:class:`riverflow.components.props.Pose`.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


def _zeros2() -> np.ndarray:
    return np.zeros(2)


@dataclass(eq=False)
class Boat:
    """State, controls and tunables of one boat. Units are in the names."""

    # -- state ------------------------------------------------------------------------------
    position_m: np.ndarray = field(default_factory=_zeros2)
    """(2,) float64 hull centre (waterline) [m]."""
    heading_rad: float = 0.0
    velocity_mps: np.ndarray = field(default_factory=_zeros2)
    """(2,) float64 velocity over ground, world frame [m/s]."""
    yaw_rate_rps: float = 0.0
    """Counter-clockwise [rad/s]."""
    altitude_m: float = 0.0
    """Waterline altitude: the water level under the hull plus the bob [m]."""
    pitch_rad: float = 0.0
    roll_rad: float = 0.0

    # -- controls (gameplay writes these) ------------------------------------------------
    throttle: float = 0.0
    """−1 (full astern) … 1 (full ahead); clamped by the system."""
    rudder: float = 0.0
    """−1 (hard to starboard) … 1 (hard to port); clamped by the system."""

    # -- what the system saw last step (HUD, sounds, AI) ---------------------------------
    flow_mps: np.ndarray = field(default_factory=_zeros2)
    """(2,) float64 flow velocity under the hull, without the boat's own wake [m/s]."""
    grounded: bool = False
    """The hull touches a bank or an island shore (within 5 cm) after the last step."""

    # -- hull ---------------------------------------------------------------------------------
    length_m: float = 8.0
    beam_m: float = 3.0
    height_m: float = 1.2
    """Keel to deck (only for drawing: :class:`~riverflow.components.props.Prop` size)."""
    reach_beams: float = 1.5
    """The flow bends around the hull up to this many beams from it (obstacle influence)."""

    # -- propulsion and drag (accelerations per unit mass) --------------------------------
    max_thrust_mps2: float = 3.0
    """Forward acceleration at full throttle [m/s²]. With the drags below the top speed
    through the water is 8 m/s (15.5 kn), a small motor boat's."""
    reverse_fraction: float = 0.5
    """Astern thrust at full reverse, as a fraction of ``max_thrust_mps2``."""
    drag_forward_per_s: float = 0.15
    """Linear drag of the speed through the water along the hull [1/s]: a boat left to the
    current picks up its speed with a time constant of about 1 / 0.15 ≈ 7 s."""
    drag_forward_per_m: float = 0.028
    """Quadratic drag along the hull [1/m] (a · |v| · v)."""
    drag_lateral_per_s: float = 1.5
    """Linear drag across the hull [1/s]: the keel grips, a sideways slip dies in < 1 s."""
    drag_lateral_per_m: float = 0.3
    """Quadratic drag across the hull [1/m]."""

    # -- steering -----------------------------------------------------------------------------
    max_yaw_rate_rps: float = 0.6
    """Turn rate with the rudder hard over at speed [rad/s] (about 34°/s)."""
    steer_speed_mps: float = 3.0
    """Water speed over the rudder at which it has full authority [m/s]; below it the turn
    rate falls off linearly (no speed through the water, no steering)."""
    prop_wash_mps: float = 1.5
    """Water speed the propeller pushes over the rudder at full throttle [m/s]: a boat held
    against the current, or starting from rest, can still turn."""
    yaw_response_s: float = 0.4
    """Time constant of the turn rate following the rudder [s]."""

    # -- floating -------------------------------------------------------------------------------
    bob_m: float = 0.04
    """Amplitude of the vertical bob [m]."""
    bob_period_s: float = 2.7
    pitch_wave_rad: float = 0.008
    """Amplitude of the pitching oscillation at rest [rad]; it grows with speed."""
    roll_wave_rad: float = 0.012
    """Amplitude of the rolling oscillation at rest [rad]; it grows with speed."""
    trim_rad_per_mps: float = 0.005
    """Bow rise per m/s of forward speed through the water [rad·s/m] (2.3° at top speed)."""
    bank_rad_per_mps2: float = 0.02
    """Lean into a turn per unit of yaw rate × speed [rad per m/s²] (a planing hull banks
    inwards)."""
    phase_rad: float = 0.0
    """Phase of the bob and the oscillations (give boats different phases)."""
