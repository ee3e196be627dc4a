"""TileTable: the Python face of a tile hash table (:mod:`riverflow.kernels.tile_table`).

Kernels read ``keys`` / ``values`` directly; Python code inserts, removes and looks up through
the methods, which grow the table (doubling, rehashed) before it is half full.
"""
from __future__ import annotations

import numpy as np

from riverflow.kernels import tile_table as kt


def tile_code(level: int, tx: int, ty: int) -> int:
    """The int64 code of (level, tx, ty) (same packing as the kernels)."""
    if not (0 <= level <= kt.MAX_LEVEL and 0 <= tx < (1 << kt.TILE_BITS)
            and 0 <= ty < (1 << kt.TILE_BITS)):
        raise ValueError(f"tile ({level}, {tx}, {ty}) is outside the quadtree's range")
    return (level << 56) | (ty << 28) | tx


def code_key(code: int) -> tuple[int, int, int]:
    """(level, tx, ty) of a code."""
    code = int(code)
    return code >> 56, code & ((1 << kt.TILE_BITS) - 1), (code >> 28) & ((1 << kt.TILE_BITS) - 1)


def codes(keys) -> np.ndarray:
    """(K,) int64 codes of (K, 3) (level, tx, ty) rows."""
    rows = np.ascontiguousarray(np.asarray(keys, np.int64).reshape(-1, 3))
    out = np.empty(len(rows), np.int64)
    kt.codes_of(rows, out)
    return out


class TileTable:
    """code → int32 value, for numba (``keys``, ``values``, ``meta``) and for Python."""

    def __init__(self, capacity: int = 64) -> None:
        size = 16
        while size < 2 * max(int(capacity), 1):
            size *= 2
        self.keys = np.full(size, kt.EMPTY, np.int64)
        self.values = np.full(size, kt.NOT_FOUND, np.int32)
        self.meta = np.zeros(1, np.int64)

    def __len__(self) -> int:
        return int(self.meta[0])

    def get(self, code: int) -> int:
        """The value of ``code`` or NOT_FOUND (−1)."""
        return int(kt.table_find(self.keys, self.values, np.int64(code)))

    def __contains__(self, code: int) -> bool:
        return self.get(code) != kt.NOT_FOUND

    def set(self, code: int, value: int) -> None:
        while not kt.table_insert(self.keys, self.values, self.meta, np.int64(code),
                                  np.int32(value)):
            self._grow()

    def set_many(self, codes_: np.ndarray, values: np.ndarray | int) -> None:
        """Store ``codes_[k] → values[k]`` (one value for all if scalar)."""
        codes_ = np.ascontiguousarray(codes_, np.int64)
        vals = np.empty(codes_.shape, np.int32)   # writable: a read-only broadcast view would
        vals[...] = values                         # be another signature for numba to compile
        done = 0
        while done < len(codes_):
            done += int(kt.table_insert_many(self.keys, self.values, self.meta, codes_[done:],
                                             vals[done:]))
            if done < len(codes_):
                self._grow()

    def pop(self, code: int) -> int:
        """Remove ``code``; its value, or NOT_FOUND."""
        return int(kt.table_remove(self.keys, self.values, self.meta, np.int64(code)))

    def clear(self) -> None:
        self.keys[:] = kt.EMPTY
        self.values[:] = kt.NOT_FOUND
        self.meta[0] = 0

    def items(self) -> list[tuple[int, int]]:
        used = np.flatnonzero(self.keys != kt.EMPTY)
        return list(zip(self.keys[used].tolist(), self.values[used].tolist()))

    def find_many(self, codes_: np.ndarray) -> np.ndarray:
        out = np.empty(len(codes_), np.int32)
        kt.table_find_many(self.keys, self.values, np.ascontiguousarray(codes_, np.int64), out)
        return out

    def _grow(self) -> None:
        size = 2 * len(self.keys)
        keys = np.empty(size, np.int64)
        values = np.empty(size, np.int32)
        meta = np.zeros(1, np.int64)
        kt.table_rehash(self.keys, self.values, keys, values, meta)
        self.keys, self.values, self.meta = keys, values, meta

    @property
    def nbytes(self) -> int:
        return int(self.keys.nbytes + self.values.nbytes)
