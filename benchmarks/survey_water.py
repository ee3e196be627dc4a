"""How many river polygons with islands ``rf.read_water`` reads and builds (issue 22): a
survey of random ones, not a benchmark of time.

Each seed draws a meandering river polygon (width 40 - 250 m, 600 - 1500 m long, ends cut
square across it), up to seven long thin islands in it (0.3 - 2.5 widths long, 4 - 15 % of
the width wide), and, for 70 % of the seeds, cuts it by the edges of a box a little inside
its extent (the data's edge: its open ends there, islands cut open). ``--islands inside``
keeps only islands at least 5 % of the width inside the banks and apart (islands as a
braided river has them); ``any`` lets them cross a bank (a long notch in it) or each other.
Every case must give a network or a ``GraphError`` (anything else is a bug); the survey
counts both and groups the errors by what they say. ``--land`` also asks the flow of each
river built at 6,000 random points of its bounding box: of those in the polygon's water (less
the water the end cuts leave out, and 2 m round it) the share that does not read as water
(``FlowStatus.INSIDE``) must be 0.

Run: ``python benchmarks/survey_water.py --seeds 0 100 --islands inside`` (~10 s; ``any``:
~20 s; ``--land`` about four times as long). Figures go to docs/gis.md ("Limits").
"""
from __future__ import annotations

import argparse
import collections
import re
import tempfile
import time
from pathlib import Path

import numpy as np

ORIGIN = np.array([500_000.0, 5_000_000.0])
"""Where the polygons are written, in UTM 33N (EPSG:32633)."""
SLOPE = np.array([[2.0, 1.0], [-1.0, 2.0]]) / np.sqrt(5.0)
"""The river's frame in the map's (rows: downstream, to its left): it runs at a slope of
1/2, so that its ends cut square across it do not lie on its box's edges."""


def river(seed: int, inside: bool):
    """The water polygon of ``seed`` [m] and a line describing it."""
    import shapely
    from shapely.geometry import box

    rng = np.random.default_rng(seed)
    w = rng.uniform(40, 250)
    length = rng.uniform(600, 1500)
    x = np.linspace(0, length, 40)
    y = rng.uniform(0, 1) * w * np.sin(x / rng.uniform(150, 400))
    water = shapely.LineString(np.c_[x, y]).buffer(w / 2, cap_style="flat")
    islands = []
    for _ in range(rng.integers(0, 8)):
        cx = rng.uniform(0.1, 0.9) * length
        cy = np.interp(cx, x, y) + rng.uniform(-0.3, 0.3) * w
        size, width, a = rng.uniform(0.3, 2.5) * w, rng.uniform(0.04, 0.15) * w, rng.uniform(-0.2, 0.2)
        g = shapely.LineString([(cx, cy), (cx + size * np.cos(a), cy + size * np.sin(a))]
                               ).buffer(width / 2, quad_segs=6)
        if inside and not (water.buffer(-0.05 * w).contains(g)
                           and all(g.distance(h) >= 0.05 * w for h in islands)):
            continue
        islands.append(g)
    if islands:
        water = water.difference(shapely.union_all(islands))
    water = shapely.transform(water, lambda c: c @ SLOPE + (0.0, 150.0))
    clipped = rng.uniform() < 0.7
    if clipped:
        x0, _, x1, _ = water.bounds
        water = shapely.intersection(water, box(x0 + rng.uniform(0, 0.3) * (x1 - x0), -1e5,
                                                x1 - rng.uniform(0, 0.3) * (x1 - x0), 1e5))
    return (shapely.normalize(water),
            f"{len(islands)} islands, {'clipped' if clipped else 'ends cut across'}, {w:.0f} m")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", type=int, nargs=2, default=(0, 40), metavar=("FIRST", "END"))
    ap.add_argument("--islands", choices=("inside", "any"), default="inside")
    ap.add_argument("--list", action="store_true", help="print every failing seed")
    ap.add_argument("--land", action="store_true",
                    help="check that no water of the rivers built reads as land")
    args = ap.parse_args(argv)

    import pyogrio.raw
    import shapely

    import riverflow as rf
    from riverflow.hydro.graph import GraphError

    built, errors, failing, other, land = 0, collections.Counter(), [], [], []
    t = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        for seed in range(*args.seeds):
            water, what = river(seed, args.islands == "inside")
            if water.is_empty:
                continue
            path = Path(tmp) / f"w{seed}.gpkg"
            pyogrio.raw.write(str(path), np.array([shapely.to_wkb(shapely.transform(
                water, lambda c: c + ORIGIN))], dtype=object), [], [], driver="GPKG",
                crs="EPSG:32633", geometry_type=water.geom_type)
            try:
                builder = rf.read_water(path, origin_m=ORIGIN)
                graph = builder.build()
                built += 1
                if args.land:
                    land.append((_land_share(rf, water, builder, graph), seed))
            except GraphError as exc:
                text = str(exc).split("): ", 1)[-1]
                errors[re.sub(r"[-\d.]+", "#", re.sub(r"'[^']*'", "'…'", text))[:70]] += 1
                failing.append((seed, what, text[:120]))
            except Exception as exc:          # a bug: not a clear error
                other.append((seed, what, f"{type(exc).__name__}: {exc}"[:200]))
    n = built + len(failing) + len(other)
    print(f"{n} river polygons (islands {args.islands}), seeds {args.seeds[0]} - "
          f"{args.seeds[1] - 1}: {built} built, {len(failing)} GraphError, {len(other)} other "
          f"exceptions ({time.perf_counter() - t:.0f} s)")
    if land:
        worst, seed = max(land)
        print(f"  water read as land (end cuts left out): {sum(v > 0 for v, _ in land)} of "
              f"{len(land)} rivers, at most {100 * worst:.2f} %"
              + (f" (seed {seed})" if worst > 0 else ""))
    for text, k in errors.most_common():
        print(f"  {k:3d} × {text}")
    for seed, what, text in (failing if args.list else []) + other:
        print(f"  seed {seed} ({what}): {text}")
    return 1 if other else 0


def _land_share(rf, water, builder, graph) -> float:
    """The share of 6,000 random points of the river's water (less what the end cuts leave
    out, and 2 m round it) whose flow does not read as water."""
    import shapely

    lost = water.difference(builder.water_polygon)
    x0, y0, x1, y1 = water.bounds
    rng = np.random.default_rng(0)
    pts = np.c_[rng.uniform(x0, x1, 6000), rng.uniform(y0, y1, 6000)]
    kept = shapely.contains_xy(water, *pts.T) & ~shapely.contains_xy(lost.buffer(2.0), *pts.T)
    if not kept.any():
        return 0.0
    status, _ = rf.FlowField(graph).query(pts[kept])
    return float(np.mean(status != rf.FlowStatus.INSIDE))


if __name__ == "__main__":
    raise SystemExit(main())
