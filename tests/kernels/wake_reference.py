"""Plain-numpy twin of ``shaders/wake.glsl``: the Kelvin wake's slopes at world points,
written for clarity; the specification of the shader, checked against it through a probe
(tests/render/test_foam_wake_render.py). The shader works one point at a time; here every
step is the same formula applied to all points at once (arrays over points, and over trail
segments for the nearest-point search), with masks where the shader returns early."""
from __future__ import annotations

import math

import numpy as np

from riverflow.kernels.wake import TR_ARC, TR_SLOPE, TR_SPEED, TR_STRENGTH, TR_X, TR_Y

G = 9.81
CUSP = 1.0 / math.sqrt(8.0)          # tan(19.47°)
TRANSVERSE = 0.55


def _smoothstep(e0, e1, x):
    t = np.clip((x - e0) / (e1 - e0), 0.0, 1.0)
    return t * t * (3.0 - 2.0 * t)


def _wave(t, X, Y, k0, px_m):
    """One family of waves (direction tan φ = t) at each point: its slope (N, 2) in the
    wake's (back, port) frame, 0 where shorter than a few pixels."""
    c2 = 1.0 + t * t
    k = k0 * c2
    visible = np.clip((2.0 * math.pi / (k * np.maximum(px_m, 1e-4)) - 3.0) / 3.0, 0.0, 1.0)
    phase = k0 * (X + Y * t) * np.sqrt(c2)
    w = (visible * np.sin(phase))[:, None] * np.stack([np.ones_like(t), t], 1) \
        / np.sqrt(c2)[:, None]
    return np.where((visible > 0.0)[:, None], w, 0.0)


def nearest_on_trail(points, trail):
    """At the trail point nearest each of ``points`` (N, 2): (X, Y, U, strength, back (N, 2),
    port (N, 2), slope, past), each (N,) unless said: distance along the trail from the bow,
    signed distance (+ to port of the boat's motion), speed, strength and wave slope there,
    the unit vectors behind the boat and to its port, and how far the point lies beyond the
    trail's oldest point (0 unless that is the nearest). The first segment wins a tie, as in
    the shader; a point with no segment (a trail of one point) gets strength 0."""
    p = np.asarray(points, np.float64).reshape(-1, 2)
    n = len(p)
    # the trail's points up to the first unused one (arc < 0): segments j = 1..last
    count = 1
    while count < len(trail) and trail[count, TR_ARC] >= 0.0:
        count += 1
    last = count - 1
    a, q = trail[:count - 1], trail[1:count]                       # (S, F) segment ends
    e = q[:, [TR_X, TR_Y]] - a[:, [TR_X, TR_Y]]                    # (S, 2) from newer to older
    len2 = e[:, 0] * e[:, 0] + e[:, 1] * e[:, 1]
    ok = len2 > 1e-8                                               # degenerate ones skipped
    safe = np.where(ok, len2, 1.0)
    # every point against every segment: (N, S)
    rx = p[:, 0, None] - a[None, :, TR_X]
    ry = p[:, 1, None] - a[None, :, TR_Y]
    s = np.clip((rx * e[:, 0] + ry * e[:, 1]) / safe, 0.0, 1.0)
    dx = p[:, 0, None] - (a[None, :, TR_X] + s * e[:, 0])
    dy = p[:, 1, None] - (a[None, :, TR_Y] + s * e[:, 1])
    dist2 = np.where(ok, dx * dx + dy * dy, np.inf)
    # the nearest segment: argmin takes the first of equal distances (the shader's strict <)
    best = np.argmin(dist2, axis=1) if len(a) else np.zeros(n, int)
    rows = np.arange(n)
    found = np.isfinite(dist2[rows, best]) if len(a) else np.zeros(n, bool)
    if not found.any():
        zero, zero2 = np.zeros(n), np.zeros((n, 2))
        return zero, zero, zero, zero, zero2, zero2, zero, zero
    sb = s[rows, best]
    d = np.stack([dx[rows, best], dy[rows, best]], 1)
    u = e[best] / np.sqrt(safe[best])[:, None]
    port = np.stack([u[:, 1], -u[:, 0]], 1)
    a_b, q_b = a[best], q[best]

    def mix(c):
        return np.where(found, (1 - sb) * a_b[:, c] + sb * q_b[:, c], 0.0)

    along = d[:, 0] * u[:, 0] + d[:, 1] * u[:, 1]
    past = np.where((sb >= 1.0) & (best + 1 == last), np.maximum(along, 0.0), 0.0)
    Y = d[:, 0] * port[:, 0] + d[:, 1] * port[:, 1]
    return (mix(TR_ARC), np.where(found, Y, 0.0), mix(TR_SPEED), mix(TR_STRENGTH),
            np.where(found[:, None], u, 0.0), np.where(found[:, None], port, 0.0),
            mix(TR_SLOPE), np.where(found, past, 0.0))


BREAK = 0.35


def wake_slopes(points, table, count, px_m, crest=None):
    """d(height)/d(x, y) (N, 2) of the wakes of ``table[:count]`` (B, K, TR_FIELDS) at
    ``points`` (N, 2) [m]; ``px_m`` (N,) or a scalar: a pixel's size there [m]. ``crest`` (N,)
    if given gets the breaking crests' foam."""
    pts = np.asarray(points, np.float64).reshape(-1, 2)
    px = np.broadcast_to(np.asarray(px_m, np.float64), (len(pts),))
    tab = np.asarray(table, np.float64)
    out = np.zeros((len(pts), 2))
    for b in range(count):
        trail = tab[b]
        used = trail[:, TR_ARC] >= 0.0
        if not used.any():
            continue
        # the box around the wedge outside which the wake is flat
        reach = 1.1 * trail[used, TR_ARC].max() * CUSP + 1.0
        lo = trail[used][:, [TR_X, TR_Y]].min(axis=0) - reach
        hi = trail[used][:, [TR_X, TR_Y]].max(axis=0) + reach
        idx = np.flatnonzero(~((pts < lo).any(axis=1) | (pts > hi).any(axis=1)))
        X, Y, U, strength, back, port, slope, past = nearest_on_trail(pts[idx], trail)
        # the points with a wake: moving water behind the bow, inside the wedge
        keep = (strength > 0.0) & (U >= 0.3) & (X > 0.0)
        r = np.full(len(idx), np.inf)
        r[keep] = np.abs(Y[keep]) / X[keep]
        keep &= r <= 1.06 * CUSP
        idx, X, Y, U, strength, back, port, slope, past, r = (
            v[keep] for v in (idx, X, Y, U, strength, back, port, slope, past, r))
        k0 = G / (U * U)
        amp = (slope * strength * _smoothstep(0.0, 4.0, X)
               * (1.0 - _smoothstep(0.0, math.pi / k0, past))
               / np.sqrt(1.0 + X * k0 / (2.0 * math.pi) * 0.5)
               * (1.0 - _smoothstep(0.88 * CUSP, 1.06 * CUSP, r)))
        rr = np.minimum(r, CUSP)
        D = np.sqrt(np.maximum(X * X - 8.0 * Y * Y, 0.0))
        cusp = 1.0 + 0.8 * np.exp(-((CUSP - rr) / (0.18 * CUSP)) ** 2)
        w = TRANSVERSE * _wave(-2.0 * Y / (X + D), X, Y, k0, px[idx])
        # the diverging waves, where the point is off the track (|Y| > 1 mm)
        off = np.abs(Y) > 1e-3
        t_div = -(X + D) / (4.0 * np.where(off, Y, 1.0))
        w = w + np.where(off[:, None], _smoothstep(0.0, 0.5 * CUSP, r)[:, None]
                         * _wave(t_div, X, Y, k0, px[idx]), 0.0)
        w = w * amp[:, None] * cusp[:, None]
        out[idx] += w[:, :1] * back + w[:, 1:] * port
        if crest is not None:
            crest[idx] = np.maximum(crest[idx], strength * _smoothstep(BREAK, 2 * BREAK,
                                                                       np.hypot(*w.T)))
    return out
