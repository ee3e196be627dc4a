"""Live edits keep what the network carries (issue 25): hand-placed falls and rapids move
with their branch (dropped, and said so, only when the branch goes), and the spills' mass is
carried to the new network's cells, none lost or made. The dam scene's lake:
tests/scenes/test_dam_scene.py.

One small world (two rivers 500 m apart, a fall and a rapid on the first, an 80 × 60 frame,
no OpenGL) is shared by the module; each test checks what one edit does, from whatever
network the world has then (so the tests pass alone and in any order)."""
from __future__ import annotations

import numpy as np
import pytest

from riverflow.engine.config import RiverConfig
from riverflow.engine.edits import edited_branches, edited_scene, fill_discharges
from riverflow.engine.world import RiverWorld
from riverflow.hydro.builder import RiverNetworkBuilder
from riverflow.scenes.landscape import landscape

WIDTH_M = 20.0
FALL_AT, RAPID_AT = 0.3, (0.55, 0.65)


def _line(y0: float) -> np.ndarray:
    x = np.linspace(-200.0, 200.0, 21)
    return np.c_[x, y0 + 8.0 * np.sin(x / 60.0)]


def _arc(line: np.ndarray) -> np.ndarray:
    return np.r_[0.0, np.cumsum(np.hypot(*np.diff(line, axis=0).T))]


@pytest.fixture(scope="module")
def world():
    builder = RiverNetworkBuilder(tolerance_m=0.25)
    builder.add_branch(_line(0.0), WIDTH_M, 10.0, name="falls")
    builder.add_branch(_line(500.0), WIDTH_M, 10.0, name="calm")
    n = _arc(_line(0.0))[-1]
    builder.add_fall(FALL_AT * n, 3.0, branch="falls")
    builder.add_rapids(RAPID_AT[0] * n, RAPID_AT[1] * n, 1.5, branch="falls")
    scene = landscape(builder.build(), lambda x, y: 8.0 - 0.004 * x + 0.0 * y, cell_m=4.0,
                      pad_m=64.0)
    w = RiverWorld(scene, size=(80, 60), seed=0, gl=False,
                   config=RiverConfig(tile_worker="thread"))
    yield w
    w.close()


def _bumped(line: np.ndarray, dy_m: float) -> np.ndarray:
    s = _arc(line)
    out = line.copy()
    out[1:-1, 1] += dy_m * np.sin(np.pi * s[1:-1] / s[-1])
    return out


def _fractions(scene):
    n = _arc(scene.branches[0].centerline_m)[-1]
    (fall,), (rapid,) = scene.graph.falls, scene.graph.rapids
    return fall, rapid, fall.at_m / n, (rapid.from_m / n, rapid.to_m / n)


def test_a_fall_and_a_rapid_move_with_their_branch(world):
    w = world
    fall, rapid, at, reach = _fractions(w.scene)
    line = w.scene.branches[0].centerline_m
    new_line = _bumped(line, 25.0)
    w.move_axis(0, new_line)
    moved, moved_rapid, at_now, reach_now = _fractions(w.scene)
    assert not w.edits.last["dropped"]
    assert (moved.drop_m, moved.kind, moved_rapid.drop_m) == (fall.drop_m, fall.kind,
                                                              rapid.drop_m)
    assert at_now == pytest.approx(at, abs=1e-3) and reach_now == pytest.approx(reach, abs=1e-3)
    # on the new centre line, where the fraction puts it; the water drops there
    s = _arc(new_line)
    where = np.array([np.interp(at * s[-1], s, new_line[:, i]) for i in (0, 1)])
    assert np.hypot(*(np.asarray(moved.centre_m) - where)) < 1.0
    assert np.hypot(*(np.asarray(moved.centre_m) - fall.centre_m)) > 5.0
    d = 3.0 * np.asarray(moved.direction)
    above, below = w.scene.water.level(np.array([where - d, where + d]))
    assert above - below > 0.5 * fall.drop_m


def test_a_fall_is_dropped_and_said_so_only_when_its_branch_goes(world):
    scene = world.scene
    fill_discharges(scene, world.field)       # (a scene made from a graph: as an edit does)
    dropped = []
    new, graph = edited_scene(scene, edited_branches(scene, "remove", 0),
                              dropped=dropped)
    assert not graph.falls and not graph.rapids and len(dropped) == 2
    name = scene.branches[0].name     # (a scene made from a graph: named after its axes)
    assert all(repr(name) in d and "gone" in d for d in dropped)
    dropped = []
    new, graph = edited_scene(scene, edited_branches(scene, "width", 1, widths=16.0),
                              dropped=dropped)
    assert not dropped and len(graph.falls) == len(graph.rapids) == 1


def test_a_spills_mass_is_the_same_after_an_edit(world):
    w = world
    line = w.scene.branches[1].centerline_m
    row = w.add_spill(line[6], 500.0)
    w.advance_spills(120.0)                       # a plume some way down the river
    before = w.spill(row)
    assert before.in_water_kg > 0.9 * 500.0
    new_line = _bumped(line, -20.0)
    w.move_axis(1, new_line)
    after = w.spill(row)
    # the spills run on the new network's cells now (the edited river's, where it is now)
    import shapely

    centre = shapely.LineString(new_line)
    net = w.spill_solver.network
    cells = net.cell_xy_m[net.cell_link == net.names.index(w.scene.branches[1].name)]
    assert shapely.distance(centre, shapely.points(cells)).max() < 1e-6
    assert shapely.distance(centre, shapely.Point(after.front_xy_m)) < 0.5 * WIDTH_M
    assert shapely.distance(shapely.LineString(line), shapely.Point(after.front_xy_m)) > 5.0
    assert after.in_water_kg == pytest.approx(before.in_water_kg, rel=1e-12)
    assert after.released_kg == before.released_kg and abs(after.balance_kg) < 1e-9
    # the same place along the river: the front's distance from the source ~ the same
    assert after.front_m == pytest.approx(before.front_m, rel=0.1, abs=10.0)
    w.advance_spills(60.0)                       # and it goes on, conserved
    assert abs(w.spill(row).balance_kg) < 1e-9
    assert w.concentration(after.front_xy_m[None, :])[0] >= 0.0


def test_a_running_flood_keeps_its_wave_across_an_edit(world):
    from riverflow.hydro.flood import FloodRouter

    w = world
    calm = w.scene.branches[1].name
    w.set_hydrograph(calm, [w.flood_time_s, w.flood_time_s + 30.0], [20.0, 60.0])
    # the level's textures made with the router, in this call, not in a frame
    assert w.flood.textures_made
    w.advance_flood(90.0)                        # a wave part-way down the river
    router = w.flood
    net = router.network
    on = net.cell_link == net.names.index(calm)
    rise = router.cell_level_rise_m()[on]
    assert rise.max() > 0.05 and rise.min() < 0.5 * rise.max()
    w.set_width(0, 18.0)                          # the other river edited
    router = w.flood
    # its level's textures made with the edit, not by the first frame that reads the
    # raised level (the particles' altitudes: ~0.2 s in that frame, drawn or not): the
    # textures a router made afresh on that network has (tests/engine/test_flood.py: only
    # the blocks near what changed are made again)
    assert router.textures_made
    fresh = FloodRouter(router.network).level_textures()
    assert fresh[0] == router.level_textures()[0]
    assert np.array_equal(fresh[1], router.level_textures()[1])
    net = router.network
    on = net.cell_link == net.names.index(calm)
    assert np.array_equal(router.cell_level_rise_m()[on], rise)   # the same wave, carried
    assert router.time_s == pytest.approx(w.flood_time_s, abs=router.dt_s)
    before = router.cell_level_rise_m()[on].copy()
    w.advance_flood(30.0)                         # and it goes on moving
    assert not np.array_equal(w.flood.cell_level_rise_m()[on], before)
    w.set_hydrograph(calm, None, None)            # (the module's world back to base flow)
