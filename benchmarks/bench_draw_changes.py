"""The draw system's CPU on the frames where the drawn tile set changes (issue 29: the terrain
seams must cost nothing there) against the other frames.

Run: ``python benchmarks/bench_draw_changes.py [--frames N]``. ``bench_draw.py``'s case 0
(1920×1080, r = 5 px, advected, 120 warm-up frames of the chase flight, one core, the GL calls
that render made no-ops, thread CPU time), with ``_TerrainTiles.sync`` (the terrain tiles'
upload and seams, run when the cut or a pool changed) and the draw system's tile sync, terrain
and reflection passes wrapped: per frame, the draw CPU split by whether the terrain sync ran,
and the mean of each wrapped part over those frames and over the others. To compare with older
code, run this file against an export of it (``PYTHONPATH=<export>``, its own
``benchmarks/bench_draw.py``): the wrapped methods exist since the tile arenas.
Figures go to docs/performance.md.
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import time

os.environ.setdefault("PYGLET_HEADLESS", "1")
os.environ.setdefault("PYGLET_DEBUG_GL", "0")
os.environ.setdefault("NUMBA_NUM_THREADS", "1")

import numpy as np  # noqa: E402


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=120)
    args = parser.parse_args(argv)
    import riverflow
    root = os.path.dirname(os.path.dirname(os.path.abspath(riverflow.__file__)))
    sys.path.insert(0, os.path.join(root, "benchmarks"))
    import bench_draw as bd

    import riverflow as rf
    import riverflow.systems.draw as dm
    from riverflow.engine import gl
    from riverflow.scenes.flight import fly

    frame = [0]
    syncs: list[int] = []
    parts: dict[str, list] = {}

    def wrap(cls, name):
        real = getattr(cls, name)

        def timed(self, *a, **k):
            t = time.thread_time_ns()
            out = real(self, *a, **k)
            parts.setdefault(name, []).append((frame[0], (time.thread_time_ns() - t) / 1e6))
            if name == "sync":
                syncs.append(frame[0])
            return out
        setattr(cls, name, timed)

    wrap(dm._TerrainTiles, "sync")
    for name in ("_tile_meshes", "_draw_terrain", "_draw_reflection"):
        wrap(dm.DrawRivers, name)
    world = bd.drawn_world(rf.default_scene(seed=0), (1920, 1080), 5.0, "advected", 120)
    parts.clear()
    cpu = []
    for i in range(args.frames):
        frame[0] = i
        fly(world, 1, start=120 + i)
        gl.finish()
        with bd._NoDraw():
            world.draw()
        cpu.append(world.timings_ms["draw"])
    world.close()
    cpu = np.array(cpu)
    changed = np.zeros(len(cpu), bool)
    changed[syncs] = True
    out = {"root": root, "frames": len(cpu), "changing_frames": int(changed.sum()),
           "draw_cpu_ms": {"p50": float(np.median(cpu)), "p95": float(np.percentile(cpu, 95))},
           "draw_cpu_changing_mean_ms": float(cpu[changed].mean()) if changed.any() else None,
           "draw_cpu_other_median_ms": float(np.median(cpu[~changed]))}
    for name, calls in parts.items():
        on = sum(t for f, t in calls if changed[f])
        off = sum(t for f, t in calls if not changed[f])
        out[f"{name}_ms"] = {"changing_mean": on / max(changed.sum(), 1),
                             "other_mean": off / max((~changed).sum(), 1)}
    print(json.dumps(out, indent=2))
    return out


if __name__ == "__main__":
    main()
