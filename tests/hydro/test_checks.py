"""The builder's self-check (:func:`graph_problems`) finds what it is meant to find, and its
bulk ray queries (:mod:`riverflow.hydro.nearest`: ``ray_hits`` over ``LineChunks``,
``first_per_group``) give what one shapely query per ray gives."""
from __future__ import annotations

import copy

import numpy as np
import pytest
import shapely
from shapely.geometry import LineString, Point

from riverflow.hydro._checks import graph_problems
from riverflow.hydro.builder import RiverNetworkBuilder
from riverflow.hydro.graph import Area, Curve, CurveType, HydroGraph
from riverflow.hydro.nearest import (CHUNK_SEGMENTS, LineChunks, first_per_group, ray_hits,
                                     tangents_at)


@pytest.fixture(scope="module")
def confluence():
    """A small confluence: (graph, branches as (centre line, widths, discharge))."""
    b = RiverNetworkBuilder()
    main = np.array([[0.0, 0.0], [100.0, 5.0], [200.0, 0.0]])
    trib = np.array([[120.0, 120.0], [160.0, 60.0], [200.0, 0.0]])
    lower = np.array([[200.0, 0.0], [300.0, -10.0], [400.0, 0.0]])
    b.add_branch(main, 20.0, 30.0, name="main")
    b.add_branch(trib, 12.0, 10.0, name="trib")
    b.add_branch(lower, 26.0, name="lower")
    graph = b.build()
    branches = [(main, np.full(3, 20.0), 30.0), (trib, np.full(3, 12.0), 10.0),
                (lower, np.full(3, 26.0), 40.0)]
    return graph, branches


def test_a_good_graph_has_no_problems(confluence):
    graph, branches = confluence
    assert graph_problems(graph, branches) == []
    assert graph_problems(graph, [(line, q) for line, _, q in branches]) == []   # no widths


def test_a_wrong_discharge_is_found(confluence):
    graph, branches = confluence
    wrong = [branches[0], branches[1], (branches[2][0], branches[2][1], 41.0)]
    problems = graph_problems(graph, wrong)
    assert any(p.startswith("branch 2: ψ(right) − ψ(left) = 40") for p in problems), problems
    assert not any(p.startswith(("branch 0", "branch 1")) for p in problems), problems


def test_a_bank_with_another_potential_is_found(confluence):
    graph, branches = confluence
    bad = copy.deepcopy(graph)
    bank = bad.banks()[0]
    bad.curves[bank].potential += 5.0
    problems = graph_problems(bad, branches)
    assert any("different ψ" in p for p in problems), problems
    assert any("discharge" in p for p in problems), problems


def test_a_reversed_area_is_found(confluence):
    """The water loop walked the other way: clockwise and not an island, water on the right
    of every bank."""
    graph, _ = confluence
    bad = copy.deepcopy(graph)
    bad.areas = [Area([(c, 1 - o) for c, o in reversed(a.curves)]) for a in bad.areas]
    problems = graph_problems(bad)
    assert any("clockwise loop that is not an island" in p for p in problems), problems
    assert any("water is not on its left" in p for p in problems), problems


def test_a_nested_counter_clockwise_loop_is_found(confluence):
    graph, _ = confluence
    loop = np.array([[50.0, -3.0], [60.0, -3.0], [60.0, 3.0], [50.0, 3.0]])     # in the water
    nodes = np.vstack([graph.nodes, loop])
    n0 = len(graph.nodes)
    curves = list(graph.curves)
    first = len(curves)
    for k in range(4):
        curves.append(Curve(n0 + k, n0 + (k + 1) % 4, type=CurveType.CLOSING_SEGMENT))
    bad = HydroGraph(nodes, curves, list(graph.areas) + [Area([(first + k, 0) for k in range(4)])])
    problems = graph_problems(bad)
    assert any(p.startswith(f"area {len(graph.areas)}: counter-clockwise loop inside")
               for p in problems), problems


def _main_banks(graph):
    """The banks linked to the axis of branch "main" (the one along y ≈ 0 left of x = 200)."""
    main = [i for i in graph.axes() if graph.vertices(i)[:, 0].max() <= 200.0 + 1e-6
            and abs(graph.vertices(i)[:, 1]).max() < 10.0]
    assert len(main) == 1
    return main[0], [i for i in graph.banks() if graph.curves[i].river == main[0]]


def test_a_bank_beyond_its_axis_reach_is_found(confluence):
    """Linked to the tributary's axis, the main river's bank lies farther from it than its
    half width; the other banks stay clean."""
    graph, branches = confluence
    bad = copy.deepcopy(graph)
    main, banks = _main_banks(bad)
    trib = next(i for i in bad.axes() if bad.vertices(i)[:, 1].max() > 100.0)
    bad.curves[banks[0]].river = trib
    problems = graph_problems(bad, branches)
    assert any(p.startswith(f"bank {banks[0]}: ") and f"farther from axis {trib}" in p
               for p in problems), problems
    assert not any(p.startswith(f"bank {banks[1]}: ") for p in problems), problems
    # the builder makes every axis cover its banks and skips this test (only this one)
    assert graph_problems(bad, branches, axes_cover_banks=True) == [
        p for p in problems if "farther from axis" not in p]


def test_a_bank_with_its_axis_on_the_right_is_found(confluence):
    """A bank mirrored across its axis (same direction): the axis lies on its right there
    (the water the areas describe changes too, so other banks' tests fail as well); the
    problem says where the bank lies (its vertices' mean)."""
    graph, branches = confluence
    bad = copy.deepcopy(graph)
    main, banks = _main_banks(bad)
    axis = bad.vertices(main)
    c = bad.curves[banks[1]]
    y_axis = np.interp(c.points[:, 0], axis[:, 0], axis[:, 1])
    c.points = np.stack([c.points[:, 0], 2.0 * y_axis - c.points[:, 1]], axis=1)
    problems = graph_problems(bad, branches)
    x, y = bad.vertices(banks[1]).mean(axis=0)
    assert any(p.startswith(f"bank {banks[1]}: its axis {main} lies on its right")
               and p.endswith(f"near ({x:.1f}, {y:.1f})") for p in problems), problems


def _scalar_hits(origin, direction, reach, lines, tree):
    """One ray the way the builder asked before: the lines it crosses, the distance to each
    line's crossing (shapely on the whole line)."""
    ray = LineString([origin, origin + direction * reach])
    hits = tree.query(ray, predicate="intersects")
    return hits, [shapely.distance(Point(origin), ray.intersection(lines[i])) for i in hits]


def test_bulk_ray_hits_equal_one_query_per_ray():
    """Lines of many chunks (and of one, and a ring): the same lines crossed, each at exactly
    the distance shapely gives for the whole line."""
    rng = np.random.default_rng(3)
    sizes = rng.integers(2, 5 * CHUNK_SEGMENTS, 40)
    coords = [np.cumsum(rng.normal(0.0, 6.0, (n, 2)), axis=0) + rng.uniform(0, 100, 2)
              for n in sizes]
    coords[0] = np.vstack([coords[0], coords[0][:1]])        # a closed ring
    lines = [LineString(c) for c in coords]
    tree = shapely.STRtree(lines)
    origins = rng.uniform(0, 100, (60, 2))
    angle = rng.uniform(0, 2 * np.pi, 60)
    directions = np.stack([np.cos(angle), np.sin(angle)], axis=1)
    reach = rng.uniform(1, 60, 60)
    ray, hit, dist = ray_hits(origins, directions, reach, LineChunks(coords))
    assert len(ray) > 60
    nearest = first_per_group(ray, dist, 60)
    farthest = first_per_group(ray, dist, 60, largest=True)
    for r in range(60):
        want_hits, want_dist = _scalar_hits(origins[r], directions[r], reach[r], lines, tree)
        order = np.argsort(want_hits)
        want_hits, want_dist = np.asarray(want_hits)[order], np.asarray(want_dist)[order]
        assert list(hit[ray == r]) == list(want_hits)        # by line
        assert list(dist[ray == r]) == list(want_dist)       # exactly the same numbers
        if len(want_hits):
            assert hit[nearest[r]] == want_hits[int(np.argmin(want_dist))]
            assert hit[farthest[r]] == want_hits[int(np.argmax(want_dist))]
        else:
            assert nearest[r] == farthest[r] == -1


def test_tangents_at_equal_the_nearest_segment_point_by_point():
    """The batch of nearest segments' directions (the box hierarchy) equals the one-point
    loop over every segment it replaced (the first of equally near segments: a polyline's
    vertices are shared by two)."""
    rng = np.random.default_rng(3)
    line = np.cumsum(rng.normal(0.0, 10.0, (40, 2)), axis=0)
    points = np.vstack([rng.uniform(line.min(axis=0) - 20, line.max(axis=0) + 20, (300, 2)),
                        line])                                   # vertices: ties
    a, d = line[:-1], np.diff(line, axis=0)
    dd = np.maximum(np.einsum("ij,ij->i", d, d), 1e-300)
    looped = []
    for p in points:
        u = np.clip(np.einsum("ij,ij->i", p - a, d) / dd, 0.0, 1.0)
        looped.append(d[int(np.argmin(np.hypot(*(a + u[:, None] * d - p).T)))])
    assert np.array_equal(tangents_at(line, points), np.array(looped))


def test_first_per_group_takes_the_first_of_equal_keys():
    group = np.array([0, 0, 0, 2, 2])
    key = np.array([1.0, 0.5, 0.5, 3.0, 3.0])
    assert list(first_per_group(group, key, 4)) == [1, -1, 3, -1]
    assert list(first_per_group(group, key, 4, largest=True)) == [0, -1, 3, -1]


def test_tiled_point_location_equals_shapely(monkeypatch):
    """contains_xy_tiled cut into many small tiles answers as one contains_xy, also for points
    a few millimetres from the outline and on the tiles' cut lines."""
    from riverflow.hydro import _checks
    monkeypatch.setattr(_checks, "TILE_VERTICES", 40)
    rng = np.random.default_rng(5)
    s = np.linspace(0.0, 2000.0, 400)
    axis = np.stack([s, 80.0 * np.sin(s / 150.0)], axis=1)
    river = shapely.LineString(axis).buffer(12.0, quad_segs=8)
    river = shapely.difference(river, shapely.Point(1000.0, 80.0 * np.sin(1000.0 / 150.0))
                               .buffer(4.0))                                  # an island
    river = shapely.MultiPolygon([river, shapely.box(0.0, 300.0, 50.0, 340.0)])
    ring = shapely.get_coordinates(shapely.get_exterior_ring(river.geoms[0]))
    d = np.diff(ring, axis=0)
    mid = 0.5 * (ring[:-1] + ring[1:])
    n = np.stack([-d[:, 1], d[:, 0]], axis=1) / np.hypot(*d.T)[:, None]
    xy = np.vstack([rng.uniform([-20, -120], [2020, 360], (3000, 2)),
                    mid + 0.005 * n, mid - 0.005 * n,
                    np.stack([np.full(50, 1000.0), rng.uniform(-120, 120, 50)], axis=1)])
    want = shapely.contains_xy(river, xy[:, 0], xy[:, 1])
    got = _checks.contains_xy_tiled(river, xy)
    assert want.sum() > 1000 and (~want).sum() > 1000
    assert np.array_equal(got, want)


def test_a_free_island_near_a_bank_is_not_taken_for_the_bank():
    """A width read short across a free island near a bank (a water mask's skeleton measures
    it to the island) must not make the check take the island's ψ for the bank's: it looks
    for banks within 0.75-1.25 half-widths, and the island lies there, the bank beyond."""
    b = RiverNetworkBuilder()
    b.add_branch([(0.0, 0.0), (1000.0, 0.0)], 100.0, discharge_m2s=2.0)
    t = np.linspace(0.0, 2.0 * np.pi, 24, endpoint=False)
    b.add_island(np.c_[500.0 + 150.0 * np.cos(t), 32.0 + 6.0 * np.sin(t)])
    graph = b.build()
    # an axis 10 m off the middle, read 70 m wide along the island: the right bank 40 m away,
    # the island's near shore 36 m, the left bank 60 m (banks count from 26 to 45 m)
    line = np.array([(0.0, -10.0), (300.0, -10.0), (400.0, -10.0), (600.0, -10.0),
                     (700.0, -10.0), (1000.0, -10.0)])
    short = np.array([100.0, 100.0, 70.0, 70.0, 100.0, 100.0])
    assert graph_problems(graph, [(line, short, 2.0)]) == []
    assert graph_problems(graph, [(line, short, 3.0)])   # a wrong discharge is still found


def test_a_centimetre_step_back_along_a_bank_is_not_a_bank_on_the_wrong_side(confluence):
    """Overlays of nearly equal outlines (a river's strip drawn on to a lake's shore) leave
    a vertex a centimetre back along a bank: that step's direction is rounding, not a bank
    whose axis lies on its right (the dam scene's main river widened by 10 % was refused)."""
    graph, branches = confluence
    stepped = copy.deepcopy(graph)
    main, banks = _main_banks(stepped)
    c = stepped.curves[banks[0]]
    k = len(c.points) // 2
    t = (c.points[k + 1] - c.points[k]) / np.hypot(*(c.points[k + 1] - c.points[k]))
    left = np.array([-t[1], t[0]])
    # as measured there: 3 mm back along the bank and 14 mm to the water's side
    c.points = np.insert(c.points, k + 1, c.points[k] - 0.003 * t + 0.014 * left, axis=0)
    assert graph_problems(stepped, branches) == []
