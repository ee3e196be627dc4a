"""The ``riverflow`` command line (SPEC §7): ``demo``, ``render``, ``profile``, ``flowmap``.

Every subcommand's ``--help`` works without a display: nothing here imports pyglet, and the
heavy modules (numba kernels, matplotlib, the default scene) load only when a command runs.
Every option has a default, so a bare ``riverflow render`` or ``riverflow profile`` runs on the
built-in scene and says what it did.

    riverflow render                                  # → out/render.png
    riverflow flowmap --scene rivers.graph --out out/flowmap.png
    python -m riverflow demo --headless --out out/demo
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from riverflow.gis.cli import load_scene

DISPLAY_MODES = ("none", "mesh", "coverage", "advected", "pre-advected", "non-advected",
                 "foam", "concentration", "grid", "particles", "velocities")
"""Display / debug modes of the river drawing (SPEC §4 "Drawing"; Proland MeshDisplayType,
reference §4.6): ground only, mesh only, particle coverage, per-pixel sprite blending,
pre-advected texture, non-advected texture, the particles' foam alone, sprite-grid cells,
particles coloured by status, velocity arrows. The same names as ``riverflow.components.display.MODE_NAMES`` (tested), kept
here so that ``--help`` needs no numba import."""



def main(argv: list[str] | None = None) -> int:
    """Run the command line; returns the exit status (0 ok, 1 failure, 2 usage)."""
    parser = _parser()
    args = parser.parse_args(argv)
    if args.command is None:
        parser.print_help()
        return 2
    wrong = _scene_option_misuse(args)
    if wrong:
        print(f"riverflow {args.command}: error: {wrong}", file=sys.stderr)
        return 2
    return args.run(args)


def _scene_option_misuse(args: argparse.Namespace) -> str | None:
    """What is wrong with the scene options together (an option that the chosen scene would
    silently ignore), or None."""
    if not hasattr(args, "scene") or not hasattr(args, "seed"):
        return None
    if args.scene is None:
        given = [f"--{name}" for name in ("layer", "terrain", "inlet", "outlet", "lines")
                 if getattr(args, name, None) is not None]
        if given:
            return (f"{', '.join(given)} {'apply' if len(given) > 1 else 'applies'} to a "
                    f"--scene FILE; the built-in scene makes its own network and hills")
        return None
    given = [f"--{name}" for name in ("falls", "dam") if getattr(args, name, False)]
    if given:
        return (f"{' and '.join(given)} shape{'s' if len(given) == 1 else ''} the built-in "
                f"scene; with --scene {args.scene} the file decides")
    return None


# -- parser -------------------------------------------------------------------------------------


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="riverflow",
        description="Real-time flowing rivers for 3-D games (after Proland and Yu et al. "
                    "2009): the playable boat demo, offscreen frames of a scripted flight, "
                    "per-system timings and pictures of a river network's flow. Every option "
                    "has a default: try 'riverflow render' or 'riverflow demo'.",
        epilog="'riverflow COMMAND --help' tells more. With no display, drawing goes through "
               "EGL offscreen (Mesa's llvmpipe works with no GPU).")
    from riverflow import __version__

    parser.add_argument("--version", action="version", version=f"riverflow {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")

    p = sub.add_parser(
        "flowmap", help="draw a river network and its flow into a PNG",
        description="Draw a river network and its flow field into a PNG: water coloured by "
                    "speed, streamlines, banks coloured and labelled by their stream function "
                    "ψ, axes dashed, closing segments, and the terrain as a hillshade for the "
                    "built-in scene. Needs matplotlib (pip install 'riverflow[plot]').")
    _scene_args(p)
    p.add_argument("--out", type=_file, default=Path("out/flowmap.png"), metavar="FILE.png",
                   help="the picture to write, a file (default: %(default)s)")
    p.add_argument("--slip", type=_positive, default=1.0, metavar="S",
                   help="exponent of the bank weights d^-S (default: %(default)s)")
    p.add_argument("--radius-factor", type=_positive, default=5.0, metavar="F",
                   help="search radius = F × the widest axis (default: %(default)s)")
    p.add_argument("--size-px", type=_side_px, default=1600, metavar="PX",
                   help="width of the picture in pixels (default: %(default)s)")
    p.add_argument("--arrows", action="store_true", help="draw arrows instead of streamlines")
    p.set_defaults(run=_flowmap)

    p = sub.add_parser(
        "demo", help="the playable boat demo (or, with no display, its scripted run to PNGs)",
        description="Play the boat demo in a window: the flow carries your boat, the water is "
                    "drawn with wave sprites carried by the flow; H shows the keys. With "
                    "--headless (or when there is no display) the scripted run is rendered "
                    "offscreen to DIR/frame_NNNNN.png and DIR/demo.gif instead.")
    _scene_args(p)
    p.add_argument("--headless", action="store_true",
                   help="no window: render the scripted run to PNG frames and an animated GIF")
    p.add_argument("--frames", type=_positive_int, default=None, metavar="N",
                   help="frames to run (headless default: 600; windowed: until ESC)")
    p.add_argument("--out", type=_folder, default=Path("out/demo"), metavar="DIR",
                   help="headless: the folder for frame_NNNNN.png and demo.gif (default: "
                        "%(default)s)")
    p.add_argument("--size", type=_size, default=None, metavar="WxH",
                   help="window / frame size (default: 1280x720 windowed, 640x360 headless)")
    p.add_argument("--script", type=Path, default=None, metavar="FILE",
                   help="key script for the headless run: lines 'FRAME KEY down|up|tap' "
                        "(e.g. '0 W down', '420 3 tap'; '#' starts a comment; keys as on the "
                        "keyboard: W, A, S, D, UP, LEFT, 1-6, G, P, V, T, C, SPACE, +, -, "
                        "F2…); default: the built-in run")
    p.add_argument("--every", type=_positive_int, default=10, metavar="K",
                   help="headless: write every K-th frame (default: %(default)s)")
    p.set_defaults(run=_demo)

    p = sub.add_parser(
        "render", help="render a scripted flight offscreen and save its last frame as a PNG",
        description="Fly the scripted chase camera down the scene's main river for N frames "
                    "at 1/60 s (particles, flow tiles, wave sprites), draw the last frame with "
                    "offscreen OpenGL (EGL when there is no display) in the given display mode "
                    "and save it as a PNG. A graph file is put on procedural hills with its rivers "
                    "carved in (riverflow.landscape). With no options: the built-in scene, "
                    "1280x720, 240 frames, advected wave sprites, out/render.png.")
    _scene_args(p)
    p.add_argument("--size", type=_size, default=(1280, 720), metavar="WxH",
                   help="frame size in pixels (default: 1280x720)")
    p.add_argument("--frames", type=_positive_int, default=240, metavar="N",
                   help="frames to run before saving (default: %(default)s, 4 s of flight)")
    p.add_argument("--mode", choices=DISPLAY_MODES, default="advected",
                   help="display mode: one of %(choices)s (default: %(default)s; the README "
                        "says what each colour of the debug modes means)")
    p.add_argument("--out", type=_png_file, default=Path("out/render.png"), metavar="FILE.png",
                   help="the frame to write, a .png file (default: %(default)s)")
    p.add_argument("--radius-px", type=_positive, default=None, metavar="R",
                   help="Poisson-disk radius of the particles in pixels (default: "
                        "RiverConfig's, 10)")
    p.add_argument("--no-reflections", dest="reflections", action="store_false",
                   help="reflect the sky alone, not the banks and the boats (no reflection "
                        "pass; DisplaySettings.reflections)")
    p.set_defaults(run=_render)

    p = sub.add_parser(
        "profile", help="time every system of a scripted camera flight (no drawing)",
        description="Fly a chase camera down the scene's main river (particles, flow tiles, no "
                    "drawing) and print mean / p50 / p95 ms per system and the particle "
                    "count, or JSON. A graph file is put on procedural hills "
                    "(riverflow.landscape). With no options: the built-in scene at 1920x1080, "
                    "r = 10 px, 300 frames "
                    "timed after 60 of warm-up (the design's performance case).")
    _scene_args(p)
    p.add_argument("--size", type=_size, default=(1920, 1080), metavar="WxH",
                   help="screen size in pixels (default: 1920x1080)")
    p.add_argument("--radius-px", type=_positive, default=10.0, metavar="R",
                   help="Poisson-disk radius of the particles in pixels (default: 10)")
    p.add_argument("--frames", type=_positive_int, default=300, metavar="N",
                   help="frames to time, after 60 frames of warm-up (default: %(default)s)")
    p.add_argument("--json", action="store_true", help="print the timings as JSON")
    p.set_defaults(run=_profile)

    from riverflow.gis.cli import (add_bake_command, add_check_command, add_spill_command,
                                   add_view_command)

    add_bake_command(sub, _scene_args, _positive)
    add_check_command(sub)
    add_spill_command(sub, _scene_args, _positive)
    add_view_command(sub)
    return parser


def _scene_args(p: argparse.ArgumentParser) -> None:
    from riverflow.gis.cli import SCENE_HELP, add_scene_options

    p.add_argument("--scene", type=Path, metavar="FILE", help=SCENE_HELP)
    add_scene_options(p)
    p.add_argument("--seed", type=_seed, default=0, metavar="N",
                   help="seed of the built-in scene (default: %(default)s)")
    p.add_argument("--falls", action="store_true",
                   help="the built-in scene with a 6 m fall and a rapid on its tributary "
                        "(the demo's boat starts above the fall)")
    p.add_argument("--dam", action="store_true",
                   help="the built-in scene with a reservoir on its main river; the demo's "
                        "dam breaks a few seconds in and the flood runs down past the boat")


def _positive(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None
    if not value > 0.0 or value == float("inf"):
        raise argparse.ArgumentTypeError(f"must be a positive number, got {text!r}")
    return value


MAX_COUNT = 10_000_000
"""Most frames (--frames, --every) a command takes: 46 hours at 60 frames a second."""
MAX_SIDE_PX = 1 << 15
"""Widest picture or window side [px] (--size, --size-px): RiverWorld's limit."""


def _seed(text: str) -> int:
    """A seed: a whole number ≥ 0 (what numpy's generators take)."""
    try:
        value = int(text)
    except ValueError:             # also past Python's 4,300-digit limit
        raise argparse.ArgumentTypeError(f"not an integer: {text[:40]!r}") from None
    if value < 0:
        raise argparse.ArgumentTypeError(f"must be a whole number ≥ 0, got {text[:40]!r}")
    return value


def _positive_int(text: str) -> int:
    """A whole number 1 … MAX_COUNT (argparse names the option in its error)."""
    try:
        value = int(text)
    except ValueError:             # also past Python's 4,300-digit limit
        raise argparse.ArgumentTypeError(f"not an integer: {text[:40]!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be at least 1, got {text!r}")
    if value > MAX_COUNT:
        raise argparse.ArgumentTypeError(f"must be at most {MAX_COUNT:,}, got {text[:40]!r}")
    return value


def _side_px(text: str) -> int:
    """A picture side 1 … MAX_SIDE_PX pixels."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a whole number of pixels: {text[:40]!r}") \
            from None
    if not 1 <= value <= MAX_SIDE_PX:
        raise argparse.ArgumentTypeError(f"must be 1 … {MAX_SIDE_PX} px, got {text[:40]!r}")
    return value


def _file(text: str) -> Path:
    """An output file's path: not a folder (``--out`` says FILE where it means one)."""
    path = Path(text)
    if text.endswith(("/", "\\")) or path.is_dir():
        raise argparse.ArgumentTypeError(f"expected a file name, got the folder {text!r} "
                                         f"(e.g. {str(path / 'frame.png')!r})")
    return path


def _folder(text: str) -> Path:
    path = Path(text)
    if path.exists() and not path.is_dir():
        raise argparse.ArgumentTypeError(f"expected a folder, got the file {text!r}")
    return path


def _png_file(text: str) -> Path:
    path = _file(text)
    if path.suffix.lower() != ".png":
        raise argparse.ArgumentTypeError(f"expected a .png file name, got {text!r}")
    return path


def _size(text: str) -> tuple[int, int]:
    """WxH: two whole numbers of pixels, 1 … MAX_SIDE_PX each."""
    try:
        w, h = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected WxH such as 1280x720, got "
                                         f"{text[:40]!r}") from None
    if w < 1 or h < 1:
        raise argparse.ArgumentTypeError(f"width and height must be positive, got {text!r}")
    if max(w, h) > MAX_SIDE_PX:
        raise argparse.ArgumentTypeError(f"width and height must be at most {MAX_SIDE_PX} px, "
                                         f"got {text[:40]!r}")
    return w, h


# -- commands -----------------------------------------------------------------------------------


def _flowmap(args: argparse.Namespace) -> int:
    return _draw(args, args.out, size_px=args.size_px, slip=args.slip,
                 radius_factor=args.radius_factor, arrows=args.arrows)


def _demo(args: argparse.Namespace) -> int:
    import os

    headless = args.headless
    if not headless and not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
        print(f"riverflow demo: no display found (DISPLAY is not set); rendering the scripted "
              f"run headless to {args.out}/ instead (PNG frames and demo.gif)")
        headless = True
    if headless:
        os.environ["PYGLET_HEADLESS"] = "1"      # before anything imports pyglet's GL
    scene, title = load_scene(args)
    if scene is None:
        return 1
    from riverflow import demo

    if headless:
        script = None
        if args.script is not None:
            from riverflow.engine.controls import KeyScript

            try:
                text = args.script.read_text(encoding="utf-8")
            except UnicodeDecodeError as exc:
                print(f"riverflow demo: --script {args.script}: not a text key script "
                      f"(byte {exc.start} is not UTF-8)", file=sys.stderr)
                return 1
            except OSError as exc:
                print(f"riverflow demo: --script {args.script}: cannot read it: "
                      f"{exc.strerror or exc}", file=sys.stderr)
                return 1
            try:
                script = KeyScript.from_text(text, str(args.script), keys=demo.KEYS)
            except ValueError as exc:
                print(f"riverflow demo: {exc}", file=sys.stderr)
                return 1
        try:
            run = demo.run_headless(args.frames or 600, args.out, scene=scene,
                                    size=args.size or (640, 360), seed=args.seed,
                                    script=script, every=args.every)
        except Exception as exc:  # no OpenGL at all: say so, don't dump a traceback
            print(f"riverflow demo: cannot render headless: {exc}", file=sys.stderr)
            return 1
        print(f"wrote {len(run.frames)} frames to {args.out.resolve()}/ and "
              f"{run.animation.resolve() if run.animation else 'no animation'} ({title})")
        return 0
    drawn = demo.run_window(scene=scene, size=args.size or (1280, 720), seed=args.seed,
                            frames=args.frames)
    print(f"riverflow demo: {drawn} frames drawn")
    return 0


def _profile(args: argparse.Namespace) -> int:
    import json

    scene, title = load_scene(args)
    if scene is None:
        return 1
    from riverflow.engine.profiling import format_profile, profile_flight

    w, h = args.size
    if not args.json:
        print(f"riverflow profile: {title}, {w}x{h}, r = {args.radius_px:g} px: a chase camera "
              f"down the main river, 60 frames of warm-up then {args.frames} timed "
              f"(no drawing)…", flush=True)
    start = time.perf_counter()
    try:
        result = profile_flight(scene, args.size, args.radius_px, args.frames)
    except (ValueError, OSError) as exc:
        print(f"riverflow profile: {exc}", file=sys.stderr)
        return 1
    result["scene"] = title
    if args.json:
        print(json.dumps(result, indent=2))
    else:
        print(f"{format_profile(result)}\n({time.perf_counter() - start:.1f} s)")
    return 0


def _render(args: argparse.Namespace) -> int:
    if not _can_write(args):
        return 1
    scene, title = load_scene(args)
    if scene is None:
        return 1
    import dataclasses

    from riverflow.components.display import legend, settings_for
    from riverflow.engine.config import RiverConfig
    from riverflow.engine.world import RiverWorld
    from riverflow.scenes.flight import fly

    config = RiverConfig.from_env()
    if args.radius_px is not None:
        config = dataclasses.replace(config, radius_px=args.radius_px)
    w, h = args.size
    print(f"riverflow render: {title}, {w}x{h}, {args.frames} frames of the chase flight, "
          f"mode {args.mode}…", flush=True)
    start = time.perf_counter()
    try:
        world = RiverWorld(scene, size=args.size, gl=True, seed=args.seed, config=config)
    except ValueError as exc:  # the scene (a GraphError: a graph no flow can run in)
        print(f"riverflow render: {exc}", file=sys.stderr)
        return 1
    except Exception as exc:  # no OpenGL context: say what would help
        print(f"riverflow render: cannot draw: {exc}", file=sys.stderr)
        return 1
    with world:
        for name, value in dataclasses.asdict(settings_for(args.mode)).items():
            setattr(world.display, name, value)
        world.display.reflections = args.reflections
        fly(world, args.frames)
        frame = world.render()
        particles = len(world.particles)
        entries = legend(world.display)
    from riverflow.images import save_png

    try:
        path = save_png(frame, args.out)
    except OSError as exc:
        print(f"riverflow render: cannot write {args.out}: {exc}", file=sys.stderr)
        return 1
    print(f"wrote {path.resolve()} ({title}, {w}x{h}, mode {args.mode}, {args.frames} "
          f"frames, {particles} particles, {time.perf_counter() - start:.1f} s)")
    if any(colour is not None for colour, _ in entries):      # a debug mode: its colours
        print("colours: " + "\n         ".join(text for _, text in entries))
    return 0


def _draw(args: argparse.Namespace, out: Path, *, size_px: int, slip: float = 1.0,
          radius_factor: float = 5.0, arrows: bool = False) -> int:
    if not _can_write(args):
        return 1
    scene, title = load_scene(args)
    if scene is None:
        return 1
    try:
        from riverflow.hydro.flow_field import FlowField
        from riverflow.hydro.plot import plot_flow

        graph = getattr(scene, "graph", scene)
        field = FlowField(graph, slip, radius_factor, cache_tiles=1024)
        path = plot_flow(scene, out, field=field, size_px=size_px,
                         style="arrows" if arrows else "streamlines",
                         title=f"{title}: flow field (slip {slip:g}, search radius "
                               f"{radius_factor:g} × widest axis)")
    except (ImportError, ValueError, OSError) as exc:  # GraphError is a ValueError
        print(f"riverflow {args.command}: {exc}", file=sys.stderr)
        return 1
    print(f"wrote {path.resolve()}")
    return 0


def _can_write(args: argparse.Namespace) -> bool:
    """Whether --out can be written (checked before any work; else says why)."""
    from riverflow._atomic import writable_path

    try:
        writable_path(args.out)
    except OSError as exc:
        print(f"riverflow {args.command}: --out: {exc}", file=sys.stderr)
        return False
    return True


if __name__ == "__main__":
    sys.exit(main())
