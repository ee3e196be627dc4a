"""Falls and rapids benchmark: what a fall and a rapid on screen cost a frame (issue #23).

Run: ``python benchmarks/bench_falls.py [--json] [--frames N] [--draw-size WxH]``. One core.

The built-in scene with ``falls=True`` (a 6 m fall and a 6 % rapid on the tributary) and the
same scene without them, the same camera (downstream of the fall, looking up the tributary at
it, the rapid in front), 1920×1080 with r = 10 px:

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
    from riverflow.engine.config import RiverConfig

    with_falls = rf.default_scene(seed=0, falls=True)
    view = _view(with_falls)
    for scene in (with_falls, rf.default_scene(seed=0)):
        world = rf.RiverWorld(scene, size=size, gl=gl,
                              config=RiverConfig(radius_px=10.0, tile_production="blocking"))
        world.camera.look_at(*view)
        yield world


def simulation(frames: int, warm: int = 60) -> dict[str, dict[str, float]]:
    out = {}
    for name, world in zip(("falls", "plain"), _worlds((1920, 1080), gl=False)):
        ms, cpu = [], []
        for frame in range(frames + warm):
            t0 = time.thread_time()
            world.step(1 / 60)
            if frame >= warm:
                cpu.append((time.thread_time() - t0) * 1e3)
                ms.append(sum(v for k, v in world.timings_ms.items() if k != "draw"))
        out[name] = {"systems_ms": float(np.median(ms)), "frame_cpu_ms": float(np.median(cpu)),
                     "particles": int(len(world.particles)),
                     "inside": int((world.particles.status == 1).sum())}
        world.close()
    out["extra"] = {k: out["falls"][k] - out["plain"][k] for k in ("systems_ms", "frame_cpu_ms")}
    return out


def drawing(frames: int, size) -> dict[str, dict[str, float]]:
    out = {}
    for name, world in zip(("falls", "plain"), _worlds(size, gl=True)):
        for _ in range(30):
            world.step(1 / 60)
        cpu, proc, wall = [], [], []
        for _ in range(frames):
            world.step(1 / 60)
            t0, p0, w0 = time.thread_time(), time.process_time(), time.perf_counter()
            world.render()
            cpu.append((time.thread_time() - t0) * 1e3)
            proc.append((time.process_time() - p0) * 1e3)
            wall.append((time.perf_counter() - w0) * 1e3)
        out[name] = {"render_thread_cpu_ms": float(np.median(cpu)),
                     "render_process_cpu_ms": float(np.median(proc)),
                     "render_wall_ms": float(np.median(wall))}
        world.close()
    out["extra"] = {k: out["falls"][k] - out["plain"][k] for k in out["falls"]}
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
