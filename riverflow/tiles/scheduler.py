"""Producers and the TileScheduler: tiles made on demand, in a worker thread or at once.

Re-does Proland's ``TileProducer`` + ``Scheduler`` (reference §2.2, §3.4) for every kind of
tile (SPEC §8). A :class:`Producer` makes the tiles of one kind from their key alone, possibly
reading tiles of other kinds (its :meth:`~Producer.dependencies`: the same key or its parent),
so a tile's content depends only on its key and the sources, never on what was made or evicted
before. The :class:`TileScheduler` takes requests (the tiles a frame needs), produces missing
dependencies first, and installs results into the :class:`~riverflow.tiles.cache.TileCache`:

* ``"background"``: one daemon worker thread produces (numba kernels and shapely release the
  GIL, so it runs beside the frame on another core) — or, with ``worker="process"``, hands
  each tile to a forked :class:`~riverflow.tiles.remote.ProducerProcess` and waits for it
  without the interpreter lock, so the producers' Python glue never delays a frame;
  :meth:`TileScheduler.collect` installs finished tiles at the start of a frame. A frame never waits: what is missing is read at a
  coarser level by whoever needs it. Coarse levels are made first; requests that no frame has
  repeated for ``stale_frames`` are dropped unmade (a fast flight leaves no backlog).
* ``"blocking"``: :meth:`TileScheduler.request` produces and installs at once.

Either way a frame can ask for its tiles to be *complete* (:meth:`TileScheduler.complete`: the
world does, with ``RiverConfig.deterministic``, the default): every tile it asked for is made
before the frame reads any, the ones the worker has not finished in the frame itself, so the
worker changes *when* and *where* a tile is made, never *what* a frame computes.

A resident dependency is pinned (never evicted) until the tile that reads it is installed.

The sources can change while tiles are made (a live edit of the river network:
:mod:`riverflow.engine.edits`): :meth:`TileScheduler.replace_producers` takes the new
producers and :meth:`TileScheduler.invalidate` starts a new *generation*: the resident tiles it
names become *stale*, standing in (read as before) until their new versions, made in the
background like any missing tile, replace them; every tile being made from the old sources is
dropped when it arrives, never stored, and never kept in the new producers' memo.
A producer that raises does not crash the frame: the error is kept in ``errors`` and that tile
is not asked for again.
"""
from __future__ import annotations

import contextlib
import itertools
import os
import queue
import sys
import threading
import time
import weakref
from collections import deque
from collections.abc import Hashable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from riverflow.tiles.cache import FieldSpec, TileCache
from riverflow.tiles.memo import TileMemo
from riverflow.kernels.tile_table import NOT_FOUND
from riverflow.tiles.quadtree import TileKey
from riverflow.tiles.remote import (WRITTEN_MAX_PAGES, ProducerProcess, TileProcessError,
                                    fork_available, forked, within, writable_regions,
                                    written_pages)
from riverflow.tiles.table import TileTable, code_key, codes as codes_of, tile_code

Dep = tuple[str, TileKey]
_PENDING = 1
_FAILED = 2
_LONG_AGO = -(1 << 30)
MAX_STARTS = 6
"""Default :attr:`TileScheduler.max_starts`: 6 new tiles of each kind a frame (360 a second
a kind) is still far more than the worker makes (60-110 tiles a second of all kinds at
1000 km), so the queue never runs dry; queuing more only made work for the frame (a job and
its dependencies set up in Python) for tiles that went stale unmade (half of those queued in
a 200 m/s flight with 16)."""
STALE_ELSEWHERE_FRAMES = 10
"""After a :meth:`TileScheduler.queue_stale` call that left stale tiles unqueued, the frames
leave them to the next call for this many frames (then queue them themselves again)."""
PAUSE_MIN_IDLE_S = 0.002
"""The worker process is paused in a frame only if the frame before left it this much idle
time (:attr:`TileScheduler.pause_in_frames`)."""
INSTALL_BUDGET_S = 0.0004
"""Default :attr:`TileScheduler.install_budget_s`: a frame copies at most ~0.4 ms of finished
tiles into the pools (a burst of a dozen tiles arriving together would otherwise cost a
millisecond or more in one frame; at 1000 km they come ~2 a frame on average)."""
GAP_WAIT_S = 0.1
"""Longest :meth:`TileScheduler.wait_gap` waits for a frame to end."""
IDLE_WAIT_S = 0.02
"""Longest a worker waits for the frame to end before starting a tile (a host that steps
back to back, with no idle time, still gets tiles made)."""
"""A wanted-frame stamp no frame is near (the tile is let go)."""
DEPENDENCY_WAIT_S = 5.0
"""A worker whose tile's dependency another worker is making waits for it this long at most
(then lets its tile go, to be asked again)."""
MAX_WORKERS = 4
"""Worker threads (and processes) "auto" gives at most (:func:`worker_count`)."""
FRAME_PAGES = 4096
"""At most this many pages (16 MiB; a 1080p frame writes ~1,700) are copied ahead of the
frames after a fork (:meth:`TileScheduler.learn_written`)."""
WORKER_NICE = int(os.environ.get("RIVERFLOW_WORKER_NICE", "19"))
"""The tile worker thread's nice value (19: the lowest priority; 0 keeps the frame's)."""


class Producer:
    """Makes the tiles of one kind. Subclasses set ``kind`` and ``fields`` (per-tile arrays
    that kernels read; None: one Python object per tile) and implement :meth:`produce`."""

    kind: str = "tile"
    fields: Mapping[str, FieldSpec] | None = None
    max_level: int = 0
    """Deepest level this kind is made at."""
    memo: TileMemo | None = None
    """Where the scene keeps the tiles of this kind for every world over it (array kinds
    only: :mod:`riverflow.tiles.memo`); None: each world makes its own."""
    memo_tag: Hashable = None
    """What else than the kind and key a tile depends on (a producer parameter)."""

    def dependencies(self, key: TileKey) -> Sequence[Dep]:
        """Tiles of other kinds this tile is made from (same key or its parent)."""
        return ()

    def is_empty(self, key: TileKey) -> bool:
        """True when the tile is known to hold nothing (it is never made; readers treat it as
        empty, not as missing)."""
        return False

    def empty_mask(self, codes: np.ndarray) -> np.ndarray:
        """(K,) bool: :meth:`is_empty` of each tile code (override with a vectorised test:
        the scheduler asks it every frame for the tiles a view needs that are not resident).
        A producer that does not override :meth:`is_empty` has no empty tile: no per-code
        Python call (at 1000 km a flight's frame asks this of hundreds of missing tiles)."""
        if type(self).is_empty is Producer.is_empty:
            return np.zeros(len(codes), bool)
        return np.fromiter((self.is_empty(code_key(c)) for c in codes.tolist()), bool,
                           len(codes))

    def produce(self, key: TileKey, deps: Mapping[Dep, Any]) -> Any:
        """The tile's content: for array kinds a mapping or tuple of arrays in ``fields``
        order, else any object. Must depend only on ``key``, ``deps`` and the sources. Runs in
        the worker thread in background mode."""
        raise NotImplementedError

    def nbytes(self, data: Any) -> int:
        """Bytes an object tile holds (array kinds: from their fields)."""
        return 0


@dataclass(eq=False)
class _Job:
    kind: str
    key: TileKey
    code: int
    resident: dict = field(default_factory=dict)   # dep → (pool, slot, data view), pinned
    awaited: list = field(default_factory=list)    # deps being produced by earlier jobs
    generation: int = 0                            # the sources it is made from


class TileScheduler:
    """Requests, production and installation of tiles of every kind (module docstring)."""

    def __init__(self, cache: TileCache, producers: Iterable[Producer] = (),
                 mode: str = "background", stale_frames: int = 30,
                 worker: str = "thread", pause_in_frames: bool | str = "auto",
                 workers: int | str = 1) -> None:
        if mode not in ("background", "blocking"):
            raise ValueError(f"mode must be 'background' or 'blocking', got {mode!r}")
        if worker not in ("thread", "process"):
            raise ValueError(f"worker must be 'thread' or 'process', got {worker!r}")
        self.cache = cache
        self.mode = mode
        self.worker = worker if worker == "thread" or fork_available() else "thread"
        """Where background tiles are made: "thread" (the worker thread itself) or "process"
        (a forked :class:`ProducerProcess` the worker thread hands them to; asked for where
        ``fork`` is not available, the thread)."""
        if pause_in_frames not in (True, False, "auto"):
            raise ValueError("pause_in_frames must be True, False or 'auto', "
                             f"got {pause_in_frames!r}")
        self.pause_in_frames = pause_in_frames
        self.workers = worker_count(workers)
        """Background mode: worker threads, each with its process (``worker="process"``),
        taking the queued tiles in turn (:func:`worker_count`)."""
        """With a worker process: stop it from :meth:`frame_begins` to :meth:`frame_ends`, so
        that it never takes the frame's core for a scheduler tick (4 ms at 250 Hz: even at
        nice 19 it was given one now and then, ~20 frames of a 60 s flight on one core).
        "auto": when this process may run on one core only (the process then shares it, and a
        host that paces its frames leaves it the rest); on more cores it runs beside the
        frame. A host that steps back to back without idle time still gets tiles made: the
        process is left running when the frame before began less than 2 ms after the last
        one ended."""
        self._idle_since = 0.0
        self._paused: list[ProducerProcess] = []       # paused for this frame
        self._frame_pages = np.zeros(0, np.int64)      # copied ahead after a fork
        self._learn_from = -1                          # learn_written: from this frame on
        self._copied = self._frame_pages               # of those, copied after the last fork
        self._fork_regions = np.zeros((0, 2), np.int64)  # the writable mappings at that fork
        self.stale_frames = int(stale_frames)
        self.max_starts = MAX_STARTS
        """Background mode: at most this many new tiles of a kind are queued a frame."""
        self.install_budget_s = INSTALL_BUDGET_S
        """Background mode: :meth:`collect` stops installing finished tiles once it has spent
        this long in a frame (at least one is installed); the rest wait for the next frame."""
        self.frame = 0
        """Calls of :meth:`collect` so far (one a frame)."""
        self.producers: dict[str, Producer] = {}
        self.errors: list[str] = []
        self.requested = 0
        """Tiles queued or produced since the start."""
        self._pending: set[tuple[str, int]] = set()
        self._failed: set[tuple[str, int]] = set()
        self._wanted: dict[str, TileTable] = {}
        """Per kind, code → the last frame that asked for the tile (numba tables: a frame asks
        for hundreds of missing tiles during a flight; the worker reads them under _lock)."""
        self._state: dict[str, TileTable] = {}
        """Per kind, code → PENDING or FAILED (mirrors _pending and _failed for numba)."""
        self._queue: queue.PriorityQueue = queue.PriorityQueue()
        self._seq = itertools.count()
        self._done: deque = deque()
        self._arrived = threading.Event()  # set by the worker each time it hands a job back
        self._fresh: dict[tuple[str, int], Any] = {}
        self._awaiting: dict[tuple[str, int], set] = {}   # dep → the jobs waiting for it
        self._lock = threading.Lock()
        self._making: set[tuple[str, int]] = set()     # (kind, code) a worker makes now
        self._made = threading.Condition(self._lock)   # notified as each is done
        self._idle = threading.Event()     # set between frames: the worker starts jobs then
        self._idle.set()
        self._gap = threading.Condition()   # notified as each frame ends (wait_gap)
        self._frames_ended = 0
        self._threads: list[threading.Thread] = []
        self._processes: list[ProducerProcess] = []     # one per worker thread, or none
        self._closed = False
        self._process_kinds: frozenset[str] = frozenset()
        self.generation = 0
        """Changes at each :meth:`invalidate` (a tile made from older sources is dropped)."""
        self._stale: dict[str, set[int]] = {}
        """Per kind, the codes of resident tiles standing in for their new versions."""
        self.remade = 0
        """Stale tiles replaced by their new versions so far."""
        self._invalidated_at = 0
        self._first: frozenset[str] = frozenset()
        self._rank: dict[str, dict[int, float]] = {}      # kind → code → [0, 1) (invalidate)
        self._later: dict[str, set[int]] = {}             # kind → codes made last (invalidate)
        self._priority: dict[str, tuple[np.ndarray, np.ndarray]] = {}   # (invalidate)
        # the stale sets as hash tables (request: a frame's codes looked up in one call)
        self._stale_codes: dict[str, tuple[int, TileTable]] = {}
        self._stale_elsewhere_until = -1      # frames leave the stale tiles to queue_stale
        for producer in producers:
            self.add(producer)

    def add(self, producer: Producer) -> None:
        """Register the producer of a kind (and make its pool)."""
        if producer.kind in self.producers:
            raise ValueError(f"a producer of {producer.kind!r} tiles is already registered")
        self.producers[producer.kind] = producer
        self.cache.pool(producer.kind, producer.fields)
        self._wanted[producer.kind] = TileTable(1024)
        self._state[producer.kind] = TileTable(1024)
        self._stale[producer.kind] = set()

    def fork_for(self, producers: Iterable[Producer], *, in_gap: bool = False
                 ) -> list[ProducerProcess] | None:
        """The worker processes (one per worker thread) forked now with ``producers`` in
        place of the current ones of their kinds, for :meth:`replace_producers` (any thread
        may fork them: a live edit does, in its background thread); None when tiles are not
        made in processes. The pages :meth:`learn_written` found the frames write are
        copied after it, in this thread, until a frame begins
        (:func:`~riverflow.tiles.remote.forked`). ``in_gap``: forked at the start of the
        next gap between frames (waited for up to GAP_WAIT_S), not across a frame: the fork
        holds the interpreter lock (~6 ms at 1080p) and the copy has the rest of the gap."""
        if self.worker != "process" or not self._processes or self._closed:
            return None
        producers = {**self.producers, **{p.kind: p for p in producers}}
        regions = writable_regions()
        if in_gap:
            self.wait_gap()
        self._learn_from = self.frame + 1
        with forked(self._frame_pages, lambda: not self._idle.is_set()) as copied:
            processes = [ProducerProcess(producers, WORKER_NICE) for _ in self._processes]
        self._fork_regions = regions
        self._copied = self._frame_pages[:copied[0]]
        return processes

    def learn_frame(self, run) -> None:
        """Run ``run()`` (a frame's work: the world's loading screen runs its systems once)
        with a child forked just before it that only waits, and learn the pages it wrote
        (:meth:`learn_written`'s list), so that an edit's first fork already copies them
        ahead (else its first frame takes every fault, ~2.5 ms at 1080p). Where tiles are
        not made in processes, or pages cannot be read or copied here, just ``run()``."""
        if (self.worker != "process" or not self._processes or self._closed
                or not sys.platform.startswith("linux")
                or os.environ.get("RIVERFLOW_COPY_AHEAD") == "0"):
            run()
            return
        regions = writable_regions()
        hold, release = os.pipe()
        pid = os.fork()
        if pid == 0:                     # the child: shares every page until it is told
            try:
                os.close(release)
                os.read(hold, 1)
            finally:
                os._exit(0)
        os.close(hold)
        try:
            run()
            pages = within(written_pages(), regions)
        finally:
            os.close(release)            # (the child reads EOF and ends)
            os.waitpid(pid, 0)
        if len(pages) <= WRITTEN_MAX_PAGES:
            self._frame_pages = pages[:FRAME_PAGES]

    def wait_gap(self, timeout_s: float = GAP_WAIT_S) -> bool:
        """Wait until a frame that ends after this call has ended (at most ``timeout_s``: a
        host that does not step); True if one did."""
        with self._gap:
            ended = self._frames_ended
            return self._gap.wait_for(lambda: self._frames_ended > ended and self._idle.is_set(),
                                      timeout_s)

    def learn_written(self) -> None:
        """After the first frame that followed :meth:`fork_for`, before other work between
        frames: the pages written since the fork (:func:`~riverflow.tiles.remote.
        written_pages`, of the mappings there at the fork) that were not copied ahead are
        the frame's misses: the next fork copies those first, then the ones copied ahead
        this time, at most FRAME_PAGES (those not copied and not written go: what the
        frames no longer write leaves the list once the copy stops short of it); too many to
        be a frame's (a world just made) and the next fork learns them afresh. Any thread,
        outside a frame (it reads ``/proc/self/pagemap``: 3–5 ms)."""
        if self._learn_from < 0 or self.frame < self._learn_from:
            return
        self._learn_from = -1
        pages = within(written_pages(), self._fork_regions)
        if len(pages) > WRITTEN_MAX_PAGES:        # not a frame's: learnt afresh next time
            self._frame_pages = pages[:0]
            return
        copied = self._copied
        misses = pages[~np.isin(pages, copied)]
        self._frame_pages = np.concatenate([misses, copied])[:FRAME_PAGES]

    def replace_producers(self, producers: Iterable[Producer],
                          processes: list[ProducerProcess] | None = None, *,
                          close_old: bool = True) -> list[ProducerProcess] | None:
        """Make the tiles of the given kinds with these producers from now on (same kinds and
        fields as the ones they replace; call :meth:`invalidate` for the tiles this changes).
        The worker processes, forked with the old producers, are let go (closed in a thread
        of their own: their end is not waited for in a frame); ``processes`` (:meth:`fork_for`
        with these producers) take their place, else the tiles are made in the worker
        threads. ``close_old`` False: the old processes are handed back for the caller to
        close (None if there were none)."""
        producers = list(producers)
        for producer in producers:
            old = self.producers.get(producer.kind)
            if old is None:
                raise ValueError(f"replace_producers: no {producer.kind!r} producer to replace")
            if (old.fields is None) != (producer.fields is None) or (
                    old.fields is not None and dict(old.fields) != dict(producer.fields)):
                raise ValueError(f"replace_producers: the new {producer.kind!r} producer's tiles "
                                 "have other fields than the old one's")
        for producer in producers:
            self.producers[producer.kind] = producer
        old, self._processes = self._processes, list(processes or [])
        self._process_kinds = frozenset(self.producers) if self._processes else frozenset()
        if old and close_old:
            threading.Thread(target=close_all, args=(old, 1.0), daemon=True,
                             name="riverflow-tiles-close").start()
            return None
        return old or None

    def invalidate(self, stale: Mapping[str, np.ndarray], release: Iterable[str] = (),
                   first: Iterable[str] = (),
                   rank: Mapping[str, np.ndarray] | None = None,
                   later: Mapping[str, np.ndarray] | None = None) -> int:
        """Start a new generation (module docstring): the resident tiles of ``stale`` (kind →
        codes) stand in until they are made again, before any other tile (those of the kinds
        in ``first`` first of all), those of the kinds in ``release`` (and every one in
        blocking mode) are dropped at once, as are those the current producer says are
        empty; every tile queued or being made is let go (asked again, it is made from the
        current producers). ``rank`` (kind → a number per code of ``stale``, smaller first:
        the distance to the change) orders the stale tiles of a kind; those of ``later`` (kind →
        codes: the ancestors of the view's cut, drawn only where a leaf is missing) are made
        after every other stale tile. Returns how many resident tiles were marked or
        dropped."""
        release = set(release)
        self._later = {kind: set(np.asarray(codes, np.int64).tolist())
                       for kind, codes in (later or {}).items()}
        self._rank = {}
        for kind, values in (rank or {}).items():
            values = np.asarray(values, np.float64)
            values = np.where(np.isfinite(values) & (values >= 0), values, 0.0)
            top = float(values.max()) if len(values) else 0.0
            self._rank[kind] = dict(zip(np.asarray(stale[kind], np.int64).tolist(),
                                        (values / (top + 1.0)).tolist()))
        self._first = frozenset(first)
        # each stale tile's place in the queue as sorted arrays: a frame that queues the
        # stale tiles again looks them up at once (_stale_priorities)
        self._priority = {}
        for kind, codes in stale.items():
            codes = np.asarray(codes, np.int64)
            ranks = self._rank.get(kind, {})
            r = (np.fromiter(map(ranks.get, codes.tolist(), [0.0] * len(codes)), np.float64,
                             len(codes)) if ranks else np.zeros(len(codes)))
            later_codes = self._later.get(kind)
            made_later = (np.isin(codes, np.fromiter(later_codes, np.int64, len(later_codes)))
                          if later_codes else np.zeros(len(codes), bool))
            place = np.where(made_later, -1.0, -3.0 if kind in self._first else -2.0) + r
            keys, at = np.unique(codes, return_index=True)
            self._priority[kind] = (keys, place[at])
        self._stale_codes.clear()        # (only invalidate adds to a stale set)
        self._stale_elsewhere_until = -1
        self.generation += 1
        self._invalidated_at = self.frame
        with self._lock:
            self._fresh.clear()
            self._awaiting.clear()
            for kind, code in self._pending:
                self._wanted[kind].set(code, _LONG_AGO)
        self._pending.clear()
        self._failed.clear()
        for table in self._state.values():
            table.clear()
        for pool in self.cache.pools.values():
            pool.pins[:] = 0        # the old jobs' pins: their tiles are dropped anyway
        marked = 0
        for kind, codes in stale.items():
            pool = self.cache.pools[kind]
            codes = np.ascontiguousarray(codes, np.int64)
            codes = codes[pool.table.find_many(codes) >= 0]
            if not len(codes):
                continue
            empty = self.producers[kind].empty_mask(codes)
            drop = kind in release or self.mode == "blocking"
            for code, gone in zip(codes.tolist(), empty.tolist()):
                if drop or gone:
                    pool.release(pool.slot(code))
                    self._stale[kind].discard(code)
                else:
                    self._stale[kind].add(code)
                marked += 1
        return marked

    def stale(self, kind: str, *, wanted: bool = False) -> set[int]:
        """Codes of the resident ``kind`` tiles standing in for their new versions (a copy);
        ``wanted``: only those the latest frame asked for (in view)."""
        pool = self.cache.pools[kind]
        out = {c for c in self._stale[kind] if c in pool}
        if wanted:
            with self._lock:
                out = {c for c in out if self._wanted[kind].get(c) == self.frame}
        return out

    def _stale_table(self, kind: str) -> TileTable:
        """The stale tiles of ``kind`` as a :class:`TileTable` (made again when the set has
        shrunk: only :meth:`invalidate` adds to it, and it clears these)."""
        stale = self._stale[kind]
        known = self._stale_codes.get(kind)
        if known is None or known[0] != len(stale):
            table = TileTable(len(stale))
            table.set_many(np.fromiter(stale, np.int64, len(stale)), 0)
            known = self._stale_codes[kind] = (len(stale), table)
        return known[1]

    def install(self, kind: str, code: int, data) -> bool:
        """Install a tile made elsewhere with the current producer of ``kind`` (a live edit's
        thread made it ahead), as if the worker had: resident from now on unless it is or
        its old version is (a stale one is made again as usual). Returns whether it was."""
        pool = self.cache.pools[kind]
        if code in pool or (kind, code) in self._pending:
            return False
        stored = self._store(kind, code, data, self.cache.tick)
        if stored:
            self.cache.evict_to_budget()
        return stored

    def queue_stale(self, limit: int | None = None) -> int:
        """Queue the stale tiles the latest frame read (background mode), each in its place,
        the river's kinds first, at most ``limit`` (and their dependencies) in this call; the
        frames leave them to these calls meanwhile (STALE_ELSEWHERE_FRAMES after the last).
        A live edit's swap between frames has its thread do it between the frames after it:
        an edit's ~300 tiles' set-up is not the frames'. Returns how many are left to
        queue (0: done, the frames queue what they ask for again)."""
        if self.mode != "background":
            return 0
        todo = []
        for kind, stale in self._stale.items():
            if not stale:
                continue
            pool = self.cache.pools[kind]
            codes = np.fromiter(stale, np.int64, len(stale))
            slots = pool.table.find_many(codes)
            codes = codes[(slots >= 0) & (pool.last_used[np.maximum(slots, 0)]
                                          >= self.cache.tick - 1)]
            codes = codes[self._state[kind].find_many(codes) < 0]
            if len(codes):
                todo.append((kind, codes, self._stale_priorities(kind, codes)))
        if not todo:
            self._stale_elsewhere_until = -1
            return 0
        kinds = np.concatenate([np.full(len(c), k) for k, (_, c, _) in enumerate(todo)])
        codes = np.concatenate([c for _, c, _ in todo])
        order = np.argsort(np.concatenate([p for _, _, p in todo]), kind="stable")
        take = order if limit is None else order[:limit]
        for k in np.unique(kinds[take]).tolist():
            with self._lock:
                self._wanted[todo[k][0]].set_many(codes[take[kinds[take] == k]], self.frame)
        for at in take.tolist():
            self._start(todo[kinds[at]][0], code_key(int(codes[at])), int(codes[at]))
        left = len(order) - len(take)
        self._stale_elsewhere_until = self.frame + STALE_ELSEWHERE_FRAMES if left else -1
        return left

    def _let_stale_go(self) -> None:
        """Stale tiles no frame asked for since the edit (or within stale_frames) are
        released: a stand-in nobody reads is not kept to be read later."""
        if self.frame - self._invalidated_at <= self.stale_frames:
            return
        for kind, stale in self._stale.items():
            if not stale:
                continue
            pool = self.cache.pools[kind]
            with self._lock:
                table = self._wanted[kind]
                old = [c for c in stale if not (self.frame - table.get(c) <= self.stale_frames
                                                and table.get(c) >= self._invalidated_at)]
            for code in old:
                stale.discard(code)
                slot = pool.slot(code)
                if slot >= 0 and pool.pins[slot] == 0:
                    pool.release(slot)

    def _is_stale(self, kind: str, code: int) -> bool:
        return code in self._stale[kind]

    def _store(self, kind: str, code: int, data, tick: int) -> bool:
        """Install a made tile: a new one, or the new version of a stale one (into another
        slot, the old one released: whoever syncs by slot sees the change); a tile already
        resident and not stale is kept. Returns whether it was stored."""
        pool = self.cache.pools[kind]
        nbytes = self.producers[kind].nbytes(data)
        stale = self._stale[kind]
        if code in pool:
            if code not in stale:
                return False
            pool.replace(code, data, nbytes, tick)
            self.remade += 1
        else:
            pool.store(code, data, nbytes, tick)
        stale.discard(code)
        return True

    # -- requests --------------------------------------------------------------------------

    def request(self, kind: str, keys: np.ndarray | Iterable[TileKey],
                codes: np.ndarray | None = None) -> int:
        """Ask for tiles of ``kind`` ((K, 3) (level, tx, ty) rows, or their (K,) int64
        ``codes`` when the caller has them: a frame asks for the same tiles of several kinds;
        the frame asks for every tile it needs every frame). Resident ones are marked used;
        the others are queued (background) or made now (blocking), their dependencies first.
        Returns how many were queued or made."""
        pool = self.cache.pools[kind]
        codes = codes_of(keys) if codes is None else codes
        missing = pool.mark_used(codes, self.cache.tick)
        stale = self._stale[kind]
        if stale:                       # standing in: made again like missing ones
            known = self._stale_table(kind)
            again = codes[known.find_many(codes) >= 0]
            if len(again):
                missing = np.concatenate([missing, again])
        started = 0
        producer = self.producers[kind]
        if len(missing):
            missing = missing[~producer.empty_mask(missing)]
        if not len(missing):
            return 0
        with self._lock:
            self._wanted[kind].set_many(missing, self.frame)
        new = missing[self._state[kind].find_many(missing) < 0]   # neither pending nor failed
        if stale and self.frame <= self._stale_elsewhere_until:
            new = new[known.find_many(new) < 0]        # queued by queue_stale's caller
        if self.mode == "background" and len(new) > self.max_starts:
            # the worker makes tens of tiles a second: more would go stale unmade, and the
            # view asks again next frame; coarse first, so the view fills from coarse to fine,
            # but stale tiles (a live edit) before any, in the order _start queues them
            order = (new >> 56).astype(np.float64)
            if stale:
                again = known.find_many(new) >= 0
                order[again] = self._stale_priorities(kind, new[again])
            new = new[np.argsort(order, kind="stable")[:self.max_starts]]
        for code in new.tolist():
            started += self._start(kind, code_key(code), code)
        return started

    def _start(self, kind: str, key: TileKey, code: int) -> int:
        """Queue (or make) one missing tile, its missing dependencies first."""
        if self.mode == "blocking":
            self._make_now(kind, key, code)
            return 1
        job = _Job(kind, key, code, generation=self.generation)
        started = 1
        for dep in self.producers[kind].dependencies(key):
            dkind, dkey = dep
            dcode = tile_code(*dkey)
            dpool = self.cache.pools[dkind]
            slot = dpool.slot(dcode)
            if slot >= 0 and not self._is_stale(dkind, dcode):
                dpool.pins[slot] += 1
                dpool.last_used[slot] = self.cache.tick
                job.resident[dep] = (dpool, slot, dpool.tile(slot))
                continue
            if self.producers[dkind].is_empty(dkey):
                job.resident[dep] = (None, -1, None)
                continue
            if (dkind, dcode) in self._failed:
                self._unpin(job)
                self._set_failed(kind, code)
                self.errors.append(f"{kind} tile {key}: its {dkind} tile {dkey} failed")
                return 0
            if (dkind, dcode) not in self._pending:
                self._stamp_wanted(dkind, dcode, self.frame)
                started += self._start(dkind, dkey, dcode)
            with self._lock:
                self._awaiting.setdefault((dkind, dcode), set()).add((kind, code))
            job.awaited.append(dep)
        self._pending.add((kind, code))
        self._state[kind].set(code, _PENDING)
        self.requested += 1
        self._ensure_thread()
        # coarse first; a stale tile (a live edit) before any (_stale_priority)
        priority = key[0] if code not in self._stale[kind] else self._stale_priority(kind, code)
        self._queue.put((priority, next(self._seq), job))
        return started

    def _stale_priority(self, kind: str, code: int) -> float:
        """A stale tile's place in the queue, before any other tile's (those are made coarse
        first: their level, ≥ 0): the kinds asked ``first`` first, each kind's by its rank,
        the ones made ``later`` after every other stale tile (:meth:`invalidate`)."""
        rank = self._rank.get(kind, {}).get(code, 0.0)
        if code in self._later.get(kind, ()):
            return -1.0 + rank
        return (-3.0 if kind in self._first else -2.0) + rank

    def _stale_priorities(self, kind: str, codes: np.ndarray) -> np.ndarray:
        """:meth:`_stale_priority` of many stale tiles (from the table :meth:`invalidate`
        made; a tile left standing in by an earlier edit gets its kind's plain place)."""
        out = np.full(len(codes), -3.0 if kind in self._first else -2.0)
        keys, values = self._priority.get(kind, (None, None))
        if keys is not None and len(keys) and len(codes):
            at = np.minimum(np.searchsorted(keys, codes), len(keys) - 1)
            hit = keys[at] == codes
            out[hit] = values[at[hit]]
        return out

    def _make_now(self, kind: str, key: TileKey, code: int) -> None:
        """Blocking mode: make the dependencies that are not resident, then the tile; install."""
        deps: dict[Dep, Any] = {}
        pinned = []
        for dep in self.producers[kind].dependencies(key):
            dkind, dkey = dep
            dcode = tile_code(*dkey)
            dpool = self.cache.pools[dkind]
            if self.producers[dkind].is_empty(dkey):
                deps[dep] = None
                continue
            if dpool.slot(dcode) < 0 or self._is_stale(dkind, dcode):
                self._make_now(dkind, dkey, dcode)
            slot = dpool.slot(dcode)
            if slot < 0 or self._is_stale(dkind, dcode):    # it failed
                self._set_failed(kind, code)
                return
            dpool.pins[slot] += 1
            dpool.last_used[slot] = self.cache.tick
            pinned.append((dpool, slot))
            deps[dep] = dpool.tile(slot)
        try:
            data = self._from_memo(kind, key, lambda: self.producers[kind].produce(key, deps))
        except Exception as exc:  # a bad source value must not crash the frame
            self._record_failure(kind, key, code, exc)
            data = None
        for dpool, slot in pinned:
            dpool.pins[slot] = max(dpool.pins[slot] - 1, 0)
        self.requested += 1
        if data is not None and self._store(kind, code, data, self.cache.tick):
            self.cache.evict_to_budget()

    # -- worker and installation -----------------------------------------------------------------

    def start(self) -> None:
        """Background mode: start the worker (and fork its process) now rather than at the
        first request, in a frame (a world does it while it is made). Blocking mode: nothing."""
        if self.mode == "background":
            self._ensure_thread()

    def _ensure_thread(self) -> None:
        if not self._threads:
            if self.worker == "process" and not self._processes:
                # forked before the worker threads start: the children hold no lock of theirs
                self._processes = [ProducerProcess(self.producers, WORKER_NICE)
                                   for _ in range(self.workers)]
                self._process_kinds = frozenset(self.producers)
            self._threads = [threading.Thread(target=_work, args=(weakref.ref(self),
                                                                  self._queue, lane),
                                              name="riverflow-tiles", daemon=True)
                             for lane in range(self.workers)]
            for thread in self._threads:
                thread.start()

    def _run(self, job: _Job, lane: int = 0) -> None:
        """Worker side (worker thread ``lane``): make one queued tile (or drop it if no frame
        wants it any more, nor any wanted tile that waits for it)."""
        item = (job.kind, job.code)
        producer = self.producers[job.kind]     # with the generation: one edit's sources
        with self._lock:
            needed = job.generation == self.generation and (self._is_wanted(item) or any(
                self._is_wanted(w) for w in self._awaiting.get(item, ())))
        if not needed:
            self._release_awaited(job)
            self._hand_back(job, None, None)
            return
        deps: dict[Dep, Any] = {dep: view for dep, (_, _, view) in job.resident.items()}
        error = None
        dropped = False
        with self._lock:
            for dep in job.awaited:
                dcode = tile_code(*dep[1])
                data = self._fresh.get((dep[0], dcode))
                if data is None and (dep[0], dcode) in self._making:
                    # another worker makes it now: waited for, not let go (with several
                    # workers a tile and its dependency are often taken one after the other)
                    self._made.wait_for(lambda d=(dep[0], dcode): d not in self._making,
                                        timeout=DEPENDENCY_WAIT_S)
                    data = self._fresh.get((dep[0], dcode))
                if data is None:
                    if (dep[0], dcode) in self._failed:
                        error = RuntimeError(f"its {dep[0]} tile {dep[1]} was not made")
                    else:
                        dropped = True      # let go as stale: asked again, made again
                deps[dep] = data
        if dropped and error is None:
            self._release_awaited(job)
            self._hand_back(job, None, None)
            return
        data = None
        if error is None:
            with self._lock:
                self._making.add(item)
            try:
                data = self._produce(job.kind, job.key, deps, producer, lane)
            except Exception as exc:  # reported on the main thread by collect()
                # (by its type and message: its traceback's frames hold this scheduler, a
                # cycle that would keep a dropped world's tiles until the collector ran)
                error = exc.with_traceback(None)
            finally:
                with self._lock:
                    if data is not None and job.generation == self.generation:
                        self._fresh[item] = data
                    self._making.discard(item)
                    self._made.notify_all()
        self._release_awaited(job)
        self._hand_back(job, data, error)

    def _hand_back(self, job: _Job, data: Any, error: BaseException | None) -> None:
        """Worker side: a finished (or dropped) job, for the main thread to install."""
        self._done.append((job, data, error))
        self._arrived.set()

    def _from_memo(self, kind: str, key: TileKey, make, producer: Producer | None = None) -> Any:
        """The tile the scene's memo keeps, or ``make()`` it (and keep it there); ``producer``:
        the one the tile is made with (default: the current one of ``kind``)."""
        producer = producer or self.producers[kind]
        memo = producer.memo if producer.fields is not None else None
        if memo is None:
            return make()
        tag = (kind, producer.memo_tag, tuple(key))
        data = memo.get(tag)
        if data is None:
            data = make()
            if data is not None:
                memo.put(tag, _owned(data))
        return data

    def _produce(self, kind: str, key: TileKey, deps: dict, producer: Producer,
                 lane: int = 0) -> Any:
        """Worker side: the tile (:meth:`_from_memo`)."""
        return self._from_memo(kind, key, lambda: self._make(kind, key, deps, producer, lane),
                               producer)

    def _make(self, kind: str, key: TileKey, deps: dict, producer: Producer,
              lane: int = 0) -> Any:
        """Worker side: make the tile, in worker thread ``lane``'s process if there is one (a
        producer added after it was forked, or a process that died, makes it here)."""
        processes = self._processes
        process = processes[lane] if lane < len(processes) else None
        if self._closed:         # closed since the job was taken: dropped, like a stale one
            return None
        if producer is not self.producers[kind]:
            return None            # made from the sources before an edit: dropped anyway
        if process is not None and kind in self._process_kinds:
            try:
                return process.produce(kind, key, deps)
            except TileProcessError:
                raise
            except (EOFError, OSError, ValueError) as exc:
                if self._closed or producer is not self.producers[kind]:
                    return None                    # closed or replaced meanwhile: dropped
                if self._processes is processes:   # not replaced meanwhile: it died
                    self._processes = []
                    self.errors.append(f"a tile process ended ({type(exc).__name__}: {exc}); "
                                       "tiles are made in the worker threads from now on")
                    close_all(processes, 0.5)
        return producer.produce(key, deps)

    @property
    def worker_pid(self) -> int | None:
        """The first tile process's id while there is one (its memory is the world's too)."""
        pids = self.worker_pids
        return pids[0] if pids else None

    @property
    def worker_pids(self) -> list[int]:
        """The tile processes' ids (one per worker thread; none when tiles are made in the
        worker threads)."""
        return [p.pid for p in self._processes if p.alive and p.pid is not None]

    def _is_wanted(self, item) -> bool:
        """(under _lock) Some frame asked for ``item`` within stale_frames."""
        kind, code = item
        frame = self._wanted[kind].get(code)
        return frame != NOT_FOUND and self.frame - frame <= self.stale_frames

    def _stamp_wanted(self, kind: str, code: int, frame: int) -> None:
        with self._lock:
            self._wanted[kind].set(code, frame)

    def _set_failed(self, kind: str, code: int) -> None:
        self._failed.add((kind, code))
        self._state[kind].set(code, _FAILED)

    def _release_awaited(self, job: _Job) -> None:
        with self._lock:
            item = (job.kind, job.code)
            for dep in job.awaited:
                k = (dep[0], tile_code(*dep[1]))
                waiting = self._awaiting.get(k)
                if waiting is not None:
                    waiting.discard(item)
                    if not waiting:
                        del self._awaiting[k]

    def frame_begins(self) -> None:
        """The frame starts: the worker thread finishes the tile in hand but starts no other
        of its own until :meth:`frame_ends` (or for IDLE_WAIT_S at most), so it runs in the
        frame's idle time rather than taking the interpreter from the frame at every switch
        interval; the tiles the process makes are handed to it meanwhile (it holds no lock
        of the frame's)."""
        self._idle.clear()
        if self._processes and self._pause_now():
            self._pause_sharing()

    def _pause_sharing(self) -> None:
        processes = self._processes
        self._paused = processes[len(processes) - self._sharing_frame_core():]
        for process in self._paused:
            process.pause()

    @contextlib.contextmanager
    def frame_work(self):
        """The world's own work outside its frames (a live edit swapped in between them by
        the edits' thread): as in a frame (:meth:`frame_begins`), the worker threads start
        no tile, and the processes sharing the frame's core are stopped (whatever the idle
        time before it: the work is short and a frame may be waiting for it)."""
        self._idle.clear()
        if self._processes and self.pause_in_frames:
            self._pause_sharing()
        try:
            yield
        finally:
            self.frame_ends()

    def frame_ends(self) -> None:
        if self._paused:
            paused, self._paused = self._paused, []
            for process in paused:
                process.resume()
        self._idle_since = time.perf_counter()
        self._idle.set()
        with self._gap:
            self._frames_ended += 1
            self._gap.notify_all()

    def wait_idle(self, timeout_s: float = IDLE_WAIT_S) -> None:
        """Wait (at most ``timeout_s``) until no frame runs: background work in Python (a
        live edit) starts its next piece between frames, as the worker starts its tiles."""
        self._idle.wait(timeout_s)

    def _sharing_frame_core(self) -> int:
        """How many worker processes ``pause_in_frames`` stops in a frame: all (True); "auto":
        those beyond one per core but the frame's (none where they all have a core of their
        own; the one on a single core)."""
        n = len(self._processes)
        if self.pause_in_frames != "auto":
            return n
        cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else n + 1
        return min(max(n - (cores - 1), 0), n)

    def _pause_now(self) -> bool:
        if self.pause_in_frames == "auto":
            if self._sharing_frame_core() == 0:
                return False
        elif not self.pause_in_frames:
            return False
        return time.perf_counter() - self._idle_since >= PAUSE_MIN_IDLE_S

    def complete(self, wanted: Iterable[tuple[str, np.ndarray]]) -> int:
        """Make every tile of ``wanted`` ((kind, (K,) codes) pairs: what this frame asked
        for) resident before returning: what the worker finished is installed, and every tile
        still missing (not known empty, not failed) is made here and now, its dependencies
        first, as blocking production would; the worker lets its own queued copy go. Returns
        how many tiles were made here.

        This is what makes a world deterministic in background mode: what a frame reads is
        the same tiles whatever the machine's load and whenever the worker ran; only where and
        when the work is done changes. The tiles are made in the frame's own thread, at its
        priority: a frame that waited for the worker would wait for a nice-19 process, which a
        busy machine starves (seconds a tile). The new versions of stale tiles (a live edit)
        are installed within :attr:`install_budget_s` a frame, as :meth:`collect` does: the
        old ones stand in meanwhile."""
        self._install(replacements_s=self.install_budget_s)
        made = 0
        for kind, codes in wanted:
            codes = np.ascontiguousarray(codes, np.int64)
            if not len(codes):
                continue
            pool = self.cache.pools[kind]
            missing = codes[pool.table.find_many(codes) < 0]
            if not len(missing):
                continue
            missing = missing[~self.producers[kind].empty_mask(missing)]
            missing = missing[self._state[kind].find_many(missing) != _FAILED]
            # from the last: the workers take the queue from its first, and what they finish
            # meanwhile is installed as this goes (a view's hundreds of new tiles, a world's
            # first view, shared with them: on a machine with cores to spare, made sooner);
            # none is waited for (a busy machine starves the nice-19 workers)
            for code in reversed(missing.tolist()):
                if self._threads and self._done:
                    self._install(replacements_s=0.0)
                if pool.slot(code) >= 0 or (kind, code) in self._failed:
                    continue                   # made meanwhile, as another tile's dependency
                if (kind, code) in self._pending:
                    with self._lock:           # the worker drops its copy unless another needs it
                        self._wanted[kind].set(code, _LONG_AGO)
                self._make_now(kind, code_key(code), code)
                made += 1
        return made

    def collect(self) -> int:
        """Install the tiles the worker finished (main thread, start of a frame); returns how
        many were installed."""
        self.frame += 1
        installed = self._install(self.install_budget_s)
        if self.frame % 8 == 0 and any(self._stale.values()):
            self._let_stale_go()
        return installed

    def _install(self, budget_s: float | None = None, replacements_s: float | None = None
                 ) -> int:
        """Install what the worker finished: all of it, or (``budget_s``) until that long
        has been spent (at least one tile); ``replacements_s``: the new versions of stale
        tiles (which stand in meanwhile: no frame needs them) only until that long has been
        spent, the others all."""
        installed = 0
        now = time.perf_counter()
        end = None if budget_s is None else now + budget_s
        replace_end = None if replacements_s is None else now + replacements_s
        later = []
        while self._done:
            if end is not None and installed and time.perf_counter() > end:
                break
            job, data, error = self._done.popleft()
            if job.generation != self.generation:   # made from the sources before an edit
                continue
            if (replace_end is not None and data is not None and error is None
                    and job.code in self._stale[job.kind] and installed
                    and time.perf_counter() > replace_end
                    and job.code in self.cache.pools[job.kind]):
                later.append((job, data, error))    # a later frame's
                continue
            item = (job.kind, job.code)
            self._pending.discard(item)
            if item not in self._failed:
                self._state[job.kind].pop(job.code)
            self._unpin(job)
            if error is not None:
                self._record_failure(job.kind, job.key, job.code, error)
            elif data is not None:
                if self._store(job.kind, job.code, data, self.cache.tick):
                    installed += 1
        if later:
            self._done.extendleft(reversed(later))
        if installed:
            self.cache.evict_to_budget()
        with self._lock:
            for item in [k for k in self._fresh if k not in self._pending
                         and not self._awaiting.get(k)]:
                del self._fresh[item]
        if self.frame % 256 == 0:              # forget what no frame asked for in a while
            old = self.frame - self.stale_frames
            with self._lock:
                for kind, table in self._wanted.items():
                    if len(table) > 4 * len(self._pending) + 4096:
                        keep = [(c, f) for c, f in table.items()
                                if f >= old or (kind, c) in self._pending]
                        table.clear()
                        if keep:
                            c, f = np.array(keep, np.int64).T
                            table.set_many(c, f.astype(np.int32))
        return installed

    def _unpin(self, job: _Job) -> None:
        for pool, slot, _ in job.resident.values():
            if pool is not None:
                pool.pins[slot] = max(pool.pins[slot] - 1, 0)
        job.resident = {}

    def _record_failure(self, kind: str, key: TileKey, code: int, exc: BaseException) -> None:
        self._set_failed(kind, code)
        if len(self.errors) < 100:
            self.errors.append(f"{kind} tile {key}: {type(exc).__name__}: {exc}")

    def forget_unrequested(self) -> int:
        """Let the worker drop, unmade, every queued tile that the latest frame did not ask
        for (after a teleport or a fast flight: :meth:`wait` then makes only what the current
        view needs). Returns how many were let go."""
        dropped = 0
        with self._lock:
            for kind, code in list(self._pending):
                if self._wanted[kind].get(code) != self.frame:
                    self._wanted[kind].set(code, _LONG_AGO)
                    dropped += 1
        return dropped

    @property
    def pending(self) -> int:
        return len(self._pending)

    def wait(self, timeout_s: float = 60.0) -> bool:
        """Block until every queued tile is made and installed (tests, loading screens).
        Returns False on timeout."""
        end = time.perf_counter() + timeout_s
        while self._pending:
            left = end - time.perf_counter()
            if left <= 0.0:
                break
            self._arrived.clear()          # cleared before the install: a job handed back
            self._install()                # after it sets it again, and the wait returns
            if self._pending and not self._done:
                self._arrived.wait(min(left, 0.05))
        self._install()
        return not self._pending

    def close(self) -> None:
        """Stop the worker threads and processes (queued tiles are dropped). Safe from any
        thread, a worker's own included (a world's finalizer may run where the collector
        ran)."""
        self._closed = True
        threads, self._threads = self._threads, []
        for _ in threads:
            self._queue.put((-1, -1, None))
        processes, self._processes = self._processes, []
        # first, and at once: a thread may be waiting for the tile its process makes at its
        # low priority (seconds on a busy machine); a tile dropped loses nothing
        close_all(processes, 0.1)
        for thread in threads:
            if thread is not threading.current_thread():
                thread.join(timeout=10.0)


def worker_count(workers: int | str) -> int:
    """Worker threads (and processes) for ``workers``: a number ≥ 1, or "auto": one on a
    machine (or an affinity) of one core, where they share the frame's; else one per core
    but the frame's, at least two and at most MAX_WORKERS (the frame's thread outranks them:
    they run at WORKER_NICE)."""
    if workers == "auto":
        cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (
            os.cpu_count() or 1)
        return 1 if cores <= 1 else min(max(cores - 1, 2), MAX_WORKERS)
    if isinstance(workers, bool) or not isinstance(workers, (int, np.integer)) or workers < 1:
        raise ValueError(f"workers must be a whole number ≥ 1 or 'auto', got {workers!r}")
    return int(workers)


def close_all(processes, timeout_s: float) -> None:
    """Close tile processes (:meth:`ProducerProcess.close`), one after the other."""
    for process in processes:
        process.close(timeout_s=timeout_s)


def _lower_priority(nice: int | None = None) -> None:
    """Run the calling thread at ``nice`` (default WORKER_NICE; Linux, where a thread has a
    priority of its own; elsewhere nothing): on a core it shares with the frame, the frame's
    thread runs first whenever both could (a nogil tile kernel takes only the frame's idle
    time)."""
    nice = WORKER_NICE if nice is None else nice
    if not sys.platform.startswith("linux") or nice <= 0:
        return
    tid = threading.get_native_id()
    try:
        os.setpriority(os.PRIO_PROCESS, tid, max(os.getpriority(os.PRIO_PROCESS, tid), nice))
    except OSError:   # not allowed here: the worker keeps the frame's priority
        pass


def _work(ref: weakref.ref, jobs: queue.PriorityQueue, lane: int = 0) -> None:
    """Worker thread ``lane``'s loop, at a low CPU priority. It holds the scheduler only while
    making a tile, so a scheduler nobody uses any more is collected (and its thread ends)."""
    _lower_priority()
    while True:
        try:
            _, _, job = jobs.get(timeout=1.0)
        except queue.Empty:
            if ref() is None:
                return
            continue
        if job is None:
            return
        scheduler = ref()
        if scheduler is None:
            return
        idle = scheduler._idle
        # a tile the process makes is handed to it at once (its own interpreter, beside the
        # frame; paused in frames where it shares the frame's core): waiting for the frame to
        # end left it idle a frame's time at every tile (a live edit's ~240 tiles: ~0.5 s)
        remote = lane < len(scheduler._processes) and job.kind in scheduler._process_kinds
        del scheduler
        if not remote:
            idle.wait(IDLE_WAIT_S)
        scheduler = ref()
        if scheduler is None:
            return
        scheduler._run(job, lane)
        del scheduler


def _owned(data):
    """A tile's data as the memo keeps it: its arrays that are views of other memory (a
    producer's dependency: a slot of a pool, given to another tile once evicted) copied."""
    if isinstance(data, dict):
        return {k: v.copy() if isinstance(v, np.ndarray) and v.base is not None else v
                for k, v in data.items()}
    if isinstance(data, np.ndarray) and data.base is not None:
        return data.copy()
    return data
