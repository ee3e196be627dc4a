"""Water surface of a scene: monotone water profiles along the branches and a bed depth.

Profiles follow Proland's WaterElevationLayer (reference §4.8): the terrain is sampled along
each branch, made monotone by a running minimum from upstream, forced down to one height at every
junction, box-smoothed (the window shrinks at the ends so junction heights are kept) and
made monotone again, so the water only goes
downhill along every branch and meets itself at junctions. The surface altitude at a point in
the water is the profile at the nearest centre-line point; the bed lies ``depth`` below it,
deepest mid-stream and shallow at the banks.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import shapely
from scipy.spatial import cKDTree

MAX_JUNCTION_SLOPE = 0.01
"""Steepest descent [m/m] of a profile forced down to a lower junction level."""


def monotone_profiles(samples: list[np.ndarray], ground_m: list[np.ndarray],
                      start_of: list[int], end_of: list[int], n_junctions: int,
                      half_window: int) -> list[np.ndarray]:
    """Water levels along branches (listed upstream first).

    Args:
        samples: per branch, (P, 2) centre-line samples [m] from upstream to downstream.
        ground_m: per branch, (P,) ground altitude at the samples [m] (already lowered by any
            freeboard wanted).
        start_of, end_of: junction index of each branch's start / end, -1 if free.
        half_window: box-smoothing half width [samples].

    Returns:
        per branch, (P,) non-increasing water level [m], equal at shared junctions.
    """
    raw, junction = [], np.full(n_junctions, np.inf)
    for k, z in enumerate(ground_m):
        z = np.asarray(z, dtype=np.float64).copy()
        if start_of[k] >= 0:
            z[0] = junction[start_of[k]]
        raw.append(np.minimum.accumulate(z))
        if end_of[k] >= 0:
            junction[end_of[k]] = min(junction[end_of[k]], raw[-1][-1])
    out = []
    for k, z in enumerate(raw):
        s = _arc_length(samples[k])
        if end_of[k] >= 0:
            target = junction[end_of[k]]
            slope = max(MAX_JUNCTION_SLOPE, (z[0] - target) / max(s[-1], 1e-9))
            z = np.minimum(z, target + slope * (s[-1] - s))
        z = _box_smooth(z, half_window)
        out.append(np.maximum(np.minimum.accumulate(z), z[-1]))  # rounding must not move the end
    return out


def _box_smooth(z: np.ndarray, half_window: int) -> np.ndarray:
    """Centred moving average whose window shrinks near the ends (so both end values are
    kept exactly), (P,) → (P,)."""
    c = np.concatenate([[0.0], np.cumsum(z)])
    i = np.arange(len(z))
    k = np.minimum(np.minimum(i, len(z) - 1 - i), half_window)
    return np.where(k == 0, z, (c[i + k + 1] - c[i - k]) / (2 * k + 1))


def _arc_length(points: np.ndarray) -> np.ndarray:
    return np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(points, axis=0).T))])


def resample(points: np.ndarray, spacing_m: float, *values: np.ndarray):
    """Resample a polyline (K, 2) at about ``spacing_m`` along its arc length, interpolating
    per-point ``values`` (K,) linearly. Returns the points (M, 2) then the values (M,)."""
    s = _arc_length(points)
    n = max(2, int(np.ceil(s[-1] / spacing_m)) + 1)
    t = np.linspace(0.0, s[-1], n)
    pts = np.stack([np.interp(t, s, points[:, 0]), np.interp(t, s, points[:, 1])], axis=1)
    return (pts, *[np.interp(t, s, v) for v in values])


@dataclass(eq=False)
class WaterSurface:
    """The water of a scene.

    ``samples_m`` (S, 2), ``levels_m`` (S,), ``widths_m`` (S,) and ``branch`` (S,) are dense
    centre-line samples of every branch with their water level, river width and branch index
    (samples of one branch are consecutive, upstream first); ``polygon`` is the water
    (shapely, islands are holes); ``profiles`` maps a branch name to its (s_m, level_m)
    profile.
    """

    samples_m: np.ndarray
    levels_m: np.ndarray
    widths_m: np.ndarray
    branch: np.ndarray
    polygon: shapely.Geometry
    profiles: dict[str, tuple[np.ndarray, np.ndarray]] = field(default_factory=dict)
    boundary_spacing_m: float = 1.0

    def __post_init__(self) -> None:
        shapely.prepare(self.polygon)
        self._decimated: dict[int, tuple] = {}
        edge = shapely.segmentize(self.polygon.boundary, self.boundary_spacing_m)
        self._boundary_trees = {1: cKDTree(shapely.get_coordinates(edge))}
        self._reach_m = 0.75 * float(self.widths_m.max()) + 2.0 * self.boundary_spacing_m

    # -- queries (all take xy (N, 2) [m] and return (N,) float64) -------------------------

    def nearest(self, xy: np.ndarray, stride: int = 1) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Distance to the nearest centre line [m], water level there and river width there,
        projected onto the nearest segment of the branch so that levels vary continuously.

        ``stride`` > 1 uses every stride-th sample only: coarser but much faster for points
        far from the river (a KD-tree query far from its data visits many leaves).
        """
        p = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
        if stride not in self._decimated:
            sel = slice(None, None, stride)
            self._decimated[stride] = (cKDTree(self.samples_m[sel]), self.samples_m[sel],
                                       self.levels_m[sel], self.widths_m[sel], self.branch[sel])
        tree, samples, levels, widths, branch = self._decimated[stride]
        _, k = tree.query(p, workers=-1)
        n = len(samples)
        best_d = np.full(len(p), np.inf)
        level = np.empty(len(p))
        width = np.empty(len(p))
        for a_off in (-1, 0):
            a = np.clip(k + a_off, 0, n - 2)
            b = a + 1
            same = branch[a] == branch[b]
            sa, sb = samples[a], samples[b]
            ab = sb - sa
            t = np.clip(np.einsum("ij,ij->i", p - sa, ab) / np.maximum(np.einsum("ij,ij->i", ab, ab), 1e-12), 0, 1)
            t = np.where(same, t, np.where(a == k, 0.0, 1.0))
            d = np.hypot(*(sa + t[:, None] * ab - p).T)
            better = d < best_d
            best_d = np.where(better, d, best_d)
            level = np.where(better, (1 - t) * levels[a] + t * levels[b], level)
            width = np.where(better, (1 - t) * widths[a] + t * widths[b], width)
        return best_d, level, width

    def level(self, xy: np.ndarray) -> np.ndarray:
        """Water level of the nearest river point [m], defined everywhere."""
        return self.nearest(xy)[1]

    def distance_to_shore(self, xy: np.ndarray, stride: int = 1) -> np.ndarray:
        """Distance to the nearest bank or island shore [m] (unsigned); ``stride`` > 1 uses
        every stride-th shore sample only (faster far away, error up to stride × the shore
        sample spacing)."""
        if stride not in self._boundary_trees:
            self._boundary_trees[stride] = cKDTree(self._boundary_trees[1].data[::stride])
        d, _ = self._boundary_trees[stride].query(np.asarray(xy, dtype=np.float64).reshape(-1, 2), workers=-1)
        return d

    def contains(self, xy: np.ndarray, shore_m: np.ndarray | None = None) -> np.ndarray:
        """(N,) bool: points in the water. ``shore_m``: distance_to_shore(xy) if known."""
        p = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
        d = self.distance_to_shore(p) if shore_m is None else shore_m
        near = d < self._reach_m
        inside = np.zeros(len(p), bool)
        inside[near] = shapely.contains_xy(self.polygon, p[near, 0], p[near, 1])
        return inside

    def height(self, xy: np.ndarray) -> np.ndarray:
        """Water surface altitude [m] at points in the water, NaN elsewhere."""
        p = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
        return np.where(self.contains(p), self.level(p), np.nan)

    def depth(self, xy: np.ndarray) -> np.ndarray:
        """Water depth [m] in the water (0 at the shore, deepest mid-stream), NaN elsewhere."""
        p = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
        shore = self.distance_to_shore(p)
        _, _, width = self.nearest(p)
        return np.where(self.contains(p, shore), bed_depth(shore, width), np.nan)

    def bed(self, xy: np.ndarray) -> np.ndarray:
        """River-bed altitude [m] in the water, NaN elsewhere."""
        return self.height(xy) - self.depth(xy)


def bed_depth(shore_m: np.ndarray, width_m: np.ndarray) -> np.ndarray:
    """Depth [m] at a distance ``shore_m`` inside the water of a river ``width_m`` wide: rises
    from 0 at the shore to 1 + width/50 m over 30 % of the width (quadratic ease)."""
    full = 1.0 + width_m / 50.0
    t = np.clip(shore_m / (0.3 * width_m), 0.0, 1.0)
    return full * (1.0 - (1.0 - t) ** 2)
