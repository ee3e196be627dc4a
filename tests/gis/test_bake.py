"""rf.bake_flow_map and `riverflow bake`: the map decoded back agrees with FlowField.query at
the pixel centres (velocity within the quantisation step, water exactly), A holds the distance
to the nearest bank, the sidecar says how to read it, north-up."""
from __future__ import annotations

import json

import numpy as np
import pytest

import riverflow as rf
from riverflow.gis.bake import bank_distance, decode_flow_map, pixel_centres
from tests.gis.conftest import ORIGIN, polyline, require_gis, write_lines

require_gis()


@pytest.fixture(scope="module")
def river(tmp_path_factory):
    """A bend with a tributary, read from a GeoPackage (so the graph has a CRS)."""
    lines = [polyline((-300, 150), (-100, 60), (0, 0)), polyline((-300, -120), (0, 0)),
             polyline((0, 0), (150, -40), (300, 0))]
    path = write_lines(tmp_path_factory.mktemp("bake") / "river.gpkg", lines,
                       {"W": np.array([24.0, 18.0, 36.0])})
    graph = rf.read_rivers(path, origin_m=None, width_m="W").build()
    return graph, rf.FlowField(graph)


REGION = (ORIGIN[0] - 320.0, ORIGIN[1] - 150.0, ORIGIN[0] + 320.0, ORIGIN[1] + 170.0)


@pytest.mark.parametrize("bits", [8, 16])
def test_the_decoded_map_agrees_with_the_flow(river, tmp_path, bits):
    graph, field = river
    result = rf.bake_flow_map(field, REGION, 4.0, tmp_path / "flow.png", bits=bits)
    assert result.size_px == (160, 80)
    velocity, water, distance, meta = decode_flow_map(result.image)
    assert velocity.shape == (80, 160, 2)
    centres = pixel_centres(meta["origin_m"], meta["cell_m"], meta["size_px"])
    status, expected = field.query(centres)
    inside = (status == rf.FlowStatus.INSIDE).reshape(80, 160)
    np.testing.assert_array_equal(water, inside)
    assert 0.05 < inside.mean() < 0.5
    step = 2.0 * meta["max_speed_mps"] / ((1 << bits) - 1)
    error = np.abs(velocity.reshape(-1, 2) - expected)
    assert error.max() <= 0.5 * step * (1 + 1e-6)
    speed = np.hypot(*expected.T)
    assert meta["max_speed_mps"] == pytest.approx(speed.max())
    exact = bank_distance(graph, centres).reshape(80, 160)
    clipped = np.minimum(exact, meta["max_distance_m"])
    assert np.abs(distance - clipped).max() <= 0.5 * meta["max_distance_m"] / ((1 << bits) - 1) + 1e-9
    assert meta["max_distance_m"] == pytest.approx(exact[inside].max())


def test_rows_are_north_up_and_the_sidecar_says_so(river, tmp_path):
    _, field = river
    result = rf.bake_flow_map(field, REGION, 8.0, tmp_path / "maps" / "river.png")
    assert result.sidecar == tmp_path / "maps" / "river.json"
    meta = json.loads(result.sidecar.read_text())
    for key in ("origin_m", "cell_m", "size_px", "max_speed_mps", "encoding", "rows", "crs",
                "bounds_m", "max_distance_m", "bits"):
        assert key in meta
    assert meta["origin_m"] == [REGION[0], REGION[1]] and meta["cell_m"] == 8.0
    assert meta["rows"].startswith("north-up")
    assert "EPSG" in meta["crs"] or "UTM" in meta["crs"]
    _, water, _, _ = decode_flow_map(result.image)
    # the tributary comes from the north-west: water in the top-left quarter, row 0 = north
    north_west = water[: water.shape[0] // 2, : water.shape[1] // 4]
    south_west = water[water.shape[0] // 2:, : water.shape[1] // 8]
    assert north_west.any()
    top = pixel_centres(meta["origin_m"], meta["cell_m"], meta["size_px"])[0]
    assert top[1] == pytest.approx(REGION[1] + (meta["size_px"][1] - 0.5) * 8.0)
    assert south_west.any()


def test_bad_requests(river, tmp_path):
    _, field = river
    with pytest.raises(ValueError, match="bits must be 8 or 16"):
        rf.bake_flow_map(field, REGION, 4.0, tmp_path / "a.png", bits=12)
    with pytest.raises(ValueError, match="x0 < x1"):
        rf.bake_flow_map(field, (0, 0, -1, 5), 4.0, tmp_path / "a.png")
    with pytest.raises(ValueError, match="over 16384 px"):
        rf.bake_flow_map(field, REGION, 0.01, tmp_path / "a.png")
    with pytest.raises(TypeError, match="needs a FlowField"):
        rf.bake_flow_map("river.graph", REGION, 4.0, tmp_path / "a.png")


def test_the_command_line_bakes_a_gis_scene(tmp_path, capsys):
    from riverflow.__main__ import main

    lines = [polyline((-200, 0), (200, 0))]
    net = write_lines(tmp_path / "one.geojson", lines, {"width_m": np.array([20.0])})
    region = "--region=-220,-40,220,40"    # read with origin_m="auto": moved by ORIGIN
    out = tmp_path / "flow.png"
    assert main(["bake", "--scene", str(net), region, "--cell-m", "2", "--out", str(out),
                 "--16bit"]) == 0
    assert "220x40 px" in capsys.readouterr().out
    velocity, water, _, meta = decode_flow_map(out)
    assert meta["bits"] == 16 and water.any()
    assert (velocity[water][:, 0] > 0).all()       # the river runs east
    assert main(["bake", "--scene", str(tmp_path / "none.shp"), "--out", str(out)]) == 1
    assert "none.shp" in capsys.readouterr().err
