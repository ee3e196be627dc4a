"""Test helpers around the package's scripted flight (riverflow.scenes.flight)."""
from __future__ import annotations

import numpy as np

from riverflow.engine.config import RiverConfig
from riverflow.engine.world import RiverWorld
from riverflow.scenes.flight import flight_pose, fly, main_centerline  # noqa: F401


def make_world(scene, size=(320, 180), radius_px=5.0, seed=0, **config) -> RiverWorld:
    cfg = RiverConfig(radius_px=radius_px, tile_production="blocking", **config)
    return RiverWorld(scene, size=size, seed=seed, config=cfg)


def river_view(scene, height_m=4.0, back_m=12.0):
    """(eye, target) a few metres above the middle of the main river, looking downstream."""
    line = main_centerline(scene)
    k = len(line) // 2
    p = line[k]
    d = line[k + 3] - p
    d = d / np.linalg.norm(d)
    level = float(scene.water.level(p[None])[0])
    return ((p[0] - back_m * d[0], p[1] - back_m * d[1], level + height_m),
            (p[0] + 5 * d[0], p[1] + 5 * d[1], level))
