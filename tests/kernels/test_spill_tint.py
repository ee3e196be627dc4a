"""The wave particles' spill tint (issue 24, :func:`riverflow.kernels.spill.sample_tint`)
against its plain-numpy twin: bilinear between texel centres of the premultiplied colour and
of the concentration (clamped at the square's edge texels, 0 outside it), sampled by the new
particles, every ``every`` frames by slot, or by all when the grid changed."""
from __future__ import annotations

import numpy as np
import pytest

from riverflow.kernels.spill import ParticleTint, TintGrid, sample_tint


def tint_at_reference(rgba: np.ndarray, rect, xy: np.ndarray) -> np.ndarray:
    """(P, 4) (r, g, b, c) at points (P, 2): the twin of ``_tint_at``."""
    x0, y0, side = rect
    n = rgba.shape[0]
    out = np.zeros((len(xy), 4))
    with np.errstate(invalid="ignore"):
        inside = (side > 0) & (xy[:, 0] >= x0) & (xy[:, 0] <= x0 + side) \
            & (xy[:, 1] >= y0) & (xy[:, 1] <= y0 + side)
    if not inside.any():
        return out
    p = xy[inside]
    u = np.clip((p[:, 0] - x0) / side * n - 0.5, 0, n - 1)
    v = np.clip((p[:, 1] - y0) / side * n - 0.5, 0, n - 1)
    i0 = np.minimum(u.astype(int), n - 2)
    j0 = np.minimum(v.astype(int), n - 2)
    fu, fv = u - i0, v - j0
    a = np.zeros(len(p))
    rgb = np.zeros((len(p), 3))
    for dj, wj in ((0, 1 - fv), (1, fv)):
        for di, wi in ((0, 1 - fu), (1, fu)):
            t = rgba[j0 + dj, i0 + di].astype(np.float64)
            c = wj * wi * t[:, 3]
            a += c
            rgb += c[:, None] * t[:, :3]
    ok = a > 0
    res = np.zeros((len(p), 4))
    res[ok, :3] = rgb[ok] / a[ok, None]
    res[ok, 3] = a[ok]
    out[inside] = res
    return out


def _grid(rng, n=16):
    rgba = np.zeros((n, n, 4), np.float32)
    rgba[..., :3] = rng.random((n, n, 3))
    rgba[..., 3] = np.where(rng.random((n, n)) < 0.6, rng.random((n, n)) * 1e-2, 0.0)
    rgba[rgba[..., 3] == 0, :3] = 0.0                     # as the tint writes a clean texel
    return TintGrid(rgba, np.array([-100.0, 50.0, 320.0]))


def _particles(rng, c=300):
    xy = rng.uniform((-140.0, 10.0), (260.0, 410.0), (c, 2))   # some outside the square
    world = np.column_stack([xy, rng.normal(0, 1, c)])
    world[5] = np.nan
    alive = rng.random(c) < 0.8
    has_world = rng.random(c) < 0.9
    return ParticleTint(alive, has_world, np.arange(c, dtype=np.int64) + 1000, world,
                        np.full((c, 4), -1.0, np.float32), np.full(c, -1, np.int64))


def test_the_kernel_is_its_numpy_twin():
    rng = np.random.default_rng(3)
    grid = _grid(rng)
    p = _particles(rng)
    n = sample_tint(grid, p, len(p.alive), 7, 8, False)   # all new: every one samples
    ok = p.alive & p.has_world
    assert n == ok.sum()
    want = tint_at_reference(grid.rgba, grid.rect, p.world_m[:, :2])
    np.testing.assert_allclose(p.tint[ok], want[ok], rtol=2e-6, atol=1e-9)
    assert (p.tint[~ok] == -1).all() and (p.tint_id[ok] == p.ids[ok]).all()
    assert (p.tint_id[~ok] == -1).all()
    # exact at a texel's centre; a clean texel does not darken its neighbours' colour
    x0, y0, side = grid.rect
    j, i = 5, 9
    centre = np.array([[x0 + (i + 0.5) * side / 16, y0 + (j + 0.5) * side / 16]])
    got = tint_at_reference(grid.rgba, grid.rect, centre)[0]
    np.testing.assert_allclose(got, grid.rgba[j, i], rtol=1e-6)
    assert np.all(p.tint[ok & (p.tint[:, 3] > 0), :3] <= 1.0 + 1e-6)


@pytest.mark.parametrize("frame", [0, 5, 13])
def test_samples_by_slot_every_k_frames_new_ones_at_once_or_all(frame):
    rng = np.random.default_rng(frame)
    grid = _grid(rng)
    p = _particles(rng, 64)
    ok = p.alive & p.has_world
    sample_tint(grid, p, 64, frame, 8, False)
    p.tint[:] = 7.0                                        # marks what is sampled next
    p.ids[::9] += 5000                                     # new particles in those slots
    n = sample_tint(grid, p, 64, frame + 1, 8, False)
    slot = np.arange(64)
    due = ok & (((slot & 7) == ((frame + 1) & 7)) | (slot % 9 == 0))
    assert n == due.sum() and (p.tint[due, 0] != 7.0).all() and (p.tint[~due] == 7.0).all()
    assert (p.tint_id[ok] == p.ids[ok]).all()
    assert sample_tint(grid, p, 64, frame + 1, 8, True) == ok.sum()    # the grid changed
    assert sample_tint(grid, p, 32, frame + 2, 8, True) == ok[:32].sum()  # the slot bound
    empty = TintGrid(grid.rgba, np.array([0.0, 0.0, 0.0]))
    sample_tint(empty, p, 64, 0, 8, True)
    assert (p.tint[ok] == 0).all()                         # no square: no tint
