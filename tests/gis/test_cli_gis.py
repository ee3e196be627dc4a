"""The command line with GIS files: `--scene` takes a shapefile / GeoPackage / GeoJSON in
every subcommand, `bake --help` needs no display, numba or pyglet."""
from __future__ import annotations

import numpy as np
import pytest

from tests.gis.conftest import polyline, require_gis, write_lines

require_gis()
from tests.test_cli import PNG_SIGNATURE, run_cli, run_python


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
                 "--size-px", "300"]) == 0
    assert out.read_bytes().startswith(PNG_SIGNATURE)
    assert main(["flowmap", "--scene", str(net), "--layer", "lakes", "--out", str(out)]) == 1
    assert "no layer 'lakes'" in capsys.readouterr().err


@pytest.mark.data
@pytest.mark.slow
def test_profile_runs_on_red_butte(redbutte):
    result = run_cli("profile", "--scene", str(redbutte), "--size", "64x48", "--radius-px", "10",
                     "--frames", "2")
    assert result.returncode == 0, result.stderr
    assert "a001_network.shp" in result.stdout
