"""The foam kernels (riverflow.kernels.foam) against their numpy twins and exact geometry, and
their properties: bounded, never NaN, inherited by new particles, none out of the water."""
from __future__ import annotations

import math

import numpy as np
import numpy.testing as npt
import pytest
import shapely

from riverflow.components.foam import FoamSettings
from riverflow.components.particles import ParticlePool
from riverflow.components.status import FlowStatus
from riverflow.hydro.flow_field import FlowField
from riverflow.kernels import flow as kf
from riverflow.kernels import foam as kfoam
from riverflow.kernels.lifecycle import allocate_particle
from riverflow.kernels.surface_tiles import water_slope_at
from riverflow.tiles.surface import one_tile_surface
from riverflow.kernels.wake import TR_FIELDS, advance_trail, pack_trail
from riverflow.systems.foam import foam_params
from tests.flow.networks import bend_with_island, straight_channel
from tests.kernels import foam_reference as ref

SLOPE = 0.02        # the test surface's water falls 2 % along +x


@pytest.fixture(scope="module")
def channel():
    graph, _ = straight_channel()           # 400 m along +x, 40 m wide, 1 m/s
    field = FlowField(graph)
    n, cell = 64, 8.0
    xs = -40.0 + cell * np.arange(n + 1)
    gx, gy = np.meshgrid(xs, -256.0 + cell * np.arange(n + 1))
    water = (50.0 - SLOPE * gx).astype(np.float32)
    surface = one_tile_surface(water - 2.0, water, -40.0, -256.0, cell)
    field.ensure_tiles(field.max_level, {tuple(t) for t in field.tile_of(
        np.stack(np.meshgrid(np.arange(-20.0, 420.0, 5.0), np.arange(-30.0, 30.0, 5.0)),
                 -1).reshape(-1, 2))})
    return field, surface


def _flow(field):
    t = field.tiles
    return kfoam.FoamFlow(t.view(), t.shore, t.bank, field.max_level, field.max_level,
                          field.fall_table())


def _boat_trail(speed_mps, frames=240, k=48, heading=0.0, start=(100.0, 0.0)):
    """A boat's packed trail after ``frames`` at ``speed_mps`` along ``heading``."""
    trail = np.zeros((k, 6))
    count, t = 0, 0.0
    p = np.array(start, float)
    f = np.array([math.cos(heading), math.sin(heading)])
    for _ in range(frames):
        t += 1 / 60
        p = p + speed_mps * f / 60
        count = advance_trail(trail, count, p[0], p[1], speed_mps, 0.5, 0.0, t, 1 / 60,
                              1 / 3, 15.0)
    table = np.zeros((1, k, TR_FIELDS), np.float32)
    pack_trail(trail, count, t, 15.0, 0.5, 0.35, 3.0, 0.5, table[0])
    hull = np.array([[p[0] - 0.4 * 8 * f[0], p[1] - 0.4 * 8 * f[1], heading, 8.0, 3.0,
                      speed_mps, 1.0, 0.0]])
    return hull, table


# -- what the flow tiles answer -----------------------------------------------------------------

def test_shore_distance_is_the_distance_to_the_nearest_bank_or_island():
    graph, _ = bend_with_island()
    field = FlowField(graph)
    banks = shapely.union_all([shapely.LineString(graph.polyline(c)) for c in graph.banks()])
    rng = np.random.default_rng(3)
    pts = rng.uniform((-200, -30), (230, 420), (4000, 2))
    d = field.shore_distance(pts)
    h = field.tiles.spacing_m(field.max_level)
    # not within two lattice cells of the river's ends (closing segments are not shores, and
    # the lattice is dry beyond them)
    inside = np.isfinite(d) & (pts[:, 0] > -200 + 2 * h) & (pts[:, 1] < 400 - 2 * h)
    assert inside.sum() > 400
    exact = shapely.distance(shapely.points(pts[inside]), banks)
    err = d[inside] - exact
    assert np.abs(err).max() < h                     # bilinear over the lattice
    assert np.median(np.abs(err)) < 0.1 * h
    assert (d[inside] >= 0).all()
    island = shapely.Point(200 * math.sin(math.pi / 4), 200 * (1 - math.cos(math.pi / 4)))
    near_island = shapely.distance(shapely.points(pts[inside]), island) < 15
    assert near_island.any() and (d[inside][near_island] < 6.5).all()   # its shore counts


def test_strain_and_vorticity_are_the_velocity_gradient_s(channel):
    """flow_details_at's strain and vorticity against central differences of the velocity
    (bend with an island: the flow turns and shears)."""
    graph, _ = bend_with_island()
    field = FlowField(graph)
    rng = np.random.default_rng(4)
    pts = rng.uniform((-150, 0), (230, 380), (3000, 2))
    d = field.shore_distance(pts)
    pts = pts[np.isfinite(d) & (d > 3.0)][:300]
    eps = 1e-3
    def vel(q):
        return field.query(q, exclude_obstacles=True)[1].astype(np.float64)
    ux = (vel(pts + (eps, 0)) - vel(pts - (eps, 0))) / (2 * eps)
    uy = (vel(pts + (0, eps)) - vel(pts - (0, eps))) / (2 * eps)
    strain = np.hypot(0.5 * (ux[:, 0] - uy[:, 1]), 0.5 * (uy[:, 0] + ux[:, 1]))
    vorticity = ux[:, 1] - uy[:, 0]
    out = np.empty((len(pts), 5))
    t = field.tiles
    assert kf.sample_flow_details(np.ascontiguousarray(pts), field.max_level, 0, t.view(),
                                  t.shore, t.bank, out) == 0
    # float32 velocities: differences over 2 mm are good to a few 1e-3 /s
    npt.assert_allclose(out[:, 3], strain, atol=5e-3)
    npt.assert_allclose(out[:, 4], vorticity, atol=5e-3)
    assert strain.max() > 0.02                      # the test sees some shear


# -- the terms and the target against the twin --------------------------------------------------

def test_flow_terms_match_the_twin(channel):
    field, surface = channel
    params = foam_params(FoamSettings(steep_from=0.005, steep_full=0.03))
    flow = _flow(field)
    rng = np.random.default_rng(5)
    pts = np.c_[rng.uniform(0, 400, 500), rng.uniform(-21, 21, 500)]
    vel = rng.normal(0, 1.5, (500, 2))
    out = np.empty((500, 5))
    kf.sample_flow_details(pts, field.max_level, field.max_level, flow.tiles, flow.shore,
                           flow.bank, out)
    patch = np.empty((4, 4))
    for k in range(500):
        got = kfoam.flow_terms(pts[k, 0], pts[k, 1], vel[k, 0], vel[k, 1], params, flow,
                               surface, patch)
        slope = math.hypot(*water_slope_at(surface, pts[k, 0], pts[k, 1]))
        assert slope == pytest.approx(SLOPE, abs=1e-5)
        found = bool(np.isfinite(out[k, 0]))
        want = ref.flow_terms(found, *(out[k, :4] if found else [0] * 4), slope, *vel[k],
                              params)
        npt.assert_allclose(got, want, atol=1e-9)
        assert all(0.0 <= v <= 1.0 for v in got)


def test_moving_terms_match_the_twin():
    params = foam_params(FoamSettings())
    hulls, trails = _boat_trail(6.0)
    rng = np.random.default_rng(6)
    pts = hulls[0, :2] + rng.uniform((-60, -20), (15, 20), (3000, 2))
    caps, n_caps, wash, n_wash = kfoam.moving_sources(kfoam.FoamSources(hulls, trails), params)
    assert n_wash >= 4 and n_caps == 1
    got = np.array([kfoam.moving_closeness(x, y, caps, n_caps, wash, n_wash, params.wash_s)
                    for x, y in pts])
    want = np.array([ref.moving_closeness(x, y, hulls, trails, params) for x, y in pts])
    npt.assert_allclose(got, want, atol=1e-9)
    assert got.max() > 0.9 and (got == 0).mean() > 0.5
    # a still boat makes no foam at all
    still_hulls, still = _boat_trail(0.0)
    caps, n_caps, wash, n_wash = kfoam.moving_sources(kfoam.FoamSources(still_hulls, still),
                                                      params)
    assert n_caps == 0 and n_wash == 0
    assert max(kfoam.moving_closeness(x, y, caps, n_caps, wash, n_wash, params.wash_s)
               for x, y in pts) == 0


# -- one frame against the twin --------------------------------------------------------------------

def _world_like(rng, n, field, surface, frame_px=(320, 180)):
    """A pool of n particles over the channel (some out of the water, some new), the screen
    grid (cells of 4r) listing them, r = 5 px."""
    pool = ParticlePool(n + 16)
    for _ in range(n):
        allocate_particle(pool.alive, pool.ids, pool.counters, 0)
    pool.alive[:n][rng.random(n) < 0.1] = False
    pool.has_world[:n] = rng.random(n) > 0.05
    pool.world_m[:n, 0] = rng.uniform(60, 160, n)
    pool.world_m[:n, 1] = rng.uniform(-22, 22, n)
    pool.velocity_mps[:n] = rng.normal((1, 0), 0.3, (n, 2))
    pool.status[:n] = rng.choice([FlowStatus.INSIDE] * 8 + [FlowStatus.LEAVING,
                                                          FlowStatus.OUTSIDE], n)
    pool.screen_px[:n] = rng.uniform((0, 0), frame_px, (n, 2))
    pool.intensity[:n] = rng.uniform(0, 1, n)
    pool.foam[:n] = rng.uniform(0, 1, n)
    pool.foam_flow[:n] = rng.uniform(0, 0.5, n)
    pool.foam_shore[:n] = rng.uniform(0, 0.5, n)
    pool.foam_near[:n] = rng.uniform(0, 0.5, n)
    pool.foam_id[:n] = np.where(rng.random(n) < 0.8, pool.ids[:n], -1)
    r = 5.0
    cell = 4 * r
    gw, gh = int(np.ceil(frame_px[0] / cell)), int(np.ceil(frame_px[1] / cell))
    count = np.zeros(gw * gh, np.int32)
    items = np.full((gw * gh, 64), -1, np.int32)
    for i in np.flatnonzero(pool.alive[:n]):
        c = int(pool.screen_px[i, 1] // cell) * gw + int(pool.screen_px[i, 0] // cell)
        items[c, count[c]] = i
        count[c] += 1
    grid = kfoam.ScreenNeighbours(cell, gw, gh, count, items, 3 * r)
    return pool, grid


@pytest.mark.parametrize("frame", [0, 1, 6, 7])
def test_a_frame_matches_the_twin(channel, frame):
    field, surface = channel
    rng = np.random.default_rng(10 + frame)
    pool, grid = _world_like(rng, 400, field, surface)
    hulls, trails = _boat_trail(5.0, start=(40.0, 2.0))
    params = foam_params(FoamSettings())
    flow = _flow(field)
    twin = ParticlePool(pool.capacity)
    for name, column in pool.columns().items():
        getattr(twin, name)[...] = column
    patch = np.empty((4, 4))

    def river_terms(i):
        return kfoam.flow_terms(pool.world_m[i, 0], pool.world_m[i, 1], pool.velocity_mps[i, 0],
                                pool.velocity_mps[i, 1], params, flow, surface, patch)

    n = int(pool.counters[2])
    sources = kfoam.FoamSources(hulls, trails)
    got = kfoam.update_foam(n, pool.arrays, params, flow, surface, sources, grid, 1 / 60, frame,
                            4, 2, np.zeros(pool.capacity, np.int32))
    ref.update_foam(twin, n, river_terms, hulls, trails, params, grid.radius_px, 1 / 60, frame,
                    4, 2)
    for name in ("foam", "foam_flow", "foam_shore", "foam_near"):
        npt.assert_allclose(getattr(pool, name), getattr(twin, name), atol=2e-6, err_msg=name)
    npt.assert_array_equal(pool.foam_id, twin.foam_id)
    assert got[2] > 0                                  # some new particles were handled
    assert got[1] > 0                                  # and some near the hull


# -- properties ------------------------------------------------------------------------------------

def test_foam_stays_in_the_unit_interval_and_is_never_nan(channel):
    field, surface = channel
    rng = np.random.default_rng(20)
    pool, grid = _world_like(rng, 400, field, surface)
    pool.foam[:40] = np.nan
    pool.foam[40:80] = np.inf
    pool.world_m[80:90] = np.nan
    pool.velocity_mps[90:100] = np.nan
    pool.screen_px[100:110] = np.nan
    pool.foam_id[80:110] = -1                           # new, with bad values
    hulls, trails = _boat_trail(7.0, start=(60.0, 0.0))
    hulls[0, 2] = np.nan                                # a broken heading never spreads NaN
    flow = _flow(field)
    for settings in (FoamSettings(), FoamSettings(base=3.0), FoamSettings(distance=40.0)):
        for frame in range(8):
            kfoam.update_foam(int(pool.counters[2]), pool.arrays, foam_params(settings), flow,
                              surface, kfoam.FoamSources(hulls, trails), grid,
                              1 / 60 if frame else np.nan, frame, 2, 2,
                              np.zeros(pool.capacity, np.int32))
            if frame % 2 == 0:
                continue                        # each frame visits half the pool
            live = pool.alive
            assert np.isfinite(pool.foam[live]).all()
            assert ((pool.foam[live] >= 0) & (pool.foam[live] <= 1)).all()
            assert np.isfinite(pool.foam_near[live] + pool.foam_shore[live]).all()
    water = pool.alive & pool.has_world & np.isin(pool.status, [1, 2])
    assert (pool.foam[pool.alive & ~water] == 0).all()          # none out of the water
    assert (pool.foam_id[pool.alive & ~water] == -1).all()


def test_a_new_particle_starts_with_its_neighbours_foam(channel):
    field, surface = channel
    pool = ParticlePool(8)
    for _ in range(4):
        allocate_particle(pool.alive, pool.ids, pool.counters, 0)
    pool.has_world[:4] = True
    pool.status[:4] = FlowStatus.INSIDE
    pool.world_m[:4] = (200.0, 0.0, 50.0)                       # mid-channel: target ≈ 0
    pool.screen_px[:4] = [(50, 50), (53, 50), (47, 50), (50, 54)]
    pool.intensity[:4] = 1.0
    pool.foam[:4] = [0.0, 0.8, 0.6, 0.7]
    pool.foam_id[:4] = pool.ids[:4]
    pool.foam_id[0] = -1                                         # slot 0 holds a new particle
    count = np.array([4], np.int32)
    items = np.array([[0, 1, 2, 3]], np.int32)
    grid = kfoam.ScreenNeighbours(100.0, 1, 1, count, items, 15.0)
    kfoam.update_foam(4, pool.arrays, foam_params(FoamSettings()), _flow(field), surface,
                      kfoam.FoamSources(np.zeros((0, 8)), np.zeros((0, 2, TR_FIELDS),
                                                                    np.float32)),
                      grid, 1 / 60, 0, 64, 4, np.zeros(8, np.int32))
    assert 0.6 < pool.foam[0] < 0.8                     # the neighbours' (weighted) mean
    assert pool.foam_id[0] == pool.ids[0]


def test_foam_pattern_is_periodic_and_evenly_spread():
    p = kfoam.foam_pattern(64, seed=1)
    assert p.shape == (64, 64, 2) and p.dtype == np.float32
    for c in range(2):
        hist = np.histogram(p[..., c], bins=10, range=(0, 1))[0]
        assert hist.min() > 0.9 * hist.max()            # even: threshold 1 − f covers f
        # periodic: the step across the border is like a step inside
        inner = np.abs(np.diff(p[..., c], axis=1)).mean()
        across = np.abs(p[:, 0, c] - p[:, -1, c]).mean()
        assert across < 1.5 * inner
    levels = kfoam.mip_chain(p)
    assert [lv.shape[0] for lv in levels] == [64, 32, 16, 8, 4, 2, 1]
    npt.assert_allclose(levels[-1][0, 0], p.reshape(-1, 2).mean(axis=0), rtol=1e-5)
