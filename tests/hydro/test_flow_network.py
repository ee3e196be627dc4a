"""The flow network of a real-sized graph (riverflow.hydro.flow_network): its searches for
the axes near each end, cap and bank go through the axes' boxes, so a network of many
rivers costs what its neighbours do, not every pair (NHD's Shellmound: 998 links, 19.5 s
asking every pair of axes, 0.2 s), and the network is the one asking every pair makes."""
from __future__ import annotations

import numpy as np

from riverflow.hydro import flow_network
from riverflow.hydro.builder import RiverNetworkBuilder


def _many_rivers(n_side: int):
    """n_side² short rivers on a grid 400 m apart (separate networks), and one that ends
    within another's water (their components merge)."""
    b = RiverNetworkBuilder()
    for i in range(n_side):
        for j in range(n_side):
            x, y = 400.0 * i, 400.0 * j
            b.add_branch([(x, y), (x + 100.0, y + 30.0), (x + 200.0, y)], 20.0,
                         discharge_m2s=5.0, name=f"r{i}_{j}")
    return b.build()


def test_the_axes_near_each_end_are_asked_not_every_pair(monkeypatch):
    graph = _many_rivers(8)                                        # 64 axes
    calls = []
    real = flow_network._points_to_polyline
    monkeypatch.setattr(flow_network, "_points_to_polyline",
                        lambda pts, line: (calls.append(1), real(pts, line))[1])
    net = flow_network.build_flow_network(graph, 5.0, 0.05)
    axes = len(graph.axes())
    assert axes == 64 and len(calls) < 8 * axes        # every pair: 64² + 128 caps × 64
    assert len(set(net.curve_comp.tolist())) == 64      # each river its own network

    def every_pair(pt, axes_, poly, boxes):
        return min(axes_, key=lambda a: float(real(pt, poly[a])[0]))
    monkeypatch.setattr(flow_network, "_nearest_axis", every_pair)
    calls.clear()
    asked = flow_network.build_flow_network(graph, 5.0, 0.05)
    for name in ("curve_kind", "curve_comp", "curve_group", "seg_ax", "seg_by", "curve_cutoff"):
        assert np.array_equal(getattr(net, name), getattr(asked, name))


def test_nearest_axis_is_the_first_of_the_nearest_as_min_gives(rng):
    poly = {k: np.cumsum(rng.normal(size=(6, 2)) * 30.0, axis=0) + rng.uniform(-500, 500, 2)
            for k in range(40)}
    poly[7] = poly[3].copy()                                   # a tie: the first one wins
    axes = list(range(40))
    boxes = np.array([[*poly[a].min(axis=0), *poly[a].max(axis=0)] for a in axes])
    for pt in rng.uniform(-700, 700, (200, 2)).tolist() + [poly[3][2].tolist()]:
        pt = np.array([pt])
        want = min(axes, key=lambda a: float(flow_network._points_to_polyline(pt, poly[a])[0]))
        assert flow_network._nearest_axis(pt, axes, poly, boxes) == want
