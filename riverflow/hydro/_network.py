"""Hydro-graph assembly for :mod:`riverflow.hydro.builder`: ψ of the boundary pieces, axes,
bank curves split by nearest axis, closing segments, nodes and areas (reference §1.2).

The boundary pieces (stretches of water outline between closing segments, and whole island
loops) are the nodes of a small graph whose edges are the branches: facing downstream,
ψ(right piece) − ψ(left piece) = the branch's discharge. ψ is solved by breadth-first search
from 0 on one piece, checked around every loop, and shifted so that its minimum is 0. A
branch's banks are the pieces the rays across its middle meet; where those do not solve (a
branch beside a short island meets the shore beyond it), the pieces facing each branch
(:func:`_sides_by_shores`).

Lateral inflow (``inlets``: surplus discharge entering at a junction) cuts the two banks of the
junction's outgoing branch with a short closing segment each (an inlet across from the
junction); the pieces on both sides of an inlet are tied by ψ(downstream) − ψ(upstream) =
−surplus/2 on the left bank, +surplus/2 on the right one.
"""
from __future__ import annotations

from collections import deque
from dataclasses import dataclass

import numpy as np
import shapely
from scipy.spatial import cKDTree
from shapely.geometry import LineString, Point

from riverflow.hydro._strips import Piece, Ring
from riverflow.hydro.graph import (LAKE_INFO, LAKE_LEVEL_INFO, NO_CURVE, NO_POTENTIAL, Area, Curve,
                                   CurveType, GraphError, HydroGraph)
from riverflow.hydro.nearest import (LineChunks, PolylineIndex, first_per_group, ray_hits, stations,
                                     tangents_at)

AXIS_WIDTH_FACTOR = 1.1
"""Axis width = largest river width along it × this + AXIS_MARGIN_M (reference rule 1)."""
AXIS_MARGIN_M = 1.0
AXIS_SPLIT_RATIO = 0.25
"""A branch's axis is split where its width differs from the axis start by more than this."""
_STATIONS = (0.2, 0.35, 0.5, 0.65, 0.8)
INLET_WIDTH_FRACTION = 0.25
"""Length of a lateral-inflow inlet cut into a bank, as a fraction of the river's width (at most
a tenth of the shorter branch at its junction, so it stays across from the junction)."""


@dataclass
class BranchGeometry:
    """A branch after junction snapping: centre line (K, 2) and widths (K,) [m], discharge
    [m²/s], start / end junction index (-1 = free end) and, once built, its strip polygon."""

    name: str
    centerline_m: np.ndarray
    widths_m: np.ndarray
    discharge_m2s: float
    start_junction: int
    end_junction: int
    strip: shapely.Geometry | None = None

    def station(self, fraction: float) -> tuple[np.ndarray, np.ndarray, float]:
        """Point (2,), unit left normal (2,) and half-width [m] at an arc-length fraction."""
        p, n, w = stations(self.centerline_m, np.array([fraction]), self.widths_m)
        return p[0], n[0], 0.5 * w[0]


@dataclass
class LakeParts:
    """The lakes of a build (:mod:`riverflow.hydro._lakes`): the lakes, per lake its axes
    [(points (2, 2) drawn downstream, width of the river at the mouth [m])], and per water
    polygon its lake (-1: a river polygon)."""

    lakes: list
    axes: list[list[tuple[np.ndarray, float]]]
    polygon_lake: list[int]


def _first_hits(origins: np.ndarray, directions: np.ndarray, reach_m: np.ndarray,
                lines: LineChunks) -> np.ndarray:
    """For each ray (origins, unit directions (R, 2), lengths (R,) [m]), the index of the
    first of the lines it crosses (of equally near crossings, the lowest line), or of the
    line nearest its far end if it crosses none (the first of equally near ones), (R,)."""
    ray, hit, dist = ray_hits(origins, directions, reach_m, lines)
    first = first_per_group(ray, dist, len(origins))
    out = np.where(first >= 0, hit[np.maximum(first, 0)] if len(hit) else -1, -1)
    missed = np.flatnonzero(out < 0)
    if len(missed):
        ends = origins[missed] + directions[missed] * reach_m[missed][:, None]
        at, nearest = lines.line_tree.query_nearest(shapely.points(ends))
        pick = first_per_group(at, np.zeros(len(at)), len(missed))
        out[missed] = nearest[pick]
    return out


def _branch_sides(geoms: list[BranchGeometry], pieces: list[Piece], island_of: dict[int, int]
                  ) -> list[tuple[int, int]]:
    """(left piece, right piece) of each branch, facing downstream (majority over stations;
    every station's rays in one bulk query)."""
    ids = [i for i in range(len(pieces)) if i not in island_of]
    lines = LineChunks([np.vstack([pieces[i].points, pieces[i].points[:1]]) if pieces[i].closed
                        else pieces[i].points for i in ids])
    at = [stations(g.centerline_m, np.asarray(_STATIONS), g.widths_m) for g in geoms]
    origins = np.vstack([p for p, _, _ in at])
    normals = np.vstack([n for _, n, _ in at])
    reach = 1.5 * (0.5 * np.concatenate([w for _, _, w in at])) + 1.0
    # rays: left then right at every station
    hits = _first_hits(np.repeat(origins, 2, axis=0),
                       np.stack([normals, -normals], axis=1).reshape(-1, 2),
                       np.repeat(reach, 2), lines).reshape(len(geoms), len(_STATIONS), 2)
    sides = []
    for g, station_hits in zip(geoms, hits):
        votes = [(ids[left], ids[right]) for left, right in station_hits]
        best = max(set(votes), key=lambda v: (votes.count(v), -votes.index(v)))
        if best[0] == best[1]:
            raise GraphError(f"branch {g.name!r}: both of its banks are one continuous shore; "
                             f"its strip overlaps itself or another branch (a bend tighter than "
                             f"its width, or a branch that doubles back)")
        sides.append(best)
    return sides


def _sides_by_shores(geoms: list[BranchGeometry], pieces: list[Piece],
                     island_of: dict[int, int]) -> list[tuple[int, int]]:
    """(left piece, right piece) of each branch, facing downstream, seen from the shores:
    from points along each piece a ray runs out across the water (the piece's normal) to the
    first branch it meets, which has that piece on the side the ray comes from; a branch's
    bank on each side is the piece that reaches it over the most length. Where a branch runs
    beside a short island, or past a point of land whose tip lies off its middle, the rays
    from its middle (:func:`_branch_sides`) miss that shore and meet the one beyond."""
    lines = [np.asarray(g.centerline_m, np.float64) for g in geoms]
    chunks = LineChunks(lines)
    width = min(float(np.median(g.widths_m)) for g in geoms)
    reach = 2.0 * max(float(np.max(g.widths_m)) for g in geoms) + 1.0
    ids = [i for i in range(len(pieces)) if i not in island_of]
    total = sum(shapely.length(pieces[i].line()) for i in ids)
    step = max(0.125 * width, total / 20_000.0, 1e-6)
    weight = np.zeros((len(geoms), 2, len(pieces)))
    for i in ids:
        v = shapely.get_coordinates(shapely.segmentize(pieces[i].line(), step))
        if len(v) < 2:
            continue
        d = np.diff(v, axis=0)
        length = np.hypot(*d.T)
        ok = length > 0
        mid, d, length = (0.5 * (v[1:] + v[:-1]))[ok], d[ok], length[ok]
        inward = np.stack([-d[:, 1], d[:, 0]], axis=1) / length[:, None]  # water on the left
        ray, hit, dist = ray_hits(mid, inward, np.full(len(mid), reach), chunks)
        first = first_per_group(ray, dist, len(mid))
        got = np.flatnonzero(first >= 0)
        if not len(got):
            continue
        b = hit[first[got]]
        at = mid[got] + inward[got] * dist[first[got]][:, None]
        # the branch's direction where the ray meets it: coming from its left, the ray runs
        # against its left normal
        tangent = np.empty((len(b), 2))
        for k in np.unique(b).tolist():          # each branch's points at once
            on = np.flatnonzero(b == k)
            tangent[on] = tangents_at(lines[k], at[on])
        from_right = (tangent[:, 0] * inward[got, 1] - tangent[:, 1] * inward[got, 0]) > 0.0
        np.add.at(weight, (b, from_right.astype(int), np.full(len(b), i)), length[got])
    sides = []
    for k, g in enumerate(geoms):
        left, right = (int(np.argmax(weight[k, side])) for side in (0, 1))
        if not (weight[k, 0, left] > 0 and weight[k, 1, right] > 0) or left == right:
            raise GraphError(f"branch {g.name!r}: no shore faces it on both sides")
        sides.append((left, right))
    return sides


def _solve_potentials(geoms, sides, pieces, island_of, ties=(), still=frozenset()) -> np.ndarray:
    """ψ of every non-island piece [m²/s], minimum 0 in each connected network; ``ties``
    (upstream piece, downstream piece, ψ step [m²/s], junction point) across inlets and where
    pieces meet; ``still``: pieces that may have no branch along them (the shore of a lake
    with no river: ψ 0)."""
    adj: dict[int, list[tuple[int, float, int]]] = {}
    for b, (l, r) in enumerate(sides):
        q = geoms[b].discharge_m2s
        adj.setdefault(l, []).append((r, q, b))
        adj.setdefault(r, []).append((l, -q, b))
    for k, (up, down, step, _) in enumerate(ties):
        adj.setdefault(up, []).append((down, step, -1 - k))
        adj.setdefault(down, []).append((up, -step, -1 - k))
    # the search runs in the branches' order, not the pieces' numbering: the sums (and their
    # last bits) are the same when an edit of one branch renumbers the pieces, so the flow
    # tiles far from it stay as they were
    first_seen = {}
    for pair in sides:
        for piece in pair:
            first_seen.setdefault(piece, len(first_seen))
    psi = np.full(len(pieces), np.nan)
    for i, piece in enumerate(pieces):
        if i in still and i not in adj:
            psi[i] = 0.0
        elif i not in island_of and i not in adj:
            x, y = piece.points.mean(axis=0)
            raise GraphError(f"the water has a shore near ({x:.1f}, {y:.1f}) that no branch runs "
                             f"along (a branch loops onto itself or branches overlap)")
    for start in sorted(adj, key=lambda p: (first_seen.get(p, len(first_seen)), p)):
        if not np.isnan(psi[start]):
            continue
        psi[start] = 0.0
        component, queue = [start], deque([start])
        while queue:
            a = queue.popleft()
            for c, dq, b in adj[a]:
                if np.isnan(psi[c]):
                    psi[c] = psi[a] + dq
                    component.append(c)
                    queue.append(c)
                elif abs(psi[c] - psi[a] - dq) > 1e-6 * max(1.0, abs(dq)):
                    what = (f"branch {geoms[b].name!r}: its banks" if b >= 0 else
                            "the lateral inflow at ({:.1f}, {:.1f}): the banks beside its "
                            "inlet".format(*ties[-1 - b][3]) if ties[-1 - b][2] != 0.0 else
                            "the shores meeting at ({:.1f}, {:.1f}): their ψ".format(
                                *ties[-1 - b][3]))
                    raise GraphError(
                        f"discharges are inconsistent around {what} "
                        f"differ by {psi[c] - psi[a]:g} m²/s along another path, not {dq:g}")
        psi[component] -= psi[component].min()
    # pieces tied with no step (meeting end to end) hold one value, bit for bit (their ψ came
    # along different paths of the search and may differ in the last bits): the least
    same = {}
    for up, down, step, _ in ties:
        if step == 0.0:
            a, b = same.get(up, up), same.get(down, down)
            while same.get(a, a) != a:
                a = same[a]
            while same.get(b, b) != b:
                b = same[b]
            if a != b:
                same[max(a, b)] = min(a, b)
    groups: dict[int, list[int]] = {}
    for i in sorted(same):
        r = i
        while same.get(r, r) != r:
            r = same[r]
        groups.setdefault(r, [r]).append(i)
    for members in groups.values():
        psi[members] = psi[members].min()
    return psi


def _cut_inlets(geoms: list[BranchGeometry], sides, rings: list[Ring], pieces: list[Piece],
                island_of: dict[int, int], junctions: np.ndarray, inlets: dict[int, float]):
    """Cut an inlet into both banks of the outgoing branch of every junction with lateral
    inflow; returns the new sides and the ψ ties across the inlets (module docstring)."""
    family: dict[int, list[int]] = {}   # piece → the pieces it has been cut into
    cut_ids = []                        # (inlet id, junction, side sign, surplus)
    outs_of: dict[int, list[int]] = {}
    ins_of: dict[int, list[int]] = {}
    for b, g in enumerate(geoms):
        outs_of.setdefault(g.start_junction, []).append(b)
        ins_of.setdefault(g.end_junction, []).append(b)
    for j, surplus in sorted(inlets.items()):
        outs = outs_of.get(j, [])
        ins = ins_of.get(j, [])
        b = outs[0]
        p = junctions[j]
        width = 2.0 * geoms[b].station(0.0)[2]
        shortest = min(_length(geoms[k].centerline_m) for k in outs + ins)
        length = min(INLET_WIDTH_FRACTION * width, 0.1 * shortest)
        for pc, sign in ((sides[b][0], -0.5), (sides[b][1], 0.5)):
            if pieces[pc].closed or pc in island_of:
                raise GraphError(f"lateral inflow at ({p[0]:.1f}, {p[1]:.1f}) into branch "
                                 f"{geoms[b].name!r}: its bank there is an island's shore "
                                 "(give the branch the inflow's discharge)")
            members = family.setdefault(pc, [pc])
            target = min(members, key=lambda m: shapely.distance(pieces[m].line(), Point(p)))
            new = _cut_piece(rings, pieces, target, p, length, len(cut_ids),
                             straight_m=AXIS_WIDTH_FACTOR * width + AXIS_MARGIN_M,
                             shift_m=0.15 * shortest)
            members.append(new)
            cut_ids.append((j, sign, surplus))
    sides = _branch_sides(geoms, pieces, island_of)
    down = {}
    for b, (l, r) in enumerate(sides):
        down.setdefault(geoms[b].start_junction, set()).update((l, r))
    ties = []
    for ring in rings:
        n = len(ring.items)
        for k, (kind, item) in enumerate(ring.items):
            if kind != "inlet":
                continue
            j, sign, surplus = cut_ids[item[0]]
            before, after = ring.items[(k - 1) % n][1], ring.items[(k + 1) % n][1]
            if after in down.get(j, ()):
                up, dn = before, after
            elif before in down.get(j, ()):
                up, dn = after, before
            else:
                p = junctions[j]
                raise GraphError(f"lateral inflow at ({p[0]:.1f}, {p[1]:.1f}): no bank of the "
                                 f"branch leaving there lies beside its inlet (a branch shorter "
                                 f"than its width?)")
            ties.append((up, dn, sign * surplus, tuple(junctions[j])))
            ring.items[k] = ("closing", item[1])
    return sides, ties


def _length(line: np.ndarray) -> float:
    return float(np.hypot(*np.diff(line, axis=0).T).sum())


def _cut_piece(rings: list[Ring], pieces: list[Piece], pc: int, point: np.ndarray,
               length_m: float, inlet_id: int, straight_m: float = 0.0,
               shift_m: float = 0.0) -> int:
    """Cut an open piece near its point nearest ``point`` with an inlet ``length_m`` long:
    the piece keeps the part before it, a new piece (returned) holds the part after it, and
    the piece's ring gets ("inlet", (id, points)) between them.

    The inlet is a closing segment, and the flow's inside test takes the side of the nearest
    closing segment from its line (reference V9): so it is put on a straight stretch of the
    bank, ``straight_m`` of straight bank on both sides of it (then no water point within
    that reach lies across its line's extension), the one nearest the junction within
    ``shift_m`` of it; else as straight as can be found there."""
    v = pieces[pc].points
    seg = np.hypot(*np.diff(v, axis=0).T)
    s = np.concatenate([[0.0], np.cumsum(seg)])
    index = PolylineIndex(v)
    sc = float(index.nearest(np.asarray(point, np.float64)[None])[2][0])
    half = min(0.5 * length_m, 0.2 * s[-1])
    margin = 0.01 * s[-1]                      # both parts keep some length
    lo = np.maximum(s[:-1] + min(straight_m, seg.max()), margin)   # where inlet centres
    hi = np.minimum(s[1:] - min(straight_m, seg.max()), s[-1] - margin)   # keep the margin
    fits = lo + half <= hi - half
    centre = np.clip(sc, lo + half, hi - half)
    near = fits & (np.abs(centre - sc) <= shift_m)
    if near.any():
        k = int(np.argmin(np.where(near, np.abs(centre - sc), np.inf)))
        sc = float(centre[k])
    else:   # no straight stretch long enough near the junction: the longest segment there
        k = int(np.argmax(np.where(np.abs(np.clip(sc, s[:-1], s[1:]) - sc) <= shift_m, seg, 0)))
        sc = float(np.clip(sc, s[k] + half, s[k + 1] - half)) if seg[k] > 2 * half else sc
    sa = float(np.clip(sc - half, margin, s[-1] - margin - 2.0 * half))
    sb = sa + 2.0 * half

    def at(t: float) -> np.ndarray:
        return np.array([np.interp(t, s, v[:, 0]), np.interp(t, s, v[:, 1])])

    inner = (s > sa) & (s < sb)
    first = np.vstack([v[s < sa], at(sa)])
    inlet = np.vstack([at(sa), v[inner], at(sb)])
    second = np.vstack([at(sb), v[s > sb]])
    ring = rings[pieces[pc].ring]
    k = ring.items.index(("piece", pc))
    new = len(pieces)
    pieces[pc] = Piece(pieces[pc].ring, first, False)
    pieces.append(Piece(pieces[pc].ring, second, False))
    ring.items[k:k + 1] = [("piece", pc), ("inlet", (inlet_id, inlet)), ("piece", new)]
    return new


def _island_potentials(geoms, sides, pieces, islands, island_of, psi) -> None:
    """Fill ψ of the free islands (given, or the plug-flow estimate: between the ψ of its
    channel's banks as the gaps between its shore and the nearest shores with each, each
    gap carrying the discharge of its width (a bank cut into pieces, London's at every
    basin's mouth, has one ψ, and its piece the branch names may lie far from the island:
    an island 2 m off the bank took 78 % of the channel's discharge on that side, 100 m/s
    through the gap; measured from its centre, an island's own width counted in the gap on
    each side: a small island 0.1–2 m from a pocket's shore sent a tenth of the discharge
    round it, a ring of water at 9 m/s)."""
    lines = banks = None
    for piece_index, k in sorted(island_of.items()):
        outline = islands[k].outline
        c = outline.centroid
        dist = [shapely.distance(c, LineString(g.centerline_m)) for g in geoms]
        inside = [i for i, g in enumerate(geoms) if g.strip is not None and g.strip.contains(c)]
        b = min(inside or range(len(geoms)), key=lambda i: dist[i])
        left, right = sides[b]
        lo, hi = psi[left], psi[right]
        if islands[k].potential is None:
            if lines is None:          # (made once, for the first island that needs them)
                lines = np.array([p.line() for p in pieces], dtype=object)
                banks = np.array([j not in island_of for j in range(len(pieces))])
            # (not the shores of water inside it: a pond on the island)
            solid = shapely.Polygon(outline.exterior)
            off = banks & ~shapely.within(lines, solid)
            dl = float(shapely.distance(solid, lines[off & (psi == lo)]).min())
            dr = float(shapely.distance(solid, lines[off & (psi == hi)]).min())
            psi[piece_index] = lo + (hi - lo) * dl / max(dl + dr, 1e-12)
        else:
            p = islands[k].potential
            if not lo < p < hi:
                raise GraphError(f"island {k}: potential {p:g} must lie strictly between the ψ of "
                                 f"the banks of branch {geoms[b].name!r} ({lo:g} and {hi:g})")
            psi[piece_index] = p


def _axis_sections(g: BranchGeometry) -> list[tuple[np.ndarray, float]]:
    """Split a branch's centre line where its width changes by more than AXIS_SPLIT_RATIO:
    [(points (M, 2), largest width [m])]."""
    w = g.widths_m
    cuts, ref = [0], w[0]
    for i in range(1, len(w) - 1):
        if abs(w[i] / ref - 1.0) > AXIS_SPLIT_RATIO:
            cuts.append(i)
            ref = w[i]
    cuts.append(len(w) - 1)
    return [(g.centerline_m[a:b + 1], float(w[a:b + 1].max())) for a, b in zip(cuts[:-1], cuts[1:])]


def _runs(labels: np.ndarray) -> list[tuple[int, int, int]]:
    """Runs of equal values: [(first index, last index + 1, value)]."""
    edges = np.flatnonzero(np.diff(labels)) + 1
    bounds = np.concatenate([[0], edges, [len(labels)]])
    return [(int(a), int(b), int(labels[a])) for a, b in zip(bounds[:-1], bounds[1:])]


def _axis_cost(seg_start: np.ndarray, seg_end: np.ndarray, axis_ids: list[int],
               axis_index: list[PolylineIndex], use_side: bool,
               reach_m: float | None = None) -> np.ndarray:
    """(S, A) cost of linking each bank segment to each candidate axis: the distance from the
    segment's midpoint, ×10 when the axis lies on the segment's right (water is on a bank's
    left; not for islands, which may straddle their axis) and ×2 when the midpoint lies beyond
    the axis' ends (its nearest point is an end node, as around junctions). Axes farther than
    ``reach_m`` from a midpoint cost inf (a far query is then almost free); a segment whose
    best cost is over ``reach_m`` is looked at again without it (exactly as unbounded)."""
    mid = 0.5 * (seg_start + seg_end)
    d = seg_end - seg_start
    cost = np.empty((len(mid), len(axis_ids)))
    for k, a in enumerate(axis_ids):
        cost[:, k] = _cost_to(mid, d, axis_index[a], use_side, reach_m)
    # an axis beyond reach costs at least reach_m: only rows whose best cost is within it are
    # sure of their choice (the side and end factors can make a near axis cost more)
    lost = ~(cost.min(axis=1) <= reach_m) if reach_m is not None else np.zeros(len(mid), bool)
    if lost.any():
        for k, a in enumerate(axis_ids):
            cost[lost, k] = _cost_to(mid[lost], d[lost], axis_index[a], use_side, None)
    return cost


def _cost_to(mid: np.ndarray, d: np.ndarray, index: PolylineIndex, use_side: bool,
             reach_m: float | None) -> np.ndarray:
    dist, q, s = index.nearest(mid, reach_m)
    to = q - mid
    with np.errstate(invalid="ignore"):
        right = d[:, 0] * to[:, 1] - d[:, 1] * to[:, 0] < 0
        beyond = (s <= 1e-9) | (s >= index.length - 1e-9)
    return dist * (1.0 + beyond) * (1.0 + 9.0 * (right & use_side))


def _bank_runs(piece: Piece, axis_ids: list[int], axis_index: list[PolylineIndex],
               island: bool, reach_m: float | None = None,
               widths: list[float] | None = None) -> list[tuple[np.ndarray, int]]:
    """Split a piece where its nearest axis changes: [(points (M, 2), axis)]; a closed piece
    with one axis stays one closed curve (its points repeat the first point at the end).
    A segment that runs on past its axis's end farther from it than the axis is wide
    (``widths``, per axis: a straight bank along branches drawn end to end is one segment)
    is cut where it passes the candidate axes' ends, and its parts linked again."""
    v = piece.points
    for again in (False, True):
        seg_end = np.roll(v, -1, axis=0) if piece.closed else v[1:]
        seg_start = v if piece.closed else v[:-1]
        cost = _axis_cost(seg_start, seg_end, axis_ids, axis_index, not island, reach_m)
        labels = np.asarray(axis_ids)[np.argmin(cost, axis=1)]
        if again or widths is None:
            break
        cut = _cuts_past_axis_ends(seg_start, seg_end, labels, axis_ids, axis_index, widths)
        if not cut:
            break
        out = []
        for k in range(len(seg_start)):
            out.append(seg_start[k:k + 1])
            if k in cut:
                out.append(cut[k])
        if not piece.closed:
            out.append(v[-1:])
        v = np.vstack(out)
    runs = _runs(labels)
    if piece.closed:
        if len(runs) == 1:
            return [(np.vstack([v, v[:1]]), runs[0][2])]
        shift = runs[-1][1] - runs[-1][0] if runs[-1][2] == runs[0][2] else 0
        v = np.roll(v, shift, axis=0)
        labels = np.roll(labels, shift)
        runs = _runs(labels)
        v = np.vstack([v, v[:1]])
    return [(v[a:b + 1], lab) for a, b, lab in runs]


def _cuts_past_axis_ends(seg_start: np.ndarray, seg_end: np.ndarray, labels: np.ndarray,
                         axis_ids: list[int], axis_index: list[PolylineIndex],
                         widths: list[float]) -> dict[int, np.ndarray]:
    """{segment: points (n, 2) in order along it}: where each segment whose end lies farther
    from its linked axis than that axis is wide passes the candidate axes' end nodes (their
    feet on it, strictly inside)."""
    ends = np.array([p for a in axis_ids for p in (axis_index[a].points[0],
                                                   axis_index[a].points[-1])])
    cut: dict[int, np.ndarray] = {}
    for a in set(labels.tolist()):
        ks = np.flatnonzero(labels == a)
        far = np.maximum(axis_index[a].nearest(seg_start[ks])[0],
                         axis_index[a].nearest(seg_end[ks])[0]) > widths[a]
        for k in ks[far]:
            d = seg_end[k] - seg_start[k]
            t = (ends - seg_start[k]) @ d / max(float(d @ d), 1e-300)
            t = np.unique(np.round(t[(t > 1e-6) & (t < 1.0 - 1e-6)], 9))
            if len(t):
                cut[int(k)] = seg_start[k] + t[:, None] * d
    return cut


class _Nodes:
    """Deduplicated node list keyed by exact coordinates."""

    def __init__(self) -> None:
        self.index: dict[tuple[float, float], int] = {}
        self.points: list[tuple[float, float]] = []

    def __call__(self, p: np.ndarray) -> int:
        key = (float(p[0]), float(p[1]))
        if key not in self.index:
            self.index[key] = len(self.points)
            self.points.append(key)
        return self.index[key]


def _meeting_ties(pieces: list[Piece], eps_m: float) -> list:
    """(piece, piece, 0, point) for every two open pieces that meet end to end: banks that
    meet at a node have one ψ (reference §1.2 rule 2; where a river's banks meet a lake's
    shore at a mouth)."""
    ends, owner = [], []
    for i, piece in enumerate(pieces):
        if not piece.closed:
            ends += [piece.points[0], piece.points[-1]]
            owner += [i, i]
    if len(ends) < 2:
        return []
    ends = np.asarray(ends)
    ties = []
    for a, b in sorted(cKDTree(ends).query_pairs(eps_m)):
        if owner[a] != owner[b]:
            ties.append((owner[a], owner[b], 0.0, tuple(ends[a])))
    return ties


def _split_at_basin_mouths(rings, lakes) -> None:
    """Two basins whose mouths meet end to end (a point of land between them touching the
    river's bank) leave the river's outline one closing segment across both: it is split
    where a basin's mouth ends, so that each mouth is one closing segment of both areas."""
    ends = {tuple(p) for r in rings if lakes.polygon_lake[r.polygon] >= 0
            and lakes.lakes[lakes.polygon_lake[r.polygon]].basin
            for kind, item in r.items if kind == "closing" for p in (item[0], item[-1])}
    if not ends:
        return
    for ring in rings:
        if lakes.polygon_lake[ring.polygon] >= 0:
            continue
        items = []
        for kind, item in ring.items:
            cut = ([k for k in range(1, len(item) - 1) if tuple(item[k]) in ends]
                   if kind == "closing" else [])
            items += ([(kind, item[a:b + 1]) for a, b in zip([0] + cut, cut + [len(item) - 1])]
                      if cut else [(kind, item)])
        ring.items = items


def _basin_mouths(rings, pieces, lakes, basin_of, piece_axes, axis_index, axis_width, psi,
                  nodes) -> dict:
    """The mouths of the basins (:mod:`riverflow.hydro._basins`): {(start node, end node) as the
    river's outline runs: (points (M, 2), the river's axis it links to, ψ)}. A mouth is one
    bank curve of both areas (the river's, traversed forward, and the basin's, backward), with
    the ψ of the basin's shore (the bank it opens from); the axis it links to is the river's
    nearest axis among those of the banks beside it, widened to cover it."""
    out = {}
    for ring in rings:
        k = lakes.polygon_lake[ring.polygon]
        if k >= 0:
            continue
        n = len(ring.items)
        for j, (kind, item) in enumerate(ring.items):
            if kind != "closing":
                continue
            beside = [ring.items[(j + d) % n] for d in (-1, 1)]
            mine = {a for kd, pc in beside if kd == "piece" for a in piece_axes.get(pc, ())}
            basin = [pc for r in rings if lakes.polygon_lake[r.polygon] >= 0
                     and lakes.lakes[lakes.polygon_lake[r.polygon]].basin
                     for kd, it in r.items if kd == "closing"
                     and np.array_equal(it[0], item[-1]) and np.array_equal(it[-1], item[0])
                     for kd2, pc in r.items if kd2 == "piece"]
            if not basin or not mine:
                continue
            pts = np.asarray(item)
            mid = 0.5 * (pts[0] + pts[-1])[None]
            axis = min(sorted(mine), key=lambda a: float(axis_index[a].distance(mid)[0]))
            reach = float(axis_index[axis].distance(pts).max())
            axis_width[axis] = max(axis_width[axis], 2.0 * reach * 1.001 + AXIS_MARGIN_M)
            out[(nodes(pts[0]), nodes(pts[-1]))] = (pts, axis, float(psi[basin[0]]))
    return out


def assemble_graph(geoms: list[BranchGeometry], rings: list[Ring], pieces: list[Piece],
                   islands: list, junctions: np.ndarray, inlets: dict[int, float] | None = None,
                   lakes: LakeParts | None = None, axis_index: list | None = None,
                   free_banks: list | None = None) -> HydroGraph:
    """Make the hydro graph from the branches and the cut water outline; ``inlets``: lateral
    inflow [m²/s] per junction (module docstring); ``lakes``: the lakes' axes and polygons
    (:mod:`riverflow.hydro._lakes`). ``axis_index``: a list that gets each axis'
    :class:`PolylineIndex` (the axes are the graph's first curves, in order; each index is of
    the axis' :meth:`~HydroGraph.vertices` exactly, the nodes being keyed by exact
    coordinates), for the self-check to reuse. ``free_banks``: a list that gets the curve
    indices of the free islands' shores (one curve per run of a shore's nearest axis)."""
    if lakes is not None:
        _split_at_basin_mouths(rings, lakes)
    island_of: dict[int, int] = {}
    for i, piece in enumerate(pieces):
        if piece.closed and rings[piece.ring].hole:
            hole = shapely.Polygon(piece.points)
            for k, isl in enumerate(islands):
                if hole.contains(isl.outline.representative_point()):
                    island_of[i] = k
    lake_of: dict[int, int] = {}
    if lakes is not None:
        for i, piece in enumerate(pieces):
            k = lakes.polygon_lake[rings[piece.ring].polygon]
            if k >= 0:
                lake_of[i] = k
    def meeting() -> list:
        if lakes is None:
            return []
        ties = _meeting_ties(pieces, 1e-6 * max(1.0, float(np.abs(
            np.vstack([p.points for p in pieces])).max())))
        # a basin is still water: its shore's pieces (between its mouths) have one ψ
        first: dict[int, int] = {}
        for i, k in sorted(lake_of.items()):
            if lakes.lakes[k].basin and not rings[pieces[i].ring].hole:
                if k in first:
                    ties.append((first[k], i, 0.0, tuple(pieces[i].points[0])))
                else:
                    first[k] = i
        return ties

    ties: list = []
    try:
        sides = _branch_sides(geoms, pieces, {**island_of, **lake_of}) if geoms else []
        if inlets:
            sides, ties = _cut_inlets(geoms, sides, rings, pieces, island_of, junctions, inlets)
        ties = list(ties) + meeting()
        psi = _solve_potentials(geoms, sides, pieces, island_of, ties, frozenset(lake_of))
    except GraphError as exc:
        # the rays across the branches' middles took a shore beyond the one beside them
        # (a short island, a point of land): the shores facing each branch, where that
        # solves (without lateral inflow, whose inlets are cut by the rays' sides)
        if not geoms or inlets or not any(t in str(exc) for t in (
                "inconsistent", "no branch runs along", "one continuous shore")):
            raise
        try:
            sides = _sides_by_shores(geoms, pieces, {**island_of, **lake_of})
            ties = meeting()
            psi = _solve_potentials(geoms, sides, pieces, island_of, ties, frozenset(lake_of))
        except GraphError:
            raise exc from None
    _island_potentials(geoms, sides, pieces, islands, island_of, psi)

    nodes = _Nodes()
    for p in junctions:
        nodes(p)
    axes: list[Curve] = []
    axis_lines = []
    axis_width = []
    branch_axes: list[list[int]] = []
    for g in geoms:
        branch_axes.append([])
        for pts, wmax in _axis_sections(g):
            branch_axes[-1].append(len(axes))
            axes.append(Curve(nodes(pts[0]), nodes(pts[-1]), pts[1:-1], np.zeros(len(pts) - 2, bool),
                              type=CurveType.AXIS))
            axis_lines.append(LineString(pts))
            axis_width.append(AXIS_WIDTH_FACTOR * wmax + AXIS_MARGIN_M)
    lake_axes: list[list[int]] = []
    for lines in (lakes.axes if lakes is not None else []):
        lake_axes.append([])
        for pts, w in lines:
            lake_axes[-1].append(len(axes))
            axes.append(Curve(nodes(pts[0]), nodes(pts[-1]), pts[1:-1], np.zeros(len(pts) - 2, bool),
                              type=CurveType.AXIS))
            axis_lines.append(LineString(pts))
            axis_width.append(AXIS_WIDTH_FACTOR * w + AXIS_MARGIN_M)

    piece_axes: dict[int, set[int]] = {}
    for b, (l, r) in enumerate(sides):
        for pc in (l, r):
            piece_axes.setdefault(pc, set()).update(branch_axes[b])
    for pc, k in lake_of.items():
        piece_axes[pc] = set(lake_axes[k])
    for pc, k in island_of.items():
        c = islands[k].outline.centroid
        b = min(range(len(geoms)), key=lambda i: shapely.distance(c, LineString(geoms[i].centerline_m)))
        piece_axes[pc] = set(branch_axes[b])
    # a bank beside an inlet may reach past it (the nearest point to the junction is not
    # always straight across): it may link to the axes on either side of the inlet
    extra: dict[int, set[int]] = {}
    for up, dn, step, _ in ties:
        if step == 0.0 and (up in lake_of) != (dn in lake_of):
            continue    # a river's bank meeting a lake's shore: each keeps its own axes
        extra.setdefault(up, set()).update(piece_axes.get(dn, ()))
        extra.setdefault(dn, set()).update(piece_axes.get(up, ()))
    for a, more in extra.items():
        piece_axes[a] = piece_axes.get(a, set()) | more
    basin_of = {pc: k for pc, k in lake_of.items() if lakes.lakes[k].basin} if lakes else {}
    if basin_of:    # a bank a basin cuts in two: both parts take the axes of either (and
        #             the shores between the mouths of one basin: an island's, a pier's)
        # (basins that touch, a mouth's end on the next one's, pass it on too)
        joined = {k: k for k in set(basin_of.values())}

        def root(k: int) -> int:
            while joined[k] != k:
                k = joined[k]
            return k

        for up, dn, step, _ in ties:
            if step == 0.0 and up in basin_of and dn in basin_of:
                joined[root(basin_of[up])] = root(basin_of[dn])
        beside: dict[int, set[int]] = {}
        for up, dn, step, _ in ties:
            if step == 0.0 and (up in basin_of) != (dn in basin_of):
                b, r = (up, dn) if up in basin_of else (dn, up)
                if r not in lake_of:
                    beside.setdefault(root(basin_of[b]), set()).add(r)
        for _ in range(len(beside)):      # (a bank between two basins passes them on)
            for group in beside.values():
                both = set().union(*(piece_axes.get(r, set()) for r in group))
                for r in group:
                    piece_axes[r] = piece_axes.get(r, set()) | both

    banks: list[tuple[np.ndarray, int, float]] = []  # points, axis, psi
    piece_banks: list[list[int]] = []
    axis_index = [] if axis_index is None else axis_index
    axis_index[:] = [PolylineIndex.of(line) for line in axis_lines]
    for i, piece in enumerate(pieces):
        piece_banks.append([])
        if not piece_axes.get(i):
            x, y = piece.points.mean(axis=0)
            raise GraphError(f"the water has a shore near ({x:.1f}, {y:.1f}) that no branch "
                             f"runs along (a piece of a river's strip left outside a lake, "
                             f"where the river crosses a spit of its shore: end the branch "
                             f"at the shore, or smooth the shore there)")
        candidates = sorted(piece_axes[i])
        # a bank's own axis is within half its width (axis widths include a margin): rows
        # whose best cost is over this are looked at again unbounded (_axis_cost)
        reach = 0.75 * max(axis_width[a] for a in candidates) + 50.0
        for pts, axis in _bank_runs(piece, candidates, axis_index, i in island_of, reach,
                                    axis_width):
            piece_banks[-1].append(len(banks))
            banks.append((pts, axis, float(psi[i])))
            reach = float(axis_index[axis].distance(pts).max())
            axis_width[axis] = max(axis_width[axis], 2.0 * reach * 1.001 + AXIS_MARGIN_M)
    mouths = _basin_mouths(rings, pieces, lakes, basin_of, piece_axes, axis_index, axis_width,
                           psi, nodes) if basin_of else {}
    for a, w in zip(axes, axis_width):
        a.width_m = w

    curves: list[Curve] = list(axes)
    mouth_curve: dict[tuple[int, int], int] = {}
    for key, (pts, axis, value) in mouths.items():
        mouth_curve[key] = len(curves)
        curves.append(Curve(key[0], key[1], pts[1:-1], np.zeros(len(pts) - 2, bool),
                            width_m=axis_width[axis], type=CurveType.BANK, potential=value,
                            river=axis))
    areas: list[Area] = []
    ring_curves: list[list] = []
    closing_at: dict[tuple[int, int], int] = {}
    for ring in rings:
        ring_curves.append([])
        for kind, item in ring.items:
            if kind == "closing":
                ends = (nodes(item[0]), nodes(item[-1]))
                if ends in mouth_curve or ends[::-1] in mouth_curve:   # a basin's mouth
                    ring_curves[-1].append((mouth_curve[ends], 0) if ends in mouth_curve
                                           else (mouth_curve[ends[::-1]], 1))
                    continue
                if ends[::-1] in closing_at:    # a mouth, shared with a lake: one curve
                    ring_curves[-1].append((closing_at[ends[::-1]], 1))
                    continue
                closing_at[ends] = len(curves)
                ring_curves[-1].append((len(curves), 0))
                curves.append(Curve(ends[0], ends[1], item[1:-1],
                                    np.zeros(len(item) - 2, bool), width_m=0.0,
                                    type=CurveType.CLOSING_SEGMENT, potential=NO_POTENTIAL,
                                    river=NO_CURVE))
            else:
                ring_curves[-1].append(("piece", item))
    bank_index = {}
    for b, (pts, axis, value) in enumerate(banks):
        bank_index[b] = len(curves)
        curves.append(Curve(nodes(pts[0]), nodes(pts[-1]), pts[1:-1], np.zeros(len(pts) - 2, bool),
                            width_m=axis_width[axis], type=CurveType.BANK, potential=value,
                            river=axis))
    if free_banks is not None:
        free_banks[:] = sorted(bank_index[b] for pc in island_of for b in piece_banks[pc])
    for ring, loop in zip(rings, ring_curves):
        flat = []
        for entry in loop:
            if entry[0] == "piece":
                flat.extend((bank_index[b], 0) for b in piece_banks[entry[1]])
            else:
                flat.append(entry)
        k = lakes.polygon_lake[ring.polygon] if lakes is not None else -1
        if k >= 0 and lakes.lakes[k].basin:    # begin with a wall: the water on its left
            first = next((i for i, (c, o) in enumerate(flat) if o == 0 and curves[c].is_bank), 0)
            flat = flat[first:] + flat[:first]
        if k >= 0 and not ring.hole:
            level = lakes.lakes[k].level_m
            areas.append(Area(flat, LAKE_INFO if level is None else LAKE_LEVEL_INFO,
                              level_m=level))
        else:
            areas.append(Area(flat))
    return HydroGraph(np.asarray(nodes.points).reshape(-1, 2), curves, areas,
                      source="RiverNetworkBuilder")
