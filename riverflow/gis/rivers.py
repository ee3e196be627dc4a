"""Real river networks from GIS line data: :func:`read_rivers` (``rf.read_rivers``).

Stream centre lines come from a shapefile, GeoPackage, GeoJSON or OpenStreetMap file (read
by pyogrio/GDAL), one feature per link (a LineString; each part of a MultiLineString is a
link). The builder that comes back is filled and may take more branches before ``build()``::

    builder = rf.read_rivers("a001_network.shp", drainage_area_km2="usarea_km2",
                             elevation_m=("uselev_m", "dselev_m"))
    print(builder.report)            # what was read, derived and changed, per link
    graph = builder.build()          # graph.crs: the metric CRS of the coordinates
    scene = rf.landscape(graph)

Topology comes from the geometry only: end points closer than ``snap_m`` are one junction, an
end point within ``snap_m`` of another line's interior splits that line there (a tributary
digitised onto its river), the line's direction is the flow direction (``reverse`` names an
attribute that says otherwise). Junctions closer together than their rivers are wide, or
joined by a link shorter than that, are merged (the links between them lie inside the
confluence and are dropped). No id, node or
"to-link" attribute is needed or trusted.

Widths and discharges (per link, first that applies):

1. given: ``width_m`` and/or ``discharge_m2s`` / ``discharge_m3s`` (an attribute name or a
   number);
2. from the drainage area A [km²] (``drainage_area_km2``), by hydraulic geometry
   (:class:`HydraulicGeometry`);
3. from the Strahler stream order ω (``stream_order``): A = A₁ · R_A^(ω − 1) (Horton's law of
   stream areas), then as 2;
4. else: every source gets the discharge of a river ``default_width_m`` wide, and downstream
   links add up what flows into them.

Attributes left as None are looked for under well-known names (:data:`KNOWN_ATTRIBUTES`:
TauDEM, NHDPlus, HydroRIVERS, MERIT Hydro spellings, case-insensitive); a number or an explicit
name turns that off. Discharge is conserved: a link carries at least what flows into it, and
where its own estimate is larger (the drainage area grows along a river) the surplus enters
as lateral inflow at its upstream junction (:class:`~riverflow.RiverNetworkBuilder`
``lateral_inflow``), so discharge grows downstream. The builder's ``discharge_m2s`` is ψ's
difference across the river (per unit depth): Q / depth.

Coordinates: lon/lat (any geographic CRS) and projected data in feet are projected to the UTM
zone pyproj picks for the data (an azimuthal equidistant projection centred on the data where
no UTM zone fits); projected data in metres keeps its CRS. Far from the CRS's origin (more
than AUTO_ORIGIN_M, as UTM northings always are) the coordinates are moved near 0 by a round
``origin_m`` (the data's centre to the kilometre), and the CRS's false easting and northing
with them: its projection and datum are the file's, only its origin moves. Drawing works in
float32, which resolves 0.5 m at 4 500 km (the graph's coordinates would be its mesh vertices
and particle positions). ``builder.crs`` and the graph's ``crs`` hold the CRS (WKT), so
results can be mapped back; ``builder.report.origin_m`` the shift.

Repairs (``strict=False``, the default): real data is repaired as it comes and every repair
is a :class:`Repair` in ``builder.report.repairs`` naming the feature (id and attributes) and
what was done: features that are not lines, non-finite vertices, zero-length lines and
duplicates are left out; the loop of a line that crosses itself is cut out
(:func:`_cut_self_loops`); lines drawn upstream are turned (:func:`_direct`: one outlet per
connected piece, found from drainage areas or stream orders, elevations, else the drawing and
the junction angles; a delta keeps its several outlets); rivers that meet where nothing
leaves (clipped data) get a short outlet, not in land the network's loops close round (where
they close round every side, one of the lines is turned or left out:
:func:`_close_clipped_ends`); lines crossing without a shared vertex are cut
where the narrower crosses the wider one's water (no junction); lines that run on into one
another where nothing else meets are one link where one of them is short, or both are
shorter than twice their planned widths (OSM: always; :func:`_join_runs`); a line in land
the network's loops close round is left out (:func:`_drop_enclosed`); a hook at a free end
is trimmed (:func:`_trim_hooks`); an OSM way closing a loop that flows back into itself is
turned (:func:`_break_osm_loops`); a free end in another river's water is cut back out of it
(:func:`_cut_ends_in_water`); two channels flowing into
one junction that run closer than their widths above it merge into one reach there
(:func:`_merge_close_channels`); an inflow laid back up an outflow's line, in its water,
joins it farther down (:func:`_move_side_inflows`); attribute values that are text, NaN or
≤ 0 (stream orders below 1, OSM width tags that are no width) are not used (the next rule
applies); a given
width under MIN_WIDTH_M is raised to it; and ``build()`` narrows channels that lie closer
together than their widths where the network cannot be built otherwise. Lines traced on a
raster's cells (a staircase) are smoothed at the scale of the cell or the width
(:func:`_smooth_traced`; a derivation in ``report.derived``, not a repair). ``strict=True``: lines are taken as drawn and the first defect
raises :class:`~riverflow.GraphError` naming the file, layer, feature and attributes.
Values replaced without a defect in the data (a derived width raised to MIN_WIDTH_M, a given
discharge smaller than its inflows or split at a bifurcation, elevations rising downstream)
are notes naming the feature and the value; nothing is replaced silently.
OpenStreetMap files (``.osm``, ``.osm.pbf``) give their ``waterway=`` ways
(:data:`OSM_WATERWAYS`), drawn downstream, with their ``width`` tag.

Bad input raises :class:`~riverflow.GraphError` (a missing file :class:`FileNotFoundError`)
naming the file, the layer, the feature (its id and attribute values) and what is wrong;
nothing is half-built. Errors of ``build()`` name the features too.
"""
from __future__ import annotations

import itertools
import math
import os
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np
import shapely
import shapely.errors
import shapely.ops
from scipy.spatial import cKDTree

from riverflow import _validate
from riverflow._extras import require
from riverflow._memory import without_collector
from riverflow.hydro.builder import (MAX_TURN_DEG, RiverNetworkBuilder, by_junction,
                                     upstream_first)
from riverflow.hydro.graph import GraphError
from riverflow.hydro.nearest import PolylineIndex

SUFFIXES = (".shp", ".gpkg", ".geojson", ".json", ".osm", ".pbf")
"""File suffixes :func:`read_rivers` takes (the command line's ``--scene`` sends these here)."""
DEFAULT_SNAP_M = 1.0
"""End points (and end points and lines) closer than this [m] are joined."""
DUPLICATE_SNAPS = 3.0
"""Lines within this many ``snap_m`` of each other everywhere (Hausdorff) are one line drawn
twice: the second is left out."""
ANGLE_PER_TURN = 1.0
"""Where no attribute tells, an outlet that needs one more line turned must fit the rule that
tributaries join at acute angles better by this much (sum of cosines at the junctions)."""
TIE_CANDIDATES = 8
"""Outlets that the drawing cannot tell apart (as many lines to turn) are compared by their
junction angles, at most this many per piece of network."""
NARROW_TRIES = 3
"""How many times ``build()`` narrows channels that lie closer than their widths and tries
again (:func:`_narrow_branches`)."""
NARROW_GAP = 0.8
"""Narrowed channels fill this fraction of the gap between their centre lines (the rest is
land), shared in proportion to their widths."""
GRID_TURN_DEG = 30.0
GRID_TURN_SHARE = 0.3
"""A line not on a lattice still zigzags like a traced one (:func:`_smooth_traced`) when its
vertices lie closer together than half its width and at least GRID_TURN_SHARE of them turn
by GRID_TURN_DEG or more."""
LATTICE_SHARE = 0.8
"""A line is grid-traced (traced on a raster's cells, a staircase: :func:`_lattice_cells`)
when at least this share of its segments run along a lattice direction (a multiple of 45° in
the file's coordinates) with a length that is a whole number of the layer's cells, and it
turns."""
LATTICE_ANGLE = 0.01
"""A segment runs along a lattice direction when its smaller coordinate step is under this
fraction of its larger one (an axis, within 0.6°) or over 1 − this (a diagonal)."""
TRACED_CAP_CELLS = 0.5 * math.sqrt(2.0)
"""A grid-traced centre line is moved by at most max(half its width, this many cells: half a
cell's diagonal, so it stays in the cells it was traced through)."""
TRACED_SIGMA_CELLS = 1.5
"""Grid-traced lines are smoothed by a Gaussian of σ = max(this many cells, half the width)
along them: it takes out the steps of one or two cells that tracing on a lattice makes."""
DELTA_COS = 0.5
DELTA_COS_EVIDENCE = 0.0
"""A piece of network that drains to several outlets is a delta (kept so, each line as drawn
or as its own elevations or drainage areas say: :func:`_drains_as_a_delta`) when at every
split each outflow leaves within acos(DELTA_COS) = 60° of the inflow's direction (delta
bifurcations open by about 70° in all, Coffey & Shaw 2017, GRL 44; a tributary drawn upstream
points back), or within 90° where the lines' own values tell their direction."""
MERGE_GAP = 0.42
"""Two channels flowing into one junction (braid arms, rivers meeting at a very acute angle)
whose centre lines run closer than MERGE_GAP × the sum of their widths for longer than
MERGE_REACH × the wider one's width above the junction are merged there into one wider reach
(:func:`_merge_close_channels`): narrowing them (:func:`_narrow_branches`, NARROW_GAP · d ·
w / (w + w_other)) would leave each less than a third of its width."""
MERGE_REACH = 2.0
SIDE_ANGLE_DEG = 45.0
"""An inflow that enters a junction less than this far from an outflow's course, no wider
than it, its water in the outflow's beyond the junction (NHDPlus: a 10 m canal's last 41 m
laid back up a 22 m river's line, 29° off it), joins the outflow farther down instead
(:func:`_move_side_inflows`)."""
CONTINUATION_WIDTHS = 2.0
"""The outlet added where rivers meet at the edge of clipped data (nothing leaves the
junction) is this many times the widest inflow's width long."""
MIN_WIDTH_M = 0.5
"""Narrowest river made [m] (the flow lattice is a 24th of the narrowest width)."""
SIMPLIFY_WIDTHS = 0.05
"""Centre lines are simplified (Douglas-Peucker) to this fraction of their width (at most
SIMPLIFY_MAX_M), so dense digitising does not cost strips and banks."""
SIMPLIFY_MAX_M = 2.0
LEVEL_SPACING_M = 5.0
AUTO_ORIGIN_M = 100_000.0
"""``origin_m="auto"`` moves coordinates farther than this [m] from 0 near 0 (module docstring)."""
"""Spacing [m] of the water-level samples along the links (elevation attributes)."""

OSM_WATERWAYS = ("river", "stream", "canal", "ditch", "drain")
"""The OpenStreetMap ``waterway=*`` values read as river centre lines (other ways are left
out, and the report says which)."""
OSM_SOURCE_WIDTH_M = {"stream": 2.0, "ditch": 1.0, "drain": 1.0, "canal": 6.0}
"""A source way's width [m] by its ``waterway=`` class where it has no ``width`` tag (rule 4
of the module docstring; ``river`` and any other: the geometry's ``default_width_m``): a
stream is one a person can jump across, a ditch or drain a field's channel (OSM wiki,
Key:waterway). Read as 10 m rivers, the ditches beside a stream overlapped it."""
OSM_FALLS = {"waterfall": "fall", "weir": "weir", "dam": "dam"}
"""OpenStreetMap ``waterway=*`` nodes and ways read as falls (:meth:`RiverNetworkBuilder.
add_fall`), with the kind each becomes. A node is the lip; a way (a weir's or dam's crest
across the river) is placed where it crosses a river line, else at its middle."""
OSM_DEFAULT_DROP_M = 2.0
"""The drop [m] of an OSM fall without a ``drop_m`` or ``height`` tag (the report says so)."""

KNOWN_ATTRIBUTES: dict[str, tuple] = {
    "width_m": ("width_m",),
    "drainage_area_km2": ("drainage_area_km2", "usarea_km2", "TotDASqKM", "UPLAND_SKM",
                          "uparea", "DSContArea_km2"),
    "stream_order": ("stream_order", "strmOrder", "StreamOrde", "ORD_STRA", "strahler"),
    "elevation_m": (("uselev_m", "dselev_m"), ("elev_up_m", "elev_down_m")),
}
PLAUSIBLE_MAX = {"width_m": 1e5, "discharge_m3s": 1e7, "discharge_m2s": 1e8,
                 "drainage_area_km2": 1e8, "stream_order": 30.0, "elevation_m": 2e4}
"""Largest magnitude of each attribute a river can have (the Amazon: 2·10⁵ m³/s, 7·10⁶ km²,
order 12; a bed 11 km below to 9 km above the sea) with a wide margin: a value beyond it
lies (a unit slip, a no-data code such as 1e30) and is not used, as a negative one is."""

FLOW_DIRECTION_ATTRIBUTES = ("FLOWDIR", "flowDirection")
"""Attributes that say, line by line, whether a line is drawn in the flow's direction (looked
for, case-insensitive, when ``reverse`` is None): NHD's and NHDPlus's ``FLOWDIR`` ("With
Digitized"; NHDPlus HR: 1), the Ordnance Survey's (OS Open Rivers, INSPIRE hydrography)
``flowDirection`` ("inDirection", "inOppositeDirection"). A line they say is drawn with
the flow, or against it, is never turned; one they leave open ("Uninitialized", 0, "both",
empty) is directed by the topology (:func:`_direct`)."""
FLOW_AS_DRAWN = ("with digitized", "withdigitized", "1", "indirection")
FLOW_AGAINST = ("against digitized", "againstdigitized", "inoppositedirection")

"""Attribute names looked for (case-insensitive) when a keyword is left as None: TauDEM
(``strmOrder``), NHDPlus (``TotDASqKM``, ``StreamOrde``), HydroRIVERS (``UPLAND_SKM``,
``ORD_STRA``), MERIT Hydro (``uparea``), the Red Butte example (``usarea_km2``,
``uselev_m``/``dselev_m``). Only names whose unit is unambiguous are listed."""


class HydraulicGeometry(NamedTuple):
    """Power laws from drainage area to discharge, width and depth.

    Discharge from drainage area (mean annual flow): Q = c · A^d [m³/s, A in km²]. The
    default c = 0.0092 m³ s⁻¹ km⁻² is about 290 mm a year of runoff, the mean of the world's
    land (river discharge to the oceans ≈ 40 000 km³ a year over ≈ 135 million km²; Oki &
    Kanae 2006, Science 313); d = 1 (runoff proportional to area; regional regressions give
    0.7 - 1). Regional values are better: pass your own.

    Width and depth from discharge, downstream hydraulic geometry (Leopold & Maddock 1953,
    USGS Prof. Paper 252: w = a · Q^b, D = c · Q^f with b ≈ 0.5, f ≈ 0.4): the coefficients
    of Andreadis, Schumann & Pavelsky 2013 (Water Resour. Res. 49, doi:10.1002/wrcr.20440,
    after Moody & Troutman 2002), w = 7.2 · Q^0.50 m, D = 0.27 · Q^0.39 m, Q the mean annual
    flow [m³/s]. A 100 m river carries ~190 m³/s, a 1 m stream ~0.02 m³/s.

    Stream order ω to drainage area: Horton's law of stream areas (Schumm 1956), A = A₁ ·
    R_A^(ω − 1), with A₁ = ``order1_area_km2`` (depends on the map's resolution: the area
    draining to a first-order stream) and R_A = 4.7 (typical ratios 3 - 6; Strahler 1964).

    The builder's discharge is ψ's difference across the river, per unit depth: q = Q / D
    [m²/s] (= width × mean speed).
    """

    runoff_m3s_per_km2: float = 0.0092
    area_exponent: float = 1.0
    width_coef: float = 7.2
    width_exponent: float = 0.5
    depth_coef: float = 0.27
    depth_exponent: float = 0.39
    order1_area_km2: float = 1.0
    order_area_ratio: float = 4.7
    default_width_m: float = 10.0
    """Width [m] of a source river when nothing else says (rule 4 of the module docstring)."""

    def discharge_of_area(self, area_km2: float) -> float:
        """Mean annual flow Q [m³/s] of a drainage area [km²]."""
        return self.runoff_m3s_per_km2 * area_km2 ** self.area_exponent

    def area_of_order(self, order: float) -> float:
        """Drainage area [km²] of a Strahler order."""
        return self.order1_area_km2 * self.order_area_ratio ** (order - 1.0)

    def width(self, q_m3s: float) -> float:
        """Width [m] for a discharge [m³/s]."""
        return self.width_coef * q_m3s ** self.width_exponent

    def discharge_of_width(self, width_m: float) -> float:
        """The discharge [m³/s] whose width is ``width_m``."""
        return (width_m / self.width_coef) ** (1.0 / self.width_exponent)

    def depth(self, q_m3s: float) -> float:
        """Depth [m] for a discharge [m³/s]."""
        return self.depth_coef * q_m3s ** self.depth_exponent

    def psi(self, q_m3s: float) -> float:
        """ψ discharge q = Q / D [m²/s] of a volume discharge [m³/s]."""
        return q_m3s / self.depth(q_m3s)

    def volume(self, q_m2s: float) -> float:
        """The volume discharge Q [m³/s] whose ψ discharge is ``q_m2s`` (inverse of psi)."""
        return (self.depth_coef * q_m2s) ** (1.0 / (1.0 - self.depth_exponent))


DEFAULT_GEOMETRY = HydraulicGeometry()


class Repair(NamedTuple):
    """One defect of the data that :func:`read_rivers` repaired (``builder.report.repairs``)."""

    feature: str
    """The feature (or branch) it touched: ``feature <fid>`` (+ ``part k``, ``piece k``)."""
    fid: int | None
    """Its feature id (None for a repair that names no single feature)."""
    attributes: dict[str, Any]
    """Its attribute values."""
    what: str
    """What was wrong and what was done."""

    def __str__(self) -> str:
        return f"{self.feature}: {self.what} [{_attrs_text(self.attributes)}]"


class ImportedLink(NamedTuple):
    """One link as it went into the builder (``builder.report.links``)."""

    name: str
    """Branch name in the builder: ``feature <fid>`` (+ ``part k``, ``piece k``)."""
    fid: int
    width_m: float
    discharge_m2s: float
    """ψ difference across the river [m²/s] (what the builder conserves)."""
    discharge_m3s: float
    """Volume discharge [m³/s] by :class:`HydraulicGeometry` (given or derived)."""
    width_from: str
    discharge_from: str
    lateral_m2s: float
    """Lateral inflow [m²/s] entering at its upstream junction (0 if none)."""


@dataclass
class RiverImport:
    """What :func:`read_rivers` read and did (``builder.report``; ``str()`` summarises)."""

    path: str
    layer: str
    features: int
    source_crs: str | None
    crs: str | None
    links: list[ImportedLink] = field(default_factory=list)
    derived: dict[str, Any] = field(default_factory=dict)
    """How widths, discharges, elevations and coordinates were obtained (counts per method)."""
    notes: list[str] = field(default_factory=list)
    """What was changed: snapped ends, split lines, merged junctions, dropped links, …"""
    attributes: dict[str, dict[str, Any]] = field(default_factory=dict)
    """Attribute values of every feature, by branch name (for error messages)."""
    origin_m: tuple[float, float] = (0.0, 0.0)
    """What was subtracted from the projected coordinates [m] (``read_rivers(origin_m=)``)."""
    repairs: list[Repair] = field(default_factory=list)
    """Every defect of the data that was repaired, with the feature it touched."""
    strict: bool = False
    """``read_rivers(strict=True)``: the first defect raises instead of being repaired."""
    optional: set[str] = field(default_factory=set)
    """Attributes that are often absent (OSM's ``width`` tag): a missing value there is no
    defect and is not reported."""

    def repair(self, feature: str, fid: int | None, attributes: dict[str, Any] | None,
               what: str) -> None:
        """Record a repair; in strict mode raise :class:`GraphError` naming the file, layer,
        feature and attributes instead."""
        attributes = attributes or {}
        if self.strict:
            raise GraphError(f"{self.path} (layer {self.layer!r}): {feature}: {what} "
                             f"[{_attrs_text(attributes)}] (strict=True: no repairs)")
        self.repairs.append(Repair(feature, fid, dict(attributes), what))

    @property
    def length_m(self) -> float:
        """Total length [m] of the links' centre lines as built (``read_rivers``)."""
        return float(self.derived.get("length_m", 0.0))

    def __str__(self) -> str:
        lines = [f"{self.path} (layer {self.layer!r}): {self.features} features -> "
                 f"{len(self.links)} links; CRS {_short_crs(self.crs)}"
                 + (f" (from {_short_crs(self.source_crs)})"
                    if self.source_crs and self.source_crs != self.crs else "")]
        lines += [f"  {k}: {v}" for k, v in self.derived.items()]
        lines += [f"  note: {n}" for n in self.notes]
        lines.append(f"  repairs: {len(self.repairs)}" if self.repairs else "  repairs: none")
        lines += [f"  repair: {r}" for r in self.repairs]
        return "\n".join(lines)


class GisRiverBuilder(RiverNetworkBuilder):
    """The :class:`RiverNetworkBuilder` :func:`read_rivers` returns: ``report``
    (:class:`RiverImport`), ``derived`` (its ``derived`` dict) and ``crs``; ``build()`` errors
    name the features (id and attribute values) and the file."""

    report: RiverImport

    @property
    def derived(self) -> dict[str, Any]:
        return self.report.derived

    def build(self):
        """Make the hydro graph (``graph.source``: the GIS file); errors name the features.

        Where it fails because channels lie closer together than their widths (two arms of
        a braid converging at an acute angle, neighbouring rivers, a bend tighter than the
        river is wide), the widths narrow there and it tries again (up to NARROW_TRIES
        times, a reported repair per branch; not in strict mode)."""
        if not self.report.strict:
            _cut_ends_in_water(self._branches, self.report)
        for attempt in range(NARROW_TRIES + 1):
            try:
                graph = super().build()
                break
            except GraphError as exc:
                if self.report.strict or attempt == NARROW_TRIES or not _narrow_branches(
                        self._branches, self.report, attempt):
                    self._raise_named(exc)
        graph.source = self.report.path
        return graph

    def _raise_named(self, exc: GraphError):
        """Raise ``exc`` again with the file, the layer and the named features' attributes."""
        text = str(exc)
        named = [n for n in self.report.attributes if f"'{n}'" in text]
        where = "; ".join(f"{n} = {_attrs_text(self.report.attributes[n])}" for n in named)
        raise GraphError(f"{self.report.path} (layer {self.report.layer!r}): {text}"
                         + (f" [{where}]" if where else "")) from None


# -- reading -------------------------------------------------------------------------------------


@dataclass
class _Link:
    """A link being imported: centre line (K, 2) [m] drawn downstream, and its values."""

    name: str
    fid: int
    points: np.ndarray
    attrs: dict[str, Any]
    values: dict[str, tuple[float, float]]   # keyword → (value at start, value at end), NaN = none
    start: int = -1
    end: int = -1
    z: tuple[float, float] = (math.nan, math.nan)
    """Z of its first and last vertex (NaN when the file has none)."""
    fixed: bool = False
    """Its direction was set by the user (``reverse=``): never turned."""
    added: bool = False
    """Made by a repair (a continuation at a clipped outlet), not read from the file."""
    cell_m: float = math.nan
    """The raster cell [m] its source line was traced on (:func:`_lattice_cells`), NaN for a
    line that is not grid-traced."""
    source_width_m: float = math.nan
    """The width [m] it has as a source where nothing is given (OSM_SOURCE_WIDTH_M by its
    OSM class); NaN: the geometry's ``default_width_m``."""


@without_collector
def read_rivers(path, *, layer: str | int | None = None, width_m=None, discharge_m2s=None,
                drainage_area_km2=None, elevation_m=None, crs=None, discharge_m3s=None,
                stream_order=None, reverse=None, origin_m="auto",
                snap_m: float = DEFAULT_SNAP_M,
                geometry: HydraulicGeometry = DEFAULT_GEOMETRY,
                tolerance_m: float = 0.25, strict: bool = False, lakes=None) -> GisRiverBuilder:
    """Stream centre lines from a GIS file as a filled river-network builder.

    Args:
        path: a shapefile (``.shp``), GeoPackage (``.gpkg``) or GeoJSON (``.geojson``,
            ``.json``) file of line features, one per link, drawn downstream.
        layer: layer name or index (GeoPackages may hold several); default: the only line
            layer, else the first.
        width_m: river width [m]: an attribute name or a number.
        discharge_m2s: ψ discharge [m²/s] (width × mean speed): attribute name or number.
        drainage_area_km2: drainage area [km²]: an attribute, a pair (upstream end, downstream
            end) of attributes, or a number.
        elevation_m: bed elevation [m]: a pair of attributes (upstream end, downstream end),
            one attribute or a number; the water surface follows it (bed + depth).
        crs: the coordinates' CRS (anything pyproj reads: ``"EPSG:4326"``, WKT, …) when the
            file has none or a wrong one.
        discharge_m3s: volume discharge Q [m³/s] (mean annual flow): attribute or number.
        stream_order: Strahler order: attribute or number.
        reverse: attribute whose true values mark lines drawn upstream, or True (all are).
        lakes: lakes the lines run through (:meth:`RiverNetworkBuilder.add_lake`): a polygon
            file (its CRS; every polygon is a lake) or polygons (shapely, or (M, 2) arrays) in
            the lines' CRS. A line is cut at a lake's shore; a link inside a lake is left out
            (reported: the lake carries its water); a link that starts in a lake takes its
            discharge from the lake.
        origin_m: (x, y) [m] subtracted from the (projected) coordinates, None for none, or
            "auto": the data's centre rounded to 1 km when it lies more than AUTO_ORIGIN_M
            from 0 (the module docstring); the CRS's false origin moves with it.
        snap_m: ends (and ends and lines) closer than this [m] are joined.
        geometry: the hydraulic-geometry laws and constants (:class:`HydraulicGeometry`).
        tolerance_m: the builder's tolerance [m].
        strict: False (default): defects of real data (module docstring, "Repairs") are
            repaired and listed in ``builder.report.repairs``; True: the first one raises
            :class:`GraphError` naming the file, layer, feature and attributes.

    Returns:
        A :class:`GisRiverBuilder` (a :class:`~riverflow.RiverNetworkBuilder` with lateral
        inflow on) holding every link; ``report`` says what was derived and changed.

    Raises:
        FileNotFoundError: no such file.
        GraphError: unreadable file, unknown layer or attribute, no features, a feature that
            is not a line or has NaN coordinates, a CRS that cannot be projected, bad values.
        ImportError: the ``gis`` extra is not installed.
        TypeError / ValueError: an argument of the wrong type or out of range
            (:func:`_check_arguments`, before the file is opened), naming the argument.
    """
    _check_arguments(path=path, layer=layer, crs=crs, snap_m=snap_m, geometry=geometry,
                     tolerance_m=tolerance_m, strict=strict, width_m=width_m,
                     discharge_m2s=discharge_m2s, discharge_m3s=discharge_m3s,
                     drainage_area_km2=drainage_area_km2, stream_order=stream_order,
                     elevation_m=elevation_m)
    path = Path(path)
    where = str(path)
    pyogrio = require("pyogrio", f"reading {where}")
    if not path.exists():
        raise FileNotFoundError(f"GIS file not found: {where}")
    if path.is_file() and path.stat().st_size == 0:
        raise GraphError(f"{where}: the file is empty")
    osm = _is_osm(path)
    layer_name = "lines" if osm and layer is None else _pick_layer(pyogrio, path, layer)
    where = f"{path} (layer {layer_name!r})"
    try:
        meta, fids, wkb, columns = _read_raw(pyogrio, path, layer_name)
    except Exception as exc:  # pyogrio's DataSourceError and friends: say which file
        raise GraphError(f"{where}: cannot read it: {exc}") from None
    names = [str(n) for n in meta["fields"]]
    table = {n: columns[k] for k, n in enumerate(names)}
    osm_notes: list[str] = []
    osm_bad_widths: list = []
    osm_falls: list[tuple[str, np.ndarray, str, float | None, shapely.Geometry | None]] = []
    if osm:
        osm_falls = _osm_fall_features(pyogrio, path, fids, wkb, table)
        fids, wkb, table, names, osm_notes, osm_bad_widths = _osm_waterways(
            fids, wkb, table, names, where)
        if width_m is None:
            width_m = "width"
    if len(fids) == 0:
        raise GraphError(f"{where}: no features (an empty layer)"
                         + (f"; {osm_notes[0]}" if osm_notes else ""))
    fids = np.asarray(fids, np.int64)

    def attrs_of(k: int) -> dict[str, Any]:
        return {n: _plain(table[n][k]) for n in names}

    report = RiverImport(str(path), layer_name, len(fids), None, None, strict=bool(strict))
    report.notes += osm_notes
    if osm:
        report.optional.add("width")
    for k, tag in osm_bad_widths:
        report.repair(f"feature {fids[k]}", int(fids[k]), attrs_of(k),
                      f"width tag {tag!r} is not a width in metres: not used (the link falls "
                      "back to the next rule)")
    keys = {"width_m": width_m, "discharge_m2s": discharge_m2s, "discharge_m3s": discharge_m3s,
            "drainage_area_km2": drainage_area_km2, "stream_order": stream_order,
            "elevation_m": elevation_m}
    specs = {k: _attribute_spec(k, v, names, where, report) for k, v in keys.items()}
    flip = _reverse_spec(reverse, names, where)
    flow_dir = None
    if flip is None:                # the file's own word on each line's direction, if any
        lower = {n.lower(): n for n in names}
        flow_dir = next((lower[a.lower()] for a in FLOW_DIRECTION_ATTRIBUTES
                         if a.lower() in lower), None)
    said = {"as drawn": 0, "against": 0, "open": 0}

    geoms, invalid = _from_wkb(wkb)
    raw = _lines(geoms, fids, attrs_of, where, report, invalid)
    if crs is None and path.suffix.lower() in (".geojson", ".json"):
        _check_geojson_crs(path, where)
    source_crs = crs if crs is not None else meta.get("crs")
    fall_xy = [f[1] for f in osm_falls]
    lake_geoms = _lake_polygons(lakes, source_crs, where) if lakes is not None else []
    lake_xy = shapely.get_coordinates(lake_geoms) if lake_geoms else np.zeros((0, 2))
    xy, crs_out, crs_note = _project(np.vstack([p for _, _, p, _ in raw] + [lake_xy] + fall_xy),
                                     source_crs, where,
                                     [(fids[k], attrs_of(k), len(p)) for k, _, p, _ in raw]
                                     + [(-1, {"lakes": len(lake_geoms)}, len(lake_xy))])
    report.source_crs = _wkt(source_crs)
    xy = _move_to_origin(xy, origin_m, crs_out, crs_note, where, report)
    if fall_xy:             # the falls' points, projected and moved with the lines
        n_fall = sum(len(p) for p in fall_xy)
        xy, fall_pts = xy[:-n_fall], xy[-n_fall:]
        at = np.cumsum([0] + [len(p) for p in fall_xy])
        osm_falls = [(name, fall_pts[at[i]:at[i + 1]], kind, drop, None)
                     for i, (name, _, kind, drop, _) in enumerate(osm_falls)]
    if lake_geoms:
        lake_geoms = list(shapely.set_coordinates(np.array(lake_geoms, dtype=object),
                                                  xy[len(xy) - len(lake_xy):]))
        xy = xy[:len(xy) - len(lake_xy)]

    cells = _lattice_cells([pts for _, _, pts, _ in raw])
    links: list[_Link] = []
    at = 0
    for (k, part, pts, z), cell in zip(raw, cells):
        p = xy[at:at + len(pts)]
        at += len(pts)
        name = f"feature {fids[k]}" + (f" part {part}" if part is not None else "")
        attrs = attrs_of(k)
        values = {key: _values(spec, table, k, name, attrs, where, report, int(fids[k]), key)
                  for key, spec in specs.items()}
        users = flip is not None and _truthy(flip if isinstance(flip, bool) else table[flip][k])
        told = None
        if flow_dir is not None:
            word = _plain(table[flow_dir][k])
            word = str(int(word) if isinstance(word, float) and word.is_integer() else word)
            told = ("as drawn" if word.strip().lower() in FLOW_AS_DRAWN else "against"
                    if word.strip().lower() in FLOW_AGAINST else "open")
            said[told] += 1
        if users or told == "against":
            p, z = p[::-1], (z[1], z[0])
            values = {key: (v[1], v[0]) for key, v in values.items()}
        link = _Link(name, int(fids[k]), np.ascontiguousarray(p), attrs, values)
        link.z = z
        # the user's word, the file's, or OSM's rule
        link.fixed = users or osm or (flip is not None) or told in ("as drawn", "against")
        if osm:
            link.source_width_m = OSM_SOURCE_WIDTH_M.get(str(attrs.get("waterway")), math.nan)
        if math.isfinite(cell):                           # the cell in metres, as projected
            link.cell_m = cell * _length(p) / max(_length(pts), 1e-300)
        links.append(link)
    if flow_dir is not None:
        report.derived["direction"] = (
            f"by the attribute {flow_dir!r}: {said['as drawn']} line(s) drawn with the flow"
            + (f", {said['against']} against it (turned)" if said["against"] else "")
            + (f"; {said['open']} it leaves open, directed by the topology"
               if said["open"] else ""))
    links = _clean(links, report)
    if not links:
        last = report.repairs[-1] if report.repairs else None
        raise GraphError(f"{where}: no line with two distinct points"
                         + (f": {last.feature}: {last.what}" if last else ""))
    links = _drop_duplicates(links, snap_m, report)
    links, crossings = _topology(links, snap_m, report)
    links = _direct(links, report)
    widths = None                   # a file's lines as wide as the discharges summed down say
    if not (osm or report.strict):
        try:
            widths = [p[0] for p in _plan(links, geometry, specs, report)]
        except GraphError:          # a loop the user's or the file's directions close: later
            pass
    links = _join_runs(links, report, shapely.union_all(lake_geoms) if lake_geoms else None,
                       None if osm else geometry.default_width_m, widths)
    links = _drop_enclosed(links, report)
    if osm and flip is None:
        _break_osm_loops(links, report)
    plan = _plan(links, geometry, specs, report)
    links, plan = _close_clipped_ends(links, plan, geometry, specs, report)
    links, plan = _merge_close_junctions(links, plan, geometry, specs, report)
    if crossings:
        links, plan = _cut_crossings(links, plan, crossings, geometry, specs, report)
    if not report.strict:
        links, plan = _merge_close_channels(links, plan, geometry, specs, report)
        links, plan = _merge_close_channels(links, plan, geometry, specs, report, outflow=True)
        links, plan = _move_side_inflows(links, plan, geometry, specs, report)

    builder = GisRiverBuilder(tolerance_m, lateral_inflow=True)
    builder.report = report
    builder.crs = report.crs
    _smooth_traced(links, plan, report)
    lake_area = shapely.union_all(lake_geoms) if lake_geoms else None
    for link, (width, q, q3, wfrom, qfrom, lateral) in zip(links, plan):
        _report_substitutions(link, wfrom, qfrom, report)
        line = _simplify(link.points, width)
        line, hooks = _trim_hooks(line, width, link.start < 0, link.end < 0)
        if hooks:
            report.repair(link.name, link.fid, link.attrs, "; ".join(hooks))
        if lake_area is not None:
            if lake_area.buffer(tolerance_m).contains(shapely.LineString(line)):
                report.repair(link.name, link.fid, link.attrs, "inside a lake: left out (the "
                              "lake carries its water)")
                continue
            if lake_area.distance(shapely.Point(line[0])) <= 0.75 * width:
                q = None            # it starts in a lake: its discharge is the lake's outflow
        builder.add_branch(line, width, discharge_m2s=q, name=link.name)
        report.links.append(ImportedLink(link.name, link.fid, width, q, q3, wfrom, qfrom, lateral))
        report.attributes[link.name] = link.attrs
    for poly in lake_geoms:
        builder.add_lake(poly)
    if lake_geoms:
        report.derived["lakes"] = f"{len(lake_geoms)} given: flat water bodies the lines run through"
    _summarise(report)
    report.derived["length_m"] = round(sum(_length(lk.points) for lk in links if not lk.added), 1)
    if specs["elevation_m"] is not None:
        builder.water_levels = _water_levels(links, plan, geometry, report)
    _add_osm_falls(builder, osm_falls, report)
    return builder


def _osm_fall_features(pyogrio, path: Path, fids, wkb, table: dict):
    """The falls of an OSM file (OSM_FALLS): (name, points (K, 2) in the file's CRS, kind,
    drop [m] or None) of the ``points`` layer's nodes and the ``lines`` layer's ways tagged
    ``waterway=waterfall|weir|dam`` (a node: its point; a way: its vertices, placed later);
    the drop from a ``drop_m`` or ``height`` tag."""
    out = []

    def drop_of(tags: dict) -> float | None:
        for key in ("drop_m", "height"):
            if key in tags:
                value = _osm_width(tags[key])
                if math.isfinite(value) and value > 0.0:
                    return value
        return None

    try:
        meta, pfids, pwkb, pcols = _read_raw(pyogrio, path, "points")
        pnames = [str(n) for n in meta["fields"]]
    except Exception:  # noqa: BLE001 - no points layer: no falls from nodes
        pfids, pwkb, pcols, pnames = [], [], [], []
    ptable = {n: pcols[k] for k, n in enumerate(pnames)}
    other = ptable.get("other_tags", [None] * len(pfids))
    for k in range(len(pfids)):
        tags = _hstore(other[k])
        kind = OSM_FALLS.get(str(ptable["waterway"][k]) if "waterway" in ptable
                             and ptable["waterway"][k] is not None else tags.get("waterway"))
        if kind is None or pwkb[k] is None:
            continue
        pt = shapely.from_wkb(pwkb[k])
        out.append((f"node {pfids[k]}", shapely.get_coordinates(pt)[:1], kind, drop_of(tags),
                    None))
    if "waterway" in table:
        other = table.get("other_tags", [None] * len(fids))
        for k, w in enumerate(table["waterway"]):
            kind = OSM_FALLS.get(None if w is None else str(w))
            if kind is None or wkb[k] is None:
                continue
            line = shapely.from_wkb(wkb[k])
            out.append((f"way {fids[k]}", shapely.get_coordinates(line), kind,
                        drop_of(_hstore(other[k])), None))
    return out


def _add_osm_falls(builder: RiverNetworkBuilder, falls, report) -> None:
    """Each OSM fall onto the builder (:meth:`~RiverNetworkBuilder.add_fall`): a node at its
    point, a way where it crosses a river's centre line (else at its middle); the report
    notes the drops assumed and the falls left out (off every river)."""
    if not falls:
        return
    lines = [b.centerline_m for b in builder._branches]
    tree = shapely.STRtree([shapely.LineString(ln) for ln in lines]) if lines else None
    added, assumed, left = [], [], []
    for name, pts, kind, drop in ((f[0], f[1], f[2], f[3]) for f in falls):
        if len(pts) == 1:
            at = pts[0]
        else:
            way = shapely.LineString(pts)
            at = np.asarray(way.interpolate(0.5, normalized=True).coords[0])
            if tree is not None:
                for i in tree.query(way, predicate="intersects"):
                    cross = shapely.get_coordinates(
                        shapely.intersection(way, shapely.LineString(lines[i])))
                    if len(cross):
                        at = cross[0]
                        break
        if drop is None:
            drop = OSM_DEFAULT_DROP_M
            assumed.append(name)
        try:
            builder.add_fall(at, drop, kind=kind)
            added.append(name)
        except GraphError as exc:
            left.append(f"{name} ({exc})")
    if added:
        report.derived["falls"] = f"{len(added)} from OpenStreetMap: {', '.join(added[:8])}"
    if assumed:
        report.notes.append(f"OpenStreetMap: {len(assumed)} falls without a drop_m or height "
                            f"tag, {OSM_DEFAULT_DROP_M:g} m assumed: {', '.join(assumed[:8])}")
    if left:
        report.notes.append(f"OpenStreetMap: {len(left)} falls left out: {'; '.join(left[:8])}")


def _check_arguments(*, path, layer, crs, snap_m, geometry, tolerance_m, strict,
                     **values) -> None:
    """read_rivers' arguments, before any file is opened (riverflow._validate): ``path`` a
    str or os.PathLike; ``layer`` None, a name or an index; ``crs`` None, text, an EPSG code,
    a dict or a pyproj CRS; ``snap_m`` ≥ 0 and ``tolerance_m`` > 0, finite; ``geometry`` a
    :class:`HydraulicGeometry` of finite positive numbers (depth_exponent < 1);
    ``strict`` a bool; each value keyword None, an attribute name (a pair for
    ``elevation_m`` / ``drainage_area_km2``) or a number: finite (elevation_m), ≥ 1
    (stream_order), else > 0. TypeError / ValueError naming the argument."""
    if isinstance(path, bytes) or not isinstance(path, (str, os.PathLike)):
        raise TypeError(f"read_rivers: path must be a file path (str or os.PathLike), got "
                        f"{type(path).__name__} {path!r:.80}")
    if layer is not None and (isinstance(layer, bool)
                              or not isinstance(layer, (str, int, np.integer))):
        raise TypeError(f"read_rivers: layer must be a layer name or index, got "
                        f"{type(layer).__name__} {layer!r:.80}")
    if crs is not None and (isinstance(crs, (bool, float, bytes)) or not (
            isinstance(crs, (str, int, np.integer, dict)) or hasattr(crs, "to_wkt"))):
        raise TypeError(f"read_rivers: crs must be a CRS (text such as 'EPSG:4326', an EPSG "
                        f"code, a dict or a pyproj.CRS), got {type(crs).__name__} {crs!r:.80}")
    _validate.non_negative(snap_m, "read_rivers: snap_m")
    _validate.finite_positive(tolerance_m, "read_rivers: tolerance_m")
    if not isinstance(strict, (bool, np.bool_)):
        raise TypeError(f"read_rivers: strict must be True or False, got {strict!r:.80}")
    if not isinstance(geometry, HydraulicGeometry):
        raise TypeError(f"read_rivers: geometry must be a HydraulicGeometry, got "
                        f"{type(geometry).__name__}")
    for name, v in geometry._asdict().items():
        _validate.finite_positive(v, f"read_rivers: geometry.{name}")
    if not geometry.depth_exponent < 1.0:
        raise ValueError(f"read_rivers: geometry.depth_exponent must be < 1 (Q = c·q^(1/(1−f))),"
                         f" got {geometry.depth_exponent!r}")
    for key, value in values.items():
        arg = f"read_rivers: {key}"
        if value is None or isinstance(value, str):
            continue
        if isinstance(value, (tuple, list)):
            if all(isinstance(v, str) for v in value):
                continue                    # names: checked against the file's attributes
            raise TypeError(f"{arg} must be an attribute name"
                            + (" or a pair of them" if key in ("elevation_m", "drainage_area_km2")
                               else "") + f" or a number, got {value!r:.80}")
        try:
            v = _validate.finite(value, arg)
        except TypeError:
            raise TypeError(f"{arg} must be an attribute name or a number, got "
                            f"{type(value).__name__} {value!r:.80}") from None
        if key == "stream_order" and v < 1.0:
            raise ValueError(f"{arg} must be ≥ 1 (Strahler orders start at 1), got {value!r}")
        if key not in ("elevation_m", "stream_order"):
            _validate.finite_positive(value, arg)


def _is_osm(path: Path) -> bool:
    name = path.name.lower()
    return name.endswith(".osm") or name.endswith(".osm.pbf") or name.endswith(".pbf")


def _osm_waterways(fids, wkb, table: dict, names: list[str], where: str):
    """The ways of an OSM ``lines`` layer (GDAL's OSM driver) tagged ``waterway=`` one of
    OSM_WATERWAYS, with a numeric ``width`` column from the ``width`` tag (metres; NaN where
    absent or unreadable); a note on the ways left out; and (index, tag) of the kept ways
    whose width tag is unreadable (read_rivers reports them)."""
    if "waterway" not in table:
        raise GraphError(f"{where}: no 'waterway' attribute: not an OpenStreetMap lines layer "
                         f"(its attributes: {names})")
    kind = np.array([None if w is None else str(w) for w in table["waterway"]], dtype=object)
    keep = np.array([k in OSM_WATERWAYS for k in kind], dtype=bool)
    other = table.get("other_tags", np.full(len(kind), None, dtype=object))
    tags = [_hstore(t).get("width") for t in other]
    width = np.array([_osm_width(t) for t in tags])
    unreadable = [t is not None and math.isnan(w) for t, w in zip(tags, width)]
    left: dict[str, int] = {}
    falls = np.array([k in OSM_FALLS for k in kind], dtype=bool)   # read as falls instead
    for k in kind[~keep & ~falls]:
        label = f"waterway={k}" if k is not None else "not a waterway"
        left[label] = left.get(label, 0) + 1
    notes = []
    if left:
        out = ~keep & ~falls
        ids = [str(table["osm_id"][i]) if "osm_id" in table else str(fids[i])
               for i in np.flatnonzero(out)[:8]]
        notes.append(f"OpenStreetMap: {int(out.sum())} ways left out (not waterway="
                     f"{'|'.join(OSM_WATERWAYS)}): "
                     + ", ".join(f"{k} ×{n}" for k, n in sorted(left.items()))
                     + f"; ways {', '.join(ids)}{', …' if out.sum() > 8 else ''}")
    table = {n: np.asarray(v)[keep] for n, v in table.items()}
    table["width"] = width[keep]
    names = [*names, "width"] if "width" not in names else names
    bad = [(k, tags[i]) for k, i in enumerate(np.flatnonzero(keep)) if unreadable[i]]
    return (np.asarray(fids)[keep], np.asarray(wkb, dtype=object)[keep], table, names, notes,
            bad)


def _hstore(text) -> dict[str, str]:
    """GDAL's ``other_tags`` (``"k"=>"v","k2"=>"v2"``) as a dict."""
    if not text:
        return {}
    out = {}
    for part in str(text).split('","'):
        k, sep, v = part.strip('"').partition('"=>"')
        if sep:
            out[k] = v
    return out


def _osm_width(text) -> float:
    """An OSM ``width`` tag in metres ("12", "12 m", "7.5", "40'"): NaN when unreadable."""
    if text is None:
        return math.nan
    t = str(text).strip().lower().replace(",", ".")
    try:
        if t.endswith("'") or t.endswith("ft"):
            return float(t.rstrip("'ft ").strip()) * 0.3048
        return float(t.removesuffix("m").strip())
    except ValueError:
        return math.nan


def _read_raw(pyogrio, path: Path, layer: str):
    """``pyogrio.raw.read`` of a layer with its fids; an OpenStreetMap file whose node ids
    do not increase (an editor's export, not a planet extract: GDAL's OSM driver then asks
    for OSM_USE_CUSTOM_INDEXING=NO) is read again with that option (its slower index)."""
    try:
        return pyogrio.raw.read(str(path), layer=layer, return_fids=True)
    except Exception as exc:  # noqa: BLE001 - pyogrio's errors: retried or raised as they are
        if "OSM_USE_CUSTOM_INDEXING=NO" not in str(exc):
            raise
    before = pyogrio.get_gdal_config_option("OSM_USE_CUSTOM_INDEXING")
    pyogrio.set_gdal_config_options({"OSM_USE_CUSTOM_INDEXING": "NO"})
    try:
        return pyogrio.raw.read(str(path), layer=layer, return_fids=True)
    finally:
        pyogrio.set_gdal_config_options({"OSM_USE_CUSTOM_INDEXING": before})


def _pick_layer(pyogrio, path: Path, layer) -> str:
    """The layer to read (a name), or GraphError naming the layers there are."""
    try:
        layers = pyogrio.list_layers(str(path))
    except Exception as exc:
        raise GraphError(f"{path}: cannot read it as GIS data: {exc}") from None
    names = [str(n) for n, _ in layers]
    kinds = [str(t) for _, t in layers]
    if not names:
        raise GraphError(f"{path}: no layers")
    if layer is None:
        lines = [n for n, t in zip(names, kinds) if "line" in t.lower()]
        return lines[0] if lines else names[0]
    if isinstance(layer, (int, np.integer)) and not isinstance(layer, bool):
        if not 0 <= int(layer) < len(names):
            raise GraphError(f"{path}: no layer {layer} (it has {len(names)}: {names})")
        return names[int(layer)]
    if str(layer) not in names:
        raise GraphError(f"{path}: no layer {layer!r}; its layers: {names}")
    return str(layer)


def _attribute_spec(key: str, value, names: list[str], where: str, report: RiverImport):
    """None (not given, no known attribute), a float, an attribute name, or a pair of names."""
    if value is None:
        lower = {n.lower(): n for n in names}
        for known in KNOWN_ATTRIBUTES.get(key, ()):
            if isinstance(known, tuple):
                if all(k.lower() in lower for k in known):
                    found = tuple(lower[k.lower()] for k in known)
                    report.notes.append(f"{key} from the attributes {found} (a known name)")
                    return found
            elif known.lower() in lower:
                report.notes.append(f"{key} from the attribute {lower[known.lower()]!r} "
                                    "(a known name)")
                return lower[known.lower()]
        return None
    if isinstance(value, (str, tuple, list)):
        items = [value] if isinstance(value, str) else list(value)
        if not items or (len(items) > 2) or (len(items) == 2 and key not in
                                              ("elevation_m", "drainage_area_km2")):
            raise GraphError(f"{where}: {key}={value!r}: give one attribute name"
                             + (" or a pair (upstream end, downstream end)"
                                if key in ("elevation_m", "drainage_area_km2") else ""))
        for item in items:
            if not isinstance(item, str):
                raise GraphError(f"{where}: {key}={value!r}: attribute names must be strings")
            if item not in names:
                close = [n for n in names if n.lower() == item.lower()]
                hint = f" (did you mean {close[0]!r}?)" if close else ""
                raise GraphError(f"{where}: no attribute {item!r} (for {key}){hint}; its "
                                 f"attributes: {names}")
        return items[0] if len(items) == 1 else tuple(items)
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise GraphError(f"{where}: {key} must be an attribute name or a number, got "
                         f"{value!r}") from None
    if not math.isfinite(number) or (number <= 0 and key != "elevation_m"):
        raise GraphError(f"{where}: {key}={value!r} must be a "
                         + ("finite number" if key == "elevation_m" else "positive number"))
    if abs(number) > PLAUSIBLE_MAX.get(key, math.inf):
        raise GraphError(f"{where}: {key}={value!r} is beyond any river's (at most "
                         f"{PLAUSIBLE_MAX[key]:g})")
    return number


def _reverse_spec(reverse, names: list[str], where: str):
    if reverse is None or isinstance(reverse, bool):
        return reverse or None
    if not isinstance(reverse, str) or reverse not in names:
        raise GraphError(f"{where}: no attribute {reverse!r} (for reverse); its attributes: "
                         f"{names}")
    return reverse


def _values(spec, table, k: int, name: str, attrs: dict, where: str,
            report: RiverImport | None = None, fid: int | None = None,
            key: str = "") -> tuple[float, float]:
    """(value at the link's start, at its end) of one keyword; NaN where not given. Text,
    NaN, (but for elevations) values ≤ 0 and stream orders below 1 are reported repairs and
    become NaN: the link falls back to the next rule."""
    if spec is None:
        return (math.nan, math.nan)
    if isinstance(spec, float):
        return (spec, spec)
    pair = spec if isinstance(spec, tuple) else (spec, spec)
    out, told = [], set()
    for attr in pair:
        raw = table[attr][k]
        try:
            v = math.nan if raw is None else float(raw)
        except (TypeError, ValueError):
            if report is None or report.strict:
                raise GraphError(f"{where}: {name}: attribute {attr!r} = {raw!r} is not a number "
                                 f"[{_attrs_text(attrs)}]") from None
            v, why = math.nan, f"{raw!r} is not a number"
        else:
            why = ("missing (NaN)" if not math.isfinite(v) else
                   f"{v:g} is not positive" if v <= 0 and key != "elevation_m" else
                   f"{v:g} is below 1 (Strahler orders start at 1)"
                   if v < 1 and key == "stream_order" else
                   f"{v:g} is beyond any river's (at most {PLAUSIBLE_MAX[key]:g})"
                   if key in PLAUSIBLE_MAX and abs(v) > PLAUSIBLE_MAX[key] else None)
            if why is not None:
                v = math.nan
        if why is not None and report is not None and attr not in told and not (
                raw is None or (isinstance(raw, float) and math.isnan(raw))
                and attr in report.optional):
            told.add(attr)
            report.repair(name, fid, attrs, f"attribute {attr!r}: {why}; not used (the link "
                                            "falls back to the next rule)")
        out.append(v)
    return (out[0], out[1])



def _from_wkb(wkb) -> tuple[list, dict[int, str]]:
    """Shapely geometries of the features, and why those that GEOS refuses are None (a line
    of one vertex, …)."""
    with np.errstate(invalid="ignore"):      # NaN coordinates are reported later
        try:
            return list(shapely.from_wkb(wkb)), {}
        except shapely.errors.GEOSException:
            pass
        geoms, invalid = [], {}
        for k, item in enumerate(wkb):
            try:
                geoms.append(shapely.from_wkb(item))
            except shapely.errors.GEOSException as exc:
                geoms.append(None)
                invalid[k] = str(exc).split(": ", 1)[-1].strip()
    return geoms, invalid


def _lines(geoms, fids, attrs_of, where: str, report: RiverImport, invalid=None
           ) -> list[tuple[int, int | None, np.ndarray, tuple[float, float]]]:
    """(feature index, part or None, coordinates (K, 2), Z at its ends) of every line.

    A feature with no geometry or one that is not a line, and non-finite vertices, are
    repairs (left out, reported; in strict mode GraphError); GraphError when no line is left.
    """
    out, first_problem = [], None

    def problem(k: int, label: str, what: str) -> None:
        nonlocal first_problem
        text = f"{where}: {label} {what} [{_attrs_text(attrs_of(k))}]"
        first_problem = first_problem or text
        if report.strict:
            raise GraphError(text)
        report.repair(label, int(fids[k]), attrs_of(k), what)

    for k, g in enumerate(geoms):
        label = f"feature {fids[k]}"
        if g is None or g.is_empty:
            problem(k, label, f"is not a valid geometry ({invalid[k]}): left out"
                    if invalid and k in invalid else "has no geometry: left out")
            continue
        kind = g.geom_type
        if kind in ("LineString", "LinearRing"):
            parts = [(None, g)]
        elif kind == "MultiLineString":
            parts = [(i, p) for i, p in enumerate(g.geoms) if not p.is_empty]
            parts = parts if len(parts) > 1 else [(None, parts[0][1])]
        elif kind == "GeometryCollection" and any(
                p.geom_type in ("LineString", "MultiLineString") for p in g.geoms):
            lines = [q for p in g.geoms for q in getattr(p, "geoms", [p])
                     if q.geom_type == "LineString" and not q.is_empty]
            parts = [(i, q) for i, q in enumerate(lines)]
            problem(k, label, f"is a GeometryCollection: its {len(lines)} lines kept, the "
                              "rest left out")
        else:
            problem(k, label, f"is a {kind}, not a line (stream centre lines must be "
                              "LineString or MultiLineString): left out")
            continue
        for part, line in parts:
            c3 = shapely.get_coordinates(line, include_z=True)
            c = np.ascontiguousarray(c3[:, :2])
            with np.errstate(invalid="ignore"):
                bad = ~(np.abs(c) <= MAX_COORDINATE).all(axis=1)     # also NaN
            name = label + ('' if part is None else f' part {part}')
            if bad.any():
                i = int(np.flatnonzero(bad)[0])
                kind = ("non-finite coordinates" if not np.isfinite(c[i]).all() else
                        f"a coordinate beyond ±{MAX_COORDINATE:g} (no map's)")
                what = (f"has {kind} at vertex {i} "
                        f"{tuple(float(v) for v in c[i])}: {int(bad.sum())} such vertices "
                        "left out")
                problem(k, name, what)
                c3, c = c3[~bad], c[~bad]
                if len(c) < 2:
                    continue
            out.append((k, part, c, (float(c3[0, 2]), float(c3[-1, 2]))))
    if not out:
        raise GraphError(f"{where}: no usable line"
                         + (f": {first_problem.removeprefix(where + ': ')}" if first_problem
                            else ""))
    return out


# -- coordinates ---------------------------------------------------------------------------------

MAX_COORDINATE = 1e12
"""Largest coordinate a vertex may have in its file (degrees, metres or feet of any CRS are
far below; past it float64 keeps less than a millimetre): beyond, the vertex is left out as
a NaN one is."""
MAX_EXTENT_M = 1e8
"""Widest network [m] once projected: 100,000 km, over twice round the Earth."""


def _lake_polygons(lakes, source_crs, where: str) -> list:
    """The lakes given to :func:`read_rivers` as shapely polygons in the lines' CRS."""
    if isinstance(lakes, (str, Path)):
        from riverflow.gis.water import _read_polygons

        features, lake_crs, _ = _read_polygons(Path(lakes), None)
        polys = [g for _, g, _ in features if g is not None and not g.is_empty]
        if lake_crs and source_crs:
            pyproj = require("pyproj", f"projecting the lakes of {where}")
            a, b = pyproj.CRS.from_user_input(lake_crs), pyproj.CRS.from_user_input(source_crs)
            if a != b:
                to = pyproj.Transformer.from_crs(a, b, always_xy=True)
                polys = [shapely.transform(g, lambda p: np.column_stack(
                    to.transform(p[:, 0], p[:, 1]))) for g in polys]
    else:
        polys = [g if isinstance(g, shapely.Geometry) else shapely.Polygon(np.asarray(g, float))
                 for g in lakes]
    out = []
    for k, g in enumerate(polys):
        parts = [p for p in shapely.get_parts(shapely.make_valid(g)) if p.geom_type == "Polygon"]
        if not parts:
            raise GraphError(f"{where}: lake {k} is not a polygon with an area")
        out += parts
    return out


def _project(xy: np.ndarray, source, where: str, features) -> tuple[np.ndarray, str | None, str]:
    """Coordinates in a metric CRS: (xy (N, 2) [m], its WKT or None, how)."""
    if source is None:
        return xy, None, "no CRS in the file: coordinates taken as metres as they are"
    if not len(xy):             # no geometry at all: what is missing is said by the reader
        return xy, None, "no coordinates to project"
    pyproj = require("pyproj", f"projecting {where}")
    try:
        src = pyproj.CRS.from_user_input(source)
    except Exception as exc:  # pyproj.exceptions.CRSError
        raise GraphError(f"{where}: cannot read its CRS {str(source)[:120]!r}: {exc}") from None
    if src.is_projected and _metres(src):
        return xy, src.to_wkt(), f"kept the file's projected CRS {_short_crs(src)}"
    if not (src.is_geographic or src.is_projected):
        raise GraphError(f"{where}: its CRS {_short_crs(src)} cannot be projected to a map in "
                         f"metres (it is neither geographic nor projected)")
    try:
        to_lonlat = pyproj.Transformer.from_crs(src, "EPSG:4326", always_xy=True)
        lon, lat = to_lonlat.transform(xy[:, 0], xy[:, 1], errcheck=False)
    except Exception as exc:
        raise GraphError(f"{where}: cannot project from its CRS {_short_crs(src)}: {exc}") from None
    lon, lat = np.asarray(lon, float), np.asarray(lat, float)
    bad = ~(np.isfinite(lon) & np.isfinite(lat) & (np.abs(lat) <= 90.0))
    what = f"cannot be projected from {_short_crs(src)}"
    if src.is_geographic:
        degrees = (np.abs(xy[:, 0]) <= 360.0) & (np.abs(xy[:, 1]) <= 90.0)
        bad |= ~degrees
        if (np.isfinite(xy).all(axis=1) & ~degrees).any():    # not degrees: metres?
            what += (" (not a longitude and latitude: a file in metres that does not say "
                     "its CRS, as a GeoJSON may not? give it: crs=\"EPSG:…\")")
    if bad.any():
        _raise_at(bad, features, where, xy, what)
    dst = _local_crs(pyproj, lon, lat)
    try:
        out = pyproj.Transformer.from_crs(src, dst, always_xy=True).transform(
            xy[:, 0], xy[:, 1], errcheck=False)
    except Exception as exc:
        raise GraphError(f"{where}: cannot project to {_short_crs(dst)}: {exc}") from None
    out = np.column_stack([np.asarray(out[0], float), np.asarray(out[1], float)])
    bad = ~np.isfinite(out).all(axis=1)
    if bad.any():
        _raise_at(bad, features, where, xy, f"cannot be projected to {_short_crs(dst)}")
    return out, dst.to_wkt(), f"projected from {_short_crs(src)} to {_short_crs(dst)}"


def _move_to_origin(xy: np.ndarray, origin_m, crs_out, crs_note: str, where: str,
                    report: RiverImport) -> np.ndarray:
    """The projected coordinates moved by ``origin_m`` (:func:`_origin`), the report's CRS,
    origin and "coordinates" note written to match."""
    extent = float((xy.max(axis=0) - xy.min(axis=0)).max()) if len(xy) else 0.0
    if not extent <= MAX_EXTENT_M:
        raise GraphError(f"{where}: its features span {extent / 1000:.4g} km once projected, "
                         f"more than {MAX_EXTENT_M / 1000:.0f} km: coordinates in another unit "
                         "or CRS than the file says?")
    offset = _origin(origin_m, xy, where)
    if offset is not None:
        xy = xy - offset
        report.origin_m = (float(offset[0]), float(offset[1]))
        crs_out, moved = _moved_crs(crs_out, offset)
        crs_note += (f"; coordinates moved by −({offset[0]:.0f}, {offset[1]:.0f}) m"
                     + (" (the CRS's false origin with them)" if moved else
                        "" if crs_out is None else " (the CRS could not say so: add them back)"))
    report.crs = crs_out
    report.derived["coordinates"] = crs_note
    return xy


def _origin(origin_m, xy: np.ndarray, where: str) -> np.ndarray | None:
    """The shift [m] to subtract from the coordinates, or None."""
    if origin_m is None:
        return None
    if isinstance(origin_m, str):
        if origin_m != "auto":
            raise GraphError(f"{where}: origin_m must be 'auto', None or (x, y), got {origin_m!r}")
        if not len(xy):                 # no coordinates at all: said later, feature by feature
            return None
        lo, hi = xy.min(axis=0), xy.max(axis=0)
        if max(np.abs(lo).max(), np.abs(hi).max()) <= AUTO_ORIGIN_M:
            return None
        return np.round(0.5 * (lo + hi) / 1000.0) * 1000.0
    try:
        offset = np.array([float(v) for v in origin_m])
    except (TypeError, ValueError):
        raise GraphError(f"{where}: origin_m must be 'auto', None or (x, y), got "
                         f"{origin_m!r}") from None
    if offset.shape != (2,) or not np.isfinite(offset).all():
        raise GraphError(f"{where}: origin_m must be two finite numbers, got {origin_m!r}")
    return offset if offset.any() else None


def _moved_crs(crs_wkt: str | None, offset: np.ndarray) -> tuple[str | None, bool]:
    """The CRS with its false easting and northing lowered by ``offset`` [m] (WKT), and
    whether that could be done (a projection with metre false easting / northing)."""
    if crs_wkt is None:
        return None, False
    pyproj = require("pyproj", "moving a CRS's origin")
    from pyproj.crs import CoordinateOperation, ProjectedCRS

    crs = pyproj.CRS.from_wkt(crs_wkt)
    op = crs.coordinate_operation
    if op is None:
        return crs_wkt, False
    data = op.to_json_dict()
    done = set()
    for param in data.get("parameters", []):
        name = param.get("name", "").lower()
        unit = param.get("unit", "metre")
        unit = unit.get("name", "") if isinstance(unit, dict) else str(unit)
        if unit not in ("metre", "meter"):
            continue
        for axis, key in ((0, "easting"), (1, "northing")):
            if key in name and axis not in done:
                param["value"] = float(param["value"]) - float(offset[axis])
                done.add(axis)
    if done != {0, 1}:
        return crs_wkt, False
    moved = ProjectedCRS(conversion=CoordinateOperation.from_json_dict(data),
                         geodetic_crs=crs.geodetic_crs,
                         name=f"{crs.name} (false origin moved by -{offset[0]:.0f}, "
                              f"-{offset[1]:.0f} m)")
    return moved.to_wkt(), True


def _raise_at(bad: np.ndarray, features, where: str, xy: np.ndarray, what: str):
    """GraphError naming the first feature with a bad point."""
    i = int(np.flatnonzero(bad)[0])
    start = 0
    for fid, attrs, n in features:
        if i < start + n:
            point = tuple(float(v) for v in xy[i])
            raise GraphError(f"{where}: feature {fid}: vertex {i - start} {point} {what} "
                             f"[{_attrs_text(attrs)}]")
        start += n
    raise GraphError(f"{where}: a vertex {tuple(float(v) for v in xy[i])} {what}")


GEOJSON_HEAD_BYTES = 1 << 20
GEOJSON_TAIL_BYTES = 1 << 16


def _check_geojson_crs(path: Path, where: str) -> None:
    """GraphError naming the file, layer and CRS text when a GeoJSON's top-level ``crs``
    member (GeoJSON 2008) names a CRS pyproj cannot resolve: GDAL reads such a file as WGS 84
    without a word. No ``crs`` member (RFC 7946) or ``"crs": null`` is WGS 84. Only the
    text before ``"features"`` (in the first GEOJSON_HEAD_BYTES) and a ``crs`` member that
    closes the file (in the last GEOJSON_TAIL_BYTES) are looked at: memory stays bounded."""
    import json
    import re

    try:
        with open(path, "rb") as f:
            head = f.read(GEOJSON_HEAD_BYTES)
            size = f.seek(0, 2)
            f.seek(max(size - GEOJSON_TAIL_BYTES, len(head)))
            tail = f.read()
    except OSError:
        return                                  # pyogrio read it: nothing to add here
    head_text = head.decode("utf-8", "replace")
    cut = head_text.find('"features"')
    found = None
    decoder = json.JSONDecoder()
    for text, at_end in ((head_text[:cut] if cut >= 0 else head_text, False),
                         (head_text if size <= len(head) else
                          tail.decode("utf-8", "replace"), True)):
        for m in re.finditer(r'"crs"\s*:\s*', text):
            try:
                value, end = decoder.raw_decode(text, m.end())
            except ValueError:
                continue
            if at_end and text[end:].strip(" \t\r\n") != "}":
                continue                        # not the top-level object's last member
            found = (value,)
            break
        if found:
            break
    if not found or found[0] is None:
        return
    value = found[0]
    name = (value.get("properties") or {}).get("name") \
        if isinstance(value, dict) and value.get("type") == "name" \
        and isinstance(value.get("properties"), dict) else None
    text = name if isinstance(name, str) else json.dumps(value)[:200]
    pyproj = require("pyproj", f"reading the CRS of {where}")
    try:
        if not isinstance(name, str):
            raise ValueError("not a named CRS ({\"type\": \"name\", \"properties\": "
                             "{\"name\": …}})")
        pyproj.CRS.from_user_input(name)
    except Exception as exc:              # pyproj.exceptions.CRSError
        raise GraphError(f"{where}: its GeoJSON crs member names a CRS that cannot be read: "
                         f"{text!r} ({str(exc).splitlines()[0][:160]}); pass "
                         "read_rivers(crs=...) to say which it is") from None


def _metres(crs) -> bool:
    axes = crs.axis_info
    return bool(axes) and all(abs(a.unit_conversion_factor - 1.0) < 1e-12 for a in axes[:2])


def _local_crs(pyproj, lon: np.ndarray, lat: np.ndarray):
    """The UTM zone pyproj picks for the data's lon/lat box, else an azimuthal equidistant
    projection centred on it."""
    from pyproj.aoi import AreaOfInterest
    from pyproj.database import query_utm_crs_info

    w, e, s, n = float(lon.min()), float(lon.max()), float(lat.min()), float(lat.max())
    if e - w <= 6.0 and max(abs(s), abs(n)) < 84.0:
        infos = query_utm_crs_info(datum_name="WGS 84",
                                   area_of_interest=AreaOfInterest(w, s, e, n))
        if infos:
            centre = 0.5 * (w + e)
            best = min(infos, key=lambda i: abs(0.5 * (i.area_of_use.west + i.area_of_use.east)
                                                - centre))
            return pyproj.CRS.from_epsg(int(best.code))
    return pyproj.CRS.from_dict({"proj": "aeqd", "lat_0": 0.5 * (s + n), "lon_0": 0.5 * (w + e),
                                 "datum": "WGS84", "units": "m"})


def _short_crs(crs) -> str:
    if crs is None:
        return "none"
    try:
        pyproj = require("pyproj", "naming a CRS")
        c = pyproj.CRS.from_user_input(crs)
        auth = c.to_authority()
        return f"{auth[0]}:{auth[1]} ({c.name})" if auth else c.name
    except Exception:
        return str(crs)[:60]


def _wkt(crs) -> str | None:
    if crs is None:
        return None
    try:
        return require("pyproj", "reading a CRS").CRS.from_user_input(crs).to_wkt()
    except Exception:
        return str(crs)


# -- geometry clean-up and topology --------------------------------------------------------------


def _clean(links: list[_Link], report: RiverImport) -> list[_Link]:
    """Drop repeated vertices, zero-length lines and spikes (turns sharper than the builder
    takes); cut out the loops of a line that crosses itself (not in strict mode)."""
    out, spikes = [], 0
    for link in links:
        p = link.points
        keep = np.concatenate([[True], np.any(np.abs(np.diff(p, axis=0)) > 1e-9, axis=1)])
        p = p[keep]
        if len(p) < 2:
            report.repair(link.name, link.fid, link.attrs,
                          "a line of zero length (one distinct vertex): left out")
            continue
        p, n = _drop_spikes(p)
        if n and _length(p) <= 1e-9:
            report.repair(link.name, link.fid, link.attrs,
                          f"a line that turns back on itself at every vertex ({n} turns "
                          f"sharper than {MAX_TURN_DEG:.0f}°, nothing left between them): "
                          "left out")
            continue
        spikes += n
        p, cut_m = (p, 0.0) if report.strict else _cut_self_loops(p)
        if cut_m > 0.0:
            p, n = _drop_spikes(p)          # where the loop's two legs met: a turn back
            spikes += n
            report.repair(link.name, link.fid, link.attrs,
                          f"crosses itself (drawn out and back over itself, or with a twist): "
                          f"the loop between the crossings cut out ({cut_m:.0f} m of line)")
        link.points = p
        out.append(link)
    if spikes:
        report.notes.append(f"{spikes} vertices dropped where a line turned back on itself "
                            f"(a turn sharper than {MAX_TURN_DEG:.0f}°)")
    return out


def _cut_self_loops(p: np.ndarray) -> tuple[np.ndarray, float]:
    """A line that crosses (or touches) itself with each loop cut out: from the first
    segment another one meets to the last segment that meets it, joined at their crossing,
    until the line is simple; a closed ring is left as it is. Returns the line and the
    length cut out [m]."""
    line = shapely.LineString(p)
    if line.is_simple or line.is_ring:
        return p, 0.0
    before = _length(p)
    for _ in range(len(p)):
        segs = shapely.linestrings(np.stack([p[:-1], p[1:]], axis=1))
        a, b = shapely.STRtree(segs).query(segs, predicate="intersects")
        keep = b > a + 1                     # not itself, not its neighbour (a shared vertex)
        a, b = a[keep], b[keep]
        if not len(a):
            break
        i = int(a.min())
        j = int(b[a == i].max())
        x = shapely.intersection(segs[i], segs[j])
        at = np.asarray(shapely.get_coordinates(x)[0]) if not x.is_empty else p[i + 1]
        p = np.vstack([p[:i + 1], at, p[j + 1:]])
        p = p[np.concatenate([[True], np.any(np.abs(np.diff(p, axis=0)) > 1e-9, axis=1)])]
    return p, max(before - _length(p), 0.0)


def _drop_spikes(p: np.ndarray) -> tuple[np.ndarray, int]:
    dropped = 0
    while len(p) > 2:
        d = np.diff(p, axis=0)
        turn = np.degrees(np.abs(np.arctan2(d[:-1, 0] * d[1:, 1] - d[:-1, 1] * d[1:, 0],
                                            np.einsum("ij,ij->i", d[:-1], d[1:]))))
        if turn.max() <= MAX_TURN_DEG - 1.0:
            break
        p = np.delete(p, int(np.argmax(turn)) + 1, axis=0)
        dropped += 1
    return p, dropped


def _topology(links: list[_Link], snap_m: float, report: RiverImport
              ) -> tuple[list[_Link], list[tuple[str, str, np.ndarray]]]:
    """Split lines where another line's end lies on them, and two lines where they cross at
    a vertex of both; then snap the ends into junctions (``link.start`` / ``link.end``:
    junction index, -1 for a free end). Returns the links and the crossings without a shared
    vertex (name, name, point): no junction there (:func:`_cut_crossings`)."""
    if not (math.isfinite(snap_m) and snap_m >= 0):
        raise GraphError(f"{report.path}: snap_m must be a number ≥ 0, got {snap_m!r}")
    lines = [shapely.LineString(lk.points) for lk in links]
    tree = shapely.STRtree(lines)
    ends = np.array([[lk.points[0], lk.points[-1]] for lk in links]).reshape(-1, 2)
    cuts: dict[int, list[float]] = {}
    pairs = tree.query(shapely.points(ends), predicate="dwithin", distance=max(snap_m, 1e-9))
    for e, li in zip(*pairs):
        owner = e // 2
        if li == owner:
            continue
        line = lines[li]
        s = float(line.project(shapely.Point(ends[e])))
        if min(s, line.length - s) <= max(snap_m, 1e-6):
            continue     # near that line's end: the snapping joins them
        cuts.setdefault(int(li), []).append(s)
    if cuts:
        out = []
        for i, lk in enumerate(links):
            if i not in cuts:
                out.append(lk)
                continue
            out.extend(_split(lk, sorted(set(cuts[i]))))
        report.notes.append(f"{len(cuts)} lines split where {sum(map(len, cuts.values()))} "
                            f"other lines end on them (within {snap_m:g} m)")
        links = out
    links, crossings = _crossings(links, snap_m, report)
    ends = np.array([[lk.points[0], lk.points[-1]] for lk in links]).reshape(-1, 2)
    from scipy.cluster.hierarchy import DisjointSet

    joined = DisjointSet(range(len(ends)))
    snapped = 0
    for a, b in cKDTree(ends).query_pairs(max(snap_m, 1e-9)):
        if joined.merge(a, b) and np.any(ends[a] != ends[b]):
            snapped += 1
    junction = 0
    for members in sorted(sorted(group) for group in joined.subsets()):
        if len(members) < 2:
            continue
        if len({m // 2 for m in members}) < len(members):
            lk = links[members[0] // 2]
            if report.strict:
                raise GraphError(f"{report.path}: {lk.name}: its two ends meet (a closed loop "
                                 f"of one line) [{_attrs_text(lk.attrs)}]")
            loops = {m // 2 for m in members if sum(1 for n in members if n // 2 == m // 2) > 1}
            # a line within a few snapping distances end to end is no river (and its halves
            # would meet again, forever): left out; longer loops are cut in two halves
            tiny = {i for i in loops if _length(links[i].points) <= 4.0 * max(snap_m, 1e-9)}
            for i in sorted(loops):
                report.repair(links[i].name, links[i].fid, links[i].attrs,
                              f"a line of {_length(links[i].points):.3g} m, its ends within "
                              f"{snap_m:g} m: left out" if i in tiny else
                              "its two ends meet (a closed loop of one line): cut in two halves")
            index = [i for i in range(len(links)) if i not in tiny]
            kept = [links[i] for i in index]
            loops = {k for k, i in enumerate(index) if i in loops}
            if not kept:
                raise GraphError(f"{report.path} (layer {report.layer!r}): no usable line: every line is shorter than "
                                 f"{4 * snap_m:g} m (snap_m={snap_m:g})")
            return _topology(_halve(kept, loops), snap_m, report)
        centre = ends[members].mean(axis=0)
        for m in members:
            lk = links[m // 2]
            if m % 2 == 0:
                lk.points = _move_end(lk.points, centre, True)
                lk.start = junction
            else:
                lk.points = _move_end(lk.points, centre, False)
                lk.end = junction
        junction += 1
    if snapped:
        report.notes.append(f"{snapped} line ends moved by up to {snap_m:g} m to meet "
                            "(near-miss junctions)")
    return links, crossings


def _join_runs(links: list[_Link], report: RiverImport, lakes=None,
               short_m: float | None = None, widths: list[float] | None = None) -> list[_Link]:
    """Lines that run on into one another where nothing else meets (one line in and one out
    of a junction: OpenStreetMap splits a river's way at every bridge, culvert, weir or
    change of its tags) joined into one link, named (and attributed) after the longest of
    them: a piece shorter than the river is wide would otherwise be a branch of its own,
    its far end within the river of the next one's start (``build()`` cannot make that).
    ``short_m``: only where one of the two is shorter than twice this width [m] (or its
    given width), or both are shorter than twice their widths as planned (``widths``, per
    link, from the discharges summed down the network: a river drawn in pieces shorter than
    it is wide, a model grid's routing lines, one per cell), so that a file's features stay
    links (None: every such junction, as for OpenStreetMap, whose ways are no links). Lines
    are joined only where their attributes give the same kinds of values (each value given
    on both or on neither: a width given on one and derived on the next stays two links),
    neither was added by a repair, and neither runs into a lake (``lakes``: the lakes' area,
    the lines cut at their shores). Not in strict mode (lines as drawn). A note says how
    many were joined; a run joined by its planned widths is a repair."""
    if report.strict or len(links) < 2:
        return links
    ins: dict[int, list[int]] = {}
    outs: dict[int, list[int]] = {}
    for i, lk in enumerate(links):
        if lk.end >= 0:
            ins.setdefault(lk.end, []).append(i)
        if lk.start >= 0:
            outs.setdefault(lk.start, []).append(i)

    def kinds(lk: _Link, at: int) -> tuple:
        return tuple(bool(np.isfinite(lk.values[key][at])) for key in sorted(lk.values)) + (
            math.isnan(lk.cell_m),)

    def short(i: int, planned: bool = False) -> bool:
        width = widths[i] if planned else _given_width(links[i]) or short_m
        return _length(links[i].points) < 2.0 * width

    def joinable(i: int, k: int) -> bool:
        a, b = links[i], links[k]
        return (not (a.added or b.added) and sorted(a.values) == sorted(b.values)
                and (short_m is None or short(i) or short(k)
                     or widths is not None and short(i, True) and short(k, True))
                and kinds(a, 0) == kinds(b, 0) and kinds(a, 1) == kinds(b, 1)
                and (math.isnan(a.cell_m) or abs(a.cell_m - b.cell_m) <= 1e-9 * a.cell_m)
                and (lakes is None or not (lakes.intersects(shapely.LineString(a.points))
                                           or lakes.intersects(shapely.LineString(b.points)))))

    after: dict[int, int] = {}
    by_width = set()                    # joined by their planned widths only: repairs
    for j, came in ins.items():
        went = outs.get(j, [])
        if len(came) == 1 and len(went) == 1 and came[0] != went[0] \
                and joinable(came[0], went[0]):
            after[came[0]] = went[0]
            if short_m is not None and not (short(came[0]) or short(went[0])):
                by_width.add(came[0])
    if not after:
        return links
    before = {b: a for a, b in after.items()}
    out, joined, seen, spikes = [], 0, set(), 0
    for i, lk in enumerate(links):
        if i in before or i in seen:
            continue                    # not the first of its run (or a ring: kept as is)
        run = [i]
        while run[-1] in after and after[run[-1]] not in seen and after[run[-1]] != i:
            run.append(after[run[-1]])
        seen.update(run)
        if len(run) == 1:
            out.append(lk)
            continue
        pieces = [links[k] for k in run]
        main = max(pieces, key=lambda p: _length(p.points))
        first, last = pieces[0], pieces[-1]
        points = np.concatenate([pieces[0].points] + [p.points[1:] for p in pieces[1:]])
        points, n = _drop_spikes(points)        # a joint may turn back (two ways' ends)
        spikes += n
        values = {key: (first.values[key][0], last.values[key][1]) for key in first.values}
        link = _Link(main.name, main.fid, np.ascontiguousarray(points), main.attrs, values,
                     first.start, last.end, (first.z[0], last.z[1]),
                     any(p.fixed for p in pieces), False, first.cell_m, first.source_width_m)
        out.append(link)
        if by_width.intersection(run):
            others = [p.name for p in pieces if p is not main]
            report.repair(main.name, main.fid, main.attrs,
                          f"drawn in {len(run)} pieces (with {', '.join(others[:6])}"
                          f"{', …' if len(others) > 6 else ''}) that run on into one another "
                          f"where nothing else meets, shorter than twice the river's width "
                          f"({max(widths[k] for k in run):.1f} m at most): joined into one "
                          "link (such a piece has no banks of its own)")
        else:
            joined += len(run) - 1
    out += [links[i] for i in range(len(links)) if i not in seen and i in before]  # rings
    if joined or spikes:
        report.notes.append(f"{joined} junctions where one line runs on into the next and nothing "
                            f"else meets: the lines joined into one link (named after the "
                            f"longest)" + (f"; {spikes} vertices dropped where the joined line "
                                           f"turned back on itself (sharper than "
                                           f"{MAX_TURN_DEG:.0f}°)" if spikes else ""))
    return out


def _drop_enclosed(links: list[_Link], report: RiverImport) -> list[_Link]:
    """Links that lie in land the network's loops close round (a ditch rising in a field
    between two canals, a drain ending in an island of a braid: a line that is no side of
    any face of the network, inside one) left out, each a reported repair: water entering
    or leaving through such an island's land would make ψ many-valued round it (the
    island's shore is one bank from the line's free end round to it again), which no
    network of banks can hold. Not in strict mode."""
    if report.strict or len(links) < 3:
        return links
    enclosed = _enclosed_land(links)
    if enclosed is False:
        return links
    land, sides = enclosed
    lines = [shapely.LineString(lk.points) for lk in links]
    middle = shapely.line_interpolate_point(lines, 0.5, normalized=True)
    inside = shapely.contains(land, middle) & (shapely.distance(sides, middle) > 1e-6)
    if not inside.any():
        return links
    for i in np.flatnonzero(inside):
        lk = links[i]
        report.repair(lk.name, lk.fid, lk.attrs,
                      "lies in land the network's channels close round (an island), one of its "
                      "ends there: no banks can carry water into or out of that land: left out")
    return [lk for lk, enclosed in zip(links, inside) if not enclosed]


HOOK_TURN_DEG = 45.0
"""A free end's last segment shorter than its river is wide that turns off the line by more
than this is a hook (:func:`_trim_hooks`)."""


def _trim_hooks(p: np.ndarray, width_m: float, start_free: bool, end_free: bool
                ) -> tuple[np.ndarray, list[str]]:
    """A line (K, 2) [m] without the hooks at its free ends: a last segment shorter than the
    river is wide that turns off the line by more than HOOK_TURN_DEG (a flick of the
    digitiser's pen: Helsinki's OSM drains; the end's cap, across that segment, crossed the
    river's own banks and ``build()`` refused the branch), its end vertex dropped, again
    while one is left and at least two vertices remain. Returns the line and what was done."""
    said = []
    for free, name in ((start_free, "start"), (end_free, "end")):
        q = p if name == "end" else p[::-1]
        while free and len(q) > 2:
            u, v = q[-2] - q[-3], q[-1] - q[-2]
            last, before = float(np.hypot(*v)), float(np.hypot(*u))
            if last >= width_m or before <= 0.0:
                break
            turn = math.degrees(math.acos(max(-1.0, min(1.0, float(u @ v) / max(last * before,
                                                                             1e-300)))))
            if turn <= HOOK_TURN_DEG:
                break
            said.append(f"a hook at its free {name} ({last:.2f} m turning by {turn:.0f}°, "
                        f"shorter than its {width_m:.1f} m width): that vertex dropped")
            q = q[:-1]
        p = q if name == "end" else q[::-1]
    return np.ascontiguousarray(p), said


def _halve(links: list[_Link], which: set[int]) -> list[_Link]:
    out = []
    for i, lk in enumerate(links):
        out.extend(_split(lk, [0.5 * _length(lk.points)]) if i in which else [lk])
    return out


def _crossings(links: list[_Link], snap_m: float, report: RiverImport):
    """Lines that cross: where the crossing is a vertex of both, both are split there (a
    junction); elsewhere (a canal over a river, a culvert) no junction is made and the
    crossing is returned for :func:`_cut_crossings`."""
    lines = _geoms([lk.points for lk in links])
    tree = shapely.STRtree(lines)
    a_idx, b_idx = tree.query(lines, predicate="intersects")
    tol = max(snap_m, 1e-9)
    cuts: dict[int, list[float]] = {}
    crossings = []
    pair = a_idx < b_idx
    a_idx, b_idx = a_idx[pair], b_idx[pair]
    # every pair's crossing points at once (most are the junctions where the lines end)
    xy, k = shapely.get_coordinates(shapely.intersection(lines[a_idx], lines[b_idx]),
                                    return_index=True)
    first = np.array([lk.points[0] for lk in links]).reshape(-1, 2)
    last = np.array([lk.points[-1] for lk in links]).reshape(-1, 2)
    at_end = np.zeros(len(xy), bool)
    for i in (a_idx[k], b_idx[k]):
        at_end |= np.minimum(np.hypot(*(first[i] - xy).T), np.hypot(*(last[i] - xy).T)) <= tol
    # (a point at an end of either line is where one ends on the other: split or snapped
    # already)
    for x, a, b in zip(xy[~at_end], a_idx[k[~at_end]], b_idx[k[~at_end]]):
        va = np.hypot(*(links[a].points - x).T).min() <= 1e-6
        vb = np.hypot(*(links[b].points - x).T).min() <= 1e-6
        if va and vb:
            cuts.setdefault(int(a), []).append(float(lines[a].project(shapely.Point(x))))
            cuts.setdefault(int(b), []).append(float(lines[b].project(shapely.Point(x))))
        else:
            crossings.append((links[a].name, links[b].name, x.copy()))
    if cuts:
        out = []
        for i, lk in enumerate(links):
            out.extend(_split(lk, sorted(set(cuts[i]))) if i in cuts else [lk])
        report.notes.append(f"{len(cuts)} lines split where they cross at a shared vertex "
                            "(a junction)")
        links = out
    return links, crossings


def _drop_duplicates(links: list[_Link], snap_m: float, report: RiverImport) -> list[_Link]:
    """Leave out lines that repeat another (either direction): a Hausdorff distance under
    DUPLICATE_SNAPS × ``snap_m`` and lengths within 5 %; the first one read is kept."""
    if len(links) < 2:
        return links
    tol = max(DUPLICATE_SNAPS * snap_m, 1e-6)
    lines = _geoms([lk.points for lk in links])
    lengths = shapely.length(lines)
    tree = shapely.STRtree(lines)
    a_idx, b_idx = tree.query(lines, predicate="dwithin", distance=tol)
    gone: set[int] = set()
    for a, b in sorted(zip(a_idx.tolist(), b_idx.tolist())):
        if a >= b or a in gone or b in gone:
            continue
        if abs(lengths[a] - lengths[b]) > 0.05 * max(lengths[a], lengths[b]) + tol:
            continue
        if shapely.hausdorff_distance(lines[a], lines[b]) <= tol:
            gone.add(b)
            same = (np.array_equal(links[a].points, links[b].points)
                    or np.array_equal(links[a].points, links[b].points[::-1]))
            report.repair(links[b].name, links[b].fid, links[b].attrs,
                          f"{'an exact' if same else 'a near'} duplicate of {links[a].name} "
                          f"(within {tol:g} m): left out")
    return [lk for i, lk in enumerate(links) if i not in gone]


def _split(link: _Link, at: list[float]) -> list[_Link]:
    """A link cut at arc lengths ``at`` [m]; values given per end are interpolated."""
    p = link.points
    s = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(p, axis=0).T))])
    bounds = [0.0, *at, float(s[-1])]
    out = []
    for k, (a, b) in enumerate(itertools.pairwise(bounds)):
        inner = p[(s > a) & (s < b)]
        pa = np.array([np.interp(a, s, p[:, 0]), np.interp(a, s, p[:, 1])])
        pb = np.array([np.interp(b, s, p[:, 0]), np.interp(b, s, p[:, 1])])
        values = {key: (v0 + (v1 - v0) * a / s[-1], v0 + (v1 - v0) * b / s[-1])
                  for key, (v0, v1) in link.values.items()}
        piece = _Link(f"{link.name} piece {k}", link.fid, np.vstack([pa, inner, pb]),
                      link.attrs, values)
        z0, z1 = link.z
        piece.z = (z0 + (z1 - z0) * a / s[-1], z0 + (z1 - z0) * b / s[-1])
        piece.fixed = link.fixed
        piece.cell_m = link.cell_m
        piece.source_width_m = link.source_width_m
        out.append(piece)
    return out


def _move_end(p: np.ndarray, target: np.ndarray, at_start: bool) -> np.ndarray:
    """The line with its start (or end) moved to ``target``, dropping the vertices nearer to
    the target than the moved end was (so the line does not fold back there)."""
    q = p if at_start else p[::-1]
    reach = float(np.hypot(*(q[0] - target)))
    if reach > 0:
        d = np.hypot(*(q[1:-1] - target).T)
        first = 1 + int(np.argmax(d > reach)) if (d > reach).any() else len(q) - 1
        q = np.vstack([target, q[first:]])
    else:
        q = q.copy()
    return q if at_start else q[::-1]


def _length(p: np.ndarray) -> float:
    return float(np.hypot(*np.diff(p, axis=0).T).sum())


def _lattice_cells(lines: list[np.ndarray]) -> np.ndarray:
    """The raster cell each line was traced on (in the file's coordinate units), NaN for a
    line that is not grid-traced.

    A line traced along a raster's cells (a DEM's flow directions: TauDEM, ArcHydro, …) has
    its vertices on the cells' centres: every segment runs along one of the 8 lattice
    directions (a multiple of 45° in the raster's coordinates, the file's) and is a whole
    number of cells long (of cell diagonals on the diagonals). The cell is the layer's (one
    raster): the longest step, among those common in the layer, that at least LATTICE_SHARE
    of the lattice segments are whole multiples of. A line is grid-traced when at least
    LATTICE_SHARE of its segments run along lattice directions, as many of its inner
    segments (its first and last may end at a cell's edge or a snapped junction) are whole
    numbers of cells, and it runs in two directions or more (a staircase)."""
    out = np.full(len(lines), math.nan)
    per_line = []
    for p in lines:
        d = np.diff(np.asarray(p, float), axis=0)
        d = d[np.abs(d).max(axis=1) > 0]
        big = np.abs(d).max(axis=1) if len(d) else np.zeros(0)
        rel = np.abs(d).min(axis=1) / np.maximum(big, 1e-300) if len(d) else np.zeros(0)
        on = (rel <= LATTICE_ANGLE) | (rel >= 1.0 - LATTICE_ANGLE)
        heading = np.round(np.degrees(np.arctan2(d[:, 1], d[:, 0])) / 45.0).astype(int) % 8
        per_line.append((big, on, heading))
    steps = np.concatenate([big[on] for big, on, _ in per_line]) if per_line else np.zeros(0)
    if len(steps) < 3:
        return out
    values, counts = np.unique(np.round(steps / steps.max(), 6), return_counts=True)
    common = values[counts >= max(2, 0.02 * len(steps))][::-1] * steps.max()

    def whole(x: np.ndarray, c: float) -> np.ndarray:
        m = x / c
        return (m >= 0.98) & (np.abs(m - np.round(m)) <= 0.02)

    cell = next((c for c in common if whole(steps, c).mean() >= LATTICE_SHARE), None)
    if cell is None:
        return out
    for i, (big, on, heading) in enumerate(per_line):
        if len(big) < 2:
            continue
        inner = slice(1, -1) if len(big) >= 3 else slice(None)   # ends: at a cell's edge
        lattice = on & whole(big, cell)
        if (on.mean() >= LATTICE_SHARE and lattice[inner].mean() >= LATTICE_SHARE
                and len(np.unique(heading[on])) >= 2):
            out[i] = cell
    return out


def _zigzags(p: np.ndarray, width_m: float) -> bool:
    """A line off any lattice that zigzags at a scale below its width (traced or digitised
    densely): vertices closer together than half its width, at least GRID_TURN_SHARE of
    them turning by GRID_TURN_DEG or more."""
    if len(p) < 5:
        return False
    d = p[1:] - p[:-1]
    seg = np.hypot(d[:, 0], d[:, 1])
    n = len(seg)                      # the median, as np.median has it, without its overhead
    part = np.partition(seg, [(n - 1) // 2, n // 2])
    if not 0.5 * (part[(n - 1) // 2] + part[n // 2]) < 0.5 * width_m:
        return False
    turn = np.degrees(np.abs(np.arctan2(d[:-1, 0] * d[1:, 1] - d[:-1, 1] * d[1:, 0],
                                        np.einsum("ij,ij->i", d[:-1], d[1:]))))
    return bool((turn >= GRID_TURN_DEG).mean() >= GRID_TURN_SHARE)


def _smooth_traced(links: list[_Link], plan, report: RiverImport) -> None:
    """Smooth grid-traced centre lines (:func:`_lattice_cells`), and lines that zigzag below
    their width (:func:`_zigzags`), at the scale σ = max(cell, half the width): a Gaussian
    of σ along the line, sampled every σ/4. Lines that continue each other (a junction with
    one link in and one out) are smoothed as one, so no corner is left where they meet;
    the ends of such a run (sources, outlets, confluences, bifurcations) stay where they
    are. No point moves by more than max(half its link's width, TRACED_CAP_CELLS cells).
    The links' points are replaced; ``report.derived["centre_lines"]`` says how many were
    smoothed and by how much they moved (a derivation, not a repair: tracing on a raster is
    how the data was made, not a defect of a feature)."""
    sigma = np.zeros(len(links))
    cap = np.zeros(len(links))
    cells = []
    dense = 0
    for i, (lk, p) in enumerate(zip(links, plan)):
        width = p[0]
        cell = lk.cell_m if math.isfinite(lk.cell_m) and not lk.added else 0.0
        if cell <= 0.0 and not _zigzags(lk.points, width):
            continue
        sigma[i] = max(TRACED_SIGMA_CELLS * cell, 0.5 * width)
        cap[i] = max(0.5 * width, TRACED_CAP_CELLS * cell)
        if cell > 0:
            cells.append(cell)
        else:
            dense += 1
    if not sigma.any():
        return
    ins, outs = by_junction([lk.start for lk in links], [lk.end for lk in links])

    def following(i: int) -> int | None:
        j = links[i].end
        if j < 0 or len(ins.get(j, [])) != 1 or len(outs.get(j, [])) != 1:
            return None
        k = outs[j][0]
        return k if sigma[k] > 0 and k != i else None

    flagged = [i for i in range(len(links)) if sigma[i] > 0]
    has_prev = {k for i in flagged if (k := following(i)) is not None}
    shifts = []
    for first in flagged:                  # links flow downstream (no cycle): runs have heads
        if first in has_prev:
            continue
        run = [first]
        while (k := following(run[-1])) is not None and k not in run:
            run.append(k)
        shifts.append(_smooth_run([links[i] for i in run], float(sigma[run].max()),
                                  cap[run]))
    report.derived["centre_lines"] = (
        (f"{len(cells)} grid-traced link{'s' if len(cells) > 1 else ''} (on a lattice of "
         f"{np.median(cells):.3g} m cells) " if cells else "")
        + ("and " if cells and dense else "")
        + (f"{dense} link{'s' if dense > 1 else ''} zigzagging below their width "
           if dense else "")
        + f"smoothed (a Gaussian along them of max({TRACED_SIGMA_CELLS:g} cells, half the "
        f"width)): centre lines moved by at most {max(shifts):.2f} m")


def _smooth_run(run: list[_Link], sigma: float, caps: np.ndarray) -> float:
    """Smooth the links of one run (each continuing the one before) as one line: resampled
    every σ/4 (each link on its own, so the points where they meet stay samples), a Gaussian
    of σ (odd reflection at the run's ends: they stay put), each sample's move capped by its
    link's cap. Replaces the links' points; returns the largest move [m] (the farthest new
    point from the line as it was)."""
    h = 0.25 * sigma
    parts, bounds = [], [0]
    for lk in run:
        p = lk.points
        s = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(p, axis=0).T))])
        t = np.linspace(0.0, s[-1], max(int(np.ceil(s[-1] / h)), 1) + 1)
        q = np.column_stack([np.interp(t, s, p[:, 0]), np.interp(t, s, p[:, 1])])
        parts.append(q if not parts else q[1:])
        bounds.append(bounds[-1] + len(q) - 1)
    q = np.vstack(parts)
    limit = np.concatenate([np.full(b - a, c) for a, b, c in zip(bounds, bounds[1:], caps)]
                           + [[caps[-1]]])

    def gaussian(x: np.ndarray, samples: float) -> np.ndarray:
        """x smoothed by a Gaussian of ``samples`` samples (odd reflection at the ends)."""
        half = int(3 * samples)
        k = np.arange(-half, half + 1)
        kernel = np.exp(-0.5 * (k / samples) ** 2)
        kernel /= kernel.sum()
        padded = np.pad(x, ((half, half), (0, 0)), mode="reflect", reflect_type="odd")
        return np.column_stack([np.convolve(padded[:, i], kernel, mode="valid")
                                for i in (0, 1)])

    def within(x: np.ndarray) -> np.ndarray:
        """x with each point moved back towards q to at most its cap from it."""
        shift = x - q
        size = np.hypot(*shift.T)
        return q + shift * np.minimum(1.0, limit / np.maximum(size, 1e-12))[:, None]

    smooth = within(gaussian(q, 4.0))              # σ = 4 samples
    smooth[0], smooth[-1] = q[0], q[-1]
    moved = 0.0
    for lk, a, b in zip(run, bounds, bounds[1:]):
        new = np.ascontiguousarray(smooth[a:b + 1])
        moved = max(moved, float(shapely.distance(shapely.points(new),
                                                  shapely.LineString(lk.points)).max()))
        lk.points = new
    return moved


def _simplify(p: np.ndarray, width_m: float) -> np.ndarray:
    tol = min(SIMPLIFY_WIDTHS * width_m, SIMPLIFY_MAX_M)
    if len(p) <= 2 or tol <= 0:
        return p
    line = shapely.LineString(p)
    # the plain Douglas-Peucker simplifier (a third of the time of the topology-preserving
    # one, the same line wherever its result does not cross itself)
    simple = shapely.simplify(line, tol, preserve_topology=False)
    if not simple.is_simple and line.is_simple:
        simple = shapely.simplify(line, tol)
    return shapely.get_coordinates(simple)


# -- widths and discharges -----------------------------------------------------------------------


def _order(links: list[_Link]) -> list[int]:
    """Links upstream first (GraphError naming the links of a cycle); O(n) (Kahn)."""
    order, loop = upstream_first([lk.start for lk in links], [lk.end for lk in links])
    if loop:
        names = [links[i].name for i in loop][:6]
        raise GraphError(f"links {names} form a loop that flows back into itself (a line "
                         f"drawn upstream? see read_rivers' reverse=)")
    return order


def _plan(links: list[_Link], geometry: HydraulicGeometry, specs: dict, report: RiverImport):
    """Per link: (width [m], ψ discharge [m²/s], Q [m³/s], width from, discharge from,
    lateral inflow [m²/s]) — the module docstring's rules.

    Two discharges are carried downstream: the volume Q [m³/s], which adds up at confluences
    and sets the widths (w = a·Q^b), and the ψ discharge q the builder conserves (sources
    and lateral inflow converted at their own depth, q = Q / D(Q); along a chain q stays
    q(Q)). Below a confluence q is the sum of the inflows' q, more than q(ΣQ) (D grows with
    Q): the 2-D flow, which has no depth, runs faster there than Leopold & Maddock's
    v ∝ Q^0.1 (by about √2 where two equal rivers meet).
    """
    order = _order(links)
    ins, outs = by_junction([lk.start for lk in links], [lk.end for lk in links])
    own = [_own_estimate(lk, geometry) for lk in links]     # (Q, q, how) or None
    volume = [0.0] * len(links)
    psi = [0.0] * len(links)
    braid: list[frozenset] = [frozenset()] * len(links)
    lateral = [0.0] * len(links)
    source = [""] * len(links)
    for i in order:
        lk = links[i]
        upstream = ins.get(lk.start, []) if lk.start >= 0 else []
        siblings = outs.get(lk.start, [i]) if lk.start >= 0 else [i]
        if not upstream:
            if own[i] is None:
                width = lk.source_width_m if math.isfinite(lk.source_width_m) \
                    else geometry.default_width_m
                q3 = geometry.discharge_of_width(width)
                own[i] = (q3, geometry.psi(q3), f"default (a source {width:g} m wide"
                          + (f": OSM waterway={lk.attrs.get('waterway')})"
                             if math.isfinite(lk.source_width_m) else ")"))
            volume[i], psi[i], source[i] = own[i]
            continue
        q_in, psi_in = sum(volume[k] for k in upstream), sum(psi[k] for k in upstream)
        labels = frozenset().union(*(braid[k] for k in upstream))
        closed = {lab[0] for lab in labels
                  if any(o[0] == lab[0] and o != lab for o in labels)}
        labels = frozenset(lab for lab in labels if lab[0] not in closed)
        if len(siblings) > 1:
            given = [_given_width(links[k]) for k in siblings]
            if all(w is not None for w in given):      # arms of given widths: by width
                weights = given
            else:                                      # else by their own estimates
                weights = [None if own[k] is None else own[k][0] for k in siblings]
            if any(w is None for w in weights):
                weights = [1.0] * len(siblings)
            share = weights[siblings.index(i)] / sum(weights)
            volume[i], psi[i] = q_in * share, psi_in * share
            source[i] = f"split of the inflow at a bifurcation ({share:.0%})" + (
                f" (its own estimate, {own[i][2]}, {own[i][0]:.4g} m³/s, not used)"
                if own[i] is not None and own[i][2].startswith("given") else "")
            braid[i] = labels | {(lk.start, i)}
            continue
        braid[i] = labels
        if own[i] is not None and own[i][0] > q_in * (1 + 1e-9) and not labels:
            volume[i], source[i] = own[i][0], own[i][2]
            lateral[i] = max(0.0, own[i][1] - geometry.psi(q_in)) if q_in > 0 else own[i][1]
            psi[i] = psi_in + lateral[i]
        else:
            volume[i], psi[i] = q_in, psi_in
            source[i] = "sum of the inflows"
            if own[i] is not None and own[i][0] < q_in * (1 - 1e-9):
                source[i] += f" (its own estimate, {own[i][2]}, {own[i][0]:.4g} m³/s, is smaller)"
            elif own[i] is not None and own[i][0] > q_in * (1 + 1e-9):
                source[i] += (f" (its own estimate, {own[i][2]}, {own[i][0]:.4g} m³/s, is "
                              "larger, but it lies in a braid)")
    plan = []
    for i, lk in enumerate(links):
        w0, w1 = lk.values["width_m"]
        given = [w for w in (w0, w1) if math.isfinite(w) and w > 0]
        if given:
            width, wfrom = float(np.mean(given)), "given"
        else:
            width, wfrom = geometry.width(volume[i]), "hydraulic geometry of the discharge"
        if width < MIN_WIDTH_M:
            width, wfrom = MIN_WIDTH_M, wfrom + f", {width:.3g} m raised to {MIN_WIDTH_M:g} m"
        plan.append((width, psi[i], volume[i], wfrom, source[i], lateral[i]))
    return plan


def _report_substitutions(link: _Link, wfrom: str, qfrom: str, report: RiverImport) -> None:
    """Put every value of the link that :func:`_plan` replaced or clamped in the report with
    the feature: a given width under MIN_WIDTH_M raised (a repair), a width derived under it
    raised, a given discharge not used (the inflows are larger, a bifurcation split it, a
    braid): notes naming the feature, the value and what was used instead."""
    if link.added:
        return
    attrs = f"[{_attrs_text(link.attrs)}]"
    if "raised to" in wfrom:
        if wfrom.startswith("given"):
            report.repair(link.name, link.fid, link.attrs,
                          f"its width {wfrom.split(', ')[-1]} (the narrowest river made)")
        else:
            report.notes.append(f"{link.name}: width by {wfrom} (the narrowest river made) "
                                + attrs)
    if "own estimate, given" in qfrom:
        report.notes.append(f"{link.name}: its given discharge is not used: {qfrom} {attrs}")


def _given_width(link: _Link) -> float | None:
    """The link's given width [m] (the mean of its ends' values), or None."""
    given = [w for w in link.values["width_m"] if math.isfinite(w) and w > 0]
    return float(np.mean(given)) if given else None


def _own_estimate(link: _Link, g: HydraulicGeometry) -> tuple[float, float, str] | None:
    """The link's own (volume discharge [m³/s], ψ discharge [m²/s], how) from its values
    (the first rule that applies), or None."""
    v = link.values

    def last(key: str) -> float:
        a, b = v[key]
        return b if math.isfinite(b) and b > 0 else a

    q2, q3 = last("discharge_m2s"), last("discharge_m3s")
    if math.isfinite(q2) and q2 > 0:
        return g.volume(q2), q2, "given (ψ discharge)"
    if math.isfinite(q3) and q3 > 0:
        return q3, g.psi(q3), "given (volume discharge)"
    w = last("width_m")
    if math.isfinite(w) and w > 0:
        q3 = g.discharge_of_width(w)
        return q3, g.psi(q3), "hydraulic geometry of the given width"
    a = last("drainage_area_km2")
    if math.isfinite(a) and a > 0:
        q3 = g.discharge_of_area(a)
        return q3, g.psi(q3), "hydraulic geometry of the drainage area"
    o = last("stream_order")
    if math.isfinite(o) and o >= 1:
        q3 = g.discharge_of_area(g.area_of_order(o))
        return q3, g.psi(q3), "hydraulic geometry of the stream order"
    return None


def _merge_close_junctions(links, plan, geometry, specs, report):
    """Merge junctions closer together than half the sum of their rivers' widths (the
    builder cannot tell them apart: one lies inside the other's confluence), or joined by a
    link shorter than the sum and than half every other line there (its middle lies in their
    water: no banks of its own there; not a chain of such links, not in strict mode, nor
    where they are a braid's); the links between them are dropped.
    Repeats until none is left (at most a few passes)."""
    for _ in range(8):
        widths = [p[0] for p in plan]
        pts: dict[int, np.ndarray] = {}
        reach: dict[int, float] = {}
        for lk, w in zip(links, widths):
            for j, p in ((lk.start, lk.points[0]), (lk.end, lk.points[-1])):
                if j >= 0:
                    pts[j] = p
                    reach[j] = max(reach.get(j, 0.0), w)
        if len(pts) < 2:
            return links, plan
        ids = sorted(pts)
        xy = np.array([pts[j] for j in ids])
        tree = cKDTree(xy)
        parent = {j: j for j in ids}
        root = _finder(parent)
        long_links = {frozenset((lk.start, lk.end)) for lk in links
                      if lk.start >= 0 and lk.end >= 0 and _length(lk.points)
                      > 1.5 * (reach[lk.start] + reach[lk.end])}
        merged = 0
        widest = max(reach.values())
        for a, b in tree.query_pairs(widest):
            ja, jb = ids[a], ids[b]
            if frozenset((ja, jb)) in long_links:
                continue     # a long link bends back to near its start: leave it to the builder
            if np.hypot(*(xy[a] - xy[b])) < 0.5 * (reach[ja] + reach[jb]) and root(ja) != root(jb):
                parent[max(root(ja), root(jb))] = min(root(ja), root(jb))
                merged += 1
        at: dict[int, list[tuple[float, int]]] = {}     # the lines at each junction
        for k, lk in enumerate(links):
            for j in (lk.start, lk.end):
                if j >= 0 and not lk.added:
                    at.setdefault(j, []).append((_length(lk.points), k))
        for k, lk in enumerate(links):      # a link between them shorter than their widths:
            ja, jb = lk.start, lk.end           # its middle lies in their confluences' water
            if report.strict or ja < 0 or jb < 0 or root(ja) != ja or root(jb) != jb:
                continue                        # (one merge a pass at a junction: no chains)
            length = _length(lk.points)
            others = [x for j in (ja, jb) for x, m in at.get(j, []) if m != k]
            if (length < reach[ja] + reach[jb] and length < 0.5 * min(others, default=math.inf)
                    and not _another_path(links, lk)):
                parent[max(ja, jb)] = min(ja, jb)
                merged += 1
        if not merged:
            return links, plan
        groups: dict[int, list[int]] = {}
        for j in ids:
            groups.setdefault(root(j), []).append(j)
        centre = {r: np.mean([pts[j] for j in g], axis=0) for r, g in groups.items()}
        kept = []
        for lk in links:
            s, e = (root(lk.start) if lk.start >= 0 else -1), (root(lk.end) if lk.end >= 0 else -2)
            if s == e:
                report.notes.append(f"{lk.name}: dropped (it lies inside a confluence: its "
                                    f"ends are closer, or it is shorter, than the rivers "
                                    f"there are wide) "
                                    f"[{_attrs_text(lk.attrs)}]")
                continue
            if lk.start >= 0:
                lk.points = _move_end(lk.points, centre[s], True)
                lk.start = s
            if lk.end >= 0:
                lk.points = _move_end(lk.points, centre[e], False)
                lk.end = e
            kept.append(lk)
        report.notes.append(f"{merged} pairs of junctions merged (closer than their rivers "
                            "are wide)")
        links = kept
        plan = _plan(links, geometry, specs, report)
    return links, plan


def _another_path(links: list[_Link], link: _Link) -> bool:
    """Whether the flow also runs from ``link``'s start to its end along other links (a
    braid: its two junctions merged would make a loop that flows back into itself)."""
    outs: dict[int, list[_Link]] = {}
    for lk in links:
        if lk is not link and lk.start >= 0:
            outs.setdefault(lk.start, []).append(lk)
    seen, todo = {link.start}, [link.start]
    while todo:
        for lk in outs.get(todo.pop(), []):
            if lk.end == link.end:
                return True
            if lk.end >= 0 and lk.end not in seen:
                seen.add(lk.end)
                todo.append(lk.end)
    return False


def _finder(parent: dict[int, int]):
    """The root lookup of a union-find forest ``parent`` (node → parent)."""
    def root(a: int) -> int:
        while parent[a] != a:
            a = parent[a]
        return a
    return root


def _summarise(report: RiverImport) -> None:
    def counts(values):
        out: dict[str, int] = {}
        for v in values:
            out[v] = out.get(v, 0) + 1
        return out

    report.derived["width_m"] = counts(
        lk.width_from.split(", ")[0] + (f", raised to {MIN_WIDTH_M:g} m"
                                        if "raised to" in lk.width_from else "")
        for lk in report.links)
    report.derived["discharge"] = counts(lk.discharge_from.split(" (")[0] if "default" not in
                                         lk.discharge_from else lk.discharge_from
                                         for lk in report.links)
    inflow = sum(lk.lateral_m2s for lk in report.links)
    if inflow:
        report.derived["lateral_inflow_m2s"] = round(inflow, 6)


# -- repairs: direction, clipped ends, crossings, close channels ----------------------------------


def _turn(link: _Link) -> None:
    link.points = np.ascontiguousarray(link.points[::-1])
    link.values = {key: (v[1], v[0]) for key, v in link.values.items()}
    link.z = (link.z[1], link.z[0])
    link.start, link.end = link.end, link.start


OSM_CLASS_RANK = {"drain": 0, "ditch": 0, "stream": 1, "canal": 2, "river": 3}
"""The order in which :func:`_break_osm_loops` turns ways: the smallest class first."""


def _break_osm_loops(links: list[_Link], report: RiverImport) -> None:
    """OpenStreetMap ways are drawn downstream and never turned, but a way drawn the wrong
    way round closes a loop that flows back into itself (graphhopper's north-bayreuth.osm:
    a stream leaving the Roter Main and drawn back up to join it 1.4 km upstream): in each
    such loop the way of the smallest class (a ditch before a stream, a canal, a river),
    the shortest of those, is turned (a reported repair) until none is left; a way is turned
    once at most (three ways between two junctions drawn →, ←, →: turning the shortest
    closes the loop with the third, which turned it back, on and on). Not in strict
    mode."""
    if report.strict:
        return
    turned: set[int] = set()
    for _ in range(len(links)):
        _, left = upstream_first([lk.start for lk in links], [lk.end for lk in links])
        if not left:
            return
        cycle = [i for i in _a_cycle(links, left) if i not in turned]
        if not cycle:           # (each way turned once at most: no turning back and forth)
            return
        k = min(cycle, key=lambda i: (OSM_CLASS_RANK.get(str(links[i].attrs.get("waterway")), 1),
                                      _length(links[i].points)))
        turned.add(k)
        lk = links[k]
        _turn(lk)
        report.repair(lk.name, lk.fid, lk.attrs, "closed a loop that flows back into itself "
                      f"with {', '.join(links[i].name for i in cycle if i != k)} (drawn the "
                      "wrong way round, against OpenStreetMap's rule): turned, the smallest "
                      "and shortest way of the loop")


def _a_cycle(links: list[_Link], among: list[int]) -> list[int]:
    """The links of one directed cycle among ``among`` (each leads on to the links starting
    where it ends), or [] if none (depth first, iteratively)."""
    outs: dict[int, list[int]] = {}
    for i in among:
        if links[i].start >= 0:
            outs.setdefault(links[i].start, []).append(i)
    colour: dict[int, int] = {}          # 1: on the path, 2: done
    for root in among:
        if root in colour:
            continue
        colour[root] = 1
        path, stack = [root], [(root, 0)]
        while stack:
            node, k = stack[-1]
            succ = outs.get(links[node].end, []) if links[node].end >= 0 else []
            if k < len(succ):
                stack[-1] = (node, k + 1)
                nxt = succ[k]
                if colour.get(nxt) == 1:
                    return path[path.index(nxt):]
                if nxt not in colour:
                    colour[nxt] = 1
                    path.append(nxt)
                    stack.append((nxt, 0))
            else:
                stack.pop()
                path.pop()
                colour[node] = 2
    return []


def _direct(links: list[_Link], report: RiverImport) -> list[_Link]:
    """Turn lines drawn upstream: each connected piece of the network drains to one outlet.

    Per piece, the outlet is the node (junction or free end) with the largest drainage area
    (or stream order) at it when most links give one; else the lowest (Z coordinates or
    elevation attributes) when most give one; else from the drawing: the node that needs the
    fewest lines turned (a line split in pieces counts once), less ANGLE_PER_TURN for each
    unit of fit to the rule that tributaries join at acute angles (:func:`_junction_angles`),
    among the TIE_CANDIDATES best (a piece already drawn with one outlet and no junction left
    without inflow or outflow is kept as it is unless the angles say otherwise); an outlet at
    a junction only where every line drawn there ends there. Every line then flows towards the
    outlet along the shortest
    path (so both arms of a braid run from its bifurcation to its confluence); lines given
    by ``reverse=`` are never turned. Each turned line is a reported repair."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components, dijkstra

    n_links = len(links)
    if n_links == 0 or report.strict:      # strict: as drawn (errors come from the topology)
        return links
    n_junctions = 1 + max(max(lk.start, lk.end) for lk in links)
    u = np.array([lk.start if lk.start >= 0 else n_junctions + 2 * i
                  for i, lk in enumerate(links)])
    v = np.array([lk.end if lk.end >= 0 else n_junctions + 2 * i + 1
                  for i, lk in enumerate(links)])
    n_nodes = n_junctions + 2 * n_links
    lengths = np.array([max(_length(lk.points), 1e-6) for lk in links])
    adjacency = coo_matrix((lengths, (u, v)), shape=(n_nodes, n_nodes)).tocsr()
    _, label = connected_components(adjacency, directed=False)
    node_xy = np.zeros((n_nodes, 2))
    node_xy[u] = [lk.points[0] for lk in links]
    node_xy[v] = [lk.points[-1] for lk in links]
    # evidence at the nodes: drainage area (or order) and elevation at each link end
    area = np.full(n_nodes, -np.inf)
    low = np.full(n_nodes, np.inf)
    has_area = np.zeros(n_links, bool)
    has_z = np.zeros(n_links, bool)
    for i, lk in enumerate(links):
        a0, a1 = lk.values.get("drainage_area_km2", (math.nan, math.nan))
        if not (math.isfinite(a0) or math.isfinite(a1)):
            a0, a1 = lk.values.get("stream_order", (math.nan, math.nan))
        if math.isfinite(a0) or math.isfinite(a1):
            has_area[i] = True
            a0 = a0 if math.isfinite(a0) else a1
            a1 = a1 if math.isfinite(a1) else a0
            area[u[i]] = max(area[u[i]], a0)
            area[v[i]] = max(area[v[i]], a1)
        z0, z1 = lk.z
        if not (math.isfinite(z0) and math.isfinite(z1)):
            z0, z1 = lk.values.get("elevation_m", (math.nan, math.nan))
        if math.isfinite(z0) and math.isfinite(z1) and z0 != z1:
            has_z[i] = True
            low[u[i]] = min(low[u[i]], z0)
            low[v[i]] = min(low[v[i]], z1)
    drawn = [lk.name.split(" piece ")[0] for lk in links]     # one drawing: a line's pieces
    pieces = {}
    for name in drawn:
        pieces[name] = pieces.get(name, 0) + 1
    flips = _flip_counts(u, v, n_nodes, np.array([1.0 / pieces[n] for n in drawn]))
    outs = np.bincount(u, minlength=n_nodes)
    ins = np.bincount(v, minlength=n_nodes)
    in_cycle = _cycle_nodes(u, v, n_nodes)
    node_groups = _groups(label)
    link_groups = _groups(label[u])
    ends_dir = [(_unit(lk.points[1] - lk.points[0]), _unit(lk.points[-1] - lk.points[-2]))
                for lk in links]
    outlets: dict[int, int] = {}
    how: dict[int, str] = {}
    own = np.array([_own_direction(lk) for lk in links])
    delta_turns: list[int] = []
    for comp, mine in link_groups.items():
        members = node_groups[comp]
        junction = members[(ins[members] + outs[members]) >= 2]
        turned = mine[(own[mine] < 0) & ~np.array([links[i].fixed for i in mine], bool)]
        if _drains_as_a_delta(u[mine], v[mine], [ends_dir[i] for i in mine],
                              np.isin(mine, turned),
                              DELTA_COS_EVIDENCE if (own[mine] != 0).any() else DELTA_COS):
            delta_turns += turned.tolist()
            continue                 # several outlets (a delta), each line as drawn or by its own
        sinks = members[(ins[members] > 0) & (outs[members] == 0)]
        consistent = (len(sinks) == 1 and not in_cycle[members].any()
                      and (ins[junction] > 0).all() and (outs[junction] > 0).all())
        if has_area[mine].sum() * 2 > len(mine):
            evidence = -area[members]
            why = ("the drainage areas" if any(math.isfinite(
                links[i].values.get("drainage_area_km2", (math.nan,))[0]) for i in mine)
                   else "the stream orders")
        elif has_z[mine].sum() * 2 > len(mine):
            evidence, why = low[members], "the elevations"
        elif len(junction) == 0:
            continue                     # one line alone: as drawn
        else:
            evidence, why = np.zeros(len(members)), "the topology: one outlet per piece"
        # then: fewest lines turned, a free end, a sink as drawn
        degree = ins[members] + outs[members]
        # an outlet at a junction only where the lines drawn there all end there (clipped data)
        evidence = np.where((degree > 1) & (outs[members] > 0), np.inf, evidence)
        rank = np.lexsort((-(ins[members] > 0).astype(int), degree, flips[members], evidence))
        same = evidence[rank] == evidence[rank[0]]
        tied = rank[: max(1, int(same.sum()))][:TIE_CANDIDATES]
        best = members[tied[0]]
        if len(tied) > 1 and len(junction):
            # the drawing against the geometry: tributaries join their river at acute angles
            sub = adjacency[members][:, members]
            local = {int(n): k for k, n in enumerate(members)}
            lu = np.array([local[int(x)] for x in u[mine]])
            lv = np.array([local[int(x)] for x in v[mine]])
            scores = [_junction_angles(dijkstra(sub, directed=False, indices=int(t)), lu, lv,
                                       [ends_dir[i] for i in mine])
                      - ANGLE_PER_TURN * flips[members[t]] for t in tied]
            best = members[tied[int(np.argmax(scores))]]
        if consistent and not np.isfinite(evidence).any() and best in sinks:
            continue
        outlets[comp] = int(best)
        how[comp] = why
    for i in delta_turns:
        lk = links[i]
        report.repair(lk.name, lk.fid, lk.attrs,
                      "drawn upstream (by its own " + ("drainage areas" if own[i] == -2 else
                                                      "elevations") +
                      "; its piece of the network is a delta, several outlets): turned")
        _turn(lk)
    if not outlets:
        return links
    dist = dijkstra(adjacency, directed=False, indices=list(outlets.values()), min_only=True)
    for i, lk in enumerate(links):
        comp = int(label[u[i]])
        if comp not in how or lk.fixed:
            continue
        if dist[u[i]] < dist[v[i]] - 1e-9:
            x, y = node_xy[outlets[comp]]
            report.repair(lk.name, lk.fid, lk.attrs,
                          f"drawn upstream (by {how[comp]}; its piece of the network drains "
                          f"to ({x:.1f}, {y:.1f})): turned")
            _turn(lk)
    return links


def _own_direction(lk: _Link) -> int:
    """What the line's own values say of its drawing: 2 / −2 drawn downstream / upstream by
    its drainage areas (given at both ends, growing downstream), 1 / −1 by its elevations
    (Z, else the elevation attributes; falling downstream), 0 when they do not tell."""
    a0, a1 = lk.values.get("drainage_area_km2", (math.nan, math.nan))
    if math.isfinite(a0) and math.isfinite(a1) and a0 != a1:
        return 2 if a1 > a0 else -2
    z0, z1 = lk.z
    if not (math.isfinite(z0) and math.isfinite(z1)):
        z0, z1 = lk.values.get("elevation_m", (math.nan, math.nan))
    if math.isfinite(z0) and math.isfinite(z1) and z0 != z1:
        return 1 if z1 < z0 else -1
    return 0


def _drains_as_a_delta(u: np.ndarray, v: np.ndarray, dirs, turned: np.ndarray,
                       min_cos: float) -> bool:
    """Whether a piece of network, with the lines ``turned`` turned, drains to several
    outlets as a delta does: no loop, every junction with inflow and outflow, more than one
    outlet (a node where lines end and none starts), and at every split each outflow leaving
    within acos(``min_cos``) of the inflows' mean direction (distributaries go on forward; a
    tributary drawn upstream would point back)."""
    if len(u) < 3:                       # a split needs a line in and two out
        return False
    u, v = np.where(turned, v, u), np.where(turned, u, v)
    dirs = [(-last, -first) if t else (first, last) for (first, last), t in zip(dirs, turned)]
    nodes, local = np.unique(np.concatenate([u, v]), return_inverse=True)
    lu, lv = local[:len(u)], local[len(u):]
    n = len(nodes)
    ins, outs = np.bincount(lv, minlength=n), np.bincount(lu, minlength=n)
    junction = (ins + outs) >= 2
    if (((ins == 0) | (outs == 0)) & junction).any() or ((ins > 0) & (outs == 0)).sum() < 2:
        return False
    if _cycle_nodes(lu, lv, n).any():
        return False
    inflow: dict[int, list[np.ndarray]] = {}
    for b, (_, last) in zip(lv.tolist(), dirs):
        inflow.setdefault(b, []).append(last)
    for a, (first, _) in zip(lu.tolist(), dirs):
        if outs[a] >= 2 and float(np.dot(_unit(np.mean(inflow[a], axis=0)), first)) < min_cos:
            return False
    return True


def _groups(label: np.ndarray) -> dict[int, np.ndarray]:
    """Indices of ``label``'s entries by value (O(n log n))."""
    order = np.argsort(label, kind="stable")
    values, first = np.unique(label[order], return_index=True)
    return {int(v): g for v, g in zip(values, np.split(order, first[1:]))}


def _unit(d: np.ndarray) -> np.ndarray:
    return d / max(float(np.hypot(*d)), 1e-12)


def _junction_angles(dist: np.ndarray, u: np.ndarray, v: np.ndarray, dirs) -> float:
    """How well an orientation (every line towards smaller ``dist``) fits the rule that rivers
    join at acute angles: the sum over junctions of the cosine between each inflow's last
    direction and each outflow's first direction."""
    inflow: dict[int, list[np.ndarray]] = {}
    outflow: dict[int, list[np.ndarray]] = {}
    for a, b, (first, last) in zip(u.tolist(), v.tolist(), dirs):
        if dist[a] < dist[b]:            # flows b → a: drawn upstream
            a, b, first, last = b, a, -last, -first
        outflow.setdefault(a, []).append(first)
        inflow.setdefault(b, []).append(last)
    return float(sum(np.dot(i, o) for n in inflow if n in outflow
                     for i in inflow[n] for o in outflow[n]))


def _flip_counts(u: np.ndarray, v: np.ndarray, n_nodes: int, weight: np.ndarray) -> np.ndarray:
    """For every node: how many lines of a spanning tree of its piece point away from it
    (the lines to turn if it were the outlet; a line split in k pieces counts 1/k a piece),
    by rerooting in O(n)."""
    adj: dict[int, list[tuple[int, float]]] = {}
    for a, b, w in zip(u.tolist(), v.tolist(), weight.tolist()):
        adj.setdefault(a, []).append((b, w))      # drawn a → b
        adj.setdefault(b, []).append((a, -w))
    flips = np.zeros(n_nodes)
    seen = np.zeros(n_nodes, bool)
    for root in adj:
        if seen[root]:
            continue
        seen[root] = True
        order, parent_dir, queue, count = [root], {}, [root], 0.0
        while queue:
            nxt = []
            for a in queue:
                for b, d in adj[a]:
                    if not seen[b]:
                        seen[b] = True
                        parent_dir[b] = (a, d)    # d=+1: drawn parent → child (away from root)
                        count += max(d, 0.0)
                        order.append(b)
                        nxt.append(b)
            queue = nxt
        flips[root] = count
        for b in order[1:]:
            a, d = parent_dir[b]
            flips[b] = flips[a] - d
    return flips


def _cycle_nodes(u: np.ndarray, v: np.ndarray, n_nodes: int) -> np.ndarray:
    """Nodes on a directed cycle (or downstream of one): those Kahn's algorithm never frees."""
    ins = np.bincount(v, minlength=n_nodes)
    out_edges: dict[int, list[int]] = {}
    for a, b in zip(u.tolist(), v.tolist()):
        out_edges.setdefault(a, []).append(b)
    free = [n for n in range(n_nodes) if ins[n] == 0]
    done = np.zeros(n_nodes, bool)
    while free:
        a = free.pop()
        done[a] = True
        for b in out_edges.get(a, ()):
            ins[b] -= 1
            if ins[b] == 0:
                free.append(b)
    return ~done


def _close_clipped_ends(links: list[_Link], plan, geometry: HydraulicGeometry, specs,
                        report: RiverImport):
    """Where rivers meet and nothing leaves (the data was clipped there) add a short outlet
    (CONTINUATION_WIDTHS × the widest inflow long, along their mean direction); where rivers
    leave a junction that nothing enters, a short inflow; either from the other side where it
    would lie in land the network's loops close round (arms that leave the junction and meet
    again: water cannot enter or leave through an island). Returns the links and their plan."""
    ins, outs = by_junction([lk.start for lk in links], [lk.end for lk in links])
    added = []
    land, turned, dropped = None, False, set()
    for j in sorted(set(ins) | set(outs)):
        into, out_of = ins.get(j, []), outs.get(j, [])
        if into and out_of:
            continue
        group = into or out_of
        at_end = bool(into)
        p = links[group[0]].points[-1 if at_end else 0]
        dirs = []
        for i in group:
            q = links[i].points
            d = (q[-1] - q[-2]) if at_end else (q[1] - q[0])
            dirs.append(d / max(np.hypot(*d), 1e-12))
        d = np.mean(dirs, axis=0)
        if np.hypot(*d) < 1e-6:      # inflows from opposite sides: go across them
            d = np.array([-dirs[0][1], dirs[0][0]])
        d /= np.hypot(*d)
        width = max(plan[i][0] for i in group)
        q3 = sum(plan[i][2] for i in group)
        length = CONTINUATION_WIDTHS * max(width, geometry.width(q3))
        line = np.array([p, p + d * length]) if at_end else np.array([p - d * length, p])
        if land is None:
            land = _enclosed_land(links)
        other_side = land is not False and _in_land(land, line)
        if other_side:              # the arms of a loop close round that side: from the other
            line = 2.0 * p - line
            if _in_land(land, line):                   # loops on every side
                if _turn_one_of(links, group, at_end, ins, outs, report):
                    turned = True
                    continue
                i = min(group, key=lambda k: _length(links[k].points))
                report.repair(links[i].name, links[i].fid, links[i].attrs,
                              f"{' and '.join(links[k].name for k in group)} "
                              + ("end where nothing leaves" if at_end else
                                 "start where nothing enters")
                              + f" ({p[0]:.1f}, {p[1]:.1f}), between loops of the network on "
                                "every side, and none can be turned without closing a loop "
                                "that flows back into itself: left out, the shortest of them")
                dropped.add(i)
                continue
        names = [links[i].name for i in group]
        lead = links[group[0]]
        values = {key: (math.nan, math.nan) for key in lead.values}
        if not at_end:
            values["discharge_m3s"] = (q3, q3)
        link = _Link(f"outlet of {names[0]}" if at_end else f"inflow of {names[0]}", -1, line,
                     {}, values, start=j if at_end else -1, end=-1 if at_end else j)
        link.added = True
        report.repair(lead.name, lead.fid, lead.attrs,
                      (f"{' and '.join(names)} end at ({p[0]:.1f}, {p[1]:.1f}) where nothing "
                       f"leaves (the data is clipped there): an outlet {length:.0f} m long "
                       "added" if at_end else
                       f"{' and '.join(names)} start at ({p[0]:.1f}, {p[1]:.1f}) where nothing "
                       f"enters: an inflow {length:.0f} m long added")
                      + (" (on the side away from the land their loop closes round)"
                         if other_side else ""))
        added.append(link)
    if dropped:             # what is left of them may lie in land now: left out, and again
        links = _drop_enclosed([lk for i, lk in enumerate(links) if i not in dropped] + added,
                               report)
        return _close_clipped_ends(links, _plan(links, geometry, specs, report), geometry,
                                   specs, report)
    if not added and not turned:
        return links, plan
    links = links + added
    return links, _plan(links, geometry, specs, report)


def _turn_one_of(links: list[_Link], group: list[int], at_end: bool, ins: dict, outs: dict,
                 report: RiverImport) -> bool:
    """Where lines leave a junction nothing enters and the network's loops close round it
    on every side (no inflow can reach it but through an island: a divide between two
    streams drawn from one point, NHDPlus), turn the shortest of them that runs on from a
    junction something else enters (``at_end``: lines that meet where nothing leaves, the
    shortest that comes from one something else leaves) and closes no loop that flows back
    into itself: it feeds the others (a reported repair, even against the file's word).
    ``ins``/``outs`` are kept current. Returns whether one was turned."""
    for i in sorted(group, key=lambda k: _length(links[k].points)):
        lk = links[i]
        j, k = (lk.end, lk.start) if at_end else (lk.start, lk.end)
        if k < 0 or len((outs if at_end else ins).get(k, [])) < 2:
            continue
        # a loop if the far junction k is reached from j along the flow (the other lines)
        step = ins if at_end else outs
        seen, todo = {j}, [j]
        while todo:
            n = todo.pop()
            for m in step.get(n, []):
                if m == i:
                    continue
                nxt = links[m].start if at_end else links[m].end
                if nxt >= 0 and nxt not in seen:
                    seen.add(nxt)
                    todo.append(nxt)
        if k in seen:
            continue
        (outs if at_end else ins)[k].remove(i)
        (ins if at_end else outs).setdefault(k, []).append(i)
        group.remove(i)
        (outs if at_end else ins).setdefault(j, []).append(i)
        _turn(lk)
        others = " and ".join(links[m].name for m in group)
        report.repair(lk.name, lk.fid, lk.attrs,
                      (f"it and {others} end where nothing leaves" if at_end else
                       f"it and {others} start where nothing enters")
                      + f" ({links[i].points[0 if at_end else -1][0]:.1f}, "
                        f"{links[i].points[0 if at_end else -1][1]:.1f}), between loops of the "
                        f"network on every side (no water can come or go there but through an "
                        f"island): turned, the shortest of them, to "
                      + ("carry their water on" if at_end else "feed the others"))
        return True
    return False


def _enclosed_land(links: list[_Link]):
    """The land the links' loops close round (the faces of the network, prepared) and the
    channels round it (every face's rings, inner too), or False where there are no loops."""
    faces = shapely.get_parts(shapely.polygonize([shapely.LineString(lk.points)
                                                  for lk in links]))
    if not len(faces):
        return False
    land = shapely.union_all(faces)
    shapely.prepare(land)
    return land, shapely.multilinestrings(shapely.get_rings(faces))


def _in_land(land, line: np.ndarray) -> bool:
    """Whether the middle of ``line`` lies in that land, off the channels round it."""
    middle = shapely.Point(0.5 * (line[0] + line[-1]))
    return bool(land[0].contains(middle) and land[1].distance(middle) > 1e-6)


def _cut_crossings(links: list[_Link], plan, crossings, geometry: HydraulicGeometry, specs,
                   report: RiverImport):
    """Two lines that cross without a shared vertex (a canal over a river, a culvert) make
    no junction: the narrower one is cut where it crosses the wider one's water (its part
    above ends there, its part below starts there with the same discharge)."""
    width = {id(lk): p[0] for lk, p in zip(links, plan)}
    volume = {id(lk): p[2] for lk, p in zip(links, plan)}
    family: dict[str, list[_Link]] = {}          # crossing name → the links made from it
    names = {n for a, b, _ in crossings for n in (a, b)}
    for lk in links:
        if lk.name in names:
            family.setdefault(lk.name, []).append(lk)
    replaced: dict[int, list[_Link]] = {}

    def member(name: str, x: np.ndarray) -> _Link | None:
        """The link (of those made from the line ``name``) that passes through ``x``."""
        near = [(shapely.distance(shapely.LineString(lk.points), shapely.Point(x)), k)
                for k, lk in enumerate(family.get(name, []))]
        best = min(near, default=None)
        return family[name][best[1]] if best is not None and best[0] < 1e-3 else None

    for name_a, name_b, x in crossings:
        a, b = member(name_a, x), member(name_b, x)
        if a is None or b is None or a is b:
            continue
        lk, other = (a, b) if width[id(a)] <= width[id(b)] else (b, a)
        w_n, w_o = width[id(lk)], width[id(other)]
        line = shapely.LineString(lk.points)
        zone = shapely.buffer(shapely.LineString(other.points), 0.5 * w_o + 0.75 * w_n)
        s_x = line.project(shapely.Point(x))
        hits = [line.project(shapely.Point(c)) for c in
                shapely.get_coordinates(shapely.intersection(line, zone.boundary))]
        before = max([h for h in hits if h < s_x], default=0.0)
        after = min([h for h in hits if h > s_x], default=line.length)
        pieces = []
        for k, (s0, s1) in enumerate(((0.0, before), (after, line.length))):
            if s1 - s0 < max(w_n, 1e-3):
                continue
            part = shapely.get_coordinates(shapely.ops.substring(line, s0, s1))
            piece = _Link(f"{lk.name} {'above' if k == 0 else 'below'} the crossing", lk.fid,
                          part, lk.attrs, dict(lk.values),
                          start=lk.start if k == 0 else -1, end=-1 if k == 0 else lk.end)
            piece.fixed = True
            piece.cell_m = lk.cell_m
            piece.source_width_m = lk.source_width_m
            if k == 1 and not math.isfinite(lk.values["discharge_m2s"][1]):
                piece.values["discharge_m3s"] = (volume[id(lk)], volume[id(lk)])
            width[id(piece)], volume[id(piece)] = w_n, volume[id(lk)]
            pieces.append(piece)
        report.repair(lk.name, lk.fid, lk.attrs,
                      f"crosses {other.name} at ({x[0]:.1f}, {x[1]:.1f}) without a shared "
                      f"vertex (a culvert or aqueduct: no junction): cut out where it crosses "
                      f"the other's water ({after - before:.0f} m)")
        replaced[id(lk)] = pieces
        for name, members in family.items():
            if any(m is lk for m in members):
                family[name] = [m for m in members if m is not lk] + pieces

    def expand(lk: _Link) -> list[_Link]:
        return [q for p in replaced[id(lk)] for q in expand(p)] if id(lk) in replaced else [lk]

    if not replaced:
        return links, plan
    links = [q for lk in links for q in expand(lk)]
    return links, _plan(links, geometry, specs, report)


def _first_gaps(links: list[_Link], width, pairs, outflow: bool = False) -> dict:
    """For each pair (a, b) of links flowing into one junction (``outflow``: out of it): the
    first FIRST_GAPS distances back from its end along a (on from its start), every quarter
    of the narrower width, and a's distance there to b (what :func:`_merge_close_channels`
    measured first pair by pair; in one GEOS call for all pairs)."""
    if not pairs:
        return {}
    geoms = {i: shapely.LineString(links[i].points) for pair in pairs for i in pair}
    a_rows, b_rows, backs = [], [], []
    for a, b in pairs:
        step = 0.25 * min(width[a], width[b])
        more = np.arange(FIRST_GAPS) * step
        more = more[more < geoms[a].length]
        backs.append(more)
        a_rows += [a] * len(more)
        b_rows += [b] * len(more)
    back = np.concatenate(backs)
    line_a = np.array([geoms[i] for i in a_rows], dtype=object)
    line_b = np.array([geoms[i] for i in b_rows], dtype=object)
    d = shapely.distance(shapely.line_interpolate_point(
        line_a, back if outflow else shapely.length(line_a) - back), line_b)
    out, k = {}, 0
    for pair, more in zip(pairs, backs):
        out[pair] = (more, d[k:k + len(more)])
        k += len(more)
    return out


FIRST_GAPS = 8
"""Points measured at once per pair of channels into a junction (most part within a few
widths; those that do not are followed in batches that double)."""


def _merge_close_channels(links: list[_Link], plan, geometry: HydraulicGeometry, specs,
                          report: RiverImport, outflow: bool = False):
    """Two channels that flow into one junction and run closer together than MERGE_GAP ×
    the sum of their widths w_a + w_b (between centre lines) over more than MERGE_REACH ×
    the wider one's width above it meet earlier: from where they come that close, they are
    one reach along their mid line that carries both discharges, its width by the rules of
    a link below a confluence (the hydraulic geometry of the sum), at least the wider one's
    (wider than the gap: it holds both centre lines). Two arms of a braid keep their island
    above that point. ``outflow``: two channels that flow out of one junction at a small
    angle and run that close below it (Sydney's OSM: two drains 14° apart, 1 m wide) part
    later: one reach carries both from the junction to where they part. Each merged channel
    is a reported repair. Returns the links and their plan."""
    ins, outs = by_junction([lk.start for lk in links], [lk.end for lk in links])
    groups = outs if outflow else ins
    width = [p[0] for p in plan]
    next_j = 1 + max([max(lk.start, lk.end) for lk in links], default=-1)
    added, told = [], []
    first = _first_gaps(links, width, [(a, b) for j in sorted(groups)
                                       for a, b in itertools.combinations(groups[j], 2)],
                        outflow)

    def along(line, s):           # s back from the junction along the line (its arc length)
        return s if outflow else line.length - s

    widest = {}                              # the widest river at each junction: its water
    for i, lk in enumerate(links):
        for j in (lk.start, lk.end):
            widest[j] = max(widest.get(j, 0.0), width[i])

    for j in sorted(groups):
        group = groups[j]
        used: set[int] = set()
        for a, b in itertools.combinations(group, 2):
            if a in used or b in used:
                continue
            la, lb = links[a], links[b]
            wa, wb = width[a], width[b]
            line_a, line_b = shapely.LineString(la.points), shapely.LineString(lb.points)
            step = 0.25 * min(wa, wb)
            back, d = first[a, b]
            batch = 16          # most pairs part within a few widths: batches that double
            while len(back) * step < line_a.length and not (
                    d >= MERGE_GAP * (wa + wb)).any():     # from the junction on, till they part
                more = np.arange(len(back), len(back) + batch) * step
                batch = min(2 * batch, 64)
                more = more[more < line_a.length]
                back = np.concatenate([back, more])
                d = np.concatenate([d, shapely.distance(shapely.line_interpolate_point(
                    line_a, along(line_a, more)), line_b)])
                if (d >= MERGE_GAP * (wa + wb)).any():
                    break
            close = d < MERGE_GAP * (wa + wb)
            k = int(np.argmin(close)) if not close.all() else len(close)
            reach = back[k - 1] if k else 0.0
            reach = min(reach, 0.8 * line_a.length)
            if reach <= max(MERGE_REACH * max(wa, wb), widest[j]):
                continue                     # close only around the junction: its own shape
            cut_a = np.array(line_a.interpolate(along(line_a, reach)).coords[0])
            at_b = float(line_b.project(shapely.Point(cut_a)))
            if line_b.length - along(line_b, at_b) <= 0.2 * line_b.length:
                continue                     # b would be left with nothing beyond
            cut_b = np.array(line_b.interpolate(at_b).coords[0])
            gap = float(np.hypot(*(cut_a - cut_b)))
            mid = 0.5 * (cut_a + cut_b)
            s = (np.arange(reach, 0.0, -step) if outflow          # from the cut on
                 else np.arange(line_a.length - reach, line_a.length, step))
            on_a = shapely.get_coordinates(shapely.line_interpolate_point(line_a, s))
            on_b = shapely.get_coordinates(shapely.line_interpolate_point(
                line_b, shapely.line_locate_point(line_b, shapely.points(on_a))))
            junction = la.points[0] if outflow else la.points[-1]
            midline = np.vstack([mid, 0.5 * (on_a + on_b)[1:], junction])
            f_a = along(line_a, reach) / line_a.length
            z0, z1 = la.values.get("elevation_m", (math.nan, math.nan))
            values = {key: (math.nan, math.nan) for key in la.values}   # by the rules
            z_cut = z0 + (z1 - z0) * f_a
            values["elevation_m"] = (z0, z_cut) if outflow else (z_cut, z1)
            for lk, line, at in ((la, line_a, along(line_a, reach)), (lb, line_b, at_b)):
                f = at / line.length                 # values given per end: at the cut
                # each arm leaves its line a gap's length before the cut and meets the
                # merged reach at its end slantwise (≤ 27°), not square across the gap: two
                # arms running side by side would end in a T whose strips overlap beyond the
                # junction
                lead = min(gap, 0.5 * (line.length - at if outflow else at))
                if outflow:
                    beyond = shapely.get_coordinates(shapely.ops.substring(
                        line, at + lead, line.length))
                    lk.points = np.vstack([mid, beyond])
                    lk.start = next_j
                    lk.values = {key: (v0 + (v1 - v0) * f, v1) for key, (v0, v1) in
                                 lk.values.items()}
                    lk.z = (lk.z[0] + (lk.z[1] - lk.z[0]) * f, lk.z[1])
                else:
                    above = shapely.get_coordinates(shapely.ops.substring(line, 0.0,
                                                                          at - lead))
                    lk.points = np.vstack([above, mid])
                    lk.end = next_j
                    lk.values = {key: (v0, v0 + (v1 - v0) * f) for key, (v0, v1) in
                                 lk.values.items()}
                    lk.z = (lk.z[0], lk.z[0] + (lk.z[1] - lk.z[0]) * f)
            if outflow:
                midline = midline[::-1]
            link = _Link(f"{la.name} and {lb.name} merged", la.fid, midline, {}, values,
                         start=j if outflow else next_j, end=next_j if outflow else j)
            closest = float(d[(back > max(wa, wb)) & (back <= reach)].min())
            told.append((la, lb, wa, wb, closest, reach, gap, len(links) + len(added)))
            added.append(link)
            used |= {a, b}
            next_j += 1
    if not added:
        return links, plan
    links = links + added
    plan = _plan(links, geometry, specs, report)
    narrow = [(i, max(wa, wb)) for _, _, wa, wb, _, _, _, i in told if plan[i][0] < max(wa, wb)]
    for i, w in narrow:                  # given arms wider than their discharge says
        links[i].values["width_m"] = (w, w)
    if narrow:
        plan = _plan(links, geometry, specs, report)
    for la, lb, wa, wb, closest, reach, gap, i in told:
        for lk, other in ((la, lb), (lb, la)):
            report.repair(lk.name, lk.fid, lk.attrs,
                          f"runs closer to {other.name} than their widths allow ({closest:.1f} m "
                          f"between centre lines at the closest, {wa:.1f} and {wb:.1f} m wide) "
                          f"for its {'first' if outflow else 'last'} {reach:.0f} m: merged with "
                          f"it there ({gap:.1f} m apart) into one reach {plan[i][0]:.1f} m "
                          f"wide that carries both")
    return links, plan


def _move_side_inflows(links: list[_Link], plan, geometry: HydraulicGeometry, specs,
                       report: RiverImport):
    """An inflow a that enters a junction beside an outflow b (their lines leave it less than
    SIDE_ANGLE_DEG apart, over the wider one's width; a no wider than b; another inflow
    there) whose last half or more lies in b's water has no banks of its own across its
    middle: they would be b's. It joins b farther
    down instead: a is cut back to where its strip clears b's (centre lines half their widths
    apart) and led straight to b's nearest point there, b split at that point (at b's end
    junction when that is nearer than half their widths). Each moved inflow is a reported
    repair. Returns the links and their plan."""
    ins, outs = by_junction([lk.start for lk in links], [lk.end for lk in links])
    width = [p[0] for p in plan]
    next_j = 1 + max([max(lk.start, lk.end) for lk in links], default=-1)
    touched: set[int] = set()
    dropped: set[int] = set()
    added: list[_Link] = []
    cos_side = math.cos(math.radians(SIDE_ANGLE_DEG))
    for j in sorted(set(ins) & set(outs)):
        if len(ins[j]) < 2:
            continue
        for a, b in itertools.product(ins[j], outs[j]):
            if a in touched or b in touched or width[a] > width[b]:
                continue
            la, lb = links[a], links[b]
            wa, wb = width[a], width[b]
            line_a, line_b = shapely.LineString(la.points), shapely.LineString(lb.points)
            reach = max(wa, wb)
            at = la.points[-1]
            da = np.asarray(line_a.interpolate(max(line_a.length - reach, 0.0)).coords[0]) - at
            db = np.asarray(line_b.interpolate(min(reach, line_b.length)).coords[0]) - at
            cos = float(da @ db) / max(np.hypot(*da) * np.hypot(*db), 1e-12)
            if cos < cos_side:
                continue
            clear = 0.5 * (wa + wb)
            back = np.arange(0.0, line_a.length, 0.25 * wa)[1:]
            d = shapely.distance(shapely.line_interpolate_point(line_a, line_a.length - back),
                                 line_b)
            if not (d >= clear).any():
                continue                   # all of it in b's water: the build says so
            s_clear = float(back[int(np.argmax(d >= clear))])
            if s_clear <= 0.5 * line_a.length:
                continue                   # its middle clear of it: banks of its own there
            cut = np.asarray(line_a.interpolate(line_a.length - s_clear).coords[0])
            t = float(line_b.project(shapely.Point(cut)))
            if line_b.length - t < clear:
                if lb.end < 0:
                    continue               # b's outlet: no junction to join there
                target, end_j, pieces, t = lb.points[-1], lb.end, [], line_b.length
            else:
                above, below = _split(lb, [t])
                above.start, above.end = lb.start, next_j
                below.start, below.end = next_j, lb.end
                links[b] = above
                target, end_j, pieces = above.points[-1], next_j, [below]
                next_j += 1
            told, above_it = (la.name, la.fid, la.attrs), ""
            ups = ins.get(la.start, [])
            if (line_a.length - s_clear < np.hypot(*(cut - target)) and len(ups) == 1
                    and outs.get(la.start) == [a] and ups[0] not in touched):
                # what is left of a would lie mostly in b's water (its middle too): a short
                # link goes on from the one line above it, nothing else meeting there
                u = links[ups[0]]
                la = _Link((u if _length(u.points) > line_a.length else la).name, la.fid,
                           np.vstack([u.points, la.points[1:]]), la.attrs,
                           {key: (u.values[key][0], v[1]) for key, v in la.values.items()},
                           u.start, la.end, (u.z[0], la.z[1]), u.fixed or la.fixed,
                           cell_m=la.cell_m, source_width_m=u.source_width_m)
                links[a] = la
                above_it = f" (joined with {u.name}, the one line above it)"
                dropped.add(ups[0])
                touched.add(ups[0])
                line_a = shapely.LineString(la.points)
            f = (line_a.length - s_clear) / line_a.length
            kept = shapely.get_coordinates(shapely.ops.substring(line_a, 0.0,
                                                                 line_a.length - s_clear))
            la.points = np.vstack([kept, target])
            la.end = end_j
            la.values = {key: (v0, v0 + (v1 - v0) * f) for key, (v0, v1) in la.values.items()}
            la.z = (la.z[0], la.z[0] + (la.z[1] - la.z[0]) * f)
            angle = math.degrees(math.acos(min(cos, 1.0)))
            report.repair(*told,
                          f"flows into ({at[0]:.1f}, {at[1]:.1f}) {angle:.0f}° off the course of "
                          f"{lb.name}, which leaves it ({wa:.1f} and {wb:.1f} m wide): its last "
                          f"{s_clear:.0f} m lay in that river's water; cut back to where it is "
                          f"clear of it{above_it} and led into it {t:.0f} m downstream at "
                          f"({target[0]:.1f}, {target[1]:.1f})")
            touched |= {a, b}
            added += pieces
    if not touched:
        return links, plan
    links = [lk for i, lk in enumerate(links) if i not in dropped] + added
    return links, _plan(links, geometry, specs, report)


def _cut_ends_in_water(branches, report: RiverImport) -> None:
    """A source or an outlet (an end no other branch shares) that lies in another branch's
    water (nearer its centre line than half the two widths) but off its junctions (Andorra's
    OSM: a stream rising 5 m from the Valira del Nord, 15 m wide: "overlap but do not meet")
    is cut back along its own line to where it is clear of that water (a reported repair);
    a branch whose whole length lies in it is left alone (the build says what is wrong)."""
    if len(branches) < 2:
        return
    lines = _geoms([b.centerline_m for b in branches])
    tree = shapely.STRtree(lines)
    ends = np.array([[b.centerline_m[0], b.centerline_m[-1]] for b in branches])
    flat = ends.reshape(-1, 2)
    fids = {lk.name: lk.fid for lk in report.links}
    widest = max(float(b.widths_m.max()) for b in branches)
    for i, b in enumerate(branches):
        for at in (0, 1):
            p = ends[i, at]
            w = float(b.widths_m[0 if at == 0 else -1])
            shared = np.hypot(*(flat - p).T) <= 0.25 * w + 1e-6
            shared[2 * i + at] = False
            if shared.any():
                continue                                       # a junction
            for j in tree.query(shapely.Point(p), predicate="dwithin",
                                distance=0.5 * (w + widest)):
                if j == i:
                    continue
                other = branches[j]
                clear = 0.5 * (w + float(other.widths_m.max()))
                d = float(lines[j].distance(shapely.Point(p)))
                if d >= clear:
                    continue
                # the line with that end last, its points in the water from k + 1 on
                line = b.centerline_m if at == 1 else b.centerline_m[::-1]
                widths = b.widths_m if at == 1 else b.widths_m[::-1]
                arc = np.r_[0.0, np.cumsum(np.hypot(*np.diff(line, axis=0).T))]
                inside = shapely.distance(lines[j], shapely.points(line)) < clear
                k = len(line) - 1
                while k > 0 and inside[k]:
                    k -= 1
                if inside[k]:
                    break                                      # all of it in that water
                seg = shapely.LineString(line)
                lo, hi = float(arc[k]), float(arc[k + 1])
                for _ in range(40):                            # where it enters the water
                    mid = 0.5 * (lo + hi)
                    if lines[j].distance(seg.interpolate(mid)) >= clear:
                        lo = mid
                    else:
                        hi = mid
                kept = np.vstack([line[:k + 1], np.asarray(seg.interpolate(lo).coords)])
                keep_w = np.r_[widths[:k + 1], widths[k]]
                if at == 0:
                    kept, keep_w = kept[::-1], keep_w[::-1]
                b.centerline_m = np.ascontiguousarray(kept)
                b.widths_m = np.ascontiguousarray(keep_w)
                s_end = float(arc[-1])
                report.repair(b.name, fids.get(b.name), report.attributes.get(b.name, {}),
                              f"its {'start' if at == 0 else 'end'} lies in the water of "
                              f"{other.name} ({d:.1f} m from its centre line, off its "
                              f"junctions): cut back by {s_end - lo:.1f} m to where it is "
                              f"clear of it")
                lines[i] = shapely.LineString(b.centerline_m)
                ends[i] = [b.centerline_m[0], b.centerline_m[-1]]
                break


def _narrow_branches(branches, report: RiverImport, attempt: int) -> bool:
    """Narrow the branches of a builder where they lie closer to another branch than their
    widths allow (for :meth:`GisRiverBuilder.build`): each vertex (lines densified to a
    quarter of their width) farther than the junction disc (shrinking with ``attempt``) from a
    junction the two share, whose distance d to the other's centre line is less than half
    the sum of their widths, gets the width NARROW_GAP · d · w / (w + w_other). Returns
    whether any width changed; each narrowed branch is a reported repair."""
    if len(branches) < 2:
        return False
    for b in branches:
        b.centerline_m, b.widths_m = _densify(b.centerline_m, b.widths_m,
                                              max(0.25 * float(b.widths_m.min()), 0.05))
    lines = _geoms([b.centerline_m for b in branches])
    widest = np.array([float(b.widths_m.max()) for b in branches])
    tree = shapely.STRtree(lines)
    a_idx, b_idx = tree.query(lines, predicate="dwithin", distance=0.5 * (widest + widest.max()))
    disc = (1.0, 0.6, 0.3, 0.15)[min(attempt, 3)]
    fids = {lk.name: lk.fid for lk in report.links}
    changed = {}
    indexes: dict[int, PolylineIndex] = {}     # segment boxes: a star of long densified
    for a, b in zip(a_idx.tolist(), b_idx.tolist()):    # lines stays linear, not N·M
        if a == b:
            continue
        ba, bb = branches[a], branches[b]
        pts = ba.centerline_m
        w = ba.widths_m
        if b not in indexes:
            indexes[b] = PolylineIndex(bb.centerline_m)
        d, nearest, _ = indexes[b].nearest(pts, 0.5 * (float(w.max()) + widest[b]))
        close = d < 0.5 * (w + widest[b])
        if not close.any():
            continue
        for pa, wa in ((ba.centerline_m[0], ba.widths_m[0]), (ba.centerline_m[-1], ba.widths_m[-1])):
            for pb, wb in ((bb.centerline_m[0], bb.widths_m[0]),
                           (bb.centerline_m[-1], bb.widths_m[-1])):
                if np.hypot(*(pa - pb)) <= 0.25 * min(wa, wb) + 1e-6:   # a shared junction
                    # near it, or close to the other only around it: the junction's shape
                    reach = disc * 0.5 * max(wa, wb)
                    close &= ((np.hypot(*(pts - pa).T) > reach)
                              & (np.hypot(*(nearest - pa).T) > 2.0 * reach))
        if not close.any():
            continue
        limit = NARROW_GAP * d * w / (w + widest[b])
        new = np.where(close, np.maximum(np.minimum(w, limit), MIN_WIDTH_M * 0.5), w)
        if (new < w - 1e-9).any():
            before = changed.get(a, (float(w.max()), set(), math.inf))
            changed[a] = (before[0], before[1] | {bb.name}, min(before[2], float(d[close].min())))
            ba.widths_m = new
    for a, (w0, others, gap) in changed.items():
        b = branches[a]
        seg = np.hypot(*np.diff(b.centerline_m, axis=0).T)
        narrow = b.widths_m < w0 - 1e-9
        stretch = float(seg[narrow[:-1] | narrow[1:]].sum())
        report.repair(b.name, fids.get(b.name), report.attributes.get(b.name, {}),
                      f"runs closer to {', '.join(sorted(others))} than their widths allow "
                      f"({gap:.1f} m between centre lines at the closest): narrowed from "
                      f"{w0:.1f} m to {float(b.widths_m.min()):.1f} m over {stretch:.0f} m")
    return bool(changed)


def _geoms(lines) -> np.ndarray:
    """LineStrings (an object array) of polylines of any lengths."""
    out = np.empty(len(lines), dtype=object)
    out[:] = [shapely.LineString(p) for p in lines]
    return out


def _densify(line: np.ndarray, widths: np.ndarray, step: float) -> tuple[np.ndarray, np.ndarray]:
    """A polyline with vertices at most ``step`` apart, widths interpolated along it."""
    s = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(line, axis=0).T))])
    if s[-1] <= 0 or np.diff(s).max() <= step:
        return line, widths
    extra = np.arange(step, s[-1], step)
    # (none within a hair of a vertex: a sample 1e-15 m from one made a segment of no length,
    # which the builder refuses as a branch degenerated by its junctions)
    at = np.clip(np.searchsorted(s, extra), 1, len(s) - 1)
    gap = np.minimum(extra - s[at - 1], s[at] - extra)
    t = np.sort(np.concatenate([s, extra[gap > 1e-6 * step]]))
    return (np.column_stack([np.interp(t, s, line[:, 0]), np.interp(t, s, line[:, 1])]),
            np.interp(t, s, widths))


# -- water levels --------------------------------------------------------------------------------


class ProfileLevels:
    """Water level [m] near the rivers from the links' bed elevations: the level of the
    nearest sample (every LEVEL_SPACING_M along each link; bed elevation interpolated along
    the link, plus the depth of its discharge). ``graph.water_levels`` of an import with
    ``elevation_m``."""

    def __init__(self, samples_m: np.ndarray, levels_m: np.ndarray) -> None:
        self.samples_m = samples_m
        self.levels_m = levels_m
        self._tree = cKDTree(samples_m)

    def __call__(self, xy: np.ndarray) -> np.ndarray:
        _, idx = self._tree.query(np.asarray(xy, np.float64).reshape(-1, 2), workers=1)
        return self.levels_m[idx]


def _water_levels(links: list[_Link], plan, geometry: HydraulicGeometry,
                  report: RiverImport) -> ProfileLevels | None:
    samples, levels, missing, uphill = [], [], [], []
    for lk, (_, _, q3, *_rest) in zip(links, plan):
        z0, z1 = lk.values["elevation_m"]
        if not (math.isfinite(z0) and math.isfinite(z1)):
            missing.append(lk.name)
            continue
        if z1 > z0:
            uphill.append(f"{lk.name} ({z0:g} m → {z1:g} m)")
        p = lk.points
        s = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(p, axis=0).T))])
        t = np.linspace(0.0, s[-1], max(2, math.ceil(s[-1] / LEVEL_SPACING_M) + 1))
        samples.append(np.column_stack([np.interp(t, s, p[:, 0]), np.interp(t, s, p[:, 1])]))
        levels.append(z0 + (z1 - z0) * t / s[-1] + geometry.depth(q3))
    if missing:
        report.notes.append(f"no bed elevation for {len(missing)} links (their water follows "
                            f"the nearest link that has one): {missing[:5]}")
    if uphill:
        report.notes.append(f"{len(uphill)} links rise downstream by their elevations (the "
                            "water surface is made monotone downhill): " + ", ".join(uphill))
    if not samples:
        return None
    report.derived["water_levels"] = "bed elevation + depth (hydraulic geometry), per link"
    return ProfileLevels(np.vstack(samples), np.concatenate(levels))


# -- small helpers -------------------------------------------------------------------------------


def _plain(value):
    if isinstance(value, np.generic):
        return value.item()
    return value


def _truthy(value) -> bool:
    if isinstance(value, str):
        return value.strip().lower() in ("1", "true", "yes", "y", "t", "reversed", "reverse")
    try:
        return bool(value) and not (isinstance(value, float) and math.isnan(value))
    except (TypeError, ValueError):
        return False


def _attrs_text(attrs: dict[str, Any], limit: int = 8) -> str:
    items = list(attrs.items())
    text = ", ".join(f"{k}={_fmt(v)}" for k, v in items[:limit])
    return text + (", …" if len(items) > limit else "") if items else "no attributes"


def _fmt(v) -> str:
    if isinstance(v, float):
        return f"{v:.6g}"
    return repr(v)


def is_gis_path(path: str | Path | Sequence) -> bool:
    """True for a path :func:`read_rivers` reads (by its suffix)."""
    return isinstance(path, (str, Path)) and Path(path).suffix.lower() in SUFFIXES
