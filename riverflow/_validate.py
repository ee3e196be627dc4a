"""Checks of what the public API is given (issue #30): one small module, used at every entry
point, so that bad input gets a clear ``ValueError`` / ``TypeError`` naming the argument and
the value, never a library's error from deep inside or a silently reinterpreted array.

Checks run at the public boundary only (once per call), never inside per-frame loops.

The resource limit: every allocation that scales with an input (grids, lattices, rasters,
tiles, rain drops, images) is estimated first with :func:`check_allocation` and refused with a
:class:`ResourceLimitError` naming the input and the size when it is over
:func:`memory_limit_bytes` (default half the machine's memory; ``rf.set_memory_limit``, or
the ``RIVERFLOW_MEMORY_LIMIT_MB`` environment variable).
"""
from __future__ import annotations

import math
import numbers
import os

import numpy as np

__all__ = ["ResourceLimitError", "as_points", "check_allocation", "choice", "finite",
           "finite_positive", "memory_limit_bytes", "non_negative", "set_memory_limit",
           "size_px"]

DEFAULT_MEMORY_FRACTION = 0.5
"""The default limit: this fraction of the machine's physical memory."""

_limit_bytes: int | None = None


class ResourceLimitError(ValueError, MemoryError):
    """An input asks for more memory than :func:`memory_limit_bytes` allows (a ValueError,
    since the input is what is wrong, and a MemoryError, for code that catches those)."""


def _machine_bytes() -> int:
    try:
        return int(os.sysconf("SC_PAGE_SIZE")) * int(os.sysconf("SC_PHYS_PAGES"))
    except (AttributeError, OSError, ValueError):
        return 8 << 30


def memory_limit_bytes() -> int:
    """The most bytes one input may make riverflow allocate (module docstring)."""
    if _limit_bytes is not None:
        return _limit_bytes
    env = os.environ.get("RIVERFLOW_MEMORY_LIMIT_MB")
    if env:
        try:
            mb = float(env)
        except ValueError:
            raise ValueError(f"RIVERFLOW_MEMORY_LIMIT_MB must be a number of MB, got {env!r}") \
                from None
        if math.isfinite(mb) and mb > 0:
            return int(mb * (1 << 20))
        raise ValueError(f"RIVERFLOW_MEMORY_LIMIT_MB must be positive, got {env!r}")
    return int(DEFAULT_MEMORY_FRACTION * _machine_bytes())


def set_memory_limit(nbytes: int | None) -> None:
    """Set the limit [bytes] (None: back to the default)."""
    global _limit_bytes
    if nbytes is not None:
        nbytes = int(finite_positive(nbytes, "set_memory_limit: nbytes"))
    _limit_bytes = nbytes


def _gib(nbytes: float) -> str:
    if nbytes >= 1 << 30:
        return f"{nbytes / (1 << 30):,.1f} GiB"
    return f"{nbytes / (1 << 20):,.1f} MiB"


def check_allocation(nbytes: float, what: str) -> None:
    """Refuse an allocation of about ``nbytes`` for ``what`` (which names the input and its
    value, e.g. "FlowField: lattice_cells=100000") when over the limit."""
    limit = memory_limit_bytes()
    if not (nbytes <= limit):            # NaN / inf estimates are over the limit too
        raise ResourceLimitError(f"{what} needs about {_gib(float(nbytes))} of memory, over the "
                                 f"limit of {_gib(limit)} (riverflow.set_memory_limit(nbytes) "
                                 "or RIVERFLOW_MEMORY_LIMIT_MB to change it)")


def _number(value, name: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (numbers.Real, np.number)) \
            or isinstance(value, np.complexfloating):
        raise TypeError(f"{name} must be a number, got {type(value).__name__} {value!r}")
    try:
        return float(value)
    except OverflowError:
        return math.inf if value > 0 else -math.inf


def finite(value, name: str) -> float:
    """``value`` as a float; TypeError if it is not a real number, ValueError if NaN/inf."""
    v = _number(value, name)
    if not math.isfinite(v):
        raise ValueError(f"{name} must be a finite number, got {value!r}")
    return v


def finite_positive(value, name: str) -> float:
    v = finite(value, name)
    if not v > 0.0:
        raise ValueError(f"{name} must be positive, got {value!r}")
    return v


def non_negative(value, name: str) -> float:
    v = finite(value, name)
    if v < 0.0:
        raise ValueError(f"{name} must be ≥ 0, got {value!r}")
    return v


def seed(value, name: str) -> int:
    """A random seed: a whole number ≥ 0 (what numpy's generators take)."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)):
        raise ValueError(f"{name} must be a whole number ≥ 0, got {value!r:.80}")
    if value < 0:
        raise ValueError(f"{name} must be ≥ 0, got {value!r}")
    return int(value)


def choice(value, name: str, options) -> object:
    """``value`` if it is one of ``options``, else a ValueError listing them."""
    try:
        ok = value in options
    except TypeError:
        ok = False
    if not ok:
        raise ValueError(f"{name} must be one of {', '.join(map(repr, options))}, got {value!r}")
    return value


def size_px(size, name: str, *, limit: int = 1 << 15) -> tuple[int, int]:
    """(W, H) positive whole numbers of pixels, each at most ``limit``."""
    try:
        w, h = size
    except (TypeError, ValueError):
        raise TypeError(f"{name} must be (width, height) [px], got {size!r}") from None
    out = []
    for v in (w, h):
        if isinstance(v, bool) or not isinstance(v, (numbers.Integral, np.integer)):
            if isinstance(v, (float, np.floating)) and float(v).is_integer():
                v = int(v)
            else:
                raise TypeError(f"{name} must be whole pixels (width, height), got {size!r}")
        if not 1 <= int(v) <= limit:
            raise ValueError(f"{name} must be 1 … {limit} px a side, got {size!r}")
        out.append(int(v))
    return out[0], out[1]


def as_points(xy, name: str = "xy", *, allow_nan: bool = False,
              finite: bool = True) -> np.ndarray:
    """``xy`` as a C-contiguous (N, 2) float64 array of points [m].

    An (N, 2) array or sequence of pairs, or one (2,) point; anything else — a (2, N) array,
    (N, 3), a ragged list, strings, complex numbers — is an error, never reshaped into other
    points. NaN / inf coordinates are a ValueError naming the first bad row (``allow_nan``:
    NaN rows pass; ``finite=False``: no finiteness check, for queries that answer such points
    with a clear status).
    """
    if type(xy) is np.ndarray and xy.dtype == np.float64 and xy.ndim == 2 \
            and xy.shape[1] == 2:                   # the common case, in a few µs
        pts = xy if xy.flags.c_contiguous else np.ascontiguousarray(xy)
        if not finite or allow_nan or np.isfinite(pts).all():
            return pts
        return _check_finite(pts, name, allow_nan)
    if isinstance(xy, (str, bytes)):
        raise TypeError(f"{name} must be (N, 2) points [m], got {type(xy).__name__}")
    try:
        arr = np.asarray(xy)
    except ValueError as exc:             # ragged nested sequences
        raise ValueError(f"{name} must be (N, 2) points [m]: {exc}") from None
    if not np.issubdtype(arr.dtype, np.number) or np.issubdtype(arr.dtype, np.complexfloating):
        raise TypeError(f"{name} must be (N, 2) real numbers [m], got dtype {arr.dtype}")
    if arr.ndim == 1 and arr.shape == (2,):
        arr = arr[None]
    elif arr.size == 0 and arr.ndim <= 2 and (arr.ndim < 2 or arr.shape[1] in (0, 2)):
        arr = arr.reshape(0, 2)
    if arr.ndim != 2 or arr.shape[1] != 2:
        raise ValueError(f"{name} must be (N, 2) points [m], got shape {arr.shape}"
                         + (" (transposed? pass xy.T)" if arr.ndim == 2 and arr.shape[0] == 2
                            else ""))
    pts = np.ascontiguousarray(arr, dtype=np.float64)
    return _check_finite(pts, name, allow_nan) if finite else pts


def as_floats(value, name: str, error: type[Exception] = ValueError) -> np.ndarray:
    """``value`` as a float64 array; ``error`` naming ``name`` when it holds anything but real
    numbers (text, None, ragged lists, numbers past float's range)."""
    if isinstance(value, (str, bytes)):
        raise error(f"{name} must be numbers, got {type(value).__name__} {value!r:.60}")
    try:
        return np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError, OverflowError) as exc:
        raise error(f"{name} must be numbers, got {value!r:.60} ({exc})") from None


def _check_finite(pts: np.ndarray, name: str, allow_nan: bool) -> np.ndarray:
    bad = ~np.isfinite(pts)
    if allow_nan:
        bad &= ~np.isnan(pts)
    if bad.any():
        row = int(np.flatnonzero(bad.any(axis=1))[0])
        raise ValueError(f"{name} must hold finite coordinates [m]; row {row} is "
                         f"{pts[row].tolist()}")
    return pts
