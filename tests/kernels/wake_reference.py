"""Plain-numpy twin of ``shaders/wake.glsl``: the Kelvin wake's slopes at world points,
written for clarity (one point at a time, as the shader does); the specification of the
shader, checked against it through a probe (tests/render/test_foam_wake_render.py)."""
from __future__ import annotations

import math

import numpy as np

from riverflow.kernels.wake import TR_ARC, TR_SLOPE, TR_SPEED, TR_STRENGTH, TR_X, TR_Y

G = 9.81
CUSP = 1.0 / math.sqrt(8.0)          # tan(19.47°)
TRANSVERSE = 0.55


def _smoothstep(e0, e1, x):
    t = min(max((x - e0) / (e1 - e0), 0.0), 1.0)
    return t * t * (3.0 - 2.0 * t)


def _wave(t, X, Y, k0, px_m):
    c2 = 1.0 + t * t
    k = k0 * c2
    visible = min(max((2.0 * math.pi / (k * max(px_m, 1e-4)) - 3.0) / 3.0, 0.0), 1.0)
    if visible <= 0.0:
        return np.zeros(2)
    phase = k0 * (X + Y * t) * math.sqrt(c2)
    return visible * math.sin(phase) * np.array([1.0, t]) / math.sqrt(c2)


def nearest_on_trail(p, trail):
    """(X, Y, U, strength, back (2,), port (2,), slope, past) at the trail point nearest p:
    distance along the trail from the bow, signed distance (+ to port of the boat's motion),
    speed, strength and wave slope there, the unit vectors behind the boat and to its port,
    and how far p lies beyond the trail's oldest point (0 unless that is the nearest; the
    first segment wins a tie, as in the shader)."""
    best = math.inf
    out = (0.0, 0.0, 0.0, 0.0, np.zeros(2), np.zeros(2), 0.0, 0.0, 0)
    a = trail[0]
    last = 0
    for j in range(1, len(trail)):
        q = trail[j]
        if q[TR_ARC] < 0.0:
            break
        last = j
        e = q[[TR_X, TR_Y]] - a[[TR_X, TR_Y]]
        len2 = float(e @ e)
        if len2 > 1e-8:
            s = min(max(float((p - a[[TR_X, TR_Y]]) @ e) / len2, 0.0), 1.0)
            d = p - (a[[TR_X, TR_Y]] + s * e)
            dist2 = float(d @ d)
            if dist2 < best:
                best = dist2
                u = e / math.sqrt(len2)
                port = np.array([u[1], -u[0]])
                mix = lambda c: (1 - s) * a[c] + s * q[c]   # noqa: E731
                past = max(float(d @ u), 0.0) if s >= 1.0 else 0.0
                out = (mix(TR_ARC), float(d @ port), mix(TR_SPEED), mix(TR_STRENGTH), u, port,
                       mix(TR_SLOPE), past, j)
        a = q
    *values, past, segment = out
    return (*values, past if segment == last else 0.0)


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
        reach = 1.1 * trail[used, TR_ARC].max() * CUSP + 1.0
        lo = trail[used][:, [TR_X, TR_Y]].min(axis=0) - reach
        hi = trail[used][:, [TR_X, TR_Y]].max(axis=0) + reach
        for i, p in enumerate(pts):
            if (p < lo).any() or (p > hi).any():
                continue
            X, Y, U, strength, back, port, slope, past = nearest_on_trail(p, trail)
            if strength <= 0.0 or U < 0.3 or X <= 0.0:
                continue
            r = abs(Y) / X
            if r > 1.06 * CUSP:
                continue
            k0 = G / (U * U)
            amp = (slope * strength * _smoothstep(0.0, 4.0, X)
                   * (1.0 - _smoothstep(0.0, math.pi / k0, past))
                   / math.sqrt(1.0 + X * k0 / (2.0 * math.pi) * 0.5)
                   * (1.0 - _smoothstep(0.88 * CUSP, 1.06 * CUSP, r)))
            rr = min(r, CUSP)
            D = math.sqrt(max(X * X - 8.0 * Y * Y, 0.0))
            cusp = 1.0 + 0.8 * math.exp(-((CUSP - rr) / (0.18 * CUSP)) ** 2)
            w = TRANSVERSE * _wave(-2.0 * Y / (X + D), X, Y, k0, px[i])
            if abs(Y) > 1e-3:
                w = w + _smoothstep(0.0, 0.5 * CUSP, r) * _wave(-(X + D) / (4.0 * Y), X, Y, k0,
                                                                px[i])
            w = w * amp * cusp
            out[i] += w[0] * back + w[1] * port
            if crest is not None:
                crest[i] = max(crest[i], strength * _smoothstep(BREAK, 2 * BREAK,
                                                                float(np.hypot(*w))))
    return out
