"""The command line with GIS files: `--scene` takes a shapefile / GeoPackage / GeoJSON in
every subcommand, `bake --help` needs no display, numba or pyglet."""
from __future__ import annotations

import numpy as np
import pytest

from tests.gis.conftest import ORIGIN, polyline, require_gis, write_lines

require_gis()
from tests.test_cli import PNG_SIGNATURE, cli, run_python


def test_bake_help_imports_nothing_heavy():
    code = ("import sys\n"
            "from riverflow.__main__ import main\n"
            "try:\n"
            "    main(['bake', '--help'])\n"
            "except SystemExit as exc:\n"
            "    assert exc.code == 0, exc.code\n"
            "bad = {'pyglet', 'esper', 'matplotlib', 'numba', 'pyogrio', 'rasterio'} & set(sys.modules)\n"
            "assert not bad, bad\n")
    result = run_python(code)
    assert result.returncode == 0, result.stderr


@pytest.mark.slow
def test_flowmap_draws_a_geopackage(tmp_path, capsys):
    pytest.importorskip("matplotlib")
    from riverflow.__main__ import main

    net = write_lines(tmp_path / "net.gpkg", [polyline((-300, 0), (0, 100), (300, 0))],
                      {"W": np.array([30.0])}, layer="rivers")
    out = tmp_path / "map.png"
    assert main(["flowmap", "--scene", str(net), "--layer", "rivers", "--out", str(out),
                 "--size-px", "600"]) == 0
    assert out.read_bytes().startswith(PNG_SIGNATURE)
    assert main(["flowmap", "--scene", str(net), "--layer", "lakes", "--out", str(out)]) == 1
    assert "no layer 'lakes'" in capsys.readouterr().err


@pytest.mark.data
@pytest.mark.slow
def test_profile_runs_on_red_butte(redbutte):
    result = cli("profile", "--scene", str(redbutte), "--size", "64x48", "--radius-px", "10",
                     "--frames", "2")
    assert result.returncode == 0, result.stderr
    assert "a001_network.shp" in result.stdout


def test_a_scene_on_a_dem_from_the_command_line(tmp_path, capsys):
    """--terrain: the DEM (UTM 33N) under rivers whose coordinates were moved near 0 (their
    CRS's false origin with them): the raster is warped to the rivers' CRS."""
    pytest.importorskip("rasterio")
    from riverflow.__main__ import _parser
    from riverflow.gis.cli import load_scene
    from riverflow.scenes.rasters import RasterSource
    from tests.gis.test_rasters import plane, write_dem

    net = write_lines(tmp_path / "net.gpkg", [polyline((-250, 0), (250, 0))],
                      {"W": np.array([12.0])}, layer="streams")
    dem = write_dem(tmp_path / "dem.tif", nx=400, ny=400, west=ORIGIN[0] - 400.0,
                    north=ORIGIN[1] + 400.0)
    args = _parser().parse_args(["bake", "--scene", str(net), "--layer", "streams",
                                 "--terrain", str(dem)])
    scene, title = load_scene(args)
    assert title == "net.gpkg" and isinstance(scene.terrain.source, RasterSource)
    assert scene.terrain.source.reprojected
    far = np.array([[-200.0, 350.0], [100.0, -350.0]])        # moved coordinates
    np.testing.assert_allclose(scene.terrain.height(far),
                               plane(far[:, 0] + ORIGIN[0], far[:, 1] + ORIGIN[1]), atol=0.01)


def test_check_prints_the_report_and_fails_only_on_unusable_data(tmp_path, capsys):
    import shapely

    from riverflow.__main__ import main

    lines = [polyline((-600, 300), (0, 0)), polyline((0, 0), (-600, -300)),   # drawn upstream
             polyline((0, 0), (800, 0)), polyline((0, 0), (800, 0))]        # twice
    net = write_lines(tmp_path / "net.geojson", lines, {"name": np.array(["a", "b", "c", "d"],
                                                                         dtype=object)})
    assert main(["check", str(net)]) == 0
    out = capsys.readouterr().out
    assert "net.geojson (layer 'net'): 4 features -> 3 links" in out
    assert "repair: feature 1: drawn upstream" in out and "name='b'" in out
    assert "repair: feature 3: an exact duplicate of feature 2" in out
    assert "usable: 3 links, 2.142 km of river, 2 repairs" in out
    assert main(["check", str(net), "--strict"]) == 1      # strict: the defect is an error
    assert "net.geojson (layer 'net'): feature 3: an exact duplicate" in capsys.readouterr().err
    points = write_lines(tmp_path / "points.gpkg", None, {"n": np.array([1])},
                         geoms=[shapely.Point(ORIGIN)])
    assert main(["check", str(points)]) == 1
    err = capsys.readouterr().err
    assert "points.gpkg (layer 'points'): no usable line: feature 1 is a Point" in err
