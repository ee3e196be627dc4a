"""Flow-field benchmark: uncached ψ lattice points/s, cached velocity queries/s, JIT times.

Run: ``make bench`` or ``python benchmarks/bench_flow.py [--json]``. One core (the kernels are
serial). Figures go to docs/performance.md; no test asserts on them (shared, noisy machines).
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time

import numpy as np

FIRST_CALL = """
import time, numpy as np
t0 = time.perf_counter()
import riverflow as rf
from riverflow.hydro.builder import RiverNetworkBuilder
b = RiverNetworkBuilder(); b.add_branch([(0, 0), (400, 0)], 40.0, discharge_m2s=40.0)
field = rf.FlowField(b.build())
t1 = time.perf_counter()
field.query(np.array([[200.0, 0.0]])); field.potential(np.array([[200.0, 0.0]]))
field.exact_potential(np.array([[200.0, 0.0]]))
print(t1 - t0, time.perf_counter() - t1)
"""


def first_call_s(cache_dir: str) -> tuple[float, float]:
    """(import + build, first query) seconds in a fresh process using ``cache_dir``."""
    env = dict(os.environ, NUMBA_CACHE_DIR=cache_dir)
    out = subprocess.run([sys.executable, "-c", FIRST_CALL], env=env, check=True,
                         capture_output=True, text=True).stdout.split()
    return float(out[0]), float(out[1])


def best_rate(fn, n_items: int, repeat: int = 5) -> float:
    """Items per second of the fastest of ``repeat`` runs."""
    best = np.inf
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return n_items / best


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--json", action="store_true", help="print JSON instead of a table")
    parser.add_argument("--points", type=int, default=2_000_000, help="cached query batch size")
    parser.add_argument("--large-km", type=float, default=0.0, metavar="KM",
                        help="also time finest flow tiles along the rivers of a default scene "
                             "this large (e.g. 1000: its banks have ~500,000 segments)")
    args = parser.parse_args(argv)

    import riverflow as rf
    from riverflow.hydro.areas import water_polygon
    from riverflow.kernels import flow as kf

    results: dict[str, float] = {}
    with tempfile.TemporaryDirectory() as cache:
        results["jit_cold_build_s"], results["jit_cold_first_query_s"] = first_call_s(cache)
        results["jit_warm_build_s"], results["jit_warm_first_query_s"] = first_call_s(cache)

    t0 = time.perf_counter()
    scene = rf.default_scene(seed=0)
    results["default_scene_build_s"] = time.perf_counter() - t0
    field = rf.FlowField.for_scene(scene, cache_tiles=1024)
    lv = field.max_level
    tiles = field.tiles
    n = 1 << lv
    field.ensure_tiles(lv, [(x, y) for x in range(n) for y in range(n)][: tiles.capacity])
    # tiles with water anywhere on the level
    water = water_polygon(scene.graph)
    x0, y0, x1, y1 = water.bounds
    keys = {tuple(k) for k in field.tile_of(
        np.array(water.buffer(10.0).exterior.coords) if water.geom_type == "Polygon" else
        np.vstack([np.array(g.exterior.coords) for g in water.geoms]), lv)}
    import shapely
    keys = [(tx, ty) for tx in range(n) for ty in range(n)
            if shapely.box(*tiles.tile_origin_m(lv, tx, ty),
                           *(np.add(tiles.tile_origin_m(lv, tx, ty), tiles.tile_size_m(lv))))
            .intersects(water)]
    m = (tiles.n_cells + 1 + 2 * kf.LATTICE_RING) ** 2

    def produce() -> None:
        field.clear_tiles()
        field.ensure_tiles(lv, keys)

    rate = best_rate(produce, len(keys) * m, repeat=3)
    slots = np.array([tiles.slot_of(lv, tx, ty) for tx, ty in keys])
    slots = slots[slots >= 0]
    results["water_tiles"] = len(keys)
    results["uncached_lattice_points_per_s"] = rate
    results["uncached_water_points_per_s"] = rate * tiles.pool.arrays["inside_points"][slots].sum() / (len(keys) * m)
    results["tile_build_ms"] = 1e3 * len(keys) * m / rate / len(keys)

    rng = np.random.default_rng(0)
    pts = rng.uniform((x0, y0), (x1, y1), (4 * args.points, 2))
    pts_water = pts[shapely.contains_xy(water, pts[:, 0], pts[:, 1])][: args.points]
    pts_box = pts[: args.points]
    field.query(pts_water)
    field.query(pts_box)
    coherent = pts_water[np.lexsort((pts_water[:, 0], np.floor(pts_water[:, 1] / 8.0)))]
    results["cached_queries_per_s_water"] = best_rate(lambda: field.query(pts_water), len(pts_water))
    results["cached_queries_per_s_water_coherent"] = best_rate(lambda: field.query(coherent),
                                                               len(coherent))
    results["cached_queries_per_s_river_bbox"] = best_rate(lambda: field.query(pts_box), len(pts_box))
    # within 4 m of the banks: the bank correction's cells (kernels/flow.py _bank_correction)
    near = pts_water[shapely.distance(shapely.points(pts_water), water.boundary) < 4.0]
    results["cached_queries_per_s_near_banks"] = best_rate(lambda: field.query(near), len(near))
    results["cached_potential_per_s_water"] = best_rate(lambda: field.potential(pts_water),
                                                        len(pts_water))
    results["lattice_spacing_m"] = tiles.spacing_m(lv)
    results["max_level"] = lv
    if args.large_km > 0:
        results.update(large_tiles(rf, args.large_km))

    if args.json:
        print(json.dumps(results, indent=2))
    else:
        for k, v in results.items():
            print(f"{k:40s} {v:14,.3f}" if isinstance(v, float) else f"{k:40s} {v:>14}")
    return results


def large_tiles(rf, size_km: float, count: int = 40) -> dict[str, float]:
    """CPU ms per finest flow tile (made afresh) at ``count`` wet tiles along the rivers of the
    default scene of ``size_km``: what a view pays per new tile there."""
    scene = rf.default_scene(seed=0, size_km=size_km)
    field = rf.FlowField.for_scene(scene, cache_tiles=4 * count)
    lv = field.max_level
    centre = np.concatenate([np.asarray(field.graph.curves[a].points)[:, :2]
                             for a in field.graph.axes()])
    rng = np.random.default_rng(0)
    keys = np.unique(field.tile_of(centre[rng.choice(len(centre), 8 * count)], lv), axis=0)
    keys = [(int(x), int(y)) for x, y in keys if field.tiles.is_wet(lv, x, y)][:count]
    field.ensure_tiles(lv, keys[:1])                      # kernels loaded
    field.clear_tiles()
    t0 = time.process_time()
    field.ensure_tiles(lv, keys)
    return {"large_scene_km": size_km, "large_segments": field.network.n_segments,
            "large_tile_build_ms_cpu": 1e3 * (time.process_time() - t0) / len(keys)}


if __name__ == "__main__":
    main()
