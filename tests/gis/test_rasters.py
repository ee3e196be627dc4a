"""Elevation rasters as height sources: GeoTIFF read by windows (rasterio), reprojected on
the fly to the network's CRS, 16-bit PNG heightmaps north-up, and rf.landscape on them."""
from __future__ import annotations

import numpy as np
import pytest

import riverflow as rf
from riverflow.scenes.rasters import BLOCK_CELLS, PngHeightSource, RasterSource
from tests.gis.conftest import ORIGIN, UTM, polyline, require_gis, write_lines

require_gis()

rasterio = pytest.importorskip("rasterio")
png = pytest.importorskip("png")

CELL = 2.0


def plane(x, y):
    """The test terrain [m]: a tilted plane (bilinear interpolation reproduces it exactly)."""
    return 100.0 + 0.01 * (x - ORIGIN[0]) + 0.02 * (y - ORIGIN[1])


def write_dem(path, nx=300, ny=200, west=ORIGIN[0] - 300.0, north=ORIGIN[1] + 200.0,
              cell=CELL, crs=UTM, fn=plane, nodata=None, transform=None):
    """A GeoTIFF of fn at the pixel centres; returns the path."""
    transform = transform or rasterio.Affine(cell, 0.0, west, 0.0, -cell, north)
    xs, ys = np.meshgrid(west + (np.arange(nx) + 0.5) * cell, north - (np.arange(ny) + 0.5) * cell)
    z = fn(xs, ys).astype(np.float32)
    if nodata is not None:
        z[:5, :5] = nodata
    with rasterio.open(path, "w", driver="GTiff", width=nx, height=ny, count=1,
                       dtype="float32", crs=crs, transform=transform, nodata=nodata) as ds:
        ds.write(z, 1)
    return path


def test_a_geotiff_gives_its_heights(tmp_path, rng):
    source = RasterSource(write_dem(tmp_path / "dem.tif"))
    x = ORIGIN[0] + rng.uniform(-298.0, 298.0, 500)
    y = ORIGIN[1] + rng.uniform(-198.0, 198.0, 500)
    np.testing.assert_allclose(source.heights(x, y), plane(x, y), atol=2e-4)  # float32 cells
    assert source.cell_m == CELL
    lo, hi = source.z_range_m
    assert lo <= plane(x, y).min() and hi >= plane(x, y).max()
    # pointwise: a point's height does not depend on its batch
    one = np.array([source.heights(x[k], y[k]) for k in range(20)])
    np.testing.assert_array_equal(one, source.heights(x[:20], y[:20]))
    # outside the raster: the nearest edge's value
    edge = source.heights(ORIGIN[0] + 1000.0, ORIGIN[1])
    assert edge == pytest.approx(float(source.heights(source.bounds_m[2], ORIGIN[1])))


def test_reads_are_windows_never_the_whole_raster(tmp_path, rng, monkeypatch):
    n = 3 * BLOCK_CELLS
    source = RasterSource(write_dem(tmp_path / "big.tif", nx=n, ny=n,
                                    north=ORIGIN[1] + n * CELL))
    shapes = []
    real = source._ds.read

    def read(*args, **kwargs):
        if "window" in kwargs:
            shapes.append((kwargs["window"].height, kwargs["window"].width))
        return real(*args, **kwargs)

    monkeypatch.setattr(source._ds, "read", read)
    x = ORIGIN[0] - 300.0 + rng.uniform(0.0, n * CELL, 200)
    y = ORIGIN[1] + rng.uniform(0.0, n * CELL, 200)
    np.testing.assert_allclose(source.heights(x, y), plane(x, y), atol=5e-4)
    assert shapes and max(h * w for h, w in shapes) <= (BLOCK_CELLS + 1) ** 2
    assert sum(h * w for h, w in shapes) < n * n        # never the whole raster


def test_nodata_is_filled_with_the_lowest_height(tmp_path):
    source = RasterSource(write_dem(tmp_path / "holes.tif", nodata=-9999.0))
    corner = source.heights(ORIGIN[0] - 298.0, ORIGIN[1] + 198.0)
    assert corner == pytest.approx(source.fill_m)
    assert source.z_range_m[0] > -100.0


def test_an_undeclared_no_data_value_is_no_data(tmp_path):
    """A float DEM whose holes hold float32's lowest value with no no-data tag (a common
    export): those cells are no-data (filled with the lowest height), not pits 3·10³⁸ m deep."""
    lowest = float(np.finfo(np.float32).min)
    source = RasterSource(write_dem(tmp_path / "undeclared.tif", fn=lambda x, y: np.where(
        (x < ORIGIN[0] - 290.0) & (y > ORIGIN[1] + 190.0), lowest, plane(x, y))))
    assert source.nodata is None
    corner = source.heights(ORIGIN[0] - 298.0, ORIGIN[1] + 198.0)
    assert corner == pytest.approx(source.fill_m) and source.z_range_m[0] > -100.0


def test_a_raster_in_another_crs_is_reprojected(tmp_path, rng):
    import pyproj

    to_lonlat = pyproj.Transformer.from_crs(UTM, "EPSG:4326", always_xy=True)
    lon0, lat0 = to_lonlat.transform(*ORIGIN)

    def by_degrees(lon, lat):
        return 50.0 + 1000.0 * (lon - lon0) + 2000.0 * (lat - lat0)

    path = write_dem(tmp_path / "lonlat.tif", nx=400, ny=400, west=lon0 - 0.01,
                     north=lat0 + 0.01, cell=0.00005, crs="EPSG:4326", fn=by_degrees)
    source = RasterSource(path, crs=UTM)
    assert source.reprojected
    x = ORIGIN[0] + rng.uniform(-500.0, 500.0, 200)
    y = ORIGIN[1] + rng.uniform(-500.0, 500.0, 200)
    lon, lat = to_lonlat.transform(x, y)
    np.testing.assert_allclose(source.heights(x, y), by_degrees(np.asarray(lon), np.asarray(lat)),
                               atol=0.02)


def test_bad_rasters(tmp_path):
    with pytest.raises(FileNotFoundError, match="nowhere.tif"):
        RasterSource(tmp_path / "nowhere.tif")
    bad = tmp_path / "bad.tif"
    bad.write_text("not a tiff")
    with pytest.raises(ValueError, match="bad.tif: cannot read it as a raster"):
        RasterSource(bad)
    with pytest.raises(ValueError, match="no band 2"):
        RasterSource(write_dem(tmp_path / "one.tif"), band=2)
    rotated = rasterio.Affine(2.0, 0.5, ORIGIN[0], 0.5, -2.0, ORIGIN[1])
    with pytest.raises(ValueError, match="rotated raster"):
        RasterSource(write_dem(tmp_path / "rot.tif", transform=rotated))


def test_a_16bit_png_heightmap_is_north_up(tmp_path):
    ny, nx = 50, 80
    values = np.zeros((ny, nx), np.uint16)
    values[:, :] = (np.arange(ny)[::-1, None] * 1000 + np.arange(nx)[None, :] * 10)  # north high
    path = tmp_path / "heights.png"
    with open(path, "wb") as f:
        png.Writer(nx, ny, greyscale=True, bitdepth=16).write(f, values.tolist())
    source = PngHeightSource(path, (10.0, 20.0), 2.0, scale_m=0.01, offset_m=5.0)
    # the south-west corner is the bottom-left pixel: value (0 rows from the south) = 0
    assert source.heights(10.0, 20.0) == pytest.approx(5.0)
    north_west = source.heights(10.0, 20.0 + 2.0 * (ny - 1))
    assert north_west == pytest.approx(5.0 + 0.01 * 1000 * (ny - 1))
    assert source.heights(10.0 + 2.0 * 3, 20.0) == pytest.approx(5.0 + 0.01 * 30)
    # through rf.landscape's terrain= (as_height_source)
    from riverflow.scenes.sources import as_height_source

    same = as_height_source(str(path), origin_m=(10.0, 20.0), cell_m=2.0)
    assert same.heights(12.0, 30.0) == pytest.approx((source.heights(12.0, 30.0) - 5.0) / 0.01)


def test_a_landscape_on_a_dem(tmp_path):
    lines = [polyline((-250, 0), (250, 0))]
    net = write_lines(tmp_path / "river.gpkg", lines, {"W": np.array([12.0])})
    graph = rf.read_rivers(net, origin_m=None, width_m="W").build()
    dem = write_dem(tmp_path / "dem.tif", nx=400, ny=400, west=ORIGIN[0] - 400.0,
                    north=ORIGIN[1] + 400.0)
    scene = rf.landscape(graph, terrain=dem, pad_m=100.0)
    assert isinstance(scene.terrain.source, RasterSource)
    far = np.array([[ORIGIN[0] - 200.0, ORIGIN[1] + 350.0], [ORIGIN[0] + 100.0, ORIGIN[1] - 350.0]])
    np.testing.assert_allclose(scene.terrain.height(far), plane(far[:, 0], far[:, 1]), atol=1e-3)
    on_river = np.array([[ORIGIN[0] - 100.0, ORIGIN[1]], [ORIGIN[0] + 100.0, ORIGIN[1]]])
    assert (scene.water.level(on_river) < plane(on_river[:, 0], on_river[:, 1])).all()
    assert (scene.terrain.height(on_river) < scene.water.level(on_river)).all()  # carved
