"""RiverConfig, RiverWorld's size, scenes, props, flow maps, graph files, the memory limit."""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import riverflow as rf
from riverflow import _validate
from riverflow._validate import ResourceLimitError
from riverflow.components.props import SHAPES, Prop
from riverflow.engine.config import RiverConfig
from riverflow.hydro.builder import RiverNetworkBuilder
from tests.fuzz.strategies import BAD, FUZZ, NON_FINITE, assert_names

FLOAT_FIELDS = [f.name for f in dataclasses.fields(RiverConfig) if isinstance(f.default, float)]


@pytest.fixture(scope="module")
def field():
    b = RiverNetworkBuilder()
    b.add_branch([(0, 0), (200, 30), (400, 0)], 40.0, discharge_m2s=40.0)
    return rf.FlowField(b.build())


@FUZZ
@given(name=st.sampled_from(FLOAT_FIELDS), value=NON_FINITE)
def test_every_float_setting_must_be_finite(name, value):
    with pytest.raises(ValueError) as info:
        RiverConfig(**{name: value})
    assert_names(info, f"RiverConfig.{name}")


@FUZZ
@given(size=st.tuples(st.integers(-10**6, 0), st.integers(-10**6, 10**6))
       .flatmap(lambda s: st.sampled_from([s, s[::-1]]))
       | st.tuples(st.integers(2**15 + 1, 2**40), st.integers(1, 100)))
def test_world_sizes_must_be_positive_and_bounded(size):
    with pytest.raises(ValueError) as info:
        rf.RiverWorld(None, size=size)            # refused before the scene is looked at
    assert_names(info, "size", str(size))


@FUZZ
@given(size=st.one_of(st.tuples(st.floats(1.01, 100.0).filter(lambda v: not v.is_integer()),
                                st.integers(1, 100)),
                      st.text(max_size=4), st.integers(), st.none()))
def test_world_sizes_must_be_pairs_of_whole_pixels(size):
    with pytest.raises(TypeError) as info:
        rf.RiverWorld(None, size=size)
    assert_names(info, "size")


@FUZZ
@given(size_km=st.one_of(NON_FINITE, st.floats(-1e9, 0.499)))
def test_default_scene_sizes(size_km):
    with pytest.raises(ValueError) as info:
        rf.default_scene(seed=0, size_km=size_km)
    assert_names(info, "size_km")


@FUZZ
@given(size_km=st.floats(1e6, 1e300))
def test_huge_default_scenes_are_refused_up_front(size_km):
    with pytest.raises(ResourceLimitError) as info:
        rf.default_scene(seed=0, size_km=size_km)
    assert_names(info, "size_km", "GiB")


@FUZZ
@given(cell_m=st.floats(1e-300, 1e-6))
def test_tiny_landscape_cells_are_refused_up_front(field, cell_m):
    with pytest.raises(ResourceLimitError) as info:
        rf.landscape(field.graph, cell_m=cell_m)
    assert_names(info, "cell_m")


@FUZZ
@given(cell_m=BAD)
def test_landscape_cells_must_be_finite_and_positive(field, cell_m):
    with pytest.raises(ValueError) as info:
        rf.landscape(field.graph, cell_m=cell_m)
    assert_names(info, "cell_m")


@FUZZ
@given(shape=st.text(max_size=8).filter(lambda s: s not in SHAPES))
def test_unknown_prop_names_are_refused(shape):
    with pytest.raises(ValueError) as info:
        Prop(shape, (4.0, 2.0, 1.0))
    assert_names(info, "Prop.shape", repr(shape))


@FUZZ
@given(i=st.integers(0, 2), value=BAD)
def test_prop_sizes_must_be_finite_and_positive(i, value):
    size = [4.0, 2.0, 1.0]
    size[i] = value
    with pytest.raises(ValueError) as info:
        Prop("boat", tuple(size))
    assert_names(info, f"Prop.size_m[{i}]")


@FUZZ
@given(suffix=st.sampled_from([".jpg", ".jpeg", ".tif", ".gif", ".json", "", ".png.bak",
                               ".webp"]), bits=st.sampled_from([8, 16]))
def test_the_flow_map_extension_decides_the_format(field, tmp_path, suffix, bits):
    with pytest.raises(ValueError) as info:
        rf.bake_flow_map(field, (-20, -60, 420, 60), 4.0, tmp_path / f"map{suffix}", bits=bits)
    assert_names(info, f"map{suffix}", ".png")
    assert not any(tmp_path.iterdir())


@FUZZ
@given(name=st.sampled_from(["max_speed_mps", "max_distance_m"]), value=BAD)
def test_flow_map_scales_must_be_finite_and_positive(field, tmp_path, name, value):
    with pytest.raises(ValueError) as info:
        rf.bake_flow_map(field, (-20, -60, 420, 60), 4.0, tmp_path / "m.png", **{name: value})
    assert_names(info, name)


@FUZZ
@given(side=st.integers(5000, 16384))
def test_big_flow_maps_are_refused_under_a_small_limit(field, tmp_path, side):
    _validate.set_memory_limit(64 << 20)
    try:
        with pytest.raises(ResourceLimitError) as info:
            rf.bake_flow_map(field, (0, 0, side, side), 1.0, tmp_path / "m.png")
    finally:
        _validate.set_memory_limit(None)
    assert_names(info, f"{side}×{side}", "MiB")


@FUZZ
@given(data=st.binary(min_size=0, max_size=200))
def test_random_graph_files_are_graph_errors_naming_file_and_byte(tmp_path, data):
    path = tmp_path / "fuzz.graph"
    path.write_bytes(data)
    try:
        rf.load_graph(path)
    except rf.GraphError as exc:
        assert str(path) in str(exc) and "byte " in str(exc), str(exc)


@FUZZ
@given(tokens=st.lists(st.sampled_from(["0", "1", "2", "3", "5", "-1", "1e999", "nan", "x",
                                        "9" * 60, "0.5", "2147483648"]), max_size=40))
def test_random_ascii_graphs_are_graph_errors_naming_file_and_byte(tmp_path, tokens):
    path = tmp_path / "fuzz.graph"
    path.write_text("0 " + " ".join(tokens))
    try:
        rf.load_graph(path)
    except rf.GraphError as exc:
        assert str(path) in str(exc) and "byte " in str(exc), str(exc)


@FUZZ
@given(nbytes=st.one_of(NON_FINITE, st.floats(-1e9, 0.0), st.text(max_size=3)))
def test_the_memory_limit_must_be_a_positive_number(nbytes):
    with pytest.raises((ValueError, TypeError)) as info:
        _validate.set_memory_limit(nbytes)
    assert_names(info, "nbytes")
    assert _validate.memory_limit_bytes() > 0


def test_the_memory_limit_is_settable_and_defaults_to_half_the_machine(monkeypatch):
    default = _validate.memory_limit_bytes()
    assert default == int(0.5 * _validate._machine_bytes())
    _validate.set_memory_limit(1 << 20)
    try:
        with pytest.raises(ResourceLimitError, match="what=3"):
            _validate.check_allocation(2 << 20, "what=3")
        _validate.check_allocation(1 << 19, "fits")
    finally:
        _validate.set_memory_limit(None)
    monkeypatch.setenv("RIVERFLOW_MEMORY_LIMIT_MB", "2")
    assert _validate.memory_limit_bytes() == 2 << 20
    with pytest.raises(ResourceLimitError):
        _validate.check_allocation(math.nan, "nan bytes")
    assert np.isfinite(default)


@FUZZ
@given(thing=st.one_of(st.none(), st.integers(), st.text(max_size=3), st.lists(st.integers())))
def test_graph_entry_points_refuse_what_is_not_a_graph_or_a_path(tmp_path, field, thing):
    for call, name in ((lambda: rf.save_graph(thing, tmp_path / "g.graph"), "graph"),
                       (lambda: rf.validate_graph(thing), "graph"),
                       (lambda: rf.FlowField(thing), "graph")):
        with pytest.raises(TypeError) as info:
            call()
        assert_names(info, name)
    if not isinstance(thing, str):
        for call in (lambda: rf.load_graph(thing), lambda: rf.save_graph(field.graph, thing)):
            with pytest.raises(TypeError) as info:
                call()
            assert_names(info, "path")


@FUZZ
@given(region=st.one_of(
    st.tuples(NON_FINITE, st.just(0.0), st.just(10.0), st.just(10.0)),
    st.tuples(st.floats(0, 100), st.floats(0, 100)).map(lambda t: (t[0], t[1], t[0], t[1] + 1)),
    st.sampled_from([(0, 0, 10), (0, 0, 10, 10, 5), (), 5.0, (10.0, 0.0, 0.0, 10.0)])))
def test_bake_regions(field, tmp_path_factory, region):
    with pytest.raises(ValueError) as info:
        rf.bake_flow_map(field, region, 1.0, tmp_path_factory.mktemp("b") / "f.png")
    assert_names(info, "region_m")


@FUZZ
@given(region=st.sampled_from(["0,0,10,10", ("0", 0, 10, 10), (None, 0, 10, 10),
                               (0, 0, 10j, 10), (True, 0, 10, 10)]))
def test_bake_regions_of_numbers(field, tmp_path_factory, region):
    with pytest.raises(TypeError) as info:
        rf.bake_flow_map(field, region, 1.0, tmp_path_factory.mktemp("b") / "f.png")
    assert_names(info, "region_m")


@FUZZ
@given(cell=st.one_of(BAD, st.floats(5e-324, 1e-3), st.sampled_from(["1", True, [1.0]])),
       region=st.sampled_from([(0.0, 0.0, 100.0, 100.0), (-1e308, -1e308, 1e308, 1e308)]))
def test_bake_cells(field, tmp_path_factory, cell, region):
    out = tmp_path_factory.mktemp("b")
    kind = TypeError if not isinstance(cell, float) else ValueError
    with pytest.raises(kind) as info:
        rf.bake_flow_map(field, region, cell, out / "f.png")
    assert_names(info, "cell_m")
    assert list(out.iterdir()) == []                   # nothing written


# -- the world's calls: a wrong value of any kind is an error naming the call ------------------

HUGE = 10 ** 400                      # an int past float's range
WRONG = [float("nan"), float("inf"), -1.0, "abc", None, [1, 2], HUGE, object()]


@pytest.fixture(scope="module")
def small_world():
    b = RiverNetworkBuilder()
    b.add_branch([(0, 0), (200, 30), (400, 0)], 40.0, discharge_m2s=40.0)
    world = rf.RiverWorld(rf.landscape(b.build()), size=(16, 16))
    yield world
    world.close()


def _calls(world):
    return {
        "speed_factor": lambda v: setattr(world, "speed_factor", v),
        "set_rain: drops_per_s": lambda v: world.set_rain(v),
        "set_rain: variance": lambda v: world.set_rain(1.0, v),
        "configure_spills: dt_s": lambda v: world.configure_spills(dt_s=v),
        "configure_spills: dispersion": lambda v: world.configure_spills(v),
        "add_spill: mass_kg": lambda v: world.add_spill((200.0, 20.0), v),
        "add_spill: xy_m": lambda v: world.add_spill(v, 1.0),
        "advance_spills": lambda v: world.advance_spills(v),
        "advance_flood": lambda v: world.advance_flood(v),
        "set_hydrograph": lambda v: world.set_hydrograph(None, [0.0, v], [1.0, 2.0]),
        "add_boat": lambda v: world.add_boat((200.0, 20.0), v),
        "water_level": lambda v: world.water_level([[v, 0.0]]),
        "pose": lambda v: world.pose(v),
        "boat": lambda v: world.boat(v),
        "wake": lambda v: world.wake(v),
        "spill": lambda v: world.spill(v),
        "RiverWorld: seed": lambda v: rf.RiverWorld(world.scene, size=(8, 8), seed=v),
        "landscape: seed": lambda v: rf.landscape(world.scene.graph, seed=v),
        "KeyScript.from_text": lambda v: rf.KeyScript.from_text(v if v != "abc" else "1 W"),
        "RiverConfig.radius_px": lambda v: RiverConfig(radius_px=v),
        "branch 'b'": lambda v: RiverNetworkBuilder().add_branch([(0, 0), (v, 0)], 5.0, name="b"),
    }


CALLS = list(_calls(None))
VALID = {"speed_factor": [HUGE], "RiverWorld: seed": [HUGE], "landscape: seed": [HUGE],
         "add_boat": [-1.0], "water_level": [-1.0], "branch 'b'": [-1.0],
         "configure_spills: dt_s": [None], "configure_spills: dispersion": [None],
         "add_spill: xy_m": [[1, 2]], "set_hydrograph": [-1.0]}
"""What each call takes among the wrong values (a huge seed, a negative heading or
coordinate, None for a default, [1, 2] for a point, a hydrograph time before now)."""


@pytest.mark.parametrize("call", CALLS)
def test_wrong_values_are_errors_naming_the_call(small_world, call):
    """NaN, ±inf, a negative, text, None, a list, an int past float's range, an object: each
    a ValueError, TypeError or (entities) KeyError whose message names the call (a key
    script's: its source and line), never a library's error (an OverflowError,
    AttributeError, numba's TypingError) — and the world still steps after it."""
    make = _calls(small_world)[call]
    named = "<script>" if call == "KeyScript.from_text" else call.split(":")[0]
    for value in WRONG:
        if any(value is v or (type(value) is type(v) and value == v)
               for v in VALID.get(call, ())):
            continue
        with pytest.raises((ValueError, TypeError, KeyError)) as info:
            make(value)
        assert named in str(info.value) or call in str(info.value), (value, info.value)
        small_world.step(1 / 60)
