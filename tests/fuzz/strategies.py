"""Shared Hypothesis settings and strategies of the fuzz suite."""
from __future__ import annotations

import math

import numpy as np
from hypothesis import HealthCheck, settings
from hypothesis import strategies as st

FUZZ = settings(derandomize=True, max_examples=30, deadline=None, database=None,
                suppress_health_check=[HealthCheck.function_scoped_fixture,
                                       HealthCheck.too_slow])
"""Fixed seed, small budget: the same cases on every run and machine."""

NON_FINITE = st.sampled_from([math.nan, math.inf, -math.inf])
EXTREME = st.one_of(NON_FINITE, st.sampled_from([0.0, -0.0, -1.0, -1e300, 5e-324, -5e-324]))
BAD = st.one_of(NON_FINITE, st.sampled_from([0.0, -0.0, -1.0, -1e300, -5e-324]))
"""Not a finite positive number."""
ANY_FLOAT = st.floats(allow_nan=True, allow_infinity=True)


def bad_shapes():
    """Shapes that are not (N, 2), (2,) or empty: (2, N), (N, 3), 0-d, 3-d …"""
    dims = st.lists(st.integers(0, 5), min_size=0, max_size=3).map(tuple)
    return dims.filter(lambda s: not (len(s) == 2 and s[1] == 2) and s != (2,)
                       and not (np.prod(s, dtype=int) == 0 and len(s) <= 2
                                and (len(s) < 2 or s[1] in (0, 2))))


def assert_names(exc_info, *names: str) -> None:
    msg = str(exc_info.value)
    for name in names:
        assert name in msg, msg
