"""Rivers carved into a terrain, point by point: bed, banks above the water, smooth shores.

Re-does Proland's ``WaterElevationLayer`` (reference §4.8) as a pointwise function, so that a
tile of any size and level carves exactly the same heights as its neighbours and its parent at
their shared points, and no whole-map grid is ever made:

* in the water, the bed lies :func:`~riverflow.scenes.water.bed_depth` below the water level
  (deepest mid-stream, 0 at the shore);
* outside, a *valley* rises from the water level at the shore (``bank_rise_m`` within a few
  metres, ``valley_rise_m`` over a few hundred), and blends into the source terrain between
  ``blend_m``; where the source lies below the valley, it is raised to it until
  ``raise_until_m`` from the shore. Beyond that the source is untouched, so points far from any
  river cost nothing but the source;
* the level under the land is the water level of the nearest river samples at the shore
  (:meth:`WaterSurface.bank_level`: a mix that widens with the distance, so that inside a
  sharp bend, where the nearest reach changes, the ground has no step), blended into a smooth
  mix of nearby levels (:meth:`WaterSurface.land_level`) a few metres out, so banks stay
  above their water and the valleys of reaches at different levels meet without steps.

The bank's shape comes from exact distances to the shore polygon, not from grid cells: the
shoreline is as smooth at 64 m cells as at 1 m (no stair steps).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from riverflow.scenes.water import WaterSurface, bed_depth


@dataclass(frozen=True)
class Carving:
    """How rivers are carved into the terrain (module docstring); lengths in metres."""

    bank_rise_m: float = 2.5
    bank_scale_m: float = 12.0
    valley_rise_m: float = 12.0
    valley_scale_m: float = 250.0
    blend_m: tuple[float, float] = (60.0, 400.0)
    raise_until_m: float = 1000.0
    exact_level_m: tuple[float, float] = (5.0, 25.0)
    """The level under the land is the nearest river samples' at the shore, the smooth mix
    from the second distance on."""
    land_lattice_m: float = 16.0
    """The smooth mix varies slowly: it is evaluated on a global lattice this fine (anchored
    at the quadtree root) and interpolated bilinearly, still a function of the point alone."""

    @classmethod
    def measured(cls) -> Carving:
        """For measured terrain (an elevation raster, a callable): banks only, no valley, the
        source kept from 200 m out."""
        return cls(valley_rise_m=0.0, blend_m=(20.0, 200.0), raise_until_m=300.0)

    @property
    def reach_m(self) -> float:
        """Farther than this from every shore the source is untouched."""
        return max(self.raise_until_m, self.blend_m[1])


def carve(water: WaterSurface, xy: np.ndarray, source_m,
          carving: Carving = Carving(), anchor_m: tuple[float, float] = (0.0, 0.0),
          shore_m: np.ndarray | None = None, inside: np.ndarray | None = None,
          nearest=None) -> np.ndarray:
    """Carved terrain heights [m], (N,) float64, at points xy (N, 2) [m] whose uncarved
    source heights are ``source_m`` (N,), or a function of points (K, 2) giving them (then
    read only where they count: not under the water); ``anchor_m`` is a node of the
    land-level lattice (the quadtree root's corner); ``shore_m`` (N,): the points' distance
    to the shore if known (:meth:`WaterSurface.distance_to_shore`, inf or any value from
    ``carving.reach_m`` on: beyond reach); ``inside`` (N,) bool: the points in the water
    (:meth:`WaterSurface.contains` on that distance) if known; ``nearest``: a function of
    indices (K,) into xy giving :meth:`WaterSurface.nearest`'s level and width there (a
    tile's producers share them, :class:`~riverflow.scenes.tile_kinds.LandscapeTiles`).
    Every value is the point's alone, however it was given."""
    p = np.asarray(xy, np.float64).reshape(-1, 2)
    if callable(source_m):
        out = np.zeros(len(p))
    else:
        out = np.asarray(source_m, np.float64).reshape(-1).copy()
    if shore_m is None:
        shore = water.distance_to_shore(p, upper_bound_m=carving.reach_m)
    else:
        shore = np.asarray(shore_m, np.float64).reshape(-1)
        if shore.shape != (len(p),):
            raise ValueError(f"carve: shore_m has {shore.size} values for {len(p)} points")
        shore = np.where(shore < carving.reach_m, shore, np.inf)
    near = np.flatnonzero(np.isfinite(shore))
    if inside is None:
        inside = water.contains(p[near], shore[near])
    else:
        inside = np.asarray(inside, bool).reshape(-1)[near]
    if callable(source_m):          # the source where it counts: not under the water
        land = np.ones(len(p), bool)
        land[near[inside]] = False
        if land.any():
            out[land] = source_m(p[land])
    if not len(near):
        return out
    q, d, far = p[near], shore[near], out[near]
    exact0, exact1 = carving.exact_level_m
    beta = _smoothstep(exact0, exact1, d)
    # the nearest river's level and width count in the water and where the land's level is
    # not all the smooth mix (beta < 1): the centre-line query (as costly as the shore's) is
    # made there only
    level = np.zeros(len(q))
    width = np.ones(len(q))
    wanted = np.flatnonzero(inside | (beta < 1.0))
    if len(wanted):
        if nearest is None:
            _, level[wanted], width[wanted] = water.nearest(q[wanted])
        else:
            level[wanted], width[wanted] = nearest(near[wanted])
    land_level = level.copy()
    dry = np.flatnonzero(~inside & (beta < 1.0))
    if len(dry):                    # continuous where the nearest reach changes (bends)
        land_level[dry] = water.bank_level(q[dry], d[dry])
    mixed = np.flatnonzero(~inside & (beta > 0.0))      # (the land's level: not in the water)
    if len(mixed):
        smooth = lattice_land_level(water, q[mixed], carving.land_lattice_m, anchor_m)
        land_level[mixed] = (1.0 - beta[mixed]) * land_level[mixed] + beta[mixed] * smooth
    valley = (land_level + carving.bank_rise_m * (1.0 - np.exp(-d / carving.bank_scale_m))
              + carving.valley_rise_m * (1.0 - np.exp(-d / carving.valley_scale_m)))
    alpha = _smoothstep(*carving.blend_m, d)
    lift = 1.0 - _smoothstep(carving.blend_m[1], carving.raise_until_m, d)
    raised = far + lift * np.maximum(valley - far, 0.0)
    land = (1.0 - alpha) * valley + alpha * raised
    out[near] = np.where(inside, level - bed_depth(d, width), land)
    return out


def lattice_land_level(water: WaterSurface, xy: np.ndarray, lattice_m: float,
                       anchor_m: tuple[float, float]) -> np.ndarray:
    """:meth:`WaterSurface.land_level` on the lattice ``anchor + (i, j) · lattice_m``,
    interpolated bilinearly at xy (N, 2) [m]; exact at lattice nodes."""
    g = (xy - np.asarray(anchor_m, np.float64)) / lattice_m
    ij = np.floor(g).astype(np.int64)
    fx, fy = g[:, 0] - ij[:, 0], g[:, 1] - ij[:, 1]
    # a corner whose weight is exactly 0 (a point on a lattice line) is not read: the node
    # before it is read in its place (x + 0 · x is x), so a point on a lattice node, as the
    # height-change grid's are, reads one node, not four
    i0, j0 = ij[:, 0], ij[:, 1]
    i1, j1 = i0 + (fx != 0.0), j0 + (fy != 0.0)
    lo_i, lo_j = int(i0.min()), int(j0.min())
    ni, nj = int(i1.max()) - lo_i + 1, int(j1.max()) - lo_j + 1
    if ni * nj <= 4 * len(ij):
        # a compact batch (a tile's nodes, finer than the lattice): every node of the
        # lattice's box around it, indexed directly, not sorted out (same nodes, same values)
        gi, gj = np.divmod(np.arange(ni * nj), nj)
        nodes = np.stack([gi + lo_i, gj + lo_j], axis=1)
        table = water.land_level(np.asarray(anchor_m, np.float64) + nodes * lattice_m)
        v00 = table[(i0 - lo_i) * nj + (j0 - lo_j)]
        v10 = table[(i1 - lo_i) * nj + (j0 - lo_j)]
        v01 = table[(i0 - lo_i) * nj + (j1 - lo_j)]
        v11 = table[(i1 - lo_i) * nj + (j1 - lo_j)]
    else:
        # the corners read, once each, through one int64 key per node (ordered as
        # np.unique(axis=0) orders the rows: by i, then j), several times faster than
        # sorting rows
        keys = np.concatenate([(i0 - lo_i) * nj + (j0 - lo_j), (i1 - lo_i) * nj + (j0 - lo_j),
                               (i0 - lo_i) * nj + (j1 - lo_j), (i1 - lo_i) * nj + (j1 - lo_j)])
        keys, inverse = np.unique(keys, return_inverse=True)
        nodes = np.stack([keys // nj + lo_i, keys % nj + lo_j], axis=1)
        v00, v10, v01, v11 = water.land_level(
            np.asarray(anchor_m, np.float64) + nodes * lattice_m)[inverse].reshape(4, -1)
    return (1 - fy) * ((1 - fx) * v00 + fx * v10) + fy * ((1 - fx) * v01 + fx * v11)


def _smoothstep(e0: float, e1: float, x: np.ndarray) -> np.ndarray:
    t = np.clip((x - e0) / max(e1 - e0, 1e-12), 0.0, 1.0)
    return t * t * (3 - 2 * t)
