"""Wake trails (riverflow.kernels.wake) and the Kelvin wake's twin (tests/kernels/
wake_reference.py, the specification of shaders/wake.glsl): a moving boat's wake lies in the
19.47° wedge behind it with the wavelength 2πU²/g; a still boat leaves none."""
from __future__ import annotations

import math

import numpy as np
import numpy.testing as npt
import pytest

from riverflow.kernels.wake import (TP_TIME, TP_X, TP_Y, TR_AGE, TR_ARC, TR_FIELDS,
                                    TR_HALF_WIDTH, TR_SLOPE, TR_STRENGTH, TR_X, TR_Y,
                                    WEDGE_HALF_WIDTH, advance_trail, pack_trail, wake_texture)
from tests.kernels.wake_reference import CUSP, G, wake_slopes

K = 48
SAMPLE_S, LIFE_S = 1 / 3, 15.0


def _drive(speed_mps, seconds, current=(0.0, 0.0), turn_rps=0.0, k=K):
    """A bow driven at ``speed_mps`` through water flowing at ``current`` (its own speed over
    ground adds the current), turning at ``turn_rps``; returns (trail, count, now, table)."""
    trail = np.zeros((k, 6))
    count, t, heading = 0, 0.0, 0.0
    p = np.zeros(2)
    dt = 1 / 60
    for _ in range(int(round(seconds * 60))):
        t += dt
        heading += turn_rps * dt
        p = p + (speed_mps * np.array([math.cos(heading), math.sin(heading)])
                 + current) * dt
        count = advance_trail(trail, count, p[0], p[1], speed_mps, current[0], current[1], t,
                              dt, SAMPLE_S, LIFE_S)
    table = np.zeros((1, k, TR_FIELDS), np.float32)
    pack_trail(trail, count, t, LIFE_S, 0.5, 0.35, 3.0, 0.5, table[0])
    return trail, count, t, table


def test_a_trail_keeps_a_point_every_sample_and_forgets_old_ones():
    trail, count, now, table = _drive(4.0, 30.0)
    assert count == K or (now - trail[count - 1, TP_TIME]) <= LIFE_S
    ages = now - trail[1:count, TP_TIME]
    assert ages.max() <= LIFE_S + 1e-9
    npt.assert_allclose(np.diff(trail[1:count, TP_TIME]), -SAMPLE_S, atol=1 / 60 + 1e-9)
    gaps = np.hypot(*np.diff(trail[1:count, :2], axis=0).T)
    npt.assert_allclose(gaps, 4.0 * SAMPLE_S, rtol=0.06)      # straight at 4 m/s
    assert trail[0, TP_X] == pytest.approx(4.0 * 30.0, rel=1e-6)
    # the packed table: arc lengths add up from the bow, the rest is marked
    arc = table[0, :count, TR_ARC]
    assert arc[0] == 0 and (np.diff(arc) > 0).all()
    assert (table[0, count:, TR_ARC] == -1).all() and (table[0, count:, TR_STRENGTH] == -1).all()
    assert (table[0, :count, TR_SLOPE] == 0.5).all()
    assert (np.diff(table[0, :count, TR_HALF_WIDTH]) > 0).all()   # the wash spreads
    npt.assert_allclose(table[0, :count, TR_AGE], now - trail[:count, TP_TIME], atol=1e-4)


def test_trail_points_drift_with_the_current_they_were_left_in():
    trail, count, now, _ = _drive(0.0, 5.0, current=(0.8, -0.3))
    # a boat drifting with the current: every point it left is carried to where it is
    npt.assert_allclose(trail[:count, TP_X], trail[0, TP_X], atol=1e-6)
    npt.assert_allclose(trail[:count, TP_Y], trail[0, TP_Y], atol=1e-6)


def test_a_still_boat_leaves_no_strength_and_a_bad_bow_empties_the_trail():
    _, count, _, table = _drive(0.0, 10.0)
    assert count > 10 and (table[0, :count, TR_STRENGTH] == 0).all()
    trail = np.zeros((K, 6))
    assert advance_trail(trail, 5, np.nan, 0.0, 1.0, 0.0, 0.0, 1.0, 1 / 60, SAMPLE_S,
                         LIFE_S) == 0


def test_wake_texture_packs_points_and_a_box_around_the_wedge():
    _, count, _, table = _drive(5.0, 10.0)
    out = np.zeros((2, 1 + 2 * K, 4), np.float32)
    assert wake_texture(table, out) == 1
    npt.assert_array_equal(out[0, 1:1 + K], table[0, :, :4])
    npt.assert_array_equal(out[0, 1 + K:], table[0, :, 4:])
    box = out[0, 0]
    reach = table[0, :count, TR_ARC].max() * WEDGE_HALF_WIDTH
    assert box[0] < table[0, :count, TR_X].min() - reach
    assert box[3] > table[0, :count, TR_Y].max() + reach


# -- the Kelvin pattern (the shader's twin) ------------------------------------------------------

def _grid(table, count, half_len=None, nx=200, ny=160):
    """Points around the trail's straight part, with their (X, Y) behind the bow."""
    bow = table[0, 0, :2].astype(float)
    length = float(table[0, count - 1, TR_ARC]) if half_len is None else half_len
    xs = np.linspace(-5.0, length, nx)
    ys = np.linspace(-0.6 * length, 0.6 * length, ny)
    X, Y = np.meshgrid(xs, ys)
    pts = np.stack([bow[0] - X.ravel(), bow[1] + Y.ravel()], 1)   # the boat goes +x
    return pts, X.ravel(), Y.ravel()


@pytest.mark.parametrize("speed", [3.0, 6.0])
def test_a_moving_boat_s_wake_lies_in_the_kelvin_wedge(speed):
    _, count, _, table = _drive(speed, 20.0)
    pts, X, Y = _grid(table, count)
    s = wake_slopes(pts, table, 1, 0.01)
    slope = np.hypot(*s.T)
    r = np.abs(Y) / np.maximum(X, 1e-9)
    behind = X > 5.0
    inside = behind & (r < 0.9 * CUSP)
    outside = (X <= 0.0) | (r > 1.06 * CUSP)
    assert (slope[outside] == 0).all()                   # nothing ahead or outside the wedge
    assert np.var(s[inside], axis=0).sum() > 1e-3        # waves inside it
    # the cusp lines at ±19.47° carry the highest waves: per distance behind, the steepest
    # slope lies near them
    for x in np.unique(X[behind])[20::40]:
        row = (X == x)
        k = np.argmax(slope[row])
        assert 0.6 * CUSP < r[row][k] < 1.06 * CUSP


def test_a_still_boat_has_no_wake():
    _, count, _, table = _drive(0.0, 20.0)
    pts, _, _ = _grid(table, count, half_len=60.0)
    assert not wake_slopes(pts, table, 1, 0.01).any()


def test_transverse_waves_have_the_kelvin_wavelength():
    """Along the track the waves are the transverse ones: wavelength 2πU²/g."""
    speed = 4.0
    _, count, _, table = _drive(speed, 20.0)
    bow = table[0, 0, :2].astype(float)
    X = np.linspace(8.0, 60.0, 4000)
    pts = np.stack([bow[0] - X, np.full_like(X, bow[1])], 1)
    sx = wake_slopes(pts, table, 1, 0.001)[:, 0]
    crossings = X[1:][np.diff(np.sign(sx)) != 0]
    wavelength = 2 * np.median(np.diff(crossings))
    assert wavelength == pytest.approx(2 * math.pi * speed ** 2 / G, rel=0.03)


def test_the_wake_bends_with_the_boat_s_path():
    _, count, _, table = _drive(5.0, 15.0, turn_rps=0.15)
    pts = table[0, 5:count, :2].astype(float)          # on the trail, behind the bow
    bow = table[0, 0, :2].astype(float)
    # straight behind the bow (where a straight wake would be) there is nothing at the end
    far = bow + np.array([-1.0, 0.0]) * table[0, count - 1, TR_ARC]
    s_far = wake_slopes(far[None], table, 1, 0.01)
    s_on = wake_slopes(pts + (0.0, 0.5), table, 1, 0.01)
    assert np.abs(s_on).sum() > 0 and not s_far.any()


def test_waves_finer_than_a_few_pixels_fade_out():
    _, count, _, table = _drive(3.0, 20.0)
    pts, _, _ = _grid(table, count)
    near = np.hypot(*wake_slopes(pts, table, 1, 0.01).T)
    far = np.hypot(*wake_slopes(pts, table, 1, 5.0).T)     # 5 m pixels: λ₀ = 5.8 m
    assert far.sum() < 0.05 * near.sum()


def test_the_twin_s_nearest_trail_point_takes_the_first_segment_of_a_tie():
    """The shader's rules in its twin: of equally near segments the first (newer) wins, and
    a point lies 'past' the trail only beyond its oldest point."""
    from tests.kernels.wake_reference import nearest_on_trail
    trail = np.full((K, TR_FIELDS), -1.0)
    arm = np.array([[0, 0], [-10, 0], [-20, 10], [-30, 0], [-40, 0]], float)   # a ∧ in the path
    trail[:5, :2] = arm
    trail[:5, TR_ARC] = np.r_[0, np.cumsum(np.hypot(*np.diff(arm, axis=0).T))]
    # on the ∧'s axis: as near segment 2 as segment 3, the last one beyond its apex
    y = np.array([-3.0, 0.0, 4.0, 8.0, 15.0])
    X, _, _, _, back, _, _, past = nearest_on_trail(np.stack([np.full(5, -20.0), y], 1), trail)
    npt.assert_allclose(back, np.tile([-1.0, 1.0], (5, 1)) / math.sqrt(2))   # segment 2
    npt.assert_allclose(X, 10.0 + np.minimum(0.5 + y / 20.0, 1.0) * math.sqrt(200.0))
    assert not past.any()                              # beyond segment 2's end is not past
    behind = np.stack([np.linspace(-80.0, -30.0, 6), np.zeros(6)], 1)
    npt.assert_allclose(nearest_on_trail(behind, trail)[-1], [40, 30, 20, 10, 0, 0])
