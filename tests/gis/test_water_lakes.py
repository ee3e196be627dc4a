"""Lakes in water polygons (issue 22, item 2): polygons tagged ``water=lake|reservoir|pond``
(an OSM tag, or a polygon file's ``water`` attribute) are read as lakes: the rivers' water is
cut open at their shores, the lake is a flat water body the rivers run into and out of; a
file of lakes alone is still water; ``riverflow check`` lists the lakes."""
from __future__ import annotations

import numpy as np
import pytest
import shapely

import riverflow as rf
from riverflow.hydro.areas import area_ring
from tests.gis.conftest import DRIVERS, ORIGIN, UTM, require_gis

require_gis()

LAKE = shapely.Point(600, 0).buffer(150, quad_segs=16)
WEST = shapely.LineString([(0, 20), (300, 0), (520, 0)]).buffer(15, cap_style="flat")
EAST = shapely.LineString([(680, 0), (900, -30), (1200, -30)]).buffer(20, cap_style="flat")


def write_tagged(path, geoms, water, field="water"):
    """Polygons (relative to ORIGIN) with a ``water`` attribute (``field``: another name;
    numbers are written as numbers)."""
    import pyogrio.raw

    geoms = [shapely.transform(g, lambda p: p + ORIGIN) for g in geoms]
    values = np.array(water, dtype=None if isinstance(water[0], (int, float)) else object)
    pyogrio.raw.write(str(path), np.array([shapely.to_wkb(g) for g in geoms], dtype=object),
                      [values], [field], driver=DRIVERS[path.suffix],
                      crs=UTM, geometry_type="Polygon")
    return path


def flow_at(builder, graph, pts):
    """(status, velocity) of the built network's flow at points [m] relative to ORIGIN."""
    shift = ORIGIN - np.asarray(builder.report.origin_m or (0.0, 0.0))
    return rf.FlowField(graph).query(np.asarray(pts, float) + shift)


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


def test_nhd_feature_types_of_standing_water_are_lakes(tmp_path):
    """The National Hydrography Dataset's polygons say what they are in ``FTYPE``: NHDPlus
    by name (LakePond, Reservoir, SwampMarsh; StreamRiver is a river's water), NHD HR by
    code (390, 436; 460): its waterbodies are lakes (a real NHDPlus waterbody layer came in
    as rivers and was refused, "do not meet")."""
    for name, ftypes in (("plus.shp", ["StreamRiver", "LakePond", "StreamRiver"]),
                         ("hr.gpkg", [460, 390, 460])):
        path = write_tagged(tmp_path / name, [WEST, LAKE, EAST], ftypes, field="FTYPE")
        b = rf.read_water(path, inlets=[tuple(ORIGIN + (0, 20))],
                          outlets=[tuple(ORIGIN + (1200, -30))])
        graph = b.build()
        (k,) = graph.lakes()
        assert len(b.discharges_m2s) == 2, name
        lake = shapely.Polygon(area_ring(graph, k))
        assert abs(lake.area - LAKE.area) < 0.01 * LAKE.area, name
    ponds = [shapely.Point(0, 0).buffer(60), shapely.Point(400, 0).buffer(40)]
    path = write_tagged(tmp_path / "wb.shp", ponds, ["SwampMarsh", "Reservoir"], field="FType")
    assert len(rf.read_water(path).build().lakes()) == 2


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


def test_osm_water_without_a_water_tag_and_oxbows_are_lakes(tmp_path):
    """OpenStreetMap's ``natural=water`` without ``water=`` is a lake (the tag's documented
    default: Liechtenstein's extract holds 20 such ponds and lakes, which came in as rivers
    or were left out); ``water=oxbow`` is an oxbow lake: still water."""
    from tests.gis.test_osm import write_osm

    pond = np.asarray(shapely.Point(0, 0).buffer(40, quad_segs=8).exterior.coords)
    oxbow = np.asarray(shapely.LineString([(300, 0), (300, 150), (450, 150), (450, 0)])
                       .buffer(12, cap_style="flat").exterior.coords)
    path = write_osm(tmp_path / "ponds.osm", [(301, pond, {"natural": "water"}),
                                               (302, oxbow, {"natural": "water",
                                                             "water": "oxbow"})])
    builder = rf.read_water(path)
    graph = builder.build()
    assert len(graph.lakes()) == 2 and builder.report.derived["lakes"].startswith("2 ")
    assert "OSM natural=water areas without water=" in builder.report.derived["lakes"]
    centres = [shapely.Polygon(area_ring(graph, k)).representative_point().coords[0]
               for k in graph.lakes()]
    status, v = rf.FlowField(graph).query(np.array(centres))
    assert (status == rf.FlowStatus.INSIDE).all() and np.abs(v).max() < 1e-6


def test_a_pond_apart_from_a_river_polygon_is_still_water(tmp_path):
    """A round pond beside a river in one untagged polygon file (a water mask's gravel pit):
    still water (a lake, reported), where it was left out; a speck is still left out."""
    pond = shapely.Point(300, 200).buffer(40, quad_segs=8)
    speck = shapely.Point(700, 200).buffer(1.5, quad_segs=4)
    path = write_tagged(tmp_path / "w.geojson", [WEST, pond, speck], ["river", None, None])
    builder = rf.read_water(path, inlets=[tuple(ORIGIN + (0, 20))])
    graph = builder.build()
    (k,) = graph.lakes()
    assert abs(shapely.Polygon(area_ring(graph, k)).area - pond.area) < 0.01 * pond.area
    said = [r.what for r in builder.report.repairs if r.feature.startswith("water body")]
    assert any("a pond, read as still water" in w for w in said)
    assert any("a speck" in w and "left out" in w for w in said)
    status, v = rf.FlowField(graph).query(np.array([[300.0, 200.0], [150.0, 10.0]]))
    assert (status == rf.FlowStatus.INSIDE).all()
    assert np.abs(v[0]).max() < 1e-6 and v[1, 0] > 0.0        # the pond still, the river on


def test_osm_ponds_whose_rings_cross_themselves_or_each_other(tmp_path):
    """Real OSM ponds (graphhopper's krems.osm: 27 untagged ponds, a sliver of their union
    was read as a river and refused): a ring drawn as a bow tie (made valid: two triangles
    meeting at a point, lakes that touch: refused) is two lakes, one's shore moved back
    from the other round the point, reported; two ponds drawn overlapping are one lake; nothing is read as a
    river."""
    from tests.gis.test_osm import write_osm

    bowtie = np.array([(0, 0), (100, 0), (0, 60), (100, 60), (0, 0)], float)
    a = np.asarray(shapely.Point(300, 0).buffer(40, quad_segs=7).exterior.coords)
    b = np.asarray(shapely.Point(355, 3).buffer(30, quad_segs=5).exterior.coords)
    path = write_osm(tmp_path / "ponds.osm", [(401, bowtie, {"natural": "water"}),
                                               (402, a, {"natural": "water"}),
                                               (403, b, {"natural": "water"})])
    builder = rf.read_water(path)
    graph = builder.build()
    assert len(graph.lakes()) == 3 and builder.discharges_m2s == []
    said = [r.what for r in builder.report.repairs if r.feature == "water"]
    assert len(said) == 1 and "two parts of the water touch" in said[0]
    assert "near (50.0, 30.0)" in said[0] and "moved back to 0.5 m from the other" in said[0]
    rings = [shapely.Polygon(area_ring(graph, k)) for k in graph.lakes()]
    rings.sort(key=lambda p: p.area)
    assert rings[-1].area > shapely.Point(0, 0).buffer(40, quad_segs=7).area   # the two as one
    # the bow tie's halves (1,500 m² each): one cut back round the point where they met
    assert 1499.0 < rings[0].area <= rings[1].area < 1501.0
    assert rings[0].distance(rings[1]) > 0.45        # (the buffer's chords: 0.498 m)


def test_a_ring_of_water_round_an_island_beside_a_river_is_still_water(tmp_path):
    """Liechtenstein's OSM extract of today: a riverbank polygon round an island, cut off
    from its river (a ring of water, its skeleton a loop): no way in or out, and the whole
    file was refused ("fewer than two free ends"). It is still water, a lake with its
    island (reported); the river beside it builds and flows."""
    moat = shapely.Point(600, 300).buffer(45).difference(shapely.Point(600, 300).buffer(20))
    river = shapely.LineString([(0, 0), (1200, 0)]).buffer(15, cap_style="flat")
    path = write_tagged(tmp_path / "moat.gpkg", [river, moat], ["river", "river"])
    b = rf.read_water(path, inlets=[tuple(ORIGIN + (0, 0))])
    graph = b.build()
    assert rf.validate_graph(graph) == []
    (said,) = [r.what for r in b.report.repairs if "no way in and out" in r.what]
    assert "a ring round 1 islands" in said and "still water (a lake)" in said
    (k,) = graph.lakes()
    assert abs(shapely.Polygon(area_ring(graph, k)).area - moat.exterior.convex_hull.area) \
        < 0.02 * moat.exterior.convex_hull.area
    status, v = flow_at(b, graph, [[600.0, 332.0], [600.0, 300.0], [600.0, 0.0]])
    assert list(status) == [rf.FlowStatus.INSIDE, rf.FlowStatus.OUTSIDE, rf.FlowStatus.INSIDE]
    assert np.abs(v[0]).max() < 1e-6 and v[2, 0] > 0.0


def pond_on_an_island(tmp_path, island_m: float, pond_m: float):
    """(builder, graph) of a 200 m river with a round island (radius ``island_m``) in its
    middle and a pond (radius ``pond_m``) on the island, built and checked."""
    river = shapely.box(0, -100, 1200, 100).difference(shapely.Point(600, 0).buffer(island_m))
    pond = shapely.Point(600, 0).buffer(pond_m)
    path = write_tagged(tmp_path / "pond.gpkg", [river, pond], ["river", "pond"])
    b = rf.read_water(path, inlets=[tuple(ORIGIN + (0, 0))])
    graph = b.build()
    assert rf.validate_graph(graph) == []
    return b, graph


def test_a_pond_on_a_rivers_island_is_water_again(tmp_path):
    """Liechtenstein's OSM extract of today: a pond on an island of the Rhine's riverbank
    polygon. The graph checks took its shore for a loop inside the river's area ("counter-
    clockwise loop inside another area") and its water for the island's land; by the odd
    winding rule the hydro graph's areas follow, water inside an island is water again."""
    b, graph = pond_on_an_island(tmp_path, 60.0, 25.0)
    assert len(graph.lakes()) == 1
    status, v = flow_at(b, graph, [[600.0, 0.0], [600.0, 45.0], [600.0, 80.0]])
    assert list(status) == [rf.FlowStatus.INSIDE, rf.FlowStatus.OUTSIDE, rf.FlowStatus.INSIDE]
    assert np.abs(v[0]).max() < 1e-6 and v[2, 0] > 0.0


def test_a_pond_on_a_free_island_is_water_again(tmp_path):
    """A pond on a small island in one channel (a free island: the channel's axis runs
    across it): the axis was cut at the pond's shore ("ends both at a junction and on the
    shore of lake 0") and the island's land cut the pond's water away ("the rivers cut it
    into 0 pieces"). A lake apart from the rivers' water cuts no axis, and its water is
    water again inside the island."""
    b, graph = pond_on_an_island(tmp_path, 30.0, 12.0)
    assert b.report.derived["islands"]["free (in one channel)"] == 1 and len(graph.lakes()) == 1
    status, v = flow_at(b, graph, [[600.0, 0.0], [600.0, 20.0], [600.0, 60.0]])
    assert status[0] == rf.FlowStatus.INSIDE and status[1] != rf.FlowStatus.INSIDE
    assert status[2] == rf.FlowStatus.INSIDE and np.abs(v[0]).max() < 1e-6 and v[2, 0] > 0.0


def test_a_lone_pond_or_moat_with_nothing_said_of_how_it_flows_is_still_water(tmp_path):
    """A file of one water body that no inlet, outlet or line says runs anywhere: a square
    moat round its island (the skeleton's spurs into its corners were given back as a
    river's two ends: refused, "no banks found across its middle") and a round lake from a
    water mask (read as a river 300 m long and 480 m wide, from its narrower end to its
    wider) are still water, lakes (reported); the lake with an inlet and an outlet given is a
    river through it. A body longer than twice its width is no pond: a river 1 km long and
    80 m wide, necked to 8 m, whose banks lie on its file's box (read as the data's edge
    with its ends, one piece round each corner, its skeleton was broken, 250 m long, as
    wide: refused, then a pond) is a river through its neck."""
    from tests.gis.test_water import write_mask, write_polygons

    moat = shapely.box(0, 0, 1000, 1000).difference(shapely.box(50, 50, 950, 950))
    b = rf.read_water(write_polygons(tmp_path / "moat.geojson", [moat]))
    graph = b.build()
    (said,) = [r.what for r in b.report.repairs if "no way in and out" in r.what]
    assert "a ring round 1 islands" in said and b.discharges_m2s == []
    (k,) = graph.lakes()
    assert abs(shapely.Polygon(area_ring(graph, k)).area - 1000.0 ** 2) < 1.0
    t = np.linspace(0.0, 2.0 * np.pi, 90, endpoint=False)
    r = 240.0 * (1.0 + 0.12 * np.cos(3.0 * t + 0.4) + 0.06 * np.sin(5.0 * t))
    lake = shapely.Polygon(np.c_[600.0 + r * np.cos(t), 300.0 + 0.8 * r * np.sin(t)])
    mask = write_mask(tmp_path / "lake.tif", lake, 5.0, bounds=(200.0, -100.0, 1000.0, 700.0))
    b = rf.read_water(mask)
    graph = b.build()
    assert b.discharges_m2s == [] and len(graph.lakes()) == 1
    assert any("a pond, read as still water" in r.what for r in b.report.repairs)
    status, v = flow_at(b, graph, [[600.0, 300.0]])
    assert status[0] == rf.FlowStatus.INSIDE and np.abs(v).max() < 1e-6
    b = rf.read_water(mask, inlets=[tuple(ORIGIN + (600.0 - 1.12 * 240.0, 300.0))],
                      outlets=[tuple(ORIGIN + (600.0 + 0.94 * 240.0, 300.0))])
    graph = b.build()
    assert graph.lakes() == [] and b.discharges_m2s
    status, v = flow_at(b, graph, [[600.0, 300.0]])
    assert status[0] == rf.FlowStatus.INSIDE and v[0, 0] > 0.0
    necked = shapely.union_all([shapely.box(0, 0, 480, 80), shapely.box(480, 36, 520, 44),
                                shapely.box(520, 0, 1000, 80)])
    b = rf.read_water(write_polygons(tmp_path / "necked.geojson", [necked]))
    graph = b.build()
    assert b.report.derived["axes"] == {"skeleton": 1} and graph.lakes() == []
    status, v = flow_at(b, graph, [[200.0, 40.0], [500.0, 40.0], [800.0, 40.0]])
    assert (status == rf.FlowStatus.INSIDE).all() and len(set(np.sign(v[:, 0]))) == 1
    assert abs(v[1, 0]) > 5.0 * abs(v[0, 0])                 # faster through the neck
