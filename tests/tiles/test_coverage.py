"""Which tiles capsules touch (riverflow.tiles.coverage): every tile a capsule overlaps, few
more, and memory that grows with the water's tiles, not with its width times its length."""
from __future__ import annotations

import numpy as np

from riverflow.tiles.coverage import coverage_table, touched_bytes, touched_codes
from riverflow.tiles.quadtree import Quadtree


def _square_to_segment(cx, cy, half, seg) -> np.ndarray:
    """The exact distance from squares (centres cx, cy (N,), half side) to one segment
    (4,): 0 where they overlap (sampled finely along the segment and across the square's
    border: a twin by brute force)."""
    ax, ay, bx, by = seg
    t = np.linspace(0.0, 1.0, 400)
    px, py = ax + t * (bx - ax), ay + t * (by - ay)
    dx = np.maximum(np.abs(px[None] - cx[:, None]) - half, 0.0)
    dy = np.maximum(np.abs(py[None] - cy[:, None]) - half, 0.0)
    return np.hypot(dx, dy).min(axis=1)


def test_every_tile_a_capsule_overlaps_is_touched_and_few_others(rng):
    tree = Quadtree(0.0, 0.0, 1024.0)
    level = 6                                                  # 16 m tiles
    size = tree.tile_size_m(level)
    for _ in range(25):
        seg = rng.uniform(100.0, 900.0, 4)
        r = float(rng.choice([2.0, 20.0, 150.0]))
        got = touched_codes(tree, seg[None], r, level)
        i, j = np.meshgrid(np.arange(64), np.arange(64))
        i, j = i.ravel(), j.ravel()
        d = _square_to_segment((i + 0.5) * size, (j + 0.5) * size, 0.5 * size, seg)
        # the segment is sampled every 1/400 of it: a tile it grazes may read up to that far
        slack = np.hypot(seg[2] - seg[0], seg[3] - seg[1]) / 400.0
        overlapped = (np.int64(level) << 56) | (j[d <= r - slack] << 28) | i[d <= r - slack]
        assert np.isin(overlapped, got).all()
        # and nothing farther than the tile's diagonal from the capsule
        beside = (np.int64(level) << 56) | (j[d > r + size * 1.5] << 28) | i[d > r + size * 1.5]
        assert not np.isin(beside, got).any()
        assert np.array_equal(got, np.unique(got)) and (got >> 56 == level).all()


def test_the_touched_tiles_are_those_whose_centre_is_within_reach_of_a_segment(rng):
    """Twin by brute force: every tile whose centre lies within its capsule's radius plus
    half the tile's diagonal of a segment (the rule), none other, whatever the segments'
    directions (level, vertical, a point) and their capsules' overlaps (but for centres
    within a micrometre of that reach)."""
    tree = Quadtree(-50.0, -50.0, 1024.0)
    level = 6
    size = tree.tile_size_m(level)
    i, j = np.meshgrid(np.arange(64), np.arange(64))
    i, j = i.ravel(), j.ravel()
    cx, cy = -50.0 + (i + 0.5) * size, -50.0 + (j + 0.5) * size
    for case in range(30):
        seg = rng.uniform(-100.0, 1000.0, (int(rng.integers(1, 6)), 4))
        if case % 5 == 1:
            seg[:, 3] = seg[:, 1]                               # level
        if case % 5 == 2:
            seg[:, 2] = seg[:, 0]                               # vertical
        if case % 5 == 3:
            seg[:, 2:] = seg[:, :2]                             # a point
        r = rng.choice([0.5, 5.0, 40.0, 200.0], len(seg))
        got = touched_codes(tree, seg, r, level)
        ax, ay, bx, by = seg.T[:, :, None]
        dx, dy = bx - ax, by - ay
        t = np.clip(((cx - ax) * dx + (cy - ay) * dy) / np.maximum(dx * dx + dy * dy, 1e-300),
                    0.0, 1.0)
        d = np.hypot(cx - ax - t * dx, cy - ay - t * dy) - (r[:, None] + size * np.sqrt(0.5))
        code = (np.int64(level) << 56) | (j << 28) | i
        assert np.isin(code[(d < -1e-6).any(axis=0)], got).all()
        assert not np.isin(code[(d > 1e-6).all(axis=0)], got).any()
        assert np.array_equal(got, np.unique(got))
    # a segment or radius that is not finite touches nothing (never a garbage row's tiles)
    bad = np.array([[np.nan, 0.0, 10.0, 10.0], [0.0, 0.0, 10.0, 10.0], [np.inf, 0.0, 1.0, 1.0]])
    ok = touched_codes(tree, bad[1:2], 5.0, level)
    assert np.array_equal(touched_codes(tree, bad, 5.0, level), ok) and len(ok)
    assert not len(touched_codes(tree, bad[1:2], np.nan, level))


def test_a_wide_river_at_a_fine_level_costs_its_area_not_its_width_squared():
    """A 2 km wide river 10 km long at 4 m tiles: ~1.3 million tiles touched; cut into pieces
    a tile long, their boxes held ~500 times that (Porto's river area was refused at 28 GiB).
    And one drawn in short segments (London's basins: 6 m segments of axes 200 - 1300 m
    wide) is estimated by its extent, not its capsules' sum of areas."""
    tree = Quadtree(-1000.0, -6000.0, 16384.0)
    level = 12                                                 # 4 m tiles
    seg = np.array([[0.0, 0.0, 10_000.0, 0.0]])
    estimate = touched_bytes(seg, 1000.0, tree.tile_size_m(level))
    tiles = (10_000.0 + 2000.0) * 2000.0 / 16.0
    assert estimate < 200.0 * tiles          # bytes: ~130 a tile (pieces a tile long: ~90,000)
    short = np.array([[0.0, 0.0, 1000.0, 0.0]])         # made: the capsule's tiles, no more
    got = touched_codes(tree, short, 1000.0, 10)        # 16 m tiles
    capsule = (1000.0 * 2000.0 + np.pi * 1000.0 ** 2) / 16.0 ** 2
    assert capsule < len(got) < 1.1 * capsule
    x = np.linspace(0.0, 10_000.0, 1668)                   # 6 m segments
    many = np.column_stack([x[:-1], np.zeros(len(x) - 1), x[1:], np.zeros(len(x) - 1)])
    assert touched_bytes(many, 1000.0, tree.tile_size_m(level)) < 3.0 * estimate   # not 200x


def test_coverage_table_holds_the_touched_tiles_and_their_ancestors(rng):
    from riverflow.tiles.coverage import with_ancestors

    tree = Quadtree(0.0, 0.0, 1024.0)
    seg = np.array([[100.0, 120.0, 700.0, 650.0], [700.0, 650.0, 900.0, 400.0]])
    fine = touched_codes(tree, seg, np.array([10.0, 30.0]), 7)
    table = coverage_table(tree, seg, np.array([10.0, 30.0]), 7)
    every = with_ancestors(fine)
    assert (table.find_many(every) >= 0).all()
    assert len(table) == len(every)


def test_a_segment_flat_but_for_a_denormal_is_the_flat_ones_without_overflow():
    """A segment whose dy (or dx) is a denormal (a graph file's 0.0 read as 1e-320) overflows
    the row's band to ±inf, the flat segment's limit: the same tiles, no RuntimeWarning."""
    import warnings

    q = Quadtree(-512.0, -512.0, 1024.0)
    flat = np.array([[-300.0, 0.0, 300.0, 0.0], [0.0, -300.0, 0.0, 300.0]])
    tiny = flat.copy()
    tiny[0, 3] = tiny[1, 2] = 1e-320          # (0 + 1e-320: the denormal stays)
    assert tiny[0, 3] - tiny[0, 1] == 1e-320
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        got = touched_codes(q, tiny, np.array([20.0, 20.0]), 6)
    assert np.array_equal(got, touched_codes(q, flat, np.array([20.0, 20.0]), 6))
