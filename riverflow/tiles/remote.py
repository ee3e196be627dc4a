"""ProducerProcess: tiles made in a forked process, so that making them never holds the
frame's interpreter lock (SPEC §8, the open-worlds issue's flight target).

A worker *thread* shares the interpreter lock with the frame: a nogil kernel runs beside the
frame, but the producers' Python, numpy, shapely and scipy glue holds the lock, and a frame
that wants it back waits up to a switch interval (5 ms) at any call — at 1000 km that was the
flight's p99 (3× its p50). A worker *process* has its own interpreter: the frame only ever
waits for the scheduler's bookkeeping (a job sent, a tile received: tens of microseconds).

The process is forked from the world's, so it starts with the producers and everything they
read (the landscape, the flow network, the sources; no pickling, nothing built twice) and its
memory is shared copy-on-write until either side writes. A job is ``(kind, key, deps)``, deps
being copies of the dependency tiles the scheduler holds; the answer is the tile, or the
producer's error as text. Producers are pure functions of their key, the sources and their
dependencies (:class:`~riverflow.tiles.scheduler.Producer`), so a tile made there is the tile
the thread would have made, bit for bit. The process runs at the worker's low priority and
ends when the scheduler closes, when its pipe closes (the world's process ended) or at exit.

Forking needs the ``fork`` start method (Linux; macOS and Windows keep the thread). A height
source that cannot be used from a forked process (a callable holding a socket, a GPU) needs
``RiverConfig(tile_worker="thread")``.

After a fork every page of the world's process is shared with the child until either writes
it: the first frame after it pays a page fault and a 4 KiB copy for each page it writes (~2.5
ms at 1080p, over its own work). :func:`forked` has the forking thread pay them instead, in
the gap between frames the fork began in (:meth:`~riverflow.tiles.scheduler.TileScheduler.
fork_for`): the pages the frames write (the misses of the first frame after the last fork,
read from ``/proc/self/pagemap``: :meth:`~riverflow.tiles.scheduler.TileScheduler.
learn_written`) are copied until the next frame begins (``MADV_POPULATE_WRITE``: no byte is
written, so no thread's data is touched; Linux ≥ 5.14, elsewhere nothing is done).
"""
from __future__ import annotations

import atexit
import contextlib
import ctypes
import multiprocessing
import os
import signal
import sys
import warnings
import weakref
from collections.abc import Mapping
from typing import Any

import numpy as np

_PAUSED: weakref.WeakSet = weakref.WeakSet()
"""Processes paused now (a frame that raised past its end, a scheduler dropped mid-frame):
resumed at exit, before multiprocessing joins its daemon children (a stopped child would
never end, and the interpreter would wait for it for ever)."""


@atexit.register
def _resume_paused() -> None:
    for process in list(_PAUSED):
        process.resume()


IN_WORKER_PROCESS = False
"""True inside a tile worker process (its main thread is a worker, not a frame's)."""


def fork_available() -> bool:
    """Whether tiles can be made in a forked process here (Linux: the ``fork`` start method,
    safe beside the threads a world runs)."""
    return sys.platform.startswith("linux") and "fork" in multiprocessing.get_all_start_methods()


MADV_POPULATE_WRITE = 23
"""Linux's madvise advice (5.14): fault the pages in writable, as a write would, writing
nothing."""
PAGE = 4096
COPY_CHUNK = 64
"""Pages :func:`copy_ahead` copies a call (~0.25 ms here): it stops at a frame's start
between calls."""
WRITTEN_MAX_PAGES = 1 << 14
"""At most this many pages (64 MiB) are copied ahead of the frames after a fork: more is
not a frame's working set (~1,700 pages at 1080p) but a world just made or an edit's own
new data (12,000–56,000 pages, 0.05–0.16 s to copy: after the frame that needed them)."""


def _writable_regions() -> list[tuple[int, int]]:
    """(start, end) addresses of this process's private writable mappings."""
    regions = []
    with open("/proc/self/maps") as f:
        for line in f:
            fields = line.split(maxsplit=5)
            if len(fields) < 5 or fields[1][1] != "w" or fields[1][3] != "p":
                continue
            name = fields[5].strip() if len(fields) > 5 else ""
            if name.startswith("/dev/") or name in ("[vvar]", "[vsyscall]", "[vdso]", "[stack]"):
                continue
            lo, hi = fields[0].split("-")
            regions.append((int(lo, 16), int(hi, 16)))
    return regions


def written_pages() -> np.ndarray:
    """Addresses (sorted, int64) of the private writable pages present in memory and mapped
    by this process alone (pagemap bits 63 and 56): those written since the last fork whose
    child is still alive (or allocated since). Empty where pagemap cannot be read."""
    pages = []
    try:
        regions = _writable_regions()
        fd = os.open("/proc/self/pagemap", os.O_RDONLY)
    except OSError:
        return np.zeros(0, np.int64)
    try:
        for lo, hi in regions:
            try:
                raw = os.pread(fd, 8 * ((hi - lo) // PAGE), (lo // PAGE) * 8)
            except OSError:
                continue
            entry = np.frombuffer(raw, np.uint64)
            mine = (entry >> np.uint64(56)) & np.uint64(0x81) == np.uint64(0x81)  # 63 and 56
            if mine.any():
                pages.append(lo + np.flatnonzero(mine).astype(np.int64) * PAGE)
    finally:
        os.close(fd)
    return np.concatenate(pages) if pages else np.zeros(0, np.int64)


def _madvise():
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        fn = libc.madvise
    except (OSError, AttributeError):
        return None
    fn.argtypes = [ctypes.c_void_p, ctypes.c_size_t, ctypes.c_int]
    fn.restype = ctypes.c_int
    return fn


def copy_ahead(pages: np.ndarray, stop=None) -> int:
    """Break the sharing of ``pages`` (in their order) with the children forked since they
    were listed (``MADV_POPULATE_WRITE``, at most COPY_CHUNK consecutive pages a call, the
    interpreter lock released): the page faults a frame would take writing them are taken
    here. ``stop``, if given, is asked before each call: True (a frame began) ends the copy
    there (the frame takes the faults of the pages it writes; copying the rest beside it
    would only take its core). A run unmapped since is skipped. Returns how many of
    ``pages`` were dealt with, a prefix (0 where the kernel lacks the advice)."""
    if not len(pages) or len(pages) > WRITTEN_MAX_PAGES:
        return 0
    madvise = _madvise()
    if madvise is None:
        return 0
    pages = np.asarray(pages, np.int64)        # in the order given: runs of consecutive pages
    cut = np.flatnonzero(np.diff(pages) != PAGE) + 1
    starts = np.concatenate([pages[:1], pages[cut]]).tolist()
    ends = (np.concatenate([pages[cut - 1], pages[-1:]]) + PAGE).tolist()
    done = 0
    for lo, hi in zip(starts, ends):
        for a in range(lo, hi, COPY_CHUNK * PAGE):
            if stop is not None and stop():
                return done
            b = min(a + COPY_CHUNK * PAGE, hi)
            if madvise(a, b - a, MADV_POPULATE_WRITE) != 0 and ctypes.get_errno() == 22 \
                    and done == 0:      # EINVAL: no such advice (< 5.14)
                return 0
            done += (b - a) // PAGE
    return done


def writable_regions() -> np.ndarray:
    """(K, 2) int64 start and end addresses of this process's private writable mappings
    now (:func:`written_pages` of those alone: the pages written since a fork that were
    there at the fork, not memory mapped since, which no child shares)."""
    try:
        return np.array(_writable_regions(), np.int64).reshape(-1, 2)
    except OSError:
        return np.zeros((0, 2), np.int64)


def within(pages: np.ndarray, regions: np.ndarray) -> np.ndarray:
    """The ``pages`` that lie in one of ``regions`` (sorted, disjoint: writable_regions)."""
    k = np.searchsorted(regions[:, 0], pages, side="right") - 1
    inside = k >= 0
    inside[inside] = pages[inside] < regions[k[inside], 1]
    return pages[inside]


@contextlib.contextmanager
def forked(pages: np.ndarray, stop=None):
    """Fork the tile processes in the block; ``pages`` (those the frames write: what
    :func:`written_pages` listed after the first frame that followed the last fork) are
    copied at its end rather than by the first frame after it (module docstring; ``stop``:
    :func:`copy_ahead`'s). Yields a list that holds, after the block, how many of
    ``pages`` were copied (a prefix). Linux only; elsewhere (or with
    ``RIVERFLOW_COPY_AHEAD=0``) nothing is copied."""
    copied = [0]
    yield copied
    if sys.platform.startswith("linux") and os.environ.get("RIVERFLOW_COPY_AHEAD") != "0":
        copied[0] = copy_ahead(pages, stop)


class TileProcessError(RuntimeError):
    """A producer raised in the worker process (the message names its type and text)."""


class ProducerProcess:
    """One forked process that makes tiles with ``producers`` (module docstring)."""

    def __init__(self, producers: Mapping[str, Any], nice: int = 19) -> None:
        ctx = multiprocessing.get_context("fork")
        here, there = ctx.Pipe()
        self._process = ctx.Process(target=_serve, args=(dict(producers), there, here, nice),
                                    name="riverflow-tiles", daemon=True)
        with warnings.catch_warnings():
            # Python ≥ 3.12 warns on any fork beside other threads (a host's, a previous
            # world's worker): the child runs only the producers, on locks it alone takes
            warnings.filterwarnings("ignore", r".*multi-threaded.*fork", DeprecationWarning)
            self._process.start()
        there.close()
        self._conn = here

    @property
    def pid(self) -> int | None:
        return self._process.pid

    def pause(self) -> None:
        """Stop the process where it is (SIGSTOP: a tile half made waits, nothing is lost)
        until :meth:`resume`; the world's frame then has its core to itself."""
        _PAUSED.add(self)
        self._signal(signal.SIGSTOP)

    def resume(self) -> None:
        self._signal(signal.SIGCONT)
        _PAUSED.discard(self)

    def _signal(self, signum: int) -> None:
        pid = self._process.pid
        if pid is not None and self._conn is not None:
            try:
                os.kill(pid, signum)
            except OSError:   # gone: produce() finds out and says so
                pass

    @property
    def alive(self) -> bool:
        return self._conn is not None and self._process.is_alive()

    def produce(self, kind: str, key: tuple[int, int, int], deps: Mapping) -> Any:
        """Make one tile there (blocks this thread, not the interpreter: the pipe's read
        releases the lock). Raises :class:`TileProcessError` for a producer's error and
        ``EOFError``/``OSError`` when the process is gone."""
        conn = self._conn
        if conn is None:
            raise EOFError("the tile process was closed")
        conn.send((kind, key, dict(deps)))
        ok, value = conn.recv()
        if not ok:
            raise TileProcessError(value)
        return value

    def close(self, timeout_s: float = 5.0) -> None:
        """End the process (idempotent; safe from any thread)."""
        self.resume()                       # a paused process could not read the goodbye
        conn, self._conn = self._conn, None
        if conn is not None:
            try:
                conn.send(None)
            except (OSError, ValueError):
                pass
            conn.close()
        process = self._process
        if process.pid is None:
            return
        process.join(timeout_s)
        if process.is_alive():
            process.kill()
            process.join(max(timeout_s, 5.0))   # a killed process still has to be scheduled


def _serve(producers: Mapping[str, Any], conn, parent_end, nice: int) -> None:
    """The process's loop: jobs in, tiles out, until told to stop or the pipe closes."""
    global IN_WORKER_PROCESS
    IN_WORKER_PROCESS = True
    parent_end.close()     # the world's end of the pipe: EOF here once the world's is closed
    signal.signal(signal.SIGINT, signal.SIG_IGN)   # Ctrl-C is the host's to handle; it ends us
    _die_with_parent()     # a world's process killed while this one is paused: not left stopped
    if nice > 0:
        try:
            os.setpriority(os.PRIO_PROCESS, 0, max(os.getpriority(os.PRIO_PROCESS, 0), nice))
        except OSError:
            pass
    while True:
        try:
            job = conn.recv()
        except (EOFError, OSError):
            return
        if job is None:
            return
        kind, key, deps = job
        try:
            answer = (True, producers[kind].produce(key, deps))
        except Exception as exc:  # noqa: BLE001 - reported to the scheduler, which records it
            answer = (False, f"{type(exc).__name__}: {exc}")
        try:
            conn.send(answer)
        except (OSError, ValueError, EOFError):
            return
        except Exception as exc:  # noqa: BLE001 - a tile that cannot be pickled: said so
            conn.send((False, f"{kind} tile {key} cannot be sent back: "
                              f"{type(exc).__name__}: {exc}"))


def _die_with_parent() -> None:
    """Linux: SIGKILL this process when the thread that forked it ends (``prctl
    PR_SET_PDEATHSIG``); a paused (stopped) process would otherwise outlive a world's process
    that was killed mid-frame, since it reads no EOF while stopped."""
    if not sys.platform.startswith("linux"):
        return
    try:
        import ctypes

        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(1, signal.SIGKILL, 0, 0, 0)     # PR_SET_PDEATHSIG = 1
    except (OSError, AttributeError):
        pass
