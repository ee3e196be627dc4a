"""Mesh benchmark: terrain tiles and water surface of the default scene.

Run: ``python benchmarks/bench_meshes.py [--json] [--repeat N]``. Times ``terrain_mesh`` and
``water_mesh`` (at 4, 8 and 16 m cells) on the default scene (best of N runs) and prints
what the draw system uploads: vertex and triangle counts per level of detail and megabytes.
No test asserts on these figures.
"""
from __future__ import annotations

import argparse
import json
import time

import numpy as np

WATER_CELLS_M = (4.0, 8.0, 16.0)


def best_seconds(fn, repeat: int) -> tuple[float, object]:
    """Wall time of the fastest of ``repeat`` calls, and the last call's result."""
    best, out = np.inf, None
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return best, out


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--json", action="store_true", help="print JSON instead of a table")
    parser.add_argument("--repeat", type=int, default=5, help="runs per timing (best is kept)")
    args = parser.parse_args(argv)

    from riverflow.scenes.default import default_scene
    from riverflow.scenes.meshes import lod_indices, terrain_mesh, water_mesh

    results: dict[str, float] = {}
    t0 = time.perf_counter()
    scene = default_scene(seed=0)
    results["default_scene_s"] = time.perf_counter() - t0

    seconds, terrain = best_seconds(lambda: terrain_mesh(scene.terrain), args.repeat)
    results["terrain_mesh_ms"] = 1e3 * seconds
    results["terrain_tiles"] = terrain.positions.shape[0]
    results["terrain_vertices_per_tile"] = terrain.vertices_per_tile
    results["terrain_vertex_MB"] = (terrain.positions.nbytes + terrain.normals.nbytes) / 1e6
    results["terrain_skirt_m_min"] = float(terrain.skirt_m.min())
    results["terrain_skirt_m_max"] = float(terrain.skirt_m.max())
    for level, idx in enumerate(lod_indices(terrain.cells_per_tile)):
        results[f"terrain_triangles_per_tile_level{level}"] = len(idx)
    results["terrain_index_MB_all_levels"] = sum(i.nbytes for i in lod_indices(terrain.cells_per_tile)) / 1e6

    for cell in WATER_CELLS_M:
        seconds, water = best_seconds(lambda: water_mesh(scene, cell_m=cell), args.repeat)
        tag = f"water_{cell:g}m"
        results[f"{tag}_ms"] = 1e3 * seconds
        results[f"{tag}_vertices"] = len(water.positions)
        results[f"{tag}_triangles"] = len(water.indices)
        results[f"{tag}_MB"] = (water.positions.nbytes + water.indices.nbytes) / 1e6
        results[f"{tag}_area_rel_error"] = water.area_m2 / scene.water.polygon.area - 1.0

    if args.json:
        print(json.dumps(results, indent=2))
    else:
        for key, value in results.items():
            print(f"{key:40s} {value:.4g}" if isinstance(value, float) else f"{key:40s} {value}")
    return results


if __name__ == "__main__":
    main()
