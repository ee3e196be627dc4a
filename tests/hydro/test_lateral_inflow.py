"""RiverNetworkBuilder(lateral_inflow=True): a branch leaving a junction alone may carry more
than flows into it; the surplus enters through an inlet (a closing segment) cut into each bank
across from the junction, half on each side, and the flow carries the larger discharge."""
from __future__ import annotations

import numpy as np
import pytest

import riverflow as rf
from riverflow.hydro.graph import CurveType


def chain(lateral=True, discharges=(10.0, 14.0, 20.0)):
    b = rf.RiverNetworkBuilder(lateral_inflow=lateral)
    xs = [0.0, 300.0, 600.0, 900.0]
    for k, q in enumerate(discharges):
        line = [(xs[k], 0.0), (0.5 * (xs[k] + xs[k + 1]), 20.0 * (-1) ** k), (xs[k + 1], 0.0)]
        b.add_branch(line, 20.0, discharge_m2s=q, name=f"reach{k}")
    return b


def test_discharge_grows_downstream_through_inlets():
    b = chain()
    graph = b.build()
    assert rf.validate_graph(graph) == []
    assert b.discharges_m2s == [10.0, 14.0, 20.0]
    assert [s for _, s in b.inlets_m2s] == pytest.approx([4.0, 6.0])
    assert [p for p, _ in b.inlets_m2s] == [(300.0, 0.0), (600.0, 0.0)]
    closing = [c for c in graph.curves if c.type == CurveType.CLOSING_SEGMENT]
    assert len(closing) == 2 + 4               # two river ends, two inlets per junction
    field = rf.FlowField(graph)
    for k, x in enumerate((150.0, 450.0, 750.0)):
        y = 20.0 * (-1) ** k
        psi = field.potential(np.array([[x, y - 9.9], [x, y + 9.9]]))
        assert psi[0] - psi[1] == pytest.approx(b.discharges_m2s[k], rel=0.02)


def test_the_banks_share_the_surplus():
    graph = chain().build()
    left = sorted({c.potential for c in graph.curves if c.is_bank and
                   np.mean(graph.vertices(graph.curves.index(c))[:, 1]) > 0})
    right = sorted({c.potential for c in graph.curves if c.is_bank and
                    np.mean(graph.vertices(graph.curves.index(c))[:, 1]) < 0})
    # facing downstream (east) the left bank is north: ψ steps down by half of each surplus
    assert np.diff(left[::-1]) == pytest.approx([-2.0, -3.0])
    assert np.diff(right) == pytest.approx([2.0, 3.0])


def test_without_it_more_outflow_is_an_error():
    with pytest.raises(rf.GraphError, match="inflow 10 m²/s ≠ outflow 14 m²/s"):
        chain(lateral=False).build()


def test_water_never_vanishes():
    with pytest.raises(rf.GraphError, match="inflow 14 m²/s ≠ outflow 12 m²/s"):
        chain(discharges=(10.0, 14.0, 12.0)).build()
