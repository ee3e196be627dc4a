"""The flow-tile quadtree: levels, the bounded cache, determinism, bad options."""
from __future__ import annotations

import numpy as np
import numpy.testing as npt
import pytest

import riverflow as rf
from riverflow.hydro.graph import Curve, CurveType, GraphError, HydroGraph
from tests.flow.networks import bifurcation, confluence


def _water_points(field, rng, n):
    x0, y0, x1, y1 = field.graph.bounds()
    pts = rng.uniform((x0, y0), (x1, y1), (20 * n, 2))
    status, _ = field.query(pts)
    return pts[status == rf.FlowStatus.INSIDE][:n]


def test_every_level_carries_the_flow(rng):
    graph, _ = confluence()
    field = rf.FlowField(graph)
    assert field.max_level >= 2
    line = field.network.polylines[0]
    mid = line[len(line) // 2][None]
    speeds = []
    for level in range(field.max_level + 1):
        status, v = field.query(mid, level=level)
        if field.tiles.spacing_m(level) < 10.0:
            assert status[0] == rf.FlowStatus.INSIDE, level
            speeds.append(float(np.hypot(*v[0])))
    assert np.ptp(speeds) < 0.15 * np.mean(speeds)


def test_level_for_spacing_picks_coarser_tiles_for_coarser_needs():
    graph, _ = confluence()
    field = rf.FlowField(graph)
    fine = field.tiles.spacing_m(field.max_level)
    assert field.level_for_spacing(fine) == field.max_level
    assert field.level_for_spacing(fine * 4.0) == field.max_level - 2
    assert field.level_for_spacing(1e9) == 0
    assert field.level_for_spacing(fine / 100.0) == field.max_level
    assert field.tiles.spacing_m(field.level_for_spacing(7.0)) <= 7.0


def test_bounded_cache_gives_the_same_answers(rng):
    graph, _ = bifurcation()
    big = rf.FlowField(graph, cache_tiles=256)
    small = rf.FlowField(graph, cache_tiles=3)
    pts = _water_points(big, rng, 4000)
    s1, v1 = big.query(pts)
    s2, v2 = small.query(pts)
    npt.assert_array_equal(s1, s2)
    npt.assert_array_equal(v1, v2)
    npt.assert_array_equal(big.potential(pts), small.potential(pts))
    assert small.tiles.cached <= 3
    assert small.tiles.evicted > 0
    assert big.tiles.evicted == 0


def test_tiles_are_reproducible_and_cleared():
    graph, _ = confluence()
    field = rf.FlowField(graph)
    lv = field.max_level
    line = field.network.polylines[0]
    tx, ty = (int(v) for v in field.tile_of(line[len(line) // 2][None], lv)[0])
    field.ensure_tiles(lv, [(tx, ty)])
    slot = field.tiles.slot_of(lv, tx, ty)
    first = field.tiles.psi[slot].copy()
    field.clear_tiles()
    assert field.tiles.cached == 0
    assert field.ensure_tiles(lv, [(tx, ty)]) == 1
    assert field.ensure_tiles(lv, [(tx, ty)]) == 0
    npt.assert_array_equal(field.tiles.psi[field.tiles.slot_of(lv, tx, ty)], first)
    with pytest.raises(ValueError):
        field.ensure_tiles(lv, [(i, 0) for i in range(field.tiles.capacity + 1)])


def test_bad_networks_and_options_are_refused():
    nodes = [(0, 0), (100, 0), (0, -10), (100, -10)]
    no_psi = HydroGraph(nodes, [Curve(0, 1, width_m=24, type=CurveType.AXIS),
                                Curve(2, 3, width_m=24, type=CurveType.BANK, river=0)])
    with pytest.raises(GraphError, match="curve 1 has no potential"):
        rf.FlowField(no_psi)
    bad_link = HydroGraph(nodes, [Curve(0, 1, width_m=24, type=CurveType.AXIS),
                                  Curve(2, 3, width_m=24, type=CurveType.BANK, potential=1,
                                        river=1)])
    with pytest.raises(GraphError, match="links to curve 1"):
        rf.FlowField(bad_link)
    with pytest.raises(GraphError, match="no river axis"):
        rf.FlowField(HydroGraph(nodes, [Curve(2, 3, type=CurveType.BANK, potential=0)]))
    graph, _ = confluence()
    for kwargs in ({"slip": 0.0}, {"slip": float("nan")}, {"search_radius_factor": -1.0},
                   {"potential_delta_m": 0.0}, {"cache_tiles": 0}):
        with pytest.raises(ValueError):
            rf.FlowField(graph, **kwargs)
    with pytest.raises(ValueError):
        rf.FlowField(graph).query(np.zeros((1, 2)), level=99)


def test_dry_tiles_answer_outside_without_being_made():
    graph, _ = confluence()
    field = rf.FlowField(graph)
    x0, y0, x1, y1 = field.graph.bounds()
    far = np.array([[x0 - 0.4 * (x1 - x0) + 1.0, y1 + 0.3 * (y1 - y0)]])
    status, velocity = field.query(far)
    assert status[0] in (rf.FlowStatus.OUTSIDE, rf.FlowStatus.OUTSIDE_DOMAIN)
    assert np.all(velocity == 0)
    assert field.tiles.produced == 0


def test_the_finest_lattice_does_not_depend_on_the_domain_s_size(rng):
    """No fixed level limit: the same network in a 4 km and a 1000 km domain gets the same
    finest lattice (spacing ≤ the narrowest width / 24), the quadtree is deeper instead, and
    the flow there is the same."""
    graph, _ = confluence()
    x0, y0, x1, y1 = graph.bounds()
    small = rf.FlowField(graph, domain_m=(x0 - 1000.0, y0 - 1000.0, 4000.0))
    large = rf.FlowField(graph, domain_m=(x0 - 500_000.0, y0 - 500_000.0, 1_000_000.0))
    fine_small = small.tiles.spacing_m(small.max_level)
    fine_large = large.tiles.spacing_m(large.max_level)
    narrowest = min(graph.curves[a].width_m for a in graph.axes())
    assert fine_small <= narrowest / 24.0 and fine_large <= narrowest / 24.0
    assert 0.5 < fine_large / fine_small <= 2.0
    assert large.max_level - small.max_level >= 7               # 250× the side: ~8 levels more
    pts = _water_points(small, rng, 200)
    s_small, v_small = small.query(pts)
    s_large, v_large = large.query(pts)
    npt.assert_array_equal(s_small, s_large)
    speed = np.hypot(*v_small.T)
    assert np.abs(v_large - v_small).max() < 0.05 * speed.max()
