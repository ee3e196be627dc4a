"""Lakes in water polygons (issue 22, item 2): polygons tagged ``water=lake|reservoir|pond``
(an OSM tag, or a polygon file's ``water`` attribute) are read as lakes: the rivers' water is
cut open at their shores, the lake is a flat water body the rivers run into and out of; a
file of lakes alone is still water; ``riverflow check`` lists the lakes."""
from __future__ import annotations

import numpy as np
import shapely

import riverflow as rf
from riverflow.hydro.areas import area_ring
from tests.gis.conftest import DRIVERS, ORIGIN, UTM, require_gis

require_gis()

LAKE = shapely.Point(600, 0).buffer(150, quad_segs=16)
WEST = shapely.LineString([(0, 20), (300, 0), (520, 0)]).buffer(15, cap_style="flat")
EAST = shapely.LineString([(680, 0), (900, -30), (1200, -30)]).buffer(20, cap_style="flat")


def write_tagged(path, geoms, water):
    """Polygons (relative to ORIGIN) with a ``water`` attribute."""
    import pyogrio.raw

    geoms = [shapely.transform(g, lambda p: p + ORIGIN) for g in geoms]
    pyogrio.raw.write(str(path), np.array([shapely.to_wkb(g) for g in geoms], dtype=object),
                      [np.array(water, dtype=object)], ["water"], driver=DRIVERS[path.suffix],
                      crs=UTM, geometry_type="Polygon")
    return path


def test_a_polygon_tagged_lake_between_two_rivers_is_a_lake(tmp_path):
    path = write_tagged(tmp_path / "w.geojson", [WEST, LAKE, EAST], ["river", "lake", "river"])
    b = rf.read_water(path, inlets=[tuple(ORIGIN + (0, 20))],
                      outlets=[tuple(ORIGIN + (1200, -30))])
    graph = b.build()
    assert "lakes" in b.report.derived
    (k,) = graph.lakes()
    q = b.discharges_m2s
    assert len(q) == 2 and abs(q[0] - q[1]) < 1e-9          # the outlet carries the inflow
    shore = [graph.curves[c].potential for c, _ in graph.areas[k].curves if graph.curves[c].is_bank]
    assert sorted(set(shore)) == [0.0, q[0]]
    lake = shapely.Polygon(area_ring(graph, k))
    assert abs(lake.area - LAKE.area) < 0.01 * LAKE.area
    field = rf.FlowField(graph)
    status, v = field.query(np.array(lake.centroid.coords))
    assert status[0] == rf.FlowStatus.INSIDE and v[0, 0] > 0.0   # west to east across it


def test_lakes_alone_are_still_water_and_check_lists_them(tmp_path, capsys):
    from riverflow.__main__ import main

    ponds = [shapely.Point(0, 0).buffer(60), shapely.Point(400, 0).buffer(40)]
    path = write_tagged(tmp_path / "ponds.gpkg", ponds, ["pond", "reservoir"])
    graph = rf.read_water(path).build()
    assert len(graph.lakes()) == 2
    field = rf.FlowField(graph)
    centres = [shapely.Polygon(area_ring(graph, k)).centroid.coords[0] for k in graph.lakes()]
    status, v = field.query(np.array(centres))
    assert (status == rf.FlowStatus.INSIDE).all() and np.abs(v).max() < 1e-6
    assert main(["check", str(path)]) == 0
    out = capsys.readouterr().out
    assert out.count("no river (still water)") == 2
    assert "2 areas, 2 of them lakes" in out


def test_stream_lines_through_a_lake_given_with_them(tmp_path):
    """read_rivers(lakes=...): a main line through a lake and a tributary joining it inside
    the lake: both run into the lake, the line leaving it takes their sum."""
    from tests.gis.conftest import polyline, write_lines

    lines = [polyline((-800, 0), (0, 0)), polyline((0, 0), (800, 100)),
             polyline((100, -700), (0, 0))]
    net = write_lines(tmp_path / "net.geojson", lines,
                      {"name": np.array(["a", "b", "c"], dtype=object)})
    lake = shapely.Point(*ORIGIN).buffer(200)
    b = rf.read_rivers(net, lakes=[lake])
    graph = b.build()
    assert len(graph.lakes()) == 1 and "lakes" in b.report.derived
    qa, qb, qc = b.discharges_m2s
    assert abs(qb - (qa + qc)) < 1e-9


def test_a_river_polygon_into_a_lake_with_no_outlet(tmp_path):
    """A river's polygon that ends in a lake's (tagged water=lake) with nothing leaving it: a
    terminal lake, still water; the river runs into it and its water stops a tolerance off
    the shore (before, a GraphError: still water only in networks built from lines)."""
    path = write_tagged(tmp_path / "t.gpkg", [WEST, LAKE], ["river", "lake"])
    b = rf.read_water(path, inlets=[tuple(ORIGIN + (0, 20))])
    graph = b.build()
    assert "terminal lakes" in b.report.derived and len(graph.lakes()) == 1
    field = rf.FlowField(graph)
    (k,) = graph.lakes()
    river = max((graph.polyline(a) for a in graph.axes()), key=lambda p: np.ptp(p[:, 0]))
    at = np.array([river[len(river) // 2], shapely.Polygon(area_ring(graph, k)).centroid.coords[0]])
    status, v = field.query(at)
    assert (status == rf.FlowStatus.INSIDE).all()
    assert v[0, 0] > 0.0 and np.abs(v[1]).max() < 1e-6


def test_a_lake_with_an_island_between_its_centre_and_a_mouth_builds(tmp_path):
    """The lake file of the first test with an island in front of the west mouth (it built
    with the island filled; kept as a hole, it was refused as not star-shaped): it builds,
    the island is a hole of the lake's area with one ψ between the shores'."""
    from riverflow.hydro import lake_flow

    lake = LAKE.difference(shapely.Point(515, 0).buffer(20, quad_segs=8))
    path = write_tagged(tmp_path / "w.geojson", [WEST, lake, EAST], ["river", "lake", "river"])
    b = rf.read_water(path, inlets=[tuple(ORIGIN + (0, 20))],
                      outlets=[tuple(ORIGIN + (1200, -30))])
    graph = b.build()
    (k,) = graph.lakes()
    (isl,) = lake_flow.lake_islands(graph, k, 0.25)
    psi = {graph.curves[c].potential for c, _ in graph.areas[isl].curves}
    assert len(psi) == 1 and 0.0 < psi.pop() < b.discharges_m2s[0]
