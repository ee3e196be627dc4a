"""Graph files with the defects a hand edit or a broken export leaves: a number replaced by an
extreme one (1e308, a denormal, NaN), a file cut short, a line lost or doubled. Loading the
file and making its flow field either works or raises GraphError / ValueError / OSError, and
no number overflows on the way (a control point at 1e308 overflowed the Bézier flattening
before the coordinates' limit was checked; a denormal segment overflowed the wet-tile rows)."""
from __future__ import annotations

import warnings

import pytest
from hypothesis import given
from hypothesis import strategies as st

import riverflow as rf
from riverflow.hydro.builder import RiverNetworkBuilder
from riverflow.hydro.io import load_graph, save_graph
from tests.fuzz.strategies import FUZZ

EXTREMES = [b"1e308", b"-1e308", b"1e-320", b"nan", b"inf", b"-1", b"0", b"-0",
            b"99999999999", b"abc", b""]


@pytest.fixture(scope="module")
def text(tmp_path_factory) -> bytes:
    b = RiverNetworkBuilder()
    b.add_branch([(0, 0), (120, 25), (240, 0)], 30.0, discharge_m2s=20.0)
    b.add_branch([(240, 0), (300, 80)], 20.0)
    b.add_branch([(240, 0), (360, -20)], 20.0)
    path = tmp_path_factory.mktemp("graph") / "g.graph"
    save_graph(b.build(), path)
    return path.read_bytes()


def _opens_or_says_why(path) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        try:
            rf.FlowField(load_graph(path))
        except (rf.GraphError, ValueError, OSError):
            pass


@FUZZ
@given(at=st.integers(0, 10_000), value=st.sampled_from(EXTREMES))
def test_a_number_replaced_by_an_extreme_one(text, tmp_path, at, value):
    tokens = text.split(b" ")
    tokens[at % len(tokens)] = value
    (tmp_path / "m.graph").write_bytes(b" ".join(tokens))
    _opens_or_says_why(tmp_path / "m.graph")


@FUZZ
@given(at=st.integers(0, 10_000), how=st.sampled_from(["cut", "lose", "double"]))
def test_a_file_cut_short_or_a_line_lost_or_doubled(text, tmp_path, at, how):
    lines = text.split(b"\n")
    k = at % len(lines)
    if how == "cut":
        data = text[:at % len(text)]
    elif how == "lose":
        data = b"\n".join(lines[:k] + lines[k + 1:])
    else:
        data = b"\n".join(lines[:k + 1] + lines[k:])
    (tmp_path / "m.graph").write_bytes(data)
    _opens_or_says_why(tmp_path / "m.graph")


def test_a_control_point_far_beyond_any_map_is_named(text, tmp_path):
    # the main axis's middle vertex (120, 25) made a Bézier control point at x = 1e308
    assert text.count(b" 120.0 25.0 0 ") == 1
    (tmp_path / "far.graph").write_bytes(text.replace(b" 120.0 25.0 0 ", b" 1e308 25.0 1 "))
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        with pytest.raises(rf.GraphError, match=r"coordinate 1e\+308 m from the origin"):
            rf.FlowField(load_graph(tmp_path / "far.graph"))
