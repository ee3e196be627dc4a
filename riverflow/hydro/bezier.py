"""Bézier flattening of Proland curves (reference §1.1).

A curve's vertex list mixes regular vertices (on the curve) and control vertices: one control
vertex between two regular ones is a quadratic patch, two consecutive ones a cubic patch. Patches
are subdivided (de Casteljau, halving) until the control polygon is within ``tolerance_m`` of the
chord — Proland's ``squareFlat`` test.
"""
from __future__ import annotations

import numpy as np

_MAX_DEPTH = 16


def flatten_curve(vertices: np.ndarray, is_control: np.ndarray, tolerance_m: float) -> np.ndarray:
    """Flatten a vertex list with Bézier control points into a polyline.

    Args:
        vertices: (M, 2) float [m], first and last are regular (the curve's nodes).
        is_control: (M,) bool.
        tolerance_m: largest distance of a control point from its chord before a patch is split.

    Returns:
        (K, 2) float64 polyline through every regular vertex, in order.

    Raises:
        ValueError: more than two control vertices in a row, or a control vertex at an end.
    """
    v = np.asarray(vertices, dtype=np.float64)
    ctrl = np.asarray(is_control, dtype=bool)
    if len(v) == 0:
        return v.reshape(0, 2)
    if ctrl[0] or ctrl[-1]:
        raise ValueError("a curve cannot start or end on a Bézier control vertex")
    if not ctrl.any():                      # a plain polyline (every builder-made curve)
        return v.copy()
    tol2 = max(float(tolerance_m), 1e-6) ** 2
    out = [v[0]]
    i = 0
    while i < len(v) - 1:
        j = i + 1
        while j < len(v) and ctrl[j]:
            j += 1
        n_ctrl = j - i - 1
        if n_ctrl > 2:
            raise ValueError(f"{n_ctrl} Bézier control vertices in a row at vertex {i + 1} (at most 2)")
        if j >= len(v):
            raise ValueError("a curve cannot end on a Bézier control vertex")
        patch = v[i : j + 1]
        if n_ctrl == 0:
            out.append(v[j])
        else:
            _subdivide(patch, tol2, 0, out)
        i = j
    return np.asarray(out)


def _subdivide(p: np.ndarray, tol2: float, depth: int, out: list) -> None:
    """Append the flattened patch ``p`` (control polygon, 3 or 4 points) minus its first point."""
    a, b = p[0], p[-1]
    ab = b - a
    l2 = float(ab @ ab)
    worst = 0.0
    for c in p[1:-1]:
        ac = c - a
        if l2 > 0.0:
            t = min(max(float(ac @ ab) / l2, 0.0), 1.0)
            d = ac - t * ab
        else:
            d = ac
        worst = max(worst, float(d @ d))
    if worst <= tol2 or depth >= _MAX_DEPTH:
        out.append(b)
        return
    left, right = _split_half(p)
    _subdivide(left, tol2, depth + 1, out)
    _subdivide(right, tol2, depth + 1, out)


def _split_half(p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """de Casteljau split of a Bézier control polygon at t = 1/2."""
    levels = [p]
    while len(levels[-1]) > 1:
        q = levels[-1]
        levels.append(0.5 * (q[:-1] + q[1:]))
    left = np.array([lv[0] for lv in levels])
    right = np.array([lv[-1] for lv in reversed(levels)])
    return left, right
