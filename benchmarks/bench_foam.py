"""Foam and wake benchmark: what the particles' foam and the boats' wakes cost a frame.

Run: ``make bench`` or ``python benchmarks/bench_foam.py [--json] [--frames N]``. One core.

* simulation (no drawing): the demo's boat at full throttle down the main river, a chase
  camera, 1920×1080 with r = 10 px (the design's performance case): the "foam" and "wake"
  systems' milliseconds a frame (wall clock, as the HUD shows them) and the foam kernel's
  own CPU time (``time.thread_time``: a loaded machine's waits left out), with the particles
  it looked at;
* drawing (OpenGL; Mesa's llvmpipe on a machine with no GPU): the same view at 640×360 (or
  ``--draw-size``), the CPU work of a drawn and read-back frame with foam and the wake on,
  and with each off (the foam off: ``FoamSettings.enabled``; the wake off: no boat in the
  wake table), so the water shader's share of each shows.

Figures go to docs/performance.md; no test asserts on them.
"""
from __future__ import annotations

import argparse
import json
import math
import time

import numpy as np


def _chase(world, boat) -> None:
    f = np.array([math.cos(boat.heading_rad), math.sin(boat.heading_rad), 0.0])
    c = np.array([*boat.position_m, boat.altitude_m])
    world.camera.look_at(c - 22.0 * f + (0.0, 0.0, 9.0), c + 6.0 * f)


def _world(size, gl: bool, radius_px: float = 10.0):
    import shapely

    import riverflow as rf
    from riverflow.engine.config import RiverConfig
    from riverflow.scenes.flight import main_centerline

    scene = rf.default_scene(seed=0)
    line = shapely.LineString(main_centerline(scene))
    start = np.array(line.interpolate(1500.0).coords[0])
    ahead = np.array(line.interpolate(1510.0).coords[0])
    world = rf.RiverWorld(scene, size=size, gl=gl,
                          config=RiverConfig(radius_px=radius_px, tile_production="blocking"))
    entity = world.add_boat(start, math.atan2(*(ahead - start)[::-1]), throttle=1.0)
    return world, world.boat(entity), entity


def simulation(frames: int) -> dict[str, float]:
    import riverflow.systems.foam as system

    kernel_cpu: list[float] = []
    counts: list[tuple] = []
    update = system.update_foam

    def timed(*args):
        t0 = time.thread_time()
        out = update(*args)
        kernel_cpu.append(time.thread_time() - t0)
        counts.append(out)
        return out

    system.update_foam = timed
    try:
        world, boat, _ = _world((1920, 1080), gl=False)
        foam_ms, wake_ms = [], []
        for frame in range(frames + 120):
            _chase(world, boat)
            world.step(1 / 60)
            if frame >= 120:
                foam_ms.append(world.timings_ms["foam"])
                wake_ms.append(world.timings_ms["wake"])
        water = int((world.particles.status == 1).sum())
        live = len(world.particles)
        world.close()
    finally:
        system.update_foam = update
    cpu = np.array(kernel_cpu[-frames:]) * 1e3
    c = np.array(counts[-frames:], float)
    return {"foam_system_ms_median": float(np.median(foam_ms)),
            "foam_system_ms_p95": float(np.percentile(foam_ms, 95)),
            "foam_kernel_cpu_ms_median": float(np.median(cpu)),
            "foam_kernel_cpu_ms_p95": float(np.percentile(cpu, 95)),
            "wake_system_ms_median": float(np.median(wake_ms)),
            "particles_live": live, "particles_in_water": water,
            "river_terms_per_frame": float(c[:, 0].mean()),
            "hull_terms_per_frame": float(c[:, 1].mean()),
            "new_particles_per_frame": float(c[:, 2].mean())}


def drawing(frames: int, size=(640, 360)) -> dict[str, float]:
    """CPU work (this process's CPU time: every llvmpipe thread's work) of a drawn and read
    back frame in four cases, interleaved frame by frame so that a loaded machine's drift
    falls on all alike: foam and the wake on, the wake off, the foam off, both off."""
    from riverflow.components.wake import Wakes

    world, boat, entity = _world(size, gl=True, radius_px=10.0)
    for _ in range(300):
        _chase(world, boat)
        world.step(1 / 60)
    wakes = world.resource(Wakes)
    table, hulls = wakes.table, wakes.hulls
    cases = {"foam_and_wake": (True, True), "foam_no_wake": (True, False),
             "wake_no_foam": (False, True), "no_foam_no_wake": (False, False)}
    cpu: dict[str, list[float]] = {k: [] for k in cases}
    for k, (foam, wake) in cases.items():       # first draws (shader variants, uploads)
        world.foam.enabled = foam
        world.render()
    for _ in range(frames):
        for k, (foam, wake) in cases.items():
            world.foam.enabled = foam
            world.foam.shoreline = 0.8 if foam else 0.0
            wakes.table, wakes.hulls = (table, hulls) if wake else (table[:0], hulls[:0])
            t0 = time.process_time()
            world.render()
            cpu[k].append(time.process_time() - t0)
    world.close()
    out = {f"draw_cpu_ms_{k}": float(np.median(v) * 1e3) for k, v in cpu.items()}
    out["draw_size"] = f"{size[0]}x{size[1]}"
    return out


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--json", action="store_true", help="print JSON instead of a table")
    parser.add_argument("--frames", type=int, default=600)
    parser.add_argument("--draw-frames", type=int, default=30)
    parser.add_argument("--draw-size", default="640x360", help="WxH of the drawn frames")
    parser.add_argument("--no-draw", action="store_true", help="simulation figures only")
    parser.add_argument("--no-sim", action="store_true", help="drawing figures only")
    args = parser.parse_args(argv)
    results = {} if args.no_sim else simulation(args.frames)
    if not args.no_draw:
        w, h = (int(v) for v in args.draw_size.split("x"))
        results.update(drawing(args.draw_frames, (w, h)))
    if args.json:
        print(json.dumps(results, indent=2))
    else:
        for k, v in results.items():
            print(f"{k:32s} {v:12,.3f}" if isinstance(v, float) else f"{k:32s} {v:>12}")
    return results


if __name__ == "__main__":
    main()
