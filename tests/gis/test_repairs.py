"""Real data as it comes (issue 21): ``rf.read_rivers`` repairs what real stream networks get
wrong, names the feature it touched in ``builder.report.repairs``, and the network builds and
validates; ``strict=True`` raises at the first defect instead. Each defect is written by the
test into a small file (shapefile, GeoPackage, GeoJSON)."""
from __future__ import annotations

import json
import re

import numpy as np
import pytest
import shapely

import riverflow as rf
from tests.gis.conftest import ORIGIN, UTM, along, polyline, require_gis, write_lines
from tests.gis.test_read_rivers import check_flows_downstream, confluence

_, pyproj = require_gis()


def repairs_of(builder, feature: str) -> list[str]:
    """What the report says was done to ``feature`` (its repairs' texts)."""
    return [r.what for r in builder.report.repairs if r.feature == feature]


def built(builder):
    graph = builder.build()
    assert rf.validate_graph(graph) == []
    return graph


# -- channels closer than their width --------------------------------------------------------


def braid_arms():
    """A river splitting into two 40 m arms that converge at an acute angle and run 12 - 24 m
    apart for their last 200 m (the issue's 720-link network, feature 149)."""
    return [polyline((-500, 0), (0, 0)),
            polyline((0, 0), (60, 40), (100, 12), (250, 6), (300, 0)),
            polyline((0, 0), (60, -40), (100, -12), (250, -6), (300, 0)),
            polyline((300, 0), (900, 0))]


def test_braid_arms_closer_than_their_width_merge_around_an_island(tmp_path):
    path = write_lines(tmp_path / "arms.gpkg", braid_arms(),
                       {"name": np.array(["up", "left", "right", "down"], dtype=object),
                        "W": np.array([50.0, 40.0, 40.0, 60.0])})
    with pytest.raises(rf.GraphError, match=r"arms.gpkg \(layer 'arms'\)"):
        rf.read_rivers(path, width_m="W", strict=True).build()      # today's behaviour
    builder = rf.read_rivers(path, origin_m=None, width_m="W")
    graph = built(builder)
    for feature, other in (("feature 2", "feature 3"), ("feature 3", "feature 2")):
        (what,) = repairs_of(builder, feature)                      # GeoPackage ids from 1
        assert f"runs closer to {other}" in what and "11.8 m between" in what, what
        assert "merged with it there (30.5 m apart) into one reach 50.0 m wide" in what, what
    assert not repairs_of(builder, "feature 1") and not repairs_of(builder, "feature 4")
    text = str(builder.report)
    assert "repair: feature 2" in text and "name='left'" in text
    # narrowing them would have left ~4 m of 40: merged, nothing is narrower than given
    (merged,) = [lk for lk in builder.report.links if lk.name.endswith("merged")]
    assert merged.width_m == pytest.approx(50.0)      # their discharge: the river above's
    assert min(b.widths_m.min() for b in builder._branches) >= 40.0
    # each arm meets the merged reach slantwise (it leaves its line a gap's length before
    # the cut), not square across the gap: side by side, a T's strips overlap past the disc
    branches = {b.name: b.centerline_m for b in builder._branches}
    reach = branches[merged.name]
    ahead = (reach[-1] - reach[0]) / np.hypot(*(reach[-1] - reach[0]))
    for name in ("feature 2", "feature 3"):              # (square: 75° and 105° here)
        last = branches[name][-1] - branches[name][-2]
        assert np.dot(last, ahead) / np.hypot(*last) > np.cos(np.radians(60.0)), name
    # the water between the arms above the merge is an island: land inside the braid
    field = check_flows_downstream(graph, braid_arms(), skip_m=3.0)
    status, _ = field.query(np.array([[60.0, 0.0]]) + ORIGIN)
    assert status[0] != rf.FlowStatus.INSIDE


def split_arms():
    """A river splitting into two 40 m arms that leave at an acute angle and run 12 - 24 m
    apart for their first 200 m before they part round an island (the mirror of
    :func:`braid_arms`; Sydney's OSM drains do it at 1 m)."""
    return [polyline((-500, 0), (0, 0)),
            polyline((0, 0), (50, 6), (200, 12), (240, 40), (300, 0)),
            polyline((0, 0), (50, -6), (200, -12), (240, -40), (300, 0)),
            polyline((300, 0), (900, 0))]


def test_arms_leaving_a_junction_closer_than_their_width_merge_below_it(tmp_path):
    """Two arms that leave one junction running closer than their widths allow are one
    reach from the junction to where they part (as two that join are, above it): each a
    reported repair ("for its first … m"); the island between them below that point stays
    land, and the flow runs downstream everywhere."""
    path = write_lines(tmp_path / "split.gpkg", split_arms(),
                       {"name": np.array(["up", "left", "right", "down"], dtype=object),
                        "W": np.array([50.0, 40.0, 40.0, 60.0])})
    with pytest.raises(rf.GraphError, match=r"split.gpkg \(layer 'split'\)"):
        rf.read_rivers(path, width_m="W", strict=True).build()
    builder = rf.read_rivers(path, origin_m=None, width_m="W")
    graph = built(builder)
    for feature, other in (("feature 2", "feature 3"), ("feature 3", "feature 2")):
        (what,) = repairs_of(builder, feature)
        assert f"runs closer to {other}" in what and "for its first" in what, what
        assert "merged with it there" in what and "that carries both" in what, what
    (merged,) = [lk for lk in builder.report.links if lk.name.endswith("merged")]
    assert merged.width_m >= 40.0
    field = check_flows_downstream(graph, split_arms(), skip_m=3.0)
    status, _ = field.query(np.array([[250.0, 0.0]]) + ORIGIN)
    assert status[0] != rf.FlowStatus.INSIDE


def test_neighbouring_rivers_closer_than_their_width(tmp_path):
    lines = [polyline((0, 0), (1000, 0)), polyline((0, 30), (1000, 30))]
    path = write_lines(tmp_path / "pair.shp", lines, {"W": np.array([50.0, 50.0])})
    builder = rf.read_rivers(path, origin_m=None, width_m="W")
    graph = built(builder)
    assert all("narrowed" in w for w in repairs_of(builder, "feature 0") + repairs_of(
        builder, "feature 1"))
    check_flows_downstream(graph, lines, skip_m=3.0)


# -- clipped networks --------------------------------------------------------------------------


def test_an_outlet_where_two_rivers_meet_and_nothing_leaves(tmp_path):
    """NHDPlus cut where its river joins a larger one: two rivers end at the outlet."""
    lines = confluence()[:2]
    path = write_lines(tmp_path / "cut.geojson", lines, {"A": np.array([50.0, 80.0])},
                       lonlat=True)
    builder = rf.read_rivers(path, origin_m=None, drainage_area_km2="A")
    graph = built(builder)
    (what,) = [r.what for r in builder.report.repairs]
    assert "feature 0 and feature 1 end at" in what and "outlet" in what
    check_flows_downstream(graph, lines)
    with pytest.raises(rf.GraphError, match=r"cut.geojson.*feature 0.*strict=True"):
        rf.read_rivers(path, origin_m=None, drainage_area_km2="A", strict=True)


def test_an_inflow_added_where_a_loops_arms_leave_comes_from_outside_the_loop(tmp_path):
    """NHDPlus Shellmound, feature 844: two arms leave a junction nothing enters and meet
    again, the loop closing round the side the added inflow would come from (along their
    mean direction): rising in that island, its banks were one shore. It comes from the
    other side (the repair says so), and the flow runs downstream."""
    lines = [polyline((0, 0), (200, -100), (400, 200), (0, 500)),
             polyline((0, 0), (-200, 0), (-200, 300), (0, 500)),
             polyline((0, 500), (0, 900))]
    path = write_lines(tmp_path / "loop.gpkg", lines, {"W": np.array([10.0, 10.0, 14.0])})
    builder = rf.read_rivers(path, origin_m=None, width_m="W")
    graph = built(builder)
    (what,) = repairs_of(builder, "feature 1")
    assert what.endswith("an inflow 28 m long added (on the side away from the land their "
                         "loop closes round)"), what
    inflow = next(b for b in builder._branches if b.name == "inflow of feature 1").centerline_m
    assert (inflow[:, 1] - ORIGIN[1] <= 1e-6).all()                 # from the south
    check_flows_downstream(graph, lines, skip_m=3.0)


def divide(west: bool):
    """Two lines drawn (FLOWDIR) from one point, east and west, nothing entering it, between
    two loops (north and south) that leave the west end and meet at the east one (NHDPlus
    Shellmound, features 844 and 878); ``west``: a river comes into the west end too."""
    lines = [polyline((0, 0), (-200, 0)), polyline((0, 0), (300, 0)),
             polyline((-200, 0), (-100, 200), (200, 200), (300, 0)),
             polyline((-200, 0), (-100, -200), (200, -200), (300, 0)),
             polyline((300, 0), (700, 0))]
    return lines + [polyline((-600, 0), (-200, 0))] * west


@pytest.mark.parametrize("west", [True, False])
def test_lines_leaving_a_point_between_loops_are_turned_or_left_out(tmp_path, west):
    """No inflow can reach a junction that loops close round on every side (it would rise in
    an island). The shortest line leaving it is turned where it comes from a junction that
    something else enters and no loop flows back into itself (``west``), so it feeds the
    other; else it is left out, and the other with it (it lies in land then). Each a
    reported repair; strict mode refuses it."""
    lines = divide(west)
    flowdir = np.array(["With Digitized"] * len(lines), dtype=object)
    path = write_lines(tmp_path / "divide.gpkg", lines, {"FLOWDIR": flowdir})
    with pytest.raises(rf.GraphError, match=r"start where nothing enters.*strict=True"):
        rf.read_rivers(path, strict=True)
    builder = rf.read_rivers(path, origin_m=None)
    graph = built(builder)
    (what,) = repairs_of(builder, "feature 1")
    names = [b.name for b in builder._branches]
    if west:
        assert what.startswith("it and feature 2 start where nothing enters") and what.endswith(
            "turned, the shortest of them, to feed the others"), what
        assert len(names) == 6
        check_flows_downstream(graph, [lines[0][::-1]] + lines[1:], skip_m=3.0)
    else:
        assert "none can be turned without closing a loop that flows back into itself: left " \
               "out, the shortest of them" in what, what
        assert "lies in land" in repairs_of(builder, "feature 2")[0]
        assert sorted(names) == ["feature 3", "feature 4", "feature 5", "inflow of feature 3"]
        check_flows_downstream(graph, lines[2:], skip_m=3.0)


def test_disconnected_pieces_and_rivers_entering_from_outside(tmp_path):
    east = [p + (5000.0, 0.0) for p in confluence()]
    lines = [*confluence(), *east, polyline((0, 2000), (1500, 2500))]
    path = write_lines(tmp_path / "pieces.shp", lines)
    builder = rf.read_rivers(path, origin_m=None)
    graph = built(builder)
    assert builder.report.repairs == []
    check_flows_downstream(graph, lines)


def delta():
    """A river splitting into three distributaries that reach the sea (the data's edge at
    x = 900) separately, drawn downstream."""
    return [polyline((-1200, 0), (0, 0)),
            polyline((0, 0), (400, 180), (900, 420)),
            polyline((0, 0), (450, 10), (900, 0)),
            polyline((0, 0), (400, -170), (900, -380))]


def test_a_delta_stays_a_delta(tmp_path):
    """Several outlets branching from one river (distributaries) are kept, each its own
    outlet, the discharge split by the widths; with elevations, a distributary drawn
    upstream is turned by its own elevations and the delta stays."""
    lines = delta()
    widths = np.array([60.0, 30.0, 20.0, 10.0])
    path = write_lines(tmp_path / "delta.gpkg", lines, {"W": widths})
    builder = rf.read_rivers(path, origin_m=None, width_m="W")
    graph = built(builder)
    assert builder.report.repairs == []                  # drawn downstream: nothing turned
    check_flows_downstream(graph, lines, skip_m=3.0)
    q = np.array(builder.discharges_m2s)
    np.testing.assert_allclose(q[1:] / q[0], widths[1:] / widths[1:].sum())
    # topology only: one distributary drawn upstream is ambiguous (it could be a tributary)
    # unless its elevations say; with them it is turned back and the delta stays
    drawn = [lines[0], lines[1], lines[2][::-1], lines[3]]
    up = np.array([10.0, 5.0, 0.0, 5.0])
    down = np.array([5.0, 0.0, 5.0, 0.0])                # the third drawn from the sea
    path = write_lines(tmp_path / "delta_up.shp", drawn, {"W": widths, "up": up, "dn": down})
    builder = rf.read_rivers(path, origin_m=None, width_m="W", elevation_m=("up", "dn"))
    graph = built(builder)
    (what,) = repairs_of(builder, "feature 2")
    assert "drawn upstream" in what and "delta" in what and "elevations" in what
    assert [r.feature for r in builder.report.repairs] == ["feature 2"]
    check_flows_downstream(graph, lines, skip_m=3.0)
    # a tributary drawn upstream is not a distributary: it points back where it joins
    trib = [polyline((-1200, 0), (0, 0)), polyline((0, 0), (900, 0)),
            polyline((0, 0), (-500, 600))]               # drawn from the junction out
    path = write_lines(tmp_path / "trib.geojson", trib, crs=UTM)
    builder = rf.read_rivers(path, width_m=20.0)
    assert [r.feature for r in builder.report.repairs] == ["feature 2"]


# -- direction ---------------------------------------------------------------------------------


def test_lines_drawn_upstream_found_from_the_topology(tmp_path):
    lines = confluence()
    drawn = [lines[0][::-1], lines[1], lines[2]]
    path = write_lines(tmp_path / "topo.gpkg", drawn, {"name": np.array(["n", "s", "m"],
                                                                        dtype=object)})
    builder = rf.read_rivers(path, origin_m=None)
    graph = built(builder)
    assert [r.feature for r in builder.report.repairs] == ["feature 1"]   # (ids from 1)
    assert "drawn upstream (by the topology" in builder.report.repairs[0].what
    check_flows_downstream(graph, lines)


def test_a_files_flow_direction_attribute_is_its_word(tmp_path):
    """Two rivers leaving the data, joined by a canal (a delta's or a clipped network's
    several outlets): the topology alone takes one outlet per piece and turns one river's
    lower reach up into the canal. NHD's ``FLOWDIR`` ("With Digitized") and the Ordnance
    Survey's ``flowDirection`` ("inDirection", "inOppositeDirection": turned) say each
    line's direction: kept as they say, never turned; lines they leave open
    ("Uninitialized") are directed by the topology."""
    lines = [polyline((0, 1000), (0, 0)), polyline((0, 0), (0, -1000)),
             polyline((800, 1000), (800, 200)), polyline((800, 200), (800, -1000)),
             polyline((0, 0), (400, 150), (800, 200))]
    for word, turned in (("Uninitialized", ["feature 1"]), ("With Digitized", [])):
        path = write_lines(tmp_path / f"nhd {word}.shp", lines,
                           {"FLOWDIR": np.array([word] * 5, dtype=object)})
        builder = rf.read_rivers(path, origin_m=None)
        graph = built(builder)
        assert [r.feature for r in builder.report.repairs] == turned, word
    assert builder.report.derived["direction"] == (
        "by the attribute 'FLOWDIR': 5 line(s) drawn with the flow")
    check_flows_downstream(graph, lines, skip_m=20.0)    # (the canal leaves in the river)
    lines = lines[:2] + [lines[4]]                          # one river and the canal
    drawn = [lines[0], lines[1][::-1], lines[2]]
    os_dir = np.array(["inDirection", "inOppositeDirection", "inDirection"], dtype=object)
    builder = rf.read_rivers(write_lines(tmp_path / "os.gpkg", drawn,
                                         {"flowDirection": os_dir}), origin_m=None)
    check_flows_downstream(built(builder), lines, skip_m=20.0)
    assert not builder.report.repairs and "1 against it (turned)" in builder.report.derived[
        "direction"]
    joined = confluence()
    drawn = [joined[0][::-1], joined[1], joined[2]]      # a tributary drawn upstream
    open_ = np.array(["Uninitialized", "With Digitized", "With Digitized"], dtype=object)
    builder = rf.read_rivers(write_lines(tmp_path / "open.shp", drawn, {"FLOWDIR": open_}),
                             origin_m=None)
    check_flows_downstream(built(builder), joined)
    assert "; 1 it leaves open, directed by the topology" in builder.report.derived["direction"]
    (what,) = repairs_of(builder, "feature 0")
    assert "drawn upstream (by the topology" in what


def test_lines_drawn_upstream_found_from_drainage_areas(tmp_path):
    lines = confluence()
    drawn = [lines[0], lines[1][::-1], lines[2][::-1]]     # only the north one as drawn
    # areas at both ends: (upstream, downstream) as drawn
    path = write_lines(tmp_path / "area.geojson", drawn, {"up": np.array([5.0, 80.0, 140.0]),
                                                          "dn": np.array([50.0, 8.0, 130.0])})
    builder = rf.read_rivers(path, origin_m=None, drainage_area_km2=("up", "dn"))
    graph = built(builder)
    assert sorted(r.feature for r in builder.report.repairs) == ["feature 1", "feature 2"]
    assert all("the drainage areas" in r.what for r in builder.report.repairs)
    check_flows_downstream(graph, lines)


def test_lines_drawn_upstream_found_from_z_and_elevation_attributes(tmp_path):
    line = polyline((0, 0), (800, 100))
    z = np.linspace(100.0, 80.0, len(line))          # falls along the river
    up = shapely.LineString(np.column_stack([line[::-1] + ORIGIN, z[::-1]]))  # drawn upstream
    path = write_lines(tmp_path / "z.gpkg", None, {"n": np.array([1])}, geoms=[up])
    builder = rf.read_rivers(path, origin_m=None, width_m=20.0)
    graph = built(builder)
    (what,) = repairs_of(builder, "feature 1")
    assert "the elevations" in what
    check_flows_downstream(graph, [line])
    path = write_lines(tmp_path / "elev.shp", [line[::-1]],
                       {"up_m": np.array([80.0]), "dn_m": np.array([100.0])})
    builder = rf.read_rivers(path, origin_m=None, width_m=20.0, elevation_m=("up_m", "dn_m"))
    check_flows_downstream(built(builder), [line])
    assert "the elevations" in repairs_of(builder, "feature 0")[0]
    # the user's word stands: reverse= marks lines that are never turned
    kept = rf.read_rivers(path, origin_m=None, width_m=20.0, elevation_m=("up_m", "dn_m"),
                          reverse=True)
    assert kept.report.repairs == []


# -- messy features ----------------------------------------------------------------------------


def test_duplicates_empty_lines_and_multilinestrings(tmp_path):
    lines = confluence()
    near = lines[2][::-1] + (0.0, 0.4)                      # the main river again, reversed
    geoms = [shapely.MultiLineString([lines[0] + ORIGIN, lines[1] + ORIGIN]),
             shapely.LineString(lines[2] + ORIGIN),
             shapely.LineString(lines[2] + ORIGIN),          # an exact duplicate
             shapely.LineString(near + ORIGIN),               # a near one
             shapely.LineString([ORIGIN + (50, 50), ORIGIN + (50, 50)])]   # zero length
    path = write_lines(tmp_path / "messy.geojson", None,
                       {"name": np.array(["tribs", "main", "again", "near", "dot"], dtype=object)},
                       geoms=geoms)
    builder = rf.read_rivers(path, origin_m=None, width_m=25.0)
    graph = built(builder)
    assert "an exact duplicate of feature 1" in repairs_of(builder, "feature 2")[0]
    assert "a near duplicate of feature 1" in repairs_of(builder, "feature 3")[0]
    assert "zero length" in repairs_of(builder, "feature 4")[0]
    assert len(builder.report.links) == 3
    check_flows_downstream(graph, lines)


def test_z_and_m_coordinates(tmp_path):
    import struct

    import pyogrio.raw

    lines = confluence()

    def zm_wkb(p, z0, z1):        # an ISO WKB LineString ZM (type 3002), x y z m per vertex
        z = np.linspace(z0, z1, len(p))
        m = np.arange(len(p), dtype=float)
        body = np.column_stack([p + ORIGIN, z, m]).astype("<f8").tobytes()
        return struct.pack("<BII", 1, 3002, len(p)) + body

    path = tmp_path / "zm.gpkg"
    pyogrio.raw.write(str(path), np.array([zm_wkb(p, 100.0 - 10 * k, 90.0 - 10 * k)
                                           for k, p in enumerate(lines)], dtype=object),
                      [np.array([1, 2, 3])], ["k"], driver="GPKG", crs=UTM,
                      geometry_type="Unknown")
    builder = rf.read_rivers(path, origin_m=None, width_m=25.0)
    assert builder.report.repairs == []
    check_flows_downstream(built(builder), lines)


def test_one_vertex_lines_and_non_lines(tmp_path):
    lines = confluence()
    lonlat = pyproj.Transformer.from_crs(UTM, "EPSG:4326", always_xy=True)

    def coords(p, zm=True):
        lon, lat = lonlat.transform(*(p + ORIGIN).T)
        return [[x, y, 100.0] if zm else [x, y] for x, y in zip(lon, lat)]

    features = [{"type": "Feature", "properties": {"k": k},
                 "geometry": {"type": "LineString", "coordinates": coords(p)}}
                for k, p in enumerate(lines)]
    features.append({"type": "Feature", "properties": {"k": 3},
                     "geometry": {"type": "LineString", "coordinates": coords(lines[0][:1])}})
    features.append({"type": "Feature", "properties": {"k": 4},
                     "geometry": {"type": "Point", "coordinates": coords(lines[0][:1])[0]}})
    features.append({"type": "Feature", "properties": {"k": 5}, "geometry": None})
    path = tmp_path / "zm.geojson"
    path.write_text(json.dumps({"type": "FeatureCollection", "features": features}))
    builder = rf.read_rivers(path, width_m=25.0)
    graph = built(builder)
    named = {r.feature: r.what for r in builder.report.repairs}
    assert set(named) == {"feature 3", "feature 4", "feature 5"}, named
    assert "is a Point" in named["feature 4"] and "no geometry" in named["feature 5"]
    with pytest.raises(rf.GraphError, match=r"zm.geojson \(layer 'zm'\): feature 3.*k=3"):
        rf.read_rivers(path, width_m=25.0, strict=True)
    x0, y0, *_ = graph.bounds()
    assert abs(x0) < 5000 and abs(y0) < 5000              # moved near 0, in UTM metres


def test_crossings_without_a_shared_vertex_are_no_junction(tmp_path):
    river = polyline((-1000, 0), (1000, 0), step=100.0)
    canal = polyline((0, -800), (5, 800), step=100.0)       # crosses between two vertices
    canal = canal[np.abs(canal[:, 1]) > 30]
    path = write_lines(tmp_path / "canal.gpkg", [river, canal],
                       {"kind": np.array(["river", "canal"], dtype=object),
                        "W": np.array([60.0, 8.0])})
    builder = rf.read_rivers(path, origin_m=None, width_m="W")
    graph = built(builder)
    (what,) = repairs_of(builder, "feature 2")
    assert "crosses feature 1" in what and "no junction" in what
    assert all(lk.name != "feature 1 piece 0" for lk in builder.report.links)   # not split
    check_flows_downstream(graph, [river])
    # a shared vertex is a junction: the canal and the river meet there
    shared = polyline((0, -800), (0, 0), (0, 800), step=100.0)
    path = write_lines(tmp_path / "joined.gpkg", [river, shared], {"W": np.array([60.0, 8.0])})
    builder = rf.read_rivers(path, origin_m=None, width_m="W")
    assert len(builder.report.links) == 4 and not any(
        "crosses" in r.what for r in builder.report.repairs)


# -- attributes that lie -----------------------------------------------------------------------


def test_attributes_that_lie_fall_back_to_the_next_rule(tmp_path):
    lines = confluence()
    attrs = {"A": np.array([-5.0, np.nan, 140.0]),
             "W": np.array(["12", "wide", "0"], dtype=object),
             "strmOrder": np.array([1, 2, 3])}
    path = write_lines(tmp_path / "lies.gpkg", lines, attrs)
    builder = rf.read_rivers(path, origin_m=None, drainage_area_km2="A", width_m="W")
    graph = built(builder)
    assert "'A': -5 is not positive" in repairs_of(builder, "feature 1")[0]
    assert any("'A': missing (NaN)" in w for w in repairs_of(builder, "feature 2"))
    assert any("'W': 'wide' is not a number" in w for w in repairs_of(builder, "feature 2"))
    assert any("'W': 0 is not positive" in w for w in repairs_of(builder, "feature 3"))
    links = builder.report.links
    assert links[0].width_m == 12.0
    assert links[1].discharge_from == "hydraulic geometry of the stream order"
    check_flows_downstream(graph, lines)
    with pytest.raises(rf.GraphError, match=r"lies.gpkg.*feature 1.*'A': -5"):
        rf.read_rivers(path, origin_m=None, drainage_area_km2="A", width_m="W", strict=True)


def test_values_beyond_any_river_and_lines_shorter_than_the_snap_are_left_out(tmp_path):
    """A unit slip or a no-data code (a width of 1e9 m, a stream order of 1e30) is not used,
    as a negative value is; a line whose ends lie within the snapping distance (0.3 m long)
    is left out, reported (it made the topology halve it forever); a vertex at 1e300 is
    left out as a NaN one is."""
    lines = [*confluence(), np.array([(2000.0, 2000.0), (2000.3, 2000.0)])]
    far = shapely.LineString(np.vstack([np.asarray(lines[2]) + ORIGIN, [(1e300, 0.0)]]))
    geoms = [shapely.LineString(np.asarray(p) + ORIGIN) for p in lines]
    geoms[2] = far
    attrs = {"W": np.array([1e9, 20.0, 30.0, 5.0]), "strmOrder": np.array([1.0, 1e30, 3.0, 1.0])}
    path = write_lines(tmp_path / "odd.gpkg", None, attrs, geoms=geoms)
    builder = rf.read_rivers(path, origin_m=None, width_m="W")
    graph = built(builder)
    assert any("'W': 1e+09 is beyond any river's" in w for w in repairs_of(builder, "feature 1"))
    assert any("'strmOrder': 1e+30 is beyond" in w for w in repairs_of(builder, "feature 2"))
    assert any("beyond ±1e+12" in w for w in repairs_of(builder, "feature 3"))
    assert any("ends within 1 m: left out" in w for w in repairs_of(builder, "feature 4"))
    check_flows_downstream(graph, lines[:3])


# -- what cannot be used -----------------------------------------------------------------------


@pytest.mark.parametrize("case", ["empty", "points", "polygons", "not-gis", "all-nan", "far"])
def test_unusable_input_names_file_and_layer_and_writes_nothing(tmp_path, case):
    data = tmp_path / "data"
    data.mkdir()
    if case == "empty":
        path = write_lines(data / "empty.gpkg", None, {"n": np.array([], dtype=np.int64)},
                           geoms=[], layer="streams")
        expect = r"empty.gpkg \(layer 'streams'\): no features"
    elif case == "points":
        path = write_lines(data / "points.shp", None, {"n": np.array([1, 2])},
                           geoms=[shapely.Point(ORIGIN), shapely.Point(ORIGIN + 10)])
        expect = r"points.shp \(layer 'points'\): no usable line: feature 0 is a Point"
    elif case == "polygons":
        path = write_lines(data / "lakes.geojson", None, {"n": np.array([1])},
                           geoms=[shapely.Point(ORIGIN).buffer(100.0)])
        expect = r"lakes.geojson \(layer 'lakes'\): no usable line: feature 0 is a Polygon"
    elif case == "not-gis":
        path = data / "notes.geojson"
        path.write_text("these are not rivers\n")
        expect = r"notes.geojson: cannot read it"
    elif case == "far":                       # metres read as millimetres, say
        path = write_lines(data / "far.gpkg", [np.array([(0.0, 0.0), (3e11, 0.0)])])
        expect = r"far.gpkg \(layer 'far'\): its features span 3e\+08 km once projected"
    else:
        with np.errstate(invalid="ignore"):
            geoms = [shapely.LineString([(np.nan, np.nan), (np.nan, np.nan)])] * 2
        path = write_lines(data / "nan.gpkg", None, {"n": np.array([1, 2])}, geoms=geoms)
        expect = r"nan.gpkg \(layer 'nan'\): no usable line: feature 1 has non-finite"
    before = sorted(p.name for p in tmp_path.rglob("*"))
    with pytest.raises(rf.GraphError, match=expect):
        rf.read_rivers(path)
    assert sorted(p.name for p in tmp_path.rglob("*")) == before


# -- a property: any valid network, written out with defects, reads back the same ---------------


def _tree(rng):
    """A random valid network: a main river with 3 - 5 tributaries, some with their own."""
    lines = [polyline((0, 0), (1500, 0), (3000, 200), step=50.0)]
    s = np.linspace(300.0, 2600.0, rng.integers(3, 6))
    for k, x in enumerate(s):
        on = lines[0][np.argmin(np.abs(lines[0][:, 0] - x))]
        side = 1.0 if k % 2 else -1.0
        far = on + (rng.uniform(-400, -100), side * rng.uniform(600, 1000))
        mid = 0.5 * (on + far) + (0.0, side * rng.uniform(-80, 80))
        lines.append(polyline(far, mid, on, step=40.0))
    return lines


def _with_defects(lines, rng):
    """Split some lines in two features, reverse a third of them, duplicate one."""
    out = []
    for p in lines:
        if len(p) > 8 and rng.random() < 0.4:
            k = int(rng.integers(3, len(p) - 3))
            out += [p[:k + 1], p[k:]]
        else:
            out.append(p)
    out = [p[::-1] if rng.random() < 0.33 else p for p in out]
    out.append(out[int(rng.integers(len(out)))].copy())
    return [out[i] for i in rng.permutation(len(out))]


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_a_valid_network_with_random_defects_reads_back_the_same(tmp_path, seed):
    rng = np.random.default_rng(seed)
    lines = _tree(rng)
    # the main river is split where the tributaries end on it (the reader does the same)
    box = shapely.box(-200.0, -700.0, 2700.0, 700.0)           # clips the outlet and some tops
    parts = [shapely.intersection(shapely.LineString(p), box) for p in lines]
    clipped = [shapely.get_coordinates(g) for c in parts for g in getattr(c, "geoms", [c])
               if not g.is_empty and g.length > 50.0]
    total = sum(shapely.length(shapely.LineString(p)) for p in clipped)
    path = write_lines(tmp_path / f"defects{seed}.geojson", _with_defects(clipped, rng),
                       lonlat=True)
    builder = rf.read_rivers(path, width_m=20.0)
    graph = built(builder)
    assert builder.report.length_m == pytest.approx(total, rel=0.01)
    field = rf.FlowField(graph)
    ahead = inside = 0
    for p in clipped:
        pts, tangent = along(p + ORIGIN - builder.report.origin_m, step=10.0, skip_m=15.0)
        status, velocity = field.query(pts)
        inside += int((status == rf.FlowStatus.INSIDE).sum())
        ahead += int(((status == rf.FlowStatus.INSIDE)
                      & (np.einsum("ij,ij->i", velocity, tangent) > 0)).sum())
    assert ahead >= 0.95 * inside and inside > 0


def test_a_grid_traced_line_is_smoothed_within_half_its_width(tmp_path):
    """A meandering river 30 m wide traced along 5 m DEM cells: a staircase of 45° and 90°
    turns."""
    x = np.linspace(0.0, 1200.0, 4000)
    cells = np.round(np.column_stack([x, 80.0 * np.sin(2 * np.pi * x / 600.0)]) / 5.0)
    steps = [cells[0]]
    for c in cells[1:]:
        while np.abs(c - steps[-1]).max() > 0:             # 8-connected, one cell at a time
            steps.append(steps[-1] + np.sign(c - steps[-1]))
    stair = 5.0 * np.array(steps)
    path = write_lines(tmp_path / "grid.shp", [stair], {"W": np.array([30.0])})
    builder = rf.read_rivers(path, origin_m=None, width_m="W")
    graph = built(builder)
    # tracing on a raster is how the data was made, not a defect: derived, not a repair
    assert builder.report.repairs == []
    assert builder.derived["centre_lines"].startswith(
        "1 grid-traced link (on a lattice of 5 m cells) smoothed")
    source = shapely.LineString(stair + ORIGIN)
    for axis in graph.axes():
        line = graph.vertices(axis)
        # never farther than half the width from the line as traced
        assert shapely.distance(shapely.points(line), source).max() <= 15.0 + 1e-6
        pts, tangent = along(line, step=5.0)         # its direction every cell
        turn = np.degrees(np.arccos(np.clip(np.einsum("ij,ij->i", tangent[:-1], tangent[1:]),
                                            -1.0, 1.0)))
        assert turn.max() < 30.0                       # no staircase of 45° turns left


def _traced(cells):
    """An 8-connected path through the raster cells nearest to ``cells`` (i, j), a vertex
    at each turn only (as TauDEM writes them)."""
    cells = np.round(np.asarray(cells, float))
    steps = [cells[0]]
    for c in cells[1:]:
        while np.abs(c - steps[-1]).max() > 0:
            steps.append(steps[-1] + np.sign(c - steps[-1]))
    steps = np.array(steps)
    d = np.diff(steps, axis=0)
    turn = np.concatenate([[True], np.any(d[1:] != d[:-1], axis=1), [True]])
    return steps[turn]


def test_a_grid_traced_lonlat_network_is_smoothed_as_runs_with_its_junctions_kept(tmp_path):
    """A river and a tributary traced on a 3″ lon/lat DEM (HydroSHEDS' grid: cells of 65 m
    by 93 m at 45° N) for a river 20 m wide: the lattice is the file's (lon/lat), the cell
    larger than the width. The main river is two features that continue each other: they
    are smoothed as one, so no corner is left where they meet; the confluence and the ends
    stay where they are; nothing moves farther than half a cell's diagonal."""
    x = np.linspace(0.0, 60.0, 600)
    main = _traced(np.column_stack([x, 6.0 * np.sin(2 * np.pi * x / 30.0)]))
    k = len(main) // 2                                   # two features, end to end
    at = main[np.argmin(np.abs(main[:, 0] - 45.0))]           # the tributary ends on a vertex
    y = np.linspace(25.0, 0.0, 300)
    trib = _traced(np.column_stack([at[0] - 0.4 * y + 2.0 * np.sin(y / 3.0), at[1] + y]))
    cell = 1.0 / 1200.0                                  # 3″
    lonlat = [15.0 + cell * p for p in (main[:k + 1], main[k:], trib)]
    lonlat = [np.column_stack([p[:, 0], 45.0 + p[:, 1] - 15.0]) for p in lonlat]
    path = write_lines(tmp_path / "dem3s.geojson", None, {"W": np.array([20.0, 20.0, 12.0])},
                       geoms=[shapely.LineString(p) for p in lonlat], crs="EPSG:4326")
    builder = rf.read_rivers(path, width_m="W")
    graph = built(builder)
    assert builder.report.repairs == []
    assert "4 grid-traced links (on a lattice of" in builder.derived["centre_lines"]
    to = pyproj.Transformer.from_crs("EPSG:4326", pyproj.CRS.from_wkt(graph.crs), always_xy=True)
    traced = [np.column_stack(to.transform(p[:, 0], p[:, 1])) for p in lonlat]
    lat_cell = float(np.hypot(*np.diff(np.column_stack(
        to.transform([15.0, 15.0], [45.0, 45.0 + cell])), axis=1).T[0]))   # ~93 m
    branches = {b.name: b.centerline_m for b in builder._branches}
    everything = shapely.union_all([shapely.LineString(p) for p in traced])
    for line in branches.values():
        assert shapely.distance(shapely.points(line), everything).max() <= 0.71 * lat_cell
    # the confluence, the source ends and the outlet are where they were drawn
    for p in (traced[2][-1], traced[2][0], traced[0][0], traced[1][-1]):
        assert min(np.hypot(*(np.array([b[0], b[-1]]) - p).T).min()
                   for b in branches.values()) < 1e-6
    # no staircase, and no corner where the two features of the main river meet
    data = np.concatenate([np.degrees(np.arccos(np.clip(np.einsum(
        "ij,ij->i", t[:-10], t[10:]), -1, 1))) for t in (along(p, step=2.0)[1] for p in traced)])
    assert data.max() >= 44.9
    for axis in graph.axes():
        _, t = along(graph.vertices(axis), step=2.0)
        turn = np.degrees(np.arccos(np.clip(np.einsum("ij,ij->i", t[:-10], t[10:]), -1, 1)))
        assert turn.max() < 30.0                         # over 20 m


def test_a_braid_splits_its_flow_by_the_arms_widths(tmp_path):
    lines = [polyline((-800, 0), (0, 0)),
             polyline((0, 0), (400, 150), (800, 0)),
             polyline((0, 0), (400, -150), (800, 0)),
             polyline((800, 0), (1600, 0))]
    path = write_lines(tmp_path / "split.geojson", lines, {"W": np.array([45.0, 30.0, 15.0,
                                                                          45.0])})
    builder = rf.read_rivers(path, origin_m=None, width_m="W")
    check_flows_downstream(built(builder), lines, skip_m=3.0)
    q = builder.discharges_m2s
    assert q[1] == pytest.approx(2.0 * q[2]) and q[1] + q[2] == pytest.approx(q[0])


def test_narrowing_densifies_without_a_segment_of_no_length():
    """``build()``'s narrowing densifies the lines (a quarter width apart): a sample a
    rounding error from a vertex (a line 14 m + 2e-15 long at 1.75 m steps) made a segment
    of no length, which the builder refused ("degenerates when its ends are snapped")
    after the first narrowing of Liechtenstein's OSM extract."""
    from riverflow.gis.rivers import _densify

    line = np.array([[0.0, 0.0], [14.000000000000002, 0.0], [14.000000000000002, 3.5]])
    for step in (1.75, 0.7, 3.5):
        dense, widths = _densify(line, np.array([4.0, 6.0, 8.0]), step)
        seg = np.hypot(*np.diff(dense, axis=0).T)
        assert seg.min() > 1e-6 * step and seg.max() <= step + 1e-9
        assert np.array_equal(dense[[0, -1]], line[[0, -1]])
        assert any(np.array_equal(p, line[1]) for p in dense)           # vertices kept
        assert np.all(np.diff(widths[:-1]) >= 0) and widths[-1] == 8.0


def test_a_ditch_rising_in_an_island_between_two_arms_is_left_out(tmp_path):
    """A river splits round a 400 m island and meets again; a ditch rises inside the island
    and flows into the north arm (Liechtenstein's OSM extract: a drain ending in the land
    between two canals). Its source would put water into the island's land, whose shore is
    one bank round to it again (ψ many-valued): the build failed ("both of its banks are one
    continuous shore"). The ditch is left out, reported; the rest builds and flows on."""
    lines = [polyline((-400, 0), (0, 0)),
             polyline((0, 0), (100, 150), (300, 150)),
             polyline((300, 150), (500, 150), (600, 0)),
             polyline((0, 0), (100, -150), (500, -150), (600, 0)),
             polyline((600, 0), (1000, 0)),
             polyline((250, -60), (300, 40), (300, 150))]          # the ditch in the island
    path = write_lines(tmp_path / "island.geojson", lines,
                       {"W": np.array([30.0, 20.0, 20.0, 20.0, 30.0, 4.0])})
    builder = rf.read_rivers(path, origin_m=None, width_m="W")
    graph = built(builder)
    assert len(repairs_of(builder, "feature 5")) == 1
    assert "lies in land the network's channels close round" in repairs_of(builder, "feature 5")[0]
    assert "feature 5" not in {lk.name for lk in builder.report.links}
    check_flows_downstream(graph, lines[:5], skip_m=3.0)
    status, _ = rf.FlowField(graph).query(np.array([[300.0, 0.0]]) + ORIGIN)
    assert status[0] != rf.FlowStatus.INSIDE                       # the island is land


def test_a_hook_at_a_free_end_is_trimmed(tmp_path):
    """Helsinki's OSM drains: an outlet 9 m long whose last 0.77 m turns by 89° (shorter than
    its 1.4 m width): the end's cap, across that flick, crossed the drain's own banks and the
    build failed ("both of its banks are one continuous shore"). The hook's vertex is
    dropped, a reported repair; a hook at a junction is the junction's, left alone."""
    lines = [np.array([[-542.39, 55.03], [-549.89, 66.92]]),
             np.array([[-492.39, 97.94], [-512.89, 84.92], [-520.81, 85.3], [-549.89, 66.92]]),
             np.array([[-549.89, 66.92], [-554.08, 73.48], [-554.73, 73.07]])]
    path = write_lines(tmp_path / "drains.geojson", lines, {"W": np.array([1.0, 1.0, 1.41])})
    builder = rf.read_rivers(path, origin_m=None, width_m="W")
    built(builder)
    (said,) = repairs_of(builder, "feature 2")
    assert re.match(r"a hook at its free end \(0\.77 m turning by (89|90)°", said)
    assert repairs_of(builder, "feature 0") == repairs_of(builder, "feature 1") == []


def test_a_source_rising_in_a_rivers_water_is_cut_back_to_its_bank(tmp_path):
    """Andorra's OSM: a stream 2 m wide rises 5.2 m from the centre line of the Valira del
    Nord, 15 m wide, with no junction ("overlap but do not meet"; the narrowing then made
    it 0.5 m wide there, and in Andorra's network its retries failed at other junctions).
    Its start is cut back along it to where it is clear of the river's water, a reported
    repair, before any narrowing; the river and the stream both flow."""
    lines = [polyline((0, 0), (1000, 0)),
             polyline((500, 5.2), (520, 60), (600, 400))]
    path = write_lines(tmp_path / "spring.geojson", lines, {"W": np.array([15.0, 2.0])})
    builder = rf.read_rivers(path, origin_m=None, width_m="W")
    graph = built(builder)
    (said,) = repairs_of(builder, "feature 1")
    assert re.match(r"its start lies in the water of feature 0 \(5\.2 m from its centre line, "
                    r"off its junctions\): cut back by [0-9.]+ m", said)
    assert not any("narrowed" in r.what for r in builder.report.repairs)
    start = builder._branches[1].centerline_m[0] - ORIGIN      # clear of the river's water:
    assert start[1] >= 8.5 - 1e-6 and np.hypot(*(start - [500.0, 5.2])) < 5.0   # 7.5 + 1 m
    check_flows_downstream(graph, [lines[0]], skip_m=3.0)


def test_an_inflow_laid_up_an_outflows_line_joins_it_farther_down(tmp_path):
    """NHDPlus (Yazoo basin, feature 233): a canal's last link, 10 m wide and 40 m long, runs
    back up a 22 m river leaving the junction, 29° off its course, in its water: its banks
    were the river's ("both of its banks are one continuous shore"; with the river's first
    41 m joined to the rest, the builder's rounding of junctions broke). It is cut back to
    where it clears the river's water, joined with the canal above it (what is left of it
    would lie mostly in the river) and led into the river farther down (the river split
    there), a reported repair; strict mode still refuses it; the flow runs downstream."""
    lines = [polyline((-600, 440), (-59.6, 44), (0, 0)),                # a river, 20 m
             polyline((0, 0), (17.3, -37.3)),                           # on from the junction
             polyline((17.3, -37.3), (72.5, -104.4), (300, -400)),
             polyline((500, 300), (102.3, 13.3), (34.6, -19.1)),        # a canal, 10 m
             polyline((34.6, -19.1), (27.7, -20.5), (0, 0))]            # its last link
    path = write_lines(tmp_path / "side.gpkg", lines,
                       {"W": np.array([20.0, 22.4, 22.4, 10.0, 10.0])})
    with pytest.raises(rf.GraphError, match=r"side.gpkg \(layer 'side'\): branch 'feature 5'"):
        rf.read_rivers(path, width_m="W", strict=True).build()
    builder = rf.read_rivers(path, origin_m=None, width_m="W")
    graph = built(builder)
    (said,) = repairs_of(builder, "feature 5")
    assert re.match(r"flows into \(500000\.0, 5000000\.0\) 29° off the course of feature 3, "
                    r"which leaves it \(10\.0 and 22\.4 m wide\): its last 35 m lay in that "
                    r"river's water; cut back to where it is clear of it \(joined with feature "
                    r"4, the one line above it\) and led into it 30 m downstream", said), said
    canal = next(b for b in builder._branches if b.name == "feature 4").centerline_m
    below = next(b for b in builder._branches if b.name == "feature 3 piece 1").centerline_m
    assert np.allclose(canal[0] - ORIGIN, (500, 300)) and np.allclose(canal[-1], below[0])
    assert np.hypot(*(canal[-1] - ORIGIN)) > 25.0
    check_flows_downstream(graph, lines[:4], skip_m=3.0)


def test_the_rounding_of_junctions_keeps_only_the_water_of_an_overlay(tmp_path, monkeypatch):
    """The same canal led up the river with the river's first 41 m one line with the rest
    and no repair of it: GEOS's overlay of the junction's rounded corners with the water
    gave a line beside the polygons and the builder raised a ValueError ("MultiPolygon ...
    got a LineString"); lines and points of an overlay are no water: it builds."""
    from riverflow.gis import rivers

    monkeypatch.setattr(rivers, "_move_side_inflows", lambda links, plan, *a, **k: (links, plan))
    lines = [polyline((-600, 440), (-59.6, 44), (0, 0)),
             polyline((0, 0), (17.3, -37.3), (72.5, -104.4), (300, -400)),
             polyline((500, 300), (102.3, 13.3), (34.6, -19.1)),
             polyline((34.6, -19.1), (27.7, -20.5), (0, 0))]
    path = write_lines(tmp_path / "joined.gpkg", lines,
                       {"W": np.array([20.0, 22.4, 10.0, 10.0])})
    built(rf.read_rivers(path, origin_m=None, width_m="W"))


def test_a_link_shorter_than_the_rivers_at_its_ends_are_wide_is_dropped(tmp_path):
    """NHDPlus Shellmound, feature 56: a link 38 m long, 23.5 m wide, from where nothing
    else meets to a confluence of rivers 31.6 and 39.4 m wide: its middle lay in the
    confluence's water ("no banks found across its middle"). Its junctions are merged and
    it is dropped (a note), and the flow runs downstream."""
    lines = [polyline((700, 400), (82.3, 60.1), (19.6, 33.0)), polyline((19.6, 33.0), (0, 0)),
             polyline((-300, 600), (-53.0, 99.2), (0, 0)),
             polyline((0, 0), (10.3, -111.6), (76.9, -225.2), (300, -700))]
    path = write_lines(tmp_path / "short.gpkg", lines,       # 23.5, 23.5, 31.6, 39.4 m wide
                       {"A": np.array([1158.0, 1158.0, 2094.0, 3252.0])})
    builder = rf.read_rivers(path, origin_m=None, drainage_area_km2="A")
    graph = built(builder)
    assert [b.name for b in builder._branches] == ["feature 1", "feature 3", "feature 4"]
    assert any(n.startswith("feature 2: dropped (it lies inside a confluence: its ends are "
                            "closer, or it is shorter, than the rivers there are wide)")
               for n in builder.report.notes)
    check_flows_downstream(graph, [lines[0][:2], lines[2], lines[3]], skip_m=3.0)


def test_streams_close_only_within_a_wide_confluence_are_not_merged(tmp_path):
    """NHDPlus Shellmound, features 761 and 762: two 10 m streams meet 19° apart where a 38 m
    river joins and a 41 m one leaves, close together for 24 m above it, inside the
    confluence's water: merged there, their 24 m reach had no banks of its own ("no banks
    found across its middle"). Channels close only within the widest river's width of their
    junction keep their own lines (as they do within twice their own width)."""
    lines = [polyline((-300, 600), (-98.8, 189.3), (-29.2, 48.8), (-21.0, 26.1), (0, 0)),
             polyline((0, 0), (3.1, -24.1), (16.7, -59.3), (31.4, -135.2), (100, -600)),
             polyline((400, -300), (139.0, -74.0), (112.9, -44.2), (66.5, -19.9), (0, 0)),
             polyline((900, 300), (873.2, 33.5), (0, 0))]
    path = write_lines(tmp_path / "wide.gpkg", lines, {"W": np.array([38.1, 40.6, 10.0, 10.0])})
    builder = rf.read_rivers(path, origin_m=None, width_m="W")
    graph = built(builder)
    assert builder.report.repairs == []
    field = check_flows_downstream(graph, lines[:2], skip_m=3.0)
    check_flows_downstream(graph, lines[2:], skip_m=20.0, field=field)   # ends in the confluence


def test_a_river_of_links_shorter_than_it_is_wide_is_no_chain_to_collapse(tmp_path):
    """A link shorter than the rivers at its ends are wide, but not shorter than half the
    lines beside it (a model grid's routing lines: a 50 m river in 60 m steps, a tributary
    at each), is kept: merged, the river's junctions would chain into one."""
    river = [polyline((60 * k, 0), (60 * (k + 1), 0)) for k in range(4)]
    tributaries = [polyline((60 * k, 400), (60 * k, 0)) for k in (1, 2, 3)]
    path = write_lines(tmp_path / "grid.gpkg", river + tributaries,
                       {"W": np.array([50.0] * 4 + [10.0] * 3)})
    builder = rf.read_rivers(path, origin_m=None, width_m="W")
    assert len(builder._branches) == 7
    assert not any("dropped" in n for n in builder.report.notes)


def test_a_river_drawn_in_pieces_shorter_than_it_is_wide_is_joined(tmp_path):
    """NHD HR routing lines of a model grid (sfrmaker's example, features 1711, 1654, 1656,
    1775): a 77 m river (its width from the drainage area) in one 100 m piece per cell,
    turning west and south again where a 10 m stream comes in head-on from below. The pieces
    were links of their own: the one between the turns had no banks across its middle.
    Pieces that run on into one another where nothing else meets, both shorter than twice
    their river's width as planned, are joined into one link (a repair per joined link)."""
    river = [polyline((0, 300), (0, 200), step=100), polyline((0, 200), (0, 100), step=100),
             polyline((0, 100), (-100, 100), step=100), polyline((-100, 100), (-100, 0), step=100),
             polyline((-100, 0), (-100, -100), step=100)]
    stream = polyline((0, 0), (0, 100), step=100)
    path = write_lines(tmp_path / "cells.gpkg", river + [stream],
                       {"A": np.array([12400.0] * 5 + [1.0])})          # 77 m and 0.7 m wide
    with pytest.raises(rf.GraphError, match="no banks found across its middle"):
        rf.read_rivers(path, origin_m=None, drainage_area_km2="A", strict=True).build()
    builder = rf.read_rivers(path, origin_m=None, drainage_area_km2="A")
    graph = built(builder)
    assert [b.name for b in builder._branches] == ["feature 1", "feature 3", "feature 6"]
    (up,) = repairs_of(builder, "feature 1")
    assert up.startswith("drawn in 2 pieces (with feature 2) that run on into one another "
                         "where nothing else meets, shorter than twice the river's width"), up
    (down,) = repairs_of(builder, "feature 3")
    assert "drawn in 3 pieces (with feature 4, feature 5)" in down, down
    assert len(builder.report.repairs) == 2
    check_flows_downstream(graph, [polyline((0, 300), (0, 100), (-100, 100), (-100, -100))],
                           skip_m=5.0)
