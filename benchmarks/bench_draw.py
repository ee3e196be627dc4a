"""Cost of drawing: the CPU side (sprite tables built and uploaded) and the whole frame.

Run: ``make bench`` or ``python benchmarks/bench_draw.py [--json] [--frames N]``. Issue target:
the CPU side of drawing (building and uploading the tables) under 1 ms a frame at 1920×1080
with r = 10 px. The whole frame (all GL passes, ``glFinish``) on Mesa's llvmpipe is reported,
not a target: software rendering is 10–100× slower than any GPU. Figures go to
docs/performance.md. Set ``PYGLET_DEBUG_GL=0`` (done below) so pyglet does not check errors
after every GL call.
"""
from __future__ import annotations

import argparse
import json
import os
import time

os.environ.setdefault("PYGLET_HEADLESS", "1")
os.environ.setdefault("PYGLET_DEBUG_GL", "0")

import numpy as np  # noqa: E402

import riverflow as rf  # noqa: E402
from riverflow.components.display import settings_for  # noqa: E402
from riverflow.scenes.flight import fly  # noqa: E402

CASES = (((1920, 1080), 10.0, "advected"), ((1920, 1080), 10.0, "pre-advected"),
         ((1920, 1080), 5.0, "advected"), ((640, 360), 10.0, "advected"))


def run_case(scene, size, radius, mode, frames: int, warmup: int) -> dict:
    from riverflow.engine import gl

    world = rf.RiverWorld(scene, size=size, gl=True, seed=0,
                          config=rf.RiverConfig(radius_px=radius, tile_production="blocking"))
    for key, value in vars(settings_for(mode)).items():
        setattr(world.display, key, value)
    fly(world, warmup)
    world.draw()                       # first draw: programs, meshes, textures
    gl.finish()
    drawer = next(s for s in world.systems if s.name == "draw")
    tables, cpu, frame = [], [], []
    fly_start = warmup
    for i in range(frames):
        fly(world, 1, start=fly_start + i)
        t0 = time.perf_counter()
        world.draw()
        t1 = time.perf_counter()
        gl.finish()
        t2 = time.perf_counter()
        tables.append(drawer.last_tables_ms)
        cpu.append((t1 - t0) * 1e3)
        frame.append((t2 - t0) * 1e3)
    world.close()

    def stats(v):
        return {"p50_ms": float(np.median(v)), "p95_ms": float(np.percentile(v, 95)),
                "mean_ms": float(np.mean(v))}

    return {"size": list(size), "radius_px": radius, "mode": mode, "frames": frames,
            "particles": len(world.particles), "renderer": gl.renderer_name(),
            "tables": stats(tables), "draw_calls_cpu": stats(cpu), "frame_with_finish": stats(frame)}


def main(argv: list[str] | None = None) -> list[dict]:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--json", action="store_true")
    parser.add_argument("--frames", type=int, default=30)
    parser.add_argument("--warmup", type=int, default=120)
    args = parser.parse_args(argv)
    scene = rf.default_scene(seed=0)
    results = []
    for size, radius, mode in CASES:
        r = run_case(scene, size, radius, mode, args.frames, args.warmup)
        results.append(r)
        if not args.json:
            print(f"{size[0]}x{size[1]} r={radius:g} {mode:13s} particles {r['particles']:5d}  "
                  f"tables p50 {r['tables']['p50_ms']:.3f} p95 {r['tables']['p95_ms']:.3f} ms  "
                  f"draw CPU p50 {r['draw_calls_cpu']['p50_ms']:.2f} ms  "
                  f"frame (+glFinish) p50 {r['frame_with_finish']['p50_ms']:.1f} "
                  f"p95 {r['frame_with_finish']['p95_ms']:.1f} ms  [{r['renderer']}]", flush=True)
    if args.json:
        print(json.dumps(results, indent=2))
    return results


if __name__ == "__main__":
    main()
