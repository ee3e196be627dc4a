"""read_rivers' arguments (issue #30): checked before the file is opened, so no file is
needed; each bad value is a TypeError / ValueError naming the argument."""
from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import riverflow as rf
from riverflow.gis.rivers import HydraulicGeometry
from tests.fuzz.strategies import BAD, FUZZ, NON_FINITE, assert_names

POSITIVE_KEYS = ["width_m", "discharge_m2s", "discharge_m3s", "drainage_area_km2"]
VALUE_KEYS = [*POSITIVE_KEYS, "stream_order", "elevation_m"]
NOT_A_VALUE = st.one_of(st.booleans(), st.complex_numbers(max_magnitude=10, min_magnitude=1),
                        st.just(b"W"), st.just({"a": 1}), st.just(object()),
                        st.just(np.array([1.0, 2.0])), st.lists(st.integers(), min_size=1,
                                                                 max_size=3))


@FUZZ
@given(key=st.sampled_from(POSITIVE_KEYS), value=BAD)
def test_given_values_must_be_finite_and_positive(key, value):
    with pytest.raises(ValueError) as info:
        rf.read_rivers("no-such-file.geojson", **{key: value})
    assert_names(info, f"read_rivers: {key}")


@FUZZ
@given(key=st.sampled_from(VALUE_KEYS), value=NOT_A_VALUE)
def test_given_values_must_be_names_or_numbers(key, value):
    with pytest.raises(TypeError) as info:
        rf.read_rivers("no-such-file.geojson", **{key: value})
    assert_names(info, f"read_rivers: {key}")


@FUZZ
@given(order=st.one_of(NON_FINITE, st.floats(-1e300, 0.999)))
def test_stream_orders_start_at_one(order):
    with pytest.raises(ValueError) as info:
        rf.read_rivers("no-such-file.geojson", stream_order=order)
    assert_names(info, "read_rivers: stream_order")


@FUZZ
@given(elevation=NON_FINITE)
def test_elevations_may_be_negative_but_finite(elevation):
    with pytest.raises(ValueError) as info:
        rf.read_rivers("no-such-file.geojson", elevation_m=elevation)
    assert_names(info, "read_rivers: elevation_m")
    with pytest.raises(FileNotFoundError):           # −3 m below sea level: fine
        rf.read_rivers("no-such-file.geojson", elevation_m=-3.0)


@FUZZ
@given(name=st.sampled_from(["snap_m", "tolerance_m"]),
       value=st.one_of(NON_FINITE, st.floats(-1e300, -1e-300)))
def test_snap_and_tolerance(name, value):
    with pytest.raises(ValueError) as info:
        rf.read_rivers("no-such-file.geojson", **{name: value})
    assert_names(info, f"read_rivers: {name}")


@FUZZ
@given(name=st.sampled_from(["snap_m", "tolerance_m", "layer", "crs", "strict", "geometry",
                             "path"]),
       value=st.sampled_from([b"x", 1j, object(), [1, 2], 2.5]))
def test_argument_types(name, value):
    if name in ("snap_m", "tolerance_m") and value == 2.5:
        return                                           # a fine number
    kwargs = {"path": "no-such-file.geojson", name: value}
    with pytest.raises(TypeError) as info:
        rf.read_rivers(**kwargs)
    assert_names(info, f"read_rivers: {name}")


@FUZZ
@given(field=st.sampled_from(HydraulicGeometry._fields), value=BAD)
def test_hydraulic_geometry_constants(field, value):
    geometry = HydraulicGeometry()._replace(**{field: value})
    with pytest.raises(ValueError) as info:
        rf.read_rivers("no-such-file.geojson", geometry=geometry)
    assert_names(info, f"read_rivers: geometry.{field}")


def test_a_depth_exponent_of_one_or_more_is_refused():
    with pytest.raises(ValueError, match="geometry.depth_exponent must be < 1"):
        rf.read_rivers("no-such-file.geojson", geometry=HydraulicGeometry(depth_exponent=1.0))
    assert math.isfinite(HydraulicGeometry().volume(1.0))
