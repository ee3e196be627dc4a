"""A hand-edited graph file with values no river has (input hardening): a zero-length axis or
bank (a self-loop, two nodes at one place), an axis wider than any river, coordinates far off
the Earth, an axis too narrow for the ψ lattice: each a GraphError naming the file and the
curve when the flow network is made (before, a silent zero flow, an OverflowError or an
error about a derived lattice spacing)."""
from __future__ import annotations

import pytest

from riverflow.hydro.flow_network import build_flow_network
from riverflow.hydro.graph import GraphError
from riverflow.hydro.io import load_graph
from tests.conftest import SHARED_DATA

TINY = SHARED_DATA / "tiny_channel.graph"


def edited(tmp_path, line: int, text: str):
    if not TINY.exists():
        pytest.skip(f"shared data absent: {TINY}")
    lines = TINY.read_text().splitlines()
    lines[line] = text
    path = tmp_path / "edited.graph"
    path.write_text("\n".join(lines) + "\n")
    return load_graph(path)


@pytest.mark.parametrize("line,text,words", [
    (9, "2 24.000 1 -1.000 -1 0 0 -1 -1 -1", r"curve 0 \(an axis, nodes 0->0\) has zero length"),
    (10, "2 24.000 2 100.000 0 2 2 0 -1 -1", r"curve 1 \(a bank, nodes 2->2\) has zero length"),
    (3, "0.000 0.000 1 0", r"curve 0 \(an axis, nodes 0->1\) has zero length"),
    (9, "2 1e30 1 -1.000 -1 0 1 -1 -1 -1", "width 1e\\+30 m, beyond"),
    (9, "2 1e300 1 -1.000 -1 0 1 -1 -1 -1", "width 1e\\+300 m, beyond"),
    (3, "1e30 0.000 1 0", "coordinate 1e\\+30 m from the origin"),
])
def test_a_graph_value_no_river_has_is_named(tmp_path, line, text, words):
    graph = edited(tmp_path, line, text)
    with pytest.raises(GraphError, match=words) as err:
        build_flow_network(graph, 5.0, 0.1)
    assert "edited.graph" in str(err.value)


def test_an_axis_too_narrow_for_the_lattice_names_the_curve(tmp_path, monkeypatch):
    from riverflow.hydro import flow_field
    from riverflow.hydro.flow_field import FlowField

    monkeypatch.setattr(flow_field, "compile_kernels", lambda *a: None)   # refused before use

    graph = edited(tmp_path, 9, "2 1e-30 1 -1.000 -1 0 1 -1 -1 -1")
    with pytest.raises(GraphError, match=r"narrowest axis \(curve 0, 1e-30 m wide\)"):
        FlowField(graph)


@pytest.mark.parametrize("width,words", [
    (1e30, "width at point 0 is 1e\\+30 m, outside"),
    (1e-30, "width at point 0 is 1e-30 m, outside"),
    (1e-3, "banks could not be made"),         # a GEOS TopologyException before
])
def test_branch_widths_no_river_has_are_graph_errors(width, words):
    from riverflow.hydro.builder import RiverNetworkBuilder

    builder = RiverNetworkBuilder(tolerance_m=0.25)
    with pytest.raises(GraphError, match=words):
        builder.add_branch([[0.0, 0.0], [100.0, 0.0]], width, 5.0, name="a")
        builder.add_branch([[100.0, 0.0], [200.0, 0.0]], 10.0, name="b")
        builder.build()
