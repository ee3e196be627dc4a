"""Ray-casting benchmark: rays/s onto the default scene's terrain + water, typical game cameras.

Run: ``python benchmarks/bench_raycast.py [--json] [--size 1920x1080]``. One core (the kernel
is serial). For cameras 2, 10, 30 and 50 m above the main river's water, looking at a river
point 150 m ahead, it casts 5,000 and 20,000 rays through random pixels of the view ("all"),
and as many rays through pixels that see water ("water": what new particles need), and prints
the best of several runs. Also: the first-call (JIT or cache load) time, the water grid and the
pyramid build times. Figures go to docs/performance.md; no test asserts on them.
"""
from __future__ import annotations

import argparse
import json
import time

import numpy as np

COUNTS = (5_000, 20_000)
HEIGHTS_ABOVE_WATER_M = (2.0, 10.0, 30.0, 50.0)


def best_seconds(fn, repeat: int = 15) -> float:
    """Wall time of the fastest of ``repeat`` calls."""
    best = np.inf
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--json", action="store_true", help="print JSON instead of a table")
    parser.add_argument("--size", default="1920x1080", help="viewport WxH [px]")
    args = parser.parse_args(argv)
    width, height = (int(v) for v in args.size.split("x"))

    from riverflow.engine.camera import Camera
    from riverflow.kernels.raycast import HIT_WATER, cast_rays_onto_heightfield, height_pyramid
    from riverflow.scenes.default import default_scene
    from riverflow.scenes.water_grid import water_level_grid

    results: dict[str, float] = {}
    scene = default_scene(seed=0)
    terrain = scene.terrain
    heights = terrain.heights_m
    x0, y0 = (float(v) for v in terrain.origin_m)
    t0 = time.perf_counter()
    water = water_level_grid(scene)
    results["water_level_grid_ms"] = 1e3 * (time.perf_counter() - t0)

    t0 = time.perf_counter()
    tiny_h, tiny_w = heights[:3, :3].copy(), water[:3, :3].copy()  # C-contiguous, as the real ones
    one = np.zeros((1, 3))
    cast_rays_onto_heightfield(one, one, tiny_h, tiny_w, 0.0, 0.0, 1.0, 1.0, one.copy(),
                               np.zeros(1, np.uint8), height_pyramid(tiny_h, tiny_w))
    results["first_calls_ms"] = 1e3 * (time.perf_counter() - t0)
    t0 = time.perf_counter()
    pyramid = height_pyramid(heights, water)
    results["height_pyramid_ms"] = 1e3 * (time.perf_counter() - t0)

    main_river = np.vstack([b.centerline_m for b in scene.branches if b.kind == "main"])
    k = len(main_river) // 3
    target_xy = main_river[k + 15]
    eye_xy = main_river[k] - 0.5 * (main_river[k + 15] - main_river[k])
    level = float(scene.water.level(target_xy[None])[0])
    pixels = np.random.default_rng(0).uniform((0.0, 0.0), (width, height), (max(COUNTS), 2))

    def cast(origins, directions, out_xyz, out_hit) -> int:
        return cast_rays_onto_heightfield(origins, directions, heights, water, x0, y0,
                                          terrain.cell_m, 1e4, out_xyz, out_hit, pyramid)

    for above_m in HEIGHTS_ABOVE_WATER_M:
        cam = Camera(size_px=(width, height), fov_y_deg=60.0, near_m=0.5, far_m=8000.0)
        cam.look_at((*eye_xy, level + above_m), (*target_xy, level))
        origins, directions = cam.screen_to_ray(pixels)
        out_xyz = np.empty_like(origins)
        out_hit = np.empty(len(origins), np.uint8)
        cast(origins, directions, out_xyz, out_hit)
        tag = f"{above_m:g} m up"
        results[f"hit_fraction[{tag}]"] = float((out_hit > 0).mean())
        results[f"water_fraction[{tag}]"] = float((out_hit == HIT_WATER).mean())
        wet = np.resize(np.flatnonzero(out_hit == HIT_WATER), len(origins))
        sets = {"all": (origins, directions), "water": (origins[wet], directions[wet])}
        for name, (o, d) in sets.items():
            for n in COUNTS:
                o_n, d_n = np.ascontiguousarray(o[:n]), np.ascontiguousarray(d[:n])
                s = best_seconds(lambda: cast(o_n, d_n, out_xyz[:n], out_hit[:n]))
                results[f"ms_{n}_{name}[{tag}]"] = 1e3 * s
                results[f"rays_per_s_{n}_{name}[{tag}]"] = n / s

    if args.json:
        print(json.dumps(results, indent=2))
    else:
        for key, v in results.items():
            print(f"{key:42s} {v:14,.3f}")
    return results


if __name__ == "__main__":
    main()
