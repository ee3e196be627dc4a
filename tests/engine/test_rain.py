"""Rain (issue 12 item 4, seed 002): drops per frame, death on the surface, rain off, drops only
in the camera's box and view, no NaN, and the kernel against a plain-numpy twin."""
from __future__ import annotations

import math

import numpy as np
import pytest

from riverflow.components.rain import Rain
from riverflow.components.river import TerrainView
from riverflow.engine.camera import Camera
from riverflow.engine.config import RiverConfig
from riverflow.kernels.rain import SPAWN_TRIES, drops_this_frame, empty_drops, step_rain
from riverflow.kernels.surface_tiles import surface_altitude
from riverflow.tiles.surface import one_tile_surface
from riverflow.scenes.default import default_scene
from riverflow.scenes.flight import main_centerline
from tests.engine.flight import river_view

DT = 1 / 60


@pytest.fixture(scope="module")
def scene():
    return default_scene(seed=0)


@pytest.fixture(scope="module")
def world(scene):
    from riverflow.engine.world import RiverWorld
    w = RiverWorld(scene, size=(160, 90), gl=False, seed=0,
                   config=RiverConfig(tile_production="blocking"))
    w.camera.look_at(*river_view(scene))
    w.load_view()
    yield w
    w.close()


# -- count per frame -------------------------------------------------------------------------

@pytest.mark.parametrize("rate", [5.0, 60.0, 1000.0, 12345.0])
@pytest.mark.parametrize("variance", [0.0, 0.1, 0.5])
def test_new_drops_per_frame_within_mean_plus_minus_variance(rate, variance):
    rng = np.random.default_rng(1)
    carry = 0.0
    total = 0
    mean = rate * DT
    frames = 600
    for _ in range(frames):
        n, carry = drops_this_frame(rate, variance, DT, rng.uniform(-1, 1), carry)
        assert math.floor(mean * (1 - variance)) <= n <= math.ceil(mean * (1 + variance))
        assert 0.0 <= carry < 1.0
        total += n
    assert abs(total - rate * DT * frames) <= rate * DT * frames * variance + 1.0


def test_world_makes_the_asked_number_of_drops_in_an_open_view(scene):
    """Looking at the sky from above the land, every asked drop is born, within mean ± var."""
    from riverflow.engine.world import RiverWorld
    eye, target = river_view(scene, height_m=30.0)
    with RiverWorld(scene, size=(160, 90), gl=False, seed=3,
                    config=RiverConfig(tile_production="blocking")) as w:
        w.camera.look_at(eye, (target[0], target[1], eye[2] + 5.0))
        w.load_view()
        w.set_rain(1200.0, variance=0.25)
        rain = w.resource(Rain)
        mean = 1200.0 * DT
        for _ in range(30):
            w.step(DT)
            born, asked = int(rain.drops.counts[1]), int(rain.drops.counts[2])
            assert math.floor(mean * 0.75) <= asked <= math.ceil(mean * 1.25)
            assert born == asked


# -- the surface, rain off, the box, NaN -----------------------------------------------------

def test_no_drop_below_the_ground_or_the_water_after_a_frame(world):
    world.set_rain(3000.0)
    rain = world.resource(Rain)
    landed_total = 0
    for _ in range(90):
        world.step(DT)
        landed_total += world.systems[[s.name for s in world.systems].index("rain")].last[0]
        surface = world.resource(TerrainView).surface
        for x, y, z in world.rain_drops:
            alt = surface_altitude(surface, x, y)      # water level where wet, else ground
            assert math.isnan(alt) or z > alt
    assert landed_total > 0 and rain.drops.counts[3] > 0   # drops did land, on water too
    assert np.isfinite(world.rain_drops).all()
    world.set_rain(0)


def test_rain_off_leaves_no_drops(world):
    world.set_rain(2000.0)
    for _ in range(10):
        world.step(DT)
    assert len(world.rain_drops) > 0
    world.set_rain(0)                                     # at once, not after they land
    assert world.rain_drops.shape == (0, 3)
    for _ in range(5):
        world.step(DT)
        assert world.rain_drops.shape == (0, 3)
    assert not np.isfinite(world.resource(Rain).drops.hits[:, 3]).any()   # no ripple left


def test_drops_live_only_in_the_camera_box_and_view(world, scene):
    """Cost follows the view, not the map: wherever the camera goes, the drops are in the box
    around it and inside its six frustum planes."""
    rain = world.resource(Rain)
    world.set_rain(3000.0, wind_mps=(4.0, -2.0))
    line = main_centerline(scene)
    for frac in (0.3, 0.7):
        p = line[int(frac * (len(line) - 1))]
        level = float(scene.water.level(p[None])[0])
        world.camera.look_at((p[0] - 20, p[1] - 20, level + 15), (p[0], p[1], level))
        world.load_view()
        for _ in range(20):
            world.step(DT)
        drops = world.rain_drops
        assert len(drops) > 0
        eye = world.camera.position
        assert (np.abs(drops - eye) <= rain.box_half_m + 1e-9).all()
        m, _ = world.camera.matrices_for_kernels()
        clip = np.c_[drops, np.ones(len(drops))] @ m.T
        w = clip[:, 3:4]
        assert (np.abs(clip[:, :3]) <= w + 1e-9).all()
    world.set_rain(0)
    world.camera.look_at(*river_view(scene))
    world.load_view()


def test_set_rain_rejects_bad_values(world):
    for args in [(-1.0,), (float("nan"),), (10.0, -0.1), (10.0, 0.1, (float("inf"), 0.0)),
                 (10.0, 0.1, (1.0,))]:
        with pytest.raises(ValueError):
            world.set_rain(*args)


def test_no_nan_survives_a_frame():
    """Drops with NaN or infinite positions are removed; a huge dt leaves only finite drops."""
    cam = Camera((0.0, -50.0, 20.0), (0.0, 0.0, 5.0), size_px=(160, 90))
    m, inv = cam.matrices_for_kernels()
    surface = one_tile_surface(np.zeros((9, 9)), np.full((9, 9), np.nan), -200.0, -200.0, 50.0)
    drops = empty_drops(64, 8)
    drops.position[:3] = [[np.nan, 0, 10], [0, np.inf, 10], [0.0, -30.0, 15.0]]
    drops.velocity[:3] = [[0, 0, -5]] * 3
    drops.counts[0] = 3
    step_rain(drops, 0, np.zeros((0, 3)), DT, 0.0, 6.0, 9.81, 0.0, 0.0, m, inv,
              cam.position.astype(float), 40.0, surface, True, 1.0)
    n = int(drops.counts[0])
    assert n == 1 and np.isfinite(drops.position[:n]).all()
    step_rain(drops, 20, np.random.default_rng(0).random((20 * SPAWN_TRIES, 3)), 1e6, 0.0, 6.0,
              9.81, 0.0, 0.0, m, inv, cam.position.astype(float), 40.0, surface, True, 1.0)
    n = int(drops.counts[0])
    assert np.isfinite(drops.position[:n]).all() and np.isfinite(drops.velocity[:n]).all()


# -- kernel vs numpy twin --------------------------------------------------------------------

def _twin_step(pos, vel, n_new, randoms, dt, fall, g, wind, m, inv, eye, half, top_at):
    """Plain-numpy rain step (same rules as the kernel); returns (pos, vel, landed_xy)."""
    vel = vel.copy()
    vel[:, 0], vel[:, 1] = wind
    vel[:, 2] -= g * dt
    new = pos + vel * dt
    finite = np.isfinite(new).all(axis=1)
    top, wet = top_at(new[:, 0], new[:, 1])
    landed = finite & (new[:, 2] <= top)
    inside = _in_view(new, m, eye, half)
    keep = finite & ~landed & inside
    out_p, out_v = [new[keep]], [vel[keep]]
    f = _unproject(inv, np.array([[0.0, 0.0, -1.0]]))[0] - eye
    near = np.linalg.norm(f)
    f /= near
    far = half * math.sqrt(3.0)
    t = 0
    for _ in range(n_new):
        while t < len(randoms):
            r = randoms[t]
            t += 1
            d = (near ** 3 + r[2] * (far ** 3 - near ** 3)) ** (1 / 3)
            p = _unproject(inv, np.array([[2 * r[0] - 1, 2 * r[1] - 1, -1.0]]))[0]
            ray = p - eye
            q = eye + ray * (d / ray.dot(f))
            if not _in_view(q[None], m, eye, half)[0]:
                continue
            if q[2] <= top_at(q[None, 0], q[None, 1])[0][0]:
                continue
            out_p.append(q[None])
            out_v.append(np.array([[wind[0], wind[1], -fall]]))
            break
    return (np.concatenate(out_p), np.concatenate(out_v),
            new[landed & wet][:, :2])


def _in_view(p, m, eye, half):
    clip = np.c_[p, np.ones(len(p))] @ m.T
    w = clip[:, 3:4]
    return ((np.abs(p - eye) <= half).all(axis=1)
            & ((clip[:, :3] >= -w) & (clip[:, :3] <= w)).all(axis=1))


def _unproject(inv, ndc):
    h = np.c_[ndc, np.ones(len(ndc))] @ inv.T
    return h[:, :3] / h[:, 3:4]


def test_kernel_matches_the_numpy_twin():
    n_cells, cell = 16, 10.0
    x0, y0 = -80.0, -80.0
    ground = np.full((n_cells + 1, n_cells + 1), 0.0)
    water = np.full_like(ground, np.nan)
    water[:, : n_cells // 2] = 1.0                   # wet where x < 0 (node columns i < 8)
    surface = one_tile_surface(ground, water, x0, y0, cell)

    def top_at(x, y):
        i = np.floor((np.asarray(x) - x0) / cell)
        wet = i < n_cells // 2                       # a cell with a wet corner: level 1 m
        return np.where(wet, 1.0, 0.0), wet

    cam = Camera((0.0, -45.0, 12.0), (0.0, 0.0, 2.0), size_px=(160, 90))
    m, inv = cam.matrices_for_kernels()
    eye = cam.position.astype(float)
    rng = np.random.default_rng(7)
    drops = empty_drops(4096, 16)
    pos = np.zeros((0, 3))
    vel = np.zeros((0, 3))
    wind = (1.5, -0.5)
    for frame in range(40):
        n_new = int(rng.integers(0, 40))
        randoms = rng.random((n_new * SPAWN_TRIES, 3))
        step_rain(drops, n_new, randoms, DT, frame * DT, 6.0, 9.81,
                                         *wind, m, inv, eye, 30.0, surface, True, 0.0)
        pos, vel, _ = _twin_step(pos, vel, n_new, randoms, DT, 6.0, 9.81, wind, m, inv,
                                       eye, 30.0, top_at)
        n = int(drops.counts[0])
        assert n == len(pos)
        order_k = np.lexsort(drops.position[:n].T)
        order_t = np.lexsort(pos.T)
        np.testing.assert_allclose(drops.position[:n][order_k], pos[order_t], atol=1e-9)
        np.testing.assert_allclose(drops.velocity[:n][order_k], vel[order_t], atol=1e-9)
    assert len(pos) > 100
    assert drops.counts[3] > 0                       # hits on the wet half were recorded
    ring = drops.hits[np.isfinite(drops.hits[:, 3])]
    assert (ring[:, 0] < 0.0).all() and np.allclose(ring[:, 2], 1.0)


def test_demo_key_r_toggles_the_rain(scene):
    from riverflow.demo import KEYS, BoatDemo
    from riverflow.engine.controls import KeyScript
    demo = BoatDemo(scene, (96, 64), seed=0, gl=False,
                    config=RiverConfig(tile_production="blocking"))
    try:
        script = KeyScript.from_text("0 R tap\n40 r tap", keys=KEYS)
        for frame in range(40):
            script.feed(frame, demo.input)
            demo.step()
        assert demo.raining and len(demo.world.rain_drops) > 0
        assert any("rain" in line for line in demo.hud.lines(demo))
        for frame in range(40, 42):
            script.feed(frame, demo.input)
            demo.step()
        assert not demo.raining and len(demo.world.rain_drops) == 0
    finally:
        demo.close()
