"""CPU side of drawing: the sprite parameter table and indirection grid (kernels/sprites.py).

Run: ``python benchmarks/bench_draw_tables.py [--json] [--runs N]``. At 1920×1080 with
r = 10 px (~4,050 particles) and r = 5 px (~15,750), particles spread like a Poisson disk of
radius r (a jittered grid of spacing 2r·1.07, the band of the screen nearest its horizontal
mid-line: a river across the view), all INSIDE with intensity in (0, 1], in random slot order
(as in a running pool, whose slots are reused in no spatial order) and, for comparison, in
row-major screen order (the best case for the caches). Prints the median of
``--runs`` calls after warm-up of ``fill_sprite_params`` and ``build_sprite_grid``, the bytes a
frame uploads (whole parameter rows written + the grid), a same-size memory copy of those bytes
(a floor on what handing them to the driver costs), and what clearing the whole grid to −1
every frame would add. Issue target: tables built + uploaded < 1 ms at r = 10 px, one core.
"""
from __future__ import annotations

import argparse
import json
import time

import numpy as np

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
             slot_order: str = "random") -> dict:
    from riverflow.components.particles import ParticlePool
    from riverflow.components.status import FlowStatus
    from riverflow.kernels import sprites as ks

    width, height = size
    rng = np.random.default_rng(0)
    pts = poisson_like_screen(rng, width, height, radius, count)
    n = len(pts)
    if slot_order == "random":
        pts = pts[rng.permutation(n)]
    pool = ParticlePool(int(n * 1.25))
    pool.alive[:n] = True
    pool.has_world[:n] = True
    pool.status[:n] = FlowStatus.INSIDE
    pool.screen_px[:n] = pts
    pool.world_m[:n] = rng.uniform(-2000.0, 2000.0, (n, 3))
    pool.offset_m[:n] = rng.uniform(-10.0, 10.0, (n, 2))
    pool.velocity_mps[:n] = rng.uniform(-2.0, 2.0, (n, 2))
    pool.intensity[:n] = 1.0 - rng.random(n)  # (0, 1]

    cell, gw, gh = ks.sprite_grid_shape(width, height, radius)
    params, counts, grid = ks.empty_sprite_tables(pool.capacity, gw, gh)
    n_slots = ks.slot_span(pool.alive)
    sprite_r = ks.SPRITE_RADIUS_FACTOR * radius

    def fill() -> int:
        return ks.fill_sprite_params(pool.alive, pool.has_world, pool.screen_px, pool.world_m,
                                     pool.offset_m, pool.intensity, pool.status,
                                     pool.velocity_mps, radius, n_slots, params)

    def build() -> int:
        return ks.build_sprite_grid(pool.alive, pool.has_world, pool.screen_px, pool.intensity,
                                    pool.status, n_slots, sprite_r, float(cell), gw, gh, counts,
                                    grid)

    rows = fill()
    full = build()
    param_bytes = rows * params.shape[1] * params.shape[2] * params.itemsize
    staging = np.empty(param_bytes + grid.nbytes, np.uint8)
    flat_params = params[:rows].reshape(-1).view(np.uint8)
    flat_grid = grid.reshape(-1).view(np.uint8)

    def copy_out() -> None:
        staging[:param_bytes] = flat_params
        staging[param_bytes:] = flat_grid

    fill_ms = median_ms(fill, runs)
    build_ms = median_ms(build, runs)
    return {
        "size_px": [width, height], "radius_px": radius, "particles": n, "slot_order": slot_order,
        "cell_px": cell, "grid_cells": [gw, gh], "param_rows": rows,
        "mean_entries_per_cell": float(counts.mean()), "full_cells": int(full),
        "fill_sprite_params_ms": fill_ms, "build_sprite_grid_ms": build_ms,
        "tables_ms": fill_ms + build_ms,
        "param_bytes": int(param_bytes), "grid_bytes": int(grid.nbytes),
        "upload_bytes": int(param_bytes + grid.nbytes),
        "memcpy_upload_bytes_ms": median_ms(copy_out, runs),
        "clear_grid_ms": median_ms(lambda: grid.fill(-1), runs),
    }


def format_case(r: dict) -> str:
    (w, h), (gw, gh) = r["size_px"], r["grid_cells"]
    head = (f"{w}×{h}, r = {r['radius_px']:g} px: {r['particles']} particles "
            f"({r['slot_order']} slot order), cells {r['cell_px']} px → {gw}×{gh} grid, "
            f"{r['mean_entries_per_cell']:.2f} entries a cell, {r['full_cells']} full")
    fill = (f"  fill_sprite_params   {r['fill_sprite_params_ms']:.3f} ms  "
            f"({r['param_rows']} rows, {r['param_bytes'] / 1024:.0f} KiB)")
    build = (f"  build_sprite_grid    {r['build_sprite_grid_ms']:.3f} ms  "
             f"({r['grid_bytes'] / 1024:.0f} KiB)")
    total = (f"  tables               {r['tables_ms']:.3f} ms, upload "
             f"{r['upload_bytes'] / 2**20:.2f} MiB (memcpy of it "
             f"{r['memcpy_upload_bytes_ms']:.3f} ms)")
    clear = f"  clearing the grid to −1 would add {r['clear_grid_ms']:.3f} ms"
    return f"{head}\n{fill}\n{build}\n{total}\n{clear}"


def main(argv: list[str] | None = None) -> list[dict]:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--json", action="store_true", help="print JSON instead of a table")
    parser.add_argument("--runs", type=int, default=200)
    args = parser.parse_args(argv)
    results = [run_case(size, radius, count, args.runs, order)
               for size, radius, count in CASES for order in ("random", "row-major")]
    if args.json:
        print(json.dumps(results, indent=2))
    else:
        print("\n\n".join(format_case(r) for r in results))
    return results


if __name__ == "__main__":
    main()
