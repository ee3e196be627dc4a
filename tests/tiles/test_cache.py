"""The tile cache: pools, one byte budget, least-recently-used eviction across kinds, pins."""
from __future__ import annotations

import numpy as np
import pytest

from riverflow.tiles.cache import FieldSpec, TileCache, TilePool
from riverflow.tiles.table import tile_code

FIELDS = {"a": FieldSpec((4, 4), np.float32, np.nan), "n": FieldSpec((), np.int32, 0)}


def _tile(value: float) -> dict:
    return {"a": np.full((4, 4), value, np.float32), "n": np.int32(value)}


def test_pool_stores_grows_and_reuses_slots():
    pool = TilePool("k", FIELDS, capacity=2)
    slots = [pool.store(tile_code(3, i, 0), _tile(i)) for i in range(5)]
    assert pool.capacity >= 5 and len(pool) == 5 and len(set(slots)) == 5
    assert pool.get(tile_code(3, 2, 0))["a"][0, 0] == 2.0
    assert pool.store(tile_code(3, 2, 0), _tile(99)) == slots[2]  # resident: kept as it is
    assert pool.get(tile_code(3, 2, 0))["n"] == 2
    pool.release(slots[1])
    assert tile_code(3, 1, 0) not in pool and np.isnan(pool.a[slots[1]]).all()
    assert pool.store(tile_code(4, 0, 0), _tile(7)) == slots[1]
    assert pool.resident_bytes == 5 * pool.tile_bytes
    assert sorted(pool.keys()) == [(3, 0, 0), (3, 2, 0), (3, 3, 0), (3, 4, 0), (4, 0, 0)]


def test_budget_evicts_least_recently_used_across_kinds():
    per_tile = TilePool("x", FIELDS).tile_bytes
    cache = TileCache(4 * per_tile + 1)
    cache.pool("a", FIELDS)
    cache.pool("b")
    for i in range(3):
        cache.next_tick()
        cache.install("a", tile_code(1, i, 0), _tile(i))
    cache.next_tick()
    cache.install("b", tile_code(1, 0, 0), object(), nbytes=per_tile)
    assert cache.resident_bytes == 4 * per_tile
    cache.next_tick()
    cache.pools["a"].mark_used(np.array([tile_code(1, 0, 0)]), cache.tick)  # the oldest, used again
    cache.install("b", tile_code(1, 1, 0), object(), nbytes=2 * per_tile)
    a = cache.pools["a"]
    # (1, 1, 0) then (1, 2, 0) were the least recently used
    assert tile_code(1, 0, 0) in a and tile_code(1, 1, 0) not in a and tile_code(1, 2, 0) not in a
    assert cache.resident_bytes <= cache.budget_bytes
    assert a.evicted == 2


def test_tiles_used_now_and_pinned_tiles_stay_over_budget():
    per_tile = TilePool("x", FIELDS).tile_bytes
    cache = TileCache(per_tile)
    pool = cache.pool("a", FIELDS)
    cache.install("a", tile_code(0, 0, 0), _tile(0))
    cache.install("a", tile_code(1, 0, 0), _tile(1))  # same tick: both stay
    assert len(pool) == 2 and cache.over_budget
    pool.pins[pool.slot(tile_code(0, 0, 0))] = 1
    cache.next_tick()
    assert cache.evict_to_budget() == 1
    assert tile_code(0, 0, 0) in pool and tile_code(1, 0, 0) not in pool


def test_bad_budget_is_refused():
    with pytest.raises(ValueError, match="budget"):
        TileCache(0)


def test_eviction_picks_the_same_tiles_in_the_same_order_as_sorting_every_candidate():
    """_oldest_first sorts only the oldest candidates; what it evicts (the shortest prefix
    that frees the excess) is what sorting them all gives, ties in last use included."""
    from riverflow.tiles.cache import _oldest_first

    rng = np.random.default_rng(7)
    for trial in range(200):
        n = int(rng.integers(1, 3000))
        cand = np.stack([rng.integers(0, rng.integers(1, 60), n), rng.integers(0, 7, n),
                         rng.permutation(10 * n)[:n], np.arange(n),
                         rng.integers(1, 5000, n)], 1).astype(np.int64)
        excess = int(rng.integers(1, int(cand[:, 4].sum()) + 5000))
        full = cand[np.lexsort((cand[:, 2], cand[:, 1], cand[:, 0]))]
        got = _oldest_first(cand, excess)
        k = int(np.searchsorted(np.cumsum(full[:, 4]), excess)) + 1
        assert np.array_equal(got[:k], full[:k]), trial
        assert int(got[:k, 4].sum()) >= min(excess, int(cand[:, 4].sum()))
