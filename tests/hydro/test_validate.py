"""Tests of riverflow.hydro.validate: clean networks give no issue, each broken rule is reported
on the right curve id (reference §1.2 rules, §1.7 facts of Proland's example)."""
from __future__ import annotations

import numpy as np
import pytest
from shapely.geometry import LineString

from riverflow.hydro.graph import NO_CURVE, NO_POTENTIAL, Area, Curve, CurveType, GraphError, HydroGraph
from riverflow.hydro.io import load_graph
from riverflow.hydro.validate import (ValidationIssue, _left_fraction, _signed_area, check_graph,
                                      validate_graph)

BANK, CLOSING = CurveType.BANK, CurveType.CLOSING_SEGMENT


def channel(width: float = 24.0) -> HydroGraph:
    """Straight channel along +x, banks at y = ±10 (the right one split at x = 50), axis 0.

    curves: 0 axis, 1-2 right bank (ψ 100), 3 downstream closing, 4 left bank (ψ 0),
    5 upstream closing; area 0 = 1, 2, 3, 4, 5."""
    nodes = np.array([(0, 0), (100, 0), (0, -10), (50, -10), (100, -10), (100, 10), (0, 10)], float)
    curves = [
        Curve(0, 1, [(50, 0)], [False], width, CLOSING),
        Curve(2, 3, [(25, -10)], [False], width, BANK, 100.0, 0),
        Curve(3, 4, [(75, -10)], [False], width, BANK, 100.0, 0),
        Curve(4, 5, width_m=0.0, type=CLOSING),
        Curve(5, 6, [(50, 10)], [False], width, BANK, 0.0, 0),
        Curve(6, 2, width_m=0.0, type=CLOSING),
    ]
    return HydroGraph(nodes, curves, [Area([(i, 0) for i in range(1, 6)])])


def with_island(g: HydroGraph, clockwise: bool = True, river: int = NO_CURVE) -> HydroGraph:
    """Add curve 6: a closed bank loop (ψ 50) around (50, 0), radius 3, and its area."""
    g.nodes = np.vstack([g.nodes, [53.0, 0.0]])
    ang = np.linspace(0, 2 * np.pi, 9)[1:-1] * (-1 if clockwise else 1)
    pts = np.c_[50 + 3 * np.cos(ang), 3 * np.sin(ang)]
    g.curves.append(Curve(7, 7, pts, np.zeros(len(pts), bool), 0.0, BANK, 50.0, river))
    g.areas.append(Area([(6, 0)]))
    return g


def reverse(g: HydroGraph, i: int) -> None:
    """Reverse curve i in place and flip its orientation in the areas (loops stay continuous)."""
    c = g.curves[i]
    c.start, c.end = c.end, c.start
    c.points, c.is_control = c.points[::-1].copy(), c.is_control[::-1].copy()
    for a in g.areas:
        a.curves = [(k, 1 - o if k == i else o) for k, o in a.curves]


def kinds(issues: list[ValidationIssue]) -> dict[str, set]:
    out: dict[str, set] = {}
    for i in issues:
        out.setdefault(i.kind, set()).add(i.curve)
    return out


# -- clean graphs -----------------------------------------------------------------------------

def test_clean_graphs():
    assert validate_graph(channel()) == []
    assert validate_graph(with_island(channel())) == []
    assert validate_graph(with_island(channel(), river=0)) == []
    check_graph(channel())


def test_tiny_channel_is_clean(tiny_channel_path):
    assert validate_graph(load_graph(tiny_channel_path)) == []


def test_proland_example_is_clean(proland_graph_path):
    """§1.7: valid, except that the island (curve 9) is unlinked, which is allowed."""
    g = load_graph(proland_graph_path)
    assert g.curves[9].river == NO_CURVE
    assert validate_graph(g) == []


def test_proland_example_facts(proland_graph_path):
    """Reference §1.2 rule 4 / §1.7: water on the left of all 10 linked banks (each axis
    midpoint 11-22 m on their left), island and both area loops clockwise."""
    g = load_graph(proland_graph_path)
    linked = [b for b in g.banks() if g.curves[b].river != NO_CURVE]
    assert len(linked) == 10
    for b in linked:
        bank, axis = g.polyline(b), g.polyline(g.curves[b].river)
        assert _left_fraction(bank, axis) == 1.0
        mid = LineString(axis).interpolate(0.5, normalized=True)
        line = LineString(bank)
        assert 11 <= line.distance(mid) <= 22
        s = line.project(mid)
        a, c = np.array(line.interpolate(s - 0.01).coords[0]), np.array(line.interpolate(s + 0.01).coords[0])
        d, r = c - a, np.array(mid.coords[0]) - a
        assert d[0] * r[1] - d[1] * r[0] > 0  # on the left
    assert _signed_area(g.polyline(9)[:-1]) == pytest.approx(-915, abs=1)
    signed = []
    for area in g.areas:
        ring = [g.polyline(c)[::-1 if o else 1][:-1] for c, o in area.curves]
        signed.append(_signed_area(np.vstack(ring)))
    assert signed[0] == pytest.approx(-50222, rel=5e-3) and signed[1] == pytest.approx(-915, abs=1)


@pytest.mark.parametrize("curve", [9, *range(10, 20)])
def test_proland_reversed_bank_is_reported(curve, proland_graph_path):
    g = load_graph(proland_graph_path)
    reverse(g, curve)
    assert kinds(validate_graph(g)) == {"wrong-side": {curve}}


# -- each broken rule on the right curve ------------------------------------------------------

def test_reversed_bank():
    g = channel()
    reverse(g, 4)
    issues = validate_graph(g)
    assert kinds(issues) == {"wrong-side": {4}}
    assert "axis 0" in issues[0].message


def test_counter_clockwise_island():
    for river in (NO_CURVE, 0):
        assert kinds(validate_graph(with_island(channel(), clockwise=False, river=river))) == \
            {"wrong-side": {6}}


def test_crossing_banks():
    g = channel()
    g.curves[4].points = np.array([[50.0, -20.0]])
    found = kinds(validate_graph(g))
    assert found["crossing"] == {1, 2, 4}


def test_self_crossing_bank():
    g = channel()
    g.curves[4].points = np.array([[40.0, 8.0], [60.0, 4.0], [55.0, 9.0], [45.0, 2.0]])
    g.curves[4].is_control = np.zeros(4, bool)
    assert kinds(validate_graph(g)) == {"crossing": {4}}


def test_banks_touching_only_at_shared_nodes_do_not_cross():
    g = channel()
    g.curves[2].points = np.array([[50.0, -9.0], [75.0, -10.0]])  # leaves node 3 along bank 1's line
    g.curves[2].is_control = np.zeros(2, bool)
    assert validate_graph(g) == []


def test_potential_mismatch_at_node():
    g = channel()
    g.curves[2].potential = 90.0
    issues = validate_graph(g)
    assert kinds(issues) == {"potential-mismatch": {1, 2}}
    msg = next(i.message for i in issues if i.curve == 2)
    assert "node 3" in msg and "90" in msg


def test_potential_mismatch_names_the_odd_one():
    """Three banks at a node: the one that differs from the other two is reported."""
    g = channel()
    g.nodes = np.vstack([g.nodes, [50.0, -5.0]])
    g.curves.append(Curve(3, 7, width_m=24.0, type=BANK, potential=77.0, river=0))
    assert kinds(validate_graph(g)).get("potential-mismatch") == {6}


def test_axis_too_narrow():
    issues = validate_graph(channel(width=16.0))
    assert kinds(issues) == {"narrow-axis": {0}}
    assert {b for b in (1, 2, 4) if any(f"bank {b}:" in i.message for i in issues)} == {1, 2, 4}
    assert validate_graph(channel(width=19.5), tolerance_m=0.5) == []
    assert kinds(validate_graph(channel(width=19.5), tolerance_m=0.1)) == {"narrow-axis": {0}}


def test_bank_without_potential():
    g = channel()
    g.curves[4].potential = NO_POTENTIAL
    assert kinds(validate_graph(g)) == {"no-potential": {4}}
    g.curves[4].potential = float("nan")
    assert kinds(validate_graph(g)) == {"non-finite": {4}}


@pytest.mark.parametrize("river", [1, 3, 4, 17, -5])
def test_bad_river_link(river):
    g = channel()
    g.curves[4].river = river
    assert kinds(validate_graph(g)).get("bad-river") == {4}


def test_unlinked_banks():
    g = channel()
    g.curves[4].river = NO_CURVE  # covered by axis 0: its side is still checked
    assert validate_graph(g) == []
    reverse(g, 4)
    assert kinds(validate_graph(g)) == {"wrong-side": {4}}
    g = channel()
    g.curves[4].river = NO_CURVE
    g.curves[4].points = np.array([[50.0, 40.0]])  # far from every axis
    assert kinds(validate_graph(g))["unlinked-bank"] == {4}


def test_area_not_continuous():
    g = channel()
    g.areas[0].curves.remove((3, 0))
    issues = validate_graph(g)
    assert kinds(issues) == {"area-gap": {2}}
    assert "area 0" in issues[0].message
    g.areas[0].curves.append((42, 0))
    assert None in kinds(validate_graph(g))["area-gap"]


def test_broken_geometry_does_not_crash():
    g = channel()
    g.nodes[6] = [np.nan, 10.0]
    found = kinds(validate_graph(g))
    assert found["non-finite"] == {None, 4, 5}
    g = channel()
    g.curves[4].end = 99
    assert kinds(validate_graph(g))["bad-node"] == {4}
    g = channel()
    g.curves[4].points = np.array([[75.0, 10.0], [50.0, 10.0], [25.0, 10.0]])
    g.curves[4].is_control = np.ones(3, bool)
    assert kinds(validate_graph(g))["bad-curve"] == {4}


def test_subgraph_issues_are_prefixed():
    g = channel()
    bad = channel()
    bad.curves[1].potential = NO_POTENTIAL
    g.areas[0].subgraph = bad
    (issue,) = validate_graph(g)
    assert issue.curve == 1 and issue.kind == "no-potential" and issue.message.startswith("area 0 subgraph")


def test_check_graph_lists_all_issues():
    g = channel()
    g.source = "demo.graph"
    g.curves[4].potential = NO_POTENTIAL
    g.curves[1].river = 3
    with pytest.raises(GraphError) as info:
        check_graph(g)
    msg = str(info.value)
    assert msg.startswith("demo.graph: 2 ") and "curve 4: [no-potential]" in msg
    assert "curve 1: [bad-river]" in msg
    assert isinstance(info.value, ValueError)


def test_issue_is_frozen():
    issue = ValidationIssue(3, "wrong-side", "m")
    with pytest.raises(AttributeError):
        issue.curve = 4  # type: ignore[misc]
    assert str(issue) == "curve 3: [wrong-side] m"
