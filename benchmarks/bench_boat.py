"""Boat benchmark: the "boat" system per frame, and FlowField.query with and without a hull.

Run: ``make bench`` or ``python benchmarks/bench_boat.py [--json] [--frames N]``. One core.
The boat system is timed alone (a world with only it) and inside a full gl=False world with a
chase camera (its share of the frame, and what the hull costs the advection system). Queries:
points over the river's cached tiles with no obstacle, with one hull (most points far from
it: the price of the early bounding-circle test), and all within the hull's influence (the ψ
sample and the modulation for every point). Figures go to docs/performance.md; no test
asserts on them.
"""
from __future__ import annotations

import argparse
import json
import math
import time

import numpy as np


def best_rate(fn, n_items: int, repeat: int = 5) -> float:
    """Items per second of the fastest of ``repeat`` runs."""
    best = np.inf
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return n_items / best


def _chase(world, boat) -> None:
    f = np.array([math.cos(boat.heading_rad), math.sin(boat.heading_rad), 0.0])
    c = np.array([*boat.position_m, boat.altitude_m])
    world.camera.look_at(c - 26.0 * f + (0.0, 0.0, 9.0), c + 10.0 * f)


def _boat_run(scene, start, heading, frames: int, systems, size=(1280, 720)) -> tuple:
    """(boat ms per frame samples, advection ms samples) of a boat driving in circles."""
    import riverflow as rf
    from riverflow.engine.config import RiverConfig

    world = rf.RiverWorld(scene, size=size, config=RiverConfig(tile_production="blocking"),
                          systems=systems)
    boat = world.boat(world.add_boat(start, heading, throttle=0.6, rudder=0.3))
    boat_ms, advection_ms = [], []
    for frame in range(frames + 60):
        _chase(world, boat)
        world.step(1 / 60)
        if frame >= 60:
            boat_ms.append(world.timings_ms["boat"])
            advection_ms.append(world.timings_ms.get("advection", np.nan))
    world.close()
    return np.array(boat_ms), np.array(advection_ms)


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--json", action="store_true", help="print JSON instead of a table")
    parser.add_argument("--frames", type=int, default=600)
    parser.add_argument("--points", type=int, default=1_000_000)
    args = parser.parse_args(argv)

    import shapely

    import riverflow as rf
    from riverflow.hydro.flow_field import Obstacle
    from riverflow.scenes.flight import main_centerline
    from riverflow.systems.boat import MoveBoats

    results: dict[str, float] = {}
    scene = rf.default_scene(seed=0)
    line = shapely.LineString(main_centerline(scene))
    start = np.array(line.interpolate(1500.0).coords[0])
    ahead = np.array(line.interpolate(1510.0).coords[0])
    heading = math.atan2(*(ahead - start)[::-1])

    alone, _ = _boat_run(scene, start, heading, args.frames, [MoveBoats()])
    results["boat_system_alone_ms_mean"] = float(alone.mean())
    results["boat_system_alone_ms_p95"] = float(np.percentile(alone, 95))
    in_world, advection = _boat_run(scene, start, heading, args.frames, None)
    results["boat_system_in_world_ms_mean"] = float(in_world.mean())
    results["advection_with_boat_ms_mean"] = float(np.nanmean(advection))

    field = rf.FlowField.for_scene(scene)
    rng = np.random.default_rng(0)
    water = scene.water.polygon
    box = np.array(shapely.buffer(shapely.Point(start), 300.0).bounds)
    pts = rng.uniform(box[:2], box[2:], (4 * args.points, 2))
    pts = pts[shapely.contains_xy(water, pts[:, 0], pts[:, 1])][: args.points]
    near = start + rng.uniform(-8.0, 8.0, (args.points, 2))
    field.query(pts)
    field.query(near)
    results["query_points_per_s_no_obstacle"] = best_rate(lambda: field.query(pts), len(pts))
    results["query_points_per_s_near_no_obstacle"] = best_rate(lambda: field.query(near),
                                                               len(near))
    psi = float(field.potential(start[None])[0])
    field.set_obstacles([Obstacle(tuple(start), heading, 8.0, 3.0, psi, (1.0, 0.5), 0.1)])
    results["query_points_per_s_one_hull_far"] = best_rate(lambda: field.query(pts), len(pts))
    results["query_points_per_s_one_hull_all_near"] = best_rate(lambda: field.query(near),
                                                                len(near))
    results["query_points"] = len(pts)

    if args.json:
        print(json.dumps(results, indent=2))
    else:
        for k, v in results.items():
            print(f"{k:40s} {v:14,.3f}" if isinstance(v, float) else f"{k:40s} {v:>14}")
    return results


if __name__ == "__main__":
    main()
