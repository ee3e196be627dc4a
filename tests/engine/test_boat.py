"""The boat: carried by the flow, driven upstream, kept in the water, floating, deterministic —
and an obstacle the particles go around (headless RiverWorld, blocking tile production)."""
from __future__ import annotations

import math

import esper
import numpy as np
import pytest
import shapely

import riverflow as rf
from riverflow.components.boat import Boat
from riverflow.components.props import Pose
from riverflow.components.status import FlowStatus
from riverflow.engine.config import RiverConfig
from riverflow.kernels import obstacles as ko
from riverflow.physics.hull import hull_axis, hull_outline
from riverflow.scenes.flight import main_centerline
from riverflow.systems.boat import MoveBoats

DT = 1 / 60


@pytest.fixture(scope="module")
def scene():
    return rf.default_scene(seed=0)


@pytest.fixture(scope="module")
def river(scene):
    """The main river's centre line, as a shapely line and as samples every 10 m with the
    flow speed there and the room around them (distance to the nearest shore)."""
    line = main_centerline(scene)
    shape = shapely.LineString(line)
    s = np.arange(0.0, shape.length, 10.0)
    pts = shapely.get_coordinates(shape.interpolate(s))
    field = rf.FlowField.for_scene(scene)
    status, v = field.query(pts)
    speed = np.where(status == FlowStatus.INSIDE, np.hypot(*v.T), np.nan)
    room = shapely.distance(scene.water.polygon.boundary, shapely.points(pts))
    return {"line": shape, "s": s, "pts": pts, "speed": speed, "room": room}


def boat_world(scene, full: bool = False, size=(320, 180), seed: int = 0) -> rf.RiverWorld:
    """A gl=False world with only the boat system, or (``full``) every default system."""
    config = RiverConfig(radius_px=5.0, tile_production="blocking")
    systems = None if full else [MoveBoats()]
    return rf.RiverWorld(scene, size=size, gl=False, seed=seed, config=config, systems=systems)


def _along(river, xy) -> float:
    return float(river["line"].project(shapely.Point(xy)))


def _tangent(river, s: float) -> np.ndarray:
    a, b = (np.array(river["line"].interpolate(min(max(v, 0.0), river["line"].length)).coords[0])
            for v in (s - 5.0, s + 5.0))
    return (b - a) / np.linalg.norm(b - a)


def _hull_distance(boat: Boat, pts: np.ndarray) -> np.ndarray:
    """Signed distance [m] from points (M, 2) to the boat's capsule hull (< 0 inside)."""
    a, b = hull_axis(boat.position_m, boat.heading_rad, boat.length_m, boat.beam_m)
    e = b - a
    t = np.clip((pts - a) @ e / (e @ e), 0.0, 1.0)
    return np.hypot(*(pts - a - t[:, None] * e).T) - 0.5 * boat.beam_m


def _steer_towards(boat: Boat, target_xy, gain: float = 2.0) -> float:
    d = np.asarray(target_xy) - boat.position_m
    err = math.remainder(math.atan2(d[1], d[0]) - boat.heading_rad, math.tau)
    return float(np.clip(gain * err, -1.0, 1.0))


def _start(river, s_m: float) -> tuple[np.ndarray, float]:
    """A point of the centre line and the downstream heading there."""
    p = np.array(river["line"].interpolate(s_m).coords[0])
    t = _tangent(river, s_m)
    return p, math.atan2(t[1], t[0])


# -- drifting, driving ----------------------------------------------------------------------

def test_left_alone_the_boat_drifts_downstream(scene, river):
    world = boat_world(scene)
    s0 = 600.0
    p, heading = _start(river, s0)
    boat = world.boat(world.add_boat(p, heading))
    flow = river["speed"][np.argmin(np.abs(river["s"] - s0))]
    polygon = scene.water.polygon
    for _ in range(int(20 / DT)):
        world.step(DT)
        ring = hull_outline(boat.position_m, boat.heading_rad, boat.length_m, boat.beam_m)
        assert shapely.contains_xy(polygon, ring[:, 0], ring[:, 1]).all()
    gained = _along(river, boat.position_m) - s0
    assert gained >= 0.5 * flow * 20.0, (gained, flow)
    assert boat.velocity_mps @ boat.flow_mps > 0.0          # moving with the current
    world.close()


def test_full_throttle_upstream_makes_headway_in_a_slow_reach(scene, river):
    s, speed, room = river["s"], river["speed"], river["room"]
    ok = (room > 25.0) & (s > 300.0) & (s < s[-1] - 300.0) & np.isfinite(speed)
    smooth = np.convolve(np.nan_to_num(speed, nan=np.inf), np.ones(11) / 11, mode="same")
    k = np.flatnonzero(ok)[np.argmin(smooth[ok])]
    assert speed[k] < 0.8 * np.nanmedian(speed)             # a slow reach indeed
    world = boat_world(scene)
    p, downstream = _start(river, s[k])
    boat = world.boat(world.add_boat(p, downstream + math.pi))
    boat.throttle = 1.0
    for _ in range(int(15 / DT)):
        here = _along(river, boat.position_m)
        carrot = river["line"].interpolate(max(here - 40.0, 0.0)).coords[0]
        boat.rudder = _steer_towards(boat, carrot)
        world.step(DT)
    headway = s[k] - _along(river, boat.position_m)
    assert headway > 60.0, headway                           # ≈ 7 m/s over ground
    assert boat.flow_mps @ _tangent(river, s[k] - headway) > 0.0    # against the current
    assert boat.flow_mps @ np.array([math.cos(boat.heading_rad),
                                     math.sin(boat.heading_rad)]) < 0.0
    world.close()


class RammingPilot:
    """Scripted controls that ram things: targets in turn the free island, far past the right
    bank, far past the left bank (the island is often in the way), the right bank again…, at
    full throttle; after each hit (half a second grounded) or 20 s, two seconds astern with
    the rudder hard over, then the next."""

    def __init__(self, scene, river) -> None:
        self.scene, self.river = scene, river
        self.target = 0
        self.since_s = 0.0
        self.grounded_s = 0.0
        self.reverse_s = 0.0

    def controls(self, boat: Boat, dt_s: float) -> tuple[float, float]:
        self.since_s += dt_s
        self.grounded_s = self.grounded_s + dt_s if boat.grounded else 0.0
        if self.reverse_s > 0.0:
            self.reverse_s -= dt_s
            return -1.0, (1.0 if self.target % 2 else -1.0)
        if self.grounded_s > 0.5 or self.since_s > 20.0:
            self.target, self.since_s, self.reverse_s = self.target + 1, 0.0, 2.0
        kind = (0, 2, 1, 2)[self.target % 4]
        if kind == 0:
            return 1.0, _steer_towards(boat, np.mean(self.scene.islands[0], axis=0))
        river = self.river
        here = _along(river, boat.position_m)
        centre = np.array(river["line"].interpolate(here).coords[0])
        t = _tangent(river, here)
        side = np.array([-t[1], t[0]]) * (1.0 if kind == 1 else -1.0)
        return 1.0, _steer_towards(boat, centre + 400.0 * side + 30.0 * t)


@pytest.mark.slow
def test_long_scripted_run_never_leaves_the_water(scene, river):
    """3 simulated minutes ramming banks and the island: every hull outline point stays in
    the water polygon (islands are holes) at every step. Stepped at 30 Hz, a slow game's
    frame rate: its longer steps are the harder case for staying in the water."""
    dt = 1 / 30
    world = boat_world(scene)
    island = np.mean(scene.islands[0], axis=0)
    s0 = _along(river, island) - 120.0
    p, heading = _start(river, s0)
    boat = world.boat(world.add_boat(p, heading))
    polygon = scene.water.polygon
    island_ring = shapely.LinearRing(scene.islands[0])
    worst = 0.0
    bank_hits = island_hits = 0
    last_contact = -1000
    pilot = RammingPilot(scene, river)
    for frame in range(int(180 / dt)):
        boat.throttle, boat.rudder = pilot.controls(boat, dt)
        world.step(dt)
        ring = hull_outline(boat.position_m, boat.heading_rad, boat.length_m, boat.beam_m, 24)
        out = ~shapely.contains_xy(polygon, ring[:, 0], ring[:, 1])
        if out.any():
            worst = max(worst, float(shapely.distance(polygon, shapely.points(ring[out])).max()))
        if boat.grounded:
            if (frame - last_contact) * dt > 1.0:             # a new collision
                near_island = shapely.distance(island_ring, shapely.Point(boat.position_m))
                island_hits += near_island < boat.length_m
                bank_hits += near_island >= boat.length_m
            last_contact = frame
        assert np.isfinite(boat.position_m).all() and np.isfinite(boat.velocity_mps).all()
    assert worst < 1e-3, worst
    # (how often each is hit follows the current round the island: 4 and 12 with the
    # island's ψ by its centre's distances to the banks, 3 and 10 by its shore's)
    assert bank_hits >= 3 and island_hits >= 5, (bank_hits, island_hits)
    world.close()


def test_same_script_gives_identical_boat_paths(scene, river):
    def run(seed):
        world = boat_world(scene, full=True, seed=seed)
        p, heading = _start(river, 900.0)
        boat = world.boat(world.add_boat(p, heading))
        path = []
        for frame in range(240):
            t = frame * DT
            boat.throttle = 1.0 if t < 2.5 else -0.5
            boat.rudder = math.sin(1.3 * t)
            f = np.array([math.cos(boat.heading_rad), math.sin(boat.heading_rad), 0.0])
            c = np.array([*boat.position_m, boat.altitude_m])
            world.camera.look_at(c - 20.0 * f + (0, 0, 12.0), c + 10.0 * f)
            world.step(DT)
            path.append([*boat.position_m, boat.heading_rad, *boat.velocity_mps,
                         boat.altitude_m, boat.pitch_rad, boat.roll_rad])
        pool = world.pool.columns()
        world.close()
        return np.array(path), pool

    a, pool_a = run(3)
    b, pool_b = run(3)
    np.testing.assert_array_equal(a, b)
    for name in pool_a:
        np.testing.assert_array_equal(pool_a[name], pool_b[name], err_msg=name)
    assert np.ptp(a[:, 0]) + np.ptp(a[:, 1]) > 5.0            # it did go somewhere


# -- floating --------------------------------------------------------------------------------

def test_the_boat_floats_on_the_water_and_tilts_a_little(scene, river):
    world = boat_world(scene)
    p, heading = _start(river, 2000.0)
    entity = world.add_boat(p, heading, throttle=0.8, rudder=0.5, phase_rad=1.0)
    boat = world.boat(entity)
    pose = world.pose(entity)
    rec = []
    for _ in range(int(8 / DT)):
        world.step(DT)
        level = float(scene.water.level(boat.position_m[None])[0])
        rec.append((boat.altitude_m - level, boat.pitch_rad, boat.roll_rad))
        assert np.allclose(pose.position_m, [*boat.position_m, boat.altitude_m])
        assert (pose.yaw_rad, pose.pitch_rad, pose.roll_rad) == (
            boat.heading_rad, boat.pitch_rad, boat.roll_rad)
    rec = np.array(rec)
    assert np.abs(rec[:, 0]).max() <= boat.bob_m + 0.02       # on the surface, bobbing
    assert np.ptp(rec[:, 0]) > boat.bob_m                     # it does bob
    assert np.abs(rec[:, 1:]).max() < 0.15                    # a few degrees at most
    assert np.ptp(rec[:, 1]) > 0.002 and np.ptp(rec[:, 2]) > 0.002
    assert rec[-60:, 1].mean() > 0.0                          # bow up at speed
    assert rec[-60:, 2].mean() < 0.0                          # leaning into a port turn
    world.close()


# -- the boat in the flow ------------------------------------------------------------------

def test_the_boat_is_an_obstacle_in_the_flow(scene, river):
    world = boat_world(scene)
    p, heading = _start(river, 1500.0)
    entity = world.add_boat(p, heading + 0.8)
    world.step(DT)
    boat = world.boat(entity)
    field = world.field
    assert field.obstacle_rows("boats") == range(1)
    row = field.obstacles[0]
    np.testing.assert_allclose(row[[ko.OB_X, ko.OB_Y]], boat.position_m)
    assert row[ko.OB_PSI] == pytest.approx(
        field.potential(boat.position_m[None], exclude_obstacles=True)[0])
    ring = hull_outline(boat.position_m, boat.heading_rad, boat.length_m, 1.6 * boat.beam_m)
    _, with_boat = field.query(ring)
    _, without = field.query(ring, exclude_obstacles=True)
    assert np.abs(with_boat - without).max() > 0.2
    # the boat's own reading of the flow leaves its hull out
    np.testing.assert_allclose(boat.flow_mps, field.query(
        boat.position_m + np.outer([2.8, 0, -2.8], [math.cos(boat.heading_rad),
                                                    math.sin(boat.heading_rad)]),
        exclude_obstacles=True)[1].mean(axis=0), atol=0.05)
    with world.active():
        esper.delete_entity(entity)
    world.step(DT)
    assert len(field.obstacles) == 0
    world.close()


def test_particles_go_around_the_hull_not_through_it(scene, river):
    """A boat held against the current, then driven upstream at full throttle, with the
    camera on it: particles that start within a beam upstream of the bow never enter the
    hull, and pass it (those heading for the bow of the still boat slow down there and are
    mostly culled by the Poisson maintenance before they get round: crowded)."""
    world = boat_world(scene, full=True)
    s, speed, room = river["s"], river["speed"], river["room"]
    k = np.flatnonzero((room > 30.0) & (s > 300.0) & (speed > 0.9))[0]   # a brisk reach
    p, downstream = _start(river, s[k])
    boat = world.boat(world.add_boat(p, downstream + math.pi))
    hold = p.copy()
    tracked: dict[int, float] = {}
    passed: set[int] = set()
    entered = []

    for frame in range(int(14 / DT)):
        t = frame * DT
        f = np.array([math.cos(boat.heading_rad), math.sin(boat.heading_rad)])
        if t < 6.0:                                  # hold station: a P controller
            behind = float((hold - boat.position_m) @ f)
            boat.throttle = float(np.clip(0.1 + 0.4 * behind - 0.8 * (boat.velocity_mps @ f),
                                          -1, 1))
        else:
            boat.throttle = 1.0
        c = np.array([*boat.position_m, boat.altitude_m])
        world.camera.look_at(c - 12.0 * np.r_[f, 0] + (0, 0, 30.0), c + 6.0 * np.r_[f, 0])
        world.step(DT)
        live = world.particles
        rel = live.world_m[:, :2] - boat.position_m
        along, across = rel @ f, rel @ np.array([-f[1], f[0]])
        if frame >= 90 and frame % 15 == 0:          # new particles ahead of the bow
            ahead = ((live.status == FlowStatus.INSIDE) & (along > 0.5 * boat.length_m)
                     & (along < 0.5 * boat.length_m + boat.beam_m)
                     & (np.abs(across) < boat.beam_m))
            ahead &= _hull_distance(boat, live.world_m[:, :2]) > 0.0
            for pid in live.ids[ahead].tolist():
                tracked.setdefault(pid, np.inf)
        mine = np.isin(live.ids, list(tracked))
        d = _hull_distance(boat, live.world_m[mine, :2])
        for pid, dist, a in zip(live.ids[mine].tolist(), d, along[mine]):
            tracked[pid] = min(tracked[pid], dist)
            if dist < -0.02:
                entered.append((frame, pid, dist))
            if a < -0.5 * boat.length_m:
                passed.add(pid)
    assert not entered, entered[:5]
    assert len(tracked) >= 30, len(tracked)
    # a third of them pass the hull (48 of 139 since the flow kernel reads a convex corner's
    # tie by the corner normal: the hull's corners no longer read as water; 52 of 136 before)
    assert len(passed) >= max(20, 0.33 * len(tracked)), (len(passed), len(tracked))
    closest = sorted(tracked.values())
    assert closest[0] < 1.0                                  # some brushed past the hull
    world.close()


# -- API -----------------------------------------------------------------------------------

def test_add_boat_checks_its_arguments(scene, river):
    world = boat_world(scene)
    with pytest.raises(ValueError, match="fit"):
        world.add_boat((0.0, 1900.0))                        # on land
    island = np.mean(scene.islands[0], axis=0)
    with pytest.raises(ValueError, match="fit"):
        world.add_boat(island)
    p, heading = _start(river, 1000.0)
    with pytest.raises(ValueError, match="no field"):
        world.add_boat(p, heading, speed=3.0)
    with pytest.raises(ValueError):
        world.add_boat(p, heading, beam_m=0.0)
    entity = world.add_boat(p, heading, drawn=False, length_m=12.0)
    boat = world.boat(entity)
    assert isinstance(boat, Boat) and boat.length_m == 12.0
    with world.active():
        assert esper.try_component(entity, Pose) is None
    boat.throttle, boat.rudder = float("nan"), 7.0           # bad input never crashes a frame
    boat.velocity_mps = np.array([np.nan, 1.0])
    world.step(DT)
    assert (boat.throttle, boat.rudder) == (0.0, 1.0)
    assert np.isfinite(boat.position_m).all() and np.isfinite(boat.velocity_mps).all()
    world.close()
