"""Live edits of a running world's river network (issue 25, Proland's ``edit4``).

An edit is made in three steps:

1. **the new network** (:func:`edited_branches` for the finer calls, :func:`branches_of_input`
   for a whole builder or graph): a list of :class:`~riverflow.scenes.layout.RiverBranch` and
   the islands, built with the :class:`~riverflow.hydro.builder.RiverNetworkBuilder` (which
   rejects what cannot carry a flow: banks that cross, a branch turning back on itself, a
   junction that does not balance: :class:`~riverflow.hydro.graph.GraphError`) and made into a
   new :class:`~riverflow.scenes.landscape.Landscape` on the same height source, carving,
   quadtree and cell size (:func:`edited_scene`), with its own
   :class:`~riverflow.hydro.flow_field.FlowField` on the same quadtree, lattice spacing and
   flattening tolerance. Nothing of the running world is touched until all of it is made, so a
   bad edit leaves the world as it was.
2. **what changed** (:func:`plan_edit`): the water-surface samples whose position, level or
   width differ (per branch, by name) and the flow network's segments whose geometry, ψ or
   search radius differ. Each gives boxes [m] padded by how far such a change reaches: the
   carving's reach (or the water tiles' LEVEL_REACH_M, the larger) for the terrain kinds,
   each segment's own cut-off radius for the flow. The resident flow tiles keep their bank
   lists through an old → new segment index map (an untouched segment keeps its tiles).
3. **the swap** (:meth:`RiverWorld._apply_edit`, main thread, between frames): the scheduler
   takes the new producers and marks the resident tiles whose footprint meets the boxes as
   stale (:meth:`~riverflow.tiles.scheduler.TileScheduler.invalidate`): they stand in until
   their new versions, made in the background, replace them.

Everything here is plain numpy / shapely; nothing needs OpenGL.
"""
from __future__ import annotations

import copy
import math
import sys
import weakref
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from riverflow._validate import as_floats
from riverflow.hydro.builder import RiverNetworkBuilder
from riverflow.hydro.flow_field import FlowField
from riverflow.hydro.flow_network import FlowNetwork
from riverflow.hydro.graph import GraphError, HydroGraph
from riverflow.scenes.landscape import (FREEBOARD_M, CarvedTerrain, Landscape,
                                        branches_of_graph, water_surface, z_range)
from riverflow.scenes.layout import RiverBranch
from riverflow.scenes.tile_kinds import LEVEL_REACH_M
from riverflow.scenes.water import WaterSurface
from riverflow.tiles.memo import TileMemo

JUNCTION_SNAP_M = 1.0
"""A branch end this close to another branch's end (or a junction) meets it there."""
BOX_SAMPLES = 24
"""Water-surface samples per box of a changed branch (boxes follow a branch's bends)."""
EDGE_CELLS = 4
"""A tile's footprint is widened by this many of its own cells (its ψ ring, its normals'
ring, bicubic support) when it is tested against the changed boxes."""


@dataclass(eq=False)
class EditPlan:
    """A checked edit, ready to be swapped in (module docstring, step 2)."""

    scene: Landscape
    field: FlowField
    terrain_boxes: np.ndarray
    """(B, 4) xmin, ymin, xmax, ymax [m]: the terrain kinds' tiles meeting them are made again."""
    flow_boxes: np.ndarray
    """(F, 4): the flow tiles meeting them are made again."""
    segment_map: np.ndarray
    """(S_old,) int32: each old flow segment's index in the new network (a segment gone: the
    nearest new one, the tiles listing it being stale)."""
    changed: list[str] = field(default_factory=list)
    """Names of the branches whose water changed (added, moved, widened, removed)."""
    renumbered: tuple | None = None
    """(slots, their codes, their new bank lists): the flow tiles resident when the edit was
    planned, renumbered (:func:`renumbered_segments`) in the edit's thread."""
    renumbered_all: tuple | None = None
    """(slots, codes) of every flow tile resident when the edit was planned."""
    cell_network: object = None
    """The new network's cells for a running flood (:mod:`riverflow.hydro.spill_network`),
    None without one."""
    flood_router: object = None
    """A flood router on :attr:`cell_network` with its level's textures made (what the
    shaders draw the rise from and the particles are lifted by) as the old router had them
    (:meth:`RiverWorld.set_hydrograph` makes them), None otherwise: the swap carries the
    flood onto it."""
    spill_network: object = None
    """The new network's cells for the spills (their dispersion), None without spills."""
    dropped: list[str] = field(default_factory=list)
    """What the old network carried that the new one cannot (a fall or rapid whose branch
    was removed), in words."""
    marked_ahead: dict = field(default_factory=dict)
    """kind → (codes sorted, made again or not, rank): :func:`marked_tiles` for the tiles
    resident when the edit was planned, worked out in the edit's thread; the swap works out
    only the tiles installed since (:func:`marked_at_swap`)."""
    flow_changes: FlowChanges | None = None
    """The flow segments the edit changed: of the flow tiles meeting :attr:`flow_boxes`, only
    those that read one are made again (:func:`flow_tiles_reached`); None: all."""
    flow_ahead: dict = field(default_factory=dict)
    """code → flow tile: the view's flow tiles the edit makes wet (none resident when it was
    planned), made in the edit's thread with the new producer; the swap installs them (the
    frame after it would make them itself, in deterministic mode)."""

    @property
    def change_centres(self) -> np.ndarray:
        """(B, 2) [m]: the middles of the changed boxes (a stale tile's rank is its distance
        to the nearest)."""
        boxes = np.concatenate([self.terrain_boxes, self.flow_boxes])
        return 0.5 * (boxes[:, :2] + boxes[:, 2:])


# -- step 1: the new network ------------------------------------------------------------------


def _link_index(branches: list[RiverBranch], link, what: str) -> int:
    if isinstance(link, (int, np.integer)) and not isinstance(link, bool):
        if not -len(branches) <= int(link) < len(branches):
            raise ValueError(f"{what}: no branch {int(link)} (the scene has {len(branches)})")
        return int(link) % len(branches)
    if isinstance(link, str):
        for k, b in enumerate(branches):
            if b.name == link:
                return k
        names = ", ".join(b.name for b in branches)
        raise ValueError(f"{what}: no branch named {link!r} (the scene has {names})")
    raise TypeError(f"{what}: link must be a branch name or index, got {type(link).__name__} "
                    f"{link!r:.80}")


def _points(points, what: str) -> np.ndarray:
    pts = as_floats(points, f"{what}: points")
    if pts.ndim != 2 or pts.shape[1] != 2 or len(pts) < 2:
        raise ValueError(f"{what}: points must be (K ≥ 2, 2) [m], got shape {pts.shape}")
    if not np.isfinite(pts).all():
        bad = int(np.flatnonzero(~np.isfinite(pts).all(axis=1))[0])
        raise ValueError(f"{what}: point {bad} is not finite: {pts[bad].tolist()}")
    return pts


def _widths(widths, k: int, what: str) -> np.ndarray:
    w = as_floats(widths, f"{what}: widths")
    if w.ndim == 0:
        w = np.full(k, float(w))
    if w.shape != (k,):
        raise ValueError(f"{what}: widths must be one number or one per centre-line point "
                         f"({k}), got shape {w.shape}")
    if not (np.isfinite(w).all() and (w > 0).all()):
        bad = int(np.flatnonzero(~(np.isfinite(w) & (w > 0)))[0])
        raise ValueError(f"{what}: width {bad} must be a finite number > 0 [m], got {w[bad]!r}")
    return w


def _arc_fraction(line: np.ndarray) -> np.ndarray:
    s = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(line, axis=0).T))])
    return s / s[-1] if s[-1] > 0 else np.linspace(0.0, 1.0, len(line))


def edited_branches(scene: Landscape, op: str, link=None, **args) -> list[RiverBranch]:
    """The scene's branches after one finer edit (copies; the scene is not changed):

    * ``"width"``: ``widths`` (one number or one per centre-line point) [m];
    * ``"axis"``: ``points`` (K, 2) [m], the new centre line drawn downstream; an end that
      meets a junction must stay there; ``widths`` (optional: else the old ones, each point's
      its own where the line keeps its number of points, else carried along the arc length);
    * ``"add"``: ``points``, ``widths``, ``discharge_m2s`` (needed for a source), ``name``;
    * ``"remove"``: the branch ``link``.

    Raises ValueError / TypeError naming the call and what is wrong with its arguments (the
    network itself is checked by the builder: :func:`edited_scene`)."""
    branches = [copy.copy(b) for b in scene.branches]
    what = {"width": "set_width", "axis": "move_axis", "add": "add_branch",
            "remove": "remove_branch"}[op]
    if op == "add":
        pts = _points(args["points"], what)
        w = _widths(args["widths"], len(pts), what)
        q = args.get("discharge_m2s")
        if q is not None and not (math.isfinite(float(q)) and float(q) > 0):
            raise ValueError(f"{what}: discharge_m2s must be a finite number > 0, got {q!r}")
        name = args.get("name") or f"branch_{len(branches)}"
        if any(b.name == name for b in branches):
            raise ValueError(f"{what}: a branch named {name!r} exists already")
        branches.append(RiverBranch(str(name), pts, w, None if q is None else float(q),
                                    "tributary", -1, -1))
        return _renumber_junctions(branches)
    k = _link_index(branches, link, what)
    b = branches[k]
    if op == "width":
        b.widths_m = _widths(args["widths"], len(b.centerline_m), what)
    elif op == "axis":
        pts = _points(args["points"], what)
        for end, j, old in (("start", b.start_junction, b.centerline_m[0]),
                            ("end", b.end_junction, b.centerline_m[-1])):
            new = pts[0] if end == "start" else pts[-1]
            if j >= 0 and float(np.hypot(*(new - old))) > JUNCTION_SNAP_M:
                raise ValueError(f"{what}: branch {b.name!r}'s {end} is at a junction "
                                 f"({old[0]:.1f}, {old[1]:.1f}) m; the new centre line must "
                                 f"keep it there, got ({new[0]:.1f}, {new[1]:.1f})")
        if b.start_junction >= 0:
            pts[0] = b.centerline_m[0]
        if b.end_junction >= 0:
            pts[-1] = b.centerline_m[-1]
        if args.get("widths") is not None:
            b.widths_m = _widths(args["widths"], len(pts), what)
        elif len(pts) != len(b.centerline_m):
            b.widths_m = np.interp(_arc_fraction(pts), _arc_fraction(b.centerline_m),
                                   b.widths_m)
        # else each point keeps its width (a drag moves points): the water beyond the
        # points moved stays as it was
        b.centerline_m = pts
    elif op == "remove":
        del branches[k]
        if not branches:
            raise ValueError(f"{what}: {b.name!r} is the scene's last branch")
    return _renumber_junctions(branches)


def _renumber_junctions(branches: list[RiverBranch]) -> list[RiverBranch]:
    """Junctions from the branch ends that meet (within JUNCTION_SNAP_M): the ones that stay
    keep their order, new ones come after, and a junction left with one branch is a free end."""
    ends = []
    for k, b in enumerate(branches):
        ends.append((k, 0, b.centerline_m[0], b.start_junction))
        ends.append((k, 1, b.centerline_m[-1], b.end_junction))
    groups: list[list[int]] = []
    for e, (_, _, p, _) in enumerate(ends):
        for g in groups:
            if float(np.hypot(*(ends[g[0]][2] - p))) <= JUNCTION_SNAP_M:
                g.append(e)
                break
        else:
            groups.append([e])
    groups = [g for g in groups if len(g) >= 2]
    old = [min([ends[e][3] for e in g if ends[e][3] >= 0], default=1 << 30) for g in groups]
    order = sorted(range(len(groups)), key=lambda i: (old[i], i))
    number = {i: n for n, i in enumerate(order)}
    for b in branches:
        b.start_junction = b.end_junction = -1
    for i, g in enumerate(groups):
        for e in g:
            k, side, _, _ = ends[e]
            if side == 0:
                branches[k].start_junction = number[i]
            else:
                branches[k].end_junction = number[i]
    return branches


def branches_of_input(builder_or_graph) -> tuple[list[RiverBranch], list[np.ndarray], HydroGraph,
                                                 RiverNetworkBuilder | None]:
    """A whole new network: a :class:`RiverNetworkBuilder` (built here) or a
    :class:`HydroGraph`, as branches (:func:`~riverflow.scenes.landscape.branches_of_graph`)."""
    if isinstance(builder_or_graph, RiverNetworkBuilder):
        graph = builder_or_graph.build()
        polygon = builder_or_graph.water_polygon
    elif isinstance(builder_or_graph, HydroGraph):
        from riverflow.hydro.areas import water_polygon

        graph = builder_or_graph
        polygon = water_polygon(graph)
    else:
        raise TypeError("edit_network: needs a RiverNetworkBuilder or a HydroGraph, got "
                        f"{type(builder_or_graph).__name__}")
    if polygon is None or polygon.is_empty:
        raise GraphError("edit_network: the new network holds no water")
    return branches_of_graph(graph, polygon), [], graph, None


def fill_discharges(scene: Landscape, field: FlowField) -> None:
    """Give the scene's branches without a discharge (a landscape made from a graph) the ψ
    difference across their middle section, from the banks themselves (no tile is made: any
    thread may call it), so the builder can rebuild the network."""
    from riverflow.hydro.flow_field import TileBuilder
    from riverflow.hydro.spill_network import section_discharge_m2s
    from riverflow.kernels import flow as kf

    missing = [b for b in scene.branches if b.discharge_m2s is None]
    if not missing:
        return
    builder = TileBuilder(field)

    def potential(xy):
        pts = np.ascontiguousarray(np.asarray(xy, np.float64).reshape(-1, 2))
        psi = np.empty(len(pts))
        kf.evaluate_potential(pts, psi, field.network.arrays, field.slip, builder.blk,
                              builder.gval)
        return psi
    for b in missing:
        b.discharge_m2s = float(section_discharge_m2s(potential, b.centerline_m, b.widths_m))


@dataclass(frozen=True)
class Carried:
    """What a network carries besides its branches and islands, kept by an edit of its
    branches (:func:`carried_by`): its lakes and the falls and rapids placed by hand."""

    lakes: tuple = ()
    """((polygon, the builder's level [m] or None, the water surface's level [m]), …)."""
    falls: tuple = ()
    """((branch name, lip's fraction of the branch's length, drop [m], lip [m] or None (the
    river's width), kind), …): a fall moves with its branch (same fraction along it)."""
    rapids: tuple = ()
    """((branch name, start fraction, end fraction, drop [m]), …)."""
    lost: tuple = ()
    """Falls and rapids no branch of the scene lies under, in words (not kept)."""


def _arc_length(line: np.ndarray) -> float:
    return float(np.hypot(*np.diff(line, axis=0).T).sum())


def carried_by(scene: Landscape) -> Carried:
    """The lakes (their outline in the graph, their level) and the falls and rapids given by
    hand (not found in water levels: ``in_levels``) of ``scene``'s network, by the scene's
    branch under them and their fraction of its length."""
    import shapely

    from riverflow.hydro.areas import area_ring

    graph = scene.graph
    lakes = []
    for a in graph.lakes():
        poly = shapely.Polygon(area_ring(graph, a))
        given = graph.areas[a].level_m
        at = np.asarray(poly.representative_point().coords, np.float64)
        surface = float(given) if given is not None else float(scene.water.level(at)[0])
        lakes.append((poly, given, surface))
    lines = [shapely.LineString(b.centerline_m) for b in scene.branches]

    def along(points) -> tuple[str | None, list[float]]:
        """The scene's branch nearest the points (a scene made from a graph names its branches
        after the graph's axes, not the builder's names) and their fractions along it."""
        pts = shapely.points(np.asarray(points, np.float64))
        k = int(np.argmin([shapely.distance(line, pts).max() for line in lines]))
        b = scene.branches[k]
        if shapely.distance(lines[k], pts).max() > 0.5 * float(b.widths_m.max()):
            return None, []
        return b.name, list(shapely.line_locate_point(lines[k], pts, normalized=True))

    falls, rapids, lost = [], [], []
    for f in graph.falls:
        if not f.in_levels:
            name, (at,) = along([f.centre_m]) if lines else (None, [0.0])
            lip = f.lip_m if f.lip_m < f.width_m * (1.0 - 1e-6) else None
            if name is None:
                lost.append(f"the {f.kind} on {f.branch!r} (no branch of the scene under it)")
            else:
                falls.append((name, float(at), f.drop_m, lip, f.kind))
    for r in graph.rapids:
        if not r.in_levels:
            name, ends = along([r.start_m, r.end_m]) if lines else (None, [])
            if name is None:
                lost.append(f"the rapid on {r.branch!r} (no branch of the scene under it)")
            else:
                rapids.append((name, float(min(ends)), float(max(ends)), r.drop_m))
    return Carried(tuple(lakes), tuple(falls), tuple(rapids), tuple(lost))


def _in_lake(b: RiverBranch, lakes) -> bool:
    """A branch lying in a lake (the dam scene's ``reservoir``: the water surface's samples
    there, not a river for the builder, which cuts what enters a lake at its shore)."""
    import shapely

    line = shapely.LineString(b.centerline_m)
    return any(line.within(poly.buffer(JUNCTION_SNAP_M)) for poly, _, _ in lakes)


def _through_lakes(branches: list[RiverBranch], in_lake: list[bool]) -> dict:
    """The rivers through a lake (the dam scene's, :func:`~riverflow.scenes.default.
    cut_at_lake`: a branch into the lake's shore, one in it, one out of it) joined again as
    the builder was given them: {the outlet's name: (the inlet branch, (its centre line
    through the lake to the outlet's end, widths: the lake's part between the mouths'))}."""
    joined = {}
    for k, lake in enumerate(in_lake):
        b = branches[k]
        if not lake or b.start_junction < 0 or b.end_junction < 0:
            continue
        up = [x for x in branches if x.end_junction == b.start_junction]
        down = [x for x in branches if x.start_junction == b.end_junction]
        if len(up) != 1 or len(down) != 1:
            continue
        up, down = up[0], down[0]
        w_in = np.interp(_arc_fraction(b.centerline_m), [0.0, 1.0],
                         [up.widths_m[-1], down.widths_m[0]])
        line = np.vstack([up.centerline_m, b.centerline_m[1:], down.centerline_m[1:]])
        widths = np.r_[up.widths_m, w_in[1:], down.widths_m[1:]]
        keep = np.r_[True, np.hypot(*np.diff(line, axis=0).T) > 1e-9]
        joined[down.name] = (up, (line[keep], widths[keep]))
    return joined


def _build(branches: list[RiverBranch], islands, tolerance_m: float,
           carried: Carried = Carried()) -> tuple[HydroGraph, RiverNetworkBuilder, list[str]]:
    """The network of ``branches`` with ``carried``'s lakes, falls and rapids; also what of
    them could not be kept (a fall on a branch gone), in words."""
    builder = RiverNetworkBuilder(tolerance_m=tolerance_m)
    in_lake = [_in_lake(b, carried.lakes) for b in branches]
    built = [b for b, lake in zip(branches, in_lake) if not lake]
    through = _through_lakes(branches, in_lake)
    sources = {b.end_junction for b in built if b.end_junction >= 0}
    for b in built:
        if b.name in through:      # (a river through a lake: given whole, as it was built)
            continue
        line, widths = b.centerline_m, b.widths_m
        outlet = next((o for o, (up, _) in through.items() if up is b), None)
        if outlet is not None:
            line, widths = through[outlet][1]
        # a branch below a junction takes what flows into it (the builder splits it by width)
        fed = b.start_junction >= 0 and b.start_junction in sources
        builder.add_branch(line, widths, None if fed else b.discharge_m2s, name=b.name)
    built = [b for b in built if b.name not in through]
    for outline in islands:
        builder.add_island(outline)
    for poly, level, _ in carried.lakes:
        builder.add_lake(poly, level)
    dropped = list(carried.lost)
    by_name = {b.name: b for b in built}
    for name, at, drop, lip, kind in carried.falls:
        b = by_name.get(name)
        if b is None:
            dropped.append(f"the {kind} {at:.0%} along {name!r} (its branch is gone)")
            continue
        arc = np.r_[0.0, np.cumsum(np.hypot(*np.diff(b.centerline_m, axis=0).T))]
        station = at * arc[-1]
        if lip is not None:               # a lip given: no longer than the river is wide now
            lip = min(lip, 0.999 * float(np.interp(station, arc, b.widths_m)))
        builder.add_fall(station, drop, branch=name, lip_m=lip, kind=kind)
    for name, a, e, drop in carried.rapids:
        b = by_name.get(name)
        if b is None:
            dropped.append(f"the rapid {a:.0%}–{e:.0%} along {name!r} (its branch is gone)")
            continue
        n = _arc_length(b.centerline_m)
        builder.add_rapids(a * n, e * n, drop, branch=name)
    graph = builder.build()
    for b, q in zip(built, builder.discharges_m2s):
        b.discharge_m2s = q
    for name, (up, _) in through.items():      # through a lake: what comes in goes out
        for b in branches:
            if b.name == name or (b.start_junction == up.end_junction and b is not up):
                b.discharge_m2s = up.discharge_m2s
    return graph, builder, dropped


def edited_scene(scene: Landscape, branches: list[RiverBranch], islands=None,
                 graph: HydroGraph | None = None, dropped: list[str] | None = None
                 ) -> tuple[Landscape, HydroGraph]:
    """A landscape like ``scene`` (height source, carving, quadtree, cell size, seed) over the
    network of ``branches`` (built here unless ``graph`` is given: then with ``scene``'s
    lakes, falls and rapids, :func:`carried_by`; what cannot be kept is appended to
    ``dropped``) with its own, empty tile memo. Its lakes are flat at their old level (a
    new graph's: at their given level, else the old one where a lake was). Raises
    :class:`GraphError` for a network that cannot carry a flow."""
    import shapely

    from riverflow.hydro.areas import area_ring, basin_mouth

    islands = scene.islands if islands is None else islands
    carried = carried_by(scene)
    if graph is None:
        graph, builder, lost = _build(branches, islands, getattr(scene, "tolerance_m", 0.25),
                                      carried)
        polygon = builder.water_polygon
        if dropped is not None:
            dropped.extend(lost)
    else:
        from riverflow.hydro.areas import water_polygon

        polygon = water_polygon(graph)
    lakes = []
    for a in graph.lakes():
        poly = shapely.Polygon(area_ring(graph, a))
        level = graph.areas[a].level_m
        if level is None:                  # the old level of the lake it overlaps most
            over = [(poly.intersection(p).area, z) for p, _, z in carried.lakes]
            best = max(over, default=(0.0, None))
            level = best[1] if best[0] > 0.5 * poly.area else None
        lakes.append((poly, level, basin_mouth(graph, a)))
    ground = scene.profile_ground or _LevelGround(scene.water)
    old = scene.terrain
    water = water_surface(branches, ground, polygon, graph.falls, graph.rapids, lakes)
    terrain = CarvedTerrain(old.source, water, old.carving, old.quadtree, old.cell_m,
                            old.tile_cells, old.source_tiles)    # (the source is the same)
    lo, hi = z_range(old.source, water, old.carving)
    new = Landscape(graph, terrain, water, scene.bounds_m, scene.seed, branches, list(islands),
                    (min(lo, scene.z_range_m[0]), max(hi, scene.z_range_m[1])),
                    TileMemo(scene.tile_memo.budget_bytes / 1e6), scene.profile_ground)
    return new, graph


@dataclass(frozen=True)
class _LevelGround:
    """A scene without its profiles' ground: its water level + FREEBOARD_M (so its untouched
    branches keep their levels, up to the profiles' smoothing)."""

    water: WaterSurface

    def __call__(self, xy: np.ndarray) -> np.ndarray:
        return np.asarray(self.water.level(xy), np.float64) + FREEBOARD_M


def edited_field(old: FlowField, graph: HydroGraph) -> FlowField:
    """The flow of ``graph`` on ``old``'s quadtree, lattice spacing, tolerance and cache (so an
    untouched segment is flattened alike and its tiles are the same tiles)."""
    t = old.tiles
    field = FlowField(graph, old.slip, old.search_radius_factor,
                      potential_delta_m=t.spacing_m(old.max_level),
                      lattice_cells=t.n_cells, domain_m=(t.root_x_m, t.root_y_m, t.root_size_m),
                      tolerance_m=old.tolerance_m, cache=t.cache)
    if field.max_level != old.max_level:      # cannot happen with the same spacing; guarded
        raise GraphError(f"the edited flow's finest level {field.max_level} is not the "
                         f"running one's {old.max_level}")
    field.discharge_scale = old.discharge_scale
    field._obstacle_sets = dict(old._obstacle_sets)
    field.obstacles = old.obstacles
    return field


# -- step 2: what changed ---------------------------------------------------------------------


def plan_edit(old_scene: Landscape, old_field: FlowField, new_scene: Landscape,
              new_field: FlowField) -> EditPlan:
    """What the edit changes (module docstring, step 2)."""
    reach = max(old_scene.terrain.carving.reach_m, LEVEL_REACH_M)
    boxes, changed = _water_boxes(old_scene.water, old_scene.branches, new_scene.water,
                                  new_scene.branches, reach)
    if reach > LEVEL_REACH_M and len(boxes):
        # the carving's far reach changes the ground by centimetres: only where the heights
        # actually differ (on a coarse grid) is made again; the water kinds' level reach stays
        level, _ = _water_boxes(old_scene.water, old_scene.branches, new_scene.water,
                                new_scene.branches, LEVEL_REACH_M)
        boxes = np.concatenate([level, _height_change_boxes(old_scene.terrain,
                                                            new_scene.terrain, boxes)])
    seg_map, flow_boxes, flow_changes = _segment_changes(old_field.network, new_field.network)
    return EditPlan(new_scene, new_field, boxes, flow_boxes, seg_map, changed,
                    flow_changes=flow_changes)


HEIGHT_CHANGE_M = 0.02
"""A terrain change smaller than this [m] (compared on a grid of HEIGHT_GRID_M) leaves the
resident terrain tiles as they are (deviation E2)."""
HEIGHT_GRID_M = 32.0


def _height_change_boxes(old: CarvedTerrain, new: CarvedTerrain, boxes: np.ndarray
                         ) -> np.ndarray:
    """Boxes [m] (one per grid cell, merged) around the points of a HEIGHT_GRID_M grid over
    ``boxes`` where the old and new terrain differ by more than HEIGHT_CHANGE_M."""
    s = HEIGHT_GRID_M
    lo = np.floor(boxes[:, :2].min(axis=0) / s).astype(np.int64)
    hi = np.ceil(boxes[:, 2:].max(axis=0) / s).astype(np.int64)
    gx, gy = np.meshgrid(np.arange(lo[0], hi[0] + 1), np.arange(lo[1], hi[1] + 1))
    ij = np.column_stack([gx.ravel(), gy.ravel()])      # on one grid for every edit
    p = ij * s
    inside = np.zeros(len(p), bool)
    for b in boxes:
        inside |= (p[:, 0] >= b[0]) & (p[:, 0] <= b[2]) & (p[:, 1] >= b[1]) & (p[:, 1] <= b[3])
    p, ij = p[inside], ij[inside]
    if not len(p):
        return np.zeros((0, 4))
    keys = (ij[:, 0] << 32) + (ij[:, 1] & 0xFFFFFFFF)
    moved = p[np.abs(_grid_heights(new, p, keys) - _grid_heights(old, p, keys))
              > HEIGHT_CHANGE_M]
    # a grid cell of changed points widened by one spacing (a change between points is seen)
    return _merge_boxes(np.hstack([moved - s, moved + s]))


_GRID_HEIGHTS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()
"""terrain → (sorted grid keys, heights [m]): the heights :func:`_height_change_boxes`
computed on a terrain, kept while it lives (the next edit of a drag compares against them:
half the grid's cost)."""
GRID_HEIGHTS_KEPT = 1 << 20


def _grid_heights(terrain: CarvedTerrain, p: np.ndarray, keys: np.ndarray) -> np.ndarray:
    """``terrain.height(p)`` at HEIGHT_GRID_M grid points (their ``keys``), those computed
    before on this terrain read back."""
    known_keys, known = _GRID_HEIGHTS.get(terrain, (np.zeros(0, np.int64), np.zeros(0)))
    at = np.minimum(np.searchsorted(known_keys, keys), max(len(known_keys) - 1, 0))
    hit = known_keys[at] == keys if len(known_keys) else np.zeros(len(keys), bool)
    z = np.empty(len(keys))
    z[hit] = known[at[hit]]
    miss = ~hit
    if miss.any():
        z[miss] = terrain.height(p[miss])
        all_keys = np.concatenate([known_keys, keys[miss]])
        if len(all_keys) <= GRID_HEIGHTS_KEPT:
            order = np.argsort(all_keys, kind="stable")
            _GRID_HEIGHTS[terrain] = (all_keys[order], np.concatenate([known, z[miss]])[order])
    return z


def _branch_samples(water: WaterSurface, k: int) -> np.ndarray:
    rows = water.branch == k
    return np.column_stack([water.samples_m[rows], water.levels_m[rows], water.widths_m[rows]])


def _water_boxes(old: WaterSurface, old_branches, new: WaterSurface, new_branches,
                 reach_m: float) -> tuple[np.ndarray, list[str]]:
    old_k = {b.name: k for k, b in enumerate(old_branches)}
    new_k = {b.name: k for k, b in enumerate(new_branches)}
    boxes, changed = [], []
    for name in list(old_k) + [n for n in new_k if n not in old_k]:
        a = _branch_samples(old, old_k[name]) if name in old_k else np.zeros((0, 4))
        b = _branch_samples(new, new_k[name]) if name in new_k else np.zeros((0, 4))
        if a.shape == b.shape and np.array_equal(a, b):
            continue
        changed.append(name)
        # the samples both have from the start and to the end are the same water: only
        # those between (and their neighbours) changed (a drag of a few points)
        head, tail = _same_ends(a, b)
        a = a[max(head - 1, 0):len(a) - max(tail - 1, 0)]
        b = b[max(head - 1, 0):len(b) - max(tail - 1, 0)]
        for rows in (a, b):
            for s in range(0, len(rows), BOX_SAMPLES):
                chunk = rows[s:s + BOX_SAMPLES + 1]
                pad = reach_m + 0.5 * float(chunk[:, 3].max())
                lo, hi = chunk[:, :2].min(axis=0) - pad, chunk[:, :2].max(axis=0) + pad
                boxes.append([lo[0], lo[1], hi[0], hi[1]])
    return np.array(boxes, np.float64).reshape(-1, 4), changed


def _same_ends(a: np.ndarray, b: np.ndarray) -> tuple[int, int]:
    """How many rows ``a`` and ``b`` have equal from their starts, and from their ends (the
    two not overlapping in the shorter)."""
    n = min(len(a), len(b))
    if n == 0:
        return 0, 0
    head = np.flatnonzero(np.any(a[:n] != b[:n], axis=1))
    head = int(head[0]) if len(head) else n
    tail = np.flatnonzero(np.any(a[len(a) - n:][::-1] != b[len(b) - n:][::-1], axis=1))
    tail = int(tail[0]) if len(tail) else n
    return head, min(tail, n - head)


def _segment_rows(net: FlowNetwork) -> tuple[np.ndarray, np.ndarray]:
    """Per segment: a key of everything a flow tile reads of it (ends, curve kind, half width,
    cut-off, ψ) and its cut-off radius [m]."""
    n = net.n_segments
    curve = np.repeat(np.arange(net.n_curves), (net.curve_seg1 - net.curve_seg0).astype(np.int64))
    if len(curve) != n:         # segments not covered by a curve (none expected): keyed alone
        curve = np.resize(curve, n)
    psi = net.segment_psi()
    rows = np.column_stack([net.seg_ax, net.seg_ay, net.seg_bx, net.seg_by,
                            net.curve_kind[curve].astype(np.float64), net.curve_hw2[curve],
                            net.curve_cutoff[curve], psi])
    rows = np.where(np.isnan(rows), np.inf, rows)     # NaN ψ (axes, caps) keys alike
    return np.ascontiguousarray(rows), np.asarray(net.curve_cutoff[curve], np.float64)


def _segment_changes(old: FlowNetwork, new: FlowNetwork
                     ) -> tuple[np.ndarray, np.ndarray, FlowChanges]:
    """The old → new segment map, the boxes of the segments that changed and what they are
    (:class:`FlowChanges`). A segment gone maps to the nearest new segment (by midpoint):
    the flow tiles that list it are near the change, so they stand in (stale) until they are
    made again, and a stand-in's inside test near the moved bank reads a bank nearby rather
    than a number past the new list."""
    from scipy.spatial import cKDTree

    a, cut_a = _segment_rows(old)
    b, cut_b = _segment_rows(new)
    index = {row.tobytes(): i for i, row in enumerate(b)}
    seg_map = np.array([index.get(row.tobytes(), -1) for row in a], np.int32)
    kept = np.zeros(len(b), bool)
    kept[seg_map[seg_map >= 0]] = True
    gone = seg_map < 0
    boxes = []
    for rows, cut in ((a[gone], cut_a[gone]), (b[~kept], cut_b[~kept])):
        if len(rows):
            lo = np.minimum(rows[:, :2], rows[:, 2:4]) - cut[:, None]
            hi = np.maximum(rows[:, :2], rows[:, 2:4]) + cut[:, None]
            boxes.append(np.hstack([lo, hi]))
    boxes = np.concatenate(boxes) if boxes else np.zeros((0, 4))
    boxes = _merge_boxes(boxes)
    changes = _flow_changes([(old, ~gone), (new, kept)], boxes)
    if gone.any() and len(b):
        _, near = cKDTree(0.5 * (b[:, :2] + b[:, 2:4])).query(0.5 * (a[gone, :2] + a[gone, 2:4]))
        seg_map[gone] = near
    return seg_map, boxes, changes


class FlowChanges(NamedTuple):
    """The flow network's segments an edit changed (those gone from the old network and
    those new in the new one), for :func:`flow_tiles_reached`.

    A flow tile reads a bank segment only through its ψ-group's nearest segment at each of
    its points (the ψ weighting, the inside test, the shore's distance; the boundary cells'
    lists hold segments within a cell's diagonal): where, everywhere in the tile, a segment
    the edit kept is nearer than every changed segment of the group, old and new, the tile
    comes out as it was. An axis is read within its half width (which network a point is
    in); a cap, and a bank of a network with a basin's mouth (whose shore's distance skips
    the mouth's group), within its cut-off radius."""

    reached: list
    """(changed segments, reach [m]): a tile that comes within ``reach`` of one is made
    again; changed segments as a :class:`~riverflow.hydro.nearest.PolylineIndex` of
    two-point lines."""
    groups: list
    """(changed segments, kept segments or None, cut-off [m]) per ψ-group of a changed bank
    segment: the group's segments the edit changed and those it kept within the changed
    boxes (None: none)."""


TIE_MARGIN = 1e-3
"""A kept segment counts as nearer than a changed one where it is nearer by this share
(and a millimetre): well past the kernel's tie rule (_TIE, on squared distances)."""


def _segment_lines(ends: np.ndarray):
    """Segments (S, 4) as a :class:`~riverflow.hydro.nearest.PolylineIndex` of two-point
    lines."""
    from riverflow.hydro.nearest import PolylineIndex

    return PolylineIndex(ends.reshape(-1, 2), np.repeat(np.arange(len(ends)), 2))


def _flow_changes(networks, boxes: np.ndarray) -> FlowChanges:
    """:class:`FlowChanges` of (network, kept (S,) bool) pairs (the old network with the
    segments it keeps, the new one with those it kept); ``boxes`` (B, 4) [m] hold every
    changed segment's cut-off reach."""
    from riverflow.kernels.flow import KIND_AXIS, KIND_BANK, NEAR_BOX_SLACK, OPEN_BANK

    reached: dict[float, list] = {}
    groups: dict[tuple, list] = {}
    for which, (net, kept) in enumerate(networks):
        changed = np.flatnonzero(~kept)
        if not len(changed):
            continue
        curve = np.repeat(np.arange(net.n_curves),
                          (net.curve_seg1 - net.curve_seg0).astype(np.int64))
        kind = net.curve_kind[curve]
        ends = np.column_stack([net.seg_ax, net.seg_ay, net.seg_bx, net.seg_by])
        mouths = np.unique(net.curve_comp[(net.curve_kind == KIND_BANK)
                                          & (net.curve_hw2 == OPEN_BANK)])
        c = curve[changed]
        by_group = (kind[changed] == KIND_BANK) & ~np.isin(net.curve_comp[c], mouths)
        hw = np.sqrt(net.curve_hw2[c] * (1.0 + NEAR_BOX_SLACK) + NEAR_BOX_SLACK)
        reach = np.where(kind[changed] == KIND_AXIS, hw * (1.0 + TIE_MARGIN) + 1e-3,
                         net.curve_cutoff[c])
        for r in np.unique(reach[~by_group]):
            reached.setdefault(float(r), []).append(ends[changed[~by_group & (reach == r)]])
        seg_group = net.curve_group[curve]
        touched = np.unique(seg_group[changed[by_group]])
        near = np.flatnonzero(kept & (kind == KIND_BANK) & np.isin(seg_group, touched))
        seg = ends[near]
        near = near[_rects_meeting(np.hstack([np.minimum(seg[:, :2], seg[:, 2:]),
                                              np.maximum(seg[:, :2], seg[:, 2:])]), boxes)]
        for g in touched:
            mine = changed[by_group & (seg_group[changed] == g)]
            others = near[seg_group[near] == g]
            groups[(which, int(g))] = [
                _segment_lines(ends[mine]),
                _segment_lines(ends[others]) if len(others) else None,
                float(net.curve_cutoff[curve[mine]].min())]
    return FlowChanges([(_segment_lines(np.concatenate(e)), r) for r, e in reached.items()],
                       [tuple(v) for v in groups.values()])


FLOW_READ_CELLS = 8
"""How far beyond its footprint a flow tile reads the banks, in its cells: its ψ ring
(LATTICE_RING), ψ mirrored across a cap from there (three cells more) and the boundary
cells' lists (a cell's diagonal), rounded up."""


FLOW_SPLITS = 2
"""A flow tile's bounds are tried on its square, then on its quarters where they fail, down
to (2^FLOW_SPLITS)² squares: a bound from a square's centre is loose by twice its
half-diagonal (the 4 km scene's edits: 37 flow tiles within the changed boxes, 27 made
again with no split, 26 with two splits or more, 14 of them changed)."""


def flow_tiles_reached(changes: FlowChanges, codes: np.ndarray, quadtree, cells: int
                       ) -> np.ndarray:
    """(K,) bool: the flow tiles of ``codes`` that may read a changed segment
    (:class:`FlowChanges`): one within its reach of a point the tile reads (its footprint
    widened by FLOW_READ_CELLS), or within its cut-off where its ψ-group's nearest kept
    segment is not nearer. Bounds from a square's centre (± its half-diagonal), on the
    tile's square and where they fail on its quarters (FLOW_SPLITS times)."""
    codes = np.asarray(codes, np.int64)
    if not len(codes) or not (changes.reached or changes.groups):
        return np.zeros(len(codes), bool)
    centre, size = _tile_centres(codes, quadtree)
    side = size * (1.0 + 2.0 * FLOW_READ_CELLS / cells)
    owner = np.arange(len(codes))
    for split in range(FLOW_SPLITS + 1):
        fails = _square_reads(changes, centre, 0.5 * np.sqrt(2.0) * side)
        owner, centre, side = owner[fails], centre[fails], side[fails]
        if split == FLOW_SPLITS or not len(owner):
            break
        centre = (centre[:, None, :] + 0.25 * side[:, None, None] * QUARTERS).reshape(-1, 2)
        owner, side = np.repeat(owner, 4), np.repeat(0.5 * side, 4)
    out = np.zeros(len(codes), bool)
    out[owner] = True
    return out


QUARTERS = np.array([[-1.0, -1.0], [1.0, -1.0], [-1.0, 1.0], [1.0, 1.0]])
"""A square's quarters' centres from its own, in quarters of its side."""


def _square_reads(changes: FlowChanges, centre: np.ndarray, half: np.ndarray) -> np.ndarray:
    """(K,) bool: squares (centres (K, 2), half-diagonals (K,) [m]) where a point may read a
    changed segment (:func:`flow_tiles_reached`)."""
    out = np.zeros(len(centre), bool)
    for line, reach in changes.reached:
        out |= line.distance(centre) - half < reach
    for changed, kept, cut in changes.groups:
        ask = np.flatnonzero(~out)
        if not len(ask):
            break
        near = changed.distance(centre[ask]) - half[ask]         # the changed: no nearer
        ask, near = ask[near < cut], near[near < cut]
        hi = (kept.distance(centre[ask]) if kept is not None
              else np.full(len(ask), np.inf)) + half[ask]       # a kept one: no farther
        out[ask] = ~((hi < cut) & (near > hi * (1.0 + TIE_MARGIN) + 1e-3))
    return out


def _merge_boxes(boxes: np.ndarray, limit: int = 512) -> np.ndarray:
    """At most ``limit`` boxes covering ``boxes`` (consecutive ones merged: segments of a curve
    are consecutive, so the merged boxes still follow the river)."""
    if len(boxes) <= limit:
        return boxes
    starts = np.arange(0, len(boxes), -(-len(boxes) // limit))
    return np.hstack([np.minimum.reduceat(boxes[:, :2], starts, axis=0),
                      np.maximum.reduceat(boxes[:, 2:], starts, axis=0)])


def renumbered_segments(segments: np.ndarray, slots: np.ndarray, seg_map: np.ndarray
                        ) -> tuple[np.ndarray, np.ndarray]:
    """The flow pool's bank lists (``segments``: the pool's ``cell_segments``) of ``slots``
    in the new network's numbers: (the slots that list a renumbered segment, their new
    lists); the other slots' lists stay as they are. Reads the pool, writes nothing (an edit's
    thread makes them while the frames run; :meth:`RiverWorld._apply_edit` stores them)."""
    moved = seg_map != np.arange(len(seg_map), dtype=seg_map.dtype)
    if not moved.any() or not len(slots):
        return slots[:0], segments[:0]
    first = int(np.argmax(moved))          # the segments before it keep their numbers
    top = np.array([segments[s].max() for s in slots.tolist()])    # (no copy of every list)
    slots = slots[top >= first]
    lookup = np.concatenate([seg_map, [-1]]).astype(segments.dtype)     # −1 (the last) stays
    return slots, lookup[segments[slots]]


def tile_distances(codes: np.ndarray, quadtree, points: np.ndarray) -> np.ndarray:
    """(K,) distance [m] from each tile's centre to the nearest of ``points`` (P, 2) (inf with
    none): the order a live edit's stale tiles are made again in."""
    codes = np.asarray(codes, np.int64)
    if not len(codes) or not len(points):
        return np.full(len(codes), np.inf)
    from scipy.spatial import cKDTree

    d, _ = cKDTree(points).query(_tile_centres(codes, quadtree)[0])
    return d


def _tile_centres(codes: np.ndarray, quadtree) -> tuple[np.ndarray, np.ndarray]:
    """((K, 2) each tile's centre [m], (K,) its side [m])."""
    mask = (1 << 28) - 1
    size = quadtree.root_size_m / np.exp2((codes >> 56).astype(np.float64))
    return np.column_stack([
        quadtree.root_x_m + ((codes & mask).astype(np.float64) + 0.5) * size,
        quadtree.root_y_m + (((codes >> 28) & mask).astype(np.float64) + 0.5) * size]), size


def tiles_meeting(codes: np.ndarray, quadtree, boxes: np.ndarray, cells: int) -> np.ndarray:
    """(K,) bool: the tiles of ``codes`` whose footprint (widened by EDGE_CELLS of its
    ``cells`` cells a side) meets one of ``boxes`` (B, 4) [m]."""
    codes = np.asarray(codes, np.int64)
    if not len(codes) or not len(boxes):
        return np.zeros(len(codes), bool)
    return _rects_meeting(_tile_rects(codes, quadtree, cells), boxes)


def _rects_meeting(rects: np.ndarray, boxes: np.ndarray) -> np.ndarray:
    """(K,) bool: the rectangles (K, 4) x0, y0, x1, y1 [m] that meet one of ``boxes``
    (B, 4)."""
    out = np.zeros(len(rects), bool)
    x0, y0, x1, y1 = rects.T
    for s in range(0, len(boxes), 256):       # (K, 256) at a time: bounded temporaries
        bx = boxes[s:s + 256]
        out |= ((x0[:, None] <= bx[None, :, 2]) & (x1[:, None] >= bx[None, :, 0])
                & (y0[:, None] <= bx[None, :, 3]) & (y1[:, None] >= bx[None, :, 1])).any(axis=1)
    return out


def hints_near_changes(codes: np.ndarray, quadtree, old: Landscape, new: Landscape,
                       changed: list[str]) -> np.ndarray:
    """(K,) bool: the hints tiles of ``codes`` some node of which may have its nearest
    centre-line sample (:meth:`WaterSurface.nearest_sample`, which a hint is made from, at any
    distance) among those of a changed branch the edit moved (or whose width or level it
    changed), before or after it: a tile whose centre c (half
    diagonal h) is no nearer the changed samples than d + 2h, d its distance to the nearest
    unchanged one, is not (every node is within h of c)."""
    from scipy.spatial import cKDTree

    from riverflow.scenes.water import NEAREST_SAMPLE_STRIDE

    codes = np.asarray(codes, np.int64)
    if not len(codes) or not changed:
        return np.zeros(len(codes), bool)
    names = set(changed)
    rows, kept = [], None
    for scene in (old, new):
        s = scene.water.decimated(NEAREST_SAMPLE_STRIDE)
        on = np.isin(s.branch, [k for k, b in enumerate(scene.branches) if b.name in names])
        rows.append(np.ascontiguousarray(np.column_stack([s.samples[on], s.widths[on],
                                                          s.levels[on]])))
        if scene is new:
            kept = s.samples[~on]
    # a changed branch's picks that are the same before and after (a drag leaves those
    # beyond its reach) are kept ones too
    keys = [{r.tobytes() for r in side} for side in rows]
    same = [np.array([r.tobytes() in keys[1 - i] for r in side], bool).reshape(len(side))
            for i, side in enumerate(rows)]
    moved = np.concatenate([rows[0][~same[0], :2], rows[1][~same[1], :2]])
    kept = np.concatenate([kept, rows[1][same[1], :2]])
    if not len(moved):
        return np.zeros(len(codes), bool)
    if not len(kept):
        return np.ones(len(codes), bool)
    rects = _tile_rects(codes, quadtree, 1 << 30)        # the footprint (no edge)
    centre = 0.5 * (rects[:, :2] + rects[:, 2:])
    half = 0.5 * np.hypot(*(rects[:, 2:] - rects[:, :2]).T)
    d_moved, _ = cKDTree(moved).query(centre)
    d_kept, _ = cKDTree(kept).query(centre)
    return d_moved <= d_kept + 2.0 * half + 1e-6


def marked_tiles(plan: EditPlan, old: Landscape, kind: str, codes: np.ndarray, cells: int
                 ) -> tuple[np.ndarray, np.ndarray]:
    """(K,) bool: which ``kind`` tiles of ``codes`` the edit makes again (footprint widened by
    EDGE_CELLS of ``cells`` a side meeting the changed boxes; a hints tile also where its
    nearest centre line may have moved), and (K,) their ranks (:func:`tile_distances`). A
    function of the codes alone (and the plan): it may be worked out for any snapshot of the
    resident tiles, in any thread."""
    from riverflow.components.flow_tiles import FLOW_KIND
    from riverflow.scenes.tile_kinds import HINTS

    codes = np.asarray(codes, np.int64)
    q = plan.scene.quadtree
    if kind == FLOW_KIND:
        near = tiles_meeting(codes, q, plan.flow_boxes, cells)
        if plan.flow_changes is not None and near.any():
            near[near] = flow_tiles_reached(plan.flow_changes, codes[near], q, cells)
    else:
        near = tiles_meeting(codes, q, plan.terrain_boxes, cells)
        if kind == HINTS:     # a hint reads the nearest centre line, however far
            near |= hints_near_changes(codes, q, old, plan.scene, plan.changed)
    rank = np.zeros(len(codes))
    rank[near] = tile_distances(codes[near], q, plan.change_centres)
    return near, rank


def marked_ahead(plan: EditPlan, old: Landscape, kind: str, codes: np.ndarray, cells: int
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`marked_tiles` of a snapshot of the resident codes, sorted by code (for
    :func:`marked_at_swap`)."""
    codes = np.unique(np.asarray(codes, np.int64))
    return (codes, *marked_tiles(plan, old, kind, codes, cells))


def marked_at_swap(plan: EditPlan, old: Landscape, kind: str, codes: np.ndarray, cells: int
                   ) -> tuple[np.ndarray, np.ndarray]:
    """(the codes of ``codes`` the edit makes again, their ranks): the ones the edit's thread
    saw read from :attr:`EditPlan.marked_ahead`, the rest (installed since) worked out now."""
    codes = np.asarray(codes, np.int64)
    near = np.zeros(len(codes), bool)
    rank = np.zeros(len(codes))
    rest = np.ones(len(codes), bool)
    ahead = plan.marked_ahead.get(kind)
    if ahead is not None and len(ahead[0]) and len(codes):
        known, known_near, known_rank = ahead
        at = np.minimum(np.searchsorted(known, codes), len(known) - 1)
        found = known[at] == codes
        near[found], rank[found] = known_near[at[found]], known_rank[at[found]]
        rest = ~found
    if rest.any():
        near[rest], rank[rest] = marked_tiles(plan, old, kind, codes[rest], cells)
    return codes[near], rank[near]


def _tile_rects(codes: np.ndarray, quadtree, cells: int) -> np.ndarray:
    """(K, 4) x0, y0, x1, y1 [m]: each tile's footprint widened by EDGE_CELLS of its
    ``cells`` cells a side."""
    mask = (1 << 28) - 1
    size = quadtree.root_size_m / np.exp2((codes >> 56).astype(np.float64))
    edge = size * EDGE_CELLS / cells
    x0 = quadtree.root_x_m + (codes & mask).astype(np.float64) * size - edge
    y0 = quadtree.root_y_m + ((codes >> 28) & mask).astype(np.float64) * size - edge
    return np.column_stack([x0, y0, x0 + size + 2 * edge, y0 + size + 2 * edge])


# -- step 3: in the background, then swapped in between frames --------------------------------


class LiveEdits:
    """A world's edits in the background (``wait=False``): one at a time in a worker thread,
    the latest one asked for while another is made waiting its turn (a drag asks for an edit
    each frame: only the newest of those is made), each swapped in at the start of the first
    frame after it is ready (:meth:`RiverWorld.step`). ``errors`` keeps what the background
    edits raised (the world keeps its network then)."""

    def __init__(self) -> None:
        self.thread = None          # a threading.Event while an edit is made, set when done
        self.result = None          # (plan, producers) or an exception, set by the thread
        self.future = None
        self.queued = None          # (make_plan, future)
        self._worker = None         # the edits' thread (start)
        self._jobs = None
        self._planner = None        # the planner thread (planned)
        self._plans = None
        self.errors: list[str] = []
        self.applied = 0
        """Edits swapped in so far."""
        self.last: dict = {}
        """The last edit swapped in: ``changed`` branch names, ``marked`` tiles per kind,
        ``released`` flow tiles, ``applied_s`` (time.perf_counter() of the swap)."""

    @property
    def busy(self) -> bool:
        return self.thread is not None or self.queued is not None

    def start(self, run) -> None:
        """Run ``run()`` in the edits' thread: one thread for the world's life, not one per
        edit, because the tile process an edit forks there is killed when the thread that
        forked it ends (``PR_SET_PDEATHSIG``: :mod:`riverflow.tiles.remote`)."""
        import queue
        import threading
        import weakref

        if self._worker is None or not self._worker.is_alive():
            self._jobs = queue.Queue()
            self._worker = threading.Thread(target=_serve_edits,
                                            args=(weakref.ref(self), self._jobs),
                                            name="riverflow-edits", daemon=True)
            self._worker.start()
        done = threading.Event()
        self.thread = done                   # busy until ``run`` has set the result
        self._jobs.put((run, done))

    def planned(self, plan):
        """``plan()`` run in the planner thread, its result returned here (or its exception
        raised): a thread for the world's life (the tile processes an edit forks there die
        with it) at a low priority (PLANNER_NICE), so that on a core it shares with the
        frames a frame's thread runs first whenever both could. The swap is not made there:
        a thread at that priority holding the world's lock would keep a frame waiting
        whenever anything else on the machine wants the core."""
        import queue
        import threading
        import weakref

        if self._planner is None or not self._planner.is_alive():
            self._plans = queue.Queue()
            self._planner = threading.Thread(target=_serve_edits,
                                             args=(weakref.ref(self), self._plans, True),
                                             name="riverflow-edit-plans", daemon=True)
            self._planner.start()
        done, out = threading.Event(), []

        def job():
            try:
                out.append((True, plan()))
            except BaseException as exc:  # noqa: BLE001 - raised again in the caller's thread
                out.append((False, exc))
        self._plans.put((job, done))
        done.wait()
        ok, value = out[0]
        if not ok:
            raise value
        return value

    def run_later(self, fn) -> None:
        """Run ``fn()`` in the edits' thread after what it does now (closing a tile process
        replaced by an edit: its end is not waited for in a frame)."""
        import threading

        if self._worker is None or not self._worker.is_alive():
            threading.Thread(target=fn, daemon=True, name="riverflow-edits-close").start()
            return
        self._jobs.put((fn, threading.Event()))

    def running(self) -> bool:
        return self.thread is not None and not self.thread.is_set()

    def join(self) -> None:
        if self.thread is not None:
            self.thread.wait()

    def stop(self) -> None:
        if self._worker is not None:
            self._jobs.put(None)
            self._worker = None
        if self._planner is not None:
            self._plans.put(None)
            self._planner = None


PLANNER_NICE = 10
"""The planner thread's nice value: a frame's thread (0) gets ~90 % of a core they share,
and it ~88 % of one it shares with a tile process (19, making the last edit's tiles; at 19
too they would share it half and half)."""
EDIT_SWITCH_INTERVAL_S = 0.0005
"""While the edits' thread runs a job, the interpreter's switch interval is at most this
[s] (``sys.setswitchinterval``; put back after): a frame that wants the interpreter while
the edit's Python runs gets it within this, not the default 5 ms (over twice a frame's own
work)."""


def _serve_edits(ref, jobs, low_priority: bool = False) -> None:
    """The edits' thread (the planner thread: ``low_priority``, at PLANNER_NICE): runs
    what :meth:`LiveEdits.start` (:meth:`LiveEdits.planned`) hands it until told to stop or
    its LiveEdits is gone."""
    import queue

    if low_priority:
        from riverflow.tiles.scheduler import _lower_priority

        _lower_priority(PLANNER_NICE)
    while True:
        try:
            job = jobs.get(timeout=1.0)
        except queue.Empty:
            if ref() is None:
                return
            continue
        if job is None:
            return
        run, done = job
        # the frame's thread takes the interpreter back within this while the edits' thread
        # runs Python (the default 5 ms is over twice a frame's work)
        interval = sys.getswitchinterval()
        sys.setswitchinterval(min(interval, EDIT_SWITCH_INTERVAL_S))
        try:
            run()
        finally:
            if sys.getswitchinterval() == min(interval, EDIT_SWITCH_INTERVAL_S):
                sys.setswitchinterval(interval)       # (unless the host set another since)
            done.set()
