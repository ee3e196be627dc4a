"""RiverNetworkBuilder: hydro graphs from centre lines satisfy the Proland rules (reference
§1.2): water on the left of every bank, right bank ψ larger facing downstream, ψ difference
across a branch = its discharge, equal ψ at nodes, axes covering their banks, continuous
areas, no crossing banks, islands as clockwise bank loops."""
from __future__ import annotations

import numpy as np
import pytest
import shapely
from shapely.geometry import LineString, Point

from riverflow.hydro._checks import area_loop, graph_problems
from riverflow.hydro.builder import RiverNetworkBuilder
from riverflow.hydro.graph import CurveType, GraphError, HydroGraph


def _signed_area(loop: np.ndarray) -> float:
    x, y = loop[:, 0], loop[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y))


def _bank_psi_near(graph: HydroGraph, xy) -> float:
    """ψ of the bank curve nearest to a point."""
    banks = graph.banks()
    d = [LineString(graph.vertices(i)).distance(Point(xy)) for i in banks]
    return graph.curves[banks[int(np.argmin(d))]].potential


def _psi_across(graph: HydroGraph, line, width_m: float, fraction: float = 0.5) -> float:
    """ψ(right bank) − ψ(left bank) at an arc-length fraction of a centre line drawn downstream."""
    line = np.asarray(line, dtype=float)
    s = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(line, axis=0).T))])
    j = int(np.clip(np.searchsorted(s, fraction * s[-1], side="right") - 1, 0, len(line) - 2))
    u = (fraction * s[-1] - s[j]) / (s[j + 1] - s[j])
    p = line[j] + u * (line[j + 1] - line[j])
    t = (line[j + 1] - line[j]) / (s[j + 1] - s[j])
    n = np.array([-t[1], t[0]])
    return _bank_psi_near(graph, p - 0.5 * width_m * n) - _bank_psi_near(graph, p + 0.5 * width_m * n)


def _check(graph: HydroGraph, branches) -> None:
    """Every self-check property, plus independent checks of the areas and the axis side."""
    assert graph_problems(graph, branches) == []
    for i in graph.banks():  # the linked axis is on the left of every shore bank
        c = graph.curves[i]
        assert c.has_potential and graph.curves[c.river].type == CurveType.AXIS
    signs = [np.sign(_signed_area(area_loop(graph, a))) for a in range(len(graph.areas))]
    assert signs.count(1.0) >= 1  # every water polygon has a counter-clockwise shore loop
    for n, inc in enumerate(graph.incident_curves()):
        psi = {graph.curves[c].potential for c in inc if graph.curves[c].is_bank}
        assert len(psi) <= 1, f"node {n}"
    assert min(graph.curves[i].potential for i in graph.banks()) == 0.0
    for line, widths, q in branches:
        assert q > 0
        w = float(np.min(widths))
        for f in (0.3, 0.7):
            assert _psi_across(graph, line, 0.98 * w, f) == pytest.approx(q, rel=1e-9)


def test_straight_channel():
    b = RiverNetworkBuilder()
    b.add_branch([[0.0, 0.0], [100.0, 0.0]], 20.0, 50.0, name="channel")
    g = b.build()
    _check(g, [([[0, 0], [100, 0]], [20.0, 20.0], 50.0)])
    types = [c.type for c in g.curves]
    assert types.count(CurveType.AXIS) == 1 and types.count(CurveType.CLOSING_SEGMENT) == 2
    assert types.count(CurveType.BANK) == 2 and len(g.areas) == 1
    axis = g.curves[g.axes()[0]]
    assert axis.width_m >= 1.1 * 20.0
    right = _bank_psi_near(g, (50.0, -10.0))
    left = _bank_psi_near(g, (50.0, 10.0))
    assert (left, right) == (0.0, 50.0)  # facing +x the right bank (y < 0) has the larger ψ
    for i in g.banks():
        v = g.vertices(i)
        d = v[-1] - v[0]
        to_axis = np.array([50.0, 0.0]) - v[0]
        assert d[0] * to_axis[1] - d[1] * to_axis[0] > 0  # axis (the water) on the left
    for c in g.curves:
        if c.type == CurveType.CLOSING_SEGMENT:
            assert c.width_m == 0.0 and not c.has_potential
    assert b.water_polygon.area == pytest.approx(2000.0, rel=1e-3)
    assert b.discharges_m2s == [50.0]


def test_building_twice_gives_equal_graphs():
    def make():
        b = RiverNetworkBuilder()
        b.add_branch([[0, 0], [50, 20], [100, 0]], [20, 25, 30], 40.0)
        return b.build()

    assert make() == make()


def test_a_network_built_again_looks_up_what_did_not_change(monkeypatch):
    """The strips and the junctions' corners are kept by a digest of their inputs
    (``_strips.MEMO``): a network built again (a live edit of one branch, a retry) looks
    up the strips and corners of what did not change, and the graph is the one a cold
    build makes, bit for bit (equal graphs)."""
    from riverflow.hydro import _strips

    def make(down_end):
        b = RiverNetworkBuilder()
        b.add_branch([[0, 0], [100, 0], [200, 10]], 30.0, 60.0)
        b.add_branch([[120, -150], [150, -60], [200, 10]], 20.0, 30.0)
        b.add_branch([[200, 10], [300, 0], [400, down_end]], 40.0)
        b.add_branch([[400, down_end], [500, down_end + 10], [900, down_end]], 40.0)
        return b.build()

    monkeypatch.setattr(_strips, "MEMO", _strips.GeometryMemo(10**6))
    cold = make(20.0)
    assert _strips.MEMO.hits == 0 and _strips.MEMO.misses == 4 + 2   # 4 strips, 2 junctions
    assert make(20.0) == cold and _strips.MEMO.misses == 6          # all looked up
    moved = make(35.0)        # the last two branches and both junctions near them moved
    assert _strips.MEMO.misses == 6 + 4 and _strips.MEMO.hits == 6 + 2
    monkeypatch.setattr(_strips, "MEMO", _strips.GeometryMemo(10**6))
    assert make(35.0) == moved                                      # as made cold
    tiny = _strips.GeometryMemo(0)                                  # over its budget: none kept
    monkeypatch.setattr(_strips, "MEMO", tiny)
    assert make(20.0) == cold and len(tiny._kept) == 0


def test_bend_with_free_island():
    th = np.linspace(0.0, np.pi / 2, 40)
    line = np.c_[200 * np.cos(th), 200 * np.sin(th)]
    b = RiverNetworkBuilder()
    b.add_branch(line, np.linspace(40.0, 60.0, 40), 50.0)
    ang = np.linspace(0, 2 * np.pi, 16, endpoint=False)
    centre = 200.0 * np.array([np.cos(0.6), np.sin(0.6)])
    b.add_island(centre + np.c_[6 * np.cos(ang), 12 * np.sin(ang)])
    g = b.build()
    _check(g, [(line, np.linspace(40.0, 60.0, 40), 50.0)])
    holes = [a for a in range(len(g.areas)) if _signed_area(area_loop(g, a)) < 0]
    assert len(holes) == 1  # the island: a clockwise loop, water on its left
    island_psi = {g.curves[c].potential for c, _ in g.areas[holes[0]].curves}
    assert len(island_psi) == 1
    psi = island_psi.pop()
    assert 0.0 < psi < 50.0 and psi == pytest.approx(25.0, rel=0.1)  # centred: about half
    for c, _ in g.areas[holes[0]].curves:
        assert g.curves[c].is_bank and g.curves[c].river in g.axes()


def test_a_free_island_near_a_bank_sends_the_gaps_share_of_the_discharge_round_it():
    """A free island 20 m wide 1.5 m off the left bank of a 100 m river: its ψ by the gaps
    between its shore and each bank (1.5 and 78.5 m), so the gap carries the discharge of
    its width, the river's own speed. By its centre's distances (11.5 and 88.5 m: its own
    width counted on each side) the 1.5 m gap carried 11.5 % of the discharge, 7.6 times the
    river's speed (London: a ring of 9 m/s round a small island in a pocket)."""
    import riverflow as rf

    line = np.c_[np.linspace(0.0, 600.0, 61), np.zeros(61)]
    b = RiverNetworkBuilder()
    b.add_branch(line, np.full(61, 100.0), 100.0)
    b.add_island(shapely.box(290.0, 28.5, 310.0, 48.5).exterior.coords[:-1])
    graph = b.build()
    holes = [a for a in range(len(graph.areas)) if _signed_area(area_loop(graph, a)) < 0]
    psi = graph.curves[graph.areas[holes[0]].curves[0][0]].potential
    left = _bank_psi_near(graph, (300.0, 50.0))
    right = _bank_psi_near(graph, (300.0, -50.0))
    assert abs(psi - left) == pytest.approx(100.0 * 1.5 / 80.0, rel=0.02)
    assert abs(psi - right) == pytest.approx(100.0 * 78.5 / 80.0, rel=0.02)
    xs, ys = np.meshgrid(np.linspace(295.0, 305.0, 5), np.linspace(48.8, 49.7, 4))
    status, v = rf.FlowField(graph).query(np.c_[xs.ravel(), ys.ravel()])
    inside = status == rf.FlowStatus.INSIDE
    assert inside.sum() >= 10
    mean = 100.0 / 100.0
    assert np.hypot(*v[inside].T).max() < 1.6 * mean


def test_island_with_given_potential_and_bad_potential():
    b = RiverNetworkBuilder()
    b.add_branch([[0, 0], [100, 0]], 40.0, 80.0)
    b.add_island([[40, 0], [60, 0], [50, 5]], potential=30.0)
    g = b.build()
    assert 30.0 in {g.curves[i].potential for i in g.banks()}
    b = RiverNetworkBuilder()
    b.add_branch([[0, 0], [100, 0]], 40.0, 80.0)
    b.add_island([[40, 0], [60, 0], [50, 5]], potential=100.0)
    with pytest.raises(GraphError, match="between"):
        b.build()


def test_confluence_sums_discharges():
    up, trib = [[0, 0], [100, 0], [200, 10]], [[120, -150], [150, -60], [200, 10]]
    down = [[200, 10], [300, 0], [400, 20]]
    b = RiverNetworkBuilder()
    b.add_branch(up, 30.0, 60.0, name="up")
    b.add_branch(trib, 20.0, 30.0, name="trib")
    b.add_branch(down, 40.0, name="down")
    g = b.build()
    assert b.discharges_m2s == [60.0, 30.0, 90.0]
    _check(g, [(up, [30.0], 60.0), (trib, [20.0], 30.0), (down, [40.0], 90.0)])
    junction = [n for n, inc in enumerate(g.incident_curves())
                if sum(g.curves[c].type == CurveType.AXIS for c in inc) == 3]
    assert len(junction) == 1 and np.allclose(g.nodes[junction[0]], [200, 10])
    assert len(g.areas) == 1 and sum(c.type == CurveType.CLOSING_SEGMENT for c in g.curves) == 3


def test_confluence_with_bezier_tributary():
    b = RiverNetworkBuilder(tolerance_m=0.1)
    b.add_branch([[0, 0], [200, 0]], 40.0, 60.0)
    b.add_branch([[0, -300], [50, -200], [150, -100], [200, 0]], [20.0, 24.0], 20.0, bezier=True)
    b.add_branch([[200, 0], [400, 0]], [50.0, 60.0])
    g = b.build()
    assert b.discharges_m2s == [60.0, 20.0, 80.0]
    assert graph_problems(g) == []
    assert _psi_across(g, [[200, 0], [400, 0]], 48.0) == pytest.approx(80.0)


def test_bifurcation_split_by_width_or_given():
    b = RiverNetworkBuilder()
    b.add_branch([[0, 0], [100, 0]], 40.0, 80.0)
    b.add_branch([[100, 0], [200, 60]], 30.0)
    b.add_branch([[100, 0], [200, -60]], 10.0)
    g = b.build()
    assert b.discharges_m2s == pytest.approx([80.0, 60.0, 20.0])
    _check(g, [([[0, 0], [100, 0]], [40.0], 80.0), ([[100, 0], [200, 60]], [30.0], 60.0),
               ([[100, 0], [200, -60]], [10.0], 20.0)])
    b = RiverNetworkBuilder()
    b.add_branch([[0, 0], [100, 0]], 40.0, 80.0)
    b.add_branch([[100, 0], [200, 60]], 30.0, 50.0)
    b.add_branch([[100, 0], [200, -60]], 20.0)
    b.build()
    assert b.discharges_m2s == pytest.approx([80.0, 50.0, 30.0])


def test_bifurcation_that_rejoins_encloses_an_island():
    up, left, right, down = ([[0, 0], [100, 0]], [[100, 0], [150, 30], [250, 30], [300, 0]],
                             [[100, 0], [150, -30], [250, -30], [300, 0]], [[300, 0], [400, 0]])
    b = RiverNetworkBuilder()
    b.add_branch(up, 40.0, 80.0)
    b.add_branch(left, 22.0)
    b.add_branch(right, 18.0)
    b.add_branch(down, 40.0)
    g = b.build()
    q = b.discharges_m2s
    assert q == pytest.approx([80.0, 44.0, 36.0, 80.0])
    _check(g, [(up, [40.0], 80.0), (left, [22.0], q[1]), (right, [18.0], q[2]), (down, [40.0], 80.0)])
    holes = [a for a in range(len(g.areas)) if _signed_area(area_loop(g, a)) < 0]
    assert len(holes) == 1
    island_psi = {g.curves[c].potential for c, _ in g.areas[holes[0]].curves}
    assert len(island_psi) == 1  # right bank of the left arm = left bank of the right arm
    assert island_psi.pop() == pytest.approx(q[1])  # left shore ψ 0 + the left arm's discharge
    assert shapely.Polygon(area_loop(g, holes[0])).contains(Point(200, 0))


def test_axis_split_where_width_changes():
    line = np.c_[np.linspace(0, 400, 9), np.zeros(9)]
    widths = np.linspace(20.0, 60.0, 9)
    b = RiverNetworkBuilder()
    b.add_branch(line, widths, 30.0)
    g = b.build()
    axes = [g.curves[i] for i in g.axes()]
    assert len(axes) >= 3
    _check(g, [(line, widths, 30.0)])


def test_separate_rivers_each_start_at_zero():
    b = RiverNetworkBuilder()
    b.add_branch([[0, 0], [200, 0]], 40.0, 80.0)
    b.add_branch([[0, 200], [200, 200]], 30.0, 50.0)
    g = b.build()
    assert len(g.areas) == 2
    assert sorted(g.curves[i].potential for i in g.banks()) == [0.0, 0.0, 50.0, 80.0]


def test_sharp_corner_polyline():
    line = [[0, 0], [100, 0], [100, 100]]
    b = RiverNetworkBuilder()
    b.add_branch(line, 30.0, 40.0)
    _check(b.build(), [(line, [30.0], 40.0)])


def _pair(b, first, second):
    b.add_branch(*first)
    b.add_branch(*second)


@pytest.mark.parametrize("make, message", [
    (lambda b: (b.add_branch([[0, 0], [100, 0]], 40, 80), b.add_branch([[100, 0], [200, 60]], 30, 50),
                b.add_branch([[100, 0], [200, -60]], 20, 40)), "inflow 80 m²/s ≠ outflow 90"),
    (lambda b: (b.add_branch([[0, 0], [100, 0]], 40, 80), b.add_branch([[100, -100], [100, 0]], 30, 50),
                b.add_branch([[100, 0], [200, 0]], 40, 100)), "inflow 130 m²/s ≠ outflow 100"),
    (lambda b: (b.add_branch([[0, 0], [100, 0]], 40, 80), b.add_branch([[100, 0], [200, 60]], 30, 80),
                b.add_branch([[100, 0], [200, -60]], 20)), "leave nothing"),
    (lambda b: _pair(b, ([[0, 0], [100, 0]], 40, 80), ([[120, 0], [200, 0]], 40)), "do not meet"),
    (lambda b: _pair(b, ([[0, 0], [200, 0]], 40, 80), ([[100, -100], [100, 0]], 30, 50)), "overlap"),
    (lambda b: _pair(b, ([[0, 0], [100, 0]], 40, 80),
                     ([[100, 0], [100, 100], [0, 100], [0, 0]], 40)), "loop"),
    (lambda b: _pair(b, ([[0, 0], [100, 0]], 40, 80), ([[0, 0], [-100, 0]], 40, 80)), "none ends there"),
    (lambda b: b.add_branch([[0, 0], [100, 0]], 40), "give its discharge"),
    (lambda b: b.add_branch([[0, 0], [200, 0]], [40, 0], 80), "positive"),
    (lambda b: b.add_branch([[0, 0], [200, 0]], -5.0, 80), "positive"),
    (lambda b: b.add_branch([[0, 0], [200, 0]], [40, 40, 40], 80), "one value per"),
    (lambda b: b.add_branch([[0, 0], [np.nan, 0]], 40, 80), "not finite"),
    (lambda b: b.add_branch([[0, 0]], 40, 80), "at least 2"),
    (lambda b: b.add_branch([[0, 0], [0, 0]], 40, 80), "at least 2 distinct"),
    (lambda b: b.add_branch([[0, 0], [100, 0]], 40, -1.0), "discharge must be a positive"),
    (lambda b: b.add_branch([[0, 0], [1, 1], [2, 2], [3, 3], [4, 4]], 4, 8, bezier=True), "3·n"),
    (lambda b: (b.add_branch([[0, 0], [100, 0]], 40, 80), b.add_island([[50, 30], [60, 30], [55, 40]])),
     "strictly inside"),
    (lambda b: (b.add_branch([[0, 0], [100, 0]], 40, 80), b.add_island([[50, 10], [60, 10], [55, 25]])),
     "strictly inside"),
    (lambda b: b.add_island([[0, 0], [1, 1], [1, 0], [0, 1]]), "simple polygon"),
    (lambda b: None, "no branches"),
    (lambda b: (b.add_branch([[0, 0], [200, 0], [200, 100], [100, 100], [100, -100]], 30, 10), b.build()),
     "loops onto itself"),
    (lambda b: b.add_branch([[0, 0], [100, 0], [0, 5]], 30, 10), "turns back"),
    (lambda b: (b.add_branch([[-400, 0], [0, 0]], 40, 10),
                b.add_branch([[-300, 100], [-250, -60], [-100, -60], [0, 0]], 30, 5),
                b.add_branch([[0, 0], [200, 0]], 40)), "away from the junction"),
])
def test_bad_input_raises_graph_error(make, message):
    b = RiverNetworkBuilder()
    with pytest.raises(GraphError, match=message):
        make(b)
        b.build()


def test_strips_that_overlap_away_from_a_shared_junction_are_refused():
    """Branches whose strips overlap must meet at a junction, and overlap only around it
    (their overlap is found on the strips cut to the box their boxes share)."""
    crossing = RiverNetworkBuilder()
    crossing.add_branch([[0.0, 0.0], [400.0, 0.0]], 20.0, 50.0, name="east")
    crossing.add_branch([[200.0, -200.0], [200.0, 200.0]], 20.0, 50.0, name="north")
    with pytest.raises(GraphError, match="'east' and 'north' overlap but do not meet"):
        crossing.build()
    # a tributary that joins at (400, 0) from the north but runs beside the river first, 8 m
    # from its axis, between x = 100 and 250 m
    beside = RiverNetworkBuilder()
    beside.add_branch([[0.0, 0.0], [400.0, 0.0]], 20.0, 50.0, name="river")
    beside.add_branch([[100.0, 300.0], [100.0, 8.0], [250.0, 8.0], [250.0, 100.0],
                       [400.0, 100.0], [400.0, 0.0]], 10.0, 20.0, name="trib")
    beside.add_branch([[400.0, 0.0], [800.0, 0.0]], 25.0, name="lower")
    with pytest.raises(GraphError, match=r"'river' and 'trib' overlap near \(.*\), away from"):
        beside.build()


def test_bank_potentials_do_not_depend_on_the_pieces_numbering():
    """ψ of the shore pieces is summed along a search over the branches: in the branches'
    order, not the pieces' numbering, so an edit of one branch that renumbers the pieces
    leaves every ψ elsewhere the same bit for bit (discharges whose sums differ in the last
    bits by order: 0.1 + 0.2 ≠ 0.3); pieces tied end to end hold one value."""
    from types import SimpleNamespace

    from riverflow.hydro._network import _solve_potentials

    # three sources into one river, then a split round an island: pieces 0..6
    q = [0.1, 0.2, 0.3, 0.6000000000000001]
    geoms = [SimpleNamespace(name=f"b{k}", discharge_m2s=v) for k, v in enumerate(q)]
    sides = [(0, 1), (1, 2), (2, 3), (0, 4)]
    ties = [(3, 4, 0.0, (0.0, 0.0)), (5, 6, 0.0, (1.0, 1.0))]
    pieces = [SimpleNamespace(points=np.zeros((2, 2))) for _ in range(7)]
    island_of = {5: 0, 6: 0}
    psi = _solve_potentials(geoms, sides, pieces, island_of, ties)
    assert psi[3] == psi[4]                                     # tied: one value
    for seed in range(5):
        perm = np.random.default_rng(seed).permutation(7)      # piece i is now perm[i]
        moved = _solve_potentials(
            geoms, [(perm[a], perm[b]) for a, b in sides], pieces,
            {int(perm[k]): v for k, v in island_of.items()},
            [(perm[a], perm[b], s, p) for a, b, s, p in ties])
        assert [moved[perm[i]] for i in range(5)] == psi[:5].tolist()


def test_a_strip_too_bent_to_mitre_is_its_quads_union_whatever_the_way_made():
    """A line of one width with a bend too tight to mitre (the strip's fallback): its strip is
    GEOS's buffer of the line (one operation; graphhopper's Beatty washes spent 16 s in
    unions of their segments' quads) and covers what the union of segment quads and bevels
    covers, more only at the mitre-clipped corners; a line whose width varies still takes
    the union."""
    import shapely

    from riverflow.hydro import _strips

    x = np.linspace(0.0, 400.0, 201)
    p = np.column_stack([x, 3.0 * np.sin(x / 7.0)])
    p[100] += (0.0, 9.0)                                    # a spike: no mitre there
    w = np.full(len(p), 4.0)
    strip = _strips.strip_polygon(p, w)
    h, n = 0.5 * w, _strips._unit_normals(p)
    quads = np.stack([p[:-1] + n * h[:-1, None], p[1:] + n * h[1:, None],
                      p[1:] - n * h[1:, None], p[:-1] - n * h[:-1, None],
                      p[:-1] + n * h[:-1, None]], axis=1)
    bevels = [np.stack([p[1:-1], p[1:-1] + s * n[:-1] * 2.0, p[1:-1] + s * n[1:] * 2.0,
                        p[1:-1]], axis=1) for s in (1.0, -1.0)]
    union = shapely.union_all(list(shapely.polygons(quads))
                              + [g for b in bevels for g in shapely.polygons(b)])
    assert strip.is_valid and strip.geom_type == "Polygon"
    assert shapely.difference(union, strip.buffer(1e-6)).area < 1e-6 * union.area
    reach = 1.5 * _strips.MITER_LIMIT * 0.5 * float(w[0])       # a clipped mitre's corner
    corners = shapely.union_all(shapely.buffer(shapely.points(p), reach))
    assert shapely.difference(shapely.difference(strip, union), corners).area < 1e-6
    assert shapely.hausdorff_distance(strip.boundary, union.boundary) < reach
    varying = _strips.strip_polygon(p, np.linspace(4.0, 5.0, len(p)))
    assert varying.is_valid and varying.area > union.area


def test_two_branches_leaving_a_junction_at_a_small_angle_build():
    """Two drains leave a junction 8° apart and run in one stream for a few metres before
    their strips part round a sliver of land (OpenStreetMap's Sydney extract: the drains of
    ways 532637503 and 532638010); the short one meets a tributary and runs on beside the
    other. A ray across the short drain's middle, where both run in one stream, crosses the
    other's centre line before it meets a bank: it reads the water of both (ψ twice the
    discharge) and says nothing of its banks; the check skips it (it refused the network).
    The banks beside the sliver still carry each drain's discharge."""
    ways = {
        "in_a": ([(-62.3, 420.4), (-16.0, 368.6), (-10.1, 358.8), (-7.1, 348.9),
                  (-6.4, 343.8), (-5.8, 332.8), (-8.3, 321.4), (-14.0, 311.9)], 1.73, 1.0),
        "in_b": ([(32.5, 350.5), (24.8, 344.3), (-1.7, 322.0)], 1.41, 0.67),
        "a": ([(-1.7, 322.0), (-14.0, 311.9)], 1.0, None),
        "b": ([(-1.7, 322.0), (-12.6, 307.4), (-24.7, 297.5), (-39.2, 285.0),
               (-124.8, 212.7), (-138.2, 187.2), (-149.0, 140.6)], 1.0, None),
        "c": ([(-14.0, 311.9), (-118.5, 223.1), (-131.9, 211.3), (-139.6, 198.7),
               (-144.1, 180.1), (-150.8, 151.5), (-149.0, 140.6)], 2.0, None),
        "out": ([(-149.0, 140.6), (-155.8, 123.0), (-167.1, 109.5), (-248.1, 42.6)], 2.24, None),
    }
    builder = RiverNetworkBuilder()
    for name, (points, width, q) in ways.items():
        builder.add_branch(np.array(points), width, q, name=name)
    graph = builder.build()
    q = dict(zip(ways, builder.discharges_m2s))
    assert q["a"] == pytest.approx(0.5 * 0.67) and q["c"] == pytest.approx(1.0 + q["a"])
    # beside the sliver, well past where the strips part, each drain carries its own share
    for name in ("b", "c"):
        points, width, _ = ways[name]
        for f in (0.3, 0.5, 0.7):
            assert _psi_across(graph, points, 0.98 * width, f) == pytest.approx(q[name], rel=1e-9)


def test_a_straight_bank_along_branches_end_to_end_links_to_each_axis():
    """Three 10 m branches drawn end to end in a straight line: each bank is one straight
    segment along all three. Linked whole to the middle axis, it made that axis 201 m wide
    (the flow field then read banks a kilometre away: NHD HR routing lines, a 10 m stream
    flowing +3.3 to -2.2 m/s across its width). It is cut where it passes the axes' ends."""
    b = RiverNetworkBuilder()
    for k in range(3):
        b.add_branch(np.array([[100.0 * k, 0.0], [100.0 * (k + 1), 0.0]]), 10.0,
                     discharge_m2s=5.0 if k == 0 else None)
    graph = b.build()
    assert [round(graph.curves[i].width_m, 1) for i in graph.axes()] == [12.0, 12.0, 12.0]


def test_ends_with_land_between_them_are_separate_waters():
    """Two rivers' ends 14 m apart across a 4 m strip of land (two water bodies of a given
    water area, as a mask's canals cut by a road): neither joined nor refused ("branches
    do not meet", which ends that near in one water still are)."""
    apart = shapely.union(shapely.box(0, -20, 100, 20), shapely.box(104, -20, 200, 20))
    for water, ok in ((apart, True), (shapely.box(0, -20, 200, 20), False)):
        b = RiverNetworkBuilder()
        b.add_branch([[0, 0], [93, 0]], 40.0, 50.0)
        b.add_branch([[107, 0], [200, 0]], 40.0, 50.0)
        b.set_water_area(water)
        if ok:
            g = b.build()
            assert len(g.areas) == 2 and graph_problems(g) == []
        else:
            with pytest.raises(GraphError, match="do not meet"):
                b.build()
