"""Tile tables: open-addressing hash tables from a tile's quadtree key to a pool slot.

A tile key (level, tx, ty) packs into one int64 *code* (:func:`tile_code`): level in bits
56–62, ty in bits 28–55, tx in bits 0–27, so levels go to 27 and a level has up to 2²⁸ tiles
per side (a 1000 km root square at level 27 has 7.5 mm tiles). A table is two arrays of a
power-of-two length H: ``keys`` (H,) int64 (``EMPTY`` where free) and ``values`` (H,) int32,
plus ``meta`` (1,) int64 holding the number of entries. Linear probing; deletion shifts the
following entries back (no tombstones), so a lookup never walks past the first empty entry and
the table never degrades. Every function here is twinned by a Python dict in the tests.

The tables replace the dense per-level slot arrays of the flow cache (4^level entries per
level: 4 MB at level 10, impossible at level 15), so the quadtree has no depth limit.
"""
from __future__ import annotations

import numpy as np
from numba import njit

from riverflow.kernels._jit import JIT_OPTIONS

EMPTY = -1
"""``keys`` entry of a free place."""
NOT_FOUND = -1
"""What :func:`table_find` returns for a key not in the table."""
MAX_LEVEL = 27
"""Deepest level a code can hold."""
TILE_BITS = 28
_TILE_MASK = (1 << TILE_BITS) - 1
_MIX = np.uint64(0x9E3779B97F4A7C15)


@njit(inline="always", **JIT_OPTIONS)
def tile_code(level, tx, ty):
    """The int64 code of tile (level, tx, ty)."""
    return (np.int64(level) << 56) | (np.int64(ty) << 28) | np.int64(tx)


@njit(inline="always", **JIT_OPTIONS)
def code_level(code):
    return np.int64(code >> 56)


@njit(inline="always", **JIT_OPTIONS)
def code_tx(code):
    return np.int64(code & _TILE_MASK)


@njit(inline="always", **JIT_OPTIONS)
def code_ty(code):
    return np.int64((code >> 28) & _TILE_MASK)


@njit(inline="always", **JIT_OPTIONS)
def _home(code, mask):
    """Fibonacci hashing: the high bits of code × 2⁶⁴/φ, folded into the table."""
    h = np.uint64(code) * _MIX
    return np.int64((h >> np.uint64(32)) ^ (h & np.uint64(0xFFFFFFFF))) & mask


@njit(inline="always", **JIT_OPTIONS)
def table_find(keys, values, code):
    """The value stored for ``code``, or NOT_FOUND."""
    mask = keys.shape[0] - 1
    i = _home(code, mask)
    while True:
        k = keys[i]
        if k == code:
            return values[i]
        if k == EMPTY:
            return NOT_FOUND
        i = (i + 1) & mask


@njit(**JIT_OPTIONS)
def table_insert(keys, values, meta, code, value):
    """Store ``value`` for ``code`` (replacing any). Returns False (nothing stored) when the
    table would be more than half full: the caller grows it (:func:`table_rehash`)."""
    mask = keys.shape[0] - 1
    i = _home(code, mask)
    while True:
        k = keys[i]
        if k == code:
            values[i] = value
            return True
        if k == EMPTY:
            if 2 * (meta[0] + 1) > keys.shape[0]:
                return False
            keys[i] = code
            values[i] = value
            meta[0] += 1
            return True
        i = (i + 1) & mask


@njit(**JIT_OPTIONS)
def table_remove(keys, values, meta, code):
    """Remove ``code``; returns its value, or NOT_FOUND if it was not there. The entries after
    it in its probe run move back so that no lookup stops early."""
    mask = keys.shape[0] - 1
    i = _home(code, mask)
    while True:
        k = keys[i]
        if k == EMPTY:
            return NOT_FOUND
        if k == code:
            break
        i = (i + 1) & mask
    found = values[i]
    meta[0] -= 1
    j = i
    while True:
        j = (j + 1) & mask
        k = keys[j]
        if k == EMPTY:
            break
        home = _home(k, mask)
        # k may fill the hole at i unless its home lies cyclically in (i, j]
        if (j > i and (home <= i or home > j)) or (j < i and home <= i and home > j):
            keys[i] = k
            values[i] = values[j]
            i = j
    keys[i] = EMPTY
    values[i] = NOT_FOUND
    return found


@njit(**JIT_OPTIONS)
def table_rehash(keys, values, new_keys, new_values, new_meta):
    """Copy every entry into an empty (larger) table."""
    new_keys[:] = EMPTY
    new_values[:] = NOT_FOUND
    new_meta[0] = 0
    for i in range(keys.shape[0]):
        if keys[i] != EMPTY:
            table_insert(new_keys, new_values, new_meta, keys[i], values[i])


@njit(**JIT_OPTIONS)
def table_find_many(keys, values, codes, out):
    """``out[k] = table_find(codes[k])`` for every k."""
    for k in range(codes.shape[0]):
        out[k] = table_find(keys, values, codes[k])


@njit(**JIT_OPTIONS)
def codes_of(key_rows, out):
    """Codes of (K, 3) int (level, tx, ty) rows into ``out`` (K,) int64."""
    for k in range(key_rows.shape[0]):
        out[k] = tile_code(key_rows[k, 0], key_rows[k, 1], key_rows[k, 2])


@njit(**JIT_OPTIONS)
def mark_used(keys, values, codes, n, last_used, tick, out_missing):
    """Of the tiles ``codes[:n]``: stamp the ones in the table (value = pool slot) used at
    ``tick`` in ``last_used`` (P,) int64, and copy the others to ``out_missing``; returns how
    many are missing."""
    m = 0
    for k in range(n):
        slot = table_find(keys, values, codes[k])
        if slot >= 0:
            last_used[slot] = tick
        else:
            out_missing[m] = codes[k]
            m += 1
    return m


@njit(**JIT_OPTIONS)
def table_insert_many(keys, values, meta, codes, vals):
    """Insert ``codes[k] → vals[k]`` in order; returns how many went in before the table
    would have been more than half full (the caller grows it and goes on from there)."""
    for k in range(codes.shape[0]):
        if not table_insert(keys, values, meta, codes[k], vals[k]):
            return k
    return codes.shape[0]
