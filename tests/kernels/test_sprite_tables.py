"""The sprite table and bins (kernels/sprites.py) against their numpy twin, and their properties:
the bins partition the drawn sprites, and the look-up of sprite_bins.glsl (its Python twin)
finds every sprite that meets a pixel or a grid cell."""
from __future__ import annotations

import numpy as np
import numpy.testing as npt
import pytest

from riverflow.components.particles import ParticlePool
from riverflow.components.status import FlowStatus
from riverflow.kernels import sprites as ks
from tests.kernels import sprites_reference as ref

W, H = 96, 64


def _poisson_like(rng, pool: ParticlePool, r: float, w: float, h: float, margin: float = 0.0):
    """Live, INSIDE particles on a jittered grid of spacing 2r·1.07 (≈ Poisson disk of radius r)
    over [−margin, w + margin] × [−margin, h + margin], in random slot order; returns their
    number. world x is the slot's own index (to find an entry's slot)."""
    step = 2.0 * r * 1.07
    xs = np.arange(-margin, w + margin, step)
    ys = np.arange(-margin, h + margin, step)
    pts = np.stack(np.meshgrid(xs, ys), -1).reshape(-1, 2)
    pts += rng.uniform(0, 0.3 * step, pts.shape)
    pts = pts[rng.permutation(len(pts))]
    n = min(len(pts), pool.capacity)
    pool.alive[:n] = True
    pool.has_world[:n] = True
    pool.status[:n] = FlowStatus.INSIDE
    pool.screen_px[:n] = pts[:n]
    pool.world_m[:n] = rng.uniform(-500, 500, (n, 3))
    pool.world_m[:n, 0] = np.arange(n)
    pool.intensity[:n] = rng.uniform(0.0, 1.0, n).astype(np.float32)
    pool.intensity[:n][pool.intensity[:n] == 0] = 0.5
    pool.offset_m[:n] = rng.uniform(-10, 10, (n, 2))
    pool.velocity_mps[:n] = rng.uniform(-2, 2, (n, 2))
    return n


def _build(pool, radius, n_slots, bins, rows=None, fill=7.0, with_tail=True):
    params, starts, scratch = ks.empty_sprite_tables(pool.capacity, bins)
    if rows is not None:                            # a table shorter than the pool
        params = np.zeros((rows, *params.shape[1:]), np.float32)
    params[...] = fill
    starts[...] = -9
    n_drawn, n_entries, n_rows = ks.build_sprite_tables(ks.sprite_source(pool), radius, n_slots,
                                                        bins, params, starts, scratch, with_tail)
    return params, ks.bin_texels(starts, bins), int(n_drawn), int(n_entries), int(n_rows)


def _build_ref(pool, radius, n_slots, bins, rows, with_tail=True):
    return ref.build_sprite_tables(pool.alive, pool.has_world, pool.screen_px, pool.world_m,
                                   pool.offset_m, pool.intensity, pool.status, pool.velocity_mps,
                                   radius, n_slots, bins, rows, with_tail, pool.foam,
                                   pool.tint)


def _check_against_reference(pool, radius, n_slots, bins, rows=None, with_tail=True):
    params, starts, n_drawn, n_entries, n_rows = _build(pool, radius, n_slots, bins, rows,
                                                        with_tail=with_tail)
    cap_rows = params.shape[0]
    table, want_starts, want_drawn, want_entries, want_rows = _build_ref(
        pool, radius, n_slots, bins, cap_rows, with_tail)
    assert (n_drawn, n_entries, n_rows) == (want_drawn, want_entries, want_rows)
    got = params[:n_rows].reshape(-1, ks.TEXELS_PER_PARTICLE, 4)
    npt.assert_array_equal(got, table)
    assert (params[n_rows:] == 7.0).all()           # rows past the last written are untouched
    npt.assert_array_equal(starts, want_starts)
    return params, starts, n_drawn, n_entries, n_rows


# ---------------------------------------------------------------- shapes


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


@pytest.mark.parametrize("size, radius, expect", [
    ((1920, 1080), 5.0, (5, 35, 4, 2, 384 + 8, 31 + 4)),
    ((1920, 1080), 10.0, (10, 70, 4, 2, 192 + 8, 16 + 4)),
    ((240, 136), 6.0, (6, 42, 4, 2, 40 + 8, 4 + 4)),
    ((0, 0), 5.0, (5, 35, 4, 2, 8, 4)),
    ((64, 48), float("nan"), (1, 1, 1, 1, 64 + 2, 48 + 2)),
    ((64, 48), -3.0, (1, 1, 1, 1, 64 + 2, 48 + 2)),
    ((64, 48), 0.1, (1, 1, 2, 2, 64 + 4, 48 + 4)),
])
def test_sprite_bins_shape(size, radius, expect):
    bins = ks.sprite_bins(*size, radius)
    assert tuple(bins) == expect
    # the margins hold every centre whose disc reaches a pixel centre of the screen
    reach = ks.SPRITE_RADIUS_FACTOR * max(radius, 0.0) if np.isfinite(radius) else 0.0
    assert bins.margin_x * bins.bin_w >= reach + 1 and bins.margin_y * bins.bin_h >= reach + 1


def test_helpers():
    alive = np.zeros(10, np.bool_)
    assert ks.slot_span(alive) == 0
    alive[[0, 3, 7]] = True
    assert ks.slot_span(alive) == 8
    assert [ks.param_table_rows(n) for n in (0, 1, 256, 257, -4)] == [0, 1, 1, 2, 0]
    bins = ks.SpriteBins(2, 3, 1, 1, 5, 3)
    params, starts, scratch = ks.empty_sprite_tables(300, bins)
    assert params.shape == (2, 256 * ks.TEXELS_PER_PARTICLE, 4) and params.dtype == np.float32
    assert starts.shape == (3 * 6 + 2,) and starts.dtype == np.int32
    assert scratch.shape == (600,) and scratch.dtype == np.int32
    assert ks.bin_texels(starts, bins).shape == (3, 6)
    assert np.shares_memory(ks.bin_texels(starts, bins), starts)


# ---------------------------------------------------------------- the sprite table


def test_table_layout_of_hand_made_particles():
    pool = ParticlePool(600)
    placed = {0: (10.5, 20.25), 1: (-3.0, 7.0), 3: (95.0, 63.0), 257: (1.0, 2.0),
              300: (50.0, 5.0), 301: (11.0, 21.0)}
    for i, (sx, sy) in placed.items():
        pool.alive[i] = True
        pool.has_world[i] = True
        pool.screen_px[i] = (sx, sy)
        pool.world_m[i] = (100.0 + i, -200.0 - i, 12.5 + i)
        pool.offset_m[i] = (0.25 * i, -0.5)
        pool.intensity[i] = 0.75
        pool.status[i] = FlowStatus.LEAVING if i == 3 else FlowStatus.INSIDE
        pool.velocity_mps[i] = (1.5, -0.125 * i)
        pool.foam[i] = 0.5
    pool.foam[3] = np.nan                           # written 0, never NaN
    pool.tint[1] = (0.55, 0.33, 0.12, 2e-3)         # a spill's colour and concentration
    pool.tint[3] = (1.5, np.nan, -1.0, 1e-4)        # clamped: 255, 0, 0
    pool.tint[0] = (0.2, 0.2, 0.2, np.nan)          # no concentration: no tint
    pool.status[300] = FlowStatus.NEAR              # usable, not drawn: the tail
    pool.alive[256] = True                          # alive, no world position: left out
    pool.screen_px[256] = (5.0, 5.0)
    bins = ks.sprite_bins(W, H, 4.0)                # bins of 4 × 28 px, margins 4 and 2
    params, starts, n_drawn, n_entries, rows = _build(pool, 4.0, 302, bins, rows=3)
    assert (n_drawn, n_entries, rows) == (5, 6, 1)
    table = params[0].reshape(-1, ks.TEXELS_PER_PARTICLE, 4)
    # drawn, by bin (row-major) then slot: row y 0–28 holds slots 0 (x 10.5 → bin 2), 1
    # (x −3 → bin −1), 257 (x 1 → bin 0), 301 (x 11 → bin 2); slot 3 (y 63) is in row 2
    assert [int(e[0, 2]) - 100 for e in table[:6]] == [1, 257, 0, 301, 3, 300]
    npt.assert_array_equal(table[2], [[10.5, 20.25, 100.0, -200.0],
                                      [0.0, -0.5, 0.75, 4.0],
                                      [1.0, 1.5, 0.0, 12.5],
                                      [0.5, 0.0, 0.0, 0.0]])
    npt.assert_array_equal(table[4], [[95.0, 63.0, 103.0, -203.0],
                                      [0.75, -0.5, 0.75, 4.0],
                                      [2.0, 1.5, -0.375, 15.5],
                                      [0.0, np.float32(1e-4), 255 * 65536, 0.0]])
    # the spill tint: its concentration, its colour 8 bits a channel in one exact float
    npt.assert_array_equal(table[0, 3], np.float32([0.5, 2e-3, 140 * 65536 + 84 * 256 + 31, 0]))
    npt.assert_array_equal(table[5, 2, 0], FlowStatus.NEAR)
    free = np.array([[0, 0, 0, 0], [0, 0, 0, 0], [-1, 0, 0, 0], [0, 0, 0, 0]], np.float32)
    for e in (6, 100, 255):
        npt.assert_array_equal(table[e], free)
    assert (params[1:] == 7.0).all()
    # bins: entries [0, 4) in screen row 0 (bin row 2), [4, 5) in screen row 2 (bin row 4)
    row0 = starts[bins.margin_y]
    assert (row0[:bins.margin_x - 1] == 0).all() and row0[bins.margin_x - 1] == 0
    assert row0[bins.margin_x] == 1 and row0[bins.margin_x + 1] == 2
    assert row0[bins.margin_x + 2] == 2 and row0[bins.margin_x + 3] == 4 and row0[-1] == 4
    assert starts[bins.margin_y + 2][-1] == 5 and starts[-1][-1] == 5
    _check_against_reference(pool, 4.0, 302, bins, rows=3)


def test_tables_match_reference_on_random_pools(rng):
    pool = ParticlePool(1500)
    n = _poisson_like(rng, pool, 3.0, 300, 200, margin=12.0)
    pool.alive[rng.random(pool.capacity) < 0.2] = False
    pool.has_world[rng.random(pool.capacity) < 0.1] = False
    pool.status[:] = rng.integers(0, 8, pool.capacity)
    pool.intensity[rng.random(pool.capacity) < 0.05] = 0.0
    pool.tint[:] = rng.random((pool.capacity, 4)) * (1.2, 1.2, 1.2, 1e-3)
    pool.tint[rng.random(pool.capacity) < 0.5, 3] = 0.0
    for radius, size in ((2.5, (300, 200)), (3.0, (120, 90)), (7.0, (300, 200))):
        bins = ks.sprite_bins(*size, radius)
        for n_slots in (0, 1, 255, 256, 257, n, pool.capacity, pool.capacity + 99, -5):
            for with_tail in (True, False):
                _check_against_reference(pool, radius, n_slots, bins, with_tail=with_tail)
    # a table shorter than the pool: the tail goes first, the bins stop at its end
    bins = ks.sprite_bins(300, 200, 3.0)
    for rows in (1, 2):
        _, starts, n_drawn, n_entries, _ = _check_against_reference(pool, 3.0, pool.capacity,
                                                                    bins, rows=rows)
        assert n_entries == rows * 256 and starts.max() == n_drawn <= n_entries


def test_without_the_tail_the_table_ends_after_the_drawn_entries(rng):
    pool = ParticlePool(2000)
    n = _poisson_like(rng, pool, 3.0, 300, 200, margin=12.0)
    pool.status[:n] = rng.choice([FlowStatus.INSIDE, FlowStatus.NEAR, FlowStatus.OUTSIDE], n)
    bins = ks.sprite_bins(300, 200, 3.0)
    full = _build(pool, 3.0, n, bins)
    short = _build(pool, 3.0, n, bins, with_tail=False)
    n_drawn = full[2]
    assert 0 < n_drawn < full[3] and short[2] == short[3] == n_drawn
    assert short[4] == ks.param_table_rows(n_drawn) < full[4]
    npt.assert_array_equal(short[0].reshape(-1, ks.TEXELS_PER_PARTICLE, 4)[:n_drawn],
                           full[0].reshape(-1, ks.TEXELS_PER_PARTICLE, 4)[:n_drawn])
    npt.assert_array_equal(short[1], full[1])


def test_no_radius_or_bins_draws_nothing_but_keeps_the_overlays(rng):
    pool = ParticlePool(400)
    n = _poisson_like(rng, pool, 4.0, W, H)
    for radius, bins in ((0.0, ks.sprite_bins(W, H, 4.0)), (np.nan, ks.sprite_bins(W, H, 4.0)),
                         (-2.0, ks.sprite_bins(W, H, 4.0)), (4.0, ks.SpriteBins(0, 3, 1, 1, 5, 3)),
                         (4.0, ks.SpriteBins(4, 4, 1, 1, 0, 0))):
        params, starts, n_drawn, n_entries, rows = _build(pool, radius, n, bins)
        assert n_drawn == 0 and n_entries == n and (starts == 0).all()
        assert np.isfinite(params[:rows]).all()


def test_tables_never_hold_non_finite_values(rng):
    pool = ParticlePool(300)
    _poisson_like(rng, pool, 4.0, W, H)
    bad = {0: ("screen_px", 0, np.nan), 1: ("screen_px", 1, np.inf), 2: ("world_m", 0, np.nan),
           3: ("world_m", 2, -np.inf), 4: ("world_m", 1, 1e300),  # overflows float32
           5: ("intensity", None, np.nan), 8: ("screen_px", 0, 3e38), 9: ("screen_px", 1, -1e30)}
    for i, (name, k, v) in bad.items():
        col = getattr(pool, name)
        if k is None:
            col[i] = v
        else:
            col[i, k] = v
    pool.offset_m[6] = (np.nan, 1.0)
    pool.velocity_mps[7] = (np.inf, -np.inf)
    bins = ks.sprite_bins(W, H, 4.0)
    for radius in (4.0, np.nan, 0.0):
        params, starts, n_drawn, n_entries, rows = _check_against_reference(pool, radius, 300,
                                                                            bins)
        assert np.isfinite(params[:rows]).all()
        table = params[:rows].reshape(-1, ks.TEXELS_PER_PARTICLE, 4)
        slots = table[:n_entries, 0, 2].astype(int)     # world x = slot
        assert not set(slots) & {0, 1, 2, 3, 4, 5}      # left out
        assert {6, 7, 8, 9} <= set(slots)               # usable: kept (8, 9 far off screen)
        assert not set(slots[:n_drawn]) & {8, 9}        # ... but not drawn
        e6, e7 = (np.flatnonzero(slots == i)[0] for i in (6, 7))
        assert table[e6, 1, 0] == 0 and table[e6, 1, 1] == 1.0
        npt.assert_array_equal(table[e7, 2, 1:3], [0, 0])


def test_empty_and_full_pools(rng):
    bins = ks.sprite_bins(W, H, 4.0)
    pool = ParticlePool(512)
    params, starts, n_drawn, n_entries, rows = _build(pool, 4.0, 512, bins)
    assert (n_drawn, n_entries, rows) == (0, 0, 0) and (starts == 0).all()
    pool.alive[:] = True                            # every slot live, piled up and spread
    pool.has_world[:] = True
    pool.status[:] = FlowStatus.INSIDE
    pool.intensity[:] = 1.0
    pool.screen_px[:] = rng.uniform(-50, 150, (512, 2))
    pool.screen_px[:100] = (10.0, 10.0)
    pool.world_m[:, 0] = np.arange(512)
    params, starts, n_drawn, n_entries, rows = _check_against_reference(pool, 4.0, 512, bins)
    assert n_entries == 512 and rows == 2 and n_drawn >= 100


# ---------------------------------------------------------------- the bins


def _slot_of(params, n):
    return params.reshape(-1, ks.TEXELS_PER_PARTICLE, 4)[:n, 0, 2].astype(int)


def test_bins_partition_the_drawn_entries(rng):
    pool = ParticlePool(1200)
    n = _poisson_like(rng, pool, 4.0, W, H, margin=30.0)
    pool.status[:n] = rng.choice([FlowStatus.INSIDE, FlowStatus.LEAVING, FlowStatus.NEAR], n)
    bins = ks.sprite_bins(W, H, 4.0)
    params, starts, n_drawn, n_entries, _ = _build(pool, 4.0, n, bins)
    flat = starts[:, :-1].ravel()
    assert (np.diff(starts.ravel()) >= 0).all() and starts[0, 0] == 0
    assert (starts[:-1, -1] == starts[1:, 0]).all() and starts[-1, -1] == n_drawn
    table = params.reshape(-1, ks.TEXELS_PER_PARTICLE, 4)
    slots = _slot_of(params, n_entries)
    for k in range(len(flat)):
        end = flat[k + 1] if k + 1 < len(flat) else n_drawn
        by, bx = divmod(k, bins.bw)
        for e in range(flat[k], end):
            x, y = table[e, 0, :2].astype(np.float64)
            assert int(np.floor(x / bins.bin_w)) + bins.margin_x == bx
            assert int(np.floor(y / bins.bin_h)) + bins.margin_y == by
        assert (np.diff(slots[flat[k]:end]) > 0).all()     # slot order within a bin
    drawn = ref.drawable(pool.alive[:n], pool.has_world[:n], pool.screen_px[:n],
                         pool.intensity[:n], pool.status[:n])
    x, y = pool.screen_px[:n].astype(np.float64).T
    binned = ((x >= -bins.margin_x * bins.bin_w) & (x < (bins.bw - bins.margin_x) * bins.bin_w)
              & (y >= -bins.margin_y * bins.bin_h) & (y < (bins.bh - bins.margin_y) * bins.bin_h))
    assert (drawn & ~binned).sum() > 0
    assert set(slots[:n_drawn]) == set(np.flatnonzero(drawn & binned))
    assert (np.diff(slots[n_drawn:]) > 0).all()            # the tail in slot order
    assert len(set(slots)) == n_entries == int(pool.alive[:n].sum())


def _found(starts, bins, lo, hi, radius):
    out = set()
    for by, a, b in ref.bins_touching(bins, lo, hi, radius):
        out.update(range(starts[by, a], starts[by, b + 1]))
    return out


@pytest.mark.parametrize("r", [3.0, 4.0, 5.5, 10.0])
def test_every_sprite_meeting_a_pixel_or_cell_is_found_through_the_bins(rng, r):
    pool = ParticlePool(3000)
    n = _poisson_like(rng, pool, r, W, H, margin=4 * r)
    bins = ks.sprite_bins(W, H, r)
    radius = ks.SPRITE_RADIUS_FACTOR * r
    params, starts, n_drawn, _, _ = _build(pool, r, n, bins)
    centres = params.reshape(-1, ks.TEXELS_PER_PARTICLE, 4)[:n_drawn, 0, :2].astype(np.float64)
    checked = 0
    for px, py in rng.uniform(0, (W, H), (300, 2)).round() + 0.5:         # pixel centres
        found = _found(starts, bins, (px, py), (px, py), radius)
        covering = np.flatnonzero(np.hypot(*(centres - (px, py)).T) < radius)
        assert set(covering) <= found
        checked += len(covering)
    cell, gw, gh = ks.sprite_grid_shape(W, H, r)
    for cx, cy in zip(rng.integers(0, gw, 200), rng.integers(0, gh, 200)):  # grid cells
        lo = np.array([cx, cy], float) * cell
        hi = lo + cell
        found = _found(starts, bins, lo, hi, radius)
        d = np.maximum(np.maximum(lo - centres, centres - hi), 0.0)
        meeting = np.flatnonzero((d ** 2).sum(axis=1) <= radius ** 2)
        assert set(meeting) <= found
        assert len(found) <= 3 * len(meeting) + 12         # and not much more
    assert checked > 500
