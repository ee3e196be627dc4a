"""The Red Butte Creek example (../shared/data/gis/redbutte, a TauDEM-style stream network in
NAD83 / UTM 12N): every link is water, the flow along every centre line runs downstream,
discharge grows downstream, the axes are as long as the links, and it flows in a world."""
from __future__ import annotations

import numpy as np
import pytest
import shapely

import riverflow as rf
from tests.gis.conftest import along, require_gis

pyogrio, pyproj = require_gis()

pytestmark = pytest.mark.data


@pytest.fixture(scope="module")
def imported(request):
    from tests.gis.conftest import REDBUTTE

    if not REDBUTTE.exists():
        pytest.skip(f"shared data absent: {REDBUTTE}")
    builder = rf.read_rivers(REDBUTTE)
    graph = builder.build()
    _, _, wkb, columns = pyogrio.raw.read(str(REDBUTTE))
    # the graph's coordinates are the file's less a round origin (float32 drawing)
    lines = [shapely.get_coordinates(g) - builder.report.origin_m for g in shapely.from_wkb(wkb)]
    return builder, graph, lines, columns, rf.FlowField(graph)


def centre_lines(builder) -> list[np.ndarray]:
    """The links' centre lines as built (smoothed: the file's are traced on 10 m DEM cells),
    in the file's order."""
    by_name = {b.name: b.centerline_m for b in builder._branches}
    return [by_name[link.name] for link in builder.report.links]


def test_every_link_is_water_with_its_flow_running_downstream(imported):
    builder, graph, lines, _, field = imported
    assert rf.validate_graph(graph) == []
    assert len(builder.report.links) == len(lines) == 12
    assert builder.report.repairs == []          # clean data: nothing repaired
    for k, line in enumerate(centre_lines(builder)):
        pts, tangent = along(line, step=2.0)
        status, velocity = field.query(pts)
        assert (status == rf.FlowStatus.INSIDE).all(), \
            f"link {k}: {(status != rf.FlowStatus.INSIDE).sum()} of {len(pts)} points dry"
        downstream = np.einsum("ij,ij->i", velocity, tangent)
        assert (downstream > 0).all(), f"link {k}: {(downstream <= 0).sum()} points flow back"


def test_discharge_grows_downstream(imported):
    builder, _, lines, columns, field = imported
    grid_id, to_link, area = columns[0], columns[2], columns[3]
    # walk the chain from the top (the link no other flows into) to the outlet (ToLink 0)
    by_id = {int(g): k for k, g in enumerate(grid_id)}
    top = next(k for k in range(len(lines)) if int(grid_id[k]) not in set(to_link.astype(int)))
    chain = [top]
    while int(to_link[chain[-1]]) != 0:
        chain.append(by_id[int(to_link[chain[-1]])])
    assert len(chain) == len(lines)
    assert np.all(np.diff(area[chain]) > 0)          # the data: the drainage area grows
    given = np.array(builder.discharges_m2s)[chain]
    assert np.all(np.diff(given) > 0)                  # so does the discharge built
    # and the flow carries it: ψ across the middle of each link
    carried = []
    centre = centre_lines(builder)
    for k in chain:
        mid, tangent = along(centre[k], step=1.0)
        i = len(mid) // 2
        normal = np.array([-tangent[i, 1], tangent[i, 0]])
        half = 0.5 * builder.report.links[k].width_m
        s = np.linspace(-1.5 * half, 1.5 * half, 301)
        psi = field.potential(mid[i] + s[:, None] * normal)
        carried.append(np.nanmax(psi) - np.nanmin(psi))
    carried = np.array(carried)
    np.testing.assert_allclose(carried, given, rtol=0.03)
    assert np.all(np.diff(carried) > 0)


def test_axes_are_as_long_as_the_links(imported):
    builder, graph, lines, _, _ = imported
    traced_m = sum(float(np.hypot(*np.diff(p, axis=0).T).sum()) for p in lines)
    links_m = sum(float(np.hypot(*np.diff(p, axis=0).T).sum()) for p in centre_lines(builder))
    axes_m = sum(float(np.hypot(*np.diff(graph.polyline(a), axis=0).T).sum()) for a in graph.axes())
    assert axes_m == pytest.approx(links_m, rel=0.02)
    assert builder.report.length_m == pytest.approx(links_m, rel=1e-3)
    # a staircase of 8 directions is longer than the creek it traces (by up to 8 %, for
    # a course 22.5° off the grid); smoothed, the centre lines are shorter, not much
    assert 0.9 * traced_m < links_m < traced_m


def test_no_staircase_of_grid_cells(imported):
    """The file's lines are traced on a 10 m DEM: a staircase of 45° and 90° turns at its
    vertices, for a creek 2 - 3 m wide (over a fifth of its 5 m stretches turn by 45° or
    more). As built, no 5 m of centre line turns by 35° (31° on today's data, at a bend the
    DEM traced at a right angle), and they lie within half a cell's
    diagonal (7.07 m, the smoothing's bound) of the lines as traced; the links still meet."""
    builder, graph, lines, _, _ = imported
    assert "12 grid-traced links (on a lattice of 10 m cells)" in builder.derived["centre_lines"]

    def turns(line, metres=5):
        """How much the line's direction changes over each `metres` of it [°]."""
        _, tangent = along(line, step=1.0)
        return np.degrees(np.arccos(np.clip(np.einsum("ij,ij->i", tangent[:-metres],
                                                      tangent[metres:]), -1.0, 1.0)))

    data = np.concatenate([turns(p) for p in lines])
    assert data.max() >= 89.9 and (data >= 45.0).mean() > 0.1           # the data: steps
    for axis in graph.axes():
        assert turns(graph.vertices(axis)).max() < 35.0
    traced = shapely.union_all([shapely.LineString(p) for p in lines])
    for line in centre_lines(builder):
        assert shapely.distance(shapely.points(line), traced).max() <= 0.5 * 2 ** 0.5 * 10 + 1e-6
    ends = np.array([[p[0], p[-1]] for p in centre_lines(builder)])
    # a chain: each link starts where another ends (but the top), as in the file
    starts, stops = ends[:, 0], ends[:, 1]
    joined = np.hypot(*(starts[:, None, :] - stops[None, :, :]).transpose(2, 0, 1)).min(axis=1)
    assert np.sort(joined)[:-1].max() < 1e-6 and (joined > 1.0).sum() == 1


def test_the_import_says_what_it_derived(imported):
    builder, graph, lines, *_ = imported
    report = builder.report
    assert "EPSG:26912" in str(report) and report.origin_m == (433000.0, 4516000.0)
    back = pyproj.Transformer.from_crs(pyproj.CRS.from_wkt(graph.crs), "EPSG:26912",
                                       always_xy=True)
    x, y = back.transform(*lines[0][0])
    np.testing.assert_allclose([x, y], lines[0][0] + report.origin_m, atol=1e-6)
    assert graph.crs is not None and builder.crs == graph.crs
    assert report.derived["discharge"] == {"hydraulic geometry of the drainage area": 12}
    assert report.derived["width_m"] == {"hydraulic geometry of the discharge": 12}
    assert any("usarea_km2" in n for n in report.notes)
    assert graph.water_levels is not None


@pytest.mark.slow
def test_it_flows_in_a_world(imported):
    builder, graph, lines, _, _ = imported
    scene = rf.landscape(graph)
    # the water follows the bed elevations of the data (uselev_m / dselev_m), downhill
    top, bottom = lines[0][0], lines[1][-1]
    levels = scene.water.level(np.array([top, bottom]))
    assert 1880.0 < levels[0] < 1910.0 and 1630.0 < levels[1] < 1645.0
    assert np.all(np.diff(scene.water.levels_m[scene.water.branch == 0]) <= 0)
    world = rf.RiverWorld(scene, size=(160, 90), gl=False, seed=0,
                          config=rf.RiverConfig(radius_px=6, tile_production="blocking"))
    with world:
        centre = centre_lines(builder)[5]
        p = centre[len(centre) // 2]
        z = float(graph.water_levels(p[None])[0])
        world.camera.look_at((p[0] - 8.0, p[1] - 8.0, z + 6.0), (p[0], p[1], z))
        for _ in range(20):
            world.step(1 / 30)
        particles = world.particles
        inside = particles.status == rf.FlowStatus.INSIDE
        assert inside.sum() > 10
        assert np.isfinite(particles.world_m).all()


@pytest.mark.slow
def test_the_boat_demo_floats_down_red_butte(imported):
    """The demo's boat, sized to the creek (2 m wide: its beam a third of that), starts on the
    water and the flow carries it downstream (no throttle)."""
    from riverflow.demo import BoatDemo

    _, graph, _, _, field = imported
    demo = BoatDemo(rf.landscape(graph), size=(160, 90), gl=False,
                    config=rf.RiverConfig(radius_px=8, tile_production="blocking"))
    try:
        boat = demo.boat_state
        assert boat.beam_m < 1.0 and boat.length_m < 3.0
        start = boat.position_m.copy()
        for _ in range(120):
            demo.step()
        moved = boat.position_m - start
        status, velocity = field.query(start[None])
        assert status[0] == rf.FlowStatus.INSIDE
        assert float(moved @ velocity[0]) > 0.0          # downstream, with the flow
        assert field.query(boat.position_m[None])[0][0] == rf.FlowStatus.INSIDE
    finally:
        demo.close()
