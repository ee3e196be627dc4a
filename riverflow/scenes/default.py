"""The built-in landscapes: seeded procedural terrain around a river network, of any size.

``default_scene(seed)`` lays out (:mod:`riverflow.scenes.layout`) a meandering main river
(west to east, about 4.5 km, 55 m wide at its source widening to 150 m at its mouth), a
tributary joining it (confluence), an island splitting it (a bifurcation that re-joins) and a
small free island further down, on a 4 km square. ``default_scene(seed, size_km=500)`` makes
a world of that size: a main river across it with tributaries (and theirs) reaching the whole
square, islands along the way. The :class:`~riverflow.hydro.builder.RiverNetworkBuilder`
turns the layout into the hydro graph.

The ground is designed around the river and evaluated point by point (a
:class:`DefaultGround` height source): a regional slope down to the east, a valley along the
main river, seeded fBm noise calmer near the river, and hills. Water profiles follow the ground
downhill (:mod:`riverflow.scenes.water`); the rivers are carved in per point
(:mod:`riverflow.scenes.carving`). The result is a streamed
:class:`~riverflow.scenes.landscape.Landscape`: no whole-map array is made, and the river world
makes tiles of it where the camera looks. Same seed → bitwise the same scene.
"""
from __future__ import annotations

import numpy as np
import shapely

from riverflow._validate import check_allocation, finite
from riverflow._validate import seed as seed_value
from riverflow.hydro.builder import RiverNetworkBuilder
from riverflow.scenes.carving import Carving
from riverflow.scenes.landscape import (DEFAULT_CELL_M, CarvedTerrain, Landscape, SourceGround,
                                        water_surface, z_range)
from riverflow.scenes.layout import DEFAULT_SIZE_M, RiverBranch, layout
from riverflow.scenes.sources import FbmSource, HeightSource
from riverflow.scenes.water import point_tree
from riverflow.tiles.quadtree import Quadtree

__all__ = ["DAM_OUTLET", "DefaultGround", "RiverBranch", "Scene", "default_scene"]

HALF_SIZE_M = 0.5 * DEFAULT_SIZE_M
"""The 4 km scene covers [-HALF_SIZE_M, HALF_SIZE_M]² [m]."""
CELL_M = DEFAULT_CELL_M
TILE_M = 256.0
"""Side of the finest terrain tiles [m] (64 cells of CELL_M)."""
VALLEY_REACH_M = 1500.0
"""The main river's valley shapes the ground this far from its centre line."""
REGIONAL_DROP_M = 16.4
"""How much lower the east edge is than the west edge on the 4 km scene (0.004 m/m); larger
worlds fall at most 400 m across."""

Scene = Landscape
"""The built-in scenes are landscapes (kept as a name of the public API)."""


class DefaultGround(HeightSource):
    """The ground of the built-in scenes [m], before the rivers are carved in:
    ``30 + slope·(half − x) + 0.03·min(d, 1500) + calm(d)·noise + hills`` with d the distance
    to the main river's centre line [m] (``calm`` quietens the noise along the river) and the
    hills optional (the water profiles are sampled on the ground without them)."""

    def __init__(self, main_line_m: np.ndarray, size_m: float, noise_seed: int, hills_seed: int,
                 hills: bool = True) -> None:
        self._tree = point_tree(np.asarray(main_line_m, np.float64))
        self.half_m = 0.5 * float(size_m)
        self.slope = min(REGIONAL_DROP_M / DEFAULT_SIZE_M, 400.0 / float(size_m))
        self._noise = FbmSource(noise_seed, ((700.0, 6.0), (220.0, 2.5), (70.0, 0.8)))
        self._hills = FbmSource(hills_seed, ((900.0, 0.8), (350.0, 0.3))) if hills else None
        lo, hi = self._noise.z_range_m
        top = 30.0 + self.slope * 2.0 * self.half_m + 0.03 * VALLEY_REACH_M + hi
        if self._hills is not None:
            top += 28.0 * (0.5 + 0.5 * self._hills.z_range_m[1])
        self.z_range_m = (30.0 + lo, top)
        self.hills = self._hills is not None

    def without_hills(self) -> DefaultGround:
        ground = object.__new__(DefaultGround)
        ground.__dict__.update(self.__dict__)
        ground._hills = None
        ground.hills = False
        return ground

    def heights(self, x_m, y_m) -> np.ndarray:
        x, y = np.broadcast_arrays(np.asarray(x_m, np.float64), np.asarray(y_m, np.float64))
        p = np.stack([x.ravel(), y.ravel()], axis=1)
        valley, _ = self._tree.query(p, distance_upper_bound=VALLEY_REACH_M, workers=1)
        valley = np.minimum(valley, VALLEY_REACH_M)
        t = np.clip(valley / 600.0, 0.0, 1.0)
        calm = 0.3 + 0.7 * t * t * (3 - 2 * t)
        z = (30.0 + self.slope * (self.half_m - p[:, 0]) + 0.03 * valley
             + calm * self._noise.heights(p[:, 0], p[:, 1]))
        if self._hills is not None:
            z += 28.0 * np.clip(0.5 + 0.5 * self._hills.heights(p[:, 0], p[:, 1]), 0.0, None)
        return z.reshape(x.shape)


FALL_AT = 0.4
"""With ``falls=True`` the first tributary drops over a fall this far along it…"""
FALL_DROP_M = 6.0
"""…of this height…"""
RAPIDS_AT = (0.55, 0.62)
"""…and runs down a rapid between these fractions of its length…"""
RAPIDS_SLOPE = 0.06
"""…this steep (6 %: whitewater, not a cascade)."""


DAM_AT = 0.45
"""With ``dam=True`` a reservoir lies this far along the main river's first reach…"""
DAM_LAKE_M = (520.0, 300.0)
"""…an ellipse this long along the river and this wide [m] round it; its level is the
river's where it comes in, so the water steps down at the outlet (the dam)."""
DAM_OUTLET = "main_below_dam"
"""The name of the link that leaves the reservoir: the dam's release is its hydrograph
(``world.set_hydrograph(DAM_OUTLET, …)``)."""


def default_scene(seed: int = 0, size_km: float = 4.0, *, falls: bool = False,
                  dam: bool = False) -> Landscape:
    """The built-in scene for ``seed`` on a ``size_km`` square (deterministic; the 4 km one in
    about a second, larger ones in seconds: only the network is made up front). With
    ``falls=True`` the first tributary has a fall (FALL_DROP_M high, FALL_AT along it) and a
    rapid below it (RAPIDS_AT, RAPIDS_SLOPE); the water above them is raised to make their
    drop, so the rest of the network is the scene without them. With ``dam=True`` the main
    river's first reach runs through a reservoir (a lake, :func:`dam_lake`: DAM_AT along it,
    DAM_LAKE_M, flat at the inflowing river's level) drawn as water, its bed carved below it
    (the reservoir's samples are as wide as the lake: :func:`cut_at_lake`), and the
    scene's branches are cut at its shore: the river above, the ``"reservoir"`` through it
    and DAM_OUTLET below the dam (where a release starts, :func:`riverflow.hydro.flood.
    level_pool_release`, ``demos/dam_break.py``)."""
    seed = seed_value(seed, "default_scene: seed")
    size_km = finite(size_km, "default_scene: size_km")
    size_m = DEFAULT_SIZE_M if abs(size_km - 4.0) < 1e-9 else 1000.0 * float(size_km)
    if not size_m >= 500.0:
        raise ValueError(f"default_scene: size_km must be at least 0.5, got {size_km!r}")
    # the network grows with the side: about 0.6 MB a km measured (30 km, 300 km), + 250 MB
    check_allocation(250e6 + 0.6e6 * size_km, f"default_scene: size_km={size_km!r}")
    rng = np.random.default_rng(seed)
    branches, islands = layout(rng, size_m)
    builder = RiverNetworkBuilder(tolerance_m=0.25)
    for b in branches:
        builder.add_branch(b.centerline_m, b.widths_m, b.discharge_m2s, name=b.name)
    for outline in islands:
        builder.add_island(outline)
    lake = dam_lake(branches) if dam else None
    if lake is not None:
        builder.add_lake(lake)
    if falls:
        k = next((i for i, b in enumerate(branches) if b.kind == "tributary"), None)
        if k is None:
            raise ValueError("default_scene: this layout has no tributary to put a fall on")
        length = float(np.hypot(*np.diff(branches[k].centerline_m, axis=0).T).sum())
        builder.add_fall(FALL_AT * length, FALL_DROP_M, branch=k)
        a, e = RAPIDS_AT[0] * length, RAPIDS_AT[1] * length
        builder.add_rapids(a, e, RAPIDS_SLOPE * (e - a), branch=k)
    graph = builder.build()
    for b, q in zip(branches, builder.discharges_m2s):
        b.discharge_m2s = q
    noise_seed, hills_seed = (int(v) for v in rng.integers(0, 2**62, size=2))
    main = np.vstack([b.centerline_m for b in branches if b.kind == "main"])
    ground = DefaultGround(main, size_m, noise_seed, hills_seed)
    base = ground.without_hills()
    along = lambda xy: base.heights(xy[:, 0], xy[:, 1])  # noqa: E731
    if lake is not None:
        branches = cut_at_lake(branches, lake)
        # the reservoir stands at the level its river comes in at (a first pass for that)
        _, z_in = water_surface(branches, along, builder.water_polygon, graph.falls,
                                   graph.rapids).profiles[branches[0].name]
        lakes = [(lake, float(z_in[-1]))]
    else:
        lakes = []
    water = water_surface(branches, along, builder.water_polygon, graph.falls, graph.rapids,
                          lakes)
    half = 0.5 * size_m
    quadtree = Quadtree(-half, -half, size_m)
    carving = Carving()
    terrain = CarvedTerrain(ground, water, carving, quadtree, CELL_M)
    return Landscape(graph, terrain, water, quadtree.bounds_m, int(seed), branches, islands,
                     z_range(ground, water, carving),
                     profile_ground=SourceGround(base))


def dam_lake(branches: list[RiverBranch]) -> shapely.Polygon:
    """The ``dam=True`` reservoir: an ellipse DAM_LAKE_M round the point DAM_AT along the first
    main branch, its long axis along the river there."""
    main = next(b for b in branches if b.kind == "main")
    line = main.centerline_m
    s = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(line, axis=0).T))])
    at = DAM_AT * s[-1]
    centre = np.array([np.interp(at, s, line[:, 0]), np.interp(at, s, line[:, 1])])
    k = min(int(np.searchsorted(s, at)), len(line) - 1)
    t = line[k] - line[max(k - 1, 0)]
    t = t / np.hypot(*t)
    a = np.linspace(0.0, 2.0 * np.pi, 64, endpoint=False)
    u, v = 0.5 * DAM_LAKE_M[0] * np.cos(a), 0.5 * DAM_LAKE_M[1] * np.sin(a)
    pts = centre + np.outer(u, t) + np.outer(v, [-t[1], t[0]])
    return shapely.Polygon(pts)


def cut_at_lake(branches: list[RiverBranch], lake: shapely.Polygon) -> list[RiverBranch]:
    """The branches with the one through ``lake`` cut at its shore into the river above
    (its name), ``"reservoir"`` (inside, as wide as the lake there, so its water covers the
    whole lake) and DAM_OUTLET below; two new junctions at the shore."""
    k = next(i for i, b in enumerate(branches)
             if shapely.LineString(b.centerline_m).intersects(lake))
    b = branches[k]
    line = b.centerline_m
    s = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(line, axis=0).T))])
    ls = shapely.LineString(line)
    inside = ls.intersection(lake)
    if inside.geom_type != "LineString":
        raise ValueError(f"default_scene: branch {b.name!r} crosses the reservoir more than "
                         f"once")
    ends = shapely.line_locate_point(ls, shapely.points(np.asarray(inside.coords)[[0, -1]]))
    s_in, s_out = float(ends.min()), float(ends.max())

    def piece(a: float, e: float) -> tuple[np.ndarray, np.ndarray]:
        keep = (s > a) & (s < e)
        ss = np.concatenate([[a], s[keep], [e]])
        pts = np.stack([np.interp(ss, s, line[:, 0]), np.interp(ss, s, line[:, 1])], axis=1)
        return pts, np.interp(ss, s, b.widths_m)

    j_in = 1 + max(max(x.start_junction, x.end_junction) for x in branches)
    j_out = j_in + 1
    above, w_above = piece(0.0, s_in)
    through, w_through = piece(s_in, s_out)
    below, w_below = piece(s_out, s[-1])
    shore = shapely.distance(lake.exterior, shapely.points(through))
    w_through = np.maximum(w_through, 2.0 * shore)
    q = b.discharge_m2s
    cut = [RiverBranch(b.name, above, w_above, q, b.kind, b.start_junction, j_in),
           RiverBranch("reservoir", through, w_through, q, b.kind, j_in, j_out),
           RiverBranch(DAM_OUTLET, below, w_below, q, b.kind, j_out, b.end_junction)]
    return branches[:k] + cut + branches[k + 1:]
