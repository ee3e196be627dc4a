"""Wave-tile generation: seconds per constructor, first call (JIT compile or cache load) and warm.

Run: ``make bench`` or ``python benchmarks/bench_waves.py [--json]``. "cold" is the first call in
a fresh process with an empty numba cache (compile), "cached" the first call in a fresh process
with that cache filled, "warm" the best of five calls once compiled. One core (serial kernels).
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile

CONSTRUCTORS = {
    "perlin_wave_tile()  256², 1 frame": "cw.perlin_wave_tile()",
    "animated_wave_tile() 128², 32 frames": "cw.animated_wave_tile()",
    "default_static_wave_tile() 256²": "cw.default_static_wave_tile()",
    "static_wave_tile(array 256²)": "cw.static_wave_tile(np.ones((256, 256, 2)))",
}

TIMED_CALLS = """
import time, numpy as np
from riverflow.components import waves as cw
t0 = time.perf_counter()
{call}
first = time.perf_counter() - t0
best = float("inf")
for _ in range({repeat}):
    t0 = time.perf_counter()
    {call}
    best = min(best, time.perf_counter() - t0)
print(first, best)
"""


def timed_calls_s(call: str, cache_dir: str, repeat: int = 5) -> tuple[float, float]:
    """(first call, fastest of ``repeat`` more) seconds of ``call`` in a fresh process using
    ``cache_dir`` as numba's cache."""
    env = dict(os.environ, NUMBA_CACHE_DIR=cache_dir)
    script = TIMED_CALLS.format(call=call, repeat=repeat)
    out = subprocess.run([sys.executable, "-c", script], env=env, check=True,
                         capture_output=True, text=True).stdout.split()
    return float(out[-2]), float(out[-1])


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--json", action="store_true", help="print JSON instead of a table")
    args = parser.parse_args(argv)
    results: dict[str, dict[str, float]] = {}
    for name, call in CONSTRUCTORS.items():
        with tempfile.TemporaryDirectory() as cache:
            cold, warm = timed_calls_s(call, cache)
            cached, _ = timed_calls_s(call, cache, repeat=0)
        results[name] = {"cold_s": cold, "cached_s": cached, "warm_s": warm}
    if args.json:
        print(json.dumps(results, indent=2))
    else:
        print(f"{'constructor':40s} {'cold [s]':>9s} {'cached [s]':>11s} {'warm [ms]':>10s}")
        for name, r in results.items():
            print(f"{name:40s} {r['cold_s']:9.2f} {r['cached_s']:11.2f} {1e3 * r['warm_s']:10.1f}")
    return results


if __name__ == "__main__":
    main()
