"""Moving obstacles in the flow: the kernel against its plain-numpy twin, then the properties
of the modulated flow (tangent to the hull, divergence-free, unchanged beyond the influence
distance, the discharge between the banks kept) through the public FlowField API."""
from __future__ import annotations

import numpy as np
import numpy.testing as npt
import pytest

import riverflow as rf
from riverflow.hydro.flow_field import Obstacle
from riverflow.kernels import obstacles as ko
from tests.flow.networks import straight_channel

INSIDE = int(rf.FlowStatus.INSIDE)


# -- the twin: obvious numpy, no numba -----------------------------------------------------

def reference_apply(xy, psi, velocity, status, obstacles):
    """(ψ', v') at points (N, 2) from ψ (N,), v (N, 2), status (N,) and obstacle rows, one
    obstacle after the other (ψ' = ψ_r + ψ_o + (ψ − ψ_r − ψ_o)·g(d), v' = its curl)."""
    psi = psi.astype(np.float64).copy()
    vel = velocity.astype(np.float64).copy()
    live = (status == INSIDE) & np.isfinite(psi)
    for ob in obstacles:
        if not np.isfinite(ob[ko.OB_PSI]):
            continue
        c = ob[[ko.OB_X, ko.OB_Y]]
        r = ob[ko.OB_BEAM] / 2
        half = max(ob[ko.OB_LENGTH] / 2 - r, 0.0)
        f = np.array([np.cos(ob[ko.OB_HEADING]), np.sin(ob[ko.OB_HEADING])])
        a, b = c - half * f, c + half * f
        e = b - a
        t = np.clip(((xy - a) @ e) / max(e @ e, 1e-300), 0, 1) if half > 0 else np.zeros(len(xy))
        off = xy - (a + t[:, None] * e)
        dist = np.hypot(*off.T)
        d = dist - r
        reach = ob[ko.OB_REACH]
        u = ob[[ko.OB_VX, ko.OB_VY]]
        w = ob[ko.OB_YAW_RATE]
        rel = xy - c
        psi_r = u[1] * rel[:, 0] - u[0] * rel[:, 1] + 0.5 * w * (rel ** 2).sum(1)
        v_r = np.c_[u[0] - w * rel[:, 1], u[1] + w * rel[:, 0]]
        s = np.clip(d / reach, 0, 1)
        g = 1 - (1 - s) ** 3
        dg = 3 * (1 - s) ** 2 / reach
        n = off / np.where(dist > 0, dist, 1)[:, None]
        delta = psi - psi_r - ob[ko.OB_PSI]
        hit = live & (d < reach)
        hull = hit & ((d <= 0) | (dist == 0))
        ring = hit & ~hull
        vel[ring] = (v_r + g[:, None] * (vel - v_r)
                     + (delta * dg)[:, None] * np.c_[-n[:, 1], n[:, 0]])[ring]
        psi[ring] = (psi_r + ob[ko.OB_PSI] + delta * g)[ring]
        vel[hull] = v_r[hull]
        psi[hull] = (psi_r + ob[ko.OB_PSI])[hull]
    return psi, vel


def _random_obstacles(rng, k):
    rows = np.empty((k, ko.OBSTACLE_FIELDS))
    rows[:, ko.OB_X:ko.OB_Y + 1] = rng.uniform(-10, 10, (k, 2))
    rows[:, ko.OB_HEADING] = rng.uniform(-np.pi, np.pi, k)
    rows[:, ko.OB_BEAM] = rng.uniform(1, 4, k)
    rows[:, ko.OB_LENGTH] = rows[:, ko.OB_BEAM] * rng.uniform(1, 4, k)
    rows[:, ko.OB_PSI] = rng.uniform(-5, 5, k)
    rows[:, ko.OB_VX:ko.OB_VY + 1] = rng.uniform(-2, 2, (k, 2))
    rows[:, ko.OB_YAW_RATE] = rng.uniform(-0.5, 0.5, k)
    rows[:, ko.OB_REACH] = rows[:, ko.OB_BEAM] * 1.5
    return rows


def test_apply_obstacles_matches_reference(rng):
    n = 4000
    xy = rng.uniform(-20, 20, (n, 2))
    psi = xy[:, 1] * 1.3 + rng.normal(0, 0.1, n)
    velocity = rng.normal(0, 1, (n, 2)).astype(np.float32)
    status = np.where(rng.random(n) < 0.9, INSIDE, 4).astype(np.uint8)
    psi[rng.random(n) < 0.02] = np.nan
    obstacles = _random_obstacles(rng, 3)
    obstacles[2, ko.OB_PSI] = np.nan                         # disabled
    want_psi, want_v = reference_apply(xy, psi, velocity, status, obstacles)

    index = np.empty(n, np.int64)
    m = ko.select_obstacle_points(xy, status, obstacles, index)
    sel = index[:m]
    # the bounding-circle selection keeps every point an obstacle can change
    same_psi = (want_psi == psi) | (np.isnan(want_psi) & np.isnan(psi))
    changed = np.flatnonzero(np.any(want_v != velocity, axis=1) | ~same_psi)
    assert set(changed) <= set(sel.tolist())
    assert np.all(status[sel] == INSIDE)
    got_psi = psi[sel].copy()
    got_v = velocity.copy()
    count = ko.apply_obstacles(xy, index, m, got_psi, obstacles, status, got_v)
    assert count >= len(changed) > 100
    npt.assert_allclose(got_psi, want_psi[sel], rtol=1e-12, atol=1e-12)
    npt.assert_allclose(got_v, want_v.astype(np.float32), rtol=1e-5, atol=1e-5)
    untouched = np.setdiff1d(np.arange(n), sel)
    npt.assert_array_equal(got_v[untouched], velocity[untouched])


def test_no_obstacles_select_nothing(rng):
    xy = rng.uniform(-5, 5, (50, 2))
    index = np.empty(50, np.int64)
    status = np.full(50, INSIDE, np.uint8)
    assert ko.select_obstacle_points(xy, status, np.zeros((0, ko.OBSTACLE_FIELDS)), index) == 0


# -- properties through FlowField ----------------------------------------------------------

CENTRE = np.array([200.0, 3.0])
HEADING = 0.35
LENGTH, BEAM = 8.0, 3.0
REACH = 1.5 * BEAM


@pytest.fixture(scope="module")
def channel():
    """A straight 40 m channel (1 m/s mean) with one still hull a little off its axis."""
    graph, _ = straight_channel()
    field = rf.FlowField(graph)
    psi_o = float(field.potential(CENTRE[None])[0])
    field.set_obstacles([Obstacle(CENTRE, HEADING, LENGTH, BEAM, psi_o)])
    return field, psi_o


def _outline(offset_m, n=400, centre=CENTRE, heading=HEADING):
    """Points at distance ``offset_m`` from the hull (n of them) and the outward normals."""
    r = BEAM / 2
    half = LENGTH / 2 - r
    f = np.array([np.cos(heading), np.sin(heading)])
    a, b = centre - half * f, centre + half * f
    ang = np.linspace(0, 2 * np.pi, n, endpoint=False)
    normals = np.c_[np.cos(ang), np.sin(ang)]
    ends = np.where((normals @ f)[:, None] >= 0, b, a)
    return ends + (r + offset_m) * normals, normals


def test_velocity_is_tangent_to_a_still_hull(channel):
    field, _ = channel
    pts, normals = _outline(1e-4)
    status, v = field.query(pts)
    assert np.all(status == INSIDE)
    normal = np.abs((v * normals).sum(1))
    tangent = np.abs(v[:, 0] * normals[:, 1] - v[:, 1] * normals[:, 0])
    assert normal.max() < 1e-3 * tangent.max()
    assert 0.7 < tangent.max() < 2.0     # the water slips round the hull, fast at its sides
    # the normal part grows with g (about 3·d/reach of the free flow's)
    pts, normals = _outline(0.1)
    _, v = field.query(pts)
    assert np.abs((v * normals).sum(1)).max() < 3 * 0.1 / REACH * 1.3


def test_nothing_enters_a_moving_turning_hull():
    graph, _ = straight_channel()
    field = rf.FlowField(graph)
    u, w = np.array([-1.5, 0.4]), 0.3
    psi_o = float(field.potential(CENTRE[None])[0])
    field.set_obstacles([Obstacle(CENTRE, HEADING, LENGTH, BEAM, psi_o, tuple(u), w)])
    pts, normals = _outline(1e-4)
    _, v = field.query(pts)
    rigid = u + w * np.c_[-(pts - CENTRE)[:, 1], (pts - CENTRE)[:, 0]]
    assert np.abs(((v - rigid) * normals).sum(1)).max() < 1e-3
    # inside, the water moves with the hull
    inner, _ = _outline(-0.5, 50)
    _, v_in = field.query(inner)
    rigid_in = u + w * np.c_[-(inner - CENTRE)[:, 1], (inner - CENTRE)[:, 0]]
    npt.assert_allclose(v_in, rigid_in, atol=1e-5)


def test_velocity_is_the_curl_of_the_potential(channel):
    field, _ = channel
    pts, _ = _outline(1.2, 40)
    h = 1e-3
    dx = (field.potential(pts + (h, 0)) - field.potential(pts - (h, 0))) / (2 * h)
    dy = (field.potential(pts + (0, h)) - field.potential(pts - (0, h))) / (2 * h)
    _, v = field.query(pts)
    npt.assert_allclose(v, np.c_[-dy, dx], atol=2e-3)


def test_flux_through_small_loops_around_the_hull_is_zero(channel):
    field, _ = channel
    ang = np.linspace(0, 2 * np.pi, 2048, endpoint=False)
    ring = np.c_[np.cos(ang), np.sin(ang)]
    centres, _ = _outline(1.5, 16)
    for c in centres:
        pts = c + 1.0 * ring
        _, v = field.query(pts)
        flux = (v * ring).sum(1).mean() * 2 * np.pi        # ∮ v·n ds, radius 1
        scale = np.abs(v).sum(1).mean() * 2 * np.pi
        assert abs(flux) < 1e-3 * scale, (c, flux, scale)


def test_flow_is_unchanged_beyond_the_influence_distance(channel, rng):
    field, _ = channel
    pts = rng.uniform((170, -19), (230, 19), (3000, 2))
    far = np.hypot(*(pts - CENTRE).T) > LENGTH / 2 + REACH + 1e-6
    s1, v1 = field.query(pts)
    s0, v0 = field.query(pts, exclude_obstacles=True)
    npt.assert_array_equal(s1, s0)
    npt.assert_array_equal(v1[far], v0[far])
    assert np.any(v1[~far] != v0[~far])
    pts, _ = _outline(REACH + 0.01, 100)
    npt.assert_array_equal(field.query(pts)[1], field.query(pts, exclude_obstacles=True)[1])


def test_discharge_between_the_banks_is_kept(channel):
    field, psi_o = channel
    y = np.linspace(-19.999, 19.999, 40001)

    def discharge(x):
        _, v = field.query(np.c_[np.full_like(y, x), y])
        return np.trapezoid(v[:, 0], y)

    free = discharge(150.0)
    assert free == pytest.approx(40.0, rel=2e-3)
    for x in (CENTRE[0] - 2.0, CENTRE[0], CENTRE[0] + 1.0):   # sections through the hull
        assert discharge(x) == pytest.approx(free, rel=2e-3)
    # ψ_o splits it: between the right bank (y = −20: the larger ψ) and the hull flows
    # ψ(right bank) − ψ_o
    section = np.c_[np.full_like(y, CENTRE[0]), y]
    _, v = field.query(section)
    hull = _hull_distance(section) <= 0
    below = y < y[hull].min()
    psi_right = float(field.potential(np.array([[150.0, -19.999]]))[0])
    assert np.trapezoid(v[below, 0], y[below]) == pytest.approx(psi_right - psi_o, rel=2e-3)


def _hull_distance(pts):
    r = BEAM / 2
    f = np.array([np.cos(HEADING), np.sin(HEADING)])
    a, e = CENTRE - (LENGTH / 2 - r) * f, (LENGTH - BEAM) * f
    t = np.clip((pts - a) @ e / (e @ e), 0, 1)
    return np.hypot(*(pts - a - t[:, None] * e).T) - r


def test_obstacle_sets_and_exclusion(channel):
    graph, _ = straight_channel()
    field = rf.FlowField(graph)
    assert len(field.obstacles) == 0
    a = Obstacle((100.0, 0.0), psi=float(field.potential(np.array([[100.0, 0.0]]))[0]))
    b = Obstacle((300.0, 0.0), psi=float(field.potential(np.array([[300.0, 0.0]]))[0]))
    field.set_obstacles([a])
    field.set_obstacles(np.stack([b.row()]), key="boats")
    assert len(field.obstacles) == 2
    assert field.obstacle_rows("default") == range(1)
    assert field.obstacle_rows("boats") == range(1, 2)
    pts = np.array([[100.0, 1.0], [300.0, 1.0]])
    _, v_none = field.query(pts, exclude_obstacles=True)
    _, v_all = field.query(pts)
    _, v_no_b = field.query(pts, exclude_obstacles=[1])
    npt.assert_array_equal(v_all, 0.0)            # both points lie inside a still hull
    npt.assert_array_equal(v_no_b[1], v_none[1])
    npt.assert_array_equal(v_no_b[0], 0.0)
    field.set_obstacles([], key="boats")
    assert len(field.obstacles) == 1 and field.obstacle_rows("boats") == range(1, 1)
    with pytest.raises(ValueError):
        field.set_obstacles(np.zeros((1, 3)))
    bad = a.row()
    bad[ko.OB_BEAM] = -1.0
    with pytest.raises(ValueError):
        field.set_obstacles(bad[None])
