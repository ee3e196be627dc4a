"""Camera.look_at, RiverWorld.step(dt_s) and RiverWorld.load_view(timeout_s) (issue #30): a
bad argument is a TypeError / ValueError naming it, and the camera is unchanged. (step's
NaN / inf / negative dt_s still clamp: tests/engine/test_world.py,
test_bad_frames_never_crash_or_leave_nan.)"""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import riverflow as rf
from riverflow.engine.camera import Camera
from tests.fuzz.strategies import FUZZ, NON_FINITE, assert_names

ARGS = ["eye_xyz", "target_xyz", "up"]
GOOD = {"eye_xyz": (0.0, -10.0, 5.0), "target_xyz": (0.0, 0.0, 0.0), "up": (0.0, 0.0, 1.0)}


def state(camera):
    return (camera.position.tolist(), camera.target.tolist(), camera.up.tolist(),
            camera.revision, camera.view_matrix().tolist())


@pytest.fixture(scope="module")
def camera():
    c = Camera(size_px=(64, 48))
    c.look_at(**GOOD)
    return c


def three_with_a_bad_one():
    return st.tuples(st.integers(0, 2), NON_FINITE).map(
        lambda t: tuple(t[1] if i == t[0] else 1.0 + i for i in range(3)))


BAD_SHAPES = st.sampled_from([(), (2,), (4,), (1, 3), (3, 1), (3, 3), (0,), (1, 1, 3)]).map(
    lambda s: np.ones(s))


@FUZZ
@given(name=st.sampled_from(ARGS), value=st.one_of(three_with_a_bad_one(), BAD_SHAPES,
                                                   st.just([1.0, [2.0, 3.0], 4.0])))
def test_look_at_refuses_nan_and_wrong_shapes(camera, name, value):
    before = state(camera)
    with pytest.raises(ValueError) as info:
        camera.look_at(**{**GOOD, name: value})
    assert_names(info, f"look_at: {name}")
    assert state(camera) == before


@FUZZ
@given(name=st.sampled_from(ARGS),
       value=st.sampled_from(["abc", b"xyz", (1.0, "2", 3.0), (1j, 0, 0), (True, False, True),
                              None, object(), np.array([None, 1, 2], dtype=object)]))
def test_look_at_refuses_what_is_not_numbers(camera, name, value):
    before = state(camera)
    with pytest.raises(TypeError) as info:
        camera.look_at(**{**GOOD, name: value})
    assert_names(info, f"look_at: {name}")
    assert state(camera) == before


def test_look_at_takes_what_it_should(camera):
    camera.look_at([0, -20, 5], np.zeros(3, np.float32), np.array([0, 0, 2]))
    assert camera.position.tolist() == [0.0, -20.0, 5.0]
    camera.look_at(**GOOD)


@FUZZ
@given(dt=st.sampled_from(["1/60", None, [0.016], np.array([0.016]), True, 1j, object()]))
def test_step_needs_a_number(dt):
    world = object.__new__(rf.RiverWorld)            # the check comes first: no scene needed
    with pytest.raises(TypeError) as info:
        world.step(dt)
    assert_names(info, "step: dt_s")


@FUZZ
@given(timeout=st.one_of(st.sampled_from(["10", None, True, [1.0]]),
                         st.floats(-1e300, -1e-300), st.just(float("nan"))))
def test_load_view_timeout(timeout):
    world = object.__new__(rf.RiverWorld)
    with pytest.raises((TypeError, ValueError)) as info:
        world.load_view(timeout)
    assert info.type is (ValueError if isinstance(timeout, float) else TypeError)
    assert_names(info, "load_view: timeout_s")
