"""GIS benchmark: a real-sized stream network read from a GeoPackage and built, on one core.

The network is made here (so the benchmark needs no data): a meandering main river with a
tributary every ``--spacing-km`` on alternating sides, each tributary meandering too and fed
by two sub-tributaries that end on it (so the reader splits it there), vertices every 30 m,
drainage areas that add up downstream, in UTM 33N (northings of 5000 km: the reader moves
them near 0). With the defaults: 200 km of main river, 50 tributaries of 12 km and 100
sub-tributaries of 4 km: 1200 km of rivers, 200 features, 300 links after the splits.

Timed, each on its own (one core: the process is pinned and NUMBA_NUM_THREADS=1):

* write: the GeoPackage (pyogrio), not part of the target;
* import: the first use of ``rf.read_rivers`` imports ``riverflow.gis.rivers`` (once per
  process, not part of the target);
* read: ``rf.read_rivers`` (reading, projection, topology, widths and discharges);
* build: ``builder.build()`` (strips, water polygon, banks, ψ);
* validate: ``rf.validate_graph``;
* landscape: ``rf.landscape(graph)`` (water profiles, procedural hills);
* flow: ``rf.FlowField.for_scene`` (the flow network);
* bake: ``rf.bake_flow_map`` of a ``--bake-km`` square at ``--bake-cell-m`` around a confluence
  (flow tiles made on demand, blocking).

Target (the GIS issue): a 1000 km network with hundreds of links read and built in ≤ 60 s on
one core; issue 21: ≤ 10 s per 1000 km and time linear in the number of links (``--copies N``
puts N disjoint copies side by side; ``--read-build-only`` stops after the build). Read and
build are timed by the wall clock and by the process's CPU time (equal on a quiet machine),
and reported per 1000 links and per 1000 km (CPU), with the peak memory after the build
(``peak_rss_mb``). Figures go to docs/performance.md. Run: ``python benchmarks/bench_gis.py``
(``--json out.json`` keeps the figures).
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("NUMBA_NUM_THREADS", "1")

import numpy as np  # noqa: E402

UTM = "EPSG:32633"
ORIGIN = np.array([400_000.0, 5_000_000.0])
STEP_M = 30.0


def meander(start, direction, length_m, amplitude_m, wavelength_m, phase=0.0):
    """A sinuous line (K, 2) [m] from ``start`` along unit ``direction``."""
    s = np.arange(0.0, length_m + 1e-9, STEP_M)
    if s[-1] < length_m:
        s = np.append(s, length_m)
    d = np.asarray(direction, float) / np.hypot(*direction)
    n = np.array([-d[1], d[0]])
    offset = amplitude_m * np.sin(2 * np.pi * s / wavelength_m + phase) * np.sin(np.pi * s / length_m)
    return np.asarray(start, float) + s[:, None] * d + offset[:, None] * n


def network(main_km: float, spacing_km: float, trib_km: float, sub_km: float):
    """Lines drawn downstream (metres, relative to ORIGIN) and their drainage areas [km²]."""
    lines, areas = [], []
    main = meander((0.0, 0.0), (1.0, 0.0), main_km * 1000.0, 250.0, 3000.0)
    n_trib = int(main_km / spacing_km) - 1
    s_main = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(main, axis=0).T))])
    joins = []
    for k in range(n_trib):
        at = int(np.searchsorted(s_main, (k + 1) * spacing_km * 1000.0))
        side = 1.0 if k % 2 == 0 else -1.0
        mouth = main[at]
        far = mouth + (0.0, side * trib_km * 1000.0)
        trib = meander(far, (0.0, -side), trib_km * 1000.0, 120.0, 1800.0, phase=k)
        trib[-1] = mouth
        sub_area = 0.0
        for j, frac in enumerate((1 / 3, 2 / 3)):
            i = int(frac * (len(trib) - 1))
            sx = -1.0 if j == 0 else 1.0
            direction = np.array([-sx, -side]) / np.sqrt(2.0)     # towards the tributary
            start = trib[i] - direction * sub_km * 1000.0
            sub = meander(start, direction, sub_km * 1000.0, 60.0, 1200.0, phase=j)
            sub[-1] = trib[i]
            lines.append(sub)
            areas.append(15.0)
            sub_area += 15.0
        lines.append(trib)
        areas.append(40.0 + sub_area)
        joins.append((at, 40.0 + sub_area))
    # the main river, one feature per stretch between tributaries: its area grows
    cuts = [0] + [a for a, _ in joins] + [len(main) - 1]
    area = 200.0
    for k, (a, b) in enumerate(zip(cuts[:-1], cuts[1:])):
        if k > 0:
            area += joins[k - 1][1] + 10.0
        lines.append(main[a:b + 1])
        areas.append(area)
    return lines, np.array(areas)


def _peak_rss_mb() -> float | None:
    """The process's peak resident memory so far [MB] (None where ``resource`` is missing)."""
    try:
        import resource
    except ImportError:     # Windows
        return None
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return rss / 1024.0 / (1024.0 if sys.platform == "darwin" else 1.0)    # bytes on macOS


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--main-km", type=float, default=200.0)
    parser.add_argument("--spacing-km", type=float, default=4.0)
    parser.add_argument("--trib-km", type=float, default=12.0)
    parser.add_argument("--sub-km", type=float, default=4.0)
    parser.add_argument("--bake-km", type=float, default=2.0)
    parser.add_argument("--bake-cell-m", type=float, default=2.0)
    parser.add_argument("--copies", type=int, default=1,
                        help="disjoint copies of the network side by side (scaling in links)")
    parser.add_argument("--read-build-only", action="store_true",
                        help="time read + build only (no validate, landscape, flow, bake)")
    parser.add_argument("--json", type=Path, default=None)
    args = parser.parse_args(argv)
    if hasattr(os, "sched_setaffinity"):
        os.sched_setaffinity(0, {sorted(os.sched_getaffinity(0))[0]})

    import pyogrio.raw
    import shapely

    import riverflow as rf

    one, one_areas = network(args.main_km, args.spacing_km, args.trib_km, args.sub_km)
    span = 2.0 * (args.trib_km + args.sub_km) * 1000.0 + 5000.0
    lines = [p + (0.0, k * span) for k in range(args.copies) for p in one]
    areas = np.tile(one_areas, args.copies)
    length_km = sum(float(np.hypot(*np.diff(p, axis=0).T).sum()) for p in lines) / 1000.0
    out: dict = {"features": len(lines), "network_km": round(length_km, 1),
                 "vertices": int(sum(len(p) for p in lines))}
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "network.gpkg"
        t = time.perf_counter()
        geoms = np.array([shapely.to_wkb(shapely.LineString(p + ORIGIN)) for p in lines],
                         dtype=object)
        pyogrio.raw.write(str(path), geoms, [areas], ["area_km2"], driver="GPKG", crs=UTM,
                          geometry_type="LineString")
        out["write_s"] = time.perf_counter() - t
        # riverflow.gis.rivers is imported on first use (``rf.read_rivers``): some 1.1 s of
        # CPU, once per process, whatever the network; timed on its own, not as reading
        t, c = time.perf_counter(), time.process_time()
        read_rivers = rf.read_rivers
        out["import_s"] = time.perf_counter() - t
        out["import_cpu_s"] = time.process_time() - c
        t, c = time.perf_counter(), time.process_time()
        builder = read_rivers(path, drainage_area_km2="area_km2")
        out["read_s"] = time.perf_counter() - t
        out["read_cpu_s"] = time.process_time() - c
    t, c = time.perf_counter(), time.process_time()
    graph = builder.build()
    out["build_s"] = time.perf_counter() - t
    out["build_cpu_s"] = time.process_time() - c
    out["read_and_build_s"] = out["read_s"] + out["build_s"]
    out["read_and_build_cpu_s"] = out["read_cpu_s"] + out["build_cpu_s"]
    out["links"] = len(builder.report.links)
    out["repairs"] = len(builder.report.repairs)
    # per 1000 links / km, by CPU time (the process's own, one core: what a quiet machine's
    # wall clock shows; a shared machine's wall clock also counts the other processes)
    out["cpu_s_per_1000_links"] = out["read_and_build_cpu_s"] / out["links"] * 1000.0
    out["cpu_s_per_1000_km"] = out["read_and_build_cpu_s"] / length_km * 1000.0
    out["peak_rss_mb"] = _peak_rss_mb()
    if args.read_build_only:
        print(json.dumps({k: round(v, 3) if isinstance(v, float) else v
                          for k, v in out.items()}, indent=2))
        if args.json:
            args.json.write_text(json.dumps(out, indent=2))
        return 0
    out["curves"] = len(graph.curves)
    widths = [lk.width_m for lk in builder.report.links]
    out["width_m"] = [round(min(widths), 2), round(max(widths), 2)]
    t = time.perf_counter()
    problems = rf.validate_graph(graph)
    out["validate_s"] = time.perf_counter() - t
    out["problems"] = len(problems)
    t = time.perf_counter()
    scene = rf.landscape(graph)
    out["landscape_s"] = time.perf_counter() - t
    t = time.perf_counter()
    field = rf.FlowField.for_scene(scene)
    out["flow_s"] = time.perf_counter() - t
    mouth = lines[2][-1] - np.asarray(builder.report.origin_m) + ORIGIN    # first tributary
    half = 500.0 * args.bake_km
    region = (mouth[0] - half, mouth[1] - half, mouth[0] + half, mouth[1] + half)
    with tempfile.TemporaryDirectory() as tmp:
        result = rf.bake_flow_map(field, region, args.bake_cell_m, Path(tmp) / "flow.png")
    out["bake_s"] = result.seconds
    out["bake_px"] = list(result.size_px)
    out["bake_water"] = round(result.water_fraction, 4)
    print(json.dumps({k: round(v, 3) if isinstance(v, float) else v for k, v in out.items()},
                     indent=2))
    if args.json:
        args.json.write_text(json.dumps(out, indent=2))
    return 0 if not problems else 1


if __name__ == "__main__":
    sys.exit(main())
