"""Cost of the terrain's shading: whole frames with the water off (display mode "none": sky,
terrain tiles, props) and on ("advected"), over the chase flight, on this machine's OpenGL
(Mesa's llvmpipe here: software, so the fragment shaders dominate).

Run: ``python benchmarks/bench_terrain.py [--json] [--frames N] [--sizes 640x360,1920x1080]``.
Compare two versions of ``shaders/terrain.glsl`` by running this on each (same machine, same
load). Figures go to docs/performance.md.
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


def run_case(scene, size, mode: str, frames: int, warmup: int) -> dict:
    from riverflow.engine import gl

    world = rf.RiverWorld(scene, size=size, gl=True, seed=0,
                          config=rf.RiverConfig(radius_px=10.0, tile_production="blocking"))
    for key, value in vars(settings_for(mode)).items():
        setattr(world.display, key, value)
    fly(world, warmup)
    world.draw()
    gl.finish()
    times = []
    for i in range(frames):
        fly(world, 1, start=warmup + i)
        t0 = time.perf_counter()
        world.draw()
        gl.finish()
        times.append((time.perf_counter() - t0) * 1e3)
    world.close()
    return {"size": list(size), "mode": mode, "frames": frames, "renderer": gl.renderer_name(),
            "p50_ms": float(np.median(times)), "min_ms": float(np.min(times)),
            "p95_ms": float(np.percentile(times, 95))}


def main(argv: list[str] | None = None) -> list[dict]:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--json", action="store_true")
    parser.add_argument("--frames", type=int, default=20)
    parser.add_argument("--warmup", type=int, default=60)
    parser.add_argument("--sizes", default="640x360,1920x1080")
    parser.add_argument("--modes", default="none,advected")
    args = parser.parse_args(argv)
    scene = rf.default_scene(seed=0)
    results = []
    for size in args.sizes.split(","):
        w, h = (int(v) for v in size.split("x"))
        for mode in args.modes.split(","):
            r = run_case(scene, (w, h), mode, args.frames, args.warmup)
            results.append(r)
            if not args.json:
                print(f"{w}x{h} {mode:9s} frame (+glFinish) p50 {r['p50_ms']:.1f} ms, min "
                      f"{r['min_ms']:.1f}, p95 {r['p95_ms']:.1f}  [{r['renderer']}]", flush=True)
    if args.json:
        print(json.dumps(results, indent=2))
    return results


if __name__ == "__main__":
    main()
