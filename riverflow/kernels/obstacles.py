"""Moving obstacles in the flow (boats): a divergence-free modulation of ψ around capsule hulls.

The paper's model takes obstacles as boundaries of constant ψ (reference §2.1, §2.4.2). Adding
a moving hull to the bank weighting would change every cached ψ lattice each frame, so the
hull is applied *after* the cached query, as a local modulation of the stream function
around it. For an obstacle with centre c, rigid velocity u and yaw rate ω:

    ψ'(p) = ψ_r(p) + ψ_o + (ψ(p) − ψ_r(p) − ψ_o) · g(d(p))

* d(p) [m]: distance from p to the hull, a capsule: the segment of the hull's length along
  its heading, shortened by the radius r = beam / 2 at both ends (so the capsule is exactly
  ``length`` long and ``beam`` wide); d ≤ 0 inside.
* g(d) = f(clamp(d / reach, 0, 1)), f(t) = 1 − (1 − t)³: g = 0 on the hull, g = 1 from
  ``reach`` [m] on (the influence distance; 1.5 beams by default), f'(1) = f''(1) = 0 so the
  velocity joins the free flow smoothly there, and f'(0) = 3 so the water *slips* along the
  hull (a ramp with f'(0) = 0, like the paper's 6t⁵ − 15t⁴ + 10t³, would stop it dead on
  the hull and particles would pile up along the sides).
* ψ_r(p) = u_y·(p_x − c_x) − u_x·(p_y − c_y) + ω·|p − c|² / 2: the stream function of the
  hull's rigid motion (its curl is u + ω × (p − c)).
* ψ_o [m²/s]: the hull's ψ, normally the unobstructed ψ at its centre (sampled by the caller
  when it moves the obstacle): it sets how the discharge splits between the hull's two sides.

The velocity is its curl (v = (−∂ψ/∂y, ∂ψ/∂x), as for the banks):

    v'(p) = v_r(p) + g · (v(p) − v_r(p)) + (ψ(p) − ψ_r(p) − ψ_o) · g'(d) · (−n_y, n_x)

with n = ∇d the unit vector from the nearest hull-axis point to p. Properties: exactly
divergence-free (a curl); on the hull ψ' − ψ_r is constant, so the flow *relative to the
hull* is tangent to it (a still hull: the velocity is tangent; a moving one: nothing enters
or leaves it), sliding along it at about the free-stream speed at its sides (reach = 3 radii);
v' = v beyond ``reach`` and v' is C¹ across that circle; inside the hull the velocity is the
hull's own rigid velocity (water carried along, as particles under the boat are). A point
approaching the hull closes in at most at 3·|v − v_r|·d / reach, so an explicit Euler step
never crosses onto the hull while |v − v_r|·dt < reach / 3. For a still hull (u = 0, ω = 0)
this is ψ' = ψ_o + (ψ − ψ_o)·g. The flux between the banks is unchanged as long as the influence
zone stays off them. Several obstacles are applied one after the other (each one's ψ' is the
next one's ψ), so each stays divergence-free; where influence zones overlap only the last
hull is exactly a streamline.

An obstacle is a row of an (K, OBSTACLE_FIELDS) float64 array, columns OB_*.
"""
from __future__ import annotations

import math

from numba import njit

from riverflow.kernels._jit import JIT_OPTIONS, is_finite

OB_X = 0
"""Hull centre x [m]."""
OB_Y = 1
"""Hull centre y [m]."""
OB_HEADING = 2
"""Heading [rad] (counter-clockwise from +x): the capsule's long axis."""
OB_LENGTH = 3
"""Overall length [m] (tip to tip)."""
OB_BEAM = 4
"""Width [m]; the capsule's radius is half of it."""
OB_PSI = 5
"""ψ_o of the hull [m²/s]; NaN disables the obstacle."""
OB_VX = 6
"""Hull velocity x [m/s]."""
OB_VY = 7
"""Hull velocity y [m/s]."""
OB_YAW_RATE = 8
"""Hull yaw rate [rad/s] (counter-clockwise)."""
OB_REACH = 9
"""Influence distance from the hull [m]: beyond it the flow is unchanged."""
OBSTACLE_FIELDS = 10

DEFAULT_REACH_BEAMS = 1.5
"""Default influence distance, in beams: wide enough that the flow bends smoothly around the
bow (the tangential speed-up at the sides stays under about 2× the free stream, as around a
cylinder in potential flow), narrow enough that a boat in mid-river leaves the banks alone."""

STATUS_INSIDE = 1


@njit(inline="always", **JIT_OPTIONS)
def _hull_axis(obstacles, j):
    """(ax, ay, bx, by, radius, reach) of obstacle j's capsule [m]."""
    cx = obstacles[j, OB_X]
    cy = obstacles[j, OB_Y]
    r = 0.5 * obstacles[j, OB_BEAM]
    half = max(0.5 * obstacles[j, OB_LENGTH] - r, 0.0)
    hx = half * math.cos(obstacles[j, OB_HEADING])
    hy = half * math.sin(obstacles[j, OB_HEADING])
    return cx - hx, cy - hy, cx + hx, cy + hy, r, obstacles[j, OB_REACH]


@njit(**JIT_OPTIONS)
def select_obstacle_points(xy, status, obstacles, out_index):
    """Indices of the INSIDE points of ``xy`` (N, 2) [m] (``status`` (N,) uint8 FlowStatus)
    within the influence of some obstacle (a bounding-circle test), into ``out_index`` (N,)
    int64; returns their number."""
    n = 0
    k_obs = obstacles.shape[0]
    for k in range(xy.shape[0]):
        if status[k] != STATUS_INSIDE:
            continue
        px = xy[k, 0]
        py = xy[k, 1]
        for j in range(k_obs):
            half = 0.5 * max(obstacles[j, OB_LENGTH], obstacles[j, OB_BEAM])
            reach = half + obstacles[j, OB_REACH]
            dx = px - obstacles[j, OB_X]
            dy = py - obstacles[j, OB_Y]
            if dx * dx + dy * dy < reach * reach:
                out_index[n] = k
                n += 1
                break
    return n


@njit(**JIT_OPTIONS)
def apply_obstacles(xy, index, n, psi, obstacles, out_status, out_velocity):
    """Modulate the flow at points ``index[:n]`` of ``xy`` (N, 2) [m] by every obstacle, in
    order (module docstring).

    ``psi`` (n,) float64 [m²/s]: the unobstructed ψ at those points (``psi[q]`` belongs to
    point ``index[q]``), replaced by ψ'. ``out_velocity`` (N, 2) float32 [m/s] holds the
    unobstructed curl and is replaced by the modulated one; only points whose ``out_status``
    (N,) uint8 is INSIDE and whose ψ is finite change. Obstacles (K, OBSTACLE_FIELDS) with a
    non-finite ψ_o are skipped. Returns the number of points changed.
    """
    changed = 0
    for q in range(n):
        k = index[q]
        p = psi[q]
        if out_status[k] != STATUS_INSIDE or not is_finite(p):
            continue
        px = xy[k, 0]
        py = xy[k, 1]
        vx = float(out_velocity[k, 0])
        vy = float(out_velocity[k, 1])
        touched = False
        for j in range(obstacles.shape[0]):
            psi_o = obstacles[j, OB_PSI]
            if not is_finite(psi_o):
                continue
            ax, ay, bx, by, r, reach = _hull_axis(obstacles, j)
            ex = bx - ax
            ey = by - ay
            len2 = ex * ex + ey * ey
            t = 0.0
            if len2 > 0.0:
                t = min(max(((px - ax) * ex + (py - ay) * ey) / len2, 0.0), 1.0)
            nx = px - (ax + t * ex)
            ny = py - (ay + t * ey)
            dist = math.sqrt(nx * nx + ny * ny)
            d = dist - r
            if d >= reach:
                continue
            touched = True
            cx = obstacles[j, OB_X]
            cy = obstacles[j, OB_Y]
            ux = obstacles[j, OB_VX]
            uy = obstacles[j, OB_VY]
            w = obstacles[j, OB_YAW_RATE]
            rx = px - cx
            ry = py - cy
            psi_r = uy * rx - ux * ry + 0.5 * w * (rx * rx + ry * ry)
            vrx = ux - w * ry
            vry = uy + w * rx
            if d <= 0.0 or dist == 0.0:
                p = psi_r + psi_o
                vx = vrx
                vy = vry
                continue
            s = d / reach
            m = 1.0 - s
            g = 1.0 - m * m * m
            dg = 3.0 * m * m / reach                  # dg/dd [1/m]
            delta = p - psi_r - psi_o
            nx /= dist
            ny /= dist
            vx = vrx + g * (vx - vrx) - delta * dg * ny
            vy = vry + g * (vy - vry) + delta * dg * nx
            p = psi_r + psi_o + delta * g
        if touched:
            psi[q] = p
            if is_finite(vx) and is_finite(vy):
                out_velocity[k, 0] = vx
                out_velocity[k, 1] = vy
            changed += 1
    return changed
