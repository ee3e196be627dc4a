"""Tile tables (numba hash tables) against a Python dict, and the key packing."""
from __future__ import annotations

import numpy as np
import pytest

from riverflow.kernels import tile_table as kt
from riverflow.tiles.table import TileTable, code_key, codes, tile_code


def test_table_matches_a_dict_through_random_inserts_and_removals():
    rng = np.random.default_rng(0)
    table, twin = TileTable(4), {}
    for _ in range(60_000):
        code = int(rng.integers(0, 2000))
        op = rng.random()
        if op < 0.5:
            value = int(rng.integers(0, 1000))
            table.set(code, value)
            twin[code] = value
        elif op < 0.8:
            assert table.pop(code) == twin.pop(code, kt.NOT_FOUND)
        else:
            assert table.get(code) == twin.get(code, kt.NOT_FOUND)
    assert len(table) == len(twin)
    assert dict(table.items()) == twin
    probe = np.arange(2000, dtype=np.int64)
    assert table.find_many(probe).tolist() == [twin.get(c, -1) for c in probe.tolist()]


def test_set_many_grows_and_keeps_every_entry():
    table = TileTable(1)
    keys = np.arange(0, 30_000, 7, dtype=np.int64) << 28
    table.set_many(keys, np.arange(len(keys)))
    assert len(table) == len(keys)
    assert np.array_equal(table.find_many(keys), np.arange(len(keys)))
    assert len(table.keys) >= 2 * len(keys)


def test_codes_pack_and_unpack():
    rows = np.array([[0, 0, 0], [3, 5, 7], [27, (1 << 28) - 1, 12345]])
    packed = codes(rows)
    assert [code_key(c) for c in packed.tolist()] == [tuple(r) for r in rows.tolist()]
    assert packed.tolist() == [tile_code(*r) for r in rows.tolist()]
    assert len(set(packed.tolist())) == 3
    with pytest.raises(ValueError):
        tile_code(28, 0, 0)
    with pytest.raises(ValueError):
        tile_code(3, -1, 0)


def test_mark_used_stamps_resident_tiles_and_lists_the_rest():
    table = TileTable()
    table.set(tile_code(2, 1, 1), 4)
    last_used = np.zeros(8, np.int64)
    wanted = codes([[2, 1, 1], [2, 0, 1], [5, 3, 3]])
    out = np.empty(3, np.int64)
    m = kt.mark_used(table.keys, table.values, wanted, 3, last_used, 9, out)
    assert m == 2 and out[:2].tolist() == wanted[1:].tolist()
    assert last_used[4] == 9 and last_used.sum() == 9
