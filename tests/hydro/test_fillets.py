"""Junction corners rounded by the builder (issue 12, item 5): where banks meet at a confluence
or a bifurcation the outline is a smooth arc, not a kink; the arc sits where a fillet of the
asked radius sits; away from the junctions nothing moves; and the flow keeps its properties
on the rounded outline (the banks there carry their ψ, the velocity follows the arc, the flux
between banks is their ψ difference, no divergence)."""
from __future__ import annotations

import numpy as np
import pytest
import shapely

import riverflow as rf
from riverflow.hydro.builder import RiverNetworkBuilder
from riverflow.scenes.layout import DEFAULT_SIZE_M, layout
from tests.flow.networks import divergence_and_gradient

LEFT_IN = [(-300, 150), (-150, 60), (0, 0)]
RIGHT_IN = [(-300, -160), (-140, -70), (0, 0)]
LOWER = [(0, 0), (200, 0), (400, 30)]


def confluence(fillet_fraction=None) -> RiverNetworkBuilder:
    """tests.flow.networks.confluence: arms 40 and 30 m wide into a 60 m river at (0, 0)."""
    extra = {} if fillet_fraction is None else {"fillet_fraction": fillet_fraction}
    b = RiverNetworkBuilder(**extra)
    b.add_branch(LEFT_IN, 40.0, discharge_m2s=30.0, name="left")
    b.add_branch(RIGHT_IN, 30.0, discharge_m2s=20.0, name="right")
    b.add_branch(LOWER, 60.0, name="lower")
    return b


def bifurcation(fillet_fraction=None) -> RiverNetworkBuilder:
    """tests.flow.networks.bifurcation: a split at (0, 0), the arms re-join at (350, 0)."""
    extra = {} if fillet_fraction is None else {"fillet_fraction": fillet_fraction}
    b = RiverNetworkBuilder(**extra)
    b.add_branch([(-300, 0), (0, 0)], 60.0, discharge_m2s=60.0, name="upper")
    x = np.linspace(0, 350, 60)
    bulge = np.sin(np.pi * x / 350) ** 0.7
    b.add_branch(np.c_[x, 75 * bulge], 40.0, discharge_m2s=35.0, name="north")
    b.add_branch(np.c_[x, -65 * bulge], 35.0, discharge_m2s=25.0, name="south")
    b.add_branch([(350, 0), (650, 0)], 60.0, name="lower")
    return b


def default_layout(fillet_fraction=None) -> RiverNetworkBuilder:
    """The default scene's network (a confluence, a split around an island that re-joins)."""
    extra = {} if fillet_fraction is None else {"fillet_fraction": fillet_fraction}
    b = RiverNetworkBuilder(tolerance_m=0.25, **extra)
    branches, islands = layout(np.random.default_rng(0), DEFAULT_SIZE_M)
    for br in branches:
        b.add_branch(br.centerline_m, br.widths_m, br.discharge_m2s, name=br.name)
    for outline in islands:
        b.add_island(outline)
    return b


def _junctions(graph) -> np.ndarray:
    """(J, 2) nodes where three or more axes meet."""
    ends = np.array([graph.nodes[graph.curves[a].start] for a in graph.axes()]
                    + [graph.nodes[graph.curves[a].end] for a in graph.axes()])
    keys, counts = np.unique(np.round(ends, 6), axis=0, return_counts=True)
    return keys[counts >= 3]


def _turns_deg(water) -> list[tuple[np.ndarray, np.ndarray]]:
    """Per ring of the water: vertices (M, 2) and the outline's turn there [°] (M,)."""
    out = []
    for poly in getattr(water, "geoms", [water]):
        for ring in [poly.exterior, *poly.interiors]:
            v = np.asarray(ring.coords)[:-1]
            a, b = v - np.roll(v, 1, axis=0), np.roll(v, -1, axis=0) - v
            turn = np.degrees(np.abs(np.arctan2(a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0],
                                                np.einsum("ij,ij->i", a, b))))
            out.append((v, turn))
    return out


def _max_turn_near(water, points: np.ndarray, radius_m: float) -> float:
    worst = 0.0
    for v, turn in _turns_deg(water):
        d = np.min(np.linalg.norm(v[:, None, :] - points[None], axis=2), axis=1)
        if (d < radius_m).any():
            worst = max(worst, float(turn[d < radius_m].max()))
    return worst


JUNCTION_WATER = []
"""(local water, corner_fillets' arguments) of every junction the ``built`` networks round."""


@pytest.fixture(scope="module")
def built():
    """{name: (rounded graph, its builder, sharp builder)} for the three networks."""
    from riverflow.hydro import _strips

    out = {}
    closed_form = _strips.corner_fillets

    def record(local, *args):
        JUNCTION_WATER.append((local, args))
        return closed_form(local, *args)

    _strips.corner_fillets = record
    memo, _strips.MEMO = _strips.MEMO, _strips.GeometryMemo(0)   # every junction made here
    try:
        for name, make in (("confluence", confluence), ("bifurcation", bifurcation),
                           ("default", default_layout)):
            b = make()
            sharp = make(0.0)
            sharp.build()
            out[name] = (b.build(), b, sharp)
    finally:
        _strips.corner_fillets = closed_form
        _strips.MEMO = memo
    return out


@pytest.mark.parametrize("name", ["confluence", "bifurcation", "default"])
def test_no_kink_at_junction_corners(built, name):
    """Every outline vertex within three widths of a junction turns by at most 12° (a fillet
    arc turns 2.8° a segment); the sharp outline has kinks of over 40° there."""
    graph, b, sharp = built[name]
    junctions = _junctions(graph)
    assert len(junctions) >= 1
    reach = 3.0 * max(float(graph.curves[a].width_m) for a in graph.axes())
    before = _max_turn_near(sharp.water_polygon, junctions, reach)
    after = _max_turn_near(b.water_polygon, junctions, reach)
    assert before > 40.0, before
    assert after <= 12.0, (name, after)


def test_fillet_sits_where_an_arc_of_the_radius_does():
    """The point of land between the two arms of the confluence (an angle α between their
    banks) is cut back to an arc of radius r = half the narrower width (15 m) tangent to both
    banks: the old tip is r/sin(α/2) − r from the new outline, and nothing else moves."""
    sharp, rounded = confluence(0.0), confluence()
    sharp.build()
    rounded.build()
    old, new = sharp.water_polygon, rounded.water_polygon
    v, turn = max(_turns_deg(old), key=lambda vt: vt[1].max())
    tip = v[int(np.argmax(turn))]
    # the arms' last segments come in along (150, -60) and (140, 70): α between them
    d1, d2 = np.array([150.0, -60.0]), np.array([140.0, 70.0])
    alpha = np.arccos(d1 @ d2 / np.linalg.norm(d1) / np.linalg.norm(d2))
    r = 0.5 * 30.0
    expected = r / np.sin(0.5 * alpha) - r
    assert rounded.water_polygon.contains(shapely.Point(tip))       # the tip is water now
    assert new.boundary.distance(shapely.Point(tip)) == pytest.approx(expected, rel=0.03)
    # away from the junction (beyond the corner and the arc) the outline has not moved but
    # by the outline's simplification (Douglas-Peucker to 0.05 m: the builder's last step)
    far = shapely.Point(0, 0).buffer(5.0 * 60.0)
    moved = shapely.symmetric_difference(old, new)
    assert shapely.difference(moved, far).buffer(-0.05).is_empty
    assert moved.area < 0.02 * old.area


def test_sharp_corners_when_asked_and_bad_fraction():
    b = confluence(0.0)
    b.build()
    assert _max_turn_near(b.water_polygon, np.zeros((1, 2)), 180.0) > 40.0
    for bad in (-0.1, 1.5, float("nan")):
        with pytest.raises(rf.GraphError, match="fillet_fraction"):
            RiverNetworkBuilder(fillet_fraction=bad)


def test_right_angle_corners_get_the_full_arc_at_any_heading():
    """A tributary meeting a river at a right angle, turned to 13 headings and at 3 widths:
    :func:`_strips.fillet_pieces` rounds both corners with the full radius (two pieces of
    r²(1 − π/4) each, nothing refused). The closed water's outline runs along the water's own
    edges up to rounding; overlaid with the water itself it left needles along them, joined
    to the corner pieces, which then reached out of the junction's disc and were refused
    (10 of these 39 cases fell back to smaller arcs)."""
    from shapely import affinity

    from riverflow.hydro import _strips
    from riverflow.hydro.builder import FILLET_EXTENT, FILLET_REACH_WIDTHS

    failed = []
    for heading in range(0, 90, 7):
        for w in (7.3, 23.0, 61.0):
            r, reach = 0.4 * w, FILLET_REACH_WIDTHS * w
            parts = [shapely.box(-400, -w / 2, 400, w / 2), shapely.box(-0.4 * w, 0, 0.4 * w, 400)]
            local = shapely.intersection(
                shapely.union_all([affinity.rotate(g, heading, origin=(0, 0)) for g in parts]),
                shapely.Point(0, 0).buffer(reach + 3 * r, quad_segs=_strips.FILLET_QUAD_SEGS))
            out, refused = _strips.fillet_pieces(local, np.zeros(2), r, reach, None,
                                                 FILLET_EXTENT * r)
            areas = sorted(round(p.area / r ** 2, 4) for p in out)
            if refused or len(out) != 2 or not np.allclose(areas, 1 - np.pi / 4, atol=0.01):
                failed.append((heading, w, refused, areas))
    assert not failed


def _t_junction(heading_deg: float, w: float, r: float, extra=()):
    """A tributary 0.8 w wide meeting a river w wide at a right angle, turned by the heading,
    within the junction's window (as the builder cuts it)."""
    from shapely import affinity

    from riverflow.hydro import _strips
    from riverflow.hydro.builder import FILLET_REACH_WIDTHS

    reach = FILLET_REACH_WIDTHS * w
    parts = [shapely.box(-400, -w / 2, 400, w / 2), shapely.box(-0.4 * w, 0, 0.4 * w, 400), *extra]
    local = shapely.intersection(
        shapely.union_all([affinity.rotate(g, heading_deg, origin=(0, 0)) for g in parts]),
        shapely.Point(0, 0).buffer(reach + 3 * r, quad_segs=_strips.FILLET_QUAD_SEGS))
    return local, reach


def test_closed_form_right_angle_corners():
    """:func:`_strips.corner_fillets` rounds both corners of the right-angled junction at every
    heading with the full arc (r²(1 − π/4) each, nothing refused, no fall-back to the
    closing); with a strip of water 1.5 r from the river's bank (a neck of land thinner than
    2r) the junction is not one of simple corners."""
    from riverflow.hydro import _strips
    from riverflow.hydro.builder import FILLET_EXTENT

    failed = []
    for heading in range(0, 90, 11):
        for w in (7.3, 61.0):
            r = 0.4 * w
            local, reach = _t_junction(heading, w, r)
            found = _strips.corner_fillets(local, np.zeros(2), r, reach, None, FILLET_EXTENT * r)
            areas = None if found is None else sorted(round(p.area / r ** 2, 3) for p in found[0])
            if found is None or found[1] or not np.allclose(areas, 1 - np.pi / 4, atol=0.01):
                failed.append((heading, w, areas))
            neck = shapely.box(0.8 * w, -w / 2 - 1.5 * r - 3.0, 3 * w, -w / 2 - 1.5 * r)
            local, reach = _t_junction(heading, w, r, [neck])
            if _strips.corner_fillets(local, np.zeros(2), r, reach, None, FILLET_EXTENT * r):
                failed.append((heading, w, "neck"))
    assert not failed


def test_fillet_kernel_matches_its_numpy_twin(built):
    """At every junction of the three networks and of the right-angled one (with and without
    a neck of land), the kernel and its plain-numpy twin (``tests/hydro/fillet_twin.py``)
    agree on whether the corners are simple and on every piece at the largest radius."""
    from riverflow.hydro import _strips
    from riverflow.hydro.builder import FILLET_EXTENT
    from riverflow.kernels import fillets
    from tests.hydro.fillet_twin import twin_fillets

    cases = [(local, args[:3]) for local, args in JUNCTION_WATER]
    for heading, extra in ((17, ()), (33, ()), (61, ()), (40, (shapely.box(8.0, -14.0, 30.0, -10.0),))):
        local, reach = _t_junction(heading, 10.0, 4.0, extra)
        cases.append((local, (np.zeros(2), 4.0, reach)))
    assert len(cases) >= 10
    simple = 0
    for local, (center, radius, reach) in cases:
        status, f = fillets.corner_fillets(
            _strips.fillet_outline(local), float(center[0]), float(center[1]), float(radius),
            float(reach), _strips.FILLET_MIN_TURN, _strips.FILLET_BALL_TOL, np.array([1.0]), 0.0)
        twin = twin_fillets(local, center, radius, reach)
        assert (status == 0) == (twin is not None), (status, center)
        if twin is None:
            continue
        simple += 1
        rings = [shapely.Polygon(f.coords[a:b]) for a, b in zip(f.start[:-1], f.start[1:])]
        assert len(rings) == len(twin)
        key = lambda g: tuple(np.round(g.centroid.coords[0], 6))  # noqa: E731
        for a, b in zip(sorted(rings, key=key), sorted(twin, key=key)):
            assert shapely.hausdorff_distance(a, b) < 1e-9
            assert a.area == pytest.approx(b.area, rel=1e-9)
    assert 4 <= simple < len(cases)


def test_closed_form_fillets_match_the_closing(built):
    """Where the corners are simple the closed-form pieces change the water's outline as the
    closing's do, within 1 cm (the closing's own polygonal buffers), at the junctions of the
    three networks (the confluence's; the others have shores that bend on both sides of a
    corner within its arc's reach, and fall back to the closing)."""
    from riverflow.hydro import _strips

    simple = 0
    for local, (center, radius, reach, keep_out, extent, scales) in JUNCTION_WATER:
        found = _strips.corner_fillets(local, center, radius, reach, keep_out, extent, scales)
        if found is None:
            continue
        simple += 1
        closed, water = [], local
        for scale in scales:
            added, refused = _strips.fillet_pieces(water, center, scale * radius, reach,
                                                   keep_out, extent)
            closed += added
            if not refused:
                break
            water = shapely.union_all([water, *added])
        a = shapely.union_all([local, *found[0]]).boundary
        b = shapely.union_all([local, *closed]).boundary
        assert shapely.hausdorff_distance(a, b, densify=0.1) < 0.01
    assert simple >= 1


@pytest.mark.parametrize("name", ["confluence", "bifurcation", "default"])
def test_rounded_networks_are_valid(built, name):
    graph, b, _ = built[name]
    assert rf.validate_graph(graph) == []
    # the islands the bifurcation encloses are still there
    _, _, sharp = built[name]
    assert len(getattr(b.water_polygon, "interiors", [])) == len(
        getattr(sharp.water_polygon, "interiors", []))


# -- the flow on the rounded confluence ---------------------------------------------------


@pytest.fixture(scope="module")
def confluence_flow(built):
    graph, b, sharp = built["confluence"]
    return graph, rf.FlowField(graph), b.water_polygon, sharp.water_polygon


def _fillet_outline(water, old) -> np.ndarray:
    """Points (N, 2) of the new outline where it left the old one (the fillet arcs), spaced
    0.5 m, without their last metre at each end."""
    boundary = water.boundary
    pts = []
    for line in getattr(boundary, "geoms", [boundary]):
        for s in np.arange(0.0, line.length, 0.5):
            p = line.interpolate(s)
            if old.boundary.distance(p) > 0.3:
                pts.append(p.coords[0])
    return np.asarray(pts)


def test_flow_follows_the_fillet_arc(confluence_flow):
    """Along the rounded point of land between the arms the bank there carries the ψ of the
    piece of shore between the arms, ψ just inside the arc (0.6 m) is that value (no flux
    through the arc), and the velocity 1.2 m inside runs along it: its normal part is under
    10 % of the local speed, or where the water is slower than the slowest arm's mean speed,
    of that mean speed (the tip of the land is a stagnation point where the two flows meet:
    there the speed vanishes, and the normal part relative to it grows as distance from the
    bank / distance from the point)."""
    graph, field, water, old = confluence_flow
    arc = _fillet_outline(water, old)
    assert len(arc) > 20
    ring = water.exterior
    ratios, inside = [], []
    mean_speed = min(30.0 / 40.0, 20.0 / 30.0, 50.0 / 60.0)   # discharge / width [m/s]
    for p in arc:
        s = ring.project(shapely.Point(p))
        a = np.array(ring.interpolate(s - 0.2).coords[0])
        b = np.array(ring.interpolate(s + 0.2).coords[0])
        t = (b - a) / np.linalg.norm(b - a)
        inward = np.array([-t[1], t[0]])                 # water on the left of the exterior
        inside.append(p + 0.6 * inward)
        q = p + 0.04 * 30.0 * inward
        status, v = field.query(q[None])
        assert status[0] == rf.FlowStatus.INSIDE
        speed = float(np.hypot(*v[0]))
        ratios.append(abs(float(v[0] @ inward)) / max(speed, mean_speed))
    assert max(ratios) < 0.10, max(ratios)
    # the banks through the tip's arc have the ψ of the land between the arms (that of the
    # left arm's right bank), and so has the water just inside the arc
    tip = arc[:, 0] < -40.0     # the tip's arc lies 20-35 m upstream of the old tip (-43, -5);
    assert tip.sum() > 20       # the arcs at the outer corners, 15-20 m from the junction
    psi = {graph.curves[i].potential for i in graph.banks()
           if shapely.LineString(graph.polyline(i)).distance(shapely.MultiPoint(arc[tip])) < 1e-6}
    between = _bank_psi_near(graph, (-150.0, 60.0 - 20.0))
    assert psi == {between}
    near = field.potential(np.asarray(inside)[tip])
    assert np.isfinite(near).all()
    assert np.abs(near - between).max() < 0.01 * 50.0


def _bank_psi_near(graph, xy) -> float:
    banks = graph.banks()
    d = [shapely.LineString(graph.polyline(i)).distance(shapely.Point(xy)) for i in banks]
    return graph.curves[banks[int(np.argmin(d))]].potential


def test_flux_and_divergence_around_the_rounded_confluence(confluence_flow, rng):
    """Sections across the lower river just below the junction and across each arm just above
    it carry their discharges (ψ differences); the divergence vanishes in the junction."""
    graph, field, water, _ = confluence_flow
    for x, q in ((25.0, 50.0), (50.0, 50.0)):
        cut = shapely.LineString([(x, -60.0), (x, 60.0)]).intersection(water)
        a, b = (np.array(c) for c in cut.coords[:2])
        s = np.linspace(0.0, 1.0, 801)
        _, v = field.query(a + s[:, None] * (b - a))
        t = (b - a) / np.linalg.norm(b - a)
        flux = np.trapezoid(v.astype(float) @ np.array([t[1], -t[0]]), s * np.linalg.norm(b - a))
        assert flux == pytest.approx(q, rel=0.05), (x, flux)
    for start, q in ((LEFT_IN[1], 30.0), (RIGHT_IN[1], 20.0)):
        p = np.asarray(start, float) * 0.4                    # 40 % of the way in from the arm
        d = -np.asarray(start, float) / np.linalg.norm(start)
        n = np.array([-d[1], d[0]])
        cut = shapely.LineString([p - 40.0 * n, p + 40.0 * n]).intersection(water)
        parts = [g for g in getattr(cut, "geoms", [cut]) if g.distance(shapely.Point(p)) < 1e-6]
        a, b = (np.array(c) for c in parts[0].coords[:2])
        s = np.linspace(0.0, 1.0, 801)
        _, v = field.query(a + s[:, None] * (b - a))
        t = (b - a) / np.linalg.norm(b - a)
        flux = abs(np.trapezoid(v.astype(float) @ np.array([t[1], -t[0]]),
                                s * np.linalg.norm(b - a)))
        assert flux == pytest.approx(q, rel=0.05), (start, flux)
    # divergence: finite differences at random points of the junction's water
    h = field.tiles.spacing_m(field.max_level)
    zone = shapely.intersection(water.buffer(-3 * h), shapely.Point(-20, 0).buffer(70.0))
    x0, y0, x1, y1 = zone.bounds
    pts = rng.uniform((x0, y0), (x1, y1), (4000, 2))
    pts = pts[shapely.contains_xy(zone, pts[:, 0], pts[:, 1])][:300]
    eps = 0.05 * h
    div, grad = divergence_and_gradient(field, pts, eps)
    assert np.max(np.abs(div)) < 0.05 * (np.median(grad) + 1e-9)


def test_union_by_groups_is_the_whole_overlay():
    """The fillets join the water group by group (issue 21): the polygons of one overlay of
    the whole, byte for byte and in the same order, whether a group has pieces of both
    sides, only water (its rings are still redrawn as the whole overlay redraws them) or two
    water polygons bridged by one piece."""
    from riverflow.hydro._strips import union_by_groups

    def blob(x, y, r=10.0):
        return shapely.Point(x, y).buffer(r, quad_segs=8)

    water = shapely.MultiPolygon([blob(0, 0), blob(100, 0), blob(200, 0), blob(230, 0)])
    pieces = shapely.MultiPolygon([blob(8, 5, 4), blob(-8, -5, 3), blob(215, 0, 8),
                                   blob(400, 0, 5)])
    whole = shapely.get_parts(shapely.union(water, pieces))
    grouped = union_by_groups(water, pieces)
    assert len(grouped) == len(whole) == 4       # (200, 0) and (230, 0) bridged by a piece
    assert [shapely.to_wkb(g) for g in grouped] == [shapely.to_wkb(g) for g in whole]


def test_the_outline_does_not_depend_on_where_its_rings_start():
    """The water's outline is simplified after the union of the strips (issue 21): the same
    polygon whose rings start at other vertices (as one overlay or another draws them) gives
    the same outline, vertex for vertex, so that an edit far away leaves a tile's water as
    it was."""
    from riverflow.hydro._strips import oriented_polygons

    rng = np.random.default_rng(3)

    def ring(r, n, shift):
        a = np.linspace(0.0, 2.0 * np.pi, n, endpoint=False)
        xy = np.c_[r * np.cos(a), 0.5 * r * np.sin(a)] + rng.normal(0.0, 0.02, (n, 2))
        return np.roll(xy, shift, axis=0)

    outer, hole = ring(100.0, 400, 0), ring(20.0, 120, 0)[::-1]
    made = [oriented_polygons(shapely.Polygon(np.roll(outer, s, axis=0), [np.roll(hole, t, axis=0)]),
                              0.05)
            for s, t in ((0, 0), (37, 5), (211, 90))]
    assert all(len(m) == 1 for m in made)
    n_kept = shapely.get_num_coordinates(made[0][0])
    assert 0 < n_kept < 400 + 120                 # the simplification dropped some vertices
    assert [shapely.to_wkb(m[0]) for m in made[1:]] == [shapely.to_wkb(made[0][0])] * 2
