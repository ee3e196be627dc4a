"""Flow-map presets (issue #26): each preset decoded with its engine's documented formula (the
table below, written from the engines' shaders, not from riverflow's PRESETS) gives the
FlowField's velocity at the pixel centres, with both axes the right way round on the direction
test map."""
from __future__ import annotations

import json

import numpy as np
import pytest
from PIL import Image

import riverflow as rf
from riverflow.gis.bake import (PRESETS, bank_distance, decode_flow_map, direction_test_map,
                                pixel_centres, rotating_flow)
from tests.gis.conftest import ORIGIN, polyline, require_gis, write_lines

require_gis()

# how each engine's flow shader turns a texel into a flow vector in its UV space, and which
# way its V runs on a north-up image: Catlike Coding's Unity shaders sample with OpenGL's V up;
# Unreal (DirectX), Source (DirectX) and Godot (Waterways' river.shader) with V down the image
ENGINE_V_DOWN = {"raw": False, "unity": False, "unreal": True, "godot-waterways": True,
                 "source": True}


def engine_flow(rgba: np.ndarray) -> np.ndarray:
    """``tex.rg * 2 - 1`` (Unity, Unreal, Source) = ``(tex.xy - 0.5) * 2`` (Waterways)."""
    return rgba[..., :2].astype(np.float64) / 255.0 * 2.0 - 1.0


def world_flow(rgba, preset, max_speed):
    """The engine's UV-space flow as (east, north) [m/s]."""
    uv = engine_flow(rgba) * max_speed
    return np.stack([uv[..., 0], -uv[..., 1] if ENGINE_V_DOWN[preset] else uv[..., 1]], -1)


@pytest.fixture(scope="module")
def river(tmp_path_factory):
    lines = [polyline((-300, 150), (-100, 60), (0, 0)), polyline((-300, -120), (0, 0)),
             polyline((0, 0), (150, -40), (300, 0))]
    path = write_lines(tmp_path_factory.mktemp("presets") / "river.gpkg", lines,
                       {"W": np.array([24.0, 18.0, 36.0])})
    graph = rf.read_rivers(path, origin_m=None, width_m="W").build()
    return graph, rf.FlowField(graph)


REGION = (ORIGIN[0] - 320.0, ORIGIN[1] - 150.0, ORIGIN[0] + 320.0, ORIGIN[1] + 170.0)


def test_the_engine_list_is_the_presets():
    assert set(ENGINE_V_DOWN) == set(PRESETS)


@pytest.mark.parametrize("preset", sorted(ENGINE_V_DOWN))
def test_each_preset_decodes_to_the_flow_by_its_engines_formula(river, tmp_path, preset):
    graph, field = river
    result = rf.bake_flow_map(field, REGION, 8.0, tmp_path / "flow.png", preset=preset)
    rgba = np.asarray(Image.open(result.image).convert("RGBA"))
    meta = json.loads(result.sidecar.read_text())
    assert meta["preset"] == preset and "linear" in meta["colour_space"]
    assert meta["v_axis"].startswith("down" if ENGINE_V_DOWN[preset] else "up")
    centres = pixel_centres(meta["origin_m"], meta["cell_m"], meta["size_px"])
    status, expected = field.query(centres)
    water = status == rf.FlowStatus.INSIDE
    got = world_flow(rgba, preset, meta["max_speed_mps"]).reshape(-1, 2)
    error = np.hypot(*(got - expected)[water].T)
    assert np.percentile(error, 90) <= 0.02 * meta["max_speed_mps"]
    fast = np.hypot(*expected.T) > 0.2 * meta["max_speed_mps"]
    for axis in (0, 1):                                   # right sign on both axes
        moving = fast & (np.abs(expected[:, axis]) > 0.1 * meta["max_speed_mps"])
        assert moving.sum() > 20
        assert (np.sign(got[moving, axis]) == np.sign(expected[moving, axis])).all()
    back, *_ = decode_flow_map(result.image)          # riverflow's own reader agrees
    np.testing.assert_allclose(back.reshape(-1, 2), got, atol=1e-9)
    blue, alpha = rgba[..., 2].ravel() / 255.0, rgba[..., 3].ravel() / 255.0
    speed = np.hypot(*expected.T)
    if preset in ("raw", "unreal"):
        np.testing.assert_array_equal(blue > 0.5, water)
    if preset == "unity":                                  # Directional Flow: B = speed
        assert np.abs(blue - np.minimum(speed / meta["max_speed_mps"], 1)).max() <= 0.5 / 255
    if preset in ("unity", "godot-waterways"):             # A = smooth noise, not constant
        assert alpha.std() > 0.05 and np.abs(np.diff(alpha.reshape(rgba.shape[:2]), axis=1)).max() < 0.1
    if preset == "godot-waterways":
        assert (blue[~water] == 0).all() and blue[water].max() > 0.3   # foam at the banks
        d = bank_distance(graph, centres)
        near, far = water & (d < 2.0), water & (d > 10.0)
        assert blue[near].mean() > 2 * blue[far].mean()
        dist = np.asarray(Image.open(tmp_path / meta["distance_map"]).convert("RGBA"))
        expect_r = 1.0 - np.minimum(d / meta["max_distance_m"], 1.0)
        assert np.abs(dist[..., 0].ravel() / 255.0 - expect_r).max() <= 0.5 / 255 + 1e-9
    if preset == "source":
        assert (rgba[..., 3] == 255).all()


@pytest.mark.parametrize("preset", sorted(ENGINE_V_DOWN))
def test_the_direction_test_map_turns_counter_clockwise_in_every_engine(tmp_path, preset):
    size = 64
    path = direction_test_map(tmp_path / "dir.png", preset, size)
    rgba = np.asarray(Image.open(path).convert("RGBA"))
    uv = engine_flow(rgba)
    # the texture's motion in image pixels (columns right, rows down) as the engine sees it
    right, down = uv[..., 0], (uv[..., 1] if ENGINE_V_DOWN[preset] else -uv[..., 1])
    c = size // 2
    east, north = (c, c + size * 2 // 5), (c - size * 2 // 5, c)
    assert down[east] < -0.5 and abs(right[east]) < 0.1      # east side: up the image
    assert right[north] < -0.5 and abs(down[north]) < 0.1    # north side: to the left
    meta = json.loads(path.with_suffix(".json").read_text())
    centres = pixel_centres(meta["origin_m"], 1.0, (size, size))
    expected, water, _ = rotating_flow(centres, 0.45 * size, 1.0)
    got = world_flow(rgba, preset, 1.0).reshape(-1, 2)
    assert np.abs(got - expected)[water].max() <= 1.0 / 255 + 1e-6


def test_an_unknown_preset_is_named_and_nothing_is_written(river, tmp_path):
    from riverflow.__main__ import main

    _, field = river
    with pytest.raises(ValueError, match="unknown preset 'unity3d'.*godot-waterways"):
        rf.bake_flow_map(field, REGION, 8.0, tmp_path / "a.png", preset="unity3d")
    with pytest.raises(ValueError, match="unknown preset"):
        direction_test_map(tmp_path / "b.png", "godot")
    assert main(["bake", "--preset", "nope", "--out", str(tmp_path / "c.png")]) == 1
    assert list(tmp_path.iterdir()) == []


def test_the_command_line_writes_a_preset_and_a_direction_test(tmp_path, capsys):
    from riverflow.__main__ import main

    net = write_lines(tmp_path / "one.geojson", [polyline((-200, 0), (200, 0))],
                      {"width_m": np.array([20.0])})
    out = tmp_path / "flow.png"
    assert main(["bake", "--scene", str(net), "--region=-220,-40,220,40", "--cell-m", "4",
                 "--out", str(out), "--preset", "godot-waterways"]) == 0
    meta = json.loads(out.with_suffix(".json").read_text())
    assert meta["preset"] == "godot-waterways" and (tmp_path / "flow_dist.png").exists()
    assert main(["bake", "--direction-test", "--preset", "unreal", "--out",
                 str(tmp_path / "dir.png")]) == 0
    assert json.loads((tmp_path / "dir.json").read_text())["preset"] == "unreal"
