"""Profiling: run a scripted flight and summarise the per-system frame times.

``riverflow profile`` and ``benchmarks/bench_systems.py`` call :func:`profile_flight`.
"""
from __future__ import annotations

import numpy as np

from riverflow.engine.config import RiverConfig
from riverflow.engine.world import RiverWorld
from riverflow.scenes.flight import fly


def profile_flight(scene, size: tuple[int, int], radius_px: float, frames: int, *,
                   warmup: int = 60, seed: int = 0, tile_production: str = "background",
                   capacity: int | None = None) -> dict:
    """Fly ``warmup + frames`` frames at 1/60 s; statistics of the last ``frames``.

    Returns {"systems": {name: {"mean_ms", "p50_ms", "p95_ms"}}, "total": {...},
    "particles": {"mean", "min", "max"}, "size": [W, H], "radius_px", "frames"}.
    """
    w, h = size
    if capacity is None:
        capacity = max(1024, int(1.5 * 0.87 * w * h / (2 * radius_px) ** 2))
    config = RiverConfig(radius_px=radius_px, capacity=capacity, tile_production=tile_production)
    world = RiverWorld(scene, size=size, seed=seed, config=config)
    times: dict[str, list[float]] = {}
    counts: list[int] = []

    def record(frame: int, wld: RiverWorld) -> None:
        if frame < warmup:
            return
        for name, ms in wld.timings_ms.items():
            times.setdefault(name, []).append(ms)
        counts.append(wld.pool.count)

    try:
        fly(world, warmup + frames, callback=record)
    finally:
        world.close()

    def stats(values) -> dict:
        v = np.asarray(values, float)
        return {"mean_ms": float(v.mean()), "p50_ms": float(np.median(v)),
                "p95_ms": float(np.percentile(v, 95))}

    total = np.sum([times[k] for k in times], axis=0)
    return {"systems": {k: stats(v) for k, v in times.items()}, "total": stats(total),
            "particles": {"mean": float(np.mean(counts)), "min": int(np.min(counts)),
                          "max": int(np.max(counts))},
            "size": [int(w), int(h)], "radius_px": float(radius_px), "frames": int(frames)}


def format_profile(result: dict) -> str:
    """A table of :func:`profile_flight`'s result."""
    w, h = result["size"]
    lines = [f"{w}x{h}, r = {result['radius_px']:g} px, {result['frames']} frames, particles "
             f"mean {result['particles']['mean']:.0f} (min {result['particles']['min']}, "
             f"max {result['particles']['max']})",
             f"{'system':<12} {'mean ms':>9} {'p50 ms':>9} {'p95 ms':>9}"]
    for name, s in [*result["systems"].items(), ("total", result["total"])]:
        lines.append(f"{name:<12} {s['mean_ms']:9.3f} {s['p50_ms']:9.3f} {s['p95_ms']:9.3f}")
    return "\n".join(lines)
