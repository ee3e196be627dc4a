"""Tiles made again after their sources change (a live edit, issue 25): stale tiles stand in
until their new versions replace them, tiles being made from the old sources are never stored,
and the new producers' memo only ever holds tiles of the new sources."""
from __future__ import annotations

import threading

import numpy as np
import pytest

from riverflow.tiles.cache import FieldSpec, TileCache
from riverflow.tiles.memo import TileMemo
from riverflow.tiles.scheduler import Producer, TileScheduler
from riverflow.tiles.table import codes, tile_code

N = 4


class Level(Producer):
    """Every node holds the producer's ``version``; ``gate`` (an Event) holds production."""

    kind = "a"
    fields = {"v": FieldSpec((N, N), np.float64, np.nan)}

    def __init__(self, version: float, gate: threading.Event | None = None) -> None:
        self.version = version
        self.gate = gate
        self.memo = TileMemo()
        self.made = 0

    def produce(self, key, deps):
        if self.gate is not None:
            self.gate.wait(5.0)
        self.made += 1
        return {"v": np.full((N, N), self.version)}


class Twice(Producer):
    """Reads the "a" tile of its key: 2 × its value."""

    kind = "b"
    fields = {"v": FieldSpec((N, N), np.float64, np.nan)}

    def dependencies(self, key):
        return [("a", key)]

    def produce(self, key, deps):
        return {"v": 2.0 * deps[("a", key)]["v"]}


KEYS = np.array([[2, i, j] for i in range(4) for j in range(4)], np.int32)


def _resident(sched, kind):
    pool = sched.cache.pools[kind]
    return {c: float(pool.get(c)["v"][0, 0]) for c in pool.codes().tolist()}


def _made(sched, keys=KEYS, frames=50):
    kinds = [k for k in ("a", "b") if k in sched.producers]
    for _ in range(frames):
        sched.collect()
        for kind in kinds:
            sched.request(kind, keys)
        sched.wait(5.0)
        if not any(sched.stale(k) for k in kinds) and not sched.pending and all(
                set(codes(keys).tolist()) <= set(sched.cache.pools[k].codes().tolist())
                for k in kinds):
            return
    raise AssertionError("the stale tiles were not made again")


def test_stale_tiles_stand_in_until_their_new_versions_replace_them():
    sched = TileScheduler(TileCache(1 << 20), [Level(1.0), Twice()])
    try:
        _made(sched)
        assert set(_resident(sched, "b").values()) == {2.0}
        stale = codes(KEYS[:5])
        slots = {c: sched.cache.pools["a"].slot(c) for c in stale.tolist()}
        sched.replace_producers([Level(7.0)])
        assert sched.invalidate({"a": stale, "b": stale}) == 10
        # standing in: still resident, read as before
        assert _resident(sched, "a")[int(stale[0])] == 1.0
        assert sched.stale("a") == set(stale.tolist()) == sched.stale("b")
        evicted = sched.cache.pools["a"].evicted
        _made(sched)
        a, b = _resident(sched, "a"), _resident(sched, "b")
        assert {a[c] for c in stale.tolist()} == {7.0}
        assert {b[c] for c in stale.tolist()} == {14.0}      # from the new "a", not the stale one
        rest = set(a) - set(stale.tolist())
        assert rest and {a[c] for c in rest} == {1.0}        # the others are kept as they were
        assert sched.remade == 10
        # each new version went into another slot (whoever syncs by slot sees the change)
        pool = sched.cache.pools["a"]
        assert all(pool.slot(c) != s for c, s in slots.items())
        assert pool.evicted == evicted + 5
    finally:
        sched.close()


def test_tiles_made_from_the_old_sources_are_never_stored():
    gate = threading.Event()
    old = Level(1.0, gate)
    sched = TileScheduler(TileCache(1 << 20), [old])
    try:
        sched.request("a", KEYS[:3])            # queued, held at the gate by the worker
        assert sched.pending == 3
        new = Level(2.0)
        sched.replace_producers([new])
        sched.invalidate({})
        gate.set()                             # the old jobs finish now, after the edit
        _made(sched, KEYS[:3])
        assert set(_resident(sched, "a").values()) == {2.0}
        # nothing of the old sources in the new producer's memo, nor anything made by it there
        kept = [entry[0] for entry in new.memo._tiles.values()]
        assert len(kept) == 3 and all(float(t["v"][0, 0]) == 2.0 for t in kept)
        assert not old.memo._tiles or all(float(e[0]["v"][0, 0]) == 1.0
                                          for e in old.memo._tiles.values())
    finally:
        sched.close()


def test_blocking_mode_drops_what_changed_and_makes_it_again():
    sched = TileScheduler(TileCache(1 << 20), [Level(1.0), Twice()], mode="blocking")
    for kind in ("a", "b"):
        sched.request(kind, KEYS[:4])
    sched.replace_producers([Level(3.0)])
    sched.invalidate({"a": codes(KEYS[:2]), "b": codes(KEYS[:2])})
    assert len(sched.cache.pools["a"]) == 2
    for kind in ("a", "b"):
        sched.request(kind, KEYS[:4])
    b = _resident(sched, "b")
    assert [b[int(c)] for c in codes(KEYS[:4])] == [6.0, 6.0, 2.0, 2.0]


def test_complete_makes_a_missing_tile_from_fresh_dependencies():
    """A tile missing in a deterministic frame is made at once; a dependency of it that is
    stale is made again first (never read as a stand-in into a new tile)."""
    sched = TileScheduler(TileCache(1 << 20), [Level(1.0), Twice()])
    try:
        sched.request("a", KEYS[:1])
        sched.wait(5.0)
        sched.replace_producers([Level(5.0)])
        code = tile_code(*KEYS[0])
        sched.invalidate({"a": np.array([code])})
        sched.complete([("b", np.array([code]))])
        assert _resident(sched, "b")[code] == 10.0
        assert _resident(sched, "a")[code] == 5.0 and not sched.stale("a")
    finally:
        sched.close()


def test_replace_producers_checks_kinds_and_fields():
    sched = TileScheduler(TileCache(1 << 20), [Level(1.0)], mode="blocking")
    with pytest.raises(ValueError, match="no 'b' producer"):
        sched.replace_producers([Twice()])
    other = Level(1.0)
    other.fields = {"v": FieldSpec((N + 1, N), np.float64, np.nan)}
    with pytest.raises(ValueError, match="other fields"):
        sched.replace_producers([other])


def test_stale_tiles_no_frame_asks_for_are_let_go():
    sched = TileScheduler(TileCache(1 << 20), [Level(1.0)], stale_frames=4)
    try:
        _made(sched, KEYS[:4])
        sched.replace_producers([Level(2.0)])
        sched.invalidate({"a": codes(KEYS[:4])})
        for _ in range(16):                   # the view asks for the first two only
            sched.collect()
            sched.request("a", KEYS[:2])
            sched.wait(5.0)
        assert not sched.stale("a")
        assert _resident(sched, "a") == {int(c): 2.0 for c in codes(KEYS[:2])}
    finally:
        sched.close()


def test_stale_tiles_are_made_again_nearest_first():
    gate = threading.Event()
    sched = TileScheduler(TileCache(1 << 20), [Level(1.0)])
    try:
        _made(sched, KEYS[:4])
        new = Level(2.0, gate)
        order = []
        produce = new.produce
        new.produce = lambda key, deps: (order.append(tuple(key)), produce(key, deps))[1]
        sched.replace_producers([new])
        stale = codes(KEYS[:4])
        sched.invalidate({"a": stale}, rank={"a": np.array([30.0, 0.0, 20.0, 10.0])})
        sched.max_starts = 4
        sched.request("a", KEYS[:4])          # all four queued before the worker starts one
        gate.set()
        _made(sched, KEYS[:4])
        rank = {tuple(k): r for k, r in zip(KEYS[:4].tolist(), (30.0, 0.0, 20.0, 10.0))}
        later = [rank[k] for k in order[1:]]   # (the first may be taken before all are queued)
        assert sorted(order) == sorted(rank) and later == sorted(later)
    finally:
        sched.close()


def test_stale_tiles_made_later_come_after_every_other_even_when_few_are_queued():
    # four stale tiles: two at level 2 (a cut's leaves), two of level 1 and 0 (their
    # ancestors, made ``later``); the frame queues one new tile at a time (max_starts = 1),
    # so the one it picks decides the order: the leaves, nearest first, then the ancestors,
    # never coarse first as missing tiles are, though an ancestor is nearer the change
    keys = np.array([[2, 0, 0], [2, 1, 1], [1, 0, 0], [0, 0, 0]], np.int32)
    sched = TileScheduler(TileCache(1 << 20), [Level(1.0)])
    try:
        _made(sched, keys)
        new = Level(2.0)
        order = []
        produce = new.produce
        new.produce = lambda key, deps: (order.append(tuple(key)), produce(key, deps))[1]
        sched.replace_producers([new])
        stale = codes(keys)
        sched.invalidate({"a": stale}, rank={"a": np.array([5.0, 1.0, 0.0, 3.0])},
                         later={"a": stale[2:]})
        sched.max_starts = 1
        for _ in range(50):
            sched.collect()
            sched.request("a", keys)
            sched.wait(5.0)
            if len(order) == 4:
                break
        assert order == [(2, 1, 1), (2, 0, 0), (1, 0, 0), (0, 0, 0)]
    finally:
        sched.close()


def test_the_stale_tiles_places_looked_up_at_once_are_their_places_one_by_one():
    """A frame queues its stale tiles in the order of their places looked up at once (the
    table :meth:`invalidate` makes); each equals the place worked out one tile at a time
    (rank, made later, the kinds asked first), also for a tile left standing in by an earlier
    edit, which has no rank in the latest one."""
    sched = TileScheduler(TileCache(1 << 20), [Level(1.0), Twice()])
    try:
        _made(sched)
        sched.replace_producers([Level(2.0), Twice()])
        stale = codes(KEYS)
        sched.invalidate({"a": stale[:10], "b": stale}, first=("b",))
        rng = np.random.default_rng(3)
        sched.invalidate({"a": stale[4:], "b": stale[::2]}, first=("a",),
                         rank={"a": rng.uniform(0, 50, 12), "b": rng.uniform(0, 50, 8)},
                         later={"a": stale[10:13], "b": stale[:4:2]})
        for kind in ("a", "b"):
            many = sched._stale_priorities(kind, stale)
            one = [sched._stale_priority(kind, c) for c in stale.tolist()]
            assert many.tolist() == one
        assert len(set(sched._stale_priorities("a", stale[4:]).tolist())) > 3
    finally:
        sched.close()

