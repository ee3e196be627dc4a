"""Water-area benchmark (issue 22): a large water mask read into a river network, on one core.

The mask is made here (no data needed): a ``--cells`` × ``--cells`` GeoTIFF of ``--cell-m``
cells (UTM 33N) holding a meandering river ``--width-m`` wide across it with ``--islands``
elliptic islands (20 - 70 m long) scattered in it, none touching another or a bank.

Timed, each on its own (the process pinned to one core, NUMBA_NUM_THREADS=1), by the wall
clock and by the process's CPU time (equal on a quiet machine):

* read: ``rf.read_water`` (polygonise the mask, simplify, skeleton, direction, discharges);
* build: ``builder.build()`` (end cuts, banks, ψ, the graph checks);
* flow: ``rf.FlowField(graph)`` (the flow network).

Target (issue 22): a 1 500 × 1 500-cell mask with ~100 islands → running world in ≤ 20 s on
one core. Run: ``python benchmarks/bench_water.py`` (``--json out.json`` keeps the figures).
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("NUMBA_NUM_THREADS", "1")

import numpy as np  # noqa: E402
import shapely  # noqa: E402
import shapely.affinity  # noqa: E402

ORIGIN = np.array([500_000.0, 5_000_000.0])


def make_water(cells: int, cell_m: float, width_m: float, islands: int, seed: int = 0):
    """The river (shapely, relative to ORIGIN) and the number of islands placed."""
    rng = np.random.default_rng(seed)
    size = cells * cell_m
    x = np.linspace(0.0, size, 400)
    y = 0.5 * size + 0.2 * size * np.sin(x / size * 3.0 * np.pi)
    centre = shapely.LineString(np.c_[x, y])
    river = centre.buffer(0.5 * width_m, cap_style="flat", quad_segs=16)
    inner = river.buffer(-12.0)
    placed: list = []
    tries = 0
    while len(placed) < islands and tries < 50 * islands:
        tries += 1
        s = rng.uniform(0.05, 0.95) * centre.length
        p = np.array(centre.interpolate(s).coords[0])
        p += rng.uniform(-0.35, 0.35, 2) * width_m
        a, b = rng.uniform(10.0, 35.0), rng.uniform(5.0, 12.0)
        ell = shapely.affinity.rotate(shapely.affinity.scale(shapely.Point(p).buffer(1.0, 8), a, b),
                                      rng.uniform(0, 180))
        if not inner.contains(ell) or any(ell.distance(q) < 12.0 for q in placed):
            continue
        placed.append(ell)
    return river.difference(shapely.union_all(placed)), len(placed), (x[0], y[0])


def write_mask(path: Path, water, cells: int, cell_m: float) -> None:
    import rasterio
    from rasterio import features

    tr = rasterio.Affine(cell_m, 0.0, ORIGIN[0], 0.0, -cell_m, ORIGIN[1] + cells * cell_m)
    data = features.rasterize([shapely.transform(water, lambda p: p + ORIGIN)],
                              out_shape=(cells, cells), transform=tr, dtype=np.uint8)
    with rasterio.open(path, "w", driver="GTiff", width=cells, height=cells, count=1,
                       dtype="uint8", crs="EPSG:32633", transform=tr, compress="deflate") as dst:
        dst.write(data, 1)


def timed(fn):
    w, c = time.perf_counter(), time.process_time()
    out = fn()
    return out, time.perf_counter() - w, time.process_time() - c


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--cells", type=int, default=1500)
    p.add_argument("--cell-m", type=float, default=2.0)
    p.add_argument("--width-m", type=float, default=300.0)
    p.add_argument("--islands", type=int, default=100)
    p.add_argument("--json", type=Path, default=None)
    args = p.parse_args(argv)
    if hasattr(os, "sched_setaffinity"):
        os.sched_setaffinity(0, {min(os.sched_getaffinity(0))})
    import riverflow as rf

    water, placed, inlet = make_water(args.cells, args.cell_m, args.width_m, args.islands)
    figures = {"cells": args.cells, "cell_m": args.cell_m, "islands": placed}
    with tempfile.TemporaryDirectory() as d:
        mask = Path(d) / "mask.tif"
        write_mask(mask, water, args.cells, args.cell_m)
        builder, figures["read_wall_s"], figures["read_cpu_s"] = timed(
            lambda: rf.read_water(mask, inlets=[ORIGIN + inlet]))
        graph, figures["build_wall_s"], figures["build_cpu_s"] = timed(builder.build)
        _, figures["flow_wall_s"], figures["flow_cpu_s"] = timed(lambda: rf.FlowField(graph))
    figures["channels"] = len(builder.report.links)
    figures["islands_read"] = builder.report.derived["islands"]
    figures["curves"] = len(graph.curves)
    figures["total_cpu_s"] = round(figures["read_cpu_s"] + figures["build_cpu_s"]
                                   + figures["flow_cpu_s"], 2)
    figures["total_wall_s"] = round(figures["read_wall_s"] + figures["build_wall_s"]
                                    + figures["flow_wall_s"], 2)
    for k, v in figures.items():
        print(f"{k}: {round(v, 2) if isinstance(v, float) else v}")
    if args.json:
        args.json.write_text(json.dumps(figures, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
