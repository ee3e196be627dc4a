"""Lake benchmark (issue 22, item 2): what a lake costs the builder and the flow tiles.

A round lake of radius ``--radius-m`` with two inlets and one outlet (the lake of
``tests/hydro/test_lakes.py`` scaled), against the same three rivers ending on free ends
where the lake's shore was. A lake's axes are as wide as the lake, so its river network's
search radius (5 × its widest axis) grows with it and every bank of that network is a
candidate in every flow tile near it.

Timed by the wall clock and by the process's CPU time (NUMBA_NUM_THREADS=1):

* build: ``builder.build()``;
* tiles: ``rf.FlowField(graph)`` and a first query of a grid over the network (every finest
  flow tile there made, at ``--delta-m`` lattice spacing);
* query: the same query again (cached tiles).

Run: ``python benchmarks/bench_lakes.py`` (``--radius-m 600`` for a larger lake).
"""
from __future__ import annotations

import argparse
import os
import time

os.environ.setdefault("NUMBA_NUM_THREADS", "1")

import numpy as np  # noqa: E402
import shapely  # noqa: E402


def networks(radius_m: float):
    from riverflow.hydro.builder import RiverNetworkBuilder

    r = radius_m
    west = [(-4 * r, 0.8 * r), (-2 * r, 0.4 * r), (-0.6 * r, 0.13 * r)]
    south = [(-0.6 * r, -4 * r), (-0.4 * r, -2 * r), (-0.15 * r, -0.6 * r)]
    out = [(0.6 * r, 0.07 * r), (2.3 * r, 0.27 * r), (4.6 * r, 0.0)]
    lake = RiverNetworkBuilder()
    lake.add_branch(west, 30.0, discharge_m2s=20.0)
    lake.add_branch(south, 24.0, discharge_m2s=10.0)
    lake.add_branch(out, 36.0)
    lake.add_lake(shapely.Point(0, 0).buffer(r, quad_segs=24))
    rivers = RiverNetworkBuilder()
    rivers.add_branch(west[:2] + [(-1.07 * r, 0.21 * r)], 30.0, discharge_m2s=20.0)
    rivers.add_branch(south[:2] + [(-0.23 * r, -1.07 * r)], 24.0, discharge_m2s=10.0)
    rivers.add_branch([(1.07 * r, 0.09 * r)] + out[1:], 36.0, discharge_m2s=30.0)
    return {"lake": lake, "rivers only": rivers}


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--radius-m", type=float, default=150.0)
    p.add_argument("--delta-m", type=float, default=None,
                   help="ψ-lattice spacing [m] (default: the radius / 150, as many tiles for "
                        "any radius)")
    args = p.parse_args()
    import riverflow as rf

    r = args.radius_m
    xs = np.linspace(-4.5 * r, 4.5 * r, 300)
    ys = np.linspace(-4.2 * r, 1.3 * r, 200)
    gx, gy = np.meshgrid(xs, ys)
    grid = np.c_[gx.ravel(), gy.ravel()]
    rf.FlowField(networks(r)["rivers only"].build()).query(grid[:10])     # compile, warm
    for name, builder in networks(r).items():
        c0, w0 = time.process_time(), time.perf_counter()
        graph = builder.build()
        c1, w1 = time.process_time(), time.perf_counter()
        field = rf.FlowField(graph, potential_delta_m=args.delta_m or r / 150.0)
        status, _ = field.query(grid)
        c2, w2 = time.process_time(), time.perf_counter()
        field.query(grid)
        c3, w3 = time.process_time(), time.perf_counter()
        net = field.network
        print(f"{name:12s} build {c1 - c0:6.3f} s CPU ({w1 - w0:6.3f} wall)  tiles "
              f"{c2 - c1:6.3f} s CPU ({w2 - w1:6.3f} wall)  cached query of {len(grid)} points "
              f"{(c3 - c2) * 1e3:6.2f} ms CPU  | search radius {net.comp_radius.max():7.1f} m, "
              f"{net.n_segments} segments, {int((status == 1).sum())} points in the water")


if __name__ == "__main__":
    main()
