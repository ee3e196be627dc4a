"""Test helpers around the package's scripted flight (riverflow.scenes.flight)."""
from __future__ import annotations

from riverflow.engine.config import RiverConfig
from riverflow.engine.world import RiverWorld
from riverflow.scenes.flight import fly, flight_pose, main_centerline  # noqa: F401


def make_world(scene, size=(320, 180), radius_px=5.0, seed=0, **config) -> RiverWorld:
    cfg = RiverConfig(radius_px=radius_px, tile_production="blocking", **config)
    return RiverWorld(scene, size=size, seed=seed, config=cfg)
