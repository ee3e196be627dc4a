"""Reports instead of silent defaults (issue 30, item 5): every attribute value that
``rf.read_rivers`` replaces or clamps is in ``builder.report`` with the feature that had it
and the value. Each case is a small GeoJSON (or OSM) file the test writes."""
from __future__ import annotations

import numpy as np
import pytest

import riverflow as rf
from tests.gis.conftest import require_gis, write_lines
from tests.gis.test_read_rivers import confluence

_, pyproj = require_gis()


def repairs_of(builder, feature: str) -> list[str]:
    return [r.what for r in builder.report.repairs if r.feature == feature]


def notes_of(builder, feature: str) -> list[str]:
    return [n for n in builder.report.notes if n.startswith(feature + ":")]


def test_negative_width_nan_discharge_negative_area_are_reported(tmp_path):
    attrs = {"W": np.array([-3.0, 12.0, 30.0]), "Q": np.array([2.0, np.nan, 9.0]),
             "A": np.array([50.0, 40.0, -7.5]), "rev": np.array([0, 0, 0])}
    path = write_lines(tmp_path / "bad.geojson", confluence(), attrs)
    builder = rf.read_rivers(path, origin_m=None, width_m="W", discharge_m3s="Q",
                             drainage_area_km2="A", reverse="rev")
    assert repairs_of(builder, "feature 0") == [
        "attribute 'W': -3 is not positive; not used (the link falls back to the next rule)"]
    assert repairs_of(builder, "feature 1") == [
        "attribute 'Q': missing (NaN); not used (the link falls back to the next rule)"]
    assert repairs_of(builder, "feature 2") == [
        "attribute 'A': -7.5 is not positive; not used (the link falls back to the next rule)"]
    (r,) = [r for r in builder.report.repairs if r.feature == "feature 2"]
    assert r.fid == 2 and r.attributes["A"] == -7.5
    assert "repair: feature 0: attribute 'W': -3" in str(builder.report)


def test_clamped_widths_and_unused_discharges_are_reported(tmp_path):
    attrs = {"W": np.array([0.2, np.nan, np.nan]),        # a given width under 0.5 m
             "A": np.array([np.nan, 0.01, np.nan]),       # a derived width under 0.5 m
             "Q": np.array([np.nan, np.nan, 1e-4])}       # a given Q smaller than the inflows
    path = write_lines(tmp_path / "small.geojson", confluence(), attrs)
    builder = rf.read_rivers(path, origin_m=None, width_m="W", drainage_area_km2="A",
                             discharge_m3s="Q")
    (raised,) = [w for w in repairs_of(builder, "feature 0") if "raised" in w]
    assert raised == "its width 0.2 m raised to 0.5 m (the narrowest river made)"
    (r,) = [r for r in builder.report.repairs if r.what == raised]
    assert r.fid == 0 and r.attributes["W"] == 0.2
    (derived,) = notes_of(builder, "feature 1")
    assert "width by hydraulic geometry of the discharge, 0.0691 m raised to 0.5 m" in derived
    assert "A=0.01" in derived
    (unused,) = [n for n in notes_of(builder, "feature 2") if "given discharge" in n]
    assert "its given discharge is not used" in unused and "0.0001 m³/s" in unused
    assert "Q=0.0001" in unused
    assert [lk.width_m for lk in builder.report.links] == [0.5, 0.5, 0.5]
    assert builder.report.derived["width_m"] == {"given, raised to 0.5 m": 1,
                                                 "hydraulic geometry of the discharge, "
                                                 "raised to 0.5 m": 2}
    path = write_lines(tmp_path / "narrow.geojson", confluence(),
                       {"W": np.array([0.2, 12.0, 30.0])})
    with pytest.raises(rf.GraphError, match=r"narrow.geojson.*feature 0: its width 0.2 m raised"):
        rf.read_rivers(path, origin_m=None, width_m="W", strict=True)


def test_stream_orders_below_one_and_rising_elevations_are_reported(tmp_path):
    attrs = {"O": np.array([0.5, 1.0, 2.0]), "rev": np.array([0, 0, 0]),
             "zu": np.array([30.0, 30.0, 10.0]), "zd": np.array([20.0, 20.0, 25.0])}
    path = write_lines(tmp_path / "orders.geojson", confluence(), attrs)
    builder = rf.read_rivers(path, origin_m=None, stream_order="O", reverse="rev",
                             elevation_m=("zu", "zd"))
    assert repairs_of(builder, "feature 0") == [
        "attribute 'O': 0.5 is below 1 (Strahler orders start at 1); not used (the link "
        "falls back to the next rule)"]
    assert builder.report.links[0].discharge_from.startswith("default")
    (rise,) = [n for n in builder.report.notes if "rise downstream" in n]
    assert rise.endswith(": feature 2 (10 m → 25 m)"), rise


def test_an_unreadable_osm_width_tag_is_reported(tmp_path):
    from tests.gis.conftest import polyline
    from tests.gis.test_osm import write_osm

    river = polyline((-1000, 0), (0, 0), (1000, 100), step=100.0)
    stream = polyline((-300, 700), (-100, 300), (0, 0), step=100.0)
    path = write_osm(tmp_path / "area.osm", [
        (101, river, {"waterway": "river", "width": "25"}),
        (102, stream, {"waterway": "stream", "width": "wide"})])
    builder = rf.read_rivers(path)
    assert repairs_of(builder, "feature 102") == [
        "width tag 'wide' is not a width in metres: not used (the link falls back to the next "
        "rule)"]
    assert repairs_of(builder, "feature 101") == []


def _geojson(path, crs_member, coords):
    import json
    doc = {"type": "FeatureCollection"}
    if crs_member is not ...:
        doc["crs"] = crs_member
    doc["features"] = [{"type": "Feature", "properties": {"crs": "not this one"},
                        "geometry": {"type": "LineString", "coordinates": c}} for c in coords]
    path.write_text(json.dumps(doc))
    return path


LONLAT = [[[15.0, 45.0], [15.01, 45.0]], [[15.01, 45.0], [15.02, 45.001]]]


@pytest.mark.parametrize("member", [
    {"type": "name", "properties": {"name": "urn:ogc:def:crs:EPSG::999999"}},
    {"type": "name", "properties": {"name": "NOT A CRS"}},
    {"type": "link", "properties": {"href": "http://example.com/crs/42", "type": "proj4"}}])
def test_an_unknown_geojson_crs_is_an_error(tmp_path, member):
    path = _geojson(tmp_path / "odd.geojson", member, LONLAT)
    text = member["properties"].get("name", "http://example.com/crs/42")
    with pytest.raises(rf.GraphError) as err:
        rf.read_rivers(path)
    message = str(err.value)
    for part in ("odd.geojson", "(layer 'odd')", text):
        assert part in message, message
    builder = rf.read_rivers(path, crs="EPSG:4326")       # the user says which: read
    assert "EPSG:4326" in builder.report.derived["coordinates"]


def test_an_unknown_crs_after_the_features_is_an_error(tmp_path):
    import json
    path = tmp_path / "late.geojson"
    doc = json.loads(_geojson(path, ..., LONLAT).read_text())
    doc["crs"] = {"type": "name", "properties": {"name": "EPSG:0"}}
    path.write_text(json.dumps(doc))
    with pytest.raises(rf.GraphError, match=r"late.geojson \(layer 'late'\).*'EPSG:0'"):
        rf.read_rivers(path)


@pytest.mark.parametrize("member", [..., None,
                                    {"type": "name", "properties": {"name": "EPSG:4326"}},
                                    {"type": "name", "properties": {
                                        "name": "urn:ogc:def:crs:OGC:1.3:CRS84"}}])
def test_geojson_without_or_with_a_known_crs_is_wgs84(tmp_path, member):
    path = _geojson(tmp_path / "ok.geojson", member, LONLAT)
    builder = rf.read_rivers(path)
    assert "projected from EPSG:4326" in builder.report.derived["coordinates"] \
        or "OGC:CRS84" in builder.report.derived["coordinates"]
    assert len(builder.report.links) == 2
