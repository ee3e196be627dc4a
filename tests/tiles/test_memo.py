"""The scene's tile memo (riverflow.tiles.memo): least recently used out within its budget,
read-only tiles, thread-safe, empty when pickled; the frames it serves are in
tests/render/test_first_frame.py."""
from __future__ import annotations

import pickle
import threading

import numpy as np
import pytest

from riverflow.tiles.memo import TileMemo


def tile(value: float, n: int = 100) -> dict:
    return {"z": np.full((n, n), value, np.float32), "dip": np.array([value], np.float32)}


def test_least_recently_used_tiles_leave_first_within_the_budget():
    size = tile(0.0)["z"].nbytes + 4
    memo = TileMemo(budget_mb=3.5 * size / 1e6)
    for k in range(3):
        memo.put(("height", 0, (5, k, 0)), tile(k))
    assert memo.get(("height", 0, (5, 0, 0)))["dip"][0] == 0.0     # now the most recent
    memo.put(("height", 0, (5, 3, 0)), tile(3.0))
    assert len(memo) == 3 and memo.bytes == 3 * size <= memo.budget_bytes
    assert memo.get(("height", 0, (5, 1, 0))) is None               # the least recent left
    assert memo.get(("height", 0, (5, 0, 0))) is not None
    assert (memo.hits, memo.misses) == (2, 1)
    memo.put(("height", 0, (5, 3, 0)), tile(4.0))                   # replaced, not doubled
    assert memo.bytes == 3 * size and memo.get(("height", 0, (5, 3, 0)))["dip"][0] == 4.0


def test_kept_tiles_are_read_only_and_other_data_is_not_kept():
    memo = TileMemo()
    memo.put("a", tile(1.0))
    with pytest.raises(ValueError):
        memo.get("a")["z"][0, 0] = 2.0
    memo.put("b", object())                  # an object tile: each world makes its own
    memo.put("c", (np.zeros(3), "text"))
    assert memo.get("b") is None and memo.get("c") is None
    small = TileMemo(budget_mb=0.01)
    small.put("d", tile(1.0))                # larger than its budget
    assert len(small) == 0 and small.bytes == 0
    assert TileMemo(0).budget_bytes == 0
    with pytest.raises(ValueError, match="budget_mb"):
        TileMemo(float("nan"))


def test_a_pickled_memo_is_empty_and_threads_share_one():
    memo = TileMemo(budget_mb=2.0)

    def fill(k0: int) -> None:
        for k in range(k0, k0 + 200):
            memo.put(k, tile(k, n=10))
            memo.get(k - 1)

    threads = [threading.Thread(target=fill, args=(k * 1000,)) for k in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert len(memo) == 800 and memo.bytes == 800 * (400 + 4)
    copy = pickle.loads(pickle.dumps(memo))
    assert len(copy) == 0 and copy.budget_bytes == memo.budget_bytes


def test_the_memo_never_keeps_a_view_of_a_pools_slot():
    """A ray-cast tile's water was its water tile's level array itself, a view of the water
    pool's slot; the memo kept it, and once the cache evicted the water tile and gave the
    slot to another, the memo's ray-cast tile read that one's levels: the next world of
    the level (a game reopening it, the test suite's shared scenes) had particles metres
    off the water. A tile is kept with its arrays owned; the ray-cast producer copies."""
    from riverflow.scenes.default import default_scene
    from riverflow.scenes.tile_kinds import HEIGHT, RAYCAST, WATER, terrain_producers
    from riverflow.tiles.scheduler import _owned

    pool = np.zeros((4, 3, 3))
    kept = _owned({"a": pool[1], "b": np.ones(2), "c": 3})
    pool[1] = 7.0
    assert (kept["a"] == 0.0).all() and kept["c"] == 3
    assert _owned(pool[2]).base is None

    scene = default_scene(seed=0)
    producers = {p.kind: p for p in terrain_producers(scene)}
    key = (scene.terrain.max_level, *scene.quadtree.tile_of(*scene.water.samples_m[0],
                                                             scene.terrain.max_level))
    deps = {(kind, key): producers[kind].produce(key, {}) for kind in (HEIGHT, WATER)}
    made = producers[RAYCAST].produce(key, deps)
    for dep in deps.values():
        for arr in dep.values():
            for mine in made.values():
                assert not np.shares_memory(arr, mine)
