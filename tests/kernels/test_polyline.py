"""The nearest-point kernel (:mod:`riverflow.kernels.polyline`) against its plain-numpy twin
(every segment tried, the first of the nearest taken, the point projected on it), and :class:`PolylineIndex` against
shapely's own distances."""
from __future__ import annotations

import numpy as np
import pytest
import shapely

from riverflow.hydro.nearest import PolylineIndex
from riverflow.kernels.polyline import LEAF, Nearest, Polyline, nearest_points, segment_boxes


def nearest_points_twin(a, d, xy, max_d2):
    """Brute force: for each point the first segment of least squared distance, in the
    kernel's operations; −1 where that exceeds ``max_d2``. Returns (segment, distance, nearest
    point, arc length), inf / NaN where none."""
    x, y = xy[:, 0:1], xy[:, 1:2]
    ax, ay, dx, dy = a[:, 0], a[:, 1], d[:, 0], d[:, 1]
    dd = dx * dx + dy * dy
    with np.errstate(invalid="ignore", divide="ignore"):
        t = np.where(dd > 0.0, ((x - ax) * dx + (y - ay) * dy) / np.where(dd > 0.0, dd, 1.0), 0.0)
    t = np.minimum(np.maximum(t, 0.0), 1.0)
    qx = ax + t * dx - x
    qy = ay + t * dy - y
    d2 = qx * qx + qy * qy
    seg = np.argmin(d2, axis=1)
    rows = np.arange(len(xy))
    best = d2[rows, seg]
    found = best <= max_d2
    tb = t[rows, seg]
    point = a[seg] + tb[:, None] * d[seg]
    dist = np.hypot(point[:, 0] - xy[:, 0], point[:, 1] - xy[:, 1])
    seg_len = np.hypot(dx, dy)
    s0 = np.concatenate([[0.0], np.cumsum(seg_len)[:-1]])
    arc = s0[seg] + tb * seg_len[seg]
    return (np.where(found, seg, -1), np.where(found, dist, np.inf),
            np.where(found[:, None], point, np.nan), np.where(found, arc, np.nan))


def _line(rng, n, rounded):
    steps = rng.normal(size=(n, 2)) * rng.uniform(0.5, 40.0)
    if rounded:     # grid points: many equally near segments and vertices
        steps = np.round(steps)
    return np.cumsum(steps, axis=0)


@pytest.mark.parametrize("trial", range(12))
def test_kernel_matches_twin(trial):
    rng = np.random.default_rng(trial)
    n = int(rng.integers(2, 2500)) if trial else 2      # one segment; then any count
    rounded = trial % 3 == 0
    p = _line(rng, n, rounded)
    a = np.ascontiguousarray(p[:-1])
    d = p[1:] - p[:-1]
    boxes = segment_boxes(a, d)
    leaves = (len(boxes) + 1) // 2
    assert leaves & (leaves - 1) == 0 and leaves * LEAF >= len(a)
    q = p[rng.integers(0, len(p), 400)] + rng.normal(size=(400, 2)) * rng.uniform(0.1, 500.0)
    if rounded:
        q = np.round(q)
    seg_len = np.hypot(d[:, 0], d[:, 1])
    line = Polyline(a, d, boxes, np.concatenate([[0.0], np.cumsum(seg_len)[:-1]]), seg_len)
    for max_d2 in (np.inf, float(rng.uniform(1.0, 200.0)) ** 2, 0.0):
        n = len(q)
        got = Nearest(np.empty(n, np.int64), np.empty(n), np.empty((n, 2)), np.empty(n))
        nearest_points(line, q, max_d2, got)
        for g, want in zip(got, nearest_points_twin(a, d, q, max_d2)):
            np.testing.assert_array_equal(g, want)     # bit for bit, inf and NaN included


def test_box_hierarchy_bounds_its_segments():
    rng = np.random.default_rng(5)
    p = _line(rng, 1000, False)
    a, d = p[:-1], p[1:] - p[:-1]
    boxes = segment_boxes(a, d)
    first = (len(boxes) + 1) // 2 - 1
    for j in range(len(a)):
        node = first + j // LEAF
        while True:
            x0, y0, x1, y1 = boxes[node]
            for e in (a[j], a[j] + d[j]):
                assert x0 <= e[0] <= x1 and y0 <= e[1] <= y1
            if node == 0:
                break
            node = (node - 1) // 2
    # a missing leaf's box is empty and never searched
    assert np.all(boxes[first + -(-len(a) // LEAF):, 0] == np.inf)


def test_index_answers_as_shapely():
    """Distance, nearest point and arc length agree with shapely's own (to rounding), far points
    beyond max_distance get inf and NaN."""
    rng = np.random.default_rng(7)
    p = _line(rng, 3000, False)
    line = shapely.LineString(p)
    index = PolylineIndex(p)
    q = p[rng.integers(0, len(p), 300)] + rng.normal(size=(300, 2)) * 60.0
    dist, near, arc = index.nearest(q)
    pts = shapely.points(q)
    np.testing.assert_allclose(dist, shapely.distance(pts, line), rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(np.hypot(*(near - q).T), dist, rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(shapely.distance(shapely.line_interpolate_point(line, arc), pts), dist,
                               rtol=1e-6, atol=1e-6)
    cut = 20.0
    d_cut, near_cut, arc_cut = index.nearest(q, cut)
    inside = dist <= cut
    np.testing.assert_array_equal(d_cut[inside], dist[inside])
    assert np.all(np.isinf(d_cut[~inside])) and np.isnan(near_cut[~inside]).all()
    assert np.isnan(arc_cut[~inside]).all()
    assert np.all(np.isfinite(index.distance(q)))


def test_index_of_a_point_and_of_nan_queries():
    index = PolylineIndex(np.array([[3.0, 4.0], [3.0, 4.0]]))     # degenerate: one point
    dist, near, arc = index.nearest(np.array([[0.0, 0.0], [np.nan, 1.0]]))
    assert dist[0] == 5.0 and np.array_equal(near[0], [3.0, 4.0]) and arc[0] == 0.0
    assert np.isinf(dist[1])


def test_index_of_rings_is_a_polygons_shore_whatever_the_batch():
    """:meth:`PolylineIndex.of_rings`: the distance to a multipolygon's outer rings and holes
    is shapely's to its boundary (no segment joins two rings), and a point's distance is the
    same bit for bit in any batch of points (tiles that share nodes agree on them)."""
    rng = np.random.default_rng(11)
    outer = shapely.Point(0.0, 0.0).buffer(400.0, 64)
    holes = [shapely.Point(x, y).buffer(r, 16) for x, y, r in
             ((-150.0, 0.0, 60.0), (120.0, 80.0, 40.0), (100.0, -150.0, 25.0))]
    water = shapely.union(shapely.difference(outer, shapely.union_all(holes)),
                          shapely.box(600.0, -50.0, 900.0, 50.0))       # a second polygon
    index = PolylineIndex.of_rings(water)
    rings = shapely.get_rings(shapely.get_parts(water))
    assert len(index.a) == int(sum(shapely.get_num_coordinates(rings) - 1))
    q = rng.uniform([-500.0, -500.0], [1000.0, 500.0], (2000, 2))
    dist = index.distance(q)
    np.testing.assert_allclose(dist, shapely.distance(shapely.points(q), water.boundary),
                               rtol=1e-9, atol=1e-9)
    order = rng.permutation(len(q))
    for part in np.array_split(order, 7):
        np.testing.assert_array_equal(index.nearest(q[part], 150.0)[0],
                                      np.where(dist[part] < 150.0, dist[part], np.inf))
    empty = PolylineIndex.of_rings(shapely.Polygon())
    assert np.isinf(empty.distance(q[:3])).all()
