"""Python's cyclic garbage collector during big one-off computations.

Reading and building a national stream network (10⁵ links) holds millions of small Python
containers; each full collection of the cyclic collector walks all of them, and there are
more full collections the longer the build: its cost grew faster than the number of links
(docs/performance.md, "Scaling in links"). What the reader and the builder make is freed by
reference counting (they make no cycles that matter), so they run with the collector's
automatic passes held off and give the heap back to it afterwards.
"""
from __future__ import annotations

import contextlib
import functools
import gc
import threading

_lock = threading.Lock()
_depth = 0


@contextlib.contextmanager
def collector_paused():
    """Hold off the cyclic collector's automatic passes for the block (nested and threaded
    use count: the outermost block re-enables it, only if it was enabled before)."""
    global _depth, _was_enabled
    with _lock:
        if _depth == 0:
            _was_enabled = gc.isenabled()
            gc.disable()
        _depth += 1
    try:
        yield
    finally:
        with _lock:
            _depth -= 1
            if _depth == 0 and _was_enabled:
                gc.enable()


_was_enabled = True


def without_collector(fn):
    """``fn`` run inside :func:`collector_paused`."""
    @functools.wraps(fn)
    def run(*args, **kwargs):
        with collector_paused():
            return fn(*args, **kwargs)
    return run
