"""The kernels' numba options keep NaN and infinity testable (riverflow/kernels/_jit.py)."""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from riverflow.kernels._jit import FASTMATH, is_finite


@njit(fastmath=FASTMATH)
def _blend_is_finite(a, u):
    return is_finite((1.0 - u) * a[0] + u * a[1])


@njit(fastmath=FASTMATH)
def _blend_math_isfinite(a, u):
    return math.isfinite((1.0 - u) * a[0] + u * a[1])


def test_is_finite_sees_a_computed_nan_and_inf():
    for dtype in (np.float32, np.float64):
        assert not _blend_is_finite(np.array([np.nan, 1.0], dtype), 0.3)
        assert not _blend_is_finite(np.array([np.inf, 1.0], dtype), 0.3)
        assert _blend_is_finite(np.array([2.0, 1.0], dtype), 0.3)


def test_math_isfinite_is_what_we_avoid():
    """Documents why :func:`is_finite` exists: if numba ever compiles math.isfinite right
    under these flags, this fails and the workaround can go."""
    assert _blend_math_isfinite(np.array([np.nan, 1.0], np.float32), 0.3)
