"""Ray-casting benchmark: rays/s onto the default scene's surface tiles, typical game cameras.

Run: ``python benchmarks/bench_raycast.py [--json] [--size 1920x1080]``. One core (the kernels
are serial).

* ``tiles``: what new particles are placed with. For cameras 2, 10, 30 and 50 m above the
  main river's water, looking at a river point 150 m ahead, a world steps once with blocking
  tile production (so every tile of the view is made), and
  :func:`~riverflow.kernels.raycast_tiles.cast_rays_onto_tiles` casts 5,000 and 20,000 rays
  through random pixels of the view ("all"), and as many through pixels that see water
  ("water": what new particles need) onto that frame's surface
  (``world.resource(TerrainView).surface``: the quadtree cut the view needs).
* ``grid``: :func:`~riverflow.kernels.raycast.cast_rays_onto_heightfield` (the same walk on one
  grid, which each raycast tile runs on its own nodes) on a synthetic 1025² grid of 4 m cells,
  hills with a winding channel of water, from the same heights above the water.

Each figure is the best of several runs. Also: the first-call (JIT or cache load) times, the
world's first step, and the grid's pyramid build. Figures go to docs/performance.md; no test
asserts on them.
"""
from __future__ import annotations

import argparse
import json
import time

import numpy as np

COUNTS = (5_000, 20_000)
HEIGHTS_ABOVE_WATER_M = (2.0, 10.0, 30.0, 50.0)
GRID_NODES = 1025
GRID_CELL_M = 4.0


def best_seconds(fn, repeat: int = 15) -> float:
    """Wall time of the fastest of ``repeat`` calls."""
    best = np.inf
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best


def synthetic_grid() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(heights, water, channel centre line (M, 2) [m]) on GRID_NODES² nodes of GRID_CELL_M
    from (0, 0): rolling hills (tens of metres), a channel 60 m wide winding along x, its
    water 1.5 m under the banks and NaN elsewhere (C-contiguous float32, as tiles are)."""
    k = np.arange(GRID_NODES) * GRID_CELL_M
    x, y = np.meshgrid(k, k)
    mid = 0.5 * k[-1]
    centre = mid + 300.0 * np.sin(x / 700.0)
    dist = np.abs(y - centre)
    hills = 15.0 * np.sin(x / 310.0) * np.cos(y / 270.0) + 8.0 * np.sin((x + 2 * y) / 97.0)
    banks = 2.0 + 0.02 * dist
    land = banks + hills * np.clip((dist - 30.0) / 200.0, 0.0, 1.0)
    heights = np.where(dist < 30.0, -3.0 + 0.002 * dist**2, land)
    water = np.where(dist < 30.0 + 2 * GRID_CELL_M, 0.5, np.nan)
    line = np.c_[k, mid + 300.0 * np.sin(k / 700.0)]
    return (np.ascontiguousarray(heights, np.float32), np.ascontiguousarray(water, np.float32),
            line)


def _rays(results, tag, cast, cam, pixels) -> None:
    """Time ``cast`` for every count on all and on water-seeing pixels of ``cam``."""
    from riverflow.kernels.raycast import HIT_LAND, HIT_WATER

    origins, directions = cam.screen_to_ray(pixels)
    out_xyz = np.empty_like(origins)
    out_hit = np.empty(len(origins), np.uint8)
    cast(origins, directions, out_xyz, out_hit)
    results[f"hit_fraction[{tag}]"] = float(np.isin(out_hit, (HIT_LAND, HIT_WATER)).mean())
    results[f"water_fraction[{tag}]"] = float((out_hit == HIT_WATER).mean())
    wet = np.flatnonzero(out_hit == HIT_WATER)
    if not len(wet):
        wet = np.arange(len(origins))
    wet = np.resize(wet, len(origins))
    sets = {"all": (origins, directions), "water": (origins[wet], directions[wet])}
    for name, (o, d) in sets.items():
        for n in COUNTS:
            o_n, d_n = np.ascontiguousarray(o[:n]), np.ascontiguousarray(d[:n])
            s = best_seconds(lambda: cast(o_n, d_n, out_xyz[:n], out_hit[:n]))
            results[f"ms_{n}_{name}[{tag}]"] = 1e3 * s
            results[f"rays_per_s_{n}_{name}[{tag}]"] = n / s


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--json", action="store_true", help="print JSON instead of a table")
    parser.add_argument("--size", default="1920x1080", help="viewport WxH [px]")
    args = parser.parse_args(argv)
    width, height = (int(v) for v in args.size.split("x"))

    from riverflow.components.river import TerrainView
    from riverflow.engine.camera import Camera
    from riverflow.engine.config import RiverConfig
    from riverflow.engine.world import RiverWorld
    from riverflow.kernels.raycast import cast_rays_onto_heightfield, height_pyramid
    from riverflow.kernels.raycast_tiles import cast_rays_onto_tiles
    from riverflow.scenes.default import default_scene

    results: dict[str, float] = {}
    pixels = np.random.default_rng(0).uniform((0.0, 0.0), (width, height), (max(COUNTS), 2))

    # -- the default scene's surface tiles -------------------------------------------------
    scene = default_scene(seed=0)
    main_river = np.vstack([b.centerline_m for b in scene.branches if b.kind == "main"])
    k = len(main_river) // 3
    target_xy = main_river[k + 15]
    eye_xy = main_river[k] - 0.5 * (main_river[k + 15] - main_river[k])
    level = float(scene.water.level(target_xy[None])[0])
    world = RiverWorld(scene, size=(width, height),
                       config=RiverConfig(tile_production="blocking", fov_y_deg=60.0))
    try:
        for i, above_m in enumerate(HEIGHTS_ABOVE_WATER_M):
            world.camera.look_at((*eye_xy, level + above_m), (*target_xy, level))
            t0 = time.perf_counter()
            world.step(1 / 60)
            tag = f"tiles, {above_m:g} m up"
            step = "first_step_ms" if i == 0 else "step_ms"
            results[f"{step}[{tag}]"] = 1e3 * (time.perf_counter() - t0)
            surface = world.resource(TerrainView).surface
            results[f"cut_leaves[{tag}]"] = len(surface.leaf_slot)
            if i == 0:
                one = np.zeros((1, 3))
                t0 = time.perf_counter()
                cast_rays_onto_tiles(one, one + (0.0, 0.0, -1.0), surface, 1e4, one.copy(),
                                     np.zeros(1, np.uint8))
                results["first_call_tiles_ms"] = 1e3 * (time.perf_counter() - t0)

            def cast(origins, directions, out_xyz, out_hit, surface=surface) -> int:
                return cast_rays_onto_tiles(origins, directions, surface, 1e4, out_xyz, out_hit)

            _rays(results, tag, cast, world.camera, pixels)
    finally:
        world.close()

    # -- one synthetic grid ----------------------------------------------------------------
    heights, water, line = synthetic_grid()
    t0 = time.perf_counter()
    tiny_h, tiny_w = heights[:3, :3].copy(), water[:3, :3].copy()  # C-contiguous, as the real ones
    one = np.zeros((1, 3))
    cast_rays_onto_heightfield(one, one, tiny_h, tiny_w, 0.0, 0.0, 1.0, 1.0, one.copy(),
                               np.zeros(1, np.uint8), height_pyramid(tiny_h, tiny_w))
    results["first_call_grid_ms"] = 1e3 * (time.perf_counter() - t0)
    t0 = time.perf_counter()
    pyramid = height_pyramid(heights, water)
    results["grid_pyramid_ms"] = 1e3 * (time.perf_counter() - t0)
    k = len(line) // 3
    target_xy, eye_xy = line[k + 38], line[k]  # 150 m ahead along the channel
    for above_m in HEIGHTS_ABOVE_WATER_M:
        cam = Camera(size_px=(width, height), fov_y_deg=60.0, near_m=0.5, far_m=8000.0)
        cam.look_at((*eye_xy, 0.5 + above_m), (*target_xy, 0.5))

        def cast(origins, directions, out_xyz, out_hit) -> int:
            return cast_rays_onto_heightfield(origins, directions, heights, water, 0.0, 0.0,
                                              GRID_CELL_M, 1e4, out_xyz, out_hit, pyramid)

        _rays(results, f"grid, {above_m:g} m up", cast, cam, pixels)

    if args.json:
        print(json.dumps(results, indent=2))
    else:
        for key, v in results.items():
            print(f"{key:46s} {v:14,.3f}")
    return results


if __name__ == "__main__":
    main()
