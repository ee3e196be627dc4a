"""TilePool and TileCache: where tiles live, under one memory budget (SPEC §8).

A **TilePool** holds the resident tiles of one kind. Kinds that kernels read store each tile in
a *slot* of fixed-shape arrays (``pool.arrays[name][slot]``; ``pool.table`` maps a tile's code
to its slot, for numba); other kinds (meshes) keep one Python object per slot. A pool grows by
doubling when full; freed slots are reused.

The **TileCache** owns the pools of every kind and one byte budget: after tiles are installed
it evicts the least recently used ones, across kinds, until the tiles it holds fit the budget.
Tiles used in the current tick (the frame, or the query, that needs them) and tiles pinned by a
pending production are never evicted, so the view's working set always stays (the budget may
then be exceeded; ``over_budget`` says so). Eviction order is (last use, kind, code): it never
depends on which slot a tile happened to get.
"""
from __future__ import annotations

import mmap
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from riverflow.kernels import tile_table as kt
from riverflow.tiles.table import TileTable, code_key


@dataclass(frozen=True)
class FieldSpec:
    """One per-tile array of a pool: its shape (per tile), dtype and the value of free slots."""

    shape: tuple[int, ...]
    dtype: Any
    fill: Any = 0

    @property
    def nbytes(self) -> int:
        return int(np.prod(self.shape, dtype=np.int64)) * np.dtype(self.dtype).itemsize


def lazy_zeros(shape: tuple[int, ...], dtype) -> np.ndarray:
    """Zeros whose memory is committed page by page as it is first written, in plain 4 kB
    pages: an anonymous mmap advised MADV_NOHUGEPAGE. numpy advises transparent huge pages for
    large arrays, and on a kernel that honours the advice (``madvise`` mode) the first write to
    a pool slot could then stall on huge-page compaction: stores of 34 kB tiles took 10-20 ms in
    a frame (p99 of the install 8.9 ms, 0.7 ms with 4 kB pages)."""
    dtype = np.dtype(dtype)
    nbytes = int(np.prod(shape, dtype=np.int64)) * dtype.itemsize
    if nbytes < (1 << 21) or not hasattr(mmap, "MADV_NOHUGEPAGE"):
        return np.zeros(shape, dtype)
    buf = mmap.mmap(-1, nbytes)
    buf.madvise(mmap.MADV_NOHUGEPAGE)
    return np.frombuffer(buf, dtype).reshape(shape)


def tile_bytes(data) -> bytes:
    """A tile's content as bytes (arrays with their dtype and shape, dicts, sequences,
    dataclasses such as meshes, numbers): two versions of a tile are the same tile when these
    are equal (a live edit's kept tiles against fresh ones, in tests and benchmarks)."""
    import dataclasses

    if isinstance(data, np.ndarray):
        return data.dtype.str.encode() + str(data.shape).encode() + data.tobytes()
    if isinstance(data, dict):
        return b"|".join(k.encode() + b"=" + tile_bytes(v) for k, v in data.items())
    if isinstance(data, (tuple, list)):
        return b"(" + b"|".join(tile_bytes(v) for v in data) + b")"
    if dataclasses.is_dataclass(data):
        return tile_bytes({f.name: getattr(data, f.name) for f in dataclasses.fields(data)})
    return repr(data).encode()


class TilePool:
    """The resident tiles of one kind (module docstring)."""

    def __init__(self, kind: str, fields: Mapping[str, FieldSpec] | None = None,
                 capacity: int = 8) -> None:
        self.kind = kind
        self.fields = dict(fields) if fields else None
        self.capacity = 0
        self.arrays: dict[str, np.ndarray] = {}
        self.objects: list[Any] = []
        self.slot_code = np.zeros(0, np.int64)
        self.last_used = np.zeros(0, np.int64)
        self.pins = np.zeros(0, np.int32)
        self.slot_bytes = np.zeros(0, np.int64)
        self.table = TileTable(capacity)
        self.resident_bytes = 0
        self.installed = 0
        """Tiles installed so far."""
        self.evicted = 0
        self.revision = 0
        """Changes on every install and release (systems sync against it)."""
        self.grown = -1
        """Times the pool grew after it was made."""
        self._free: list[int] = []
        self._grow(max(int(capacity), 1))

    # -- slots ---------------------------------------------------------------------------------

    @property
    def tile_bytes(self) -> int:
        """Bytes of one array tile (0 for object kinds: each says its own)."""
        return sum(f.nbytes for f in self.fields.values()) if self.fields else 0

    def __len__(self) -> int:
        return len(self.table)

    def slot(self, code: int) -> int:
        """The slot of a resident tile, or −1."""
        return self.table.get(code)

    def __contains__(self, code: int) -> bool:
        return self.table.get(code) >= 0

    def tile(self, slot: int):
        """A resident tile's data: {field: view} for array kinds, the object otherwise."""
        if self.fields is None:
            return self.objects[slot]
        return {name: arr[slot] for name, arr in self.arrays.items()}

    def get(self, code: int):
        """A resident tile's data (:meth:`tile`), or None."""
        slot = self.table.get(code)
        return None if slot < 0 else self.tile(slot)

    def codes(self) -> np.ndarray:
        """Codes of the resident tiles, (T,) int64, in slot order."""
        return self.slot_code[self.slot_code >= 0].copy()

    def keys(self) -> list[tuple[int, int, int]]:
        return [code_key(c) for c in self.codes().tolist()]

    def store(self, code: int, data, nbytes: int | None = None, tick: int = 0) -> int:
        """Install a tile (array kinds: a mapping or tuple of arrays in field order, copied;
        object kinds: the object, ``nbytes`` its size). Returns its slot; a tile already
        resident keeps its slot and data."""
        slot = self.table.get(code)
        if slot >= 0:
            return slot
        if not self._free:
            self._grow(2 * self.capacity)
        slot = self._free.pop()
        if self.fields is None:
            self.objects[slot] = data
            size = int(nbytes or 0)
        else:
            values = data.values() if isinstance(data, Mapping) else data
            for arr, value in zip(self.arrays.values(), values, strict=True):
                arr[slot] = value
            size = self.tile_bytes
        self.table.set(code, slot)
        self.slot_code[slot] = code
        self.last_used[slot] = tick
        self.slot_bytes[slot] = size
        self.resident_bytes += size
        self.installed += 1
        self.revision += 1
        return slot

    def replace(self, code: int, data, nbytes: int | None = None, tick: int = 0) -> int:
        """Install the new version of a resident tile (a live edit) in another slot and release
        the old one, so that whoever keeps per-slot copies (the draw system's GPU buffers)
        sees the slot's tile change; a tile not resident is stored. Returns its slot."""
        old = self.table.get(code)
        if old < 0:
            return self.store(code, data, nbytes, tick)
        if not self._free:
            self._grow(2 * self.capacity)
        slot = self._free.pop()
        self.release(old, fill=False)    # not read again: its arrays are left as they are
        self._free.remove(old)
        self._free.append(slot)          # store() takes the last free slot: this one
        slot = self.store(code, data, nbytes, tick)
        self._free.append(old)
        return slot

    def release(self, slot: int, fill: bool = True) -> None:
        """Drop the tile in ``slot`` (``fill``: its arrays get their free value; a free slot
        is never read, kernels reach slots through the table)."""
        code = int(self.slot_code[slot])
        if code < 0:
            return
        self.table.pop(code)
        self.slot_code[slot] = -1
        self.resident_bytes -= int(self.slot_bytes[slot])
        self.slot_bytes[slot] = 0
        self.pins[slot] = 0
        if self.fields is None:
            self.objects[slot] = None
        elif fill:
            for name, spec in self.fields.items():
                self.arrays[name][slot] = spec.fill
        self._free.append(slot)
        self.evicted += 1
        self.revision += 1

    def clear(self) -> None:
        for slot in np.flatnonzero(self.slot_code >= 0).tolist():
            self.release(slot)

    def mark_used(self, codes: np.ndarray, tick: int) -> np.ndarray:
        """Stamp the resident tiles of ``codes`` used at ``tick``; returns the missing codes."""
        codes = np.ascontiguousarray(codes, np.int64)
        missing = np.empty(len(codes), np.int64)
        m = kt.mark_used(self.table.keys, self.table.values, codes, len(codes), self.last_used,
                         tick, missing)
        return missing[:m]

    def _grow(self, capacity: int) -> None:
        """Room for ``capacity`` tiles. New slots are not filled (a free slot is never read:
        kernels reach slots through the table) and their memory is only committed when a tile
        is stored there (``np.zeros``: pages mapped on first write), so a pool can be made as
        large as the budget allows without costing RSS; growing later copies every array,
        which in a frame is a stall (TileCache.pool sizes pools up front)."""
        old = self.capacity
        if self.fields is not None:
            for name, spec in self.fields.items():
                arr = lazy_zeros((capacity, *spec.shape), spec.dtype)
                if old:
                    arr[:old] = self.arrays[name]
                self.arrays[name] = arr
        self.objects.extend([None] * (capacity - old))
        self.slot_code = np.concatenate([self.slot_code, np.full(capacity - old, -1, np.int64)])
        self.last_used = np.concatenate([self.last_used, np.zeros(capacity - old, np.int64)])
        self.pins = np.concatenate([self.pins, np.zeros(capacity - old, np.int32)])
        self.slot_bytes = np.concatenate([self.slot_bytes, np.zeros(capacity - old, np.int64)])
        self._free.extend(range(capacity - 1, old - 1, -1))  # lowest slot first
        self.capacity = capacity
        self.revision += 1
        self.grown += 1

    def __getattr__(self, name: str) -> np.ndarray:
        arrays = self.__dict__.get("arrays")
        if arrays is not None and name in arrays:
            return arrays[name]
        raise AttributeError(f"{type(self).__name__} {self.__dict__.get('kind')!r} has no "
                             f"field {name!r}")

    @property
    def allocated_bytes(self) -> int:
        arrays = sum(a.nbytes for a in self.arrays.values())
        return int(arrays + (self.resident_bytes if self.fields is None else 0)
                   + self.table.nbytes + 28 * self.capacity)


MAX_PREALLOCATED = 4096
"""Most slots a pool is made with (tiles of one kind past that grow the pool)."""


class TileCache:
    """The pools of every tile kind under one byte budget (module docstring)."""

    def __init__(self, budget_bytes: int = 512 << 20) -> None:
        if not budget_bytes > 0:
            raise ValueError(f"TileCache: budget_bytes must be positive, got {budget_bytes!r}")
        self.budget_bytes = int(budget_bytes)
        self.pools: dict[str, TilePool] = {}
        self.tick = 1

    def pool(self, kind: str, fields: Mapping[str, FieldSpec] | None = None,
             capacity: int | None = None) -> TilePool:
        """The pool of ``kind`` (made on first use with ``fields``). Array kinds get room for
        as many tiles as the budget holds (at most MAX_PREALLOCATED; the memory is committed
        only as tiles arrive), so a pool does not grow, copying every array, in a frame."""
        pool = self.pools.get(kind)
        if pool is None:
            if capacity is None:
                capacity = 8
                if fields:
                    tile = sum(f.nbytes for f in fields.values())
                    capacity = min(self.budget_bytes // max(tile, 1) + 16, MAX_PREALLOCATED)
            pool = self.pools[kind] = TilePool(kind, fields, capacity)
        return pool

    def next_tick(self) -> int:
        """Start a new use period (a frame, a query): tiles used in it stay resident."""
        self.tick += 1
        return self.tick

    def install(self, kind: str, code: int, data, nbytes: int | None = None) -> int:
        """Store a produced tile in its pool (used now), then keep within the budget."""
        slot = self.pools[kind].store(code, data, nbytes, self.tick)
        self.evict_to_budget()
        return slot

    @property
    def resident_bytes(self) -> int:
        return sum(p.resident_bytes for p in self.pools.values())

    @property
    def allocated_bytes(self) -> int:
        return sum(p.allocated_bytes for p in self.pools.values())

    @property
    def over_budget(self) -> bool:
        return self.resident_bytes > self.budget_bytes

    def evict_to_budget(self) -> int:
        """Evict least recently used tiles (not used this tick, not pinned) until the held
        tiles fit the budget; returns how many were evicted."""
        excess = self.resident_bytes - self.budget_bytes
        if excess <= 0:
            return 0
        rows = []
        for k, pool in enumerate(self.pools.values()):
            ok = np.flatnonzero((pool.slot_code >= 0) & (pool.last_used < self.tick)
                                & (pool.pins == 0))
            if len(ok):
                rows.append(np.stack([pool.last_used[ok], np.full(len(ok), k),
                                      pool.slot_code[ok], ok, pool.slot_bytes[ok]], 1))
        if not rows:
            return 0
        cand = np.concatenate(rows)
        cand = _oldest_first(cand, excess)
        # the shortest prefix that frees the excess (a big world has tens of thousands of
        # candidates: only the evicted ones are visited in Python)
        n = int(np.searchsorted(np.cumsum(cand[:, 4]), excess)) + 1
        pools = list(self.pools.values())
        for _, k, _, slot, _ in cand[:n].tolist():
            pools[k].release(slot)
        return min(n, len(cand))

    def clear(self) -> None:
        for pool in self.pools.values():
            pool.clear()

    def stats(self) -> dict[str, dict[str, int]]:
        """Per kind: resident tiles, resident bytes, installed and evicted so far."""
        return {kind: {"tiles": len(p), "bytes": p.resident_bytes, "installed": p.installed,
                       "evicted": p.evicted} for kind, p in self.pools.items()}


def _oldest_first(cand: np.ndarray, excess: int) -> np.ndarray:
    """The eviction candidates (rows: last use, kind, code, slot, bytes) that come first in
    (last use, kind, code) order, sorted, at least enough of them to free ``excess`` bytes
    (all of them when they do not). The same prefix as sorting them all, without sorting tens
    of thousands of rows to evict one or two: the rows used no later than the k-th oldest are
    picked in linear time (``k`` from the mean tile size, doubled until they free enough) and
    only those are sorted."""
    used = cand[:, 0]
    k = min(len(cand), 4 * int(excess // max(int(cand[:, 4].mean()), 1)) + 16)
    while k < len(cand):
        last = used[np.argpartition(used, k - 1)[k - 1]]
        head = cand[used <= last]
        if int(head[:, 4].sum()) >= excess:
            return head[np.lexsort((head[:, 2], head[:, 1], head[:, 0]))]
        k = min(len(cand), 2 * k)
    return cand[np.lexsort((cand[:, 2], cand[:, 1], cand[:, 0]))]
