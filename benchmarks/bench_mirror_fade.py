"""Cost of the held mirror's cross-fade (issue 29 item 2): how often the chase flight draws a
second reflection pass, and what a frame with one costs on Mesa's llvmpipe.

Run: ``python benchmarks/bench_mirror_fade.py [--json] [--frames N] [--sizes 640x360,...]``.
The chase flight of ``benchmarks/bench_draw.py`` (advected mode, r = 10 px):

* ``fade_frames``: of ``--count`` flight frames (from its start, 320 × 180, the GL calls made
  no-ops), those drawn with a second pass (``scenes.reflection.hold_levels`` fading a new
  level in), and the range of the eased mirror level over them;
* per size, each of ``--frames`` flight frames drawn twice, one pass and two (the second
  forced at the eased level + 0.5 m, fade 0.5), in alternating order, ``glFinish`` before and
  after: medians of this process's CPU time (every llvmpipe thread's work: far less sensitive
  than wall time to other processes on a shared machine) and of wall time [ms].

Figures go to docs/performance.md. No test asserts on time.
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import time

os.environ.setdefault("PYGLET_HEADLESS", "1")
os.environ.setdefault("PYGLET_DEBUG_GL", "0")

import numpy as np  # noqa: E402


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--json", action="store_true")
    parser.add_argument("--count", type=int, default=240)
    parser.add_argument("--frames", type=int, default=12)
    parser.add_argument("--sizes", default="640x360,1920x1080")
    args = parser.parse_args(argv)
    import riverflow
    root = os.path.dirname(os.path.dirname(os.path.abspath(riverflow.__file__)))
    sys.path.insert(0, os.path.join(root, "benchmarks"))
    import bench_draw as bd

    import riverflow as rf
    import riverflow.systems.draw as dm
    from riverflow.engine import gl
    from riverflow.scenes.flight import fly

    scene = rf.default_scene(seed=0)
    out: dict = {}
    world = bd.drawn_world(scene, (320, 180), 10.0, "advected", 0)
    drawer = world._drawer()
    levels, fading = [], 0
    for i in range(args.count):
        fly(world, 1, start=i)
        with bd._NoDraw():
            world.draw()
        if drawer.last_mirror_level_m is not None:
            levels.append(drawer.last_mirror_level_m)
            fading += drawer.last_mirror_levels[1] is not None
    world.close()
    out["fade_frames"] = {"frames": args.count, "with_a_second_pass": int(fading),
                          "mirror_level_m": [min(levels), max(levels)] if levels else None}

    real = dm.hold_levels
    force = [False]

    def forced(held, level, dt_s, eye_z, *rest):
        return (level, level + 0.5, 0.5) if force[0] else (level, None, 0.0)
    dm.hold_levels = forced
    try:
        for size in args.sizes.split(","):
            w, h = (int(v) for v in size.split("x"))
            world = bd.drawn_world(scene, (w, h), 10.0, "advected", 60)
            times: dict = {False: [], True: []}
            for i in range(args.frames):
                fly(world, 1, start=60 + i)
                for two in ((False, True) if i % 2 else (True, False)):
                    force[0] = two
                    gl.finish()
                    t, c = time.perf_counter(), time.process_time()
                    world.draw()
                    gl.finish()
                    times[two].append((time.process_time() - c, time.perf_counter() - t))
            world.close()
            row = {}
            for two, name in ((False, "one_pass"), (True, "two_passes")):
                a = np.array(times[two]) * 1e3
                row[name] = {"cpu_ms": float(np.median(a[:, 0])),
                             "wall_ms": float(np.median(a[:, 1]))}
            out[size] = row
    finally:
        dm.hold_levels = real
    print(json.dumps(out, indent=None if args.json else 2))
    return out


if __name__ == "__main__":
    main()
