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
* **Axes** (:func:`lake_axes`): the lake may be any simple polygon with islands. Its axes
  only give its shore banks their axis links (on their water side) and the flow's inside
  test a nearest axis that each water point sees: one from each mouth (the river's axis
  end) to the lake's centre (the pole of inaccessibility), straight where that stays in the
  lake, else through the middle of the water; one into each bay and behind each island that
  those do not serve; one short axis from the centre for a lake with no river. Their widths
  grow to cover the shore linked to them (reference §1.2 rule 1). The flow in the lake is
  its potential flow (:mod:`riverflow.hydro.lake_flow`), whatever the axes.
* The lake's area in the graph is marked with ``Area.info`` = LAKE_INFO, or LAKE_LEVEL_INFO
  and ``Area.level_m`` when its level is given.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import shapely
from shapely.geometry import LineString
from shapely.ops import polylabel

from riverflow.hydro.graph import GraphError


@dataclass
class Lake:
    """A lake given to the builder: its polygon [m], its level [m] (None: from the terrain)
    and a name for messages."""

    polygon: shapely.Polygon
    level_m: float | None
    name: str

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
        pts = np.asarray(polygon, dtype=np.float64)
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


def cut_branches(branches: list, lakes: list[Lake], tolerance_m: float):
    """Cut the branches at the lakes' shores. Returns the new branch list (objects of the same
    kind: ``name``, ``centerline_m``, ``widths_m``, ``discharge_m2s``), for each the lake its
    start / end lies on (-1: none), and for each the index of the branch it came from."""
    if not lakes:
        return branches, [(-1, -1)] * len(branches), list(range(len(branches)))
    union = shapely.union_all([lk.polygon for lk in lakes])
    out, ends, origin = [], [], []
    for i, b in enumerate(branches):
        line, w = b.centerline_m, b.widths_m
        # an end just outside a shore is drawn on to it
        for at_start in (True, False):
            p = line[0] if at_start else line[-1]
            width = w[0] if at_start else w[-1]
            pt = shapely.Point(p)
            if union.contains(pt):
                continue
            d = union.boundary.distance(pt)
            if 1e-6 * max(1.0, np.abs(p).max()) < d <= END_SNAP * width:
                q = np.asarray(shapely.ops.nearest_points(union.boundary, pt)[0].coords[0])
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


def _on_lake(lakes: list[Lake], p: np.ndarray) -> int:
    """The lake whose shore ``p`` lies on (-1: none)."""
    for k, lk in enumerate(lakes):
        if lk.polygon.boundary.distance(shapely.Point(p)) <= 1e-6 * max(1.0, np.abs(p).max()):
            return k
    return -1


def end_at_terminal_lakes(branches: list, lakes: list[Lake], lake_ends: list, allowed: bool):
    """A lake that rivers flow into and none out of (a terminal, endorheic lake) is still
    water: its inlets end on free ends (caps: their water leaves there, as at any river end)
    just short of its shore, each drawn back from the lake until its strip's last stretch is
    0.02 widths clear of it, and the lake is one shore, one ψ. Returns the branches, the lake
    ends (those inlets no longer end on the lake) and the terminal lakes' indices; GraphError
    when not ``allowed`` (water polygons given: the rivers' water meets the lake's)."""
    from riverflow.hydro._strips import strip_polygon

    branches, lake_ends = list(branches), list(lake_ends)
    terminal = []
    for k, lake in enumerate(lakes):
        ins = [i for i, (_, e) in enumerate(lake_ends) if e == k]
        outs = [i for i, (s, _) in enumerate(lake_ends) if s == k]
        if not ins or outs:
            continue
        names = [branches[i].name for i in ins]
        if not allowed:
            raise GraphError(f"{lake.name}: rivers {names} flow into it but none flows out; a "
                             f"lake without an outlet is still water only in networks built "
                             f"from lines (the water polygons given meet its shore)")
        for i in ins:
            b = branches[i]
            line, w = b.centerline_m.copy(), b.widths_m
            width = float(w[-1])
            for _ in range(200):
                strip = strip_polygon(line[-2:], w[-2:])
                if lake.polygon.distance(strip) > 0.02 * width:
                    break
                t = line[-1] - line[-2]
                seg = float(np.hypot(*t))
                if seg <= 0.1 * width:
                    raise GraphError(f"branch {b.name!r}: its last stretch ({seg:.1f} m) lies "
                                     f"along the shore of {lake.name} (a lake with no outlet): "
                                     f"end the branch square to the shore")
                line[-1] = line[-1] - t / seg * 0.05 * width
            branches[i] = type(b)(b.name, line, w, b.discharge_m2s)
            lake_ends[i] = (lake_ends[i][0], -1)
        terminal.append(k)
    return branches, lake_ends, terminal


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
    for lk in lakes:
        part = shapely.difference(water, shapely.union_all([river] + [o.polygon for o in lakes
                                                                     if o is not lk]))
        polys = [p for p in getattr(part, "geoms", [part])
                 if isinstance(p, shapely.Polygon) and p.area > min_area_m2]
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


AXIS_CELLS = 100
"""The grid a lake's axes are routed on has about this many cells across the lake."""
MAX_BAY_AXES = 24
"""At most this many axes into bays and behind islands per lake."""


@dataclass
class _Grid:
    """The lake on a square grid of spacing ``h`` [m]: the points (N, 2) [m] of the nodes
    inside and the 8-neighbour graph (a SciPy sparse matrix) weighted by length / clearance²
    (the distance to the shore: paths keep to the middle of the water)."""

    points: np.ndarray
    cost: object
    h: float


def _lake_grid(polygon: shapely.Polygon, tolerance_m: float) -> _Grid:
    from scipy.sparse import coo_matrix

    x0, y0, x1, y1 = polygon.bounds
    h = max(max(x1 - x0, y1 - y0) / AXIS_CELLS, tolerance_m, 1e-3)
    xs = np.arange(x0 + 0.5 * h, x1, h)
    ys = np.arange(y0 + 0.5 * h, y1, h)
    gx, gy = np.meshgrid(xs, ys)
    inside = shapely.contains_xy(polygon, gx, gy)
    ids = np.full(inside.shape, -1)
    ids[inside] = np.arange(int(inside.sum()))
    pts = np.c_[gx[inside], gy[inside]]
    clear = shapely.distance(polygon.boundary, shapely.points(pts))
    rows, cols, step = [], [], []
    ny, nx = inside.shape
    for di, dj in ((0, 1), (1, 0), (1, 1), (1, -1)):
        a = ids[max(0, -di):ny - max(0, di), max(0, -dj):nx - max(0, dj)]
        b = ids[max(0, di):ny - max(0, -di), max(0, dj):nx - max(0, -dj)]
        ok = (a >= 0) & (b >= 0)
        rows.append(a[ok])
        cols.append(b[ok])
        step.append(np.full(int(ok.sum()), h * np.hypot(di, dj)))
    r, c, s = np.concatenate(rows), np.concatenate(cols), np.concatenate(step)
    # an edge that crosses the shore (a thin spit between two grid nodes) is no edge
    water = polygon.buffer(0.0)
    shapely.prepare(water)
    keep = shapely.covers(water, shapely.linestrings(np.stack([pts[r], pts[c]], axis=1))
                          ) if len(r) else np.zeros(0, bool)
    r, c, s = r[keep], c[keep], s[keep]
    w = s / (0.5 * (clear[r] + clear[c])) ** 2
    n = len(pts)
    cost = coo_matrix((np.r_[w, w], (np.r_[r, c], np.r_[c, r])), shape=(n, n)).tocsr()
    return _Grid(pts, cost, h)


def _route(grid: _Grid, pred: np.ndarray, start: int) -> np.ndarray:
    """The grid path from node ``start`` back along ``pred`` to its source, as points."""
    path = [start]
    while pred[path[-1]] >= 0:
        path.append(int(pred[path[-1]]))
    return grid.points[path]


def _tidy(line: np.ndarray, inside, h: float) -> np.ndarray:
    """The routed polyline simplified (by two cells, one or half of one) where it then stays
    in the water."""
    ls = LineString(line)
    for tol in (2.0 * h, h, 0.5 * h):
        s = ls.simplify(tol, preserve_topology=True)
        if inside.contains(s):
            return np.asarray(s.coords)
    return line


def lake_axes(lake: Lake, mouths_m: list[np.ndarray], outlet: list[bool], tolerance_m: float
              ) -> list[np.ndarray]:
    """The lake's axes: from each mouth point (a river's axis end on the shore) to the lake's
    centre (drawn downstream: into the centre for inlets, out of it for outlets), or one short
    axis from the centre towards the nearest shore for a lake with no river; plus one axis into
    each bay that lies round a corner from them (from the nearest axis to the bay's far end).

    The axis from a mouth is the straight line where that stays in the lake (a lake that is
    star-shaped about its centre), else the way through the middle of the water (the least
    length / clearance² path on a grid of the lake, round islands and bends), simplified.
    The axes only say which shore belongs to which part of the lake (the banks' links, their
    water side): the flow in the lake is its potential flow (:mod:`lake_flow`)."""
    from scipy.sparse.csgraph import dijkstra

    poly = lake.polygon
    c = lake.centre(tolerance_m)
    inside = poly.buffer(max(tolerance_m, 1e-6))
    axes = []
    if not mouths_m:
        q = np.asarray(shapely.ops.nearest_points(poly.exterior, shapely.Point(c))[0].coords[0])
        axes.append(np.array([c, c + 0.5 * (q - c)]))
    straight = [inside.contains(LineString([m, c])) for m in mouths_m]
    grid = None
    if (not all(straight) or len(poly.interiors)
            or len(_unserved(poly, axes + [np.array([m, c]) for m in mouths_m])[0])):
        grid = _lake_grid(poly, tolerance_m)
    if grid is not None and len(grid.points) < 2:
        grid = None
    for m, out, ok in zip(mouths_m, outlet, straight):
        if ok or grid is None:
            if not ok:
                raise GraphError(f"{lake.name}: the lake is too small for its mouth at "
                                 f"({m[0]:.1f}, {m[1]:.1f}) to reach its centre")
            line = np.array([m, c])
        else:
            centre = int(np.argmin(np.hypot(*(grid.points - c).T)))
            dist, pred = dijkstra(grid.cost, indices=centre, return_predecessors=True)
            near = np.argsort(np.hypot(*(grid.points - m).T))[:8]
            near = near[np.isfinite(dist[near])]
            if not len(near):
                raise GraphError(f"{lake.name}: its mouth at ({m[0]:.1f}, {m[1]:.1f}) is not "
                                 f"connected to its centre through the water")
            start = int(near[0])
            path = _route(grid, pred, start)
            line = _tidy(np.vstack([m, path[1:-1], c]) if len(path) > 2 else np.array([m, c]),
                         inside, grid.h)
        axes.append(line[::-1] if out else line)
    if grid is not None:
        axes += _bay_axes(grid, axes, poly, inside)
    return axes


def _unserved(poly: shapely.Polygon, axes: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """The outer shore's segments whose best axis (as the banks choose theirs:
    :func:`riverflow.hydro._network._axis_cost`) lies on their right, the land side:
    (their midpoints (S, 2), their inward unit normals (S, 2)), the deepest (farthest from
    every axis) first."""
    v = np.asarray(poly.exterior.coords)
    a, b = v[:-1], v[1:]
    mid, d = 0.5 * (a + b), b - a
    keep = np.hypot(*d.T) > 0
    mid, d = mid[keep], d[keep]
    cost = np.empty((len(mid), len(axes)))
    right = np.empty((len(mid), len(axes)), bool)
    far = np.empty(len(mid))
    pm = shapely.points(mid)
    for k, line in enumerate(axes):
        ls = LineString(line)
        s = shapely.line_locate_point(ls, pm)
        q = shapely.get_coordinates(shapely.line_interpolate_point(ls, s))
        to = q - mid
        dist = np.hypot(*to.T)
        right[:, k] = d[:, 0] * to[:, 1] - d[:, 1] * to[:, 0] < -1e-9 * np.hypot(*d.T) * dist
        beyond = (s <= 1e-9) | (s >= ls.length - 1e-9)
        cost[:, k] = dist * (1.0 + beyond) * (1.0 + 9.0 * right[:, k])
    best = np.argmin(cost, axis=1)
    bad = right[np.arange(len(mid)), best]
    far = cost.min(axis=1)
    order = np.flatnonzero(bad)[np.argsort(-far[bad])]
    n = np.c_[-d[:, 1], d[:, 0]] / np.hypot(*d.T)[:, None]    # inward: the ring is CCW
    return mid[order], n[order]


def _bay_axes(grid: _Grid, axes: list[np.ndarray], poly: shapely.Polygon, inside
              ) -> list[np.ndarray]:
    """Axes into the bays: while a stretch of the outer shore has no axis on its water side
    (:func:`_unserved`: a bay round a corner from the axes, an arm of a reservoir), the
    deepest such stretch gets an axis: the middle-of-the-water path from the nearest axis to
    the grid node a cell in from it."""
    from scipy.sparse.csgraph import dijkstra

    out = []
    pts = grid.points
    nodes = shapely.points(pts)
    shapely.prepare(inside)
    for _ in range(MAX_BAY_AXES):
        lines = shapely.MultiLineString([LineString(a) for a in axes + out])
        mid, n = _unserved(poly, axes + out)
        if len(mid):
            # a point just in from the stretch (a narrow spike may be thinner than a cell)
            goal = next((g for g in (mid[0] + n[0] * t for t in (grid.h, 0.5 * grid.h,
                                                                   0.1 * grid.h))
                         if poly.contains(shapely.Point(g))), mid[0])
        else:
            # water that does not see its nearest axis (behind an island, round a corner):
            # the flow's inside test looks from a point to its nearest axis
            to_axis = shapely.shortest_line(nodes, lines)
            hidden = ~shapely.covers(inside, to_axis)
            if not hidden.any():
                break
            far = shapely.length(to_axis)
            goal = pts[np.flatnonzero(hidden)[np.argmax(far[hidden])]]
        src = np.flatnonzero(shapely.distance(lines, nodes) <= 0.75 * grid.h)
        if not len(src):
            break
        dist, pred, _ = dijkstra(grid.cost, indices=src, min_only=True,
                                 return_predecessors=True)
        # the nearest node joined to the axes that sees the goal
        near = np.flatnonzero(np.isfinite(dist))
        near = near[np.argsort(np.hypot(*(pts[near] - goal).T))][:64]
        sees = shapely.covers(inside, shapely.linestrings(np.stack(
            [pts[near], np.broadcast_to(goal, (len(near), 2))], axis=1)))
        if not sees.any():
            break
        path = _route(grid, pred, int(near[np.argmax(sees)]))[::-1]
        path = np.vstack([path, goal])
        out.append(_tidy(path, inside, grid.h))
    return out
