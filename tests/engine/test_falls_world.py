"""A river world over a 5 m fall (issue #23): the particles speed up to the lip, fall with the
water and go on in the pool, none left at the lip; a boat that reaches the lip goes over."""
from __future__ import annotations

import math

import numpy as np
import pytest

import riverflow as rf
from riverflow.components.status import FlowStatus
from riverflow.engine.config import RiverConfig
from riverflow.systems.boat import MoveBoats
from tests.hydro.test_falls import DROP, LIP_X, _straight

DT = 1 / 30


@pytest.fixture(scope="module")
def scene():
    return rf.landscape(_straight().build(), seed=0)


def test_particles_go_over_the_fall_none_stays_at_the_lip_and_the_pool_foams(scene):
    """One view of the approach, the fall and 60 m of river below it: particles ride the
    river's level above and the pool's below, move on over the lip and the nappe frame after
    frame (none stuck), and foam where they land (the foam's pressure term at the impact):
    the pool's foam well above that 50 m downstream and above the fall. (Carrying it on
    downstream is the foam's slow decay, tested in tests/engine/test_foam.py; 3 s of frames do
    not take a particle 50 m.)"""
    (f,) = scene.graph.falls
    lip = float(scene.water.level(np.array([[LIP_X, 0.0]]))[0])
    world = rf.RiverWorld(scene, size=(160, 90), gl=False, seed=0,
                          config=RiverConfig(radius_px=5.0, tile_production="blocking"))
    world.camera.look_at((LIP_X + 20.0, -55.0, lip + 22.0), (LIP_X + 20.0, 0.0, lip - 4.0))
    seen: dict[int, list[tuple[float, float]]] = {}
    foam = {"above": [], "pool": [], "below": []}
    for frame in range(90):
        world.step(DT)
        p = world.particles
        assert np.isfinite(p.world_m).all() and np.isfinite(p.velocity_mps).all()
        inside = p.status == FlowStatus.INSIDE
        for i in np.flatnonzero(inside):
            seen.setdefault(int(p.ids[i]), []).append((frame, float(p.world_m[i, 0])))
        if frame >= 60:
            d = p.world_m[inside, 0] - LIP_X
            for name, sel in (("above", (d > -20.0) & (d < -5.0)),
                              ("pool", (d > f.throw_m) & (d < f.throw_m + 8.0)),
                              ("below", (d > 45.0) & (d < 60.0))):
                foam[name] += p.foam[inside][sel].tolist()
    p = world.particles
    inside = p.status == FlowStatus.INSIDE
    x, z = p.world_m[inside, 0], p.world_m[inside, 2]
    speed = np.hypot(*p.velocity_mps[inside].T)
    # above the lip at the river's level, in the pool at the pool's
    up = x < LIP_X - 8.0
    pool = x > LIP_X + f.throw_m + 4.0
    assert up.sum() >= 3 and pool.sum() >= 3
    assert np.all(np.abs(z[up] - lip) < 0.3)
    assert np.all(np.abs(z[pool] - (lip - DROP)) < 0.3)
    # over the lip and the nappe they move faster than the river far above it (1 m/s)
    over = (x > LIP_X - 5.0) & (x < LIP_X + f.throw_m + 2.0)
    assert over.any() and np.all(speed[over] > 1.5 * f.speed_mps)
    # none stuck: from frame to frame, every particle near the lip or over the nappe moved
    # on downstream by at least half the river's own speed
    steps = 0
    for track in seen.values():
        for (f0, x0), (f1, x1) in zip(track, track[1:]):
            if f1 == f0 + 1 and LIP_X - 5.0 < x0 < LIP_X + f.throw_m + 2.0:
                assert x1 - x0 > 0.5 * DT * f.speed_mps, (f0, x0, x1)
                steps += 1
    assert steps > 20
    means = {k: float(np.mean(v)) for k, v in foam.items()}
    assert all(len(v) > 10 for v in foam.values()), {k: len(v) for k, v in foam.items()}
    assert means["pool"] > means["below"] + 0.3 and means["pool"] > means["above"] + 0.3, means
    world.close()


def test_a_boat_at_the_lip_goes_over(scene):
    (f,) = scene.graph.falls
    lip = float(scene.water.level(np.array([[LIP_X, 0.0]]))[0])
    world = rf.RiverWorld(scene, size=(160, 90), gl=False, seed=0, systems=[MoveBoats()],
                          config=RiverConfig(tile_production="blocking"))
    boat = world.boat(world.add_boat((LIP_X - 25.0, 0.0), 0.0))
    speeds = []
    for _ in range(int(25 / DT)):
        world.step(DT)
        speeds.append(float(np.hypot(*boat.flow_mps)))
        if boat.position_m[0] > LIP_X + f.throw_m + 8.0:
            break
    assert boat.position_m[0] > LIP_X + f.throw_m + 8.0         # it went over
    assert boat.altitude_m < lip - DROP + 0.5                    # and floats in the pool
    assert max(speeds) >= 0.95 * math.sqrt(9.81 * f.depth_m)     # the flow it felt sped up
    world.close()


def test_a_steep_rapid_foams_more_than_a_gentle_reach():
    """Foam follows the slope (the foam's steepness term on the surface tiles): particles on
    a 10 % rapid carry more than those on the same river's 0.05 % reach."""
    b = _straight(fall=False)
    b.add_rapids(100.0, 160.0, 6.0)
    scene = rf.landscape(b.build(), seed=0)
    world = rf.RiverWorld(scene, size=(160, 90), gl=False, seed=0,
                          config=RiverConfig(radius_px=5.0, tile_production="blocking"))
    foam = {}
    for name, x0 in (("rapid", 130.0), ("gentle", 450.0)):
        z = float(scene.water.level(np.array([[x0, 0.0]]))[0])
        world.camera.look_at((x0, -45.0, z + 20.0), (x0, 0.0, z))
        values = []
        for frame in range(30):
            world.step(DT)
            if frame >= 20:
                p = world.particles
                sel = ((p.status == FlowStatus.INSIDE) & (np.abs(p.world_m[:, 0] - x0) < 20.0))
                values += p.foam[sel].tolist()
        assert len(values) > 10
        foam[name] = float(np.mean(values))
    assert foam["rapid"] > foam["gentle"] + 0.2, foam
    world.close()
