"""Strip geometry for :mod:`riverflow.hydro.builder`: branch strips, junction discs, the water
polygon and its boundary rings cut into pieces at the closing segments.

All polygon clipping is done by shapely (GEOS). A branch's strip is the union of one
quadrilateral per centre-line segment (offset ±width/2 along the segment normal, the width
interpolated linearly) and one bevel triangle per side at each interior vertex, so sharp bends
and widths larger than the bend radius stay valid. Ends that meet a junction are extended a
little into it and covered by a disc; free ends are cut flat (these cuts become the closing
segments).
"""
from __future__ import annotations

import hashlib
from dataclasses import dataclass

import numpy as np
import shapely
from shapely.geometry import LineString, Point, Polygon
from shapely.geometry.polygon import orient

from riverflow.tiles.memo import BudgetMemo

JUNCTION_EXTENSION = 0.05
"""How far a strip is pushed into a junction, as a fraction of its half-width."""

MITER_LIMIT = 3.0
"""Longest mitre, in half-widths, before a strip falls back to bevelled joins."""

_DISC_SEGMENTS = 32
"""Quarter-circle segments of a junction disc (chord error ≈ 3e-4 × radius)."""


class GeometryMemo(BudgetMemo):
    """What a pure function of geometry made, by a digest of its inputs (:meth:`key`), least
    recently used first out beyond ``budget`` coordinates. A network built again (a live
    edit of one branch, the narrowing's retries, a water area's retries) makes the same
    strips and junction corners for everything the change did not touch: they are looked
    up, not made again, and come out the same whatever was built before (the function is
    pure: the same inputs give the same geometry)."""

    @staticmethod
    def key(*parts) -> bytes:
        """A digest of ``parts``: arrays (their dtype, shape and bytes), geometries (WKB),
        sequences of those, numbers, None."""
        h = hashlib.blake2b(digest_size=20)
        stack = list(parts)
        while stack:
            part = stack.pop(0)
            if isinstance(part, np.ndarray):
                h.update(f"{part.dtype.str}{part.shape}".encode())
                h.update(np.ascontiguousarray(part).tobytes())
            elif isinstance(part, shapely.Geometry):
                h.update(b"g" + shapely.to_wkb(part))
            elif isinstance(part, (list, tuple)):
                h.update(f"[{len(part)}".encode())
                stack[:0] = list(part)
            else:
                h.update(repr(part).encode())
        return h.digest()

    def put(self, key: bytes, value, size: int) -> None:
        self.keep(key, value, size)


GEOMETRY_MEMO_COORDS = 250_000
"""Coordinates the strips' and junction corners' memo keeps (~6 MB with shapely's objects):
a network of a few hundred branches, built again after an edit of one."""
MEMO = GeometryMemo(GEOMETRY_MEMO_COORDS)


def _unit_normals(centerline_m: np.ndarray) -> np.ndarray:
    """Left unit normals of the segments of a (K, 2) polyline, (K-1, 2)."""
    d = np.diff(centerline_m, axis=0)
    length = np.hypot(d[:, 0], d[:, 1])
    return np.stack([-d[:, 1], d[:, 0]], axis=1) / length[:, None]


def extend_ends(centerline_m: np.ndarray, widths_m: np.ndarray, extend_start: bool,
                extend_end: bool) -> tuple[np.ndarray, np.ndarray]:
    """Push the junction ends of a centre line (K, 2) a little further along their tangents.

    Returns the new (K', 2) centre line and (K',) widths [m].
    """
    pts, w = centerline_m, widths_m
    if extend_start:
        t = pts[0] - pts[1]
        e = JUNCTION_EXTENSION * 0.5 * w[0]
        pts = np.vstack([pts[0] + t / np.hypot(*t) * e, pts])
        w = np.concatenate([[w[0]], w])
    if extend_end:
        t = pts[-1] - pts[-2]
        e = JUNCTION_EXTENSION * 0.5 * w[-1]
        pts = np.vstack([pts, pts[-1] + t / np.hypot(*t) * e])
        w = np.concatenate([w, [w[-1]]])
    return pts, w


def strip_polygon(centerline_m: np.ndarray, widths_m: np.ndarray) -> shapely.Geometry:
    """The water strip of one branch: centre line (K, 2) [m] offset by ±widths_m/2 (K,).

    The two sides are offset polylines with mitred vertices when that makes a simple polygon
    (smooth centre lines); where a bend is too tight for that (an offset side folds over
    itself, or a mitre is longer than MITER_LIMIT half-widths), the strip is the union of
    one quadrilateral per segment and bevel triangles at the vertices instead. Kept in
    :data:`MEMO` (a branch built again unchanged is looked up).
    """
    key = MEMO.key("strip", np.asarray(centerline_m, np.float64), np.asarray(widths_m, np.float64))
    strip = MEMO.get(key)
    if strip is None:
        strip = _strip_polygon(centerline_m, widths_m)
        MEMO.put(key, strip, int(shapely.get_num_coordinates(strip)))
    return strip


def _strip_polygon(centerline_m: np.ndarray, widths_m: np.ndarray) -> shapely.Geometry:
    p = centerline_m
    h = 0.5 * widths_m
    n = _unit_normals(p)
    if len(p) > 2:
        n0, n1 = n[:-1], n[1:]
        one_plus_cos = 1.0 + np.einsum("ij,ij->i", n0, n1)
        mitre_ok = one_plus_cos >= 2.0 / MITER_LIMIT ** 2
    else:
        mitre_ok = np.ones(0, bool)
    if mitre_ok.all():
        if len(p) > 2:  # mitre vectors: n·m = 1 for both segments at a vertex
            vn = np.vstack([n[:1], (n[:-1] + n[1:]) / one_plus_cos[:, None], n[-1:]])
        else:
            vn = np.vstack([n, n])
        left, right = p + vn * h[:, None], p - vn * h[:, None]
        poly = Polygon(np.vstack([left, right[::-1]]))
        if poly.is_valid:
            return poly
    return _strip_union(p, h, n, widths_m)


def _strip_union(p: np.ndarray, h: np.ndarray, n: np.ndarray, widths_m: np.ndarray) -> shapely.Geometry:
    """Strip as a union of segment quads and vertex bevels (robust for any bend); of one
    width, GEOS's buffer of the line (flat ends, mitred joins clipped at MITER_LIMIT): the
    same strip but at the mitre-clipped outer corners (0.3 m at most on graphhopper's Beatty
    washes, 0.01 % of the area) in one operation, not a union of thousands of pieces (a
    real line with a vertex every few metres and a few tight bends: 16 s of unions there)."""
    if np.all(widths_m == widths_m[0]):
        return drop_slivers(shapely.buffer(shapely.LineString(p), float(h[0]), cap_style="flat",
                                           join_style="mitre", mitre_limit=MITER_LIMIT),
                            0.25 * float(widths_m[0]) ** 2)
    t = np.stack([n[:, 1], -n[:, 0]], axis=1)
    # consecutive quads overlap by 2 ε at interior vertices: exactly shared edges computed
    # from nearly equal normals would leave floating-point cracks in the union
    eps = np.minimum(1e-3 * widths_m.min(), 0.01)
    grow_a = np.full((len(p) - 1, 1), eps)
    grow_b = np.full((len(p) - 1, 1), eps)
    grow_a[0] = grow_b[-1] = 0.0  # the strip's own ends stay flat cuts
    a, b = p[:-1] - t * grow_a, p[1:] + t * grow_b
    ha, hb = h[:-1, None], h[1:, None]
    quads = np.stack([a + n * ha, b + n * hb, b - n * hb, a - n * ha, a + n * ha], axis=1)
    polys = list(shapely.polygons(quads))
    if len(p) > 2:
        c = p[1:-1]
        hc = h[1:-1, None]
        n0, n1 = n[:-1], n[1:]
        turn = np.abs(n0[:, 0] * n1[:, 1] - n0[:, 1] * n1[:, 0])
        keep = turn > 1e-9
        for sign in (1.0, -1.0):
            tri = np.stack([c, c + sign * n0 * hc, c + sign * n1 * hc, c], axis=1)[keep]
            if len(tri):
                polys.extend(shapely.polygons(tri))
    # a single strip has no holes: small ones are artefacts of tapered quads overlapping at
    # jagged inner bends; a large one means the branch loops onto itself (the builder says so)
    return drop_slivers(shapely.union_all(polys), 0.25 * float(widths_m.min()) ** 2)


def drop_slivers(geom: shapely.Geometry, min_area_m2: float) -> shapely.Geometry:
    """Remove the holes smaller than ``min_area_m2`` (slivers left between the pieces of a
    union, where bevels meet quads in floating point)."""
    parts = []
    for g in getattr(geom, "geoms", [geom]):
        if not isinstance(g, Polygon) or g.is_empty:
            continue
        holes = [r for r in g.interiors if shapely.Polygon(r).area >= min_area_m2]
        parts.append(Polygon(g.exterior, holes) if len(holes) < len(g.interiors) else g)
    return parts[0] if len(parts) == 1 else shapely.MultiPolygon(parts)


def union_by_groups(a: shapely.Geometry, b: shapely.Geometry) -> list[Polygon]:
    """The polygons of ``shapely.union(a, b)`` for two polygonal geometries, overlaid group by
    group: the polygons of both whose boxes overlap, directly or through others, are one
    group, and each group is one overlay of its polygons of ``a`` with its polygons of ``b``
    (with nothing, where it has none: the overlay still redraws their rings as the whole one
    does). The overlay of a group nodes the same segments as the overlay of the whole
    (polygons of different groups are apart), so its polygons are those of the whole one,
    vertex for vertex; its cost grows with the group, not the whole network."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    pa, pb = shapely.get_parts(a), shapely.get_parts(b)
    parts = np.concatenate([pa, pb])
    n = len(parts)
    i, j = shapely.STRtree(parts).query(parts)
    _, label = connected_components(coo_matrix((np.ones(len(i)), (i, j)), shape=(n, n)),
                                    directed=False)
    order = np.argsort(label, kind="stable")
    cuts = np.flatnonzero(np.diff(label[order])) + 1
    out: list[Polygon] = []
    for group in np.split(order, cuts):
        ga, gb = parts[group[group < len(pa)]], parts[group[group >= len(pa)]]
        u = shapely.union(ga[0] if len(ga) == 1 else shapely.multipolygons(ga),
                          gb[0] if len(gb) == 1 else shapely.multipolygons(gb))
        # (an overlay of nearly touching pieces may also give lines and points: no water)
        out.extend(p for p in shapely.get_parts(shapely.get_parts(u))
                   if p.geom_type == "Polygon" and not p.is_empty)
    return out


def free_end_cut(centerline_m: np.ndarray, widths_m: np.ndarray, at_start: bool) -> np.ndarray:
    """The flat cut across a free river end, (2, 2) [m]: the future closing segment's line."""
    n = _unit_normals(centerline_m)
    if at_start:
        c, nn, h = centerline_m[0], n[0], 0.5 * widths_m[0]
    else:
        c, nn, h = centerline_m[-1], n[-1], 0.5 * widths_m[-1]
    return np.array([c + nn * h, c - nn * h])


def junction_disc(center_m: np.ndarray, half_widths_m: list[float]) -> Polygon:
    """A disc covering the (extended) strip ends that meet at a junction."""
    r = max(np.hypot(h, JUNCTION_EXTENSION * h) for h in half_widths_m) * 1.001
    return Point(center_m).buffer(r, quad_segs=_DISC_SEGMENTS)


def canonical_rings(water: shapely.Geometry) -> shapely.Geometry:
    """``water`` with every ring started at its least vertex (smallest x, then y), its
    direction kept: an outline that does not depend on where the overlay that made it happened
    to start each ring (a simplification keeps a ring's first vertex and splits from it)."""
    parts = []
    for poly in getattr(water, "geoms", [water]):
        if not isinstance(poly, Polygon) or poly.is_empty:
            continue
        rings = []
        for ring in [poly.exterior, *poly.interiors]:
            xy = shapely.get_coordinates(ring)[:-1]
            least = np.flatnonzero(xy[:, 0] == xy[:, 0].min())
            k = int(least[np.argmin(xy[least, 1])])
            xy = np.roll(xy, -k, axis=0)
            rings.append(np.vstack([xy, xy[:1]]))
        parts.append(Polygon(rings[0], rings[1:]))
    return parts[0] if len(parts) == 1 else shapely.MultiPolygon(parts)


def oriented_polygons(water: shapely.Geometry, simplify_m: float) -> list[Polygon]:
    """The polygons of a (multi)polygon, exterior counter-clockwise and holes clockwise, so
    that the water lies on the left of every ring traversal.

    The outline is first simplified (Douglas-Peucker, ``simplify_m``) to drop the millimetre
    notches left where the tapered segment quads of a strip meet. The plain simplifier is
    tried first: GEOS's topology-preserving one gives the same outline wherever the plain one
    leaves it valid with the same rings, but holds some 300 bytes per vertex while it works
    (150 MB for a 2,400-link network: the build's peak) and takes 3 times as long; it is
    used where the plain one breaks the outline.
    """
    shape = topology(water)
    water = canonical_rings(water)
    simple = shapely.remove_repeated_points(
        shapely.simplify(water, simplify_m, preserve_topology=False), tolerance=1e-6)
    if not (simple.is_valid and topology(simple) == shape):
        simple = shapely.remove_repeated_points(
            shapely.simplify(water, simplify_m, preserve_topology=True), tolerance=1e-6)
        if not simple.is_valid:
            simple = shapely.make_valid(simple)
    water = simple
    parts = [g for g in getattr(water, "geoms", [water]) if isinstance(g, Polygon) and not g.is_empty]
    parts.sort(key=lambda g: (-g.area, g.bounds))
    return [orient(g, sign=1.0) for g in parts]


@dataclass
class Piece:
    """A continuous stretch of one boundary ring between two closing segments (or a whole ring).

    ``points`` (M, 2) [m] run in the ring direction (water on the left); a closed piece does
    not repeat its first point.
    """

    ring: int
    points: np.ndarray
    closed: bool

    def line(self) -> shapely.Geometry:
        if self.closed:
            return shapely.LinearRing(self.points)
        return LineString(self.points)


@dataclass
class Ring:
    """One boundary ring: ``items`` is the ring in order as ("piece", index) and ("closing",
    (M, 2) points) entries; ``hole`` tells exterior from island loops."""

    polygon: int
    hole: bool
    items: list


def split_rings(polygons: list[Polygon], cuts: list[np.ndarray], eps_m: float
                ) -> tuple[list[Ring], list[Piece]]:
    """Cut every ring of ``polygons`` at the edges lying on one of the ``cuts`` ((2, 2) each).

    Returns the rings (pieces and closing segments in ring order) and the pieces.
    """
    cut_lines = [LineString(c) for c in cuts]
    tree = shapely.STRtree(cut_lines)
    n_cuts = max(len(cut_lines), 1)
    rings: list[Ring] = []
    pieces: list[Piece] = []
    for ip, poly in enumerate(polygons):
        for hole, lr in [(False, poly.exterior)] + [(True, r) for r in poly.interiors]:
            v = np.asarray(lr.coords)[:-1]
            m = len(v)
            flagged = np.zeros(m, bool)
            if cut_lines:
                # edge i lies on a cut when both its vertices lie within eps of the same cut
                p, c = tree.query(shapely.points(v), predicate="dwithin", distance=eps_m)
                code = p.astype(np.int64) * n_cuts + c
                after = ((p + 1) % m).astype(np.int64) * n_cuts + c
                flagged[p[np.isin(after, code)]] = True
            ring = Ring(ip, hole, [])
            if not flagged.any():
                ring.items.append(("piece", len(pieces)))
                pieces.append(Piece(len(rings), v.copy(), True))
                rings.append(ring)
                continue
            if flagged.all():
                raise ValueError("a boundary ring made only of closing segments")
            # rotate so that edge 0 is the first edge of a closing run
            starts = np.flatnonzero(flagged & ~np.roll(flagged, 1))
            s0 = int(starts[0])
            v = np.roll(v, -s0, axis=0)
            flagged = np.roll(flagged, -s0)
            i = 0
            while i < m:
                j = i
                while j < m and flagged[j]:
                    j += 1
                ring.items.append(("closing", v[np.arange(i, j + 1) % m]))
                k = j
                while k < m and not flagged[k]:
                    k += 1
                ring.items.append(("piece", len(pieces)))
                pieces.append(Piece(len(rings), v[np.arange(j, k + 1) % m], False))
                i = k
            rings.append(ring)
    return rings, pieces


# -- junction fillets ---------------------------------------------------------------------

FILLET_QUAD_SEGS = 32
"""Segments per quarter circle of a fillet arc (2.8° of turn per segment)."""
FILLET_OVERLAP_M = 1e-3
"""The pieces of water a fillet adds are grown this much before they are added."""
FILLET_GAP_M = 1e-4
"""The closed water is compared with the water grown this much: the closing's outline runs
along the water's own edges up to rounding, and an overlay of two nearly equal outlines costs
GEOS several noding passes (2.5 times the time); grown, their common edges lie apart. The
pieces found lose this much along the water's edges, and get it back when they are grown."""


def fillet_pieces(local: shapely.Geometry, center_m: np.ndarray, radius_m: float,
                  reach_m: float, keep_out: shapely.Geometry | None = None,
                  extent_m: float | None = None) -> tuple[list[Polygon], bool]:
    """The pieces of water that round the corners of the water outline around one junction,
    and whether a corner was refused.

    Where two branches' banks meet at a junction their strips leave a sharp corner: a point of
    land between them, or a notch where a narrower strip meets the junction disc (the disc
    only widens the water: every such corner turns the outline away from the water). The
    morphological closing of the water with a disc of radius ``radius_m`` cuts every point of
    land sharper than that back to an arc of that radius, tangent to both banks; straight
    banks, outer bends and inner bends gentler than the radius are left alone.

    ``local`` is the water within ``reach_m + 3·radius_m`` of ``center_m`` (the closing is
    exact within ``reach_m``). Each connected piece of water the closing adds is returned if it
    lies within ``reach_m``, away from ``keep_out`` (the closing segments of free river ends,
    which must stay straight cuts), is thicker than the arcs' own chord error (the buffers'
    rounding along gentle bends), fits in a circle of radius ``extent_m`` (default two radii:
    a point of land of 28° or more; a slimmer one would be eaten far back) and leaves the
    water's topology as it was (it neither joins two shores nor fills an island). Each is
    grown by FILLET_OVERLAP_M (beyond the FILLET_GAP_M it was found with): it shares an edge
    with the outline up to rounding, and an overlay of two nearly equal edges can leave a
    needle between them; grown, it overlaps.

    A corner is *refused* when a piece thicker than the chord error that reaches into the
    ``reach_m`` disc fails one of the other tests: only then can a smaller arc round it
    (the closing with a smaller disc adds nothing to water already closed with a larger one
    but where the larger one's pieces were left out).
    """
    if local.is_empty:
        return [], False
    rounded = local.buffer(radius_m, quad_segs=FILLET_QUAD_SEGS).buffer(
        -radius_m, quad_segs=FILLET_QUAD_SEGS)
    inner = Point(center_m).buffer(reach_m, quad_segs=FILLET_QUAD_SEGS)
    # a chord of an arc of radius r misses it by r·(1 − cos(Δ/2)), Δ = 90°/quad_segs: thinner
    # differences are the buffers' own rounding along straight banks and gentle bends (their
    # areas are under r²·Δ³/8; a corner that turns by 12° leaves r²·(tan 6° − π/30))
    half = 0.5 * np.pi / (2.0 * FILLET_QUAD_SEGS)
    thin = 4.0 * radius_m * (1.0 - np.cos(half))
    small = 4.0 * radius_m ** 2 * (2.0 * half) ** 3
    shape = topology(local)
    grown = local.buffer(FILLET_GAP_M, join_style="mitre")
    changed = shapely.get_parts(shapely.difference(rounded, grown))
    # the tests below, cheapest first, each on the parts the previous ones kept
    changed = changed[(shapely.get_type_id(changed) == 3) & (shapely.area(changed) >= small)]
    shapely.prepare(inner)
    changed = changed[shapely.intersects(inner, changed)]
    changed = changed[~shapely.is_empty(shapely.buffer(changed, -thin))]
    candidates = len(changed)
    changed = changed[shapely.contains(inner, changed)]
    if keep_out is not None and len(changed):
        changed = changed[~(shapely.distance(changed, keep_out) < 2.0 * radius_m)]
    # a slim point of land: its rounding would eat it far back
    changed = changed[~(shapely.minimum_bounding_radius(changed) > (extent_m or 2.0 * radius_m))]
    out = []
    for part in shapely.buffer(changed, FILLET_GAP_M + FILLET_OVERLAP_M, join_style="mitre"):
        if topology(shapely.union(local, part)) != shape:
            continue        # it joins two shores across a neck of land, or fills an island
        out.append(part)
    return out, len(out) < candidates


def topology(geom: shapely.Geometry) -> list[int]:
    """Holes per polygon of a (multi)polygon, largest polygon first."""
    parts = [g for g in getattr(geom, "geoms", [geom]) if isinstance(g, Polygon) and not g.is_empty]
    parts.sort(key=lambda g: -g.area)
    return [len(g.interiors) for g in parts]


FILLET_MIN_TURN = np.radians(5.0)
"""Corners that turn less than this are not rounded by :func:`corner_fillets` (the closing's
piece there is under a tenth of the chord-error area that :func:`fillet_pieces` keeps)."""
FILLET_BALL_TOL = 1e-3
"""Relative slack of :func:`corner_fillets`' rolling-disc test: a disc of radius r tangent to
the shore must keep r·(1 − this) from the water (the closing's own pieces thinner than its
chord error, 1.2e-3 r, are dropped anyway)."""


def corner_fillets(local: shapely.Geometry, center_m: np.ndarray, radius_m: float,
                   reach_m: float, keep_out: shapely.Geometry | None = None,
                   extent_m: float | None = None, scales: tuple[float, ...] = (1.0,)
                   ) -> tuple[list[Polygon], bool] | None:
    """:func:`fillet_pieces` in closed form where the water's outline near the junction is made
    of simple corners, or None where it is not (then the closing must do it).

    At a corner where the outline (water on the left) turns right by θ — a point of land of
    angle π − θ — the closing with a disc of radius r adds the land between the two shores and
    the arc of radius r tangent to both: its centre C lies on the land side at r from both
    shores. Between straight edges C is where the edges' lines offset by r cross and the
    tangent points lie r·tan(θ/2) from the corner; where one shore bends away from the land
    (the polygonal arc of a junction disc) C lies on the other edge's offset line at r from
    the bent shore. A blunt point (a run of right turns joined by edges shorter than their
    arcs' tangents) is one corner, θ the sum of its turns. That is all the closing adds near
    the junction when (checked, else None): the corners' tangent stretches do not overlap; a
    disc of radius r tangent to the shore on the land side anywhere along the edges within
    ``reach_m`` + r of ``center_m``, outside the tangent stretches, keeps clear of the water
    (no neck of land thinner than 2r, no inner bend tighter than r, no water reaching into an
    arc), and so do the corners' discs; and no other vertex of the water lies in a corner's
    piece (it would join two shores or fill an island). Each piece then leaves the water's
    topology as it was. Corners turning less than FILLET_MIN_TURN between straight edges are
    not rounded (the closing's piece there is under a tenth of the smallest area it keeps).
    The geometry is :func:`riverflow.kernels.fillets.corner_fillets`.

    The pieces meet the same tests as :func:`fillet_pieces`' (area, thickness, within the
    ``reach_m`` disc, away from ``keep_out``, within ``extent_m``) and are grown the same
    FILLET_GAP_M + FILLET_OVERLAP_M. ``scales``: the arcs' radii tried in turn (× ``radius_m``),
    each smaller one only at the corners the larger one refused (the tests above at the
    largest radius hold for the smaller ones). Returns the pieces and whether a corner was
    refused at the last scale.
    """
    from riverflow.kernels import fillets as _kernel

    if local.is_empty:
        return [], False
    outline = fillet_outline(local)
    sc = np.sort(np.asarray(scales, float))[::-1]
    r = float(radius_m) * sc[0]
    c = np.asarray(center_m, float)
    status, f = _kernel.corner_fillets(outline, float(c[0]), float(c[1]), r, float(reach_m),
                                       FILLET_MIN_TURN, FILLET_BALL_TOL, sc / sc[0],
                                       FILLET_GAP_M + FILLET_OVERLAP_M)
    if status:
        return None
    if not len(f.corner):
        return [], False
    counts = np.diff(f.start)

    def rings(coords, idx):
        rows = np.concatenate([np.arange(f.start[k], f.start[k + 1]) for k in idx])
        return shapely.polygons(shapely.linearrings(
            coords[rows], indices=np.repeat(np.arange(len(idx)), counts[idx])))

    polys = np.full(len(f.corner), None, dtype=object)

    def pieces(idx):
        """The pieces ``idx`` as polygons (made when a test needs them)."""
        missing = idx[polys[idx] == None]  # noqa: E711
        if len(missing):
            polys[missing] = rings(f.coords, missing)
        return polys[idx]

    # a corner of one vertex between straight edges makes a valid piece; the others are
    # checked
    other = np.flatnonzero((f.scale == 0) & (f.inscribed_m < 0.0))
    if len(other) and not shapely.is_valid(pieces(other)).all():
        return None
    # the reach disc is a polygon of 4·FILLET_QUAD_SEGS sides: a piece surely meets it
    # (lies in it) when its nearest (farthest) point lies within the inscribed circle, surely
    # not beyond the circumscribed one; GEOS decides between the two
    apothem = reach_m * np.cos(np.pi / (4 * FILLET_QUAD_SEGS))
    inner = None

    def in_reach(idx, dist, test):
        nonlocal inner
        out = dist[idx] < apothem if test is shapely.intersects else dist[idx] <= apothem
        unsure = (dist[idx] >= apothem) & (dist[idx] <= reach_m)
        if unsure.any():
            if inner is None:
                inner = Point(center_m).buffer(reach_m, quad_segs=FILLET_QUAD_SEGS)
            out[unsure] = test(inner, pieces(idx[unsure]))
        return out

    todo = np.unique(f.corner[f.scale == 0])
    out, refused = [], False
    half = 0.5 * np.pi / (2.0 * FILLET_QUAD_SEGS)
    for s in range(len(sc)):
        rs = float(radius_m) * sc[s]
        if not f.solved[todo, s].all():
            return None                   # a smaller arc would touch a blunt point's vertices
        sel = np.flatnonzero((f.scale == s) & np.isin(f.corner, todo) & f.inside_reach)
        if not len(sel):
            return out, False
        # the tests of fillet_pieces, in its order (the thickness in closed form where known)
        thin = 4.0 * rs * (1.0 - np.cos(half))
        small = 4.0 * rs ** 2 * (2.0 * half) ** 3
        sel = sel[f.area_m2[sel] >= small]
        sel = sel[in_reach(sel, f.near_m, shapely.intersects)]
        known = f.inscribed_m[sel]
        thick = known > 1.01 * thin
        unsure = (known < 0.0) | ((known >= 0.99 * thin) & ~thick)
        if unsure.any():
            thick[unsure] = ~shapely.is_empty(shapely.buffer(pieces(sel[unsure]), -thin))
        sel = sel[thick]
        kept = in_reach(sel, f.far_m, shapely.contains)
        if keep_out is not None:
            kept &= ~(shapely.distance(pieces(sel), keep_out) < 2.0 * rs)
        # the smallest circle around a piece has a radius between half its diameter and the
        # diameter / √3
        extent = extent_m or 2.0 * rs
        d = f.diameter_m[sel]
        slim = d / 2.0 > extent
        unsure = kept & ~slim & (d / np.sqrt(3.0) > extent)
        if unsure.any():
            slim[unsure] = shapely.minimum_bounding_radius(pieces(sel[unsure])) > extent
        kept &= ~slim
        if kept.any():
            out += list(rings(f.grown, sel[kept]))
        refused = not kept.all()
        todo = f.corner[sel[~kept]]
        if not refused:
            break
    return out, refused


def fillet_outline(local: shapely.Geometry):
    """The rings of a (multi)polygon as :class:`riverflow.kernels.fillets.Outline` (water on
    the left: exteriors counter-clockwise, holes clockwise)."""
    from riverflow.kernels.fillets import outline

    parts = shapely.get_parts(local)
    rings = shapely.get_rings(parts)
    xy, ring_of = shapely.get_coordinates(rings, return_index=True)
    exterior = np.zeros(len(rings), bool)
    exterior[np.cumsum(np.r_[0, 1 + shapely.get_num_interior_rings(parts)[:-1]])] = True
    return outline(xy, ring_of.astype(np.int64), exterior)
