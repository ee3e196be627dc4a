"""Each query point's nearest segment of one polyline, through a box hierarchy over its
consecutive segments (:class:`riverflow.hydro.nearest.PolylineIndex`).

A polyline's consecutive segments lie side by side, so runs of them make tight boxes without
sorting: leaves of :data:`LEAF` consecutive segments, and a complete binary tree (heap order,
node ``i``'s children ``2i + 1`` and ``2i + 2``) whose node boxes bound consecutive runs of
leaves. A query walks it depth first, nearer child first, and skips every box farther than
the best segment so far (or than ``max_distance``): O(log n) box tests and a few leaves for a
point near the line, a handful of box tests for one far from it.

The winner is the segment whose nearest point is nearest (exact options: no fused
multiply-adds); of equally near segments, the first. Boxes equal to the best distance are
still searched, so the answer does not depend on the visiting order, nor on the batch: a
point's search starts bounded by the previous point's distance plus the step between them (a
batch's consecutive points are mostly neighbours: a tile's nodes), a bound no nearer than
its answer. The kernel also
projects the point there (distance, nearest point, arc length): done in numpy afterwards,
the small arrays of the many short queries cost 5 - 10 times the search.
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from riverflow.kernels._jit import EXACT_JIT_OPTIONS

LEAF = 8
"""Consecutive segments in one leaf box."""


def segment_boxes(a: np.ndarray, d: np.ndarray) -> np.ndarray:
    """The box hierarchy (2P − 1, 4) [x0, y0, x1, y1] of segments from ``a`` (n, 2) by ``d``
    (n, 2): P ≥ 1 leaves (a power of two) of :data:`LEAF` consecutive segments; boxes of
    missing leaves are empty (x0 = +inf, x1 = −inf: never searched)."""
    n = len(a)
    leaves = max(1, -(-n // LEAF))
    p = 1 << (leaves - 1).bit_length()
    lo = np.minimum(a, a + d)
    hi = np.maximum(a, a + d)
    pad = p * LEAF - n
    lo = np.concatenate([lo, np.full((pad, 2), np.inf)]).reshape(p, LEAF, 2).min(axis=1)
    hi = np.concatenate([hi, np.full((pad, 2), -np.inf)]).reshape(p, LEAF, 2).max(axis=1)
    boxes = np.empty((2 * p - 1, 4))
    level = np.concatenate([lo, hi], axis=1)
    start = p - 1
    boxes[start:] = level
    while start > 0:
        level = np.concatenate([np.minimum(level[0::2, :2], level[1::2, :2]),
                                np.maximum(level[0::2, 2:], level[1::2, 2:])], axis=1)
        start = (start - 1) // 2
        boxes[start:start + len(level)] = level
    return boxes


@njit(inline="always", **EXACT_JIT_OPTIONS)
def _box_d2(boxes, node, x, y):
    """Squared distance from (x, y) to a node's box (inf for an empty box)."""
    x0 = boxes[node, 0]
    if x0 > boxes[node, 2]:
        return math.inf
    dx = max(x0 - x, 0.0, x - boxes[node, 2])
    dy = max(boxes[node, 1] - y, 0.0, y - boxes[node, 3])
    return dx * dx + dy * dy


@njit(inline="always", **EXACT_JIT_OPTIONS)
def _walk_bound(prev_r, prev_x, prev_y, x, y):
    """A bound on a point's answer [m] from the previous point's (``prev_r`` at ``prev_x,
    prev_y``; inf or NaN: none): that distance plus the step between them, a little wider
    (rounding); boxes beyond it are skipped from the start."""
    return (prev_r + math.hypot(x - prev_x, y - prev_y)) * (1.0 + 1e-9) + 1e-6


@njit(inline="always", **EXACT_JIT_OPTIONS)
def _push_children(boxes, node, x, y, stack, stack_d2, top):
    """Push a node's two children on the search stack at ``top`` with their boxes' squared
    distances, the nearer on top (searched first); returns the new top."""
    c0 = 2 * node + 1
    c1 = c0 + 1
    d0 = _box_d2(boxes, c0, x, y)
    d1 = _box_d2(boxes, c1, x, y)
    if d0 <= d1:
        stack[top] = c1
        stack_d2[top] = d1
        stack[top + 1] = c0
        stack_d2[top + 1] = d0
    else:
        stack[top] = c0
        stack_d2[top] = d0
        stack[top + 1] = c1
        stack_d2[top + 1] = d1
    return top + 2


class Polyline(NamedTuple):
    """One polyline's segments for :func:`nearest_points`: segment ``j`` runs from ``a[j]``
    (n, 2) by ``d[j]`` (n, 2); ``boxes`` from :func:`segment_boxes`; ``s0`` (n,) the arc
    length at each segment's start and ``seg_len`` (n,) its length [m]."""

    a: np.ndarray
    d: np.ndarray
    boxes: np.ndarray
    s0: np.ndarray
    seg_len: np.ndarray


class Nearest(NamedTuple):
    """What :func:`nearest_points` writes per query point: ``seg`` (N,) the nearest segment
    (−1: none within reach), ``dist`` (N,) [m] (inf where none), ``point`` (N, 2) the nearest
    point and ``arc`` (N,) its arc length from the line's start [m] (NaN where none)."""

    seg: np.ndarray
    dist: np.ndarray
    point: np.ndarray
    arc: np.ndarray


@njit(**EXACT_JIT_OPTIONS)
def nearest_points(line, xy, max_d2, out):
    """For each point ``xy[i]`` (N, 2): its nearest segment of ``line`` (a :class:`Polyline`)
    within ``max_d2`` [m²] (inf: no limit), and the distance, nearest point and arc length
    there, into ``out`` (a :class:`Nearest`). The point is ``a + t·d`` with t the clamped
    projection parameter, the distance the ``hypot`` of its offset and the arc length
    ``s0 + t·seg_len``, in numpy's operations."""
    a = line.a
    d = line.d
    boxes = line.boxes
    n = a.shape[0]
    first_leaf = (boxes.shape[0] + 1) // 2 - 1
    stack = np.empty(128, np.int64)
    stack_d2 = np.empty(128)
    prev_x = math.nan
    prev_y = math.nan
    prev_d = math.inf
    for i in range(xy.shape[0]):
        x = xy[i, 0]
        y = xy[i, 1]
        bound = _walk_bound(prev_d, prev_x, prev_y, x, y)
        best = min(max_d2, bound * bound) if bound < math.inf else max_d2
        best_seg = -1
        best_t = 0.0
        top = 0
        stack[0] = 0
        stack_d2[0] = _box_d2(boxes, 0, x, y)
        top = 1
        while top > 0:
            top -= 1
            node = stack[top]
            if stack_d2[top] > best:
                continue
            if node >= first_leaf:
                j0 = (node - first_leaf) * LEAF
                for j in range(j0, min(j0 + LEAF, n)):
                    ax = a[j, 0]
                    ay = a[j, 1]
                    dx = d[j, 0]
                    dy = d[j, 1]
                    dd = dx * dx + dy * dy
                    t = 0.0
                    if dd > 0.0:
                        t = ((x - ax) * dx + (y - ay) * dy) / dd
                    t = min(max(t, 0.0), 1.0)
                    qx = ax + t * dx - x
                    qy = ay + t * dy - y
                    d2 = qx * qx + qy * qy
                    if d2 < best or (d2 == best and (best_seg < 0 or j < best_seg)):
                        best = d2
                        best_seg = j
                        best_t = t
                continue
            top = _push_children(boxes, node, x, y, stack, stack_d2, top)
        out.seg[i] = best_seg
        if best_seg < 0:
            prev_d = math.inf
            out.dist[i] = math.inf
            out.point[i, 0] = math.nan
            out.point[i, 1] = math.nan
            out.arc[i] = math.nan
        else:
            px = a[best_seg, 0] + best_t * d[best_seg, 0]
            py = a[best_seg, 1] + best_t * d[best_seg, 1]
            out.point[i, 0] = px
            out.point[i, 1] = py
            out.dist[i] = math.hypot(px - x, py - y)
            prev_x = x
            prev_y = y
            prev_d = out.dist[i]
            out.arc[i] = line.s0[best_seg] + best_t * line.seg_len[best_seg]
