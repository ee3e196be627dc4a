"""Flood benchmark (issue 25): what routing a hydrograph costs a frame.

Two parts, one core, CPU time (``time.process_time``) next to wall time:

1. **Routing** on the procedural built-in network of about ``--network-km`` of rivers (world
   not drawn): a flood hydrograph on every source (base → 5× base over 10 min, back over an
   hour) routed for ``--hours`` of world time with ``FloodRouter.advance`` in one-hour chunks:
   cells, fixed step, cell-updates per second; then the "flood" system's ms per frame over
   600 frames of 1/60 s (``timings_ms["flood"]``: most frames take no step, the step being
   seconds long).
2. **The flow's speed factor** at 1920×1080, r = 10 px (the built-in 4 km scene, default
   camera, ``gl=False``): ``timings_ms["advection"]`` per frame over ``--frames`` frames
   with no flood, then the same frames with a flood on screen (every velocity the particles
   ask for is scaled: :meth:`FloodRouter.scale_velocity`), and the scaling's own time per
   frame (timed by wrapping it).

3. **The drawn flood** (``--draw``, headless GL): the built-in scene at 1920×1080, default
   camera: the step + render CPU time and the draw system's ``timings_ms["draw"]`` (medians
   over ``--draw-frames``) with no flood, the first frame of a 4× flood (the router's level
   texture made and uploaded), then the same medians with the flood drawn (the water raised,
   the banks flooded).

Target (the issue brief): the routing's frame cost ≤ 0.3 ms at 1080p, one core.

Run: ``NUMBA_NUM_THREADS=1 taskset -c 0 python benchmarks/bench_flood.py`` (``--json out.json``
to keep the figures). Figures go to docs/performance.md.
"""
from __future__ import annotations

import argparse
import json
import time


def _flood(world, peak: float = 5.0) -> None:
    world.set_hydrograph(None, [], None)                # makes the router
    router = world.flood
    sources = [b for b in range(len(router.network.names)) if router.net.link_start[b] < 0]
    router_q = float(router.net.link_q0[sources].sum())
    now = world.clock.now_s
    world.set_hydrograph(None, [now, now + 600.0, now + 3600.0],
                         [router_q, peak * router_q, router_q])


def routing(network_km: float, hours: float, seed: int) -> dict:
    import numpy as np

    import riverflow as rf
    from riverflow.scenes.layout import network_length_m, size_for_network_length

    out: dict = {}
    scene = rf.default_scene(seed=seed,
                             size_km=size_for_network_length(network_km * 1000.0) / 1000.0)
    world = rf.RiverWorld(scene, size=(64, 36), gl=False, seed=seed)
    out["network_km"] = network_length_m(scene.branches) / 1000.0
    t0, c0 = time.perf_counter(), time.process_time()
    _flood(world)
    router = world.flood
    out["setup_wall_s"] = time.perf_counter() - t0
    out["setup_cpu_s"] = time.process_time() - c0
    out["cells"] = router.network.n_cells
    out["dt_s"] = router.dt_s
    steps0 = router.time_s
    t0, c0 = time.perf_counter(), time.process_time()
    for _ in range(int(hours)):
        router.advance(3600.0)
    out["route_wall_s"] = time.perf_counter() - t0
    out["route_cpu_s"] = time.process_time() - c0
    steps = (router.time_s - steps0) / router.dt_s
    out["cell_updates_per_cpu_s"] = steps * out["cells"] / max(out["route_cpu_s"], 1e-9)
    ms = []
    for _ in range(600):
        world.step(1 / 60)
        ms.append(world.timings_ms["flood"])
    out["frame_flood_ms_mean"] = float(np.mean(ms))
    out["frame_flood_ms_max"] = float(np.max(ms))
    world.close()
    return out


def speed_factor(frames: int, seed: int) -> dict:
    import numpy as np

    import riverflow as rf
    from riverflow.hydro import flood as flood_module

    out: dict = {}
    world = rf.RiverWorld(rf.default_scene(seed=seed), size=(1920, 1080), gl=False, seed=seed)
    world.load_view()
    for _ in range(30):
        world.step(1 / 60)
    base_ms, base_cpu = [], []
    for _ in range(frames):
        c0 = time.process_time()
        world.step(1 / 60)
        base_cpu.append((time.process_time() - c0) * 1e3)
        base_ms.append(world.timings_ms["advection"])
    spent_wall, spent_cpu, points = [], [], []
    original = flood_module.FloodRouter.scale_velocity

    def timed(self, xy, status, velocity, n=None):
        w0, c0 = time.perf_counter_ns(), time.process_time_ns()
        try:
            return original(self, xy, status, velocity, n)
        finally:
            spent_wall.append((time.perf_counter_ns() - w0) * 1e-6)
            spent_cpu.append((time.process_time_ns() - c0) * 1e-6)
            points.append(len(xy) if n is None else n)

    flood_module.FloodRouter.scale_velocity = timed
    try:
        _flood(world)
        world.flood.advance(1200.0)                     # the wave is in the view
        for _ in range(30):
            world.step(1 / 60)
        spent_wall.clear(), spent_cpu.clear(), points.clear()
        flood_ms, flood_cpu, flood_sys = [], [], []
        for _ in range(frames):
            c0 = time.process_time()
            world.step(1 / 60)
            flood_cpu.append((time.process_time() - c0) * 1e3)
            flood_ms.append(world.timings_ms["advection"])
            flood_sys.append(world.timings_ms["flood"])
    finally:
        flood_module.FloodRouter.scale_velocity = original
    out["particles"] = len(world.particles)
    out["active"] = bool(world.flood.active)
    out["advection_ms_no_flood_median"] = float(np.median(base_ms))
    out["advection_ms_flood_median"] = float(np.median(flood_ms))
    out["step_cpu_ms_no_flood_median"] = float(np.median(base_cpu))
    out["step_cpu_ms_flood_median"] = float(np.median(flood_cpu))
    out["flood_system_ms_mean"] = float(np.mean(flood_sys))
    out["scale_calls_per_frame"] = len(spent_wall) / frames
    out["scale_points_per_frame"] = float(np.sum(points)) / frames
    out["scale_wall_ms_per_frame"] = float(np.sum(spent_wall)) / frames
    out["scale_cpu_ms_per_frame"] = float(np.sum(spent_cpu)) / frames
    out["scale_wall_ms_per_call_max"] = float(np.max(spent_wall)) if spent_wall else 0.0
    world.close()
    return out


def drawn(frames: int, seed: int) -> dict:
    import numpy as np

    import riverflow as rf

    world = rf.RiverWorld(rf.default_scene(seed=seed), size=(1920, 1080), gl=True, seed=seed)
    world.load_view()
    for _ in range(30):
        world.step(1 / 60)
        world.render()

    def run():
        draw, cpu = [], []
        for _ in range(frames):
            c0 = time.process_time()
            world.step(1 / 60)
            world.render()
            cpu.append((time.process_time() - c0) * 1e3)
            draw.append(world.timings_ms["draw"])
        return float(np.median(draw)), float(np.median(cpu))

    out: dict = {}
    out["draw_ms_no_flood_median"], out["frame_cpu_ms_no_flood_median"] = run()
    _flood(world, peak=4.0)
    world.flood.advance(3600.0)
    c0, w0 = time.process_time(), time.perf_counter()
    world.step(1 / 60)
    world.render()
    out["first_flood_frame_cpu_s"] = time.process_time() - c0
    out["first_flood_frame_wall_s"] = time.perf_counter() - w0
    out["draw_ms_flood_median"], out["frame_cpu_ms_flood_median"] = run()
    world.close()
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--network-km", type=float, default=100.0)
    ap.add_argument("--hours", type=float, default=6.0)
    ap.add_argument("--frames", type=int, default=120)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--json", default=None)
    ap.add_argument("--draw", action="store_true", help="also time the drawn flood (GL)")
    ap.add_argument("--draw-frames", type=int, default=40)
    args = ap.parse_args()
    out = {**routing(args.network_km, args.hours, args.seed), **speed_factor(args.frames,
                                                                              args.seed)}
    if args.draw:
        out.update(drawn(args.draw_frames, args.seed))
    for k, v in out.items():
        print(f"{k:>32}: {v:.6g}" if isinstance(v, float) else f"{k:>32}: {v}")
    if args.json:
        with open(args.json, "w") as f:
            json.dump(out, f, indent=2)


if __name__ == "__main__":
    main()
