"""Landscape: a river network on a height source, streamed as tiles (SPEC §8).

Nothing here is allocated per unit of map area. A landscape is

* a **height source** (:mod:`riverflow.scenes.sources`: seeded noise, a callable, an array or a
  memory-mapped file), sampled point by point;
* the **water** of the network (:class:`~riverflow.scenes.water.WaterSurface`): a water level
  profile along each branch, made once per network (sampled from the source along the centre
  lines, made monotone downhill, equal at junctions), KD-trees of the centre lines and shores,
  the water polygon;
* the **carving** (:mod:`riverflow.scenes.carving`) that turns both into the terrain heights at
  any point: :attr:`Landscape.terrain` ``.height(xy)``.

The tile kinds that the world streams (heights, water levels, meshes, the particles' tables;
:mod:`riverflow.scenes.tile_kinds`) sample these functions on the nodes of their tiles, so
tiles agree bitwise at shared nodes, whatever their level and whatever was made before.

:func:`landscape` makes one for any hydro graph (the command line's ``--scene FILE``);
:func:`riverflow.scenes.default.default_scene` makes the built-in ones.
"""
from __future__ import annotations

import math
import threading
from collections import OrderedDict
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import shapely
from scipy.spatial import cKDTree

from riverflow._validate import check_allocation, finite_positive
from riverflow._validate import seed as seed_value
from riverflow.hydro.areas import area_ring, basin_mouth, water_polygon
from riverflow.hydro.falls import Fall, Rapid, drop_along
from riverflow.hydro.graph import GraphError, HydroGraph
from riverflow.hydro.nearest import PolylineIndex
from riverflow.scenes.carving import Carving, carve
from riverflow.scenes.layout import RiverBranch
from riverflow.scenes.sources import FbmSource, HeightSource, as_height_source
from riverflow.scenes.water import (WaterSurface, bed_depth, monotone_profiles, point_tree,
                                    resample, resample_segments)
from riverflow.tiles.memo import TileMemo
from riverflow.tiles.quadtree import Quadtree

TILE_CELLS = 64
"""Cells per side of a terrain tile (all terrain kinds)."""
DEFAULT_CELL_M = 4.0
"""Node spacing of the finest terrain tiles [m] unless the network or the source needs finer."""
PROFILE_SPACING_M = 10.0
"""Centre-line sample spacing of the water profiles [m]."""
SURFACE_SPACING_M = 2.0
"""Centre-line sample spacing of the water-surface lookup [m]."""
FREEBOARD_M = 1.5
"""Water profiles are sampled this far below the ground."""
PROFILE_HALF_WINDOW = 12
"""Box-smoothing half window of the profiles [samples]."""


SOURCE_KEEP = 256
"""Tiles whose nodes' source heights a terrain keeps (:class:`SourceTiles`; 36 KB each at 64
cells: 9 MB at most; a 1080p view draws ~150 terrain tiles)."""


class SourceTiles:
    """The source's heights at the nodes (with their one-node ring) of recently made height
    tiles, kept across the live edits of the network (:func:`riverflow.engine.edits.
    edited_scene` hands them to the new terrain): the rivers change, the source does not, so
    the edits of a drag read a tile's source back rather than make it again. They belong to
    one source and one tile grid (quadtree, cells a tile): a terrain on another one starts
    its own (:meth:`fits`). At most ``keep`` tiles, the least recently read out first."""

    def __init__(self, source: HeightSource, quadtree: Quadtree, n: int,
                 keep: int = SOURCE_KEEP) -> None:
        self.source, self.quadtree, self.n, self.keep = source, quadtree, int(n), int(keep)
        self._tiles: OrderedDict[tuple[int, int, int], np.ndarray] = OrderedDict()
        self._lock = threading.Lock()

    def fits(self, source: HeightSource, quadtree: Quadtree, n: int) -> bool:
        """Whether these are the heights of ``source`` on the tiles of ``quadtree`` with ``n``
        cells a side."""
        return source is self.source and quadtree is self.quadtree and int(n) == self.n

    def __contains__(self, key) -> bool:
        return tuple(key) in self._tiles

    def __len__(self) -> int:
        return len(self._tiles)

    def heights(self, key, nodes: np.ndarray) -> np.ndarray:
        """The source's heights (N,) float64 [m] at tile ``key``'s ``nodes`` (N, 2) [m] (its
        (n + 3)² nodes with their ring), read back if kept, else made and kept."""
        key = tuple(int(k) for k in key)
        with self._lock:
            got = self._tiles.get(key)
            if got is not None and len(got) == len(nodes):
                self._tiles.move_to_end(key)
                return got
        p = np.asarray(nodes, np.float64).reshape(-1, 2)
        z = np.asarray(self.source.heights(p[:, 0], p[:, 1]), np.float64).reshape(-1)
        z.flags.writeable = False
        with self._lock:
            self._tiles[key] = z
            while len(self._tiles) > self.keep:
                self._tiles.popitem(last=False)
        return z

    def __getstate__(self) -> dict:
        state = dict(self.__dict__)
        del state["_lock"]
        return state

    def __setstate__(self, state: dict) -> None:
        self.__dict__.update(state)
        self._lock = threading.Lock()


@dataclass(eq=False)
class CarvedTerrain:
    """The terrain of a landscape: the source with the rivers carved in, at any point.

    ``height(xy)`` [m] is pointwise (:func:`riverflow.scenes.carving.carve`); ``cell_m`` is the
    node spacing of the finest tiles, ``tile_size_m`` their side; ``origin_m`` the quadtree
    root's corner.
    """

    source: HeightSource
    water: WaterSurface
    carving: Carving
    quadtree: Quadtree
    cell_m: float
    tile_cells: int = TILE_CELLS
    source_tiles: SourceTiles | None = None
    """The source at recently made height tiles' nodes (:class:`SourceTiles`): an edited
    network's terrain is given its predecessor's; one that does not fit this terrain's source
    and grid is replaced by an empty one."""

    def __post_init__(self) -> None:
        if self.source_tiles is None or not self.source_tiles.fits(
                self.source, self.quadtree, self.tile_cells):
            self.source_tiles = SourceTiles(self.source, self.quadtree, self.tile_cells)

    def height(self, xy: np.ndarray, shore_m: np.ndarray | None = None,
               inside: np.ndarray | None = None, nearest=None, source_m=None) -> np.ndarray:
        """Terrain altitude [m] at points (N, 2) [m], (N,) float64; ``shore_m`` (N,): their
        distance to the shore, ``inside`` whether they are in the water and ``nearest`` the
        centre line's level and width, if known (:func:`~riverflow.scenes.carving.carve`);
        ``source_m`` (N,): the source's heights there if known, else the source is read
        only where it counts (not under the water)."""
        p = np.asarray(xy, np.float64).reshape(-1, 2)
        return carve(self.water, p, self._source_at if source_m is None else source_m,
                     self.carving,
                     (self.quadtree.root_x_m, self.quadtree.root_y_m), shore_m, inside,
                     nearest)

    def _source_at(self, p: np.ndarray) -> np.ndarray:
        return np.asarray(self.source.heights(p[:, 0], p[:, 1]), np.float64).reshape(-1)

    @property
    def tile_size_m(self) -> float:
        return self.cell_m * self.tile_cells

    @property
    def origin_m(self) -> np.ndarray:
        return np.array([self.quadtree.root_x_m, self.quadtree.root_y_m])

    @property
    def bounds_m(self) -> tuple[float, float, float, float]:
        return self.quadtree.bounds_m

    @property
    def max_level(self) -> int:
        """The finest tile level (node spacing ≤ cell_m)."""
        return self.quadtree.level_for_cell(self.cell_m, self.tile_cells)

    def grid(self, x0_m: float, y0_m: float, cell_m: float, nx: int, ny: int) -> np.ndarray:
        """Heights (ny, nx) float32 [m] at ``(x0 + i·cell, y0 + j·cell)`` (tools, tests)."""
        gx, gy = np.meshgrid(x0_m + np.arange(nx) * cell_m, y0_m + np.arange(ny) * cell_m)
        return self.height(np.c_[gx.ravel(), gy.ravel()]).reshape(ny, nx).astype(np.float32)


@dataclass(eq=False)
class Landscape:
    """A streamed scene (module docstring): ``graph``, ``terrain`` (:class:`CarvedTerrain`),
    ``water`` (:class:`WaterSurface`), ``bounds_m`` (the quadtree root square), ``seed``,
    ``branches`` (upstream first), free island outlines and ``z_range_m`` (bounds of every
    terrain and water height)."""

    graph: HydroGraph
    terrain: CarvedTerrain
    water: WaterSurface
    bounds_m: tuple[float, float, float, float]
    seed: int
    branches: list[RiverBranch]
    islands: list[np.ndarray] = field(default_factory=list)
    z_range_m: tuple[float, float] = (0.0, 0.0)
    tile_memo: TileMemo = field(default_factory=TileMemo, repr=False)
    """The array tiles made for this scene, shared by every world over it
    (:mod:`riverflow.tiles.memo`; ``TileMemo(0)``: none kept)."""
    profile_ground: Callable[[np.ndarray], np.ndarray] | None = field(default=None, repr=False)
    """``ground(xy)`` the water profiles were sampled on (:func:`water_surface`): a live edit
    samples its new branches on it (:mod:`riverflow.engine.edits`); None: the scene's water
    level + FREEBOARD_M."""

    def branch(self, name: str) -> RiverBranch:
        return next(b for b in self.branches if b.name == name)

    @property
    def quadtree(self) -> Quadtree:
        return self.terrain.quadtree


@dataclass(frozen=True)
class SourceGround:
    """``ground(xy)`` (N, 2) → (N,) [m] of a height source (picklable, unlike a lambda)."""

    source: HeightSource

    def __call__(self, xy: np.ndarray) -> np.ndarray:
        return np.asarray(self.source.heights(xy[:, 0], xy[:, 1]), np.float64)


@dataclass(frozen=True)
class GivenGround:
    """``ground(xy)`` of given water levels (a graph's ``water_levels``) + FREEBOARD_M."""

    levels: Callable[[np.ndarray], np.ndarray]

    def __call__(self, xy: np.ndarray) -> np.ndarray:
        return np.asarray(self.levels(xy), np.float64) + FREEBOARD_M


def z_range(source: HeightSource, water: WaterSurface, carving: Carving) -> tuple[float, float]:
    """Conservative bounds [m] of the carved terrain and the water."""
    lo, hi = source.z_range_m
    deepest = float(np.max(bed_depth(np.inf, water.widths_m))) if len(water.widths_m) else 0.0
    levels = water.levels_m
    lo = min(lo, float(levels.min()) - deepest - 1.0)
    hi = max(hi, float(levels.max()) + carving.bank_rise_m + carving.valley_rise_m + 1.0)
    return lo, hi


# -- water surfaces ------------------------------------------------------------------------------


def water_surface(branches: list[RiverBranch],
                  ground: Callable[[np.ndarray], np.ndarray] | list[np.ndarray],
                  polygon, falls: list[Fall] = (), rapids: list[Rapid] = (),
                  lakes=()) -> WaterSurface:
    """Monotone water profiles of the branches (listed upstream first) on the ground [m]
    (``ground(xy)`` of the uncarved terrain, or its values at each branch's centre-line
    points) lowered by FREEBOARD_M, as a :class:`WaterSurface`. ``falls`` and ``rapids``
    (the graph's) drop the water along their nappes and slopes (:func:`monotone_profiles`);
    the surface is sampled finely along each nappe (NAPPE_SAMPLES). ``lakes``: [(polygon,
    level [m] or None)] or [(polygon, None, mouth (2,) [m])] for a basin: the samples in a lake
    are at its level (given; a basin's the river's at its mouth; else the lowest the profiles
    reach in it), those upstream of it no lower and those downstream no higher: the lake is
    flat and no river runs uphill into or out of it."""
    n_junctions = 1 + max(max(b.start_junction, b.end_junction) for b in branches)
    along = ground if isinstance(ground, list) else [ground(b.centerline_m) for b in branches]
    sampled = [np.asarray(z, np.float64) - FREEBOARD_M for z in along]
    on_branch = falls_on_branches(branches, falls, rapids)
    levels = monotone_profiles([b.centerline_m for b in branches], sampled,
                               [b.start_junction for b in branches],
                               [b.end_junction for b in branches], max(n_junctions, 0),
                               half_window=PROFILE_HALF_WINDOW, caps_m=junction_caps(branches),
                               falls=on_branch)
    lost = [k for k, z in enumerate(levels) if not np.isfinite(z).all()]
    if lost:       # (a NaN level hides the whole water and terrain: a world of fog)
        k = lost[0]
        raise ValueError(f"water_surface: no finite water level along {len(lost)} branch(es), "
                         f"first {branches[k].name!r} (its ground from "
                         f"{np.nanmin(sampled[k]):g} to {np.nanmax(sampled[k]):g} m, "
                         f"{int(np.sum(~np.isfinite(sampled[k])))} of {len(sampled[k])} "
                         "heights not finite)")
    samples, lv, wd, index, profiles = [], [], [], [], {}
    for k, (b, z) in enumerate(zip(branches, levels)):
        s = _arc(b.centerline_m)
        profiles[b.name] = (s, z)
        if on_branch[k]:
            pts, zz, ww = _resample_over_falls(b.centerline_m, s, z, b.widths_m, on_branch[k])
        else:
            pts, zz, ww, _ = resample_segments(b.centerline_m, SURFACE_SPACING_M, z,
                                               b.widths_m)
        samples.append(pts)
        lv.append(np.minimum.accumulate(zz))
        wd.append(ww)
        index.append(np.full(len(pts), k))
    _flat_lakes(samples, lv, lakes, wd)
    junctions = np.zeros((max(n_junctions, 0), 2))
    members: list[tuple[int, ...]] = []
    for j in range(max(n_junctions, 0)):
        members.append(tuple(k for k, b in enumerate(branches)
                             if j in (b.start_junction, b.end_junction)))
        b = branches[members[-1][0]]
        junctions[j] = b.centerline_m[0] if b.start_junction == j else b.centerline_m[-1]
    return WaterSurface(np.vstack(samples), np.concatenate(lv), np.concatenate(wd),
                        np.concatenate(index), polygon, profiles, junctions, members)


NAPPE_SAMPLES = 16
"""The water surface is sampled this many times along each fall's nappe (and its level there
is the nappe's parabola itself, not an interpolation between profile points)."""


def falls_on_branches(branches: list[RiverBranch], falls, rapids=()
                      ) -> list[list[tuple[float, float, float, str, str]]]:
    """Per branch, its falls and rapids as :func:`monotone_profiles` takes them: (station
    [m] along the branch's centre line, drop [m], length [m] (a fall's throw, a rapid's
    length), how, shape). Each lies on the branch whose centre line passes nearest its lip
    (a rapid: its middle); its drop is "given" where it was found in the levels, else made
    by raising the water above it on a branch from a free source, by lowering the water
    below it otherwise."""
    out: list[list[tuple[float, float, float, str, str]]] = [[] for _ in branches]
    if not falls and not rapids:
        return out
    indexes = [PolylineIndex(b.centerline_m) for b in branches]

    def nearest(xy) -> tuple[int, np.ndarray]:
        p = np.asarray(xy, np.float64).reshape(-1, 2)
        found = [index.nearest(p) for index in indexes]
        best = min(range(len(branches)), key=lambda k: found[k][0][0])
        return best, found[best][2]

    def how(item, b: RiverBranch) -> str:
        return "given" if item.in_levels else ("raise" if b.start_junction < 0 else "lower")

    for f in falls:
        k, at = nearest(f.centre_m)
        out[k].append((float(at[0]), f.drop_m, f.throw_m, how(f, branches[k]), "nappe"))
    for r in rapids:
        k, _ = nearest(r.centre_m)
        index = indexes[k]
        a = float(index.nearest(np.asarray(r.start_m, np.float64)[None])[2][0])
        e = float(index.nearest(np.asarray(r.end_m, np.float64)[None])[2][0])
        if e > a:
            out[k].append((a, r.drop_m, e - a, how(r, branches[k]), "ramp"))
    for row in out:
        row.sort()
    return out


def _resample_over_falls(line: np.ndarray, s: np.ndarray, z: np.ndarray, widths: np.ndarray,
                         falls: list[tuple[float, float, float, str, str]]):
    """:func:`resample` of a branch with falls or rapids: every SURFACE_SPACING_M plus
    NAPPE_SAMPLES stations along each nappe (a rapid's two ends), the level there the profile
    without its drops (interpolated) less the drops' exact shape."""
    n = max(2, int(np.ceil(s[-1] / SURFACE_SPACING_M)) + 1)
    extra = [np.linspace(0.0, s[-1], n)]
    nappe_s = np.zeros_like(s)
    for at, drop, length, _, shape in falls:
        extra.append(at + length * (np.linspace(0.0, 1.0, NAPPE_SAMPLES + 1)
                                    if shape == "nappe" else np.array([0.0, 1.0])))
        nappe_s += drop_along(s - at, drop, length, shape)
    t = np.unique(np.clip(np.concatenate(extra), 0.0, s[-1]))
    t = t[np.concatenate([[True], np.diff(t) > 1e-6])]
    nappe_t = np.zeros_like(t)
    for at, drop, length, _, shape in falls:
        nappe_t += drop_along(t - at, drop, length, shape)
    pts = np.stack([np.interp(t, s, line[:, 0]), np.interp(t, s, line[:, 1])], axis=1)
    return pts, np.interp(t, s, z + nappe_s) - nappe_t, np.interp(t, s, widths)


def _flat_lakes(samples: list[np.ndarray], levels: list[np.ndarray], lakes,
                widths: list[np.ndarray]) -> None:
    """Put the samples in each lake at its level, in place (:func:`water_surface`). A river
    that starts or ends just off a lake's shore (an outlet of a source lake, an inlet of a
    terminal one: their free ends) has that end sample at the lake's level too, so no river
    runs uphill out of a lake. A basin (a lake given as ``(polygon, None, mouth)``) stands at
    the level of the nearest sample to its mouth's middle of the branches with none in it
    (its river's: its water is level with the river's there, and the surface has no step
    where the river passes its mouth) and is as deep: its samples are at least that
    sample's width (the bed's depth follows the width, :func:`~riverflow.scenes.water.bed_depth`).
    """
    for lake in lakes:
        poly, given = lake[0], lake[1]
        mouth = lake[2] if len(lake) > 2 else None
        inside = []
        for p, w in zip(samples, widths):
            m = shapely.contains_xy(poly, p[:, 0], p[:, 1])
            if not m.any():
                for k in (0, -1):
                    m[k] = shapely.distance(poly, shapely.Point(p[k])) <= 0.75 * w[k]
            inside.append(m)
        found = [z[m] for z, m in zip(levels, inside) if m.any()]
        if not found:
            continue
        river_width = None
        if mouth is not None:
            outside = [(p, z, w) for p, z, w, m in zip(samples, levels, widths, inside)
                       if not m.any()]
            if outside:
                d = [np.hypot(*(p - np.asarray(mouth, np.float64)).T) for p, _, _ in outside]
                k = min(range(len(outside)), key=lambda i: float(d[i].min()))
                at = int(np.argmin(d[k]))
                river_width = float(outside[k][2][at])
                if given is None:
                    given = float(outside[k][1][at])
        level = float(given) if given is not None else float(min(f.min() for f in found))
        for z, w, m in zip(levels, widths, inside):
            if not m.any():
                continue
            first, last = np.flatnonzero(m)[[0, -1]]
            z[:first] = np.maximum(z[:first], level)
            z[m] = level
            z[last + 1:] = np.minimum(z[last + 1:], level)
        if river_width is not None:
            # a basin's bed is its river's at the mouth (its own axis's width made it a
            # shallow shelf, and the river's water beside the mouth nearer that axis's end
            # than the river's: a straight step in the bed, drawn lighter, Porto's docks):
            # its samples and those within a width of it
            for p, w, m in zip(samples, widths, inside):
                if m.any():
                    near = m | (shapely.distance(poly, shapely.points(p)) <= w)
                    w[near] = np.maximum(w[near], river_width)


def junction_caps(branches: list[RiverBranch]) -> list[tuple[float, float]]:
    """Per branch, the lengths [m] from its start / end junction along which it lies within one
    width of the other branches of that junction (at least their largest half-width): the
    water there is kept at the junction height, so the surface has no step at the mouth."""
    caps = []
    lines: dict[int, PolylineIndex] = {}      # the branches that meet another, indexed once
    for b in branches:
        s = _arc(b.centerline_m)
        ends = []
        for j, at_end in ((b.start_junction, False), (b.end_junction, True)):
            others = [k for k, o in enumerate(branches)
                      if o is not b and j >= 0 and j in (o.start_junction, o.end_junction)]
            if not others:
                ends.append(0.0)
                continue
            inside = np.zeros(len(s), bool)
            for k in others:
                # farther than one width from another centre line, no point of that
                # branch's water is nearer to this one: the surface switches without a step
                reach = float(branches[k].widths_m.max()) + 0.1 * float(b.widths_m.max())
                if k not in lines:
                    lines[k] = PolylineIndex(branches[k].centerline_m)
                inside |= lines[k].nearest(b.centerline_m, reach)[0] < reach
            from_j = (s[-1] - s) if at_end else s
            outside = from_j[~inside]
            cap = float(outside.min()) if len(outside) else float(s[-1])
            ends.append(max(cap, max(0.5 * float(branches[k].widths_m.max()) for k in others)))
        caps.append((ends[0], ends[1]))
    return caps


def _arc(points: np.ndarray) -> np.ndarray:
    return np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(points, axis=0).T))])


# -- any hydro graph -----------------------------------------------------------------------------


def landscape(graph: HydroGraph, terrain=None, *, seed: int = 0, cell_m: float | None = None,
              origin_m: tuple[float, float] | None = None, source_cell_m: float | None = None,
              carving: Carving | None = None, pad_m: float | None = None) -> Landscape:
    """A streamed landscape around any river network.

    Args:
        graph: the river network (a graph file, the builder's output, …).
        terrain: None for procedural hills around the network (seeded), or a height source
            (:func:`riverflow.scenes.sources.as_height_source`: a callable
            ``heights(x_m, y_m) -> z_m`` on arrays, an array, ``.npy`` or 16-bit ``.png``
            path with ``origin_m`` and ``source_cell_m``, a GeoTIFF path (riverflow[gis];
            reprojected to ``graph.crs`` when that differs), a :class:`HeightSource`).
            Where the graph has ``water_levels`` (GIS bed elevations) the water follows
            them, else the terrain.
        seed: seeds the procedural hills.
        cell_m: node spacing of the finest terrain tiles [m]; default 4 m, finer for narrow
            rivers (a quarter of the narrowest river's width, at least 0.5 m) or a finer source.
        carving: how the rivers are carved (default: :class:`Carving` on procedural hills,
            :meth:`Carving.measured` on a given terrain).
        pad_m: land around the network's bounds [m]; default a quarter of their size (at
            least 512 m).

    Raises:
        GraphError: the graph has no river axis, or its water cannot be made.
    """
    if not isinstance(graph, HydroGraph):
        raise TypeError(f"landscape: graph must be a HydroGraph, got {type(graph).__name__}")
    seed = seed_value(seed, "landscape: seed")
    axes = graph.axes()
    if not axes:
        raise GraphError(f"{graph.source or 'graph'}: no river axis to make a landscape around")
    if cell_m is not None:
        cell_m = finite_positive(cell_m, "landscape: cell_m")
        length = sum(float(np.hypot(*np.diff(graph.polyline(a), axis=0).T).sum()) for a in axes)
        # the carving profiles and water lines are sampled per cell along every axis
        check_allocation(64.0 * length / cell_m, f"landscape: cell_m={cell_m!r} along "
                         f"{length:,.0f} m of rivers")
    polygon = water_polygon(graph)
    if polygon.is_empty:
        raise GraphError(f"{graph.source or 'graph'}: its areas hold no water")
    branches = branches_of_graph(graph, polygon)
    x0, y0, x1, y1 = graph.bounds()
    if pad_m is None:
        pad_m = max(0.25 * max(x1 - x0, y1 - y0), 512.0)
    quadtree = Quadtree.around((x0, y0, x1, y1), pad_m=pad_m)
    source = as_height_source(terrain, origin_m=origin_m, cell_m=source_cell_m, crs=graph.crs)
    _check_overlap(source, (x0, y0, x1, y1), graph)
    narrowest = min(float(b.widths_m.min()) for b in branches)
    if cell_m is None:
        cell_m = min(DEFAULT_CELL_M, max(0.25 * narrowest, 0.5))
        if source is not None and source.cell_m:
            cell_m = min(cell_m, max(source.cell_m, 0.5))
    given = graph.water_levels
    lakes = [(shapely.Polygon(area_ring(graph, a)), graph.areas[a].level_m,
              basin_mouth(graph, a)) for a in graph.lakes()]
    if source is None:
        water = water_surface(branches, _synthetic_ground(branches) if given is None
                              else lambda xy: given(xy) + FREEBOARD_M, polygon, graph.falls,
                              graph.rapids,
                              lakes)
        profile_ground = None if given is None else GivenGround(given)
        source = valley_source(water, seed)
        carving = carving or Carving()
    else:
        profile_ground = SourceGround(source) if given is None else GivenGround(given)
        water = water_surface(branches, profile_ground, polygon, graph.falls, graph.rapids,
                              lakes)
        carving = carving or Carving.measured()
    terrain_ = CarvedTerrain(source, water, carving, quadtree, float(cell_m))
    return Landscape(graph, terrain_, water, quadtree.bounds_m, int(seed), branches, [],
                     z_range(source, water, carving), profile_ground=profile_ground)


def _check_overlap(source, bounds, graph: HydroGraph) -> None:
    """A terrain whose data lies wholly away from the rivers (another CRS, a wrong origin) is
    an error naming both boxes, not a flat plain of edge values."""
    box = getattr(source, "bounds_m", None)
    if box is None:
        return
    x0, y0, x1, y1 = bounds
    if box[0] <= x1 and x0 <= box[2] and box[1] <= y1 and y0 <= box[3]:
        return
    hint = ""
    if getattr(source, "crs", "given") is None and graph.crs:
        hint = ("; the raster has no CRS, so its coordinates were taken in the network's: "
                "give it one (gdal_edit.py -a_srs)")
    raise ValueError(f"landscape: the terrain {source!r} covers x {box[0]:,.1f} … "
                     f"{box[2]:,.1f}, y {box[1]:,.1f} … {box[3]:,.1f} [m], away from the river "
                     f"network (x {x0:,.1f} … {x1:,.1f}, y {y0:,.1f} … {y1:,.1f}){hint}")


def branches_of_graph(graph: HydroGraph, polygon) -> list[RiverBranch]:
    """The graph's axes as branches, upstream first: each axis oriented downstream (facing
    downstream the right bank has the larger ψ), chained through nodes where one axis ends
    and one starts; widths from the distance to the shore (at most the axis width)."""
    axes = graph.axes()
    lines = {a: graph.polyline(a) for a in axes}
    ends = {}
    banks: dict[int, list[int]] = {}
    for i, c in enumerate(graph.curves):
        if c.is_bank and c.has_potential:
            banks.setdefault(c.river, []).append(i)
    for a in axes:
        c = graph.curves[a]
        if _flows_backwards(graph, lines[a], banks.get(a, [])):
            lines[a] = lines[a][::-1].copy()
            ends[a] = (c.end, c.start)
        else:
            ends[a] = (c.start, c.end)
    into: dict[int, list[int]] = {}
    out_of: dict[int, list[int]] = {}
    for a, (s, e) in ends.items():
        out_of.setdefault(s, []).append(a)
        into.setdefault(e, []).append(a)

    def passes(node: int) -> bool:
        return len(into.get(node, [])) == 1 and len(out_of.get(node, [])) == 1

    chains, seen = [], set()
    for a in axes:
        if a in seen or passes(ends[a][0]):
            continue
        chain = [a]
        seen.add(a)
        while passes(ends[chain[-1]][1]):
            nxt = out_of[ends[chain[-1]][1]][0]
            if nxt in seen:
                break
            chain.append(nxt)
            seen.add(nxt)
        chains.append(chain)
    for a in axes:  # a loop of pass-through nodes only
        if a not in seen:
            chains.append([a])
            seen.add(a)
    junction_of: dict[int, int] = {}
    for node in sorted(set(into) | set(out_of)):
        if not passes(node) and len(into.get(node, [])) + len(out_of.get(node, [])) >= 2:
            junction_of[node] = len(junction_of)
    boundary = cKDTree(shapely.get_coordinates(shapely.segmentize(polygon.boundary, 1.0)))
    branches = []
    for chain in chains:
        pts = np.vstack([lines[chain[0]]] + [lines[a][1:] for a in chain[1:]])
        keep = np.concatenate([[True], np.any(np.diff(pts, axis=0) != 0.0, axis=1)])
        narrowest = min(graph.curves[a].width_m for a in chain)
        # no coarser than the river is wide: a 2 m creek's bends are not cut onto its banks
        pts, = resample(pts[keep], min(PROFILE_SPACING_M, max(narrowest, 0.5)))
        axis_w = max(graph.curves[a].width_m for a in chain)
        shore, _ = boundary.query(pts)
        widths = np.clip(2.0 * shore, 0.2 * axis_w, axis_w)
        branches.append(RiverBranch(f"axis_{chain[0]}", pts, widths, None, "tributary",
                                    junction_of.get(ends[chain[0]][0], -1),
                                    junction_of.get(ends[chain[-1]][1], -1)))
    branches = _upstream_first(branches)
    for b in _longest_path(branches):
        b.kind = "main"
    return branches


def _longest_path(branches: list[RiverBranch]) -> list[RiverBranch]:
    """The branches (ordered upstream first) of the longest path down the network, each
    joining the next at a junction: the main river the flight follows."""
    best: dict[int, tuple[float, int]] = {}   # branch → (length of the longest path ending
    ending_at: dict[int, list[int]] = {}       # with it, the branch before it or −1)
    for k, b in enumerate(branches):
        own = float(np.linalg.norm(np.diff(b.centerline_m, axis=0), axis=1).sum())
        before = max(((best[j][0], j) for j in ending_at.get(b.start_junction, ())
                      if b.start_junction >= 0), default=(0.0, -1))
        best[k] = (before[0] + own, before[1])
        if b.end_junction >= 0:
            ending_at.setdefault(b.end_junction, []).append(k)
    if not best:
        return []
    k = max(best, key=lambda j: best[j][0])
    path = []
    while k >= 0:
        path.append(branches[k])
        k = best[k][1]
    return path[::-1]


def _flows_backwards(graph: HydroGraph, line: np.ndarray, banks: list[int]) -> bool:
    """True when the axis ``line`` is drawn upstream: its right-hand banks (``banks``: the
    curves that are its banks with a ψ) have the smaller ψ."""
    left, right = [], []
    tangents = np.diff(line, axis=0)
    for i in banks:
        c = graph.curves[i]
        p = graph.polyline(i)
        mid = p[len(p) // 2]
        d = np.hypot(*(line[:-1] - mid).T)
        k = int(np.argmin(d))
        k = min(k, len(tangents) - 1)
        side = tangents[k, 0] * (mid[1] - line[k, 1]) - tangents[k, 1] * (mid[0] - line[k, 0])
        (left if side > 0 else right).append(c.potential)
    if not left or not right:
        return False
    return float(np.mean(right)) < float(np.mean(left))


def _upstream_first(branches: list[RiverBranch]) -> list[RiverBranch]:
    """Branches ordered so that every branch comes after all that end where it starts
    (cycles, which bad data may hold, are broken where found)."""
    done: list[RiverBranch] = []
    left = list(branches)
    waiting: dict[int, int] = {}       # junction → branches ending there not yet done
    for b in branches:
        if b.end_junction >= 0:
            waiting[b.end_junction] = waiting.get(b.end_junction, 0) + 1
    while left:
        ready = [b for b in left if b.start_junction < 0
                 or not waiting.get(b.start_junction, 0)]
        if not ready:
            ready = [left[0]]
        for b in ready:
            done.append(b)
            if b.end_junction >= 0:
                waiting[b.end_junction] -= 1
        taken = {id(b) for b in ready}
        left = [b for b in left if id(b) not in taken]
    return done


# -- procedural hills around any network -----------------------------------------------------------


RIVER_SLOPE = 0.0005
"""Slope [m/m] of the synthetic river profiles of a network placed on procedural hills."""


def _synthetic_ground(branches: list[RiverBranch]) -> list[np.ndarray]:
    """Ground along each branch [m] for a network with no terrain: 20 m plus RIVER_SLOPE
    times the flow distance to the nearest outlet (every river goes downhill, junctions
    agree)."""
    to_outlet: dict[int, float] = {}   # junction → shortest flow distance to an outlet [m]
    remaining: dict[int, float] = {}   # branch → the same from its start
    for _ in range(len(branches) + 1):
        changed = False
        for i, b in enumerate(branches):
            below = 0.0 if b.end_junction < 0 else to_outlet.get(b.end_junction, math.inf)
            start = float(_arc(b.centerline_m)[-1]) + below
            if start < remaining.get(i, math.inf):
                remaining[i] = start
                changed = True
            if b.start_junction >= 0 and start < to_outlet.get(b.start_junction, math.inf):
                to_outlet[b.start_junction] = start
                changed = True
        if not changed:
            break
    out = []
    for i, b in enumerate(branches):
        s = _arc(b.centerline_m)
        total = remaining.get(i, math.inf)
        total = total if math.isfinite(total) else float(s[-1])
        out.append(20.0 + FREEBOARD_M + RIVER_SLOPE * (total - s))
    return out


@dataclass(eq=False)
class ValleySource(HeightSource):
    """Procedural hills around a river network: a smooth surface through the network's water
    levels (control points every ~500 m of river, the K nearest weighted by
    (1 − d/d_K)²), ``rise_m`` above them, plus seeded fBm hills that fade in away from the
    rivers (their distance from the same control points). Pointwise and seeded."""

    control_xy: np.ndarray
    control_z: np.ndarray
    seed: int
    rise_m: float = 12.0
    hills_m: float = 28.0
    neighbours: int = 8

    def __post_init__(self) -> None:
        self._tree = point_tree(self.control_xy)
        self._hills = FbmSource(self.seed, ((900.0, 0.8), (350.0, 0.3)))
        self._relief = FbmSource(self.seed + 1, ((700.0, 6.0), (220.0, 2.5), (70.0, 0.8)))
        k = min(self.neighbours, len(self.control_xy))
        self._k = k
        amp = self.hills_m * 1.5 + self._relief.z_range_m[1]
        self.z_range_m = (float(self.control_z.min()) - self._relief.z_range_m[1],
                          float(self.control_z.max()) + self.rise_m + amp)
        self.cell_m = None
        self.bounds_m = None

    def heights(self, x_m, y_m) -> np.ndarray:
        x, y = np.broadcast_arrays(np.asarray(x_m, np.float64), np.asarray(y_m, np.float64))
        p = np.stack([x.ravel(), y.ravel()], axis=1)
        if self._k >= 2:
            d, idx = self._tree.query(p, k=self._k, workers=1)
            span = np.maximum(d[:, -1:], 1e-9)
            w = (1.0 - d / span) ** 2 + 1e-12
            base = (w * self.control_z[idx]).sum(axis=1) / w.sum(axis=1)
            near = d[:, 0]
        else:
            base = np.full(len(p), float(self.control_z[0]))
            near = np.hypot(*(p - self.control_xy[0]).T)
        fade = np.clip(near / 1500.0, 0.0, 1.0)
        hills = self.hills_m * np.clip(0.5 + 0.5 * self._hills.heights(p[:, 0], p[:, 1]), 0.0,
                                       None)
        relief = (0.3 + 0.7 * fade) * self._relief.heights(p[:, 0], p[:, 1])
        return (base + self.rise_m * fade + hills * fade + relief).reshape(x.shape)


def valley_source(water: WaterSurface, seed: int, spacing_m: float = 500.0) -> ValleySource:
    """A :class:`ValleySource` through the water levels of ``water``'s centre-line samples,
    one every ``spacing_m`` of river."""
    step = max(1, int(round(spacing_m / SURFACE_SPACING_M)))
    keep = np.zeros(len(water.samples_m), bool)
    keep[::step] = True
    starts = np.flatnonzero(np.diff(water.branch, prepend=-1) != 0)
    keep[starts] = True
    keep[np.append(starts[1:] - 1, len(keep) - 1)] = True
    return ValleySource(water.samples_m[keep].copy(), water.levels_m[keep].copy(), int(seed))
