"""Time of the river-network builder (``RiverNetworkBuilder.build``) on the default scene's
network and on a large procedural one, with the junction corners rounded (the default) and
sharp (``fillet_fraction=0``).

Run: ``python benchmarks/bench_builder.py [--json] [--repeat N] [--large-km K]``. The layouts
are made once (``riverflow.scenes.layout``); each build is timed alone, the fastest of
``--repeat`` runs reported. Figures go to docs/performance.md.
"""
from __future__ import annotations

import argparse
import json
import time

import numpy as np

from riverflow.hydro.builder import RiverNetworkBuilder
from riverflow.scenes.layout import DEFAULT_SIZE_M, layout


def _build(branches, islands, fillet_fraction: float):
    builder = RiverNetworkBuilder(tolerance_m=0.25, fillet_fraction=fillet_fraction)
    for b in branches:
        builder.add_branch(b.centerline_m, b.widths_m, b.discharge_m2s, name=b.name)
    for outline in islands:
        builder.add_island(outline)
    t0 = time.perf_counter()
    graph = builder.build()
    return time.perf_counter() - t0, graph


def run_case(size_m: float, repeat: int, seed: int = 0) -> dict:
    branches, islands = layout(np.random.default_rng(seed), size_m)
    length_km = sum(float(np.hypot(*np.diff(b.centerline_m, axis=0).T).sum())
                    for b in branches) / 1000.0
    out = {"size_km": size_m / 1000.0, "branches": len(branches), "network_km": length_km}
    for label, fraction in (("sharp", 0.0), ("rounded", None)):
        times = []
        for _ in range(repeat):
            dt, graph = _build(branches, islands,
                               RiverNetworkBuilder().fillet_fraction if fraction is None
                               else fraction)
            times.append(dt)
        out[label] = {"best_s": min(times), "median_s": float(np.median(times)),
                      "curves": len(graph.curves)}
    return out


def main(argv: list[str] | None = None) -> list[dict]:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--json", action="store_true")
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--large-km", type=float, default=50.0)
    args = parser.parse_args(argv)
    results = []
    for size_m in (DEFAULT_SIZE_M, 1000.0 * args.large_km):
        r = run_case(size_m, args.repeat)
        results.append(r)
        if not args.json:
            print(f"{r['size_km']:.0f} km square, {r['branches']} branches, "
                  f"{r['network_km']:.1f} km of river: build sharp {r['sharp']['best_s']:.3f} s, "
                  f"rounded {r['rounded']['best_s']:.3f} s (best of {args.repeat})", flush=True)
    if args.json:
        print(json.dumps(results, indent=2))
    return results


if __name__ == "__main__":
    main()
