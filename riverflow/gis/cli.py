"""The command line's scene and GIS parts (``riverflow/__main__.py`` calls these; nothing here
imports it): the scene a command runs on (:func:`load_scene`: ``--scene`` with a graph file,
GIS stream lines or water areas, ``--layer``, ``--terrain``, or the built-in scene), and the
``bake``, ``check`` and ``spill`` subcommands.

Nothing heavy is imported here at import time (``--help`` stays free of numba and pyglet).
"""
from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path
from typing import Any


def add_scene_options(p: argparse.ArgumentParser) -> None:
    """``--layer``, ``--terrain``, ``--inlet`` / ``--outlet`` and ``--lines`` beside every
    ``--scene``."""
    p.add_argument("--layer", default=None, metavar="NAME",
                   help="the layer of a GIS --scene file that holds several (default: its "
                        "line layer)")
    add_water_options(p)
    p.add_argument("--terrain", type=Path, default=None, metavar="DEM.tif",
                   help="an elevation raster (GeoTIFF, riverflow[gis]) under --scene's rivers, "
                        "reprojected to their CRS (default: procedural hills)")


def add_water_options(p: argparse.ArgumentParser) -> None:
    """``--inlet``, ``--outlet`` (repeatable) and ``--lines`` for water polygons and masks."""
    p.add_argument("--inlet", type=_point, action="append", default=None, metavar="X,Y",
                   help="water polygons / masks: where water enters, in the data's CRS "
                        "(repeatable; default: the narrower end of the longest channel)")
    p.add_argument("--outlet", type=_point_or_lines, action="append", default=None,
                   metavar="X,Y|FILE",
                   help="water polygons / masks: where water leaves (repeatable): a point, or "
                        "a file of lines (a coastline, a dam: every free end of the water on "
                        "them)")
    p.add_argument("--lines", default=None, metavar="FILE|LAYER",
                   help="water polygons: the waterway lines that give the channels' axes and "
                        "direction (a file, or a layer of the polygon file; default: the "
                        "polygons' skeleton)")


SCENE_HELP = ("a Proland hydro-graph file (.graph), GIS stream lines (.shp, .gpkg, .geojson, "
              ".json, OpenStreetMap .osm / .osm.pbf: riverflow.read_rivers), or water polygons "
              "in those formats or a water mask (.tif: riverflow.read_water); GIS files need "
              "riverflow[gis]; default: the built-in scene")


def read_water_args(path, args: argparse.Namespace):
    """:func:`~riverflow.read_water` of ``path`` with the command line's ``--layer``,
    ``--lines``, ``--inlet``, ``--outlet``."""
    from riverflow.gis.water import read_water

    return read_water(path, layer=getattr(args, "layer", None),
                      lines=getattr(args, "lines", None),
                      inlets=getattr(args, "inlet", None), outlets=getattr(args, "outlet", None))


def load_scene(args: argparse.Namespace) -> tuple[Any, str]:
    """The landscape of --scene (a graph file on procedural hills, :func:`landscape`), or the
    built-in scene of --seed; (None, message) after an error."""
    from riverflow.hydro.graph import GraphError

    if args.scene is not None:
        from riverflow.scenes.landscape import landscape

        try:    # a graph file or GIS lines, on --terrain or procedural hills
            return landscape(scene_graph(args), args.terrain, seed=args.seed), args.scene.name
        except (GraphError, ValueError, OSError, ImportError) as exc:  # a bad --terrain too
            print(f"riverflow {args.command}: cannot load {args.scene}"
                  f"{f' on --terrain {args.terrain}' if args.terrain else ''}: {exc}",
                  file=sys.stderr)
            return None, ""
    from riverflow.scenes.default import default_scene

    falls = bool(getattr(args, "falls", False))
    dam = bool(getattr(args, "dam", False))
    return (default_scene(seed=args.seed, falls=falls, dam=dam),
            f"built-in scene, seed {args.seed}{', falls' if falls else ''}"
            f"{', dam' if dam else ''}")



def scene_graph(args: argparse.Namespace, config=None):
    """The hydro graph of ``--scene``: water polygons and masks through
    :func:`~riverflow.read_water`, GIS lines through :func:`~riverflow.read_rivers`
    (``--layer``), anything else as a Proland graph file. ``config``: the
    :class:`~riverflow.engine.config.RiverConfig` whose fall and rapid thresholds the GIS
    builders find falls with (default: the environment's, ``RiverConfig.from_env()``)."""
    from riverflow.engine.config import RiverConfig
    from riverflow.gis.rivers import is_gis_path
    from riverflow.gis.water import holds_water_areas

    config = RiverConfig.from_env() if config is None else config
    if holds_water_areas(args.scene, getattr(args, "layer", None)):
        return read_water_args(args.scene, args).use_config(config).build()
    given = [f"--{name}" for name in ("inlet", "outlet", "lines")
             if getattr(args, name, None) is not None]
    if given:
        from riverflow.hydro.graph import GraphError

        raise GraphError(f"{', '.join(given)}: for water polygons and masks only; "
                         f"{args.scene} holds no water areas (its lines or graph give the "
                         f"direction)")
    if is_gis_path(args.scene):
        from riverflow.gis.rivers import read_rivers

        return read_rivers(args.scene, layer=getattr(args, "layer", None)).use_config(
            config).build()
    from riverflow.hydro.io import load_graph

    return load_graph(args.scene)


def add_bake_command(sub, scene_args, positive) -> None:
    """The ``bake`` subcommand (SPEC §7)."""
    p = sub.add_parser(
        "bake", help="bake the flow into a flow-map PNG (+ JSON) for other engines, web "
                     "tiles (--tiles) or a GeoTIFF (--format geotiff)",
        description="Sample the flow at every pixel centre of a region and write a flow map: "
                    "--preset raw (default): RG = 0.5 + v / (2 max_speed) (x east, y north), "
                    "B = water / land, A = distance to the nearest bank / max_distance; "
                    "--preset unity, unreal, godot-waterways or source: what that engine's "
                    "flow-map shaders read (docs/flowmaps.md); rows north-up. A JSON file "
                    "beside it (same name, .json) holds origin_m, cell_m, size_px, "
                    "max_speed_mps, the preset, the encoding and the CRS. --tiles DIR writes "
                    "an XYZ Web Mercator pyramid instead (resumable; --workers, --scheduler).")
    scene_args(p)
    p.add_argument("--region", type=_region, default=None, metavar="X0,Y0,X1,Y1",
                   help="the region [m] in the scene's coordinates (default: the network's "
                        "bounds)")
    p.add_argument("--cell-m", type=positive, default=None, metavar="C",
                   help="pixel size [m] (default: the region's longer side / 1024)")
    p.add_argument("--out", type=Path, default=Path("out/flow.png"), metavar="FILE.png",
                   help="the flow map to write (default: %(default)s; the JSON goes beside it)")
    p.add_argument("--16bit", dest="bits16", action="store_true",
                   help="16 bits a channel (needs pypng: pip install 'riverflow[gis]')")
    p.add_argument("--max-speed", type=positive, default=None, metavar="MPS",
                   help="speed [m/s] of R, G = 0 or full (default: the fastest water in the map)")
    p.add_argument("--preset", default="raw", metavar="NAME",
                   help="the engine whose flow-map shaders read the map: raw, unity, unreal, "
                        "godot-waterways, source (docs/flowmaps.md; default: %(default)s)")
    p.add_argument("--direction-test", action="store_true",
                   help="write the preset's direction test map (a counter-clockwise "
                        "rotation, 256 px) to --out instead of the scene's flow")
    p.add_argument("--format", choices=("png", "geotiff"), default="png",
                   help="png: the flow map (--preset); geotiff: a cloud-optimised GeoTIFF of "
                        "float32 vx, vy [m/s], mask and distance [m] in the network's CRS "
                        "(--out FILE.tif; riverflow[gis])")
    p.add_argument("--tiles", type=Path, default=None, metavar="DIR",
                   help="write web tiles instead: an XYZ PNG pyramid in Web Mercator "
                        "(DIR/{z}/{x}/{y}.png + DIR/tiles.json; resumable; riverflow[gis])")
    p.add_argument("--zoom", default="10-14", metavar="Z0-Z1",
                   help="--tiles: the zoom levels, 0-22 (default: %(default)s)")
    p.add_argument("--crs", default=None, metavar="CRS",
                   help="--tiles: the network's CRS where the scene has none (e.g. EPSG:32633)")
    p.add_argument("--workers", type=int, default=1, metavar="N",
                   help="--tiles: processes (a Dask LocalCluster of N where riverflow[cluster] "
                        "is installed, else local processes; default: %(default)s)")
    p.add_argument("--scheduler", default=None, metavar="ADDRESS",
                   help="--tiles: bake on the Dask cluster of this scheduler "
                        "(tcp://host:8786; riverflow[cluster])")
    p.set_defaults(run=run_bake)


def run_bake(args: argparse.Namespace) -> int:
    from riverflow.gis.bake import direction_test_map, preset_spec

    try:
        preset_spec(args.preset, "riverflow bake --preset")
        if args.tiles is None:
            from riverflow._atomic import writable_path

            writable_path(args.out)          # before the scene is made and baked
        if args.tiles is not None:
            from riverflow.gis.tiles import parse_zooms

            zooms = parse_zooms(args.zoom)
            if args.tiles.exists() and not args.tiles.is_dir():
                raise ValueError(f"--tiles {args.tiles} is a file, expected a folder")
        if args.direction_test:
            path = direction_test_map(args.out, args.preset, bits=16 if args.bits16 else 8)
            print(f"wrote {path.resolve()} (direction test map, preset {args.preset})")
            return 0
    except (ImportError, ValueError, OSError) as exc:
        print(f"riverflow bake: {exc}", file=sys.stderr)
        return 1
    scene, title = load_scene(args)
    if scene is None:
        return 1
    if args.tiles is not None:
        return _run_bake_tiles(args, scene, title, zooms)
    if args.format == "geotiff":
        from riverflow.gis.bake import bake_geotiff

        try:
            result = bake_geotiff(scene, args.region, args.cell_m, args.out)
        except (ImportError, ValueError, OSError) as exc:
            print(f"riverflow bake: {exc}", file=sys.stderr)
            return 1
        w, h = result.size_px
        print(f"wrote {result.image.resolve()} ({title}: {w}x{h} px of {result.cell_m:g} m, "
              f"cloud-optimised GeoTIFF: vx, vy [m/s], mask, distance [m])")
        return 0
    from riverflow.gis.bake import bake_flow_map

    try:
        result = bake_flow_map(scene, args.region, args.cell_m, args.out,
                               bits=16 if args.bits16 else 8, max_speed_mps=args.max_speed,
                               preset=args.preset)
    except (ImportError, ValueError, OSError) as exc:
        print(f"riverflow bake: {exc}", file=sys.stderr)
        return 1
    w, h = result.size_px
    print(f"wrote {result.image.resolve()} and {result.sidecar.name} ({title}: {w}x{h} px of "
          f"{result.cell_m:g} m from ({result.origin_m[0]:.1f}, {result.origin_m[1]:.1f}), "
          f"max speed {result.max_speed_mps:.3g} m/s, {result.water_fraction:.1%} water, "
          f"{result.seconds:.1f} s)")
    return 0


def add_spill_command(sub, scene_args, positive) -> None:
    """The ``spill`` subcommand (SPEC §7, issue 24)."""
    p = sub.add_parser(
        "spill", help="release a pollutant, run it down the rivers, write concentration maps",
        description="Release MASS kg at X,Y (moved to the nearest water within 50 m), run the "
                    "spill for H hours and write, every MIN minutes, a concentration map "
                    "[kg/m3] of the region (GeoTIFF in the network's CRS with rasterio, else "
                    "16-bit PNG + JSON), gauges.csv (the concentration over time at the gauges: "
                    "the release point and each outlet unless --gauge is given) and spill.json "
                    "(the mass in the water, out per outlet and decayed at each time).")
    scene_args(p)
    p.add_argument("--at", type=_point, required=True, metavar="X,Y",
                   help="the release point [m] in the scene's coordinates")
    p.add_argument("--mass", type=positive, required=True, metavar="KG", help="mass released [kg]")
    p.add_argument("--hours", type=_spill_hours(positive), required=True, metavar="H",
                   help=f"how long to run the spill [h], at most {MAX_SPILL_HOURS:,}")
    p.add_argument("--every", type=positive, required=True, metavar="MIN",
                   help="minutes between two maps")
    p.add_argument("--duration-min", type=float, default=0.0, metavar="MIN",
                   help="release over this many minutes (default: at once)")
    p.add_argument("--decay-per-s", type=float, default=0.0, metavar="K",
                   help="first-order decay rate [1/s] (default: none)")
    p.add_argument("--region", type=_region, default=None, metavar="X0,Y0,X1,Y1",
                   help="the region [m] of the maps (default: the network's bounds)")
    p.add_argument("--cell-m", type=positive, default=None, metavar="C",
                   help="pixel size [m] (default: the region's longer side / 512)")
    p.add_argument("--gauge", type=_point, action="append", default=None, metavar="X,Y",
                   help="a gauge point [m] for gauges.csv (repeat for more)")
    p.add_argument("--png", action="store_true", help="16-bit PNG + JSON even with rasterio")
    p.add_argument("--out", type=Path, default=Path("out/spill"), metavar="DIR",
                   help="the output folder (default: %(default)s)")
    p.set_defaults(run=run_spill)


MAX_SPILL_HOURS = 8760
"""Longest spill ``riverflow spill --hours`` runs: a year."""
MAX_SPILL_MAPS = 10_000
"""Most maps one ``riverflow spill`` writes (``--hours`` × 60 / ``--every``)."""


def _spill_hours(positive):
    def hours(text: str) -> float:
        value = positive(text)
        if value > MAX_SPILL_HOURS:
            raise argparse.ArgumentTypeError(f"must be at most {MAX_SPILL_HOURS:,} h (a year), "
                                             f"got {text[:40]!r}")
        return value
    return hours


def run_spill(args: argparse.Namespace) -> int:

    maps = 60.0 * args.hours / args.every
    if maps > MAX_SPILL_MAPS:
        print(f"riverflow spill: error: --hours {args.hours:g} every {args.every:g} min makes "
              f"{maps:,.0f} maps; at most {MAX_SPILL_MAPS:,}: give a larger --every",
              file=sys.stderr)
        return 2
    from riverflow._atomic import writable_path

    try:
        writable_path(args.out, folder=True)   # before the scene is made and the spill run
    except OSError as exc:
        print(f"riverflow spill: --out: {exc}", file=sys.stderr)
        return 1
    scene, title = load_scene(args)
    if scene is None:
        return 1
    import numpy as np

    from riverflow.engine.world import RiverWorld
    from riverflow.gis.spill import bake_concentration

    try:
        world = RiverWorld(scene, size=(16, 16), gl=False, seed=args.seed)
    except (ImportError, ValueError, OSError) as exc:   # a graph no flow can run in
        print(f"riverflow spill: {exc}", file=sys.stderr)
        return 1
    try:
        entity = world.add_spill(args.at, args.mass, 60.0 * args.duration_min,
                                 decay_per_s=args.decay_per_s, name="spill")
        solver = world.spill_solver
        report = world.spill(entity)
        if args.gauge:
            gauges = np.array(args.gauge, np.float64)
            names = [f"gauge_{i}" for i in range(len(gauges))]
        else:
            net = solver.network
            outlets = [int(net.net.link_c1[net.names.index(n)]) - 1 for n in net.outlets]
            gauges = np.vstack([report.source_xy_m[None, :], net.cell_xy_m[outlets]])
            names = ["release", *(f"outlet_{n}" for n in net.outlets)]
        step = 60.0 * args.every
        times = np.arange(step, 3600.0 * args.hours + 1e-6, step)
        if not len(times):
            times = np.array([3600.0 * args.hours])
        region = args.region
        cell = args.cell_m
        if cell is None:
            from riverflow.gis.bake import _region as region_of

            x0, y0, x1, y1 = region_of(region, scene.graph, world.field)
            region, cell = (x0, y0, x1, y1), max(x1 - x0, y1 - y0) / 512.0
        result = bake_concentration(world, region, cell, args.out, times, gauges_m=gauges,
                                    gauge_names=names, geotiff=False if args.png else None)
        final = world.spill(entity)
    except (ImportError, ValueError, OSError) as exc:
        print(f"riverflow spill: {exc}", file=sys.stderr)
        return 1
    finally:
        world.close()
    moved = f" (moved {report.moved_m:.1f} m into the water)" if report.moved_m else ""
    w, h = result.size_px
    print(f"wrote {len(result.images)} {'GeoTIFF' if result.geotiff else 'PNG'} maps of {w}x{h} "
          f"px, gauges.csv and spill.json to {result.folder.resolve()} ({title}; release at "
          f"{report.source_xy_m[0]:.1f},{report.source_xy_m[1]:.1f}{moved}; after "
          f"{final.time_s / 3600:.2f} h: {final.in_water_kg:.4g} kg in the water, "
          f"{sum(final.out_kg.values()):.4g} kg out, {final.decayed_kg:.4g} kg decayed)")
    return 0


def _run_bake_tiles(args, scene, title, zooms) -> int:
    from riverflow.gis.tiles import bake_tiles

    workers, scheduler = args.workers, args.scheduler
    try:
        result = bake_tiles(scene, args.tiles, zooms, crs=args.crs, region_m=args.region,
                            max_speed_mps=args.max_speed, workers=workers,
                            scheduler=scheduler, progress=True)
    except (ImportError, ValueError, OSError) as exc:
        print(f"riverflow bake: {exc}", file=sys.stderr)
        return 1
    print(f"wrote {result.written} tiles to {result.folder.resolve()} ({title}: zoom "
          f"{zooms[0]}-{zooms[1]}, {result.skipped} already there, {result.empty} without "
          f"water not written, max speed {result.max_speed_mps:.3g} m/s, "
          f"{result.seconds:.1f} s); TileJSON {result.tilejson.name}")
    return 0


def add_view_command(sub) -> None:
    """The ``view`` subcommand: a page that animates a tile pyramid's water in a browser."""
    p = sub.add_parser(
        "view", help="write (and --serve) a web page that shows baked flow tiles flowing",
        description="Write DIR/index.html for a pyramid that `riverflow bake --tiles DIR` "
                    "baked: a self-contained page (Leaflet inlined, no CDN) that draws the "
                    "water from the tiles and animates it with particles. Browsers cannot read "
                    "the pixels of file:// images: open it with --serve.")
    p.add_argument("folder", type=Path, metavar="DIR", help="the tile pyramid's folder")
    p.add_argument("--serve", action="store_true",
                   help="serve DIR on http://127.0.0.1:PORT/ until interrupted")
    p.add_argument("--port", type=_port, default=8000, metavar="PORT",
                   help="--serve: the port (0: any free one; default: %(default)s)")
    p.add_argument("--basemap", default=None, metavar="URL",
                   help="an XYZ basemap URL (https://…/{z}/{x}/{y}.png) under the water "
                        "(default: a plain colour; nothing is fetched)")
    p.add_argument("--attribution", default="", metavar="TEXT",
                   help="--basemap: its attribution, shown in the corner")
    p.set_defaults(run=run_view)


def _port(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a port number, got {text[:40]!r}") from None
    if not 0 <= value <= 65535:
        raise argparse.ArgumentTypeError(f"must be 0 … 65535, got {text[:40]!r}")
    return value


def run_view(args: argparse.Namespace) -> int:
    from riverflow.web import serve, write_viewer

    try:
        page = write_viewer(args.folder, basemap=args.basemap, attribution=args.attribution)
    except (ValueError, OSError) as exc:
        print(f"riverflow view: {exc}", file=sys.stderr)
        return 1
    print(f"wrote {page.resolve()}")
    if args.serve:
        try:
            server = serve(args.folder, args.port, background=True)
        except OSError as exc:
            print(f"riverflow view: cannot serve on port {args.port}: {exc}", file=sys.stderr)
            return 1
        host, port = server.server_address[:2]
        print(f"serving {args.folder} on http://{host}:{port}/ (Ctrl-C stops)", flush=True)
        try:
            threading_event_wait()
        except KeyboardInterrupt:
            pass
        finally:
            server.shutdown()
            server.server_close()
    return 0


def threading_event_wait() -> None:
    """Wait until interrupted."""
    import threading

    threading.Event().wait()


def add_check_command(sub) -> None:
    """The ``check`` subcommand (SPEC §7): the import report of a GIS file."""
    p = sub.add_parser(
        "check", help="read GIS stream lines, repair and build them, and print the report",
        description="Read stream centre lines (shapefile, GeoPackage, GeoJSON, OpenStreetMap "
                    ".osm / .osm.pbf) as riverflow.read_rivers does, build the network and "
                    "print the report: features, links, every repair with the feature it "
                    "touched, what was derived, the total length. Exits 1 only when the data "
                    "cannot be used at all (or, with --strict, at the first defect).")
    p.add_argument("file", type=Path, metavar="FILE", help="the GIS file")
    p.add_argument("--layer", default=None, metavar="NAME",
                   help="the layer to read (default: its line layer)")
    p.add_argument("--strict", action="store_true",
                   help="no repairs: the first defect is an error (stream lines)")
    add_water_options(p)
    p.set_defaults(run=run_check)


def run_check(args: argparse.Namespace) -> int:
    from riverflow.gis.rivers import read_rivers
    from riverflow.gis.water import holds_water_areas
    from riverflow.hydro.graph import GraphError

    try:
        if holds_water_areas(args.file, args.layer):
            builder = read_water_args(args.file, args)
        else:
            builder = read_rivers(args.file, layer=args.layer, strict=args.strict)
        graph = builder.build()
    except (GraphError, FileNotFoundError, ImportError) as exc:
        print(f"riverflow check: {exc}", file=sys.stderr)
        return 1
    report = builder.report
    print(report)
    lakes = graph.lakes()
    for line in lake_lines(graph):
        print(line)
    print(f"usable: {len(report.links)} links, {report.length_m / 1000.0:.3f} km of river, "
          f"{len(report.repairs)} repairs; the hydro graph has {len(graph.curves)} curves and "
          f"{len(graph.areas)} areas" + (f", {len(lakes)} of them lakes" if lakes else ""))
    return 0


def lake_lines(graph) -> list[str]:
    """One line per lake of a hydro graph: its area, level and mouths."""
    import shapely

    from riverflow.hydro.areas import area_ring

    lines = []
    for k in graph.lakes():
        area = graph.areas[k]
        poly = shapely.Polygon(area_ring(graph, k))
        x, y = poly.representative_point().coords[0]
        mouths = sum(1 for c, _ in area.curves if not graph.curves[c].is_bank)
        level = (f"level {area.level_m:g} m" if area.level_m is not None
                 else "level from the terrain")
        lines.append(f"  lake (area {k}) near ({x:.1f}, {y:.1f}): {poly.area:,.0f} m², {level}, "
                     + (f"{mouths} river mouths" if mouths else "no river (still water)"))
    return lines


def _point(text: str) -> tuple[float, float]:
    """X,Y: two finite numbers."""
    try:
        x, y = (float(v) for v in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected X,Y (two numbers, the data's CRS), got "
                                         f"{text[:80]!r}") from None
    if not (math.isfinite(x) and math.isfinite(y)):
        raise argparse.ArgumentTypeError(f"X,Y must be finite numbers, got {text[:80]!r}")
    return x, y


def _point_or_lines(text: str):
    """X,Y, or a GIS file of lines (a coastline, a dam: :func:`~riverflow.read_water`'s
    outlet lines)."""
    try:
        return _point(text)
    except argparse.ArgumentTypeError:
        if Path(text).is_file():
            return text
        raise argparse.ArgumentTypeError(f"expected X,Y (two numbers, the data's CRS) or a "
                                         f"file of lines, got {text[:80]!r}") from None


def _region(text: str) -> tuple[float, float, float, float]:
    """X0,Y0,X1,Y1: four finite numbers [m], X0 < X1 and Y0 < Y1."""
    try:
        x0, y0, x1, y1 = (float(v) for v in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected X0,Y0,X1,Y1 in metres, got "
                                         f"{text[:80]!r}") from None
    if not all(math.isfinite(v) for v in (x0, y0, x1, y1)):
        raise argparse.ArgumentTypeError(f"X0,Y0,X1,Y1 must be finite numbers [m], got "
                                         f"{text[:80]!r}")
    if not (x1 > x0 and y1 > y0):
        raise argparse.ArgumentTypeError(f"need X0 < X1 and Y0 < Y1, got {text!r}")
    return x0, y0, x1, y1
