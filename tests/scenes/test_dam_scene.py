"""The built-in scene with a dam (``default_scene(dam=True)``, issue 25 item 4): a reservoir on
the main river, drawn as water with a flat level over a carved bed, whose release is routed
from its outlet downstream."""
import numpy as np
import pytest
import shapely

import riverflow as rf
from riverflow.hydro.areas import area_ring
from riverflow.hydro.flood import BROAD_CRESTED_WEIR, level_pool_release
from riverflow.scenes.default import DAM_OUTLET


@pytest.fixture(scope="module")
def world():
    w = rf.RiverWorld(rf.default_scene(seed=0, dam=True), size=(48, 32), gl=False, seed=0)
    yield w
    w.close()


@pytest.fixture(scope="module")
def lake(world):
    (area,) = world.scene.graph.lakes()
    return shapely.Polygon(area_ring(world.scene.graph, area))


def _inside(lake, n=600, inset_m=10.0):
    rng = np.random.default_rng(3)
    x0, y0, x1, y1 = lake.bounds
    p = rng.uniform((x0, y0), (x1, y1), (n, 2))
    return p[shapely.contains_xy(lake.buffer(-inset_m), p[:, 0], p[:, 1])]


def test_the_main_river_is_cut_at_the_reservoirs_shore(world, lake):
    names = [b.name for b in world.scene.branches]
    k = names.index("reservoir")
    above, through, below = world.scene.branches[k - 1:k + 2]
    assert (above.name, below.name) == ("main_upper", DAM_OUTLET)
    assert above.end_junction == through.start_junction
    assert through.end_junction == below.start_junction
    for p in (above.centerline_m[-1], below.centerline_m[0]):     # the mouths, on the shore
        assert lake.exterior.distance(shapely.Point(p)) < 1e-6
    assert lake.area > 0.9 * np.pi / 4 * 520.0 * 300.0


def test_the_lake_is_water_with_a_flat_level_over_a_carved_bed(world, lake):
    scene = world.scene
    p = _inside(lake)
    assert len(p) > 200
    status, v = world.field.query(p)
    assert (status == rf.FlowStatus.INSIDE).all()             # water in the flow field
    assert np.isfinite(v).all()
    assert scene.water.contains(p).all()
    _, level, _ = scene.water.nearest(p)
    assert np.ptp(level) < 1e-9                               # flat
    drawn = world.water_level(p)
    assert np.ptp(drawn) < 1e-6 and drawn[0] == pytest.approx(level[0])
    bed = scene.terrain.height(p)                             # what the terrain tiles draw
    assert (bed < level - 0.5).all()                          # no land left in the lake
    # the reservoir stands at its inflowing river's level: the water steps down at the dam
    outlet = scene.branch(DAM_OUTLET).centerline_m
    below = outlet[len(outlet) // 2]
    assert float(world.water_level(below[None])[0]) < level[0] - 0.5


def test_the_dams_release_starts_at_the_outlet_and_runs_downstream(world):
    scene = world.scene
    world.set_hydrograph(None, [], None)
    router = world.flood
    names = list(router.network.names)
    out = names.index(DAM_OUTLET)
    q0 = float(router.net.link_q0[out])
    head, factor = 5.0, 6.0
    t, q = level_pool_release(4e5, head, factor * q0 / (BROAD_CRESTED_WEIR * head ** 1.5), q0,
                              3 * 3600.0, points=61)
    assert q[0] == pytest.approx(factor * q0)
    now = world.flood_time_s
    world.set_hydrograph(DAM_OUTLET, np.concatenate([[now], now + 1.0 + t]),
                         np.concatenate([[q0], q]))

    def at(name, frac):
        line = scene.branch(name).centerline_m
        return line[int(frac * (len(line) - 1))][None, :]

    above, below_dam = at("main_upper", 0.5), at(DAM_OUTLET, 0.1)
    downstream = at("main_middle", 0.6)
    base_down = float(router.discharge(downstream)[0])
    world.advance_flood(120.0)
    assert float(router.discharge(below_dam)[0]) > 3.0 * q0        # at once below the dam
    assert float(router.discharge(downstream)[0]) < 1.01 * base_down  # not there yet
    peak = 0.0
    for _ in range(30):
        world.advance_flood(120.0)
        peak = max(peak, float(router.discharge(downstream)[0]))
    assert peak > base_down + 2.0 * q0                             # the wave got there
    assert float(router.discharge(above)[0]) == pytest.approx(q0, rel=1e-6)  # held above
    assert np.isfinite(router.a).all()


def test_release_dam_sets_the_outlets_hydrograph_and_refuses_a_scene_without_a_dam(world):
    from types import SimpleNamespace

    from riverflow.demo import release_dam

    now = world.flood_time_s
    link, times, flows = release_dam(world, factor=4.0, after_s=10.0)
    router = world.flood
    q0 = float(router.net.link_q0[router.link_index(DAM_OUTLET)])
    assert link == DAM_OUTLET
    assert times[0] == now and times[1] == pytest.approx(now + 11.0)
    assert flows[0] == pytest.approx(q0) and flows[1] == pytest.approx(4.0 * q0)
    assert np.all(np.diff(flows[1:]) <= 1e-9)                 # falls as the reservoir empties
    with pytest.raises(ValueError, match="no branch 'main_below_dam'"):
        release_dam(SimpleNamespace(scene=rf.default_scene(seed=0)))
    with pytest.raises(ValueError, match="factor"):
        release_dam(world, factor=float("nan"))


def test_the_command_lines_dam_flag_loads_the_dam_scene():
    from riverflow.__main__ import _parser
    from riverflow.gis.cli import load_scene

    scene, title = load_scene(_parser().parse_args(["demo", "--dam"]))
    assert title.endswith(", dam") and scene.branch(DAM_OUTLET) is not None
    scene, title = load_scene(_parser().parse_args(["demo"]))
    assert "dam" not in title and all(b.name != DAM_OUTLET for b in scene.branches)


def test_an_edit_of_the_river_above_keeps_the_reservoir(world, lake):
    """A live edit rebuilds the network from the scene's branches (issue 25): the lake goes
    with it, same shore, same flat level, and the reservoir's branch stays in it. Made at the
    scene's level (what ``world.set_width`` swaps in), the module's world left as it is."""
    from riverflow.engine.edits import edited_branches, edited_scene

    scene = world.scene
    above = scene.branch("main_upper")
    dropped = []
    new, graph = edited_scene(scene, edited_branches(scene, "width", above.name,
                                                     widths=0.9 * above.widths_m),
                              dropped=dropped)
    assert not dropped
    (area,) = graph.lakes()
    kept = shapely.Polygon(area_ring(graph, area))
    assert kept.symmetric_difference(lake).area < 1e-6 * lake.area
    p = _inside(lake, n=300)
    _, old_level, _ = scene.water.nearest(p)
    _, level, _ = new.water.nearest(p)
    assert np.ptp(level) < 1e-9 and level[0] == pytest.approx(old_level[0], abs=1e-9)
    assert new.water.contains(p).all()
    assert new.branch("main_upper").widths_m == pytest.approx(0.9 * above.widths_m)
    assert [b.name for b in new.branches] == [b.name for b in scene.branches]
    assert new.branch(DAM_OUTLET).discharge_m2s == pytest.approx(above.discharge_m2s)
