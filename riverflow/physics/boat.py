"""A boat's physics: carried by the flow, driven by throttle and rudder, kept in the water,
floating, and put into the flow as a moving obstacle (plain numpy and math: one boat is a
handful of numbers). The "boat" system (:class:`riverflow.systems.boat.MoveBoats`) runs
:func:`step_boat` for every :class:`~riverflow.components.boat.Boat` each frame.

One step of one boat:

1. **Flow under the hull** from the public :meth:`FlowField.query` (what a game would call),
   at the bow, the centre and the stern, leaving out the boat's own obstacle: the mean is the
   current that carries it, the bow-to-stern difference across the hull turns it with the
   river's bends.
2. **Motion** (per unit mass, semi-implicit so any step is stable): the velocity through the
   water r = v − flow, split along and across the hull, decays by linear + quadratic drags
   (strong across: the keel; weak along); the throttle pushes along the heading (astern at
   half strength); the rudder turns the boat at up to ``max_yaw_rate_rps`` times the water
   speed over the rudder (speed through the water plus propeller wash) / ``steer_speed_mps``.
3. **Banks and island shores are walls**: the hull is a capsule (its axis segment, radius
   beam/2); every shore segment (``scene.water.polygon``'s rings, islands are holes) closer to
   the axis than the radius pushes the boat back out along the shortest line, and the
   velocity into that shore is removed, so the boat slides along it. A step that cannot be
   resolved (never seen: a boat moves at most 0.8 m a step) is undone.
4. **Floating**: altitude = water level under the hull + a small bob; pitch and roll follow
   the water-level gradient under the hull, plus trim with speed, a lean into turns and a
   small oscillation growing with speed — all functions of the world clock (deterministic).
   The level is read from the view's surface tiles (``TerrainView.surface``, what the particles
   ride on), bilinear: ``scene.water.level`` itself costs about a millisecond a call (it
   serves where no tile is made yet).
5. **Obstacle**: the hull as a row of the flow's obstacle table (:func:`obstacle_row`), with
   its velocity, yaw rate and ψ_o = the unobstructed ψ at its centre; the system puts the rows
   into the flow (``FlowField.set_obstacles(..., key=BOATS_KEY)``), so that
   ``FlowField.query`` and the particles (advection runs later in the frame) go around it.

The hull's capsule geometry and the shore contacts are :mod:`riverflow.physics.hull`.
"""
from __future__ import annotations

import math

import numpy as np
import shapely

from riverflow._validate import as_points, finite
from riverflow.components.boat import Boat
from riverflow.components.props import Pose, Prop
from riverflow.components.status import FlowStatus
from riverflow.kernels import obstacles as ko
from riverflow.kernels.surface_tiles import water_level_at
from riverflow.physics.hull import Shore, forward, hull_axis, port

BOATS_KEY = "boats"
"""The obstacle set of :meth:`FlowField.set_obstacles` that the boats' hulls are (the "boat"
system owns it; the foam tells the boats from other obstacles by it)."""

SKIN_M = 0.05
"""A hull closer than this to a shore [m] touches it (``Boat.grounded``) and is pushed back
to this distance."""

PUSH_MARGIN_M = 1e-4
"""A push ends this much beyond ``SKIN_M``, so rounding never leaves the hull touching the
same shore again (a boat pressing on a shore still moves in by more each step: it stays
grounded)."""

MAX_PUSHES = 4
"""Shore contacts resolved per step (the deepest first)."""

FLOW_SAMPLE_FRACTION = 0.35
"""The flow is read at the centre and ± this × length along the hull."""


def step_boat(boat: Boat, field, shore: Shore, surface, water, dt_s: float, now_s: float,
              last_pose: tuple[np.ndarray, float], exclude=()) -> np.ndarray:
    """Advance one boat by ``dt_s`` (module docstring, 1–5) and return its obstacle row.

    ``field`` is the :class:`~riverflow.hydro.flow_field.FlowField` (read without the
    obstacle rows ``exclude``: the boat's own), ``shore`` the :class:`Shore` of the scene's
    water polygon, ``surface`` the view's surface tiles (None before the first view),
    ``water`` the scene's water (``water.level(xy)``: where no tile is made), ``now_s`` the
    world clock, ``last_pose`` the boat's last good (position, heading)."""
    sanitise(boat, last_pose)
    flow, flow_yaw = sense_flow(boat, field, exclude)
    if dt_s > 0.0:
        prev = (boat.position_m.copy(), boat.heading_rad)
        integrate(boat, flow, flow_yaw, dt_s)
        keep_in_water(boat, shore, *prev)
    float_on_water(boat, surface, water, flow, now_s)
    return obstacle_row(boat, field)


# -- the steps, one function each ---------------------------------------------------------

def sanitise(boat: Boat, last_pose: tuple[np.ndarray, float]) -> None:
    """Whatever gameplay wrote, leave a boat the step can move: controls clamped to [−1, 1]
    (NaN → 0), a non-finite motion reset to rest, a non-finite position or heading back to
    ``last_pose`` (the last good one), a hull at least 0.1 m wide and as long as wide."""
    boat.throttle = _unit(boat.throttle)
    boat.rudder = _unit(boat.rudder)
    boat.position_m = np.asarray(boat.position_m, np.float64).reshape(2)
    boat.velocity_mps = np.asarray(boat.velocity_mps, np.float64).reshape(2)
    x, y = boat.position_m
    if not (math.isfinite(x) and math.isfinite(y) and math.isfinite(boat.heading_rad)):
        boat.position_m = last_pose[0].copy()
        boat.heading_rad = last_pose[1]
    vx, vy = boat.velocity_mps
    if not (math.isfinite(vx) and math.isfinite(vy) and math.isfinite(boat.yaw_rate_rps)):
        boat.velocity_mps = np.zeros(2)
        boat.yaw_rate_rps = 0.0
    boat.beam_m = max(float(boat.beam_m), 0.1) if boat.beam_m == boat.beam_m else 3.0
    boat.length_m = max(float(boat.length_m), boat.beam_m) if boat.length_m == boat.length_m \
        else boat.beam_m
    if not boat.reach_beams > 0.0:
        boat.reach_beams = 1.5


def sense_flow(boat: Boat, field, exclude) -> tuple[np.ndarray, float]:
    """(flow (2,) [m/s], its turn rate along the hull [rad/s]) under the boat, from
    :meth:`FlowField.query` at bow, centre and stern without the obstacles ``exclude``."""
    f = forward(boat.heading_rad)
    arm = FLOW_SAMPLE_FRACTION * boat.length_m
    pts = boat.position_m + np.outer([arm, 0.0, -arm], f)
    status, velocity = field.query(pts, exclude_obstacles=exclude)
    wet = status == FlowStatus.INSIDE
    flow = velocity[wet].astype(np.float64).mean(axis=0) if wet.any() else np.zeros(2)
    flow_yaw = 0.0
    if wet[0] and wet[2]:
        side = port(boat.heading_rad)
        flow_yaw = float((velocity[0] - velocity[2]) @ side) / (2.0 * arm)
        flow_yaw = min(max(flow_yaw, -boat.max_yaw_rate_rps), boat.max_yaw_rate_rps)
    boat.flow_mps = flow
    return flow, flow_yaw


def integrate(boat: Boat, flow_mps: np.ndarray, flow_yaw_rps: float, dt_s: float) -> None:
    """One step of the motion (module docstring, 2): velocity, yaw rate, heading, position."""
    f = forward(boat.heading_rad)
    side = port(boat.heading_rad)
    rel = boat.velocity_mps - flow_mps
    along = float(rel @ f)
    across = float(rel @ side)
    t = boat.throttle
    thrust = t * boat.max_thrust_mps2 * (1.0 if t >= 0.0 else boat.reverse_fraction)
    along = (along + thrust * dt_s) / (
        1.0 + dt_s * (boat.drag_forward_per_s + boat.drag_forward_per_m * abs(along)))
    across = across / (1.0 + dt_s * (boat.drag_lateral_per_s
                                     + boat.drag_lateral_per_m * abs(across)))
    boat.velocity_mps = flow_mps + along * f + across * side
    over_rudder = along + boat.prop_wash_mps * t
    authority = min(max(over_rudder / boat.steer_speed_mps, -1.0), 1.0)
    target = boat.rudder * boat.max_yaw_rate_rps * authority + flow_yaw_rps
    follow = 1.0 - math.exp(-dt_s / boat.yaw_response_s)
    boat.yaw_rate_rps += (target - boat.yaw_rate_rps) * follow
    boat.heading_rad = math.remainder(boat.heading_rad + boat.yaw_rate_rps * dt_s, math.tau)
    boat.position_m = boat.position_m + boat.velocity_mps * dt_s


def keep_in_water(boat: Boat, shore: Shore, prev_position_m: np.ndarray,
                  prev_heading_rad: float) -> None:
    """Push the hull out of every shore it entered and cancel the velocity into the shore
    (module docstring, 3); undo the step if that does not resolve it."""
    radius = 0.5 * boat.beam_m
    boat.grounded = False
    for push in range(MAX_PUSHES + 1):
        a, b = hull_axis(boat.position_m, boat.heading_rad, boat.length_m, boat.beam_m)
        contact = shore.deepest_contact(a, b, radius + SKIN_M)
        if contact is None:
            return
        boat.grounded = True
        dist, bank_pt, axis_pt = contact
        if dist < 1e-6 or push == MAX_PUSHES:
            break                       # the axis crossed the shore, or no way out: undo
        normal = (axis_pt - bank_pt) / dist     # from the shore into the water
        boat.position_m = boat.position_m + normal * (radius + SKIN_M + PUSH_MARGIN_M - dist)
        into = float(boat.velocity_mps @ normal)
        if into < 0.0:
            boat.velocity_mps = boat.velocity_mps - into * normal
    boat.position_m = np.array(prev_position_m, np.float64)
    boat.heading_rad = float(prev_heading_rad)
    boat.velocity_mps = np.zeros(2)
    boat.yaw_rate_rps = 0.0


def float_on_water(boat: Boat, surface, water, flow_mps: np.ndarray, now_s: float) -> None:
    """Altitude, pitch and roll (module docstring, 4)."""
    fx, fy = math.cos(boat.heading_rad), math.sin(boat.heading_rad)
    half_l = 0.4 * boat.length_m
    half_b = 0.5 * boat.beam_m
    x, y = boat.position_m
    pts = [(x, y), (x + half_l * fx, y + half_l * fy), (x - half_l * fx, y - half_l * fy),
           (x - half_b * fy, y + half_b * fx), (x + half_b * fy, y - half_b * fx)]
    z = surface_levels(surface, pts)
    if not all(map(math.isfinite, z)):
        z = [float(v) for v in water.level(np.array(pts))]
    vx, vy = boat.velocity_mps
    along = (vx - flow_mps[0]) * fx + (vy - flow_mps[1]) * fy
    gain = 1.0 + abs(along) / 4.0
    w = math.tau / boat.bob_period_s
    ph = boat.phase_rad
    boat.altitude_m = float(z[0]) + boat.bob_m * math.sin(w * now_s + ph)
    boat.pitch_rad = (math.atan2(z[1] - z[2], 2.0 * half_l)
                      + boat.trim_rad_per_mps * max(along, 0.0)
                      + boat.pitch_wave_rad * gain * math.sin(1.3 * w * now_s + ph + 1.1))
    boat.roll_rad = (math.atan2(z[3] - z[4], 2.0 * half_b)
                     - boat.bank_rad_per_mps2 * boat.yaw_rate_rps * along
                     + boat.roll_wave_rad * gain * math.sin(0.8 * w * now_s + ph + 0.4))


def obstacle_row(boat: Boat, field) -> np.ndarray:
    """The boat as a flow obstacle row (``kernels.obstacles.OB_*``), ψ_o = the unobstructed ψ
    at its centre (NaN there, e.g. outside the water, disables it)."""
    psi = float(field.potential(boat.position_m[None], exclude_obstacles=True)[0])
    row = np.empty(ko.OBSTACLE_FIELDS)
    row[ko.OB_X], row[ko.OB_Y] = boat.position_m
    row[ko.OB_HEADING] = boat.heading_rad
    row[ko.OB_LENGTH] = boat.length_m
    row[ko.OB_BEAM] = boat.beam_m
    row[ko.OB_PSI] = psi
    row[ko.OB_VX], row[ko.OB_VY] = boat.velocity_mps
    row[ko.OB_YAW_RATE] = boat.yaw_rate_rps
    row[ko.OB_REACH] = boat.reach_beams * boat.beam_m
    return row


def boat_components(scene, position_m, heading_rad: float = 0.0, *, drawn: bool = True,
                    **params) -> list:
    """The components of a new boat at ``position_m`` (2,) [m] on ``scene``'s water: a
    :class:`Boat` (``params``: its fields), plus a "boat" :class:`Prop` and its :class:`Pose`
    if ``drawn``. Raises ValueError on an unknown field, a bad size, or a hull that does not
    fit in the water there."""
    fields = set(Boat.__dataclass_fields__)
    unknown = set(params) - fields
    if unknown:
        raise ValueError(f"Boat has no field(s) {sorted(unknown)}; known: {sorted(fields)}")
    position = as_points(position_m, "add_boat: position_m (x, y) [m]")
    if len(position) != 1:
        raise ValueError(f"add_boat: position_m must be one (x, y) [m], got {position_m!r:.80}")
    boat = Boat(position_m=position[0].copy(),
                heading_rad=finite(heading_rad, "add_boat: heading_rad"), **params)
    boat.velocity_mps = np.array(boat.velocity_mps, np.float64).reshape(2)
    if not (boat.beam_m > 0.0 and boat.length_m >= boat.beam_m and boat.reach_beams > 0.0):
        raise ValueError("a boat needs beam_m > 0, length_m ≥ beam_m and reach_beams > 0")
    if not (np.isfinite(boat.position_m).all() and math.isfinite(boat.heading_rad)):
        raise ValueError(f"bad boat position {position_m!r} / heading {heading_rad!r}")
    a, b = hull_axis(boat.position_m, boat.heading_rad, boat.length_m, boat.beam_m)
    polygon = scene.water.polygon
    if (not shapely.contains_xy(polygon, *boat.position_m)
            or Shore(polygon).deepest_contact(a, b, 0.5 * boat.beam_m) is not None):
        raise ValueError(f"a {boat.length_m} × {boat.beam_m} m hull at {position_m!r} does not "
                         "fit in the water")
    boat.altitude_m = float(np.asarray(scene.water.level(boat.position_m[None]))[0])
    if not drawn:
        return [boat]
    pose = Pose(np.array([*boat.position_m, boat.altitude_m]), boat.heading_rad)
    return [boat, Prop("boat", (boat.length_m, boat.beam_m, boat.height_m)), pose]


def surface_levels(surface, pts) -> list[float]:
    """Water level [m] at a few points [(x, y), …] [m], bilinear on the view's surface tiles
    (:class:`~riverflow.kernels.surface_tiles.SurfaceTiles`; NaN where a corner is dry, where
    no tile is made yet, or with no view yet)."""
    if surface is None:
        return [math.nan] * len(pts)
    return [float(water_level_at(surface, float(x), float(y))) for x, y in pts]


def _unit(value: float) -> float:
    """``value`` clamped to [−1, 1]; NaN → 0."""
    value = float(value)
    return 0.0 if math.isnan(value) else min(max(value, -1.0), 1.0)
