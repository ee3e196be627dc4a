"""Bad GIS input gets a clear error naming the file, the layer, the feature (its id and
attribute values) and what is wrong, and nothing half-built comes back: a missing file, a
wrong layer, a non-line geometry, an empty file, NaN coordinates, an unknown attribute, a CRS
that cannot be projected, and networks the builder cannot make."""
from __future__ import annotations

import numpy as np
import pytest
import shapely

import riverflow as rf
from tests.gis.conftest import ORIGIN, polyline, require_gis, write_lines

require_gis()

LINES = [polyline((-600, 300), (0, 0)), polyline((-600, -300), (0, 0)),
         polyline((0, 0), (800, 0))]
ATTRS = {"name": np.array(["north", "south", "main"], dtype=object),
         "W": np.array([20.0, 25.0, 35.0])}


def test_missing_file(tmp_path):
    with pytest.raises(FileNotFoundError, match="nowhere.shp"):
        rf.read_rivers(tmp_path / "nowhere.shp")


def test_wrong_layer(tmp_path):
    path = write_lines(tmp_path / "two.gpkg", LINES, ATTRS, layer="rivers")
    with pytest.raises(rf.GraphError, match=r"two.gpkg: no layer 'streams'; its layers: \['rivers'\]"):
        rf.read_rivers(path, layer="streams")
    with pytest.raises(rf.GraphError, match=r"no layer 3 \(it has 1"):
        rf.read_rivers(path, layer=3)
    assert len(rf.read_rivers(path, layer="rivers", width_m="W").report.links) == 3


def test_a_point_among_the_lines(tmp_path):
    geoms = [shapely.LineString(p + ORIGIN) for p in LINES]
    geoms[1] = shapely.Point(ORIGIN + (-600, -300))
    path = write_lines(tmp_path / "mixed.geojson", None, ATTRS, geoms=geoms)
    with pytest.raises(rf.GraphError) as err:
        rf.read_rivers(path, strict=True)
    message = str(err.value)
    for part in ("mixed.geojson", "feature 1", "is a Point, not a line", "name='south'", "W=25"):
        assert part in message, message
    # not strict: left out, and the report says so
    (repair,) = rf.read_rivers(path).report.repairs
    assert repair.feature == "feature 1" and "is a Point" in repair.what
    assert repair.attributes == {"name": "south", "W": 25.0}


def test_a_polygon_layer(tmp_path):
    geoms = [shapely.Point(ORIGIN).buffer(50.0)]
    path = write_lines(tmp_path / "lake.shp", None, {"id": np.array([7])}, geoms=geoms)
    with pytest.raises(rf.GraphError, match=r"lake.shp.*feature 0 is a Polygon.*id=7"):
        rf.read_rivers(path)


def test_empty_files(tmp_path):
    empty = tmp_path / "empty.geojson"
    empty.write_text("")
    with pytest.raises(rf.GraphError, match="empty.geojson: the file is empty"):
        rf.read_rivers(empty)
    no_features = tmp_path / "none.geojson"
    no_features.write_text('{"type": "FeatureCollection", "features": []}')
    with pytest.raises(rf.GraphError, match=r"none.geojson \(layer 'none'\): no features"):
        rf.read_rivers(no_features)
    garbage = tmp_path / "garbage.gpkg"
    garbage.write_bytes(b"this is not a geopackage")
    with pytest.raises(rf.GraphError, match="garbage.gpkg: cannot read it"):
        rf.read_rivers(garbage)


def test_nan_coordinates(tmp_path):
    line = LINES[2] + ORIGIN
    line[4, 1] = np.nan
    with np.errstate(invalid="ignore"):     # (shapefiles refuse NaN; GeoPackages keep it)
        geoms = [shapely.LineString(p + ORIGIN) for p in LINES[:2]] + [shapely.LineString(line)]
        path = write_lines(tmp_path / "nan.gpkg", None, ATTRS, geoms=geoms)
    with pytest.raises(rf.GraphError) as err:
        rf.read_rivers(path, strict=True)
    message = str(err.value)
    for part in ("nan.gpkg", "feature 3", "vertex 4", "non-finite", "name='main'"):
        assert part in message, message
    (repair,) = rf.read_rivers(path).report.repairs       # not strict: the vertex left out
    assert repair.feature == "feature 3" and "vertex 4" in repair.what


def test_unknown_attributes(tmp_path):
    path = write_lines(tmp_path / "attrs.gpkg", LINES, ATTRS)
    with pytest.raises(rf.GraphError, match=r"no attribute 'WIDTH' \(for width_m\); its "
                                            r"attributes: \['name', 'W'\]"):
        rf.read_rivers(path, width_m="WIDTH")
    with pytest.raises(rf.GraphError, match=r"no attribute 'w' \(for drainage_area_km2\) "
                                            r"\(did you mean 'W'\?\)"):
        rf.read_rivers(path, drainage_area_km2="w")
    with pytest.raises(rf.GraphError, match=r"no attribute 'dn' \(for elevation_m\)"):
        rf.read_rivers(path, elevation_m=("W", "dn"))
    with pytest.raises(rf.GraphError, match=r"feature 1: attribute 'name' = 'north' is not a "
                                            r"number"):   # (GeoPackage ids start at 1)
        rf.read_rivers(path, width_m="name", strict=True)
    with pytest.raises(ValueError, match=r"read_rivers: width_m must be positive, got -3.0"):
        rf.read_rivers(path, width_m=-3.0)


def test_crs_that_cannot_be_projected(tmp_path):
    path = write_lines(tmp_path / "crs.geojson", LINES, ATTRS)
    with pytest.raises(rf.GraphError, match=r"crs.geojson.*cannot read its CRS 'not a CRS'"):
        rf.read_rivers(path, crs="not a CRS")
    # metres taken for degrees: latitudes of millions of degrees
    with pytest.raises(rf.GraphError) as err:
        rf.read_rivers(path, crs="EPSG:4326")
    message = str(err.value)
    for part in ("crs.geojson", "feature 0", "vertex 0", "cannot be projected", "name='north'",
                 "not a longitude and latitude", 'give it: crs="EPSG:'):
        assert part in message, message
    with pytest.raises(rf.GraphError, match="EPSG:4978.*cannot be projected to a map in metres"):
        rf.read_rivers(path, crs="EPSG:4978")     # geocentric


def test_build_errors_name_the_features(tmp_path):
    lines = [polyline((0, 0), (1000, 0)), polyline((0, 30), (1000, 30))]   # overlapping
    path = write_lines(tmp_path / "overlap.shp", lines,
                       {"name": np.array(["left", "right"], dtype=object),
                        "W": np.array([50.0, 50.0])})
    builder = rf.read_rivers(path, width_m="W", strict=True)   # (not strict: narrowed)
    with pytest.raises(rf.GraphError) as err:
        builder.build()
    message = str(err.value)
    for part in ("overlap.shp", "'feature 0'", "'feature 1'", "name='left'", "name='right'"):
        assert part in message, message


def test_a_loop_that_flows_into_itself(tmp_path):
    lines = [polyline((0, 0), (500, 0), (500, 500)), polyline((500, 500), (0, 500), (0, 0))]
    path = write_lines(tmp_path / "loop.geojson", lines)
    with pytest.raises(rf.GraphError, match="loop that flows back into itself"):
        rf.read_rivers(path, strict=True)


def test_missing_extra_is_named(monkeypatch, tmp_path):
    import sys

    monkeypatch.setitem(sys.modules, "pyogrio", None)     # as if not installed
    with pytest.raises(ImportError, match=r"reading .*x.shp needs the optional GIS extra.*"
                                          r"pip install 'riverflow\[gis\]'"):
        rf.read_rivers(tmp_path / "x.shp")
    monkeypatch.setitem(sys.modules, "rasterio", None)
    with pytest.raises(ImportError, match=r"riverflow\[gis\]"):
        rf.landscape(_graph(),
                     terrain=tmp_path / "dem.tif")


def _graph():
    b = rf.RiverNetworkBuilder()
    b.add_branch([(0, 0), (100, 0)], 10.0, discharge_m2s=5.0)
    return b.build()
