"""Wrong elevation rasters (issue: input hardening): every one gets a clear error naming the
file and what is wrong, from rf.landscape(terrain=), rf.read_water(dem=) and --terrain; the
odd-but-valid ones (1×N, south-up, integer dtypes, NaN cells) give finite heights."""
from __future__ import annotations

import numpy as np
import pytest
import shapely

import riverflow as rf
from riverflow.scenes.rasters import RasterSource
from riverflow.hydro.graph import GraphError
from tests.gis.conftest import ORIGIN, UTM, polyline, require_gis, write_lines

require_gis()
rasterio = pytest.importorskip("rasterio")
png = pytest.importorskip("png")


def dem(path, nx=8, ny=6, *, dtype="float32", crs=UTM, cell=100.0, west=ORIGIN[0] - 300.0,
        north=ORIGIN[1] + 300.0, transform=None, values=None, nodata=None):
    """A tiny GeoTIFF; ``values`` (ny, nx) or a ramp rising eastwards."""
    z = 100.0 + np.arange(nx)[None, :] + np.zeros((ny, 1)) if values is None else values
    with rasterio.open(path, "w", driver="GTiff", width=nx, height=ny, count=1, dtype=dtype,
                       crs=crs, nodata=nodata,
                       transform=transform or rasterio.Affine(cell, 0, west, 0, -cell, north)) as f:
        f.write(np.asarray(z).astype(dtype), 1)
    return path


def not_a_tiff(path, kind):
    if kind == "png":
        with open(path, "wb") as f:
            png.Writer(4, 4, greyscale=True, bitdepth=8).write(f, [[1, 2, 3, 4]] * 4)
    elif kind == "truncated":
        whole = dem(path.with_name("whole.tif"), 64, 64).read_bytes()
        path.write_bytes(whole[: len(whole) // 2])
    elif kind == "empty":
        path.write_bytes(b"")
    elif kind == "directory":
        path.mkdir()
    return path


@pytest.fixture(scope="module")
def river(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("river")
    net = write_lines(tmp / "river.gpkg", [polyline((-250, 0), (250, 0), step=50.0)],
                      {"W": np.array([12.0])})
    graph = rf.read_rivers(net, origin_m=None, width_m="W").build()
    from tests.gis.test_water import write_polygons

    water = write_polygons(tmp / "w.geojson",
                           [shapely.Polygon([(0, -15), (400, -40), (400, 40), (0, 15)])])
    return graph, water


BAD = {   # name: (make the file, the error's words)
    "all no-data": (lambda p: dem(p, nodata=-9999.0, values=np.full((6, 8), -9999.0)),
                    "no valid cell"),
    "all NaN": (lambda p: dem(p, values=np.full((6, 8), np.nan)), "no valid cell"),
    "all beyond any height": (lambda p: dem(p, values=np.full((6, 8), -3.4e38)),
                              "no valid cell.*beyond ±1e\\+07 m"),
    "complex": (lambda p: dem(p, dtype="complex64"), "complex numbers"),
    "rotated": (lambda p: dem(p, transform=rasterio.Affine(100, 20, ORIGIN[0], 20, -100,
                                                           ORIGIN[1])), "rotated raster"),
    "a PNG renamed .tif": (lambda p: not_a_tiff(p, "png"), "not georeferenced"),
    "truncated": (lambda p: not_a_tiff(p, "truncated"), "truncated or corrupt"),
    "empty file": (lambda p: not_a_tiff(p, "empty"), "cannot read it as a raster"),
    "a directory": (lambda p: not_a_tiff(p, "directory"), "not a file"),
    "away from the rivers": (lambda p: dem(p, west=ORIGIN[0] + 1e5), "away from the river"),
    "no CRS and elsewhere": (lambda p: dem(p, crs=None, west=0.0, north=0.0), "has no CRS"),
}


@pytest.mark.parametrize("name", BAD)
def test_a_bad_terrain_raster_is_a_clear_error(tmp_path, river, name):
    make, words = BAD[name]
    path = make(tmp_path / "dem.tif")
    with pytest.raises(ValueError, match=words) as err:
        rf.landscape(river[0], terrain=path, pad_m=100.0)
    assert "dem.tif" in str(err.value)


@pytest.mark.parametrize("name", ["complex", "a PNG renamed .tif", "empty file", "a directory",
                                  "all no-data", "away from the rivers"])
def test_a_bad_dem_for_water_polygons_is_a_clear_error(tmp_path, river, name):
    path = BAD[name][0](tmp_path / "dem.tif")
    with pytest.raises(GraphError, match="DEM") as err:
        rf.read_water(river[1], dem=path, origin_m=ORIGIN)
    assert "dem.tif" in str(err.value) or "free ends" in str(err.value)


def test_a_dem_that_is_not_a_file_name_is_named(river):
    with pytest.raises(GraphError, match="the DEM must be a file name, got int 5"):
        rf.read_water(river[1], dem=5, origin_m=ORIGIN)
    with pytest.raises(TypeError, match="elevation raster must be a file name"):
        RasterSource(np.zeros((3, 3)))


def test_a_dem_flat_at_the_free_ends_does_not_choose_one_end_twice(tmp_path, river):
    """A 1×1 DEM gives both ends one height: the width rule decides (before, the same end
    was made inlet and outlet)."""
    path = dem(tmp_path / "one.tif", 1, 1, cell=2000.0, west=ORIGIN[0] - 1000.0,
               north=ORIGIN[1] + 1000.0)
    builder = rf.read_water(river[1], dem=path, origin_m=ORIGIN)
    assert builder.report.derived["direction"].startswith("the DEM is flat at the free ends")


@pytest.mark.parametrize("shape,dtype,transform", [
    ((1, 9), "float32", None), ((9, 1), "int8", None), ((6, 8), "uint16", None),
    ((6, 8), "float64", "south-up"), ((6, 8), "float32", "nan cells")])
def test_odd_but_valid_rasters_give_finite_heights(tmp_path, shape, dtype, transform):
    ny, nx = shape
    values = 10.0 + np.arange(nx)[None, :] + np.zeros((ny, 1))
    t = None
    if transform == "south-up":
        t = rasterio.Affine(100.0, 0, ORIGIN[0] - 300, 0, 100.0, ORIGIN[1] - 300)
    elif transform == "nan cells":
        values[0, :3], values[1, 1], values[2, 2] = np.nan, np.inf, -np.inf
    source = RasterSource(dem(tmp_path / "d.tif", nx, ny, dtype=dtype, values=values,
                              transform=t))
    z = source.heights(ORIGIN[0] + np.linspace(-400, 600, 7), ORIGIN[1] + np.linspace(-300, 300, 7))
    assert np.isfinite(z).all() and (z >= 10.0).all() and (z <= 10.0 + nx).all()
    source.close()


def test_bad_raster_options_name_the_argument(tmp_path):
    path = dem(tmp_path / "d.tif")
    with pytest.raises(ValueError, match="z_range_m"):
        RasterSource(path, z_range_m=(5.0, float("nan")))
    with pytest.raises(TypeError, match="nodata"):
        RasterSource(path, nodata="zero")
    with pytest.raises(ValueError, match="no band 0"):
        RasterSource(path, band=0)
    with pytest.raises(ValueError, match="cannot reproject"):
        RasterSource(path, crs="EPSG:999999")


def test_a_bad_terrain_on_the_command_line_is_an_error_not_a_traceback(tmp_path, capsys):
    from riverflow.__main__ import main

    graph = tmp_path / "tiny.graph"
    graph.write_text("0 2 5 3 1 3 2 0\n6\n0 0 1 0\n100 0 1 0\n0 -10 2 1 4\n100 -10 2 1 2\n"
                     "100 10 2 2 3\n0 10 2 3 4\n5\n2 24 1 -1 -1 0 1 -1 -1 -1\n"
                     "2 24 2 100 0 2 3 0 -1 -1\n2 0 1 -1 -1 3 4 0 -1 -1\n"
                     "2 24 2 0 0 4 5 0 -1 -1\n2 0 1 -1 -1 5 2 0 -1 -1\n1\n"
                     "4 0 0 1 0 2 0 3 0 4 0 -1\n")
    bad = not_a_tiff(tmp_path / "dem.tif", "png")
    out = tmp_path / "o.png"
    assert main(["flowmap", "--scene", str(graph), "--terrain", str(bad), "--out", str(out)]) == 1
    err = capsys.readouterr().err
    assert "--terrain" in err and "not georeferenced" in err and "Traceback" not in err
    assert not out.exists()


def test_a_huge_raster_without_overviews_is_ranged_from_a_few_blocks(tmp_path, monkeypatch):
    """A strided scan reads every block of a tiled raster without overviews (minutes for a
    200 000² one): past SCAN_BLOCKS blocks a spread of whole blocks is read instead."""
    import riverflow.scenes.rasters as rasters

    values = 50.0 + np.add.outer(np.arange(64.0), np.arange(64.0))       # 50 … 176
    path = tmp_path / "tiled.tif"
    with rasterio.open(path, "w", driver="GTiff", width=64, height=64, count=1, dtype="float32",
                       crs=UTM, transform=rasterio.Affine(1, 0, 0, 0, -1, 64), tiled=True,
                       blockxsize=16, blockysize=16) as f:
        f.write(values.astype("float32"), 1)
    monkeypatch.setattr(rasters, "FULL_SCAN_CELLS", 64)      # stride 8: a subsample
    monkeypatch.setattr(rasters, "SCAN_BLOCKS", 4)           # 16 blocks > 4
    reads, original = [], RasterSource._block_sample

    def spy(self, bh, bw):
        reads.append((bh, bw))
        return original(self, bh, bw)

    monkeypatch.setattr(RasterSource, "_block_sample", spy)
    source = RasterSource(path)
    assert reads == [(16, 16)]
    lo, hi = source.z_range_m
    assert lo <= 50.0 and hi >= 176.0 and source.fill_m >= 50.0   # the corners' blocks are read
    source.close()



def _png_bytes(width, height, idat=b"\0" * 100):
    """A 16-bit greyscale PNG header declaring width × height over a tiny image stream."""
    import struct
    import zlib

    def chunk(kind, data):
        return (struct.pack(">I", len(data)) + kind + data
                + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF))
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 16, 0,
                                                               0, 0, 0))
            + chunk(b"IDAT", zlib.compress(idat)) + chunk(b"IEND", b""))


@pytest.mark.parametrize("data,words", [
    (_png_bytes(2000, 2000), "cannot read it as a PNG heightmap"),     # rows missing
    (_png_bytes(2**31 - 1, 2**31 - 1), "GiB of scratch space"),
    (_png_bytes(4, 3, b"\0" * 30)[:-30], "cannot read it as a PNG")],
    ids=["huge header, tiny file", "header past any disk", "truncated"])
def test_a_damaged_png_heightmap_is_a_clear_error(tmp_path, data, words):
    from riverflow.scenes.rasters import PngHeightSource

    path = tmp_path / "heights.png"
    path.write_bytes(data)
    with pytest.raises(ValueError, match=words) as err:
        PngHeightSource(path, (0.0, 0.0), 1.0)
    assert "heights.png" in str(err.value)
