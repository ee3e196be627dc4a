"""Floods (issue 25, item 2): hydrographs routed down the network by the kinematic wave
(riverflow/kernels/flood.py, riverflow/hydro/flood.py), the flow's speed and the water level
following the local discharge, and the world API.

Tests of record: a hydrograph step at the upstream end of a 30 km uniform river reaches 20 km
downstream after the kinematic-wave travel time (within 5 %) and the level there matches
Manning's rating curve once steady (within 2 %); bad input leaves the old state.
"""
from __future__ import annotations

import numpy as np
import pytest

import riverflow as rf
from riverflow.hydro.falls import channel_depth_m
from riverflow.hydro.flood import (FLOODPLAIN_ROUGHNESS, FLOODPLAIN_SHEAR_M, FloodRouter,
                                   cell_raster)
from riverflow.hydro.spill_network import build_spill_network
from riverflow.kernels.flood import flood_steps, sample_by_cells, scale_by_cells
from riverflow.tiles.table import tile_code
from tests.engine import cell_networks
from tests.engine.cell_networks import branch, straight


# -- the kernel against its plain-numpy twin ---------------------------------------------------

def _twin_steps(net, hydro, a, t0, dt, n):
    """riverflow.kernels.flood.flood_steps, vectorised per link with numpy."""
    n_nodes = int(max(net.link_end.max(), net.link_start.max(), 0)) + 1
    for k in range(n):
        t = t0 + k * dt
        q = np.empty_like(a)
        for b in range(len(net.link_q0)):
            c = slice(net.link_c0[b], net.link_c1[b])
            q[c] = net.link_q0[b] * a[c] ** (5 / 3)
        node = np.zeros(n_nodes)
        for b in range(len(net.link_q0)):
            if net.link_end[b] >= 0:
                node[net.link_end[b]] += q[net.link_c1[b] - 1]
        inflow = np.where(net.link_start >= 0, node[np.maximum(net.link_start, 0)]
                          * net.link_share, net.link_q0)
        for h in range(len(hydro.link)):
            s = slice(hydro.start[h], hydro.start[h + 1])
            inflow[hydro.link[h]] = np.interp(t, hydro.times[s], hydro.q[s])
        for b in range(len(net.link_q0)):
            c = slice(net.link_c0[b], net.link_c1[b])
            upstream = np.concatenate([[inflow[b]], q[c][:-1]])
            a[c] = np.maximum(a[c] + dt / net.link_dx[b] * (upstream - q[c])
                              / net.cell_area0[c], 0.0)
    return a


@pytest.fixture(scope="module")
def diamond():
    """A source splitting at a bifurcation into two arms that meet again, a tributary joining
    below, and an outlet (the spill tests' network)."""
    return cell_networks.diamond()


def test_kernel_matches_numpy_twin(diamond):
    router = FloodRouter(diamond)
    q0 = float(router.net.link_q0[0])
    router.set_hydrograph("top", [0.0, 600.0, 1800.0], [q0, 4.0 * q0, 0.5 * q0])
    a = router.a.copy()
    n = int(2400.0 / router.dt_s)
    flood_steps(router.net, router._table, router.a, 0.0, router.dt_s, n, router._outflow,
                router._node_q, router._inflow)
    twin = _twin_steps(router.net, router._table, a, 0.0, router.dt_s, n)
    assert np.abs(router.a - 1.0).max() > 0.1            # the wave is in the network
    np.testing.assert_allclose(router.a, twin, rtol=1e-9, atol=1e-12)


def test_volume_is_conserved_and_a_junction_adds_its_inflows(diamond):
    router = FloodRouter(diamond)
    router.advance(3600.0)                # base flow is a steady state of the routing
    np.testing.assert_allclose(router.a, 1.0, atol=1e-12)
    assert not router.active
    net = router.net
    q0 = net.link_q0.copy()
    router.set_hydrograph("trib", [0.0, 60.0], [q0[router.link_index("trib")],
                                               3.0 * q0[router.link_index("trib")]])
    dx = net.link_dx[diamond.cell_link]
    volume = lambda: float(np.sum(router.a * net.cell_area0 * dx))   # noqa: E731
    v0, inflow, outflow = volume(), 0.0, 0.0
    out_cell = int(net.link_c1[router.link_index("bottom")]) - 1
    for _ in range(int(4 * 3600 / router.dt_s)):
        q_out = q0[router.link_index("bottom")] * router.a[out_cell] ** (5 / 3)
        router.advance(router.dt_s)
        inflow += router._inflow[np.asarray(net.link_start) < 0].sum() * router.dt_s
        outflow += q_out * router.dt_s
    assert volume() == pytest.approx(v0 + inflow - outflow, rel=1e-9)
    # steady: the outlet carries the base flow plus the tributary's extra 2 q0
    q = router.cell_discharge_m3s()
    extra = 2.0 * q0[router.link_index("trib")]
    assert q[out_cell] == pytest.approx(q0[router.link_index("bottom")] + extra, rel=1e-3)
    # the bifurcation above is untouched
    top = slice(net.link_c0[0], net.link_c1[0])
    np.testing.assert_allclose(router.a[top], 1.0, atol=1e-12)


# -- tests of record: a 30 km uniform river ----------------------------------------------------

WIDTH_M, U0_MPS, N_MANNING = 50.0, 1.0, 0.03


@pytest.fixture(scope="module")
def long_river():
    """A hydrograph step Q₀ → 2 Q₀ at t = 0 at the upstream end of a 30 km uniform river,
    the level rise at 20 km recorded every step for 5 hours."""
    network = build_spill_network([branch("river", straight(30_000.0, 301), WIDTH_M)],
                                  [U0_MPS * WIDTH_M])          # ψ difference q = U W [m²/s]
    router = FloodRouter(network)
    q0 = float(router.net.link_q0[0])
    router.set_hydrograph(None, [0.0, 1e-6], [q0, 2.0 * q0])
    at = np.array([[20_000.0, 0.0]])
    times, rise = [], []
    while router.time_s < 5 * 3600.0:
        router.advance(router.dt_s)
        times.append(router.time_s)
        rise.append(float(router._at(router.cell_level_rise_m(), at, 0.0)[0]))   # routed
    return router, q0, np.array(times), np.array(rise)


def test_a_step_reaches_20_km_after_the_kinematic_wave_travel_time(long_river):
    router, q0, times, rise = long_river
    h0 = float(channel_depth_m(WIDTH_M))
    final = rise[-1]
    # kinematic wave: Q ∝ A^(5/3); a rising step travels as a front at ΔQ / ΔA
    a2 = 2.0 ** 0.6
    celerity = q0 / (WIDTH_M * h0 * (a2 - 1.0))
    expected = 20_000.0 / celerity
    arrival = float(np.interp(0.5 * final, rise, times))    # half the rise has arrived
    assert arrival == pytest.approx(expected, rel=0.05)
    assert np.all(rise[times < 0.8 * expected] < 0.02 * final)   # not instantly
    # the celerity is that of Manning's law: between (5/3) U at Q₀ and at 2 Q₀
    assert 5 / 3 * U0_MPS < celerity < 5 / 3 * U0_MPS * 2 ** 0.4


def test_the_level_matches_the_rating_curve_once_steady(long_river):
    router, q0, times, rise = long_river
    h0 = float(channel_depth_m(WIDTH_M))
    # Manning, wide channel: Q = W h^(5/3) √S / n; the slope the base state implies
    slope = (q0 * N_MANNING / (WIDTH_M * h0 ** (5 / 3))) ** 2
    h_manning = (2.0 * q0 * N_MANNING / (WIDTH_M * np.sqrt(slope))) ** 0.6
    assert h0 + rise[-1] == pytest.approx(h_manning, rel=0.02)
    assert float(router.discharge(np.array([[20_000.0, 0.0]]))[0]) == pytest.approx(2 * q0,
                                                                                    rel=1e-3)
    # the speed factor is U/U₀ = (Q/Q₀)^(2/5)
    velocity = np.ones((1, 2), np.float32)
    router.scale_velocity(np.array([[20_000.0, 0.0]]), np.ones(1, np.uint8), velocity)
    assert velocity[0, 0] == pytest.approx(2.0 ** 0.4, rel=1e-3)


def test_bad_hydrographs_raise_and_keep_the_old_state(diamond):
    router = FloodRouter(diamond)
    router.set_hydrograph("top", [0.0, 100.0], [20.0, 40.0])
    router.advance(300.0)
    before = (router.a.copy(), router.dt_s, {k: (t.copy(), q.copy())
                                             for k, (t, q) in router.hydrographs.items()})
    for link, t, q, match in (
            ("top", [0.0, 10.0], [1.0, -1.0], "discharge_m3s\\[1\\]"),
            ("top", [0.0, 10.0], [1.0, float("nan")], "discharge_m3s\\[1\\]"),
            ("top", [0.0, 10.0, 10.0], [1.0, 2.0, 3.0], "increase strictly"),
            ("top", [5.0, 1.0], [1.0, 2.0], "increase strictly"),
            ("top", [0.0, float("inf")], [1.0, 2.0], "finite"),
            ("top", [0.0, 1.0], [1.0], "2 values"),
            ("top", "soon", [1.0], "numbers"),
            ("nowhere", [0.0], [1.0], "no link named 'nowhere'"),
            (7, [0.0], [1.0], "out of range"),
            ("top", [0.0, 1.0], [20.0, 1e300], "at most 10000 ×"),   # overflowed the step count
            (None, [0.0], [1e12], "at most 10000 ×")):
        with pytest.raises(ValueError, match=match):
            router.set_hydrograph(link, t, q)
    assert np.array_equal(router.a, before[0]) and router.dt_s == before[1]
    assert router.hydrographs.keys() == before[2].keys()
    for k, (t, q) in before[2].items():
        assert np.array_equal(router.hydrographs[k][0], t)
        assert np.array_equal(router.hydrographs[k][1], q)


# -- the cell raster (the speed factor and the level read per point) ----------------------------

def _twin_raster_cells(raster, xy):
    """numpy twin of ``kernels.flood.raster_cell``: each point's cell coordinate, −1: none."""
    f = (xy - (raster.x0, raster.y0)) / raster.pixel_m
    B = raster.block_px
    by_bx = raster.blocks.shape
    ok = np.all(f >= 0, axis=1) & (f[:, 0] < by_bx[1] * B) & (f[:, 1] < by_bx[0] * B)
    i = np.where(ok[:, None], f, 0).astype(np.int64)
    k = np.where(ok, raster.blocks[i[:, 1] // B, i[:, 0] // B], -1)
    p = raster.cells[np.maximum(k, 0), i[:, 1] % B, i[:, 0] % B]
    return np.where(k >= 0, p, -1.0)


def _twin_interp(values, p):
    c = np.clip(np.floor(p).astype(np.int64), 0, len(values) - 1)
    w = p - c
    nxt = np.minimum(c + 1, len(values) - 1)
    return np.where(w > 0, values[c] * (1 - w) + values[nxt] * w, values[c])


@pytest.fixture(scope="module")
def flooded_diamond(diamond):
    router = FloodRouter(diamond)
    router.set_hydrograph("top", [0.0, 100.0], [20.0, 80.0])
    router.advance(900.0)
    rng = np.random.default_rng(3)
    xy = np.stack([rng.uniform(-100.0, 4300.0, 20_000), rng.uniform(-150.0, 400.0, 20_000)], 1)
    xy[:3] = [np.nan, 0.0], [1e9, 0.0], [-1e9, -1e9]            # beyond any raster
    return router, xy


def test_an_edits_level_textures_are_made_near_what_changed_only(diamond, monkeypatch):
    """The drawn level's textures after a live edit (``level_textures(previous)``): the
    blocks of texels near the changed link made again, the others the old ones with their
    cell coordinates moved to the new numbering: the textures a router made afresh on the
    new network has, bit for bit; where the square or the raster's pixels changed, all made."""
    from riverflow.hydro.flood import LEVEL_BLOCK, LEVEL_TEXELS

    old = FloodRouter(diamond)
    old.level_textures()
    line = straight(1200.0, 25, 60.0, 1500.0)
    line[1:-1, 1] += 20.0 * np.sin(np.linspace(0.0, np.pi, 25)[1:-1])   # the left arm bent
    made = []
    fill = FloodRouter._fill_blocks
    monkeypatch.setattr(FloodRouter, "_fill_blocks", lambda self, frame, blocks, texels: (
        made.append(len(blocks)), fill(self, frame, blocks, texels)))
    every = (LEVEL_TEXELS // LEVEL_BLOCK) ** 2
    for edited, some in ((cell_networks.diamond(left=line), True),
                         (cell_networks.diamond(bottom_m=2500.0), False)):   # a longer outlet
        made.clear()
        got = FloodRouter(edited).level_textures(old)
        assert len(made) == 1 and (0 < made[0] < 0.6 * every if some else made[0] == every)
        fresh = fill.__get__(FloodRouter(edited))          # (the spy left out)
        texels = np.zeros((LEVEL_TEXELS ** 2, 3), np.float32)
        fresh(got[0], np.arange(every), texels)
        assert np.array_equal(got[1].reshape(-1, 3), texels)
        assert (got[1][..., 0] >= 0).any() and (got[1][..., 1] >= 0).any()    # a blend


def test_raster_kernels_match_their_numpy_twin(flooded_diamond):
    router, xy = flooded_diamond
    raster = router.raster
    factor = router.cell_speed_factor()
    p = _twin_raster_cells(raster, xy)
    assert np.all(p[:3] == -1.0) and (p >= 0).mean() > 0.2
    velocity = np.ones((len(xy), 2), np.float32)
    velocity[::5] = 0.0
    expected = velocity * np.where(p >= 0, _twin_interp(factor, p), 1.0)[:, None]
    missed = np.empty(len(xy), np.int64)
    n = scale_by_cells(xy, velocity, len(xy), raster, factor, missed)
    np.testing.assert_allclose(velocity, expected, rtol=1e-6)
    moving = np.flatnonzero(np.arange(len(xy)) % 5 != 0)
    assert np.array_equal(missed[:n], moving[p[moving] < 0])
    out = np.empty(len(xy))
    n_none = sample_by_cells(xy, len(xy), raster, router.cell_level_rise_m(), -7.0, out)
    np.testing.assert_allclose(out, np.where(p >= 0, _twin_interp(
        router.cell_level_rise_m(), p), -7.0), rtol=1e-12)
    assert n_none == int((p < 0).sum())


def test_the_raster_reads_the_nearest_cell_like_the_kd_tree(flooded_diamond):
    """scale_velocity (raster + KD-tree beyond it) agrees with the KD-tree at every point, to
    the change of the factor over a pixel; the whole water of every link is covered."""
    router, xy = flooded_diamond
    net = router.network
    velocity = np.ones((len(xy), 2), np.float32)
    router.scale_velocity(xy, None, velocity)
    assert np.all(velocity[0] == 1.0)                     # a NaN point is left as it is
    xy, velocity = xy[3:], velocity[3:]
    link, s, d = net.locate(xy)
    a, b, _ = net.weights(np.maximum(link, 0), np.nan_to_num(s))
    inside = (link >= 0) & (d < 0.5 * net.cell_width_m[a])
    p = _twin_raster_cells(router.raster, xy)
    assert np.all(p[inside] >= 0)                         # the water is covered
    kd = router._at(router.cell_speed_factor(), xy, 1.0)
    factor = router.cell_speed_factor()
    slope = np.abs(np.diff(factor)).max() / net.link_dx_m.min()   # [1/m]
    tol = slope * router.raster.pixel_m * np.sqrt(2) + 1e-6
    assert np.abs(factor - 1).max() > 0.03                         # a real flood
    away = ~inside & (p < 0)                                   # beyond the raster: the KD-tree
    np.testing.assert_allclose(velocity[away, 0], kd[away], rtol=1e-6)
    err = np.abs(velocity[inside, 0] - kd[inside])
    # away from the junctions, where the nearest link may change within a pixel
    ends = np.array([ln[[0, -1]] for ln in net.lines]).reshape(-1, 2)
    far = np.min(np.hypot(*(xy[inside][:, None, :] - ends[None]).transpose(2, 0, 1)), 1) > 60.0
    assert far.sum() > 1000 and err[far].max() <= tol
    with pytest.raises(ValueError, match="pixel_m"):
        cell_raster(net, pixel_m=0.0)
    # its blocks lie on a lattice of their side: an edit that moves the network's extent a
    # little leaves the raster (and the level texture made from it) where it was
    r = router.raster
    block = r.block_px * r.pixel_m
    for corner in (r.x0, r.y0):
        assert abs(corner / block - round(corner / block)) < 1e-9


# -- the world ---------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def world():
    w = rf.RiverWorld(rf.default_scene(seed=0), size=(48, 32), gl=False, seed=0)
    yield w
    w.close()


def test_the_world_routes_a_flood_and_its_flow_and_level_follow(world):
    scene = world.scene
    line = scene.branch("main_upper").centerline_m
    probe = line[len(line) // 2][None, :]
    status0, v0 = world.field.query(probe)
    level0 = float(world.water_level(probe)[0])
    assert status0[0] == rf.FlowStatus.INSIDE and world.flood is None
    with pytest.raises(ValueError, match="discharge_m3s"):
        world.set_hydrograph("main_upper", [0.0], [-5.0])
    assert world.flood is None and world.field.discharge_scale is None   # nothing kept
    world.set_hydrograph(None, [], None)    # makes the router, changes nothing
    router = world.flood
    assert world.field.discharge_scale == router.scale_velocity
    router_sources = [b for b in range(len(router.network.names))
                      if router.net.link_start[b] < 0]
    base = float(router.net.link_q0[router_sources].sum())
    now = world.flood_time_s
    world.set_hydrograph(None, [now, now + 1.0], [base, 3.0 * base])
    world.speed_factor = 100.0
    for _ in range(40):
        world.step(0.1)                               # the flood's clock runs 100× too
    assert router.clock_s == pytest.approx(now + 400.0)
    assert router.time_s <= router.clock_s < router.time_s + router.dt_s
    with pytest.raises(ValueError, match="advance_flood"):
        world.advance_flood(-1.0)
    world.advance_flood(4 * 3600.0)                   # long after the wave has passed
    status, v = world.field.query(probe)
    factor = float(np.hypot(*v[0]) / np.hypot(*v0[0]))
    link, s, _ = router.network.locate(probe)
    r = float(router.network.interpolate(router.cell_discharge_m3s(), link, s)[0]
              / router.net.link_q0[link[0]])
    assert r > 1.5
    assert factor == pytest.approx(r ** 0.4, rel=1e-4)
    h0 = float(router.network.link_depth_m[link[0]])
    assert float(world.water_level(probe)[0]) - level0 == pytest.approx(h0 * (r ** 0.6 - 1),
                                                                         rel=1e-6)
    assert np.isfinite(router.a).all() and router.a.min() > 0


# -- a dam's breach: level-pool routing ----------------------------------------------------------

def test_level_pool_release_matches_the_emptying_reservoir():
    from riverflow.hydro.flood import BROAD_CRESTED_WEIR, level_pool_release
    area, head, width = 2.0e5, 6.0, 30.0
    t, q = level_pool_release(area, head, width, 0.0, 3600.0)
    k = BROAD_CRESTED_WEIR * width
    # no inflow: A dh/dt = −k h^(3/2), so h(t) = (h0^(−1/2) + k t / (2 A))^(−2)
    h = (head ** -0.5 + 0.5 * k * t / area) ** -2.0
    np.testing.assert_allclose(q, k * h ** 1.5, rtol=1e-5)
    assert q[0] == pytest.approx(k * head ** 1.5) and np.all(np.diff(q) < 0)
    # with an inflow: the volume released beyond it is what the reservoir lost
    inflow = 40.0
    t, q = level_pool_release(area, head, width, inflow, 7200.0, points=2001)
    h_end = (q[-1] / k) ** (2.0 / 3.0)
    released = np.trapezoid(q - inflow, t)
    assert released == pytest.approx(area * (head - h_end), rel=1e-3)
    assert inflow < q[-1] < 1.5 * inflow                   # falling towards the inflow
    for kwargs, match in (({"area_m2": 0.0}, "area_m2"), ({"head_m": float("nan")}, "head_m"),
                          ({"inflow_m3s": -1.0}, "inflow_m3s"), ({"points": 1}, "points")):
        args = {"area_m2": area, "head_m": head, "breach_width_m": width, "inflow_m3s": 1.0,
                "duration_s": 60.0, **kwargs}
        with pytest.raises(ValueError, match=match):
            level_pool_release(**args)


def test_the_ground_stays_wet_looking_behind_a_falling_flood(diamond):
    from riverflow.hydro.flood import WET_FALL_MPS
    router = FloodRouter(diamond)
    q0 = float(router.net.link_q0[0])
    router.set_hydrograph("top", [0.0, 60.0, 1800.0, 1860.0], [q0, 4 * q0, 4 * q0, q0])
    router.advance(1800.0)
    t_peak = router.time_s
    peak = router.cell_level_rise_m().copy()
    assert peak.max() > 0.5 and np.allclose(router.wet_rise_m, np.maximum(peak, 0.0))
    assert router.drawn
    router.advance(3 * 3600.0)                          # the flood has passed
    assert np.abs(router.cell_level_rise_m()).max() < 1e-3 and not router.active
    elapsed = router.time_s - t_peak
    # each cell's wet line has fallen from its highest rise, at most WET_FALL_MPS
    assert np.all(router.wet_rise_m >= peak - WET_FALL_MPS * elapsed - 1e-9)
    assert router.wet_rise_m.max() > 0.0 and router.drawn   # still wet-looking
    router.advance(12 * 3600.0)
    assert router.wet_rise_m.max() < 1e-9 and not router.drawn   # dry again


# -- water over its banks: the floodplain's flow (item 3) -------------------------------------
# With the flood's level 1 m above the bank top in the built-in valley, the ground below the
# raised level beside the tributary's banks is INSIDE the flow, moving slowly (faster than 0,
# slower than the channel beyond the shear layer at its bank, down the valley), continuous
# with the channel's flow across the bank; the channel's own flow is the base field's,
# scaled; it dries (OUTSIDE) when the flood falls back. No NaN.

WET_M = 0.05
"""Points this much below (above) the raised level count as flooded (dry): the terrain the
test reads and the flood's interpolation of its rise agree to well within it."""


@pytest.fixture(scope="module")
def flooded(world):
    """The module's world with the tributary's level 1 m above its bank top (steady), after
    what the tests above left settled back to base flow."""
    if world.flood is not None:                           # back to base flow first
        world.set_hydrograph(None, [], None)
        world.advance_flood(12 * 3600.0)
    scene = world.scene
    line = scene.branch("tributary").centerline_m
    k = len(line) // 2
    t = line[k + 1] - line[k - 1]
    t = t / np.hypot(*t)
    normal = np.array([-t[1], t[0]])
    # five sections across the valley, 30 m apart, 1 m steps out to 130 m from the axis
    off = np.arange(-130.0, 130.5, 1.0)
    pts = np.concatenate([line[k] + 30.0 * j * t + off[:, None] * normal
                          for j in range(-2, 3)])
    base_status, base_v = world.field.query(pts)
    rise, ratio, q0 = cell_networks.flood_over_the_banks(world)    # 1 m above the bank top
    return world, pts, t, base_status, base_v, (ratio, q0), rise


def test_flooded_ground_flows_slowly_down_the_valley(flooded):
    world, pts, t, base_status, base_v, _, rise = flooded
    router = world.flood
    centre = pts[len(pts) // 2][None]
    assert float(router.level_rise(centre)[0]) == pytest.approx(rise, rel=0.02)
    status, v = world.field.query(pts)
    assert np.isfinite(v).all()
    ground, level = router.ground(pts)      # the terrain as drawn: its resident tiles
    depth = level + router.level_rise(pts) - ground
    plain = (base_status == rf.FlowStatus.OUTSIDE) & (depth > WET_M)
    dry = (base_status == rf.FlowStatus.OUTSIDE) & (depth < -WET_M)
    assert plain.sum() > 100 and dry.sum() > 100          # the water is over its banks
    assert np.all(status[plain] == rf.FlowStatus.INSIDE)
    assert np.all(status[dry] == rf.FlowStatus.OUTSIDE) and not v[dry].any()
    speed = np.hypot(*v.T.astype(np.float64))
    channel = base_status == rf.FlowStatus.INSIDE
    u_mid = float(np.median(speed[channel]))
    assert np.all(speed[plain] > 0.0)
    assert speed[plain].max() < u_mid * 1.01
    # beyond the shear layer beside the bank, the floodplain's own slow flow
    off = np.tile(np.arange(-130.0, 130.5, 1.0), 5)        # the fixture's sections
    edge = np.abs(np.where(channel, off, 0.0)).reshape(5, -1).max(axis=1)
    beyond = plain & (np.abs(off) > np.repeat(edge, len(off) // 5) + FLOODPLAIN_SHEAR_M + 1.0)
    assert beyond.sum() > 50
    assert speed[beyond].max() < u_mid / FLOODPLAIN_ROUGHNESS * 1.01
    # continuous across the bank (issue 25): neighbours 1 m apart on either side of it
    status_grid = base_status.reshape(5, -1)
    grid = speed.reshape(5, -1)
    across = status_grid[:, 1:] != status_grid[:, :-1]
    assert across.sum() >= 10
    jump = np.abs(grid[:, 1:] - grid[:, :-1])[across]
    assert jump.max() < 0.1 * u_mid                      # (it was 1.1 m/s of 1.75)
    down = (v[plain] @ t) / speed[plain]
    assert np.mean(down > np.cos(np.radians(30.0))) >= 0.95   # down the valley
    # slower where shallower: the speed rises with the depth on each section
    shallow = plain & (depth < 0.5)
    deep = plain & (depth > 1.5)
    assert speed[shallow].mean() < speed[deep].mean()
    # the channel's own flow: the base field, scaled by the discharge's speed factor only
    router.ground, ground = None, router.ground
    try:
        _, v_channel = world.field.query(pts[channel])
    finally:
        router.ground = ground
    assert np.array_equal(v[channel], v_channel)
    assert np.all(status[channel] == rf.FlowStatus.INSIDE)


def test_the_floodplain_dries_when_the_flood_falls_back(flooded):
    world, pts, _, base_status, base_v, (ratio, q0), _ = flooded
    now = world.flood_time_s
    world.set_hydrograph(None, [now, now + 1.0], [ratio * q0, q0])
    world.advance_flood(12 * 3600.0)
    status, v = world.field.query(pts)
    assert np.array_equal(status, base_status)
    assert np.allclose(v, base_v, rtol=1e-4, atol=1e-6)


def test_the_floods_ground_is_the_resident_tiles_bilinear(world):
    """tile_kinds.ground_and_level (the flood's ground): at the nodes of the finest resident
    height and water tiles, their heights and levels seen; no resident pair: reported."""
    from riverflow.scenes.tile_kinds import ground_and_level

    world.load_view()                                  # alone or first: the view's tiles
    cache, scene = world.tiles.cache, world.scene
    n, top = scene.terrain.tile_cells, scene.terrain.max_level
    both = set(cache.pools["height"].keys()) & set(cache.pools["water"].keys())
    key = max(both)                                    # the finest level resident
    x, y = scene.quadtree.node_coords(*key, n)
    gx, gy = np.meshgrid(x[1:-1], y[1:-1])             # inner nodes: no neighbour's edge
    xy = np.column_stack([gx.ravel(), gy.ravel()])
    ground, level, missed = ground_and_level(cache, scene.quadtree, n, top,
                                             np.vstack([xy, [[np.nan, 0.0], [1e7, 1e7]]]))
    z = cache.pools["height"].get(tile_code(*key))["z"][2:-2, 2:-2]
    seen = cache.pools["water"].get(tile_code(*key))["level_seen"][1:-1, 1:-1]
    assert np.allclose(ground[:-2], z.ravel(), rtol=0, atol=1e-4)
    assert np.allclose(level[:-2], seen.ravel(), rtol=0, atol=1e-4)
    assert sorted(missed.tolist()) == [len(xy), len(xy) + 1]


def test_the_drawn_rise_ramps_across_the_line_where_the_nearest_link_changes(world):
    """hydro.flood.FloodRouter._blend_links (issue 25, F7's saw-tooth): with one branch
    flooded and the one beside it not, the rise the shaders draw (level_rise, the CPU twin
    of flood.glsl's flood_at) crosses the line between them on a ramp of FLOOD_BLEND_M,
    where the nearest cell's rise steps."""
    from riverflow.hydro.flood import FLOOD_BLEND_M

    world.set_hydrograph(None, [], None)
    router = world.flood
    names = router.network.names
    b = names.index("tributary")
    q0 = float(router.net.link_q0[b])
    now = world.flood_time_s
    world.set_hydrograph("tributary", [now, now + 1.0], [q0, 4.0 * q0])
    world.advance_flood(6 * 3600.0)
    trib = router.network.lines[b]
    main = np.concatenate([router.network.lines[k] for k in range(len(names)) if k != b])
    a = trib[-1] + 0.0
    for p in trib[::-1]:                          # 150 m up the tributary from its end
        if np.hypot(*(p - trib[-1])) > 150.0:
            a = p
            break
    c = main[np.argmin(np.hypot(*(main - a).T))]  # the nearest point of another link
    t = np.linspace(0.0, 1.0, 400)[:, None]
    xy = a + t * (c - a)
    step = router._at(router.cell_level_rise_m(), xy, 0.0)   # the nearest cell's
    drawn = router.level_rise(xy)
    jump = np.abs(np.diff(step)).max()
    assert jump > 0.5                             # the nearest cell's rise steps...
    spacing = float(np.hypot(*(c - a))) / 399
    texel = router.level_textures()[0][2] / router.level_textures()[1].shape[0]
    ramp = np.abs(np.diff(drawn)).max()
    # ...the drawn one ramps: at most ½ the step over a gap change of 2·(spacing + texel)
    assert ramp < jump * 2.0 * (spacing + texel) / FLOOD_BLEND_M
    assert drawn[0] == pytest.approx(step[0], abs=1e-6) and np.isfinite(drawn).all()
    # the CPU's level (boats, the mirror, world.water_level) is the drawn one (issue 25):
    # against a twin of flood.glsl's flood_at written here from the level textures
    (x0, y0, side), tex = router.level_textures()
    ij = np.floor((xy - (x0, y0)) / side * tex.shape[0]).astype(np.int64)
    p = tex[ij[:, 1], ij[:, 0]].astype(np.float64)
    cells = np.append(router.cell_level_rise_m(), 0.0)
    at = lambda q: np.interp(q, np.arange(len(cells)), cells)      # noqa: E731
    twin = np.where(p[:, 0] >= 0, at(np.maximum(p[:, 0], 0.0)), 0.0)
    two = (p[:, 0] >= 0) & (p[:, 1] >= 0)
    twin[two] = (1.0 - p[two, 2]) * twin[two] + p[two, 2] * at(p[two, 1])
    assert two.sum() > 20                         # the line crosses the blend
    level = world.water_level(xy) - world.scene.water.level(xy)
    np.testing.assert_allclose(level, twin, rtol=0, atol=0.01)
    assert np.abs(step - twin).max() > 0.3        # (the nearest cell's rise did not)
