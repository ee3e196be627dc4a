"""Ray-casting benchmark: rays/s onto the default scene's terrain + water, typical game cameras.

Run: ``python benchmarks/bench_raycast.py [--json] [--block-cells 8 16 32]``. One core (the
kernel is serial). For each camera (2, 10, 30 and 50 m above the main river's water, looking
at a river point ahead and slightly down) it casts 5,000 and 20,000 rays through random pixels
of a 1920×1080 view, and through random pixels that see water (what new particles need), and
prints the best of several runs. Figures go to docs/performance.md; no test asserts on them.
"""
from __future__ import annotations

import argparse
import json
import time

import numpy as np


def best_seconds(fn, repeat: int = 7) -> float:
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

    scene = default_scene(seed=0)
    terrain = scene.terrain
    results: dict[str, float] = {}
    t0 = time.perf_counter()
    water = water_level_grid(scene)
    results["water_level_grid_s"] = time.perf_counter() - t0
    heights = terrain.heights_m
    x0, y0 = (float(v) for v in terrain.origin_m)

    main_river = np.vstack([b.centerline_m for b in scene.branches if b.kind == "main"])
    k = len(main_river) // 3
    target_xy = main_river[k + 15]
    eye_xy = main_river[k] - (main_river[k + 15] - main_river[k]) * 0.5
    level = float(scene.water.level(target_xy[None])[0])
    rng = np.random.default_rng(0)
    pixels = rng.uniform((0.0, 0.0), (width, height), (20_000, 2))

    height_pyramid(heights[:3, :3], water[:3, :3])  # compile
    t0 = time.perf_counter()
    pyramid = height_pyramid(heights, water)
    results["height_pyramid_ms"] = 1e3 * (time.perf_counter() - t0)
    if True:
        for above_m in (2.0, 10.0, 30.0, 50.0):
            cam = Camera(size_px=(width, height), fov_y_deg=60.0, near_m=0.5, far_m=8000.0)
            cam.look_at((*eye_xy, level + above_m), (*target_xy, level))
            origins, directions = cam.screen_to_ray(pixels)
            out_xyz = np.empty_like(origins)
            out_hit = np.empty(len(origins), np.uint8)

            def cast(n: int) -> int:
                return cast_rays_onto_heightfield(origins[:n], directions[:n], heights, water,
                                                  x0, y0, terrain.cell_m, 1e4, out_xyz[:n],
                                                  out_hit[:n], pyramid)

            cast(20_000)
            wet = np.flatnonzero(out_hit == HIT_WATER)
            w_origins = np.ascontiguousarray(origins[np.resize(wet, 20_000)])
            w_directions = np.ascontiguousarray(directions[np.resize(wet, 20_000)])
            tag = f"{above_m:g} m up"
            results[f"hit_fraction[{tag}]"] = float((out_hit[:20_000] > 0).mean())
            results[f"water_fraction[{tag}]"] = len(wet) / 20_000
            for n in (5_000, 20_000):
                s = best_seconds(lambda: cast(n))
                results[f"ms_{n}_rays[{tag}]"] = 1e3 * s
                results[f"rays_per_s_{n}[{tag}]"] = n / s
                if len(wet):
                    s = best_seconds(lambda: cast_rays_onto_heightfield(
                        w_origins[:n], w_directions[:n], heights, water, x0, y0,
                        terrain.cell_m, 1e4, out_xyz[:n], out_hit[:n], pyramid))
                    results[f"ms_{n}_water_rays[{tag}]"] = 1e3 * s

    if args.json:
        print(json.dumps(results, indent=2))
    else:
        for key, v in results.items():
            print(f"{key:42s} {v:14,.3f}")
    return results


if __name__ == "__main__":
    main()
