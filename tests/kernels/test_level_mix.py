"""The k-nearest level mix and the nearest-sample kernels (:mod:`riverflow.kernels.level_mix`)
against their plain-numpy twins (every sample tried), bit for bit, in any batch."""
from __future__ import annotations

import numpy as np
import pytest

from riverflow.kernels.level_mix import mix_samples, mixed_levels, nearest_samples


def mixed_levels_twin(xy, level, k, p, band):
    """Brute force: the k least (squared distance, index) samples of each point, mixed as
    ``WaterSurface.bank_level`` mixes them (``land_level``: band inf)."""
    d2 = (p[:, 0:1] - xy[:, 0]) ** 2 + (p[:, 1:2] - xy[:, 1]) ** 2
    order = np.lexsort((np.broadcast_to(np.arange(len(xy)), d2.shape), d2), axis=1)[:, :k]
    d = np.sqrt(np.take_along_axis(d2, order, axis=1))
    extra = d - d[:, :1]
    span = np.maximum(extra[:, -1:], 1e-9)
    w = (1.0 - extra / span) ** 2 * np.clip(1.0 - extra / band[:, None], 0.0, 1.0) ** 2
    w[:, 0] = np.maximum(w[:, 0], 1e-12)
    return (w * level[order]).sum(axis=1) / w.sum(axis=1)


def nearest_samples_twin(xy, p):
    """Brute force: each point's nearest sample (the first of equally near ones) and
    whether another is as near."""
    d2 = (p[:, 0:1] - xy[:, 0]) ** 2 + (p[:, 1:2] - xy[:, 1]) ** 2
    best = d2.min(axis=1, keepdims=True)
    return np.argmin(d2, axis=1), (d2 == best).sum(axis=1) > 1


def _samples(rng, n, rounded):
    """Branch-like runs of samples; ``rounded``: on a 1 m grid with repeats (ties)."""
    xy = np.cumsum(rng.normal(size=(n, 2)) * rng.uniform(1.0, 12.0), axis=0)
    xy[rng.integers(0, n, n // 10)] += rng.uniform(-300.0, 300.0, (n // 10, 2))    # jumps
    if rounded:
        xy = np.round(xy)
        xy[rng.integers(0, n, n // 20)] = xy[rng.integers(0, n, n // 20)]
    return xy, rng.uniform(-5.0, 80.0, n)


def _points(rng, xy, m, rounded):
    p = xy[rng.integers(0, len(xy), m)] + rng.normal(size=(m, 2)) * rng.uniform(1.0, 400.0, (m, 1))
    p[: m // 4] = np.sort(p[: m // 4], axis=0)         # runs of near neighbours, as a tile's
    return np.round(p) if rounded else p


def _in_batches(kernel, p, rng, *per_point):
    """The kernel's answers (a tuple of (N, …) arrays) for points p in one batch and in a few
    random chunks, in order, reversed and shuffled."""
    n = len(p)
    for order in (np.arange(n), np.arange(n)[::-1], rng.permutation(n)):
        for pieces in ([order], np.split(order, np.sort(rng.integers(0, n, 5)))):
            outs = None
            for piece in pieces:
                if len(piece):
                    got = kernel(p[piece], *(a[piece] for a in per_point))
                    if outs is None:
                        outs = [np.empty((n,) + g.shape[1:], g.dtype) for g in got]
                    for o, g in zip(outs, got):
                        o[piece] = g
            yield outs


@pytest.mark.parametrize("trial", range(8))
def test_mixed_levels_match_the_twin_in_any_batch(trial):
    rng = np.random.default_rng(trial)
    rounded = trial % 2 == 1
    xy, level = _samples(rng, int(rng.integers(30, 900)), rounded)
    s = mix_samples(xy, level)
    p = _points(rng, xy, 300, rounded)
    band = np.where(rng.random(len(p)) < 0.5, np.inf, rng.uniform(0.5, 30.0, len(p)))
    for k in (2, 5, 8, 13, 24):
        def kernel(q, b):
            out = np.empty(len(q))
            mixed_levels(s, k, np.ascontiguousarray(q), np.ascontiguousarray(b), out)
            return (out,)
        want = mixed_levels_twin(xy, level, k, p, band)
        for (got,) in _in_batches(kernel, p, rng, band):
            np.testing.assert_array_equal(got, want)     # bit for bit


@pytest.mark.parametrize("trial", range(6))
def test_nearest_samples_match_the_twin_in_any_batch(trial):
    rng = np.random.default_rng(100 + trial)
    rounded = trial % 2 == 1
    xy, level = _samples(rng, int(rng.integers(1, 900)) if trial else 1, rounded)
    s = mix_samples(xy, level)
    p = _points(rng, xy, 400, rounded)
    p[:20] = xy[rng.integers(0, len(xy), 20)]          # on samples (repeated ones: ties)

    def kernel(q):
        k = np.empty(len(q), np.int64)
        tie = np.empty(len(q), bool)
        nearest_samples(s, np.ascontiguousarray(q), k, tie)
        return k, tie
    want_k, want_tie = nearest_samples_twin(xy, p)
    if rounded:
        assert want_tie.any()
    for k, tie in _in_batches(kernel, p, rng):
        np.testing.assert_array_equal(tie, want_tie)
        np.testing.assert_array_equal(k, want_k)         # of equally near ones, the first


def test_samples_are_stored_so_that_each_run_lies_in_one_place():
    """A network's branches listed upstream first lie all over the map: in their own order
    a run of LEAF samples straddling two branches had a box across the map, which every
    walk entered (NHD's Shellmound: 14 µs a point, 2.5 in Z order). Stored in Z order,
    the runs' boxes are small; the index says where each came from."""
    from riverflow.kernels.polyline import LEAF, segment_boxes

    rng = np.random.default_rng(5)
    branches = [np.cumsum(rng.normal(size=(rng.integers(3, 40), 2)) * 2.0, axis=0)
                + rng.uniform(-20_000, 20_000, 2) for _ in range(300)]
    xy = np.concatenate(branches)
    s = mix_samples(xy, np.arange(len(xy), dtype=np.float64))
    assert np.array_equal(np.sort(s.index), np.arange(len(xy)))
    assert np.array_equal(s.xy, xy[s.index]) and np.array_equal(s.level, s.index.astype(float))

    def leaf_area(boxes):
        leaves = boxes[(len(boxes) + 1) // 2 - 1:]
        leaves = leaves[np.isfinite(leaves[:, 0])]
        return float(np.sum((leaves[:, 2] - leaves[:, 0]) * (leaves[:, 3] - leaves[:, 1])))
    raw = leaf_area(segment_boxes(xy, np.zeros_like(xy)))
    assert leaf_area(s.boxes) < 0.05 * raw
    assert len(xy) > 40 * LEAF
