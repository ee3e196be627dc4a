"""The drawn frames of the default scene, offscreen on Mesa's llvmpipe: every display mode
without a GL error, golden images, full sprite coverage of the water, and water that moves
while the land stays still.

Golden images live in ``tests/render/golden``; a failing comparison writes the frame and a
diff image to ``out/golden-diff``. Re-bless on purpose only: ``RIVERFLOW_BLESS=1 make test``.
"""
from __future__ import annotations

import dataclasses
import os
from pathlib import Path

import numpy as np
import pytest

from riverflow.components.display import MODE_NAMES, DisplayMode, settings_for
from riverflow.engine.config import RiverConfig
from riverflow.scenes.default import default_scene
from riverflow.scenes.flight import fly

pytestmark = pytest.mark.gl
W, H, R = 240, 136, 6.0
WARM_FRAMES = 150
GOLDEN = Path(__file__).parent / "golden"
DIFFS = Path(__file__).resolve().parents[2] / "out" / "golden-diff"


@pytest.fixture(scope="module")
def world(gl_context):
    """The default scene after a warm-up flight (flow tiles made in-frame: deterministic)."""
    from riverflow.engine.world import RiverWorld
    w = RiverWorld(default_scene(seed=0), size=(W, H), gl=True, seed=0,
                   config=RiverConfig(radius_px=R, tile_production="blocking"))
    fly(w, WARM_FRAMES)
    yield w
    w.close()


@pytest.fixture(scope="module")
def frames(world) -> dict[str, np.ndarray]:
    """Every mode's frame of the warmed-up world, drawn before any test steps it further."""
    return {name: _show(world, name) for name in MODE_NAMES}


def _show(world, name: str) -> np.ndarray:
    for key, value in dataclasses.asdict(settings_for(name)).items():
        setattr(world.display, key, value)
    frame = world.render()
    from riverflow.engine import gl
    gl.check_errors(f"rendering mode {name}")
    return frame


@pytest.fixture(scope="module")
def water_mask(frames) -> np.ndarray:
    """(H, W) bool: pixels where the water surface is drawn (mesh-only vs ground-only)."""
    return (frames["mesh"] != frames["none"]).any(axis=2)


@pytest.mark.parametrize("name", list(MODE_NAMES))
def test_every_mode_draws_without_gl_error(frames, name):
    frame = frames[name]
    assert frame.shape == (H, W, 4) and frame.dtype == np.uint8
    assert (frame[..., 3] == 255).all()
    assert frame[..., :3].std() > 5.0


def test_the_water_is_drawn_where_the_river_is(world, water_mask):
    share = water_mask.mean()
    assert 0.1 < share < 0.6, share     # the chase view looks down the river


def _compare_golden(name: str, frame: np.ndarray) -> None:
    from PIL import Image
    path = GOLDEN / f"{name}.png"
    if os.environ.get("RIVERFLOW_BLESS") == "1" or not path.exists():
        if os.environ.get("RIVERFLOW_BLESS") != "1":
            pytest.fail(f"no golden image {path}; bless with RIVERFLOW_BLESS=1")
        GOLDEN.mkdir(exist_ok=True)
        Image.fromarray(frame).save(path)
        return
    with Image.open(path) as image:
        want = np.asarray(image.convert("RGBA"))
    diff = np.abs(frame.astype(np.int16) - want.astype(np.int16)).max(axis=2)
    mean, off = float(diff.mean()), float((diff > 40).mean())
    if mean > 1.5 or off > 0.01:
        DIFFS.mkdir(parents=True, exist_ok=True)
        Image.fromarray(frame).save(DIFFS / f"{name}-got.png")
        Image.fromarray(np.clip(diff * 4, 0, 255).astype(np.uint8)).save(DIFFS / f"{name}-diff.png")
        pytest.fail(f"{name}: differs from {path.name} (mean |Δ| {mean:.2f}/255, "
                    f"{off:.2%} of pixels off by > 40); see {DIFFS}")


@pytest.mark.parametrize("name", ["none", "mesh", "coverage", "advected", "pre-advected",
                                  "non-advected", "particles"])
def test_golden_images(frames, name):
    _compare_golden(name, frames[name])


def test_no_water_pixel_is_uncovered_after_warm_up(frames, water_mask):
    frame = frames["coverage"]
    red, green = frame[..., 0], frame[..., 1]
    uncovered = water_mask & (green == 255) & (red == 0)
    covered = water_mask & (red > 0)
    assert covered.sum() > 0.9 * water_mask.sum()
    assert uncovered.sum() == 0, np.argwhere(uncovered)[:10]


def test_coverage_counts_are_sprites_over_the_pixel(world, water_mask):
    """Red = covering sprites / 16, recomputed on the CPU from the pool (exact where no cell
    list overflowed)."""
    from riverflow.components.status import FlowStatus
    frame = _show(world, "coverage")
    pool = world.pool
    drawn = pool.alive & pool.has_world & (pool.intensity > 0) & np.isin(
        pool.status, [FlowStatus.INSIDE, FlowStatus.LEAVING])
    centres = pool.screen_px[drawn].astype(np.float64)
    ys, xs = np.nonzero(water_mask & (frame[..., 2] == 0))     # cells whose list is not full
    px = np.stack([xs + 0.5, (H - 1 - ys) + 0.5], axis=1)      # GL pixel centres
    d = np.linalg.norm(px[:, None, :] - centres[None], axis=2)
    count = (d < 3.0 * R).sum(axis=1)
    want = np.round(np.minimum(count, 16) / 16 * 255)
    got = frame[ys, xs, 0].astype(np.float64)
    assert np.mean(np.abs(got - want) <= 1) > 0.999


def test_advected_water_moves_and_the_land_does_not(world, water_mask):
    first = _show(world, "advected")
    for _ in range(60):             # one second, camera still
        world.step(1 / 60)
    second = _show(world, "advected")
    changed = (first != second).any(axis=2)
    land = ~water_mask
    assert not changed[land].any(), changed[land].sum()
    assert changed[water_mask].mean() > 0.5
    diff = np.abs(first[..., :3].astype(int) - second[..., :3].astype(int)).sum(axis=2)
    assert diff[water_mask].mean() > 1.0


def test_only_advected_water_depends_on_the_particles(world):
    pool = world.pool
    saved = {name: column.copy() for name, column in pool.columns().items()}
    before = {name: _show(world, name) for name in ("advected", "non-advected")}
    pool.clear()
    try:
        after = {name: _show(world, name) for name in ("advected", "non-advected")}
    finally:
        for name, column in saved.items():
            getattr(pool, name)[...] = column
    assert np.array_equal(before["non-advected"], after["non-advected"])
    # with no sprite the advected mode falls back to the same plain texture
    assert not np.array_equal(before["advected"], after["advected"])
    assert np.array_equal(after["advected"], after["non-advected"])


def _image_shift(before: np.ndarray, after: np.ndarray) -> tuple[np.ndarray, float]:
    """(dx, dy) [px, x right, y up] by which ``after`` is ``before`` moved (phase
    correlation of the grey levels), and the correlation peak."""
    a = before[..., :3].mean(axis=2)
    b = after[..., :3].mean(axis=2)
    spectrum = np.fft.fft2(b - b.mean()) * np.conj(np.fft.fft2(a - a.mean()))
    corr = np.fft.ifft2(spectrum / (np.abs(spectrum) + 1e-9)).real
    row, col = np.unravel_index(np.argmax(corr), corr.shape)
    row = row if row < corr.shape[0] // 2 else row - corr.shape[0]
    col = col if col < corr.shape[1] // 2 else col - corr.shape[1]
    return np.array([col, -row], float), float(corr.max())


def test_advected_waves_move_with_the_flow(gl_context):
    """Seen from straight above, the wave pattern of the advected mode moves by the flow
    velocity × time; the non-advected pattern stands still."""
    from riverflow.components.waves import WaveKind
    from riverflow.engine.world import RiverWorld
    from riverflow.scenes.flight import flight_pose, main_centerline

    scene = default_scene(seed=0)
    world = RiverWorld(scene, size=(240, 136), gl=True, seed=0,
                       config=RiverConfig(radius_px=4.0, tile_production="blocking"))
    try:
        world.display.wave = WaveKind.PERLIN          # a still texture: only advection moves it
        _, target = flight_pose(scene, 600, line=main_centerline(scene))
        height = 30.0
        world.camera.look_at(target + (0.0, 0.0, height), target + (0.0, 1e-3, 0.0))
        for _ in range(240):
            world.step(1 / 60)
        _, velocity = world.field.query(target[None, :2])
        px_per_m = 136 / (2 * height * np.tan(np.radians(world.camera.fov_y_deg / 2)))
        want = velocity[0] * 1.0 * px_per_m             # one second
        assert np.linalg.norm(want) > 3.0
        crop = (slice(38, 98), slice(80, 160))
        shifts = {}
        for mode in (DisplayMode.ADVECTED, DisplayMode.NON_ADVECTED):
            world.display.mode = mode
            before = world.render()[crop]
            for _ in range(60):
                world.step(1 / 60)
            shifts[mode] = _image_shift(before, world.render()[crop])
        moved, peak = shifts[DisplayMode.ADVECTED]
        assert np.linalg.norm(moved - want) <= 1.5, (moved, want, peak)
        still, _ = shifts[DisplayMode.NON_ADVECTED]
        assert np.abs(still).max() == 0
    finally:
        world.close()


def test_resize_and_a_zero_size_viewport_never_break_a_frame(gl_context):
    from riverflow.engine.world import RiverWorld
    world = RiverWorld(default_scene(seed=0), size=(64, 48), gl=True, seed=0,
                       config=RiverConfig(radius_px=4.0, tile_production="blocking"))
    try:
        fly(world, 5)
        assert world.render().shape == (48, 64, 4)
        world.camera.set_viewport(0, 0)             # minimised
        world.step(1 / 60)
        assert world.render().shape == (0, 0, 4)
        world.camera.set_viewport(96, 40)           # restored, another shape
        fly(world, 3, start=5)
        frame = world.render()
        assert frame.shape == (40, 96, 4) and (frame[..., 3] == 255).all()
        assert frame[..., :3].std() > 5.0
        assert np.isfinite(world.pool.world_m[world.pool.alive]).all()
    finally:
        world.close()
