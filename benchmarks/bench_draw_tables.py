"""CPU side of drawing: the sprite table and bins alone (kernels/sprites.py).

Run: ``python benchmarks/bench_draw_tables.py [--json] [--runs N]``. At 1920×1080 with
r = 10 px (~4,050 particles) and r = 5 px (~15,750), particles spread like a Poisson disk of
radius r (a jittered grid of spacing 2r·1.07, the band of the screen nearest its horizontal
mid-line: a river across the view), in random slot order (as in a running pool, whose slots
are reused in no spatial order) and, for comparison, in row-major screen order (the best case
for the caches); a ``drawn`` share of them INSIDE (the rest NEAR or OUTSIDE: in the table for
the particle and arrow overlays, not sorted into bins; left out with the overlays off): 1.0 is
the worst case, ~0.25 what the chase flight shows.
Prints the median of ``--runs`` calls of ``build_sprite_tables`` after warm-up, the bytes a
frame uploads (whole table rows + the bins) and a same-size memory copy of those bytes (a
floor on what handing them to the driver costs). Issue target (issue 12, item 6): the CPU side
of drawing ≤ 1 ms at 1920×1080 with r = 5 px, one core.
"""
from __future__ import annotations

import argparse
import json
import os
import time

os.environ.setdefault("NUMBA_NUM_THREADS", "1")

import numpy as np  # noqa: E402

CASES = (((1920, 1080), 10.0, 4_050), ((1920, 1080), 5.0, 15_750))


def median_ms(fn, runs: int) -> float:
    """Median wall time of ``runs`` calls [ms], after three warm-up calls."""
    for _ in range(3):
        fn()
    times = np.empty(runs)
    for k in range(runs):
        t0 = time.perf_counter()
        fn()
        times[k] = time.perf_counter() - t0
    return float(1e3 * np.median(times))


def poisson_like_screen(rng, width: int, height: int, radius: float, count: int) -> np.ndarray:
    """``count`` points ~2r·1.07 apart (jittered grid), the ones nearest the mid-line, in
    row-major order."""
    step = 2.0 * radius * 1.07
    xs = np.arange(0.0, width, step)
    ys = np.arange(0.0, height, step)
    pts = np.stack(np.meshgrid(xs, ys), -1).reshape(-1, 2)
    pts += rng.uniform(0.0, 0.3 * step, pts.shape)
    pts = pts[(pts[:, 0] < width) & (pts[:, 1] < height)]
    keep = np.argsort(np.abs(pts[:, 1] - 0.5 * height), kind="stable")[:count]
    return pts[np.sort(keep)]


def run_case(size: tuple[int, int], radius: float, count: int, runs: int,
             slot_order: str = "random", drawn: float = 1.0, with_tail: bool = True) -> dict:
    from riverflow.components.particles import ParticlePool
    from riverflow.components.status import FlowStatus
    from riverflow.kernels import sprites as ks

    width, height = size
    rng = np.random.default_rng(0)
    pts = poisson_like_screen(rng, width, height, radius, count)
    n = len(pts)
    if slot_order == "random":
        pts = pts[rng.permutation(n)]
    pool = ParticlePool(int(n * 1.5))
    pool.alive[:n] = True
    pool.has_world[:n] = True
    pool.status[:n] = np.where(rng.random(n) < drawn, FlowStatus.INSIDE, FlowStatus.NEAR)
    pool.screen_px[:n] = pts
    pool.world_m[:n] = rng.uniform(-2000.0, 2000.0, (n, 3))
    pool.offset_m[:n] = rng.uniform(-10.0, 10.0, (n, 2))
    pool.velocity_mps[:n] = rng.uniform(-2.0, 2.0, (n, 2))
    pool.intensity[:n] = 1.0 - rng.random(n)  # (0, 1]

    bins = ks.sprite_bins(width, height, radius)
    params, starts, scratch = ks.empty_sprite_tables(pool.capacity, bins)
    src = ks.sprite_source(pool)
    n_slots = ks.slot_span(pool.alive)

    def build():
        return ks.build_sprite_tables(src, radius, n_slots, bins, params, starts, scratch,
                                      with_tail)

    n_drawn, n_entries, rows = build()
    table_bytes = rows * params.shape[1] * params.shape[2] * params.itemsize
    bins_bytes = bins.bh * (bins.bw + 1) * 4
    staging = np.empty(table_bytes + bins_bytes, np.uint8)
    flat_params = params[:rows].reshape(-1).view(np.uint8)
    flat_bins = starts[:bins.bh * (bins.bw + 1)].view(np.uint8)

    def copy_out() -> None:
        staging[:table_bytes] = flat_params
        staging[table_bytes:] = flat_bins

    return {
        "size_px": [width, height], "radius_px": radius, "particles": n,
        "slot_order": slot_order, "drawn_share": drawn, "drawn": int(n_drawn),
        "with_tail": with_tail,
        "bins": list(bins), "table_rows": int(rows),
        "build_sprite_tables_ms": median_ms(build, runs),
        "table_bytes": int(table_bytes), "bins_bytes": int(bins_bytes),
        "upload_bytes": int(table_bytes + bins_bytes),
        "memcpy_upload_bytes_ms": median_ms(copy_out, runs),
    }


def format_case(r: dict) -> str:
    (w, h) = r["size_px"]
    bin_w, bin_h, _, _, bw, bh = r["bins"]
    head = (f"{w}×{h}, r = {r['radius_px']:g} px: {r['particles']} particles "
            f"({r['slot_order']} slot order, {r['drawn']} drawn, "
            f"{'all in the table' if r['with_tail'] else 'only those in the table'}), "
            f"bins {bin_w}×{bin_h} px → {bw}×{bh}")
    build = (f"  build_sprite_tables  {r['build_sprite_tables_ms']:.3f} ms  "
             f"({r['table_rows']} rows, {r['table_bytes'] / 1024:.0f} KiB + bins "
             f"{r['bins_bytes'] / 1024:.0f} KiB; memcpy of it {r['memcpy_upload_bytes_ms']:.3f} ms)")
    return f"{head}\n{build}"


def main(argv: list[str] | None = None) -> list[dict]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--json", action="store_true", help="print JSON instead of a table")
    parser.add_argument("--runs", type=int, default=200)
    args = parser.parse_args(argv)
    results = [run_case(size, radius, count, args.runs, order, drawn, tail)
               for size, radius, count in CASES
               for order, drawn, tail in (("random", 1.0, True), ("row-major", 1.0, True),
                                          ("random", 0.25, True), ("random", 0.25, False))]
    if args.json:
        print(json.dumps(results, indent=2))
    else:
        print("\n\n".join(format_case(r) for r in results))
    return results


if __name__ == "__main__":
    main()
