"""Foam carried by the particles: seed 001's flow force, computed from what the flow knows.

Each particle holds a foam amount in [0, 1] (pool column ``foam``; ``foam_id`` is the id whose
foam the slot holds, so a new particle in a reused slot is seen). :func:`update_foam` (glue:
:mod:`riverflow.systems.foam`), per particle in the water:

    target = clamp(base + k₁·steepness + k₂·distance + k₃·pressure, 0, 1)   (seed 001)

* **steepness**: the water surface's slope from the view's water-level tiles, 0 below
  ``steep_from`` (a lowland river), 1 from ``steep_full`` (a mountain stream, rapids);
* **distance**: the closeness to what the water runs along or past, the largest of
  - shores: shore × e^(−d / shore_m) × (shore_calm + (1 − shore_calm)·speed), d the distance
    to the nearest bank or island shore from the flow tiles' distance lattice
    (:func:`riverflow.kernels.flow.flow_details_at`),
  - hulls: (1 − d / (hull_beams·beam))² × min(U / hull_speed, 1) × the hull's foam knob, d
    the distance to the capsule hull, U its speed through the water,
  - the wash behind a hull: e^(−(d / w)²) × strength × the foam knob, d the distance to the
    boat's trail (:mod:`riverflow.kernels.wake`) where it is under ``wash_s`` old, w its
    half-width, strength its speed gate × fade with age;
* **pressure**: the water running into a shore (island noses, outer bends, a bifurcation's
  tip: −v·∇b / impinge_mps, fading over 2·shore_m from the shore; b the distance to the
  flow's nearest bank, which is d's but for a basin's open mouth, which b counts: the river
  runs along a harbour's mouth as along its bank, not into the basin's corner beyond it) or
  turning sharply (the strain rate of the velocity from the ψ bicubic's second derivatives,
  beyond a quarter of ``strain_ps``, × speed), or landing in a fall's plunge pool
  (:func:`riverflow.kernels.falls.plunge_closeness`);

speed = min(|v| / speed_mps, 1). Every frame the foam relaxes toward the target, foam +=
(target − foam)·(1 − e^(−dt/τ)), τ = rise_s going up and decay_s going down, so foam made at a
shore, an island's nose or in a boat's wash is carried downstream by the particles as a
streak (older wake foam is what the particles carry, not the trail). A new particle starts
with the mean foam of its established neighbours on screen (weighted like the sprites), or at
its target when it has none (then with the boats' whole trails as foam sources, not only
their wash: what particles there would carry after a camera cut), so refilling the screen
never punches holes in a streak (its own terms follow on its staggered schedule).
Particles out of the water have no foam. Nothing here is NaN: every input is checked.
"""
from __future__ import annotations

import math
from functools import lru_cache
from typing import NamedTuple

import numpy as np
from numba import njit

from riverflow.kernels._jit import JIT_OPTIONS, is_finite
from riverflow.kernels.falls import FallTable, plunge_closeness
from riverflow.kernels.flow import CachedTiles, flow_details_at
from riverflow.kernels.surface_tiles import water_slope_at
from riverflow.kernels.wake import TR_AGE, TR_ARC, TR_HALF_WIDTH, TR_STRENGTH, TR_X, TR_Y

STATUS_INSIDE = 1
STATUS_LEAVING = 2

HL_X, HL_Y, HL_HEADING, HL_LENGTH, HL_BEAM, HL_SPEED, HL_FOAM, HL_TRAIL = range(8)
"""Columns of FoamSources.hulls: x, y [m] of the hull centre, heading [rad], length, beam
[m], speed through the water [m/s], foam knob (× its hull and wash foam), row of its trail
in ``trails`` (−1: none)."""
HULL_FIELDS = 8
TRAIL_ALL_S = 1.0e9
"""``wash_s`` that takes a trail's every segment (:func:`wash_segments`)."""
STERN_FROM_BOW = 0.9
"""The wash's foam is full this many hull lengths behind the point the trail follows (the
bow: 0.4 L forward of the centre, :mod:`riverflow.systems.wake`), at the stern; it ramps in
from 0.6 L (beside the hull the hull term makes the foam)."""


class FoamParams(NamedTuple):
    """The knobs of :class:`riverflow.components.foam.FoamSettings` as the kernel reads them."""

    base: float
    k_steepness: float
    k_distance: float
    k_pressure: float
    shore: float
    shore_m: float
    shore_calm: float
    steep_from: float
    steep_full: float
    speed_mps: float
    impinge_mps: float
    strain_ps: float
    hull_beams: float
    hull_speed_mps: float
    wash_s: float
    rise_s: float
    decay_s: float


class FoamFlow(NamedTuple):
    """The flow tiles as foam reads them: the query view, the pool's distance lattices
    (P, n+3, n+3) float32 to the shore and to the flow's banks (a basin's mouth counted), the
    level a frame's queries start from with its fallback, and the field's falls (their plunge
    pools foam)."""

    tiles: CachedTiles
    shore: np.ndarray
    bank: np.ndarray
    level: int
    fallback: int
    falls: FallTable


class FoamSources(NamedTuple):
    """Hulls (H, HULL_FIELDS) float64 (columns HL_*) and wake trails (B, K, TR_FIELDS)
    float32 (:mod:`riverflow.kernels.wake`, TR_STRENGTH −1 past a trail's last point)."""

    hulls: np.ndarray
    trails: np.ndarray


class ScreenNeighbours(NamedTuple):
    """The screen grid of the Poisson maintenance: ``cell_px`` cells, gw × gh, each listing
    ``cell_count[c]`` slots in ``cell_items[c]``; ``radius_px`` the sprite radius (3r)."""

    cell_px: float
    gw: int
    gh: int
    cell_count: np.ndarray
    cell_items: np.ndarray
    radius_px: float


@njit(inline="always", **JIT_OPTIONS)
def _unit(v):
    """v clamped to [0, 1]; NaN → 0."""
    return min(max(v, 0.0), 1.0) if is_finite(v) else 0.0


@njit(inline="always", **JIT_OPTIONS)
def _segment_distance(px, py, ax, ay, bx, by):
    """(distance [m], t ∈ [0, 1]) from p to segment ab, t the closest point's parameter."""
    ex = bx - ax
    ey = by - ay
    e2 = ex * ex + ey * ey
    t = 0.0
    if e2 > 0.0:
        t = min(max(((px - ax) * ex + (py - ay) * ey) / e2, 0.0), 1.0)
    dx = px - (ax + t * ex)
    dy = py - (ay + t * ey)
    return math.sqrt(dx * dx + dy * dy), t


# -- the terms ------------------------------------------------------------------------------------

@njit(inline="always", **JIT_OPTIONS)
def flow_terms(x, y, vx, vy, params, flow, surface, patch):
    """The terms of the flow force that follow the river, not the boats, at a water particle
    at (x, y) [m] with velocity (vx, vy) [m/s]: (steepness, shore closeness, pressure), each
    in [0, 1] (module docstring). ``patch`` (4, 4) float64 scratch."""
    speed = _unit(math.sqrt(vx * vx + vy * vy) / params.speed_mps)
    found, shore, sx, sy, strain, _ = flow_details_at(x, y, flow.tiles, flow.level,
                                                      flow.fallback, flow.shore, flow.bank,
                                                      patch)
    shore_c = 0.0
    pressure = 0.0
    if found and is_finite(shore):
        d = max(shore, 0.0)
        shore_c = params.shore * math.exp(-d / params.shore_m) * (
            params.shore_calm + (1.0 - params.shore_calm) * speed)
        approach = -(vx * sx + vy * sy)            # [m/s] towards the nearest shore
        impinge = _unit(approach / params.impinge_mps) * math.exp(-d / (2.0 * params.shore_m))
        turn = _unit((strain - 0.25 * params.strain_ps) / (0.75 * params.strain_ps)) * speed
        pressure = max(impinge, turn)
    pressure = max(pressure, plunge_closeness(flow.falls, x, y))
    gx, gy = water_slope_at(surface, x, y)
    slope = math.sqrt(gx * gx + gy * gy)
    steep = _unit((slope - params.steep_from) / (params.steep_full - params.steep_from))
    return steep, _unit(shore_c), _unit(pressure)


HC_AX, HC_AY, HC_EX, HC_EY, HC_INV_E2, HC_RADIUS, HC_REACH, HC_GAIN, HC_BOUND2 = range(9)
HULL_CAPSULE_FIELDS = 9
"""Columns of the hull table (:func:`hull_capsules`): the capsule's axis start and direction
[m], 1/|e|², its radius and the foam's reach [m], its gain (speed factor × foam knob), and
the squared radius of a circle around it beyond which its foam is 0 [m²]."""


@njit(**JIT_OPTIONS)
def hull_capsules(hulls, hull_beams, hull_speed_mps, out):
    """The hulls (H, HULL_FIELDS) as capsules for :func:`hull_closeness` into ``out`` (≥ H,
    HULL_CAPSULE_FIELDS); returns how many (a hull with a non-finite value or no reach is
    left out)."""
    n = 0
    for h in range(hulls.shape[0]):
        beam = hulls[h, HL_BEAM]
        reach = hull_beams * beam
        r = 0.5 * beam
        half = 0.5 * hulls[h, HL_LENGTH]
        arm = max(half - r, 0.0)
        hx = arm * math.cos(hulls[h, HL_HEADING])
        hy = arm * math.sin(hulls[h, HL_HEADING])
        gain = _unit(hulls[h, HL_SPEED] / hull_speed_mps) * hulls[h, HL_FOAM]
        values = (hulls[h, HL_X], hulls[h, HL_Y], hx, hy, reach, gain)
        ok = reach > 0.0 and gain > 0.0
        for v in values:
            ok = ok and is_finite(v)
        if not ok:
            continue
        out[n, HC_AX] = hulls[h, HL_X] - hx
        out[n, HC_AY] = hulls[h, HL_Y] - hy
        out[n, HC_EX] = 2.0 * hx
        out[n, HC_EY] = 2.0 * hy
        out[n, HC_INV_E2] = 1.0 / (4.0 * (hx * hx + hy * hy)) if arm > 0.0 else 0.0
        out[n, HC_RADIUS] = r
        out[n, HC_REACH] = reach
        out[n, HC_GAIN] = gain
        out[n, HC_BOUND2] = (half + reach) * (half + reach)
        n += 1
    return n


@njit(inline="always", **JIT_OPTIONS)
def hull_closeness(px, py, caps, n_caps):
    """Max over the hull capsules (``caps[:n_caps]``, :func:`hull_capsules`) of
    (1 − d / reach)² × gain, d ≥ 0 the distance from p to the capsule (0 inside): the gain
    is min(U / hull_speed, 1) × the foam knob, U the hull's speed through the water."""
    best = 0.0
    for h in range(n_caps):
        rx = px - caps[h, HC_AX]
        ry = py - caps[h, HC_AY]
        ex = caps[h, HC_EX]
        ey = caps[h, HC_EY]
        cx = rx - 0.5 * ex
        cy = ry - 0.5 * ey
        if not cx * cx + cy * cy < caps[h, HC_BOUND2]:
            continue
        t = min(max((rx * ex + ry * ey) * caps[h, HC_INV_E2], 0.0), 1.0)
        dx = rx - t * ex
        dy = ry - t * ey
        d = max(math.sqrt(dx * dx + dy * dy) - caps[h, HC_RADIUS], 0.0)
        reach = caps[h, HC_REACH]
        if d >= reach:
            continue
        c = 1.0 - d / reach
        c = c * c * caps[h, HC_GAIN]
        if c > best:
            best = c
    return best


WS_AX, WS_AY, WS_EX, WS_EY, WS_INV_E2 = range(5)
WS_ARC0, WS_DARC, WS_W0, WS_DW, WS_S0, WS_DS, WS_AGE0, WS_DAGE = range(5, 13)
WS_START, WS_FULL, WS_GAIN = range(13, 16)
WS_X0, WS_Y0, WS_X1, WS_Y1 = range(16, 20)
WASH_FIELDS = 20
"""Columns of the wash segments table (:func:`wash_segments`): start point and direction
[m], 1/|e|²; arc length, half-width, strength and age at the start and their changes along
it; where the wash ramps in and is full (arc [m]) and the foam knob; its bounding box widened
by 3 half-widths [m]."""


@njit(**JIT_OPTIONS)
def wash_segments(hulls, trails, wash_s, out):
    """The segments of every hull's trail up to ``wash_s`` old that make foam (strength > 0
    at an end), one row each of ``out`` (≥ H·(K−1), WASH_FIELDS) float64; returns their
    number. Hull h's wash ramps in from 0.6 hull lengths behind its bow and is full from
    STERN_FROM_BOW (beside the hull its own term makes the foam)."""
    n = 0
    for h in range(hulls.shape[0]):
        b = int(hulls[h, HL_TRAIL])
        if b < 0 or b >= trails.shape[0]:
            continue
        for j in range(trails.shape[1] - 1):
            if n >= out.shape[0]:
                return n
            s0 = trails[b, j, TR_STRENGTH]
            s1 = trails[b, j + 1, TR_STRENGTH]
            if s0 < 0.0 or s1 < 0.0 or trails[b, j, TR_AGE] > wash_s:
                break
            if s0 <= 0.0 and s1 <= 0.0:
                continue
            ax = trails[b, j, TR_X]
            ay = trails[b, j, TR_Y]
            ex = trails[b, j + 1, TR_X] - ax
            ey = trails[b, j + 1, TR_Y] - ay
            e2 = ex * ex + ey * ey
            w0 = trails[b, j, TR_HALF_WIDTH]
            w1 = trails[b, j + 1, TR_HALF_WIDTH]
            if not (w0 > 0.0 and w1 > 0.0):
                continue
            reach = 3.0 * max(w0, w1)
            out[n, WS_AX] = ax
            out[n, WS_AY] = ay
            out[n, WS_EX] = ex
            out[n, WS_EY] = ey
            out[n, WS_INV_E2] = 1.0 / e2 if e2 > 0.0 else 0.0
            out[n, WS_ARC0] = trails[b, j, TR_ARC]
            out[n, WS_DARC] = trails[b, j + 1, TR_ARC] - trails[b, j, TR_ARC]
            out[n, WS_W0] = w0
            out[n, WS_DW] = w1 - w0
            out[n, WS_S0] = s0
            out[n, WS_DS] = s1 - s0
            out[n, WS_AGE0] = trails[b, j, TR_AGE]
            out[n, WS_DAGE] = trails[b, j + 1, TR_AGE] - trails[b, j, TR_AGE]
            out[n, WS_START] = 0.6 * hulls[h, HL_LENGTH]
            out[n, WS_FULL] = STERN_FROM_BOW * hulls[h, HL_LENGTH]
            out[n, WS_GAIN] = hulls[h, HL_FOAM]
            out[n, WS_X0] = min(ax, ax + ex) - reach
            out[n, WS_Y0] = min(ay, ay + ey) - reach
            out[n, WS_X1] = max(ax, ax + ex) + reach
            out[n, WS_Y1] = max(ay, ay + ey) + reach
            n += 1
    return n


@njit(inline="always", **JIT_OPTIONS)
def wash_closeness(px, py, wash, n_wash, wash_s):
    """Closeness of p to the wash behind the hulls: max over the wash segments (``wash[:n]``,
    :func:`wash_segments`) of e^(−(d / w)²) × strength × the foam knob × the ramp in behind
    the bow × a fade over the wash's last quarter of ``wash_s``; d the distance from p to the
    segment, w, strength and age interpolated at its closest point."""
    best = 0.0
    for k in range(n_wash):
        if not (wash[k, WS_X0] <= px <= wash[k, WS_X1] and wash[k, WS_Y0] <= py <= wash[k, WS_Y1]):
            continue
        rx = px - wash[k, WS_AX]
        ry = py - wash[k, WS_AY]
        ex = wash[k, WS_EX]
        ey = wash[k, WS_EY]
        t = min(max((rx * ex + ry * ey) * wash[k, WS_INV_E2], 0.0), 1.0)
        arc = wash[k, WS_ARC0] + t * wash[k, WS_DARC]
        start = wash[k, WS_START]
        if arc <= start:
            continue
        dx = rx - t * ex
        dy = ry - t * ey
        w = wash[k, WS_W0] + t * wash[k, WS_DW]
        q2 = (dx * dx + dy * dy) / (w * w)
        if q2 > 9.0:
            continue
        ramp = min((arc - start) / max(wash[k, WS_FULL] - start, 1e-6), 1.0)
        age = wash[k, WS_AGE0] + t * wash[k, WS_DAGE]
        tail = _unit(1.0 - (age - 0.75 * wash_s) / (0.25 * wash_s))
        c = (math.exp(-q2) * (wash[k, WS_S0] + t * wash[k, WS_DS]) * wash[k, WS_GAIN]
             * ramp * ramp * tail)
        if c > best:
            best = c
    return best


@njit(**JIT_OPTIONS)
def moving_box(hulls, hull_beams, wash, n_wash, out):
    """The box (xmin, ymin, xmax, ymax) [m] into ``out`` (4,) outside which every hull and
    wash term is 0 (empty when there is none)."""
    out[0] = np.inf
    out[1] = np.inf
    out[2] = -np.inf
    out[3] = -np.inf
    for h in range(hulls.shape[0]):
        reach = 0.5 * hulls[h, HL_LENGTH] + hull_beams * hulls[h, HL_BEAM]
        out[0] = min(out[0], hulls[h, HL_X] - reach)
        out[1] = min(out[1], hulls[h, HL_Y] - reach)
        out[2] = max(out[2], hulls[h, HL_X] + reach)
        out[3] = max(out[3], hulls[h, HL_Y] + reach)
    for k in range(n_wash):
        out[0] = min(out[0], wash[k, WS_X0])
        out[1] = min(out[1], wash[k, WS_Y0])
        out[2] = max(out[2], wash[k, WS_X1])
        out[3] = max(out[3], wash[k, WS_Y1])


@njit(**JIT_OPTIONS)
def moving_closeness(x, y, caps, n_caps, wash, n_wash, wash_s):
    """Closeness of (x, y) [m] to the hulls (:func:`hull_capsules`) and the wash behind them
    (:func:`wash_segments`), in [0, 1]."""
    c = hull_closeness(x, y, caps, n_caps)
    if n_wash:
        c = max(c, wash_closeness(x, y, wash, n_wash, wash_s))
    return _unit(c)


@njit(**JIT_OPTIONS)
def moving_sources(sources, params):
    """(capsules, their number, wash segments, their number) of the frame's hulls and wash
    (:func:`hull_capsules`, :func:`wash_segments`)."""
    hulls = sources.hulls
    caps = np.empty((hulls.shape[0], HULL_CAPSULE_FIELDS))
    n_caps = hull_capsules(hulls, params.hull_beams, params.hull_speed_mps, caps)
    wash = np.empty((hulls.shape[0] * max(sources.trails.shape[1] - 1, 0), WASH_FIELDS))
    n_wash = wash_segments(hulls, sources.trails, params.wash_s, wash)
    return caps, n_caps, wash, n_wash


@njit(**JIT_OPTIONS)
def foam_target(x, y, vx, vy, params, flow, surface, sources, patch):
    """Seed 001's flow force at a water particle at (x, y) [m] with velocity (vx, vy) [m/s],
    clamped to [0, 1] (module docstring), from scratch (for tests and tools; the frame's
    kernel keeps the river's terms and the wash table between calls). Returns (target,
    steepness, distance, pressure)."""
    steep, shore_c, pressure = flow_terms(x, y, vx, vy, params, flow, surface, patch)
    caps, n_caps, wash, n_wash = moving_sources(sources, params)
    distance = max(shore_c, moving_closeness(x, y, caps, n_caps, wash, n_wash, params.wash_s))
    target = _unit(params.base + params.k_steepness * steep + params.k_distance * distance
                   + params.k_pressure * pressure)
    return target, steep, distance, pressure


# -- new particles ------------------------------------------------------------------------------

@njit(inline="always", **JIT_OPTIONS)
def _fade5(t):
    t = min(max(t, 0.0), 1.0)
    return t * t * t * (t * (t * 6.0 - 15.0) + 10.0)


@njit(**JIT_OPTIONS)
def inherit_foam(i, screen_px, foam, foam_flow, foam_shore, foam_near, foam_id, ids, alive,
                 status, intensity, grid):
    """Give new particle i the foam of the established water particles around it on screen
    (``foam_id`` = their id) within ``grid.radius_px``, weighted like the sprites
    (fade5(1 − distance / radius) × intensity, at least 0.05 of it): its foam and its kept
    terms (``foam_flow``, ``foam_shore``, ``foam_near``) become their weighted means, until
    its own are computed. Returns False (nothing written) when it has no such neighbour."""
    x = screen_px[i, 0]
    y = screen_px[i, 1]
    reach = grid.radius_px
    if not (is_finite(x) and is_finite(y)) or not (grid.cell_px > 0.0 and reach > 0.0):
        return False
    cx0 = min(max(int(math.floor((x - reach) / grid.cell_px)), 0), grid.gw - 1)
    cx1 = min(max(int(math.floor((x + reach) / grid.cell_px)), 0), grid.gw - 1)
    cy0 = min(max(int(math.floor((y - reach) / grid.cell_px)), 0), grid.gh - 1)
    cy1 = min(max(int(math.floor((y + reach) / grid.cell_px)), 0), grid.gh - 1)
    total = 0.0
    a_foam = 0.0
    a_flow = 0.0
    a_shore = 0.0
    a_near = 0.0
    for cy in range(cy0, cy1 + 1):
        for cx in range(cx0, cx1 + 1):
            c = cy * grid.gw + cx
            if c >= grid.cell_count.shape[0]:
                continue
            for q in range(min(grid.cell_count[c], grid.cell_items.shape[1])):
                j = grid.cell_items[c, q]
                if j == i or j < 0 or j >= alive.shape[0] or not alive[j]:
                    continue
                if foam_id[j] != ids[j]:
                    continue
                s = status[j]
                if s != STATUS_INSIDE and s != STATUS_LEAVING:
                    continue
                dx = screen_px[j, 0] - x
                dy = screen_px[j, 1] - y
                d2 = dx * dx + dy * dy
                if not d2 < reach * reach:
                    continue
                w = _fade5(1.0 - math.sqrt(d2) / reach) * max(intensity[j], 0.05)
                total += w
                a_foam += w * foam[j]
                a_flow += w * foam_flow[j]
                a_shore += w * foam_shore[j]
                a_near += w * foam_near[j]
    if not total > 0.0:
        return False
    foam[i] = _unit(a_foam / total)
    foam_flow[i] = a_flow / total
    foam_shore[i] = _unit(a_shore / total)
    foam_near[i] = _unit(a_near / total)
    return True


# -- the frame ------------------------------------------------------------------------------------

@njit(inline="always", **JIT_OPTIONS)
def _river_terms(i, params, flow, surface, patch, world_m, velocity_mps, foam_flow,
                 foam_shore):
    steep, shore_c, pressure = flow_terms(world_m[i, 0], world_m[i, 1], velocity_mps[i, 0],
                                          velocity_mps[i, 1], params, flow, surface, patch)
    foam_flow[i] = params.base + params.k_steepness * steep + params.k_pressure * pressure
    foam_shore[i] = shore_c


@njit(**JIT_OPTIONS)
def update_foam(n_slots, pool, params, flow, surface, sources, grid, dt_s, frame, every,
                near_every, scratch):
    """One frame of foam (module docstring) of the particles of ``pool``
    (:class:`~riverflow.kernels.lifecycle.Pool`): half the slots below ``n_slots`` are updated,
    the lower half on even frames and the upper half on odd ones, each over two frames'
    time (2·``dt_s`` [s]): the foam's time constants are tenths of seconds, and a pass over
    half the pool costs half as much memory traffic.

    The river's terms change slowly along a particle's path: every ``every`` frames (a power
    of two ≥ 2, staggered by slot; at once for a new particle with no neighbour) they are
    kept in ``foam_flow`` (base + k₁·steepness + k₃·pressure) and ``foam_shore`` (the shore
    closeness), (C,) float32. Hulls and their wash move fast: a particle inside their box
    (:func:`moving_box`) asks for its closeness to them every ``near_every`` frames (a power
    of two ≥ 2, staggered), kept in ``foam_near``; outside the box that is 0. Then target =
    clamp(foam_flow + k₂·max(foam_shore, foam_near), 0, 1), and the foam relaxes toward it.
    A slot whose ``foam_id`` is not its particle's id holds a new particle: it inherits
    (:func:`inherit_foam`) and ``foam_id`` is set. ``scratch`` (C,) int32. Returns (river
    terms computed, hull terms computed, new particles).
    """
    alive, ids, has_world, status = pool.alive, pool.ids, pool.has_world, pool.status
    world_m, velocity_mps, screen_px = pool.world_m, pool.velocity_mps, pool.screen_px
    intensity, foam, foam_flow = pool.intensity, pool.foam, pool.foam_flow
    foam_shore, foam_near, foam_id = pool.foam_shore, pool.foam_near, pool.foam_id
    n = min(n_slots, alive.shape[0])
    half = (n + 1) // 2
    lo = 0 if frame % 2 == 0 else half
    hi = half if frame % 2 == 0 else n
    visit = frame // 2
    every = max(every // 2, 1)             # in visits (one every two frames)
    near_every = max(near_every // 2, 1)
    hulls = sources.hulls
    caps, n_caps, wash, n_wash = moving_sources(sources, params)
    box = np.empty(4)
    moving_box(hulls, params.hull_beams, wash, n_wash, box)
    bx0, by0, bx1, by1 = box[0], box[1], box[2], box[3]
    wash_s = params.wash_s
    k_distance = params.k_distance
    patch = np.empty((4, 4))
    dt = 2.0 * dt_s if is_finite(dt_s) and dt_s > 0.0 else 0.0
    rise = 1.0 - math.exp(-dt / params.rise_s)
    decay = 1.0 - math.exp(-dt / params.decay_s)
    computed = 0
    moved = 0
    n_new = 0
    for i in range(lo, hi):
        if not alive[i]:
            continue
        s = status[i]
        if not (has_world[i] and (s == STATUS_INSIDE or s == STATUS_LEAVING)):
            if foam_id[i] != -1 or foam[i] != 0.0:   # not drawn; back in the water it
                foam[i] = 0.0                         # starts afresh (inherits)
                foam_id[i] = -1
            continue
        if foam_id[i] != ids[i]:
            scratch[n_new] = i
            n_new += 1
            continue
        if (i + visit) & (every - 1) == 0:
            _river_terms(i, params, flow, surface, patch, world_m, velocity_mps, foam_flow,
                         foam_shore)
            computed += 1
        x = world_m[i, 0]
        y = world_m[i, 1]
        near = foam_near[i]
        if not (bx0 <= x <= bx1 and by0 <= y <= by1):
            if near != 0.0:
                near = 0.0
                foam_near[i] = near
        elif (i + visit) & (near_every - 1) == 0:
            near = moving_closeness(x, y, caps, n_caps, wash, n_wash, wash_s)
            foam_near[i] = near
            moved += 1
        target = _unit(foam_flow[i] + k_distance * max(foam_shore[i], near))
        f = foam[i]
        f += (target - f) * (rise if target > f else decay)
        foam[i] = _unit(f)              # a NaN that got in goes back to 0
    trail = np.empty((0, WASH_FIELDS))
    n_trail = -1
    for k in range(n_new):     # new particles: their neighbours' foam, else their own
        i = scratch[k]
        if inherit_foam(i, screen_px, foam, foam_flow, foam_shore, foam_near, foam_id, ids,
                        alive, status, intensity, grid):
            continue
        _river_terms(i, params, flow, surface, patch, world_m, velocity_mps, foam_flow,
                     foam_shore)
        x = world_m[i, 0]
        y = world_m[i, 1]
        foam_near[i] = moving_closeness(x, y, caps, n_caps, wash, n_wash, wash_s)
        computed += 1
        # one with no neighbour (the view cut to new water) starts with the foam the particles
        # there would carry: that of the boats' whole trails, not only their wash
        if n_trail < 0:
            trail = np.empty((wash.shape[0], WASH_FIELDS))
            n_trail = wash_segments(hulls, sources.trails, TRAIL_ALL_S, trail)
        along = wash_closeness(x, y, trail, n_trail, TRAIL_ALL_S) if n_trail else 0.0
        foam[i] = _unit(foam_flow[i] + params.k_distance * max(foam_shore[i], foam_near[i],
                                                               along))
    for k in range(n_new):
        i = scratch[k]
        foam_id[i] = ids[i]
    return computed, moved, n_new



# -- the foam texture the water shader blends ------------------------------------------------------

def foam_pattern(size: int = 256, seed: int = 0) -> np.ndarray:
    """A periodic foam texture (size, size, 2) float32, one pattern per channel, each with
    values spread evenly over [0, 1] (so that showing it where it exceeds 1 − f covers about
    a fraction f): the lace of cellular (Worley) noise, F₂ − F₁ small near the cells' edges,
    over two scales, with a finer bubbly F₁ term; channel 1 is another draw of the same
    recipe (the shader slides one over the other: the foam churns). Plain numpy, made once."""
    rng = np.random.default_rng([int(seed), 1001])
    channels = []
    for _ in range(2):
        lace = np.zeros((size, size))
        for cells, weight, kind in ((6, 0.45, "lace"), (14, 0.35, "lace"), (32, 0.2, "bubbles")):
            f1, f2 = _worley(size, cells, rng)
            if kind == "lace":
                lace += weight * np.exp(-((f2 - f1) / 0.18) ** 2)
            else:
                lace += weight * (1.0 - np.clip(f1 / 0.7, 0.0, 1.0)) ** 2
        flat = lace.ravel()
        rank = np.empty(flat.size)
        rank[np.argsort(flat, kind="stable")] = (np.arange(flat.size) + 0.5) / flat.size
        channels.append(rank.reshape(size, size))
    return np.stack(channels, axis=-1).astype(np.float32)


@lru_cache(maxsize=4)
def foam_pattern_mips(size: int = 256, seed: int = 0) -> tuple[np.ndarray, ...]:
    """:func:`mip_chain` of :func:`foam_pattern`, read-only, made once a process for each
    (size, seed): every drawn world's texture (0.3 s of CPU to make)."""
    levels = tuple(mip_chain(foam_pattern(size, seed)))
    for level in levels:
        level.flags.writeable = False
    return levels


def _worley(size: int, cells: int, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """(F₁, F₂) (size, size): distances, in cell units, from each texel to the nearest and
    second nearest of one random point per cell of a cells × cells periodic grid."""
    points = rng.random((cells, cells, 2))
    u = (np.arange(size) + 0.5) * cells / size
    gx, gy = np.meshgrid(u, u)
    cx = np.floor(gx).astype(int)
    cy = np.floor(gy).astype(int)
    d = []
    for oy in (-1, 0, 1):
        for ox in (-1, 0, 1):
            nx = cx + ox
            ny = cy + oy
            p = points[ny % cells, nx % cells]
            d.append(np.hypot(nx + p[..., 0] - gx, ny + p[..., 1] - gy))
    d = np.sort(np.stack(d), axis=0)
    return d[0], d[1]


def mip_chain(image: np.ndarray) -> list[np.ndarray]:
    """``image`` (S, S, C) and its 2 × 2 box-filtered halvings down to 1 × 1 (S a power of
    two)."""
    levels = [np.ascontiguousarray(image, np.float32)]
    while levels[-1].shape[0] > 1:
        a = levels[-1]
        levels.append(np.ascontiguousarray(
            0.25 * (a[0::2, 0::2] + a[1::2, 0::2] + a[0::2, 1::2] + a[1::2, 1::2]), np.float32))
    return levels
