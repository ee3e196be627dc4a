"""The plain-numpy twin of :func:`riverflow.kernels.fillets.corner_fillets` (the junction
fillets in closed form): the same corners, tests and arcs, written with numpy arrays and
shapely, slower; the tests compare the two."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import shapely

from riverflow.hydro._strips import FILLET_BALL_TOL, FILLET_MIN_TURN, FILLET_QUAD_SEGS


def twin_fillets(local: shapely.Geometry, center_m: np.ndarray, radius_m: float,
                 reach_m: float, scales: tuple[float, ...] = (1.0,)):
    """The pieces (unbuffered) at the largest radius of every corner of ``local`` turning by
    FILLET_MIN_TURN or more, or None where the junction is not made of simple corners: the
    plain-numpy twin of :func:`riverflow.kernels.fillets.corner_fillets`."""
    if local.is_empty:
        return []
    r = float(radius_m) * max(scales)
    c = np.asarray(center_m, float)
    rings = shapely.get_rings(shapely.get_parts(shapely.orient_polygons(local)))
    xy, ring_of = shapely.get_coordinates(rings, return_index=True)
    last = np.r_[ring_of[1:] != ring_of[:-1], True]       # each ring repeats its first point
    v, ring_of = xy[~last], ring_of[~last]
    n_v = len(v)
    start = np.r_[True, ring_of[1:] != ring_of[:-1]]
    first = np.maximum.accumulate(np.where(start, np.arange(n_v), 0))
    nxt = np.where(np.r_[start[1:], True], first, np.arange(n_v) + 1)
    prv = np.empty_like(nxt)
    prv[nxt] = np.arange(n_v)
    e = v[nxt] - v                                         # edge i runs from vertex i to nxt[i]
    length = np.hypot(e[:, 0], e[:, 1])
    if not (length > 1e-9).all():
        return None
    u = e / length[:, None]
    cross = u[prv, 0] * u[:, 1] - u[prv, 1] * u[:, 0]      # turn at vertex i: edge prv → edge i
    theta = np.arctan2(np.abs(cross), np.einsum("ij,ij->i", u[prv], u))
    right = cross < 0.0                                     # a point of land
    tangent = np.where(right, r * np.tan(0.5 * theta), 0.0)
    # the edges that matter: those within reach + r of the centre (a piece meets the reach
    # disc only where the closing leaves some land point within reach uncovered, and a disc
    # covering such a point touches the shore within r of it)
    rel = v - c
    s = np.clip(-np.einsum("ij,ij->i", rel, u), 0.0, length)
    near = np.hypot(*(rel + s[:, None] * u).T) < reach_m + 1.01 * r
    # corners: runs of right turns joined by edges shorter than their tangents
    short = near & right & right[nxt] & (length < tangent + tangent[nxt])
    is_corner = right & (near | near[prv])
    is_corner[nxt[short]] = False         # a run starts where its in-edge is not short
    geo = _Outline(v, nxt, prv, u, length, theta, right)
    corners = []
    for i0 in np.flatnonzero(is_corner):
        run = [int(i0)]
        while short[run[-1]]:
            run.append(int(nxt[run[-1]]))
            if len(run) > n_v:
                return None
        turn = float(theta[run].sum())
        if turn >= np.pi - 1e-6:
            return None                   # a point of land of 0°
        if turn < FILLET_MIN_TURN:        # too slight to round: only its tangent stretches
            k_in, t = prv[run[0]], r * np.tan(0.5 * turn)
            stretches = [(k, 0.0, length[k]) for k in run[:-1]]
            stretches += [(k_in, max(length[k_in] - t, 0.0), length[k_in]),
                          (run[-1], 0.0, min(t, length[run[-1]]))]
            corners.append((run, turn, _Fillet(None, None, r, turn, run, stretches, None, t)))
            continue
        found = geo.corner(run, turn, r)
        if found is None:
            return None
        corners.append((run, turn, found))
    if sum(len(run) - 1 for run, _, _ in corners) != short.sum():
        return None                       # a ring of short edges: an island smaller than the arc
    # the tangent stretches; two corners whose stretches meet are one blunt corner
    while True:
        covered = np.zeros(n_v, bool)
        cut_start, cut_end = np.zeros(n_v), np.zeros(n_v)
        owners = [dict() for _ in range(n_v)]         # edge: {"full"/"start"/"end": corner}
        clash = None
        for ci, (run, turn, f) in enumerate(corners):
            for k, lo, hi in f.stretches:
                own = owners[k]
                others = {x for x in own.values() if x != ci}
                if lo <= 1e-12 and hi >= length[k] - 1e-12:
                    if others:
                        clash = (min(others), ci)
                    own["full"] = ci
                    covered[k] = True
                elif lo <= 1e-12:
                    if own.get("full", ci) != ci:
                        clash = (own["full"], ci)
                    elif own.get("end", ci) != ci and hi + cut_end[k] > length[k] - 1e-9:
                        clash = (own["end"], ci)
                    own["start"] = ci
                    cut_start[k] = max(cut_start[k], hi)
                else:
                    if own.get("full", ci) != ci:
                        clash = (own["full"], ci)
                    elif own.get("start", ci) != ci and length[k] - lo + cut_start[k] > length[k] - 1e-9:
                        clash = (own["start"], ci)
                    own["end"] = ci
                    cut_end[k] = max(cut_end[k], length[k] - lo)
            if clash is not None:
                break
        if clash is None:
            break
        ca, cb = clash

        def steps(a_, b_):
            k_ = corners[a_][0][0]
            for m_ in range(1, n_v + 1):
                k_ = int(nxt[k_])
                if k_ == corners[b_][0][0]:
                    return m_
            return -1
        s_ab, s_ba = steps(ca, cb), steps(cb, ca)
        if s_ab < 0:
            return None
        first, second, st = (ca, cb, s_ab) if s_ab <= s_ba else (cb, ca, s_ba)
        cnt = max(st + len(corners[second][0]), len(corners[first][0]))
        run = [corners[first][0][0]]
        for _ in range(cnt - 1):
            run.append(int(nxt[run[-1]]))
        turn = float(sum(theta[x] if right[x] else -theta[x] for x in run))
        if not 0.0 < turn < np.pi - 1e-6 or cnt >= n_v:
            return None
        if turn < FILLET_MIN_TURN:
            k_in, t = prv[run[0]], r * np.tan(0.5 * turn)
            stretches = [(k, 0.0, length[k]) for k in run[:-1]]
            stretches += [(k_in, max(length[k_in] - t, 0.0), length[k_in]),
                          (run[-1], 0.0, min(t, length[run[-1]]))]
            merged = (run, turn, _Fillet(None, None, r, turn, run, stretches, None, t))
        else:
            found = geo.corner(run, turn, r)
            if found is None:
                return None
            merged = (run, turn, found)
        corners = [x for m_, x in enumerate(corners) if m_ not in (first, second)] + [merged]
    plain = near & ~covered & ~short
    if (length[plain] < cut_start[plain] + cut_end[plain] - 1e-9).any():
        return None                       # two corners' arcs overlap on one edge
    # the rolling-disc test: the discs of radius r tangent to a straight stretch of shore on
    # the land side have their centres on the stretch offset by r; they all keep clear of the
    # water when that offset segment does
    idx = np.flatnonzero(plain)
    lo, hi = cut_start[idx], np.maximum(length[idx] - cut_end[idx], cut_start[idx])
    # ... within reach + 2r of the centre (the discs that cover land within reach + r)
    mid = -np.einsum("ij,ij->i", rel[idx], u[idx])
    half_chord = np.sqrt(np.maximum((reach_m + 2.0 * r) ** 2 - np.einsum("ij,ij->i", rel[idx], rel[idx])
                                    + mid ** 2, 0.0))
    lo, hi = np.maximum(lo, mid - half_chord), np.minimum(hi, mid + half_chord)
    hi = np.maximum(hi, lo)
    land = r * np.stack([u[idx, 1], -u[idx, 0]], axis=1)   # right of the edge: the land side
    ends = np.stack([v[idx] + lo[:, None] * u[idx] + land, v[idx] + hi[:, None] * u[idx] + land],
                    axis=1)
    shapely.prepare(local)
    if shapely.dwithin(local, shapely.linestrings(ends), r * (1.0 - FILLET_BALL_TOL)).any():
        return None                       # a neck of land thinner than 2r, water in an arc
    # the pieces at the largest radius: valid, their discs clear of the water, and no other
    # vertex of the water in one (the smaller radii's lie within them)
    big = [j for j, (_, turn, _) in enumerate(corners) if turn >= FILLET_MIN_TURN]
    if big:
        centres = shapely.points(np.array([corners[j][2].centre for j in big]))
        if shapely.dwithin(local, centres, r * (1.0 - FILLET_BALL_TOL)).any():
            return None
        polys = _fillet_polygons([corners[j][2] for j in big])
        if not shapely.is_valid(polys).all():
            return None
        lo_xy, hi_xy = shapely.bounds(polys)[:, :2] - 1e-6, shapely.bounds(polys)[:, 2:] + 1e-6
        for j, poly, a, b in zip(big, polys, lo_xy, hi_xy):
            inside = ((v >= a) & (v <= b)).all(axis=1)
            inside[corners[j][2].vertices] = False
            if inside.any() and shapely.dwithin(poly, shapely.points(v[inside]), 1e-7).any():
                return None
    return polys if big else []


@dataclass
class _Fillet:
    """One corner's fillet: the shore from the first tangent point over the corner to the
    second (``path``, (M, 2)), the arc's centre, radius and turn, the vertices of the outline
    on the path, the stretches of edges (edge, from, to [m along it]) the arc spans, and the
    apex and how far the piece reaches from it."""

    path: np.ndarray
    centre: np.ndarray
    radius: float
    sweep: float
    vertices: list
    stretches: list
    apex: np.ndarray
    reach: float


@dataclass
class _Outline:
    """The water's outline as :func:`corner_fillets` walks it (vertex arrays, edge i from
    vertex i to nxt[i])."""

    v: np.ndarray
    nxt: np.ndarray
    prv: np.ndarray
    u: np.ndarray
    length: np.ndarray
    theta: np.ndarray
    right: np.ndarray

    def corner(self, run: list, turn: float, r: float) -> _Fillet | None:
        """The fillet of radius r at the corner ``run`` (its vertices) turning by ``turn``."""
        v, u, length, prv = self.v, self.u, self.length, self.prv
        g0, gl = run[0], run[-1]
        a, b, ua, ub = v[g0], v[gl], u[prv[g0]], u[gl]
        den = ua[0] * ub[1] - ua[1] * ub[0]
        lam = ((b - a)[0] * ub[1] - (b - a)[1] * ub[0]) / den if len(run) > 1 else 0.0
        apex = a + lam * ua
        t = r * np.tan(0.5 * turn)
        end_in, start_out = t - lam, t - float((b - apex) @ ub)
        if end_in < -1e-9 or start_out < -1e-9:
            return None                   # the arc would touch the blunt point's vertices
        k_in = prv[g0]
        if end_in <= length[k_in] and start_out <= length[gl]:
            t1, t2 = apex - t * ua, apex + t * ub
            centre = t2 + r * np.array([ub[1], -ub[0]])
            return _Fillet(np.vstack([t1, v[run], t2]), centre, r, turn, list(run),
                           [(k_in, length[k_in] - max(end_in, 0.0), length[k_in]),
                            (gl, 0.0, max(start_out, 0.0))], apex, t)
        return self._curved(run, r, 3.0 * t + 2.0 * r)

    def _curved(self, run: list, r: float, budget: float) -> _Fillet | None:
        """A corner where one shore bends within its arc's reach (the polygonal arc of a
        junction disc): C on the other, straight edge's offset line, at r from the bent shore
        (tried with either shore as the straight one)."""
        v, nxt, prv, length, u = self.v, self.nxt, self.prv, self.length, self.u
        k_in, k_out = prv[run[0]], run[-1]
        for straight_in in ((True, False) if length[k_in] >= length[k_out] else (False, True)):
            # the bent shore's vertices from the corner outward, and its edges in that order
            verts, edges, total = list(run) if straight_in else list(run[::-1]), [], 0.0
            k = k_out if straight_in else k_in
            while total < budget and len(edges) < 64:
                edges.append(int(k))
                total += length[k]
                verts.append(int(nxt[k]) if straight_in else int(k))
                k = nxt[k] if straight_in else prv[k]
            own = [run[m] for m in range(len(run) - 1)]       # the blunt point's short edges
            edges = (own if straight_in else own[::-1]) + edges
            if straight_in:
                a, w, k_line = v[run[0]], -u[k_in], k_in
            else:
                a, w, k_line = v[run[-1]], u[k_out], k_out
            m = np.array([u[k_line, 1], -u[k_line, 0]])        # the land side of the line
            p0 = v[verts[:-1]]
            d = v[verts[1:]] - p0
            seg_len = np.hypot(d[:, 0], d[:, 1])
            d = d / seg_len[:, None]
            ue = u[edges]
            mk = np.stack([ue[:, 1], -ue[:, 0]], axis=1)        # their land sides
            base = a + r * m                                     # C(s) = base + s·w
            with np.errstate(divide="ignore", invalid="ignore"):
                s_seg = (r - np.einsum("ij,ij->i", base - p0, mk)) / (mk @ w)
            q = base - v[verts]
            bq = q @ w
            disc = bq ** 2 - np.einsum("ij,ij->i", q, q) + r * r
            root = np.sqrt(np.maximum(disc, 0.0))
            s_all = np.concatenate([s_seg, np.where(disc >= 0, -bq - root, np.nan),
                                    np.where(disc >= 0, -bq + root, np.nan)])
            s_all = np.unique(s_all[np.isfinite(s_all) & (s_all >= -1e-9)])
            if not len(s_all):
                continue
            cc = base + s_all[:, None] * w
            # distance of each candidate centre to each edge of the bent shore
            rel = cc[:, None, :] - p0[None]
            tau = np.clip(np.einsum("ijk,jk->ij", rel, d), 0.0, seg_len)
            gap = np.hypot(*(rel - tau[..., None] * d).transpose(2, 0, 1))
            dmin = gap.min(axis=1)
            ok = np.flatnonzero(dmin >= r * (1.0 - 1e-9) - 1e-9)
            if not len(ok):
                continue
            best = ok[0]                  # the nearest disc to the corner that fits
            if abs(dmin[best] - r) > 1e-6 * r + 1e-9:
                continue
            s_line = float(s_all[best])
            if s_line > length[k_line]:
                continue                  # the straight edge is too short as well
            centre = cc[best]
            seg = int(np.argmin(gap[best]))
            if seg == len(edges) - 1 and tau[best, seg] >= seg_len[seg] - 1e-9:
                continue                  # the tangent point may lie beyond the shore walked
            foot = p0[seg] + tau[best, seg] * d[seg]
            t_line = a + s_line * w
            # the shore from t1 over the corner to t2, and the stretches of edges it spans
            bent = [v[x] for x in verts[:seg + 1]] + [foot]
            vset = verts[:seg + 1]
            if tau[best, seg] >= seg_len[seg] - 1e-9:     # tangent at a vertex
                vset = verts[:seg + 2]
            stretches = []
            for n_e, k in enumerate(edges[:seg + 1]):
                cut = tau[best, seg] if n_e == seg else seg_len[n_e]
                if n_e < len(run) - 1:
                    continue              # the blunt point's own short edges
                stretches.append((k, 0.0, cut) if straight_in else (k, length[k] - cut, length[k]))
            if straight_in:
                t1, t2 = t_line, foot
                path = [t_line] + bent
                stretches.append((k_in, length[k_in] - s_line, length[k_in]))
            else:
                t1, t2 = foot, t_line
                path = bent[::-1] + [t_line]
                stretches.append((k_out, 0.0, s_line))
            sweep = (np.arctan2(*(t1 - centre)[::-1]) - np.arctan2(*(t2 - centre)[::-1])) % (2 * np.pi)
            if not 0.0 < sweep < np.pi:
                return None
            apex = v[run[0]]
            reach = float(max(np.hypot(*(t1 - apex)), np.hypot(*(t2 - apex))))
            return _Fillet(np.vstack(path), centre, r, float(sweep), [int(x) for x in vset],
                           stretches, apex, reach)
        return None


def _fillet_polygons(fillets: list[_Fillet]) -> np.ndarray:
    """The pieces of the fillets: each one's shore path closed by its arc."""
    step = 0.5 * np.pi / FILLET_QUAD_SEGS
    rings = []
    for f in fillets:
        n = max(1, int(np.ceil(f.sweep / step - 1e-9)))
        t2, t1 = f.path[-1], f.path[0]
        phi = np.arctan2(t2[1] - f.centre[1], t2[0] - f.centre[0]) + np.linspace(0.0, f.sweep, n + 1)
        arc = f.centre + f.radius * np.stack([np.cos(phi), np.sin(phi)], axis=1)
        arc[0], arc[-1] = t2, t1
        rings.append(np.vstack([f.path, arc[1:]]))
    return shapely.polygons(shapely.linearrings(
        np.vstack(rings), indices=np.repeat(np.arange(len(rings)), [len(x) for x in rings])))
