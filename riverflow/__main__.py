"""The ``riverflow`` command line (SPEC §7): ``flowmap``, ``demo``, ``render``, ``profile``.

Every subcommand's ``--help`` works without a display: nothing here imports pyglet, and the
heavy modules (numba kernels, matplotlib, the default scene) load only when a command runs.

    riverflow flowmap --scene rivers.graph --out out/flowmap.png
    python -m riverflow demo --out out/demo
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

DISPLAY_MODES = ("none", "mesh", "coverage", "advected", "pre-advected", "non-advected",
                 "grid", "particles", "velocities")
"""Display / debug modes of the river drawing (SPEC §4 "Drawing"; Proland MeshDisplayType,
reference §4.6): ground only, mesh only, particle coverage, per-pixel sprite blending,
pre-advected texture, non-advected texture, sprite-grid cells, particles coloured by status,
velocity arrows. The same names as ``riverflow.components.display.MODE_NAMES`` (tested), kept
here so that ``--help`` needs no numba import."""



def main(argv: list[str] | None = None) -> int:
    """Run the command line; returns the exit status (0 ok, 1 failure, 2 usage / not yet)."""
    parser = _parser()
    args = parser.parse_args(argv)
    if args.command is None:
        parser.print_help()
        return 2
    return args.run(args)


# -- parser -------------------------------------------------------------------------------------


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="riverflow",
        description="Real-time flowing rivers (after Proland and Yu et al. 2009): flow "
                    "pictures now; the boat demo, offscreen rendering and profiling are in "
                    "progress.")
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
    p.add_argument("--out", type=Path, default=Path("out/flowmap.png"), metavar="FILE.png",
                   help="the picture to write (default: %(default)s)")
    p.add_argument("--slip", type=_positive, default=1.0, metavar="S",
                   help="exponent of the bank weights d^-S (default: %(default)s)")
    p.add_argument("--radius-factor", type=_positive, default=5.0, metavar="F",
                   help="search radius = F × the widest axis (default: %(default)s)")
    p.add_argument("--size-px", type=int, default=1600, metavar="PX",
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
    p.add_argument("--out", type=Path, default=Path("out/demo"), metavar="DIR",
                   help="folder for the headless frames (default: %(default)s)")
    p.add_argument("--size", type=_size, default=None, metavar="WxH",
                   help="window / frame size (default: 1280x720 windowed, 640x360 headless)")
    p.add_argument("--script", type=Path, default=None, metavar="FILE",
                   help="key script for the headless run (lines 'FRAME KEY down|up|tap'); "
                        "default: the built-in run")
    p.add_argument("--every", type=_positive_int, default=10, metavar="K",
                   help="headless: write every K-th frame (default: %(default)s)")
    p.set_defaults(run=_demo)

    p = sub.add_parser(
        "render", help="render a scripted run offscreen and save its last frame as a PNG",
        description="Fly the scripted chase camera down the scene's main river for N frames "
                    "at 1/60 s (particles, flow tiles, wave sprites), draw the last frame with "
                    "offscreen OpenGL (EGL when there is no display) in the given display mode "
                    "and save it as a PNG. A graph file is put on procedural hills with its rivers "
                    "carved in (riverflow.landscape).")
    _scene_args(p)
    p.add_argument("--size", type=_size, required=True, metavar="WxH",
                   help="frame size in pixels, e.g. 1280x720")
    p.add_argument("--frames", type=_positive_int, required=True, metavar="N",
                   help="frames to run before saving")
    p.add_argument("--mode", choices=DISPLAY_MODES, required=True,
                   help="display mode: one of %(choices)s")
    p.add_argument("--out", type=Path, required=True, metavar="FILE.png",
                   help="the frame to write")
    p.add_argument("--radius-px", type=_positive, default=None, metavar="R",
                   help="Poisson-disk radius of the particles in pixels (default: "
                        "RiverConfig's, 10)")
    p.set_defaults(run=_render)

    p = sub.add_parser(
        "profile", help="time every system of a scripted camera flight (no drawing)",
        description="Fly a chase camera down the scene's main river (particles, flow tiles, no "
                    "drawing) and print mean / p50 / p95 ms per system and the particle "
                    "count, or JSON. A graph file is put on procedural hills (riverflow.landscape).")
    _scene_args(p)
    p.add_argument("--size", type=_size, required=True, metavar="WxH",
                   help="screen size in pixels, e.g. 1920x1080")
    p.add_argument("--radius-px", type=_positive, required=True, metavar="R",
                   help="Poisson-disk radius of the particles in pixels, e.g. 10")
    p.add_argument("--frames", type=_positive_int, required=True, metavar="N",
                   help="frames to time")
    p.add_argument("--json", action="store_true", help="print the timings as JSON")
    p.set_defaults(run=_profile)

    from riverflow.gis.cli import add_bake_command

    add_bake_command(sub, _scene_args, _positive)
    return parser


def _scene_args(p: argparse.ArgumentParser) -> None:
    from riverflow.gis.cli import SCENE_HELP, add_scene_options

    p.add_argument("--scene", type=Path, metavar="FILE", help=SCENE_HELP)
    add_scene_options(p)
    p.add_argument("--seed", type=int, default=0, metavar="N",
                   help="seed of the built-in scene (default: %(default)s)")


def _positive(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None
    if not value > 0.0 or value == float("inf"):
        raise argparse.ArgumentTypeError(f"must be a positive number, got {text!r}")
    return value


def _positive_int(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not an integer: {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be at least 1, got {text!r}")
    return value


def _size(text: str) -> tuple[int, int]:
    try:
        w, h = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected WxH such as 1280x720, got {text!r}") from None
    if w < 1 or h < 1:
        raise argparse.ArgumentTypeError(f"width and height must be positive, got {text!r}")
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
    scene, title = _load_scene(args)
    if scene is None:
        return 1
    from riverflow import demo

    if headless:
        script = None
        if args.script is not None:
            from riverflow.engine.controls import KeyScript

            try:
                script = KeyScript.from_text(args.script.read_text(), str(args.script))
            except (OSError, ValueError) as exc:
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

    scene, title = _load_scene(args)
    if scene is None:
        return 1
    from riverflow.engine.profiling import format_profile, profile_flight

    try:
        result = profile_flight(scene, args.size, args.radius_px, args.frames)
    except (ValueError, OSError) as exc:
        print(f"riverflow profile: {exc}", file=sys.stderr)
        return 1
    result["scene"] = title
    print(json.dumps(result, indent=2) if args.json else f"{title}\n{format_profile(result)}")
    return 0


def _render(args: argparse.Namespace) -> int:
    scene, title = _load_scene(args)
    if scene is None:
        return 1
    import dataclasses

    from riverflow.components.display import settings_for
    from riverflow.engine.config import RiverConfig
    from riverflow.engine.world import RiverWorld
    from riverflow.scenes.flight import fly

    config = RiverConfig.from_env()
    if args.radius_px is not None:
        config = dataclasses.replace(config, radius_px=args.radius_px)
    try:
        world = RiverWorld(scene, size=args.size, gl=True, seed=args.seed, config=config)
    except Exception as exc:  # no OpenGL context: say what would help
        print(f"riverflow render: cannot draw: {exc}", file=sys.stderr)
        return 1
    with world:
        for name, value in dataclasses.asdict(settings_for(args.mode)).items():
            setattr(world.display, name, value)
        fly(world, args.frames)
        frame = world.render()
    from riverflow.images import save_png

    try:
        path = save_png(frame, args.out)
    except OSError as exc:
        print(f"riverflow render: cannot write {args.out}: {exc}", file=sys.stderr)
        return 1
    print(f"wrote {path.resolve()} ({title}, {args.size[0]}x{args.size[1]}, mode {args.mode}, "
          f"{args.frames} frames, {len(world.particles)} particles)")
    return 0


def _draw(args: argparse.Namespace, out: Path, *, size_px: int, slip: float = 1.0,
          radius_factor: float = 5.0, arrows: bool = False) -> int:
    scene, title = _load_scene(args)
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


def _load_scene(args: argparse.Namespace) -> tuple[Any, str]:
    """The landscape of --scene (a graph file on procedural hills, :func:`landscape`), or the
    built-in scene of --seed; (None, message) after an error."""
    from riverflow.hydro.graph import GraphError

    if args.scene is not None:
        from riverflow.gis.cli import scene_graph
        from riverflow.scenes.landscape import landscape

        try:    # a graph file or GIS lines, on --terrain or procedural hills
            return landscape(scene_graph(args), args.terrain, seed=args.seed), args.scene.name
        except (GraphError, OSError, ImportError) as exc:
            print(f"riverflow {args.command}: cannot load {args.scene}: {exc}", file=sys.stderr)
            return None, ""
    try:
        from riverflow.scenes.default import default_scene
    except Exception as exc:  # the built-in scene is still being written: say so, don't crash
        print(f"riverflow {args.command}: the built-in scene is not available "
              f"({type(exc).__name__}: {exc}); pass a hydro-graph file with --scene FILE",
              file=sys.stderr)
        return None, ""
    return default_scene(seed=args.seed), f"built-in scene, seed {args.seed}"


if __name__ == "__main__":
    sys.exit(main())
