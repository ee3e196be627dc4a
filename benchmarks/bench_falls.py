"""Falls and rapids benchmark: what a fall and a rapid on screen cost a frame (issue #23).

Run: ``python benchmarks/bench_falls.py [--json] [--frames N] [--draw-size WxH]``. One core.

The built-in scene with ``falls=True`` (a 6 m fall and a 6 % rapid on the tributary), the
camera downstream of the fall looking up the tributary at it, 1920×1080 with r = 10 px, in
two worlds stepped in turns, frame by frame (so a loaded machine slows both alike): "falls"
as it is, "off" the same scene and view with the field's falls and rapids taken away (no
speed-up, no per-frame altitude over the fall, no plunge foam), no spray and no falling sheet
drawn; the water surface still drops, so the same particles are on screen. What the falls add
is the difference:

* simulation: the systems' milliseconds a frame (all but "draw"; wall clock, as the HUD shows
  them) and the frame's CPU time (``time.thread_time``: a loaded machine's waits left out);
* drawing (OpenGL; Mesa's llvmpipe where there is no GPU): the CPU time of a drawn and
  read-back frame at ``--draw-size`` (default 640×360): the draw call's own thread
  (``time.thread_time``: the draw system's Python and numba side) and the whole process
  (``time.process_time``: llvmpipe's threads, the "GPU" here, included).

Figures go to docs/performance.md; no test asserts on them.
"""
from __future__ import annotations

import argparse
import json
import time

import numpy as np


def _view(scene):
    (f,) = scene.graph.falls
    c = np.asarray(f.centre_m)
    t = np.asarray(f.direction)
    n = np.array([-t[1], t[0]])
    lip = float(scene.water.level(c[None])[0])
    eye = (*(c + 70.0 * t + 25.0 * n), lip + 12.0)
    return eye, (*c, lip - 3.0)


def _worlds(size, gl: bool):
    import riverflow as rf
    from riverflow.components.spray import Spray
    from riverflow.engine.config import RiverConfig

    scene = rf.default_scene(seed=0, falls=True)
    view = _view(scene)
    worlds = {}
    for name in ("falls", "off"):
        world = rf.RiverWorld(scene, size=size, gl=gl,
                              config=RiverConfig(radius_px=10.0, tile_production="blocking"))
        world.camera.look_at(*view)
        if name == "off":
            world.field.falls = []
            world.field._fall_table = None
            world.field.rapids = []
            world.field._rapid_table = None
            world.resource(Spray).enabled = False
            world.display.fall_sheets = False
        worlds[name] = world
    return worlds


def simulation(frames: int, warm: int = 60) -> dict[str, dict[str, float]]:
    worlds = _worlds((1920, 1080), gl=False)
    ms = {k: [] for k in worlds}
    cpu = {k: [] for k in worlds}
    for frame in range(frames + warm):
        for name, world in worlds.items():
            t0 = time.thread_time()
            world.step(1 / 60)
            if frame >= warm:
                cpu[name].append((time.thread_time() - t0) * 1e3)
                ms[name].append(sum(v for k, v in world.timings_ms.items() if k != "draw"))
    out = {}
    for name, world in worlds.items():
        out[name] = {"systems_ms": float(np.median(ms[name])),
                     "frame_cpu_ms": float(np.median(cpu[name])),
                     "particles": int(len(world.particles)),
                     "inside": int((world.particles.status == 1).sum())}
        world.close()
    out["extra"] = {k: out["falls"][k] - out["off"][k] for k in ("systems_ms", "frame_cpu_ms")}
    return out


def drawing(frames: int, size) -> dict[str, dict[str, float]]:
    worlds = _worlds(size, gl=True)
    for world in worlds.values():
        for _ in range(30):
            world.step(1 / 60)
    cpu = {k: [] for k in worlds}
    proc = {k: [] for k in worlds}
    wall = {k: [] for k in worlds}
    system = {k: [] for k in worlds}
    for _ in range(frames):
        for name, world in worlds.items():
            world.step(1 / 60)
            t0, p0, w0 = time.thread_time(), time.process_time(), time.perf_counter()
            world.render()
            cpu[name].append((time.thread_time() - t0) * 1e3)
            proc[name].append((time.process_time() - p0) * 1e3)
            wall[name].append((time.perf_counter() - w0) * 1e3)
            system[name].append(world.timings_ms["draw"])
    out = {}
    for name, world in worlds.items():
        out[name] = {"render_thread_cpu_ms": float(np.median(cpu[name])),
                     "render_process_cpu_ms": float(np.median(proc[name])),
                     "render_wall_ms": float(np.median(wall[name])),
                     "draw_system_ms": float(np.median(system[name]))}
        world.close()
    out["extra"] = {k: out["falls"][k] - out["off"][k] for k in out["falls"]}
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=240)
    parser.add_argument("--draw-frames", type=int, default=20)
    parser.add_argument("--draw-size", default="640x360")
    parser.add_argument("--no-draw", action="store_true")
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    result = {"simulation": simulation(args.frames)}
    if not args.no_draw:
        w, h = (int(v) for v in args.draw_size.lower().split("x"))
        result["drawing"] = drawing(args.draw_frames, (w, h))
    if args.json:
        print(json.dumps(result, indent=2))
        return
    for part, rows in result.items():
        print(part)
        for name, row in rows.items():
            print(f"  {name:6s} " + "  ".join(f"{k} {v:.3f}" if isinstance(v, float)
                                               else f"{k} {v}" for k, v in row.items()))


if __name__ == "__main__":
    main()
