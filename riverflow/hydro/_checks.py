"""Property checks of a built hydro graph (reference §1.2 rules 1-7).

:func:`graph_problems` returns a list of human-readable problems, empty when the graph has
water on the left of every bank (its axis lies on its left, and exterior loops run
counter-clockwise, island loops clockwise), equal ψ where banks meet, axes that cover their
banks, continuous area loops, banks that do not cross and, when the branches are given, a ψ
difference across each branch equal to its discharge with the larger ψ on the right.
The builder runs it on everything it makes; the tests run it too.
"""
from __future__ import annotations

import numpy as np
import shapely
from shapely.geometry import LineString, MultiLineString

from riverflow.hydro.areas import area_ring
from riverflow.hydro.graph import HydroGraph
from riverflow.hydro.nearest import (LineChunks, PolylineIndex, first_per_group, ray_hits, stations,
                                     tangent_at)


def _signed_area(loop: np.ndarray) -> float:
    x, y = loop[:, 0], loop[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y))


def loop_depths(loops: list[np.ndarray], polys: list, poly_area: list[int]) -> np.ndarray:
    """How many other loops hold each loop (one tree query), asked a hair left of the middle
    of its first edge, the side its water is on (a vertex may lie on another loop: München's
    basins at an island's tip, their mouths on its shore): water (counter-clockwise loops)
    lies at an even depth, islands (clockwise) at an odd one (odd winding rule: a pond on a
    river's island is water again)."""
    probe = shapely.points(np.array([_left_of_first_edge(lp) for lp in loops]).reshape(-1, 2))
    depth = np.zeros(len(loops), int)
    if polys:
        at, by = shapely.STRtree(polys).query(probe, predicate="within")
        for a, j in zip(at, by):
            if poly_area[j] != a:
                depth[a] += 1
    return depth


def _left_of_first_edge(loop: np.ndarray) -> np.ndarray:
    """A point a hair left of the middle of a loop's first edge of some length, or its first
    vertex."""
    if len(loop) < 2:
        return loop[0] if len(loop) else np.zeros(2)
    d = np.diff(loop, axis=0)
    length = np.hypot(*d.T)
    k = int(np.argmax(length > 0.0))
    if not length[k] > 0.0:
        return loop[0]
    t = d[k] / length[k]
    eps = min(1e-3 * length[k], 1e-6 * max(1.0, float(np.abs(loop[k]).max())) + 1e-9)
    return 0.5 * (loop[k] + loop[k + 1]) + eps * np.array([-t[1], t[0]])


def area_loop(graph: HydroGraph, area: int) -> np.ndarray:
    """The closed polyline of an area (M, 2) [m], first point not repeated (builder graphs
    have no Bézier control points, so this is the raw vertex loop)."""
    return area_ring(graph, area)


TILE_VERTICES = 4000
""":func:`contains_xy_tiled` splits a polygon until its pieces have at most this many
vertices."""
TILE_MARGIN_M = 1.0


def contains_xy_tiled(geom: shapely.Geometry, xy: np.ndarray) -> np.ndarray:
    """``shapely.contains_xy(geom, xy)`` (N,) for many points in a large (multi)polygon.

    GEOS locates a point in a prepared polygon through an index of its edges by y alone: a
    point then visits every edge whose y-range holds it, all the banks of a long river
    running east-west, and the water of a large network costs more per point the larger it
    is. Here the polygon and the points are cut in halves (along the longer side of the box,
    recursively) until each tile has at most TILE_VERTICES vertices; a tile is the polygon
    within its box grown by TILE_MARGIN_M, and holds the points in its box, at least that
    margin from its cut edges (points outside the polygon's box go down the outermost
    tiles, and are outside them as they are outside the polygon): the same answer (the cuts
    add vertices only at the margin; the polygon's own vertices and edges are kept). GEOS's
    rectangle clip is used: its output may be invalid along the rectangle's edges (rings
    touching there), which changes nothing for points a margin inside it."""
    xy = np.asarray(xy, np.float64).reshape(-1, 2)
    out = np.zeros(len(xy), bool)
    if not len(xy) or geom.is_empty:
        return out
    stack = [(geom, tuple(geom.bounds), np.arange(len(xy)))]
    while stack:
        g, (x0, y0, x1, y1), idx = stack.pop()
        if not len(idx):
            continue
        if shapely.get_num_coordinates(g) <= TILE_VERTICES or max(x1 - x0, y1 - y0) < 8 * TILE_MARGIN_M:
            shapely.prepare(g)
            out[idx] = shapely.contains_xy(g, xy[idx, 0], xy[idx, 1])
            continue
        m = TILE_MARGIN_M
        axis = 0 if x1 - x0 >= y1 - y0 else 1
        cut = 0.5 * ((x0, y0)[axis] + (x1, y1)[axis])
        low = xy[idx, axis] < cut
        for b, part in (((x0, y0, cut, y1) if axis == 0 else (x0, y0, x1, cut), idx[low]),
                        ((cut, y0, x1, y1) if axis == 0 else (x0, cut, x1, y1), idx[~low])):
            if len(part):
                stack.append((shapely.clip_by_rect(g, b[0] - m, b[1] - m, b[2] + m, b[3] + m),
                              b, part))
    return out


CHUNK_SEGMENTS = 1_000_000
""":func:`graph_problems` tests the banks' segments in chunks of about this many."""


def _bank_segments(graph: HydroGraph, chunk: list[int]):
    """The banks ``chunk``'s vertices (P, 2) and their bank (P,), their segments without null
    ones: directions (S, 2), lengths (S,), midpoints (S, 2) and bank (S,) (position in
    ``chunk``), and the probes just left and just right of each segment, (2S, 2) interleaved."""
    verts = [graph.vertices(i) for i in chunk]
    n_pts = np.array([len(v) for v in verts], np.int64)
    v = np.concatenate(verts) if verts else np.zeros((0, 2))
    vb = np.repeat(np.arange(len(chunk)), n_pts)
    d = np.diff(v, axis=0)
    length = np.hypot(d[:, 0], d[:, 1])
    ok = (vb[1:] == vb[:-1]) & (length > 1e-6)   # (no segment from one bank to the next)
    d, length, sb = d[ok], length[ok], vb[:-1][ok]
    mid = 0.5 * (v[:-1][ok] + v[1:][ok])
    nrm = np.stack([-d[:, 1], d[:, 0]], axis=1) / length[:, None]
    eps = np.minimum(0.1 * length, 0.05)[:, None]
    probes = np.empty((2 * len(mid), 2))
    probes[0::2] = mid + eps * nrm
    probes[1::2] = mid - eps * nrm
    return v, vb, d, length, mid, sb, probes


def graph_problems(graph: HydroGraph, branches=None, *, rel_tol: float = 1e-6,
                   axes_cover_banks: bool = False, axis_index=None,
                   one_stream: bool = True, away=None, free_banks=()) -> list[str]:
    """Check a builder-made graph. ``branches``: optional [(centre line (K, 2), widths (K,)
    or None, discharge m²/s)] drawn downstream (widths may be omitted as a 2-tuple).
    ``axes_cover_banks``: the caller made every axis' width cover its banks' points (the
    builder sets it from the farthest of them, :func:`~riverflow.hydro._network.assemble_graph`),
    so the test that they lie within half an axis' width is skipped (the test that the axis
    lies on each bank's left stays). ``axis_index``: the axes' :class:`PolylineIndex` of their
    :meth:`~HydroGraph.vertices`, curve i's at i, as :func:`assemble_graph` gives them (else
    made here). ``one_stream``: a ray across a branch that crosses other branches' centre
    lines running the same way before it meets a bank reads their discharges too
    (:func:`_discharge_problems`); False: such a reading is an error (the axes of a water
    area's skeleton never run in one stream: where they seem to, their directions are
    wrong). ``away``: a list to which the middle of every bank segment whose axis lies on its
    right is appended with that axis' vertices, ``(point (2,), axis (K, 2))``.
    ``free_banks``: the curves of free islands' shores, no branch's bank (a shore cut into
    runs by its nearest axes does not close on itself; :func:`_discharge_problems`)."""
    problems: list[str] = []
    curves = graph.curves
    banks = graph.banks()
    for i in banks:
        c = curves[i]
        if not c.has_potential:
            problems.append(f"bank {i} has no potential")
        if not (0 <= c.river < len(curves)) or not curves[c.river].is_axis:
            problems.append(f"bank {i} is not linked to an axis (river={c.river})")
    # equal psi at nodes
    for n, inc in enumerate(graph.incident_curves()):
        values = {curves[c].potential for c in inc if curves[c].is_bank}
        if len(values) > 1:
            problems.append(f"node {n}: banks meeting there have different ψ {sorted(values)}")
    # areas continuous and oriented (exterior CCW, islands CW)
    for a, area in enumerate(graph.areas):
        ends = []
        for c, o in area.curves:
            s, e = curves[c].start, curves[c].end
            ends.append((e, s) if o else (s, e))
        for k in range(len(ends)):
            if ends[k][1] != ends[(k + 1) % len(ends)][0]:
                problems.append(f"area {a}: curve {area.curves[k][0]} does not join the next one")
                break
    loops = [area_loop(graph, a) for a in range(len(graph.areas))]
    signed = [_signed_area(lp) for lp in loops]
    polys = [shapely.Polygon(lp) for lp in loops if len(lp) >= 3]
    poly_area = [a for a, lp in enumerate(loops) if len(lp) >= 3]
    depth = loop_depths(loops, polys, poly_area)
    for a, lp in enumerate(loops):
        sa = signed[a]
        if sa > 0 and depth[a] % 2:
            problems.append(f"area {a}: counter-clockwise loop inside another area")
        if sa < 0 and not depth[a] % 2:
            problems.append(f"area {a}: clockwise loop that is not an island (water on its right)")
    # water on the left of every bank: a point just left of each segment is in the water
    # described by the areas and a point just right is not (all banks' points in one prepared
    # query); the linked axis lies on the left of every shore bank (island loops may straddle
    # their axis: their test is the first one; so may a lake's shore, whose axes only tie it
    # to the lake's component: its flow is the lake's own potential flow, and a jagged shore's
    # bays and spits face its axes every way)
    # (the loops of a sound graph are disjoint: a union by disjoint subsets leaves them as
    # they are, where the cascaded union nodes every edge again, holding ~150 B per vertex);
    # each level of nesting in turn: the water at depth 2k less the islands at 2k + 1
    levels = []
    for level in range(0, int(depth.max(initial=0)) + 1, 2):
        ccw = [p for p, a in zip(polys, poly_area) if signed[a] > 0 and depth[a] == level]
        cw = [p for p, a in zip(polys, poly_area) if signed[a] < 0 and depth[a] == level + 1]
        part = shapely.disjoint_subset_union_all(ccw)
        if cw:
            part = shapely.difference(part, shapely.disjoint_subset_union_all(cw))
        levels.append(part)
    water = levels[0] if len(levels) == 1 else shapely.union_all(levels)
    in_hole = {c for a in range(len(loops)) if signed[a] < 0 for c, _ in graph.areas[a].curves}
    in_hole |= {c for a in graph.lakes() for c, _ in graph.areas[a].curves}
    # a bank of two areas (a basin's mouth, riverflow.hydro._basins) has water on both sides
    n_areas: dict[int, int] = {}
    for area in graph.areas:
        for c in {c for c, _ in area.curves}:
            n_areas[c] = n_areas.get(c, 0) + 1
    two_sided = {c for c, n in n_areas.items() if n > 1}
    del loops, polys, levels            # (copies of the whole outline: the peak is below)
    linked = [i for i in banks if 0 <= curves[i].river < len(curves)]
    # every linked bank's segments in bulk, banks grouped by their axis (one nearest-point
    # query per axis), in chunks of about CHUNK_SEGMENTS segments (the arrays of a chunk are
    # made twice, for the probes and for the axis tests, not kept: the build's peak of memory
    # is at the probes)
    linked.sort(key=lambda i: curves[i].river)
    chunks, size, first = [], 0, 0
    for k, i in enumerate(linked):
        size += len(curves[i].points) + 1
        if size >= CHUNK_SEGMENTS and (k + 1 == len(linked)
                                       or curves[linked[k + 1]].river != curves[i].river):
            chunks.append(linked[first:k + 1])
            first, size = k + 1, 0
    if first < len(linked):
        chunks.append(linked[first:])
    probes = np.empty((2 * sum(len(curves[i].points) + 1 for i in linked), 2))
    at = 0
    for chunk in chunks:
        part = _bank_segments(graph, chunk)[-1]
        probes[at:at + len(part)] = part
        at += len(part)
        del part
    inside = contains_xy_tiled(water, probes[:at])
    del probes
    wrong_side: dict[int, tuple[int, int]] = {}
    on_right: dict[int, tuple[int, int]] = {}
    too_far: dict[int, tuple[int, int]] = {}
    at = 0
    for chunk in chunks:
        v, vb, d, length, mid, sb, _ = _bank_segments(graph, chunk)
        n_seg = len(mid)
        left, right = inside[at:at + 2 * n_seg:2].copy(), inside[at + 1:at + 2 * n_seg:2].copy()
        at += 2 * n_seg
        n = len(chunk)
        both = np.array([i in two_sided for i in chunk], bool)[sb]
        wrong = ~left | (right & ~both) | (~right & both)
        if wrong.any():
            # water narrower than the probes' offset (a slip's needle of a tip, its walls a
            # few centimetres apart there): asked again fifty times closer
            k = np.flatnonzero(wrong)
            nrm = np.stack([-d[k, 1], d[k, 0]], axis=1) / length[k, None]
            eps = 0.02 * np.minimum(0.1 * length[k], 0.05)[:, None]
            left[k] = contains_xy_tiled(water, mid[k] + eps * nrm)
            right[k] = contains_xy_tiled(water, mid[k] - eps * nrm)
            wrong = ~left | (right & ~both) | (~right & both)
        bad_side = np.bincount(sb, wrong, n).astype(np.int64)
        seg_count = np.bincount(sb, minlength=n)
        cross_bad = np.zeros(len(mid), bool)
        far = np.zeros(len(v), bool)
        # the banks of one axis are consecutive: one query per axis for their midpoints and
        # points
        rivers = np.array([curves[i].river for i in chunk])
        groups = np.flatnonzero(np.concatenate([[True], rivers[1:] != rivers[:-1]]))
        seg_at = np.searchsorted(sb, np.arange(n + 1))
        pt_at = np.searchsorted(vb, np.arange(n + 1))
        for g0, g1 in zip(groups, np.append(groups[1:], n)):
            river = int(rivers[g0])
            axis = (axis_index[river] if axis_index is not None and river < len(axis_index)
                    else PolylineIndex(graph.vertices(river)))
            covers = 0.5 * curves[river].width_m + 1e-6
            s0, s1, p0, p1 = seg_at[g0], seg_at[g1], pt_at[g0], pt_at[g1]
            dist, q, _ = axis.nearest(mid[s0:s1] if axes_cover_banks
                                      else np.vstack([mid[s0:s1], v[p0:p1]]), covers)
            to = q[:s1 - s0] - mid[s0:s1]
            dd = d[s0:s1]
            cross = dd[:, 0] * to[:, 1] - dd[:, 1] * to[:, 0]
            # a segment shorter than a thousandth of the axis' width (an overlay's rounding
            # step, a centimetre back and forth along a bank) has no direction to judge
            judged = length[s0:s1] > 1e-3 * curves[river].width_m
            with np.errstate(invalid="ignore"):   # (segments beyond reach fail the reach test)
                cross_bad[s0:s1] = judged & (
                    cross < -1e-9 * length[s0:s1] * np.hypot(to[:, 0], to[:, 1]))
            if not axes_cover_banks:
                far[p0:p1] = ~np.isfinite(dist[s1 - s0:])
        holes = np.array([i in in_hole for i in chunk], bool)
        cross_bad &= ~holes[sb]
        if away is not None and cross_bad.any():
            away += [(p, graph.vertices(int(rivers[k])))
                     for p, k in zip(mid[cross_bad], sb[cross_bad].tolist())]
        bad_axis = np.bincount(sb, cross_bad, n).astype(np.int64)
        bad_far = np.bincount(vb, far, n).astype(np.int64)
        pt_count = np.bincount(vb, minlength=n)
        for k, i in enumerate(chunk):
            if bad_side[k]:
                wrong_side[i] = (int(bad_side[k]), int(seg_count[k]))
            if bad_axis[k]:
                on_right[i] = (int(bad_axis[k]), int(seg_count[k]))
            if bad_far[k]:
                too_far[i] = (int(bad_far[k]), int(pt_count[k]))
    rank = {i: k for k, i in enumerate(banks)}
    for i in sorted(set(wrong_side) | set(on_right) | set(too_far), key=rank.__getitem__):
        c = curves[i]
        if i in wrong_side:
            x, y = graph.vertices(i).mean(axis=0)
            problems.append(f"bank {i}: water is not on its left{' and right' if i in two_sided else ''}"
                            f" at {wrong_side[i][0]} of {wrong_side[i][1]} segments, near "
                            f"({x:.1f}, {y:.1f})")
        if i in on_right:
            x, y = graph.vertices(i).mean(axis=0)
            problems.append(f"bank {i}: its axis {c.river} lies on its right at {on_right[i][0]} "
                            f"of {on_right[i][1]} segments (water must be on the left), near "
                            f"({x:.1f}, {y:.1f})")
        if i in too_far:
            problems.append(f"bank {i}: {too_far[i][0]} of its {too_far[i][1]} points "
                            f"lie farther from axis {c.river} than the "
                            f"{0.5 * curves[c.river].width_m:.2f} m it covers")
    # no crossing banks (banks and closing segments may only touch at their end nodes)
    lines = [graph.vertices(i) for i, c in enumerate(curves) if not c.is_axis]
    if not MultiLineString([ln for ln in lines if len(ln) >= 2]).is_simple:
        problems.append("banks or closing segments cross each other")
    if branches:
        problems += _discharge_problems(graph, branches, rel_tol, one_stream, free_banks)
    return problems


def _discharge_problems(graph: HydroGraph, branches, rel_tol: float,
                        one_stream: bool = True, free_banks=()) -> list[str]:
    """ψ(right bank) − ψ(left bank) = discharge at the middle of every branch (every
    station's two rays in one bulk query, :func:`_bank_psi`). A free island's shore (a bank
    that closes on itself) is no branch's bank: a ray that reaches it, where the branch's
    width read across it falls short of the far bank, must not take its ψ for the bank's; nor
    is any curve of ``free_banks`` (such a shore cut into runs by the axes nearest them)."""
    problems = []
    free = set(free_banks)
    bank_ids = [i for i in graph.banks()
                if graph.curves[i].start != graph.curves[i].end and i not in free]
    lines = LineChunks([graph.vertices(i) for i in bank_ids])
    potential = np.array([graph.curves[i].potential for i in bank_ids])
    fractions = np.array([0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8])
    origins, normals, widths = [], [], []
    for br in branches:
        o, n, w = stations(np.asarray(br[0], dtype=float), fractions,
                            br[1] if len(br) == 3 else None)
        origins.append(o)
        normals.append(n)
        widths.append(w)
    origins, normals = np.vstack(origins), np.vstack(normals)
    # rays: left then right at every station, branch by branch
    rays = (np.repeat(origins, 2, axis=0), np.stack([normals, -normals], axis=1).reshape(-1, 2),
            np.repeat(np.concatenate(widths), 2))
    psi, dist = _bank_psi(lines, potential, *rays)
    # a ray that crosses other branches' centre lines before its bank, each running the
    # same way as this one (within 45°), reads the water of them all (two branches leaving
    # a junction at a small angle run in one stream until their strips part): its ψ
    # difference is the sum of their discharges
    owner = np.repeat(np.arange(len(branches)), 2 * len(fractions))
    centre = [np.asarray(br[0], dtype=float) for br in branches]
    axes = LineChunks(centre)
    reach = np.where(np.isfinite(dist), dist, 0.0)
    ray, hit, at = ray_hits(*rays[:2], reach, axes)
    other = np.flatnonzero((hit != owner[ray]) & (at < reach[ray]) & one_stream)
    if len(other):
        along = np.stack([rays[1][:, 1], -rays[1][:, 0]], axis=1)   # the ray's normal
        along *= np.where(np.arange(len(owner)) % 2 == 0, 1.0, -1.0)[:, None]  # downstream
        at_pt = rays[0][ray[other]] + rays[1][ray[other]] * at[other][:, None]
        theirs = np.array([tangent_at(centre[h], p) for h, p in zip(hit[other], at_pt)])
        cos = np.einsum("ij,ij->i", theirs, along[ray[other]]) / np.hypot(*theirs.T)
        other = other[cos > np.sqrt(0.5)]
    ray, hit = ray[other], hit[other]
    other = np.ones(len(ray), bool)
    extra = np.zeros(len(owner))
    np.add.at(extra, ray[other], np.array([branches[h][-1] for h in hit[other]], float))
    psi = psi.reshape(len(branches), len(fractions), 2)
    extra = extra.reshape(len(branches), len(fractions), 2).sum(axis=2)
    for k, br in enumerate(branches):
        q = br[-1]
        found = [(p[1] - p[0], q + e) for p, e in zip(psi[k], extra[k]) if not np.isnan(p).any()]
        if not found:
            x, y = origins[k * len(fractions) + len(fractions) // 2]
            problems.append(f"branch {k}: no banks found across its middle, near ({x:.1f}, "
                            f"{y:.1f})")
        for dpsi, q in found:
            if not abs(dpsi - q) <= rel_tol * max(1.0, abs(q)):
                problems.append(f"branch {k}: ψ(right) − ψ(left) = {dpsi:g}, discharge {q:g}")
                break
    return problems


def _leaves_water(lines: LineChunks, hit: np.ndarray, at: np.ndarray,
                  directions: np.ndarray) -> np.ndarray:
    """(H,) bool: whether a ray along ``directions`` (H, 2) crossing line ``hit`` (H,) of
    ``lines`` (banks: the water on their left) at ``at`` (H, 2) [m] crosses from its left to
    its right (the direction of the line's segment nearest the crossing, found on the run of
    a few segments the crossing lies on: locating a point on a whole bank costs its
    length)."""
    if not len(hit):
        return np.zeros(0, bool)
    pts = shapely.points(at)
    k, chunk = lines.tree.query(pts, predicate="dwithin", distance=1e-6)
    mine = lines.owner[chunk] == hit[k]
    k, chunk = k[mine], chunk[mine]
    first = np.ones(len(k), bool)
    first[1:] = k[1:] != k[:-1]
    geoms = np.empty(len(hit), dtype=object)
    found = np.zeros(len(hit), bool)
    geoms[k[first]] = lines.chunks[chunk[first]]
    found[k[first]] = True
    for r in np.flatnonzero(~found).tolist():     # (none within a micrometre: the line)
        geoms[r] = shapely.LineString(lines.lines[int(hit[r])])
    s = shapely.line_locate_point(geoms, pts)
    length = shapely.length(geoms)
    step = np.minimum(1e-3 * length, 0.01)
    a = shapely.get_coordinates(shapely.line_interpolate_point(geoms, np.maximum(s - step, 0.0)))
    b = shapely.get_coordinates(shapely.line_interpolate_point(geoms, np.minimum(s + step,
                                                                                  length)))
    t = b - a
    return t[:, 0] * directions[:, 1] - t[:, 1] * directions[:, 0] <= 0.0


def _bank_psi(lines: LineChunks, potential: np.ndarray, origins: np.ndarray,
              directions: np.ndarray, widths: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """ψ of the bank each ray from the centre line meets (R,), NaN if none is found, and its
    distance [m] (NaN with it). With the local width known, only a bank between 0.75 and
    1.25 half-widths counts (the farthest such hit): nearer shores are islands in the
    stream; a station where the bank is elsewhere (tight bends, junctions) gives NaN and is
    skipped. Without it (NaN), the nearest bank within 100 km. Only a bank the ray leaves
    the water at counts (crossing it from its left, the water's side, to its right): the
    far shore of a strip of land, the bank of the river beyond a dyke, is not its own."""
    known = np.isfinite(widths)
    lo = np.where(known, 0.75 * 0.5 * widths, 0.0)
    reach = np.where(known, 1.25 * 0.5 * widths + 1.0, 1e5)
    ray, hit, dist = ray_hits(origins, directions, reach, lines)
    ok = (dist >= lo[ray]) & _leaves_water(lines, hit, origins[ray] + directions[ray]
                                            * dist[:, None], directions[ray])
    ray, hit, dist = ray[ok], hit[ok], dist[ok]
    far = first_per_group(ray, dist, len(origins), largest=True)
    near = first_per_group(ray, dist, len(origins))
    pick = np.where(known, far, near)
    found = pick >= 0
    if not len(hit):
        return np.full(len(origins), np.nan), np.full(len(origins), np.nan)
    return (np.where(found, potential[hit[np.maximum(pick, 0)]], np.nan),
            np.where(found, dist[np.maximum(pick, 0)], np.nan))
