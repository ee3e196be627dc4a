"""rf.read_rivers on networks the tests write: every format (GeoJSON, shapefile, GeoPackage),
lon/lat and projected, with and without width attributes, near-miss and T junctions, a 1 m
stream joining a 100 m river, a braided reach, an island, many short links, stream orders,
lines drawn upstream, bed elevations. Each network must build, validate, be water along
every centre line with its flow running downstream, and say what was derived."""
from __future__ import annotations

import itertools

import numpy as np
import pytest
import shapely

import riverflow as rf
from riverflow.gis.rivers import HydraulicGeometry
from tests.gis.conftest import ORIGIN, UTM, along, polyline, require_gis, write_lines

_, pyproj = require_gis()

INSIDE = rf.FlowStatus.INSIDE


def confluence():
    """Two tributaries joining a main river at the origin (metres, drawn downstream)."""
    return [polyline((-600, 400), (-300, 200), (0, 0)),
            polyline((-600, -400), (-300, -200), (0, 0)),
            polyline((0, 0), (500, 50), (1000, 0))]


def check_flows_downstream(graph, lines, skip_m=2.0, field=None):
    """Every point along every line (but ``skip_m`` at its ends) is water, flowing along it."""
    field = field or rf.FlowField(graph)
    for k, line in enumerate(lines):
        pts, tangent = along(np.asarray(line) + ORIGIN, step=4.0, skip_m=skip_m)
        status, velocity = field.query(pts)
        dry = int((status != INSIDE).sum())
        assert dry == 0, f"line {k}: {dry} of {len(pts)} points are not water"
        back = np.einsum("ij,ij->i", velocity, tangent) <= 0
        assert not back.any(), f"line {k}: {int(back.sum())} points flow upstream"
    return field


@pytest.mark.parametrize("suffix", [".geojson", ".shp", ".gpkg"])
@pytest.mark.parametrize("lonlat", [False, True], ids=["projected", "lonlat"])
@pytest.mark.parametrize("widths", [True, False], ids=["widths", "no-widths"])
def test_a_confluence_in_every_format(tmp_path, suffix, lonlat, widths):
    lines = confluence()
    attrs = {"name": np.array(["north", "south", "main"], dtype=object),
             "area_km2": np.array([50.0, 100.0, 160.0])}
    if widths:
        attrs["W"] = np.array([20.0, 30.0, 45.0])
    path = write_lines(tmp_path / f"net{suffix}", lines, attrs, lonlat=lonlat)
    builder = rf.read_rivers(path, origin_m=None, width_m="W" if widths else None, drainage_area_km2="area_km2")
    graph = builder.build()
    assert rf.validate_graph(graph) == []
    # the coordinates: projected data keeps its CRS; lon/lat is projected to the UTM zone
    # pyproj picks, here the one the lines were drawn in, so they come back where they were
    assert pyproj.CRS(graph.crs) == pyproj.CRS(UTM)
    junction = graph.nodes[np.argmin(np.hypot(*(graph.nodes - ORIGIN).T))]
    np.testing.assert_allclose(junction, ORIGIN, atol=1e-3 if lonlat else 1e-9)
    report = builder.report
    if widths:
        assert [lk.width_m for lk in report.links] == [20.0, 30.0, 45.0]
        assert report.derived["width_m"] == {"given": 3}
    else:
        assert report.derived["width_m"] == {"hydraulic geometry of the discharge": 3}
        w = [lk.width_m for lk in report.links]
        assert w[0] < w[1] < w[2]
    q = builder.discharges_m2s
    assert q[2] >= q[0] + q[1] - 1e-9          # conserved, or more (lateral inflow)
    check_flows_downstream(graph, lines)


def test_near_miss_and_t_junctions_are_joined(tmp_path):
    lines = confluence()
    lines[0][-1] = (0.4, 0.3)                  # ends that miss the junction by < 1 m
    lines[1][-1] = (-0.2, 0.5)
    side = polyline((700, 600), (700, 30.4))   # ends 0.4 m off the main river's middle
    path = write_lines(tmp_path / "near.gpkg", [*lines, side],
                       {"W": np.array([20.0, 30.0, 45.0, 10.0])})
    builder = rf.read_rivers(path, origin_m=None, width_m="W")
    graph = builder.build()
    assert rf.validate_graph(graph) == []
    notes = " ".join(builder.report.notes)
    assert "split" in notes and "moved" in notes
    assert len(builder.report.links) == 5      # the main river was split where the side ends
    check_flows_downstream(graph, [*confluence(), side], skip_m=3.0)


def test_a_1m_stream_joins_a_100m_river(tmp_path):
    river = polyline((-2000, 0), (0, 0), (2000, 0), step=50.0)
    stream = polyline((0, 1500), (0, 0), step=5.0)        # ends on the river's middle
    path = write_lines(tmp_path / "mouth.shp", [river, stream], {"W": np.array([100.0, 1.0])})
    builder = rf.read_rivers(path, origin_m=None, width_m="W")
    graph = builder.build()
    assert rf.validate_graph(graph) == []
    widths = {lk.name: lk.width_m for lk in builder.report.links}
    assert widths == {"feature 0 piece 0": 100.0, "feature 0 piece 1": 100.0, "feature 1": 1.0}
    q = dict(zip(widths, builder.discharges_m2s))
    assert q["feature 0 piece 1"] == pytest.approx(q["feature 0 piece 0"] + q["feature 1"])
    check_flows_downstream(graph, [river, stream[:-12]])   # the stream, but in the river
    field = rf.FlowField(graph)
    assert (field.query(np.array([[0.0, 1000.0], [0.6, 1000.0]]) + ORIGIN)[0]
            == [INSIDE, rf.FlowStatus.OUTSIDE]).all()    # the stream is 1 m wide


def test_a_braided_reach_flows_around_its_islands(tmp_path):
    lines = [polyline((-1000, 0), (0, 0)),
             polyline((0, 0), (300, 150), (700, 150), (1000, 0)),
             polyline((0, 0), (1000, 0)),
             polyline((0, 0), (300, -150), (700, -150), (1000, 0)),
             polyline((1000, 0), (2000, 0))]
    area = np.array([100.0, 30.0, 40.0, 30.0, 140.0])
    path = write_lines(tmp_path / "braid.geojson", lines, {"A": area})
    builder = rf.read_rivers(path, origin_m=None, drainage_area_km2="A")
    graph = builder.build()
    assert rf.validate_graph(graph) == []
    assert len(graph.areas) == 3                # the water and two islands
    field = check_flows_downstream(graph, lines, skip_m=3.0)
    status, _ = field.query(np.array([[500.0, 75.0], [500.0, -75.0]]) + ORIGIN)
    assert (status == rf.FlowStatus.OUTSIDE).all()
    q = builder.discharges_m2s
    assert q[1] + q[2] + q[3] == pytest.approx(q[0])   # the arms share the inflow
    assert q[2] > q[1] == pytest.approx(q[3])           # by their own estimates
    assert q[4] > q[0]                                   # lateral inflow below the braid


def test_an_island_with_no_attributes_at_all(tmp_path):
    lines = [polyline((-800, 0), (0, 0)),
             polyline((0, 0), (400, 120), (800, 0)),
             polyline((0, 0), (400, -120), (800, 0)),
             polyline((800, 0), (1600, 0))]
    path = write_lines(tmp_path / "island.shp", lines)
    builder = rf.read_rivers(path, origin_m=None)
    graph = builder.build()
    assert rf.validate_graph(graph) == []
    report = builder.report
    assert report.links[0].discharge_from.startswith("default")
    assert report.links[0].width_m == pytest.approx(HydraulicGeometry().default_width_m)
    q = builder.discharges_m2s
    assert q[1] == pytest.approx(q[2]) == pytest.approx(0.5 * q[0])
    assert q[3] == pytest.approx(q[0])
    field = check_flows_downstream(graph, lines, skip_m=3.0)
    assert field.query(np.array([[400.0, 0.0]]) + ORIGIN)[0][0] == rf.FlowStatus.OUTSIDE


def comb(n_teeth=24, spacing=120.0, tooth=300.0):
    """A main river with tributaries on both sides every ``spacing`` m, and pairs of them a
    few metres apart (links shorter than the river is wide)."""
    xs, lines = [0.0], []
    for k in range(n_teeth):
        x = (k + 1) * spacing
        xs.append(x)
        if k % 4 == 3:
            xs.append(x + 4.0)                 # a 4 m link between two junctions
    xs.append(xs[-1] + spacing)
    for a, b in itertools.pairwise(xs):
        lines.append(polyline((a, 0.0), (b, 0.0)))
    for k, x in enumerate(xs[1:-1]):
        sign = 1.0 if k % 2 else -1.0
        lines.append(polyline((x - 60.0, sign * tooth), (x, sign * 40.0), (x, 0.0)))
    return lines


def test_many_junctions_and_links_a_few_metres_long(tmp_path):
    lines = comb()
    path = write_lines(tmp_path / "comb.gpkg", lines, layer="streams")
    builder = rf.read_rivers(path, origin_m=None)
    graph = builder.build()
    assert rf.validate_graph(graph) == []
    notes = " ".join(builder.report.notes)
    assert "merged" in notes and "dropped" in notes
    main = [p for p in lines if p[0, 1] == 0.0]
    check_flows_downstream(graph, main, skip_m=3.0)
    widths = [lk.width_m for lk in builder.report.links]
    assert max(widths) > 2.0 * min(widths)       # the river widens as tributaries join


def test_stream_order_gives_widths(tmp_path):
    lines = confluence()
    path = write_lines(tmp_path / "orders.geojson", lines, {"strmOrder": np.array([1, 2, 3])})
    builder = rf.read_rivers(path, origin_m=None)             # strmOrder is a known name (TauDEM)
    builder.build()
    w = [lk.width_m for lk in builder.report.links]
    assert w[0] < w[1] < w[2]
    assert builder.report.links[2].discharge_from == "hydraulic geometry of the stream order"
    assert any("strmOrder" in n for n in builder.report.notes)


def test_lines_drawn_upstream_are_turned_by_an_attribute(tmp_path):
    lines = confluence()
    flipped = [lines[0], lines[1][::-1], lines[2][::-1]]
    path = write_lines(tmp_path / "rev.gpkg", flipped, {"up": np.array([0, 1, 1])})
    graph = rf.read_rivers(path, origin_m=None, reverse="up", width_m=25.0).build()
    check_flows_downstream(graph, lines)


def test_multilinestrings_and_bed_elevations(tmp_path):
    lines = confluence()
    geoms = [shapely.MultiLineString([lines[0] + ORIGIN, lines[1] + ORIGIN]),
             shapely.LineString(lines[2] + ORIGIN)]
    path = write_lines(tmp_path / "multi.geojson", None,
                       {"z_up": np.array([120.0, 100.0]), "z_dn": np.array([100.0, 90.0])},
                       geoms=geoms)
    builder = rf.read_rivers(path, origin_m=None, elevation_m=("z_up", "z_dn"), width_m=20.0)
    graph = builder.build()
    assert [lk.name for lk in builder.report.links] == ["feature 0 part 0", "feature 0 part 1",
                                                        "feature 1"]
    depth = HydraulicGeometry().depth
    levels = graph.water_levels(np.array([lines[0][0], lines[2][-1]]) + ORIGIN)
    q = [lk.discharge_m3s for lk in builder.report.links]
    np.testing.assert_allclose(levels, [120.0 + depth(q[0]), 90.0 + depth(q[2])], atol=0.5)
    scene = rf.landscape(graph)
    z = scene.water.level(np.array([lines[0][5], lines[2][-5]]) + ORIGIN)
    assert 100.0 < z[0] < 121.0 and 89.0 < z[1] < 95.0


def test_far_coordinates_move_near_zero_with_the_crs(tmp_path):
    """UTM northings are millions of metres: drawing in float32 would resolve 0.5 m there."""
    lines = confluence()
    path = write_lines(tmp_path / "far.gpkg", lines, {"W": np.array([20.0, 30.0, 45.0])})
    builder = rf.read_rivers(path, width_m="W")
    graph = builder.build()
    assert builder.report.origin_m == (500_000.0, 5_000_000.0)
    x0, y0, x1, y1 = graph.bounds()
    assert max(abs(x0), abs(y0), abs(x1), abs(y1)) < 2_000.0
    back = pyproj.Transformer.from_crs(pyproj.CRS.from_wkt(graph.crs), UTM, always_xy=True)
    np.testing.assert_allclose(np.column_stack(back.transform(*graph.nodes.T)),
                               graph.nodes + ORIGIN, atol=1e-6)
    check_flows_downstream(graph, [p - ORIGIN for p in lines])
    near = rf.read_rivers(path, width_m="W", origin_m=(499_000.0, 5_000_000.0))
    assert near.report.origin_m == (499_000.0, 5_000_000.0)
    with pytest.raises(rf.GraphError, match="origin_m must be"):
        rf.read_rivers(path, origin_m="centre")
