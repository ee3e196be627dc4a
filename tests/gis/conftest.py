"""Shared helpers of the GIS tests: networks written by the tests in each format, the Red
Butte example. Every module skips itself when the ``gis`` extra is not installed
(:func:`require_gis`)."""
from __future__ import annotations

import itertools

import numpy as np
import pytest
import shapely

from tests.conftest import SHARED_DATA

GIS_EXTRA = "the gis extra (pip install 'riverflow[gis]')"


def require_gis():
    """Skip the calling test module when the gis extra is absent; returns (pyogrio, pyproj).
    (Each module calls it: a skip raised while importing a conftest stops the whole run.)"""
    return (pytest.importorskip("pyogrio", reason=GIS_EXTRA),
            pytest.importorskip("pyproj", reason=GIS_EXTRA))

REDBUTTE = SHARED_DATA / "gis" / "redbutte" / "a001_network.shp"
UTM = "EPSG:32633"
"""The projected CRS the synthetic networks are drawn in (WGS 84 / UTM 33N, metres)."""
ORIGIN = np.array([500_000.0, 5_000_000.0])
"""Where the synthetic networks lie in UTM 33N (near 15° E, 45° N)."""
DRIVERS = {".geojson": "GeoJSON", ".shp": "ESRI Shapefile", ".gpkg": "GPKG"}


@pytest.fixture
def redbutte():
    if not REDBUTTE.exists():
        pytest.skip(f"shared data absent: {REDBUTTE}")
    return REDBUTTE


def write_lines(path, lines, attrs=None, *, crs=UTM, lonlat=False, layer=None, geoms=None):
    """Write line features (each (K, 2) [m] relative to ORIGIN, drawn downstream) with
    attribute columns ``attrs`` {name: values} to ``path`` (driver from the suffix). With
    ``lonlat`` the coordinates are converted to WGS 84 lon/lat and written so. ``geoms``:
    shapely geometries written as they are instead. Returns the path."""
    import pyogrio.raw
    import pyproj

    if geoms is None:
        geoms = [shapely.LineString(np.asarray(p, float) + ORIGIN) for p in lines]
    if lonlat:
        to = pyproj.Transformer.from_crs(crs, "EPSG:4326", always_xy=True)
        geoms = [shapely.transform(g, lambda xy: np.column_stack(to.transform(xy[:, 0], xy[:, 1])))
                 for g in geoms]
        crs = "EPSG:4326"
    attrs = attrs or {}
    names = list(attrs)
    data = [np.asarray(attrs[n]) for n in names]
    kinds = {g.geom_type for g in geoms if g is not None}
    pyogrio.raw.write(str(path), np.array([None if g is None else shapely.to_wkb(g) for g in geoms],
                                          dtype=object),
                      data, names, driver=DRIVERS[path.suffix], crs=crs, layer=layer,
                      geometry_type=kinds.pop() if len(kinds) == 1 else "Unknown")
    return path


def polyline(*points, step=10.0):
    """A polyline through ``points`` [m] with vertices about every ``step`` metres."""
    pts = np.asarray(points, float)
    out = [pts[:1]]
    for a, b in itertools.pairwise(pts):
        n = max(1, int(np.ceil(np.hypot(*(b - a)) / step)))
        t = np.linspace(0.0, 1.0, n + 1)[1:, None]
        out.append(a + t * (b - a))
    return np.vstack(out)


def arc(centre, radius, start_deg, end_deg, step=10.0):
    """A circular arc [m] from start_deg to end_deg (counter-clockwise if end > start)."""
    length = np.radians(abs(end_deg - start_deg)) * radius
    a = np.radians(np.linspace(start_deg, end_deg, max(3, int(length / step) + 1)))
    return np.asarray(centre, float) + radius * np.column_stack([np.cos(a), np.sin(a)])


def along(line, step=5.0, skip_m=0.0):
    """Points every ``step`` m along a polyline (K, 2), with unit tangents; ``skip_m`` metres
    left out at both ends."""
    s = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(line, axis=0).T))])
    t = np.arange(skip_m, s[-1] - skip_m + 1e-9, step)
    pts = np.column_stack([np.interp(t, s, line[:, 0]), np.interp(t, s, line[:, 1])])
    k = np.clip(np.searchsorted(s, t, side="right") - 1, 0, len(line) - 2)
    d = line[k + 1] - line[k]
    return pts, d / np.hypot(d[:, 0], d[:, 1])[:, None]
