"""Web flow tiles: tiles per second on one and two workers (issue #26).

The built-in procedural network of about 1000 km (``default_scene`` sized with
``size_for_network_length``, as bench_scale does) is placed on the Earth with a transverse
Mercator CRS centred at 45° N, 15° E (the scene's metres are metres from there), its zoom-14
candidate tiles (those whose footprint meets the water: :func:`riverflow.gis.tiles.
candidate_tiles`) are listed, and a fixed sample of them (``--tiles``, every k-th, so the
sample spreads over the network) is baked through the same blocks ``rf.bake_tiles`` runs:

* on one worker (this process),
* on two local processes (``concurrent.futures``, forked: no start-up cost to speak of),
* on a Dask ``LocalCluster`` of two one-thread processes (where dask.distributed is
  installed; its start-up is reported apart and not counted in the rate).

Reported: candidate tiles, tiles baked, written (with water), wall and CPU seconds (this
process's CPU, plus the children's for the process pool), tiles/s, the speed-up of two workers
over one, and the estimate for the whole network and for a 100,000 km network on 32 cores
(tiles scale with the network's length at a given zoom; 32 cores at the two-worker efficiency).

Run: ``python benchmarks/bench_bake.py`` (``--tiles 96`` default, ``--zoom 14``,
``--json out.json``). Goal (the issue): two workers ≥ 1.7 × one. Figures go to
docs/performance.md; say whether the machine was shared.
"""
from __future__ import annotations

import argparse
import json
import os
import resource
import shutil
import tempfile
import time
from pathlib import Path

CRS = "+proj=tmerc +lat_0=45 +lon_0=15 +k=1 +x_0=0 +y_0=0 +ellps=WGS84 +units=m +no_defs"


def _cpu() -> float:
    me = resource.getrusage(resource.RUSAGE_SELF)
    kids = resource.getrusage(resource.RUSAGE_CHILDREN)
    return me.ru_utime + me.ru_stime + kids.ru_utime + kids.ru_stime


def _timed(fn):
    w, c = time.perf_counter(), _cpu()
    out = fn()
    return out, time.perf_counter() - w, _cpu() - c


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--network-km", type=float, default=1000.0)
    ap.add_argument("--zoom", type=int, default=14)
    ap.add_argument("--tiles", type=int, default=96, help="tiles baked per run")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--no-dask", action="store_true")
    ap.add_argument("--json", type=Path, default=None)
    args = ap.parse_args(argv)

    import riverflow as rf
    from riverflow.gis import tiles as T
    from riverflow.gis.bake import _field
    from riverflow.scenes.layout import network_length_m, size_for_network_length

    (scene, make_s, _) = _timed(lambda: rf.default_scene(
        seed=args.seed, size_km=size_for_network_length(args.network_km * 1000.0) / 1000.0))
    km = network_length_m(scene.branches) / 1000.0
    field = _field(scene)
    water = T.water_shapes(field.graph, field.graph.bounds())
    candidates, list_s, _ = _timed(lambda: T.candidate_tiles(water, CRS, args.zoom, args.zoom))
    step = max(1, len(candidates) // args.tiles)
    sample = candidates[::step][:args.tiles]
    speed = T.sample_max_speed(field, field.graph.bounds())
    job = T.Job(field, CRS, speed)
    blocks = [sample[a:a + 4] for a in range(0, len(sample), 4)]
    # warm-up: the kernels loaded and the field's tiles for one block made in this process
    with tempfile.TemporaryDirectory() as warm:
        T.bake_block(job, warm, blocks[0])
    runs = {}

    def run(name, workers, client=None):
        folder = Path(tempfile.mkdtemp(prefix=f"bake-{name}-"))
        try:
            _, wall, cpu = _timed(lambda: list(T._run(job, folder, blocks, workers, client)))
            written = sum(1 for _ in folder.rglob("*.png"))
        finally:
            shutil.rmtree(folder, ignore_errors=True)
        runs[name] = {"workers": workers, "tiles": len(sample), "written": written,
                      "wall_s": wall, "cpu_s": cpu, "tiles_per_s": len(sample) / wall}
        print(f"{name:>12}: {len(sample)} tiles ({written} with water) in {wall:.1f} s wall, "
              f"{cpu:.1f} s CPU: {len(sample) / wall:.2f} tiles/s", flush=True)

    run("1 worker", 1)
    run("2 processes", 2)
    dask_start = None
    if not args.no_dask:
        try:
            import dask.distributed as dd
        except ImportError:
            print("dask.distributed not installed: no Dask run (pip install 'riverflow[cluster]')")
        else:
            w = time.perf_counter()
            cluster = dd.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                      dashboard_address=None)
            client = dd.Client(cluster)
            client.run(lambda: __import__("riverflow.gis.tiles"))
            dask_start = time.perf_counter() - w
            try:
                run("2 dask", 2, client)
            finally:
                client.close()
                cluster.close()
    one = runs["1 worker"]["tiles_per_s"]
    two = max(r["tiles_per_s"] for k, r in runs.items() if r["workers"] == 2)
    full_s = len(candidates) / one
    per_km = len(candidates) / km
    big = 100_000.0 * per_km
    eff = two / one / 2.0
    est_32 = big / (one * 32 * eff)
    out = {"network_km": km, "scene_make_s": make_s, "zoom": args.zoom,
           "candidate_tiles": len(candidates), "listing_s": list_s, "max_speed_mps": speed,
           "runs": runs, "dask_start_s": dask_start, "speedup_2_workers": two / one,
           "whole_network_1_worker_s": full_s, "tiles_per_km": per_km,
           "estimate_100000km_tiles": big, "estimate_100000km_32_cores_s": est_32,
           "cpu_count": os.cpu_count()}
    print(f"{km:.0f} km network (made in {make_s:.1f} s), zoom {args.zoom}: "
          f"{len(candidates)} candidate tiles ({per_km:.1f} per km; listed in {list_s:.1f} s)")
    print(f"two workers / one: {two / one:.2f}x (goal >= 1.7x)")
    print(f"whole network on one worker: {full_s / 60:.1f} min; 100,000 km: about {big:,.0f} "
          f"tiles, on 32 cores at the two-worker efficiency ({eff:.0%}): "
          f"{est_32 / 60:.1f} min")
    if dask_start is not None:
        print(f"Dask LocalCluster start-up (2 processes): {dask_start:.1f} s, not counted")
    if args.json:
        args.json.write_text(json.dumps(out, indent=2))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
