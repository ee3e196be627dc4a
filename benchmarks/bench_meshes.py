"""Mesh benchmark: the per-tile meshes the draw system uploads, on the default scene.

Run: ``python benchmarks/bench_meshes.py [--json] [--repeat N]``. For the tiles with water at
the finest level and one level up (the tiles a view over the river asks for), it times the
producers of the two mesh kinds, best of N runs per tile, then the median and the largest
over the tiles:

* ``terrain_mesh``: :class:`~riverflow.scenes.tile_kinds.TerrainMeshProducer`
  (:func:`~riverflow.scenes.meshes.tile_terrain_mesh`: normals, skirt, vertex layout) from the
  tile's height and water tiles, which are made beforehand (and timed too: ``height``,
  ``water``);
* ``water_mesh``: :class:`~riverflow.scenes.tile_kinds.WaterMeshProducer`
  (:func:`~riverflow.scenes.meshes.triangulate_water` of the tile's piece of the water polygon
  on WATER_MESH_CELLS cells per side, and the terrain height under each vertex) with the piece
  already cut; ``water_piece_cold``: cutting a piece from nothing (the whole polygon down
  through the tile's ancestors), as the first tile of a region pays it.

It also prints what is uploaded: vertices, triangles and kilobytes per tile, the skirt depths
and the index buffer all terrain tiles share. No test asserts on these figures.
"""
from __future__ import annotations

import argparse
import json
import time

import numpy as np


def best_seconds(fn, repeat: int) -> tuple[float, object]:
    """Wall time of the fastest of ``repeat`` calls, and the last call's result."""
    best, out = np.inf, None
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return best, out


def _summary(results: dict, tag: str, values) -> None:
    v = np.asarray(values, np.float64)
    results[f"{tag}_median"] = float(np.median(v))
    results[f"{tag}_max"] = float(v.max())


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--json", action="store_true", help="print JSON instead of a table")
    parser.add_argument("--repeat", type=int, default=5, help="runs per timing (best is kept)")
    args = parser.parse_args(argv)

    from riverflow.scenes.default import default_scene
    from riverflow.scenes.meshes import tile_indices
    from riverflow.scenes.tile_kinds import (HEIGHT, WATER, HeightProducer, LandscapeTiles,
                                             PolygonPieces, TerrainMeshProducer,
                                             WaterMeshProducer, WaterProducer)

    results: dict[str, float] = {}
    t0 = time.perf_counter()
    scene = default_scene(seed=0)
    results["default_scene_s"] = time.perf_counter() - t0
    tiles = LandscapeTiles(scene)
    q = tiles.quadtree
    heights, waters = HeightProducer(tiles), WaterProducer(tiles)
    terrain_p, water_p = TerrainMeshProducer(tiles), WaterMeshProducer(tiles)

    indices = tile_indices(tiles.n)
    results["cells_per_tile"] = tiles.n
    results["terrain_triangles_per_tile"] = len(indices)
    results["terrain_index_kB"] = indices.nbytes / 1e3

    for level in (tiles.max_level, tiles.max_level - 1):
        keys = [(level, tx, ty) for tx in range(1 << level) for ty in range(1 << level)
                if tiles.has_water((level, tx, ty))]
        tag = f"L{level}"
        results[f"{tag}_tile_m"] = q.tile_size_m(level)
        results[f"{tag}_tiles_with_water"] = len(keys)
        ms = {k: [] for k in ("height", "water", "terrain_mesh", "water_mesh", "water_piece_cold")}
        skirts, terrain_kb, water_tris, water_verts, water_kb = [], [], [], [], []
        for key in keys:
            s, height = best_seconds(lambda: heights.produce(key, {}), args.repeat)
            ms["height"].append(1e3 * s)
            s, water = best_seconds(lambda: waters.produce(key, {}), args.repeat)
            ms["water"].append(1e3 * s)
            deps = {(HEIGHT, key): height, (WATER, key): water}
            s, mesh = best_seconds(lambda: terrain_p.produce(key, deps), args.repeat)
            ms["terrain_mesh"].append(1e3 * s)
            skirts.append(mesh.skirt_m)
            terrain_kb.append(terrain_p.nbytes(mesh) / 1e3)
            t0 = time.perf_counter()
            PolygonPieces(scene.water.polygon, q).piece(key)
            ms["water_piece_cold"].append(1e3 * (time.perf_counter() - t0))
            tiles.pieces.piece(key)  # cut once: the timings below triangulate only
            s, got = best_seconds(lambda: water_p.produce(key, {}), args.repeat)
            ms["water_mesh"].append(1e3 * s)
            wmesh, _ = got
            water_tris.append(len(wmesh.indices))
            water_verts.append(len(wmesh.positions))
            water_kb.append(water_p.nbytes(got) / 1e3)
        for name, values in ms.items():
            _summary(results, f"{tag}_{name}_ms", values)
        results[f"{tag}_terrain_vertices_per_tile"] = len(mesh.vertices)
        _summary(results, f"{tag}_terrain_kB_per_tile", terrain_kb)
        results[f"{tag}_skirt_m_min"] = float(min(skirts))
        results[f"{tag}_skirt_m_max"] = float(max(skirts))
        _summary(results, f"{tag}_water_triangles_per_tile", water_tris)
        _summary(results, f"{tag}_water_vertices_per_tile", water_verts)
        _summary(results, f"{tag}_water_kB_per_tile", water_kb)

    if args.json:
        print(json.dumps(results, indent=2))
    else:
        for key, value in results.items():
            print(f"{key:40s} {value:.4g}" if isinstance(value, float) else f"{key:40s} {value}")
    return results


if __name__ == "__main__":
    main()
