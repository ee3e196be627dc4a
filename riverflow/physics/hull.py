"""A boat's hull as a capsule, and the shores it must keep out of (plain numpy and shapely).

The hull is every point within beam/2 of its axis segment (:func:`hull_axis`), ``length_m``
long tip to tip; the shores are the segments of a water polygon's rings (banks, closing
segments, island rings), and :meth:`Shore.deepest_contact` finds the one a hull touches most.
:mod:`riverflow.physics.boat` pushes the hull out along that contact.
"""
from __future__ import annotations

import math

import numpy as np
import shapely


def hull_axis(position_m, heading_rad: float, length_m: float, beam_m: float
              ) -> tuple[np.ndarray, np.ndarray]:
    """The capsule's axis (stern end, bow end) (2,) [m]: the hull is every point within
    beam/2 of it, ``length_m`` long tip to tip."""
    half = max(0.5 * length_m - 0.5 * beam_m, 0.0)
    f = forward(heading_rad) * half
    p = np.asarray(position_m, np.float64)
    return p - f, p + f


def hull_outline(position_m, heading_rad: float, length_m: float, beam_m: float,
                 points_per_cap: int = 9) -> np.ndarray:
    """(2·points_per_cap, 2) [m] points on the capsule hull's outline, counter-clockwise."""
    a, b = hull_axis(position_m, heading_rad, length_m, beam_m)
    r = 0.5 * beam_m
    ang = np.linspace(-0.5 * np.pi, 0.5 * np.pi, points_per_cap)
    bow = b + r * np.stack([np.cos(heading_rad + ang), np.sin(heading_rad + ang)], 1)
    stern = a + r * np.stack([np.cos(heading_rad + np.pi + ang),
                              np.sin(heading_rad + np.pi + ang)], 1)
    return np.concatenate([bow, stern])


def forward(heading_rad: float) -> np.ndarray:
    """(2,) unit vector towards the bow."""
    return np.array([math.cos(heading_rad), math.sin(heading_rad)])


def port(heading_rad: float) -> np.ndarray:
    """(2,) unit vector to port (the bow's left)."""
    return np.array([-math.sin(heading_rad), math.cos(heading_rad)])


class Shore:
    """The shore segments of a water polygon (banks, closing segments, island rings) in an
    STR-tree, for capsule contacts."""

    def __init__(self, polygon) -> None:
        rings = shapely.get_parts(shapely.boundary(polygon))
        segs = [np.stack([c[:-1], c[1:]], 1) for c in map(shapely.get_coordinates, rings)
                if len(c) > 1]
        self.segments = np.concatenate(segs) if segs else np.zeros((0, 2, 2))
        self.tree = shapely.STRtree(shapely.linestrings(self.segments))

    def deepest_contact(self, a: np.ndarray, b: np.ndarray, radius: float):
        """(distance, shore point (2,), axis point (2,)) of the shore segment nearest to the
        segment a–b among those closer than ``radius`` [m]; None if there is none. Distance 0
        means the segments cross."""
        lo = np.minimum(a, b) - radius
        hi = np.maximum(a, b) + radius
        near = self.tree.query(shapely.box(lo[0], lo[1], hi[0], hi[1]))
        if not len(near):
            return None
        s = self.segments[near]
        dist, on_shore, on_axis = _segment_distances(a, b, s[:, 0], s[:, 1])
        k = int(np.argmin(dist))
        if dist[k] >= radius:
            return None
        return float(dist[k]), on_shore[k], on_axis[k]


def _closest_on(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Closest points (M, 2) of segments a–b (M, 2) to points p (M, 2) (or broadcast)."""
    e = b - a
    len2 = np.einsum("...i,...i->...", e, e)
    t = np.einsum("...i,...i->...", p - a, e) / np.where(len2 > 0.0, len2, 1.0)
    return a + np.clip(t, 0.0, 1.0)[..., None] * e


def _segment_distances(a, b, p, q):
    """Distances (M,) between the segment a–b and segments p–q (M, 2), with the closest
    points on p–q and on a–b (0 and a crossing point where they cross)."""
    a = np.broadcast_to(a, p.shape)
    b = np.broadcast_to(b, p.shape)
    candidates = [(p, _closest_on(p, a, b)), (q, _closest_on(q, a, b)),
                  (_closest_on(a, p, q), a), (_closest_on(b, p, q), b)]
    on_shore = np.stack([c[0] for c in candidates])
    on_axis = np.stack([c[1] for c in candidates])
    d = np.hypot(*(on_shore - on_axis).transpose(2, 0, 1))
    best = np.argmin(d, axis=0)
    m = np.arange(len(p))
    dist = d[best, m]
    shore_pt = on_shore[best, m]
    axis_pt = on_axis[best, m]
    crossing = _crosses(a, b, p, q)
    dist[crossing] = 0.0
    return dist, shore_pt, axis_pt


def _crosses(a, b, p, q) -> np.ndarray:
    def orient(u, v, w):
        return np.sign((v[..., 0] - u[..., 0]) * (w[..., 1] - u[..., 1])
                       - (v[..., 1] - u[..., 1]) * (w[..., 0] - u[..., 0]))
    return ((orient(a, b, p) * orient(a, b, q) < 0) & (orient(p, q, a) * orient(p, q, b) < 0))

