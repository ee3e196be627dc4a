"""FlowField: the procedural, divergence-free velocity of a river network (public API).

Re-does Proland's ``HydroFlowProducer`` + ``HydroFlowTile`` and the velocity model of Yu et al.
2009 (reference §2): ψ at a point is a weighted mean of the ψ of nearby banks; the velocity is
its curl. ψ is cached on lattices of flow tiles that form a quadtree over the domain, made on
demand and kept in a bounded cache; the velocity is the curl of a C¹ bicubic interpolant of
the lattice, so it is continuous within and across tiles and divergence-free.

Moving obstacles (boats) are set each frame with :meth:`FlowField.set_obstacles`; every
query then sees the flow go around them (:mod:`riverflow.kernels.obstacles`).

Example::

    field = FlowField(graph, slip=1.0, search_radius_factor=5.0)
    status, velocity = field.query(xy)      # (N,) uint8 FlowStatus, (N, 2) float32 [m/s]
    psi = field.potential(xy)               # (N,) float64 [m²/s], NaN outside the water
    field.set_obstacles([Obstacle((x, y), heading_rad=0.3, psi=field.potential([(x, y)])[0])])
"""
from __future__ import annotations

import copy
import math
import weakref
from collections.abc import Iterable, Iterator
from dataclasses import dataclass

import numpy as np

from riverflow._validate import as_points, check_allocation, finite_positive
from riverflow.components.flow_tiles import FLOW_KIND, FlowTiles, flow_fields
from riverflow.components.status import FlowStatus
from riverflow.hydro.flow_network import FlowNetwork, build_flow_network
from riverflow.hydro.graph import CurveType, GraphError, HydroGraph
from riverflow.hydro.nearest import PolylineIndex
from riverflow.hydro.falls import RAPIDS_RAMP
from riverflow.kernels import falls as kfalls
from riverflow.kernels import flow as kf
from riverflow.kernels import obstacles as ko
from riverflow.kernels.flow import Segments
from riverflow.kernels.warmup import compile_kernels
from riverflow.tiles.cache import TileCache
from riverflow.tiles.coverage import coverage_table, touched_bytes
from riverflow.tiles.quadtree import Quadtree
from riverflow.tiles.table import tile_code

_NO_LEVELS = np.zeros(0, np.int8)
FALL_BOX_M = 5.0
""":meth:`FlowField.falls_box` reaches this far [m] before a fall's lip and past its nappe."""
_NO_OBSTACLES = np.zeros((0, ko.OBSTACLE_FIELDS))


@dataclass(eq=False)
class Obstacle:
    """A moving hull in the flow: a capsule ``length_m`` long (tip to tip) and ``beam_m``
    wide, centred at ``centre_m`` (2,) [m] along ``heading_rad`` (counter-clockwise from +x).

    ``psi`` [m²/s] is the hull's stream-function value, normally the unobstructed ψ at its
    centre (``field.potential(centre, exclude_obstacles=True)``); ``velocity_mps`` (2,) and
    ``yaw_rate_rps`` its rigid motion (the water next to it moves with it); ``reach_m`` how far
    from the hull the flow is bent (default 1.5 beams). See :mod:`riverflow.kernels.obstacles`.
    """

    centre_m: tuple[float, float]
    heading_rad: float = 0.0
    length_m: float = 8.0
    beam_m: float = 3.0
    psi: float = 0.0
    velocity_mps: tuple[float, float] = (0.0, 0.0)
    yaw_rate_rps: float = 0.0
    reach_m: float | None = None

    def row(self) -> np.ndarray:
        """The obstacle as one (OBSTACLE_FIELDS,) float64 row (columns ``obstacles.OB_*``)."""
        reach = self.reach_m if self.reach_m is not None else ko.DEFAULT_REACH_BEAMS * self.beam_m
        return np.array([self.centre_m[0], self.centre_m[1], self.heading_rad, self.length_m,
                         self.beam_m, self.psi, self.velocity_mps[0], self.velocity_mps[1],
                         self.yaw_rate_rps, reach], np.float64)


WATER_WIDTH_FACTOR = 8.0
"""The default lattice follows the narrowest axis width, or this many times the narrowest
water (:func:`narrowest_water_m`) where that is smaller: an axis's width spans every bank it
owns, so a 0.6 m creek's axis that also owns the bank of the river it joins across the
confluence is 24 m wide, and a lattice of 1 m left the creek's water between its corners (ψ
NaN, no flow, every 56 m). Where axes are about as wide as their water (Proland's margin:
1.4 - 1.7 times it; the arms beside an island: 2 - 3 times) this changes nothing."""


def narrowest_water_m(graph: HydroGraph, axes: list[int], per_bank: int = 64) -> float:
    """The narrowest water across any axis [m]: for each axis, twice the 10th percentile of its
    banks' distances to it (up to ``per_bank`` points a bank), the smallest over the axes."""
    banks: dict[int, list[np.ndarray]] = {}
    for curve in graph.curves:
        if curve.type == CurveType.BANK and curve.river in axes and len(curve.points):
            pts = np.asarray(curve.points, np.float64)
            banks.setdefault(curve.river, []).append(pts[::max(1, len(pts) // per_bank)])
    best = math.inf
    for axis, parts in banks.items():
        distance = PolylineIndex(graph.polyline(axis)).distance(np.concatenate(parts))
        best = min(best, 2.0 * float(np.percentile(distance, 10.0)))
    return best if best > 0.0 else math.inf


class FlowField:
    """Velocity and stream function of a river network, from cached flow tiles.

    Args:
        graph: the river network.
        slip: exponent p of the weights d^-p (1: plug flow between parallel banks; < 1 slip,
            > 1 no-slip-like boundary layers). Proland ``slip``.
        search_radius_factor: R = factor × the widest axis of a river network; banks farther
            than R do not shape ψ. Proland ``searchRadiusFactor``.
        potential_delta_m: wanted ψ-lattice spacing of the finest tiles [m] (Proland
            ``potentialDelta``); default: the narrowest axis width / 24.
        lattice_cells: lattice cells per tile side (Proland ``displayTileSize``, 192 there).
        cache_tiles: how many flow tiles a field's own cache holds (its byte budget); unused
            when ``cache`` is given.
        domain_m: (xmin, ymin, size) of the root square; default: the graph's bounds, padded.
        tolerance_m: Bézier flattening tolerance; default: the narrowest width / 200.
        cache: the :class:`~riverflow.tiles.cache.TileCache` to keep the tiles in (a river
            world shares one between every kind of tile); default: a cache of its own.

    The quadtree's finest level follows from the domain and ``potential_delta_m`` (no fixed
    limit), so a 1000 km network has the same finest lattice as a 4 km one.

    Raises:
        GraphError: the graph cannot carry a flow (see :func:`build_flow_network`).
        ValueError: a non-positive or non-finite option.
    """

    def __init__(
        self,
        graph: HydroGraph,
        slip: float = 1.0,
        search_radius_factor: float = 5.0,
        *,
        potential_delta_m: float | None = None,
        lattice_cells: int = 64,
        cache_tiles: int = 256,
        domain_m: tuple[float, float, float] | None = None,
        tolerance_m: float | None = None,
        cache: TileCache | None = None,
    ) -> None:
        if not isinstance(graph, HydroGraph):
            raise TypeError(f"FlowField: graph must be a HydroGraph, got {type(graph).__name__}")
        slip = finite_positive(slip, "FlowField: slip")
        search_radius_factor = finite_positive(search_radius_factor,
                                               "FlowField: search_radius_factor")
        for label, value, low in (("lattice_cells", lattice_cells, 4),
                                  ("cache_tiles", cache_tiles, 1)):
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
                raise TypeError(f"FlowField: {label} must be a whole number, got {value!r}")
            if value < low:
                raise ValueError(f"FlowField: {label} must be ≥ {low}, got {value!r}")
        n = int(lattice_cells)
        tile_bytes_est = (2 * 4 * (n + 3) ** 2 + n * n * (1 + 4 * kf.CELL_SEGMENTS)
                          + 9 * (n + 1 + 2 * kf.LATTICE_RING) ** 2 + 8 * kf.CELL_SEGMENTS * n * n)
        check_allocation(tile_bytes_est * (1 if cache is not None else 1 + int(cache_tiles)),
                         f"FlowField: lattice_cells={lattice_cells}, cache_tiles={cache_tiles}")
        for label, value in (("potential_delta_m", potential_delta_m),
                             ("tolerance_m", tolerance_m)):
            if value is not None:
                finite_positive(value, f"FlowField: {label}")
        axes = graph.axes()
        if not axes:
            raise GraphError(f"{graph.source or 'graph'}: no river axis to carry a flow")
        min_width = min(graph.curves[a].width_m for a in axes)
        self.graph = graph
        self.slip = float(slip)
        self.search_radius_factor = float(search_radius_factor)
        tol = tolerance_m if tolerance_m is not None else max(min_width / 200.0, 0.01)
        self.tolerance_m = float(tol)
        """The Bézier flattening tolerance the network was made with [m]."""
        self.network: FlowNetwork = build_flow_network(graph, self.search_radius_factor, tol)
        compile_kernels("field")          # before the first query; says so while compiling
        delta = potential_delta_m if potential_delta_m is not None else min(
            min_width, WATER_WIDTH_FACTOR * narrowest_water_m(graph, axes)) / 24.0
        if not (math.isfinite(delta) and delta > 0.0):
            raise ValueError(f"FlowField: potential_delta_m must be positive, got {delta!r}")
        if domain_m is None:
            x0, y0, x1, y1 = graph.bounds()
            pad = max(graph.curves[a].width_m for a in axes)
            size = max(x1 - x0, y1 - y0) + 2.0 * pad
            domain_m = (0.5 * (x0 + x1) - 0.5 * size, 0.5 * (y0 + y1) - 0.5 * size, size)
        root_x, root_y, root_size = (float(v) for v in domain_m)
        if not (root_size > 0.0 and math.isfinite(root_x) and math.isfinite(root_y)
                and math.isfinite(root_size)):
            raise ValueError(f"FlowField: bad domain {domain_m!r}")
        quadtree = Quadtree(root_x, root_y, root_size)
        try:
            self.max_level = quadtree.level_for_cell(delta, lattice_cells)
        except ValueError as exc:
            if potential_delta_m is not None:
                raise ValueError(f"FlowField: potential_delta_m={delta!r}: {exc}") from None
            narrow = min(axes, key=lambda a: graph.curves[a].width_m)
            raise GraphError(f"{graph.source or 'graph'}: its narrowest axis (curve {narrow}, "
                             f"{graph.curves[narrow].width_m:g} m wide) in a network "
                             f"{root_size:g} m across asks for a ψ lattice of {delta:g} m: "
                             f"{exc}") from None
        if cache is None:
            tile_bytes = sum(f.nbytes for f in flow_fields(lattice_cells).values())
            cache = TileCache(cache_tiles * tile_bytes)
        self.river_boxes = self.network.river_boxes()
        axis_segments = self.network.axis_segments()
        axis_half_widths = self.network.axis_half_widths()
        check_allocation(touched_bytes(axis_segments, axis_half_widths,
                                       quadtree.tile_size_m(self.max_level)),
                         f"FlowField: the wet-tile table of a network {root_size:,.0f} m across "
                         f"at lattice spacing potential_delta_m={delta:g} m "
                         f"(quadtree level {self.max_level}"
                         + ("" if potential_delta_m is not None else
                            f"; by default a 24th of its narrowest water: a coarser "
                            f"potential_delta_m, RiverConfig.potential_delta_m for a world, "
                            f"leaves water narrower than a few lattice cells dry") + ")")
        self.tiles = FlowTiles(quadtree, lattice_cells, self.max_level, cache,
                               coverage_table(quadtree, axis_segments, axis_half_widths,
                                              self.max_level))
        self.segments = Segments(*self.network.geometry_args(), self.network.segment_psi())
        self._builder = TileBuilder(self)
        self.lakes = self._solve_lakes(tol)
        """Per lake area, its potential flow (:class:`riverflow.hydro.lake_flow.LakeGrid`),
        which the tiles take as the ψ of their lattice points in the lake."""
        self._builder.lakes = self.lakes
        self._obstacle_sets: dict[str, np.ndarray] = {}
        self.obstacles: np.ndarray = _NO_OBSTACLES
        """(K, OBSTACLE_FIELDS) float64: every obstacle, set by set_obstacles (read-only)."""
        self.falls = list(getattr(graph, "falls", []) or [])
        """The graph's falls (:class:`riverflow.hydro.falls.Fall`): :meth:`query` speeds the
        flow up over them (:mod:`riverflow.kernels.falls`)."""
        self._fall_table: kfalls.FallTable | None = None
        self._falls_box: tuple | None = None
        self.rapids = list(getattr(graph, "rapids", []) or [])
        """The graph's rapids (:class:`riverflow.hydro.falls.Rapid`): :meth:`query` speeds the
        flow up on them by their ``speed_gain``, through the falls' kernel
        (:meth:`rapid_table`)."""
        self._rapid_table: kfalls.FallTable | None = None
        self.discharge_scale = None
        """None, or a callable (xy, status, velocity, n, n_status=n) that scales the first n
        velocities in place by the local discharge's speed factor and gives flooded ground
        beside the banks among the first n_status its slow flow (status INSIDE) (a running flood:
        :meth:`riverflow.hydro.flood.FloodRouter.scale_velocity`); :meth:`query` and the
        particles' query call it after the falls."""

    @classmethod
    def for_scene(cls, scene, slip: float = 1.0, search_radius_factor: float = 5.0,
                  **options) -> FlowField:
        """The flow of ``scene.graph`` with the quadtree root on the scene's square bounds."""
        x0, y0, x1, y1 = scene.bounds_m
        options.setdefault("domain_m", (x0, y0, max(x1 - x0, y1 - y0)))
        return cls(scene.graph, slip, search_radius_factor, **options)

    # -- public queries ---------------------------------------------------------------------

    def query(self, xy: np.ndarray, *, level: int | None = None,
              exclude_obstacles: Iterable[int] | bool = ()) -> tuple[np.ndarray, np.ndarray]:
        """Flow status and velocity at points, around the obstacles.

        Args:
            xy: (N, 2) positions [m].
            level: quadtree level of the tiles to use (default: the finest).
            exclude_obstacles: rows of :attr:`obstacles` to leave out (a boat reading the flow
                under itself), or True for the flow without any obstacle.

        Returns:
            status (N,) uint8 :class:`FlowStatus` (INSIDE, OUTSIDE or OUTSIDE_DOMAIN) and
            velocity (N, 2) float32 [m/s], zero unless INSIDE, never NaN. Inside an
            obstacle's hull the water moves with the hull. Never UNKNOWN: the tiles under
            the points are made first, by the kernels' own tile-ownership rule, so a point on
            a tile edge, corner or the domain's edge is answered like its neighbours.

        Raises:
            ValueError: ``xy`` is not (N, 2) (a (2, N) array is not read as other points);
                ``level`` outside 0 … max_level. (NaN / inf points answer OUTSIDE_DOMAIN.)
            TypeError: ``xy`` is not real numbers; ``level`` not a whole number.
        """
        pts = self._points(xy)
        lv = self._level(level)
        status = np.empty(len(pts), np.uint8)
        velocity = np.empty((len(pts), 2), np.float32)
        tick = self.tiles.cache.next_tick()
        if kf.query_velocity(pts, _NO_LEVELS, lv, 0, self.tiles.view(), tick, self.segments,
                             len(pts), status, velocity):  # some tiles are not cached
            for idx in self._batches(pts, lv, np.flatnonzero(status == FlowStatus.UNKNOWN)):
                s_out = np.empty(len(idx), np.uint8)
                v_out = np.empty((len(idx), 2), np.float32)
                kf.query_velocity(pts[idx], _NO_LEVELS, lv, 0, self.tiles.view(),
                                  self.tiles.cache.tick, self.segments, len(idx), s_out, v_out)
                status[idx] = s_out
                velocity[idx] = v_out
            _never_unknown(status, pts)
        self.apply_falls(pts, status, velocity)
        if self.discharge_scale is not None:
            self.discharge_scale(pts, status, velocity, len(pts))
        if len(self.obstacles) and exclude_obstacles is not True:
            self.apply_obstacles(pts, status, velocity, level=lv, fallback=0,
                                 exclude=exclude_obstacles)
        return status, velocity

    def potential(self, xy: np.ndarray, *, level: int | None = None,
                  exclude_obstacles: Iterable[int] | bool = ()) -> np.ndarray:
        """Interpolated stream function ψ [m²/s] at points (N, 2) [m]; NaN outside the water.
        With obstacles it is the modulated ψ' whose curl :meth:`query` returns
        (``exclude_obstacles`` as there)."""
        pts = self._points(xy)
        lv = self._level(level)
        psi = np.empty(len(pts))
        tick = self.tiles.cache.next_tick()
        if kf.sample_potential(pts, _NO_LEVELS, lv, 0, self.tiles.view(), tick, self.segments,
                               psi):  # some tiles are not cached yet
            missing = self.tile_of(pts, lv)[:, 0] >= 0
            missing &= np.isnan(psi)
            for idx in self._batches(pts, lv, np.flatnonzero(missing)):
                out = np.empty(len(idx))
                kf.sample_potential(pts[idx], _NO_LEVELS, lv, 0, self.tiles.view(),
                                    self.tiles.cache.tick, self.segments, out)
                psi[idx] = out
        obstacles = self._obstacles_without(exclude_obstacles)
        if len(obstacles):
            status = np.where(np.isfinite(psi), kf.STATUS_INSIDE, kf.STATUS_OUTSIDE)
            status = status.astype(np.uint8)
            index = np.empty(len(pts), np.int64)
            n = ko.select_obstacle_points(pts, status, obstacles, index)
            if n:
                sub = psi[index[:n]]
                ko.apply_obstacles(pts, index, n, sub, obstacles, status,
                                   np.zeros((len(pts), 2), np.float32))
                psi[index[:n]] = sub
        return psi

    def shore_distance(self, xy: np.ndarray, *, level: int | None = None) -> np.ndarray:
        """Distance [m] from points (N, 2) [m] to the nearest bank or island shore (moving
        obstacles not included), bilinear on the tiles' distance lattice (exact at lattice
        points, within a lattice spacing near a bank); NaN outside the water. The "distance
        map" that foam reads (:mod:`riverflow.kernels.foam`); gameplay may steer by it."""
        pts = self._points(xy)
        lv = self._level(level)
        status = np.empty(len(pts), np.uint8)
        velocity = np.empty((len(pts), 2), np.float32)
        details = np.empty((len(pts), 5))
        tick = self.tiles.cache.next_tick()
        if kf.query_velocity(pts, _NO_LEVELS, lv, 0, self.tiles.view(), tick, self.segments,
                             0, status, velocity):  # some tiles are not cached
            known = status != FlowStatus.UNKNOWN
            kf.sample_flow_details(pts, lv, 0, self.tiles.view(), self.tiles.shore,
                                   self.tiles.bank, details)
            for idx in self._batches(pts, lv, np.flatnonzero(~known)):
                sub = np.ascontiguousarray(pts[idx])
                s_out = np.empty(len(idx), np.uint8)
                d_out = np.empty((len(idx), 5))
                view = self.tiles.view()
                kf.query_velocity(sub, _NO_LEVELS, lv, 0, view, self.tiles.cache.tick,
                                  self.segments, 0, s_out, np.empty((len(idx), 2), np.float32))
                kf.sample_flow_details(sub, lv, 0, view, self.tiles.shore, self.tiles.bank,
                                       d_out)
                status[idx] = s_out
                details[idx] = d_out
        else:
            kf.sample_flow_details(pts, lv, 0, self.tiles.view(), self.tiles.shore,
                                   self.tiles.bank, details)
        return np.where(status == FlowStatus.INSIDE, np.maximum(details[:, 0], 0.0), np.nan)

    # -- obstacles -----------------------------------------------------------------------------

    def set_obstacles(self, obstacles: Iterable[Obstacle] | np.ndarray, *,
                      key: str = "default") -> None:
        """Replace the obstacles of set ``key`` (each owner keeps its own set: the boat system
        uses "boats") with :class:`Obstacle` objects or a (K, OBSTACLE_FIELDS) float64 array
        (columns ``kernels.obstacles.OB_*``). Call it whenever they move (every frame)."""
        if isinstance(obstacles, np.ndarray):
            rows = np.array(obstacles, np.float64, ndmin=2)
            if rows.size == 0:
                rows = _NO_OBSTACLES
        else:
            items = [o.row() for o in obstacles]
            rows = np.stack(items) if items else _NO_OBSTACLES
        if rows.ndim != 2 or rows.shape[1] != ko.OBSTACLE_FIELDS:
            raise ValueError(f"obstacles must be (K, {ko.OBSTACLE_FIELDS}), got {rows.shape}")
        if len(rows):
            finite = np.isfinite(rows)
            finite[:, ko.OB_PSI] = True                     # NaN ψ_o: a disabled obstacle
            positive = rows[:, [ko.OB_LENGTH, ko.OB_BEAM, ko.OB_REACH]].min() > 0.0
            if not (finite.all() and positive):
                raise ValueError("obstacles need finite positions, headings and motions, and "
                                 "positive length, beam and reach")
        if len(rows):
            self._obstacle_sets[key] = np.ascontiguousarray(rows)
        else:
            self._obstacle_sets.pop(key, None)
        sets = list(self._obstacle_sets.values())
        self.obstacles = np.concatenate(sets) if sets else _NO_OBSTACLES

    def obstacle_rows(self, key: str = "default") -> range:
        """The rows of :attr:`obstacles` that set ``key`` occupies (empty if none)."""
        start = 0
        for name, rows in self._obstacle_sets.items():
            if name == key:
                return range(start, start + len(rows))
            start += len(rows)
        return range(start, start)

    # -- falls ------------------------------------------------------------------------------

    def fall_table(self) -> kfalls.FallTable:
        """The falls as the kernel reads them (:class:`riverflow.kernels.falls.FallTable`),
        made on first use: each fall's gain is its lip speed over the speed this field
        gives at the lip's centre (so the lip's middle moves at the lip speed whatever the
        cross-section's profile)."""
        if self._fall_table is None:
            if not self.falls:
                self._fall_table = kfalls.empty_table()
            else:
                centre = np.array([f.centre_m for f in self.falls], np.float64)
                self._fall_table = kfalls.empty_table()     # the river's own speed
                status, velocity = self.query(centre, exclude_obstacles=True)
                speed = np.hypot(*velocity.astype(np.float64).T)
                lip = np.array([f.lip_speed_mps for f in self.falls])
                river = np.array([f.speed_mps for f in self.falls])
                # a lip on a point the flow does not reach: the branch's mean speed stands in
                speed = np.where((status == FlowStatus.INSIDE) & (speed > 1e-6), speed, river)
                self._fall_table = kfalls.FallTable(
                    centre, np.array([f.direction for f in self.falls], np.float64),
                    np.array([0.5 * f.lip_m for f in self.falls]),
                    np.array([max(1.0, 0.1 * f.lip_m) for f in self.falls]),
                    np.array([f.approach_m for f in self.falls]),
                    np.array([f.throw_m for f in self.falls]),
                    np.array([f.plunge_m for f in self.falls]),
                    np.maximum(lip / speed, 1.0))
        return self._fall_table

    def rapid_table(self) -> kfalls.FallTable:
        """The rapids as rows of the falls' kernel (:class:`riverflow.kernels.falls.FallTable`;
        a separate table: the foam's plunge term reads the falls' alone), made on first use:
        a rapid is a "fall" whose lip is its start, across the river (its width), whose
        "nappe" is its chord from start to end and whose gain is its ``speed_gain``; the flow
        speeds up over RAPIDS_RAMP before it and slows back over as much after it."""
        if self._rapid_table is None:
            rows = [r for r in self.rapids if r.speed_gain > 1.0]
            if not rows:
                self._rapid_table = kfalls.empty_table()
            else:
                start = np.array([r.start_m for r in rows], np.float64)
                chord = np.array([r.end_m for r in rows], np.float64) - start
                length = np.maximum(np.hypot(*chord.T), 1e-6)
                across = np.array([r.width_m if r.width_m > 0 else r.to_m - r.from_m
                                   for r in rows])
                frac, lo, hi = RAPIDS_RAMP
                ramp = np.clip(frac * length, lo, hi)
                self._rapid_table = kfalls.FallTable(
                    start, chord / length[:, None], 0.5 * across,
                    np.maximum(1.0, 0.1 * across), ramp, length, ramp,
                    np.array([r.speed_gain for r in rows]))
        return self._rapid_table

    def apply_falls(self, xy: np.ndarray, status: np.ndarray, velocity: np.ndarray,
                    n: int | None = None) -> int:
        """Speed up the velocities already queried (``xy`` (N, 2) float64 [m], ``status``
        (N,) uint8, ``velocity`` (N, 2) float32 [m/s]; the first ``n``) over the falls and
        the rapids, in place (:func:`riverflow.kernels.falls.accelerate_falls`, once with
        each table); returns how many changed (a point sped up by both counts twice). Costs
        nothing without falls and rapids."""
        if not self.falls and not self.rapids:
            return 0
        n = len(xy) if n is None else n
        changed = 0
        for table in (self.fall_table(), self.rapid_table()):
            if len(table.gain):
                changed += int(kfalls.accelerate_falls(xy, status, velocity, n, table))
        return changed

    def falls_box(self) -> np.ndarray:
        """(4,) [m] xmin, ymin, xmax, ymax around where the water of every fall changes
        fast (FALL_BOX_M before its lip to FALL_BOX_M past where its nappe lands, across its
        lip): the particles there ask the flow and the surface every frame. Empty (inf, inf,
        −inf, −inf) without falls. Made once for the list of falls (every frame asks it);
        a copy."""
        known = self._falls_box
        if known is not None and known[0] is self.falls and known[1] == len(self.falls):
            return known[2].copy()
        box = self._make_falls_box()
        self._falls_box = (self.falls, len(self.falls), box)
        return box.copy()

    def _make_falls_box(self) -> np.ndarray:
        if not self.falls:
            return np.array([np.inf, np.inf, -np.inf, -np.inf])
        lo, hi = [], []
        for f in self.falls:
            c = np.asarray(f.centre_m)
            t = np.asarray(f.direction)
            n = np.array([-t[1], t[0]])
            half = 0.5 * f.lip_m + max(1.0, 0.1 * f.lip_m)
            ends = np.array([c - FALL_BOX_M * t, c + (f.throw_m + FALL_BOX_M) * t])
            corners = np.concatenate([ends + half * n, ends - half * n])
            lo.append(corners.min(axis=0))
            hi.append(corners.max(axis=0))
        lo, hi = np.min(lo, axis=0), np.max(hi, axis=0)
        return np.array([lo[0], lo[1], hi[0], hi[1]])

    def apply_obstacles(self, xy: np.ndarray, status: np.ndarray, velocity: np.ndarray, *,
                        level: int, fallback: int = 0, levels: np.ndarray = _NO_LEVELS,
                        exclude: Iterable[int] | bool = ()) -> int:
        """Bend velocities already queried from the cached tiles around the obstacles, in place.

        ``xy`` (N, 2) float64 [m], ``status`` (N,) uint8 and ``velocity`` (N, 2) float32 as
        :func:`riverflow.kernels.flow.query_velocity` wrote them with the same ``levels``,
        ``level`` and ``fallback`` (so ψ comes from the same tiles). Returns the number of
        points changed; costs nothing when there are no obstacles.
        """
        obstacles = self._obstacles_without(exclude)
        if not len(obstacles):
            return 0
        index = np.empty(len(xy), np.int64)
        n = ko.select_obstacle_points(xy, status, obstacles, index)
        if not n:
            return 0
        idx = index[:n]
        pts = np.ascontiguousarray(xy[idx])
        psi = np.empty(n)
        kf.sample_potential(pts, levels[idx] if len(levels) else levels, level, fallback,
                            self.tiles.view(), self.tiles.cache.tick, self.segments, psi)
        return int(ko.apply_obstacles(xy, index, n, psi, obstacles, status, velocity))

    def _obstacles_without(self, exclude: Iterable[int] | bool) -> np.ndarray:
        if exclude is True or not len(self.obstacles):
            return _NO_OBSTACLES
        if exclude is False:
            return self.obstacles
        drop = {int(i) for i in exclude}
        if not drop:
            return self.obstacles
        if drop >= set(range(len(self.obstacles))):
            return _NO_OBSTACLES
        return np.delete(self.obstacles, sorted(drop), axis=0)

    def exact_potential(self, xy: np.ndarray) -> np.ndarray:
        """ψ [m²/s] evaluated from the banks at each point, no lattice (slow; for tests/tools);
        in a lake, its potential flow's ψ (bilinear on the lake's grid)."""
        psi = self._banks_potential(xy)
        pts = self._points(xy)
        for lake in self.lakes:
            v = lake.sample(pts)
            use = np.isfinite(v) & np.isfinite(psi)
            psi[use] = v[use]
        return psi

    def _banks_potential(self, xy: np.ndarray) -> np.ndarray:
        """Proland's ψ from the banks at each point (no lattice, no lake flow)."""
        pts = self._points(xy)
        psi = np.empty(len(pts))
        b = self._builder
        kf.evaluate_potential(pts, psi, self.network.arrays, self.slip, b.blk, b.gval)
        return psi

    def _solve_lakes(self, tolerance_m: float) -> list:
        """The potential flow of each lake a river runs through (:mod:`riverflow.hydro.lake_flow`);
        a lake no river touches is still water (one ψ) and needs none."""
        from riverflow.hydro import lake_flow
        from riverflow.hydro.areas import area_ring

        out = []
        starts = None
        for k in self.graph.lakes():
            area = self.graph.areas[k]
            shore = {self.graph.curves[c].potential for c, _ in area.curves
                     if self.graph.curves[c].is_bank}
            if len(shore) < 2:
                continue
            if starts is None:
                starts = lake_flow.loop_starts(self.graph, tolerance_m)
            islands = lake_flow.lake_islands(self.graph, k, tolerance_m, starts)
            out.append(lake_flow.solve_lake(
                self.graph, k, (self.tiles.root_x_m, self.tiles.root_y_m),
                self.tiles.spacing_m(self.max_level), self._banks_potential, tolerance_m,
                [area_ring(self.graph, a, tolerance_m) for a in islands],
                [self.graph.curves[self.graph.areas[a].curves[0][0]].potential
                 for a in islands]))
        return out

    # -- tiles ---------------------------------------------------------------------------------

    def tile_of(self, xy: np.ndarray, level: int | None = None) -> np.ndarray:
        """(N, 2) int tile indices (tx, ty) of points at ``level``; −1 outside the domain.

        The numpy twin of the query kernels' ownership rule (``kernels.flow.root_unit`` and
        ``tile_index``, bit for bit): the tile made for a point is the tile the kernels read
        for it, on every edge and corner and on the domain's far edge."""
        pts = self._points(xy)
        lv = self._level(level)
        t = self.tiles
        n = 1 << lv
        u = (pts - (t.root_x_m, t.root_y_m)) / t.root_size_m
        inside = np.all((u >= 0.0) & (u <= 1.0), axis=1)
        keys = np.minimum((np.where(inside[:, None], u, 0.0) * n).astype(np.int64), n - 1)
        keys[~inside] = -1
        return keys

    def level_for_spacing(self, spacing_m: float) -> int:
        """The coarsest quadtree level whose lattice spacing is at most ``spacing_m`` [m]
        (the finest level if none is): how a view picks coarser tiles far away."""
        if not spacing_m > 0.0:
            return self.max_level
        t = self.tiles
        level = math.ceil(math.log2(t.root_size_m / (t.n_cells * spacing_m)))
        return int(min(max(level, 0), self.max_level))

    def ensure_tiles(self, level: int, keys: Iterable[tuple[int, int]]) -> int:
        """Make sure tiles (tx, ty) of ``level`` are cached (produced now if not); returns the
        number produced. Raises ValueError if more are asked at once than the cache holds."""
        keys = list(dict.fromkeys((int(x), int(y)) for x, y in keys))
        t = self.tiles
        if len(keys) > t.capacity:
            raise ValueError(f"{len(keys)} tiles asked at once; the cache holds {t.capacity}")
        tick = t.cache.next_tick()
        codes = [tile_code(level, tx, ty) for tx, ty in keys]
        missing = set(t.pool.mark_used(np.array(codes, np.int64), tick).tolist())
        made = 0
        for code, (tx, ty) in zip(codes, keys):
            if code in missing and t.is_wet(level, tx, ty):
                t.cache.install(FLOW_KIND, code, self._builder.make(level, tx, ty))
                made += 1
        return made

    def clear_tiles(self) -> None:
        """Drop every cached tile (e.g. after editing the graph or the options)."""
        self.tiles.pool.clear()

    def detached(self, cache_tiles: int = 64) -> FlowField:
        """This field with a tile cache of its own (``cache_tiles`` tiles) and no obstacles
        nor flood hook, sharing everything else (the network, the wet-tile table, the lakes:
        read only): another thread may query it while the frames query this one (a cache
        and a tile builder are not to be shared between threads). Its tiles are the same
        tiles (a tile depends on its key and the network only), so it answers
        :meth:`potential` bit for bit as this field without obstacles."""
        twin = copy.copy(self)
        t = self.tiles
        tile_bytes = sum(f.nbytes for f in flow_fields(t.n_cells).values())
        twin.tiles = FlowTiles(t.quadtree, t.n_cells, t.max_level,
                               TileCache(int(cache_tiles) * tile_bytes), t.wet)
        twin._builder = TileBuilder(twin)
        twin._builder.lakes = self.lakes
        twin._obstacle_sets = {}
        twin.obstacles = _NO_OBSTACLES
        twin.discharge_scale = None
        return twin

    # -- internals -----------------------------------------------------------------------------

    def _level(self, level: int | None) -> int:
        if level is None:
            return self.max_level
        if isinstance(level, bool) or not isinstance(level, (int, np.integer)):
            raise TypeError(f"FlowField: level must be a whole number or None, got {level!r}")
        if not 0 <= int(level) <= self.max_level:
            raise ValueError(f"level must be in 0..{self.max_level}, got {level}")
        return int(level)

    @staticmethod
    def _points(xy: np.ndarray) -> np.ndarray:
        """(N, 2) float64 points, checked (riverflow._validate.as_points): a (2, N) array is
        an error, never read as other points. NaN / inf points pass: they answer
        OUTSIDE_DOMAIN (velocity 0, ψ NaN), so a bad value in a running world never stops a
        frame (SPEC §5)."""
        return as_points(xy, "FlowField: xy", finite=False)

    def _batches(self, pts: np.ndarray, level: int, missing: np.ndarray | None
                 ) -> Iterator[np.ndarray]:
        """Produce the tiles under ``pts[missing]`` and yield the point indices to query again.

        When they cover more tiles than the cache holds, the work goes tile batch by tile
        batch, each batch's tiles produced just before it is yielded.
        """
        sub = pts if missing is None else pts[missing]
        index = np.arange(len(pts)) if missing is None else missing
        keys = self.tile_of(sub, level)
        inside = keys[:, 0] >= 0
        n = 1 << level
        flat = keys[inside, 1] * n + keys[inside, 0]
        index = index[inside]
        unique = np.unique(flat)
        cap = self.tiles.capacity
        for start in range(0, len(unique), cap):
            batch = unique[start:start + cap]
            self.ensure_tiles(level, [(int(k % n), int(k // n)) for k in batch])
            yield index if len(unique) <= cap else index[np.isin(flat, batch)]


def _never_unknown(status: np.ndarray, pts: np.ndarray) -> None:
    """A query answers every point: UNKNOWN left after its tiles were made is a bug (the
    tiles made are not the ones the kernels read), never an answer."""
    lost = np.flatnonzero(status == FlowStatus.UNKNOWN)
    if len(lost):
        raise RuntimeError(f"FlowField: {len(lost)} point(s) found no flow tile after their "
                           f"tiles were made, first {pts[lost[0]].tolist()} (a tile-ownership "
                           "bug; please report it)")


class TileBuilder:
    """Scratch arrays to build flow tiles of one field; one per thread (kernels release the GIL)."""

    def __init__(self, field: FlowField) -> None:
        self.field = weakref.proxy(field)   # the field holds its own builder: no cycle, so a
        net = field.network                 # dropped world's tiles go with its last reference
        n = field.tiles.n_cells
        m = n + 1 + 2 * kf.LATTICE_RING
        self.psi_full = np.empty((m, m))
        self.inside_full = np.zeros((m, m), np.bool_)
        self.gval = np.empty(2 * max(net.n_groups, 1))   # ψ-groups' distances, then leads
        self.scratch = kf.TileScratch(self.gval, self.psi_full, self.inside_full,
                                      np.empty((n, n, kf.CELL_SEGMENTS)))
        self.blk = kf.BoxLists(np.empty(net.n_curves, np.int32), np.empty(net.n_curves, np.int32),
                               np.empty(net.n_curves, np.int32), np.empty(net.n_segments, np.int32),
                               np.empty(net.n_curves), np.empty(net.n_segments))
        self.lakes: list = list(getattr(field, "lakes", []))   # set by the field once solved

    def make(self, level: int, tx: int, ty: int) -> dict[str, np.ndarray]:
        """Tile (level, tx, ty) in fresh arrays, as the flow pool stores it."""
        n = self.field.tiles.n_cells
        psi = np.empty((n + 3, n + 3), np.float32)
        status = np.empty((n, n), np.uint8)
        segments = np.empty((n, n, kf.CELL_SEGMENTS), np.int32)
        shore = np.empty((n + 3, n + 3), np.float32)
        bank = np.empty((n + 3, n + 3), np.float32)
        inside = self.build(level, tx, ty, psi, status, segments, shore, bank)
        return {"psi": psi, "cell_status": status, "cell_segments": segments, "shore": shore,
                "bank": bank, "inside_points": np.int32(inside), "in_cut": np.uint8(0)}

    def build(self, level: int, tx: int, ty: int, psi: np.ndarray, cell_status: np.ndarray,
              cell_segments: np.ndarray, shore: np.ndarray | None = None,
              bank: np.ndarray | None = None) -> int:
        """Fill tile (level, tx, ty) into the given arrays (``shore``: the distance to the
        nearest shore at the lattice points, ``bank`` to the nearest bank, a basin's mouth
        counted, or None); returns its water lattice points."""
        f = self.field
        t = f.tiles
        n = t.n_cells
        if shore is None:
            shore = np.empty((n + 3, n + 3), np.float32)
        if bank is None:
            bank = np.empty((n + 3, n + 3), np.float32)
        inside = int(kf.build_flow_tile(
            t.root_x_m, t.root_y_m, t.spacing_m(level), n, tx * n, ty * n, f.network.arrays,
            f.slip, self.blk, self.scratch,
            kf.TileOut(psi, cell_status, cell_segments, shore, bank)))
        if self.lakes:
            self._lake_lattice(level, tx, ty, psi)
        return inside

    def _lake_lattice(self, level: int, tx: int, ty: int, psi: np.ndarray) -> None:
        """The lattice points of the tile in a lake take the lake's potential flow
        (:mod:`riverflow.hydro.lake_flow`); the ghosts are then extrapolated again."""
        t = self.field.tiles
        n = t.n_cells
        ring = kf.LATTICE_RING
        h = t.spacing_m(level)
        m = self.psi_full.shape[0]
        gi = tx * n - ring + np.arange(m)
        gj = ty * n - ring + np.arange(m)
        x0, y0 = t.root_x_m + gi[0] * h, t.root_y_m + gj[0] * h
        x1, y1 = t.root_x_m + gi[-1] * h, t.root_y_m + gj[-1] * h
        changed = False
        for lake in self.lakes:
            bx0, by0, bx1, by1 = lake.box_m
            if bx0 > x1 or bx1 < x0 or by0 > y1 or by1 < y0:
                continue
            v = lake.lattice_psi(gi, gj, h)
            use = self.inside_full & np.isfinite(v)
            if use.any():
                self.psi_full[use] = v[use]
                changed = True
        if changed:
            kf._extrapolate_ghosts(self.psi_full, self.inside_full, n, psi)
