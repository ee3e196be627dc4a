"""Spill benchmark (issue 24): a spill on the 1000 km built-in network run for 24 simulated hours.

The network is the procedural ``default_scene`` whose rivers add up to about ``--network-km``
(1000 km: :func:`~riverflow.scenes.layout.size_for_network_length`, one try); the world is not
drawn (``gl=False``). The spill is released at the head of the main river (its first branch's
first tenth) and run with ``world.advance_spills`` in one-hour chunks. Reported: the network's
cells and the solver's fixed step, the wall and CPU time of the solver's set-up (the cells, the
discharges) and of the 24 hours, the steps taken, cell-updates per second, and the mass
bookkeeping at the end (released = in the water + out + decayed).

Target (the issue): ≤ 30 s wall for the 24 hours on one core, world not drawn. The frame's
share of a drawn world is ``--frame``: the spill system's mean ms per step at
``clock.speed_factor`` 60 (one simulated minute a second) over 600 frames of 1/60 s, with the
plume in the network (its ``timings_ms["spill"]``).

Run: ``NUMBA_NUM_THREADS=1 taskset -c 0 python benchmarks/bench_spill.py`` (``--network-km 100``
for a quicker one, ``--json out.json`` to keep the figures). Figures go to docs/performance.md.
"""
from __future__ import annotations

import argparse
import json
import time


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--network-km", type=float, default=1000.0)
    ap.add_argument("--hours", type=float, default=24.0)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--json", default=None)
    args = ap.parse_args()

    import numpy as np

    import riverflow as rf
    from riverflow.scenes.layout import network_length_m, size_for_network_length

    out: dict = {}
    t0, c0 = time.perf_counter(), time.process_time()
    scene = rf.default_scene(seed=args.seed,
                             size_km=size_for_network_length(args.network_km * 1000.0) / 1000.0)
    world = rf.RiverWorld(scene, size=(64, 36), gl=False, seed=args.seed)
    out["network_km"] = network_length_m(scene.branches) / 1000.0
    out["branches"] = len(scene.branches)
    out["scene_and_world_wall_s"] = time.perf_counter() - t0
    out["scene_and_world_cpu_s"] = time.process_time() - c0

    t0, c0 = time.perf_counter(), time.process_time()
    solver = world.configure_spills()
    net = solver.network
    main = next(b for b in scene.branches if b.kind == "main")
    e = world.add_spill(main.centerline_m[len(main.centerline_m) // 10], 1000.0, name="bench")
    out["setup_wall_s"] = time.perf_counter() - t0
    out["setup_cpu_s"] = time.process_time() - c0
    out["cells"] = net.n_cells
    out["dt_s"] = solver.dt_s

    steps = 0
    t0, c0 = time.perf_counter(), time.process_time()
    hours = 0.0
    while hours < args.hours - 1e-9:
        chunk = min(1.0, args.hours - hours)
        steps += solver.advance(3600.0 * chunk)
        hours += chunk
    out["run_wall_s"] = time.perf_counter() - t0
    out["run_cpu_s"] = time.process_time() - c0
    out["steps"] = steps
    out["cell_updates_per_s"] = steps * net.n_cells / max(out["run_cpu_s"], 1e-9)
    r = world.spill(e)
    out["released_kg"] = r.released_kg
    out["in_water_kg"] = r.in_water_kg
    out["out_kg"] = sum(r.out_kg.values())
    out["balance_kg"] = r.balance_kg
    out["front_km"] = r.front_m / 1000.0

    # the frame's share: the spill system at 60x, 600 frames
    world.speed_factor = 60.0
    for _ in range(10):
        world.step(1 / 60)
    ms = []
    for _ in range(600):
        world.step(1 / 60)
        ms.append(world.timings_ms["spill"])
    out["frame_spill_ms_mean"] = float(np.mean(ms))
    out["frame_spill_ms_p99"] = float(np.percentile(ms, 99))
    out["frame_spill_ms_max"] = float(np.max(ms))
    world.close()
    for k, v in out.items():
        print(f"{k:>24}: {v:.6g}" if isinstance(v, float) else f"{k:>24}: {v}")
    if args.json:
        with open(args.json, "w") as f:
            json.dump(out, f, indent=2)


if __name__ == "__main__":
    main()
