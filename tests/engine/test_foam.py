"""Foam in a running world (issue 12 item 1): particles near a moving hull and near a shore
carry clearly more foam than mid-channel ones in a slow reach; a foam patch moves downstream
with the particles; foam is bounded, never NaN, and off when disabled; wakes follow boats."""
from __future__ import annotations

import math

import numpy as np
import pytest
import shapely

from riverflow.components.status import FlowStatus
from riverflow.components.wake import TR_ARC, Wakes
from riverflow.scenes.default import default_scene
from riverflow.scenes.flight import main_centerline
from tests.engine.flight import make_world, river_view


@pytest.fixture(scope="module")
def scene():
    return default_scene(seed=0)


def _start(scene, at_m=1500.0):
    line = shapely.LineString(main_centerline(scene))
    p = np.array(line.interpolate(at_m).coords[0])
    q = np.array(line.interpolate(at_m + 10.0).coords[0])
    return p, math.atan2(*(q - p)[::-1])


def _chase(world, boat, back_m=20.0, up_m=8.0):
    f = np.array([math.cos(boat.heading_rad), math.sin(boat.heading_rad), 0.0])
    c = np.array([*boat.position_m, boat.altitude_m])
    world.camera.look_at(c - back_m * f + (0.0, 0.0, up_m), c + 12.0 * f)


def _hull_distance(xy, boat):
    """Distance from points (N, 2) to the boat's capsule hull [m] (0 inside)."""
    f = np.array([math.cos(boat.heading_rad), math.sin(boat.heading_rad)])
    arm = 0.5 * boat.length_m - 0.5 * boat.beam_m
    a, b = boat.position_m - arm * f, boat.position_m + arm * f
    e = b - a
    t = np.clip((xy - a) @ e / (e @ e), 0.0, 1.0)
    return np.maximum(np.hypot(*(xy - (a + t[:, None] * e)).T) - 0.5 * boat.beam_m, 0.0)


@pytest.fixture(scope="module")
def driven(scene):
    """A boat at full throttle for 8 s down the main river, chased by the camera."""
    world = make_world(scene, size=(320, 180), radius_px=5.0)
    p, heading = _start(scene)
    entity = world.add_boat(p, heading, throttle=1.0)
    boat = world.boat(entity)
    for _ in range(480):
        _chase(world, boat)
        world.step(1 / 60)
    yield world, boat, entity
    world.close()


def test_foam_near_a_moving_hull_and_near_shores_beats_the_slow_mid_channel(driven):
    world, boat, entity = driven
    speed = float(np.hypot(*(boat.velocity_mps - boat.flow_mps)))
    assert speed > 5.0
    p = world.particles
    water = p.status == FlowStatus.INSIDE
    xy, foam = p.world_m[water, :2], p.foam[water]
    hull = _hull_distance(xy, boat)
    shore = world.field.shore_distance(xy)
    trail = world.resource(Wakes).table[0]
    trail = trail[trail[:, TR_ARC] >= 0, :2].astype(float)
    to_trail = np.min(np.hypot(*(xy[:, None, :] - trail[None]).transpose(2, 0, 1)), axis=1)
    flow_speed = np.hypot(*p.velocity_mps[water].T)
    near_hull = hull <= 1.5 * boat.beam_m
    near_shore = (shore <= 5.0) & (to_trail > 20.0)
    mid = (shore > 12.0) & (to_trail > 20.0) & (hull > 30.0) & (flow_speed < 1.2)
    for group in (near_hull, near_shore, mid):
        assert group.sum() >= 5, (near_hull.sum(), near_shore.sum(), mid.sum())
    m_hull, m_shore, m_mid = foam[near_hull].mean(), foam[near_shore].mean(), foam[mid].mean()
    assert m_hull > m_mid + 0.3, (m_hull, m_mid)
    assert m_shore > max(3.0 * m_mid, m_mid + 0.1), (m_shore, m_mid)


def test_a_moving_boat_leaves_a_foam_trail_and_a_wake_table(driven):
    world, boat, _ = driven
    wakes = world.resource(Wakes)
    assert wakes.count == 1
    trail = wakes.table[0]
    assert trail[trail[:, TR_ARC] >= 0, TR_ARC].max() > 40.0       # metres of trail
    p = world.particles
    water = p.status == FlowStatus.INSIDE
    xy, foam = p.world_m[water, :2], p.foam[water]
    behind = np.array([-math.cos(boat.heading_rad), -math.sin(boat.heading_rad)])
    rel = xy - boat.position_m
    along = rel @ behind
    across = np.abs(rel @ np.array([-behind[1], behind[0]]))
    in_wash = (along > 6.0) & (along < 25.0) & (across < 2.0)
    beside = (along > 6.0) & (along < 25.0) & (across > 8.0)
    assert in_wash.sum() >= 3 and beside.sum() >= 3
    assert foam[in_wash].mean() > foam[beside].mean() + 0.3


def test_a_foam_patch_moves_downstream_with_the_particles(scene):
    world = make_world(scene, size=(320, 180), radius_px=5.0)
    try:
        world.camera.look_at(*river_view(scene, height_m=10.0, back_m=30.0))
        world.load_view()
        world.foam.decay_s = 120.0              # the patch fades slowly
        for _ in range(120):
            world.step(1 / 60)
        pool = world.pool
        water = np.flatnonzero(pool.alive & (pool.status == FlowStatus.INSIDE)
                               & (pool.foam_id == pool.ids))
        shore = world.field.shore_distance(pool.world_m[water, :2])
        mid = water[shore > 10.0]
        centre = np.median(pool.world_m[mid, :2], axis=0)
        patch = mid[np.hypot(*(pool.world_m[mid, :2] - centre).T) < 8.0]
        assert len(patch) >= 5
        pool.foam[patch] = 1.0
        ids = pool.ids[patch].copy()
        start = pool.world_m[patch, :2].copy()
        flow = pool.velocity_mps[patch].mean(axis=0).astype(float)
        before = _foam_centroid(world)
        seconds = 3.0
        for _ in range(int(seconds * 60)):
            world.step(1 / 60)
        # the particles that held the patch and are still alive (screen-space particles are
        # culled as perspective packs them) hold it where they went
        still = np.isin(pool.ids, ids) & pool.alive
        assert still.sum() >= 5
        assert pool.foam[still].min() > 0.9
        kept = np.isin(ids, pool.ids[still])
        moved = pool.world_m[still, :2].mean(axis=0) - start[kept].mean(axis=0)
        assert moved @ flow / np.linalg.norm(flow) > 0.7 * seconds * np.linalg.norm(flow)
        # and the patch as a whole (foam-weighted) moved downstream with them
        shift = _foam_centroid(world) - before
        assert shift @ flow / np.linalg.norm(flow) > 0.5 * seconds * np.linalg.norm(flow)
    finally:
        world.close()


def _foam_centroid(world):
    p = world.particles
    heavy = p.foam > 0.8
    return p.world_m[heavy, :2].mean(axis=0)


def test_foam_is_bounded_finite_and_off_when_disabled(driven):
    world, _, _ = driven
    foam = world.particles.foam
    assert foam.dtype == np.float32 and len(foam) == len(world.particles)
    assert np.isfinite(foam).all() and (foam >= 0).all() and (foam <= 1).all()
    assert (foam[world.particles.status != FlowStatus.INSIDE]
            [world.particles.status[world.particles.status != FlowStatus.INSIDE]
             != FlowStatus.LEAVING] == 0).all()
    world.foam.enabled = False
    try:
        world.step(1 / 60)
        assert not world.particles.foam.any()
    finally:
        world.foam.enabled = True
    with pytest.raises(ValueError, match="shore_m"):
        world.foam.shore_m = -1.0
        try:
            world.step(1 / 60)
        finally:
            world.foam.shore_m = 5.0


def test_a_still_boat_makes_no_hull_foam(scene):
    world = make_world(scene, size=(320, 180), radius_px=5.0)
    try:
        p, heading = _start(scene, 2600.0)
        boat = world.boat(world.add_boat(p, heading))
        boat.velocity_mps = boat.flow_mps.copy()
        for _ in range(240):
            _chase(world, boat)
            world.step(1 / 60)
        assert np.hypot(*(boat.velocity_mps - boat.flow_mps)) < 0.5   # it drifts
        parts = world.particles
        water = parts.status == FlowStatus.INSIDE
        near = _hull_distance(parts.world_m[water, :2], boat) <= 1.5 * boat.beam_m
        shore = world.field.shore_distance(parts.world_m[water, :2])
        assert near.sum() >= 3
        assert parts.foam[water][near & (shore > 8.0)].mean() < 0.15
    finally:
        world.close()
