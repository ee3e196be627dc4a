"""FlowField and its queries, the builder's discharges, as_points."""
from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

import riverflow as rf
from riverflow._validate import ResourceLimitError, as_points
from riverflow.hydro.builder import RiverNetworkBuilder
from tests.fuzz.strategies import ANY_FLOAT, BAD, EXTREME, FUZZ, assert_names, bad_shapes

VALID = (rf.FlowStatus.INSIDE, rf.FlowStatus.OUTSIDE, rf.FlowStatus.OUTSIDE_DOMAIN)


@pytest.fixture(scope="module")
def graph():
    b = RiverNetworkBuilder()
    b.add_branch([(0, 0), (200, 30), (400, 0)], 40.0, discharge_m2s=40.0)
    return b.build()


@pytest.fixture(scope="module")
def field(graph):
    return rf.FlowField(graph)


@FUZZ
@given(shape=bad_shapes())
def test_query_refuses_every_shape_but_n_by_2(field, shape):
    xy = np.zeros(shape)
    for call in (field.query, field.potential, field.shore_distance):
        with pytest.raises(ValueError) as info:
            call(xy)
        assert_names(info, "xy", str(shape))


@FUZZ
@given(xy=hnp.arrays(np.float64, st.tuples(st.integers(1, 40), st.just(2)),
                     elements=st.floats(-1e6, 1e6)))
def test_query_answers_every_finite_point(field, xy):
    status, velocity = field.query(xy)
    psi = field.potential(xy)
    assert status.shape == (len(xy),) and velocity.shape == (len(xy), 2)
    assert np.isin(status, VALID).all() and np.isfinite(velocity).all()
    assert (np.isfinite(psi) == (status == rf.FlowStatus.INSIDE)).all()


@FUZZ
@given(xy=hnp.arrays(np.float64, st.tuples(st.integers(1, 20), st.just(2)), elements=ANY_FLOAT)
       .filter(lambda a: not np.isfinite(a).all()))
def test_non_finite_points_answer_outside_the_domain(field, xy):
    """A clear status, never an error: a bad value in a running world must not stop a frame
    (SPEC §5); as_points itself refuses them, naming the row, where finiteness is asked."""
    bad = ~np.isfinite(xy).all(axis=1)
    status, velocity = field.query(xy)
    assert (status[bad] == rf.FlowStatus.OUTSIDE_DOMAIN).all()
    assert (velocity[bad] == 0).all() and np.isnan(field.potential(xy)[bad]).all()
    row = int(np.flatnonzero(bad)[0])
    with pytest.raises(ValueError) as info:
        as_points(xy, "where")
    assert_names(info, "where", f"row {row}")


@FUZZ
@given(dtype=st.sampled_from([np.complex128, np.str_, object]))
def test_query_refuses_non_real_dtypes(field, dtype):
    xy = np.zeros((3, 2), dtype)
    with pytest.raises(TypeError) as info:
        field.query(xy)
    assert_names(info, "xy")


@FUZZ
@given(name=st.sampled_from(["slip", "search_radius_factor", "potential_delta_m",
                             "tolerance_m"]), value=BAD)
def test_flow_field_options_must_be_finite_and_positive(graph, name, value):
    args = {name: value}
    with pytest.raises(ValueError) as info:
        rf.FlowField(graph, **args)
    assert_names(info, name)


@FUZZ
@given(delta=st.floats(5e-324, 1e-9))
def test_lattice_spacings_finer_than_the_tree_are_refused(graph, delta):
    with pytest.raises(ValueError) as info:
        rf.FlowField(graph, potential_delta_m=delta)
    assert_names(info, "potential_delta_m", "level")


@FUZZ
@given(cells=st.integers(5000, 10**9))
def test_huge_lattices_are_refused_before_allocating(graph, cells):
    with pytest.raises(ResourceLimitError) as info:
        rf.FlowField(graph, lattice_cells=cells)
    assert isinstance(info.value, ValueError) and isinstance(info.value, MemoryError)
    assert_names(info, "lattice_cells", str(cells), "GiB")


@FUZZ
@given(cells=st.one_of(st.floats(4.5, 100).filter(lambda v: not v.is_integer()),
                       st.text(max_size=3), st.booleans()))
def test_lattice_cells_must_be_a_whole_number(graph, cells):
    with pytest.raises(TypeError) as info:
        rf.FlowField(graph, lattice_cells=cells)
    assert_names(info, "lattice_cells")


@FUZZ
@given(level=st.one_of(st.integers(-100, -1), st.integers(40, 10**6)))
def test_levels_out_of_the_tree_are_refused(field, level):
    with pytest.raises(ValueError) as info:
        field.query([(0.0, 0.0)], level=level)
    assert_names(info, "level", str(level))


@FUZZ
@given(q=st.one_of(BAD, st.floats(1e9, 1e308, exclude_min=True)))
def test_discharges_must_be_positive_and_plausible(q):
    b = RiverNetworkBuilder()
    with pytest.raises(rf.GraphError) as info:
        b.add_branch([(0, 0), (400, 0)], 40.0, discharge_m2s=q)
    assert_names(info, "discharge_m2s")


@FUZZ
@given(xy=st.one_of(st.lists(st.tuples(st.floats(-1e3, 1e3), st.floats(-1e3, 1e3)),
                             max_size=6),
                    st.tuples(st.floats(-1e3, 1e3), st.floats(-1e3, 1e3))))
def test_as_points_takes_pairs_and_one_point(xy):
    pts = as_points(xy, "where")
    assert pts.dtype == np.float64 and pts.flags.c_contiguous and pts.shape[1] == 2
    assert pts.shape[0] == (1 if isinstance(xy, tuple) else len(xy))


@FUZZ
@given(rows=st.lists(st.lists(st.floats(-1, 1), min_size=0, max_size=4), min_size=2,
                     max_size=4).filter(lambda r: len({len(x) for x in r}) > 1))
def test_as_points_refuses_ragged_lists(rows):
    with pytest.raises(ValueError) as info:
        as_points(rows, "where")
    assert_names(info, "where")


def test_nan_rows_pass_only_when_allowed():
    assert math.isnan(as_points([(math.nan, 1.0)], "p", allow_nan=True)[0, 0])
    with pytest.raises(ValueError, match="p must hold finite"):
        as_points([(math.inf, 1.0)], "p", allow_nan=True)
