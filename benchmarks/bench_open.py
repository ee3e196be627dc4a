"""Opening a real GIS file as a running world, phase by phase (the first run must take
seconds): ``rf.read_rivers`` / ``rf.read_water`` and ``build()``, ``rf.landscape``,
``rf.RiverWorld`` (the flow network, the wet-tile tables, the terrain producers) and
``load_view`` (the first view's tiles, made by the tile processes: wall seconds, this
process's CPU beside them), then ``--frames`` frames; with ``--blocking`` the first view's
tiles are made in this thread (``tile_production="blocking"``: their CPU, whatever the
machine's load).

The files are not in this repository (other projects' data): pass their paths, e.g. USGS
NHDPlus flowlines (sfrmaker's ``shellmound`` test data: 998 links, 1,897 km), an
OpenStreetMap extract (``--layer multipolygons`` for its water areas). Default: the Red
Butte network of ``../shared/data``.

Run: ``PYGLET_HEADLESS=1 python benchmarks/bench_open.py FILE [--layer L] [--blocking]``.
Figures go to docs/performance.md ("Real networks as worlds").
"""
from __future__ import annotations

import argparse
import json
import resource
import time
from pathlib import Path

RED_BUTTE = Path(__file__).resolve().parents[2] / "shared/data/gis/redbutte/a001_network.shp"


def run(path: Path, layer: str | None, blocking: bool, frames: int) -> dict:
    import riverflow as rf
    from riverflow.gis.water import holds_water_areas

    out: dict = {"file": str(path), "layer": layer}
    clock = [time.perf_counter(), time.process_time()]

    def phase(name: str) -> None:
        wall, cpu = time.perf_counter(), time.process_time()
        out[f"{name}_wall_s"] = round(wall - clock[0], 3)
        out[f"{name}_cpu_s"] = round(cpu - clock[1], 3)
        clock[:] = [wall, cpu]

    water = layer == "multipolygons" or (layer is None and holds_water_areas(path))
    builder = rf.read_water(path, layer=layer) if water else rf.read_rivers(path, layer=layer)
    graph = builder.build()
    phase("read_build")
    out["links"] = len(builder.report.links)
    scene = rf.landscape(graph)
    phase("landscape")
    config = rf.RiverConfig(tile_production="blocking" if blocking else "background")
    world = rf.RiverWorld(scene, size=(1280, 720), gl=False, seed=0, config=config)
    phase("world")
    world.load_view()
    phase("load_view")
    for _ in range(frames):
        world.step(1 / 60)
    phase("frames")
    out["peak_rss_mb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss // 1024
    world.close()
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("file", nargs="?", type=Path, default=RED_BUTTE)
    ap.add_argument("--layer", default=None)
    ap.add_argument("--blocking", action="store_true",
                    help="the first view's tiles made in this thread (their CPU)")
    ap.add_argument("--frames", type=int, default=60)
    ap.add_argument("--json", type=Path, default=None)
    args = ap.parse_args()
    if not args.file.exists():
        ap.error(f"{args.file}: no such file (pass a GIS file's path; the default is the Red "
                 "Butte network of ../shared/data)")
    out = run(args.file, args.layer, args.blocking, args.frames)
    for key, value in out.items():
        print(f"{key:>22}: {value}")
    if args.json:
        args.json.write_text(json.dumps(out, indent=2))


if __name__ == "__main__":
    main()
