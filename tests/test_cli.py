"""The command line (SPEC §7) and the import rules it relies on: help without a display or
pyglet, a real flow picture, an offscreen render, and kernels that import neither pyglet nor
esper."""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

SUBCOMMANDS = ["flowmap", "demo", "render", "profile"]
PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
RENDER_ARGS = ["--size", "64x48", "--frames", "2", "--mode", "advected"]
PROFILE_ARGS = ["--size", "64x48", "--radius-px", "10", "--frames", "2"]


def run_cli(*args: str, cwd: Path | None = None, timeout: float = 300.0,
            ) -> subprocess.CompletedProcess:
    """``python -m riverflow ARGS`` with no display, headless pyglet, captured output."""
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY")}
    env["PYGLET_HEADLESS"] = "1"
    env["MPLBACKEND"] = "Agg"
    return subprocess.run([sys.executable, "-m", "riverflow", *args], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=timeout)


def cli(*args: str, cwd: Path | None = None) -> subprocess.CompletedProcess:
    """``riverflow ARGS`` run by the command's own ``main()`` in this process, answered as
    :func:`run_cli` answers (exit status, stdout, stderr): the same code path without a new
    interpreter that loads every kernel and makes a GL context again (~3 s of CPU a call).
    What only a new process shows (imports, the console script, no display) uses run_cli."""
    import contextlib
    import io

    from riverflow.__main__ import main

    out, err = io.StringIO(), io.StringIO()
    here = os.getcwd()
    try:
        if cwd is not None:
            os.chdir(cwd)
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            try:
                code = main(list(args))
            except SystemExit as exc:             # argparse: usage errors and --help
                code = exc.code if isinstance(exc.code, int) else 1
    finally:
        os.chdir(here)
    return subprocess.CompletedProcess(["riverflow", *args], code, out.getvalue(),
                                       err.getvalue())


def run_python(code: str) -> subprocess.CompletedProcess:
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY")}
    env["PYGLET_HEADLESS"] = "1"
    return subprocess.run([sys.executable, "-c", code], env=env, capture_output=True,
                          text=True, timeout=300)


# -- help ------------------------------------------------------------------------------------


@pytest.mark.parametrize("sub", [None, *SUBCOMMANDS])
def test_help_works_without_a_display(sub):
    result = run_cli(*([sub] if sub else []), "--help")
    assert result.returncode == 0, result.stderr
    assert result.stdout.startswith("usage: riverflow"), result.stdout
    for name in SUBCOMMANDS if sub is None else []:
        assert name in result.stdout


def test_help_of_every_subcommand_imports_no_pyglet():
    code = (
        "import sys\n"
        "from riverflow.__main__ import main\n"
        f"for sub in {SUBCOMMANDS!r}:\n"
        "    try:\n"
        "        main([sub, '--help'])\n"
        "    except SystemExit as exc:\n"
        "        assert exc.code == 0, (sub, exc.code)\n"
        "bad = {'pyglet', 'esper', 'matplotlib', 'numba'} & set(sys.modules)\n"
        "assert not bad, bad\n"
    )
    result = run_python(code)
    assert result.returncode == 0, result.stderr


def test_help_texts_are_current():
    for sub in [None, *SUBCOMMANDS]:
        out = cli(*([sub] if sub else []), "--help").stdout
        assert "in progress" not in out and "not yet" not in out, (sub, out)


def test_render_and_profile_have_defaults_for_every_option():
    from riverflow.__main__ import _parser

    render = _parser().parse_args(["render"])
    assert (render.size, render.frames, render.mode, render.out) == \
        ((1280, 720), 240, "advected", Path("out/render.png"))
    assert render.reflections and not _parser().parse_args(["render", "--no-reflections"]
                                                           ).reflections
    profile = _parser().parse_args(["profile"])
    assert (profile.size, profile.radius_px, profile.frames) == ((1920, 1080), 10.0, 300)


def test_render_help_lists_the_display_modes():
    from riverflow.__main__ import DISPLAY_MODES

    out = run_cli("render", "--help").stdout
    for mode in DISPLAY_MODES:
        assert mode in out


def test_console_script_is_installed():
    script = Path(sys.executable).with_name("riverflow")
    if not script.exists():
        pytest.skip(f"no console script beside {sys.executable}")
    env = {k: v for k, v in os.environ.items() if k != "DISPLAY"}
    result = subprocess.run([str(script), "--help"], env=env, capture_output=True, text=True,
                            timeout=120)
    assert result.returncode == 0, result.stderr
    assert "flowmap" in result.stdout


# -- commands ----------------------------------------------------------------------------------


def test_flowmap_writes_a_png(tiny_channel_path, tmp_path):
    out = tmp_path / "tmp.png"
    result = cli("flowmap", "--scene", str(tiny_channel_path), "--out", str(out))
    assert result.returncode == 0, result.stderr
    assert out.read_bytes()[:8] == PNG_SIGNATURE
    assert out.stat().st_size > 10_000
    assert str(out.resolve()) in result.stdout


def test_flowmap_arrows_and_options(tiny_channel_path, tmp_path):
    out = tmp_path / "arrows.png"
    result = cli("flowmap", "--scene", str(tiny_channel_path), "--out", str(out),
                     "--arrows", "--slip", "1.3", "--radius-factor", "3", "--size-px", "600")
    assert result.returncode == 0, result.stderr
    assert out.read_bytes()[:8] == PNG_SIGNATURE


@pytest.mark.gl
def test_demo_headless_writes_frames_and_an_animation(tiny_channel_path, tmp_path):
    result = cli("demo", "--scene", str(tiny_channel_path), "--headless", "--frames", "12",
                     "--every", "5", "--size", "96x64", "--out", str(tmp_path / "demo"))
    assert result.returncode == 0, result.stderr
    frames = sorted((tmp_path / "demo").glob("frame_*.png"))
    assert [f.name for f in frames] == ["frame_00000.png", "frame_00005.png",
                                        "frame_00010.png", "frame_00011.png"]
    assert frames[0].read_bytes()[:8] == PNG_SIGNATURE
    assert (tmp_path / "demo" / "demo.gif").read_bytes()[:6] == b"GIF89a"
    assert f"to {(tmp_path / 'demo').resolve()}/" in result.stdout


@pytest.mark.gl
def test_demo_without_a_display_says_so_and_renders_headless(tiny_channel_path, tmp_path,
                                                            monkeypatch):
    monkeypatch.delenv("DISPLAY", raising=False)         # as run_cli's environment has it
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    result = cli("demo", "--scene", str(tiny_channel_path), "--frames", "2",
                     "--size", "64x48", "--out", str(tmp_path / "demo"))
    assert result.returncode == 0, result.stderr
    assert "no display found" in result.stdout
    assert (tmp_path / "demo" / "frame_00001.png").exists()


def test_demo_rejects_a_bad_script(tmp_path):
    script = tmp_path / "keys.txt"
    script.write_text("0 W down\nsoon W up\n")
    result = cli("demo", "--headless", "--frames", "2", "--script", str(script),
                     "--out", str(tmp_path / "demo"))
    assert result.returncode == 1
    assert "keys.txt:2" in result.stderr


def test_demo_rejects_an_unknown_key_with_its_line(tmp_path):
    script = tmp_path / "keys.txt"
    script.write_text("# a comment\n0 W down\n10 3 tap\n20 Z tap\n")
    result = cli("demo", "--headless", "--frames", "2", "--script", str(script),
                     "--out", str(tmp_path / "demo"))
    assert result.returncode == 1
    assert "keys.txt:4: unknown key 'Z'" in result.stderr, result.stderr
    assert "Traceback" not in result.stderr and not (tmp_path / "demo").exists()


def test_out_means_a_file_where_it_says_file(tmp_path):
    folder = tmp_path / "frames"
    folder.mkdir()
    for args in (["render", "--out", str(folder)], ["render", "--out", f"{tmp_path}/new/"],
                 ["flowmap", "--out", str(folder)]):
        result = cli(*args)
        assert result.returncode == 2 and "expected a file name" in result.stderr, args
    result = cli("render", "--out", str(tmp_path / "frame.jpg"))
    assert result.returncode == 2 and "expected a .png file name" in result.stderr
    (tmp_path / "file").write_text("")
    result = cli("demo", "--headless", "--out", str(tmp_path / "file"))
    assert result.returncode == 2 and "expected a folder" in result.stderr
    assert list(folder.iterdir()) == []


@pytest.mark.gl
@pytest.mark.slow
def test_bare_render_runs_on_the_defaults_and_says_what_it_did(tmp_path):
    result = cli("render", cwd=tmp_path)
    assert result.returncode == 0, result.stderr
    out = tmp_path / "out" / "render.png"
    from PIL import Image

    with Image.open(out) as image:
        assert image.size == (1280, 720)
    said = result.stdout
    for what in ("built-in scene, seed 0", "1280x720", "240 frames", "mode advected",
                 f"wrote {out.resolve()}", "particles"):
        assert what in said, (what, said)


@pytest.mark.gl
def test_render_of_a_debug_mode_prints_its_legend(tiny_channel_path, tmp_path):
    out = tmp_path / "coverage.png"
    result = cli("render", "--scene", str(tiny_channel_path), "--size", "64x48",
                     "--frames", "2", "--mode", "coverage", "--out", str(out))
    assert result.returncode == 0, result.stderr
    assert "colours: red:" in result.stdout and "magenta:" in result.stdout


def test_profile_defaults_all_but_frames(tiny_channel_path, tmp_path):
    import json

    result = cli("profile", "--scene", str(tiny_channel_path), "--frames", "3", "--json",
                     cwd=tmp_path)
    assert result.returncode == 0, result.stderr
    data = json.loads(result.stdout)
    assert data["size"] == [1920, 1080] and data["radius_px"] == 10.0 and data["frames"] == 3


@pytest.mark.gl
def test_render_writes_the_frame_of_a_graph_file(tiny_channel_path, tmp_path):
    out = tmp_path / "frames" / "frame.png"
    result = cli("render", "--scene", str(tiny_channel_path), *RENDER_ARGS,
                     "--radius-px", "4", "--out", str(out), cwd=tmp_path)
    assert result.returncode == 0, result.stderr
    assert f"wrote {out.resolve()}" in result.stdout
    from PIL import Image

    with Image.open(out) as image:
        assert image.size == (64, 48) and image.mode == "RGBA"
        pixels = np.asarray(image)
    assert (pixels[..., 3] == 255).all()      # an opaque frame
    assert pixels[..., :3].std() > 1.0        # not one flat colour


def test_display_mode_names_match_the_draw_settings():
    from riverflow.__main__ import DISPLAY_MODES
    from riverflow.components.display import MODE_NAMES

    assert DISPLAY_MODES == tuple(MODE_NAMES)


def test_the_engine_imports_no_system():
    """The systems import the engine (their System base), not the other way round: importing
    every engine module loads no riverflow.systems module (the world asks for the default
    list when it is made: riverflow/systems/schedule.py). The boat's physics sits below both."""
    code = ("import pkgutil, sys, riverflow.physics.boat\n"
            "bad = sorted(n for n in sys.modules if n.startswith(('riverflow.engine', "
            "'riverflow.systems', 'esper')))\n"
            "assert not bad, bad\n"
            "import riverflow.engine\n"
            "for m in pkgutil.iter_modules(riverflow.engine.__path__, 'riverflow.engine.'):\n"
            "    __import__(m.name)\n"
            "assert 'riverflow.engine.world' in sys.modules\n"
            "bad = sorted(n for n in sys.modules if n.startswith('riverflow.systems'))\n"
            "assert not bad, bad\n")
    result = run_python(code)
    assert result.returncode == 0, result.stderr


def test_profile_prints_per_system_timings_as_json(tiny_channel_path, tmp_path):
    import json

    result = cli("profile", "--scene", str(tiny_channel_path), *PROFILE_ARGS, "--json",
                     cwd=tmp_path)
    assert result.returncode == 0, result.stderr
    data = json.loads(result.stdout)
    from riverflow.systems.schedule import SYSTEM_ORDER

    # every update system is timed (drawing is not: profile steps gl=False worlds)
    assert set(data["systems"]) == {"boat", "wake", "flood", "camera", "tiles", "advection",
                                    "screen",
                                    "lifecycle", "poisson", "placement", "foam", "spill",
                                    "waves", "rain", "spray"}
    assert set(data["systems"]) == set(SYSTEM_ORDER) - {"draw"}
    for stats in [*data["systems"].values(), data["total"]]:
        assert 0 <= stats["p50_ms"] <= stats["p95_ms"] + 1e-9
    assert data["particles"]["mean"] > 0 and data["size"] == [64, 48]
    table = cli("profile", "--scene", str(tiny_channel_path), *PROFILE_ARGS, cwd=tmp_path)
    assert table.returncode == 0 and "p95 ms" in table.stdout and "advection" in table.stdout


def test_unreadable_scene_is_a_clear_error(tmp_path):
    bad = tmp_path / "bad.graph"
    bad.write_text("this is not a graph\n")
    result = cli("flowmap", "--scene", str(bad), "--out", str(tmp_path / "x.png"))
    assert result.returncode == 1
    assert str(bad) in result.stderr and "Traceback" not in result.stderr
    assert not (tmp_path / "x.png").exists()


def test_bad_arguments_are_usage_errors():
    assert cli("flowmap", "--slip", "-1").returncode == 2
    assert cli("render", *RENDER_ARGS[:-1], "nonsense", "--out", "x.png").returncode == 2


@pytest.mark.parametrize("argv, option", [
    (["render", "--size", "0x720"], "--size"),
    (["render", "--size", "1e9x5"], "--size"),
    (["render", "--size", "99999x720"], "--size"),
    (["profile", "--size=-5x5"], "--size"),
    (["demo", "--size", "axb"], "--size"),
    (["render", "--frames", "0"], "--frames"),
    (["render", "--frames", "1e3"], "--frames"),
    (["profile", "--frames", "nan"], "--frames"),
    (["render", "--frames", "99999999999999"], "--frames"),
    (["demo", "--frames", "9" * 5000], "--frames"),
    (["demo", "--every=-1"], "--every"),
    (["flowmap", "--size-px", "0"], "--size-px"),
    (["flowmap", "--size-px", "1e3"], "--size-px"),
    (["bake", "--region", "1,2,3"], "--region"),
    (["bake", "--region", "0,0,nan,5"], "--region"),
    (["bake", "--region", "0,0,inf,5"], "--region"),
    (["bake", "--region=-inf,0,5,5"], "--region"),
    (["bake", "--region", "5,0,1,5"], "--region"),
    (["bake", "--cell-m", "nan"], "--cell-m"),
    (["bake", "--cell-m", "-1"], "--cell-m"),
    (["bake", "--cell-m", "inf"], "--cell-m"),
    (["bake", "--cell-m", "one"], "--cell-m"),
    (["render", "--seed=-1"], "--seed"),
    (["demo", "--seed", "0.5"], "--seed"),
    (["spill", "--at", "0,0", "--mass", "1", "--every", "1", "--hours", "1e9"], "--hours"),
    (["view", "tiles", "--port", "70000"], "--port"),
    (["view", "tiles", "--port=-1"], "--port"),
])
def test_bad_numbers_are_usage_errors_naming_the_option(argv, option, capsys):
    from riverflow.__main__ import _parser

    with pytest.raises(SystemExit) as exit_:
        _parser().parse_args(argv)
    assert exit_.value.code == 2
    err = capsys.readouterr().err
    assert f"argument {option}:" in err and "Traceback" not in err, err
    assert len(err) < 2000                      # a 5000-digit number is not echoed


@pytest.mark.parametrize("argv, words", [
    (["render", "--terrain", "dem.tif"], "--terrain applies to a --scene FILE"),
    (["flowmap", "--inlet", "1,2", "--lines", "l.shp"], "--inlet, --lines apply to a --scene"),
    (["profile", "--layer", "rivers"], "--layer applies to a --scene FILE"),
    (["render", "--scene", "a.graph", "--falls", "--dam"], "--falls and --dam shape the built-in"),
    (["spill", "--at", "0,0", "--mass", "1", "--hours", "100", "--every", "0.5"],
     "makes 12,000 maps; at most 10,000"),
])
def test_options_the_scene_would_ignore_are_usage_errors(argv, words, capsys):
    from riverflow.__main__ import main

    assert main(argv) == 2                      # before any scene is made or file read
    err = capsys.readouterr().err
    assert words in err and "Traceback" not in err, err


def test_water_options_on_a_line_network_are_refused(tiny_channel_path, capsys):
    from riverflow.__main__ import main

    assert main(["render", "--scene", str(tiny_channel_path), "--inlet", "1,2"]) == 1
    err = capsys.readouterr().err
    assert "--inlet: for water polygons and masks only" in err and "Traceback" not in err


def test_a_script_that_is_no_text_names_itself(tmp_path):
    script = tmp_path / "keys.bin"
    script.write_bytes(b"\x00\xb4\xff binary")
    result = cli("demo", "--headless", "--frames", "2", "--script", str(script),
                 "--out", str(tmp_path / "demo"))
    assert result.returncode == 1 and "Traceback" not in result.stderr
    assert "--script" in result.stderr and "keys.bin: not a text key script" in result.stderr


def test_good_numbers_parse():
    from riverflow.__main__ import _parser

    args = _parser().parse_args(["render", "--size", "32768x1", "--frames", "10000000"])
    assert args.size == (32768, 1) and args.frames == 10_000_000
    args = _parser().parse_args(["bake", "--region=-1e6,-5,1e6,5", "--cell-m", "0.5"])
    assert args.region == (-1e6, -5.0, 1e6, 5.0) and args.cell_m == 0.5


# -- plot_flow in process ------------------------------------------------------------------------


def test_plot_flow_draws_a_scene_with_terrain(tiny_channel_path, tmp_path):
    """A scene-like object (graph + terrain) gets a hillshade; the picture is written."""
    pytest.importorskip("matplotlib")
    from types import SimpleNamespace

    from riverflow import load_graph
    from riverflow.hydro.plot import plot_flow
    from riverflow.scenes.sources import as_height_source

    gx, gy = np.meshgrid(np.arange(65) * 2.0 - 14.0, np.arange(65) * 2.0 - 64.0)
    heights = 0.002 * gy**2 + 0.01 * (100.0 - gx)  # a valley sloping down to +x
    source = as_height_source(heights, origin_m=(-14.0, -64.0), cell_m=2.0)
    terrain = SimpleNamespace(cell_m=2.0, height=lambda xy: source.heights(xy[:, 0], xy[:, 1]))
    scene = SimpleNamespace(graph=load_graph(tiny_channel_path), seed=7, terrain=terrain)
    out = plot_flow(scene, tmp_path / "scene.png", size_px=500, style="arrows")
    assert out == tmp_path / "scene.png"
    assert out.read_bytes()[:8] == PNG_SIGNATURE


def test_plot_flow_without_matplotlib_names_the_extra(tiny_channel_path, tmp_path):
    code = (
        "import sys\n"
        "sys.modules['matplotlib'] = None\n"
        "from riverflow import load_graph\n"
        "from riverflow.hydro.plot import plot_flow\n"
        "try:\n"
        f"    plot_flow(load_graph({str(tiny_channel_path)!r}), {str(tmp_path / 'x.png')!r})\n"
        "except ImportError as exc:\n"
        "    print(exc)\n"
        "else:\n"
        "    raise SystemExit('no ImportError')\n"
    )
    result = run_python(code)
    assert result.returncode == 0, result.stderr
    assert "riverflow[plot]" in result.stdout


# -- import rules ------------------------------------------------------------------------------


def test_core_modules_import_neither_pyglet_nor_esper():
    code = ("import sys, riverflow, riverflow.hydro.flow_field, riverflow.kernels.flow, "
            "riverflow.hydro.plot, riverflow.__main__\n"
            "bad = {'pyglet', 'esper'} & set(sys.modules)\n"
            "assert not bad, bad\n")
    result = run_python(code)
    assert result.returncode == 0, result.stderr
