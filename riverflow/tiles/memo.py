"""Tiles a scene's producers made, kept for every world over the scene (SPEC §8).

A tile depends only on its key and the scene's sources (:class:`~riverflow.tiles.scheduler.
Producer`), so two worlds over one scene — a level opened again, a second view of it, a
split screen, the next scripted run — would make the same tiles again: as in Proland, where
the views of one terrain share its producers' tile cache, a scene keeps the array tiles it
made (heights, water levels, ray-cast pyramids, hints: the carving is most of a first view's
time) in one :class:`TileMemo`, least recently used first out within a byte budget. Each
world still installs them in its own cache (copied into its pools), so what a world holds and
draws does not depend on the other worlds; only the time to make it does.
"""
from __future__ import annotations

import threading
from collections import OrderedDict
from collections.abc import Hashable, Mapping
from typing import Any

import numpy as np

DEFAULT_BUDGET_MB = 24.0
"""A memo's default budget: the first views of a scene (the built-in one's: ~300 height tiles
of 18 KB with their water, ray-cast and hint tiles) and some of a flight's around them; at
48 MB a 100 km flight's RSS grew by the whole 48 MB (bench_scale), for a second world that
mostly opens where the first one did."""


class BudgetMemo:
    """Values by key, least recently used first out once their sizes add up to more than
    ``budget`` (in the unit the sizes are given in); thread-safe. What a pure function made
    is kept by its inputs: :class:`TileMemo` (tiles, in bytes), the builder's strips and
    junction corners (:class:`riverflow.hydro._strips.GeometryMemo`, in coordinates)."""

    def __init__(self, budget: float) -> None:
        self.budget = budget
        self.used = 0
        self.hits = 0
        self.misses = 0
        self._kept: OrderedDict[Hashable, tuple[Any, int]] = OrderedDict()
        self._lock = threading.Lock()

    def __len__(self) -> int:
        return len(self._kept)

    def get(self, key: Hashable) -> Any:
        """The value kept under ``key``, or None."""
        with self._lock:
            entry = self._kept.get(key)
            if entry is None:
                self.misses += 1
                return None
            self._kept.move_to_end(key)
            self.hits += 1
            return entry[0]

    def keep(self, key: Hashable, value: Any, size: int) -> None:
        """Keep ``value`` of ``size`` under ``key`` (in place of what was there), dropping the
        least recently used beyond the budget; one larger than the whole budget is not kept."""
        if size > self.budget:
            return
        with self._lock:
            old = self._kept.pop(key, None)
            if old is not None:
                self.used -= old[1]
            self._kept[key] = (value, size)
            self.used += size
            while self.used > self.budget:
                _, (_, dropped) = self._kept.popitem(last=False)
                self.used -= dropped

    def clear(self) -> None:
        with self._lock:
            self._kept.clear()
            self.used = 0


class TileMemo(BudgetMemo):
    """Array tiles (a mapping or tuple of numpy arrays) by key, least recently used first out
    beyond ``budget_mb``; thread-safe (the tile worker fills it). What it keeps is made
    read-only: a tile is shared by every world that asks for it."""

    def __init__(self, budget_mb: float = DEFAULT_BUDGET_MB) -> None:
        if not budget_mb >= 0.0:
            raise ValueError(f"TileMemo: budget_mb must be >= 0, got {budget_mb!r}")
        super().__init__(int(budget_mb * 1e6))

    @property
    def budget_bytes(self) -> int:
        return self.budget

    @property
    def bytes(self) -> int:
        return self.used

    @property
    def _tiles(self) -> OrderedDict:
        return self._kept

    def put(self, key: Hashable, data: Any) -> None:
        """Keep ``data`` (its arrays become read-only) under ``key``, dropping the least
        recently used tiles beyond the budget; data that is not arrays is not kept."""
        arrays = list(data.values() if isinstance(data, Mapping) else
                      data if isinstance(data, (tuple, list)) else ())
        if not arrays or not all(isinstance(a, np.ndarray) for a in arrays):
            return
        size = sum(a.nbytes for a in arrays)
        if size > self.budget:
            return
        for a in arrays:
            a.flags.writeable = False
        self.keep(key, data, size)

    def __reduce__(self):
        """Pickled (a scene sent to another process): an empty memo of the same budget."""
        return (TileMemo, (self.budget_bytes / 1e6,))
