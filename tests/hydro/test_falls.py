"""Falls, weirs and dams (issue #23): placed by hand, found from water levels, bad input; the
flow speeding up to critical flow at the lip, the water surface along the nappe, and a
particle carried over a 5 m fall in the ballistic fall time."""
from __future__ import annotations

import math

import numpy as np
import pytest
from numba import njit

import riverflow as rf
from riverflow.hydro.builder import RiverNetworkBuilder
from riverflow.hydro.falls import G_MPS2, find_falls, nappe_drop
from riverflow.hydro.graph import GraphError
from riverflow.kernels import falls as kfalls

WIDTH = 20.0
DROP = 5.0
LIP_X = 300.0


def _straight(length=600.0, fall=True, **fall_args):
    b = RiverNetworkBuilder()
    x = np.linspace(0.0, length, 61)
    b.add_branch(np.stack([x, np.zeros_like(x)], 1), WIDTH, discharge_m2s=20.0, name="r")
    if fall:
        b.add_fall(fall_args.pop("at_m", LIP_X), fall_args.pop("drop_m", DROP), **fall_args)
    return b


@pytest.fixture(scope="module")
def scene():
    return rf.landscape(_straight().build(), seed=0)


@pytest.fixture(scope="module")
def field(scene):
    return rf.FlowField.for_scene(scene)


# -- the graph ---------------------------------------------------------------------------------

def test_a_placed_fall_is_on_the_graph_with_its_lip_across_the_river():
    g = _straight().build()
    (f,) = g.falls
    assert f.branch == "r" and f.at_m == LIP_X and f.drop_m == DROP and f.kind == "fall"
    assert np.allclose(f.centre_m, (LIP_X, 0.0)) and np.allclose(f.direction, (1.0, 0.0))
    assert f.lip_m == pytest.approx(WIDTH)
    assert np.allclose(f.lip_ends_m, [[LIP_X, 10.0], [LIP_X, -10.0]])
    # critical flow from the river's depth, and the ballistic throw of the nappe
    assert f.lip_speed_mps == pytest.approx(math.sqrt(G_MPS2 * f.depth_m))
    assert f.throw_m == pytest.approx(f.lip_speed_mps * math.sqrt(2 * DROP / G_MPS2))


def test_a_fall_at_a_point_goes_on_the_nearest_branch_and_a_weir_keeps_its_lip():
    b = _straight(fall=False)
    b.add_fall((120.0, 3.0), 2.0, kind="weir", lip_m=12.0)
    (f,) = b.build().falls
    assert f.at_m == pytest.approx(120.0) and f.kind == "weir" and f.lip_m == 12.0


@pytest.mark.parametrize("args, words", [
    (dict(drop_m=-1.0), "positive"),
    (dict(drop_m=float("nan")), "positive"),
    (dict(drop_m="high"), "number"),
    (dict(at_m=700.0), "off the river"),
    (dict(at_m=-1.0), "off the river"),
    (dict(at_m=(300.0, 25.0)), "off the river"),
    (dict(lip_m=25.0), "longer than the river is wide"),
    (dict(lip_m=0.0), "positive"),
    (dict(kind="cascade"), "kind"),
    (dict(branch="nile"), "no branch"),
])
def test_bad_falls_are_clear_graph_errors(args, words):
    with pytest.raises(GraphError, match=words) as err:
        _straight(**args)
    assert isinstance(err.value, ValueError)
    assert "fall 0" in str(err.value)


def test_falls_whose_nappes_do_not_fit_are_graph_errors():
    b = _straight(at_m=598.0)
    with pytest.raises(GraphError, match="fall 0: its nappe .* runs past the end"):
        b.build()
    b = _straight()
    b.add_fall(LIP_X + 1.0, 2.0)
    with pytest.raises(GraphError, match="falls 0 and 1 .* overlap"):
        b.build()


def test_falls_are_found_from_water_levels():
    s = np.linspace(0.0, 100.0, 401)
    z = 50.0 - 0.01 * s
    z[s >= 40.0] -= 3.0 * np.clip((s[s >= 40.0] - 40.0) / 2.0, 0.0, 1.0)   # 3 m over 2 m
    z[s >= 70.0] -= 0.5 * np.clip((s[s >= 70.0] - 70.0) / 0.25, 0.0, 1.0)  # too small
    (at, drop), = find_falls(s, z, 1.0)
    assert at == pytest.approx(40.0) and drop == pytest.approx(3.0, abs=0.05)
    # a steep reach (a 3 m drop spread over 20 m) is a rapid, not a fall
    ramp = 50.0 - 3.0 * np.clip((s - 40.0) / 20.0, 0.0, 1.0)
    assert find_falls(s, ramp, 1.0) == []

    b = _straight(fall=False)
    b.water_levels = lambda xy: 20.0 - np.where(xy[:, 0] >= 400.0, 4.0, 0.0)
    (f,) = b.build().falls
    assert f.in_levels and f.drop_m == pytest.approx(4.0) and abs(f.at_m - 400.0) <= 1.0
    b = _straight(fall=False)
    b.fall_min_drop_m = 5.0
    b.water_levels = lambda xy: 20.0 - np.where(xy[:, 0] >= 400.0, 4.0, 0.0)
    assert b.build().falls == []


def test_the_thresholds_come_from_the_river_config():
    """RiverConfig.fall_min_drop_m (default 1 m) and rapids_min_slope reach a builder through
    use_config; the builder's own defaults are the same numbers; bad values are named."""
    from riverflow.engine.config import RiverConfig

    config = RiverConfig()
    assert config.fall_min_drop_m == 1.0 and config.rapids_min_slope == 0.02
    fresh = RiverNetworkBuilder()
    assert (fresh.fall_min_drop_m, fresh.rapids_min_slope) == (config.fall_min_drop_m,
                                                               config.rapids_min_slope)

    def levels(xy):                    # a 4 m fall at 400 m and a 3 % reach from 100 to 200 m
        x = xy[:, 0]
        return 30.0 - 3.0 * np.clip((x - 100.0) / 100.0, 0.0, 1.0) - np.where(x >= 400.0,
                                                                               4.0, 0.0)

    found = {}
    for name, cfg in (("default", config),
                      ("strict", RiverConfig(fall_min_drop_m=5.0, rapids_min_slope=0.04))):
        b = _straight(fall=False).use_config(cfg)
        b.water_levels = levels
        g = b.build()
        found[name] = (len(g.falls), len(g.rapids))
    assert found == {"default": (1, 1), "strict": (0, 0)}
    for bad, words in (({"fall_min_drop_m": 0.0}, "fall_min_drop_m must be positive"),
                       ({"fall_min_drop_m": float("nan")}, "fall_min_drop_m must be finite"),
                       ({"rapids_min_slope": 0.6}, "rapids_min_slope must lie in")):
        with pytest.raises(ValueError, match=words):
            RiverConfig(**bad)


# -- the water surface -------------------------------------------------------------------------

def test_the_surface_drops_along_the_nappe(scene):
    (f,) = scene.graph.falls
    s = LIP_X + np.linspace(-20.0, f.throw_m + 20.0, 200)
    level = scene.water.level(np.stack([s, np.zeros_like(s)], 1))
    assert np.all(np.diff(level) <= 1e-9)
    lip = float(scene.water.level(np.array([[LIP_X, 0.0]]))[0])
    pool = float(scene.water.level(np.array([[LIP_X + f.throw_m + 0.5, 0.0]]))[0])
    assert lip - pool == pytest.approx(DROP, abs=0.02)
    on = (s > LIP_X) & (s < LIP_X + f.throw_m)
    assert np.allclose(lip - level[on], nappe_drop(s[on] - LIP_X, DROP, f.throw_m), atol=0.02)


# -- the flow ----------------------------------------------------------------------------------

def _factor_twin(table, p):
    """Numpy twin of kernels.falls.fall_factor, every fall multiplied (module docstring)."""
    k = np.ones(len(p))

    def smooth(t):
        t = np.clip(t, 0.0, 1.0)
        return t * t * (3 - 2 * t)

    for f in range(len(table.gain)):
        r = p - table.centre[f]
        t = table.direction[f]
        d = r @ t
        e = np.abs(r[:, 1] * t[0] - r[:, 0] * t[1])
        a, throw, plunge = table.approach[f], table.throw[f], table.plunge[f]
        ramp = np.where(d < 0.0, smooth((d + a) / a),
                        np.where(d <= throw, 1.0, 1.0 - smooth((d - throw) / plunge)))
        ramp = np.where((d < -a) | (d > throw + plunge), 0.0, ramp)
        lat = 1.0 - smooth((e - table.half_lip[f]) / table.fade[f])
        k *= 1.0 + (table.gain[f] - 1.0) * ramp * lat
    return k


def test_the_fall_kernel_matches_its_numpy_twin():
    rng = np.random.default_rng(3)
    table = kfalls.FallTable(np.array([[0.0, 0.0], [40.0, 5.0]]),
                             np.array([[1.0, 0.0], [0.6, 0.8]]), np.array([8.0, 5.0]),
                             np.array([1.0, 2.0]), np.array([20.0, 12.0]), np.array([4.0, 2.5]),
                             np.array([10.0, 6.0]), np.array([3.0, 2.0]))
    p = rng.uniform((-30.0, -20.0), (70.0, 30.0), (4000, 2))
    status = np.where(rng.random(len(p)) < 0.9, 1, 0).astype(np.uint8)
    v = rng.normal(size=(len(p), 2)).astype(np.float32)
    out = v.copy()
    changed = kfalls.accelerate_falls(p, status, out, len(p), table)
    want = np.where(status[:, None] == 1, v * _factor_twin(table, p)[:, None], v)
    assert np.allclose(out, want, rtol=1e-5)
    assert changed == int(np.sum((status == 1) & (_factor_twin(table, p) != 1.0)))


def test_the_flow_reaches_critical_speed_at_the_lip(field, scene):
    (f,) = scene.graph.falls
    pts = np.array([[LIP_X, 0.0], [LIP_X - 20.0, 0.0], [LIP_X - 100.0, 0.0],
                    [LIP_X + f.throw_m, 0.0], [LIP_X + 100.0, 0.0]])
    status, v = field.query(pts)
    speed = np.hypot(*v.T)
    assert (status == rf.FlowStatus.INSIDE).all()
    assert speed[0] >= math.sqrt(G_MPS2 * f.depth_m) * (1 - 1e-5)
    assert speed[0] > speed[1] > speed[2]                   # speeding up toward the lip
    assert speed[3] == pytest.approx(speed[0], rel=1e-3)    # the nappe keeps the lip speed
    assert speed[4] == pytest.approx(speed[2], rel=1e-3)    # the river's own flow below
    # the flow still runs along the banks: only the speed changes
    plain = rf.FlowField.for_scene(rf.landscape(_straight(fall=False).build(), seed=0))
    _, v0 = plain.query(pts)
    cos = np.einsum("ij,ij->i", v, v0) / (np.hypot(*v.T) * np.hypot(*v0.T))
    assert np.all(cos > 1 - 1e-6)


def test_a_particle_goes_over_a_5_m_fall_in_the_ballistic_time(field, scene):
    """Euler steps of 2 ms along field.query, riding the water surface: from the lip to the
    pool it takes √(2h/g) (within 5 %), the whole way its approach time plus that, and it goes
    on downstream; particles spread across the river are none of them left at the lip."""
    (f,) = scene.graph.falls
    lip = float(scene.water.level(np.array([[LIP_X, 0.0]]))[0])
    start_x = LIP_X - 40.0
    p = np.array([[start_x, 0.0], [start_x, 4.0], [start_x, -7.0]])
    t = 0.0
    t_lip = t_pool = None
    while t < 120.0 and p[:, 0].min() < LIP_X + 30.0:
        _, v = field.query(p)
        near = LIP_X - 2.0 <= p[0, 0] <= LIP_X + f.throw_m + 1.0
        dt = 0.002 if near else 0.04
        p = p + dt * v
        t += dt
        z = float(scene.water.level(p[:1])[0])
        if t_lip is None and p[0, 0] >= LIP_X:
            t_lip = t
        if t_pool is None and z <= lip - DROP + 0.01:
            t_pool = t
    assert t_lip is not None and t_pool is not None
    assert t_pool - t_lip == pytest.approx(f.fall_time_s, rel=0.05)
    # the approach: ∫ dx / v(x) of the river's speed times the twin's factor
    x = np.linspace(start_x, LIP_X, 2001)
    plain = rf.FlowField.for_scene(rf.landscape(_straight(fall=False).build(), seed=0))
    _, v0 = plain.query(np.stack([x, np.zeros_like(x)], 1))
    k = _factor_twin(field.fall_table(), np.stack([x, np.zeros_like(x)], 1))
    approach = np.trapezoid(1.0 / (np.hypot(*v0.T) * k), x)
    assert t_pool == pytest.approx(approach + f.fall_time_s, rel=0.05)
    assert (p[:, 0] >= LIP_X + 30.0).all() and t < 120.0   # all three went on downstream


def _plunge_twin(table, p):
    """Numpy twin of kernels.falls.plunge_closeness."""
    def smooth(t):
        t = np.clip(t, 0.0, 1.0)
        return t * t * (3 - 2 * t)

    best = np.zeros(len(p))
    for f in range(len(table.gain)):
        r = p - table.centre[f]
        t = table.direction[f]
        d = r @ t
        e = np.abs(r[:, 1] * t[0] - r[:, 0] * t[1])
        throw, plunge = table.throw[f], table.plunge[f]
        ramp = np.where(d <= throw, smooth((d - 0.5 * throw) / (0.5 * throw)),
                        1.0 - smooth((d - throw) / plunge))
        ramp = np.where((d < 0.5 * throw) | (d > throw + plunge), 0.0, ramp)
        lat = 1.0 - smooth((e - table.half_lip[f]) / table.fade[f])
        best = np.maximum(best, ramp * lat)
    return best


@njit(cache=True)
def _closeness(table, p, out):
    for i in range(p.shape[0]):
        out[i] = kfalls.plunge_closeness(table, p[i, 0], p[i, 1])


def test_the_plunge_pool_closeness_matches_its_numpy_twin():
    rng = np.random.default_rng(4)
    table = kfalls.FallTable(np.array([[0.0, 0.0], [30.0, 5.0]]),
                             np.array([[1.0, 0.0], [0.6, 0.8]]), np.array([8.0, 5.0]),
                             np.array([1.0, 2.0]), np.array([20.0, 12.0]), np.array([4.0, 2.5]),
                             np.array([10.0, 6.0]), np.array([3.0, 2.0]))
    p = rng.uniform((-10.0, -15.0), (50.0, 30.0), (3000, 2))
    out = np.empty(len(p))
    _closeness(table, p, out)
    assert np.allclose(out, _plunge_twin(table, p), atol=1e-12)
    assert out.max() == pytest.approx(1.0, abs=0.01) and (out == 0.0).mean() > 0.5


# -- rapids ------------------------------------------------------------------------------------

def test_rapids_given_and_found_and_bad_ones():
    b = _straight(fall=False)
    b.add_rapids(100.0, 160.0, 6.0)
    (r,) = b.build().rapids
    assert (r.from_m, r.to_m, r.drop_m) == (100.0, 160.0, 6.0) and r.slope == pytest.approx(0.1)
    for args, words in (((100.0, 160.0, -1.0), "positive"), ((100.0, 90.0, 1.0), "no length"),
                        ((500.0, 700.0, 1.0), "off the river"), ((100.0, 104.0, 3.0), "a fall")):
        with pytest.raises(GraphError, match=words):
            _straight(fall=False).add_rapids(*args)
    s = np.linspace(0.0, 200.0, 801)
    z = 30.0 - 0.001 * s - 3.0 * np.clip((s - 50.0) / 100.0, 0.0, 1.0)      # 3 % over 100 m
    (a, e, drop), = rf.hydro.falls.find_rapids(s, z)
    assert a == pytest.approx(50.0, abs=0.5) and e == pytest.approx(150.0, abs=0.5)
    assert drop == pytest.approx(3.1, abs=0.05)
    b = _straight(fall=False)
    b.water_levels = lambda xy: 30.0 - 0.001 * xy[:, 0] - 3.0 * np.clip(
        (xy[:, 0] - 200.0) / 100.0, 0.0, 1.0)
    g = b.build()
    assert g.falls == [] and len(g.rapids) == 1 and g.rapids[0].in_levels


def test_the_surface_slopes_down_a_rapid():
    b = _straight(fall=False)
    b.add_rapids(100.0, 160.0, 6.0)
    sc = rf.landscape(b.build(), seed=0)
    s = np.array([90.0, 100.0, 130.0, 160.0, 170.0])
    z = sc.water.level(np.stack([s, np.zeros_like(s)], 1))
    assert z[1] - z[3] == pytest.approx(6.0, abs=0.05)      # + the river's own 0.05 %
    assert (z[1] - z[2]) == pytest.approx(3.0, abs=0.05)
    assert abs(z[0] - z[1]) < 0.1 and abs(z[3] - z[4]) < 0.1


def test_the_flow_runs_faster_on_rapids_by_their_slope():
    """Rapids speed the flow up through the falls' kernel (the same query correction): on a
    10 % rapid by (10/2)^0.3 = 1.62, on a 3 % riffle of the same river by 1.13; upstream and
    downstream the river's own flow; across the river the same gain, along the banks (only
    the speed changes). The rapids' table rows are the kernel's twin's."""
    from riverflow.hydro.falls import RAPIDS_MIN_SLOPE, RAPIDS_SPEED_EXPONENT
    b = _straight(fall=False)
    b.add_rapids(100.0, 160.0, 6.0)
    b.add_rapids(300.0, 400.0, 3.0)
    graph = b.build()
    steep, riffle = graph.rapids
    assert steep.width_m == pytest.approx(WIDTH) and riffle.slope == pytest.approx(0.03)
    assert steep.speed_gain == pytest.approx((0.1 / RAPIDS_MIN_SLOPE) ** RAPIDS_SPEED_EXPONENT)
    assert riffle.speed_gain == pytest.approx(1.129, abs=1e-3)
    field = rf.FlowField(graph)
    plain = rf.FlowField(_straight(fall=False).build())
    pts = np.array([[x, y] for x in (40.0, 130.0, 350.0, 520.0) for y in (-5.0, 0.0, 5.0)])
    status, v = field.query(pts)
    _, v0 = plain.query(pts)
    assert (status == rf.FlowStatus.INSIDE).all()
    gain = (np.hypot(*v.T) / np.hypot(*v0.T)).reshape(4, 3)
    assert np.allclose(gain[0], 1.0) and np.allclose(gain[3], 1.0)
    assert np.allclose(gain[1], steep.speed_gain, rtol=1e-4)
    assert np.allclose(gain[2], riffle.speed_gain, rtol=1e-4)
    cos = np.einsum("ij,ij->i", v, v0) / (np.hypot(*v.T) * np.hypot(*v0.T))
    assert np.all(cos > 1 - 1e-6)
    # the twin: the whole gain field over the rapids' table
    p = np.stack([np.linspace(60.0, 460.0, 401), np.zeros(401)], 1)
    s, vq = field.query(p)
    _, vp = plain.query(p)
    want = _factor_twin(field.rapid_table(), p)
    assert np.allclose(np.hypot(*vq.T) / np.hypot(*vp.T), want, rtol=1e-4)
    assert want.max() == pytest.approx(steep.speed_gain) and (want == 1.0).sum() > 50
