"""Plain-numpy twins of riverflow.kernels.foam: slow, obvious, the specification of each.

The river's terms need the flow tiles and the surface tiles; the twin of the frame
(:func:`update_foam`) takes them from a callable, so that a test can give it the kernel's own
terms (tested on their own against exact geometry, finite differences and the twin formula
:func:`flow_terms`)."""
from __future__ import annotations

import math

import numpy as np

from riverflow.kernels.foam import (HL_BEAM, HL_FOAM, HL_HEADING, HL_LENGTH, HL_SPEED,
                                    HL_TRAIL, HL_X, HL_Y, STERN_FROM_BOW)
from riverflow.kernels.wake import TR_AGE, TR_ARC, TR_HALF_WIDTH, TR_STRENGTH, TR_X, TR_Y

INSIDE, LEAVING = 1, 2


def unit(v: float) -> float:
    """v clamped to [0, 1]; NaN and ±inf → 0."""
    return min(max(float(v), 0.0), 1.0) if math.isfinite(v) else 0.0


def flow_terms(found, shore, sx, sy, strain, slope, vx, vy, p, plunge=0.0
               ) -> tuple[float, float, float]:
    """(steepness, shore closeness, pressure) from what the tiles say at a particle: found
    (a tile answered), shore distance and gradient, strain rate, water-surface slope, and
    its plunge-pool closeness (``plunge``: tests/hydro/test_falls.py has its twin)."""
    speed = unit(math.hypot(vx, vy) / p.speed_mps)
    shore_c = pressure = 0.0
    if found and math.isfinite(shore):
        d = max(shore, 0.0)
        shore_c = p.shore * math.exp(-d / p.shore_m) * (p.shore_calm
                                                         + (1 - p.shore_calm) * speed)
        impinge = unit(-(vx * sx + vy * sy) / p.impinge_mps) * math.exp(-d / (2 * p.shore_m))
        turn = unit((strain - 0.25 * p.strain_ps) / (0.75 * p.strain_ps)) * speed
        pressure = max(impinge, turn)
    pressure = max(pressure, plunge)
    steep = unit((slope - p.steep_from) / (p.steep_full - p.steep_from))
    return steep, unit(shore_c), unit(pressure)


def hull_closeness(x, y, hulls, p) -> float:
    best = 0.0
    for h in hulls:
        reach = p.hull_beams * h[HL_BEAM]
        if not reach > 0:
            continue
        r = 0.5 * h[HL_BEAM]
        arm = max(0.5 * h[HL_LENGTH] - r, 0.0)
        f = np.array([math.cos(h[HL_HEADING]), math.sin(h[HL_HEADING])])
        c = np.array([h[HL_X], h[HL_Y]])
        d = max(_segment_distance(np.array([x, y]), c - arm * f, c + arm * f)[0] - r, 0.0)
        if d < reach:
            best = max(best, (1 - d / reach) ** 2 * unit(h[HL_SPEED] / p.hull_speed_mps)
                       * h[HL_FOAM])
    return best


def _segment_distance(q, a, b) -> tuple[float, float]:
    e = b - a
    e2 = float(e @ e)
    t = min(max(float((q - a) @ e) / e2, 0.0), 1.0) if e2 > 0 else 0.0
    return float(np.hypot(*(q - (a + t * e)))), t


def wash_closeness(x, y, hulls, trails, p) -> float:
    """The wash term: every trail segment up to wash_s old whose ends are not both still."""
    best = 0.0
    q = np.array([x, y])
    for h in hulls:
        b = int(h[HL_TRAIL])
        if not 0 <= b < len(trails):
            continue
        start, full = 0.6 * h[HL_LENGTH], STERN_FROM_BOW * h[HL_LENGTH]
        tr = trails[b].astype(np.float64)
        for j in range(len(tr) - 1):
            s0, s1 = tr[j, TR_STRENGTH], tr[j + 1, TR_STRENGTH]
            if s0 < 0 or s1 < 0 or tr[j, TR_AGE] > p.wash_s:
                break
            if s0 <= 0 and s1 <= 0:
                continue
            w0, w1 = tr[j, TR_HALF_WIDTH], tr[j + 1, TR_HALF_WIDTH]
            if not (w0 > 0 and w1 > 0):
                continue
            d, t = _segment_distance(q, tr[j, [TR_X, TR_Y]], tr[j + 1, [TR_X, TR_Y]])
            arc = (1 - t) * tr[j, TR_ARC] + t * tr[j + 1, TR_ARC]
            w = (1 - t) * w0 + t * w1
            if arc <= start or d / w > 3.0:
                continue
            ramp = min((arc - start) / max(full - start, 1e-6), 1.0)
            age = (1 - t) * tr[j, TR_AGE] + t * tr[j + 1, TR_AGE]
            tail = unit(1 - (age - 0.75 * p.wash_s) / (0.25 * p.wash_s))
            best = max(best, math.exp(-(d / w) ** 2) * ((1 - t) * s0 + t * s1) * h[HL_FOAM]
                       * ramp ** 2 * tail)
    return best


def moving_closeness(x, y, hulls, trails, p) -> float:
    if not len(hulls):
        return 0.0
    return unit(max(hull_closeness(x, y, hulls, p), wash_closeness(x, y, hulls, trails, p)))


def _fade5(t):
    t = min(max(t, 0.0), 1.0)
    return t * t * t * (t * (t * 6 - 15) + 10)


def inherited(i, pool, established, radius_px):
    """(foam, flow, shore, near) weighted means over the established water particles within
    ``radius_px`` of particle i on screen, or None."""
    total, acc = 0.0, np.zeros(4)
    for j in np.flatnonzero(established):
        if j == i:
            continue
        d = float(np.hypot(*(pool.screen_px[j].astype(np.float64) - pool.screen_px[i])))
        if d < radius_px:
            w = _fade5(1 - d / radius_px) * max(float(pool.intensity[j]), 0.05)
            total += w
            acc += w * np.array([pool.foam[j], pool.foam_flow[j], pool.foam_shore[j],
                                 pool.foam_near[j]], np.float64)
    return None if total <= 0 else acc / total


def update_foam(pool, n_slots, river_terms, hulls, trails, p, radius_px, dt_s, frame, every,
                near_every):
    """Twin of ``update_foam`` on a :class:`ParticlePool` (in place); ``river_terms(i)`` →
    (steepness, shore closeness, pressure) of particle i. Every established neighbour is a
    candidate for inheritance (the kernel's screen grid lists them all within the radius)."""
    n = min(n_slots, len(pool.alive))
    half = (n + 1) // 2
    lo, hi = (0, half) if frame % 2 == 0 else (half, n)
    visit, every, near_every = frame // 2, max(every // 2, 1), max(near_every // 2, 1)
    dt = 2 * dt_s if math.isfinite(dt_s) and dt_s > 0 else 0.0
    rise, decay = 1 - math.exp(-dt / p.rise_s), 1 - math.exp(-dt / p.decay_s)
    # one box around the hulls and the segments of their wash
    box = [np.inf, np.inf, -np.inf, -np.inf]
    for b in [_hull_box(h, p) for h in hulls] + _wash_boxes(hulls, trails, p):
        box = [min(box[0], b[0]), min(box[1], b[1]), max(box[2], b[2]), max(box[3], b[3])]
    new = []

    def terms(i):
        steep, shore_c, pressure = river_terms(i)
        pool.foam_flow[i] = p.base + p.k_steepness * steep + p.k_pressure * pressure
        pool.foam_shore[i] = shore_c

    for i in range(lo, hi):
        if not pool.alive[i]:
            continue
        water = pool.has_world[i] and pool.status[i] in (INSIDE, LEAVING)
        if not water:
            if pool.foam_id[i] != -1 or pool.foam[i] != 0.0:
                pool.foam[i] = 0.0
                pool.foam_id[i] = -1
            continue
        if pool.foam_id[i] != pool.ids[i]:
            new.append(i)
            continue
        if (i + visit) % every == 0:
            terms(i)
        x, y = pool.world_m[i, :2]
        if not (box[0] <= x <= box[2] and box[1] <= y <= box[3]):
            pool.foam_near[i] = 0.0
        elif (i + visit) % near_every == 0:
            pool.foam_near[i] = moving_closeness(x, y, hulls, trails, p)
        target = unit(pool.foam_flow[i] + p.k_distance * max(pool.foam_shore[i],
                                                             pool.foam_near[i]))
        f = float(pool.foam[i]) if math.isfinite(pool.foam[i]) else 0.0
        f += (target - f) * (rise if target > f else decay)
        pool.foam[i] = unit(f)
    established = ((pool.foam_id == pool.ids) & pool.alive
                   & np.isin(pool.status, [INSIDE, LEAVING]))
    for i in new:
        got = inherited(i, pool, established, radius_px)
        if got is not None:
            pool.foam[i] = unit(got[0])
            pool.foam_flow[i] = got[1]
            pool.foam_shore[i] = unit(got[2])
            pool.foam_near[i] = unit(got[3])
            continue
        terms(i)
        pool.foam_near[i] = moving_closeness(*pool.world_m[i, :2], hulls, trails, p)
        whole = wash_closeness(*pool.world_m[i, :2], hulls, trails, p._replace(wash_s=1.0e9)) \
            if len(hulls) else 0.0
        pool.foam[i] = unit(pool.foam_flow[i] + p.k_distance * max(pool.foam_shore[i],
                                                                  pool.foam_near[i], whole))
    for i in new:
        pool.foam_id[i] = pool.ids[i]


def _hull_box(h, p):
    r = 0.5 * h[HL_LENGTH] + p.hull_beams * h[HL_BEAM]
    return (h[HL_X] - r, h[HL_Y] - r, h[HL_X] + r, h[HL_Y] + r)


def _wash_boxes(hulls, trails, p):
    """The boxes of the wash segments that make foam (ends widened by 3 half-widths)."""
    out = []
    for h in hulls:
        b = int(h[HL_TRAIL])
        if not 0 <= b < len(trails):
            continue
        tr = trails[b].astype(np.float64)
        for j in range(len(tr) - 1):
            s0, s1 = tr[j, TR_STRENGTH], tr[j + 1, TR_STRENGTH]
            if s0 < 0 or s1 < 0 or tr[j, TR_AGE] > p.wash_s:
                break
            w0, w1 = tr[j, TR_HALF_WIDTH], tr[j + 1, TR_HALF_WIDTH]
            if (s0 <= 0 and s1 <= 0) or not (w0 > 0 and w1 > 0):
                continue
            r = 3 * max(w0, w1)
            xs, ys = tr[j:j + 2, TR_X], tr[j:j + 2, TR_Y]
            out.append((xs.min() - r, ys.min() - r, xs.max() + r, ys.max() + r))
    return out
