"""Wave-tile kernels against their numpy twins (waves_reference.py), and the WaveTile component."""
from __future__ import annotations

import math
import os

import numpy as np
import numpy.testing as npt
import pytest

from riverflow.components import waves as cw
from riverflow.components.waves import WaveKind, WaveTile
from riverflow.kernels import waves as kw
from tests.kernels import waves_reference as ref

PERM = kw.permutation(171717)
G2 = kw.gradients_2d()
G3 = kw.gradients_3d()


def _rms(a):
    return float(np.sqrt(np.mean(np.square(a, dtype=np.float64))))


@pytest.fixture(scope="module")
def perlin():
    return cw.perlin_wave_tile()


@pytest.fixture(scope="module")
def animated():
    """Small, so the tests stay quick with NUMBA_DISABLE_JIT=1 too."""
    return cw.animated_wave_tile(size=32, frames=8, base_cells=2)


NO_JIT = os.environ.get("NUMBA_DISABLE_JIT", "0") not in ("", "0")


# ---- kernels vs twins -------------------------------------------------------------------------

def test_tables_match_reference():
    for seed in (0, 1, 171717, 2**32 - 1):
        perm = kw.permutation(seed)
        npt.assert_array_equal(perm, ref.permutation(seed))
        assert sorted(perm.tolist()) == list(range(256))
    assert not np.array_equal(kw.permutation(1), kw.permutation(2))
    assert kw.hash32(-1) == ref.hash32(-1) and kw.hash32(2**40 + 5) == ref.hash32(2**40 + 5)
    npt.assert_allclose(G2, ref.gradients_2d(), atol=1e-12)
    npt.assert_allclose(G3, ref.gradients_3d(), atol=1e-12)
    npt.assert_allclose(np.linalg.norm(G3, axis=1), 1.0, atol=1e-12)


def test_perlin_tiles_match_reference():
    npt.assert_allclose(kw.perlin_tile_2d(32, 2, 4, PERM, G2),
                        ref.perlin_tile_2d(32, 2, 4, PERM, ref.gradients_2d()), atol=1e-9)
    npt.assert_array_equal(kw.loop_z(4, 3), ref.loop_z(4, 3))
    npt.assert_allclose(kw.perlin_frames_3d(16, kw.loop_z(4, 3), 1, 4, 3, PERM, G3),
                        ref.perlin_frames_3d(16, ref.loop_z(4, 3), 1, 4, 3, PERM,
                                             ref.gradients_3d()), atol=1e-9)
    z = np.array([1.3, -0.2, 7.9])
    npt.assert_allclose(kw.perlin_frames_3d(16, z, 2, 3, 4, PERM, G3),
                        ref.perlin_frames_3d(16, z, 2, 3, 4, PERM, ref.gradients_3d()), atol=1e-9)


def test_ripples_slopes_and_mips_match_reference(rng):
    waves = np.array([[1, 2, 0.5, 0.3], [-3, 1, 0.2, 1.0], [0, 4, 0.1, 2.0]], np.float64)
    npt.assert_allclose(kw.ripple_heights(16, waves), ref.ripple_heights(16, waves), atol=1e-9)
    h = rng.normal(size=(3, 16, 16))
    for spacing in (1.0, 4.0):
        npt.assert_allclose(kw.slopes_from_heights(h, spacing), ref.slopes_from_heights(h, spacing),
                            atol=1e-6)
    s = rng.normal(size=(2, 8, 8, 2)).astype(np.float32)
    npt.assert_allclose(kw.downsample_2x2(s), ref.downsample_2x2(s), atol=1e-6)
    npt.assert_allclose(kw.normalise_heights(h), ref.normalise_heights(h), rtol=1e-6)
    for ours, theirs in zip(kw.slope_mip_chain(h), ref.slope_mip_chain(h), strict=True):
        npt.assert_allclose(ours, theirs, atol=1e-6)
    for ours, theirs in zip(kw.box_mip_chain(s), ref.box_mip_chain(s), strict=True):
        npt.assert_allclose(ours, theirs, atol=1e-6)


# ---- periodicity and the loop -----------------------------------------------------------------

def test_perlin_height_function_is_periodic(rng):
    x, y = rng.uniform(-300, 300, (2, 50))
    for xi, yi in zip(x, y, strict=True):
        h = kw.perlin_height_2d(xi, yi, 256, 8, 4, PERM, G2)
        assert abs(kw.perlin_height_2d(xi + 256, yi, 256, 8, 4, PERM, G2) - h) < 1e-9
        assert abs(kw.perlin_height_2d(xi, yi - 256, 256, 8, 4, PERM, G2) - h) < 1e-9
        z = 1.7 * xi / 300
        h3 = kw.perlin_height_3d(xi, yi, z, 64, 2, 4, 4, PERM, G3)
        assert abs(kw.perlin_height_3d(xi - 64, yi + 128, z + 4, 64, 2, 4, 4, PERM, G3) - h3) < 1e-9


def test_tile_edges_continue_smoothly_and_slopes_wrap():
    h = kw.perlin_tile_2d(128, 4, 4, PERM, G2)[0]
    for a in (h, h.T):
        edge = np.abs(a[0] - a[-1]).max()
        inner = np.abs(np.diff(a, axis=0)).max()
        assert edge <= inner
    # wrapped slopes equal plain central differences inside a 3×3 tiled copy
    big = np.tile(h, (3, 3))
    n = h.shape[0]
    du = (big[n:2 * n, n + 1:2 * n + 1] - big[n:2 * n, n - 1:2 * n - 1]) / 2
    dv = (big[n + 1:2 * n + 1, n:2 * n] - big[n - 1:2 * n - 1, n:2 * n]) / 2
    s = kw.slopes_from_heights(h[None], 1.0)[0]
    npt.assert_allclose(s[..., 0], du, atol=1e-6)
    npt.assert_allclose(s[..., 1], dv, atol=1e-6)
    assert np.abs(s[0, :, 1]).max() > 0  # no Proland row-0 quirk


def test_animated_loop_closes():
    size, frames, period = 32, 16, 4
    h = kw.perlin_frames_3d(size, kw.loop_z(frames, period), 2, 4, period, PERM, G3)
    frame_f = kw.perlin_frames_3d(size, np.array([period * frames / frames]), 2, 4, period,
                                  PERM, G3)[0]
    npt.assert_allclose(frame_f, h[0], atol=1e-6)
    steps = [_rms(h[(f + 1) % frames] - h[f]) for f in range(frames)]
    typical = np.median(steps[:-1])
    assert 0.5 * typical < steps[-1] < 2.0 * typical
    assert min(steps) > 0


def test_animated_tile_frames_differ_and_share_one_normalisation(animated):
    s = animated.levels[0]
    assert animated.kind == WaveKind.ANIMATED and s.shape == (8, 32, 32, 2)
    assert animated.frame_s == 0.25 and animated.loop_s == 2.0
    assert _rms(s) == pytest.approx(1.0, rel=1e-4)
    per_frame = [_rms(f) for f in s]
    assert max(per_frame) / min(per_frame) < 1.5
    assert _rms(s[1] - s[0]) > 0.05
    assert _rms(s[0] - s[-1]) < 2.0 * np.median([_rms(s[f + 1] - s[f]) for f in range(7)])


@pytest.mark.skipif(NO_JIT, reason="about 50 s of pure-Python noise")
def test_default_animated_tile():
    tile = cw.animated_wave_tile()
    assert [lv.shape for lv in tile.levels] == [(32, 128 >> k, 128 >> k, 2) for k in range(8)]
    assert _rms(tile.levels[0]) == pytest.approx(1.0, rel=1e-4)
    assert all(np.isfinite(lv).all() for lv in tile.levels)


# ---- mips, units, normalisation ---------------------------------------------------------------

def test_mip_slopes_are_recomputed_from_box_filtered_heights():
    h = kw.normalise_heights(kw.perlin_tile_2d(64, 2, 4, PERM, G2))
    levels = kw.slope_mip_chain(h)
    assert [lv.shape for lv in levels] == [(1, 64 >> k, 64 >> k, 2) for k in range(7)]
    assert all(lv.dtype == np.float32 and lv.flags.c_contiguous for lv in levels)
    hk = h
    for k, lv in enumerate(levels):
        npt.assert_allclose(lv, ref.slopes_from_heights(hk, 2.0**k), atol=1e-6)
        if k:
            averaged = ref.downsample_2x2(levels[k - 1])
            if k < 5:  # on 2×2 and 1×1 both are 0 (the wrapped neighbours coincide)
                assert _rms(lv - averaged) > 0.05 * _rms(lv)
        hk = ref.box_heights(hk) if hk.shape[1] > 1 else hk
    npt.assert_array_equal(levels[-1], 0.0)


def test_every_level_measures_slope_per_level0_texel():
    """A one-cycle ripple h = sin(2πx/S) has slope amplitude 2π/S on every level."""
    size = 256
    h = kw.ripple_heights(size, np.array([[1.0, 0.0, 1.0, 0.0]]))
    levels = kw.slope_mip_chain(h)
    for k in range(4):
        assert np.abs(levels[k][..., 0]).max() == pytest.approx(2 * np.pi / size, rel=0.03)
        npt.assert_allclose(levels[k][..., 1], 0.0, atol=1e-6)


def test_level0_slopes_have_rms_one(perlin):
    s = perlin.levels[0]
    assert s.shape == (1, 256, 256, 2) and len(perlin.levels) == 9
    assert _rms(s) == pytest.approx(1.0, rel=1e-4)
    npt.assert_allclose([_rms(s[..., 0]), _rms(s[..., 1])], 1.0, rtol=0.05)
    assert _rms(cw.default_static_wave_tile().levels[0]) == pytest.approx(1.0, rel=1e-4)


def test_default_static_tile_is_periodic_ripples_not_perlin():
    tile = cw.default_static_wave_tile(size=64)
    assert tile.kind == WaveKind.STATIC and tile.frames == 1 and tile.size_px == 64
    spectrum = np.abs(np.fft.fft2(tile.levels[0][0, ..., 0]))
    assert (spectrum > 1e-3 * spectrum.max()).sum() <= 24  # 12 ripples: ±k pairs only
    for size in (4, 8, 16):
        assert len(cw.default_static_wave_tile(size=size).levels) == int(math.log2(size)) + 1


# ---- static tiles from arrays and images ------------------------------------------------------

def test_static_tile_from_array_box_filters_slopes(rng):
    s = rng.normal(size=(16, 16, 2)) * 3.0
    tile = cw.static_wave_tile(s, wave_length_m=5.0)
    assert tile.kind == WaveKind.STATIC and tile.wave_length_m == 5.0
    expect = ref.box_mip_chain((s / _rms(s))[None])
    for ours, theirs in zip(tile.levels, expect, strict=True):
        npt.assert_allclose(ours, theirs, atol=1e-6)
    npt.assert_array_equal(cw.static_wave_tile(np.zeros((8, 8, 2))).levels[0], 0.0)


def test_static_tile_from_png(tmp_path, rng):
    from PIL import Image

    rgb = rng.integers(0, 256, (8, 8, 3), dtype=np.uint8)
    path = tmp_path / "waves.png"
    Image.fromarray(rgb).save(path)
    tile = cw.static_wave_tile(path)
    s = rgb[..., :2] / 255.0 * 2.0 - 1.0
    npt.assert_allclose(tile.levels[0][0], s / _rms(s), atol=1e-6)
    Image.fromarray(rgb[:4]).save(tmp_path / "wide.png")
    with pytest.raises(ValueError, match="square"):
        cw.static_wave_tile(str(tmp_path / "wide.png"))


# ---- the component ----------------------------------------------------------------------------

def _tile(frames, frame_s=0.5):
    return WaveTile(WaveKind.ANIMATED, 20.0, kw.box_mip_chain(np.zeros((frames, 4, 4, 2))),
                    frame_s=frame_s)


def test_frame_blend_weights_and_loop():
    tile = _tile(4)
    assert tile.loop_s == 2.0 and tile.frames == 4 and tile.size_px == 4
    for t, expect in ((0.0, (0, 1, 0.0)), (0.25, (0, 1, 0.5)), (0.5, (1, 2, 0.0)),
                      (1.9, (3, 0, 0.8)), (2.0, (0, 1, 0.0)), (2.75, (1, 2, 0.5)),
                      (-0.25, (3, 0, 0.5)), (-1e-18, (0, 1, 0.0))):
        tile.time_s = t
        a, b, w = tile.frame_blend()
        assert (a, b) == expect[:2] and w == pytest.approx(expect[2], abs=1e-12), t
        assert 0.0 <= w < 1.0
    tile.time_s = 1e6 + 0.125
    a, b, w = tile.frame_blend()
    assert (a, b) == (0, 1) and w == pytest.approx(0.25, abs=1e-6)
    still = _tile(1)
    still.time_s = 3.3
    assert still.frame_blend() == (0, 0, 0.0)


def test_advance_ignores_bad_steps():
    tile = _tile(4)
    for dt in (0.1, -1.0, math.nan, math.inf, 0.0, 0.2):
        tile.advance(dt)
    assert tile.time_s == pytest.approx(0.3)


def test_set_levels_bumps_revision():
    tile = _tile(2)
    tile.set_levels(kw.box_mip_chain(np.ones((2, 8, 8, 2), np.float32)))
    assert tile.revision == 1 and tile.size_px == 8
    with pytest.raises(ValueError, match=r"levels\[1\]"):
        tile.set_levels([np.zeros((2, 8, 8, 2), np.float32), np.zeros((2, 8, 8, 2), np.float32)])


@pytest.mark.parametrize("call, match", [
    (lambda: cw.perlin_wave_tile(size=100), "size .*100"),
    (lambda: cw.perlin_wave_tile(size=2), "size .*2"),
    (lambda: cw.perlin_wave_tile(size=256.0), "size .*256.0"),
    (lambda: cw.perlin_wave_tile(base_cells=0), "base_cells .*0"),
    (lambda: cw.perlin_wave_tile(size=64), "base_cells=8"),
    (lambda: cw.perlin_wave_tile(base_cells=64, size=1024), "base_cells=64"),
    (lambda: cw.perlin_wave_tile(wave_length_m=-1.0), "wave_length_m .*-1.0"),
    (lambda: cw.perlin_wave_tile(wave_length_m=math.inf), "wave_length_m .*inf"),
    (lambda: cw.perlin_wave_tile(seed="a"), "seed .*'a'"),
    (lambda: cw.animated_wave_tile(frames=1), "frames .*1"),
    (lambda: cw.animated_wave_tile(frame_s=math.nan), "frame_s .*nan"),
    (lambda: cw.animated_wave_tile(frame_s=0.0), "frame_s .*0.0"),
    (lambda: cw.animated_wave_tile(period_z=0), "period_z .*0"),
    (lambda: cw.default_static_wave_tile(size=12), "size .*12"),
    (lambda: cw.static_wave_tile(np.zeros((8, 8, 3))), r"shape .*\(8, 8, 3\)"),
    (lambda: cw.static_wave_tile(np.zeros((6, 6, 2))), "size .*6"),
    (lambda: cw.static_wave_tile(np.full((8, 8, 2), np.nan)), "finite"),
    (lambda: cw.static_wave_tile(np.zeros((8, 8, 2)), wave_length_m=0), "wave_length_m .*0"),
])
def test_bad_inputs_raise_naming_the_parameter(call, match):
    with pytest.raises(ValueError, match=match):
        call()


def test_generation_is_deterministic_per_seed_and_finite(perlin, animated):
    one = cw.perlin_wave_tile(size=128)
    again = cw.perlin_wave_tile(size=128)
    for a, b in zip(one.levels, again.levels, strict=True):
        npt.assert_array_equal(a, b)
    assert not np.array_equal(one.levels[0], cw.perlin_wave_tile(size=128, seed=1).levels[0])
    small = cw.animated_wave_tile(size=32, frames=4, base_cells=2)
    npt.assert_array_equal(small.levels[0], cw.animated_wave_tile(size=32, frames=4,
                                                                  base_cells=2).levels[0])
    assert not np.array_equal(small.levels[0], cw.animated_wave_tile(
        size=32, frames=4, base_cells=2, seed=5).levels[0])
    assert not np.array_equal(cw.default_static_wave_tile(64, seed=1).levels[0],
                              cw.default_static_wave_tile(64, seed=2).levels[0])
    for tile in (perlin, animated, cw.default_static_wave_tile(64)):
        assert all(np.isfinite(lv).all() for lv in tile.levels)
