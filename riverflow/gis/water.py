"""Rivers from water areas: :func:`read_water` (``rf.read_water``).

A map often holds a river as the water itself, not as its centre line: OpenStreetMap's
``natural=water`` multipolygons, a cadastre's riverbank polygons, a water mask classified
from satellite images. :func:`read_water` reads them into a filled
:class:`~riverflow.RiverNetworkBuilder` whose water is the polygons themselves
(:meth:`~riverflow.RiverNetworkBuilder.set_water_area`)::

    builder = rf.read_water("riverbanks.gpkg", lines="waterways.gpkg")
    builder = rf.read_water("water_mask.tif", inlets=[(512_300.0, 5_010_250.0)])
    print(builder.report)            # what was read, decided and repaired
    graph = builder.build()

- **Banks**: the polygons' own rings, islands their holes, simplified by at most
  ``simplify_m`` (default 0.02 m, DEFAULT_SIMPLIFY_M; for a mask half a cell, which takes out
  the cells' stairs).
  A hole that is small beside the channels around it (narrower than ISLAND_SPLIT_WIDTHS
  times the water beside it, and not enclosed by the given lines) is a free island in its
  channel (its ψ the plug-flow estimate, as :meth:`~riverflow.RiverNetworkBuilder.add_island`);
  a larger one splits the river into two channels, each with its own axis, and its ψ comes
  from how the discharge splits between them.
- **Axes** (centre lines): the ``lines`` inside the water (a file, or a layer of the same
  file), cut where they cross its outline; else the water's medial axis (:func:`skeleton`:
  the Voronoi diagram of points along the outline, the edges inside the water), pruned of
  spurs shorter than SPUR_WIDTHS times the width where they branch off, so every channel of a
  braided river has one axis. The water's open ends (where the data's extent cuts it, or at
  the inlets / outlets given) are never pruned (:func:`_open_edge`, :func:`_open_ends`).
  Each free end is carried on to the outline; there the water is cut by a straight closing
  segment across the channel (where water enters or leaves).
- **Direction**: from the lines; else from ``inlets`` (points where water enters) and
  ``outlets`` (points where it leaves), each matched to the nearest free end; else from
  ``dem`` (the highest free end is the inlet, the lowest the outlet); else the two free ends
  farthest apart along the axes are the inlet (the narrower) and the outlet (the wider). The
  other free ends flow in (tributaries) or out (distributaries) as their distances along the
  axes from the inlets and outlets say; ``report.derived["direction"]`` says which rule.
- **Discharge**: ``discharge_m3s`` (the total entering at the sources, split by their widths),
  else each source's from its width by hydraulic geometry
  (:class:`~riverflow.gis.rivers.HydraulicGeometry`); at a bifurcation it splits by the
  widths of the channels leaving (their median widths).

Masks (GeoTIFF or any GDAL raster: a cell > 0 is water; nodata is land) become polygons at
the raster's resolution (``rasterio.features.shapes``). Bad input never gets through as a
library's traceback: an invalid polygon is made valid (``shapely.make_valid``) and reported,
polygons without area are left out and reported, and a file with no water, an inlet far from
every free end of the water, or a network that cannot be built raise
:class:`~riverflow.GraphError` naming the file and what is wrong.

Lakes: polygons tagged ``water=lake|reservoir|pond`` (an OSM tag, or a file's ``water``
attribute) are lakes (:meth:`~riverflow.RiverNetworkBuilder.add_lake`): the rivers' water is
cut open at their shores (their ends there are open ends), a channel starting on a shore
takes its discharge from the lake, and lakes alone are still water. The water tiles are the polygon (through the graph's water area)
clipped per tile and triangulated per grid cell (:mod:`riverflow.scenes.meshes`).
"""
from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import shapely
import shapely.ops
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import dijkstra
from scipy.spatial import cKDTree

from riverflow._extras import require
from riverflow.gis.rivers import (DEFAULT_GEOMETRY, HydraulicGeometry, ImportedLink,
                                  RiverImport, _from_wkb, _hstore, _is_osm, _move_to_origin,
                                  _osm_waterways, _pick_layer, _project, _read_raw, _wkt)
from riverflow.hydro.builder import MAX_TURN_DEG, RiverNetworkBuilder, upstream_first
from riverflow.hydro.graph import GraphError

RASTER_SUFFIXES = (".tif", ".tiff", ".vrt", ".img", ".asc")
"""Suffixes read as water masks (rasterio); anything else as polygons (pyogrio)."""
IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".bmp", ".gif")
"""Pictures a water mask may be drawn in, refused with the way to georeference them."""
VECTOR_SUFFIXES = (".shp", ".gpkg", ".geojson", ".json", ".osm", ".pbf")
DEFAULT_SIMPLIFY_M = 0.02
"""How far [m] a polygon's outline may move when simplified, by default. A simplified chord
of a bank curving with radius R turns off it by √(2·tol/R): at 0.25 m it made a 450 m bend's
flow cross the polygon by 3 % of its speed 1 m in (issue 22's ≤ 2 %); 0.02 m takes out
collinear vertices and keeps that under 1 %."""
OSM_WATER = ("river", "canal", "lake", "reservoir", "pond", "oxbow", "stream", "riverbank")
"""``water=`` values of OSM ``natural=water`` areas that are read (and ``waterway=riverbank``)."""
LAKE_WATER = ("lake", "reservoir", "pond", "oxbow")
"""``water=`` values (an OSM tag, or a polygon file's ``water`` attribute) read as lakes: flat
water bodies (:meth:`~riverflow.RiverNetworkBuilder.add_lake`). An OSM ``natural=water``
area without ``water=`` is a lake too (the tag's documented default, OSM wiki Key:water); a
polygon file's feature without the attribute is a river's water."""
NHD_LAKE_FTYPES = ("lakepond", "reservoir", "swampmarsh", "playa", "390", "436", "466", "361")
"""The USGS National Hydrography Dataset's ``FTYPE`` of standing water (NHDWaterbody:
LakePond 390, Reservoir 436, SwampMarsh 466, Playa 361; NHDPlus writes the names, NHD HR the
codes): a polygon file's feature with one of them is a lake, as ``water=lake`` is; NHDArea's
StreamRiver (460), CanalDitch (336), … are a river's water."""
LAKE_FLAG = "_riverflow_lake"
"""The attribute :func:`_read_polygons` sets on the features tagged as lakes."""
SPUR_WIDTHS = 1.0
"""Skeleton spurs shorter than this many local widths (2 × the inscribed radius where they
branch off) are pruned."""
RESTORED_END_RADII = 0.3
"""Where pruning left a skeleton no free end (:func:`_restore_ends`), a pruned branch given
back as an end of the water ends in an inscribed circle at least this share of the one where
it leaves the skeleton: a river's end cut square across parts there into its corners (its
circle as wide as the river, 0.45 of the junction's it leaves by an island); a spur into a
corner of the outline (a square moat's round its island, 0.18) narrows to nothing, and is no
end: the ring is still water. (With one free end left, a narrow one may be the other: a
channel ending on an oblique cut of the data between two islands it cuts open parts into
the cut's acute corners.)"""
JOIN_WIDTHS = 1.0
"""Skeleton junctions closer than this × the sum of their inscribed radii are one junction
(the builder's junctions must lie farther apart than half their widths' sum, and a channel's
width at a junction is at most twice its inscribed radius there; merged at 5 % more, two
forks 178 m apart became one and the second one's channels ran side by side from it)."""
ISLAND_SPLIT_WIDTHS = 2.0
"""A hole longer (2 × its bounding radius) than this many times the water beside it splits
the river into two channels; a smaller one is a free island in its channel."""
MAX_ISLAND_RETRIES = 20
"""How many islands between channels :meth:`WaterBuilder.build` may turn into free islands
when no channel's banks reach their shores."""
MIN_CHANNEL_WIDTHS = 2.0
"""A separate water body whose longest path along its axes is shorter than this many widths
is no river (a pond, a speck left by a repair): left out, reported."""
MASK_SMOOTH_CELLS = 1.5
"""A mask's outline is averaged over this many cells (:func:`_smooth_cells`)."""
SPECK_FRACTION = 1e-3
"""A separate water body with less than this fraction of all the water is a speck (a piece a
repair left): left out, reported."""
SAMPLES_PER_WIDTH = 8.0
"""Outline points per narrowest channel width for the skeleton's Voronoi diagram."""
MAX_OUTLINE_SAMPLES = 200_000
NARROW_SAMPLES = 4.0
"""Where the water is narrower than this many outline points' spacings, the skeleton's
points are put closer (:func:`_narrow_samples`; islands' passages: the spacing of the whole)."""
NARROW_AREA = 8.0
"""...in pieces of water at least this many squared half widths of that (not a corner the
opening rounds off, nor a notch)."""
OPEN_EDGE_WIDTHS = 0.25
"""A piece of the water's outline along the data's extent at least this many mean widths
long is an open end (the water cut by the map's edge), not a bank."""
SEA_WIDTHS = 8.0
"""Water is open water (a sea, a lake the data's edge cuts) where circles of this many times
the channels' wide width fit in it (the upper quartile of its inscribed circles' local
maxima) and at least half as wide as the widest, that reach the data's edge, grown by the
circles of this many times their median width that fit in the water."""
SEA_GRID = 768
"""The most cells along the water's longer side on which open water is looked for."""
SEA_CUT_RADII = 0.5
"""Open water reaches the data's edge where its outline runs along that edge in one piece
at least this many times its widest inscribed radius long: the edge cuts across it (a sea,
a lake the map's border cuts; a bay cut by the data's edge: its width). A round reservoir
on a river that only touches the water's bounding box, whose outline leaves the box at once
(a tangent circle's contact, within the tolerance, is 0.1 – 0.2 of its radius; 0.28 in a
mask of 4 m cells, 300 m across), is a lake inside the data, the river running through it."""
OVERHANG_WIDTHS = 0.04
"""An edge of the outline at most this many widths of its channel long that faces away from
the channel's axis (the far side of an island's round end where it crosses a bank, leaning
over the water) loses a vertex, moving the outline by at most a quarter as much."""
OVERHANG_MARGIN = math.sin(math.radians(20.0))
"""Within OVERHANG_WIDTHS of such an edge, an edge faces away unless the axis lies at least
20° to its left (the builder reads the axis piece by piece: beside a piece's end its nearest
point lies farther back)."""

MAX_KNOTS = 4
"""How many knots of the skeleton :meth:`WaterBuilder.build` makes lakes of, at most, where
every reading fails (each at the place the first reading failed at; a knot costs every
reading once more: Colville's delta, which 16 knots did not build, took 650 s of CPU to its
error, 60 s without knots)."""
KNOT_SHARE = 0.5
"""…and no more than this share of the rivers' water in all (a reading more lake than river
is no reading of the river: an error says so)."""
KNOT_GROW = 1.5
"""A knot's lake is the water within this many inscribed radii of the axis nearest the
failure (and of the failure's place) and of the skeleton junctions whose inscribed circles
reach that water."""


RETRIED = {"short_reaches_join": "with no short reach joining its ends",
           "ends_beside": "with no dead end kept as part of the water's ends",
           "backwaters": "with no backwater behind a spit",
           "free_by_ends": "with every reading back and the islands beside free ends "
                           "that do not reach across the water made free",
           "lines": "with the water's skeleton for its axes, the lines giving where it "
                    "enters and leaves"}
"""How :meth:`WaterBuilder.build` reads the water again after a failure, as its error
says."""


class WaterBuilder(RiverNetworkBuilder):
    """The :class:`~riverflow.RiverNetworkBuilder` :func:`read_water` returns: ``report`` (a
    :class:`~riverflow.gis.rivers.RiverImport`), ``water`` (the water polygons read, [m]),
    ``crs``; ``build()`` errors name the file."""

    report: RiverImport
    water: shapely.Geometry
    short_reaches_join = True
    one_stream = False
    seas: list = []
    """The open water found (:func:`_seas`): polygons [m], lakes the channels leave into."""
    ends_beside = True
    kept_beside = False
    backwaters = True
    free_by_ends = False
    """Whether an island beside a channel's free end that does not reach across the water
    is made free (:meth:`build`'s last reading)."""
    outlet_lines: list = []
    """The outlets given as lines [m] (a coastline, a dam): every free end of the water within
    its channel's width of one is an outlet."""
    by_line_ends = None
    """(starts (N, 2), ends (M, 2)) [m]: where the lines given enter and leave the water,
    once the lines do not make a network there and the water's skeleton gives its axes
    (:meth:`_read_by_line_ends`): inlets and outlets at the free ends they lie at."""
    _by_skeleton = None
    _knot_state = None
    """(the rivers' water, the lakes, the data's extent or None) the readings fill from:
    read_water's, less the knots made lakes (:func:`_knot_lake`)."""
    _knot_lakes: list = []
    """The lakes made of knots (polygons [m]) that joined no other lake."""
    _roles: list = []
    """[(point (2,) [m], "in" | "out", width [m])]: the ways water ran at the free ends and
    across the knots' shores in the readings the knots were made from."""
    _knot_repairs: list = []
    _knot_seeds: list = []
    """[(the water made lake, its reach [m])] of every knot made."""

    @property
    def derived(self) -> dict[str, Any]:
        return self.report.derived

    def build(self):
        """Make the hydro graph (``graph.source``: the file); errors name the file. Where
        that fails after a reach shorter than its junction is wide joined its ends (a
        channel's end where the data's edge cuts the water just past an island), the
        channels are found again and built with those ends taken as missing their junction
        (the island there made free); where it fails after a dead end was kept as part of
        one of the water's ends (:func:`_end_beside`), again with such dead ends taken as
        basins; then again without backwaters behind spits (the dropped dead ends' pockets,
        :func:`riverflow.hydro._basins.find_basins`' ``dead``), each after the last. Where
        all that fails and a channel's free end did not reach across the water, last with
        every reading back and the island beside such an end made free (``free_by_ends``:
        the channels on either side of an island just inside the data's edge run out to it
        apart, with no junction between them). Where every reading fails, the water round
        the place the first one failed at is made a lake and the water read again, up to
        MAX_KNOTS times (:meth:`_knots_made_lakes`)."""
        self._repairs_read = [r for r in self.report.repairs if not r.feature.startswith("knot ")]
        try:
            graph = self._readings()
        except GraphError as exc:
            graph = self._knots_made_lakes(exc)
        graph.source = self.report.path
        cut = sum(self.end_cuts_m2)
        if cut > 0:
            self.report.derived["ends_cut_m2"] = round(cut, 2)
        if self.islands_cut:
            self.report.notes.append(f"{len(self.islands_cut)} islands at the water's open "
                                     f"ends, where it is cut across, left out")
        return graph

    def _readings(self):
        """The graph of the water as read, else of each other reading (:meth:`build`); the
        first reading's failure and the builder's branches and networks then are kept in
        ``_first_failure`` (where :meth:`_knots_made_lakes` looks for the knot)."""
        # the islands read_water already made free stay free (else the loops they broke
        # come back and take the retries)
        forced: list[tuple[float, float]] = list(getattr(self, "_forced", ()))
        repairs = list(self.report.repairs)
        self.short_reach_joined = False
        try:
            graph = self._build_retrying(list(forced))
        except GraphError as exc:
            self._first_failure = (str(exc), list(self._branches),
                                   list(getattr(self, "_networks", [])))
            graph, first, last, seen, tried = None, exc, None, [str(exc)], []
            # again without a reading that may have failed it (then without the next too):
            # short reaches joined, dead ends kept as parts of the water's ends, backwaters
            # behind spits (their basins); last, every reading back and the islands beside
            # ends that do not reach across the water made free
            for flag, used in (("short_reaches_join", "short_reach_joined"),
                               ("ends_beside", "kept_beside"), ("backwaters", "basin_axes"),
                               ("free_by_ends", None)):
                if used is None:
                    if not any("does not reach across" in t for t in seen):
                        continue
                    self.short_reaches_join = self.ends_beside = self.backwaters = True
                    self.free_by_ends = True
                elif not getattr(self, used):
                    continue
                else:
                    setattr(self, flag, False)
                tried.append(RETRIED[flag])
                self.report.repairs[:] = repairs
                try:
                    try:
                        self._refill(list(forced))
                    except GraphError as again:
                        self._raise_named(again)
                    graph = self._build_retrying(list(forced))
                    break
                except GraphError as again:
                    seen.append(str(again))
                    last = again
            if graph is None and self._by_skeleton is not None:
                tried.append(RETRIED["lines"])
                self.short_reaches_join = self.ends_beside = self.backwaters = True
                self.free_by_ends = False
                try:
                    self._read_by_line_ends(first)
                    return self._readings()
                except GraphError as again:
                    last = again
            if graph is None:
                raise self._failed(first, tried, last) from None
        finally:
            self.short_reaches_join = self.ends_beside = self.backwaters = True
            self.free_by_ends = False
        return graph

    def _knots_made_lakes(self, failed: GraphError):
        """Where every reading fails (``failed``), the water round the place the first
        reading failed at (a knot of the skeleton the builder cannot make into channels) is
        made a lake (:func:`_knot_lake`) and the water read again; up to MAX_KNOTS times,
        each knot reported. Raises ``failed`` where no knot is found (its error names no
        place), else an error naming the knots made and the last reading's failure."""
        state = getattr(self, "_knot_state", None)
        made: list[str] = []
        last = failed
        whole = state[0].area if state is not None and state[0] is not None else 0.0
        still = 0.0
        while state is not None and len(made) < MAX_KNOTS:
            text, branches, networks = self._first_failure
            named = f"{self.report.path} (layer {self.report.layer!r}): "
            text = text[len(named):] if text.startswith(named) else text
            seeds = _knot_seeds(text, branches)
            knot = _knot_lake(self, seeds, networks) if seeds else None
            if knot is None:
                break
            knot, joined = knot
            x, y = seeds[0]
            still += knot.area
            if still > KNOT_SHARE * whole:
                refused = (f"the water round the knot near ({x:.1f}, {y:.1f}) made a lake "
                           f"would leave {100.0 * still / whole:.0f} % of the rivers' water "
                           f"still (more than {100.0 * KNOT_SHARE:.0f} %): not made")
                if not made:
                    raise GraphError(f"{failed}; {refused}") from None
                last = GraphError(f"{refused}; {text}")
                break
            made.append(f"({x:.1f}, {y:.1f})")
            islands = sum(len(p.interiors) for p in shapely.get_parts(knot))
            self._knot_repairs.append((f"knot {len(made)}", (
                f"{knot.area:.1f} m² of water round ({x:.1f}, {y:.1f}), {islands} islands in "
                f"it, where its skeleton could not be made into channels ({text[:160]}"
                f"{'…' if len(text) > 160 else ''}): a lake (still water, slow: the potential "
                f"flow from its inlets to its outlets)" + (f", {joined}" if joined else ""))))
            self.report.repairs[:] = self._repairs_read
            for where, what in self._knot_repairs:
                self.report.repair(where, None, None, what)
            try:
                try:
                    self._refill(list(getattr(self, "_forced", ())))
                except GraphError as again:
                    self._first_failure = (str(again), list(self._branches),
                                           list(getattr(self, "_networks", [])))
                    self._raise_named(again)
                graph = self._readings()
            except GraphError as again:
                last = again
                continue
            self.report.derived["knots"] = (
                f"{len(made)} (water round a knot of the skeleton the builder could not "
                f"make into channels, every reading failing there): lakes")
            return graph
        if not made:
            raise failed
        named = f"{self.report.path} (layer {self.report.layer!r}): "
        again = str(last)
        again = again[len(named):] if again.startswith(named) else again
        raise GraphError(f"{failed}; read again with the water round {len(made)} knots of its "
                         f"skeleton made lakes (near {', '.join(made)}), it failed there too: "
                         f"{again}") from None

    def _read_by_line_ends(self, failed: GraphError) -> None:
        """Find the channels again along the water's skeleton, the lines given only saying
        where the water enters and leaves (:attr:`by_line_ends`): where the lines do not
        make a network of the water (München's Isar: two lines either side of an island
        that meet at neither end, one starting in the water beside the other), which the
        skeleton does, the lines still know which way it flows (its skeleton's narrower end
        was its wider, and the Isar ran south). Reported."""
        fill, ends = self._by_skeleton
        self._by_skeleton, self.by_line_ends = None, ends()
        self._fill, self._forced = fill, []
        starts, stops = self.by_line_ends
        named = f"{self.report.path} (layer {self.report.layer!r}): "
        text = str(failed)
        self.report.repair("lines", None, None,
                           f"the lines do not make a network of the water "
                           f"({text[len(named):] if text.startswith(named) else text}): its "
                           f"axes are its skeleton, the lines giving where it enters "
                           f"({len(starts)}) and leaves ({len(stops)}) it")
        self._refill(self._forced)

    def _build_retrying(self, forced: list):
        """Build; while it fails at an island (named, or nearest a branch named), make that
        island free (``forced``) and find the channels again."""
        for _ in range(MAX_ISLAND_RETRIES + 1):
            try:
                graph = super().build()
                break
            except GraphError as exc:
                point = _shore_point(str(exc))
                hole = self._hole_at(point) if point is not None else self._hole_by(str(exc))
                # (an island already free that the error names again: no other to try)
                if hole is None or hole in forced or len(forced) >= MAX_ISLAND_RETRIES:
                    self._raise_named(exc)
                forced.append(hole)
                self.report.repair("island", None, None,
                                   f"the island near ({hole[0]:.1f}, {hole[1]:.1f}) between "
                                   f"channels cannot be told from the other shores there "
                                   f"({str(exc)[:100]}…): taken as a free island in one "
                                   f"channel")
                try:
                    self._refill(forced)
                except GraphError as again:
                    self._raise_named(again)
        return graph

    def _refill(self, forced: list) -> None:
        """Find the channels again with the holes at ``forced`` free islands; while their axes
        flow round a loop, the island nearest the loop is made free too."""
        while True:
            try:
                self._fill(tuple(forced))
                return
            except GraphError as exc:
                hole = _hole_in_loop(self, str(exc))
                if hole is None or len(forced) >= MAX_ISLAND_RETRIES:
                    raise
                forced.append(hole)
                self.report.repair("island", None, None,
                                   f"the island near ({hole[0]:.1f}, {hole[1]:.1f}) between "
                                   f"channels leaves its axes flowing round a loop: taken as "
                                   f"a free island in one channel")

    def _hole_at(self, point):
        """A point inside the hole of the water that holds ``point`` or whose ring passes
        within a metre of it (the builder names a shore by its vertices' mean), or None."""
        p = shapely.Point(point)
        for poly in getattr(self.water, "geoms", [self.water]):
            for ring in poly.interiors:
                if ring.distance(p) <= 1.0 or shapely.Polygon(ring).contains(p):
                    return shapely.Polygon(ring).representative_point().coords[0]
        return None

    def _hole_by(self, text: str):
        """For an error naming a branch whose banks the builder could not tell apart (its
        ψ does not add up round a loop, both its banks one shore, their ψ difference not its
        discharge, no banks found across it), or branches that do not meet, one that
        starts and ends at one point, or a junction that only sends or only takes water (the
        axes round an island near where the water is cut meet too close to its end, or on
        it, for a channel between), or with ``free_by_ends`` a branch whose free end does
        not reach across the water: a point inside the hole
        between channels nearest that branch's middle, or None."""
        import re

        m = (re.search(r"branches \['([^']+)'.*all (?:start|end) there", text)
             or re.search(r"branch(?:es)? '([^']+)'", text))
        k = re.search(r"branch (\d+): (?:ψ\(right\) − ψ\(left\)|no banks found)", text)
        if k is not None and int(k.group(1)) < len(self._branches):
            branch = self._branches[int(k.group(1))]     # its banks not found, or wrong
        elif m is None or ("inconsistent" not in text and "one continuous shore" not in text
                           and "do not meet" not in text and "the same point" not in text
                           and " there but none " not in text
                           and not (self.free_by_ends and "does not reach across" in text)):
            return None
        else:
            branch = next((b for b in self._branches if b.name == m.group(1)), None)
        holes = [shapely.Polygon(r) for poly in getattr(self.water, "geoms", [self.water])
                 for r in poly.interiors]
        free = [i.outline for i in self._islands]
        holes = [h for h in holes if not any(h.contains(f.representative_point()) for f in free)]
        if branch is None or not holes:
            return None
        line = shapely.LineString(branch.centerline_m)
        mid = line.interpolate(0.5, normalized=True)
        best = min(holes, key=lambda h: (h.distance(line), h.distance(mid)))
        if k is None and best.distance(line) > float(branch.widths_m.max()):
            return None      # (a branch whose banks are wrong: its ψ comes from the islands)
        return best.representative_point().coords[0]

    def _failed(self, first: GraphError, tried: list[str], last: GraphError | None
                ) -> GraphError:
        """The error of a build that failed as read and again each way in ``tried``: the
        first failure's (the water as read), then how it was read again and the last
        reading's own failure (``last``; not told where it is the first's)."""
        if not tried:
            return first
        named = f"{self.report.path} (layer {self.report.layer!r}): "
        again = str(last) if last is not None else ""
        again = again[len(named):] if again.startswith(named) else again
        told = f": {again}" if again and again != str(first)[len(named):] else ""
        ways = "; then ".join(t if i == 0 or t.startswith("with every") else f"also {t}"
                              for i, t in enumerate(tried))
        return GraphError(f"{first}; read again {ways}, it failed there too{told}")

    def _raise_named(self, exc: GraphError):
        hint = ""
        if "lies on its right" in str(exc):
            hint = (" (the outline has a bay or a point of land whose far side faces away "
                    "from its channel's axis, which the flow cannot follow yet: pass "
                    "lines= that run into the bay, or smooth the outline there)")
        raise GraphError(f"{self.report.path} (layer {self.report.layer!r}): {exc}{hint}"
                         ) from None


def _knot_seeds(text: str, branches: list) -> list[tuple[float, float]]:
    """The place a reading's error names (the builder's ``text``, ``branches`` the builder's
    then): its first point "(x, y)"; else the nearest ends of two branches that "do not
    meet"; else the middle of the first branch it names (by name, or "branch k:"); else
    none."""
    import re

    m = re.search(r"\((-?[0-9]+(?:\.[0-9]*)?), (-?[0-9]+(?:\.[0-9]*)?)\)", text)
    if m:
        return [(float(m.group(1)), float(m.group(2)))]
    by = {b.name: b for b in branches}
    two = re.search(r"branches '([^']+)' and '([^']+)' do not meet", text)
    if two and two.group(1) in by and two.group(2) in by:
        a, b = (by[two.group(k)].centerline_m for k in (1, 2))
        pa, pb = min(((p, q) for p in (a[0], a[-1]) for q in (b[0], b[-1])),
                     key=lambda pq: float(np.hypot(*(pq[0] - pq[1]))))
        return [tuple(map(float, pa)), tuple(map(float, pb))]
    k = re.search(r"branch (\d+): ", text)
    branch = (branches[int(k.group(1))] if k and int(k.group(1)) < len(branches) else
              next((by[n] for n in re.findall(r"'([^']+)'", text) if n in by), None))
    if branch is None:
        return []
    mid = shapely.LineString(branch.centerline_m).interpolate(0.5, normalized=True)
    return [mid.coords[0]]


def _knot_lake(builder: WaterBuilder, seeds: list, networks: list):
    """Make the water round ``seeds`` (a reading's failure, :func:`_knot_seeds`) a lake of
    the builder's next readings (its ``_knot_state``: the rivers' water, the lakes, the
    data's extent): the water within KNOT_GROW inscribed radii of the seeds, of the axis
    nearest each and of the skeleton junctions (of ``networks``, the failed reading's) whose
    inscribed circles reach it; with the pieces of water it cuts off that hold no free end
    of those networks (a pocket, a loop of channels back into it), its mouths straight
    (:func:`_straight_mouths`), joined to a lake it touches. The ways the failed reading's
    channels crossed its shore (into it: the end there an outlet; out of it: an inlet) and
    its free ends' ways are kept for the next readings (``_roles``: :func:`_find_networks`).
    Returns (the water made lake, how it joined a lake it touches or ""), None where no
    water lies there."""
    rivers, lakes, extent = builder._knot_state
    if rivers is None:
        return None
    tol = builder.tolerance_m
    chans = [c for net in networks for c in net.channels]
    if not chans:
        return None
    lines = [shapely.LineString(c.points) for c in chans]
    deg_of = {id(net): net.degree() for net in networks}
    junctions = []      # (point, inscribed radius) of every junction of the skeleton
    for net in networks:
        deg = deg_of[id(net)]
        radius = {}
        for c in net.channels:
            for j, w in ((c.a, c.widths[0]), (c.b, c.widths[-1])):
                if deg[j] >= 3:
                    radius[j] = max(radius.get(j, 0.0), 0.5 * float(w))
        junctions += [(net.nodes[j], radius[j]) for j in sorted(radius)]
    discs, centres, grow = [], [], KNOT_GROW
    for sx, sy in seeds:
        pt = shapely.Point(sx, sy)
        i = int(np.argmin([ln.distance(pt) for ln in lines]))
        c, ln = chans[i], lines[i]
        at = ln.project(pt)
        s = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(c.points, axis=0).T))])
        r = 0.5 * float(np.interp(at, s, c.widths))
        # (the junctions near the place: their water is the knot's scale)
        for q, rj in junctions:
            if np.hypot(sx - q[0], sy - q[1]) <= 2.0 * KNOT_GROW * rj:
                r = max(r, rj)
        # (a knot again at the lake of one made before: grown each time; its failure walked
        # along the shore when it was not)
        again = sum(lake.distance(pt) <= KNOT_GROW * max(r, reach)
                    for lake, reach in builder._knot_seeds)
        grow = max(grow, KNOT_GROW * 1.5 ** again)
        near = ln.interpolate(at)
        discs += [pt.buffer(grow * r), near.buffer(grow * r)]
        centres.append(near)
    core = shapely.union_all(discs).convex_hull
    region = [core]
    for q, rj in junctions:
        node = shapely.Point(q)
        if core.distance(node) <= rj:
            region.append(node.buffer(grow * rj))
            centres.append(node)
    region = shapely.union_all(region)
    parts = [p for p in shapely.get_parts(shapely.intersection(rivers, region))
             if p.geom_type == "Polygon" and (p.intersects(core)
                                              or any(p.distance(q) <= tol for q in centres))]
    if not parts:
        return None
    knot = shapely.union_all(parts)
    # the pieces it cuts off with no way in or out but the knot: the lake's
    ends = [shapely.Point(net.nodes[n]) for net in networks for _, n, _ in net.free_ends()]
    rest = shapely.difference(rivers, knot)
    pockets = [q for q in shapely.get_parts(rest) if q.geom_type == "Polygon"
               and q.distance(knot) <= tol
               and not any(q.distance(e) <= max(4.0 * tol, 1e-3 * math.sqrt(q.area))
                           for e in ends)]
    if pockets:
        knot = shapely.union_all([knot, *pockets])
        rest = shapely.difference(rivers, knot)
    new = []
    for piece in shapely.get_parts(knot):
        if piece.geom_type != "Polygon" or not piece.area > (4.0 * tol) ** 2:
            continue
        piece, rest = _straight_mouths(piece, rest, tol)
        if piece.area > (4.0 * tol) ** 2:
            new.append(piece)
    if not new:
        return None
    builder._knot_seeds.append((shapely.union_all(new), grow * r))
    lake_area = shapely.union_all(new)
    rivers = shapely.difference(rivers, lake_area)
    rivers = shapely.union_all([p for p in shapely.get_parts(rivers) if p.geom_type == "Polygon"
                                and p.area > (4.0 * tol) ** 2])
    if rivers.is_empty:
        return None         # (no river left: the knot is all of it)
    lakes = list(lakes)
    seas = list(builder.seas)
    made, joined = [], ""
    for piece in new:
        touching = [lk for lk in lakes if lk.distance(piece) <= tol]
        if touching:
            joined = ("joined to the open water beside it"
                      if any(any(lk is sk for sk in seas) for lk in touching)
                      else "joined to the lake beside it")
        whole = shapely.union_all([piece, *touching])
        if whole.geom_type != "Polygon":
            whole = max((p for p in shapely.get_parts(whole.buffer(tol).buffer(-tol))
                         if p.geom_type == "Polygon"), key=lambda p: p.area)
        whole = shapely.make_valid(whole)
        if whole.geom_type != "Polygon":
            whole = max((p for p in shapely.get_parts(whole) if p.geom_type == "Polygon"),
                        key=lambda p: p.area)
        sea = any(any(lk is sk for sk in seas) for lk in touching)
        lakes = [lk for lk in lakes if not any(lk is t for t in touching)] + [whole]
        seas = [sk for sk in seas if not any(sk is t for t in touching)] + ([whole] if sea else [])
        builder._knot_lakes = [k for k in builder._knot_lakes
                               if not any(k is t for t in touching)] + ([] if sea else [whole])
        made.append(whole)
    if extent is None:
        extent = shapely.box(*builder._knot_state[0].bounds)
    extent = shapely.union_all([p for p in shapely.get_parts(shapely.difference(
        extent, lake_area)) if p.geom_type == "Polygon"])
    builder._knot_state = (rivers, lakes, extent)
    builder.seas = seas
    # the ways the channels crossed its shore, and the free ends' ways
    roles = []
    shore = shapely.union_all([m.boundary for m in made])
    inside = shapely.union_all(made)
    shapely.prepare(inside)
    for net in networks:
        if not all(c.directed for c in net.channels):
            continue        # (a reading that failed before its water was oriented)
        deg = net.degree()
        for c in net.channels:
            w = c.width
            for n, role in ((c.a, "in"), (c.b, "out")):
                if deg[n] == 1:
                    roles.append((net.nodes[n], role, w))
            line = shapely.LineString(c.points)
            for q in shapely.get_coordinates(shapely.intersection(line, shore)):
                at = line.project(shapely.Point(q))
                before = line.interpolate(max(at - 0.25 * w, 0.0))
                after = line.interpolate(min(at + 0.25 * w, line.length))
                into, out_of = inside.contains(after), inside.contains(before)
                if into != out_of:
                    roles.append((q, "out" if into else "in", w))
    # (one reading's ways, all of them: ways kept from readings before it, mixed with its
    # own, let water run round a loop through the lakes)
    builder._roles = roles if roles else builder._roles
    return lake_area, joined


def _shore_point(text: str):
    """The point of the builder's "a shore near (x, y) that no branch runs along" error."""
    import re

    m = re.search(r"a shore near \(([-0-9.]+), ([-0-9.]+)\) that no branch runs along", text)
    return (float(m.group(1)), float(m.group(2))) if m else None


def is_water_path(path) -> bool:
    """True for a path :func:`read_water` reads by its suffix (polygon files and rasters)."""
    return isinstance(path, (str, Path)) and Path(path).suffix.lower() in (
        RASTER_SUFFIXES + VECTOR_SUFFIXES)


def holds_water_areas(path, layer=None) -> bool:
    """True when :func:`read_water` is the reader of ``path``: a raster, or a vector file
    whose layer (``layer``, else the first polygon layer if it has no line layer) holds
    polygons. OpenStreetMap files are read as lines (:func:`~riverflow.read_rivers`) unless
    ``layer`` is ``"multipolygons"``."""
    if not isinstance(path, (str, Path)):
        return False
    path = Path(path)
    if is_raster_path(path) or path.suffix.lower() in IMAGE_SUFFIXES:
        return True         # (a picture: read_water says how to make it a mask)
    if path.suffix.lower() not in VECTOR_SUFFIXES or not path.exists():
        return False
    if _is_osm(path):
        return layer == "multipolygons"
    try:
        import pyogrio
        layers = [(str(n), str(t).lower()) for n, t in pyogrio.list_layers(str(path))]
    except Exception:   # unreadable or no pyogrio: the line reader says why
        return False
    if layer is not None:
        chosen = [t for n, t in layers if n == str(layer)] or (
            [layers[layer][1]] if isinstance(layer, int) and 0 <= layer < len(layers) else [])
        return bool(chosen) and "polygon" in chosen[0]
    if any("line" in t for _, t in layers):
        return False
    return any("polygon" in t for _, t in layers)


def is_raster_path(path) -> bool:
    return isinstance(path, (str, Path)) and Path(path).suffix.lower() in RASTER_SUFFIXES


def _xy_text(point) -> str:
    return f"({float(point[0]):.1f}, {float(point[1]):.1f})"


def read_water(path, *, layer: str | int | None = None, lines=None, inlets=None, outlets=None,
               dem=None, discharge_m3s: float | None = None, crs=None, origin_m="auto",
               simplify_m: float | None = None, tolerance_m: float = 0.25,
               geometry: HydraulicGeometry = DEFAULT_GEOMETRY) -> WaterBuilder:
    """Water polygons or a water mask as a filled river-network builder (module docstring).

    Args:
        path: polygons (``.shp``, ``.gpkg``, ``.geojson``, ``.json``, OSM ``.osm`` /
            ``.osm.pbf``: ``natural=water`` areas, ``waterway=riverbank``) or a raster mask
            (``.tif``, ``.tiff``, ``.vrt``, ``.img``, ``.asc``: a cell > 0 is water).
        layer: the polygon layer (name or index; default: the first polygon layer; OSM:
            ``multipolygons``).
        lines: the waterway lines (drawn downstream) that give the channels' axes: a file,
            or the name of a layer of ``path`` (OSM: ``"lines"``, its ``waterway=`` ways).
        inlets, outlets: points (x, y) where water enters / leaves, in the data's CRS (as in
            the file, or ``crs``); each is matched to the nearest free end of the water.
            ``outlets`` may also hold lines where water leaves (a coastline, a dam): shapely
            lines in the data's CRS, or GIS files of lines (a path, in their own CRS); every
            free end of the water within its channel's width of one is an outlet.
        dem: an elevation raster: water runs from the highest free end to the lowest.
        discharge_m3s: total volume discharge [m³/s] entering at the sources (default: each
            source's from its width by ``geometry``).
        crs: the data's CRS when the file has none or a wrong one.
        origin_m: as :func:`~riverflow.read_rivers`.
        simplify_m: how far the outline may move when simplified [m] (default
            DEFAULT_SIMPLIFY_M, 0.02 m; half a cell for a mask).
        tolerance_m: the builder's tolerance [m].
        geometry: hydraulic-geometry laws for discharges from widths.

    Raises:
        FileNotFoundError: no such file.
        GraphError: unreadable file, no polygon with an area, a mask with no water, an inlet
            or outlet far from every free end of the water, a network that cannot be built.
        ImportError: the ``gis`` extra is not installed.
    """
    inlet_xy = _points(inlets, "inlets")
    outlet_xy, outlet_lines, outlet_files = _outlets(outlets)
    if discharge_m3s is not None and not (isinstance(discharge_m3s, (int, float))
                                          and math.isfinite(discharge_m3s) and discharge_m3s > 0):
        raise GraphError(f"read_water: discharge_m3s must be a positive number, got "
                         f"{discharge_m3s!r}")
    if simplify_m is not None and not (math.isfinite(simplify_m) and simplify_m >= 0):
        raise GraphError(f"read_water: simplify_m must be a number ≥ 0, got {simplify_m!r}")
    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(f"GIS file not found: {path}")
    if path.is_file() and path.stat().st_size == 0:
        raise GraphError(f"{path}: the file is empty")
    if path.suffix.lower() in IMAGE_SUFFIXES:
        raise GraphError(f"{path}: a {path.suffix} picture says nothing of where its cells lie "
                         f"or how large they are: write the water mask as a GeoTIFF with its "
                         f"transform and CRS (rasterio: driver='GTiff', transform=, crs=), "
                         f"cells > 0 water")
    if is_raster_path(path):
        features, source_crs, layer_name, cell, extent, values = _read_mask(path)
        if simplify_m is None:
            simplify_m = 0.5 * cell
    else:
        features, source_crs, layer_name = _read_polygons(path, layer)
        cell = extent = values = None
        if simplify_m is None:
            simplify_m = DEFAULT_SIMPLIFY_M
    where = f"{path} (layer {layer_name!r})"
    if crs is not None:
        source_crs = crs
    report = RiverImport(str(path), layer_name, len(features), None, None)
    if values:
        report.notes.append(f"mask: {values}")
    line_geoms = _read_lines(path, lines, source_crs, where) if lines is not None else []
    for f in outlet_files:                  # (in the data's CRS, near its water)
        outlet_lines += _read_lines(path, f, source_crs, where)
    if outlet_lines:
        near = shapely.box(*shapely.bounds(shapely.union_all([g for _, g, _ in features])))
        grow = 0.1 * max(near.bounds[2] - near.bounds[0], near.bounds[3] - near.bounds[1])
        outlet_lines = [g for g in shapely.get_parts(shapely.intersection(
            outlet_lines, near.buffer(grow, join_style="mitre"))) if not g.is_empty
            and g.length > 0]
        if not outlet_lines:
            raise GraphError(f"{where}: the outlet lines given pass nowhere near its water")
    hints = []          # an OSM extract's waterways, for the way its areas flow
    if lines is None and _is_osm(path) and not (len(inlet_xy) or len(outlet_xy)
                                                or outlet_lines):
        try:
            hints = _read_lines(path, "lines", source_crs, where)
        except GraphError:
            hints = []  # (an extract with no waterway line)

    _check_points_crs(source_crs, inlet_xy, np.vstack(
        [outlet_xy, shapely.get_coordinates(outlet_lines).reshape(-1, 2)]), where)
    # project everything at once (one local CRS for polygons, lines and points)
    # the raster's extent (where water touching it is cut by the data's edge) goes with them
    geoms = ([g for _, g, _ in features] + line_geoms + hints + outlet_lines
             + ([extent] if extent is not None else []))
    coords = shapely.get_coordinates(geoms)
    extra = np.vstack([inlet_xy, outlet_xy])
    xy, crs_out, crs_note = _project(np.vstack([coords, extra]), source_crs, where,
                                     [(fid, attrs, len(shapely.get_coordinates(g)))
                                      for fid, g, attrs in features])
    report.source_crs = _wkt(source_crs)
    xy = _move_to_origin(xy, origin_m, crs_out, crs_note, where, report)
    geoms = list(shapely.set_coordinates(np.array(geoms, dtype=object), xy[:len(coords)]))
    inlet_xy = xy[len(coords):len(coords) + len(inlet_xy)]
    outlet_xy = xy[len(coords) + len(inlet_xy):]
    polygons = geoms[:len(features)]
    if extent is not None:
        extent = geoms.pop()
    outlet_lines = geoms[len(geoms) - len(outlet_lines):]
    del geoms[len(geoms) - len(outlet_lines):]
    hints = geoms[len(geoms) - len(hints):]
    line_geoms = geoms[len(features):len(geoms) - len(hints)]

    water = _repair(features, polygons, report, where, simplify_m, tolerance_m)
    report.derived["outline"] = (f"the polygons' rings, simplified by at most {simplify_m:g} m"
                                 + (f" (half of the mask's {cell:g} m cells, its stairs "
                                    f"smoothed over {MASK_SMOOTH_CELLS:g} cells)" if cell else ""))
    lakes, rivers = _lakes_of(features, polygons, water, report, tolerance_m)
    seas = []
    if rivers is not None:
        seas, rivers = _seas(rivers, extent if extent is not None else shapely.box(*water.bounds),
                             cell, report, tolerance_m)
        lakes = lakes + seas
        if seas and len(outlet_xy):     # an outlet in the sea: the sea is the outlet
            sea = shapely.union_all(seas)
            out = shapely.contains_xy(sea, outlet_xy[:, 0], outlet_xy[:, 1])
            if out.any():
                report.notes.append(f"{int(out.sum())} outlets given in open water: its shore "
                                    f"is where the channels leave")
            outlet_xy = outlet_xy[~out]
    builder = WaterBuilder(tolerance_m)
    builder.outlet_lines = outlet_lines
    builder.seas = seas
    builder.report = report
    builder.crs = report.crs
    builder.water = water
    if rivers is None:          # lakes only: still water
        for lake in lakes:
            builder.add_lake(lake)
        return builder
    if lakes:   # the rivers' water is cut open where it meets a lake
        extent = shapely.difference(extent if extent is not None else shapely.box(*water.bounds),
                                    shapely.union_all(lakes))
    # (the water round knots its readings cannot make into channels is made a lake there)
    builder._knot_state = (rivers, lakes, extent)
    builder._knot_lakes, builder._roles, builder._knot_repairs = [], [], []
    builder._knot_seeds = []

    def fill(lines, forced):
        water, lakes_now, extent_now = builder._knot_state
        _fill(builder, water, lines, inlet_xy, outlet_xy, dem, discharge_m3s, geometry,
              tolerance_m, where, forced, extent_now, lakes_now)

    builder._fill = lambda forced: fill(line_geoms, forced)
    if line_geoms:
        builder._by_skeleton = (lambda forced: fill([], forced),
                                lambda: _line_ends(rivers, line_geoms, tolerance_m))
    elif hints:
        builder.by_line_ends = _line_ends(rivers, hints, tolerance_m)
    builder._forced = []
    try:
        try:
            builder._refill(builder._forced)
        except GraphError as exc:
            if builder._by_skeleton is None:
                raise
            try:
                builder._read_by_line_ends(exc)
            except GraphError as again:
                raise GraphError(f"{exc}; read again {RETRIED['lines']}, it failed there "
                                 f"too: {again}") from None
    except GraphError as exc:
        text = str(exc)
        raise (exc if text.startswith(str(path)) else GraphError(f"{where}: {text}")) from None
    return builder


def _hole_in_loop(builder: WaterBuilder, text: str):
    """For _discharges' "channels [...] flow round a loop": a point inside the hole between
    channels nearest those channels (the skeleton round islands close together can leave a
    loop no orientation drains), or None."""
    import re

    if "flow round a loop" not in text:
        return None
    names = set(re.findall(r"'([^']+)'", text))
    for net in getattr(builder, "_networks", []):
        lines = [shapely.LineString(c.points) for c in net.channels if c.name in names]
        holes = [shapely.Polygon(r) for r in net.water.interiors]
        if lines and holes:
            loop = shapely.MultiLineString(lines)
            best = min(holes, key=lambda h: h.distance(loop))
            return best.representative_point().coords[0]
    return None


def _fill(builder: WaterBuilder, water, line_geoms, inlet_xy, outlet_xy, dem, discharge_m3s,
          geometry: HydraulicGeometry, tolerance_m: float, where: str, forced,
          extent=None, lakes=()) -> None:
    """Find the channels of the water and put them into the builder (anew: what it held is
    dropped); holes containing a point of ``forced`` are free islands. ``extent``: the data's
    extent (a raster's; default the water's bounding box), where the water is cut open.
    ``lakes``: the lakes (polygons [m]) the water runs into and out of; a channel that starts
    on a lake's shore takes its discharge from the lake."""
    report = builder.report
    # the notes of the reading, without those of an earlier fill (each fill notes anew)
    if not hasattr(builder, "_read_notes"):
        builder._read_notes = list(report.notes)
    report.notes[:] = builder._read_notes
    builder._branches.clear()
    builder._islands.clear()
    builder._lakes.clear()
    for lake in lakes:
        builder.add_lake(lake)
    # (the lakes made of knots give their channels out the discharges _discharges finds)
    shores = [lk.exterior for lk in lakes if not any(lk is k for k in builder._knot_lakes)]
    shores = shapely.union_all(shores) if shores else None
    report.links.clear()
    report.attributes.clear()
    report.repairs[:] = [r for r in report.repairs if not r.feature.startswith("water body")]
    frame = extent if extent is not None else shapely.box(*water.bounds)
    dead: dict[int, np.ndarray] = {}
    notes, repairs, given = list(report.notes), list(report.repairs), len(builder._lakes)
    for _ in range(2):
        # a skeleton left with one end once its dead ends are basins is made again with
        # their tips not counted as ends (its pruned ends given back, _prune)
        report.notes[:], report.repairs[:] = notes, repairs
        del builder._lakes[given:]
        networks = _find_networks(builder, water, line_geoms, inlet_xy, outlet_xy, dem,
                                  tolerance_m, where, forced, frame, dead, lakes)
        again = {net.part: np.array([p[-1] for p, _ in net.basin_axes])
                 for net in networks if net.part not in dead and net.basin_axes
                 and net.end_groups() < 2}
        if not again:
            break
        dead.update(again)
    for k, tips in sorted(dead.items()):
        x, y = tips[0]
        report.repair(f"water body {k}", None, None,
                      f"its skeleton was left with one end of the water once its dead ends "
                      f"(the first ending near ({x:.1f}, {y:.1f})) were taken as basins: made "
                      f"again with those {len(tips)} dead ends not counted as ends of the "
                      f"water, the ends its pruning took given back")
    for net in list(networks):
        ends = net.free_ends()
        if len(ends) < 2 and (net.hinted or not (net.inlets or net.outlets)):
            # a ring of water round its islands (a moat; Liechtenstein's OSM: a riverbank
            # polygon round an island, cut off from its river), its dead ends basins even
            # with their tips not counted as ends
            _still(builder, getattr(water, "geoms", [water])[net.part], net.part,
                   f"{len(ends)} free ends beside its dead ends")
            networks.remove(net)
    seas = builder.seas
    for net in list(networks):
        ends = {n for _, n, _ in net.free_ends()}
        if seas and ends and ends <= net.outlets and not net.inlets:
            # water that opens only into open water (a lagoon, a creek between two mouths)
            # is the open water's
            _join_open_water(builder, getattr(water, "geoms", [water])[net.part], net.part,
                             "opens only into open water")
            networks.remove(net)
    knots = [lk for lk in lakes if any(lk is k for k in builder._knot_lakes)]
    for net in list(networks):
        # (water whose every way in or out is one lake made of a knot: a channel from it
        # back into it, which no order of the discharges allows, is the lake's)
        ends = net.free_ends()
        if ends and any(all(lk.exterior.distance(shapely.Point(net.nodes[n]))
                            <= max(w, tolerance_m) for _, n, w in ends) for lk in knots):
            _join_open_water(builder, getattr(water, "geoms", [water])[net.part], net.part,
                             "opens only into a lake made of a knot")
            networks.remove(net)
    if not networks and not builder._lakes:
        gone = [r for r in report.repairs if r.feature.startswith("water body")]
        raise GraphError(f"{where}: no water is left to build: its "
                         f"{len(getattr(water, 'geoms', [water]))} pieces were all left out"
                         + (f" ({gone[0].feature}: {gone[0].what}"
                            + (f"; and {len(gone) - 1} more" if len(gone) > 1 else "") + ")"
                            if gone else ""))
    if not networks:                # ponds only: still water
        report.derived["axes"] = {}
        report.derived["length_m"] = 0.0
        return
    # the free ends once the spurs are gone (their nodes are numbered anew)
    elevations = (_dem_elevations(dem, [e for net in networks for e in net.free_ends()],
                                  report, where) if dem is not None else None)
    rules = set()
    for k, net in enumerate(networks):
        rules.add(net.orient(elevations))
    report.derived["direction"] = "; ".join(sorted(rules))
    builder._networks = networks       # (for _hole_in_loop, when _discharges fails)
    builder.basin_axes = ([a for net in networks for a in net.basin_axes]
                          if builder.backwaters else [])
    _discharges(networks, discharge_m3s, geometry, report, knots)
    kept = []
    for k, net in enumerate(networks):
        net.water = _trim_overhangs(net, report, k)
        kept.append(net.water)
        for hole in net.islands:
            builder.add_island(np.asarray(hole.exterior.coords)[:-1])
        deg = net.degree()
        for ch in net.channels:
            # (a channel from a free end on a lake's shore takes the lake's outflow; one from
            # a junction near a shore, the junction's)
            from_lake = (shores is not None and deg[ch.a] == 1
                         and shores.distance(shapely.Point(ch.points[0]))
                         <= 0.5 * float(ch.widths[0]))
            builder.add_branch(ch.points, ch.widths, name=ch.name,
                               discharge_m2s=None if from_lake else ch.discharge_m2s)
            report.links.append(ImportedLink(ch.name, -1, float(np.median(ch.widths)),
                                             ch.discharge_m2s, geometry.volume(ch.discharge_m2s),
                                             "the water's outline", ch.discharge_from, 0.0))
            report.attributes[ch.name] = {}
    builder.set_water_area(kept[0] if len(kept) == 1 else shapely.MultiPolygon(kept))
    report.derived["axes"] = {src: sum(1 for n in networks for c in n.channels if c.source == src)
                              for src in ("lines", "skeleton")
                              if any(c.source == src for n in networks for c in n.channels)}
    report.derived["islands"] = {"free (in one channel)": sum(len(n.islands) for n in networks),
                                 "between channels": sum(len(n.water.interiors) for n in networks)}
    report.derived["length_m"] = round(sum(float(shapely.LineString(c.points).length)
                                           for n in networks for c in n.channels), 1)


def _find_networks(builder: WaterBuilder, water, line_geoms, inlet_xy, outlet_xy, dem,
                   tolerance_m: float, where: str, forced, frame, dead: dict,
                   lakes=()) -> list:
    """The networks of the water's parts (specks left out, ponds made lakes, reported),
    inlets and outlets matched to their free ends, the skeleton's spurs into basins dropped
    (none: ponds only). ``dead``: {part index: (N, 2) tips of dead ends that are basins, not
    counted as the water's ends}; ``lakes``: the lakes given (a piece their cut left beside
    one is no pond)."""
    report = builder.report
    networks = []
    lake_area = shapely.union_all(lakes) if len(lakes) else None
    several = len(getattr(water, "geoms", [])) > 1
    # a body's shape decides whether it is a pond where the data has others beside it, or
    # says nothing of how water runs through it (no inlet, outlet or line given) and is
    # about as wide as long (a lone round lake from a mask is no river 400 m long and 480 m
    # wide; a long river whose skeleton the data's edge broke is no pond)
    shaped = several or not (len(inlet_xy) or len(outlet_xy) or line_geoms
                             or builder.outlet_lines) and _compact(water)
    for k, part in enumerate(getattr(water, "geoms", [water])):
        speck = part.area < SPECK_FRACTION * water.area
        # (a speck is left out or joins open water whatever its channels: none are looked
        # for, a skeleton a speck; a noisy mask has thousands)
        net = _Network(part, [], [], np.zeros((0, 2))) if speck and several else _channels(
            part, k, line_geoms, tolerance_m, report, frame, forced,
            np.vstack([inlet_xy, outlet_xy]), dead.get(k),
            builder.__dict__.setdefault("_collapsed", {}))
        net.part = k
        beside_lake = lake_area is not None and lake_area.distance(part) <= tolerance_m
        if not net.channels and not (speck or beside_lake):
            _still(builder, part, k, "no channel in its skeleton")
            continue
        longest = max((c.length for c in net.channels), default=0.0)
        # (a line's width is its median chord over its middle: the chord of a zigzag's point
        # runs along the water; the skeleton's, its widest inscribed circle)
        widest = max((c.width if c.source == "lines" else float(c.widths.max())
                      for c in net.channels), default=0.0)
        if shaped and net.channels and longest < MIN_CHANNEL_WIDTHS * widest:
            # (a river's channels between its islands and points of land, each short: the
            # river itself was read as a pond)
            longest = net.longest_path()
        if shaped and net.channels and longest < MIN_CHANNEL_WIDTHS * widest and sum(
                frame.boundary.distance(shapely.Point(net.nodes[n])) <= max(4.0 * tolerance_m,
                                                                            0.05 * w)
                for _, n, w in net.free_ends()) >= 2:
            # (a short river the data's edge cuts twice, obliquely, its ends there wide: it
            # runs on beyond both, no pond)
            longest = math.inf
        if not net.channels or several and speck or shaped and (
                longest < MIN_CHANNEL_WIDTHS * widest):
            if _join_open_water(builder, part, k, "beside open water"
                                + (" or a lake made of a knot" if builder._knot_lakes else "")
                                + f", with no path along its channels longer than "
                                f"{MIN_CHANNEL_WIDTHS:g} times its width"):
                continue
            x, y = part.representative_point().coords[0]
            # a pond (not a piece a lake's cut left beside it): still water, as a lake
            pond = not (speck or beside_lake)
            if pond:
                builder.add_lake(part)
            report.repair(f"water body {k}", None, None,
                          f"{part.area:.1f} m² of water near ({x:.1f}, {y:.1f}), apart from the "
                          f"rest: " + (f"a speck (under {SPECK_FRACTION:g} of the water): left "
                                       f"out" if speck else
                                       f"no path along its channels longer than "
                                       f"{MIN_CHANNEL_WIDTHS:g} times its width: "
                                       + ("a pond, read as still water (a lake)"
                                          if pond else "left out")))
            continue
        networks.append(net)
    if not networks:
        return networks
    ends = [e for net in networks for e in net.free_ends()]
    _match_points(ends, inlet_xy, "inlet", where, water, frame=frame)
    _match_points(ends, outlet_xy, "outlet", where, water, frame=frame)
    for line in builder.outlet_lines:
        _match_line(ends, line, where)
    if builder.by_line_ends is not None and not (len(inlet_xy) or len(outlet_xy)
                                                  or builder.outlet_lines):
        # the lines' ends in the water (none far off); an end they both enter and leave by
        # (a stream across a pond) says nothing (:meth:`_Network.orient`: nor do they where
        # they leave a piece no way in or out)
        _match_points(ends, builder.by_line_ends[0], "inlet", where, water, strict=False)
        _match_points(ends, builder.by_line_ends[1], "outlet", where, water, strict=False)
        for net in networks:
            both = net.inlets & net.outlets
            net.inlets -= both
            net.outlets -= both
            net.hinted = bool(net.inlets or net.outlets)
    seas = builder.seas
    seas = shapely.union_all(seas) if seas else None
    if seas is not None:        # the channels opening into open water leave there
        for net, n, w in ends:
            if seas.distance(shapely.Point(net.nodes[n])) <= max(w, tolerance_m):
                net.outlets.add(n)
    if builder._roles:
        # knots made lakes: each free end runs the way the water ran there before (across
        # the knot's shore, or at a free end of the water)
        at = np.array([p for p, _, _ in builder._roles], float).reshape(-1, 2)
        for net, n, w in ends:
            if n in net.inlets or n in net.outlets:
                continue
            d = np.hypot(*(at - net.nodes[n]).T)
            k = int(np.argmin(d))
            _, role, wr = builder._roles[k]
            if d[k] <= max(w, wr):
                (net.inlets if role == "in" else net.outlets).add(n)
                net.knotted = True
    heights = ((lambda xy: _dem_heights(dem, xy, report, where)) if dem is not None else None)
    builder.kept_beside = False
    for net in networks:
        builder.kept_beside |= _drop_basin_spurs(net, frame, tolerance_m, report, heights,
                                                 builder.ends_beside)
        _drop_side_waters(net, frame, tolerance_m, report, builder.ends_beside)
        _drop_stubs(net, report, seas)
        _lead_into_mouths(net, report, seas, tolerance_m)
    return networks


def _compact(poly) -> bool:
    """Whether ``poly``'s smallest rotated rectangle is less than MIN_CHANNEL_WIDTHS times
    as long as it is wide."""
    box = np.asarray(shapely.oriented_envelope(poly).exterior.coords)
    if len(box) < 5:
        return False
    sides = np.hypot(*np.diff(box[:3], axis=0).T)
    return bool(sides.max() < MIN_CHANNEL_WIDTHS * sides.min())


def _still(builder: WaterBuilder, part, k: int, why: str) -> None:
    """Water body ``k`` with no way in or out (``why``) as still water: a lake (reported)."""
    x, y = part.representative_point().coords[0]
    builder.add_lake(part)
    builder.report.repair(f"water body {k}", None, None,
                          f"{part.area:.1f} m² of water near ({x:.1f}, {y:.1f})"
                          + (f", a ring round {len(part.interiors)} islands" if part.interiors
                             else "") + f", {why}: no way in and out, read as still water "
                          "(a lake)")


def _trim_overhangs(net: _Network, report: RiverImport, k: int):
    """The water of ``net`` without the short edges (OVERHANG_WIDTHS) of its outer ring that
    face away from their channel's axis (the axis on their right, which the hydro graph does
    not allow of a bank; an island's shore may): where an island's round end crosses a bank,
    its last edges lean over the water beyond the bank's normal. Within twice OVERHANG_WIDTHS
    of such an edge, while a short edge there faces the axis by less than OVERHANG_MARGIN,
    one of its end vertices is dropped (the one nearer the chord its neighbours make). The
    water is kept as given where that would move its outline by more than a quarter of
    OVERHANG_WIDTHS (a given vertex that far from the new ring) or leave it invalid.
    Reported."""
    from riverflow.hydro.nearest import PolylineIndex

    water = net.water
    lines = [c.points for c in net.channels if len(c.points) >= 2]
    if not lines:
        return water
    widths = np.array([c.width for c in net.channels if len(c.points) >= 2])
    # the axes' segments in one box hierarchy (GEOS's nearest line to a point measured every
    # vertex of London's 14 km axis for each edge asked: 11 s of its build)
    index = PolylineIndex(np.vstack(lines), np.repeat(np.arange(len(lines)),
                                                      [len(p) for p in lines]))

    def facing(v: np.ndarray, at: np.ndarray):
        """For edges ``at`` (from vertex i to i + 1) of ring ``v``: how far the axis lies to
        their left (cross product / edge length / distance: the sine of its angle), their
        lengths and OVERHANG_WIDTHS of their channel's width."""
        a, b = v[at], v[(at + 1) % len(v)]
        mid = 0.5 * (a + b)
        out = index.nearest_segments(mid)
        near = index.segment_line[out.seg]
        tv = out.point - mid                         # from the edge's middle to the axis
        d = b - a
        length = np.hypot(*d.T)
        sine = (d[:, 0] * tv[:, 1] - d[:, 1] * tv[:, 0]) / np.maximum(
            length * np.hypot(*tv.T), 1e-300)
        return sine, length, OVERHANG_WIDTHS * widths[near]

    ring = shapely.geometry.polygon.orient(water, 1.0).exterior     # water on its left
    v = given = np.asarray(ring.coords)[:-1]
    sine, length, limit = facing(v, np.arange(len(v)))
    seed = (sine < 0.0) & (length <= limit)
    if not seed.any():
        return water
    # the edges round them (their vertices keep their marks as others are dropped)
    zone = np.zeros(len(v), bool)
    for i in np.flatnonzero(seed):
        zone |= np.hypot(*(v - v[i]).T) <= 2.0 * limit[i]
    bound = 0.25 * float(limit[seed].min())
    for _ in range(len(v)):
        at = np.flatnonzero(zone)
        if len(v) < 4 or not len(at):
            break
        sine, length, limit = facing(v, at)
        best = None
        for k in np.flatnonzero((sine < OVERHANG_MARGIN) & (length <= limit)):
            for j in (at[k], (at[k] + 1) % len(v)):       # the edge's ends
                p0, p1 = v[j - 1], v[(j + 1) % len(v)]
                chord = p1 - p0
                off = abs(float(chord[0] * (v[j] - p0)[1] - chord[1] * (v[j] - p0)[0])
                          ) / max(float(np.hypot(*chord)), 1e-12)
                if off <= 0.25 * limit[k] and (best is None or off < best[1]):
                    best = (j, off)
            if best is not None:
                break
        if best is None:
            break
        v = np.delete(v, best[0], axis=0)
        zone = np.delete(zone, best[0])
    dropped = len(given) - len(v)
    moved = float(shapely.distance(shapely.LinearRing(v), shapely.points(given)).max()
                  ) if dropped else 0.0
    if not dropped or moved > bound:    # (every vertex given within the bound of the ring)
        return water
    out = shapely.Polygon(v, [np.asarray(r.coords)[:-1] for r in water.interiors])
    if not out.is_valid or len(out.interiors) != len(water.interiors):
        return water
    report.repair(f"water body {k}", None, None,
                  f"{dropped} vertices of short edges facing away from their channel's axis "
                  f"(an island's round end leaning over the water where it crosses a bank) "
                  f"dropped, moving the outline by at most {moved:.2f} m")
    return out


# -- reading -------------------------------------------------------------------------------------


def _points(value, name: str) -> np.ndarray:
    """(N, 2) finite points, or GraphError naming the argument."""
    if value is None:
        return np.zeros((0, 2))
    try:
        pts = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise GraphError(f"read_water: {name} must be points (x, y), got {value!r}") from None
    if pts.size == 0:                   # (an empty list: none)
        return np.zeros((0, 2))
    if pts.ndim == 1 and pts.shape == (2,):
        pts = pts[None]
    if pts.ndim != 2 or pts.shape[1] != 2 or not np.isfinite(pts).all():
        raise GraphError(f"read_water: {name} must be finite points (x, y), got {value!r}")
    return pts


def _outlets(value) -> tuple[np.ndarray, list, list]:
    """``read_water``'s ``outlets``: (points (N, 2), lines (shapely), files of lines): points
    (x, y), shapely lines, or GIS files of lines (a path), alone or in a list; GraphError
    naming what is none of these."""
    if value is None:
        return np.zeros((0, 2)), [], []
    items = ([value] if isinstance(value, (str, Path, shapely.Geometry))
             else list(value) if isinstance(value, (list, tuple)) else None)
    if items is None or not any(isinstance(v, (str, Path, shapely.Geometry)) for v in items):
        return _points(value, "outlets"), [], []
    pts, lines, files = [], [], []
    for v in items:
        if isinstance(v, (str, Path)):
            if not Path(v).exists():
                raise GraphError(f"read_water: outlets must be points (x, y), lines or files "
                                 f"of lines: no file {str(v)!r}")
            files.append(Path(v))
        elif isinstance(v, shapely.Geometry):
            parts = [p for p in shapely.get_parts(shapely.line_merge(shapely.boundary(v))
                                                  if v.geom_type.endswith("Polygon") else v)
                     if p.geom_type in ("LineString", "LinearRing") and p.length > 0]
            if not parts or not np.isfinite(shapely.get_coordinates(parts)).all():
                raise GraphError(f"read_water: outlets: {v.geom_type} {str(v)[:60]!r} is no "
                                 f"line (a coastline, a dam) with finite coordinates")
            lines += parts
        elif np.size(v) == 2:
            pts.append(_points(v, "outlets")[0])
        else:
            raise GraphError(f"read_water: outlets must be points (x, y), lines or files of "
                             f"lines, got {v!r}")
    return np.array(pts, dtype=np.float64).reshape(-1, 2), lines, files


def _match_line(ends, line, where: str) -> None:
    """Mark every free end within its channel's width (1 m at least) of an outlet line as an
    outlet; GraphError for a line that passes none."""
    if not ends:
        raise GraphError(f"{where}: the water has no free end to put an outlet at")
    xy = np.array([net.nodes[n] for net, n, _ in ends])
    d = shapely.distance(line, shapely.points(xy))
    w = np.maximum([e[2] for e in ends], 1.0)
    near = np.flatnonzero(d <= w)
    if not len(near):
        i = int(np.argmin(d - w))
        x, y = shapely.get_coordinates(line)[0]
        raise GraphError(f"{where}: the outlet line from ({x:.1f}, {y:.1f}) passes no free "
                         f"end of the water: the nearest, ({xy[i, 0]:.1f}, {xy[i, 1]:.1f}), "
                         f"lies {d[i]:.1f} m from it, more than the channel's width there "
                         f"({w[i]:.1f} m)")
    for i in near:
        net, n, _ = ends[i]
        net.outlets.add(n)


def _check_points_crs(source_crs, inlets: np.ndarray, outlets: np.ndarray, where: str) -> None:
    """Inlets and outlets in a geographic CRS must be longitudes and latitudes."""
    if source_crs is None or not (len(inlets) or len(outlets)):
        return
    pyproj = require("pyproj", f"projecting {where}")
    try:
        crs = pyproj.CRS.from_user_input(source_crs)
    except Exception:   # _project says what is wrong with it
        return
    if not crs.is_geographic:
        return
    for what, pts in (("inlet", inlets), ("outlet", outlets)):
        for x, y in pts:
            if not (abs(x) <= 360.0 and abs(y) <= 90.0):
                raise GraphError(f"{where}: {what} ({x:g}, {y:g}) is no longitude / latitude: "
                                 f"inlets and outlets are in the data's CRS ({crs.name})")


def _read_mask(path: Path):
    """[(fid, polygon, attrs)] of the water cells (> 0) of a raster, its CRS, layer name,
    cell size [CRS units] and extent (a polygon along its border, a point every half cell)."""
    rasterio = require("rasterio", f"reading {path}")
    from rasterio import features as rio_features

    try:
        with rasterio.open(path) as src:
            band = src.read(1, masked=True)
            transform, crs = src.transform, src.crs
    except Exception as exc:  # rasterio's RasterioIOError and friends
        raise GraphError(f"{path}: cannot read it as a raster: {exc}") from None
    data = np.ma.filled(band.astype(np.float64), 0.0)
    mask = np.isfinite(data) & (data > 0)
    if not mask.any():
        raise GraphError(f"{path}: the mask has no water (no cell > 0 of {mask.size})")
    values = _mask_values(data[mask])
    if mask.all() and mask.size > 1:
        raise GraphError(f"{path}: the mask is water in every one of its {mask.size} cells: "
                         f"no shore to read a river's banks from (a crop inside a lake or the "
                         f"sea? give the water's shores, or a wider mask"
                         + (f"; {values}" if values else "") + ")")
    shapes = rio_features.shapes(mask.astype(np.uint8), mask=mask, transform=transform,
                                 connectivity=4)
    cell = float(min(abs(transform.a), abs(transform.e)))
    polys = [_smooth_cells(shapely.geometry.shape(s), cell) for s, _ in shapes]
    extent = shapely.segmentize(shapely.box(*rasterio.transform.array_bounds(
        *mask.shape, transform)), 0.5 * cell)
    return ([(k, p, {}) for k, p in enumerate(polys)], crs.to_wkt() if crs else None,
            "band 1", cell, extent, values)


MASK_VALUES_SAMPLE = 100_000
"""How many of a mask's water cells :func:`_mask_values` looks at."""


def _mask_values(wet: np.ndarray) -> str | None:
    """Words on a mask's water values ``wet`` (the cells > 0) when they are more than two:
    a probability or an index (NDWI, a classifier's score) read as water wherever above 0."""
    sample = wet[::max(1, len(wet) // MASK_VALUES_SAMPLE)]
    distinct = np.unique(sample)
    if len(distinct) <= 2:
        return None
    return (f"its water cells hold {len(distinct)} different values from {wet.min():g} to "
            f"{wet.max():g} (in a sample): every cell above 0 is water; a probability or "
            f"an index (a classifier's score, NDWI) wants a threshold first, e.g. "
            f"(band >= 0.5).astype('uint8') written as the mask")


def _smooth_cells(poly, cell: float):
    """A mask's polygon without the cells' stairs: each ring densified to half a cell and
    averaged over a window of MASK_SMOOTH_CELLS cells (a straight bank then is a straight
    line again, moved by under half a cell; the stairs' risers would face away from the
    channel's axis, which a hydro graph does not allow)."""
    def ring(r):
        v = np.asarray(shapely.segmentize(r, 0.5 * cell).coords)[:-1]
        k = max(int(round(MASK_SMOOTH_CELLS)), 1)
        if len(v) <= 2 * k + 3:
            return v
        kernel = np.ones(2 * k + 1) / (2 * k + 1)
        pad = np.vstack([v[-k:], v, v[:k]])
        return np.column_stack([np.convolve(pad[:, i], kernel, mode="valid") for i in (0, 1)])

    holes = [h for h in map(ring, poly.interiors) if len(h) >= 3]
    out = shapely.Polygon(ring(poly.exterior), holes)
    return out if out.is_valid else shapely.make_valid(out)


def _lakes_of(features, polygons, water, report: RiverImport, tolerance_m: float):
    """(the lakes: polygons [m] of the water where features tagged as lakes lie, without
    holes; the rest of the water, None when nothing is left)."""
    tagged = [g for (_, _, attrs), g in zip(features, polygons)
              if attrs.get(LAKE_FLAG) and g is not None and not g.is_empty]
    if not tagged:
        return [], water
    area = whole = shapely.intersection(water, shapely.union_all(
        shapely.make_valid(np.array(tagged, dtype=object))))
    # lakes that touch (two ponds at a point inside water that joins them) moved apart
    parts = [p for p in shapely.get_parts(area) if p.geom_type == "Polygon"]
    apart = _parts_apart(parts, tolerance_m, report)
    if apart is not parts:
        area = shapely.union_all(apart)
    lakes = []
    for p in shapely.get_parts(area):
        if p.geom_type != "Polygon" or not p.area > (4.0 * tolerance_m) ** 2:
            continue
        x, y = p.representative_point().coords[0]
        if len(p.interiors):
            report.repair("lake", None, None, f"the lake near ({x:.1f}, {y:.1f}) has "
                          f"{len(p.interiors)} islands: kept (the flow goes round them, "
                          f"hydro/lake_flow.py)")
        lakes.append(p)
    if not lakes:
        return [], water
    if all(attrs.get(LAKE_FLAG) for _, _, attrs in features):
        # every feature a lake: what the union leaves beside them is slivers of its repair
        # (graphhopper's krems.osm, 27 ponds: one of 1.5 m² was read as a river and refused)
        rest = shapely.Polygon()
    else:
        rest = shapely.difference(water, whole)
        rest = shapely.union_all([p for p in shapely.get_parts(rest) if p.geom_type == "Polygon"
                                  and p.area > (4.0 * tolerance_m) ** 2])
    report.derived["lakes"] = (f"{len(lakes)} (polygons tagged water="
                               f"{'|'.join(LAKE_WATER)}, or OSM natural=water areas without "
                               f"water=, a lake by OSM's convention): flat water bodies")
    return lakes, (None if rest.is_empty else rest)


def _seas(water, frame, cell, report: RiverImport, tolerance_m: float):
    """(the open water (SEA_WIDTHS): polygons [m], each a lake, the channels' outlet; the
    rest of the water, None when nothing is left). The water is rasterized on cells of
    ``cell`` [m] (a mask's; at least 1/SEA_GRID of the longer side), ``frame`` the data's
    extent (cutting across the open water: SEA_CUT_RADII); the open water's outline is that
    of its cells simplified and grown by 1.5 cells, cut by the water's (its coast and islands
    are the data's), each channel's mouth then straight (:func:`_straight_mouths`)."""
    from affine import Affine
    from rasterio import features as rio_features
    from scipy import ndimage

    x0, y0, x1, y1 = water.bounds
    size = max(x1 - x0, y1 - y0)
    along = max(cell or 0.0, tolerance_m)       # an outline on the edge: within a mask's cell
    cell = max(cell or 0.0, size / SEA_GRID, tolerance_m)
    shape = (int(math.ceil((y1 - y0) / cell)) + 2, int(math.ceil((x1 - x0) / cell)) + 2)
    tr = Affine(cell, 0.0, x0 - cell, 0.0, -cell, y1 + cell)
    wet = rio_features.rasterize([water], out_shape=shape, transform=tr).astype(bool)
    d = ndimage.distance_transform_edt(wet)
    ridge = wet & (d == ndimage.maximum_filter(d, size=3))
    if not ridge.any():
        return [], water
    wide = float(np.percentile(d[ridge], 75.0))
    if not d.max() >= SEA_WIDTHS * max(wide, 1.0):
        return [], water
    # grown from its core by circles SEA_WIDTHS times the channels' median width
    core = d >= max(SEA_WIDTHS * wide, 0.5 * float(d.max()))
    r = SEA_WIDTHS * max(float(np.median(d[ridge])), 1.0)
    opened = ndimage.distance_transform_edt(d < r) <= r
    labels, _ = ndimage.label(opened & wet)
    keep = np.unique(labels[core & (labels > 0)])
    # the data's edge: its extent's, or the water's bounding box (a mask's border of empty
    # cells round the water: RivGraph's masks have one)
    frame_edge = shapely.union(frame.boundary, shapely.box(*water.bounds).boundary)
    seas, rest = [], water
    for k in keep:
        cells = shapely.union_all([shapely.geometry.shape(g) for g, v in rio_features.shapes(
            (labels == k).astype(np.uint8), mask=labels == k, transform=tr) if v])
        if cells.distance(frame_edge) > 2.0 * cell:
            continue        # a lake inside the data: the channels' skeleton runs through it
        grown = cells.simplify(cell).buffer(1.5 * cell)
        parts = [p for p in shapely.get_parts(shapely.intersection(rest, grown))
                 if p.geom_type == "Polygon" and shapely.intersection(p, cells).area
                 > 0.5 * p.area]
        if not parts:
            continue
        sea = max(parts, key=lambda p: p.area)
        on = shapely.line_merge(shapely.intersection(sea.boundary, shapely.buffer(frame_edge,
                                                                                    along)))
        cut = max((g.length for g in shapely.get_parts(on)), default=0.0)
        if cut < SEA_CUT_RADII * float(d[labels == k].max()) * cell:
            continue        # it touches the edge only: a lake inside the data
        sea, rest = _straight_mouths(sea, shapely.difference(rest, sea), cell)
        seas.append(sea)
    if not seas:
        return [], water
    rest = shapely.union_all([p for p in shapely.get_parts(rest) if p.geom_type == "Polygon"
                              and p.area > (4.0 * tolerance_m) ** 2])
    for sea in seas:
        x, y = sea.representative_point().coords[0]
        report.repair("open water", None, None,
                      f"{sea.area / 1e6:.2f} km² of water near ({x:.1f}, {y:.1f}) reaching the "
                      f"data's edge is wider than {SEA_WIDTHS:g} times the channels' wide "
                      f"width ({2 * wide * cell:.1f} m, the upper quartile): open water (a sea, "
                      f"a lake), still, the channels opening into it leave there")
    report.derived["open water"] = (f"{len(seas)} (water wider than {SEA_WIDTHS:g} channel "
                                    f"widths reaching the data's edge): still, the channels' "
                                    f"outlet")
    return seas, (None if rest.is_empty else rest)


def _join_open_water(builder: WaterBuilder, part, k: int, why: str) -> bool:
    """Join water body ``k`` (``part``, ``why``: no channel of its own) to the open water
    (builder.seas) or the lake made of a knot (:func:`_knot_lake`) it touches, still water
    (reported); False where it touches none."""
    seas = builder.seas
    near = [s for s in [*seas, *builder._knot_lakes] if s.distance(part) <= builder.tolerance_m]
    if not near:
        return False
    inside = near[0].representative_point()
    lake = next(lk for lk in builder._lakes if lk.polygon.contains(inside))
    both = shapely.union(lake.polygon, part)
    lake.polygon = max((p for p in shapely.get_parts(both) if p.geom_type == "Polygon"),
                       key=lambda p: p.area)
    x, y = part.representative_point().coords[0]
    builder.report.repair(f"water body {k}", None, None,
                          f"{part.area:.1f} m² of water near ({x:.1f}, {y:.1f}) {why}: joined to "
                          f"the {'open water' if any(near[0] is s for s in seas) else 'lake'} "
                          f"beside it (still water)")
    return True


def _straight_mouths(sea, rest, cell: float):
    """(``sea``, ``rest``) with each stretch of their common boundary (a channel's mouth)
    made the straight line between its ends, where that line lies in the water: the
    water between the two goes to the side the line leaves it on."""
    contact = shapely.intersection(sea.boundary, rest.boundary)
    lines = [g for g in shapely.get_parts(shapely.line_merge(shapely.union_all(
        [g for g in shapely.get_parts(contact) if g.geom_type == "LineString"])))
        if g.geom_type == "LineString" and g.length > 2.0 * cell]
    both = shapely.union(sea, rest).buffer(1e-6 * cell)
    to_sea, to_rest = [], []
    for line in lines:
        c = np.asarray(line.coords)
        chord = shapely.LineString([c[0], c[-1]])
        if not both.contains(chord) or chord.length < 1e-9:
            continue
        for q in shapely.get_parts(shapely.polygonize(shapely.get_parts(shapely.node(
                shapely.MultiLineString([c, np.asarray(chord.coords)]))))):
            inside = shapely.intersection(q, rest).area
            (to_sea if inside > 0.5 * q.area else to_rest).append(q)
    if to_sea:
        moved = shapely.union_all(to_sea)
        sea, rest = shapely.union(sea, shapely.intersection(moved, rest)), \
            shapely.difference(rest, moved)
    if to_rest:
        moved = shapely.union_all(to_rest)
        rest, sea = shapely.union(rest, shapely.intersection(moved, sea)), \
            shapely.difference(sea, moved)
    parts = [p for p in shapely.get_parts(sea) if p.geom_type == "Polygon"]
    sea = _without_spikes(max(parts, key=lambda p: p.area), 1e-6 * cell)
    return sea, rest


def _without_spikes(poly, within: float):
    """``poly`` without the spikes of no width its rings may have (a vertex its ring goes
    out to and back from to within ``within`` [m], as a difference can leave: Colville's
    sea had one 409 m into a mouth, which as the data's edge cut the mouth's channel short
    of its water)."""
    def ring(r):
        c = list(np.asarray(r.coords)[:-1])
        i = 0
        while len(c) > 3 and i < len(c):
            if np.hypot(*(c[i - 1] - c[(i + 1) % len(c)])) <= within:
                del c[max(i, (i + 1) % len(c))], c[min(i, (i + 1) % len(c))]
                i = max(i - 1, 0)
            else:
                i += 1
        return c

    outer = ring(poly.exterior)
    if len(outer) < 3:
        return poly
    # (a hole that was all spike, a knot's lake cut into a sliver of one, is gone)
    return shapely.Polygon(outer, [h for h in map(ring, poly.interiors) if len(h) >= 3])


def _read_polygons(path: Path, layer):
    """[(fid, polygon, attrs)] of a vector file's polygon layer, its CRS and layer name."""
    pyogrio = require("pyogrio", f"reading {path}")
    osm = _is_osm(path)
    if osm and layer is None:
        name = "multipolygons"
    elif layer is None:
        try:
            layers = pyogrio.list_layers(str(path))
        except Exception as exc:
            raise GraphError(f"{path}: cannot read it as GIS data: {exc}") from None
        polys = [str(n) for n, t in layers if "polygon" in str(t).lower()]
        name = polys[0] if polys else _pick_layer(pyogrio, path, None)
    else:
        name = _pick_layer(pyogrio, path, layer)
    where = f"{path} (layer {name!r})"
    try:
        meta, fids, wkb, columns = _read_raw(pyogrio, path, name)
    except Exception as exc:
        raise GraphError(f"{where}: cannot read it: {exc}") from None
    names = [str(n) for n in meta["fields"]]
    table = {n: columns[k] for k, n in enumerate(names)}
    keep = np.ones(len(fids), bool)
    if osm:
        other = table.get("other_tags", [None] * len(fids))
        natural = table.get("natural", [None] * len(fids))
        for i in range(len(fids)):
            tags = _hstore(other[i])
            keep[i] = ((natural[i] == "water" and tags.get("water", "lake") in OSM_WATER)
                       or tags.get("waterway") == "riverbank")
    geoms, _ = _from_wkb(wkb)
    out = []
    for i in np.flatnonzero(keep):
        attrs = {n: _plain(table[n][i]) for n in names}
        water = attrs.get("water")
        if osm:
            tags = _hstore(table["other_tags"][i]) if "other_tags" in table else {}
            water = tags.get("water", "lake" if attrs.get("natural") == "water"
                             and tags.get("waterway") != "riverbank" else None)
        if not osm and water is None:       # NHD's feature type, where the file has one
            ftype = next((v for k, v in attrs.items() if k.lower() == "ftype"), None)
            if ftype is not None and str(int(ftype) if isinstance(ftype, float) and
                                         ftype.is_integer() else ftype).strip().lower() \
                    in NHD_LAKE_FTYPES:
                water = "lake"
        if isinstance(water, str) and water.strip().lower() in LAKE_WATER:
            attrs[LAKE_FLAG] = True
        out.append((int(fids[i]), geoms[i], attrs))
    if not out:
        raise GraphError(f"{where}: no features" + (" tagged natural=water or "
                                                    "waterway=riverbank" if osm else ""))
    return out, meta.get("crs"), name


def _plain(v):
    return v.item() if isinstance(v, np.generic) else v


def _read_lines(path: Path, lines, source_crs, where: str) -> list:
    """The waterway lines (shapely LineStrings in the polygons' source CRS, drawn downstream):
    ``lines`` is a file or a layer of ``path``."""
    pyogrio = require("pyogrio", f"reading the lines of {where}")
    if isinstance(lines, (str, Path)) and Path(lines).exists() and Path(lines) != path:
        lpath, lname = Path(lines), None
    elif isinstance(lines, (str, int)) and not is_raster_path(path):
        lpath, lname = path, lines
    else:
        raise GraphError(f"{where}: lines={lines!r} is neither a file nor a layer of it")
    try:
        name = ("lines" if _is_osm(lpath) and lname is None
                else _pick_layer(pyogrio, lpath, lname))
    except GraphError as exc:
        if lname is not None and ("/" in str(lname) or Path(str(lname)).suffix):
            raise GraphError(f"{where}: lines={lines!r}: no such file (nor a layer of "
                             f"{path.name}: {exc})") from None      # (a path mistyped)
        raise
    lwhere = f"{lpath} (layer {name!r})"
    try:
        meta, fids, wkb, columns = _read_raw(pyogrio, lpath, name)
    except Exception as exc:
        raise GraphError(f"{lwhere}: cannot read it: {exc}") from None
    if _is_osm(lpath):
        names = [str(n) for n in meta["fields"]]
        table = {n: columns[k] for k, n in enumerate(names)}
        fids, wkb, *_ = _osm_waterways(fids, wkb, table, names, lwhere)
    geoms, _ = _from_wkb(wkb)
    out = []
    for g in geoms:
        if g is None or g.is_empty:
            continue
        out += [p for p in shapely.get_parts(g) if p.geom_type == "LineString" and p.length > 0]
    if not out:
        raise GraphError(f"{lwhere}: no lines")
    line_crs = meta.get("crs")
    if line_crs and source_crs:
        pyproj = require("pyproj", f"projecting {lwhere}")
        a, b = pyproj.CRS.from_user_input(line_crs), pyproj.CRS.from_user_input(source_crs)
        if a != b:
            to = pyproj.Transformer.from_crs(a, b, always_xy=True)
            out = [shapely.transform(g, lambda p: np.column_stack(to.transform(p[:, 0], p[:, 1])))
                   for g in out]
    return out


def _repair(features, polygons, report: RiverImport, where: str, simplify_m: float,
            tolerance_m: float):
    """The water (a Polygon or MultiPolygon [m]): invalid polygons made valid, polygons
    without area and other geometries left out (each reported), all joined and simplified."""
    kept = []
    for (fid, _, attrs), g in zip(features, polygons):
        label = f"feature {fid}"
        if g is None or g.is_empty:
            report.repair(label, fid, attrs, "no geometry: left out")
            continue
        if g.geom_type == "GeometryCollection":
            # (an export's collection of a polygon and the lines or points beside it)
            polys = [p for p in shapely.get_parts(g) if p.geom_type in ("Polygon",
                                                                         "MultiPolygon")]
            if polys:
                other = len(shapely.get_parts(g)) - len(polys)
                report.repair(label, fid, attrs, f"a GeometryCollection: its {len(polys)} "
                              f"polygons kept, its {other} other geometries left out")
                g = polys[0] if len(polys) == 1 else shapely.union_all([
                    q for p in polys for q in shapely.get_parts(
                        p if p.is_valid else shapely.make_valid(p))
                    if q.geom_type in ("Polygon", "MultiPolygon")])
        if g.geom_type not in ("Polygon", "MultiPolygon"):
            report.repair(label, fid, attrs, f"a {g.geom_type}, not a polygon: left out")
            continue
        if not np.isfinite(shapely.get_coordinates(g)).all():
            report.repair(label, fid, attrs, "non-finite coordinates: left out")
            continue
        why = None if g.is_valid else shapely.is_valid_reason(g)
        if why is not None:
            g = shapely.make_valid(g)
            g = shapely.union_all([p for p in shapely.get_parts(g)
                                   if p.geom_type in ("Polygon", "MultiPolygon")])
        if not g.area > tolerance_m ** 2:
            report.repair(label, fid, attrs, f"no area ({g.area:.3g} m²"
                                             + (f"; invalid: {why}" if why else "") + "): left out")
            continue
        if why is not None:
            report.repair(label, fid, attrs, f"invalid polygon ({why}): made valid "
                                             f"(shapely.make_valid), {g.area:.1f} m² of water")
        kept.append(g)
    if not kept:
        raise GraphError(f"{where}: no polygon with an area ({len(features)} features read"
                         + (f"; {report.repairs[0]}" if report.repairs else "") + ")")
    water = shapely.union_all(kept)
    if simplify_m > 0:
        water = shapely.simplify(water, simplify_m, preserve_topology=True)
    if not water.is_valid:
        water = shapely.make_valid(water)
    parts = [p for p in shapely.get_parts(water)
             if p.geom_type == "Polygon" and p.area > tolerance_m ** 2]
    parts = _bridged(parts, tolerance_m, report)
    clean = []
    for p in parts:    # holes smaller than the tolerance are specks of the data, not islands
        holes = [r for r in p.interiors if shapely.Polygon(r).area > (4.0 * tolerance_m) ** 2]
        if len(holes) < len(p.interiors):
            report.notes.append(f"{len(p.interiors) - len(holes)} holes smaller than "
                                f"{(4.0 * tolerance_m) ** 2:g} m² filled (specks, not islands)")
        clean.append(_islands_apart(shapely.Polygon(p.exterior, holes), tolerance_m, report))
    clean = _parts_apart(clean, tolerance_m, report)
    clean.sort(key=lambda p: (-p.area, p.bounds))
    return clean[0] if len(clean) == 1 else shapely.MultiPolygon(clean)


BRIDGE_MAX_M = 100.0
"""Longest gap [m] :func:`_bridged` joins the water across (a bridge's deck, a weir, a road's
embankment over a culvert the data left as land)."""
BRIDGE_WIDTHS = 2.0
"""…and at most this many times the narrower channel's width (its inscribed circle's
diameter)."""
BRIDGE_SPAN = (0.5, 1.5)
"""…where the land between the two pieces of water is (lo, hi) times that width across: it
spans one channel, bank to bank (two ponds side by side along a dyke face each other along
their length: not a bridge)."""
BRIDGE_ELONGATION = 3.0
"""…and both pieces are channels: each at least this many times as long as it is wide (its
area over its width squared; two ponds of 40 × 20 m near a footbridge are not)."""


def _bridged(parts: list, tolerance_m: float, report: RiverImport) -> list:
    """``parts`` (Polygons) with the water joined across each gap where two pieces of a
    channel face each other, cut apart by a strip of land about as long as the channel is
    wide and shorter than BRIDGE_WIDTHS widths (BRIDGE_MAX_M at most): a bridge, a weir or a
    culvert's embankment that the data (a mask classified from images, riverbank polygons
    cut at a bridge's deck) left as land. The strip is what a closing of the two pieces
    (a disc of twice the gap) adds between them, within two widths of the gap. Reported."""
    from scipy.cluster.hierarchy import DisjointSet

    if len(parts) < 2:
        return parts
    a, b = shapely.STRtree(parts).query(parts, predicate="dwithin", distance=BRIDGE_MAX_M)
    pairs = [(i, j) for i, j in zip(a.tolist(), b.tolist()) if i < j]
    if not pairs:
        return parts
    radius: dict[int, float] = {}

    def width(k: int) -> float:          # the channel's width: its inscribed circle's
        if k not in radius:
            circle = shapely.maximum_inscribed_circle(parts[k], tolerance_m)
            radius[k] = float(shapely.length(circle))
        return 2.0 * radius[k]

    joined_to = DisjointSet(range(len(parts)))      # (two pieces joined once)
    fills = []
    for i, j in pairs:
        pi, pj = parts[i], parts[j]
        gap = float(shapely.distance(pi, pj))
        if gap > BRIDGE_MAX_M or joined_to.connected(i, j):
            continue
        w = min(width(i), width(j))
        if gap > BRIDGE_WIDTHS * w or pi.area < BRIDGE_ELONGATION * width(i) ** 2 \
                or pj.area < BRIDGE_ELONGATION * width(j) ** 2:
            continue
        mid = shapely.shortest_line(pi, pj).interpolate(0.5, normalized=True)
        # a disc of twice the gap: the banks run on straight across it (within a 16th of
        # the gap; a disc of half the gap would cut the strip's corners off)
        r = 2.0 * gap + tolerance_m
        window = shapely.buffer(mid, 2.0 * r + 2.0 * w)
        near = shapely.union_all([shapely.intersection(pi, window),
                                  shapely.intersection(pj, window)])
        closed = shapely.buffer(shapely.buffer(near, r), -r)
        fill = shapely.intersection(shapely.difference(closed, near),
                                    shapely.buffer(mid, 2.0 * w))
        for piece in shapely.get_parts(fill):
            if piece.geom_type != "Polygon" or not (
                    shapely.distance(piece, pi) <= tolerance_m
                    and shapely.distance(piece, pj) <= tolerance_m):
                continue
            # across: the shores that face each other over it (the gap may cut the channel
            # obliquely: its area over the shortest gap would overstate it)
            edge = shapely.buffer(piece, tolerance_m)
            span = 0.5 * float(shapely.length(shapely.intersection(pi.exterior, edge))
                               + shapely.length(shapely.intersection(pj.exterior, edge)))
            if not BRIDGE_SPAN[0] * w <= span <= BRIDGE_SPAN[1] * w:
                continue
            # (a strip that closes a ring of water round land, touching one piece at two
            # places, makes an island no data drew: not a bridge between two pieces)
            joined = shapely.union_all([pi, pj, piece])
            if joined.geom_type != "Polygon" or len(joined.interiors) > (
                    len(pi.interiors) + len(pj.interiors)):
                continue
            fills.append(piece)
            joined_to.merge(i, j)
            x, y = piece.representative_point().coords[0]
            report.repair("water", None, None,
                          f"two pieces of a channel {gap:.1f} m apart near ({x:.1f}, {y:.1f}), "
                          f"the land between them {span:.1f} m across (the channel {w:.1f} m "
                          f"wide): joined across it (a bridge, a weir or a culvert the data "
                          f"left as land)")
    if not fills:
        return parts
    joined = shapely.union_all([*parts, *fills])
    return [p for p in shapely.get_parts(joined)
            if p.geom_type == "Polygon" and p.area > tolerance_m ** 2]


def _parts_apart(parts: list, tolerance_m: float, report: RiverImport) -> list:
    """``parts`` (Polygons) once each that comes within ``tolerance_m`` of a larger one has
    its shore there moved back to twice that from it (water does not pass through a point:
    two polygons touching at a corner, a figure-eight outline made valid, are two water
    bodies; the builder needs their shores farther apart than its tolerance). Pieces left
    smaller than the tolerance's square go. Reported."""
    if len(parts) < 2:
        return parts
    a, b = shapely.STRtree(parts).query(parts, predicate="dwithin", distance=tolerance_m)
    if not (a != b).any():
        return parts                      # (as they were: none near another)
    order = sorted(range(len(parts)), key=lambda k: (-parts[k].area, parts[k].bounds))
    parts = [parts[k] for k in order]
    a, b = shapely.STRtree(parts).query(parts, predicate="dwithin", distance=tolerance_m)
    pair = a < b                          # (a larger, b smaller: sorted by area)
    for i, j in zip(a[pair].tolist(), b[pair].tolist()):
        if parts[i].is_empty or parts[j].is_empty:
            continue
        line = shapely.shortest_line(parts[i].exterior, parts[j].exterior)
        x, y = line.interpolate(0.5, normalized=True).coords[0]
        parts[j] = shapely.difference(parts[j], shapely.buffer(parts[i], 2.0 * tolerance_m))
        report.repair("water", None, None,
                      f"two parts of the water touch or come within the tolerance "
                      f"({tolerance_m:g} m) near ({x:.1f}, {y:.1f}): the smaller one's shore "
                      f"there moved back to {2.0 * tolerance_m:g} m from the other (water "
                      f"does not pass through a point: two water bodies)")
    return [g for part in parts for g in shapely.get_parts(part)
            if g.geom_type == "Polygon" and g.area > tolerance_m ** 2]


def _islands_apart(poly, tolerance_m: float, report: RiverImport):
    """``poly`` once each island within ``tolerance_m`` of the outer shore or of
    another island has its shore there moved back to twice that (the builder needs an island
    to lie farther than its tolerance from every other shore; an island touching a bank at
    a point, as map data often has, is valid but not that). Reported."""
    rings = [poly.exterior, *poly.interiors]
    if len(rings) < 2:
        return poly
    lines = [shapely.LinearRing(r) for r in rings]
    a, b = shapely.STRtree(lines).query(lines, predicate="dwithin", distance=tolerance_m)
    pair = a < b
    if not pair.any():
        return poly
    holes = [shapely.Polygon(r) for r in poly.interiors]
    for i, j in zip(a[pair], b[pair]):
        # the island j (the smaller of two islands) moved back from the other shore
        if i > 0 and holes[i - 1].area < holes[j - 1].area:
            i, j = j, i
        line = shapely.shortest_line(lines[i], lines[j])
        x, y = line.interpolate(0.5, normalized=True).coords[0]
        report.repair("island", None, None,
                      f"the island near ({x:.1f}, {y:.1f}) is {line.length:.2f} m from "
                      + ("the outer shore" if i == 0 else "another island")
                      + f", within the tolerance ({tolerance_m:g} m): its shore there moved "
                        f"back to {2.0 * tolerance_m:g} m from it")
        holes[j - 1] = shapely.difference(holes[j - 1], shapely.buffer(
            lines[i] if i == 0 else holes[i - 1], 2.0 * tolerance_m))
    kept = [g for h in holes for g in shapely.get_parts(h)
            if g.geom_type == "Polygon" and g.area > (4.0 * tolerance_m) ** 2]
    return shapely.Polygon(poly.exterior, [g.exterior for g in kept])


# -- channels ------------------------------------------------------------------------------------


class _Channel:
    """One axis: points (K, 2) [m], widths (K,) [m], its source ("lines" / "skeleton"), end
    node ids in its network, and once oriented its discharge."""

    def __init__(self, points, widths, source: str, a: int, b: int, name: str) -> None:
        self.points = np.asarray(points, np.float64)
        self.widths = np.asarray(widths, np.float64)
        self.source = source
        self.a, self.b = a, b
        self.name = name
        self.discharge_m2s: float | None = None
        self.discharge_from = ""
        self.directed = source == "lines"

    def flip(self) -> None:
        self.points = self.points[::-1].copy()
        self.widths = self.widths[::-1].copy()
        self.a, self.b = self.b, self.a

    @property
    def width(self) -> float:
        """Its width [m]: the median over its middle (20 - 80 % of its length, evenly
        spaced; its ends widen into junctions)."""
        s = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(self.points, axis=0).T))])
        at = np.linspace(0.2, 0.8, 25) * s[-1]
        return float(np.median(np.interp(at, s, self.widths)))

    @property
    def length(self) -> float:
        return float(np.hypot(*np.diff(self.points, axis=0).T).sum())


class _Network:
    """The channels of one connected water polygon: ``water`` (with the holes that lie
    between channels), ``islands`` (free islands), ``channels``, node points, and the
    inlets / outlets matched to its free ends."""

    def __init__(self, water, islands, channels: list[_Channel], nodes: np.ndarray) -> None:
        self.water = water
        self.islands = islands
        self.channels = channels
        self.nodes = nodes
        self.inlets: set[int] = set()
        self.outlets: set[int] = set()
        self.hinted = False
        """Whether inlets / outlets are the lines' ends (:attr:`WaterBuilder.by_line_ends`)."""
        self.knotted = False
        """Whether inlets / outlets are the ways the water ran before its knots were made
        lakes (:func:`_knot_lake`)."""
        self.tributaries: set[int] = set()
        """Free ends of short dead-end channels kept as tributaries because the DEM rises
        towards them (:func:`_drop_basin_spurs`): inlets when the DEM orients the water."""
        self.basin_axes: list[tuple[np.ndarray, np.ndarray]] = []
        """The dropped spurs' axes beyond their channel's bank, (points, widths) [m]: basins
        (the builder's ``basin_axes``)."""
        self.rule = ""
        self.part = 0
        """The index of its polygon among the water's."""

    def degree(self) -> np.ndarray:
        deg = np.zeros(len(self.nodes), int)
        for c in self.channels:
            deg[c.a] += 1
            deg[c.b] += 1
        return deg

    def longest_path(self) -> float:
        """The longest of the shortest paths along the channels between two nodes [m]."""
        n = len(self.nodes)
        rows = [c.a for c in self.channels] + [c.b for c in self.channels]
        cols = [c.b for c in self.channels] + [c.a for c in self.channels]
        adj = coo_matrix(([c.length for c in self.channels] * 2, (rows, cols)),
                         shape=(n, n)).tocsr()
        d = dijkstra(adj)
        return float(d[np.isfinite(d)].max(initial=0.0))

    def free_ends(self) -> list[tuple[_Network, int, float]]:
        """(network, node, width) of every free end (a node of one channel)."""
        deg = self.degree()
        out = []
        for c in self.channels:
            for n in (c.a, c.b):
                if deg[n] == 1:
                    out.append((self, n, c.width))
        return out

    def orient(self, elevations: dict | None) -> str:
        """Draw every channel downstream; returns the rule that decided."""
        if all(c.directed for c in self.channels):
            return "from the lines"
        deg = self.degree()
        leaves = [n for n in range(len(self.nodes)) if deg[n] == 1]
        n = len(self.nodes)
        rows = [c.a for c in self.channels] + [c.b for c in self.channels]
        cols = [c.b for c in self.channels] + [c.a for c in self.channels]
        lens = [c.length for c in self.channels] * 2
        adj = coo_matrix((lens, (rows, cols)), shape=(n, n)).tocsr()
        inlets, outlets = sorted(self.inlets), sorted(self.outlets)
        flat = ""
        if inlets or outlets:
            rule = ("from where the lines enter and leave the water" if self.hinted
                    else "as the water ran before its knots were made lakes" if self.knotted
                    else "from the inlets / outlets given")
        elif elevations is not None and len(leaves) >= 2:
            z = {k: elevations.get((id(self), k), math.nan) for k in leaves}
            known = [k for k in leaves if math.isfinite(z[k])]
            if len(known) < 2:
                off = [_xy_text(self.nodes[k]) for k in leaves if k not in known]
                raise GraphError(f"the DEM gives an elevation at {len(known)} of the "
                                 f"{len(leaves)} free ends of the water, two are needed: "
                                 f"{', '.join(off[:4])}{' …' if len(off) > 4 else ''} lie off "
                                 "it or on no-data (check that the DEM covers the water, in "
                                 "its CRS), or give inlet_xy / outlet_xy")
            top, low = max(known, key=lambda k: z[k]), min(known, key=lambda k: z[k])
            if z[top] > z[low]:
                inlets, outlets = [top], [low]
                inlets += [k for k in sorted(self.tributaries) if k in leaves
                           and k not in inlets + outlets]      # a stub the DEM rises along
                rule = "from the DEM (highest free end in, lowest out)"
            else:                          # a DEM flat at the free ends cannot tell
                flat = f"the DEM is flat at the free ends ({z[top]:g} m), so "
        if not inlets and not outlets:
            if len(leaves) < 2:
                raise GraphError(f"the water near {_xy_text(self.nodes[0])} has "
                                 f"fewer than two free ends: no way in and out")
            d0 = dijkstra(adj, indices=leaves[0])
            a = max(leaves, key=lambda k: d0[k])
            da = dijkstra(adj, indices=a)
            # not an end beside a (the other channel round an island the edge cuts open)
            b = max([k for k in leaves if k != a and not self._beside(k, a)] or leaves,
                    key=lambda k: da[k])
            wa, wb = self._end_width(a), self._end_width(b)
            inlets, outlets = ([a], [b]) if wa <= wb else ([b], [a])
            rule = (f"{flat}the longest path along the axes, from its narrower end "
                    f"({min(wa, wb):.1f} m) to its wider ({max(wa, wb):.1f} m)")
        if rule not in ("from the inlets / outlets given",
                        "as the water ran before its knots were made lakes",
                        "from where the lines enter and leave the water"):
            self._same_end(leaves, inlets, outlets)
        if not outlets:          # water enters where it is said to; it leaves by the rest
            outlets = [k for k in leaves if k not in inlets]
        if not inlets:
            inlets = [k for k in leaves if k not in outlets]
        if (not inlets or not outlets) and self.hinted:
            self.inlets, self.outlets, self.hinted = set(), set(), False
            return ("the lines' ends gave no way in and out: "   # (every end one kind)
                    + self.orient(elevations))
        if (not inlets or not outlets) and self.knotted:
            self.inlets, self.outlets, self.knotted = set(), set(), False
            return ("the ways the water ran before its knots were made lakes gave no way in "
                    "and out: " + self.orient(elevations))
        if not inlets or not outlets:
            raise GraphError(f"the water near {_xy_text(self.nodes[0])} needs a free "
                             f"end where water comes in and another where it leaves")
        phi = _harmonic(adj, inlets, outlets)
        self.inlets, self.outlets = set(inlets), set(outlets)
        for c in self.channels:
            if c.directed:
                continue
            tie = abs(phi[c.a] - phi[c.b]) <= 1e-9 * max(1.0, c.length)
            if tie:    # a side channel as far from the inlet as from the outlet: it flows in
                if deg[c.b] == 1 and c.b not in self.outlets:
                    c.flip()
            elif phi[c.a] > phi[c.b]:
                c.flip()
            c.directed = True
        self._fix_junctions(adj)
        self.rule = rule
        return rule

    def _same_end(self, leaves: list[int], inlets: list[int], outlets: list[int]) -> None:
        """Free ends beside the chosen outlet (inlet), nearer to it than the two ends' widths
        together, are outlets (inlets) too, and those beside them: the channels on either
        side of islands the data's edge cuts open leave (enter) together; left to the
        distances along the axes, the one beside the outlet was taken for a tributary."""
        grew = True
        while grew:              # (and beside those: the channels between several islands)
            grew = False
            for k in leaves:
                if k in inlets or k in outlets:
                    continue
                for group in (outlets, inlets):
                    if any(self._beside(k, e) for e in group):
                        group.append(k)
                        grew = True
                        break

    def end_groups(self) -> int:
        """How many ends of the water its free ends make (free ends beside each other,
        :meth:`_beside`, and those beside them are one)."""
        ends = [n for _, n, _ in self.free_ends()]
        group = {n: n for n in ends}
        for i, k in enumerate(ends):
            for e in ends[i + 1:]:
                if self._beside(k, e):
                    a, b = group[k], group[e]
                    group = {n: (a if g == b else g) for n, g in group.items()}
        return len(set(group.values()))

    def _beside(self, k: int, e: int) -> bool:
        """Whether free ends k and e lie nearer than their widths together (one end of the
        water, parted by an island)."""
        return k != e and bool(np.hypot(*(self.nodes[k] - self.nodes[e]))
                               <= self._end_width(k) + self._end_width(e))

    def _fix_junctions(self, adj) -> None:
        """Where a junction only receives (or only sends) water, which the distances along a
        braided network's loops can make, turn the channel there that leads nearest to a
        free end water leaves by (comes in by); until every junction has both."""
        deg = self.degree()
        for _ in range(4 * len(self.channels)):
            sinks = {c.b for c in self.channels if deg[c.b] == 1}
            sources = {c.a for c in self.channels if deg[c.a] == 1}
            d_out, d_in = _distance_from(adj, sinks), _distance_from(adj, sources)
            ins = np.zeros(len(self.nodes), int)
            outs = np.zeros(len(self.nodes), int)
            for c in self.channels:
                outs[c.a] += 1
                ins[c.b] += 1
            bad = [j for j in range(len(self.nodes))
                   if deg[j] > 1 and (ins[j] == 0 or outs[j] == 0)]
            if not bad:
                return
            j = bad[0]
            if outs[j] == 0:    # a sink: send water on towards the nearest way out
                c = min((c for c in self.channels if c.b == j), key=lambda c: d_out[c.a])
            else:               # a source: take water from the nearest way in
                c = min((c for c in self.channels if c.a == j), key=lambda c: d_in[c.b])
            c.flip()

    def _end_width(self, node: int) -> float:
        """The width [m] of the channel at a free end: the median over the fifth of its
        axis next to that end (but the last tenth, where the axis leaves the water)."""
        c = next(c for c in self.channels if node in (c.a, c.b))
        s = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(c.points, axis=0).T))])
        lo, hi = (0.1, 0.3) if node == c.a else (0.7, 0.9)
        return float(np.median(np.interp(np.linspace(lo, hi, 11) * s[-1], s, c.widths)))


BASIN_SPUR_WIDTHS = 3.0
"""A skeleton channel from a junction to a dead end (its free end neither on the data's edge
nor given as an inlet or outlet) no longer than this many widths of the channel it leaves
(counted from that channel's bank) is a basin (a harbour, a dock, a marina, a side basin),
not a tributary: it is dropped from the axes and the builder makes it still water
(:mod:`riverflow.hydro._basins`). With a DEM, a spur whose water the DEM has rising towards
its end by TRIBUTARY_RISE_M or more is a tributary and stays a channel."""
TRIBUTARY_RISE_M = 0.5
"""With a DEM (``dem=``), a short dead-end channel (BASIN_SPUR_WIDTHS) whose ground rises by at
least this much [m] from the junction to its end is a tributary, not a basin (a basin's water
is level with its river's)."""


def _spur_rise(c: _Channel, end: int, junction: int, nodes: np.ndarray, heights) -> float:
    """How much the DEM rises [m] from a spur's junction to its end, both read in the water:
    at the junction node (the main channel's axis) and at the spur's last axis point at least
    its half width short of its end (a skeleton's end reaches into the corner of the shore,
    where a DEM cell may hold the bank's ground). NaN where the DEM has no value."""
    pts = c.points if c.b == end else c.points[::-1]
    widths = c.widths if c.b == end else c.widths[::-1]
    back = np.concatenate([np.cumsum(np.hypot(*np.diff(pts, axis=0).T)[::-1])[::-1], [0.0]])
    inner = np.flatnonzero(back >= 0.5 * widths)
    at = pts[inner[-1]] if len(inner) else pts[len(pts) // 2]
    z = heights(np.vstack([nodes[junction], at]))
    return float(z[1] - z[0])


def _leaving(c: _Channel, node: int, reach_m: float) -> np.ndarray:
    """The unit direction in which channel ``c`` leaves ``node`` (one of its ends): towards
    its point ``reach_m`` along it (its end, if shorter)."""
    pts = c.points if c.a == node else c.points[::-1]
    s = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(pts, axis=0).T))])
    at = min(reach_m, float(s[-1]))
    q = np.array([np.interp(at, s, pts[:, 0]), np.interp(at, s, pts[:, 1])]) - pts[0]
    return q / max(float(np.hypot(*q)), 1e-12)


def _passes_by(net: _Network, spur: _Channel, junction: int, width_m: float) -> bool:
    """Whether the water at ``junction`` goes on past a dead end ``spur``: two of the other
    channels there leave it in directions more than a right angle apart (a channel running
    through, the dead end off its side: a basin). Where they all leave on one side (the
    channels round an island, a dead end the end of the water upstream or downstream of
    them: the data's end), the dead end is where the water comes in or goes out."""
    dirs = [_leaving(d, junction, width_m) for d in net.channels
            if d is not spur and junction in (d.a, d.b)]
    return any(float(dirs[i] @ dirs[j]) < 0.0
               for i in range(len(dirs)) for j in range(i + 1, len(dirs)))


def _end_beside(net: _Network, c: _Channel, end: int, deg: np.ndarray) -> bool:
    """Whether the free end ``end`` of ``c`` is part of one of the water's ends, parted from
    the rest by a spit of land (an island joined to the bank there): it lies beside another
    free end (:meth:`_Network._beside`) and runs into a straight edge of the outline across
    it (at least half its width long, at least 45° to its axis: the water's end cut across,
    not a pocket's tip tapering shut)."""
    # (only free ends nearer than their channels' widest and this one's together can be
    # beside it: London's hundreds of free ends, each asked of every other, took 10 s)
    widest = {n: float(d.widths.max()) for d in net.channels for n in (d.a, d.b) if deg[n] == 1}
    ends = np.array(sorted(widest), np.int64)
    reach = np.array([widest[n] for n in ends.tolist()]) + widest[end]
    near = ends[np.hypot(*(net.nodes[ends] - net.nodes[end]).T) <= reach]
    if not any(k not in (c.a, c.b) and net._beside(end, k) for k in near.tolist()):
        return False
    ring = np.asarray(net.water.exterior.coords)
    segs = shapely.linestrings(np.stack([ring[:-1], ring[1:]], axis=1))
    i = int(np.argmin(shapely.distance(segs, shapely.Point(net.nodes[end]))))
    edge = ring[i + 1] - ring[i]
    length = float(np.hypot(*edge))
    axis = _leaving(c, end, 0.5 * net._end_width(end))
    return (length >= 0.5 * net._end_width(end)
            and abs(float(edge @ axis)) <= math.cos(math.radians(45.0)) * length)


def _drop_basin_spurs(net: _Network, frame, tolerance_m: float, report: RiverImport,
                      heights=None, beside: bool = True) -> bool:
    """Drop the skeleton's spurs into basins (BASIN_SPUR_WIDTHS); where the junction they left
    is then between two channels only, those two become one. Reported as notes. ``heights``:
    the DEM's heights at points (N, 2) [m], or None: a spur the DEM rises along
    (TRIBUTARY_RISE_M) is kept, a tributary (noted). With ``beside``, a spur whose end is
    part of one of the water's ends (:func:`_end_beside`) is kept; returns whether one was."""
    edge = frame.boundary if frame is not None else None
    kept = False
    for _ in range(len(net.channels)):
        deg = net.degree()
        spur = None
        for c in net.channels:
            if c.source != "skeleton":
                continue
            for end, other in ((c.a, c.b), (c.b, c.a)):
                if deg[end] != 1 or deg[other] < 3 or end in net.inlets or end in net.outlets:
                    continue
                p = net.nodes[end]
                if edge is not None and edge.distance(shapely.Point(p)) <= max(
                        4.0 * tolerance_m, 0.05 * c.width):
                    continue            # an open end: the data's edge cuts the water there
                if end in net.tributaries:
                    continue
                if beside and _end_beside(net, c, end, deg):
                    kept = True
                    continue
                main = max((d.width for d in net.channels
                            if d is not c and other in (d.a, d.b)), default=0.0)
                if not _passes_by(net, c, other, main):
                    continue            # the water goes on from its end only: a channel's end
                if c.length - 0.5 * main <= BASIN_SPUR_WIDTHS * main:
                    rise = (_spur_rise(c, end, other, net.nodes, heights)
                            if heights is not None else math.nan)
                    if rise >= TRIBUTARY_RISE_M:
                        x, y = net.nodes[end]
                        report.notes.append(
                            f"{c.name}: a dead end {c.length:.1f} m long off the channel at "
                            f"({net.nodes[other][0]:.1f}, {net.nodes[other][1]:.1f}), ending "
                            f"at ({x:.1f}, {y:.1f}), is a tributary, not a basin: the DEM "
                            f"rises {rise:.2f} m along it")
                        net.tributaries.add(end)
                        continue
                    spur = c
                    break
            if spur is not None:
                break
        if spur is None:
            return kept
        junction = spur.a if deg[spur.a] > 1 else spur.b
        end = spur.b if junction == spur.a else spur.a
        x, y = net.nodes[end]
        report.notes.append(
            f"{spur.name}: a dead end {spur.length:.1f} m long off the channel at "
            f"({net.nodes[junction][0]:.1f}, {net.nodes[junction][1]:.1f}), ending at "
            f"({x:.1f}, {y:.1f}), is a basin (a harbour, dock or side basin: still water), not "
            f"a channel (give an inlet there, or lines=, to keep it a channel)")
        net.channels.remove(spur)
        net.basin_axes.append(_beyond(spur, junction, 0.5 * max(
            (d.width for d in net.channels if junction in (d.a, d.b)), default=0.0)))
        _join_at(net, junction)
    return kept


SIDE_FRACTION = 0.25
"""Channels no wider than this fraction of the channels they open off, within
BASIN_SPUR_WIDTHS of those channels' widths of them and with no way in or out but through
them, are side water (:func:`_drop_side_waters`): still, basins."""


def _drop_side_waters(net: _Network, frame, tolerance_m: float, report: RiverImport,
                      beside: bool = True) -> None:
    """Drop the skeleton's channels of side water (:func:`_side_water`: a marina's slips and
    the water joined behind its piers, docks, a creek's branches): still water with one or
    several mouths on the river, which the builder finds as basins beyond the river's bank
    (:mod:`riverflow.hydro._basins`). As channels the network gave it a share of the
    discharge by width through a maze of narrow channels, and a source at each dead end,
    whose ψ London's marina could not make add up. Noted; the junctions left with two
    channels join them (:func:`_join_at`)."""
    edge = frame.boundary if frame is not None else None
    while True:
        deg = net.degree()
        found = _side_water(net, deg, edge, tolerance_m, beside)
        if found is None:
            return
        side, attach, main, far = found
        at = [net.nodes[n].copy() for n in attach]
        x, y = at[0]
        report.notes.append(
            f"{side[0].name}" + (f" and {len(side) - 1} more channels" if len(side) > 1 else "")
            + f": side water off the channel at ({x:.1f}, {y:.1f})"
            + (f" and {len(attach) - 1} more junctions" if len(attach) > 1 else "")
            + f", reaching {far:.1f} m along its axes, no wider than {SIDE_FRACTION:g} of "
            f"the channel's {main:.1f} m and no way in or out but through it, is still water "
            f"(basins: a marina, docks, creeks), not channels (give an inlet there, or "
            f"lines=, to keep them channels)")
        for c in side:
            net.channels.remove(c)
            for end, other in ((c.b, c.a), (c.a, c.b)):
                if deg[end] == 1:          # a dead end's axis: a basin (a backwater's too)
                    net.basin_axes.append(
                        _beyond(c, other, 0.5 * main) if other in attach
                        else (c.points, c.widths) if c.b == end
                        else (c.points[::-1], c.widths[::-1]))
        for p in at:
            hit = np.flatnonzero(np.all(net.nodes == p, axis=1))
            if len(hit):
                _join_at(net, int(hit[0]))


def _side_water(net: _Network, deg: np.ndarray, edge, tolerance_m: float, beside: bool):
    """The first side water of ``net``, (channels, junctions it opens off, the narrowest
    channel there [m], how far it reaches along its axes from them [m]), or None.
    Side water is a connected set of skeleton channels (joined at nodes no wider channel
    touches) whose narrowest water away from its ends (:func:`_narrowest`) is at most
    SIDE_FRACTION of every channel it opens off (a braid's arm is as wide as the arms beside
    it), at junctions where two of those meet (the channel runs on past it), with dead ends
    where it opens off more than one (else it is an arm the water runs through, however
    narrow: a side channel behind an island), none of its free ends a way in or out (on
    the data's edge, an inlet, an outlet, a tributary, with ``beside`` part of one of the
    water's ends: :func:`_end_beside`), and no point of it farther along its axes from those
    junctions than BASIN_SPUR_WIDTHS of their channels' widths beyond their bank."""
    width = {id(c): c.width for c in net.channels}
    narrowest = {id(c): _narrowest(c, deg) for c in net.channels}
    real = net.inlets | net.outlets | net.tributaries
    for cut in sorted({SIDE_FRACTION * w for w in width.values()}, reverse=True):
        narrow = [c for c in net.channels if narrowest[id(c)] <= cut and c.source == "skeleton"]
        mine = {id(c) for c in narrow}
        wide_at: dict[int, list[float]] = {}
        for c in net.channels:
            if id(c) not in mine:
                for n in (c.a, c.b):
                    wide_at.setdefault(n, []).append(width[id(c)])
        for side in _joined(narrow, wide_at):
            nodes = sorted({n for c in side for n in (c.a, c.b)})
            attach = [n for n in nodes if n in wide_at]
            if not attach or not all(_runs_past(net, n, mine) for n in attach):
                continue              # (off nothing, or where the water comes in or goes out)
            main = min(min(wide_at[n]) for n in attach)
            ends = [(c, n) for c in side for n in (c.a, c.b) if deg[n] == 1]
            if (not ends and len(attach) > 1          # an arm the water runs through
                    or max(narrowest[id(c)] for c in side) > SIDE_FRACTION * main
                    or any(n in real for _, n in ends)
                    or edge is not None and any(
                        edge.distance(shapely.Point(net.nodes[n])) <= max(
                            4.0 * tolerance_m, 0.05 * width[id(c)]) for c, n in ends)
                    or beside and any(_end_beside(net, c, n, deg) for c, n in ends)):
                continue
            index = {n: k for k, n in enumerate(nodes)}
            rows = [index[c.a] for c in side] + [index[c.b] for c in side]
            adj = coo_matrix(([c.length for c in side] * 2, (rows, rows[len(side):]
                                                              + rows[:len(side)])),
                             shape=(len(nodes), len(nodes))).tocsr()
            d = np.min(np.atleast_2d(dijkstra(adj, indices=[index[n] for n in attach])), axis=0)
            # (the farthest point of each channel from the junctions, along the axes)
            far = max(0.5 * (d[index[c.a]] + d[index[c.b]] + c.length) for c in side)
            if far - 0.5 * main <= BASIN_SPUR_WIDTHS * main:
                return side, attach, main, far
    return None


def _runs_past(net: _Network, junction: int, ignore: set) -> bool:
    """Whether the water at ``junction`` runs on past the channels ``ignore`` (ids): two of
    the others leave it more than a right angle apart (:func:`_passes_by`)."""
    others = [d for d in net.channels if id(d) not in ignore and junction in (d.a, d.b)]
    reach = max((d.width for d in others), default=0.0)
    dirs = [_leaving(d, junction, reach) for d in others]
    return any(float(dirs[i] @ dirs[j]) < 0.0
               for i in range(len(dirs)) for j in range(i + 1, len(dirs)))


def _joined(channels: list[_Channel], apart: dict) -> list[list[_Channel]]:
    """``channels`` in groups joined at their nodes, but at the nodes in ``apart``."""
    parent = list(range(len(channels)))

    def root(i: int) -> int:
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    first: dict[int, int] = {}
    for i, c in enumerate(channels):
        for n in (c.a, c.b):
            if n not in apart:
                parent[root(i)] = root(first.setdefault(n, i))
    groups: dict[int, list[_Channel]] = {}
    for i, c in enumerate(channels):
        groups.setdefault(root(i), []).append(c)
    return list(groups.values())


def _narrowest(c: _Channel, deg: np.ndarray) -> float:
    """The narrowest width [m] of a channel away from its ends: outside the inscribed circles
    of its junctions (the skeleton's way from a wide river's axis into a narrow mouth runs
    through the river's water first) and half its width from a free end (where the skeleton
    runs into the shore's corner); its width where none of it is."""
    r = [0.5 * (c.widths[k] if deg[n] > 1 else c.width) for k, n in ((0, c.a), (-1, c.b))]
    out = ((np.hypot(*(c.points - c.points[0]).T) > r[0])
           & (np.hypot(*(c.points - c.points[-1]).T) > r[1]))
    return float(c.widths[out].min()) if out.any() else c.width


def _join_at(net: _Network, junction: int) -> None:
    """After a channel off ``junction`` was removed: the two channels left there joined into
    one, the nodes numbered anew."""
    rest = [c for c in net.channels if junction in (c.a, c.b)]
    if len(rest) == 2 and rest[0] is not rest[1]:
        one, two = rest
        if one.b != junction:
            one.flip()
        if two.a != junction:
            two.flip()
        one.points = np.vstack([one.points, two.points[1:]])
        one.widths = np.concatenate([one.widths, two.widths[1:]])
        one.b = two.b
        net.channels.remove(two)
    used = sorted({n for c in net.channels for n in (c.a, c.b)})
    new = {n: i for i, n in enumerate(used)}
    for c in net.channels:
        c.a, c.b = new[c.a], new[c.b]
    net.nodes = net.nodes[used]
    net.inlets = {new[n] for n in net.inlets if n in new}
    net.outlets = {new[n] for n in net.outlets if n in new}
    net.tributaries = {new[n] for n in net.tributaries if n in new}


def _drop_stubs(net: _Network, report: RiverImport, open_water=None) -> None:
    """Drop channels from a junction to a free end opening into ``open_water`` (a polygon)
    whose ends lie closer than JOIN_FRACTION of their widths (a fork just inside a wide mouth
    cut straight across: the builder cannot tell its start from its end) or that are shorter
    than half their widest (a lake's shore cuts such a channel off,
    :func:`riverflow.hydro._lakes.cut_branches`); the junction's other channels reach the
    open water."""
    from riverflow.hydro.builder import JOIN_FRACTION

    def stubby(c: _Channel, deg) -> bool:
        if sorted((deg[c.a], deg[c.b]))[0] != 1 or max(deg[c.a], deg[c.b]) < 3:
            return False
        end = c.a if deg[c.a] == 1 else c.b
        if not (end in net.outlets
                and open_water.distance(shapely.Point(net.nodes[end])) <= c.width):
            return False
        return (c.length < 0.5 * float(c.widths.max())
                or np.hypot(*(c.points[-1] - c.points[0]))
                <= JOIN_FRACTION * min(float(c.widths[0]), float(c.widths[-1])))

    if open_water is None:
        return
    while True:
        deg = net.degree()
        stub = next((c for c in net.channels if stubby(c, deg)), None)
        if stub is None:
            return
        junction = stub.a if deg[stub.a] > 1 else stub.b
        x, y = net.nodes[junction]
        report.repair(stub.name, None, None,
                      f"a channel {stub.length:.1f} m long from the junction at ({x:.1f}, "
                      f"{y:.1f}) to a free end, short beside its width ({stub.width:.1f} "
                      f"m): left out (the junction's other channels reach the water's end)")
        net.channels.remove(stub)
        _join_at(net, junction)


def _lead_into_mouths(net: _Network, report: RiverImport, open_water, tolerance_m: float
                      ) -> None:
    """Lead each free end of ``net`` off ``open_water`` that lies nearer the free end of a
    wider channel opening into it (a mouth, an outlet) than half their widths together into
    that channel: its axis goes on straight to the point of the wider channel's axis nearest
    it, but at least half the mouth's width back from the mouth, where the wider channel is
    split (a junction). A side channel leaving a mouth's flared bay has no axis joining the
    mouth's (the skeleton puts no point on the mouth, its open end): left alone, its end
    would be a source in the delta, beside the mouth (two ends the builder finds not
    meeting). Only where that straight piece lies in the water; reported. (Two mouths side
    by side meet through the open water: :func:`riverflow.hydro.builder._find_junctions`.)"""
    if open_water is None:
        return
    water = net.water.buffer(tolerance_m)
    shapely.prepare(water)
    done: set[tuple[float, float]] = set()        # (free ends tried)
    while True:
        deg = net.degree()
        ends = [(c, n, (0 if n == c.a else -1)) for c in net.channels for n in (c.a, c.b)
                if deg[n] == 1 and c.source == "skeleton"
                and tuple(net.nodes[n]) not in done]
        pair = None
        for cm, m, em in ends:
            wm = float(cm.widths[em])
            if m not in net.outlets or open_water.distance(shapely.Point(net.nodes[m])) > max(
                    0.5 * wm, tolerance_m):
                continue
            for c, n, e in ends:
                w = float(c.widths[e])
                if c is cm or w > wm or n in net.outlets or not (
                        np.hypot(*(net.nodes[n] - net.nodes[m])) < 0.5 * (w + wm)):
                    continue
                pair = (cm, m, wm, c, n, e)
                break
            if pair is not None:
                break
        if pair is None:
            return
        cm, m, wm, c, n, e = pair
        done.add(tuple(net.nodes[n]))
        # the wider channel drawn towards its mouth; the junction on it
        p, w = (cm.points, cm.widths) if cm.b == m else (cm.points[::-1], cm.widths[::-1])
        line = shapely.LineString(p)
        at = min(line.project(shapely.Point(net.nodes[n])),
                 line.length - 0.5 * float(w[-1]))
        if not at > 0.0:
            continue
        j = np.asarray(line.interpolate(at).coords[0])
        lead = shapely.LineString([net.nodes[n], j])
        if not water.covers(lead):
            continue
        s = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(p, axis=0).T))])
        k = int(np.searchsorted(s, at, side="right"))
        wj = float(np.interp(at, s, w))
        up = (np.vstack([p[:k], j]), np.concatenate([w[:k], [wj]]))
        down = (np.vstack([j, p[k:]]), np.concatenate([[wj], w[k:]]))
        other = cm.a if cm.b == m else cm.b
        jn = len(net.nodes)
        net.nodes = np.vstack([net.nodes, j])
        cm.points, cm.widths, cm.a, cm.b = up[0], up[1], other, jn
        net.channels.append(_Channel(down[0], down[1], cm.source, jn, m, f"{cm.name} mouth"))
        x, y = net.nodes[n]
        if e == 0:
            c.points = np.vstack([j, c.points])
            c.widths = np.concatenate([[c.widths[0]], c.widths])
            c.a = jn
        else:
            c.points = np.vstack([c.points, j])
            c.widths = np.concatenate([c.widths, [c.widths[-1]]])
            c.b = jn
        net.inlets.discard(n)
        net.outlets.discard(n)
        report.repair(c.name, None, None,
                      f"its free end at ({x:.1f}, {y:.1f}) lies beside the mouth of "
                      f"{cm.name!r} ({wm:.1f} m wide) into open water: led on "
                      f"{lead.length:.1f} m into that channel, {line.length - at:.1f} m from "
                      f"its mouth")
        _join_at(net, n)        # (the end left no channel: the nodes numbered anew)


def _beyond(c: _Channel, junction: int, reach_m: float) -> tuple[np.ndarray, np.ndarray]:
    """(points, widths) of channel ``c`` from ``reach_m`` along it from ``junction`` (one of
    its ends) to its other end: a spur's axis beyond the bank of the channel it leaves."""
    pts, widths = (c.points, c.widths) if c.a == junction else (c.points[::-1], c.widths[::-1])
    s = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(pts, axis=0).T))])
    at = min(reach_m, 0.5 * float(s[-1]))
    k = int(np.searchsorted(s, at, side="right"))
    start = np.array([np.interp(at, s, pts[:, 0]), np.interp(at, s, pts[:, 1])])
    return (np.vstack([start, pts[k:]]),
            np.concatenate([[np.interp(at, s, widths)], widths[k:]]))


def _harmonic(adj, inlets: list[int], outlets: list[int]) -> np.ndarray:
    """The potential along the axes that is 0 at the inlets, 1 at the outlets and at every
    other node the average of its neighbours' weighted by 1 / channel length (a harmonic
    function of the network: by the maximum principle every junction has a neighbour above
    and one below it, so flowing up the potential no junction only receives or only sends
    water, and nothing flows round a loop). Free ends not given are as their junction."""
    from scipy.sparse import csr_matrix, diags
    from scipy.sparse.linalg import spsolve

    n = adj.shape[0]
    g = adj.copy().tocsr()
    g.data = 1.0 / np.maximum(g.data, 1e-9)
    lap = (diags(np.asarray(g.sum(axis=1)).ravel()) - g).tocsr()
    fixed = np.zeros(n, bool)
    value = np.zeros(n)
    fixed[inlets] = True
    fixed[outlets] = True
    value[outlets] = 1.0
    free = np.flatnonzero(~fixed)
    phi = value.copy()
    if len(free):
        a = lap[free][:, free]
        b = -(lap[free][:, np.flatnonzero(fixed)] @ value[fixed])
        a = csr_matrix(a)
        with np.errstate(all="ignore"):
            phi[free] = spsolve(a, b) if a.shape[0] > 1 else b / a.toarray().ravel()
    if not np.isfinite(phi).all():
        raise GraphError("part of the water is not connected to any inlet or outlet")
    return phi


def _distance_from(adj, nodes) -> np.ndarray:
    """Shortest distance along the axes from any of ``nodes`` (inf where none is)."""
    if not nodes:
        return np.full(adj.shape[0], np.inf)
    return np.min(np.atleast_2d(dijkstra(adj, indices=sorted(nodes))), axis=0)


def _channels(part, k: int, lines: list, tolerance_m: float, report: RiverImport,
              frame=None, forced=(), ends=None, dead=None, collapsed=None) -> _Network:
    """The channels of one water polygon: along the lines in it, else its skeleton
    (``dead``: tips of dead ends that are no ends of the water, :func:`skeleton`;
    ``collapsed``: :func:`_skeleton_channels`')."""
    inside = [g for g in lines if g.intersects(part)]
    if inside:
        return _line_channels(part, k, inside, tolerance_m, report, forced, frame)
    if lines:
        report.notes.append(f"water body {k}: no line runs through it: its axes are its skeleton")
    return _skeleton_channels(part, k, tolerance_m, report, frame, forced, ends, dead,
                              collapsed)


def _split_holes(part, enclosed=None, forced=(), open_edge=None):
    """(water with the holes that split channels, free islands): a hole is a free island when
    it is small beside the water around it (ISLAND_SPLIT_WIDTHS: its gap to the outer shore,
    not counting ``open_edge``, where the data's edge cuts the water), or, with ``enclosed``
    (a polygon), when no loop of lines goes round it."""
    banks = part.exterior
    if open_edge is not None:
        banks = shapely.difference(banks, shapely.buffer(open_edge, 1e-6 * math.sqrt(
            part.area) + 1e-9, cap_style="flat"))
        banks = part.exterior if banks.is_empty else banks
    keep, free = [], []
    for i, hole in enumerate(part.interiors):
        poly = shapely.Polygon(hole)
        if enclosed is not None:
            split = enclosed.contains(poly.representative_point())
        else:
            # the water beside it: the gap to the outer shore (a cluster of small islands
            # close together in a wide river are free islands, not channels between them)
            gap = poly.distance(banks)
            split = 2.0 * shapely.minimum_bounding_radius(poly) >= ISLAND_SPLIT_WIDTHS * gap
        if any(poly.contains(shapely.Point(p)) for p in forced):
            split = False
        (keep if split else free).append(hole if split else poly)
    return shapely.Polygon(part.exterior, keep), free


def _line_channels(part, k: int, lines: list, tolerance_m: float, report, forced=(),
                   frame=None) -> _Network:
    """Channels along the given lines, cut to the water and noded where they meet; a line
    that ends (or starts) in the water short of its ends is carried on along the water's
    skeleton (:func:`_carry_on`)."""
    merged = shapely.line_merge(shapely.node(shapely.MultiLineString(
        [np.asarray(g.coords) for g in lines])), directed=True)
    # free islands lie inside their channel: the lines are cut by the outer shore only
    pieces = [p for p in shapely.get_parts(shapely.intersection(merged,
                                                                shapely.Polygon(part.exterior)))
              if p.geom_type == "LineString" and p.length > tolerance_m]
    # keep each piece's direction: its points as the original line runs
    directed = []
    for p in pieces:
        c = np.asarray(p.coords)
        src = min(lines, key=lambda g: g.distance(shapely.Point(c[len(c) // 2])))
        if src.project(shapely.Point(c[-1])) < src.project(shapely.Point(c[0])):
            c = c[::-1]
        directed.append(shapely.LineString(c))
    if not directed:
        raise GraphError(f"water body {k}: the lines cross it but no piece lies inside it")
    faces = shapely.union_all(list(shapely.get_parts(shapely.polygonize(directed))))
    water, free = _split_holes(part, faces if not faces.is_empty else shapely.Polygon(), forced)
    merged = shapely.line_merge(shapely.MultiLineString([np.asarray(g.coords) for g in directed]),
                                directed=True)
    segs = [np.asarray(g.coords) for g in shapely.get_parts(merged)]
    segs = _without_stubs(segs, water, tolerance_m, report, k)
    key: dict[tuple[float, float], int] = {}

    def node(p) -> int:
        t = (round(float(p[0]), 6), round(float(p[1]), 6))
        return key.setdefault(t, len(key))

    channels = []
    for i, c in enumerate(segs):
        widths = _chord_widths(c, water)
        channels.append(_Channel(c, widths, "lines", node(c[0]), node(c[-1]),
                                 f"water {k} line {i}"))
    nodes = np.array(sorted(key, key=key.get), dtype=np.float64).reshape(-1, 2)
    net = _Network(water, free, channels, nodes)
    _carry_on(net, water, k, tolerance_m, report, frame)
    _extend_free_ends(net, water)
    return net


def _without_stubs(segs: list[np.ndarray], water, tolerance_m: float, report, k: int
                   ) -> list[np.ndarray]:
    """The line pieces without stubs: a piece from the outer shore to a junction of the
    others, shorter than the water is wide across it (its median chord): a stream's line
    come over the bank of a wider river to meet the river's line, whose water is the
    river's (it was a channel as wide as the river, across it). The others are joined anew
    where only two of them meet (reported)."""
    ends = np.array([p for c in segs for p in (c[0], c[-1])]).reshape(-1, 2)
    key = [tuple(np.round(p, 6)) for p in ends]
    count = {t: key.count(t) for t in set(key)}
    shore = water.exterior
    keep = []
    for i, c in enumerate(segs):
        a, b = key[2 * i], key[2 * i + 1]
        free = [p for p, t in ((c[0], a), (c[-1], b)) if count[t] == 1]
        joined = [t for t in (a, b) if count[t] >= 3]
        length = float(np.hypot(*np.diff(c, axis=0).T).sum())
        if (len(free) == 1 and joined and shore.distance(shapely.Point(free[0])) <= tolerance_m
                and length < float(np.median(_chord_widths(c, water)))):
            report.notes.append(f"water body {k}: a line piece {length:.0f} m long from the shore "
                                f"at ({free[0][0]:.1f}, {free[0][1]:.1f}) to the lines' junction, "
                                f"across water wider than it is long, is a stream come over the "
                                f"bank: left out (its water is the river's)")
            continue
        keep.append(c)
    if len(keep) == len(segs):
        return segs
    merged = shapely.line_merge(shapely.MultiLineString(keep), directed=True)
    return [np.asarray(g.coords) for g in shapely.get_parts(merged)]


def _carry_on(net: _Network, water, k: int, tolerance_m: float, report, frame) -> None:
    """Each free end of the lines with no chord across the water within two widths of it (a
    river's line that stops in its estuary, short of the water's end: Porto's Douro) carried
    on along the water's skeleton: from the skeleton's point nearest the end, along its
    chains to the free end of the skeleton that is farthest along them, leaving the way the
    line runs out (reported). An end whose way on runs into the lines' other ways on is left
    as it is."""
    from riverflow.hydro.builder import _end_chord

    eps = max(1e-3, 1e-3 * tolerance_m)
    deg = net.degree()
    short = []
    for c in net.channels:
        for at_start in (True, False):
            if deg[c.a if at_start else c.b] == 1 and _end_chord(
                    water, c.points, float(np.median(c.widths)), at_start, eps) is None:
                short.append((c, at_start))
    if not short:
        return
    chains, nodes, collapsed = skeleton(water, tolerance_m, frame)
    if collapsed is not None or not chains:
        return
    n = len(nodes)
    lengths = [float(np.hypot(*np.diff(p, axis=0).T).sum()) for p, _, _, _ in chains]
    a = np.array([c[2] for c in chains] + [c[3] for c in chains])
    b = np.array([c[3] for c in chains] + [c[2] for c in chains])
    cost = np.array(lengths * 2) + 1e-9
    leaves = np.flatnonzero(np.bincount(a, minlength=n) == 1)
    added = []
    for c, at_start in short:
        end = c.points[0] if at_start else c.points[-1]
        out = end - (c.points[1] if at_start else c.points[-2])
        out = out / max(float(np.hypot(*out)), 1e-12)
        # the skeleton's point nearest the end, and the ways on from it along its chain
        near = [(float(np.hypot(*(p - end).T).min()), i, int(np.argmin(np.hypot(*(p - end).T))))
                for i, (p, _, _, _) in enumerate(chains)]
        _, i, at = min(near)
        p, w, na, nb = chains[i]
        other = np.tile(np.arange(len(chains)) != i, 2)        # (not back along this one)
        adj = coo_matrix((cost[other], (a[other], b[other])), shape=(n, n)).tocsr()
        best = None
        for part, pw, node in ((p[at::-1], w[at::-1], na), (p[at:], w[at:], nb)):
            d, pred = dijkstra(adj, indices=node, return_predecessors=True)
            for leaf in leaves.tolist():
                if not np.isfinite(d[leaf]):
                    continue
                way, ww, cur = [part], [pw], leaf
                steps = []
                while cur != node:
                    steps.append(cur)
                    cur = int(pred[cur])
                prev = node
                for nxt in reversed(steps):
                    j = next(j for j, ch in enumerate(chains)
                             if j != i and {ch[2], ch[3]} == {prev, nxt})
                    q, qw = chains[j][0], chains[j][1]
                    if chains[j][2] != prev:
                        q, qw = q[::-1], qw[::-1]
                    way.append(q[1:])
                    ww.append(qw[1:])
                    prev = nxt
                way, ww = np.vstack(way), np.concatenate(ww)
                if len(way) < 2:
                    continue
                length = float(np.hypot(*np.diff(way, axis=0).T).sum())
                s = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(way, axis=0).T))])
                ahead = way[min(int(np.searchsorted(s, c.width)), len(way) - 1)] - end
                if ahead @ out <= 0.0 or (best is not None and length <= best[0]):
                    continue
                best = (length, way, ww)
        if best is None:
            continue
        _, way, ww = best
        line = shapely.LineString(way)
        if any(shapely.distance(line, g) < 0.5 * c.width for g in added):
            continue                    # (runs into another end's way on)
        added.append(line)
        if at_start:
            c.points = np.vstack([way[::-1], c.points])
            c.widths = np.concatenate([ww[::-1], c.widths])
            net.nodes[c.a] = way[-1]
        else:
            c.points = np.vstack([c.points, way])
            c.widths = np.concatenate([c.widths, ww])
            net.nodes[c.b] = way[-1]
        report.notes.append(f"water body {k}: {c.name} {'starts' if at_start else 'ends'} in the "
                            f"water at ({end[0]:.1f}, {end[1]:.1f}), short of its end: carried "
                            f"on {float(np.hypot(*np.diff(way, axis=0).T).sum()):.0f} m along "
                            f"the water's skeleton")


def _chord_widths(line: np.ndarray, water) -> np.ndarray:
    """Width [m] across the water at each point of a line (both banks along the normal)."""
    d = np.gradient(line, axis=0)
    t = d / np.maximum(np.hypot(*d.T), 1e-12)[:, None]
    n = np.stack([-t[:, 1], t[:, 0]], axis=1)
    reach = 2.0 * math.sqrt(water.area) + 1.0
    bound = water.boundary
    out = np.empty(len(line))
    for sign, store in ((1.0, 0), (-1.0, 1)):
        rays = shapely.linestrings(np.stack([line, line + sign * n * reach], axis=1))
        hits = shapely.intersection(rays, bound)
        for i, h in enumerate(hits):
            pts = shapely.get_coordinates(h)
            dist = np.hypot(*(pts - line[i]).T).min() if len(pts) else reach
            out[i] = dist if store == 0 else out[i] + dist
    return np.maximum(out, 1e-3)


def _skeleton_channels(part, k: int, tolerance_m: float, report, frame=None,
                       forced=(), ends=None, dead=None, collapsed=None) -> _Network:
    """Channels along the water's skeleton; holes whose loop of axes collapses become free
    islands and the skeleton is made again. ``collapsed`` ({part's WKB: points in holes},
    one reading's): the holes whose loops collapsed when the part's channels were found
    before, free from the start when they are found again (an island made free, a reading
    left out: a skeleton of 200,000 outline points less, 4 s on London's Thames; freeing
    another island only widens the water round them)."""
    key = shapely.to_wkb(part) if collapsed is not None else None
    known = tuple(collapsed.get(key, ())) if collapsed is not None else ()
    open_edge = _open_edge(part, frame, 2.0 * part.area / max(part.length, 1e-9), tolerance_m)
    water, free = _split_holes(part, None, forced, open_edge)
    if known:
        drop = [j for j, r in enumerate(water.interiors)
                if any(shapely.Polygon(r).contains(shapely.Point(p)) for p in known)]
        free += [shapely.Polygon(water.interiors[j]) for j in drop]
        water = shapely.Polygon(water.exterior, [r for j, r in enumerate(water.interiors)
                                                 if j not in drop])
    for _ in range(len(part.interiors) + 1):
        chains, nodes, collapsed_now = _skeleton_once(water, tolerance_m, frame, ends, dead)
        if collapsed_now is None:
            break
        gone = [shapely.Polygon(water.interiors[j]) for j in collapsed_now]
        free += gone
        if collapsed is not None:
            collapsed[key] = [*known, *(g.representative_point().coords[0] for g in gone)]
            known = tuple(collapsed[key])
        water = shapely.Polygon(water.exterior, [r for j, r in enumerate(water.interiors)
                                                 if j not in collapsed_now])
    channels = [_Channel(pts, w, "skeleton", a, b, f"water {k} channel {i}")
                for i, (pts, w, a, b) in enumerate(chains)]
    if not channels:        # a blob, a ring round an island: still water (_find_networks)
        return _Network(part, [], [], np.zeros((0, 2)))
    net = _Network(water, free, channels, nodes)
    _extend_free_ends(net, water)
    return net


_SKELETONS: dict[bytes, tuple] = {}
SKELETON_CACHE = 256
"""How many skeletons :func:`_skeleton_once` remembers."""


def _skeleton_once(water, tolerance_m: float, frame, ends, dead):
    """:func:`skeleton`, remembered for the last SKELETON_CACHE inputs (a reading made again,
    an island freed, finds every part of the water it did not change as it was); a copy."""
    import hashlib

    h = hashlib.blake2b(digest_size=20)
    for item in (water, frame):
        h.update(b"-" if item is None else shapely.to_wkb(item))
    for item in (ends, dead):
        h.update(b"-" if item is None else np.ascontiguousarray(item, np.float64).tobytes())
    h.update(np.float64(tolerance_m).tobytes())
    key = h.digest()
    if key not in _SKELETONS:
        if len(_SKELETONS) >= SKELETON_CACHE:
            del _SKELETONS[next(iter(_SKELETONS))]
        _SKELETONS[key] = skeleton(water, tolerance_m, frame, ends, dead)
    chains, nodes, collapsed = _SKELETONS[key]
    return ([(p.copy(), w.copy(), a, b) for p, w, a, b in chains], nodes.copy(), collapsed)


def _voronoi_edges(pts: np.ndarray) -> np.ndarray:
    """The edges of the Voronoi diagram of points (N ≥ 3, 2) [m] as segments (E, 2, 2):
    between the circumcentres of each two Delaunay triangles that share a side (Qhull's
    triangulation, ``scipy.spatial.Delaunay``: GEOS's ``voronoi_polygons`` took over a minute
    for the 200,000 outline points of London's Thames, Qhull's Voronoi diagram 3.2 s, its
    triangulation 1.8 s), an unbounded edge (a side on the hull) from its triangle's
    circumcentre outward across that side, cut at twice the points' extent beyond it (outside
    any water they outline); GEOS's where Qhull cannot start (points all in a line)."""
    from scipy.spatial import Delaunay, QhullError

    try:
        tri = Delaunay(pts, qhull_options="Qbb Qc Qz Q12")
    except QhullError:           # all in a line (a sliver's outline): GEOS's, as it was
        edges = shapely.voronoi_polygons(shapely.MultiPoint(pts), only_edges=True)
        return shapely.get_coordinates(shapely.get_parts(edges)).reshape(-1, 2, 2)
    simplices = tri.simplices
    corners = tri.points[simplices]                           # (T, 3, 2)
    a = corners[:, 1] - corners[:, 0]
    b = corners[:, 2] - corners[:, 0]
    d = 2.0 * (a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0])
    aa, bb = np.einsum("ij,ij->i", a, a), np.einsum("ij,ij->i", b, b)
    # the triangles of one Delaunay cell of more than three points on a circle (Qhull
    # merges nearly co-circular ones, then cuts the cell in triangles: they keep its
    # plane) are one Voronoi vertex, the circumcentre of the best-shaped of them
    _, cell = np.unique(tri.equations, axis=0, return_inverse=True)
    cell = cell.ravel()
    best = np.full(cell.max() + 1, -1.0)
    np.maximum.at(best, cell, np.abs(d))
    first = np.full(len(best), len(d))
    np.minimum.at(first, cell, np.where(np.abs(d) == best[cell], np.arange(len(d)), len(d)))
    with np.errstate(divide="ignore", invalid="ignore"):
        own = corners[:, 0] + np.column_stack([b[:, 1] * aa - a[:, 1] * bb,
                                               a[:, 0] * bb - b[:, 0] * aa]) / d[:, None]
    centre = own[first][cell]
    nbr = tri.neighbors                                       # opposite each corner
    t, k = np.nonzero(nbr > np.arange(len(simplices))[:, None])
    t, k = t[cell[t] != cell[nbr[t, k]]], k[cell[t] != cell[nbr[t, k]]]
    seg = np.stack([centre[t], centre[nbr[t, k]]], axis=1)
    t, k = np.nonzero(nbr < 0)
    if len(t):
        p = corners[t, (k + 1) % 3]                           # the hull side's ends
        q = corners[t, (k + 2) % 3]
        side = q - p
        n = np.column_stack([-side[:, 1], side[:, 0]]) / np.hypot(*side.T)[:, None]
        away = np.einsum("ij,ij->i", 0.5 * (p + q) - corners[t, k], n)
        n *= np.where(away < 0.0, -1.0, 1.0)[:, None]         # away from the third corner
        reach = 2.0 * float(np.hypot(*np.ptp(pts, axis=0)))
        v = centre[t]
        seg = np.concatenate([seg, np.stack([v, v + reach * n], axis=1)])
    return seg


def skeleton(water, tolerance_m: float = 0.25, frame=None, ends=None, dead=None):
    """The medial axis of a polygon as channels: ([(points (K, 2), widths (K,), start node,
    end node)], node points (N, 2), the indices of the holes whose loops collapsed or None:
    every one the diagram shows at once, each made a free island before it is made again).

    The Voronoi diagram of points along the outline (spaced a SAMPLES_PER_WIDTH-th of the
    narrowest width) has its edges inside the water along the medial axis; those are kept, the
    spurs shorter than SPUR_WIDTHS local widths pruned, junctions closer than JOIN_WIDTHS ×
    the sum of their inscribed radii merged, and the chains between junctions and ends
    simplified. Widths are twice the distance to the outline.

    The water's open ends are never pruned: where its outline runs along ``frame``'s edge
    (the data's extent: a river cut by the map's or the raster's border) over at least
    OPEN_EDGE_WIDTHS times the mean width, that piece is no bank (no outline point is put on
    it, so the axis runs straight out between the banks) and the axis's end there is kept;
    so is, for each of ``ends`` (the inlets and outlets given), the widest free end whose
    inscribed circle (grown by two sample spacings) reaches it. ``dead`` (points (N, 2)):
    tips of dead ends known to be basins; the free end nearest each is not counted among
    the water's ends when pruning leaves too few (:func:`_prune`)."""
    rings = [water.exterior, *water.interiors]
    length = sum(r.length for r in rings)
    approx_width = 2.0 * water.area / max(length, 1e-9)
    gap = approx_width
    if len(rings) > 1:       # the narrowest passage between an island and another shore
        lines = [shapely.LinearRing(r) for r in rings]
        tree = shapely.STRtree(lines)
        a, b = tree.query(lines, predicate="dwithin", distance=approx_width)
        pair = a != b
        if pair.any():
            gap = min(gap, float(shapely.distance(np.take(lines, a[pair]),
                                                  np.take(lines, b[pair])).min()))
    spacing = max(min(approx_width, 2.0 * gap) / SAMPLES_PER_WIDTH,
                  length / MAX_OUTLINE_SAMPLES, tolerance_m)
    per_ring = [np.asarray(shapely.segmentize(r, spacing).coords)[:-1] for r in rings]
    per_ring = _narrow_samples(water, rings, per_ring, spacing,
                               max(length / MAX_OUTLINE_SAMPLES, tolerance_m))
    pts = np.vstack(per_ring)
    open_edge = _open_edge(water, frame, approx_width, tolerance_m)
    banks = pts
    if open_edge is not None:
        # no outline point on it, nor on the banks' last quarter width beside it: the axis
        # runs out straight between the banks instead of bending into a corner (islands'
        # shores near it stay, and shores behind a point of land beside one piece of it,
        # whose line to it passes more than a quarter spacing inside the land); the widths
        # are read from the banks up to the edge
        outer = np.arange(len(pts)) < len(per_ring[0])
        off = shapely.distance(open_edge, shapely.points(pts))
        banks = pts[~outer | (off > 1e-6 * approx_width)]
        near = outer & (off <= 0.25 * approx_width)
        # (beside one piece: an island the edge cuts open between two is no point of land)
        at = shapely.points(pts[near])
        one = sum(shapely.distance(g, at) <= 0.25 * approx_width
                  for g in shapely.get_parts(open_edge)) == 1
        hidden = np.zeros(int(near.sum()), bool)
        hidden[one] = ~_sees(water, pts[near][one], open_edge, 0.25 * spacing)
        near[near] = ~hidden
        pts = pts[~near]
    if len(pts) < 4:
        x, y = water.representative_point().coords[0]
        raise GraphError(f"the water near ({x:.1f}, {y:.1f}): {len(pts)} points of its outline "
                         f"are banks, the rest lies on the data's edge: no channel to read")
    seg = _voronoi_edges(pts)
    inside = np.stack([shapely.contains_xy(water, seg[:, 0, 0], seg[:, 0, 1]),
                       shapely.contains_xy(water, seg[:, 1, 0], seg[:, 1, 1])], axis=1)
    ok = inside.all(axis=1)
    boundary = water.boundary
    shapely.prepare(boundary)
    ok[ok] &= ~shapely.intersects(boundary, shapely.linestrings(seg[ok]))
    if open_edge is not None:
        seg = np.concatenate([seg[ok], _out_through(seg, inside, seg[ok], open_edge, boundary,
                                                    cKDTree(pts), spacing)])
    else:
        seg = seg[ok]
    flat = np.round(seg.reshape(-1, 2), 6)
    uniq, inv = np.unique(flat, axis=0, return_inverse=True)
    inv = inv.reshape(-1, 2)
    inv = inv[inv[:, 0] != inv[:, 1]]
    radius = cKDTree(pts).query(uniq)[0]
    # adjacency
    nbr: list[dict[int, float]] = [dict() for _ in range(len(uniq))]
    step = uniq[inv[:, 0]] - uniq[inv[:, 1]]
    for a, b, d in zip(inv[:, 0].tolist(), inv[:, 1].tolist(),
                       np.hypot(step[:, 0], step[:, 1]).tolist()):
        nbr[a][b] = d
        nbr[b][a] = d
    _prune(nbr, radius, _open_ends(nbr, uniq, radius, open_edge, ends, spacing, boundary),
           uniq, dead)
    _keep_longest_piece(nbr)
    chains = _chains(nbr, uniq)
    chains, loops = _merge_junctions(chains, uniq, radius)
    collapsed = []
    for loop in loops:        # a loop round a hole collapsed: the hole becomes a free island
        ring = shapely.Polygon(uniq[loop]) if len(loop) >= 3 else shapely.Polygon()
        for j, hole in enumerate(water.interiors):
            if (j not in collapsed and ring.is_valid
                    and ring.contains(shapely.Polygon(hole).representative_point())):
                collapsed.append(j)
                break
    if collapsed:
        return [], np.zeros((0, 2)), tuple(collapsed)
    tree = cKDTree(banks)
    out = []
    ids: dict[int, int] = {}
    for chain in chains:
        p = uniq[chain]
        # (simplified by half the spacing, or by an eighth of its median inscribed radius if
        # less: by half the spacing, the axis of a channel much narrower than the spacing,
        # whose points _narrow_samples put closer, left its water)
        p = _smooth(p, radius[chain[0]], radius[chain[-1]],
                    min(spacing, 0.25 * float(np.median(radius[chain]))))
        # widths all along it, not only at the points simplification kept (a straight
        # channel keeps only its ends, which lie in the wider junctions)
        step = max(2.0 * spacing, 0.5 * float(radius[chain].min()))
        p = np.asarray(shapely.segmentize(shapely.LineString(p), step).coords)
        w = 2.0 * tree.query(p)[0]
        w = np.maximum(w, 2.0 * tolerance_m)
        a = ids.setdefault(chain[0], len(ids))
        b = ids.setdefault(chain[-1], len(ids))
        out.append((p, w, a, b))
    nodes = np.array([uniq[i] for i in sorted(ids, key=ids.get)]).reshape(-1, 2)
    return out, nodes, None


def _narrow_samples(water, rings, per_ring: list[np.ndarray], spacing: float,
                    finest: float) -> list[np.ndarray]:
    """The outline points ``per_ring`` with more where the water is narrower than
    NARROW_SAMPLES × ``spacing``: a side channel or a tributary far narrower than the water's
    mean width, whose skeleton the points at ``spacing`` do not hold (its Voronoi edges
    cross its banks: the channel was lost, its water left to the nearest axis as a bank that
    faces away). Such water (where the water less its opening by half that width, in
    pieces of at least NARROW_AREA squared half widths: not a corner or a notch) has its
    outline sampled at half the spacing, and so on within it down to ``finest``."""
    out = [p for p in per_ring]
    step = spacing
    zone = water
    while 0.5 * step >= finest:
        h = 0.5 * NARROW_SAMPLES * step
        opened = shapely.buffer(shapely.buffer(water, -h), h * (1.0 + 1e-3))
        narrow = shapely.difference(zone, opened)
        keep = [g for g in shapely.get_parts(narrow) if g.area >= NARROW_AREA * h * h]
        if not keep:
            break
        zone = shapely.union_all(keep)
        step *= 0.5
        near = shapely.buffer(zone, step)
        for k, r in enumerate(rings):
            part = shapely.intersection(r, near)
            if part.is_empty:
                continue
            more = shapely.get_coordinates(shapely.segmentize(part, step))
            if len(more):
                out[k] = np.unique(np.vstack([out[k], more]), axis=0)
    return out


def _out_through(seg: np.ndarray, inside: np.ndarray, kept: np.ndarray, open_edge, boundary,
                 tree: cKDTree, spacing: float) -> np.ndarray:
    """Voronoi edges (M, 2, 2) cut at the pieces of ``open_edge`` that no free end of the
    skeleton ``kept`` (its edges inside the water) reaches (its inscribed circle grown by
    two spacings, as :func:`_open_ends` asks): each edge ``seg`` from a vertex inside the
    water (``inside``: (M, 2) of its ends) across such a piece, up to it. Where the axes on
    either side of the water meet just inside the data's edge (islands near it), the edge
    between the banks running out to it was all the skeleton had there."""
    flat = np.round(kept, 6)
    flat = flat[(flat[:, 0] != flat[:, 1]).any(axis=1)].reshape(-1, 2)
    uniq, count = np.unique(flat, axis=0, return_counts=True)
    leaves = uniq[count == 1]
    radius = tree.query(leaves)[0] if len(leaves) else np.zeros(0)
    reach = radius + 2.0 * spacing
    # a piece is reached by a free end near it and near its middle (not a spur into a corner
    # beside it, wide for want of outline points by the edge: a delta's mouth cut
    # obliquely by the sea, 480 m long, its axis's end 146 m from its middle, 94 m wide)
    at = shapely.points(leaves)
    lacking = [g for g in shapely.get_parts(open_edge)
               if not ((shapely.distance(g, at) <= reach) & (shapely.distance(
                   g.interpolate(0.5, normalized=True), at) <= np.maximum(
                   radius, 0.25 * g.length))).any()]
    cross = np.flatnonzero(inside[:, 0] != inside[:, 1])
    if not lacking or not len(cross):
        return np.zeros((0, 2, 2))
    lines = shapely.linestrings(seg[cross])
    crossing = shapely.STRtree(lines)
    out = []
    for piece in lacking:
        # (only the edges that cross the piece: a query, not a call per edge)
        near = np.sort(crossing.query(piece, predicate="intersects"))
        if not len(near):
            continue
        hits = shapely.intersection(lines[near], piece)
        for j, i, h in zip(near, cross[near], hits):
            p = seg[i, 0] if inside[i, 0] else seg[i, 1]
            hit = shapely.get_coordinates(h)
            if not len(hit):
                continue
            q = hit[int(np.argmin(np.hypot(*(hit - p).T)))]
            if np.hypot(*(q - p)) > 0:
                out.append([p, q])
    out = np.array(out).reshape(-1, 2, 2)
    if not len(out):
        return out
    p, q = out[:, 0], out[:, 1]
    short = shapely.linestrings(np.stack([p, p + (1.0 - 1e-6) * (q - p)], axis=1))
    return out[~shapely.intersects(boundary, short)]


def _sees(water, pts: np.ndarray, open_edge, deep: float) -> np.ndarray:
    """Which outline points ``pts`` (N, 2) see ``open_edge`` over the water: the straight
    line to its nearest point keeps to the water (it passes at most ``deep`` inside the
    land, as a chord of a bank curving round the water does). A shore behind a point of
    land beside the edge (Colville's delta: a channel beside a point of land running out to
    the sea, within a quarter of the delta's mean width of its open edge) is a bank of its
    own channel, not the end of the one cut."""
    if not len(pts):
        return np.zeros(0, bool)
    to = shapely.get_coordinates(shapely.shortest_line(shapely.points(pts), open_edge))
    p, q = to[0::2], to[1::2]
    f = np.linspace(0.0, 1.0, 10)[1:-1]
    xy = (p[:, None, :] + f[None, :, None] * (q - p)[:, None, :]).reshape(-1, 2)
    land = ~shapely.contains_xy(water, xy[:, 0], xy[:, 1])
    depth = np.zeros(len(xy))
    depth[land] = shapely.distance(water.boundary, shapely.points(xy[land]))
    return depth.reshape(len(p), len(f)).max(axis=1) <= deep


OWN_FRAME_SHARE = 0.05
"""Water whose outline lies on its data's frame but for less than this share is its own
frame (:func:`_open_edge`): no piece of it is an open end."""


def _open_edge(water, frame, width: float, tolerance_m: float):
    """The pieces of the water's outline along ``frame``'s edge (where the data's extent cuts
    the water: no bank), or None. A piece counts when it is at least OPEN_EDGE_WIDTHS ×
    ``width`` long and runs across the water, not along it: the rest of the outline lies at
    least a quarter of its length from its middle (a straight bank on the frame's edge has
    the other bank much nearer), times the sine of the acute angle a bank leaves one of its
    ends at (:func:`_runs_across`: the edge cutting a river obliquely, the water a wedge
    between it and that bank, whose middle lies nearer the bank by that sine)."""
    if frame is None:
        return None
    tol = 1e-6 * max(width, 1.0) + 1e-9
    band = shapely.buffer(frame.boundary, tol, cap_style="flat")
    # the water is its own frame (a rectangle, reprojected: within a thousandth of the
    # tolerance of it, bar less than the tolerance or OWN_FRAME_SHARE of its outline: a
    # rectangle's sides sag where a bridge's gap was joined): the data's edge says nothing
    own = shapely.difference(water.exterior, shapely.buffer(
        frame.boundary, max(tol, 1e-3 * tolerance_m), cap_style="flat"))
    if own.is_empty or own.length < max(tolerance_m, OWN_FRAME_SHARE * water.exterior.length):
        return None
    on = shapely.intersection(water.boundary, band)
    rest = shapely.difference(water.boundary, band)
    pieces = [g for g in shapely.get_parts(shapely.line_merge(on) if on.geom_type in (
        "MultiLineString", "LineString") else on)
        if g.geom_type == "LineString" and g.length >= OPEN_EDGE_WIDTHS * width]
    near = [shapely.distance(g.interpolate(0.5, normalized=True), rest) for g in pieces]
    pieces = [g for g, d in zip(pieces, near) if _runs_across(g, d, rest)]
    box = shapely.get_coordinates(shapely.simplify(frame, tol))
    if pieces and len(box) == 5 and (shapely.distance(shapely.points(box[:4])[:, None], np.array(
            pieces)[None, :]) <= 2.0 * tol).any():
        pieces = _open_sides(on, rest, box[:4], width, tol)    # (one turns a corner)
    return shapely.MultiLineString(pieces) if pieces else None


def _open_sides(on, rest, corners: np.ndarray, width: float, tol: float) -> list:
    """:func:`_open_edge`'s pieces where one of them turns a corner of a rectangular frame
    (``corners`` (4, 2)): the outline on each side of the frame alone, a piece across the
    water when the rest of the outline and the other sides' pieces lie at least a quarter of
    its length from its middle (a river drawn along the axes in a file of its own, its banks
    on the file's box and its ends across it: one piece round two corners, its middle on
    the end, far from the rest, its banks read as the data's edge; a river the data cuts at
    a corner: its two pieces, each across)."""
    cut = shapely.difference(on, shapely.buffer(shapely.multipoints(corners), 2.0 * tol))
    parts = [g for g in shapely.get_parts(shapely.line_merge(cut) if cut.geom_type in (
        "MultiLineString", "LineString") else cut)
        if g.geom_type == "LineString" and g.length > 4.0 * tol]
    out = []
    for i, g in enumerate(parts):
        if g.length < OPEN_EDGE_WIDTHS * width:
            continue
        mid = g.interpolate(0.5, normalized=True)
        d = min([shapely.distance(mid, rest)]
                + [shapely.distance(mid, h) for j, h in enumerate(parts) if j != i])
        if _runs_across(g, d, rest):
            out.append(g)
    return out


SLICE_ANGLES_DEG = 270.0
"""A piece of the data's edge whose outline leaves its two ends at angles (the water's
side) summing to this much or more [°] runs along the water, not across it: the edge slices
a bend's outer bank, which goes on nearly straight through it at each end (a cut across a
channel has its banks leave its ends about parallel: 180°, 90° and 90°, or 14° and 166°)."""


def _leaving_angles(piece, rest) -> list:
    """At each end of ``piece``, the angle [rad] between the piece's way from that end over a
    hundredth of its length and the way from the end to the outline ``rest``'s point half
    the piece's length along it (the water's side of the angle), None where no part of the
    outline leaves that end."""
    parts = [g for g in shapely.get_parts(shapely.line_merge(rest) if rest.geom_type
                                           == "MultiLineString" else rest)
             if g.geom_type == "LineString" and g.length > 0]
    c = np.asarray(piece.coords)
    if not piece.length > 0:
        return [None, None]
    # (a piece round a corner of the frame runs along the edge at each end, not along its
    # chord; the band's cut leaves slivers of edges at its ends)
    near = shapely.get_coordinates(shapely.line_interpolate_point(
        piece, [0.01 * piece.length, 0.99 * piece.length]))
    out = []
    for a, b in ((c[0], near[0]), (c[-1], near[1])):
        # (the outline leaving the end: the part whose end is nearest it; a bank at an
        # angle θ leaves the band round the frame tol / sin θ from the end)
        if not parts:
            out.append(None)
            continue
        d = [np.hypot(*(np.asarray(g.coords)[[0, -1]] - a).T) for g in parts]
        k = int(np.argmin([x.min() for x in d]))
        g, d = parts[k], d[k]
        if d.min() > 0.01 * piece.length:
            out.append(None)
            continue
        at = min(0.5 * piece.length, g.length)
        q = np.asarray(g.interpolate(at if d[0] <= d[1] else g.length - at).coords[0])
        u, v = b - a, q - a
        cos = float(u @ v) / max(float(np.hypot(*u) * np.hypot(*v)), 1e-300)
        out.append(math.acos(min(1.0, max(-1.0, cos))))
    return out


def _runs_across(piece, d: float, rest) -> bool:
    """Whether ``piece`` of the data's edge runs across the water, the rest of the outline
    ``d`` [m] from its middle: at least a quarter of its length, times the sine of the
    sharpest acute angle at which the outline leaves one of its ends (the edge cutting a
    river obliquely, the water a wedge between it and that bank); and not leaving its two
    ends at angles summing to SLICE_ANGLES_DEG or more (a bend's bank the edge slices)."""
    angles = _leaving_angles(piece, rest)
    sine = min([1.0] + [math.sin(a) for a in angles if a is not None and a < 0.5 * math.pi])
    if None not in angles and math.degrees(sum(angles)) >= SLICE_ANGLES_DEG:
        return False
    return d >= 0.25 * piece.length * sine


def _open_ends(nbr, xy: np.ndarray, radius: np.ndarray, open_edge, ends, spacing: float,
               boundary=None):
    """Which skeleton nodes are ends never to prune: for each piece of ``open_edge`` and
    each point of ``ends``, the widest free end whose inscribed circle reaches it (the axis
    running out between the banks; the spurs into the corners beside it are narrower) and,
    for a piece, reaches it over water: the way from the end to the piece's nearest point
    crosses no shore (``boundary``: the water's; a corner of the water beside an island the
    edge cuts open, its circle wide for want of outline points by the edge, reached over the
    island the piece of the channel on its other side), of those nearer it than any other
    piece where there are (a wide channel's end beside a mouth, its circle reaching the next
    mouth's piece: Colville's delta). Two pieces of the edge (an island cut open by it
    between them) take two ends where there are: a piece whose widest end is another
    piece's takes the widest of the rest that is at least a quarter of the piece wide (the
    channel on its side of the island), the longer pieces first."""
    keep = np.zeros(len(xy), bool)
    leaves = np.array([i for i in range(len(nbr)) if len(nbr[i]) == 1], dtype=np.int64)
    if not len(leaves):
        return keep
    pieces = sorted(shapely.get_parts(open_edge) if open_edge is not None else [],
                    key=lambda g: -g.length)
    targets = pieces + [shapely.Point(p) for p in (ends if ends is not None else ())]
    reach = radius[leaves] + 2.0 * spacing
    taken = np.zeros(len(leaves), bool)
    at = shapely.points(xy[leaves])
    own = (np.argmin([shapely.distance(t, at) for t in pieces], axis=0) if pieces
           else np.zeros(0, np.int64))
    for k, t in enumerate(targets):
        d = shapely.distance(t, at)
        near = np.flatnonzero(d <= reach)
        if k < len(pieces) and boundary is not None and len(near):
            p = xy[leaves[near]]
            q = shapely.get_coordinates(shapely.shortest_line(shapely.points(p), t)
                                        ).reshape(-1, 2, 2)[:, 1]
            way = shapely.linestrings(np.stack([p, p + (1.0 - 1e-6) * (q - p)], axis=1))
            near = near[(np.hypot(*(q - p).T) == 0.0) | ~shapely.intersects(boundary, way)]
        if k < len(pieces) and (own[near] == k).any():
            near = near[own[near] == k]
        if not len(near):
            continue
        best = near[int(np.argmax(radius[leaves[near]]))]
        if k < len(pieces) and taken[best]:
            rest = near[~taken[near] & (radius[leaves[near]] >= 0.25 * t.length)]
            best = rest[int(np.argmax(radius[leaves[rest]]))] if len(rest) else best
        taken[best] = k < len(pieces)
        keep[leaves[best]] = True
    return keep


def _prune(nbr: list[dict[int, float]], radius: np.ndarray, keep=None, xy=None,
           dead=None) -> None:
    """Remove spurs (chains from a free end to a junction) shorter than SPUR_WIDTHS local
    widths, at most all but one at each junction per pass, until none is left; free ends
    marked in ``keep`` (the water's open ends) are never removed. Where that leaves fewer
    than two free ends (a short wide river cut square across at its ends, islands near
    them: each end's spur is shorter than the channels round the islands are wide, and the
    skeleton prunes back to the loops round them), :func:`_restore_ends` gives them back.
    The free ends nearest the points ``dead`` (tips of dead ends that are basins) are not
    counted: a pocket off the water is no way in or out."""
    leaves_before = [i for i in range(len(nbr)) if len(nbr[i]) == 1]
    gone: list[tuple[int, int, float]] = []
    while True:
        spurs: dict[int, list[tuple[float, list[int]]]] = {}
        for leaf in range(len(nbr)):
            if len(nbr[leaf]) != 1 or (keep is not None and keep[leaf]):
                continue
            path, length, prev, cur = [leaf], 0.0, -1, leaf
            while True:
                nxt = [v for v in nbr[cur] if v != prev]
                if not nxt:
                    break
                v = nxt[0]
                length += nbr[cur][v]
                path.append(v)
                prev, cur = cur, v
                if len(nbr[cur]) != 2:
                    break
            if len(nbr[cur]) >= 3 and length < SPUR_WIDTHS * 2.0 * radius[cur]:
                spurs.setdefault(cur, []).append((length, path))
        if not spurs:
            break
        for j, items in spurs.items():
            items.sort(key=lambda t: t[0])
            drop = items if len(items) < len(nbr[j]) else items[:-1]
            for _, path in drop:
                for a, b in zip(path[:-1], path[1:]):
                    if b in nbr[a]:
                        gone.append((a, b, nbr[a].pop(b)))
                    nbr[b].pop(a, None)
    if xy is None:
        return
    leaves = [i for i in range(len(nbr)) if len(nbr[i]) == 1]
    pockets: set[int] = set()
    if dead is not None and len(dead) and leaves:
        _, at = cKDTree(xy[leaves]).query(np.asarray(dead, np.float64).reshape(-1, 2))
        pockets = {leaves[i] for i in np.atleast_1d(at)}
    leaves = [i for i in leaves if i not in pockets]
    leaves_before = [i for i in leaves_before if i not in pockets]
    if _end_groups(leaves, radius, xy) < 2 and _end_groups(leaves_before, radius, xy) >= 2:
        _restore_ends(nbr, gone, xy, radius, pockets)


def _end_groups(leaves: list[int], radius: np.ndarray, xy: np.ndarray) -> int:
    """How many ends the free ends ``leaves`` (skeleton nodes) make: free ends nearer each
    other than their widths together are one end (the channels on either side of an island
    the data's edge cuts open)."""
    if len(leaves) < 2:
        return len(leaves)
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    p, r = xy[leaves], radius[leaves]
    pairs = cKDTree(p).query_pairs(4.0 * float(r.max()), output_type="ndarray")
    a, b = pairs[:, 0], pairs[:, 1]
    near = np.hypot(*(p[a] - p[b]).T) <= 2.0 * (r[a] + r[b])
    n = len(leaves)
    return connected_components(coo_matrix((np.ones(int(near.sum())), (a[near], b[near])),
                                           shape=(n, n)), directed=False)[0]


def _restore_ends(nbr: list[dict[int, float]], gone: list[tuple[int, int, float]],
                  xy: np.ndarray, radius: np.ndarray, pockets=()) -> None:
    """Give a pruned skeleton back the ends it needs (two at least, :func:`_end_groups`):
    from the nodes still in it, the pruned branches' trunks (each followed until it forks,
    where a river's end cut square across parts into its two corners, or ends), the trunks
    whose ends' inscribed circles reach farthest from each other and from the free ends left
    (a river's end, wide, not a spur into a bend of its bank beside it, a little farther off
    but narrow); with no free end left, a trunk that narrows to a corner is none
    (RESTORED_END_RADII). ``pockets``: free ends of dead ends that are no ends of the water
    (neither counted nor carried on)."""
    pruned: dict[int, dict[int, float]] = {}
    for a, b, d in gone:
        pruned.setdefault(a, {})[b] = d
        pruned.setdefault(b, {})[a] = d
    trunks = []                                  # (node path from the skeleton outwards)
    for k in [k for k in pruned if nbr[k] and k not in pockets]:
        for first in pruned[k]:
            if nbr[first]:
                continue
            path, prev, cur = [k, first], k, first
            while len(pruned[cur]) == 2:
                prev, cur = cur, next(v for v in pruned[cur] if v != prev)
                path.append(cur)
            trunks.append(path)
    leaves = [i for i in range(len(nbr)) if len(nbr[i]) == 1 and i not in pockets]
    chosen: list[list[int]] = []
    have = _end_groups(leaves, radius, xy)
    if not have:       # a ring of water round its islands: only a wide end makes it a river
        trunks = [p for p in trunks if radius[p[-1]] >= RESTORED_END_RADII * radius[p[0]]]
    while have + len(chosen) < 2 and len(chosen) < len(trunks):
        ends = xy[leaves + [p[-1] for p in chosen]]
        if len(ends):
            def score(p, ends=ends):
                return float(np.hypot(*(ends - xy[p[-1]]).T).min()) + float(radius[p[-1]])
        else:              # none left: the one farthest from another trunk's end
            tips = xy[[q[-1] for q in trunks]]

            def score(p):
                return float(np.hypot(*(tips - xy[p[-1]]).T).max()) + float(radius[p[-1]])
        best = max((p for p in trunks if p not in chosen), key=score)
        chosen.append(best)
    for path in chosen:
        for a, b in zip(path[:-1], path[1:]):
            nbr[a][b] = nbr[b][a] = pruned[a][b]


def _keep_longest_piece(nbr: list[dict[int, float]]) -> None:
    """Keep the longest connected piece of the skeleton (a polygon pinched to a point, as
    make_valid leaves a knot in an outline, has another behind the pinch: its water is
    left without an axis of its own and flows with its neighbours)."""
    label = np.full(len(nbr), -1)
    lengths = []
    for s in range(len(nbr)):
        if label[s] >= 0 or not nbr[s]:
            continue
        k = len(lengths)
        label[s] = k
        stack, total = [s], 0.0
        while stack:
            a = stack.pop()
            for b, d in nbr[a].items():
                total += 0.5 * d
                if label[b] < 0:
                    label[b] = k
                    stack.append(b)
        lengths.append(total)
    if len(lengths) <= 1:
        return
    best = int(np.argmax(lengths))
    for a in np.flatnonzero((label >= 0) & (label != best)):
        nbr[a].clear()


def _chains(nbr: list[dict[int, float]], xy: np.ndarray) -> list[list[int]]:
    """The chains of node ids between nodes of degree ≠ 2 (each once); from each node (in
    the nodes' order) by the direction they leave it in (not the Voronoi diagram's edge
    order: the two arms round an island come in the same order from a polygon and its
    mask)."""
    key = [i for i in range(len(nbr)) if nbr[i] and len(nbr[i]) != 2]
    seen: set[tuple[int, int]] = set()
    chains = []
    for s in key:
        for first in sorted(nbr[s], key=lambda v: math.atan2(xy[v][1] - xy[s][1],
                                                             xy[v][0] - xy[s][0])):
            if (s, first) in seen:
                continue
            path, prev, cur = [s, first], s, first
            while len(nbr[cur]) == 2:
                nxt = [v for v in nbr[cur] if v != prev][0]
                prev, cur = cur, nxt
                path.append(cur)
            seen.add((path[-1], path[-2]))
            seen.add((s, first))
            chains.append(path)
    return chains


def _merge_junctions(chains, xy: np.ndarray, radius: np.ndarray):
    """Merge junctions closer than JOIN_WIDTHS × the sum of their inscribed radii (one
    junction at the wider one's point): the builder joins end points within a quarter width
    and refuses ends nearer than half their widths' sum that it does not join. Returns the
    chains left (short ones between merged junctions dropped) and the chains that now start
    and end at one junction though they are long (loops round a hole)."""
    parent: dict[int, int] = {}

    def root(a: int) -> int:
        while parent.get(a, a) != a:
            a = parent[a]
        return a

    deg: dict[int, int] = {}
    for c in chains:
        deg[c[0]] = deg.get(c[0], 0) + 1
        deg[c[-1]] = deg.get(c[-1], 0) + 1
    junctions = np.array(sorted(n for n, d in deg.items() if d >= 3), dtype=np.int64)
    if len(junctions) > 1:
        reach = 2.0 * JOIN_WIDTHS * float(radius[junctions].max())
        pairs = cKDTree(xy[junctions]).query_pairs(reach, output_type="ndarray")
        a, b = junctions[pairs[:, 0]], junctions[pairs[:, 1]]
        d = np.hypot(*(xy[a] - xy[b]).T)
        close = d < JOIN_WIDTHS * (radius[a] + radius[b])
        for i in np.argsort(d[close]):
            ra, rb = root(int(a[close][i])), root(int(b[close][i]))
            # the roots themselves must be close (no chain of merges drifting along an axis)
            if ra != rb and (np.hypot(*(xy[ra] - xy[rb]))
                             < JOIN_WIDTHS * (radius[ra] + radius[rb])):
                keep, gone = (ra, rb) if radius[ra] >= radius[rb] else (rb, ra)
                parent[gone] = keep
    out, loops = [], []
    for c in chains:
        ra, rb = root(c[0]), root(c[-1])
        if ra == rb:
            span = float(np.hypot(*np.diff(xy[c], axis=0).T).sum())
            long_way = span >= JOIN_WIDTHS * 2.0 * float(radius[ra]) and c[0] != c[-1]
            if long_way or (len(c) > 3 and c[0] == c[-1]):
                loops.append(c)
            continue
        out.append([ra, *c[1:-1], rb])
    return out, loops


def _smooth(p: np.ndarray, r_start: float, r_end: float, spacing: float) -> np.ndarray:
    """A chain's points without the wiggles of the Voronoi edges: interior points within half
    the inscribed radius of a junction dropped, simplified by a quarter of the sample spacing
    and without turns sharper than the builder takes."""
    if len(p) > 2:
        d0 = np.hypot(*(p - p[0]).T)
        d1 = np.hypot(*(p - p[-1]).T)
        keep = np.ones(len(p), bool)
        keep[1:-1] = (d0[1:-1] > 0.5 * r_start) & (d1[1:-1] > 0.5 * r_end)
        p = p[keep]
    line = shapely.simplify(shapely.LineString(p), 0.5 * spacing)
    p = np.asarray(line.coords)
    for _ in range(len(p)):
        if len(p) <= 2:
            break
        d = np.diff(p, axis=0)
        turn = np.degrees(np.abs(np.arctan2(d[:-1, 0] * d[1:, 1] - d[:-1, 1] * d[1:, 0],
                                            np.einsum("ij,ij->i", d[:-1], d[1:]))))
        if turn.max() <= 0.8 * MAX_TURN_DEG:
            break
        p = np.delete(p, int(np.argmax(turn)) + 1, axis=0)
    return p


def _extend_free_ends(net: _Network, water) -> None:
    """Carry every free end of an axis on along its direction to the outline (where the
    builder cuts the water across the channel)."""
    deg = net.degree()
    for c in net.channels:
        for at_start in (True, False):
            node = c.a if at_start else c.b
            if deg[node] != 1:
                continue
            p = c.points if not at_start else c.points[::-1]
            end = p[-1]
            s = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(p[::-1], axis=0).T))])
            back_pt = p[::-1][min(int(np.searchsorted(s, 0.5 * c.width)), len(p) - 1)]
            t = end - back_pt
            if not np.hypot(*t) > 0:
                continue
            t = t / np.hypot(*t)
            ray = shapely.LineString([end, end + t * (2.0 * c.width + 1.0)])
            hit = shapely.intersection(ray, water.boundary)
            if hit.is_empty:
                continue
            hp = shapely.get_coordinates(hit)
            q = hp[int(np.argmin(np.hypot(*(hp - end).T)))]
            if np.hypot(*(q - end)) <= 1e-6:
                continue
            if at_start:
                c.points = np.vstack([q, c.points])
                c.widths = np.concatenate([[c.widths[0]], c.widths])
            else:
                c.points = np.vstack([c.points, q])
                c.widths = np.concatenate([c.widths, [c.widths[-1]]])
            net.nodes[node] = q


def _line_ends(water, lines: list, tolerance_m: float) -> tuple[np.ndarray, np.ndarray]:
    """(starts (N, 2), ends (M, 2)) [m]: where the lines (drawn downstream) enter and leave
    the water: the ends of their pieces inside it that lie on its outer shores (not the
    lines' own ends in the water, nor where they cross an island)."""
    merged = shapely.line_merge(shapely.node(shapely.MultiLineString(
        [np.asarray(g.coords) for g in lines])), directed=True)
    shores = shapely.MultiLineString([p.exterior for p in getattr(water, "geoms", [water])])
    near = max(1.0, 4.0 * tolerance_m)
    starts, stops = [], []
    for p in shapely.get_parts(shapely.intersection(merged, shapely.Polygon(
            shores.geoms[0]) if len(shores.geoms) == 1 else shapely.MultiPolygon(
            [shapely.Polygon(r) for r in shores.geoms]))):
        if p.geom_type != "LineString" or p.length <= tolerance_m:
            continue
        c = np.asarray(p.coords)
        src = min(lines, key=lambda g: g.distance(shapely.Point(c[len(c) // 2])))
        if src.project(shapely.Point(c[-1])) < src.project(shapely.Point(c[0])):
            c = c[::-1]
        for at, out in ((c[0], starts), (c[-1], stops)):
            if shores.distance(shapely.Point(at)) <= near:
                out.append(at)
    return np.array(starts).reshape(-1, 2), np.array(stops).reshape(-1, 2)


def _match_points(ends, pts: np.ndarray, what: str, where: str, water,
                  strict: bool = True, frame=None) -> None:
    """Mark the free end nearest each point as an inlet / outlet; GraphError for a point far
    from every free end (not ``strict``: such a point is passed over), or whose nearest one
    is a spur into a bank beside it (a channel from a junction shorter than SPUR_WIDTHS ×
    its width there, not on the data's edge ``frame``: the skeleton keeps the free end
    nearest a point given, and an inlet put on an island or an outlet in mid-river took a
    spur into the bank as its end)."""
    if not len(pts) or not (ends or strict):
        return
    if not ends:
        raise GraphError(f"{where}: the water has no free end to put an {what} at")
    xy = np.array([net.nodes[n] for net, n, _ in ends])
    for p in pts:
        d = np.hypot(*(xy - p).T)
        i = int(np.argmin(d))
        net, n, w = ends[i]
        if d[i] > max(w, 1.0) and not strict:
            continue
        if d[i] > max(w, 1.0):
            off = water.distance(shapely.Point(p))
            place = ("outside every water polygon, " if off > 0 else "in the water but ")
            raise GraphError(f"{where}: {what} ({p[0]:.1f}, {p[1]:.1f}) lies {place}"
                             f"{d[i]:.1f} m from the nearest free end of the water "
                             f"({xy[i, 0]:.1f}, {xy[i, 1]:.1f}), more than the channel's width "
                             f"there ({w:.1f} m): put it where a channel leaves the data "
                             f"(coordinates in the data's CRS)")
        spur = _spur_at(net, n) if strict else None
        if spur is not None and frame is not None:
            # (an end where the data's edge cuts the water may be short: a junction by it)
            edge = _open_edge(net.water, frame, 2.0 * net.water.area / max(
                net.water.length, 1e-9), 0.0)
            if edge is not None and edge.distance(shapely.Point(net.nodes[n])) <= max(w, 1.0):
                spur = None
        if spur is not None:
            x, y = net.nodes[n]
            raise GraphError(f"{where}: {what} ({p[0]:.1f}, {p[1]:.1f}) lies at no end of the "
                             f"water: its nearest free end, ({x:.1f}, {y:.1f}), is a spur "
                             f"{spur[0]:.1f} m long into the bank of a channel {spur[1]:.1f} m "
                             f"wide: put it where a channel leaves the data (coordinates in the "
                             f"data's CRS)")
        (net.inlets if what == "inlet" else net.outlets).add(n)


def _spur_at(net: _Network, n: int):
    """(length, width at its junction) [m] of the channel from free end ``n`` when it is a
    spur (shorter than SPUR_WIDTHS × its width at a junction of three or more), else None."""
    deg = net.degree()
    for c in net.channels:
        if n in (c.a, c.b) and c.a != c.b:
            other, w = (c.b, float(c.widths[-1])) if c.a == n else (c.a, float(c.widths[0]))
            if deg[other] >= 3 and c.length < SPUR_WIDTHS * w:
                return c.length, w
    return None


def _dem_elevations(dem, ends, report: RiverImport, where: str) -> dict:
    """Elevation of the DEM at every free end: {(id(network), node): z} (NaN off the DEM)."""
    z = _dem_heights(dem, np.array([net.nodes[n] for net, n, _ in ends]).reshape(-1, 2),
                     report, where)
    return {(id(net), n): float(v) for (net, n, _), v in zip(ends, z)}


def _dem_heights(dem, xy_m: np.ndarray, report: RiverImport, where: str) -> np.ndarray:
    """The DEM's heights at points (N, 2) [m] of the water's frame, (N,) (NaN off the DEM)."""
    from riverflow.scenes.rasters import open_raster

    xy = np.asarray(xy_m, np.float64) + np.asarray(report.origin_m)
    if not len(xy):
        return np.zeros(0)
    try:
        src = open_raster(dem, what="DEM")
    except (ValueError, FileNotFoundError, TypeError) as exc:
        raise GraphError(f"{where}: the DEM: {exc}") from None
    try:
        with src:
            if report.crs and src.crs:
                pyproj = require("pyproj", "projecting to the DEM")
                to = pyproj.Transformer.from_crs(pyproj.CRS.from_wkt(report.crs),
                                                 pyproj.CRS.from_user_input(src.crs.to_wkt()),
                                                 always_xy=True)
                # report.crs has the moved origin: its coordinates are the ones before the shift
                xy = np.column_stack(to.transform(*(xy - np.asarray(report.origin_m)).T))
            z = np.array([v[0] for v in src.sample([tuple(p) for p in xy], masked=True)],
                         dtype=object)
    except GraphError:
        raise
    except Exception as exc:
        raise GraphError(f"{where}: cannot read the DEM {dem}: {exc}") from None
    return np.array([math.nan if np.ma.is_masked(v) else float(v) for v in z])


def _discharges(networks: list[_Network], total_m3s, geometry: HydraulicGeometry,
                report: RiverImport, knots=()) -> None:
    """Discharge [m²/s] of every channel: sources from ``total_m3s`` split by width or from
    their widths; summed at confluences, split by width at bifurcations. ``knots``: lakes
    made of knots (:func:`_knot_lake`), junctions of the channels ending and starting on
    their shores (a knot with no channel flowing in: its channels out are sources)."""
    def knot_of(net, node, c) -> int:
        p = shapely.Point(net.nodes[node])
        return next((k for k, lk in enumerate(knots)
                     if lk.exterior.distance(p) <= 0.5 * float(c.widths[0 if node == c.a else -1])),
                    -1)

    into: dict[int, list] = {}      # knot: channels ending / starting on its shore
    out_of: dict[int, list] = {}
    for net in networks:
        deg = net.degree()
        for c in net.channels:
            c.discharge_m2s = None
            if knots and deg[c.b] == 1 and (k := knot_of(net, c.b, c)) >= 0:
                into.setdefault(k, []).append(c)
            if knots and deg[c.a] == 1 and (k := knot_of(net, c.a, c)) >= 0:
                out_of.setdefault(k, []).append(c)
    fed = {id(c) for k, cs in out_of.items() if k in into for c in cs}
    sources = []
    for net in networks:
        deg = net.degree()
        for c in net.channels:
            if deg[c.a] == 1 and id(c) not in fed:
                sources.append(c)
    if not sources:
        raise GraphError(f"{report.path}: no channel starts at a free end (no water enters)")
    wsum = sum(c.width for c in sources)
    for c in sources:
        if total_m3s is not None:
            q3 = total_m3s * c.width / wsum
            c.discharge_from = f"discharge_m3s {total_m3s:g} m³/s split by width"
        else:
            q3 = geometry.discharge_of_width(c.width)
            c.discharge_from = f"hydraulic geometry of its width {c.width:.1f} m"
        c.discharge_m2s = geometry.psi(q3)
    orders = []
    for net in networks:
        start = [c.a for c in net.channels]
        end = [c.b for c in net.channels]
        deg = net.degree()
        start_j = [s if deg[s] > 1 else -1 for s in start]
        end_j = [e if deg[e] > 1 else -1 for e in end]
        order, loop = upstream_first(start_j, end_j)
        if loop:
            raise GraphError(f"{report.path}: channels {[net.channels[i].name for i in loop]} "
                             f"flow round a loop")
        ins: dict[int, list[int]] = {}
        outs: dict[int, list[int]] = {}
        for i, c in enumerate(net.channels):
            ins.setdefault(c.b, []).append(i)
            outs.setdefault(c.a, []).append(i)
        orders.append((net, order, ins, outs))
    waiting = True
    while waiting:      # (once without knots; with them, until the knots' inflow is known)
        waiting = moved = False
        for k, cs in out_of.items():
            if k not in into or cs[0].discharge_m2s is not None:
                continue
            if any(c.discharge_m2s is None for c in into[k]):
                waiting = True
                continue
            inflow = sum(c.discharge_m2s for c in into[k])
            w = sum(c.width for c in cs)
            given = 0.0
            for m, c in enumerate(cs):
                c.discharge_m2s = inflow - given if m == len(cs) - 1 else inflow * c.width / w
                given += c.discharge_m2s
                c.discharge_from = ("the lake's outflow" if len(cs) == 1 else
                                    f"the lake's outflow split by width ({c.width:.1f} of "
                                    f"{w:.1f} m)")
            moved = True
        for net, order, ins, outs in orders:
            for i in order:
                c = net.channels[i]
                if c.discharge_m2s is not None:
                    continue
                j = c.a
                if not ins.get(j):
                    if id(c) in fed:
                        waiting = True
                        continue
                    raise GraphError(f"{report.path}: the junction at ({net.nodes[j][0]:.1f}, "
                                     f"{net.nodes[j][1]:.1f}) has no channel flowing in")
                if any(net.channels[k].discharge_m2s is None for k in ins[j]):
                    waiting = True
                    continue
                inflow = sum(net.channels[k].discharge_m2s for k in ins[j])
                leaving = outs[j]
                w = sum(net.channels[k].width for k in leaving)
                given = 0.0
                for m, k in enumerate(leaving):
                    ck = net.channels[k]
                    ck.discharge_m2s = (inflow - given if m == len(leaving) - 1
                                        else inflow * ck.width / w)
                    given += ck.discharge_m2s
                    ck.discharge_from = ("the inflow" if len(leaving) == 1 else
                                         f"the inflow split by width ({ck.width:.1f} of "
                                         f"{w:.1f} m)")
                moved = True
        if waiting and not moved:
            stuck = [c for n in networks for c in n.channels if c.discharge_m2s is None]
            x, y = shapely.LineString(stuck[0].points).interpolate(0.5, normalized=True).coords[0]
            raise GraphError(f"{report.path}: channels {[c.name for c in stuck[:6]]} flow "
                             f"round a loop through the lakes made of knots, near ({x:.1f}, "
                             f"{y:.1f})")
    report.derived["discharge"] = sorted({c.discharge_from.split(" (")[0]
                                          for n in networks for c in n.channels})
