"""The fixed-step loop, key scripts and camera rigs (no window needed)."""
from __future__ import annotations

import math

import numpy as np
import pytest

from riverflow.engine.camera import Camera
from riverflow.engine.camera_rigs import ChaseCamera, FreeFlyCamera
from riverflow.engine.controls import InputState, KeyScript
from riverflow.engine.game_loop import FixedStep


def test_fixed_step_accumulates_and_keeps_the_remainder():
    loop = FixedStep(0.01, max_substeps=10)
    assert loop.advance(0.025) == 2
    assert loop.accumulator_s == pytest.approx(0.005)
    assert loop.advance(0.006) == 1
    assert 0.0 <= loop.alpha < 1.0


def test_fixed_step_caps_substeps_after_a_hitch_and_drops_the_backlog():
    loop = FixedStep(1 / 60, max_substeps=4)
    assert loop.advance(2.0) == 4
    assert loop.accumulator_s == 0.0 and loop.dropped_s > 1.9
    assert loop.advance(1 / 60 + 1e-9) == 1


@pytest.mark.parametrize("bad", [float("nan"), float("inf"), -1.0])
def test_fixed_step_ignores_bad_elapsed_time(bad):
    loop = FixedStep()
    assert loop.advance(bad) == 0 and loop.accumulator_s == 0.0


def test_fixed_step_rejects_a_bad_step():
    with pytest.raises(ValueError, match="step_s"):
        FixedStep(0.0)


def test_key_script_holds_releases_and_taps():
    script = KeyScript.from_text("""
        # comment
        0 w down
        2 W up
        1 _3 tap
    """)
    state = InputState()
    seen = []
    for frame in range(4):
        script.feed(frame, state)
        seen.append((sorted(state.held), list(state.pressed)))
        state.end_frame()
    assert seen == [(["W"], ["W"]), (["W", "_3"], ["_3"]), ([], []), ([], [])]


def test_key_script_errors_name_the_line():
    with pytest.raises(ValueError, match=r"keys\.txt:2: expected 'FRAME KEY down\|up\|tap'"):
        KeyScript.from_text("0 W down\nten W up\n", "keys.txt")
    with pytest.raises(ValueError, match="kind"):
        KeyScript([(0, "W", "hold")])


def test_key_script_takes_keys_as_written_on_the_keyboard():
    script = KeyScript.from_text("0 3 tap\n1 _4 tap\n2 + tap\n3 - tap\n4 esc tap\n5 w down\n")
    assert [e.key for e in script.events] == ["_3", "_4", "PLUS", "MINUS", "ESCAPE", "W"]


def test_key_script_rejects_a_key_the_game_does_not_know_naming_the_line():
    keys = {"W", "_3"}
    assert [e.key for e in KeyScript.from_text("0 W down\n1 3 tap", keys=keys).events] == \
        ["W", "_3"]
    with pytest.raises(ValueError) as info:
        KeyScript.from_text("0 W down\n\n# now\n7 Z tap\n", "keys.txt", keys=keys)
    message = str(info.value)
    assert message.startswith("keys.txt:4: unknown key 'Z'") and "3" in message


def test_pressing_a_held_key_is_one_press():
    state = InputState()
    state.key_down("A")
    state.key_down("A")
    assert state.pressed == ["A"]


def test_chase_camera_settles_behind_and_above_the_target():
    camera = Camera(size_px=(64, 48))
    rig = ChaseCamera(distance_m=20.0, height_m=5.0, lead_m=0.0, rate_per_s=5.0)
    for _ in range(600):
        rig.update(camera, (100.0, 50.0, 2.0), math.pi / 2, 1 / 60)
    assert np.allclose(camera.position, (100.0, 30.0, 7.0), atol=1e-6)
    assert np.allclose(camera.target, (100.0, 50.0, 2.0), atol=1e-6)


def test_chase_camera_is_smooth():
    camera = Camera(size_px=(64, 48))
    rig = ChaseCamera(rate_per_s=3.0)
    rig.update(camera, (0.0, 0.0, 0.0), 0.0, 1 / 60)
    before = camera.position.copy()
    rig.update(camera, (50.0, 0.0, 0.0), 0.0, 1 / 60)   # the target jumps 50 m
    assert np.linalg.norm(camera.position - before) < 5.0


def test_free_fly_camera_moves_along_its_view_and_turns():
    camera = Camera(size_px=(64, 48))
    rig = FreeFlyCamera.from_view((0.0, 0.0, 10.0), (10.0, 0.0, 10.0))
    rig.move(1.0, 0.0, 0.0, 0.5)
    assert np.allclose(rig.position_m, (rig.speed_mps * 0.5, 0.0, 10.0))
    rig.turn(-100.0, 0.0)                     # mouse left → turn left (towards +y)
    rig.update(camera)
    assert camera.forward[1] > 0.3
    rig.turn(0.0, 1e6)
    assert rig.pitch_rad <= 1.5
