"""Spills (issue 24): a tracer carried down the river network by the 1-D advection–dispersion
solver (riverflow/kernels/spill.py), its world API and its bookkeeping.

Tests of record: the analytic Gaussian in a straight uniform channel, mass conservation at
every step of a 6-hour run on the built-in network (confluence and bifurcation), the split at
the bifurcation by discharge, decay, camera independence and bad input.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

import riverflow as rf
from riverflow.hydro.spill_network import Dispersion, build_spill_network
from riverflow.hydro import spills
from riverflow.hydro.spills import SpillSolver, SpillSource
from riverflow.kernels.spill import SpillBook, spill_steps
from tests.engine import cell_networks
from tests.engine.cell_networks import branch, straight


def _source(network, link, s_m):
    c0 = int(network.net.link_c0[link])
    cell = c0 + int(s_m / network.link_dx_m[link])
    xy = np.interp(s_m, [0, network.link_length_m[link]], [0, 1])
    return SpillSource(np.array([xy, 0.0]), 0.0, link, s_m, cell, 0.5, 0.0, 1.0)


# -- the kernel against its plain-numpy twin ---------------------------------------------------

def _twin_step(net, mass, released, outflow, decayed, passed, src, t0, t1, total, decay, t, dt):
    """One step of riverflow.kernels.spill.spill_steps, vectorised per link with numpy."""
    for s in range(mass.shape[0]):
        if t + dt < t0[s]:
            target = 0.0
        elif t + dt >= t1[s]:
            target = total[s]
        else:
            target = total[s] * (t + dt - t0[s]) / (t1[s] - t0[s])
        add = target - released[s]
        if add > 0:
            mass[s, src[s]] += add
            released[s] += add
        if released[s] == 0.0:
            continue
        m = mass[s].copy()
        c = m / net.cell_vol
        new = m.copy()
        node = np.zeros(max(int(max(net.link_end.max(), net.link_start.max())) + 1, 1))
        for b in range(len(net.link_c0)):
            a, e = int(net.link_c0[b]), int(net.link_c1[b])
            if net.link_start[b] >= 0:
                new[a] += node[net.link_start[b]] * net.link_share[b]
            ci, cn = c[a:e - 1], c[a + 1:e]
            dc = cn - ci
            cp = np.concatenate([[np.nan], c[a:e - 2]])
            with np.errstate(divide="ignore", invalid="ignore"):
                r = (ci - cp) / dc
                phi = np.where((dc != 0) & (np.arange(len(ci)) > 0), (r + np.abs(r)) / (1 + np.abs(r)),
                               0.0)
            q = net.cell_q[a:e - 1]
            cr = q * dt / net.cell_vol[a:e - 1]
            f = dt * (q * (ci + 0.5 * (1 - cr) * phi * dc) + net.face_k[a:e - 1] * (ci - cn))
            new[a:e - 1] -= f
            new[a + 1:e] += f
            out = dt * net.cell_q[e - 1] * c[e - 1]
            new[e - 1] -= out
            passed[s, b] += out
            if net.link_end[b] >= 0:
                node[net.link_end[b]] += out
            else:
                outflow[s, net.link_outlet[b]] += out
        if decay[s] > 0:
            kept = new * math.exp(-decay[s] * dt)
            decayed[s] += (new - kept).sum()
            new = kept
        mass[s] = new


@pytest.fixture(scope="module")
def diamond():
    """A source splitting at a bifurcation into two arms of different discharges that meet
    again, a tributary joining below, and an outlet."""
    return cell_networks.diamond()


def test_kernel_matches_numpy_twin(diamond):
    net = diamond.net
    rng = np.random.default_rng(3)
    n, o, b = diamond.n_cells, len(diamond.outlets), len(diamond.names)
    mass = rng.uniform(0.0, 5.0, (2, n))
    src = np.array([2, diamond.net.link_c0[3] + 1], np.int32)
    t0, t1 = np.array([0.0, 5.0]), np.array([0.0, 200.0])
    total, decay = np.array([100.0, 50.0]), np.array([0.0, 1e-3])
    book = SpillBook(mass.copy(), src, t0, t1, total, decay, np.zeros(2), np.zeros((2, o)),
                     np.zeros(2), np.zeros((2, b)))
    twin = [mass.copy(), np.zeros(2), np.zeros((2, o)), np.zeros(2), np.zeros((2, b))]
    dt = diamond.dt_max_s
    spill_steps(net, book, 0.0, dt, 40, np.zeros(n), np.zeros(diamond.n_nodes))
    for k in range(40):
        _twin_step(net, twin[0], twin[1], twin[2], twin[3], twin[4], src, t0, t1, total, decay,
                   k * dt, dt)
    for got, want in zip((book.mass, book.released, book.outflow, book.decayed, book.passed), twin):
        np.testing.assert_allclose(got, want, rtol=1e-10, atol=1e-10)
    assert book.released[1] > 0 and (book.mass >= -1e-12).all()


def test_bifurcation_splits_by_discharge_and_mass_is_kept(diamond):
    solver = SpillSolver(diamond)
    solver.add(_source(diamond, 0, 300.0), "a", 1000.0, 0.0, 0.0)
    for _ in range(60):
        solver.advance(120.0)
        r = solver.report(0)
        assert abs(r.balance_kg) <= 1e-9 * 1000.0
    passed = r.passed_kg
    assert passed["top"] == pytest.approx(1000.0, rel=1e-6)   # all of it has gone by
    assert passed["left"] / passed["right"] == pytest.approx(25.0 / 15.0, rel=0.03)
    assert r.out_kg["bottom"] > 0.99 * 1000.0
    assert passed["trib"] == 0.0         # nothing goes up a tributary


# -- the analytic Gaussian ---------------------------------------------------------------------

def test_instant_release_in_a_straight_channel_is_the_analytic_gaussian():
    W, U = 50.0, 1.0
    network = build_spill_network([branch("channel", straight(7000.0), W)], [U * W])
    D = float(network.cell_k_m2s[0])             # Fischer's, uniform along the channel
    h = float(network.link_depth_m[0])
    assert np.allclose(network.cell_k_m2s, D) and 50.0 < D < 500.0
    assert np.allclose(network.cell_speed_mps, U)
    solver = SpillSolver(network)
    src = _source(network, 0, 1000.0)
    solver.add(src, "a", 1000.0, 0.0, 0.0)
    x0 = float(network.cell_s_m[src.cell - int(network.net.link_c0[0])])
    station = x0 + 2000.0
    t, c = [], []
    while solver.time_s < 4500.0:
        solver.advance(solver.dt_s)
        t.append(solver.time_s)
        c.append(network.interpolate(solver.cell_concentration(), np.array([0]),
                                     np.array([station]))[0, 0])
    t, c = np.array(t), np.array(c)
    exact = 1000.0 / (W * h * np.sqrt(4 * np.pi * D * t)) * np.exp(-(station - x0 - U * t) ** 2
                                                                    / (4 * D * t))

    def spread(y):
        m = np.trapezoid(y, t)
        mu = np.trapezoid(y * t, t) / m
        return math.sqrt(np.trapezoid(y * (t - mu) ** 2, t) / m)

    assert t[np.argmax(c)] == pytest.approx(t[np.argmax(exact)], rel=0.02)
    assert c.max() == pytest.approx(exact.max(), rel=0.05)
    assert spread(c) == pytest.approx(spread(exact), rel=0.05)


def test_decay_is_exponential():
    network = build_spill_network([branch("channel", straight(6000.0), 40.0)], [40.0])
    solver = SpillSolver(network)
    k = 2e-4
    solver.add(_source(network, 0, 500.0), "a", 10.0, 0.0, k)
    solver.advance(1500.0)          # the plume is still in the channel
    r = solver.report(0)
    assert r.in_water_kg == pytest.approx(10.0 * math.exp(-k * r.time_s), rel=0.01)
    assert sum(r.out_kg.values()) < 1e-6
    assert r.in_water_kg + r.decayed_kg == pytest.approx(10.0, rel=1e-9)


# -- the world: the built-in network -----------------------------------------------------------

@pytest.fixture(scope="module")
def scene():
    return rf.default_scene(seed=0)


@pytest.fixture(scope="module")
def spilled(scene):
    """A world with an instant spill on the upper main river and a one-hour release with
    decay on the tributary, run for 6 hours, the balance checked at every step."""
    world = rf.RiverWorld(scene, size=(64, 36), gl=False, seed=0)
    up = scene.branch("main_upper").centerline_m
    trib = scene.branch("tributary").centerline_m
    a = world.add_spill(up[len(up) // 5], 1000.0, name="upper")
    b = world.add_spill(trib[len(trib) // 3], 500.0, 3600.0, decay_per_s=1e-4)
    solver = world.spill_solver
    book = solver.book
    worst = 0.0
    while solver.time_s < 6 * 3600.0:
        solver.advance(solver.dt_s)
        kept = book.mass.sum(axis=1) + book.outflow.sum(axis=1) + book.decayed
        worst = max(worst, float(np.max(np.abs(kept - book.released) / book.release_kg)))
    yield world, a, b, worst
    world.close()


def test_mass_is_conserved_at_every_step_of_six_hours(spilled):
    world, a, b, worst = spilled
    assert worst <= 0.005
    assert worst < 1e-9            # by construction: to rounding
    ra, rb = world.spill(a), world.spill(b)
    assert ra.name == "upper" and rb.name == "spill 1"
    assert ra.released_kg == 1000.0 and rb.released_kg == pytest.approx(500.0)
    assert sum(ra.out_kg.values()) > 0.99 * 1000.0       # 6 h: it has left by the outlet
    assert rb.decayed_kg > 0.0


def test_split_at_the_builtin_bifurcation_follows_discharge(spilled, scene):
    world, a, _, _ = spilled
    passed = world.spill(a).passed_kg
    q = {b.name: b.discharge_m2s for b in scene.branches}
    assert passed["arm_left"] / passed["arm_right"] == pytest.approx(
        q["arm_left"] / q["arm_right"], rel=0.03)
    assert passed["tributary"] == 0.0


def test_front_tail_and_concentration_queries(scene):
    world = rf.RiverWorld(scene, size=(64, 36), gl=False, seed=0)
    up = scene.branch("main_upper").centerline_m
    e = world.add_spill(up[len(up) // 5], 100.0)
    world.advance_spills(300.0)
    r1 = world.spill(e)
    world.advance_spills(300.0)
    r2 = world.spill(e)
    assert r1.tail_m < 0.0 < r1.front_m < r2.front_m        # the front goes downstream
    assert r1.time_s == pytest.approx(300.0, abs=world.spill_solver.dt_s)
    assert r2.peak_kg_m3 < r1.peak_kg_m3                    # and the plume spreads
    # the query: zero on land, the cross-river mean of the 2-D plume is the solver's mean
    solver = world.spill_solver
    net = solver.network
    link = net.names.index("main_upper")
    cells = np.flatnonzero(net.cell_link == link)
    k = cells[np.argmax(solver.cell_concentration()[0, cells])]
    p, s = net.cell_xy_m[k], net.cell_s_m[k]
    line = net.lines[link]
    i = int(np.searchsorted(np.concatenate([[0], np.cumsum(np.hypot(*np.diff(line, axis=0).T))]), s))
    t = line[i] - line[i - 1]
    normal = np.array([-t[1], t[0]]) / np.hypot(*t)
    off = np.linspace(-net.cell_width_m[k], net.cell_width_m[k], 801)
    xy = p + off[:, None] * normal
    c = world.concentration(xy)
    psi = world.field.potential(xy)
    assert (c[~np.isfinite(psi)] == 0).all() and (c >= 0).all()
    wet = np.isfinite(psi)
    eta = (psi[wet] - solver.sources[0].psi_left) / (solver.sources[0].psi_right
                                                     - solver.sources[0].psi_left)
    order = np.argsort(eta)
    mean = np.trapezoid(c[wet][order], eta[order]) / (eta.max() - eta.min())
    assert mean == pytest.approx(solver.cell_concentration()[0, k], rel=0.1)
    assert world.concentration(np.array([[1e5, 1e5]]))[0] == 0.0
    assert world.concentration(xy, per_spill=True).shape == (1, len(xy))
    world.close()


def test_concentrations_do_not_depend_on_the_camera(scene):
    up = scene.branch("main_upper").centerline_m
    probes = np.vstack([up[::40], scene.branch("main_lower").centerline_m[::60]])
    results = []
    for flight in (0, 1):
        world = rf.RiverWorld(scene, size=(32, 18), gl=False, seed=0)
        world.speed_factor = 120.0
        world.add_spill(up[len(up) // 5], 1000.0)
        for frame in range(4):
            eye = (probes[(frame * (3 + 5 * flight)) % len(probes)][0], -400.0 * (1 + flight),
                   150.0 + 200.0 * flight)
            world.camera.look_at(eye, (eye[0], 0.0, 0.0))
            world.step(1 / 30)
        results.append((world.spill_solver.time_s, world.concentration(probes)))
        world.close()
    assert results[0][0] == results[1][0] == pytest.approx(4 / 30 * 120.0, abs=2.0)
    np.testing.assert_allclose(results[0][1], results[1][1], rtol=1e-6, atol=0.0)
    assert results[0][1].max() > 0.0


def test_bad_input(scene):
    world = rf.RiverWorld(scene, size=(48, 32), gl=False, seed=0)
    water = scene.water.polygon
    up = scene.branch("main_upper").centerline_m
    import shapely
    for bad in (dict(mass_kg=-1.0), dict(mass_kg=float("nan")), dict(mass_kg=0.0),
                dict(mass_kg=1.0, duration_s=-5.0), dict(mass_kg=1.0, duration_s=float("nan")),
                dict(mass_kg=1.0, decay_per_s=-1e-3), dict(mass_kg=1.0, decay_per_s=float("inf"))):
        with pytest.raises(ValueError, match="add_spill"):
            world.add_spill(up[50], **bad)
    with pytest.raises(ValueError, match="xy_m"):
        world.add_spill((float("nan"), 0.0), 1.0)
    # a point on land 30 m from the shore: moved to the water, and reported
    k = len(up) // 2
    t = up[k + 1] - up[k - 1]
    normal = np.array([-t[1], t[0]]) / np.hypot(*t)
    shore = up[k].copy()
    while shapely.contains_xy(water, *shore):
        shore += normal
    near = shore + 30.0 * normal
    far = shore + 80.0 * normal
    assert not shapely.contains_xy(water, *near)
    e = world.add_spill(near, 1.0)
    r = world.spill(e)
    assert 29.0 < r.moved_m < 40.0 and shapely.contains_xy(water, *r.source_xy_m)
    with pytest.raises(ValueError, match="on land"):
        world.add_spill(far, 1.0)
    with pytest.raises(ValueError, match="advance_spills"):
        world.advance_spills(-1.0)
    world.close()


def test_the_tint_texture_holds_the_concentrations(spilled):
    from riverflow.hydro.spills import TINT_TEXELS, SpillTint

    world, _, _, _ = spilled
    solver = world.spill_solver
    world.advance_spills(0.0)
    tint = SpillTint()
    colours = [(1.0, 0.0, 0.0), (0.0, 0.0, 1.0)]
    assert tint.update(solver, world.field, colours)
    assert not tint.update(solver, world.field, colours)    # nothing stepped
    x0, y0, side = tint.rect_m
    assert side > 0
    g = (np.arange(TINT_TEXELS) + 0.5) * side / TINT_TEXELS
    gx, gy = np.meshgrid(x0 + g, y0 + g)
    xy = np.column_stack([gx.ravel(), gy.ravel()])
    rgba = tint.rgba.reshape(-1, 4)
    # the query's way (locate, interpolate, transverse profile) with the plume widened to a
    # texel as the tint does (not to alias); the query itself where that changes nothing
    net = solver.network
    link, s, _ = net.locate(xy)
    # ψ from the flow tiles whose lattice is at most half a texel, as the tint reads it
    psi = world.field.potential(xy, level=world.field.level_for_spacing(0.5 * side / TINT_TEXELS))
    wet = np.isfinite(psi) & (link >= 0)
    assert wet.sum() > 100
    cells = solver.cell_concentration()
    c = np.array([net.interpolate(cells[k], link[wet], s[wet])
                  * solver.transverse(k, link[wet], s[wet], psi[wet], side / TINT_TEXELS)
                  for k in range(solver.n_spills)])
    np.testing.assert_allclose(rgba[wet, 3], c.sum(axis=0), rtol=1e-4, atol=1e-12)
    on = c.sum(axis=0) > 1e-20
    np.testing.assert_allclose(rgba[wet][on, 0], c[0, on] / c[:, on].sum(axis=0), rtol=1e-4)
    query = world.concentration(xy[wet], per_spill=True).sum(axis=0)
    untouched = np.abs(query - c.sum(axis=0)) <= 1e-6 * query.max()
    assert untouched.mean() > 0.45                          # most: 0.4996 of the texels here
    # a refresh changes only the rows it says (the draw system uploads those alone)
    assert tint.rows == (0, TINT_TEXELS)                    # a new square: all of them
    before = tint.rgba.copy()
    world.advance_spills(60.0)
    assert tint.update(solver, world.field, colours)
    if tint.rect_m == (x0, y0, side):
        first, end = tint.rows
        changed = np.flatnonzero((tint.rgba != before).any(axis=(1, 2)))
        assert len(changed) and first <= changed.min() and changed.max() < end
        assert end - first < TINT_TEXELS


def test_the_tint_places_its_squares_in_a_thread_and_the_frames_stay_deterministic(
        spilled, monkeypatch):
    """With frames (the draw system's way) no square with texels is placed in a frame: a
    thread places it, swapped in TINT_SWAP_FRAMES frames later whatever its time (two tints
    whose threads take random times give the same texture at every frame, bit for bit); the
    plume outgrows its square and the square drawn holds it at every frame once its growth
    is known (nothing cut off); a frame drawn again places at once."""
    import threading
    import time

    from riverflow.hydro import spills

    world = spilled[0]
    net = world.spill_solver.network
    solver = SpillSolver(net)
    up = world.scene.branch("main_upper").centerline_m
    solver.add(world._spill_source(up[len(up) // 5], net), "young", 1000.0, 0.0, 0.0)
    place = spills.place_texels
    delays = iter(np.random.default_rng(0).uniform(0.0, 0.04, 1000))
    in_frame = []

    def slow(*args, **kwargs):
        if threading.current_thread() is threading.main_thread():
            in_frame.append(args[2])
        else:
            time.sleep(next(delays))
        return place(*args, **kwargs)

    monkeypatch.setattr(spills, "place_texels", slow)
    a, b = spills.SpillTint(), spills.SpillTint()
    colours = [(1.0, 0.0, 0.0)]
    sides = []
    for frame in range(300):                    # 2 s a frame: clock.speed_factor 120 at 60 Hz
        solver.advance(2.0)
        a.update(solver, world.field, colours, frame)
        b.update(solver, world.field, colours, frame)
        assert a.rect_m == b.rect_m and a.version == b.version
        assert a.rgba.tobytes() == b.rgba.tobytes()
        if frame >= 2 * spills.TINT_SWAP_FRAMES:   # (the first square: before its growth
            assert spills._holds(a.rect_m, spills._extent(solver))      # was measured)
        sides.append(a.rect_m[2])
    assert all(rect[2] == 0.0 for rect in in_frame)     # (the empty square before the first)
    assert a.placements >= 3 and len(set(sides)) >= 3
    assert a.rgba[..., 3].max() > 0
    # a frame drawn again with a spill not placed yet: placed at once
    solver.add(world._spill_source(up[len(up) // 2], net), "late", 10.0, 0.0, 0.0)
    solver.advance(6.0)
    assert a.update(solver, world.field, colours * 2, frame, again=True)
    assert in_frame and in_frame[-1][2] > 0.0 and a.placed.n_spills == 2
    # the thread's field: the world's tiles in a cache of its own, the same ψ bit for bit
    xy = solver.network.cell_xy_m[::7]
    level = world.field.level_for_spacing(8.0)
    twin = world.field.detached(4)
    assert twin.tiles.cache is not world.field.tiles.cache
    np.testing.assert_array_equal(twin.potential(xy, level=level),
                                  world.field.potential(xy, level=level))


def test_a_graph_file_scene_gets_its_discharges_from_the_stream_function(tiny_channel_path):
    """A scene read from a graph file has no discharges in its branches: the spill network
    measures them across each link (ψ difference), and the spill runs out of its outlet."""
    scene = rf.landscape(rf.load_graph(tiny_channel_path), seed=0)
    assert all(b.discharge_m2s is None for b in scene.branches)
    world = rf.RiverWorld(scene, size=(32, 18), gl=False, seed=0)
    line = scene.branches[0].centerline_m
    e = world.add_spill(line[len(line) // 4], 10.0)
    net = world.spill_solver.network
    psi = world.field.potential(np.array([[50.0, y] for y in np.linspace(-30, 30, 601)]))
    assert net.link_q_m2s[0] == pytest.approx(np.nanmax(psi) - np.nanmin(psi), rel=0.01)
    world.advance_spills(600.0)
    r = world.spill(e)
    assert sum(r.out_kg.values()) == pytest.approx(10.0, rel=1e-6) and abs(r.balance_kg) < 1e-9
    world.close()


def test_bake_concentration_and_the_spill_command(tiny_channel_path, tmp_path):
    import csv
    import json

    from riverflow.gis.bake import pixel_centres
    from riverflow.gis.spill import read_concentration
    from tests.test_cli import cli

    scene = rf.landscape(rf.load_graph(tiny_channel_path), seed=0)
    world = rf.RiverWorld(scene, size=(32, 18), gl=False, seed=0)
    world.add_spill((10.0, 2.0), 5.0, 20.0)
    with pytest.raises(ValueError, match="increasing"):
        rf.bake_concentration(world, (0, -12, 100, 12), 2.0, tmp_path / "x", [10.0, 5.0])
    dt = world.spill_solver.dt_s
    baked = rf.bake_concentration(world, (0.0, -12.0, 100.0, 12.0), 2.0, tmp_path / "png",
                                  [4.0, 8.0], gauges_m=[(30.0, 0.0), (60.0, 0.0)],
                                  geotiff=False)
    assert baked.size_px == (50, 12) and len(baked.images) == 2
    assert abs(baked.times_s[1] - 8.0) <= dt
    c, meta = read_concentration(baked.images[1])
    want = world.concentration(pixel_centres((0.0, -12.0), 2.0, (50, 12))).reshape(12, 50)
    assert np.abs(c - want).max() <= want.max() / 65535 + 1e-15 and want.max() > 0
    rows = list(csv.reader(open(baked.gauges_csv)))
    assert rows[0] == ["time_s", "gauge_0", "gauge_1"] and len(rows) == 3
    assert float(rows[2][1]) == pytest.approx(world.concentration([(30.0, 0.0)])[0])
    index = json.loads(baked.index.read_text())
    assert index["frames"][1]["spills"][0]["released_kg"] == pytest.approx(5.0 * 8.0 / 20.0,
                                                                          abs=0.25 * dt)
    world.close()
    pytest.importorskip("rasterio")
    out = tmp_path / "cli"
    result = cli("spill", "--scene", str(tiny_channel_path), "--at", "20,30", "--mass", "2",
                 "--hours", "0.01", "--every", "0.3", "--cell-m", "4", "--out", str(out))
    assert result.returncode == 0, result.stderr
    assert "moved" in result.stdout and "GeoTIFF" in result.stdout
    tifs = sorted(out.glob("concentration_*.tif"))
    assert len(tifs) == 2 and (out / "gauges.csv").exists()
    c, meta = read_concentration(tifs[-1])
    assert c.max() > 0 and meta["transform"].a == 4.0
    far = cli("spill", "--scene", str(tiny_channel_path), "--at", "20,300", "--mass", "2",
              "--hours", "1", "--every", "30", "--out", str(tmp_path / "no"))
    assert far.returncode == 1 and "on land" in far.stderr


def test_dispersion_settings():
    line = straight(2000.0, 41)
    fixed = build_spill_network([branch("c", line, 30.0)], [30.0],
                                Dispersion(longitudinal_m2s=12.0, cell_m=10.0))
    assert np.all(fixed.cell_k_m2s == 12.0) and np.allclose(fixed.link_dx_m, 10.0)
    rough = build_spill_network([branch("c", line, 30.0)], [30.0], Dispersion(manning_n=0.06))
    smooth = build_spill_network([branch("c", line, 30.0)], [30.0])
    assert rough.cell_k_m2s[0] == pytest.approx(0.5 * smooth.cell_k_m2s[0])   # K ∝ 1/u* ∝ 1/n
    for bad in (dict(manning_n=0.0), dict(fischer=float("nan")), dict(cell_m=-1.0),
                dict(longitudinal_m2s=float("inf"))):
        with pytest.raises(ValueError, match="Dispersion"):
            Dispersion(**bad)
    with pytest.raises(ValueError, match="discharge"):
        build_spill_network([branch("c", line, 30.0)], [float("nan")])


# -- mixing below a confluence -----------------------------------------------------------------

def test_a_tributary_plume_hugs_its_bank_below_the_confluence_then_mixes():
    """Below a confluence the tributary's plume stays on the tributary's side of the ψ range
    (its share of the discharge), spreads by the transverse mixing and is mixed after several
    mixing lengths 0.4 U W² / ε_t; across the section its mean is the 1-D solver's (1)."""
    from riverflow.hydro.spills import plume_sections
    net = build_spill_network(
        [branch("main", straight(1000.0, 11), 40.0, -1, 0),
         branch("trib", straight(1000.0, 11, 400.0), 20.0, -1, 0),
         branch("below", straight(60000.0, 61, 0.0, 1000.0), 50.0, 0, -1)],
        [60.0, 20.0, 80.0])
    net.link_psi_m2s = np.array([[20.0, 80.0], [0.0, 20.0], [0.0, 80.0]])   # trib: low ψ
    trib, below = net.names.index("trib"), net.names.index("below")
    src = _source(net, trib, 100.0)
    src.psi_left, src.psi_right = 0.0, 20.0
    sections = plume_sections(net, src)
    assert list(sections) == [below]
    solver = SpillSolver(net)
    solver.add(src, "t", 1.0, 0.0, 0.0)
    cells = net.cell_link == below
    u, w, eps = (float(np.median(v[cells])) for v in (net.cell_speed_mps, net.cell_width_m,
                                                       net.cell_eps_m2s))
    mixing_m = 0.4 * u * w * w / eps
    assert 3.5 * mixing_m < net.link_length_m[below]
    psi = np.linspace(0.0, 80.0, 401)

    def across(s_m):
        return solver.transverse(0, np.full(len(psi), below), np.full(len(psi), s_m), psi)

    near = across(0.05 * mixing_m)
    assert near[psi < 10].mean() > 3.0 * near[psi > 70].mean()       # the tributary's bank
    assert near[psi > 70].max() < 0.2                                 # little on the far side
    far = across(3.0 * mixing_m)
    assert np.abs(far - 1.0).max() < 0.03                             # mixed within 3 %
    for s in (0.0, 0.05 * mixing_m, 0.3 * mixing_m, mixing_m, 3.0 * mixing_m):
        assert np.trapezoid(across(s), psi) / 80.0 == pytest.approx(1.0, abs=2e-3)
    # the tributary's side by its share: a quarter of the discharge, a quarter of the range
    mid = across(0.3 * mixing_m)
    assert np.trapezoid(mid * psi, psi) / np.trapezoid(mid, psi) < 0.5 * 80.0
    # a spill on the main river is on the other side
    src2 = _source(net, net.names.index("main"), 100.0)
    src2.psi_left, src2.psi_right, src2.eta = 20.0, 80.0, 0.5
    solver.add(src2, "m", 1.0, 0.0, 0.0)
    other = solver.transverse(1, np.full(len(psi), below), np.full(len(psi), 0.05 * mixing_m),
                              psi)
    assert other[psi > 40].mean() > 1.2 > 0.5 > other[psi < 5].mean()


def test_tint_kernel_matches_numpy_twin():
    """riverflow.kernels.spill.tint_texels against the plain-numpy way it replaced."""
    from riverflow.kernels.spill import TintTexels, tint_texels
    rng = np.random.default_rng(5)
    side, n_cells, n_spills = 16, 30, 3
    wet = rng.choice(np.arange(3 * side, 11 * side), 40, replace=False).astype(np.int64)
    ia = rng.integers(0, n_cells - 1, 40).astype(np.int64)
    texels = TintTexels(wet, ia, ia + 1, rng.uniform(0, 1, 40), rng.uniform(0, 2, (n_spills, 40)),
                        np.array([2 * side + 1, 12 * side], np.int64), wet[:2].copy())
    conc = rng.uniform(0, 1e-3, (n_spills, n_cells))
    conc[:, ia[5]] = conc[:, ia[5] + 1] = 0.0            # a texel with nothing: (0, 0, 0, 0)
    colours = rng.uniform(0, 1, (n_spills, 3))
    out = np.zeros((side * side, 4), np.float32)
    rows = tint_texels(texels, conc, colours, out)
    twin = np.zeros_like(out)
    c = (conc[:, texels.cell_a] * (1 - texels.weight_b) + conc[:, texels.cell_b]
         * texels.weight_b) * texels.profile
    total = c.sum(axis=0)
    twin[wet, :3] = ((colours.T @ c) / np.maximum(total, 1e-30)).T
    twin[wet, 3] = total
    twin[texels.fringe] = twin[texels.fringe_from]
    np.testing.assert_allclose(out, twin, rtol=1e-6, atol=1e-12)
    tinted = np.flatnonzero((twin.reshape(side, side, 4)[:, :, 3] > 0).any(axis=1))
    assert rows == (tinted[0], tinted[-1] + 1) == (2, 13)
    assert tint_texels(texels, np.zeros_like(conc), colours, out) == (0, 0)


def test_the_plumes_box_takes_the_cells_above_the_front_fraction_of_each_peak():
    """``_extent``'s one comparison (c ≥ max(FRONT_FRACTION × peak, least double)) picks the
    cells with c > 0 and c ≥ FRONT_FRACTION × peak: a spill with nothing left, negative
    rounding and subnormal masses included."""
    from types import SimpleNamespace

    rng = np.random.default_rng(3)
    n = 50
    net = SimpleNamespace(cell_width_m=rng.uniform(5, 40, n), link_dx_m=rng.uniform(10, 30, 4),
                          cell_xy_m=rng.uniform(-1e3, 1e3, (n, 2)))
    for mass in (np.zeros((2, n)), rng.normal(0, 1, (3, n)) * 1e-320,
                 np.where(rng.random((2, n)) < 0.2, rng.exponential(1.0, (2, n)), 0.0),
                 np.vstack([np.zeros(n), np.full(n, -1e-12), rng.exponential(1e-3, n)])):
        solver = SimpleNamespace(n_spills=len(mass), network=net,
                                 cell_concentration=lambda m=mass: m)
        peak = mass.max(axis=1, keepdims=True)
        on = np.flatnonzero(np.any((mass > 0) & (mass >= spills.FRONT_FRACTION * peak), axis=0))
        got = spills._extent(solver)
        if not len(on):
            assert got is None
            continue
        pad = net.cell_width_m[on].max() + net.link_dx_m.max()
        np.testing.assert_array_equal(got[0], net.cell_xy_m[on].min(axis=0) - pad)
        np.testing.assert_array_equal(got[1], net.cell_xy_m[on].max(axis=0) + pad)
        assert spills._extent(solver, float(net.link_dx_m.max()))[0].tolist() == got[0].tolist()
