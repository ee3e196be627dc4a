"""Basins in a river's given water (issue 22): a harbour, a dock, a marina, a side basin.

A river polygon (:meth:`RiverNetworkBuilder.set_water_area`) may hold water off its channels:
a notch in a bank whose far side faces away from the channel's axis, which Proland's ψ
interpolation (a weighted mean of the banks' ψ, reference §2) cannot carry: between the basin's
far wall and the river's other bank it makes the basin's water run as fast as the river's,
and the graph's rule that a bank has its axis on its left fails behind a point of land.

:func:`find_basins` finds them from the channels' axes: a stretch of the outline (of any ring)
farther from its nearest axis than that channel's half width allows (by more than
BASIN_MIN_DEPTH widths at its deepest) is a basin, closed across its opening by a straight
*mouth* between the last outline points on either side that the channel's half width
reaches, when it is a pocket: as deep beyond its mouth as BASIN_POCKET of the mouth's width
(a long shallow bulge of a bank, or the far side of a free island from a line running past
it, stays the channel's water). The builder then makes each basin a **still lake** with the river passing its mouth
(:mod:`riverflow.hydro._lakes`: one mechanism): its shore is one boundary piece tied to the
bank it opens from, so its ψ is that bank's ψ and its water is still (velocity 0, tangent to
its walls); the mouth is one bank curve shared by the river's area and the basin's (Proland's
curves may have an area on each side): for the river it continues its bank straight across the
opening (its flow goes by, unchanged, continuous along the bank), for the basin it closes its
shore (:func:`riverflow.hydro.flow_network.build_flow_network` gives each side its copy).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import shapely
from shapely.geometry.polygon import orient

BASIN_MIN_DEPTH = 0.25
"""A basin reaches at least this many of its channel's widths beyond the channel's bank."""
BASIN_POCKET = 0.25
"""A basin reaches at least this many of its mouth's widths beyond its mouth (a pocket, not a
long shallow bulge of the bank: that is water the channel's flow runs along). 0.4 left a bay
80 m wide and 25 m deep off a 60 m river to the channel, whose ψ interpolation ran it at 70 %
of the river's speed, faster than the river at its corners and upstream beside its walls: a
bay with a quarter of its width in depth is the river's dead water (still, joined at its
mouth)."""
BASIN_MIN_AREA = 0.05
"""A basin's area is at least this many squared widths of its channel, unless it is deeper
beyond its mouth than its mouth is wide (a slip 4 m wide and 30 m deep off a 150 m river: as
the channel's water its walls faced away from the axis)."""
BANK_MARGIN = 0.02
"""An outline point is off the channel when it lies farther than the half width plus this many
widths (and the builder's tolerance) from the axis."""
DEAD_STEP = 0.5
"""A backwater (:func:`_backwater`) is read from its outline at points at most this many of
its dead end's widths apart (a straight shore has no vertices of its own along it)."""
DEAD_CHUNK = 64
"""Outline points :func:`_backwater` asks at a time, walking out from the dead end's far end."""
OPEN_END_REACH = 0.25
"""A backwater is a basin when it lies at least this many of its channel's widths from the
axes' free ends (other basins: a width; nearer, the data's edge cuts across it)."""
LEE_VERTICES = 24
"""A lee's mouth (:func:`_lees`) starts at most this many outline vertices from it."""
LEE_MOUTH_WIDTHS = 1.0
"""A lee's mouth is at most this many of its channel's widths long..."""
LEE_SINE = float(np.sin(np.radians(10.0)))
"""...and faces its axis by at least 10° (a bank whose axis lies ahead along it has none of
the flow's direction to give)."""
LEE_STEPS = 32.0
"""A lee's mouth ends on the outline at points this many per width."""
LEE_TRIES = 8
"""The smallest pockets tried in turn as a lee's basin (its mouth in the water)."""
LEE_END_WIDTHS = 0.25
"""No lee lies nearer than this many of its channel's widths to a free end of the axes."""
WIDTH_WINDOW = 1.0
"""The channel's width by a point is the median of its axis' widths within this many widths
along the axis (a basin widens the skeleton's inscribed circles beside its mouth)."""


@dataclass
class Basin:
    """A basin found in the given water: its polygon [m] (closed by its mouth), the mouth
    (2, 2) [m], its depth beyond the channel's bank [m] and the channel's width there [m]."""

    polygon: shapely.Polygon
    mouth: np.ndarray
    depth_m: float
    width_m: float
    mouths: list | None = None
    """All its mouths [(2, 2)] [m], the widest (``mouth``) first: several where islands part
    it from the channel (a marina's piers joined behind them)."""

    def describe(self) -> str:
        x, y = 0.5 * (self.mouth[0] + self.mouth[1])
        return (f"a basin of {self.polygon.area:.0f} m² reaching {self.depth_m:.1f} m beyond the "
                f"bank of a {self.width_m:.1f} m channel, its mouth "
                f"{float(np.hypot(*(self.mouth[1] - self.mouth[0]))):.1f} m wide at "
                f"({x:.1f}, {y:.1f})"
                + (f" and {len(self.mouths) - 1} more" if self.mouths and len(self.mouths) > 1
                   else "")
                + ": still water (a lake joined to the river at its mouth, its ψ the bank's)")


class _Grown:
    """A water polygon ``poly`` and, called with a distance, its outline grown by that much
    (``poly.buffer``, prepared), made once per distance: the basin tests ask it of the whole
    water (thousands of vertices) for every candidate."""

    def __init__(self, poly) -> None:
        self.poly = poly
        self._by: dict[float, shapely.Geometry] = {}

    def __call__(self, distance: float):
        wet = self._by.get(distance)
        if wet is None:
            wet = self._by[distance] = self.poly.buffer(distance)
            shapely.prepare(wet)
        return wet


def _robust_widths(line: np.ndarray, widths: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Arc lengths (K,) and the running median of the widths over WIDTH_WINDOW widths."""
    s = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(line, axis=0).T))])
    half = 0.5 * WIDTH_WINDOW * np.asarray(widths, np.float64)
    lo = np.searchsorted(s, s - half, side="left")
    hi = np.searchsorted(s, s + half, side="right")
    out = np.array([np.median(widths[a:b]) for a, b in zip(lo.tolist(), hi.tolist())])
    return s, out


class _Axes:
    """The channels' axes [(centre line (K, 2), widths (K,))] for :func:`_excess`: their
    segments in one box hierarchy (the nearest axis of a point at once, not each axis'
    distance to every outline point: London's Thames, 58 axes of thousands of vertices,
    took minutes), each axis' arc lengths and running-median widths."""

    def __init__(self, axes: list[tuple[np.ndarray, np.ndarray]]) -> None:
        from riverflow.hydro.nearest import PolylineIndex

        lines = [np.asarray(a, np.float64).reshape(-1, 2) for a, _ in axes]
        self.index = PolylineIndex(np.vstack(lines), np.repeat(np.arange(len(lines)),
                                                               [len(a) for a in lines]))
        self.arcs = [_robust_widths(a, np.asarray(w, np.float64))
                     for a, (_, w) in zip(lines, axes)]
        lengths = np.array([arc[-1] for arc, _ in self.arcs])
        self.start = np.concatenate([[0.0], np.cumsum(lengths)[:-1]])


def _excess(points: np.ndarray, axes: _Axes):
    """For each point, how far beyond its channel's bank it lies (distance to the nearest axis
    minus the half width there) [m], -inf where no axis has it beside its interior, and that
    channel's width [m]."""
    near = axes.index.nearest_segments(np.asarray(points, np.float64).reshape(-1, 2))
    d, arc = near.dist, near.arc
    k = (axes.index.segment_line[near.seg] if axes.index.segment_line is not None
         else np.zeros(len(d), np.int64))           # (the segment's axis, not the arc's:
    #                                                 an end's arc is the next one's start)
    out = np.full(len(d), -np.inf)
    width = np.zeros(len(d))
    for j in np.unique(k).tolist():
        at = np.flatnonzero(k == j)
        s, rw = axes.arcs[j]
        t = np.clip(arc[at] - axes.start[j], 0.0, s[-1])
        inner = (t > 1e-9 * max(1.0, s[-1])) & (t < s[-1] * (1.0 - 1e-9))
        hw = 0.5 * np.interp(t, s, rw)
        out[at] = np.where(inner, d[at] - hw, -np.inf)
        width[at] = 2.0 * hw
    return out, width


def find_basins(water, axes: list[tuple[np.ndarray, np.ndarray]], avoid=(),
                tolerance_m: float = 0.25, dead=(), lees=()) -> list[Basin]:
    """The basins of ``water`` (a Polygon or MultiPolygon [m]) beside the channels ``axes``
    [(centre line (K, 2), widths (K,))] (module docstring); outline points within ``avoid``
    (polygons: lakes) are never in a basin, nor is the outline within a channel's width of
    a free end of the axes (an open end: the data's edge, drawn slanted across the water by
    a mask's cells, is no bank). ``dead``: axes like ``axes``' of dead ends known to be
    basins (the skeleton's spurs dropped as basins, from their channel's bank on); one whose
    far end no basin found so holds is a backwater behind a spit (:func:`_backwater`).
    ``lees``: [(point (2,), axis (K, 2))], bank segments a built graph found facing away from
    their axis; the pockets behind them are basins too (:func:`_lees`)."""
    if not axes:
        return []
    avoid_u = shapely.union_all(list(avoid)) if len(avoid) else None
    polys = getattr(water, "geoms", [water])
    found: list[Basin] = []
    for poly in polys:
        poly = orient(poly, 1.0)
        grown = _Grown(poly)
        # each polygon's own channels: a neighbour's axis across a strip of land is no
        # channel of its water (a sliver between an island and the bank it crosses: its
        # dead end beside a lee of the river took the lee for the open end of the water)
        own = axes if len(polys) == 1 else _own_axes(axes, grown(tolerance_m))
        if not own:
            continue
        index, lines, free_ends = _axes_of(own, tolerance_m)
        for ring in [poly.exterior, *poly.interiors]:
            v = np.asarray(ring.coords)[:-1]
            if len(v) < 4:
                continue
            excess, width = _excess(v, index)
            margin = BANK_MARGIN * width + tolerance_m
            out = excess > margin
            if avoid_u is not None:
                out &= ~shapely.dwithin(avoid_u, shapely.points(v), tolerance_m)
            if not out.any() or out.all():
                continue
            start = int(np.flatnonzero(~out)[0])
            order = np.roll(np.arange(len(v)), -start)      # begins off any basin
            k = 0
            while k < len(order):
                if not out[order[k]]:
                    k += 1
                    continue
                j = k
                while j < len(order) and out[order[j]]:
                    j += 1
                run = order[k:j]
                before, after = order[k - 1], order[j % len(order)]
                k = j
                basin = _basin(v, run, before, after, excess, width, grown, lines, tolerance_m)
                if basin is not None and free_ends is not None and not free_ends.is_empty and (
                        shapely.distance(basin.polygon, free_ends) < basin.width_m):
                    basin = None         # beside an open end: the data's edge, no bank
                if basin is not None:
                    found.append(basin)
        for a, w in dead:
            if len(a) < 2 or not grown(tolerance_m).contains(shapely.Point(a[-1])) or any(
                    b.polygon.buffer(tolerance_m).contains(shapely.Point(a[-1])) for b in found):
                continue
            basin = _backwater(grown, a, w, index, lines, avoid_u, tolerance_m)
            if basin is not None and free_ends is not None and not free_ends.is_empty and (
                    shapely.distance(basin.polygon, free_ends) < OPEN_END_REACH * basin.width_m):
                basin = None             # (the data's edge cutting across it)
            if basin is not None and not any(b.polygon.intersection(basin.polygon).area
                                             > 1e-6 * basin.polygon.area for b in found):
                found.append(basin)
        found += _lees(grown, index, lines, found, lees, free_ends, tolerance_m)
    return found


def _own_axes(axes: list[tuple[np.ndarray, np.ndarray]], wet) -> list:
    """The axes whose middle (by arc length) lies in ``wet`` (a prepared polygon)."""
    out = []
    for a, w in axes:
        line = shapely.LineString(np.asarray(a, np.float64).reshape(-1, 2))
        if wet.contains(line.interpolate(0.5, normalized=True)):
            out.append((a, w))
    return out


def _axes_of(axes: list[tuple[np.ndarray, np.ndarray]], tolerance_m: float):
    """(:class:`_Axes`, the axes' lines in one geometry, their free ends: the ends that meet
    no other axis' end within ``tolerance_m``, a MultiPoint)."""
    lines = shapely.union_all([shapely.LineString(a) for a, _ in axes])
    ends = np.array([a[i] for a, _ in axes for i in (0, -1)], dtype=float).reshape(-1, 2)
    near = np.hypot(*(ends[:, None, :] - ends[None, :, :]).transpose(2, 0, 1)) <= tolerance_m
    free_ends = shapely.multipoints(ends[near.sum(axis=1) == 1]) if len(ends) else None
    return _Axes(axes), lines, free_ends


def _lees(grown: _Grown, axes: _Axes, lines, found: list[Basin], lees, free_ends,
          tolerance_m: float) -> list[Basin]:
    """The lees of ``grown.poly``'s outer shore: ``lees`` [(point (2,), axis (K, 2))] are the
    middles of bank segments that a built graph found facing away from the axis it read them
    with (the axis on their right, which no bank may have: the far side of a point of land,
    a step in a bank, a bay's back wall). Each run of such edges of the outline is closed by
    a *mouth* from a vertex on one side of it (the point of land's tip, at most LEE_VERTICES
    away) to a point of the outline on the other side, no longer than LEE_MOUTH_WIDTHS of
    the channel's width, with all the outline between on its land side and facing that axis
    by at least LEE_SINE, in the water; of those, the one that closes the least water: the
    pocket behind it is still water, a basin, in place of the basins found that it holds (a
    creek's inner reach beyond the walls of its mouth; ``found`` loses them). None across a
    basin's mouth, nor within LEE_END_WIDTHS of a free end of the axes (the water's open
    end)."""
    from riverflow.hydro.nearest import PolylineIndex

    ring = grown.poly.exterior
    v = np.asarray(ring.coords)[:-1]
    n = len(v)
    if n < 4 or not len(lees):
        return []
    eps = max(1e-6 * float(np.abs(v).max()), 1e-3 * tolerance_m)
    pts = np.array([p for p, _ in lees], np.float64).reshape(-1, 2)
    on = np.flatnonzero(shapely.distance(ring, shapely.points(pts)) <= eps)
    if not len(on):
        return []
    seg = PolylineIndex(np.vstack([v, v[:1]])).nearest_segments(pts[on]).seg
    axis_of = {}
    for i, k in zip(on.tolist(), seg.tolist()):
        axis_of.setdefault(int(k) % n, lees[i][1])
    away = np.zeros(n, bool)
    away[list(axis_of)] = True
    if away.all():
        return []
    wet = grown(eps)
    out: list[Basin] = []
    start = int(np.flatnonzero(~away)[0])
    order = np.roll(np.arange(n), -start)
    runs, k = [], 0
    while k < n:
        if not away[order[k]]:
            k += 1
            continue
        j = k
        while j < n and away[order[j]]:
            j += 1
        runs.append((k + start, j - 1 + start))       # (first, last edge, unwrapped)
        k = j
    for s, e in runs:
        _, width = _excess(0.5 * (v[np.arange(s, e + 1) % n] + v[np.arange(s + 1, e + 2) % n]),
                           axes)
        w = float(np.median(width))
        if not w > 0.0:
            continue
        basin = _lee(v, s, e, w, PolylineIndex(np.asarray(axis_of[s % n], np.float64)), wet,
                     lines)
        if basin is None or (free_ends is not None and not free_ends.is_empty and (
                shapely.distance(basin.polygon, free_ends) < LEE_END_WIDTHS * w)):
            continue                  # (the water's open end, cut across there)
        area = basin.polygon.area
        meets = [bs for bs in found + out
                 if bs.polygon.intersection(basin.polygon).area > 1e-6 * area]
        if any(shapely.difference(bs.polygon, basin.polygon).area > 1e-6 * bs.polygon.area
               for bs in meets):
            continue                  # (across a basin's mouth)
        # (in place of the basins it holds: a creek's inner reach)
        found[:] = [b for b in found if not any(b is m for m in meets)]
        out = [b for b in out if not any(b is m for m in meets)] + [basin]
    return out


def _lee(v: np.ndarray, s: int, e: int, w: float, axis, wet, lines) -> Basin | None:
    """The basin behind edges s..e (unwrapped indices) of ring ``v`` (:func:`_lees`)."""
    n = len(v)
    reach = LEE_MOUTH_WIDTHS * w
    # the outline round the run, its edges cut to LEE_STEPS per width, and which of its
    # points are the ring's vertices
    k = min(LEE_VERTICES, (n - 2 - (e + 1 - s)) // 2)
    if k < 0:
        return None
    given = v[np.arange(s - k, e + 2 + k) % n]
    step = np.maximum(np.ceil(np.hypot(*np.diff(given, axis=0).T) * LEE_STEPS / w), 1).astype(int)
    fine = np.vstack([given[a] + np.linspace(0.0, 1.0, m, endpoint=False)[:, None]
                      * (given[a + 1] - given[a]) for a, m in enumerate(step.tolist())]
                     + [given[-1:]])
    vertex = np.concatenate([[0], np.cumsum(step)])
    first, last = int(vertex[k]), int(vertex[k + 1 + e - s])        # the run's ends
    crs = fine[:-1, 0] * fine[1:, 1] - fine[:-1, 1] * fine[1:, 0]
    acc = np.concatenate([[0.0], np.cumsum(crs)])
    best = []
    tips_before = vertex[vertex <= first]
    tips_after = vertex[vertex >= last]
    for tips, forward in ((tips_before, True), (tips_after, False)):
        for t in tips.tolist():
            ends = np.arange(last, len(fine)) if forward else np.arange(0, first + 1)
            if not len(ends):
                continue
            i, j = (np.full(len(ends), t), ends) if forward else (ends, np.full(len(ends), t))
            chord = fine[j] - fine[i]
            length = np.hypot(*chord.T)
            ok = (length > 0.0) & (length <= reach)
            if not ok.any():
                continue
            i, j, chord, length = i[ok], j[ok], chord[ok], length[ok]
            # every point between on the land side (the right: the water is on the ring's left)
            lo_k, hi_k = int(i.min()) + 1, int(j.max())
            between = fine[lo_k:hi_k]
            side = (chord[:, None, 0] * (between[None, :, 1] - fine[i][:, None, 1])
                    - chord[:, None, 1] * (between[None, :, 0] - fine[i][:, None, 0]))
            kk = np.arange(lo_k, hi_k)[None, :]
            inside = (kk > i[:, None]) & (kk < j[:, None])
            ok = ~((side > 1e-9 * (length ** 2)[:, None]) & inside).any(axis=1)
            if not ok.any():
                continue
            i, j, chord = i[ok], j[ok], chord[ok]
            mid = 0.5 * (fine[i] + fine[j])
            ok = _sine(chord, axis.nearest(mid)[1] - mid) >= LEE_SINE
            i, j = i[ok], j[ok]
            area = 0.5 * (acc[j] - acc[i] + fine[j, 0] * fine[i, 1] - fine[j, 1] * fine[i, 0])
            best += list(zip(area.tolist(), i.tolist(), j.tolist()))
    for area, i, j in sorted(best)[:LEE_TRIES]:
        pocket = fine[i:j + 1]
        mouth = shapely.LineString([pocket[0], pocket[-1]])
        basin = shapely.Polygon(pocket)
        if (not basin.is_valid or not basin.area > 0.0 or not wet.contains(mouth)
                or shapely.intersects(basin, lines)):
            continue
        t = (pocket[-1] - pocket[0]) / float(np.hypot(*(pocket[-1] - pocket[0])))
        depth = float(np.abs((pocket - pocket[0]) @ np.array([-t[1], t[0]])).max())
        return Basin(orient(basin, 1.0), np.array([pocket[0], pocket[-1]]), depth, w)
    return None


def _sine(d: np.ndarray, to: np.ndarray) -> np.ndarray:
    """How far ``to`` lies left of directions ``d`` (N, 2): the sine of their angle."""
    return (d[:, 0] * to[:, 1] - d[:, 1] * to[:, 0]) / np.maximum(
        np.hypot(*d.T) * np.hypot(*to.T), 1e-300)


def _backwater(grown: _Grown, dead: np.ndarray, dead_widths: np.ndarray, axes, lines, avoid_u,
               tolerance_m: float) -> Basin | None:
    """The basin of a dead end known to be one (``dead``: its axis beyond its channel's bank,
    (K, 2) [m]) that the channels' half widths do not find: a backwater behind a spit of land,
    whose inner shore lies nearer the channel's axis (across the spit) than its half width.
    It is the stretch of the outer ring (read at points DEAD_STEP of its width apart) round the
    dead end's far end that sees the dead end's axis across the water and not the channels'
    axes (the spit between), closed by a mouth between its last points (from the spit's tip
    across the backwater), or None (also where none of it faces away from the channels'
    axes: the channel's water as it is)."""
    from riverflow.hydro.nearest import PolylineIndex

    poly = grown.poly
    wet = grown(max(1e-6 * float(np.abs(np.asarray(poly.exterior.coords)).max()),
                    1e-3 * tolerance_m))
    mine = [g for g in shapely.get_parts(lines) if shapely.intersects(wet, g)]
    if not mine:
        return None
    # the nearest point of this water's axes to each outline point through their segments'
    # box hierarchy (GEOS's shortest_line visits every vertex of every axis for each point:
    # minutes for London's Thames, its docks dead ends each)
    xy, which = shapely.get_coordinates(np.array(mine, dtype=object), return_index=True)
    local = PolylineIndex(xy, which)
    axis = shapely.LineString(dead)
    tip = shapely.Point(dead[-1])
    ring = poly.exterior
    if any(r.distance(tip) < ring.distance(tip) for r in poly.interiors):
        return None     # (a notch in an island's shore: the builder asks no more of it)
    v = np.asarray(shapely.segmentize(ring, max(DEAD_STEP * float(np.median(dead_widths)),
                                                tolerance_m)).coords)[:-1]
    n = len(v)
    # whether each outline point is hidden from the channels' axes (its shortest line to them
    # leaves the water) and sees the dead end's: learnt outward from the point nearest the
    # dead end's far end, a chunk at a time, only as far as the hidden run reaches (the
    # rest of a long ring, London's Thames, need not be asked)
    state = np.full(n, -1, np.int8)
    near = np.full((n, 2), np.nan)

    def learn(idx: np.ndarray) -> None:
        idx = idx[state[idx] < 0]
        if not len(idx):
            return
        p = v[idx]
        pts = shapely.points(p)
        q = local.nearest(p)[1]
        hidden = (~shapely.covers(wet, shapely.linestrings(np.stack([q, p], axis=1)))
                  & shapely.covers(wet, shapely.shortest_line(axis, pts)))
        if avoid_u is not None:
            hidden &= ~shapely.dwithin(avoid_u, pts, tolerance_m)
        state[idx] = hidden
        near[idx] = q

    at = int(np.argmin(np.hypot(*(v - dead[-1]).T)))
    learn(np.array([at]))
    if state[at] != 1:
        return None
    k0, k1 = at, at
    for step in (-1, 1):
        while k1 - k0 < n - 1:
            j = ((k0 if step < 0 else k1) + step) % n
            if state[j] < 0:
                learn(((k0 if step < 0 else k1) + step * np.arange(1, DEAD_CHUNK + 1)) % n)
            if state[j] != 1:
                break
            k0, k1 = (k0 - 1, k1) if step < 0 else (k0, k1 + 1)
    if k1 - k0 >= n - 1:
        return None                                     # (all of it hidden)
    learn(np.array([(k0 - 1) % n, (k1 + 1) % n]))
    run = np.arange(k0, k1 + 1) % n
    # only where some of it faces away from the channels' axes (a spit's inner shore, the
    # axis on its right: which no bank may); else the channel's water as it is
    d = v[(run + 1) % n] - v[run]
    tv = 0.5 * (near[run] + near[(run + 1) % n]) - 0.5 * (v[run] + v[(run + 1) % n])
    if not (d[:-1, 0] * tv[:-1, 1] - d[:-1, 1] * tv[:-1, 0] < 0.0).any():
        return None
    ends = np.concatenate([run, [(k0 - 1) % n, (k1 + 1) % n]])
    excess, width = np.full(n, -np.inf), np.zeros(n)
    excess[ends], width[ends] = _excess(v[ends], axes)
    behind = ends[state[ends] == 1]
    excess[behind] = np.maximum(excess[behind], np.hypot(*(near[behind] - v[behind]).T)
                                - 0.5 * width[behind])
    return _basin(v, run, (k0 - 1) % n, (k1 + 1) % n, excess, width, grown, lines,
                  tolerance_m)


def _basin(v, run, before, after, excess, width, grown: _Grown, lines, tolerance_m
           ) -> Basin | None:
    """The basin of one run of outline points off the channel, or None when it is too small,
    or its mouth does not lie in the water."""
    w = float(np.median(width[run]))
    depth = float(excess[run].max())
    if not depth >= BASIN_MIN_DEPTH * w:
        return None

    def corner(inner: int, outer: int) -> np.ndarray:
        # the outline point the channel's bank reaches: the last one beside the channel,
        # or where a long edge (longer than half a width) running obliquely away from the
        # bank crosses the bank's line
        a, b = v[inner], v[outer]
        ea, eb = excess[inner], excess[outer]
        length = float(np.hypot(*(b - a)))
        if length <= 0.5 * w or eb - ea >= 0.5 * length:
            return a
        t = np.clip(-ea / max(eb - ea, 1e-12), 0.0, 1.0)     # on the bank's line
        return a + t * (b - a)

    a, b = corner(before, run[0]), corner(after, run[-1])
    mouth_m = float(np.hypot(*(b - a)))
    t = (b - a) / max(mouth_m, 1e-12)
    pocket = float(np.abs((v[run] - a) @ np.array([-t[1], t[0]])).max())
    if not pocket >= max(BASIN_MIN_DEPTH * w, BASIN_POCKET * mouth_m):
        return None         # a bulge of the bank along the channel, not a pocket
    ring = np.vstack([a, v[run], b])
    basin = shapely.Polygon(ring)
    if not basin.is_valid:
        basin = shapely.make_valid(basin)
        basin = max(getattr(basin, "geoms", [basin]), key=lambda g: g.area)
        if not isinstance(basin, shapely.Polygon):
            return None
    slip = pocket >= mouth_m
    if basin.area < BASIN_MIN_AREA * w * w and not slip:
        return None
    mouth = shapely.LineString([a, b])
    eps = max(1e-6 * max(1.0, float(np.abs(v).max())), 1e-3 * tolerance_m)
    poly, wet = grown.poly, grown(eps)
    mouths = [np.array([a, b])]
    if shapely.difference(basin, wet).area > 1e-6 * basin.area:
        # islands in it (a marina's piers between its slips, joined behind them): its water,
        # open to the channel where the straight line across it is in the water
        if shapely.difference(basin, shapely.Polygon(poly.exterior).buffer(eps)).area > (
                1e-6 * basin.area):
            return None
        basin = shapely.intersection(basin, poly)
        basin = max(getattr(basin, "geoms", [basin]), key=lambda g: g.area)
        if not isinstance(basin, shapely.Polygon) or (basin.area < BASIN_MIN_AREA * w * w
                                                      and not slip):
            return None
        cut = shapely.intersection(shapely.intersection(mouth, wet), basin.buffer(eps))
        mouths = [np.asarray(g.coords)[[0, -1]] for g in shapely.get_parts(
            shapely.line_merge(cut) if cut.geom_type == "MultiLineString" else cut)
                  if g.geom_type == "LineString" and g.length > 2.0 * eps]
        if not mouths:
            return None
        mouths.sort(key=lambda m: -float(np.hypot(*(m[1] - m[0]))))
        mouth = shapely.LineString(mouths[0])
    if (shapely.difference(basin, wet).area > 1e-6 * basin.area
            or shapely.intersects(basin, lines)
            or not wet.contains(mouth)):
        return None
    return Basin(orient(basin, 1.0), mouths[0], depth, w, mouths)
