"""The boat demo and the embedding example, as users run them: scripted headless runs
(deterministic), key actions, a host game's own esper world, and the real window under Xvfb."""
from __future__ import annotations

import importlib.util
import os
import re
import subprocess
import sys
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
    170 3  tap
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
                         script=KeyScript(SCRIPT.events), every=80, hud=False)
            for k in range(2)]     # the HUD shows measured times: frames equal without it
    a, b = runs
    assert np.array_equal(a.path, b.path)
    assert len(a.frames) == len(b.frames) == 4       # frames 0, 80, 160 and 239 (the last)
    for fa, fb in zip(a.frames, b.frames):
        assert np.array_equal(np.asarray(Image.open(fa)), np.asarray(Image.open(fb)))
    # the script did something: throttle moved the boat, the turn changed its heading
    assert np.hypot(*(a.path[-1, :2] - a.path[0, :2])) > 10.0
    assert a.path[160, 2] - a.path[99, 2] < -0.1     # D: rudder to starboard, clockwise
    assert a.animation is not None and a.animation.stat().st_size > 0


@pytest.mark.gl
def test_headless_frames_carry_a_hud_with_fps_ms_and_the_legend(scene, tmp_path):
    from PIL import Image

    from riverflow.demo import run_headless
    script = KeyScript.from_text("0 3 tap")               # coverage: a legend with colours
    kwargs = dict(scene=scene, size=(320, 180), seed=0, every=10)
    bare = run_headless(2, tmp_path / "bare", script=KeyScript(script.events), hud=False,
                        **kwargs)
    run = run_headless(2, tmp_path / "hud", script=script, **kwargs)
    top = run.hud[0].split()
    assert top[1] == "fps" and top[3] == "ms" and float(top[0]) > 0 and float(top[2]) > 0
    assert "water coverage" in run.hud[1] and run.hud[2].startswith("simulation ")
    assert run.hud[3].startswith("draw ")
    with_hud = np.asarray(Image.open(run.frames[-1]), np.int16)
    without = np.asarray(Image.open(bare.frames[-1]), np.int16)
    changed = np.abs(with_hud - without).max(axis=2) > 0
    assert changed[:40, :100].mean() > 0.05                # the HUD, top left
    assert changed[-50:, :100].mean() > 0.05               # the legend, bottom left
    assert not changed[108:120, 200:].any()   # the picture between them is untouched (the HUD
    # wraps to 8 lines at 320 px: test_every_hud_line_fits_a_640_px_frame)


def test_every_hud_line_fits_a_640_px_frame():
    """The HUD of a real frame, with every system timed, is wrapped between its fields so
    that no line leaves a 640 px frame (nor a 320 px one); nothing of it is lost."""
    from PIL import Image, ImageDraw, ImageFont

    from riverflow.demo import BoatDemo, Hud, fit_lines
    demo = BoatDemo(None, (160, 90), gl=False)
    try:
        demo.step()
        demo.raining = True
        hud = Hud(fps=59.9, frame_ms=16.7, particles=12345,
                  timings_ms={**demo.world.timings_ms, "draw": 1.23})
        lines = hud.lines(demo)
    finally:
        demo.close()
    font = ImageFont.load_default(size=10)
    draw = ImageDraw.Draw(Image.new("RGBA", (8, 8)))
    measure = lambda t: draw.textlength(t, font=font)   # noqa: E731
    assert max(measure(t) for t in lines) > 624          # the system line did not fit
    for width in (624, 304):
        fitted = fit_lines(lines, width, measure)
        assert max(measure(t) for t in fitted) <= width
        assert " ".join(" ".join(fitted).split()) == " ".join(" ".join(lines).split())


def test_the_legend_names_every_colour_the_debug_shaders_draw():
    """The HUD's and README's legend (components.display) against the shaders' colours."""
    import re

    from riverflow.components.display import legend, settings_for
    from riverflow.components.status import FlowStatus

    shaders = REPO / "riverflow" / "shaders"

    def swatches(name):
        return {c for c, _ in legend(settings_for(name)) if c is not None}

    def rgb(text):
        return tuple(round(255 * float(v)) for v in text.split(","))

    particles = (shaders / "particles.glsl").read_text()
    drawn = {m[0]: rgb(m[1]) for m in re.findall(
        r"FLOW_STATUS_(\w+)\) c = vec3\(([^)]*)\)", particles)}
    drawn = {k: v * 3 if len(v) == 1 else v for k, v in drawn.items()}   # vec3(1.0)
    assert set(drawn) == {s.name for s in FlowStatus} - {"UNKNOWN"}
    assert set(drawn.values()) <= swatches("particles")
    arrows = (shaders / "arrows.glsl").read_text()
    ends = re.search(r"mix\(vec3\(([^)]*)\), vec3\(([^)]*)\)", arrows).groups()
    assert {rgb(e) for e in ends} <= swatches("velocities")
    water = (shaders / "water.glsl").read_text()
    assert "vec3(0.10, 0.35, 0.75)" in water and (26, 89, 191) in swatches("mesh")
    dark, white = re.search(r"DISPLAY_MODE_FOAM\).*?mix\(vec3\(([^)]*)\), vec3\(([^)]*)\)",
                            water, re.S).groups()
    assert {rgb(dark), rgb(white) * 3 if len(rgb(white)) == 1 else rgb(white)} \
        <= swatches("foam")
    coverage = [t for _, t in legend(settings_for("coverage"))]
    for word in ("red", "green", "blue", "magenta"):
        assert any(t.startswith(word) for t in coverage), word
    for name in ("none", "advected", "pre-advected", "non-advected", "grid", "foam"):
        assert legend(settings_for(name)), name


def test_keys_drive_the_boat_and_the_display(scene):
    from riverflow.demo import BoatDemo
    demo = BoatDemo(scene, (96, 64), seed=0, gl=False,
                    config=RiverConfig(tile_production="blocking"))
    try:
        script = KeyScript.from_text("""
            0 W down
            0 LEFT down
            1 2 tap
            2 G tap
            3 SPACE tap
            4 EQUAL tap
            5 C tap
            5 X tap
            6 ESCAPE tap
        """)
        for frame in range(8):
            script.feed(frame, demo.input)
            demo.step()
        display, world = demo.world.display, demo.world
        assert display.mode == DisplayMode.MESH and display.show_grid
        assert world.paused and world.speed_factor == pytest.approx(1.5)
        assert demo.camera_mode == "free" and demo.quit_requested
        assert demo.edit_mode                  # X: the mouse drags centre lines
        boat = demo.boat_state
        assert boat.throttle == 0.0            # in free-camera mode the keys fly the camera
        demo.input.key_down("C")
        demo.step()
        demo.step()
        assert demo.camera_mode == "chase"
        assert boat.throttle == 1.0 and boat.rudder == 1.0   # W + LEFT: ahead, turn to port
    finally:
        demo.close()


def test_key_m_turns_the_reflections_off_and_on(scene):
    from riverflow.demo import HELP, BoatDemo
    demo = BoatDemo(scene, (96, 64), seed=0, gl=False,
                    config=RiverConfig(tile_production="blocking"))
    try:
        assert demo.world.display.reflections               # on by default
        script = KeyScript.from_text("0 M tap\n2 M tap")
        seen = []
        for frame in range(4):
            script.feed(frame, demo.input)
            demo.step()
            seen.append(demo.world.display.reflections)
        assert seen == [False, False, True, True]
        assert "M reflections" in HELP
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
@pytest.mark.slow
def test_embed_command_line_runs_headless(tmp_path, capsys):
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY")}
    out = tmp_path / "shots" / "x.png"
    result = subprocess.run([sys.executable, str(REPO / "demos" / "embed.py"), "--headless",
                             "--frames", "5", "--seed", "1", "--out", str(out)], env=env,
                            capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stderr
    assert "5 frames; barrel at" in result.stdout and f"wrote {out}" in result.stdout
    assert out.is_file() and out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    with pytest.raises(SystemExit) as folder:     # its argument check, in this process
        _load_embed().main(["--headless", "--frames", "1", "--out", str(tmp_path)])
    assert folder.value.code == 2 and "takes a file name" in capsys.readouterr().err



@pytest.mark.slow
def test_windowed_demo_starts_runs_and_quits_under_xvfb(xvfb, tmp_path):
    env = {k: v for k, v in os.environ.items() if k not in ("PYGLET_HEADLESS",
                                                             "WAYLAND_DISPLAY")}
    env["DISPLAY"] = xvfb
    result = subprocess.run([sys.executable, "-m", "riverflow", "demo", "--frames", "10",
                             "--size", "320x180"], env=env, cwd=tmp_path, capture_output=True,
                            text=True, timeout=300)
    assert result.returncode == 0, result.stderr[-3000:]
    assert "riverflow demo: 10 frames drawn" in result.stdout
    assert "no display" not in result.stdout
    first = re.search(r"first frame drawn with (\d+) particles", result.stdout)
    assert first and int(first.group(1)) > 20       # not a frame of fog: its view was loaded
