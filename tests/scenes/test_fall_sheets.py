"""The falling sheets' mesh (issue #23, :mod:`riverflow.scenes.fall_sheets`): every vertex on
the nappe the water surface follows, from the lip's line down to the pool, moving at
√(v0² + 2·g·d); bad input named."""
from __future__ import annotations

import numpy as np
import pytest

from riverflow.hydro.falls import G_MPS2
from riverflow.scenes.fall_sheets import SHEET_LIFT_M, sheet_mesh
from tests.hydro.test_falls import DROP, LIP_X, WIDTH, _straight


@pytest.fixture(scope="module")
def falls():
    b = _straight(lip_m=12.0)
    b.add_fall(450.0, 2.0, kind="weir")
    return b.build().falls


def test_the_sheet_follows_the_nappe_from_the_lip_to_the_pool(falls):
    lips = np.array([25.0, 18.0])
    across, down = 7, 9
    v, idx = sheet_mesh(falls, lips, across=across, down=down)
    assert v.shape == (2 * across * down, 8) and v.dtype == np.float32
    assert idx.shape == (2 * 6 * (across - 1) * (down - 1),) and idx.max() == len(v) - 1
    v = v.astype(np.float64)
    for k, (f, lip) in enumerate(zip(falls, lips)):
        rows = v[k * across * down:(k + 1) * across * down].reshape(across, down, 8)
        c, d = np.asarray(f.centre_m), np.asarray(f.direction)
        n = np.array([-d[1], d[0]])
        rel = rows[..., :2] - c
        s, e = rel @ d, rel @ n
        # on the water surface's own nappe (hydro.falls.nappe_drop), lifted SHEET_LIFT_M
        assert np.allclose(rows[..., 2], lip + SHEET_LIFT_M - f.nappe_drop(s), atol=1e-4)
        # the lip's line at the top, the pool (a whole drop down, a throw along) at the foot
        assert np.allclose(s[:, 0], 0.0, atol=1e-4) and np.allclose(s[:, -1], f.throw_m)
        assert np.allclose(rows[:, -1, 2], lip + SHEET_LIFT_M - f.drop_m, atol=1e-4)
        assert np.allclose(np.sort(e[:, 0])[[0, -1]], [-0.5 * f.lip_m, 0.5 * f.lip_m])
        assert np.allclose(rows[..., 3], e, atol=1e-4)                  # across [m]
        assert np.allclose(rows[..., 6], 0.5 * f.lip_m - np.abs(e), atol=1e-4)
        # the speed: √(v0² + 2 g d) with d fallen; t from 0 to the fall time
        fallen = lip + SHEET_LIFT_M - rows[..., 2]
        want = np.sqrt(f.lip_speed_mps ** 2 + 2.0 * G_MPS2 * fallen)
        assert np.allclose(rows[..., 5], want, rtol=1e-4)
        assert np.allclose(rows[:, -1, 4], f.fall_time_s) and np.allclose(rows[..., 7],
                                                                           rows[..., 4] / f.fall_time_s)
        # every triangle's corners are neighbours on the ribbon (no triangle across falls)
        tri = idx.reshape(-1, 3)
        mine = tri[(tri >= k * across * down).all(1) & (tri < (k + 1) * across * down).all(1)]
        assert len(mine) == 2 * (across - 1) * (down - 1)
    assert falls[0].lip_m == 12.0 and falls[1].lip_m == WIDTH and falls[0].drop_m == DROP
    assert falls[0].at_m == LIP_X


def test_no_falls_no_sheet_and_bad_input_is_named(falls):
    v, idx = sheet_mesh([], np.zeros(0))
    assert v.shape == (0, 8) and idx.shape == (0,)
    with pytest.raises(ValueError, match="2 falls but 1 lip levels"):
        sheet_mesh(falls, [1.0])
    with pytest.raises(ValueError, match=r"lip level of fall 1 \(r at 450 m\) is nan"):
        sheet_mesh(falls, [1.0, np.nan])
    with pytest.raises(ValueError, match="across and down"):
        sheet_mesh(falls, [1.0, 2.0], across=1)


def test_the_falls_boxes_hold_the_sheet_and_say_when_it_is_in_view(falls):
    from riverflow.engine.camera import Camera
    from riverflow.scenes.fall_sheets import falls_boxes, in_view
    lips = np.array([25.0, 18.0])
    boxes = falls_boxes(falls, lips)
    v, _ = sheet_mesh(falls, lips)
    for k in range(2):
        pts = v[k * 36:(k + 1) * 36, :3]                     # 3 × 12 vertices a fall
        lo, hi = boxes[k, :, :3].min(0), boxes[k, :, :3].max(0)
        assert np.all(pts >= lo) and np.all(pts <= hi)
    camera = Camera(size_px=(64, 36))
    camera.look_at((LIP_X + 30.0, -10.0, 30.0), (LIP_X, 0.0, 22.0))
    assert in_view(boxes, camera.matrices_for_kernels()[0])
    camera.look_at((LIP_X + 30.0, -10.0, 30.0), (LIP_X + 31.0, -10.0, 200.0))  # at the sky
    assert not in_view(boxes, camera.matrices_for_kernels()[0])
    camera.look_at((LIP_X, -200.0, 30.0), (LIP_X, -400.0, 30.0))            # behind the eye
    assert not in_view(boxes, camera.matrices_for_kernels()[0])
    assert not in_view(boxes[:0], camera.matrices_for_kernels()[0])
