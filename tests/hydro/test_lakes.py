"""Lakes (issue 22, item 2): ``RiverNetworkBuilder.add_lake``.

The test of record: a round lake with two inlets and one outlet. Its shore carries one ψ
between two mouths, so the flux through each mouth is its river's discharge; in the lake the
level is flat, the flow is divergence-free, tangent to the shore, and carries tracers from
each inlet to the outlet, none stuck and none leaving the water. A lake no river touches is
still water; lakes round-trip through graph files; bad lakes are clear GraphErrors."""
from __future__ import annotations

import numpy as np
import pytest
import shapely

import riverflow as rf
from riverflow.hydro.areas import area_ring
from riverflow.hydro.builder import RiverNetworkBuilder
from riverflow.hydro import lake_flow
from riverflow.hydro.flow_network import build_flow_network
from riverflow.hydro.graph import LAKE_INFO, LAKE_LEVEL_INFO, GraphError
from riverflow.kernels.flow import KIND_CAP
from tests.flow.networks import divergence_and_gradient

LAKE = shapely.Point(0, 0).buffer(150, quad_segs=24)
WEST = [(-600, 120), (-300, 60), (-100, 20)]       # ends inside the lake: cut at its shore
SOUTH = [(-100, -600), (-60, -300), (-20, -100)]
OUT = [(100, 10), (350, 40), (700, 0)]


def two_inlets(level_m=None) -> RiverNetworkBuilder:
    b = RiverNetworkBuilder()
    b.add_branch(WEST, 30.0, discharge_m2s=20.0, name="west")
    b.add_branch(SOUTH, 24.0, discharge_m2s=10.0, name="south")
    b.add_branch(OUT, 36.0, name="out")
    b.add_lake(LAKE, level_m=level_m)
    return b


@pytest.fixture(scope="module")
def lake():
    b = two_inlets()
    graph = b.build()
    field = rf.FlowField(graph)
    shore = shapely.Polygon(area_ring(graph, graph.lakes()[0]))
    return b, graph, field, shore


def _mouth_ends(graph) -> np.ndarray:
    """The end points of every closing segment (mouths and free ends)."""
    return np.vstack([graph.vertices(i)[[0, -1]] for i, c in enumerate(graph.curves)
                      if not c.is_bank and c.width_m == 0.0])


def test_a_lake_is_an_area_whose_shore_carries_the_rivers_psi(lake):
    b, graph, _, shore = lake
    assert b.discharges_m2s == [20.0, 10.0, 30.0]           # the outlet takes all the inflow
    (k,) = graph.lakes()
    assert graph.areas[k].info == LAKE_INFO and graph.areas[k].level_m is None
    assert shore.symmetric_difference(LAKE).area < 1e-3 * LAKE.area
    # the shore: one ψ between two mouths, three pieces for three mouths
    shore_psi = [graph.curves[c].potential for c, _ in graph.areas[k].curves
                 if graph.curves[c].is_bank]
    assert sorted(set(shore_psi)) == [0.0, 20.0, 30.0]
    # each mouth is one closing segment of the lake and of its river, and no cap of the flow
    shared = [c for c, _ in graph.areas[k].curves if not graph.curves[c].is_bank]
    assert len(shared) == 3
    for c in shared:
        assert -1 not in graph.curve_areas(c)
    net = build_flow_network(graph, 5.0, 0.25)
    caps = set(net.curve_source[net.curve_kind == KIND_CAP].tolist())
    assert caps.isdisjoint(shared) and len(caps) == 3       # the three free river ends


def _shore_samples(shore, graph, offset_m: float, away_m: float = 40.0):
    """Points ``offset_m`` inside the shore every ~0.6 m, farther than ``away_m`` from every
    mouth's ends, and the shore's inward normal there: from the nearest point of the shore to
    the sample (the segment's normal, or at a corner of the polygon the direction from the
    corner: a normal taken from one segment there would measure the corner's turn, not the
    flow, and the figure would depend on where the samples fall)."""
    ring = shore.exterior
    s = np.linspace(0.0, ring.length, 1500, endpoint=False)
    p = shapely.get_coordinates(shapely.line_interpolate_point(ring, s))
    t = shapely.get_coordinates(shapely.line_interpolate_point(ring, s + 0.01)) - p
    t /= np.hypot(*t.T)[:, None]
    q = p + offset_m * np.c_[-t[:, 1], t[:, 0]]                # inward (the ring is CCW)
    ends = _mouth_ends(graph)
    q = q[np.hypot(*(q[:, None] - ends[None]).transpose(2, 0, 1)).min(axis=1) > away_m]
    foot = shapely.get_coordinates(
        shapely.line_interpolate_point(ring, shapely.line_locate_point(ring, shapely.points(q))))
    n = q - foot
    return q, n / np.hypot(*n.T)[:, None]


def _normal_ratios(field, graph, shore, offsets) -> list[np.ndarray]:
    """At each offset [m] inside the shore (away from the mouths): the flow's normal part over
    the speed (over the median speed where slower), the samples all INSIDE."""
    ratios = []
    for offset in offsets:
        q, n = _shore_samples(shore, graph, offset)
        status, v = field.query(q)
        assert (status == rf.FlowStatus.INSIDE).all()
        speed = np.hypot(*v.T)
        ratios.append(np.abs((v * n).sum(axis=1)) / np.maximum(speed, np.median(speed)))
    return ratios


def test_flow_in_the_lake_is_a_potential_flow(lake):
    """Divergence-free and irrotational (the potential flow of lake_flow, where Proland's
    interpolation had a curl 15 to 32 times the velocity gradients), by central differences."""
    _, graph, field, shore = lake
    h = field.tiles.spacing_m(field.max_level)
    rng = np.random.default_rng(5)
    pts = rng.uniform(-150, 150, (4000, 2))
    pts = pts[shapely.contains_xy(shore.buffer(-3 * h), pts[:, 0], pts[:, 1])][:300]
    status, v = field.query(pts)
    assert (status == rf.FlowStatus.INSIDE).all() and np.isfinite(v).all()
    div, grad = divergence_and_gradient(field, pts, 0.05 * h)
    assert np.abs(div).max() < 0.05 * np.median(grad)
    e = 0.5 * h
    _, vxp = field.query(pts + (e, 0))
    _, vxm = field.query(pts - (e, 0))
    _, vyp = field.query(pts + (0, e))
    _, vym = field.query(pts - (0, e))
    curl = np.abs((vxp[:, 1] - vxm[:, 1]) - (vyp[:, 0] - vym[:, 0])) / (2 * e)
    assert curl.max() < 0.25 * np.median(grad)                # measured 0.11
    assert np.percentile(curl, 99) < 0.05 * np.median(grad)   # 0.015


def test_flow_in_the_lake_follows_the_shore(lake):
    """A quarter of a metre in (a quarter of the lattice spacing), away from the mouths, the
    flow's normal part is at most 2 % of the speed (of the median speed where slower: the
    stagnation points where the flow parts); it is the potential flow's own (the stream lines
    converge on the outlet) and goes to zero at the shore: half as far in, half as much."""
    _, graph, field, shore = lake
    ratios = _normal_ratios(field, graph, shore, (0.25, 0.125))
    assert ratios[0].max() <= 0.02, ratios[0].max()           # measured 1.4 %
    assert np.median(ratios[0]) < 0.005                       # 0.23 %
    assert ratios[1].max() < 0.65 * ratios[0].max()
    # the lattice carries the lake's solution: ψ on the grid's nodes, bilinear between
    (grid,) = field.lakes
    pts = np.random.default_rng(1).uniform(-140, 140, (400, 2))
    pts = pts[shapely.contains_xy(shore.buffer(-5.0), pts[:, 0], pts[:, 1])]
    assert np.abs(field.potential(pts) - grid.sample(pts)).max() < 0.01 * np.ptp(grid.psi[grid.inside])


def _trace(field, seeds: np.ndarray, done, dt: float = 4.0, steps: int = 4000):
    """Midpoint-rule tracers: (reached, ever left the water)."""
    p = seeds.astype(float).copy()
    reached = np.zeros(len(p), bool)
    left = np.zeros(len(p), bool)
    for _ in range(steps):
        status, v = field.query(p)
        left |= (status != rf.FlowStatus.INSIDE) & ~reached
        _, v2 = field.query(p + 0.5 * dt * v)
        p = np.where(reached[:, None], p, p + dt * v2)
        reached |= done(p)
        if reached.all():
            break
    return reached, left


def test_tracers_go_from_each_inlet_to_the_outlet(lake):
    _, _, field, _ = lake
    across = np.linspace(-0.4, 0.4, 7)
    west = np.c_[np.full(7, -400.0), 80.0 + 30.0 * across]     # the west river at x = -400
    south = np.c_[-73.3 + 24.0 * across, np.full(7, -400.0)]
    for seeds in (west, south):
        status, _ = field.query(seeds)
        assert (status == rf.FlowStatus.INSIDE).all()
        reached, left = _trace(field, seeds, lambda p: p[:, 0] > 400.0)
        assert reached.all() and not left.any()


def test_the_lake_is_flat_in_the_landscape(lake):
    _, graph, _, shore = lake
    scene = rf.landscape(graph, seed=0)
    rng = np.random.default_rng(2)
    pts = rng.uniform(-150, 150, (3000, 2))
    pts = pts[shapely.contains_xy(shore.buffer(-2.0), pts[:, 0], pts[:, 1])]
    level = scene.water.level(pts)
    assert np.ptp(level) < 1e-9
    # the rivers run down into it and out of it
    assert scene.water.level(np.array([[-400.0, 80.0]]))[0] >= level[0]
    assert scene.water.level(np.array([[500.0, 30.0]]))[0] <= level[0]
    assert (scene.terrain.height(pts[:200]) < level[:200]).all()   # a carved bed under it
    given = rf.landscape(two_inlets(level_m=level[0] + 0.5).build(), seed=0)
    assert np.allclose(given.water.level(pts[:200]), level[0] + 0.5)


def test_a_lake_no_river_touches_is_still_water():
    b = RiverNetworkBuilder()
    b.add_branch([(-500, -400), (500, -400)], 30.0, discharge_m2s=10.0, name="river")
    b.add_lake(shapely.Point(0, 0).buffer(80))
    graph = b.build()
    field = rf.FlowField(graph)
    rng = np.random.default_rng(3)
    pts = rng.uniform(-80, 80, (2000, 2))
    pts = pts[np.hypot(*pts.T) < 78]
    status, v = field.query(pts)
    assert (status == rf.FlowStatus.INSIDE).all()
    assert np.isfinite(v).all() and np.abs(v).max() < 1e-6
    assert np.isfinite(field.potential(pts)).all()
    reached, left = _trace(field, pts[:20], lambda p: np.zeros(len(p), bool), steps=50)
    assert not left.any()
    # the river beside it still flows
    status, v = field.query(np.array([[0.0, -400.0]]))
    assert status[0] == rf.FlowStatus.INSIDE and v[0, 0] > 0.1


def test_a_river_through_a_lake_becomes_its_inlet_and_outlet():
    b = RiverNetworkBuilder()
    b.add_branch([(-700, 50), (-300, 0), (0, 0), (300, -20), (700, 40)], 30.0,
                 discharge_m2s=25.0, name="river")
    b.add_lake(shapely.Point(0, 0).buffer(180, quad_segs=8), level_m=3.0)
    graph = b.build()
    (k,) = graph.lakes()
    assert graph.areas[k].info == LAKE_LEVEL_INFO and graph.areas[k].level_m == 3.0
    assert sorted({graph.curves[c].potential for c, _ in graph.areas[k].curves
                   if graph.curves[c].is_bank}) == [0.0, 25.0]
    assert len(graph.areas) == 3


@pytest.mark.parametrize("level", [None, 12.5])
def test_lakes_round_trip_through_graph_files(tmp_path, level):
    graph = two_inlets(level_m=level).build()
    for kw in ({}, {"indexed": True}):
        path = tmp_path / "lake.graph"
        rf.save_graph(graph, path, **kw)
        back = rf.load_graph(path)
        assert back == graph
        assert [a.level_m for a in back.areas] == [a.level_m for a in graph.areas]
    first = (tmp_path / "lake.graph").read_bytes()[:40]
    assert (b"2 5 4 1 3 2 0" in first) == (level is not None)


@pytest.mark.parametrize("make, message", [
    (lambda b: b.add_lake([(0, 0), (10, 10), (10, 0), (0, 10)]), "not a simple polygon"),
    (lambda b: (b.add_lake(LAKE), b.add_lake(shapely.Point(100, 0).buffer(100))), "overlaps"),
    (lambda b: (b.add_branch([(-50, 0), (50, 0)], 30.0, discharge_m2s=5.0),
                b.add_lake(LAKE)), "inside a lake"),
    (lambda b: b.add_lake(LAKE, level_m=float("nan")), "level_m"),
])
def test_bad_lakes_are_clear_errors(make, message):
    b = RiverNetworkBuilder()
    with pytest.raises(GraphError, match=message):
        make(b)
        b.build()


def test_particles_on_a_still_lake_in_the_running_world():
    b = RiverNetworkBuilder()
    b.add_branch([(-500, -400), (500, -400)], 30.0, discharge_m2s=10.0, name="river")
    b.add_lake(shapely.Point(0, 0).buffer(80))
    scene = rf.landscape(b.build(), seed=0)
    level = scene.water.level(np.array([[0.0, 0.0]]))[0]
    world = rf.RiverWorld(scene, size=(160, 90), gl=False, seed=0)
    world.camera.look_at((0.0, -150.0, level + 60.0), (0.0, 0.0, level))
    for _ in range(30):
        world.step(1 / 30)
    p = world.particles
    assert np.isfinite(p.world_m).all()
    on_lake = (p.status == rf.FlowStatus.INSIDE) & (np.hypot(*p.world_m[:, :2].T) < 79.0)
    assert on_lake.sum() >= 5
    assert np.allclose(p.world_m[on_lake, 2], level)


def test_lakes_of_many_shapes_build():
    """Ellipses of 4 to 23 vertices a quarter, turned any way, with one to three inlets and
    one or two outlets meeting the shore at any angle: every one builds (the builder checks
    its graph: water left of every bank, one ψ where banks meet, the discharges)."""
    from shapely import affinity

    rng = np.random.default_rng(7)
    for _ in range(8):
        a, c = rng.uniform(100, 250, 2)
        lake = affinity.rotate(affinity.scale(shapely.Point(0, 0).buffer(
            1, quad_segs=int(rng.integers(4, 24))), a, c), rng.uniform(0, 180))
        n_in, n_out = int(rng.integers(1, 4)), int(rng.integers(1, 3))
        angles = np.sort(rng.uniform(0, 2 * np.pi, n_in + n_out))
        while np.min(np.diff(np.r_[angles, angles[0] + 2 * np.pi])) < 0.6:
            angles = np.sort(rng.uniform(0, 2 * np.pi, n_in + n_out))
        b = RiverNetworkBuilder()
        for k, angle in enumerate(angles):
            d = np.array([np.cos(angle), np.sin(angle)])
            off = rng.uniform(-30, 30) * np.array([-d[1], d[0]])
            line = [d * 900 + off, d * 460 + off, d * 20 + off]
            width = float(rng.uniform(15, 40))
            if k < n_in:
                b.add_branch(line, width, discharge_m2s=float(rng.uniform(5, 30)))
            else:
                b.add_branch(line[::-1], width)
        b.add_lake(lake)
        graph = b.build()
        assert len(graph.lakes()) == 1
        inflow = sum(b.discharges_m2s[:n_in])
        assert abs(sum(b.discharges_m2s[n_in:]) - inflow) < 1e-9 * inflow


ISLAND = shapely.Point(20, 40).buffer(25, quad_segs=24)


@pytest.fixture(scope="module")
def island_lake():
    b = RiverNetworkBuilder()
    b.add_branch(WEST, 30.0, discharge_m2s=20.0, name="west")
    b.add_branch(SOUTH, 24.0, discharge_m2s=10.0, name="south")
    b.add_branch(OUT, 36.0, name="out")
    b.add_lake(LAKE.difference(ISLAND))
    graph = b.build()
    return graph, rf.FlowField(graph)


def test_an_island_in_a_lake_has_the_psi_of_zero_circulation(island_lake):
    """The island's shore is one ψ, between the shores' (the flow passes both sides), chosen
    so that the circulation round it is zero; the flow is tangent to it (corners of the
    polygon aside: its normal part vanishes at the shore) and the tracers still go round it
    to the outlet."""
    graph, field = island_lake
    (k,) = graph.lakes()
    (isl,) = lake_flow.lake_islands(graph, k, 0.25)
    psi = {graph.curves[c].potential for c, _ in graph.areas[isl].curves}
    assert len(psi) == 1 and 0.0 < psi.pop() < 30.0
    shore = shapely.Polygon(area_ring(graph, isl))
    # circulation on circles round the island: zero (a wrong island ψ makes it ≠ 0)
    a = np.linspace(0, 2 * np.pi, 2000, endpoint=False)
    for r in (35.0, 45.0):
        ring = np.c_[20 + r * np.cos(a), 40 + r * np.sin(a)]
        status, v = field.query(ring)
        assert (status == rf.FlowStatus.INSIDE).all()
        dl = np.c_[-np.sin(a), np.cos(a)]
        assert abs((v * dl).sum()) < 0.005 * np.hypot(*v.T).sum()     # measured 0.16 %
    # tangent a quarter metre off its shore, 2 m or more from a vertex
    from scipy.spatial import cKDTree
    ring = shore.exterior
    s = np.linspace(0, ring.length, 400, endpoint=False)
    p = shapely.get_coordinates(shapely.line_interpolate_point(ring, s))
    t = shapely.get_coordinates(shapely.line_interpolate_point(ring, s + 0.01)) - p
    t /= np.hypot(*t.T)[:, None]
    n = np.c_[-t[:, 1], t[:, 0]]
    n *= np.where(shapely.contains_xy(shore, *(p + 0.25 * n).T), -1.0, 1.0)[:, None]
    keep = cKDTree(np.asarray(ring.coords)).query(p)[0] > 0.5
    ratios = []
    for offset in (0.25, 0.125):
        status, v = field.query(p[keep] + offset * n[keep])
        assert (status == rf.FlowStatus.INSIDE).all()
        speed = np.hypot(*v.T)
        ratios.append(np.abs((v * n[keep]).sum(axis=1)) / np.maximum(speed, np.median(speed)))
    # the stream lines curve round a 25 m island: the normal part grows with the distance
    # from its shore (2.6 % at 0.25 m, 1.5 % at 0.125 m, 0.8 % at 0.0625 m) and vanishes on it
    assert ratios[1].max() <= 0.02, ratios[1].max()
    assert ratios[1].max() < 0.65 * ratios[0].max()
    west = np.c_[np.full(7, -400.0), 80.0 + 30.0 * np.linspace(-0.4, 0.4, 7)]
    reached, left = _trace(field, west, lambda p: p[:, 0] > 400.0)
    assert reached.all() and not left.any()


@pytest.mark.parametrize("kind", ["terminal", "source"])
def test_a_lake_with_no_outlet_or_no_inlet_is_still_water(kind):
    """A terminal lake: its two inlets end on free ends just short of its shore (their water
    leaves there, as at any river end); a source lake (spring-fed, or its feeders not in the
    data): its outlet starts on a free end just off its shore (its water comes in there, as
    at any river's source). Either is one shore, one ψ: still water, flat, in a network of its
    own; the builder says which lakes are terminal and which are sources."""
    b = RiverNetworkBuilder()
    if kind == "terminal":
        b.add_branch(WEST, 30.0, discharge_m2s=20.0, name="west")
        b.add_branch(SOUTH, 24.0, discharge_m2s=10.0, name="south")
    else:
        b.add_branch(OUT, 36.0, discharge_m2s=30.0, name="out")
    b.add_lake(LAKE)
    graph = b.build()
    assert (b.terminal_lakes, b.source_lakes) == (([0], []) if kind == "terminal" else ([], [0]))
    assert len(graph.lakes()) == 1
    (k,) = graph.lakes()
    assert len({graph.curves[c].potential for c, _ in graph.areas[k].curves}) == 1
    field = rf.FlowField(graph)
    ends = np.vstack([graph.polyline(a)[[0, -1]] for a in graph.axes()
                      if graph.curves[a].width_m < 100.0])
    rng = np.random.default_rng(3)
    pts = rng.uniform(-150, 150, (3000, 2))
    pts = pts[(np.hypot(*pts.T) < 148)
              & (np.hypot(*(pts[:, None] - ends[None]).transpose(2, 0, 1)).min(axis=1) > 20.0)]
    status, v = field.query(pts)
    assert (status == rf.FlowStatus.INSIDE).all()
    assert np.isfinite(v).all() and np.abs(v).max() < 1e-6
    # the rivers still run towards it, or away from it
    if kind == "terminal":
        status, v = field.query(np.array([[-400.0, 80.0], [-73.3, -400.0]]))
        assert (status == rf.FlowStatus.INSIDE).all() and v[0, 0] > 0.1 and v[1, 1] > 0.1
    else:
        status, v = field.query(np.array([[350.0, 40.0]]))
        assert status[0] == rf.FlowStatus.INSIDE and v[0, 0] > 0.1
    assert np.ptp(rf.landscape(graph, seed=0).water.level(pts)) < 1e-9


@pytest.mark.parametrize("kind", ["terminal", "source"])
def test_a_closed_lake_builds_from_given_water_polygons(kind):
    """The water given as polygons (a river's and a lake's, meeting at the shore, as
    read_water reads them), the lake with no outlet or no inlet: the river's water is cut
    back a tolerance (0.25 m) from the lake's shore, its axis ends (starts) on a free end
    there, and the lake is still water; the water edge stays within 1.5 m of the polygons."""
    from riverflow.hydro.areas import water_polygon

    b = RiverNetworkBuilder()
    if kind == "terminal":
        b.add_branch([(-500, 0), (-100, 0)], 30.0, discharge_m2s=5.0)
        river = shapely.box(-500, -15, -140, 15)
    else:
        b.add_branch([(100, 0), (500, 0)], 30.0, discharge_m2s=5.0)
        river = shapely.box(140, -15, 500, 15)
    b.set_water_area(river)
    b.add_lake(LAKE)
    graph = b.build()
    assert (b.terminal_lakes, b.source_lakes) == (([0], []) if kind == "terminal" else ([], [0]))
    field = rf.FlowField(graph)
    x = -300.0 if kind == "terminal" else 300.0
    status, v = field.query(np.array([[x, 0.0], [0.0, 0.0], [40.0, 60.0]]))
    assert (status == rf.FlowStatus.INSIDE).all()
    assert v[0, 0] > 0.1 and np.abs(v[1:]).max() < 1e-6          # the river runs, the lake
    drawn = water_polygon(graph)                                   # is still
    given = shapely.union_all([river, LAKE])
    # (the river's end is a straight chord across it: the round shore curves away from it)
    gone = shapely.difference(given, drawn)                         # only next to the lake
    assert shapely.difference(gone, LAKE.buffer(1.5)).area < 1e-6 and gone.area < 30.0 * 1.5
    assert shapely.difference(drawn, given).area < 1e-3 * given.area


def graph_branch_ends(graph):
    """The river axes' polylines as objects with ``centerline_m`` (their downstream ends)."""
    from types import SimpleNamespace

    return [SimpleNamespace(centerline_m=graph.polyline(a)) for a in graph.axes()
            if graph.curves[a].width_m < 100.0]


def test_lake_tiles_agree_across_their_borders(lake):
    """Either side of a flow tile's border in the lake, ψ and the velocity are continuous
    (each tile writes the lake's solution at its own lattice points, the same nodes)."""
    _, graph, field, shore = lake
    pts = _across_tile_borders(field, shore.buffer(-3.0), (-140, 140), (-140, 140), 200)
    assert len(pts) > 100
    e = 1e-6 * field.tiles.tile_size_m(field.max_level)
    assert np.abs(field.potential(pts - (e, 0)) - field.potential(pts + (e, 0))).max() < 1e-4


def _across_tile_borders(field, water, xs_m, ys_m, n: int) -> np.ndarray:
    """Points in ``water`` on the vertical borders of the finest flow tiles between
    ``xs_m`` (x0, x1), ``n`` of them from y0 to y1 on each; the status either side is INSIDE
    and the velocity continuous (within 1e-3 of its largest)."""
    t = field.tiles
    size = t.tile_size_m(field.max_level)
    xs = t.root_x_m + size * np.arange(np.ceil((xs_m[0] - t.root_x_m) / size),
                                       np.floor((xs_m[1] - t.root_x_m) / size) + 1)
    pts = np.array([(x, y) for x in xs for y in np.linspace(*ys_m, n)])
    pts = pts[shapely.contains_xy(water, pts[:, 0], pts[:, 1])]
    assert len(xs) >= 2 and len(pts) > 50
    e = 1e-6 * size
    sa, va = field.query(pts - (e, 0))
    sb, vb = field.query(pts + (e, 0))
    assert (sa == rf.FlowStatus.INSIDE).all() and (sb == rf.FlowStatus.INSIDE).all()
    assert np.abs(va - vb).max() < 1e-3 * np.abs(va).max()
    return pts


def test_lakes_with_jagged_shores_build():
    """Shores as real lake outlines come (random radii at 12 to 30 angles: spits, notches,
    bays facing every way), with two inlets and an outlet: every one builds, and its graph
    validates. The axis-on-the-left rule is not asked of a lake's shore (its flow is the
    lake's own: test_a_lake_of_any_shape_has_its_axes_in_the_water_and_its_flow), where
    before 4 of 5 such lakes were refused ("its axis lies on its right")."""
    rng = np.random.default_rng(11)
    built = 0
    for _ in range(6):
        n = int(rng.integers(12, 31))
        angle = np.sort(rng.uniform(0.0, 2.0 * np.pi, n))
        radius = rng.uniform(120.0, 300.0, n)
        lake = shapely.Polygon(np.c_[radius * np.cos(angle), radius * np.sin(angle)])
        if not lake.is_valid:
            continue
        b = RiverNetworkBuilder()
        for k, a in enumerate((0.3, 2.4, 4.4)):
            d = np.array([np.cos(a), np.sin(a)])
            line = [d * 1200.0, d * 700.0, d * 60.0]
            if k < 2:
                b.add_branch(line, 20.0, discharge_m2s=10.0)
            else:
                b.add_branch(line[::-1], 30.0)
        b.add_lake(lake)
        graph = b.build()
        assert rf.validate_graph(graph) == []
        assert len(graph.lakes()) == 1
        built += 1
    assert built >= 5


def test_falls_and_rapids_given_along_a_branch_a_lake_cuts():
    """A fall and a rapid given by distance along the input branch land where they were
    given, on the piece of it below the lake (the pieces' stations start at their own
    starts); one inside the lake is a clear GraphError. Before, the index named a piece
    (``default_scene(dam=True, falls=True)`` failed)."""
    b = RiverNetworkBuilder()
    b.add_branch([(-800.0, 0.0), (800.0, 0.0)], 30.0, discharge_m2s=10.0, name="through")
    b.add_lake(LAKE)
    b.add_fall(1300.0, 2.0, branch="through")                 # 500 m below the lake
    b.add_rapids(1100.0, 1200.0, 1.0, branch="through")
    graph = b.build()
    (fall,) = graph.falls
    assert np.allclose(fall.centre_m, (500.0, 0.0), atol=0.5)
    (rapid,) = graph.rapids
    assert rapid.branch == fall.branch and rapid.from_m < rapid.to_m < fall.at_m
    inside = RiverNetworkBuilder()
    inside.add_branch([(-800.0, 0.0), (800.0, 0.0)], 30.0, discharge_m2s=10.0, name="through")
    inside.add_lake(LAKE)
    inside.add_fall(800.0, 2.0, branch="through")             # the lake's centre
    with pytest.raises(GraphError, match="lies in a lake"):
        inside.build()


# a reservoir in two flooded valleys joined in the south (a U: not star-shaped about its
# centre), with a bay round the corner of the east arm and an island between the centre and
# the north inlet's mouth
RESERVOIR = shapely.union_all([
    shapely.box(-250, -200, 250, -60), shapely.box(-250, -200, -130, 300),
    shapely.box(130, -200, 250, 300), shapely.box(250, 120, 330, 180),
    shapely.box(290, 120, 330, 260)]).buffer(15, quad_segs=12).buffer(-15, quad_segs=12)
RESERVOIR_ISLAND = shapely.Point(-190, 120).buffer(22, quad_segs=8)
BAY = shapely.box(255, 125, 330, 260)


@pytest.fixture(scope="module")
def reservoir():
    b = RiverNetworkBuilder()
    b.add_branch([(-190, 550), (-190, 290)], 40.0, discharge_m2s=20.0, name="north")
    b.add_branch([(-500, -130), (-240, -130)], 36.0, discharge_m2s=10.0, name="west")
    b.add_branch([(190, 290), (190, 550)], 44.0, name="out")
    b.add_lake(RESERVOIR.difference(RESERVOIR_ISLAND))
    graph = b.build()
    return graph, rf.FlowField(graph)


def test_a_reservoir_that_is_not_star_shaped_carries_its_rivers(reservoir):
    """Any simple polygon with islands is a lake: the axes from the mouths go through the
    middle of the water (round the island), the bay lies within their widths; the flow is the
    potential flow (divergence-free, tangent to the shore), carries tracers from each inlet to
    the outlet, and is slow but not still in the bay; land is never water."""
    graph, field = reservoir
    lake = RESERVOIR.difference(RESERVOIR_ISLAND)
    (k,) = graph.lakes()
    shore = shapely.Polygon(area_ring(graph, k))
    assert shore.symmetric_difference(RESERVOIR).area < 1e-3 * RESERVOIR.area
    rng = np.random.default_rng(2)
    h = field.tiles.spacing_m(field.max_level)
    pts = rng.uniform((-250, -200), (330, 300), (3000, 2))
    water = shapely.contains_xy(lake.buffer(-3 * h), *pts.T)
    # all of the water is water (behind the island and in the bay too: each point sees its
    # nearest axis), no NaN
    status, v = field.query(pts[water])
    assert water.sum() > 1000
    assert (status == rf.FlowStatus.INSIDE).all() and np.isfinite(v).all()
    div, grad = divergence_and_gradient(field, pts[water][:300], 0.05 * h)
    assert np.abs(div).max() < 0.05 * np.median(grad)
    # land next to the lake (a metre or more from its shore and from the rivers) is not water
    rivers = shapely.union_all([shapely.box(-210, 300, -170, 560),
                                shapely.box(-510, -148, -250, -112),
                                shapely.box(168, 300, 212, 560)]).buffer(2.0)
    land = pts[~shapely.contains_xy(lake.buffer(1.0), *pts.T)
               & ~shapely.contains_xy(rivers, *pts.T)]
    assert len(land) > 300 and (field.query(land)[0] != rf.FlowStatus.INSIDE).all()
    # tangent to the shore (the island's bar: the stream lines turn round the inner corners,
    # so the normal part, 3.3 % a quarter metre in and 1.8 % an eighth, vanishes at the shore)
    ratios = _normal_ratios(field, graph, shore, (0.25, 0.125))
    assert ratios[1].max() <= 0.02, ratios[1].max()
    assert ratios[1].max() < 0.65 * ratios[0].max()
    assert np.percentile(ratios[0], 99) < 0.02              # measured 1.3 %
    # tracers from both inlets reach the outlet, none leaves the water
    across = np.linspace(-0.4, 0.4, 5)
    north = np.c_[-190.0 + 40.0 * across, np.full(5, 400.0)]
    west = np.c_[np.full(5, -400.0), -130.0 + 36.0 * across]
    reached, left = _trace(field, np.vstack([north, west]), lambda p: p[:, 1] > 400.0)
    assert reached.all() and not left.any()
    # the bay: slow water (under a tenth of the lake's median speed) that still moves, and
    # tracers in it stay on the water
    in_bay = pts[water & shapely.contains_xy(BAY, *pts.T)][:20]
    assert len(in_bay) >= 10
    _, vb = field.query(in_bay)
    bay_speed = np.hypot(*vb.T)
    lake_speed = np.median(np.hypot(*field.query(pts[water])[1].T))
    assert np.median(bay_speed) < 0.1 * lake_speed and (bay_speed > 0).all()
    _, left = _trace(field, in_bay, lambda p: np.zeros(len(p), bool), dt=10.0, steps=60)
    assert not left.any()
    # across the flow tiles' borders in the lake: ψ and the velocity continuous
    _across_tile_borders(field, lake.buffer(-3.0), (-250, 330), (-200, 300), 120)


def test_a_lake_alone_passes_validation_with_or_without_an_island():
    """A lake no river touches is still water; its shore is a loop of banks only, which
    validate_graph took for an island running counter-clockwise ("reverse it")."""
    for lake in (shapely.Point(0, 0).buffer(30),
                 shapely.Point(0, 0).buffer(30).difference(shapely.Point(0, 0).buffer(15))):
        b = RiverNetworkBuilder()
        b.add_lake(lake)
        assert rf.validate_graph(b.build()) == []


def test_loop_depths_ask_on_the_water_side_of_a_loop():
    """München's OSM: a basin at an island's tip, its mouth on the island's shore (its loop's
    first vertex on the island's loop): asked at that vertex, only the river's loop held it
    ("counter-clockwise loop inside another area"); asked a hair inside its water, the island
    holds it too: depth 2, water again. The river's outer loop 0, the island 1."""
    from riverflow.hydro._checks import loop_depths

    river = np.array([[0, 0], [100, 0], [100, 100], [0, 100], [0, 0]], float)       # ccw
    island = np.array([[30, 30], [30, 70], [70, 70], [70, 30], [30, 30]], float)     # cw
    basin = np.array([[70, 40], [70, 50], [60, 45], [70, 40]], float)  # ccw, in the island
    loops = [river, island, basin]
    polys = [shapely.Polygon(lp) for lp in loops]
    assert list(loop_depths(loops, polys, [0, 1, 2])) == [0, 1, 2]


def test_an_inlet_that_runs_along_a_terminal_lakes_shore_is_drawn_back():
    """An inlet of a terminal lake whose last stretch (6 m) runs along the lake's shore
    before it ends (München's Isar lines): drawn back along that stretch to a tenth of its
    width it is still beside the shore, so the stretch is dropped and the one before drawn
    back until its strip is clear of the lake (it was "end the branch square to the
    shore"). Still water, the river running towards it."""
    b = RiverNetworkBuilder()
    b.add_branch([(-600.0, 0.0), (-151.0, 0.0), (-150.5, 6.0)], 30.0, discharge_m2s=10.0)
    b.add_lake(LAKE)
    graph = b.build()
    assert b.terminal_lakes == [0]
    (axis,) = [graph.polyline(a) for a in graph.axes() if graph.curves[a].width_m < 100.0]
    end = axis[np.argmax(axis[:, 0])]
    assert -175.0 < end[0] < -150.0 and abs(end[1]) < 1e-6
    status, v = rf.FlowField(graph).query(np.array([[-400.0, 0.0], [0.0, 0.0]]))
    assert (status == rf.FlowStatus.INSIDE).all() and v[0, 0] > 0.1 and np.abs(v[1]).max() < 1e-6


def test_a_lake_smaller_than_a_rivers_sliver_is_kept():
    """Where lakes split the water, a river's piece under 0.01 squared widths is a sliver,
    dropped; a lake smaller than that (a 15 m pond on the bank of a 200 m river: Porto's
    with its lines) was dropped too ("cut it into 0 pieces"): its own piece is kept."""
    from shapely.geometry.polygon import orient

    from riverflow.hydro import _lakes

    pond = shapely.box(480, 90, 495, 105)
    water = orient(shapely.union_all([shapely.box(0, -100, 1000, 100), pond]), 1.0)
    polys, which, _ = _lakes.split_water([water], [_lakes.Lake(pond, None, "lake 0")], 1e-3,
                                         400.0)
    assert sorted(which) == [-1, 0]
    assert abs(polys[which.index(0)].area - pond.area) < 1e-6


def test_a_long_narrow_basins_axis_is_found():
    """A dock 4 m wide and 1.3 km long with two bends: the raster the path through a lake is
    found on had 6 m cells (a 160th of its extent), none in its water ("no way through");
    it has a quarter of the basin's mean width."""
    from shapely.geometry import LineString

    from riverflow.hydro import _lakes

    dock = LineString([(0, 0), (500, 0), (500, 300), (1000, 300)]).buffer(
        2.0, cap_style="flat", join_style="mitre")
    lake = _lakes.Lake(dock, None, "basin 0", basin=True, mouth=np.array([[0.0, -2.0], [0.0, 2.0]]))
    inside = dock.buffer(0.25)
    path = _lakes._path_through(lake, inside, np.array([0.0, 0.0]), np.array([999.0, 300.0]),
                                0.25)
    assert inside.contains(LineString(path)) and LineString(path).length < 1310.0
