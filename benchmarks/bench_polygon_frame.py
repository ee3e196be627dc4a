"""Polygon river against line river: the steady frame (issue 22, "Speed").

Run: ``python benchmarks/bench_polygon_frame.py [--frames N] [--draw-frames N] [--draw-size WxH]``.
One core (NUMBA_NUM_THREADS=1).

The same meander, 1.2 km long and 40 m wide, made twice: "line" from its centre line and
width (``add_branch``), "polygon" from a water polygon with wavy banks (its width between 32
and 48 m, ``set_water_area``: the banks are the polygon's rings, as ``rf.read_water`` makes
them). Both as ``rf.landscape`` worlds with the same camera, stepped in turns frame by frame
(a loaded machine slows both alike):

* simulation: the systems' milliseconds a frame (all but "draw") and the frame's CPU time
  (``time.thread_time``);
* drawing (Mesa's llvmpipe where there is no GPU): the CPU time of a drawn and read-back
  frame at ``--draw-size`` (the process's, llvmpipe's threads included) and its wall time.

Figures go to docs/performance.md; no test asserts on them.
"""
from __future__ import annotations

import argparse
import os
import time

os.environ.setdefault("NUMBA_NUM_THREADS", "1")

import numpy as np  # noqa: E402
import shapely  # noqa: E402


def _rivers():
    from riverflow.hydro.builder import RiverNetworkBuilder

    s = np.linspace(0.0, 1200.0, 241)
    line = np.c_[s, 60.0 * np.sin(2 * np.pi * s / 400.0)]
    ls = shapely.LineString(line)
    d = np.gradient(line, axis=0)
    n = np.c_[-d[:, 1], d[:, 0]] / np.hypot(*d.T)[:, None]
    half = 20.0 + 4.0 * np.sin(2 * np.pi * s / 90.0)
    poly = shapely.Polygon(np.vstack([line + half[:, None] * n,
                                      (line - half[:, None] * n)[::-1]])).buffer(0)
    out = {}
    b = RiverNetworkBuilder()
    b.add_branch(line, 40.0, discharge_m2s=40.0, name="line")
    out["line"] = b.build()
    b = RiverNetworkBuilder()
    b.add_branch(line, 40.0, discharge_m2s=40.0, name="polygon")
    b.set_water_area(poly)
    out["polygon"] = b.build()
    assert ls.length > 0
    return out


def _worlds(size, gl: bool):
    import riverflow as rf

    worlds = {}
    for name, graph in _rivers().items():
        scene = rf.landscape(graph, seed=0)
        world = rf.RiverWorld(scene, size=size, gl=gl, seed=0)
        level = float(scene.water.level(np.array([[600.0, 0.0]]))[0])
        world.camera.look_at((600.0, -260.0, level + 120.0), (600.0, 0.0, level))
        worlds[name] = world
    return worlds


def simulation(frames: int, warm: int = 60) -> dict:
    worlds = _worlds((1280, 720), gl=False)
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
                     "particles": int(len(world.particles))}
        world.close()
    return out


def drawing(frames: int, size) -> dict:
    worlds = _worlds(size, gl=True)
    for world in worlds.values():
        for _ in range(30):
            world.step(1 / 60)
    proc = {k: [] for k in worlds}
    wall = {k: [] for k in worlds}
    for _ in range(frames):
        for name, world in worlds.items():
            world.step(1 / 60)
            p0, w0 = time.process_time(), time.perf_counter()
            world.render()
            proc[name].append((time.process_time() - p0) * 1e3)
            wall[name].append((time.perf_counter() - w0) * 1e3)
    out = {}
    for name, world in worlds.items():
        out[name] = {"render_process_cpu_ms": float(np.median(proc[name])),
                     "render_wall_ms": float(np.median(wall[name]))}
        world.close()
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=180)
    parser.add_argument("--draw-frames", type=int, default=15)
    parser.add_argument("--draw-size", default="640x360")
    parser.add_argument("--no-draw", action="store_true")
    args = parser.parse_args()
    result = {"simulation": simulation(args.frames)}
    if not args.no_draw:
        w, h = (int(v) for v in args.draw_size.lower().split("x"))
        result["drawing"] = drawing(args.draw_frames, (w, h))
    for part, rows in result.items():
        print(part)
        for name, row in rows.items():
            print(f"  {name:8s} " + "  ".join(f"{k} {v:.3f}" if isinstance(v, float)
                                                 else f"{k} {v}" for k, v in row.items()))


if __name__ == "__main__":
    main()
