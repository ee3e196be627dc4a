"""standins (tiles/cut.py) against a plain twin, on random cuts over random pools; the pool
slots and codes that come with them."""
from __future__ import annotations

import numpy as np

from riverflow.tiles.cache import TilePool
from riverflow.tiles.cut import standin_tiles, standins
from riverflow.tiles.table import codes


def _standins_twin(cut, pool, skip=None) -> np.ndarray:
    """Each leaf's own tile or its finest resident ancestor (none for a skipped leaf or one
    with none), distinct, without those another listed tile contains; (level, tx, ty) order."""
    resident = set(pool.codes().tolist())
    found = set()
    for k, (level, tx, ty) in enumerate(np.asarray(cut).tolist()):
        if skip is not None and skip[k]:
            continue
        while level >= 0:
            if int(codes(np.array([[level, tx, ty]]))[0]) in resident:
                found.add((level, tx, ty))
                break
            level, tx, ty = level - 1, tx >> 1, ty >> 1
    kept = [t for t in found
            if not any((t[0] - u, t[1] >> u, t[2] >> u) in found for u in range(1, t[0] + 1))]
    return np.array(sorted(kept), np.int32).reshape(-1, 3)


def _random_case(rng, depth: int):
    leaves = set()
    while len(leaves) < 40:                     # random leaves of a quadtree of some depth
        level = int(rng.integers(2, depth + 1))
        leaves.add((level, int(rng.integers(0, 2 ** level)), int(rng.integers(0, 2 ** level))))
    cut = np.array(sorted(leaves), np.int32)
    pool = TilePool("t", capacity=8)
    for level, tx, ty in cut.tolist():          # each leaf's tile or an ancestor, or nothing
        up = int(rng.integers(0, level + 2))
        if up <= level:
            pool.store(int(codes(np.array([[level - up, tx >> up, ty >> up]]))[0]), object(), 1)
    return cut, pool


def test_standins_match_the_twin(rng):
    for depth in (3, 6, 12, 20):
        for _ in range(20):
            cut, pool = _random_case(rng, depth)
            skip = rng.random(len(cut)) < 0.2
            for s in (None, skip):
                got = standins(cut, pool, s)
                assert got.dtype == np.int32 and got.shape[1:] == (3,)
                np.testing.assert_array_equal(got, _standins_twin(cut, pool, s))


def test_standins_of_nothing():
    pool = TilePool("t", capacity=8)
    assert standins(np.zeros((0, 3), np.int32), pool).shape == (0, 3)
    assert standins(np.array([[3, 1, 2]], np.int32), pool).shape == (0, 3)


def test_standin_slots_and_codes_are_those_of_the_keys(rng):
    for depth in (3, 12):
        for _ in range(10):
            cut, pool = _random_case(rng, depth)
            for _ in range(3):          # some tiles released: slots freed and reused
                victims = [c for c in pool.codes().tolist() if rng.random() < 0.3]
                for c in victims:
                    pool.release(pool.slot(c))
                for c in victims[: len(victims) // 2]:
                    pool.store(c, object(), 1)
                got = standin_tiles(cut, pool)
                np.testing.assert_array_equal(got.keys, _standins_twin(cut, pool))
                np.testing.assert_array_equal(got.codes, codes(got.keys))
                assert got.slots.tolist() == [pool.slot(c) for c in got.codes.tolist()]
                assert (got.slots >= 0).all()


def test_with_ancestors_of_a_mixed_level_cut_is_exactly_the_keys_parents_chains(rng):
    """A view's cut holds leaves of many levels; each one's ancestors are taken from its own
    level (no tile that is not above some leaf: they were made, for nothing, near the map's
    origin corner)."""
    from riverflow.tiles.coverage import with_ancestors
    from riverflow.tiles.quadtree import parent
    from riverflow.tiles.table import code_key, codes, tile_code

    levels = rng.integers(0, 15, 200)
    keys = np.stack([levels, rng.integers(0, 1 << levels), rng.integers(0, 1 << levels)], 1)
    twin = set()
    for key in map(tuple, keys.tolist()):
        while key is not None:
            twin.add(key)
            key = parent(key)
    got = with_ancestors(codes(keys.astype(np.int32)))
    assert [code_key(int(c)) for c in got] == sorted(twin, key=lambda k: tile_code(*k))
    assert len(with_ancestors(np.zeros(0, np.int64))) == 0


def test_unique_codes_is_numpys_unique(rng):
    """The tile tables' sort-based unique (numpy's hashed one collides on tile codes) against
    np.unique: codes of every level, repeated and shuffled, and the empty and single cases."""
    from riverflow.tiles.coverage import unique_codes
    from riverflow.tiles.table import codes

    for n in (0, 1, 2, 3000):
        levels = rng.integers(0, 29, n)
        keys = np.stack([levels, rng.integers(0, 1 << np.minimum(levels, 6)),
                         rng.integers(0, 1 << levels)], 1)
        c = codes(keys.astype(np.int32))
        c = rng.permutation(np.concatenate([c, c[::3], c[:1]]))
        got = unique_codes(c)
        assert got.dtype == np.int64
        np.testing.assert_array_equal(got, np.unique(c))


def test_near_to_far_is_numpys_stable_argsort_of_the_same_distances():
    """The draw system's tile order (kernels.tile_cut.near_to_far) against its numpy twin,
    bit for bit: random centres, with repeated ones and ties in distance (kept in their
    given order), and centres far from the origin."""
    from riverflow.kernels.tile_cut import near_to_far
    rng = np.random.default_rng(7)
    for k in (0, 1, 2, 40, 300):
        centres = rng.normal(0.0, 2000.0, (k, 3)) + rng.choice([0.0, 3.0e5], (k, 1))
        if k > 2:
            centres[rng.integers(0, k, k // 3)] = centres[0]          # ties
            centres[1] = 2 * rng.normal(0.0, 1.0, 3)                  # and a mirror image:
        eye = rng.normal(0.0, 2000.0, 3)
        if k > 2:
            centres[2] = 2 * eye - centres[1]                          # the same distance
        slots = rng.permutation(4 * k + 1)[:k].astype(np.int32)
        d = centres - eye
        d *= d
        want = slots[np.argsort(d.sum(axis=1), kind="stable")]
        got = np.full(k, -1, np.int32)
        near_to_far(slots, np.ascontiguousarray(centres), eye, got)
        assert np.array_equal(got, want), k


def _coarser_neighbours_twin(keys):
    """Plain Python twin of kernels.tile_cut.coarser_across (scenes.meshes.coarser_neighbours
    as it was written first): dicts and sets of (level, tx, ty)."""
    from riverflow.scenes.meshes import EDGE_OFFSETS
    rows = {k: r for r, k in enumerate(map(tuple, np.asarray(keys, np.int64).tolist()))}
    split = set()
    for level, tx, ty in rows:
        for up in range(1, level + 1):
            split.add((level - up, tx >> up, ty >> up))
    out = np.full((len(rows), 4), -1, np.int64)
    for (level, tx, ty), r in rows.items():
        side = 1 << level
        for e, (dx, dy) in enumerate(EDGE_OFFSETS):
            x, y = tx + dx, ty + dy
            if not (0 <= x < side and 0 <= y < side) or (level, x, y) in rows \
                    or (level, x, y) in split:
                continue
            for up in range(1, level + 1):
                found = rows.get((level - up, x >> up, y >> up))
                if found is not None:
                    out[r, e] = found
                    break
    return out


def _random_cut(rng, depth: int) -> list[tuple[int, int, int]]:
    """The leaves of a random quadtree down to ``depth`` levels."""
    leaves, todo = [], [(0, 0, 0)]
    while todo:
        level, tx, ty = todo.pop()
        if level < depth and (level < 2 or rng.random() < 0.6):
            todo += [(level + 1, 2 * tx + i, 2 * ty + j) for i in (0, 1) for j in (0, 1)]
        else:
            leaves.append((level, tx, ty))
    return leaves


def test_coarser_neighbours_match_the_twin(rng):
    """The coarser tile across each edge (numba, binary searches) as the Python twin finds
    it: 30 random cuts down to 3-7 levels, whole, thinned (tiles not drawn) and shuffled."""
    from riverflow.scenes.meshes import coarser_neighbours
    found = 0
    for k in range(30):
        leaves = _random_cut(rng, int(rng.integers(3, 8)))
        keys = np.array(leaves, np.int64)
        if k % 3 == 1:
            keys = keys[rng.random(len(keys)) < 0.7]
        rng.shuffle(keys)
        got = coarser_neighbours(keys)
        np.testing.assert_array_equal(got, _coarser_neighbours_twin(keys))
        found += int((got >= 0).sum())
    assert found > 100
    assert coarser_neighbours(np.zeros((0, 3), np.int64)).shape == (0, 4)
    np.testing.assert_array_equal(coarser_neighbours([[0, 0, 0]]), [[-1, -1, -1, -1]])


def _edge_parts_twin(keys, across, aslots, lut_counts, lut_offsets, counts, offsets):
    """Plain numpy twin of kernels.tile_cut.edge_parts (the draw system's gathers as they
    were written first): level differences, clamped, looked up by (difference, edge)."""
    level = keys[:, 0]
    up = np.where(across >= 0, level[:, None] - level[np.maximum(across, 0)], 0)
    kk = np.minimum(up, len(lut_counts) - 1)
    e4 = np.arange(4)
    counts[aslots, :, 1:] = lut_counts[kk, e4].transpose(0, 2, 1)
    offsets[aslots, :, 1:] = lut_offsets[kk, e4].transpose(0, 2, 1)
    return int(up.max(initial=0))


def test_edge_parts_match_the_twin(rng):
    """Each drawn tile's edge index ranges (numba, one pass) as the numpy twin picks them,
    into the rows of the tiles' arena slots, with the largest level difference: 20 random
    cuts (some thinned, so that neighbours 2+ levels coarser occur), tables with fewer
    levels than the cut's differences (clamped); rows of other slots untouched."""
    from riverflow.kernels.tile_cut import EdgeParts, coarser_across, edge_parts
    worst_seen = 0
    for k in range(20):
        leaves = _random_cut(rng, int(rng.integers(3, 8)))
        keys = np.array(leaves, np.int64)
        if k % 2:
            keys = keys[rng.random(len(keys)) < 0.6]
        rng.shuffle(keys)
        across = np.empty((len(keys), 4), np.int64)
        coarser_across(keys, across)
        u, meshes, slots = int(rng.integers(2, 5)), 3, 3 * len(keys) + 2
        lut_counts = rng.integers(0, 1000, (u, 4, meshes)).astype(np.int32)
        lut_offsets = rng.integers(0, 10**6, (u, 4, meshes)).astype(np.int64)
        aslots = rng.permutation(slots)[:len(keys)].astype(np.int32)
        counts = rng.integers(0, 9, (slots, meshes, 5)).astype(np.int32)
        offsets = rng.integers(0, 9, (slots, meshes, 5)).astype(np.int64)
        want_c, want_o = counts.copy(), offsets.copy()
        want = _edge_parts_twin(keys, across, aslots, lut_counts, lut_offsets, want_c, want_o)
        got = edge_parts(keys, across, aslots,
                         EdgeParts(lut_counts, lut_offsets, counts, offsets))
        assert got == want
        np.testing.assert_array_equal(counts, want_c)
        np.testing.assert_array_equal(offsets, want_o)
        worst_seen = max(worst_seen, got)
    assert worst_seen >= 3                  # beyond the smallest tables' last difference
