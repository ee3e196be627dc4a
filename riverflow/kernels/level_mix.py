"""The level seen from the land: the levels of a point's k nearest centre-line samples, mixed
(:func:`mixed_levels`: :meth:`riverflow.scenes.water.WaterSurface.land_level` and
``bank_level``), and a point's nearest sample (:func:`nearest_samples`: ``_Samples.project``).

The samples are found through a box hierarchy over runs of LEAF samples stored in their own
order or in Z order (:func:`mix_samples`; :func:`riverflow.kernels.polyline.segment_boxes`
of zero-length segments: each run and each box above lie in one place), walked depth first, nearer child first, skipping every box farther than
the k-th sample so far. A batch's consecutive points are mostly neighbours (a tile's lattice
nodes): the previous point's k-th distance plus the step between the two bounds the next
one's, so its walk skips the far boxes from the start. The answer is each point's alone
whatever batch it is in: the k least (squared distance, index), boxes as near as the k-th
still searched (the index the samples were given, not their stored place, breaks ties). The mix is done in numpy's floating-point operations and order (no
fast-math; a row of k summed as numpy sums it), so it is the KD-tree and numpy code's number
bit for bit wherever no two of the k samples are equally near (the KD-tree may list those in
another order: the last bit; a tie for the k-th place weighs 0 either way).
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from riverflow.kernels._jit import EXACT_JIT_OPTIONS
from riverflow.kernels.polyline import (LEAF, _box_d2, _push_children, _walk_bound,
                                        segment_boxes)

MAX_NEIGHBOURS = 128
"""The most samples one point mixes (numpy's pairwise sum is one block up to this many)."""


class MixSamples(NamedTuple):
    """Samples as :func:`mixed_levels` reads them: ``xy`` (S, 2) [m], their ``level`` (S,) [m]
    and ``boxes`` over runs of consecutive ones, stored in a spatial order
    (:func:`mix_samples`); ``index`` (S,) each stored sample's own index (the order the
    kernels answer in and break ties by)."""
    xy: np.ndarray
    level: np.ndarray
    boxes: np.ndarray
    index: np.ndarray


def _morton(xy: np.ndarray) -> np.ndarray:
    """(N,) uint64 Z-order codes of points (N, 2) on a 2¹⁶ grid over their box."""
    lo = xy.min(axis=0)
    span = np.maximum(xy.max(axis=0) - lo, 1e-300)
    q = np.minimum((xy - lo) / span * 65535.0, 65535.0).astype(np.uint64)
    code = np.zeros(len(xy), np.uint64)
    for bit in range(16):
        b = np.uint64(bit)
        code |= ((q[:, 0] >> b) & np.uint64(1)) << np.uint64(2 * bit)
        code |= ((q[:, 1] >> b) & np.uint64(1)) << np.uint64(2 * bit + 1)
    return code


def _boxes_area(boxes: np.ndarray) -> float:
    """The summed area of a box hierarchy's boxes (what a walk's visits grow with)."""
    live = boxes[:, 0] <= boxes[:, 2]
    return float(np.sum((boxes[live, 2] - boxes[live, 0]) * (boxes[live, 3] - boxes[live, 1])))


def mix_samples(xy: np.ndarray, level: np.ndarray) -> MixSamples:
    """:class:`MixSamples` of samples ``xy`` (S ≥ 1, 2) [m] with their ``level`` (S,) [m],
    stored in their own order or in Z order (:func:`_morton`), whichever gives the boxes the
    smaller summed area. A river's samples in their own order make boxes along it; a
    network's branches, listed upstream first, lie all over the map, and a run of LEAF
    samples straddling two of them had a box across it, which every walk entered (NHD's
    Shellmound, 952,000 samples of 1,000 branches: 14 µs a point, a KD-tree's 0.5; in Z
    order, 2.5 µs)."""
    xy = np.ascontiguousarray(xy, np.float64).reshape(-1, 2)
    level = np.ascontiguousarray(level, np.float64).reshape(-1)
    boxes = segment_boxes(xy, np.zeros_like(xy))
    if len(xy) > LEAF and np.isfinite(xy).all():
        order = np.argsort(_morton(xy), kind="stable")
        z_xy = np.ascontiguousarray(xy[order])
        z_boxes = segment_boxes(z_xy, np.zeros_like(z_xy))
        if _boxes_area(z_boxes) < _boxes_area(boxes):
            return MixSamples(z_xy, np.ascontiguousarray(level[order]), z_boxes, order)
    return MixSamples(xy, level, boxes, np.arange(len(xy), dtype=np.int64))


@njit(inline="always", **EXACT_JIT_OPTIONS)
def _numpy_sum(a, n):
    """a[0] + … + a[n − 1] in the order of numpy's pairwise sum of a contiguous row of
    n ≤ 128 (eight running sums, then the rest one by one)."""
    if n < 8:
        res = -0.0
        for i in range(n):
            res += a[i]
        return res
    r0, r1, r2, r3 = a[0], a[1], a[2], a[3]
    r4, r5, r6, r7 = a[4], a[5], a[6], a[7]
    i = 8
    while i < n - n % 8:
        r0 += a[i]
        r1 += a[i + 1]
        r2 += a[i + 2]
        r3 += a[i + 3]
        r4 += a[i + 4]
        r5 += a[i + 5]
        r6 += a[i + 6]
        r7 += a[i + 7]
        i += 8
    res = ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))
    while i < n:
        res += a[i]
        i += 1
    return res


@njit(**dict(EXACT_JIT_OPTIONS, nogil=True))    # a tile worker's: the frame goes on
def mixed_levels(samples, k, p, band, out):
    """For each point ``p[i]`` (N, 2) [m]: its ``k`` (2 ≤ k ≤ min(S, MAX_NEIGHBOURS))
    nearest ``samples`` (:class:`MixSamples`) at distances d_0 ≤ … ≤ d_{k−1}, mixed with
    weights (1 − e / span)² · clip(1 − e / band[i], 0, 1)², e = d − d_0, span =
    max(d_{k−1} − d_0, 1e-9), the nearest one's at least 1e-12, into ``out[i]`` (N,):
    Σ w·level / Σ w. ``band[i]`` = inf: no band (the factor is 1)."""
    xy = samples.xy
    levels = samples.level
    boxes = samples.boxes
    index = samples.index
    n = xy.shape[0]
    first_leaf = (boxes.shape[0] + 1) // 2 - 1
    stack = np.empty(128, np.int64)
    stack_d2 = np.empty(128)
    best_d2 = np.empty(k)
    best_j = np.empty(k, np.int64)
    wl = np.empty(k)
    w = np.empty(k)
    prev_x = math.nan
    prev_y = math.nan
    prev_r = math.inf
    for i in range(p.shape[0]):
        x = p[i, 0]
        y = p[i, 1]
        # every sample within the bound is searched: the previous point's k nearest are
        # within it (a little wider than the triangle inequality: rounding), so its k
        # nearest are too
        bound = _walk_bound(prev_r, prev_x, prev_y, x, y)
        limit = bound * bound if bound < math.inf else math.inf
        count = 0
        top = 1
        stack[0] = 0
        stack_d2[0] = _box_d2(boxes, 0, x, y)
        while top > 0:
            top -= 1
            node = stack[top]
            far = limit if count < k else min(limit, best_d2[k - 1])
            if stack_d2[top] > far:
                continue
            if node >= first_leaf:
                j0 = (node - first_leaf) * LEAF
                for j in range(j0, min(j0 + LEAF, n)):
                    dx = x - xy[j, 0]
                    dy = y - xy[j, 1]
                    d2 = dx * dx + dy * dy
                    if count == k:
                        last = best_d2[k - 1]
                        if d2 > last or (d2 == last and index[j] > index[best_j[k - 1]]):
                            continue
                        m = k - 1
                    else:
                        if d2 > limit:
                            continue
                        m = count
                        count += 1
                    # insert (d2, j) in order, the last one out when full
                    while m > 0 and (best_d2[m - 1] > d2
                                     or (best_d2[m - 1] == d2
                                         and index[best_j[m - 1]] > index[j])):
                        best_d2[m] = best_d2[m - 1]
                        best_j[m] = best_j[m - 1]
                        m -= 1
                    best_d2[m] = d2
                    best_j[m] = j
                continue
            top = _push_children(boxes, node, x, y, stack, stack_d2, top)
        if count < k:       # not finite (a NaN point): no bound for the next one either
            out[i] = math.nan
            prev_r = math.inf
            continue
        prev_x = x
        prev_y = y
        prev_r = math.sqrt(best_d2[k - 1])
        d_first = math.sqrt(best_d2[0])
        span = max(prev_r - d_first, 1e-9)
        for m in range(k):
            extra = math.sqrt(best_d2[m]) - d_first
            a = 1.0 - extra / span
            b = min(max(1.0 - extra / band[i], 0.0), 1.0)
            w[m] = a * a * (b * b)
        w[0] = max(w[0], 1e-12)
        for m in range(k):
            wl[m] = w[m] * levels[best_j[m]]
        out[i] = _numpy_sum(wl, k) / _numpy_sum(w, k)


@njit(**dict(EXACT_JIT_OPTIONS, nogil=True))    # a tile worker's: the frame goes on
def nearest_samples(samples, p, out_nearest, out_tie):
    """For each point ``p[i]`` (N, 2) [m]: its nearest of ``samples`` (:class:`MixSamples`)
    into ``out_nearest[i]`` (N,) int64, the first of the nearest ones, and ``out_tie[i]``
    (N,) bool: whether another one is as near (a KD-tree may answer either) or none was
    found (the point is not finite)."""
    xy = samples.xy
    boxes = samples.boxes
    index = samples.index
    n = xy.shape[0]
    first_leaf = (boxes.shape[0] + 1) // 2 - 1
    stack = np.empty(128, np.int64)
    stack_d2 = np.empty(128)
    prev_x = math.nan
    prev_y = math.nan
    prev_r = math.inf
    for i in range(p.shape[0]):
        x = p[i, 0]
        y = p[i, 1]
        bound = _walk_bound(prev_r, prev_x, prev_y, x, y)
        best = bound * bound if bound < math.inf else math.inf
        best_j = -1
        tie = False
        top = 1
        stack[0] = 0
        stack_d2[0] = _box_d2(boxes, 0, x, y)
        while top > 0:
            top -= 1
            node = stack[top]
            if stack_d2[top] > best:
                continue
            if node >= first_leaf:
                j0 = (node - first_leaf) * LEAF
                for j in range(j0, min(j0 + LEAF, n)):
                    dx = x - xy[j, 0]
                    dy = y - xy[j, 1]
                    d2 = dx * dx + dy * dy
                    if d2 < best or (best_j < 0 and d2 == best):
                        best = d2
                        best_j = j
                        tie = False
                    elif d2 == best:
                        tie = True
                        if index[j] < index[best_j]:
                            best_j = j
                continue
            top = _push_children(boxes, node, x, y, stack, stack_d2, top)
        out_nearest[i] = index[best_j] if best_j >= 0 else 0
        out_tie[i] = tie or best_j < 0
        if best_j < 0:
            prev_r = math.inf
        else:
            prev_x = x
            prev_y = y
            prev_r = math.sqrt(best)
