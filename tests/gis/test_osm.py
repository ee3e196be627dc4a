"""OpenStreetMap (issue 21, item 2): ``rf.read_rivers("x.osm")`` reads the ``lines`` layer of
GDAL's OSM driver: ``waterway=river|stream|canal|ditch|drain`` ways, their ``width`` tag, OSM's
rule that waterways are drawn downstream; the ways left out are reported. The ``.osm`` XML is
written by the test, and converted to ``.osm.pbf`` with pyosmium (``osmium``, of the test
extra: GDAL reads PBF but cannot write it)."""
from __future__ import annotations

import numpy as np
import pyproj
import pytest

import riverflow as rf
from tests.gis.conftest import ORIGIN, UTM, along, polyline, require_gis

require_gis()


def write_osm(path, ways):
    """ways: [(id, points (K, 2) [m] relative to ORIGIN in UTM 33N, {tag: value})]; points
    that coincide become one shared node."""
    to = pyproj.Transformer.from_crs(UTM, "EPSG:4326", always_xy=True)
    nodes, xml_ways = {}, []
    for wid, pts, tags in ways:
        refs = []
        for p in np.asarray(pts, float):
            key = (round(p[0], 3), round(p[1], 3))
            if key not in nodes:
                nodes[key] = len(nodes) + 1
            refs.append(nodes[key])
        body = "".join(f'<nd ref="{r}"/>' for r in refs)
        body += "".join(f'<tag k="{k}" v="{v}"/>' for k, v in tags.items())
        xml_ways.append(f'<way id="{wid}" version="1">{body}</way>')
    xml_nodes = []
    for (x, y), nid in nodes.items():
        lon, lat = to.transform(x + ORIGIN[0], y + ORIGIN[1])
        xml_nodes.append(f'<node id="{nid}" lat="{lat:.9f}" lon="{lon:.9f}" version="1"/>')
    path.write_text('<?xml version="1.0" encoding="UTF-8"?>\n<osm version="0.6">\n'
                    + "\n".join(xml_nodes + xml_ways) + "\n</osm>\n")
    return path


def flow_at(builder, graph, pts):
    """(status, velocity) of the built network's flow at points [m] relative to ORIGIN."""
    shift = ORIGIN - np.asarray(builder.report.origin_m or (0.0, 0.0))
    return rf.FlowField(graph).query(np.asarray(pts, float) + shift)


def to_pbf(osm_path):
    """The .osm file converted to .osm.pbf (protobuf, as planet extracts come) by pyosmium."""
    osmium = pytest.importorskip("osmium", reason="pyosmium writes the .osm.pbf "
                                                  "(pip install osmium; the test extra)")
    pbf = osm_path.with_name(osm_path.name.removesuffix(".osm") + ".osm.pbf")
    with osmium.SimpleWriter(str(pbf)) as writer:
        for obj in osmium.FileProcessor(str(osm_path)):
            writer.add(obj)
    assert pbf.read_bytes()[4:23].find(b"OSMHeader") >= 0      # a PBF, not XML renamed
    return pbf


@pytest.mark.parametrize("suffix", [".osm", ".osm.pbf"])
def test_waterways_of_an_osm_file(tmp_path, suffix):
    river = polyline((-1000, 0), (0, 0), (1000, 100), step=100.0)
    stream = polyline((-300, 700), (-100, 300), (0, 0), step=100.0)     # joins at a river node
    ditch = polyline((600, -500), (300, -100), step=100.0)               # ends in the fields
    road = polyline((-800, -400), (-800, 400), step=100.0)               # crosses the river
    bank = polyline((-1000, 30), (1000, 130), step=200.0)
    path = write_osm(tmp_path / "area.osm", [
        (101, river, {"waterway": "river", "width": "25", "name": "Big"}),
        (102, stream, {"waterway": "stream"}),
        (103, ditch, {"waterway": "ditch", "width": "2 m"}),
        (104, road, {"highway": "residential"}),
        (105, bank, {"waterway": "riverbank"})])
    if suffix == ".osm.pbf":
        path = to_pbf(path)
    builder = rf.read_rivers(path)
    graph = builder.build()
    assert rf.validate_graph(graph) == []
    report = builder.report
    assert report.layer == "lines" and report.features == 3
    (left,) = [n for n in report.notes if n.startswith("OpenStreetMap")]
    assert "2 ways left out" in left and "waterway=riverbank ×1" in left
    assert "not a waterway ×1" in left and "104" in left and "105" in left
    widths = {lk.name: lk.width_m for lk in report.links}
    assert widths["feature 101 piece 0"] == widths["feature 101 piece 1"] == 25.0
    assert widths["feature 103"] == 2.0
    assert report.repairs == []           # OSM ways are drawn downstream: nothing turned
    field = rf.FlowField(graph)
    for line in (river, stream[:-3]):
        pts, tangent = along(line + ORIGIN - report.origin_m, step=5.0, skip_m=20.0)
        status, velocity = field.query(pts)
        assert (status == rf.FlowStatus.INSIDE).all()
        assert (np.einsum("ij,ij->i", velocity, tangent) > 0).all()


def test_an_osm_file_without_waterways(tmp_path):
    path = write_osm(tmp_path / "roads.osm",
                     [(1, polyline((0, 0), (500, 0)), {"highway": "primary"})])
    with pytest.raises(rf.GraphError, match=r"roads.osm \(layer 'lines'\): no features.*"
                                            r"1 ways left out"):
        rf.read_rivers(path)


def test_osm_waterfalls_weirs_and_dams_become_falls(tmp_path):
    """A waterway=waterfall node on the river with a height tag, a waterway=weir way across
    it without one (the default drop, reported) and a waterfall node in the fields (left
    out, reported) (issue 23)."""
    river = polyline((-1000, 0), (1000, 0), step=100.0)
    path = write_osm(tmp_path / "falls.osm", [
        (101, river, {"waterway": "river", "width": "25"}),
        (102, np.array([[300.0, -20.0], [300.0, 20.0]]), {"waterway": "weir"})])
    to = pyproj.Transformer.from_crs(UTM, "EPSG:4326", always_xy=True)
    extra = []
    for nid, (x, y), tags in ((9001, (-200.0, 0.0), {"waterway": "waterfall", "height": "4"}),
                              (9002, (-200.0, 400.0), {"waterway": "waterfall"})):
        lon, lat = to.transform(x + ORIGIN[0], y + ORIGIN[1])
        body = "".join(f'<tag k="{k}" v="{v}"/>' for k, v in tags.items())
        extra.append(f'<node id="{nid}" lat="{lat:.9f}" lon="{lon:.9f}" version="1">{body}'
                     f'</node>')
    text = path.read_text()
    path.write_text(text.replace('<way id="101"', "\n".join(extra) + '\n<way id="101"', 1))
    builder = rf.read_rivers(path)
    graph = builder.build()
    falls = sorted(graph.falls, key=lambda f: f.centre_m[0])
    assert [f.kind for f in falls] == ["fall", "weir"]
    shift = np.asarray(builder.report.origin_m or (0.0, 0.0))
    assert np.allclose(np.asarray(falls[0].centre_m) + shift, (-200.0 + ORIGIN[0], ORIGIN[1]),
                       atol=1.0) or np.allclose(falls[0].centre_m, (-200.0, 0.0), atol=1.0)
    assert falls[0].drop_m == 4.0 and falls[1].drop_m == 2.0
    notes = " ".join(builder.report.notes)
    assert "way 102" in notes and "2 m assumed" in notes
    assert "node 9002" in notes and "falls left out" in notes and "off the river" in notes
    assert "ways left out" not in notes          # the weir is a fall, not a left-out way


def test_a_river_cut_at_a_culvert_a_ditch_beside_a_stream_and_a_weir(tmp_path):
    """What Liechtenstein's extract holds and the reader refused: a river's way cut where a
    culvert ends 9 m below its source (that piece alone a branch shorter than the river is
    wide: "do not meet"), joined to the next one (named after it); a ditch 8 m beside a
    stream, each a source as wide as its class is (they were 10 m rivers, overlapping);
    and a weir across one of several ways of different lengths (the weir's search over
    the lines raised a ValueError from shapely)."""
    culvert = np.array([[0.0, -9.0], [0.0, 0.0]])
    river = polyline((0, 0), (0, 400), step=50.0)
    stream = polyline((200, 0), (200, 600), step=100.0)
    ditch = polyline((208, 50), (208, 550), step=100.0)
    path = write_osm(tmp_path / "culvert.osm", [
        (201, culvert, {"waterway": "river", "tunnel": "culvert", "layer": "-1"}),
        (202, river, {"waterway": "river"}),
        (203, stream, {"waterway": "stream"}),
        (204, ditch, {"waterway": "ditch"}),
        (205, np.array([[-20.0, 200.0], [20.0, 200.0]]), {"waterway": "weir"})])
    builder = rf.read_rivers(path)
    graph = builder.build()
    assert rf.validate_graph(graph) == []
    report = builder.report
    widths = {lk.name: lk.width_m for lk in report.links}
    assert set(widths) == {"feature 202", "feature 203", "feature 204"}
    assert any(n.startswith("1 junctions where one line runs on into the next") for n in report.notes)
    assert widths["feature 204"] < widths["feature 203"] < 3.0 < widths["feature 202"]
    assert "default (a source 1 m wide: OSM waterway=ditch)" in report.derived["discharge"]
    (fall,) = graph.falls
    assert fall.kind == "weir"
    status, velocity = rf.FlowField(graph).query(
        np.array([[0.0, -4.0], [0.0, 300.0], [200.0, 300.0], [208.0, 300.0]])
        + ORIGIN - np.asarray(report.origin_m or (0.0, 0.0)))
    assert (status == rf.FlowStatus.INSIDE).all() and (velocity[:, 1] > 0).all()


def test_an_osm_file_whose_node_ids_do_not_increase(tmp_path):
    """An editor's export lists its nodes in any order (graphhopper's moscow.osm): GDAL's OSM
    driver refuses it ("Non increasing node id. Use OSM_USE_CUSTOM_INDEXING=NO"); the
    readers retry with that option."""
    river = polyline((-500, 0), (500, 0), step=100.0)
    stream = polyline((0, 400), (0, 0), step=100.0)
    path = write_osm(tmp_path / "shuffled.osm", [(101, river, {"waterway": "river"}),
                                                 (102, stream, {"waterway": "stream"})])
    lines = path.read_text().splitlines()
    nodes = [ln for ln in lines if ln.startswith("<node")]
    rest = [ln for ln in lines if not ln.startswith("<node")]
    path.write_text("\n".join(rest[:2] + nodes[::-1] + rest[2:]) + "\n")
    builder = rf.read_rivers(path)
    assert len(builder.report.links) == 3
    assert rf.validate_graph(builder.build()) == []


def test_an_osm_way_drawn_the_wrong_way_round_a_loop_is_turned(tmp_path):
    """graphhopper's north-bayreuth.osm: a stream leaves the Roter Main and is drawn back up
    to join it 1.4 km upstream, a loop that flows back into itself ("form a loop": refused,
    OSM ways being never turned). The loop's smallest, shortest way is turned (a side arm
    from upstream to downstream), a reported repair."""
    river = polyline((0, 0), (1500, 0), step=100.0)
    arm = polyline((1200, 0), (1100, 150), (400, 150), (300, 0), step=100.0)   # drawn upstream
    path = write_osm(tmp_path / "loop.osm", [(101, river, {"waterway": "river", "width": "20"}),
                                             (102, arm, {"waterway": "stream", "width": "6"})])
    builder = rf.read_rivers(path)
    graph = builder.build()
    assert rf.validate_graph(graph) == []
    (said,) = [r.what for r in builder.report.repairs if r.feature == "feature 102"]
    assert said.startswith("closed a loop that flows back into itself") and "turned" in said
    status, velocity = flow_at(builder, graph, [[700.0, 150.0], [700.0, 0.0]])
    assert (status == rf.FlowStatus.INSIDE).all() and (velocity[:, 0] > 0).all()


def test_an_osm_way_drawn_out_and_back_over_itself(tmp_path):
    """Liechtenstein's OSM extract of today: a stream's way drawn up a valley and back down
    across its own line (it crosses itself twice), beside a stream drawn down the same
    valley: the crossings made pieces between the same two nodes in both directions, and
    turning one closed the loop again with the next ("a loop that flows back into itself",
    the whole file refused). The loop between its crossings is cut out, a reported repair."""
    river = polyline((0, 0), (1500, 0), step=100.0)
    hairpin = polyline((300, 400), (500, 800), (520, 790), (380, 620), (300, 300), (250, 0),
                       step=20.0)
    path = write_osm(tmp_path / "hairpin.osm", [(101, river, {"waterway": "river", "width": "20"}),
                                                (102, hairpin, {"waterway": "stream"})])
    builder = rf.read_rivers(path)
    graph = builder.build()
    assert rf.validate_graph(graph) == []
    (said,) = [r.what for r in builder.report.repairs if r.feature == "feature 102"]
    assert said.startswith("crosses itself") and "loop between the crossings cut out" in said
    status, velocity = flow_at(builder, graph, [[275.0, 150.0]])
    assert status[0] == rf.FlowStatus.INSIDE and velocity[0, 1] < 0.0     # down to the river


def test_osm_ways_joined_where_the_line_turns_back(tmp_path):
    """Two ways of one stream meeting where the line turns back on itself (170°: drawn to a
    point and back out beside itself): joined into one link, the builder refused the turn
    ("turns back on itself"); the joint's spike is dropped, as a single line's are."""
    river = polyline((0, 0), (1500, 0), step=100.0)
    upper = polyline((600, 700), (600, 320), step=50.0)
    lower = np.array([[600.0, 320.0], [612.0, 390.0], [700.0, 300.0], [750.0, 0.0]])
    path = write_osm(tmp_path / "joint.osm", [(101, river, {"waterway": "river", "width": "20"}),
                                              (102, upper, {"waterway": "stream"}),
                                              (103, lower, {"waterway": "stream"})])
    builder = rf.read_rivers(path)
    assert rf.validate_graph(builder.build()) == []
    assert any("joined into one link" in n and "turned back on itself" in n
               for n in builder.report.notes)


def test_a_loop_of_three_ways_between_two_junctions_is_broken_once_each():
    """Three OSM ways between two junctions drawn →, ←, →, the first the shortest: turning it
    closed a loop with the third, which turned it back, and so on until the loop was left
    ("flows back into itself"). A way is turned once at most."""
    from riverflow.gis.rivers import RiverImport, _break_osm_loops, _Link
    from riverflow.hydro.builder import upstream_first

    def link(name, pts, start, end):
        return _Link(name, 0, np.asarray(pts, float), {"waterway": "stream"}, {}, start, end)

    links = [link("in", [(0, 0), (100, 0)], -1, 0),
             link("a", [(100, 0), (300, 0)], 0, 1),
             link("b", [(300, 0), (200, 80), (100, 0)], 1, 0),
             link("c", [(100, 0), (200, -150), (300, 0)], 0, 1),
             link("out", [(300, 0), (400, 0)], 1, -1)]
    report = RiverImport("x.osm", "lines", len(links), None, None)
    _break_osm_loops(links, report)
    _, left = upstream_first([lk.start for lk in links], [lk.end for lk in links])
    assert left == [] and len(report.repairs) <= 2
