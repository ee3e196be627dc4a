"""The junction fillets of :func:`riverflow.hydro._strips.corner_fillets` in closed form: where
the water's outline (water on the left of every ring) turns right — a point of land — the
closing with a disc of radius r adds the land between the two shores and the arc of radius r
tangent to both. This kernel finds the corners, solves their arcs (between straight edges, or
where one shore is a polygonal arc bending away from the land), checks that nothing else is
closed near the junction (the rolling-disc test) and writes each corner's piece at each
radius as a ring. Its plain-numpy twin is ``tests/hydro/fillet_twin.py``.

Status codes (0: the junction is made of simple corners; else the closing must do it):
1 a zero-length edge, 2 a point of land of 0°, 3 a ring of edges shorter than their arcs,
4 a corner's arc cannot be solved at the largest radius, 5 two corners' arcs overlap and
do not make one blunt corner,
6 a disc tangent to the shore reaches water (a neck of land, a tight inner bend), 7 a
corner's disc reaches water, 8 another vertex of the water lies in a corner's piece.
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from riverflow.kernels._jit import EXACT_JIT_OPTIONS

ARC_STEP = 0.5 * math.pi / 32.0
"""Turn per segment of a fillet arc (32 segments per quarter circle, as the closing's)."""
MAX_CHAIN = 64
"""Most edges walked along a bent shore for its tangent point."""


class Outline(NamedTuple):
    """The water's outline near one junction: vertices (n, 2) [m] of its rings, water on the
    left, and each vertex's next and previous vertex along its ring."""

    v: np.ndarray
    nxt: np.ndarray
    prv: np.ndarray


class Fillets(NamedTuple):
    """The pieces: ring coordinates (K, 2) [m] (closed) and those of the grown pieces, per
    piece its first coordinate
    (M + 1,), corner, radius index, whether it may reach within ``reach`` of the junction
    (its apex's distance less its tangent length), its nearest and farthest distance from the
    junction, its diameter, for a corner of one vertex between straight edges the radius of
    the largest disc in it (else −1), and its area; per corner whether each radius could be
    solved (C, S)."""

    coords: np.ndarray
    grown: np.ndarray
    start: np.ndarray
    corner: np.ndarray
    scale: np.ndarray
    inside_reach: np.ndarray
    near_m: np.ndarray
    far_m: np.ndarray
    diameter_m: np.ndarray
    inscribed_m: np.ndarray
    area_m2: np.ndarray
    solved: np.ndarray


@njit(**EXACT_JIT_OPTIONS)
def outline(xy, ring_of, exterior):
    """The :class:`Outline` of rings given as their coordinates (K, 2) (each ring closed: its
    first point repeated), each coordinate's ring (K,) and whether each ring is an exterior
    (its polygon's first ring); exteriors are walked counter-clockwise, holes clockwise."""
    k_all = len(xy)
    n = 0
    for i in range(k_all):
        if i + 1 < k_all and ring_of[i + 1] == ring_of[i]:
            n += 1
    v = np.empty((n, 2))
    nxt = np.empty(n, np.int64)
    prv = np.empty(n, np.int64)
    at = 0
    i = 0
    while i < k_all:
        j = i
        while j + 1 < k_all and ring_of[j + 1] == ring_of[i]:
            j += 1
        m = j - i                         # the ring's points, its last one repeating its first
        a2 = 0.0
        for q in range(m):
            v[at + q, 0], v[at + q, 1] = xy[i + q, 0], xy[i + q, 1]
            a2 += ((xy[i + q, 0] - xy[i, 0]) * (xy[i + q + 1, 1] - xy[i, 1])
                   - (xy[i + q + 1, 0] - xy[i, 0]) * (xy[i + q, 1] - xy[i, 1]))
        forward = (a2 > 0.0) == exterior[ring_of[i]]
        for q in range(m):
            a, b = at + (q + 1) % m, at + (q - 1) % m
            nxt[at + q], prv[at + q] = (a, b) if forward else (b, a)
        at += m
        i = j + 1
    return Outline(v, nxt, prv)


@njit(inline="always", **EXACT_JIT_OPTIONS)
def _seg_point(ax, ay, bx, by, px, py):
    dx, dy = bx - ax, by - ay
    dd = dx * dx + dy * dy
    t = 0.0 if dd <= 0.0 else ((px - ax) * dx + (py - ay) * dy) / dd
    t = min(max(t, 0.0), 1.0)
    ex, ey = ax + t * dx - px, ay + t * dy - py
    return math.sqrt(ex * ex + ey * ey)


@njit(**EXACT_JIT_OPTIONS)
def _seg_seg(ax, ay, bx, by, cx, cy, dx, dy):
    """Distance between segments ab and cd (0 where they cross)."""
    d1x, d1y, d2x, d2y = bx - ax, by - ay, dx - cx, dy - cy
    den = d1x * d2y - d1y * d2x
    if den != 0.0:
        s = ((cx - ax) * d2y - (cy - ay) * d2x) / den
        t = ((cx - ax) * d1y - (cy - ay) * d1x) / den
        if 0.0 <= s <= 1.0 and 0.0 <= t <= 1.0:
            return 0.0
    return min(min(_seg_point(cx, cy, dx, dy, ax, ay), _seg_point(cx, cy, dx, dy, bx, by)),
               min(_seg_point(ax, ay, bx, by, cx, cy), _seg_point(ax, ay, bx, by, dx, dy)))


@njit(**EXACT_JIT_OPTIONS)
def _in_water(o, px, py):
    """Whether the point lies in the water (even-odd over all rings)."""
    v, nxt = o.v, o.nxt
    inside = False
    for i in range(len(v)):
        ax, ay = v[i, 0], v[i, 1]
        bx, by = v[nxt[i], 0], v[nxt[i], 1]
        if (ay > py) != (by > py):
            x = ax + (py - ay) * (bx - ax) / (by - ay)
            if x > px:
                inside = not inside
    return inside


@njit(**EXACT_JIT_OPTIONS)
def _clear(o, px, py, qx, qy, dist):
    """Whether the segment pq keeps ``dist`` from the water."""
    v, nxt = o.v, o.nxt
    for i in range(len(v)):
        j = nxt[i]
        if _seg_seg(px, py, qx, qy, v[i, 0], v[i, 1], v[j, 0], v[j, 1]) < dist:
            return False
    return not _in_water(o, 0.5 * (px + qx), 0.5 * (py + qy))


@njit(**EXACT_JIT_OPTIONS)
def _solve(o, u, length, g0, cnt, turn, r, path, st_k, st_lo, st_hi, out):
    """The arc of radius r at the corner of ``cnt`` vertices from ``g0``: returns (status,
    path length, stretches); ``out`` gets centre, t1, t2, sweep, apex, reach."""
    v, nxt, prv = o.v, o.nxt, o.prv
    gl = g0
    for _ in range(cnt - 1):
        gl = nxt[gl]
    k_in, k_out = prv[g0], gl
    ax, ay = v[g0, 0], v[g0, 1]
    uax, uay, ubx, uby = u[k_in, 0], u[k_in, 1], u[k_out, 0], u[k_out, 1]
    lam = 0.0
    if cnt > 1:
        den = uax * uby - uay * ubx
        lam = ((v[gl, 0] - ax) * uby - (v[gl, 1] - ay) * ubx) / den
    px, py = ax + lam * uax, ay + lam * uay
    t = r * math.tan(0.5 * turn)
    end_in = t - lam
    start_out = t - ((v[gl, 0] - px) * ubx + (v[gl, 1] - py) * uby)
    if end_in < -1e-9 or start_out < -1e-9:
        return 1, 0, 0
    out[7], out[8] = v[g0, 0], v[g0, 1]
    if end_in <= length[k_in] and start_out <= length[k_out]:
        t1x, t1y = px - t * uax, py - t * uay
        t2x, t2y = px + t * ubx, py + t * uby
        out[0], out[1] = t2x + r * uby, t2y - r * ubx
        out[2], out[3], out[4], out[5] = t1x, t1y, t2x, t2y
        out[6] = turn
        out[7], out[8] = px, py
        out[9] = t
        k = g0
        for m in range(cnt):
            path[m] = k
            k = nxt[k]
        n_st = 0
        k = g0
        for m in range(cnt - 1):
            st_k[n_st], st_lo[n_st], st_hi[n_st] = k, 0.0, length[k]
            n_st += 1
            k = nxt[k]
        st_k[n_st], st_lo[n_st], st_hi[n_st] = k_in, length[k_in] - max(end_in, 0.0), length[k_in]
        st_k[n_st + 1], st_lo[n_st + 1], st_hi[n_st + 1] = k_out, 0.0, max(start_out, 0.0)
        return 0, cnt, n_st + 2
    # one shore bends within the arc's reach: C on the other edge's offset line
    budget = 3.0 * t + 2.0 * r
    verts = np.empty(cnt + MAX_CHAIN + 1, np.int64)
    edges = np.empty(cnt + MAX_CHAIN, np.int64)
    for attempt in range(2):
        straight_in = (attempt == 0) == (length[k_in] >= length[k_out])
        nv = 0
        ne = 0
        if straight_in:
            k = g0
            for m in range(cnt):
                verts[nv] = k
                nv += 1
                if m < cnt - 1:
                    edges[ne] = k
                    ne += 1
                k = nxt[k]
        else:
            k = gl
            for m in range(cnt):
                verts[nv] = k
                nv += 1
                if m < cnt - 1:
                    edges[ne] = prv[k]
                    ne += 1
                k = prv[k]
        total = 0.0
        k = k_out if straight_in else k_in
        n_chain = 0
        while total < budget and n_chain < MAX_CHAIN:
            edges[ne] = k
            ne += 1
            n_chain += 1
            total += length[k]
            if straight_in:
                verts[nv] = nxt[k]
                k = nxt[k]
            else:
                verts[nv] = k
                k = prv[k]
            nv += 1
        if straight_in:
            lx, ly = v[g0, 0], v[g0, 1]
            wx, wy = -uax, -uay
            k_line = k_in
        else:
            lx, ly = v[gl, 0], v[gl, 1]
            wx, wy = ubx, uby
            k_line = k_out
        mx, my = u[k_line, 1], -u[k_line, 0]
        bx, by = lx + r * mx, ly + r * my
        best_s = np.inf
        # candidates: tangent to an edge's line, or through a vertex at r
        for c in range(3 * ne + 3):
            if c < ne:
                k = edges[c]
                mkx, mky = u[k, 1], -u[k, 0]
                p0 = verts[c]
                den = mkx * wx + mky * wy
                if den == 0.0:
                    continue
                s = (r - ((bx - v[p0, 0]) * mkx + (by - v[p0, 1]) * mky)) / den
            else:
                q = (c - ne) // 2
                if q > ne:
                    continue
                j = verts[q]
                qx, qy = bx - v[j, 0], by - v[j, 1]
                bq = qx * wx + qy * wy
                disc = bq * bq - (qx * qx + qy * qy) + r * r
                if disc < 0.0:
                    continue
                s = -bq - math.sqrt(disc) if (c - ne) % 2 == 0 else -bq + math.sqrt(disc)
            if not (s >= -1e-9) or s >= best_s:
                continue
            cx, cy = bx + s * wx, by + s * wy
            dmin = np.inf
            for m in range(ne):
                a, b = verts[m], verts[m + 1]
                dmin = min(dmin, _seg_point(v[a, 0], v[a, 1], v[b, 0], v[b, 1], cx, cy))
            if dmin >= r * (1.0 - 1e-9) - 1e-9:
                best_s = s
        if not (best_s < np.inf) or best_s > length[k_line]:
            continue
        cx, cy = bx + best_s * wx, by + best_s * wy
        seg, dmin, tau = -1, np.inf, 0.0
        for m in range(ne):
            a, b = verts[m], verts[m + 1]
            d = _seg_point(v[a, 0], v[a, 1], v[b, 0], v[b, 1], cx, cy)
            if d < dmin:
                dx, dy = v[b, 0] - v[a, 0], v[b, 1] - v[a, 1]
                sl = math.sqrt(dx * dx + dy * dy)
                seg, dmin = m, d
                tau = min(max(((cx - v[a, 0]) * dx + (cy - v[a, 1]) * dy) / sl, 0.0), sl)
        if abs(dmin - r) > 1e-6 * r + 1e-9:
            continue
        a, b = verts[seg], verts[seg + 1]
        dx, dy = v[b, 0] - v[a, 0], v[b, 1] - v[a, 1]
        sl = math.sqrt(dx * dx + dy * dy)
        if seg == ne - 1 and tau >= sl - 1e-9:
            continue                      # the tangent point may lie beyond the shore walked
        fx, fy = v[a, 0] + tau * dx / sl, v[a, 1] + tau * dy / sl
        tlx, tly = lx + best_s * wx, ly + best_s * wy
        n_path = seg + 2 if tau >= sl - 1e-9 else seg + 1
        n_st = 0
        for m in range(seg + 1):
            if m < cnt - 1:
                continue                  # the blunt point's own short edges
            k = edges[m]
            cut = tau if m == seg else length[k]
            if straight_in:
                st_k[n_st], st_lo[n_st], st_hi[n_st] = k, 0.0, cut
            else:
                st_k[n_st], st_lo[n_st], st_hi[n_st] = k, length[k] - cut, length[k]
            n_st += 1
        if straight_in:
            t1x, t1y, t2x, t2y = tlx, tly, fx, fy
            st_k[n_st], st_lo[n_st], st_hi[n_st] = k_in, length[k_in] - best_s, length[k_in]
            for m in range(n_path):
                path[m] = verts[m]
        else:
            t1x, t1y, t2x, t2y = fx, fy, tlx, tly
            st_k[n_st], st_lo[n_st], st_hi[n_st] = k_out, 0.0, best_s
            for m in range(n_path):
                path[m] = verts[n_path - 1 - m]
        n_st += 1
        sweep = (math.atan2(t1y - cy, t1x - cx) - math.atan2(t2y - cy, t2x - cx)) % (2.0 * math.pi)
        if not (0.0 < sweep < math.pi):
            return 1, 0, 0
        out[0], out[1], out[2], out[3], out[4], out[5] = cx, cy, t1x, t1y, t2x, t2y
        out[6] = sweep
        out[9] = max(math.hypot(t1x - out[7], t1y - out[8]), math.hypot(t2x - out[7], t2y - out[8]))
        return 0, n_path, n_st
    return 1, 0, 0


@njit(**EXACT_JIT_OPTIONS)
def _ring(o, u, path, n_path, out, r, grow, coords, grown, at):
    """Write a piece's ring (t1, the shore's vertices, t2, the arc back to t1; t1 and t2
    twice) to ``coords`` and the piece grown by ``grow`` to ``grown`` (its shore pushed into
    the water, mitred, its arc drawn in by ``grow``: t1 and t2 become a step across the
    shore), both from row ``at``; returns the next free row."""
    v, prv = o.v, o.prv
    cx, cy = out[0], out[1]
    m1x, m1y = (cx - out[2]) / r, (cy - out[3]) / r      # the land side at t1 and t2
    m2x, m2y = (cx - out[4]) / r, (cy - out[5]) / r
    coords[at, 0], coords[at, 1] = out[2], out[3]
    grown[at, 0], grown[at, 1] = out[2] - grow * m1x, out[3] - grow * m1y
    at += 1
    for m in range(n_path):
        k = path[m]
        ax, ay, bx, by = u[prv[k], 0], u[prv[k], 1], u[k, 0], u[k, 1]
        den = max(1.0 + ax * bx + ay * by, 1e-3)
        coords[at, 0], coords[at, 1] = v[k, 0], v[k, 1]
        grown[at, 0] = v[k, 0] + grow * (-ay - by) / den
        grown[at, 1] = v[k, 1] + grow * (ax + bx) / den
        at += 1
    coords[at, 0], coords[at, 1] = out[4], out[5]
    grown[at, 0], grown[at, 1] = out[4] - grow * m2x, out[5] - grow * m2y
    at += 1
    n = max(1, int(math.ceil(out[6] / ARC_STEP - 1e-9)))
    phi0 = math.atan2(out[5] - cy, out[4] - cx)
    for m in range(n + 1):
        phi = phi0 + out[6] * m / n
        if m == 0:
            coords[at, 0], coords[at, 1] = out[4], out[5]
        elif m == n:
            coords[at, 0], coords[at, 1] = out[2], out[3]
        else:
            coords[at, 0], coords[at, 1] = cx + r * math.cos(phi), cy + r * math.sin(phi)
        grown[at, 0] = cx + (r - grow) * math.cos(phi)
        grown[at, 1] = cy + (r - grow) * math.sin(phi)
        at += 1
    coords[at, 0], coords[at, 1] = out[2], out[3]
    grown[at, 0], grown[at, 1] = out[2] - grow * m1x, out[3] - grow * m1y
    return at + 1


@njit(**EXACT_JIT_OPTIONS)
def corner_fillets(o, cx, cy, r, reach, min_turn, tol, scales, grow):
    """(status, :class:`Fillets`) of the outline ``o`` around the junction (cx, cy): arcs of
    radius r × each of ``scales`` (largest first, ``scales[0]`` = 1) at every corner turning
    by ``min_turn`` or more whose piece may reach within ``reach`` of the junction; each piece
    also grown by ``grow`` [m]."""
    v, nxt, prv = o.v, o.nxt, o.prv
    n = len(v)
    n_sc = len(scales)
    empty = Fillets(np.zeros((0, 2)), np.zeros((0, 2)), np.zeros(1, np.int64), np.zeros(0, np.int64),
                    np.zeros(0, np.int64), np.zeros(0, np.bool_), np.zeros(0), np.zeros(0),
                    np.zeros(0), np.zeros(0), np.zeros(0), np.zeros((0, n_sc), np.bool_))
    u = np.empty((n, 2))
    length = np.empty(n)
    for i in range(n):
        dx, dy = v[nxt[i], 0] - v[i, 0], v[nxt[i], 1] - v[i, 1]
        length[i] = math.sqrt(dx * dx + dy * dy)
        if not length[i] > 1e-9:
            return 1, empty
        u[i, 0], u[i, 1] = dx / length[i], dy / length[i]
    theta = np.empty(n)
    right = np.empty(n, np.bool_)
    tangent = np.empty(n)
    near = np.empty(n, np.bool_)
    for i in range(n):
        p = prv[i]
        cr = u[p, 0] * u[i, 1] - u[p, 1] * u[i, 0]
        theta[i] = math.atan2(abs(cr), u[p, 0] * u[i, 0] + u[p, 1] * u[i, 1])
        right[i] = cr < 0.0
        tangent[i] = r * math.tan(0.5 * theta[i]) if right[i] else 0.0
        near[i] = _seg_point(v[i, 0], v[i, 1], v[nxt[i], 0], v[nxt[i], 1], cx, cy) < reach + 1.01 * r
    short = np.zeros(n, np.bool_)
    n_short = 0
    for i in range(n):
        j = nxt[i]
        short[i] = near[i] and right[i] and right[j] and length[i] < tangent[i] + tangent[j]
        n_short += short[i]
    # corners: runs of right turns joined by short edges
    c_start = np.empty(n, np.int64)
    c_cnt = np.empty(n, np.int64)
    c_turn = np.empty(n)
    n_c = 0
    covered_short = 0
    for i in range(n):
        if not (right[i] and (near[i] or near[prv[i]]) and not short[prv[i]]):
            continue
        k, cnt, turn = i, 1, theta[i]
        while short[k]:
            k = nxt[k]
            cnt += 1
            turn += theta[k]
            if cnt > n:
                return 3, empty
        if turn >= math.pi - 1e-6:
            return 2, empty
        c_start[n_c], c_cnt[n_c], c_turn[n_c] = i, cnt, turn
        covered_short += cnt - 1
        n_c += 1
    if covered_short != n_short:
        return 3, empty
    # the tangent stretches at the largest radius; two corners whose stretches meet (a
    # point of land whose tip is a small bump of water, the arc of a junction disc between
    # two strips) are one blunt corner: the run of vertices from the first to the last
    covered = np.zeros(n, np.bool_)
    cut_start = np.zeros(n)
    cut_end = np.zeros(n)
    own_full = np.empty(n, np.int64)
    own_start = np.empty(n, np.int64)
    own_end = np.empty(n, np.int64)
    path = np.empty(n + MAX_CHAIN + 2, np.int64)
    st_k = np.empty(n + MAX_CHAIN + 2, np.int64)
    st_lo = np.empty(n + MAX_CHAIN + 2)
    st_hi = np.empty(n + MAX_CHAIN + 2)
    sol = np.zeros((n_c, 10))
    big = np.zeros(n_c, np.bool_)
    for _ in range(n + 1):
        covered[:] = False
        cut_start[:] = 0.0
        cut_end[:] = 0.0
        own_full[:] = -1
        own_start[:] = -1
        own_end[:] = -1
        big[:] = False
        ca, cb = -1, -1
        for c in range(n_c):
            turn = c_turn[c]
            if turn < min_turn:           # too slight to round: only its tangent stretches
                t = r * math.tan(0.5 * turn)
                k = c_start[c]
                n_st = 0
                for m in range(c_cnt[c] - 1):
                    st_k[n_st], st_lo[n_st], st_hi[n_st] = k, 0.0, length[k]
                    n_st += 1
                    k = nxt[k]
                k_in = prv[c_start[c]]
                st_k[n_st], st_lo[n_st], st_hi[n_st] = k_in, max(length[k_in] - t, 0.0), length[k_in]
                st_k[n_st + 1], st_lo[n_st + 1], st_hi[n_st + 1] = k, 0.0, min(t, length[k])
                n_st += 2
            else:
                status, n_path, n_st = _solve(o, u, length, c_start[c], c_cnt[c], turn, r, path,
                                              st_k, st_lo, st_hi, sol[c])
                if status != 0:
                    return 4, empty
                big[c] = True
            for m in range(n_st):
                k = st_k[m]
                if st_lo[m] <= 1e-12 and st_hi[m] >= length[k] - 1e-12:
                    for other in (own_full[k], own_start[k], own_end[k]):
                        if other >= 0 and other != c:
                            ca, cb = other, c
                    own_full[k] = c
                    covered[k] = True
                elif st_lo[m] <= 1e-12:
                    if own_full[k] >= 0 and own_full[k] != c:
                        ca, cb = own_full[k], c
                    elif (own_end[k] >= 0 and own_end[k] != c
                          and st_hi[m] + cut_end[k] > length[k] - 1e-9):
                        ca, cb = own_end[k], c
                    own_start[k] = c
                    cut_start[k] = max(cut_start[k], st_hi[m])
                else:
                    if own_full[k] >= 0 and own_full[k] != c:
                        ca, cb = own_full[k], c
                    elif (own_start[k] >= 0 and own_start[k] != c
                          and length[k] - st_lo[m] + cut_start[k] > length[k] - 1e-9):
                        ca, cb = own_start[k], c
                    own_end[k] = c
                    cut_end[k] = max(cut_end[k], length[k] - st_lo[m])
            if ca >= 0:
                break
        if ca < 0:
            break
        # merge corners ca and cb: the run from the one that comes first along the ring
        steps_ab, steps_ba = -1, -1
        k = c_start[ca]
        for m in range(1, n + 1):
            k = nxt[k]
            if k == c_start[cb]:
                steps_ab = m
                break
        k = c_start[cb]
        for m in range(1, n + 1):
            k = nxt[k]
            if k == c_start[ca]:
                steps_ba = m
                break
        if steps_ab < 0:
            return 5, empty               # on two rings
        first, second, steps = (ca, cb, steps_ab) if steps_ab <= steps_ba else (cb, ca, steps_ba)
        cnt = max(steps + c_cnt[second], c_cnt[first])
        turn = 0.0
        k = c_start[first]
        for m in range(cnt):
            turn += theta[k] if right[k] else -theta[k]
            k = nxt[k]
        if not (0.0 < turn < math.pi - 1e-6) or cnt >= n:
            return 5, empty
        c_cnt[first], c_turn[first] = cnt, turn
        n_c -= 1
        if second != n_c:
            c_start[second], c_cnt[second], c_turn[second] = c_start[n_c], c_cnt[n_c], c_turn[n_c]
    else:
        return 5, empty
    sol = sol[:n_c]
    big = big[:n_c]
    # the rolling-disc test: discs of radius r tangent to a straight stretch of shore have
    # their centres on the stretch offset by r to the land side
    lim = reach + 2.0 * r
    for i in range(n):
        if not near[i] or covered[i] or short[i]:
            continue
        if length[i] < cut_start[i] + cut_end[i] - 1e-9:
            return 5, empty
        lo, hi = cut_start[i], max(length[i] - cut_end[i], cut_start[i])
        rx, ry = v[i, 0] - cx, v[i, 1] - cy
        mid = -(rx * u[i, 0] + ry * u[i, 1])
        half = math.sqrt(max(lim * lim - (rx * rx + ry * ry) + mid * mid, 0.0))
        lo, hi = max(lo, mid - half), min(hi, mid + half)
        hi = max(hi, lo)
        mx, my = r * u[i, 1], -r * u[i, 0]
        if not _clear(o, v[i, 0] + lo * u[i, 0] + mx, v[i, 1] + lo * u[i, 1] + my,
                      v[i, 0] + hi * u[i, 0] + mx, v[i, 1] + hi * u[i, 1] + my,
                      r * (1.0 - tol)):
            return 6, empty
    n_big = 0
    for c in range(n_c):
        if big[c]:
            n_big += 1
            if not _clear(o, sol[c, 0], sol[c, 1], sol[c, 0], sol[c, 1], r * (1.0 - tol)):
                return 7, empty
    # the pieces: at each radius, each corner's ring
    max_ring = n + MAX_CHAIN + 72
    coords = np.empty((n_big * n_sc * max_ring, 2))
    grown = np.empty((n_big * n_sc * max_ring, 2))
    start = np.zeros(n_big * n_sc + 1, np.int64)
    corner = np.empty(n_big * n_sc, np.int64)
    scale = np.empty(n_big * n_sc, np.int64)
    inside_reach = np.empty(n_big * n_sc, np.bool_)
    near_m = np.empty(n_big * n_sc)
    far_m = np.empty(n_big * n_sc)
    diameter_m = np.empty(n_big * n_sc)
    inscribed_m = np.empty(n_big * n_sc)
    area_m2 = np.empty(n_big * n_sc)
    solved = np.zeros((n_c, n_sc), np.bool_)
    n_p = 0
    at = 0
    out = np.empty(10)
    mark = np.zeros(n, np.bool_)
    for s in range(n_sc):
        rs = r * scales[s]
        for c in range(n_c):
            if not big[c]:
                continue
            status, n_path, n_st = _solve(o, u, length, c_start[c], c_cnt[c], c_turn[c], rs,
                                          path, st_k, st_lo, st_hi, out)
            if status != 0:
                continue
            solved[c, s] = True
            first = at
            at = _ring(o, u, path, n_path, out, rs, grow, coords, grown, at)
            if s == 0:
                # no other vertex of the water in the piece (on its edges included)
                for m in range(n_path):
                    mark[path[m]] = True
                x0, x1 = coords[first:at, 0].min() - 1e-6, coords[first:at, 0].max() + 1e-6
                y0, y1 = coords[first:at, 1].min() - 1e-6, coords[first:at, 1].max() + 1e-6
                for i in range(n):
                    if mark[i] or not (x0 <= v[i, 0] <= x1 and y0 <= v[i, 1] <= y1):
                        continue
                    inside = False
                    for m in range(first, at - 1):
                        ax, ay, bx, by = coords[m, 0], coords[m, 1], coords[m + 1, 0], coords[m + 1, 1]
                        if _seg_point(ax, ay, bx, by, v[i, 0], v[i, 1]) <= 1e-7:
                            inside = True
                            break
                        if (ay > v[i, 1]) != (by > v[i, 1]):
                            if ax + (v[i, 1] - ay) * (bx - ax) / (by - ay) > v[i, 0]:
                                inside = not inside
                    if inside:
                        return 8, empty
                for m in range(n_path):
                    mark[path[m]] = False
            corner[n_p], scale[n_p] = c, s
            inside_reach[n_p] = math.hypot(out[7] - cx, out[8] - cy) - out[9] < reach
            lo, hi, diam = np.inf, 0.0, 0.0
            for m in range(first, at - 1):
                lo = min(lo, _seg_point(coords[m, 0], coords[m, 1], coords[m + 1, 0],
                                        coords[m + 1, 1], cx, cy))
                hi = max(hi, math.hypot(coords[m, 0] - cx, coords[m, 1] - cy))
                for q in range(m + 1, at - 1):
                    diam = max(diam, math.hypot(coords[m, 0] - coords[q, 0],
                                                coords[m, 1] - coords[q, 1]))
            near_m[n_p], far_m[n_p], diameter_m[n_p] = lo, hi, diam
            a2 = 0.0
            for m in range(first, at - 1):
                a2 += ((coords[m, 0] - coords[first, 0]) * (coords[m + 1, 1] - coords[first, 1])
                       - (coords[m + 1, 0] - coords[first, 0]) * (coords[m, 1] - coords[first, 1]))
            area_m2[n_p] = 0.5 * abs(a2)
            inscribed_m[n_p] = -1.0
            if c_cnt[c] == 1 and n_path == 1:
                half_c = math.cos(0.5 * c_turn[c])
                inscribed_m[n_p] = rs * (1.0 - half_c) / (1.0 + half_c)
            n_p += 1
            start[n_p] = at
    return 0, Fillets(coords[:at], grown[:at], start[:n_p + 1], corner[:n_p], scale[:n_p],
                      inside_reach[:n_p], near_m[:n_p], far_m[:n_p], diameter_m[:n_p],
                      inscribed_m[:n_p], area_m2[:n_p], solved)
