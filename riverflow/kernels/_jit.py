"""The one place where numba options are chosen (no ``fastmath=`` anywhere else).

fastmath without ``nnan``/``ninf`` so kernels may still test for NaN and infinity.
``cache=True`` writes to ``NUMBA_CACHE_DIR`` (the Makefile sets it to ``.numba_cache``).
"""
from __future__ import annotations

FASTMATH = {"nsz", "arcp", "contract", "afn", "reassoc"}  # numba wants a set, not a frozenset
JIT_OPTIONS = dict(cache=True, nogil=True, fastmath=FASTMATH, error_model="numpy")
"""Options for every entry kernel and helper."""
