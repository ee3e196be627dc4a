"""FlowTileProducer: flow tiles made on demand, in a worker thread or in the frame.

Re-does Proland's ``TileProducer`` scheduling for the flow (``UpdateRiversTask`` asks the tiles
the camera sees; reference §3.4). In ``background`` mode a daemon thread builds the tiles
(the numba kernels release the GIL, so it runs beside the frame on another core) and
:meth:`collect` installs the finished ones at the start of a frame: no frame ever waits for a
tile. In ``blocking`` mode :meth:`request` builds them at once: slower frames, but a scripted
run is deterministic.
"""
from __future__ import annotations

import queue
import threading
from collections import deque
from collections.abc import Iterable

import numpy as np

from riverflow.hydro.flow_field import FlowField, TileBuilder
from riverflow.kernels.view_tiles import mark_tiles_used

TileKey = tuple[int, int, int]
"""(level, tx, ty)."""


class FlowTileProducer:
    """Keeps the requested flow tiles of a :class:`FlowField` coming."""

    def __init__(self, field: FlowField, mode: str = "background") -> None:
        if mode not in ("background", "blocking"):
            raise ValueError(f"mode must be 'background' or 'blocking', got {mode!r}")
        self.field = field
        self.mode = mode
        self._pending: set[TileKey] = set()
        self._todo: queue.Queue[TileKey | None] = queue.Queue()
        self._done: deque[tuple] = deque()  # appends and pops are atomic: no lock, no raise
        self._thread: threading.Thread | None = None
        self._missing = np.empty((0, 3), np.int32)
        self.requested = 0
        """Tiles asked for (not yet cached) since the start."""

    def request(self, keys: Iterable[TileKey] | np.ndarray) -> int:
        """Ask for tiles, (level, tx, ty) each (an (N, 3) int array is fastest: the frame's
        view asks for every visible tile each frame); returns how many were not cached yet.
        Cached ones are marked used."""
        field = self.field
        tiles = field.tiles
        tiles.tick += 1
        keys = np.ascontiguousarray(np.asarray(keys, np.int32).reshape(-1, 3))
        if len(self._missing) < len(keys):
            self._missing = np.empty((len(keys), 3), np.int32)
        m = mark_tiles_used(keys, len(keys), tiles.slots_flat, tiles.level_offset,
                            tiles.last_used, tiles.tick, self._missing)
        missing: list[TileKey] = [key for key in map(tuple, self._missing[:m].tolist())
                                  if key not in self._pending]
        self.requested += len(missing)
        if self.mode == "blocking":
            by_level: dict[int, list[tuple[int, int]]] = {}
            for level, tx, ty in missing:
                by_level.setdefault(level, []).append((tx, ty))
            for level, k in by_level.items():
                for start in range(0, len(k), tiles.capacity):
                    field.ensure_tiles(level, k[start:start + tiles.capacity])
            return len(missing)
        self._start()
        for key in missing:
            self._pending.add(key)
            self._todo.put(key)
        return len(missing)

    def collect(self) -> int:
        """Install the tiles the worker finished (main thread, start of a frame)."""
        installed = 0
        while self._done:
            key, arrays = self._done.popleft()
            self._pending.discard(key)
            installed += self.field.install_tile(*key, *arrays)
        return installed

    @property
    def pending(self) -> int:
        return len(self._pending)

    def wait(self, timeout_s: float = 30.0) -> None:
        """Block until every requested tile is built and installed (tests, loading screens)."""
        import time

        end = time.perf_counter() + timeout_s
        while self._pending and time.perf_counter() < end:
            self.collect()
            if self._pending:
                time.sleep(0.001)
        self.collect()

    def close(self) -> None:
        """Stop the worker thread."""
        if self._thread is not None:
            self._todo.put(None)
            self._thread.join(timeout=5.0)
            self._thread = None

    def _start(self) -> None:
        if self._thread is None:
            self._thread = threading.Thread(target=self._work, name="riverflow-flow-tiles",
                                            daemon=True)
            self._thread.start()

    def _work(self) -> None:
        builder = TileBuilder(self.field)
        while True:
            key = self._todo.get()
            if key is None:
                return
            psi, status, segments = builder.outputs()
            inside = builder.build(*key, psi, status, segments)
            self._done.append((key, (psi, status, segments, inside)))
