"""Lakes for :mod:`riverflow.hydro.builder`: water bodies that rivers run into and out of.

A lake is a polygon given with :meth:`RiverNetworkBuilder.add_lake`. It is built with the
same machinery as the rivers (reference §1.2): its shore is made of banks whose ψ is constant
between two openings (the shore between two mouths is one boundary piece), so the flux
through each mouth is its river's discharge, and the flow inside is Proland's ψ interpolation
between the shore pieces, as for any area: divergence-free and tangent to the shore. A lake
with no river is one shore piece: one ψ, still water.

* **Branches** that cross a lake's shore are cut there: the part inside is dropped, a branch
  that runs through the lake becomes an inlet and an outlet; an end within END_SNAP of the
  river's width outside the shore is drawn on to it. A lake is then a junction of its
  inlets and outlets for the discharges (the outlets share the inflow, by width where not
  given).
* **Water**: the lake joins the rivers' strips (their banks drawn on straight to an oblique
  shore, :func:`mouth_strips`), or the given water (``set_water_area``); the result is split along the lake's shore into
  river polygons and lake polygons, which share the *mouths* (the stretches of shore across
  the rivers). Each mouth is one closing segment of both areas; banks that meet at its ends
  have one ψ (reference §1.2 rule 2), which ties the lake's shore pieces to the rivers' banks.
* **Axes**: a star of axes from the lake's centre (the pole of inaccessibility) to each mouth
  (the river's axis end), or one short axis from the centre for a lake with no river. An
  axis is the straight line where it stays in the lake, else the path along the middle of
  the water (:func:`_path_through`: round an island, along a reservoir's arm). Their widths
  grow to cover the shore linked to them, so every point of the lake is inside one
  (reference §1.2 rule 1). The flow itself is the lake's potential flow
  (:mod:`riverflow.hydro.lake_flow`), whatever its shape.
* The lake's area in the graph is marked with ``Area.info`` = LAKE_INFO, or LAKE_LEVEL_INFO
  and ``Area.level_m`` when its level is given.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import shapely
from shapely.geometry import LineString
from shapely.ops import polylabel

from riverflow._validate import as_floats
from riverflow.hydro.graph import GraphError


@dataclass
class Lake:
    """A lake given to the builder: its polygon [m], its level [m] (None: from the terrain),
    a name for messages and whether it is a river's basin."""

    polygon: shapely.Polygon
    level_m: float | None
    name: str
    basin: bool = False
    """A basin of a river's given water (:mod:`riverflow.hydro._basins`): still water whose
    mouth is a bank shared with the river."""
    mouth: np.ndarray | None = None
    """A basin's mouth (2, 2) [m]."""
    given: shapely.Geometry | None = None
    """Water of the lake given to the rivers that end in it (:func:`end_at_terminal_lakes`:
    an end too short to be drawn back from its shore), or None."""

    def centre(self, tolerance_m: float) -> np.ndarray:
        """The pole of inaccessibility (the point farthest inside), (2,) [m]."""
        p = polylabel(self.polygon, tolerance=max(tolerance_m, 1e-3 * np.sqrt(self.polygon.area)))
        return np.array(p.coords[0])


def check_lake(polygon, level_m, index: int) -> Lake:
    """A validated :class:`Lake` (GraphError naming the lake and what is wrong)."""
    name = f"lake {index}"
    if isinstance(polygon, shapely.Polygon):
        poly = polygon
    else:
        pts = as_floats(polygon, f"{name}: its outline", GraphError)
        if pts.ndim != 2 or pts.shape[1] != 2 or len(pts) < 3:
            raise GraphError(f"{name}: its outline must be a shapely Polygon or an (M >= 3, 2) "
                             f"array, got shape {pts.shape}")
        if not np.isfinite(pts).all():
            raise GraphError(f"{name}: its outline has non-finite coordinates")
        poly = shapely.Polygon(pts)
    if poly.is_empty or not poly.area > 0 or not poly.is_valid:
        raise GraphError(f"{name}: its outline is not a simple polygon with an area "
                         f"({shapely.is_valid_reason(poly)})")
    if level_m is not None:
        level_m = float(level_m)
        if not np.isfinite(level_m):
            raise GraphError(f"{name}: level_m must be finite, got {level_m!r}")
    return Lake(shapely.geometry.polygon.orient(poly, 1.0), level_m, name)


END_SNAP = 0.75
"""A branch end this many widths or nearer outside a lake's shore is drawn on to it (an axis
found from a water polygon stops about half a width short of the shore)."""


def _arc(line: np.ndarray) -> np.ndarray:
    return np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(line, axis=0).T))])


def cut_branches(branches: list, lakes: list[Lake], tolerance_m: float, water=None):
    """Cut the branches at the lakes' shores. Returns the new branch list (objects of the same
    kind: ``name``, ``centerline_m``, ``widths_m``, ``discharge_m2s``), for each the lake its
    start / end lies on (-1: none), and for each the index of the branch it came from.
    ``water``: the rivers' water where given (a builder's water area less its free islands):
    a lake apart from it (a pond on a free island, which its channel's axis crosses) cuts
    nothing, and a free end is drawn on to a shore (END_SNAP) only over water."""
    if water is not None:
        lakes = [lk if lk.polygon.distance(water) <= tolerance_m else None for lk in lakes]
    kept = [lk for lk in lakes if lk is not None]
    if not kept:
        return branches, [(-1, -1)] * len(branches), list(range(len(branches)))
    union = shapely.union_all([lk.polygon for lk in kept])
    shores = shapely.union_all([lk.polygon for lk in kept if not lk.basin])
    wet = None if water is None else shapely.union(water, union).buffer(tolerance_m)
    if wet is not None:
        shapely.prepare(wet)
    out, ends, origin = [], [], []
    tips = np.array([[b.centerline_m[0], b.centerline_m[-1]] for b in branches]).reshape(-1, 2)
    for i, b in enumerate(branches):
        line, w = b.centerline_m, b.widths_m
        # a free end just outside a (lake's, not a basin's) shore is drawn on to it (not a
        # junction: a pond on the island two channels part round lies near where they part)
        for at_start in (True, False):
            p = line[0] if at_start else line[-1]
            width = w[0] if at_start else w[-1]
            pt = shapely.Point(p)
            if shores.is_empty or shores.contains(pt):
                continue
            if int(np.sum(np.hypot(*(tips - p).T) <= 0.25 * width + 1e-9)) > 1:
                continue                                # (itself and another end: a junction)
            d = shores.boundary.distance(pt)
            if 1e-6 * max(1.0, np.abs(p).max()) < d <= END_SNAP * width:
                q = np.asarray(shapely.ops.nearest_points(shores.boundary, pt)[0].coords[0])
                if wet is not None and not wet.covers(LineString([p, q])):
                    continue        # (land between: a creek's dead end beside the lake)
                t = q - p
                q = q + t / np.hypot(*t) * min(tolerance_m, 0.05 * width)   # just inside
                line = np.vstack([q, line]) if at_start else np.vstack([line, q])
                w = np.concatenate([[width], w]) if at_start else np.concatenate([w, [width]])
        ls = LineString(line)
        if not ls.intersects(union) or ls.intersection(union).length <= 1e-9:
            # touching a shore at an end at most
            out.append(type(b)(b.name, line, w, b.discharge_m2s))
            ends.append((_on_lake(lakes, line[0]), _on_lake(lakes, line[-1])))
            origin.append(i)
            continue
        s = _arc(line)
        outside = shapely.difference(ls, union)
        parts = sorted((g for g in getattr(outside, "geoms", [outside])
                        if not g.is_empty and g.length > 1e-9),
                       key=lambda g: ls.project(shapely.Point(g.coords[0])))
        if not parts:
            raise GraphError(f"branch {b.name!r} lies inside a lake: a river must run into or "
                             f"out of a lake, not within it")
        for k, g in enumerate(parts):
            pts = np.asarray(g.coords)
            ws = np.interp(shapely.line_locate_point(ls, shapely.points(pts)), s, w)
            if g.length < 0.5 * float(ws.max()):
                x, y = pts[0]
                raise GraphError(f"branch {b.name!r}: a piece {g.length:.2f} m long near "
                                 f"({x:.1f}, {y:.1f}) lies outside the lakes it crosses (shorter "
                                 f"than half its width); end the branch on the shore or inside")
            on = [_on_lake(lakes, pts[0]), _on_lake(lakes, pts[-1])]
            name = b.name if len(parts) == 1 else f"{b.name}[{k}]"
            q = b.discharge_m2s if k == 0 else None
            out.append(type(b)(name, pts, ws, q))
            ends.append((on[0], on[1]))
            origin.append(i)
    return out, ends, origin


def _on_lake(lakes: list[Lake | None], p: np.ndarray) -> int:
    """The lake whose shore ``p`` lies on (-1: none); never a basin (still water off the side
    of a river: no branch starts or ends on it, one that meets its mouth at a junction goes on
    past it), nor a lake apart from the rivers (None)."""
    for k, lk in enumerate(lakes):
        if lk is None or lk.basin:
            continue
        if lk.polygon.boundary.distance(shapely.Point(p)) <= 1e-6 * max(1.0, np.abs(p).max()):
            return k
    return -1


def end_at_terminal_lakes(branches: list, lakes: list[Lake], lake_ends: list):
    """A lake that rivers flow into and none out of (a terminal, endorheic lake), or out of
    and none into (a source lake: a spring-fed or headwater lake whose feeders the data does
    not hold), is still water: its inlets end on free ends (caps: their water leaves there,
    as at any river end) and its outlets start on free ends (their water comes in there, as
    at any river's source), just off its shore, each drawn back from the lake until its
    strip's stretch there is 0.02 widths clear of it; the lake is one shore, one ψ. Returns
    the branches, the lake ends (those rivers no longer end or start on the lake) and the
    indices of the terminal and of the source lakes. Where the water polygons are given, the
    builder cuts the rivers' water back from these lakes' shores too (CLOSED_LAKE_GAP)."""
    branches, lake_ends = list(branches), list(lake_ends)
    terminal, source = [], []
    for k, lake in enumerate(lakes):
        ins = [i for i, (_, e) in enumerate(lake_ends) if e == k]
        outs = [i for i, (s, _) in enumerate(lake_ends) if s == k]
        if bool(ins) == bool(outs):
            continue
        for i in ins + outs:
            b = branches[i]
            at_start = not ins
            try:
                line, widths = _clear_of(lake, b.centerline_m.copy(), b.widths_m.copy(),
                                         at_start, b.name)
            except GraphError:
                lake = lakes[k] = _give_way(lake, b.centerline_m, b.widths_m, at_start)
                if lake is None:
                    raise
                line, widths = b.centerline_m, b.widths_m
            branches[i] = type(b)(b.name, line, widths, b.discharge_m2s)
            lake_ends[i] = (-1, lake_ends[i][1]) if at_start else (lake_ends[i][0], -1)
        (terminal if ins else source).append(k)
    return branches, lake_ends, terminal, source


CLOSED_LAKE_GAP_TOLERANCES = 1.0
"""Given water polygons are cut back from the shore of a terminal or source lake by this many
builder tolerances (0.25 m by default): a strip of land between the river's end and the
still lake, as the lines' square ends leave one."""


def cut_from_closed_lakes(water, lakes: list[Lake], closed: list[int], tolerance_m: float):
    """The given water without what lies within CLOSED_LAKE_GAP_TOLERANCES tolerances of the
    lakes ``closed`` (terminal and source lakes: still water, their rivers ending or starting
    on free ends off their shores); the lakes themselves are added back by the builder."""
    if not closed:
        return water
    gap = CLOSED_LAKE_GAP_TOLERANCES * tolerance_m
    given = [lakes[k].given for k in closed if lakes[k].given is not None]
    if given:       # the lakes' water given to the rivers' ends
        water = shapely.union_all([water] + given)
    return shapely.difference(water, shapely.union_all([lakes[k].polygon.buffer(gap)
                                                        for k in closed]))


def _give_way(lake: Lake, line: np.ndarray, w: np.ndarray, at_start: bool) -> Lake | None:
    """``lake`` (a copy) with its shore moved back 0.02 widths from the strip of the river's
    last (first if ``at_start``) stretch, a stretch too short to be drawn back from it (a
    fork just inside a delta's mouth): that water is the river's (``Lake.given``); None where
    the lake would lose more than half its area or fall in pieces of which the largest is
    under nine tenths."""
    from dataclasses import replace

    from riverflow.hydro._strips import strip_polygon

    e, f = (0, 1) if at_start else (-1, -2)
    strip = strip_polygon(line[[e, f]], w[[e, f]])
    cut = shapely.intersection(lake.polygon, strip.buffer(0.02 * float(w[e])))
    rest = shapely.difference(lake.polygon, cut)
    parts = [p for p in shapely.get_parts(rest) if p.geom_type == "Polygon"]
    if not parts or rest.area < 0.5 * lake.polygon.area:
        return None
    main = max(parts, key=lambda p: p.area)
    if main.area < 0.9 * rest.area:
        return None
    given = shapely.intersection(lake.polygon, strip)
    if lake.given is not None:
        given = shapely.union(lake.given, given)
    return replace(lake, polygon=main, given=given)


def _clear_of(lake: Lake, line: np.ndarray, w: np.ndarray, at_start: bool, name: str
              ) -> tuple[np.ndarray, np.ndarray]:
    """``line`` and its widths ``w`` with its end (its start if ``at_start``) drawn back from
    ``lake`` until the strip of its last (first) stretch is 0.02 widths clear of it: a
    stretch drawn back to a tenth of its width still beside the shore (a line running along
    the shore before it ends there: München's Isar) is dropped, and the one before drawn
    back; GraphError where it cannot be, or where its ends would come within a quarter of
    its width (which the builder joins: :func:`end_at_terminal_lakes` moves the shore back
    instead)."""
    from riverflow.hydro._strips import strip_polygon

    for _ in range(200 + len(line)):
        e, f = (0, 1) if at_start else (len(line) - 1, len(line) - 2)
        width = float(w[e])
        strip = strip_polygon(line[[e, f]], w[[e, f]])
        if lake.polygon.distance(strip) > 0.02 * width:
            return line, w
        t = line[e] - line[f]
        seg = float(np.hypot(*t))
        if np.hypot(*(line[-1] - line[0])) <= 0.25 * min(float(w[0]), float(w[-1])):
            raise GraphError(f"branch {name!r}: drawn back from the shore of {lake.name} (a "
                             f"lake with no {'inlet' if at_start else 'outlet'}), its ends "
                             f"come within a quarter of its width")
        if seg <= 0.1 * width:
            if len(line) > 2:
                line, w = (line[1:], w[1:]) if at_start else (line[:-1], w[:-1])
                continue
            raise GraphError(f"branch {name!r}: its {'first' if at_start else 'last'} stretch "
                             f"({seg:.1f} m) lies along the shore of {lake.name} (a lake with "
                             f"no {'inlet' if at_start else 'outlet'}): "
                             f"{'start' if at_start else 'end'} the branch square to the shore")
        line[e] = line[e] - t / seg * 0.05 * width
    return line, w


def lake_junctions(branches, lakes: list[Lake], lake_ends, start_j, end_j, junctions):
    """Make each lake that rivers touch one junction of its inlets and outlets (its centre as
    the junction's point, for messages): returns the new start / end junction lists and the
    junction points; raises GraphError for a lake with only inflow or only outflow."""
    start_j, end_j = list(start_j), list(end_j)
    points = [np.asarray(junctions).reshape(-1, 2)]
    for k, lake in enumerate(lakes):
        ins = [i for i, (_, e) in enumerate(lake_ends) if e == k]
        outs = [i for i, (s, _) in enumerate(lake_ends) if s == k]
        if not ins and not outs:
            continue
        names_in = [branches[i].name for i in ins]
        names_out = [branches[i].name for i in outs]
        if not outs:
            raise GraphError(f"{lake.name}: rivers {names_in} flow into it but none flows out; a "
                             f"lake without an outlet takes no inflow here (add its outlet)")
        if not ins:
            raise GraphError(f"{lake.name}: rivers {names_out} flow out of it but none flows in "
                             f"(add the river that feeds it)")
        j = sum(len(p) for p in points)
        for i in ins:
            if end_j[i] >= 0:
                raise GraphError(f"branch {branches[i].name!r} ends both at a junction and on "
                                 f"the shore of {lake.name}")
            end_j[i] = j
        for i in outs:
            if start_j[i] >= 0:
                raise GraphError(f"branch {branches[i].name!r} starts both at a junction and on "
                                 f"the shore of {lake.name}")
            start_j[i] = j
        points.append(lake.centre(1e-3)[None])
    return start_j, end_j, np.vstack(points)


MOUTH_REACH = 10.0
"""A river's banks are drawn on straight to its lake's shore within this many widths."""


def mouth_strips(geoms, lake_ends, lakes: list[Lake]) -> list:
    """Where a river meets its lake's shore obliquely, its strip's flat end leaves a notch of
    land beside it: its strip continued straight past the mouth, as far as it lies outside the
    lake next to the river's end (the banks drawn on to the shore; the water then has no notch
    at the mouth)."""
    from riverflow.hydro._strips import strip_polygon

    parts = []
    for g, (ls, le) in zip(geoms, lake_ends):
        for k, at_start in ((ls, True), (le, False)):
            if k < 0:
                continue
            line = g.centerline_m
            p, q = (line[0], line[1]) if at_start else (line[-1], line[-2])
            w = float(g.widths_m[0] if at_start else g.widths_m[-1])
            t = (p - q) / np.hypot(*(p - q))
            n = np.array([-t[1], t[0]])
            ext = strip_polygon(np.array([p - t * 0.05 * w, p + t * MOUTH_REACH * w]),
                                np.array([w, w]))
            end = LineString([p - t * 0.01 * w + n * 0.5 * w, p - t * 0.01 * w - n * 0.5 * w])
            outside = shapely.difference(ext, lakes[k].polygon)
            parts += [o for o in getattr(outside, "geoms", [outside])
                      if isinstance(o, shapely.Polygon) and o.intersects(end)]
    return parts


def split_water(polygons: list, lakes: list[Lake], eps_m: float, min_area_m2: float):
    """Split the oriented water polygons along the lakes' shores: (polygons, the lake of each
    polygon or -1, the mouths' edges (2, 2) each: the edges a river polygon shares with a lake
    polygon, which ``split_rings`` makes closing segments). River pieces smaller than
    ``min_area_m2`` (slivers left along a shore) are dropped; shared stretches of outline get
    the same vertices on both sides (:func:`_node_together`)."""
    from shapely.geometry.polygon import orient

    water = shapely.union_all(polygons) if len(polygons) > 1 else polygons[0]
    lake_union = shapely.union_all([lk.polygon for lk in lakes])
    river = shapely.difference(water, lake_union)
    out, which = [], []
    for p in getattr(river, "geoms", [river]):
        if isinstance(p, shapely.Polygon) and p.area > min_area_m2:
            out.append(orient(p, 1.0))
            which.append(-1)
    lake_parts = []
    tree = shapely.STRtree([lk.polygon for lk in lakes])
    for i, lk in enumerate(lakes):
        # the water less the rivers and the other lakes: the lake's water less the other
        # lakes that meet its box (not the whole water less a union of all: London's 92
        # docks and basins took 5 s of GEOS's overlay, now 0.03 s)
        part = shapely.intersection(water, lk.polygon)
        others = [lakes[j].polygon for j in tree.query(lk.polygon).tolist() if j != i]
        if others:
            part = shapely.difference(part, shapely.union_all(others))
        # (a lake smaller than a river's sliver is no sliver: its pieces of half its area)
        least = min(min_area_m2, 0.5 * lk.polygon.area)
        polys = [p for p in getattr(part, "geoms", [part])
                 if isinstance(p, shapely.Polygon) and p.area > least]
        if len(polys) != 1:
            raise GraphError(f"{lk.name}: the rivers cut it into {len(polys)} pieces (a river "
                             f"runs along or across its shore)")
        lake_parts.append(orient(polys[0], 1.0))
    out += lake_parts
    which += list(range(len(lake_parts)))
    out = _node_together(out, eps_m)
    n_river = len(out) - len(lake_parts)
    mouths = []
    if n_river:
        lake_lines = shapely.union_all([p.boundary for p in out[n_river:]])
        for p in out[:n_river]:
            for ring in [p.exterior, *p.interiors]:
                v = np.asarray(ring.coords)
                near = shapely.dwithin(lake_lines, shapely.points(v), eps_m)
                mid = shapely.dwithin(lake_lines, shapely.points(0.5 * (v[1:] + v[:-1])), eps_m)
                on = near[:-1] & near[1:] & mid
                mouths += [v[k:k + 2] for k in np.flatnonzero(on)]
    return out, which, mouths


def _node_together(polygons: list, eps_m: float) -> list:
    """The polygons with every vertex of the others that lies on one of their edges (within
    ``eps_m``, not at its ends) inserted there, so that shared stretches of outline have the
    same vertices on both sides (overlay results need not)."""
    from scipy.spatial import cKDTree
    from shapely.geometry.polygon import orient

    # vertices within eps of each other become one (the first of them)
    ring_sets = [[np.asarray(r.coords) for r in [p.exterior, *p.interiors]] for p in polygons]
    flat = np.vstack([r for rs in ring_sets for r in rs])
    rep = np.arange(len(flat))
    for a, b in sorted(cKDTree(flat).query_pairs(eps_m)):
        ra, rb = rep[a], rep[b]
        while rep[ra] != ra:
            ra = rep[ra]
        while rep[rb] != rb:
            rb = rep[rb]
        rep[max(ra, rb)] = min(ra, rb)
    for i in range(len(rep)):
        r = i
        while rep[r] != r:
            r = rep[r]
        rep[i] = r
    flat = flat[rep]
    k = 0
    for rs in ring_sets:
        for j in range(len(rs)):
            rs[j] = flat[k:k + len(rs[j])]
            k += len(rs[j])
    allv = np.unique(flat, axis=0)
    tree = shapely.STRtree(shapely.points(allv))
    out = []
    for rs in ring_sets:
        rings = []
        for v in rs:
            a, b = v[:-1], v[1:]
            segs = shapely.linestrings(np.stack([a, b], axis=1))
            si, pi = tree.query(segs, predicate="dwithin", distance=eps_m)
            d = b - a
            dd = np.maximum(np.einsum("ij,ij->i", d, d), 1e-300)
            t = np.einsum("ij,ij->i", allv[pi] - a[si], d[si]) / dd[si]
            length = np.sqrt(dd[si])
            inner = (t * length > eps_m) & ((1.0 - t) * length > eps_m)
            si, pi, t = si[inner], pi[inner], t[inner]
            if not len(si):
                rings.append(v)
                continue
            order = np.lexsort((t, si))
            si, pi = si[order], pi[order]
            rows = []
            k = 0
            for e in range(len(a)):
                rows.append(a[e:e + 1])
                while k < len(si) and si[k] == e:
                    rows.append(allv[pi[k]][None])
                    k += 1
            rows.append(v[-1:])
            rings.append(np.vstack(rows))
        rings = [_clean_ring(r, eps_m) for r in rings]
        out.append(orient(shapely.Polygon(rings[0], [r for r in rings[1:] if len(r) >= 4]), 1.0))
    return out


def _clean_ring(v: np.ndarray, eps_m: float) -> np.ndarray:
    """A closed ring (M, 2) (last point = first) without repeated points and without spikes
    (a vertex the ring goes out to and comes straight back from: a stretch of shore both
    sides of the split kept)."""
    v = list(map(tuple, v[:-1]))
    changed = True
    while changed and len(v) > 3:
        changed = False
        m = len(v)
        for i in range(m):
            a, b, c = np.array(v[i - 1]), np.array(v[i]), np.array(v[(i + 1) % m])
            if np.hypot(*(b - a)) <= eps_m:
                del v[i]
                changed = True
                break
            if np.hypot(*(c - a)) <= eps_m:        # a → b → a: drop b and the return
                for k in sorted({i, (i + 1) % m}, reverse=True):
                    del v[k]
                changed = True
                break
    v = np.asarray(v)
    return np.vstack([v, v[:1]])


def lake_axes(lake: Lake, mouths_m: list[np.ndarray], outlet: list[bool], tolerance_m: float
              ) -> list[np.ndarray]:
    """The lake's axes: from each mouth point (a river's axis end on the shore) to the lake's
    centre (drawn downstream: into the centre for inlets, out of it for outlets), or one short
    axis from the centre towards the nearest shore for a lake with no river."""
    c = lake.centre(tolerance_m)
    inside = lake.polygon.buffer(max(tolerance_m, 1e-6))
    if not mouths_m:
        q = np.asarray(shapely.ops.nearest_points(lake.polygon.exterior, shapely.Point(c))[0].coords[0])
        return [np.array([c, c + 0.5 * (q - c)])]
    axes = []
    for m, out in zip(mouths_m, outlet):
        line = np.array([m, c])
        if not inside.contains(LineString(line)):      # a bay, an arm, an island in the way
            line = _path_through(lake, inside, m, c, tolerance_m)
        axes.append(line[::-1] if out else line)
    return axes


def basin_axis(lake: Lake, tolerance_m: float) -> np.ndarray:
    """A basin's axis: from its mouth's middle along the middle of its water to its far end
    (the point farthest from the mouth that is at least half as far from the walls as the
    basin's widest point), so that its width, grown to cover the basin's walls, stays about
    the basin's own width (an L-shaped dock's axis runs down both of its arms)."""
    from scipy import ndimage

    a = 0.5 * (lake.mouth[0] + lake.mouth[1])
    inside = lake.polygon.buffer(max(tolerance_m, 1e-6))
    x0, y0, x1, y1 = lake.polygon.bounds
    cell = max(max(x1 - x0, y1 - y0) / 64.0, tolerance_m, 1e-6)
    gx, gy = np.meshgrid(np.arange(x0 + 0.5 * cell, x1, cell), np.arange(y0 + 0.5 * cell, y1, cell))
    wet = shapely.contains_xy(lake.polygon, gx, gy)
    if not wet.any():
        return np.array([a, lake.centre(tolerance_m)])
    clear = ndimage.distance_transform_edt(np.pad(wet, 1))[1:-1, 1:-1] * cell
    ok = wet & (clear >= 0.5 * clear[wet].max())
    far = np.hypot(gx - a[0], gy - a[1])
    k = np.unravel_index(int(np.argmax(np.where(ok, far, -1.0))), far.shape)
    b = np.array([gx[k], gy[k]])
    line = np.array([a, b])
    if not inside.contains(LineString(line)):
        line = _path_through(lake, inside, a, b, tolerance_m)
    return line


PATH_CELLS = 160
""":func:`_path_through` finds its path on a raster of the lake this many cells along its
longer side, or finer: PATH_CELLS_ACROSS cells across its mean width (twice its area over
its outline's length: a long narrow basin, a tributary with no line of its own, had no cell
in its water), with at most PATH_MAX_CELLS cells."""
PATH_CELLS_ACROSS = 4.0
PATH_MAX_CELLS = 1_000_000


def _path_through(lake: Lake, inside, a: np.ndarray, b: np.ndarray, tolerance_m: float
                  ) -> np.ndarray:
    """A path (K, 2) from ``a`` to ``b`` (both in the lake) that keeps to the middle of the
    water: the cheapest path through the lake's raster, each step costing its length over the
    clearance there (the distance to the nearest shore), so it runs along the middle of an
    arm or a channel between islands, simplified to a fraction of the narrowest clearance it
    passes and checked to stay in ``inside`` (the lake grown by the tolerance; a step between
    cells beside the shore only where it does; where no path is found, on a raster of half the
    cells' size, twice). An axis in a lake that is not star-shaped about its centre (a reservoir's
    flooded side valleys, an island between a mouth and the centre) follows it."""
    x0, y0, x1, y1 = lake.polygon.bounds
    width = 2.0 * lake.polygon.area / max(lake.polygon.length, 1e-9)
    cell = max(min(max(x1 - x0, y1 - y0) / PATH_CELLS, width / PATH_CELLS_ACROSS),
               float(np.sqrt((x1 - x0) * (y1 - y0) / PATH_MAX_CELLS)), tolerance_m, 1e-6)
    failed = GraphError(f"{lake.name}: the path from its mouth at ({a[0]:.1f}, {a[1]:.1f}) to "
                        f"its centre leaves the lake")
    for scale in (1.0, 0.5, 0.25):
        if (x1 - x0) * (y1 - y0) > PATH_MAX_CELLS * (scale * cell) ** 2 and scale < 1.0:
            break
        try:
            line, narrow = _raster_path(lake, inside, a, b, scale * cell)
        except GraphError as exc:           # (a passage narrower than the cells: finer)
            failed = exc
            continue
        for tol in (0.5 * narrow, 0.25 * narrow, 0.0):
            simple = np.asarray(shapely.simplify(LineString(line), tol).coords) if tol else line
            if inside.contains(LineString(simple)):
                return simple
    raise failed


def _raster_path(lake: Lake, inside, a: np.ndarray, b: np.ndarray, cell: float):
    """The cheapest path (K, 2) from ``a`` to ``b`` through the lake's raster of ``cell``
    [m] (:func:`_path_through`) and the least clearance along it [m]."""
    from scipy import ndimage
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import dijkstra

    x0, y0, x1, y1 = lake.polygon.bounds
    shapely.prepare(inside)                  # (its many steps' tests: GEOS's prepared form)
    nx, ny = int(np.ceil((x1 - x0) / cell)) + 1, int(np.ceil((y1 - y0) / cell)) + 1
    gx, gy = np.meshgrid(0.5 * (x0 + x1) + (np.arange(nx) - 0.5 * (nx - 1)) * cell,
                         0.5 * (y0 + y1) + (np.arange(ny) - 0.5 * (ny - 1)) * cell)
    wet = shapely.contains_xy(lake.polygon, gx, gy)
    clear = ndimage.distance_transform_edt(wet) * cell
    index = -np.ones(wet.shape, np.int64)
    index[wet] = np.arange(int(wet.sum()))
    xy = np.c_[gx[wet], gy[wet]]
    rows, cols, cost = [], [], []
    for di, dj in ((0, 1), (1, 0), (1, 1), (1, -1)):
        i0, i1 = max(0, -di), ny - max(0, di)
        j0, j1 = max(0, -dj), nx - max(0, dj)
        here = index[i0:i1, j0:j1]
        there = index[i0 + di:i1 + di, j0 + dj:j1 + dj]
        ok = (here >= 0) & (there >= 0)
        c = 0.5 * (clear[i0:i1, j0:j1] + clear[i0 + di:i1 + di, j0 + dj:j1 + dj])[ok]
        h, t = here[ok], there[ok]
        # (a step beside the shore must not cross a point of land thinner than a cell)
        near = np.flatnonzero(c < 2.0 * cell)
        if len(near):
            steps = shapely.linestrings(np.stack([xy[h[near]], xy[t[near]]], axis=1))
            keep = np.ones(len(c), bool)
            keep[near] = shapely.contains(inside, steps)
            h, t, c = h[keep], t[keep], c[keep]
        rows.append(h)
        cols.append(t)
        cost.append(np.hypot(di, dj) * cell / np.maximum(c, 1e-9))
    rows, cols, cost = np.concatenate(rows), np.concatenate(cols), np.concatenate(cost)
    n = len(xy)
    graph = coo_matrix((cost, (rows, cols)), shape=(n, n)).tocsr()
    ends = []
    for p in (a, b):
        d = np.hypot(*(xy - p).T)
        near = np.argsort(d)[:8]            # the nearest cell the straight step to is wet
        seen = [k for k in near if inside.contains(LineString([p, xy[k]]))]
        if not seen:
            raise GraphError(f"{lake.name}: no way through the lake from ({p[0]:.1f}, "
                             f"{p[1]:.1f}) (a mouth or its centre in a part of the lake "
                             f"narrower than {cell:.2f} m)")
        ends.append(int(seen[0]))
    dist, pred = dijkstra(graph, directed=False, indices=ends[0], return_predecessors=True)
    if not np.isfinite(dist[ends[1]]):
        raise GraphError(f"{lake.name}: its mouth at ({a[0]:.1f}, {a[1]:.1f}) and its centre "
                         f"({b[0]:.1f}, {b[1]:.1f}) are in parts of the lake that do not meet")
    path, k = [], ends[1]
    while k >= 0:
        path.append(k)
        k = pred[k] if k != ends[0] else -1
    return np.vstack([a, xy[path[::-1]], b]), float(clear[wet][path].min())
