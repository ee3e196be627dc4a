"""Frame cost of every simulation system (all but drawing) on a scripted chase flight.

Run: ``make bench`` or ``python benchmarks/bench_systems.py [--json] [--frames N]``. Issue
targets (one core of the 2-core machine): ≤ 1 ms a frame at 1920×1080 with r = 10 px and ≤ 3 ms
with r = 5 px (median over the flight). Figures go to docs/performance.md.
"""
from __future__ import annotations

import argparse
import json

import riverflow as rf
from riverflow.engine.profiling import format_profile, profile_flight

CASES = (((1920, 1080), 10.0), ((1920, 1080), 5.0), ((640, 360), 5.0))


def main(argv: list[str] | None = None) -> list[dict]:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--json", action="store_true")
    parser.add_argument("--frames", type=int, default=300)
    args = parser.parse_args(argv)
    scene = rf.default_scene(seed=0)
    results = []
    for size, radius in CASES:
        result = profile_flight(scene, size, radius, args.frames, warmup=120)
        results.append(result)
        if not args.json:
            print(format_profile(result), end="\n\n", flush=True)
    if args.json:
        print(json.dumps(results, indent=2))
    return results


if __name__ == "__main__":
    main()
