"""Nearest points on a long polyline for many query points, in O(log L) each.

``shapely.shortest_line`` / ``shapely.distance`` / ``line_locate_point`` from a point to a
whole LineString visit every vertex of the line: for the banks of a 400 km river against its
40,000-vertex axis that is 10⁹ vertex visits (the 1000 km world took 140 s to build). A
:class:`PolylineIndex` puts the line's segments in a box hierarchy once
(:mod:`riverflow.kernels.polyline`) and answers the same questions exactly, through each
point's nearest segment (of equally near ones, the first). It answered through a shapely
STRtree before: the same numbers, but 1.8 million queries of the 1000 km builder spent 4.1 s
there (1.2 s of it making shapely points), 0.2 s in the kernel.
"""
from __future__ import annotations

import numpy as np
import shapely

from riverflow.kernels.polyline import Nearest, Polyline, nearest_points, segment_boxes


class PolylineIndex:
    """The segments of one polyline (K, 2) [m], for nearest-point queries; or of several
    (``line`` (K,): each point's line, its points consecutive), their segments one list
    (none joins two lines; arc lengths run on from one line to the next)."""

    def __init__(self, points: np.ndarray, line: np.ndarray | None = None) -> None:
        p = np.asarray(points, np.float64).reshape(-1, 2)
        keep = np.concatenate([[True], np.any(np.diff(p, axis=0) != 0.0, axis=1)])[:len(p)]
        if line is not None:
            line = np.asarray(line).reshape(-1)
            keep[1:] |= line[1:] != line[:-1]
            line = line[keep]
        p = p[keep]
        if len(p) < 2:
            p = np.vstack([p, p])
            line = None
        self.points = p
        joined = slice(None) if line is None else line[1:] == line[:-1]
        self.segment_line = None if line is None else line[:-1][joined]
        """Each segment's line (several lines), else None."""
        self.a = np.ascontiguousarray(p[:-1][joined])
        self.d = np.ascontiguousarray((p[1:] - p[:-1])[joined])
        if not len(self.a):                         # lines of one point each
            self.a, self.d = p[:1].copy(), np.zeros((1, 2))
        seg_len = np.hypot(self.d[:, 0], self.d[:, 1])
        self.s0 = np.concatenate([[0.0], np.cumsum(seg_len)[:-1]])
        self.seg_len = seg_len
        self.length = float(seg_len.sum())
        self.boxes = segment_boxes(self.a, self.d)
        self.line = Polyline(self.a, self.d, self.boxes, self.s0, seg_len)

    @classmethod
    def of(cls, line) -> PolylineIndex:
        """The index of a shapely LineString."""
        return cls(shapely.get_coordinates(line))

    @classmethod
    def of_rings(cls, geometry) -> PolylineIndex:
        """The index of every ring or line of a shapely geometry (a (multi)polygon's shore:
        its outer rings and holes, each closed)."""
        parts = shapely.get_parts(geometry)
        rings = shapely.get_rings(parts[shapely.get_type_id(parts) == 3])
        lines = parts[np.isin(shapely.get_type_id(parts), (1, 2))]
        xy, which = shapely.get_coordinates(np.concatenate([rings, lines]), return_index=True)
        return cls(xy, which)

    def nearest(self, xy: np.ndarray, max_distance: float | None = None
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """For points (N, 2) [m]: (distance (N,), nearest point (N, 2), its arc length from
        the line's start (N,)) [m]. With ``max_distance`` [m], points farther than that from
        the line get distance inf (point and arc NaN): far queries are then almost free."""
        out = self.nearest_segments(xy, max_distance)
        return out.dist, out.point, out.arc

    def nearest_segments(self, xy: np.ndarray, max_distance: float | None = None) -> Nearest:
        """:meth:`nearest` with each point's nearest segment (``seg``, −1: none within
        ``max_distance``; ``segment_line[seg]``: its line)."""
        xy = np.ascontiguousarray(np.asarray(xy, np.float64).reshape(-1, 2))
        n = len(xy)
        out = Nearest(np.empty(n, np.int64), np.empty(n), np.empty((n, 2)), np.empty(n))
        if n:
            limit = np.inf if max_distance is None else float(max_distance) ** 2
            nearest_points(self.line, xy, limit, out)
        return out

    def distance(self, xy: np.ndarray) -> np.ndarray:
        """Distance [m] from points (N, 2) to the polyline, (N,)."""
        return self.nearest(xy)[0]


CHUNK_SEGMENTS = 16
"""Consecutive segments per piece of line in :class:`LineChunks`."""


class LineChunks:
    """Polylines for :func:`ray_hits`, cut into runs of :data:`CHUNK_SEGMENTS` consecutive
    segments in one STRtree: a ray meets a few short runs (its crossing with each costs a
    few segments) where a whole bank is thousands of segments, every one visited by GEOS for
    each ray that meets its box (the builder's rays visited 230 on average). ``lines``:
    (K, 2) arrays [m] (a ring repeats its first point at the end)."""

    def __init__(self, lines: list[np.ndarray]) -> None:
        lines = [np.asarray(ln, np.float64).reshape(-1, 2) for ln in lines]
        self.lines = lines
        sizes = np.array([len(ln) for ln in lines], np.int64)
        if len(lines) and sizes.min() < 2:
            raise ValueError("LineChunks: a line of fewer than 2 points")
        first = np.concatenate([[0], np.cumsum(sizes)[:-1]]).astype(np.int64)
        per = -(-(sizes - 1) // CHUNK_SEGMENTS)                      # chunks per line
        owner = np.repeat(np.arange(len(lines)), per)
        k = np.arange(len(owner)) - np.repeat(np.cumsum(per) - per, per)    # chunk within line
        start = np.repeat(first, per) + k * CHUNK_SEGMENTS
        stop = np.minimum(start + CHUNK_SEGMENTS, np.repeat(first + sizes - 1, per))
        count = stop - start + 1
        at = np.repeat(start - (np.cumsum(count) - count), count) + np.arange(int(count.sum()))
        points = np.vstack(lines) if lines else np.zeros((0, 2))
        self.owner = owner
        self.chunks = shapely.linestrings(points[at], indices=np.repeat(np.arange(len(owner)), count)) \
            if len(owner) else np.zeros(0, dtype=object)
        self.tree = shapely.STRtree(self.chunks)
        self._line_tree = None

    @property
    def line_tree(self) -> shapely.STRtree:
        """An STRtree of the whole lines (made on first use), for nearest-line queries."""
        if self._line_tree is None:
            self._line_tree = shapely.STRtree([shapely.LineString(ln) for ln in self.lines])
        return self._line_tree


def ray_hits(origins: np.ndarray, directions: np.ndarray, reach_m: np.ndarray,
             lines: LineChunks) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Where rays cross the lines of ``lines``, all rays in one bulk query.

    Ray r runs from ``origins[r]`` (R, 2) [m] to ``origins[r] + directions[r] * reach_m[r]``.
    Returns (ray index (H,), line index (H,), distance [m] from the ray's origin to the
    line's nearest crossing (H,)), one row per ray and line it crosses, by ray then line (the
    same crossings and distances as one ``ray.intersection(line)`` / ``shapely.distance`` per
    ray and line: the crossings of a line are those of its chunks).
    """
    origins = np.asarray(origins, np.float64).reshape(-1, 2)
    ends = origins + np.asarray(directions, np.float64).reshape(-1, 2) \
        * np.asarray(reach_m, np.float64).reshape(-1)[:, None]
    rays = shapely.linestrings(np.stack([origins, ends], axis=1))
    ray, chunk = lines.tree.query(rays, predicate="intersects")
    crossing = shapely.intersection(rays[ray], lines.chunks[chunk])
    dist = shapely.distance(shapely.points(origins[ray]), crossing)
    hit = lines.owner[chunk]
    order = np.lexsort((dist, hit, ray))
    ray, hit, dist = ray[order], hit[order], dist[order]
    first = np.ones(len(ray), bool)
    first[1:] = (ray[1:] != ray[:-1]) | (hit[1:] != hit[:-1])
    return ray[first], hit[first], dist[first]


def first_per_group(group: np.ndarray, key: np.ndarray, n_groups: int,
                    largest: bool = False) -> np.ndarray:
    """For rows grouped by ``group`` (H,) (non-decreasing), the row of each group with the
    smallest ``key`` (``largest``: the largest), the first of equal ones, as ``np.argmin`` /
    ``np.argmax`` over the group would pick; -1 for groups without rows, (n_groups,)."""
    pos = np.arange(len(group))
    order = np.lexsort((pos, -key if largest else key, group))
    out = np.full(n_groups, -1, np.int64)
    g = group[order]
    first = np.concatenate([[True], g[1:] != g[:-1]]) if len(g) else np.zeros(0, bool)
    out[g[first]] = order[first]
    return out


def tangent_at(line: np.ndarray, point: np.ndarray) -> np.ndarray:
    """The direction (2,) (not normalised) of the segment of polyline ``line`` (K, 2) nearest
    ``point``."""
    return tangents_at(line, np.asarray(point, np.float64).reshape(1, 2))[0]


def tangents_at(line: np.ndarray, points: np.ndarray) -> np.ndarray:
    """The directions (P, 2) (not normalised) of the segments of polyline ``line`` (K, 2)
    nearest each of ``points`` (P, 2), the first of equally near ones (through the
    :class:`PolylineIndex`'s box hierarchy: the lowest segment of a tie, as ``np.argmin``
    over them all)."""
    seg = PolylineIndex(np.asarray(line, np.float64)).nearest_segments(points).seg
    return np.diff(line, axis=0)[seg]


def stations(line: np.ndarray, fractions: np.ndarray, widths=None):
    """Points (F, 2), unit left normals (F, 2) and widths [m] (F,) (NaN if ``widths`` is None;
    else a scalar, one value or one per point) at arc-length fractions (F,) of a polyline
    (K, 2)."""
    seg = np.hypot(*np.diff(line, axis=0).T)
    s = np.concatenate([[0.0], np.cumsum(seg)])
    target = fractions * s[-1]
    j = np.clip(np.searchsorted(s, target, side="right") - 1, 0, len(seg) - 1)
    u = (target - s[j]) / seg[j]
    t = (line[j + 1] - line[j]) / seg[j][:, None]
    w = np.full(len(fractions), np.nan)
    if widths is not None:
        wa = np.broadcast_to(np.asarray(widths, dtype=float).reshape(-1), (len(line),)) \
            if np.size(widths) == 1 else np.asarray(widths, dtype=float)
        w = (1 - u) * wa[j] + u * wa[j + 1]
    return line[j] + u[:, None] * (line[j + 1] - line[j]), np.stack([-t[:, 1], t[:, 0]], axis=1), w
