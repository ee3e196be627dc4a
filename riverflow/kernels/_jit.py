"""The one place where numba options are chosen (no ``fastmath=`` anywhere else).

fastmath without ``nnan``/``ninf`` so kernels may still test for NaN and infinity.
``cache=True`` keeps the machine code in a per-user folder keyed by the sources
(:mod:`riverflow.kernels._cache`).

Test finiteness with :func:`is_finite`, never ``math.isfinite``: under these flags (the pair
``nsz`` + ``reassoc``, numba 0.68 / LLVM 20) ``math.isfinite`` of a *computed* value, e.g. a
bilinear blend of a NaN corner, is compiled to True for NaN; ``math.isnan`` and
``math.isinf`` stay exact (``tests/kernels/test_jit_options.py``).
"""
from __future__ import annotations

import math

from numba import njit

FASTMATH = {"nsz", "arcp", "contract", "afn", "reassoc"}  # numba wants a set, not a frozenset
JIT_OPTIONS = dict(cache=True, nogil=False, fastmath=FASTMATH, error_model="numpy")
"""Options for every entry kernel and helper. The frame's kernels keep the GIL: one that
released it would let the tile worker take it, and getting it back can cost up to the
interpreter's switch interval (5 ms) per call."""
EXACT_JIT_OPTIONS = dict(JIT_OPTIONS, fastmath=False)
"""Options of a kernel that must give numpy's numbers bit for bit (no contraction into fused
multiply-adds, no reassociation)."""
WORKER_JIT_OPTIONS = dict(JIT_OPTIONS, nogil=True)
"""Options of the kernels the tile worker runs (tile production): they release the GIL, so
the frame goes on meanwhile."""


@njit(inline="always", **JIT_OPTIONS)
def is_finite(x):
    """x is neither NaN nor ±inf (what ``math.isfinite`` should say; module docstring)."""
    return not (math.isnan(x) or math.isinf(x))
