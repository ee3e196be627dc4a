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

import math
import threading
from dataclasses import dataclass, field

import numpy as np
import shapely
from scipy.spatial import cKDTree

from riverflow.hydro.falls import channel_depth_m, drop_along
from riverflow.hydro.nearest import PolylineIndex
from riverflow.kernels.centre_line import (CentreSamples, LevelSamples, nearest_level,
                                           project_to_centre)
from riverflow.kernels.level_mix import mix_samples, mixed_levels, nearest_samples
from riverflow.tiles import remote

JUNCTION_BLEND = 1.25
"""Levels are blended between the branches of a junction within this many (largest) widths."""
MAX_JUNCTION_SLOPE = 0.01
"""Steepest descent [m/m] of a profile forced down to a lower junction level."""
LEVEL_SAMPLE_SPACING_M = 8.0
"""The spacing [m] of the centre-line samples that weigh the level of the water in view
(:meth:`WaterSurface.level_samples`, the reflection's mirror: one pass over them a frame)."""
BANK_LEVEL_NEIGHBOURS = 24
BANK_BLEND = 1.0
BANK_BLEND_MIN_M = 0.5
""":meth:`WaterSurface.bank_level`: samples mixed, and how far farther than the nearest one
a sample still counts: BANK_BLEND × the distance to the shore + BANK_BLEND_MIN_M [m]."""
LAND_LEVEL_STRIDE = 5
"""The level under the land is blended from every LAND_LEVEL_STRIDE-th centre-line sample…"""
LAND_LEVEL_NEIGHBOURS = 24
"""… the LAND_LEVEL_NEIGHBOURS nearest of them, weighted down to 0 at the farthest one."""


DECIMATE_CELLS = 2.5
""":meth:`WaterSurface.decimated` counts its strides again where the samples enter another
square of this many strides' length (~1 pick per 4 samples at stride 5)."""
NEAREST_SAMPLE_STRIDE = 5
""":meth:`WaterSurface.nearest_sample` picks among every this-many-th centre-line sample."""
CONTAINS_MARGIN_M = 2.0
""":meth:`WaterSurface.contains` looks this much farther from the shore than 0.75 × the
widest river's width."""


def point_tree(points: np.ndarray) -> cKDTree:
    """A KD-tree over points the tiles query at run time (centre lines, the ground's valley,
    the default scene's main line): built unbalanced, with uncompacted nodes. The answers are
    the same; queries far from the data (most of a terrain tile's nodes) visit far fewer
    nodes: 2-3.5x less CPU a point 300-900 m from a 200 km scene's 940,000 shore points
    (when shores were KD-trees too), the same near them."""
    return cKDTree(points, balanced_tree=False, compact_nodes=False)


# below this many query points a KD-tree query runs in the calling thread: starting threads
# costs more than they save (a boat's few hull points every frame: ~1 ms a call otherwise)
THREADED_QUERY_MIN = 4096


def _workers(n: int) -> int:
    """KD-tree query threads for ``n`` points: all cores on the main thread, one for a small
    query or in a tile worker thread or process (which runs beside the frame: it must not
    take the frame's core)."""
    if (n < THREADED_QUERY_MIN or remote.IN_WORKER_PROCESS
            or threading.current_thread() is not threading.main_thread()):
        return 1
    return -1


def monotone_profiles(samples: list[np.ndarray], ground_m: list[np.ndarray],
                      start_of: list[int], end_of: list[int], n_junctions: int,
                      half_window: int, caps_m: list[tuple[float, float]] | None = None,
                      falls: list[list[tuple[float, float, float, str, str]]] | None = None
                      ) -> list[np.ndarray]:
    """Water levels along branches (listed upstream first).

    Args:
        samples: per branch, (P, 2) centre-line samples [m] from upstream to downstream.
        ground_m: per branch, (P,) ground altitude at the samples [m] (already lowered by any
            freeboard wanted).
        start_of, end_of: junction index of each branch's start / end, -1 if free.
        half_window: box-smoothing half width [samples].
        caps_m: per branch, (start, end) lengths [m] kept flat at the junction height (the
            part of a branch that lies in the water of the other branches of its junction,
            Proland's junction "cap"); none by default.
        falls: per branch, its falls and rapids as (at_m, drop_m, length_m, how, shape): the
            level drops by drop_m from at_m [m] along the samples, over length_m, along a
            fall's nappe or a rapid's even slope (``shape`` "nappe" or "ramp":
            :func:`riverflow.hydro.falls.drop_along`), never smoothed away. ``how`` says
            where the drop comes from: "given" (the ground already drops there: levels it
            was found in), "raise" (the water upstream of it is raised: a branch from a
            free source, so no junction moves) or "lower" (the water downstream is lowered,
            and with it the junction it ends at).

    Returns:
        per branch, (P,) non-increasing water level [m], equal at shared junctions.
    """
    raw, junction = [], np.full(n_junctions, np.inf)
    for k, z in enumerate(ground_m):
        z = np.asarray(z, dtype=np.float64).copy()
        if start_of[k] >= 0:
            if not junction[start_of[k]] < np.inf:
                # a junction no branch flows into (channels parting where the water comes
                # in: Porto's Douro split round an island at the data's edge): the first
                # branch's own level there is the junction's
                junction[start_of[k]] = z[0]
            z[0] = junction[start_of[k]]
        z = np.minimum.accumulate(z)
        s = _arc_length(samples[k])
        for at, drop, _, how, _ in (falls[k] if falls is not None else ()):
            if how == "raise":
                z = np.where(s < at, z + drop, z)
            elif how == "lower":
                z = np.where(s >= at, z - drop, z)
            elif how != "given":
                raise ValueError(f"monotone_profiles: a fall is 'given', 'raise' or 'lower', "
                                 f"got {how!r}")
        raw.append(z)
        if end_of[k] >= 0:
            junction[end_of[k]] = min(junction[end_of[k]], raw[-1][-1])
    out = []
    for k, z in enumerate(raw):
        s = _arc_length(samples[k])
        cap0, cap1 = caps_m[k] if caps_m is not None else (0.0, 0.0)
        cap0 = min(cap0, 0.4 * s[-1]) if start_of[k] >= 0 else 0.0
        cap1 = min(cap1, 0.4 * s[-1]) if end_of[k] >= 0 else 0.0
        if end_of[k] >= 0:  # reach the junction height where the end cap begins
            target, s_cap = junction[end_of[k]], s[-1] - cap1
            slope = max(MAX_JUNCTION_SLOPE, (z[0] - target) / max(s_cap - cap0, 1e-9))
            z = np.minimum(z, target + slope * np.maximum(s_cap - s, 0.0))
        if start_of[k] >= 0:  # raw levels never exceed the start junction's: still monotone
            z = np.where(s <= cap0, z[0], z)
        step = np.zeros_like(s)
        nappe = np.zeros_like(s)
        for at, drop, length, how, shape in (falls[k] if falls is not None else ()):
            shaped = drop_along(s - at, drop, length, shape)
            # the drop as it is in the raw levels: a step where it was made here, its own
            # shape where the levels it was found in have it
            step += shaped if how == "given" else np.where(s >= at, drop, 0.0)
            nappe += shaped
        # the drops are taken out before smoothing and put back after, in their shape: a
        # smoothing window must not spread a fall over 25 samples
        z = _box_smooth(z + step, half_window) - nappe
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


def resample_segments(points: np.ndarray, spacing_m: float, *values: np.ndarray):
    """Resample a polyline (K, 2) at most ``spacing_m`` apart, each of its segments on its
    own (cut into equal parts; its vertices kept), interpolating per-point ``values`` (K,)
    linearly. A change of some vertices changes only the samples of their segments (a live
    edit's drag: :func:`resample` would move every sample after it). Returns the points
    (M, 2), the values (M,), then whether each point is a vertex (M,) bool."""
    step = np.hypot(*np.diff(points, axis=0).T)
    parts = np.maximum(np.ceil(step / spacing_m), 1).astype(np.int64)
    seg = np.repeat(np.arange(len(step)), parts)
    t = (np.arange(len(seg)) - np.repeat(np.cumsum(parts) - parts, parts)) / parts[seg]
    seg = np.append(seg, len(step) - 1)
    t = np.append(t, 1.0)
    pts = points[seg] + t[:, None] * (points[seg + 1] - points[seg])
    return (pts, *[v[seg] + t * (v[seg + 1] - v[seg]) for v in values], (t == 0.0) | (t == 1.0))


@dataclass(eq=False)
class WaterSurface:
    """The water of a scene.

    ``samples_m`` (S, 2), ``levels_m`` (S,), ``widths_m`` (S,) and ``branch`` (S,) are dense
    centre-line samples of every branch with their water level, river width and branch index
    (samples of one branch are consecutive, upstream first); ``polygon`` is the water
    (shapely, islands are holes); ``profiles`` maps a branch name to its (s_m, level_m)
    profile; ``junctions_m`` (J, 2) are the junction points and ``junction_branches`` the
    branch indices meeting at each.
    """

    samples_m: np.ndarray
    levels_m: np.ndarray
    widths_m: np.ndarray
    branch: np.ndarray
    polygon: shapely.Geometry
    profiles: dict[str, tuple[np.ndarray, np.ndarray]] = field(default_factory=dict)
    junctions_m: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    junction_branches: list[tuple[int, ...]] = field(default_factory=list)

    def __post_init__(self) -> None:
        shapely.prepare(self.polygon)
        self._local = threading.local()
        # each branch's samples (rows of the arrays), found once: asked per branch of every
        # junction, a comparison over all samples each time (NHD's Shellmound: 400
        # junctions, 952,000 samples) took seconds
        branch = np.asarray(self.branch, np.int64)
        self._by_branch = np.argsort(branch, kind="stable")
        self._row_start = np.searchsorted(branch[self._by_branch],
                                          np.arange(int(branch.max(initial=-1)) + 2))
        widest = [float(self.widths_m[self._branch_rows(b)].max(initial=0.0))
                  for b in range(len(self._row_start) - 1)]
        self._junction_radius = np.array([
            JUNCTION_BLEND * max(widest[b] for b in members)
            for members in self.junction_branches]) if len(self.junction_branches) else np.zeros(0)
        self._decimated: dict[int, _Samples] = {}
        self._per_branch: dict[int, _Samples] = {}
        self._shore = PolylineIndex.of_rings(self.polygon)
        self._reach_m = 0.75 * float(self.widths_m.max()) + CONTAINS_MARGIN_M

    def _branch_rows(self, b: int) -> np.ndarray:
        """The rows of branch ``b``'s samples, in order."""
        return self._by_branch[self._row_start[b]:self._row_start[b + 1]]

    @property
    def contains_reach_m(self) -> float:
        """:meth:`contains` tests the points nearer the shore than this [m] only (farther
        ones are dry: no river is that wide)."""
        return self._reach_m

    # -- queries (all take xy (N, 2) [m] and return (N,) float64) -------------------------

    def nearest(self, xy: np.ndarray, stride: int = 1) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Distance to the nearest centre line [m], water level there and river width there,
        projected onto the nearest segment of the branch so that levels vary continuously.
        Around junctions the levels and widths of the branches meeting there are blended by
        distance, so the surface has no seam where the nearest branch changes.

        ``stride`` > 1 uses every stride-th sample only and no junction blending: coarser
        but much faster for points far from the river (a KD-tree query far from its data
        visits many leaves).
        """
        p = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
        dist, level, width = self.decimated(stride).project(p)
        if stride == 1 and len(p) and len(self.junctions_m):
            lo, hi = p.min(axis=0), p.max(axis=0)
            c, r = self.junctions_m, self._junction_radius
            near = np.flatnonzero(np.all((c + r[:, None] >= lo) & (c - r[:, None] <= hi), axis=1))
            for j in near.tolist():
                self._blend_junction(p, j, self.junctions_m[j], dist, level, width)
        return dist, level, width

    def nearest_sample(self, xy: np.ndarray, stride: int = NEAREST_SAMPLE_STRIDE
                       ) -> tuple[np.ndarray, np.ndarray]:
        """The nearest of every stride-th centre-line sample (N, 2) [m] and the river width
        there (N,) [m]."""
        p = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
        samples = self.decimated(stride)
        _, k = samples.tree.query(p, workers=_workers(len(p)))
        return samples.samples[k], samples.widths[k]

    def decimated(self, stride: int) -> _Samples:
        """Every stride-th centre-line sample of each branch, counted from its first one and
        again from each sample in another square of DECIMATE_CELLS × stride samples' spacing
        than the one before it (a place, not a count from the branch's start: a live edit
        that adds samples to one stretch of a branch leaves the picks elsewhere as they
        were)."""
        got = self._decimated.get(stride)
        if got is None:
            if stride == 1:
                sel = slice(None)
            else:
                k = np.arange(len(self.branch))
                first = np.r_[True, self.branch[1:] != self.branch[:-1]]
                step = np.hypot(*np.diff(self.samples_m, axis=0).T)
                side = DECIMATE_CELLS * stride * float(np.median(step)) if len(step) else 1.0
                cell = np.floor(self.samples_m / max(side, 1e-6))
                first[1:] |= np.any(cell[1:] != cell[:-1], axis=1)
                start = np.maximum.accumulate(np.where(first, k, 0))
                sel = (k - start) % stride == 0
            got = self._decimated[stride] = _Samples(self.samples_m[sel], self.levels_m[sel],
                                                     self.widths_m[sel], self.branch[sel])
        return got

    def _blend_junction(self, p, j, centre, dist, level, width) -> None:
        """Blend levels / widths (in place) of the branches of junction j near it."""
        members = self.junction_branches[j]
        radius = float(self._junction_radius[j])
        wmax = radius / JUNCTION_BLEND
        r = np.hypot(*(p - centre).T)
        idx = np.flatnonzero(r < radius)
        if not len(idx):
            return
        per = []
        for b in members:
            if b not in self._per_branch:
                sel = self._branch_rows(b)
                self._per_branch[b] = _Samples(self.samples_m[sel], self.levels_m[sel],
                                               self.widths_m[sel], self.branch[sel])
            per.append(self._per_branch[b].project(p[idx]))
        d = np.stack([x[0] for x in per])
        w = np.clip(1.0 - (d - d.min(axis=0)) / (0.5 * wmax), 0.0, 1.0) ** 2
        w /= w.sum(axis=0)
        fade = 1.0 - _smoothstep(0.7 * radius, radius, r[idx])
        level[idx] = (1 - fade) * level[idx] + fade * (w * np.stack([x[1] for x in per])).sum(axis=0)
        width[idx] = (1 - fade) * width[idx] + fade * (w * np.stack([x[2] for x in per])).sum(axis=0)

    def level(self, xy: np.ndarray) -> np.ndarray:
        """Water level of the nearest river point [m], defined everywhere."""
        return self.nearest(xy)[1]

    def level_at(self, x: float, y: float) -> float:
        """:meth:`level` of the one point (x, y) [m]: the same number, found without a
        KD-tree query and numpy's cost per call (the reflection's mirror level, every
        frame: :func:`riverflow.kernels.centre_line.nearest_level`). Near a junction
        (blended levels), where two samples tie for nearest, or if the point is not finite,
        it is :meth:`level` itself."""
        x, y = float(x), float(y)
        boxes = self.__dict__.get("_junction_boxes")
        if boxes is None:
            c, r = self.junctions_m, self._junction_radius
            boxes = self._junction_boxes = [
                (lx, hx, ly, hy) for (lx, ly), (hx, hy)
                in zip((c - r[:, None]).tolist(), (c + r[:, None]).tolist())]
        if not any(hx >= x and lx <= x and hy >= y and ly <= y for lx, hx, ly, hy in boxes) \
                and math.isfinite(x) and math.isfinite(y):
            rows = self.__dict__.get("_rows")
            if rows is None:
                rows = self._rows = (np.ascontiguousarray(self.samples_m, np.float64),
                                     np.ascontiguousarray(self.levels_m, np.float64),
                                     np.ascontiguousarray(self.branch, np.int64))
            level = nearest_level(*rows, x, y)
            if level == level:
                return level
        return float(self.level(np.array([[x, y]]))[0])

    def level_samples(self) -> LevelSamples:
        """Centre-line samples about LEVEL_SAMPLE_SPACING_M apart (every k-th of each
        branch's), each with the water it stands for (its river's width times half the
        distance to its neighbours on its branch), as
        :func:`riverflow.kernels.centre_line.view_level` reads them (made once)."""
        cached = self.__dict__.get("_level_samples")
        if cached is None:
            spacing = float(np.median(np.hypot(*np.diff(self.samples_m, axis=0).T))) \
                if len(self.samples_m) > 1 else 1.0
            k = max(1, int(round(LEVEL_SAMPLE_SPACING_M / max(spacing, 1e-9))))
            first = np.r_[0, np.flatnonzero(np.diff(self.branch)) + 1]    # of each branch
            along = np.arange(len(self.branch)) - np.repeat(first, np.diff(
                np.r_[first, len(self.branch)]))
            keep = np.flatnonzero(along % k == 0)
            xy = np.ascontiguousarray(self.samples_m[keep], np.float64)
            branch = self.branch[keep]
            gap = np.hypot(*np.diff(xy, axis=0).T)
            gap[branch[1:] != branch[:-1]] = 0.0                  # between two branches
            length = 0.5 * (np.append(gap, 0.0) + np.insert(gap, 0, 0.0))
            width = np.ascontiguousarray(self.widths_m[keep], np.float64)
            cached = self._level_samples = LevelSamples(
                xy, np.ascontiguousarray(self.levels_m[keep], np.float64), width * length,
                0.5 * width)
        return cached

    def distance_to_shore(self, xy: np.ndarray, upper_bound_m: float = np.inf) -> np.ndarray:
        """Distance to the nearest bank or island shore [m] (unsigned): to the polygon's
        rings' segments, exact (:class:`~riverflow.hydro.nearest.PolylineIndex`: the same
        numbers for a point in any batch); beyond ``upper_bound_m`` it is inf (much faster
        far away)."""
        p = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
        return self._shore.nearest(p, max_distance=upper_bound_m)[0]

    def land_level(self, xy: np.ndarray) -> np.ndarray:
        """The water level seen from the land [m], (N,): the levels of the
        LAND_LEVEL_NEIGHBOURS nearest centre-line samples (every LAND_LEVEL_STRIDE-th one),
        weighted by (1 − (d − d_nearest) / (d_farthest − d_nearest))². Continuous everywhere
        (a neighbour enters or leaves the set with weight 0), smooth across the place where the
        nearest branch changes, pointwise (a tile needs nothing around it)."""
        p = np.ascontiguousarray(xy, dtype=np.float64).reshape(-1, 2)
        samples = self.decimated(LAND_LEVEL_STRIDE)
        k = min(LAND_LEVEL_NEIGHBOURS, len(samples.samples))
        if k < 2:
            return np.full(len(p), float(samples.levels[0]) if k else 0.0)
        out = np.empty(len(p))
        mixed_levels(samples.mix, k, p, np.full(len(p), np.inf), out)
        return out

    def bank_level(self, xy: np.ndarray, shore_m: np.ndarray) -> np.ndarray:
        """The water level seen from the land near a shore [m], (N,), at points xy (N, 2) a
        distance ``shore_m`` (N,) [m] from it: the levels of the BANK_LEVEL_NEIGHBOURS
        nearest centre-line samples, weighted by (1 − (d − d_nearest) / (d_farthest −
        d_nearest))² · (1 − (d − d_nearest) / (BANK_BLEND · shore + BANK_BLEND_MIN_M))²,
        clipped at 0. Continuous everywhere, also where the nearest reach changes (inside a
        sharp bend the two legs' levels differ: the nearest one's level there made a cliff
        across the grass); at the shore the nearest samples only (the level there within a
        sample spacing's fall), the mix widening with the distance."""
        p = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
        samples = self.decimated(1)
        k = min(BANK_LEVEL_NEIGHBOURS, len(samples.samples))
        if k < 2 or not len(p):
            return self.nearest(p)[1]
        shore = np.broadcast_to(np.asarray(shore_m, np.float64).reshape(-1), len(p))
        band = BANK_BLEND * np.maximum(shore, 0.0) + BANK_BLEND_MIN_M
        out = np.empty(len(p))
        mixed_levels(samples.mix, k, np.ascontiguousarray(p), band, out)
        return out

    def contains(self, xy: np.ndarray, shore_m: np.ndarray | None = None) -> np.ndarray:
        """(N,) bool: points in the water. ``shore_m``: distance_to_shore(xy) if known."""
        p = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
        # (only distances under _reach_m count: the query need not look farther)
        d = self.distance_to_shore(p, upper_bound_m=self._reach_m) if shore_m is None \
            else shore_m
        near = d < self._reach_m
        inside = np.zeros(len(p), bool)
        inside[near] = shapely.contains_xy(self._thread_polygon(), p[near, 0], p[near, 1])
        return inside

    def _thread_polygon(self) -> shapely.Geometry:
        """The polygon, prepared; a copy of its own for each other thread (GEOS prepared
        geometries build their index lazily and are not safe to share between threads)."""
        if threading.current_thread() is threading.main_thread():
            return self.polygon
        polygon = getattr(self._local, "polygon", None)
        if polygon is None:
            polygon = self._local.polygon = shapely.from_wkb(shapely.to_wkb(self.polygon))
            shapely.prepare(polygon)
        return polygon

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


class _Samples:
    """Centre-line samples with a KD-tree: nearest-segment projection of query points."""

    def __init__(self, samples, levels, widths, branch) -> None:
        self.samples, self.levels, self.widths, self.branch = samples, levels, widths, branch
        self.tree = point_tree(samples)
        self.kernel_samples = CentreSamples(np.ascontiguousarray(samples, np.float64),
                                            np.ascontiguousarray(levels, np.float64),
                                            np.ascontiguousarray(widths, np.float64),
                                            np.ascontiguousarray(branch, np.int64))

    @property
    def mix(self):
        """The samples and their levels for :func:`~riverflow.kernels.level_mix.mixed_levels`
        (made on first use)."""
        got = self.__dict__.get("_mix")
        if got is None:
            got = self._mix = mix_samples(self.samples, self.levels)
        return got

    def project(self, p: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(distance, level, width) (N,) of the nearest point on the sampled centre lines:
        the nearest sample (:func:`riverflow.kernels.level_mix.nearest_samples`; the KD-tree's
        where two are as near), then the segments on either side of it
        (:func:`riverflow.kernels.centre_line.project_to_centre`)."""
        p = np.ascontiguousarray(p, np.float64).reshape(-1, 2)
        k = np.empty(len(p), np.int64)
        tie = np.empty(len(p), bool)
        nearest_samples(self.mix, p, k, tie)
        if tie.any():       # two nearest: the KD-tree's choice, as it always was
            k[tie] = self.tree.query(p[tie])[1]
        out = np.empty((3, len(p)))
        project_to_centre(self.kernel_samples, np.ascontiguousarray(k, np.int64), p, out[0],
                          out[1], out[2])
        return out[0], out[1], out[2]


def _smoothstep(e0: float, e1: float, x: np.ndarray) -> np.ndarray:
    t = np.clip((x - e0) / (e1 - e0), 0.0, 1.0)
    return t * t * (3 - 2 * t)


BED_DEPTH_PER_WIDTH = 0.1
"""A river's bed is at most this many times its width deep: its banks under the water then
stay under 34° (a 2 m creek: 0.2 m deep, not a 1 m trench with vertical walls); rivers
wider than 12.5 m keep 1 + width/50 m (:func:`riverflow.hydro.falls.channel_depth_m`, which
the falls' critical speed reads too)."""


def bed_depth(shore_m: np.ndarray, width_m: np.ndarray) -> np.ndarray:
    """Depth [m] at a distance ``shore_m`` inside the water of a river ``width_m`` wide: rises
    from 0 at the shore to min(1 + width/50, BED_DEPTH_PER_WIDTH · width) m over 30 % of the
    width (quadratic ease: the steepest slope, at the shore, is 2 · 0.1 / 0.3 = 0.67)."""
    full = channel_depth_m(width_m)
    t = np.clip(shore_m / (0.3 * width_m), 0.0, 1.0)
    return full * (1.0 - (1.0 - t) ** 2)
