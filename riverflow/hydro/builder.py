"""RiverNetworkBuilder: hydro graphs from centre lines, widths and discharges.

Authors describe a river network as *branches* (a centre line drawn downstream, a width per
point, optionally a discharge) and *islands* (free obstacle polygons); the builder makes the
whole Proland hydro graph (reference §1.2): axes, banks, closing segments, areas, island loops
and every bank's stream-function value ψ, so that nobody ever types a potential::

    b = RiverNetworkBuilder(tolerance_m=0.25)
    b.add_branch(main_xy, widths_m=[60, 80, 90], discharge_m2s=60.0, name="main")
    b.add_branch(trib_xy, 40.0, discharge_m2s=30.0, name="tributary")  # ends where "lower" starts
    b.add_branch(lower_xy, 100.0, name="lower")                         # gets 90 m²/s
    graph = b.build()

Branches join where their end points coincide (within a quarter of the narrower width): a
confluence (several branches end where one starts) or a bifurcation (one ends where several
start). Discharge [m²/s, per unit depth] must be given for source branches; it is summed at
confluences and, at a bifurcation, taken from the outgoing branches that give one, the rest
being split in proportion to their widths. A bifurcation that re-joins encloses an island.
With ``lateral_inflow=True`` a branch that is the only one leaving its junction may be given a
discharge larger than the inflow (real rivers gain water along their course from hillslopes,
springs and streams too small to be mapped): the surplus enters through a short closing
segment (an *inlet*) cut into each bank across from the junction, half on each side, so ψ
stays constant along every bank curve and the discharge grows downstream.

Geometry: each branch is a strip (centre line ± width/2), the water is the union of the strips
minus the islands (shapely), oriented so that water lies on the left of every ring. The rings
are cut at the flat ends of free river ends (closing segments); each remaining boundary piece
gets one ψ from the discharges (facing downstream, right bank ψ − left bank ψ = discharge).

Junction corners are rounded: where the banks of two branches meet, the union of the strips
has a sharp point of land (and notches where a narrower strip meets the junction disc). Near
each junction the outline is replaced by its morphological closing: every corner of land
sharper than an arc of radius ``fillet_fraction`` × the narrowest width there (default half of
it) becomes that arc, tangent to both banks; the rest of the outline is untouched. The rounded
outline is an ordinary stretch of its piece: it carries the piece's ψ like the rest of the
bank, so the flow follows the arc (``tests/hydro/test_fillets.py``).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import shapely
import shapely.geometry
import shapely.ops
from scipy.spatial import cKDTree

from riverflow._validate import as_floats
from riverflow.hydro import _lakes, _strips
from riverflow.hydro._checks import graph_problems
from riverflow.hydro._network import BranchGeometry, LakeParts, assemble_graph
from riverflow.hydro.bezier import flatten_curve
from riverflow.hydro.falls import (FALL_KINDS, FALL_MIN_DROP_M, RAPIDS_MIN_SLOPE, Fall, Rapid,
                                   channel_depth_m, find_falls, find_rapids)
from riverflow.hydro.flow_network import MAX_PSI, MAX_WIDTH_M
from riverflow.hydro.graph import GraphError, HydroGraph
from riverflow.hydro.nearest import PolylineIndex

MIN_WIDTH_M = 1e-3
"""Narrowest branch width [m] the builder takes (a millimetre: narrower is a unit mistake)."""
MAX_TURN_DEG = 135.0
"""Sharpest turn of a centre line at one point; sharper ones fold the strip onto itself."""
JOIN_FRACTION = 0.25
"""End points closer than this fraction of the narrower width are one junction."""
FILLET_FRACTION = 0.5
"""Default radius of the arcs that round the points of land at a junction, as a fraction of
the narrowest width there (``RiverNetworkBuilder(fillet_fraction=...)``; 0: sharp corners)."""
FILLET_EXTENT = 1.5
"""What a fillet cuts off a point of land fits in a circle of this many radii; slimmer points
get smaller arcs (:func:`_round_junctions`)."""
FILLET_SCALES = (1.0, 0.5, 0.25)
"""The fillet arcs' radii tried in turn (× the full radius), each smaller one only where the
larger one refused a corner."""
FILLET_REACH_WIDTHS = 5.0
"""Corners are rounded within this many of the widest branch's widths from a junction."""
LEE_ROUNDS = 3
"""A graph from given water whose banks face away from their axes is built again with the
pockets behind them as basins (``RiverNetworkBuilder.lees``) at most this many times."""


@dataclass
class _BranchInput:
    name: str
    centerline_m: np.ndarray  # (K, 2) flattened polyline
    widths_m: np.ndarray  # (K,)
    discharge_m2s: float | None


@dataclass
class _FallInput:
    at: float | np.ndarray        # station [m] along the branch, or a point (2,) [m]
    drop_m: float
    branch: int | None
    lip_m: float | None
    kind: str


@dataclass
class _Island:
    outline: shapely.Polygon
    potential: float | None


class RiverNetworkBuilder:
    """Collects branches and islands; :meth:`build` makes the :class:`HydroGraph`.

    ``tolerance_m`` is the Bézier flattening tolerance and the geometric epsilon [m].
    ``lateral_inflow``: a branch leaving a junction alone may carry more than its inflow (the
    module docstring). ``fillet_fraction``: the corners where banks meet at a junction are
    rounded with arcs of this fraction of the narrowest width there (module docstring; 0
    leaves them sharp). After :meth:`build`, ``discharges_m2s`` holds the resolved discharge of
    every branch (in the order they were added), ``inlets_m2s`` the lateral inflow [m²/s] at
    each junction point that has one, and ``water_polygon`` the water (shapely, islands are
    holes). ``crs`` (WKT or ``EPSG:n``, None when unknown) is copied onto the built graph;
    ``water_levels`` likewise (see :attr:`HydroGraph.water_levels`); where they are given,
    :meth:`build` also finds the falls in them: drops of more than ``fall_min_drop_m`` [m]
    over less than their own height along a branch (:func:`riverflow.hydro.falls.find_falls`;
    None: none are looked for; :meth:`use_config` takes it and ``rapids_min_slope`` from a
    ``RiverConfig``), and the rapids: reaches steeper than ``rapids_min_slope``
    (2 %; :func:`~riverflow.hydro.falls.find_rapids`). Falls placed with :meth:`add_fall`
    and those found are the built graph's ``falls``; rapids (:meth:`add_rapids` and found)
    its ``rapids``.
    """

    short_reaches_join = False
    """Whether two branch ends nearer than half their widths together that one of the
    branches joins itself (a reach shorter than the junction at its other end is wide) are
    no miss (:func:`~riverflow.gis.read_water`'s builder: an axis from a junction to where
    the data's edge cuts the water); else they "do not meet"."""
    short_reach_joined = False
    """Set by :meth:`build` when such a short reach joined its ends."""
    one_stream = True
    """Whether branches may run in one stream where they leave or join a junction at a small
    angle (the graph checks then read across both: :func:`~riverflow.hydro._checks.
    graph_problems`); :func:`~riverflow.gis.read_water`'s builder: no (its skeleton's axes
    never do; where they seem to, their directions are wrong and the build retries)."""

    def __init__(self, tolerance_m: float = 0.25, *, lateral_inflow: bool = False,
                 fillet_fraction: float = FILLET_FRACTION,
                 fall_min_drop_m: float | None = FALL_MIN_DROP_M,
                 rapids_min_slope: float | None = RAPIDS_MIN_SLOPE) -> None:
        if not (np.isfinite(tolerance_m) and tolerance_m > 0):
            raise GraphError(f"tolerance_m must be a positive number, got {tolerance_m!r}")
        if not (np.isfinite(fillet_fraction) and 0.0 <= fillet_fraction <= 1.0):
            raise GraphError(f"fillet_fraction must lie in [0, 1], got {fillet_fraction!r}")
        self.tolerance_m = float(tolerance_m)
        self.lateral_inflow = bool(lateral_inflow)
        self.fillet_fraction = float(fillet_fraction)
        self._set_thresholds(fall_min_drop_m, rapids_min_slope)
        self._falls: list[_FallInput] = []
        self._rapids: list[tuple[int, float, float, float]] = []
        self._branches: list[_BranchInput] = []
        self._islands: list[_Island] = []
        self.discharges_m2s: list[float] = []
        self.inlets_m2s: list[tuple[tuple[float, float], float]] = []
        self.water_polygon: shapely.Geometry | None = None
        self.crs: str | None = None
        self.water_levels = None
        self._water_area: shapely.Geometry | None = None
        self.end_cuts_m2: list[float] = []
        self.islands_cut: list[int] = []
        self._lakes: list[_lakes.Lake] = []
        self.terminal_lakes: list[int] = []
        """After build(): the lakes with inflow and no outlet (still water, their inlets ending
        on free ends at the shore)."""
        self.source_lakes: list[int] = []
        """After build(): the lakes with outflow and no inflow (still water, their outlets
        starting on free ends at the shore)."""
        self.basins: list = []
        """After build(): the basins found in the given water (harbours, docks, side basins:
        :class:`riverflow.hydro._basins.Basin`), made still lakes joined to the river."""
        self.basin_axes: list = []
        """Axes ``(centre line (K, 2), widths (K,))`` [m] of the given water's dead ends that
        are basins, not channels (:func:`riverflow.hydro._basins.find_basins`' ``dead``)."""
        self.lees: list = []
        """Bank segments of the given water that a graph built from it found facing away from
        their axis, ``(middle (2,), axis (K, 2))`` [m]: the pockets behind them are basins
        (:func:`riverflow.hydro._basins.find_basins`' ``lees``); kept for the builds after."""
        self._lee_rounds = 0

    # -- input --------------------------------------------------------------------------


    def use_config(self, config) -> RiverNetworkBuilder:
        """Find falls and rapids in the water levels with the thresholds of ``config`` (a
        :class:`~riverflow.engine.config.RiverConfig`: its ``fall_min_drop_m`` and
        ``rapids_min_slope``) when :meth:`build` runs; returns the builder. The builder's own
        defaults are the same constants (:mod:`riverflow.hydro.falls`)."""
        self._set_thresholds(config.fall_min_drop_m, config.rapids_min_slope)
        return self

    def _set_thresholds(self, fall_min_drop_m, rapids_min_slope) -> None:
        if fall_min_drop_m is not None and not (np.isfinite(fall_min_drop_m)
                                                and fall_min_drop_m > 0):
            raise GraphError(f"fall_min_drop_m must be a positive number of metres or None, "
                             f"got {fall_min_drop_m!r}")
        if rapids_min_slope is not None and not (np.isfinite(rapids_min_slope)
                                                 and 0 < rapids_min_slope < 0.5):
            raise GraphError(f"rapids_min_slope must lie in (0, 0.5) [m/m] or be None, got "
                             f"{rapids_min_slope!r}")
        self.fall_min_drop_m = None if fall_min_drop_m is None else float(fall_min_drop_m)
        self.rapids_min_slope = None if rapids_min_slope is None else float(rapids_min_slope)
    def add_branch(self, centerline, widths_m, discharge_m2s: float | None = None, *,
                   bezier: bool = False, name: str | None = None) -> int:
        """Add a branch drawn from upstream to downstream; returns its index.

        Args:
            centerline: (K, 2) [m] polyline, or with ``bezier=True`` a cubic Bézier chain
                ``P0, C, C, P1, C, C, P2, …`` (K = 3·n + 1).
            widths_m: scalar, or one width [m] per point (polyline) / per regular point P_i
                (Bézier), interpolated along the arc length.
            discharge_m2s: ψ difference between the banks [m²/s]; required for sources,
                derived from the junction otherwise.
            name: for error messages (default ``branch<i>``).

        Raises:
            GraphError: NaN or infinite values, fewer than two distinct points, widths ≤ 0,
                a non-positive discharge, a malformed Bézier chain.
        """
        index = len(self._branches)
        name = f"branch{index}" if name is None else str(name)
        pts = as_floats(centerline, f"branch {name!r}: centerline", GraphError)
        if pts.ndim != 2 or pts.shape[1] != 2:
            raise GraphError(f"branch {name!r}: centerline must have shape (K, 2), got {pts.shape}")
        if not np.isfinite(pts).all():
            bad = int(np.flatnonzero(~np.isfinite(pts).all(axis=1))[0])
            raise GraphError(f"branch {name!r}: centerline point {bad} is not finite: {pts[bad]}")
        if bezier:
            if len(pts) < 4 or (len(pts) - 1) % 3:
                raise GraphError(f"branch {name!r}: a cubic Bézier chain needs 3·n + 1 points "
                                 f"(P0, C, C, P1, …), got {len(pts)}")
            regular = pts[::3]
        else:
            regular = pts
        if len(regular) < 2:
            raise GraphError(f"branch {name!r}: needs at least 2 points, got {len(regular)}")
        w = as_floats(widths_m, f"branch {name!r}: widths_m", GraphError)
        if w.ndim == 0:
            w = np.full(len(regular), float(w))
        if w.shape != (len(regular),):
            raise GraphError(f"branch {name!r}: widths_m must be a scalar or have one value per "
                             f"{'regular ' if bezier else ''}point ({len(regular)}), got {w.shape}")
        if not (np.isfinite(w).all() and (w > 0).all()):
            bad = int(np.flatnonzero(~(np.isfinite(w) & (w > 0)))[0])
            raise GraphError(f"branch {name!r}: width at point {bad} must be a positive number, got {w[bad]}")
        if not ((w >= MIN_WIDTH_M) & (w <= MAX_WIDTH_M)).all():
            bad = int(np.flatnonzero((w < MIN_WIDTH_M) | (w > MAX_WIDTH_M))[0])
            raise GraphError(f"branch {name!r}: width at point {bad} is {w[bad]:g} m, outside "
                             f"{MIN_WIDTH_M:g} … {MAX_WIDTH_M:g} m (no river's width)")
        if discharge_m2s is not None:
            q = as_floats(discharge_m2s, f"branch {name!r}: discharge", GraphError)
            if q.ndim != 0:
                raise GraphError(f"branch {name!r}: discharge must be one number [m²/s], got "
                                 f"shape {q.shape}")
            q = float(q)
            if not (np.isfinite(q) and 0 < q <= MAX_PSI):
                raise GraphError(f"branch {name!r}: discharge must be a positive number "
                                 f"(discharge_m2s, up to {MAX_PSI:g} m²/s), got {discharge_m2s!r}")
            discharge_m2s = q
        line, widths = self._flatten(pts, w, bezier)
        keep = np.concatenate([[True], np.hypot(*np.diff(line, axis=0).T) > 1e-9])
        line, widths = line[keep], widths[keep]
        if len(line) < 2:
            raise GraphError(f"branch {name!r}: needs at least 2 distinct points")
        d = np.diff(line, axis=0)
        turn = np.degrees(np.abs(np.arctan2(d[:-1, 0] * d[1:, 1] - d[:-1, 1] * d[1:, 0],
                                            np.einsum("ij,ij->i", d[:-1], d[1:]))))
        if len(turn) and turn.max() > MAX_TURN_DEG:
            k = int(np.argmax(turn)) + 1
            raise GraphError(f"branch {name!r} turns back on itself at ({line[k, 0]:.1f}, "
                             f"{line[k, 1]:.1f}): a turn of {turn.max():.0f}° (at most "
                             f"{MAX_TURN_DEG:.0f}° at one point; round the bend with more points)")
        self._branches.append(_BranchInput(name, line, widths, discharge_m2s))
        return index

    def add_fall(self, at_m, drop_m: float, *, branch: int | str | None = None,
                 lip_m: float | None = None, kind: str = "fall") -> int:
        """Add a fall (a weir, a dam) where the water drops by ``drop_m`` [m]; returns its
        index (:mod:`riverflow.hydro.falls`).

        Args:
            at_m: where its lip is: a distance [m] along ``branch``'s centre line from its
                start, or a point (x, y) [m] in the river (on the branch whose centre line
                is nearest it).
            drop_m: the height of the drop [m], > 0.
            branch: the branch (index or name) ``at_m`` is measured along; may be left out
                when there is one branch, or when ``at_m`` is a point.
            lip_m: the length of the lip across the river [m] (centred on the centre line,
                perpendicular to it); default: the river's width there. A weir's or dam's lip
                runs across the whole river.
            kind: "fall", "weir" or "dam".

        Raises:
            GraphError (a ValueError): a drop that is not a positive number, an unknown
                branch or kind, a point off the river or a distance beyond the branch's
                ends, a lip not positive or longer than the river is wide there.
        """
        index = len(self._falls)
        where = f"fall {index}"
        try:
            drop = float(drop_m)
        except (TypeError, ValueError):
            raise GraphError(f"{where}: drop_m must be a number of metres, got {drop_m!r}") from None
        if not (np.isfinite(drop) and drop > 0.0):
            raise GraphError(f"{where}: drop_m must be a positive number of metres (the water "
                             f"falls by it), got {drop_m!r}")
        if kind not in FALL_KINDS:
            raise GraphError(f"{where}: kind must be one of {', '.join(FALL_KINDS)}, got {kind!r}")
        if not self._branches:
            raise GraphError(f"{where}: add the branch it lies on first (add_branch)")
        b = self._branch_index(branch, where) if branch is not None else None
        at = np.asarray(at_m, dtype=np.float64)
        if at.shape == (2,):
            if not np.isfinite(at).all():
                raise GraphError(f"{where}: its point must be finite, got {at.tolist()}")
            b, station, dist, width = self._project(at, b)
            if dist > 0.5 * width:
                raise GraphError(f"{where} at ({at[0]:.1f}, {at[1]:.1f}) is off the river: "
                                 f"{dist:.1f} m from the centre line of branch "
                                 f"{self._branches[b].name!r}, which is {width:.1f} m wide there")
        elif at.shape == ():
            if b is None:
                if len(self._branches) > 1:
                    raise GraphError(f"{where}: at_m is a distance along a branch: say which "
                                     f"(branch=index or name; there are {len(self._branches)})")
                b = 0
            station = float(at)
            length = float(_arc(self._branches[b].centerline_m)[-1])
            if not (np.isfinite(station) and 0.0 <= station <= length):
                raise GraphError(f"{where}: at_m = {at_m!r} is off the river: branch "
                                 f"{self._branches[b].name!r} runs from 0 to {length:.1f} m")
            width = self._width_at(b, station)
        else:
            raise GraphError(f"{where}: at_m must be a distance [m] or a point (x, y), got "
                             f"shape {at.shape}")
        if lip_m is not None:
            lip = float(lip_m)
            if not (np.isfinite(lip) and lip > 0.0):
                raise GraphError(f"{where}: lip_m must be a positive number of metres, got "
                                 f"{lip_m!r}")
            if lip > width * (1.0 + 1e-9) + 1e-9:
                raise GraphError(f"{where}: its lip ({lip:g} m) is longer than the river is "
                                 f"wide there ({width:.2f} m, branch "
                                 f"{self._branches[b].name!r} at {station:.1f} m)")
        self._falls.append(_FallInput(station, drop, b, None if lip_m is None else float(lip_m),
                                      str(kind)))
        return index

    def add_rapids(self, from_m: float, to_m: float, drop_m: float, *,
                   branch: int | str | None = None) -> int:
        """A rapid: from ``from_m`` to ``to_m`` [m] along ``branch``'s centre line the water
        drops by ``drop_m`` [m] (slope = drop / length, under 1 : 2: steeper is a fall);
        returns its index. ``branch`` may be left out when there is one.

        Raises:
            GraphError: a drop that is not a positive number, a reach off the branch or of
                no length, a slope of a fall, an unknown branch.
        """
        index = len(self._rapids)
        where = f"rapids {index}"
        if not self._branches:
            raise GraphError(f"{where}: add the branch it lies on first (add_branch)")
        if branch is None:
            if len(self._branches) > 1:
                raise GraphError(f"{where}: say which branch (branch=index or name; there "
                                 f"are {len(self._branches)})")
            b = 0
        else:
            b = self._branch_index(branch, where)
        try:
            a, e, drop = float(from_m), float(to_m), float(drop_m)
        except (TypeError, ValueError):
            raise GraphError(f"{where}: from_m, to_m and drop_m must be numbers, got "
                             f"{from_m!r}, {to_m!r}, {drop_m!r}") from None
        if not (np.isfinite(drop) and drop > 0.0):
            raise GraphError(f"{where}: drop_m must be a positive number of metres, got "
                             f"{drop_m!r}")
        length = float(_arc(self._branches[b].centerline_m)[-1])
        if not (np.isfinite(a) and np.isfinite(e) and 0.0 <= a < e <= length):
            raise GraphError(f"{where}: {from_m!r} … {to_m!r} m is off the river or of no "
                             f"length: branch {self._branches[b].name!r} runs from 0 to "
                             f"{length:.1f} m")
        if drop / (e - a) > 0.5:
            raise GraphError(f"{where}: a drop of {drop:g} m over {e - a:g} m is a fall, not "
                             f"a rapid (add_fall)")
        self._rapids.append((b, a, e, drop))
        return index

    def _branch_index(self, branch, where: str) -> int:
        if isinstance(branch, str):
            for i, bi in enumerate(self._branches):
                if bi.name == branch:
                    return i
            raise GraphError(f"{where}: no branch named {branch!r}")
        if isinstance(branch, (int, np.integer)) and not isinstance(branch, bool) \
                and 0 <= int(branch) < len(self._branches):
            return int(branch)
        raise GraphError(f"{where}: branch must be the index or name of a branch added "
                         f"before, got {branch!r}")

    def _project(self, p: np.ndarray, only: int | None):
        """(branch, station [m], distance [m], width [m]) of the nearest centre-line point."""
        best = None
        for i, bi in enumerate(self._branches):
            if only is not None and i != only:
                continue
            dist, _, arc = PolylineIndex(bi.centerline_m).nearest(p[None])
            if best is None or dist[0] < best[2]:
                best = (i, float(arc[0]), float(dist[0]), self._width_at(i, float(arc[0])))
        return best

    def _width_at(self, b: int, station: float) -> float:
        bi = self._branches[b]
        return float(np.interp(station, _arc(bi.centerline_m), bi.widths_m))

    def add_island(self, outline, *, potential: float | None = None) -> int:
        """Add a free island (obstacle) polygon (M, 2) [m] lying inside one branch.

        ``potential`` None: the ψ the flow would have at the island's centroid without it,
        ψ_left + Q·d_left/(d_left + d_right) (plug flow across the branch). A given value must
        lie strictly between the ψ of that branch's banks (after the builder's shift that
        makes the smallest bank ψ 0). Returns the island's index.
        """
        pts = np.asarray(outline, dtype=np.float64)
        index = len(self._islands)
        if pts.ndim != 2 or pts.shape[1] != 2 or len(pts) < 3:
            raise GraphError(f"island {index}: outline must have shape (M >= 3, 2), got {pts.shape}")
        if not np.isfinite(pts).all():
            raise GraphError(f"island {index}: outline has non-finite coordinates")
        poly = shapely.Polygon(pts)
        if not poly.is_valid or poly.area <= 0:
            raise GraphError(f"island {index}: outline is not a simple polygon with an area "
                             f"({shapely.is_valid_reason(poly)})")
        if potential is not None and not np.isfinite(potential):
            raise GraphError(f"island {index}: potential must be finite, got {potential}")
        self._islands.append(_Island(poly, None if potential is None else float(potential)))
        return index

    def add_lake(self, polygon, level_m: float | None = None) -> int:
        """Add a lake: a water body with a flat surface (``polygon``: a shapely Polygon or an
        (M, 2) outline [m], any simple polygon: bays, arms and islands anywhere); returns its
        index.

        Branches that reach its shore run into it (an end inside the lake or within 0.75
        of the river's width of its shore is cut or drawn to the shore; a branch that runs
        through it becomes an inlet and an outlet). The lake is a junction of its inlets and
        outlets for the discharges; its shore carries one ψ between two mouths, and the flow in
        it is the potential flow from its inlets to its outlets, tangent to the shore
        (:mod:`riverflow.hydro._lakes`, :mod:`riverflow.hydro.lake_flow`). Holes in the polygon
        are islands: their shore gets the ψ of zero circulation round them. A lake that no
        river touches is still water, and so is one with inflow but no outlet (its inlets end
        on free ends at its shore: :attr:`terminal_lakes`) or outflow but no inflow (a source
        lake: its outlets start on free ends at its shore, with their own discharges,
        :attr:`source_lakes`). ``level_m``: its water level [m] (None: from the terrain,
        :func:`riverflow.landscape`).

        Raises:
            GraphError: not a simple polygon with an area, or a non-finite level.
        """
        lake = _lakes.check_lake(polygon, level_m, len(self._lakes))
        for other in self._lakes:
            if other.polygon.intersects(lake.polygon):
                raise GraphError(f"{lake.name} touches or overlaps {other.name}")
        self._lakes.append(lake)
        return len(self._lakes) - 1

    def set_water_area(self, water) -> None:
        """Give the water itself instead of making it from the branches' strips.

        ``water`` (a shapely Polygon or MultiPolygon [m]) is the water as a map draws it:
        its rings are the banks, its holes the land between channels (each hole must have a
        branch along each side). The branches are then its channels' axes (centre lines drawn
        downstream, widths about the channel's width), joined at junctions as usual; islands
        added with :meth:`add_island` are taken out of it like holes whose ψ is the plug-flow
        estimate. At every free end of a branch the water is cut across the channel by a
        straight closing segment (:func:`_end_chord`): the straight edge of the outline the
        branch runs into, if it spans the channel (the data's edge), else a line
        perpendicular to the branch's last segment, within END_CHORD_REACH widths of its
        end, as near it as gives a chord of at least END_CHORD_FRACTION of the branch's
        median width (and at most END_CHORD_LONGEST widths); the water beyond (the rounded
        or slanted tip of a mapped channel) is left out, its area in ``end_cuts_m2`` after
        :meth:`build`; islands there are left out too (their indices in ``islands_cut``).
        Water off the channels (a harbour basin, a dock, a marina: a pocket of the outline
        beyond a channel's bank) is made still water joined to the river at its mouth
        (:mod:`riverflow.hydro._basins`; :attr:`basins` after :meth:`build`).

        Raises:
            GraphError: not a polygon, empty, invalid, or without area.
        """
        if not isinstance(water, (shapely.Polygon, shapely.MultiPolygon)):
            raise GraphError(f"set_water_area needs a shapely Polygon or MultiPolygon, got "
                             f"{type(water).__name__}")
        if water.is_empty or not water.area > 0:
            raise GraphError("set_water_area: the water has no area")
        if not water.is_valid:
            raise GraphError(f"set_water_area: the water is not a valid polygon "
                             f"({shapely.is_valid_reason(water)}); repair it first "
                             f"(shapely.make_valid)")
        self._water_area = water

    def _flatten(self, pts: np.ndarray, w: np.ndarray, bezier: bool) -> tuple[np.ndarray, np.ndarray]:
        """Polyline (M, 2) and per-point widths (M,) of a branch's centre line."""
        if not bezier:
            return pts.copy(), w.copy()
        parts, s_regular = [pts[:1]], [0.0]
        s_total = 0.0
        for k in range(0, len(pts) - 1, 3):
            patch = flatten_curve(pts[k:k + 4], np.array([False, True, True, False]), self.tolerance_m)
            parts.append(patch[1:])
            s_total += float(np.hypot(*np.diff(patch, axis=0).T).sum())
            s_regular.append(s_total)
        line = np.vstack(parts)
        s = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(line, axis=0).T))])
        return line, np.interp(s, np.asarray(s_regular), w)

    # -- build --------------------------------------------------------------------------

    def build(self) -> HydroGraph:
        """Make the hydro graph. Raises :class:`GraphError` naming the branch or junction."""
        import shapely.errors

        from riverflow._memory import collector_paused

        try:
            with collector_paused():     # millions of containers: no full passes over them
                return self._build()
        except shapely.errors.GEOSException as exc:   # degenerate geometry: no GEOS traceback
            raise GraphError(f"the network's banks could not be made ({exc}): a width far "
                             f"below tolerance_m = {self.tolerance_m:g} m, or strips that "
                             "nearly touch?") from None

    def _build(self) -> HydroGraph:
        if not self._branches and not self._lakes:
            raise GraphError("no branches: add at least one with add_branch()")
        branches = [_BranchInput(b.name, b.centerline_m.copy(), b.widths_m.copy(), b.discharge_m2s)
                    for b in self._branches]
        lakes = self._lakes + self._basin_lakes(branches)
        rivers = self._water_area if lakes else None    # (less the free islands' land)
        if rivers is not None and self._islands:
            rivers = shapely.difference(rivers, shapely.union_all(
                [isl.outline for isl in self._islands]))
        branches, lake_ends, origin = _lakes.cut_branches(branches, lakes, self.tolerance_m,
                                                          rivers)
        shores = list(lake_ends)        # (the lakes the ends lie on, before the caps)
        branches, lake_ends, self.terminal_lakes, self.source_lakes = \
            _lakes.end_at_terminal_lakes(branches, lakes, lake_ends)
        if self.terminal_lakes and getattr(self, "report", None) is not None:
            self.report.derived["terminal lakes"] = (
                f"{len(self.terminal_lakes)} lake(s) with inflow and no outlet "
                f"({', '.join(lakes[k].name for k in self.terminal_lakes)}): still water, "
                f"their inlets end on free ends at the shore")
        if self.source_lakes and getattr(self, "report", None) is not None:
            self.report.derived["source lakes"] = (
                f"{len(self.source_lakes)} lake(s) with outflow and no inflow "
                f"({', '.join(lakes[k].name for k in self.source_lakes)}): still water, "
                f"their outlets start on free ends at the shore")
        if branches:
            start_j, end_j, junctions = _find_junctions(branches, self, shores,
                                                        self._water_area)
        else:
            start_j, end_j, junctions = [], [], np.zeros((0, 2))
        n_junctions = len(junctions)
        start_j, end_j, all_junctions = _lakes.lake_junctions(branches, lakes, lake_ends,
                                                              start_j, end_j, junctions)
        order = _topological_order(branches, start_j, end_j, all_junctions)
        discharges, inlets = _resolve_discharges(branches, order, start_j, end_j, all_junctions,
                                                 self.lateral_inflow, n_junctions)
        geoms = [BranchGeometry(b.name, b.centerline_m, b.widths_m, q, sj, ej)
                 for b, q, sj, ej in zip(branches, discharges, start_j, end_j)]
        eps = max(1e-3, 1e-3 * self.tolerance_m)
        polygon_lake: list[int] = []
        if self._water_area is None:
            polygons, cuts, islands = _water(geoms, junctions, self._islands, self.tolerance_m,
                                             self.fillet_fraction, lakes, lake_ends)
            end_cuts: list[float] = []
        else:
            water = _lakes.cut_from_closed_lakes(self._water_area, lakes,
                                                 self.terminal_lakes + self.source_lakes,
                                                 self.tolerance_m)
            if lakes:   # the lakes are water too
                water = shapely.union_all([water] + [lk.polygon for lk in lakes])
            mouths = {(i, e == 0) for i, (was, now) in enumerate(zip(shores, lake_ends))
                      for e in (0, 1) if was[e] >= 0 and now[e] < 0}
            polygons, cuts, islands, (end_cuts, cut_islands) = _given_water(
                geoms, water, self._islands, self.tolerance_m, mouths)
            self.islands_cut = cut_islands
            if lakes:   # a pond on a free island: its water again (the island's land is cut)
                kept = shapely.union_all(polygons)
                polygons = list(polygons) + [
                    lk.polygon for lk in lakes
                    if shapely.difference(lk.polygon, kept).area > 1e-6 * lk.polygon.area]
        if lakes:   # river areas and lake areas, sharing the mouths
            min_area = (0.01 * min(float(g.widths_m.min()) for g in geoms) ** 2
                        if geoms else eps ** 2)
            polygons, polygon_lake, mouths = _lakes.split_water(polygons, lakes, eps, min_area)
            cuts = list(cuts) + mouths
        try:
            rings, pieces = _strips.split_rings(polygons, cuts, eps)
        except ValueError as exc:
            raise GraphError(f"cannot cut the water outline at the river ends: {exc}") from None
        lake_parts = None
        if lakes:
            lake_parts = _lakes_of_graph(geoms, lakes, lake_ends, polygon_lake, self.tolerance_m)
        axis_index: list = []
        free_banks: list = []
        graph = assemble_graph(geoms, rings, pieces, islands, all_junctions[:n_junctions],
                               inlets, lake_parts, axis_index, free_banks)
        if lakes:   # islands in lakes: the ψ of zero circulation round them
            from riverflow.hydro.lake_flow import set_island_potentials
            set_island_potentials(graph, self.tolerance_m)
        away: list = []
        problems = graph_problems(graph, [(g.centerline_m, g.widths_m, g.discharge_m2s) for g in geoms],
                                  axes_cover_banks=True, axis_index=axis_index,
                                  one_stream=self.one_stream, free_banks=free_banks,
                                  away=away if self._water_area is not None else None)
        seen = {tuple(p) for p, _ in self.lees}
        away = [a for a in away if tuple(a[0]) not in seen]
        if problems and away and self._lee_rounds < LEE_ROUNDS:
            # the lees of the given water's points of land: basins, and built again
            self._lee_rounds += 1
            self.lees += away
            try:
                return self._build()
            finally:
                self._lee_rounds -= 1
        if problems:
            raise GraphError("the network gives an invalid hydro graph: " + "; ".join(problems[:5]))
        first = {}
        for k, i in enumerate(origin):
            first.setdefault(i, k)
        self.discharges_m2s = [float(discharges[first[i]]) for i in range(len(self._branches))]
        self.inlets_m2s = [((float(all_junctions[j][0]), float(all_junctions[j][1])), s)
                           for j, s in sorted(inlets.items())]
        self.water_polygon = (polygons[0] if len(polygons) == 1 else
                              shapely.union_all(polygons) if lakes else shapely.MultiPolygon(polygons))
        self.end_cuts_m2 = end_cuts
        graph.crs = self.crs
        graph.water_levels = self.water_levels
        graph.falls, graph.rapids = self._resolve_falls(geoms, self._pieces_of(geoms, origin))
        return graph

    def _basin_lakes(self, branches: list[_BranchInput]) -> list[_lakes.Lake]:
        """The basins of the given water (:mod:`riverflow.hydro._basins`) as still lakes,
        after the given lakes; each is reported (``report.derived["basins"]``)."""
        from riverflow.hydro._basins import find_basins

        self.basins = []
        if self._water_area is None or not branches:
            return []
        self.basins = find_basins(self._water_area,
                                  [(b.centerline_m, b.widths_m) for b in branches],
                                  [lk.polygon for lk in self._lakes], self.tolerance_m,
                                  self.basin_axes, self.lees)
        report = getattr(self, "report", None)
        if report is not None:
            report.derived.pop("basins", None)
            if self.basins:
                report.derived["basins"] = [f"basin {i}: {b.describe()}"
                                            for i, b in enumerate(self.basins)]
        return [_lakes.Lake(b.polygon, None, f"basin {i}", basin=True, mouth=b.mouth)
                for i, b in enumerate(self.basins)]

    def _pieces_of(self, geoms: list[BranchGeometry], origin: list[int]):
        """``(b, station [m]) -> (piece, station on it)``: where a distance along input branch
        ``b`` lies on the built branches (a lake cuts a branch into pieces, its part in the
        lake dropped; a piece's station 0 is where its start lies along the input branch).
        GraphError when the station is in the part a lake took."""
        spans: dict[int, list] = {}
        for k, (g, b) in enumerate(zip(geoms, origin)):
            given = PolylineIndex(self._branches[b].centerline_m)
            s0, s1 = (float(v) for v in given.nearest(g.centerline_m[[0, -1]])[2])
            spans.setdefault(b, []).append((s0, s1, k))

        def on(b: int, station: float, where: str) -> tuple[int, float]:
            pieces = sorted(spans.get(b, []))
            for i, (s0, s1, k) in enumerate(pieces):
                if s0 <= self.tolerance_m:           # (a start snapped to a junction)
                    s0 = 0.0
                # past the last piece's end (an end snapped back) the fall's own checks speak
                if s0 - 1e-6 <= station and (i == len(pieces) - 1
                                             or station <= s1 + self.tolerance_m):
                    return k, station - s0
            raise GraphError(f"{where}: {station:.1f} m along branch "
                             f"{self._branches[b].name!r} lies in a lake (the branch is cut "
                             f"at its shores)")
        return on

    def _resolve_falls(self, geoms: list[BranchGeometry], on) -> tuple[list[Fall], list[Rapid]]:
        """The falls and rapids given and those found in ``water_levels``, on the built
        (junction-snapped, lake-cut: ``on``, :meth:`_pieces_of`) centre lines, upstream first
        along each branch."""
        falls = []
        for k, f in enumerate(self._falls):
            piece, at = on(f.branch, f.at, f"fall {k}")
            fall = _fall_on(geoms[piece], at, f.drop_m, f.lip_m, f.kind, False)
            length = float(_arc(geoms[piece].centerline_m)[-1])
            if fall.at_m + fall.throw_m > length:
                raise GraphError(f"fall {k}: its nappe ({fall.throw_m:.1f} m long) runs past "
                                 f"the end of branch {fall.branch!r} ({length - fall.at_m:.1f} m "
                                 f"below the lip): place it higher up")
            for m, other in enumerate(falls):
                if other.branch == fall.branch and abs(other.at_m - fall.at_m) < max(
                        other.throw_m, fall.throw_m):
                    raise GraphError(f"falls {m} and {k} on branch {fall.branch!r} overlap: "
                                     f"{abs(other.at_m - fall.at_m):.1f} m apart, less than a "
                                     f"nappe's length; make them one fall")
            falls.append(fall)
        rapids = []
        for k, (b, a, e, drop) in enumerate(self._rapids):
            piece, a_on = on(b, a, f"rapids {k}")
            piece_e, e_on = on(b, e, f"rapids {k}")
            if piece_e != piece:
                raise GraphError(f"rapids {k}: from {a:.1f} to {e:.1f} m along branch "
                                 f"{self._branches[b].name!r} runs through a lake")
            rapids.append(_rapid_on(geoms[piece], a_on, e_on, drop, False))
        if self.water_levels is not None and (self.fall_min_drop_m is not None
                                              or self.rapids_min_slope is not None):
            for g in geoms:
                s = _arc(g.centerline_m)
                spacing = float(np.clip(self.fall_min_drop_m or 2.0, 0.25, 2.0))
                t = np.linspace(0.0, s[-1], max(2, int(np.ceil(s[-1] / spacing)) + 1))
                pts = np.stack([np.interp(t, s, g.centerline_m[:, 0]),
                                np.interp(t, s, g.centerline_m[:, 1])], axis=1)
                levels = np.asarray(self.water_levels(pts), np.float64).reshape(-1)
                if levels.shape != t.shape or not np.isfinite(levels).all():
                    continue            # no levels there: nothing to find
                for at, drop in (find_falls(t, levels, self.fall_min_drop_m)
                                 if self.fall_min_drop_m is not None else []):
                    found = _fall_on(g, at, drop, None, "fall", True)
                    if not any(o.branch == g.name and abs(o.at_m - at) <= o.throw_m + o.approach_m
                               for o in falls):
                        falls.append(found)
                for a, e, drop in (find_rapids(t, levels, self.rapids_min_slope)
                                   if self.rapids_min_slope is not None else []):
                    if not any(o.branch == g.name and o.from_m < e and a < o.to_m
                               for o in rapids):
                        rapids.append(_rapid_on(g, a, e, drop, True))
        order = {g.name: i for i, g in enumerate(geoms)}
        return (sorted(falls, key=lambda f: (order[f.branch], f.at_m)),
                sorted(rapids, key=lambda r: (order[r.branch], r.from_m)))


def _arc(line: np.ndarray) -> np.ndarray:
    return np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(line, axis=0).T))])


def _fall_on(g: BranchGeometry, at, drop_m: float, lip_m: float | None, kind: str,
             in_levels: bool) -> Fall:
    """A :class:`Fall` on branch ``g`` at station ``at`` [m] (or the point (2,) nearest)."""
    s = _arc(g.centerline_m)
    if np.ndim(at):
        at = float(PolylineIndex(g.centerline_m).nearest(np.asarray(at, np.float64)[None])[2][0])
    at = float(np.clip(at, 0.0, s[-1]))
    k = int(np.clip(np.searchsorted(s, at, side="right") - 1, 0, len(s) - 2))
    seg = g.centerline_m[k + 1] - g.centerline_m[k]
    u = (at - s[k]) / max(s[k + 1] - s[k], 1e-300)
    centre = g.centerline_m[k] + u * seg
    t = seg / np.hypot(*seg)
    width = float(np.interp(at, s, g.widths_m))
    depth = float(channel_depth_m(width))
    return Fall(g.name, at, float(drop_m), (float(centre[0]), float(centre[1])),
                (float(t[0]), float(t[1])), width, width if lip_m is None else min(lip_m, width),
                depth, float(g.discharge_m2s) / width, kind, in_levels)


def _rapid_on(g: BranchGeometry, a: float, e: float, drop_m: float, in_levels: bool) -> Rapid:
    s = _arc(g.centerline_m)
    a, e = float(np.clip(a, 0.0, s[-1])), float(np.clip(e, 0.0, s[-1]))

    def point(at):
        return (float(np.interp(at, s, g.centerline_m[:, 0])),
                float(np.interp(at, s, g.centerline_m[:, 1])))

    inside = (s >= a) & (s <= e)
    width = max(float(np.interp(a, s, g.widths_m)), float(np.interp(e, s, g.widths_m)),
                float(g.widths_m[inside].max()) if inside.any() else 0.0)
    return Rapid(g.name, a, e, float(drop_m), point(0.5 * (a + e)), point(a), point(e),
                 in_levels, width)


def _lakes_of_graph(geoms, lakes, lake_ends, polygon_lake, tolerance_m):
    """What :func:`assemble_graph` needs of the lakes: per lake its axes (from each mouth to
    its centre, :func:`_lakes.lake_axes`) with the width of the river there, and the lake of
    each water polygon."""
    axes = []
    for k, lake in enumerate(lakes):
        if lake.basin:      # its own axis, down its length (grown to cover its walls)
            line = _lakes.basin_axis(lake, tolerance_m)
            axes.append([(line, float(np.hypot(*(lake.mouth[1] - lake.mouth[0]))))])
            continue
        points, outlet, widths = [], [], []
        for g, (ls, le) in zip(geoms, lake_ends):
            if le == k:
                points.append(g.centerline_m[-1])
                outlet.append(False)
                widths.append(float(g.widths_m[-1]))
            if ls == k:
                points.append(g.centerline_m[0])
                outlet.append(True)
                widths.append(float(g.widths_m[0]))
        lines = _lakes.lake_axes(lake, points, outlet, tolerance_m)
        if not widths:
            widths = [2.0 * float(np.hypot(*(lines[0][1] - lines[0][0])))]
        axes.append(list(zip(lines, widths)))
    return LakeParts(lakes, axes, polygon_lake)


# -- topology -----------------------------------------------------------------------------


def _across_land(water, a: np.ndarray, b: np.ndarray, tol: float) -> bool:
    """Whether the segment from ``a`` to ``b`` leaves ``water`` (prepared) by more than
    ``tol`` twice [m] of its length."""
    seg = shapely.LineString([a, b])
    if water.covers(seg):
        return False
    return shapely.intersection(water, seg).length < seg.length - 2.0 * tol


def _find_junctions(branches: list[_BranchInput], builder=None, shores=None, water=None):
    """Cluster branch end points into junctions and snap them together. Two ends nearer
    than half their widths together that do not join are an error, unless one of their
    branches joins them itself (a reach shorter than its junction is wide) and ``builder``'s
    ``short_reaches_join`` is true (``builder.short_reach_joined`` says whether that
    happened). Two ends on one lake's shore (``shores``: per branch the lakes its start and
    end lie on, -1: none, as :func:`_lakes.cut_branches` finds them; a terminal lake's
    inlets capped off its shore too) are never joined nor apart: the lake joins them (mouths
    side by side, an island's tip between them or none). Nor are two ends with land
    between them (the line from one to the other leaves ``water``, the given water area:
    two water bodies, ends of channels either side of a spit).

    Returns (start junction per branch, end junction per branch, junction points (J, 2));
    -1 marks a free end.
    """
    ends = []  # (branch, is_end, point, width)
    for i, b in enumerate(branches):
        ends.append((i, False, b.centerline_m[0], b.widths_m[0]))
        ends.append((i, True, b.centerline_m[-1], b.widths_m[-1]))
    from scipy.cluster.hierarchy import DisjointSet

    joined = DisjointSet(range(len(ends)))
    points = np.array([e[2] for e in ends])
    reach = max(float(e[3]) for e in ends)       # no pair farther apart than this matters
    pairs = sorted(cKDTree(points).query_pairs(reach, output_type="set"))
    tol = getattr(builder, "tolerance_m", 0.0)
    if water is not None:
        shapely.prepare(water)
    apart = []
    for a, c in pairs:
        ia, ea, pa, wa = ends[a]
        ic, ec, pc, wc = ends[c]
        d = float(np.hypot(*(pa - pc)))
        if shores is not None and shores[ia][ea] == shores[ic][ec] >= 0:
            continue        # (both on one lake's shore: the lake joins them)
        if water is not None and d > 2.0 * tol and _across_land(water, pa, pc, tol):
            continue
        if d <= JOIN_FRACTION * min(wa, wc):
            if ia == ic:
                raise GraphError(f"branch {branches[ia].name!r} starts and ends at the same point")
            joined.merge(a, c)
        elif d < 0.5 * (wa + wc) and ia != ic:
            apart.append((a, c, d))
    short = getattr(builder, "short_reaches_join", False)
    for a, c, d in apart:
        # ends[a ^ 1] is the other end of a's branch: one of the two branches joins the two
        # points itself (it is shorter than the junction at its other end is wide, as an
        # axis from a junction to where the data's edge cuts the water can be)
        if short and (joined.connected(a ^ 1, c) or joined.connected(c ^ 1, a)):
            if builder is not None:
                builder.short_reach_joined = True
            continue
        ia, ea, pa, wa = ends[a]
        ic, ec, pc, wc = ends[c]
        which = ["start", "end"]
        raise GraphError(
            f"branches {branches[ia].name!r} and {branches[ic].name!r} do not meet: the "
            f"{which[ea]} of one is {d:.2f} m from the {which[ec]} of the other; end points "
            f"must coincide within {JOIN_FRACTION * min(wa, wc):.2f} m to join")
    start_j = [-1] * len(branches)
    end_j = [-1] * len(branches)
    points = []
    for members in sorted(sorted(group) for group in joined.subsets()):
        if len(members) < 2:
            continue
        j = len(points)
        p = np.mean([ends[a][2] for a in members], axis=0)
        points.append(p)
        for a in members:
            i, is_end, _, _ = ends[a]
            if is_end:
                end_j[i] = j
                branches[i].centerline_m[-1] = p
            else:
                start_j[i] = j
                branches[i].centerline_m[0] = p
    for b in branches:
        if len(b.centerline_m) < 2 or np.hypot(*np.diff(b.centerline_m, axis=0).T).min() <= 1e-9:
            raise GraphError(f"branch {b.name!r} degenerates when its ends are snapped to junctions")
    return start_j, end_j, np.asarray(points).reshape(-1, 2)


def by_junction(start_j, end_j) -> tuple[dict[int, list[int]], dict[int, list[int]]]:
    """Branches (or links) ending at / starting from each junction (in their order); −1: no
    junction."""
    ins: dict[int, list[int]] = {}
    outs: dict[int, list[int]] = {}
    for i, (s, e) in enumerate(zip(start_j, end_j)):
        if e >= 0:
            ins.setdefault(e, []).append(i)
        if s >= 0:
            outs.setdefault(s, []).append(i)
    return ins, outs


def upstream_first(start_j, end_j) -> tuple[list[int], list[int]]:
    """(order, loop): the branches (or links) upstream first, by Kahn's algorithm in O(n) (one
    is ready when all those ending at its start junction are done; ties in index order, as
    repeated passes would take them), and those left over, which flow round a loop."""
    ins_of, outs_of = by_junction(start_j, end_j)
    waiting = [len(ins_of.get(s, [])) if s >= 0 else 0 for s in start_j]
    ready = [i for i in range(len(waiting)) if waiting[i] == 0]
    order: list[int] = []
    while ready:
        nxt = []
        for i in ready:
            order.append(i)
            if end_j[i] >= 0:
                for k in outs_of.get(end_j[i], []):
                    waiting[k] -= 1
                    if waiting[k] == 0:
                        nxt.append(k)
        ready = sorted(nxt)
    done = set(order)
    return order, [i for i in range(len(waiting)) if i not in done]


def _topological_order(branches, start_j, end_j, junctions) -> list[int]:
    """Branches ordered upstream first; raises on junctions without in- or outflow or cycles."""
    ins_of, outs_of = by_junction(start_j, end_j)
    for j, p in enumerate(junctions):
        ins = ins_of.get(j, [])
        outs = outs_of.get(j, [])
        where = f"junction at ({p[0]:.1f}, {p[1]:.1f})"
        if not ins:
            raise GraphError(f"{where}: branches {[branches[i].name for i in outs]} all start there "
                             f"but none ends there (inflow 0 ≠ outflow)")
        if not outs:
            raise GraphError(f"{where}: branches {[branches[i].name for i in ins]} all end there but "
                             f"none starts there (inflow ≠ outflow 0)")
    order, loop = upstream_first(start_j, end_j)
    if loop:
        raise GraphError(f"branches {[branches[i].name for i in loop]} form a loop that flows "
                         "back into itself")
    return order


def _resolve_discharges(branches, order, start_j, end_j, junctions, lateral: bool = False,
                        n_lateral: int | None = None) -> tuple[list[float], dict[int, float]]:
    """Discharge of every branch [m²/s] (sources given, sums at confluences, splits) and the
    lateral inflow [m²/s] per junction that has one (only with ``lateral``, and only at the
    first ``n_lateral`` junctions: a lake's outflow is its inflow)."""
    q: list[float | None] = [None] * len(branches)
    inlets: dict[int, float] = {}
    ins_of, outs_of = by_junction(start_j, end_j)
    for i in order:
        if q[i] is not None:
            continue
        j = start_j[i]
        if j < 0:
            if branches[i].discharge_m2s is None:
                raise GraphError(f"branch {branches[i].name!r} is a source (its start is no "
                                 f"junction): give its discharge_m2s")
            q[i] = branches[i].discharge_m2s
            continue
        inflow = sum(q[k] for k in ins_of.get(j, []))
        outs = outs_of.get(j, [])
        given = {k: branches[k].discharge_m2s for k in outs if branches[k].discharge_m2s is not None}
        missing = [k for k in outs if k not in given]
        p = junctions[j]
        ins = [branches[k].name for k in ins_of.get(j, [])]
        where = (f"junction at ({p[0]:.1f}, {p[1]:.1f}) (in: {ins}, "
                 f"out: {[branches[k].name for k in outs]})")
        rest = inflow - sum(given.values())
        tol = 1e-6 * max(1.0, inflow)
        if missing:
            if rest <= tol:
                raise GraphError(f"{where}: outgoing discharges {sum(given.values()):g} m²/s leave "
                                 f"nothing of the inflow {inflow:g} m²/s for "
                                 f"{[branches[k].name for k in missing]}")
            wsum = sum(branches[k].widths_m[0] for k in missing)
            for k in missing:
                given[k] = rest * branches[k].widths_m[0] / wsum
        elif lateral and len(outs) == 1 and rest < -tol and (n_lateral is None or j < n_lateral):
            inlets[j] = -rest
        elif abs(rest) > tol:
            raise GraphError(f"{where}: inflow {inflow:g} m²/s ≠ outflow {sum(given.values()):g} m²/s")
        for k, v in given.items():
            q[k] = v
    return [float(v) for v in q], inlets


# -- water polygon ------------------------------------------------------------------------


def _round_junctions(river, parts: list, geoms: list[BranchGeometry], junctions: np.ndarray,
                     cuts: list, fraction: float, sliver_m2: float):
    """The water with the corners at every junction rounded (:func:`_strips.fillet_pieces`):
    arcs of radius r = ``fraction`` × the narrowest width there; slim points of land (the tip
    of a slim island between two arms), which that arc would cut far back, get arcs of half
    or a quarter of r, whichever first cuts off no more than fits in a circle of
    FILLET_EXTENT radii r (tried only at corners where the larger arc refused a corner).
    Where the water near a junction is made of simple corners the arcs are solved in closed
    form (:func:`_strips.corner_fillets`, some 5 in 6 junctions of a real network); elsewhere
    the closing with a disc finds them.
    Each junction works on the water near it, made from the strips and
    discs (``parts``) there, so the cost does not grow with the network; the pieces join the
    whole water once at the end (left out if that changed the water's topology)."""
    cut_lines = shapely.linestrings(np.asarray(cuts).reshape(-1, 2, 2))
    cut_tree = shapely.STRtree(cut_lines)
    parts_array = np.asarray(parts, dtype=object)
    tree = shapely.STRtree(parts_array)
    pieces = []
    at_junction: dict[int, list[float]] = {}
    for g in geoms:
        for w, at in ((g.widths_m[0], g.start_junction), (g.widths_m[-1], g.end_junction)):
            if at >= 0:
                at_junction.setdefault(at, []).append(w)
    for j, p in enumerate(junctions):
        widths = at_junction[j]
        radius = fraction * min(widths)
        reach = FILLET_REACH_WIDTHS * max(widths)
        window = shapely.Point(p).buffer(reach + 3.0 * radius, quad_segs=_strips.FILLET_QUAD_SEGS)
        # each part is first cut to a square a little larger than the window (a cheap clip:
        # a whole branch's strip has hundreds of vertices far away), then the union to the
        # window itself: the same set as the window's cut of the union of the whole parts
        half = 1.01 * (reach + 3.0 * radius)
        box = (p[0] - half, p[1] - half, p[0] + half, p[1] + half)
        near = shapely.clip_by_rect(parts_array[tree.query(window, predicate="intersects")], *box)
        # the free-end cuts a fillet must keep away from: those within 2 radii of the window
        # (a fillet lies inside it); all of them made each test visit every cut
        close = cut_tree.query(window, predicate="dwithin", distance=2.0 * radius + 1.0)
        keep_out = shapely.MultiLineString(list(cut_lines[np.sort(close)])) if len(close) else None
        # a junction whose water near it is as it was (a network built again) has the same
        # corners: looked up (the strips' memo)
        key = _strips.MEMO.key("corners", np.asarray(p, np.float64), radius, reach, sliver_m2,
                               FILLET_EXTENT, FILLET_SCALES, list(near), keep_out)
        made = _strips.MEMO.get(key)
        if made is None:
            made = _junction_corners(near, p, radius, reach, window, keep_out, sliver_m2)
            _strips.MEMO.put(key, made,
                             sum(int(shapely.get_num_coordinates(g)) for g in made) + 1)
        pieces += made
    if not pieces:
        return river
    # the pieces lie in small groups (one per junction): their union by disjoint subsets is
    # some 40 times faster than GEOS's cascaded union, and one overlay with the water then
    # costs less than adding them to it in a cascade (made group by group: the same polygons,
    # at a cost that does not grow with the network)
    added = shapely.disjoint_subset_union_all(pieces)
    merged = _strips.union_by_groups(river, added)
    rounded = _strips.drop_slivers(merged[0] if len(merged) == 1 else shapely.MultiPolygon(merged),
                                   sliver_m2)
    return rounded if _strips.topology(rounded) == _strips.topology(river) else river



def _junction_corners(near, p, radius: float, reach: float, window, keep_out,
                      sliver_m2: float) -> list:
    """The pieces that round the corners of one junction (:func:`_round_junctions`): the
    water ``near`` it (its parts clipped to a square round ``window``), arcs of ``radius``."""
    merged = shapely.union_all(near)
    # the arcs in closed form where the corners are simple (they look at the water within
    # reach + 2 radii only: the square will do)
    found = _strips.corner_fillets(_strips.drop_slivers(merged, sliver_m2), p, radius, reach,
                                   keep_out, FILLET_EXTENT * radius, FILLET_SCALES)
    if found is not None:
        return list(found[0])
    pieces = []
    local = _strips.drop_slivers(shapely.intersection(merged, window), sliver_m2)
    for scale in FILLET_SCALES:  # not a junction of simple corners: the closing
        added, refused = _strips.fillet_pieces(local, p, scale * radius, reach, keep_out,
                                               FILLET_EXTENT * radius)
        pieces += added
        if not refused:
            break       # a smaller closing of the rounded water adds nothing
        if added:
            local = shapely.union_all([local, *added])
    return pieces

def _water(geoms: list[BranchGeometry], junctions: np.ndarray, islands: list[_Island],
           tolerance_m: float, fillet_fraction: float = FILLET_FRACTION, lakes=(),
           lake_ends=None):
    """Oriented water polygons, free-end cuts and validated islands; ``lakes`` join the water
    (``lake_ends``: the lake each branch starts / ends on, -1: none)."""
    lake_polys = [lk.polygon for lk in lakes]
    if not geoms:
        return [shapely.geometry.polygon.orient(p, 1.0) for p in lake_polys], [], []
    strips, cuts = [], []
    for g in geoms:
        line, w = _strips.extend_ends(g.centerline_m, g.widths_m, g.start_junction >= 0,
                                      g.end_junction >= 0)
        strips.append(_strips.strip_polygon(line, w))
        g.strip = strips[-1]
        if strips[-1].geom_type != "Polygon" or len(strips[-1].interiors):
            x, y = strips[-1].representative_point().coords[0]
            raise GraphError(f"branch {g.name!r} loops onto itself near ({x:.1f}, {y:.1f}): its "
                             f"strip encloses land or falls apart; draw it as separate branches")
        if g.start_junction < 0:
            cuts.append(_strips.free_end_cut(g.centerline_m, g.widths_m, True))
        if g.end_junction < 0:
            cuts.append(_strips.free_end_cut(g.centerline_m, g.widths_m, False))
    discs = []
    halves_at: dict[int, list[float]] = {}
    for g in geoms:
        if g.start_junction >= 0:
            halves_at.setdefault(g.start_junction, []).append(0.5 * g.widths_m[0])
        if g.end_junction >= 0:
            halves_at.setdefault(g.end_junction, []).append(0.5 * g.widths_m[-1])
    for j, p in enumerate(junctions):
        discs.append(_strips.junction_disc(p, halves_at.get(j, [])))
    # strips may only overlap around a junction their branches share
    tree = shapely.STRtree(strips)
    bounds = shapely.bounds(strips)
    for a, b in zip(*tree.query(strips, predicate="intersects")):
        if a >= b:
            continue
        ga, gb = geoms[a], geoms[b]
        shared = {ga.start_junction, ga.end_junction} & {gb.start_junction, gb.end_junction} - {-1}
        in_lakes = [lake_polys[j - len(junctions)] for j in shared if j >= len(junctions)]
        shared = {j for j in shared if j < len(junctions)}
        if not shared and not in_lakes:
            raise GraphError(f"branches {ga.name!r} and {gb.name!r} overlap but do not meet at a "
                             f"junction (end points must coincide to join; split a branch where "
                             f"another one flows into it)")
        # both strips cut to the box their boxes share first (the same overlap: a cheap clip
        # drops the long stretches of strip far from it, which the overlay would visit)
        box = np.concatenate([np.maximum(bounds[a, :2], bounds[b, :2]) - 1.0,
                              np.minimum(bounds[a, 2:], bounds[b, 2:]) + 1.0])
        common = shapely.intersection(shapely.clip_by_rect(strips[a], *box),
                                      shapely.clip_by_rect(strips[b], *box))
        near_parts = [discs[j] for j in sorted(shared)] + in_lakes
        near = near_parts[0] if len(near_parts) == 1 else shapely.union_all(near_parts)
        for part in getattr(common, "geoms", [common]):
            if part.area > tolerance_m ** 2 and not part.intersects(near):
                x, y = part.representative_point().coords[0]
                raise GraphError(f"branches {ga.name!r} and {gb.name!r} overlap near ({x:.1f}, "
                                 f"{y:.1f}), away from the junction they share")
    min_width = min(float(g.widths_m.min()) for g in geoms)
    extra = (_lakes.mouth_strips(geoms, lake_ends, lakes) + lake_polys) if lakes else []
    river = _strips.drop_slivers(shapely.disjoint_subset_union_all(strips + discs + extra),
                                 1e-4 * min_width ** 2)
    if fillet_fraction > 0.0:
        river = _round_junctions(river, strips + discs + extra, geoms, junctions, cuts,
                                 fillet_fraction, 1e-4 * min_width ** 2)
    valid_islands = []
    for k, isl in enumerate(islands):
        if not river.contains(isl.outline) or isl.outline.distance(river.boundary) <= tolerance_m:
            raise GraphError(f"island {k} is not strictly inside the river (it must not touch a bank)")
        for m, other in enumerate(valid_islands):
            if other.outline.distance(isl.outline) <= tolerance_m:
                raise GraphError(f"islands {m} and {k} touch or overlap")
        valid_islands.append(isl)
    water = river
    if islands:
        water = shapely.difference(river, shapely.union_all([i.outline for i in islands]))
    # with lakes the outline is kept as made: simplified, it would leave the lakes' shores,
    # which the rivers' outlines must share exactly (_lakes.split_water)
    return (_strips.oriented_polygons(water, 0.0 if lakes else 0.2 * tolerance_m), cuts,
            valid_islands)


# -- a given water area ---------------------------------------------------------------------

END_CHORD_FRACTION = 0.9
"""A free end of a given water area is cut where the chord across the channel is at least
this fraction of the channel's width (or of the widest chord there, if narrower)..."""
END_CHORD_REACH = 1.5
"""...looked for within this many widths of the branch's free end..."""
END_CHORD_LONGEST = 1.6
"""...and no longer than this many widths (a longer one runs across a bend)."""
END_STRAIGHT = 0.02
"""The straight edge a free end runs into (the data's edge) goes on over the outline's next
edges while their vertices lie within this many widths of a line."""
_END_STATIONS = 48


def _first_hits(water, origins: np.ndarray, direction: np.ndarray, reach_m: float):
    """Distance along ``direction`` (unit, (2,)) from each origin (N, 2) to the water's
    boundary (inf where none within ``reach_m``), and which ring that boundary is (its
    polygon's index × 2^20 + its ring's, 0 the exterior; -1 where none)."""
    rays = shapely.linestrings(np.stack([origins, origins + direction * reach_m], axis=1))
    parts = [p for p in getattr(water, "geoms", [water])]
    best = np.full(len(origins), np.inf)
    ring_of = np.full(len(origins), -1, np.int64)
    for j, poly in enumerate(parts):
        for k, ring in enumerate([poly.exterior, *poly.interiors]):
            hits = shapely.intersection(rays, ring)
            for i, h in enumerate(hits):
                if h.is_empty:
                    continue
                pts = shapely.get_coordinates(h)
                d = float(((pts - origins[i]) @ direction).min())
                if d < best[i]:
                    best[i], ring_of[i] = d, (j << 20) + k
    return best, ring_of


def _end_chord(water, line: np.ndarray, width_m: float, at_start: bool, eps_m: float,
               mouth: bool = False, within: bool = False):
    """The straight closing segment across a free end of a given water area: (chord (2, 2),
    station along the end's tangent from the end point [m], unit tangent pointing out of the
    channel). None when no chord across the channel is found within two widths of the end.
    ``mouth``: the end is capped off a still lake's shore (the water cut back along it): the
    straight edge it runs into is its chord however long (a delta's mouth flaring into a
    bay, wider than END_CHORD_LONGEST widths of its channel, opens on the sea along it).
    ``within``: the channel lies within its junction's water (no longer than its widest):
    its median width is the junction's, and a straight edge at least half that wide and as
    wide as the chord where it ends spans it (beside an island's stub on the data's edge the
    channel is narrower at its end than behind it: its chord at full width lay behind the
    stub's tip, and no bank of its own was left to it)."""
    if len(line) < 2:
        return None
    if at_start:
        c, back = line[0], line[1]
    else:
        c, back = line[-1], line[-2]
    t = c - back
    t = t / np.hypot(*t)
    n = np.array([-t[1], t[0]])
    reach = 4.0 * width_m + 1.0
    seg = np.hypot(*np.diff(line, axis=0).T)
    back = min(0.5 * width_m, 0.5 * float(seg.sum()))
    start = c - t * back                     # on the centre line, in the water
    tip, _ = _first_hits(water, start[None], t, back + 4.0 * width_m + 1.0)
    if not np.isfinite(tip[0]):
        return None
    s = np.linspace(tip[0] - eps_m, tip[0] - END_CHORD_REACH * width_m, _END_STATIONS)
    s = s[s >= 0.0]
    q = start + s[:, None] * t
    inside = shapely.contains_xy(water, q[:, 0], q[:, 1])
    left, lo = _first_hits(water, q, n, reach)
    right, ro = _first_hits(water, q, -n, reach)
    # both ends on one shore: the outer one, or one island's (a creek's dead end cut into
    # it, the island's rim its banks); not from a bank to an island
    ok = inside & (lo == ro) & (lo >= 0) & np.isfinite(left) & np.isfinite(right)
    chord = np.where(ok, left + right, 0.0)
    edge = _edge_at(water, start + t * tip[0], eps_m, END_STRAIGHT * width_m)
    span = np.hypot(*(edge[-1] - edge[0])) if edge is not None else 0.0
    ok &= chord <= END_CHORD_LONGEST * width_m       # not across a bend
    if not ok.any() and not (mouth and span >= END_CHORD_FRACTION * width_m):
        return None
    chord = np.where(ok, chord, 0.0)
    ref = min(chord.max(), width_m) if ok.any() else width_m
    spans = END_CHORD_FRACTION * ref <= span
    if within and ok.any() and not spans:
        spans = 0.5 * ref <= span and END_CHORD_FRACTION * chord[np.flatnonzero(ok)[0]] <= span
    if spans and (mouth or span <= END_CHORD_LONGEST * width_m):
        # the water ends on a straight edge across the channel (the data's edge): that edge
        if ((edge[-1] - edge[0]) @ n < 0) != at_start:
            edge = edge[::-1]
        return edge, float(tip[0] - back), t
    k = int(np.flatnonzero(chord >= END_CHORD_FRACTION * ref)[0])
    a, b = q[k] + n * left[k], q[k] - n * right[k]
    return np.array([a, b]) if at_start else np.array([b, a]), float(s[k] - back), t


def _edge_at(water, point: np.ndarray, eps_m: float, straight_m: float = 0.0):
    """The straight edge of the water's outline through ``point``, (M, 2), or None: the edge
    there, and the edges on from it while the vertices between lie within ``straight_m`` of
    the line between the ends (a map's end of the water drawn as a nearly straight line of
    several edges: the one edge left a corner of it a bank facing away from the axis)."""
    p = shapely.Point(point)
    for poly in getattr(water, "geoms", [water]):
        for ring in [poly.exterior, *poly.interiors]:
            if ring.distance(p) > eps_m:
                continue
            v = np.asarray(ring.coords)
            a, b = v[:-1], v[1:]
            d = b - a
            dd = np.maximum(np.einsum("ij,ij->i", d, d), 1e-300)
            u = np.clip(np.einsum("ij,ij->i", point - a, d) / dd, 0, 1)
            dist = np.hypot(*(a + u[:, None] * d - point).T)
            k = int(np.argmin(dist))
            if dist[k] <= eps_m:
                return _straight_run(v[:-1], k, straight_m)
    return None


def _straight_run(v: np.ndarray, k: int, straight_m: float) -> np.ndarray:
    """Ring ``v``'s (M, 2) edge k and the edges on from it either way while every vertex
    between the run's ends lies within ``straight_m`` of the line through them, (R, 2)."""
    m = len(v)
    i, j = k, k + 1

    def straight(i: int, j: int) -> bool:
        p = v[np.arange(i, j + 1) % m]
        d = p[-1] - p[0]
        length = float(np.hypot(*d))
        return length > 0.0 and bool((np.abs(d[0] * (p[1:-1] - p[0])[:, 1] - d[1] * (
            p[1:-1] - p[0])[:, 0]) <= straight_m * length).all())

    while straight_m > 0.0 and j - i < m - 2:
        if straight(i - 1, j) and (not straight(i, j + 1) or np.hypot(*(v[(i - 1) % m] - v[i % m]))
                                   <= np.hypot(*(v[(j + 1) % m] - v[j % m]))):
            i -= 1
        elif straight(i, j + 1):
            j += 1
        else:
            break
    return v[np.arange(i, j + 1) % m].copy()


def _trim_to_chord(line: np.ndarray, widths: np.ndarray, chord: np.ndarray, at_start: bool,
                   outward: np.ndarray | None = None):
    """The centre line (K, 2) and widths (K,) ending on the chord's line: cut where it first
    crosses it coming from the free end, or extended straight to it. The channel lies on
    the side of the chord's line ``outward`` (the end's tangent out of the channel) points
    away from; without it, on its other end's side (a hairpin's other end may lie on the
    line: both legs cut by one straight edge of the data)."""
    if not at_start:
        line2, w2 = _trim_to_chord(line[::-1], widths[::-1], chord, True, outward)
        return line2[::-1].copy(), w2[::-1].copy()
    a, b = chord[0], chord[-1]
    n = np.array([-(b - a)[1], (b - a)[0]])
    side = (line - a) @ n
    out = float(outward @ n) if outward is not None else 0.0
    sign = -np.sign(out) if abs(out) > 1e-6 * float(np.hypot(*n)) else (np.sign(side[-1]) or 1.0)
    keep = side * sign > 0
    k = int(np.argmax(keep)) if keep.any() else len(line) - 1
    p, q = (line[0], line[1]) if k == 0 else (line[k - 1], line[k])
    sp, sq = (side[0], side[1]) if k == 0 else (side[k - 1], side[k])
    x = p + (sp / (sp - sq) if sp != sq else 0.0) * (q - p)
    rest, wrest = line[k:], widths[k:]
    if np.hypot(*(x - rest[0])) <= 1e-9:
        rest, wrest = rest[1:], wrest[1:]
    return np.vstack([x, rest]), np.concatenate([[widths[k]], wrest])


def _given_water(geoms: list[BranchGeometry], water, islands: list[_Island], tolerance_m: float,
                 mouths=frozenset()):
    """:meth:`RiverNetworkBuilder.set_water_area`: the oriented water polygons cut at the free
    ends, the closing segments, the validated islands and the area cut off at each end.
    ``mouths``: {(branch index, at its start)} of the free ends capped off a terminal or
    source lake's shore (:func:`_lakes.end_at_terminal_lakes`), cut along that shore."""
    eps = max(1e-3, 1e-3 * tolerance_m)
    cuts, cut_area, cut_islands = [], [], []
    given = water
    for k, g in enumerate(geoms):
        for at_start in (True, False):
            if (g.start_junction if at_start else g.end_junction) >= 0:
                continue
            where = "start" if at_start else "end"
            c = g.centerline_m[0 if at_start else -1]
            width = float(np.median(g.widths_m))
            within = (g.start_junction if not at_start else g.end_junction) >= 0 and float(
                np.hypot(*np.diff(g.centerline_m, axis=0).T).sum()) <= float(g.widths_m.max())
            found = _end_chord(water, g.centerline_m, width, at_start, eps,
                               (k, at_start) in mouths, within)
            if found is None:
                raise GraphError(f"branch {g.name!r}: its free {where} at ({c[0]:.1f}, "
                                 f"{c[1]:.1f}) does not reach across the water to its banks "
                                 f"(no chord across the channel within two widths of it)")
            chord = found[0]
            line = shapely.LineString(np.vstack([chord[0] - (chord[1] - chord[0]) * 1e-6,
                                                 chord[1:-1],
                                                 chord[-1] + (chord[-1] - chord[-2]) * 1e-6]))
            pieces = list(shapely.get_parts(shapely.ops.split(water, line)))
            t = found[2]
            mid = chord.mean(axis=0)
            chord_line = shapely.LineString(chord)
            # (less than half the water body it is cut from: a delta's arm beside a sea, a
            # small part of all the water, is not cut off whole beyond one of its ends)
            body = max((p.area for p in getattr(water, "geoms", [water])
                        if p.distance(chord_line) <= eps), default=water.area)
            beyond = [p for p in pieces
                      if (np.asarray(p.representative_point().coords[0]) - mid) @ t > 0
                      and p.distance(chord_line) <= eps and p.area < 0.5 * body]
            if len(pieces) > 1 and beyond:
                water = shapely.union_all([p for p in pieces if not any(p is q for q in beyond)])
                cut_area.append(float(sum(p.area for p in beyond)))
            else:
                cut_area.append(0.0)
            g.centerline_m, g.widths_m = _trim_to_chord(g.centerline_m, g.widths_m, chord, at_start,
                                                        t)
            seg = np.hypot(*np.diff(g.centerline_m, axis=0).T)
            if len(g.centerline_m) < 2 or not seg.min() > 1e-9:
                raise GraphError(f"branch {g.name!r}: nothing is left of it once the water is "
                                 f"cut across its free {where} near ({c[0]:.1f}, {c[1]:.1f}) "
                                 f"(a branch shorter than the water is wide there)")
            cuts.append(chord)
    valid_islands = []
    for k, isl in enumerate(islands):
        if not water.contains(isl.outline) or isl.outline.distance(water.boundary) <= tolerance_m:
            if (given.contains(isl.outline)
                    and isl.outline.distance(given.boundary) > tolerance_m):
                cut_islands.append(k)     # an island the end cut runs through: left out
                continue
            raise GraphError(f"island {k} is not strictly inside the water (it must not touch "
                             f"a bank)")
        valid_islands.append(isl)
    if valid_islands:
        water = shapely.difference(water, shapely.union_all([i.outline for i in valid_islands]))
    polygons = [shapely.geometry.polygon.orient(p, sign=1.0)
                for p in sorted((p for p in getattr(water, "geoms", [water]) if not p.is_empty),
                                key=lambda p: (-p.area, p.bounds))]
    return polygons, cuts, valid_islands, (cut_area, cut_islands)
