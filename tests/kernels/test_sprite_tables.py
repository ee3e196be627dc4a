"""Sprite parameter table and indirection grid against their numpy twins, and their properties."""
from __future__ import annotations

import numpy as np
import numpy.testing as npt
import pytest

from riverflow.components.particles import ParticlePool
from riverflow.components.status import FlowStatus
from riverflow.kernels import sprites as ks
from tests.kernels import sprites_reference as ref

W, H = 96, 64


def _pool(capacity: int) -> ParticlePool:
    return ParticlePool(capacity)


def _poisson_like(rng, pool: ParticlePool, r: float, w: float, h: float, margin: float = 0.0):
    """Live, INSIDE particles on a jittered grid of spacing 2r·1.07 (≈ Poisson disk of radius r)
    over [−margin, w + margin] × [−margin, h + margin]; returns their number."""
    step = 2.0 * r * 1.07
    xs = np.arange(-margin, w + margin, step)
    ys = np.arange(-margin, h + margin, step)
    pts = np.stack(np.meshgrid(xs, ys), -1).reshape(-1, 2)
    pts += rng.uniform(0, 0.3 * step, pts.shape)
    n = min(len(pts), pool.capacity)
    pool.alive[:n] = True
    pool.has_world[:n] = True
    pool.status[:n] = FlowStatus.INSIDE
    pool.screen_px[:n] = pts[:n]
    pool.world_m[:n] = rng.uniform(-500, 500, (n, 3))
    pool.intensity[:n] = rng.uniform(0.0, 1.0, n).astype(np.float32)
    pool.intensity[:n][pool.intensity[:n] == 0] = 0.5
    pool.offset_m[:n] = rng.uniform(-10, 10, (n, 2))
    pool.velocity_mps[:n] = rng.uniform(-2, 2, (n, 2))
    return n


def _fill(pool, radius, n_slots, out):
    return ks.fill_sprite_params(pool.alive, pool.has_world, pool.screen_px, pool.world_m,
                                 pool.offset_m, pool.intensity, pool.status, pool.velocity_mps,
                                 radius, n_slots, out)


def _fill_ref(pool, radius, n_slots, out):
    return ref.fill_sprite_params(pool.alive, pool.has_world, pool.screen_px, pool.world_m,
                                  pool.offset_m, pool.intensity, pool.status, pool.velocity_mps,
                                  radius, n_slots, out)


def _grid(pool, n_slots, sprite_r, cell, gw, gh, fill_value=77):
    counts = np.zeros(gw * gh, np.int32)
    grid = np.full((gh, gw * ks.MAX_PER_CELL), fill_value, np.int32)
    full = ks.build_sprite_grid(pool.alive, pool.has_world, pool.screen_px, pool.intensity,
                                pool.status, n_slots, sprite_r, cell, gw, gh, counts, grid)
    return full, counts, grid


def _grid_ref(pool, n_slots, sprite_r, cell, gw, gh):
    return ref.build_sprite_grid(pool.alive, pool.has_world, pool.screen_px, pool.intensity,
                                 pool.status, n_slots, sprite_r, cell, gw, gh)


def _check_terminators(counts, grid, gw, gh):
    for c, k in enumerate(counts[:gw * gh]):
        assert 0 <= k <= ks.MAX_PER_CELL
        if k < ks.MAX_PER_CELL:
            cy, cx = divmod(c, gw)
            assert grid[cy, ks.MAX_PER_CELL * cx + k] == ks.NO_PARTICLE


# ---------------------------------------------------------------- parameter table


def test_param_table_layout_of_hand_made_particles():
    pool = _pool(600)
    for i, (sx, sy) in {0: (10.5, 20.25), 1: (-3.0, 7.0), 3: (95.0, 63.0), 257: (1.0, 2.0)}.items():
        pool.alive[i] = True
        pool.has_world[i] = True
        pool.screen_px[i] = (sx, sy)
        pool.world_m[i] = (100.0 + i, -200.0 - i, 12.5 + i)
        pool.offset_m[i] = (0.25 * i, -0.5)
        pool.intensity[i] = 0.75
        pool.status[i] = FlowStatus.LEAVING if i == 3 else FlowStatus.INSIDE
        pool.velocity_mps[i] = (1.5, -0.125 * i)
    pool.alive[256] = True          # alive, no world position: free
    pool.screen_px[256] = (5.0, 5.0)
    out = np.full((3, 768, 4), 7.0, np.float32)
    assert _fill(pool, 4.0, 258, out) == 2

    npt.assert_array_equal(out[0, 0:3], [[10.5, 20.25, 100.0, -200.0],
                                         [0.0, -0.5, 0.75, 4.0],
                                         [1.0, 1.5, 0.0, 12.5]])
    npt.assert_array_equal(out[0, 9:12], [[95.0, 63.0, 103.0, -203.0],
                                          [0.75, -0.5, 0.75, 4.0],
                                          [2.0, 1.5, -0.375, 15.5]])
    slot = 257 % 256  # row 1, texels 3..5
    npt.assert_array_equal(out[1, 3 * slot:3 * slot + 3], [[1.0, 2.0, 357.0, -457.0],
                                                           [64.25, -0.5, 0.75, 4.0],
                                                           [1.0, 1.5, -32.125, 269.5]])
    free = np.array([[0, 0, 0, 0], [0, 0, 0, 0], [-1, 0, 0, 0]], np.float32)
    for row, texel in ((0, 6), (0, 12), (0, 765), (1, 0), (1, 6), (1, 765)):  # slots 2, 4, 255,
        npt.assert_array_equal(out[row, texel:texel + 3], free)              # 256, 258, 511
    assert (out[2] == 7.0).all()  # rows past the last written are untouched
    expect = np.full_like(out, 7.0)
    assert _fill_ref(pool, 4.0, 258, expect) == 2
    npt.assert_array_equal(out, expect)


def test_param_table_matches_reference_on_random_pools(rng):
    pool = _pool(1500)
    n = _poisson_like(rng, pool, 3.0, 300, 200)
    pool.alive[rng.random(pool.capacity) < 0.2] = False
    pool.has_world[rng.random(pool.capacity) < 0.1] = False
    pool.status[:] = rng.integers(0, 8, pool.capacity)
    for n_slots in (0, 1, 255, 256, 257, n, pool.capacity, pool.capacity + 99, -5):
        got = np.full((6, 768, 4), 3.0, np.float32)
        expect = got.copy()
        rows = _fill(pool, 2.5, n_slots, got)
        assert rows == _fill_ref(pool, 2.5, n_slots, expect)
        assert rows == ks.param_table_rows(max(min(n_slots, pool.capacity), 0))
        npt.assert_array_equal(got, expect)


def test_param_table_never_holds_non_finite_values(rng):
    pool = _pool(300)
    _poisson_like(rng, pool, 4.0, W, H)
    bad = {0: ("screen_px", 0, np.nan), 1: ("screen_px", 1, np.inf), 2: ("world_m", 0, np.nan),
           3: ("world_m", 2, -np.inf), 4: ("world_m", 1, 1e300),  # overflows float32
           5: ("intensity", None, np.nan)}
    for i, (name, k, v) in bad.items():
        col = getattr(pool, name)
        if k is None:
            col[i] = v
        else:
            col[i, k] = v
    pool.offset_m[6] = (np.nan, 1.0)
    pool.velocity_mps[7] = (np.inf, -np.inf)
    pool.alive[:8] = True
    pool.has_world[:8] = True
    for radius in (4.0, np.nan, 0.0):
        out = np.zeros((2, 768, 4), np.float32)
        expect = out.copy()
        assert _fill(pool, radius, 300, out) == 2
        _fill_ref(pool, radius, 300, expect)
        npt.assert_array_equal(out, expect)
        assert np.isfinite(out).all()
        table = out.reshape(-1, 3, 4)
        for i in range(6):  # written free
            npt.assert_array_equal(table[i], [[0, 0, 0, 0], [0, 0, 0, 0], [-1, 0, 0, 0]])
        assert table[6, 1, 0] == 0 and table[6, 1, 1] == 1.0 and table[6, 1, 2] > 0
        npt.assert_array_equal(table[7, 2, 1:3], [0, 0])
        assert (table[8:300, 1, 3] == (4.0 if radius == 4.0 else 0.0))[pool.alive[8:300]].all()


def test_param_table_clamps_to_a_small_output():
    pool = _pool(600)
    pool.alive[:] = True
    pool.has_world[:] = True
    pool.intensity[:] = 1.0
    out = np.zeros((1, 768, 4), np.float32)
    assert _fill(pool, 2.0, 600, out) == 1
    assert (out[0, 1::3, 2] == 1.0).all()  # 256 slots written, in one row
    assert _fill(pool, 2.0, 600, np.zeros((0, 768, 4), np.float32)) == 0
    assert _fill(pool, 2.0, 600, np.zeros((2, 10, 4), np.float32)) == 0


# ---------------------------------------------------------------- grid shape


@pytest.mark.parametrize("size, radius, expect", [
    ((1920, 1080), 10.0, (10, 192, 108)),
    ((1920, 1080), 5.0, (5, 384, 216)),
    ((100, 50), 7.5, (7, 15, 8)),
    ((0, 0), 10.0, (10, 1, 1)),
    ((640, 360), 0.0, (1, 640, 360)),
    ((64, 64), float("nan"), (1, 64, 64)),
    ((64, 64), 1000.0, (1000, 1, 1)),
])
def test_sprite_grid_shape(size, radius, expect):
    assert ks.sprite_grid_shape(*size, radius) == expect


# ---------------------------------------------------------------- indirection grid


def test_grid_hand_made_exact_disc_and_terminators():
    pool = _pool(4)
    pool.alive[:3] = True
    pool.has_world[:3] = True
    pool.status[:3] = FlowStatus.INSIDE
    pool.intensity[:3] = (1.0, 0.5, 0.25)
    pool.screen_px[:3] = ((5.0, 5.0), (30.0, 22.0), (-100.0, 5.0))  # last: far off screen
    full, counts, grid = _grid(pool, 3, 15.0, 10.0, 4, 3)
    assert full == 0
    cells = ref.grid_lists(grid, 4, 3)
    # slot 0 at (5, 5), disc radius 15, cells of 10: (2, 1) is in the bounding square only
    # (nearest corner (20, 10) is √250 > 15 away); (2, 0) touches at distance exactly 15
    # (its low edge x = 20 belongs to it; a high edge would not: cells are half-open).
    has0 = {(c % 4, c // 4) for c, lst in enumerate(cells) if 0 in lst}
    assert has0 == {(0, 0), (1, 0), (2, 0), (0, 1), (1, 1), (0, 2)}
    has1 = {(c % 4, c // 4) for c, lst in enumerate(cells) if 1 in lst}
    assert has1 == {(2, 0), (3, 0), (1, 1), (2, 1), (3, 1), (1, 2), (2, 2), (3, 2)}
    assert cells[2] == [0, 1]  # slot order
    assert not any(2 in lst for lst in cells)
    npt.assert_array_equal(counts, [len(lst) for lst in cells])
    _check_terminators(counts, grid, 4, 3)
    assert cells == _grid_ref(pool, 3, 15.0, 10.0, 4, 3)[0]


def test_grid_inserts_only_drawable_particles():
    pool = _pool(16)
    pool.screen_px[:] = (20.0, 20.0)
    pool.alive[:] = True
    pool.has_world[:] = True
    pool.intensity[:] = 0.5
    pool.status[:8] = np.arange(8)
    pool.status[8:] = FlowStatus.INSIDE
    pool.alive[8] = False
    pool.has_world[9] = False
    pool.intensity[10] = 0.0
    pool.intensity[11] = np.nan
    pool.intensity[12] = -1.0
    pool.screen_px[13] = (np.nan, 20.0)
    pool.screen_px[14] = (20.0, np.inf)
    full, counts, grid = _grid(pool, 16, 6.0, 4.0, 10, 10)
    inserted = set().union(*ref.grid_lists(grid, 10, 10))
    assert inserted == {FlowStatus.INSIDE, FlowStatus.LEAVING, 15}
    assert full == 0
    _check_terminators(counts, grid, 10, 10)


def _disc_meets_cell(p, radius, cell, cx, cy) -> bool:
    px, py = (float(v) for v in p)
    dx = max(cx * cell - px, px - (cx + 1) * cell, 0.0)
    dy = max(cy * cell - py, py - (cy + 1) * cell, 0.0)
    return dx * dx + dy * dy <= radius * radius


def _coverage(pool, n, sprite_r, cell, gw, gh, cells):
    """Every drawable particle whose disc holds a pixel centre is in that pixel's cell list."""
    ok = ref.drawable(pool.alive[:n], pool.has_world[:n], pool.screen_px[:n], pool.intensity[:n],
                      pool.status[:n])
    ys, xs = np.mgrid[0:H, 0:W] + 0.5
    pix_cell = (np.minimum(ys // cell, gh - 1) * gw + np.minimum(xs // cell, gw - 1)).astype(int)
    checked = 0
    for i in np.flatnonzero(ok):
        p = pool.screen_px[i].astype(np.float64)
        inside = (xs - p[0]) ** 2 + (ys - p[1]) ** 2 <= sprite_r ** 2
        for c in np.unique(pix_cell[inside]):
            assert i in cells[c], (i, c)
            checked += 1
    return checked


@pytest.mark.parametrize("r", [4.0, 3.0, 5.5])
def test_grid_covers_every_pixel_of_every_sprite_and_matches_reference(rng, r):
    pool = _pool(800)
    n = _poisson_like(rng, pool, r, W, H, margin=3 * r)  # some centres off screen
    pool.status[:n] = rng.choice([FlowStatus.INSIDE, FlowStatus.LEAVING, FlowStatus.NEAR], n)
    pool.intensity[rng.random(pool.capacity) < 0.05] = 0.0
    cell, gw, gh = ks.sprite_grid_shape(W, H, r)
    sprite_r = ks.SPRITE_RADIUS_FACTOR * r
    full, counts, grid = _grid(pool, n, sprite_r, float(cell), gw, gh)
    expect, expect_full = _grid_ref(pool, n, sprite_r, float(cell), gw, gh)
    cells = ref.grid_lists(grid, gw, gh)
    assert cells == expect and full == expect_full == 0
    _check_terminators(counts, grid, gw, gh)
    assert _coverage(pool, n, sprite_r, cell, gw, gh, cells) > 100
    # ... and only those whose disc meets the cell (exact disc–rectangle test)
    for c, lst in enumerate(cells):
        cy, cx = divmod(c, gw)
        assert all(_disc_meets_cell(pool.screen_px[i], sprite_r, cell, cx, cy) for i in lst)


def test_overflowing_cells_keep_the_brightest(rng):
    pool = _pool(64)
    n = 50
    pool.alive[:n] = True
    pool.has_world[:n] = True
    pool.status[:n] = FlowStatus.INSIDE
    pool.screen_px[:n] = rng.uniform(10, 14, (n, 2))
    pool.intensity[:n] = rng.permutation(np.linspace(0.02, 1.0, n)).astype(np.float32)
    pool.intensity[[3, 7]] = pool.intensity[:n].max()  # ties with the brightest: earlier kept
    full, counts, grid = _grid(pool, n, 6.0, 8.0, 4, 4)
    cells = ref.grid_lists(grid, 4, 4)
    assert (cells, full) == _grid_ref(pool, n, 6.0, 8.0, 4, 4)
    assert full == (counts == 16).sum() > 0
    assert counts[1 * 4 + 1] == 16  # cell [8, 16)² holds every centre
    for c in np.flatnonzero(counts == 16):
        cy, cx = divmod(c, 4)
        touching = [i for i in range(n) if _disc_meets_cell(pool.screen_px[i], 6.0, 8.0, cx, cy)]
        brightest = sorted(touching, key=lambda i: (-pool.intensity[i], i))[:16]
        assert sorted(cells[c]) == sorted(brightest)
    # equal intensities: the first 16 slots stay
    pool.intensity[:n] = 0.5
    full, counts, grid = _grid(pool, n, 6.0, 8.0, 4, 4)
    for c in np.flatnonzero(counts == 16):
        cy, cx = divmod(c, 4)
        touching = [i for i in range(n) if _disc_meets_cell(pool.screen_px[i], 6.0, 8.0, cx, cy)]
        assert ref.grid_lists(grid, 4, 4)[c] == touching[:16]


def test_grid_random_overflow_matches_reference(rng):
    pool = _pool(600)
    n = 600
    pool.alive[:] = True
    pool.has_world[:] = True
    pool.status[:] = FlowStatus.LEAVING
    pool.screen_px[:] = rng.uniform(-20, (W + 20, H + 20), (n, 2))
    pool.intensity[:] = rng.choice([0.25, 0.5, 0.75, 1.0], n)  # many ties
    full, _counts, grid = _grid(pool, n, 12.0, 4.0, 24, 16)
    expect, expect_full = _grid_ref(pool, n, 12.0, 4.0, 24, 16)
    assert ref.grid_lists(grid, 24, 16) == expect
    assert full == expect_full > 0


def test_grid_is_deterministic_and_survives_bad_input(rng):
    pool = _pool(500)
    n = _poisson_like(rng, pool, 4.0, W, H)
    pool.screen_px[5] = (np.nan, np.nan)
    pool.screen_px[6] = (1e30, -1e30)
    pool.screen_px[7] = (-3e38, 3e38)
    pool.screen_px[8] = (np.inf, 10.0)
    a = _grid(pool, n, 12.0, 4.0, 24, 16)
    b = _grid(pool, n, 12.0, 4.0, 24, 16)
    assert a[0] == b[0]
    npt.assert_array_equal(a[1], b[1])
    npt.assert_array_equal(a[2], b[2])
    c = _grid(pool, n, 12.0, 4.0, 24, 16, fill_value=-5)
    assert ref.grid_lists(c[2], 24, 16) == ref.grid_lists(a[2], 24, 16)
    assert not any(i in lst for lst in ref.grid_lists(a[2], 24, 16) for i in (5, 6, 7, 8))
    for radius, cell, n_slots in ((0.0, 4.0, n), (np.nan, 4.0, n), (12.0, 0.0, n),
                                  (12.0, np.inf, n), (-1.0, 4.0, n), (12.0, 4.0, 0),
                                  (12.0, 4.0, -3), (np.inf, 4.0, n)):
        full, counts, grid = _grid(pool, n_slots, radius, cell, 24, 16)
        assert full == 0 and (counts == 0).all() and (grid[:, ::16] == -1).all()
    # grid and counts smaller than gw, gh say: clamped, not a crash
    counts = np.zeros(5, np.int32)
    grid = np.zeros((2, 40), np.int32)
    ks.build_sprite_grid(pool.alive, pool.has_world, pool.screen_px, pool.intensity, pool.status,
                         n, 12.0, 4.0, 24, 16, counts, grid)
    assert ks.build_sprite_grid(pool.alive, pool.has_world, pool.screen_px, pool.intensity,
                                pool.status, n, 12.0, 4.0, 0, 0, counts, grid) == 0


def test_helpers():
    alive = np.zeros(10, np.bool_)
    assert ks.slot_span(alive) == 0
    alive[[0, 3, 7]] = True
    assert ks.slot_span(alive) == 8
    assert [ks.param_table_rows(n) for n in (0, 1, 256, 257, -4)] == [0, 1, 1, 2, 0]
    params, counts, grid = ks.empty_sprite_tables(300, 5, 3)
    assert params.shape == (2, 768, 4) and params.dtype == np.float32
    assert counts.shape == (15,) and counts.dtype == np.int32
    assert grid.shape == (3, 80) and grid.dtype == np.int32 and (grid == -1).all()
