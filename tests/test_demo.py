"""The boat demo and the embedding example, as users run them: scripted headless runs
(deterministic), key actions, a host game's own esper world, and the real window under Xvfb."""
from __future__ import annotations

import importlib.util
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

import esper
import numpy as np
import pytest

from riverflow.components.display import DisplayMode
from riverflow.engine.config import RiverConfig
from riverflow.engine.controls import KeyScript
from riverflow.scenes.default import default_scene

REPO = Path(__file__).resolve().parents[1]
SCRIPT = KeyScript.from_text("""
    0   W  down
    100 D  down
    160 D  up
    170 _3 tap
    200 P  tap
""")


@pytest.fixture(scope="module")
def scene():
    return default_scene(seed=0)


@pytest.mark.gl
def test_same_seed_and_script_give_the_same_path_and_frames(scene, tmp_path):
    from PIL import Image

    from riverflow.demo import run_headless
    runs = [run_headless(240, tmp_path / f"run{k}", scene=scene, size=(160, 96), seed=3,
                         script=KeyScript(SCRIPT.events), every=80) for k in range(2)]
    a, b = runs
    assert np.array_equal(a.path, b.path)
    assert len(a.frames) == len(b.frames) == 4       # frames 0, 80, 160 and 239 (the last)
    for fa, fb in zip(a.frames, b.frames):
        assert np.array_equal(np.asarray(Image.open(fa)), np.asarray(Image.open(fb)))
    # the script did something: throttle moved the boat, the turn changed its heading
    assert np.hypot(*(a.path[-1, :2] - a.path[0, :2])) > 10.0
    assert a.path[160, 2] - a.path[99, 2] < -0.1     # D: rudder to starboard, clockwise
    assert a.animation is not None and a.animation.stat().st_size > 0


def test_keys_drive_the_boat_and_the_display(scene):
    from riverflow.demo import BoatDemo
    demo = BoatDemo(scene, (96, 64), seed=0, gl=False,
                    config=RiverConfig(tile_production="blocking"))
    try:
        script = KeyScript.from_text("""
            0 W down
            0 LEFT down
            1 _2 tap
            2 G tap
            3 SPACE tap
            4 EQUAL tap
            5 C tap
            6 ESCAPE tap
        """)
        for frame in range(8):
            script.feed(frame, demo.input)
            demo.step()
        display, world = demo.world.display, demo.world
        assert display.mode == DisplayMode.MESH and display.show_grid
        assert world.paused and world.speed_factor == pytest.approx(1.5)
        assert demo.camera_mode == "free" and demo.quit_requested
        boat = demo.boat_state
        assert boat.throttle == 0.0            # in free-camera mode the keys fly the camera
        demo.input.key_down("C")
        demo.step()
        demo.step()
        assert demo.camera_mode == "chase"
        assert boat.throttle == 1.0 and boat.rudder == 1.0   # W + LEFT: ahead, turn to port
    finally:
        demo.close()


def _load_embed():
    spec = importlib.util.spec_from_file_location("embed_example", REPO / "demos" / "embed.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module                 # dataclasses look their module up
    spec.loader.exec_module(module)
    return module


@pytest.mark.gl
def test_embed_runs_headless_and_leaves_the_host_entities_alone():
    from riverflow.components.particles import ParticlePool
    embed = _load_embed()
    esper.switch_world("default")
    game = embed.HostGame((128, 72), seed=0)
    try:
        start = game.entity(game.barrel, embed.Floating).position_m.copy()
        for _ in range(30):
            game.update(embed.STEP_S)
        score = game.entity(game.score, embed.Score)
        barrel = game.entity(game.barrel, embed.Floating)
        assert score.ticks == 30 and score.points == 0      # the host's own logic, once a frame
        assert not barrel.stranded and np.hypot(*(barrel.position_m - start)) > 0.2
        esper.switch_world(embed.HOST_WORLD)
        try:                                                  # the host world holds only its own
            assert len(esper.get_components(embed.Floating)) == 1
            assert esper.get_component(ParticlePool) == []
            kinds = {type(c).__name__ for e in (game.score, game.camera, game.barrel)
                     for c in esper.components_for_entity(e)}
        finally:
            esper.switch_world("default")
        assert kinds == {"Score", "Orbit", "Floating"}
        with game.rivers.active():                            # and the river world none of them
            assert esper.get_component(embed.Score) == []
        assert len(game.rivers.particles) > 0
        frame = game.rivers.render()
        assert frame.shape == (72, 128, 4)
    finally:
        game.close()


@pytest.mark.gl
def test_embed_command_line_runs_headless(tmp_path):
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY")}
    result = subprocess.run([sys.executable, str(REPO / "demos" / "embed.py"), "--headless",
                             "--frames", "5", "--seed", "1", "--out", str(tmp_path)], env=env,
                            capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stderr
    assert "5 frames; barrel at" in result.stdout
    assert (tmp_path / "embed.png").exists()


@pytest.fixture
def xvfb():
    """A virtual X display (Xvfb) for the windowed demo; skipped where Xvfb is missing."""
    binary = shutil.which("Xvfb")
    if binary is None:
        pytest.skip("Xvfb is not installed (apt-get install xvfb)")
    display = f":{90 + os.getpid() % 9}"
    proc = subprocess.Popen([binary, display, "-screen", "0", "640x480x24", "-nolisten", "tcp"],
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    time.sleep(1.0)
    if proc.poll() is not None:
        pytest.skip("Xvfb did not start")
    yield display
    proc.terminate()
    proc.wait(timeout=10)


def test_windowed_demo_starts_runs_and_quits_under_xvfb(xvfb, tmp_path):
    env = {k: v for k, v in os.environ.items() if k not in ("PYGLET_HEADLESS",
                                                             "WAYLAND_DISPLAY")}
    env["DISPLAY"] = xvfb
    result = subprocess.run([sys.executable, "-m", "riverflow", "demo", "--frames", "90",
                             "--size", "320x180"], env=env, cwd=tmp_path, capture_output=True,
                            text=True, timeout=300)
    assert result.returncode == 0, result.stderr[-3000:]
    assert "riverflow demo: 90 frames drawn" in result.stdout
    assert "no display" not in result.stdout
