"""A scripted camera flight over the default scene: a chase view that follows the main river."""
from __future__ import annotations

import numpy as np

from riverflow.engine.config import RiverConfig
from riverflow.engine.world import RiverWorld


def main_centerline(scene) -> np.ndarray:
    return np.vstack([b.centerline_m for b in scene.branches if b.kind == "main"])


def flight_pose(scene, frame: int, dt_s: float = 1 / 60, speed_mps: float = 12.0,
                height_m: float = 70.0, behind_m: float = 140.0, start_m: float = 300.0):
    """(eye, target) at ``frame``: the target slides down the main river, the eye follows."""
    line = main_centerline(scene)
    seg = np.linalg.norm(np.diff(line, axis=0), axis=1)
    s = np.concatenate([[0.0], np.cumsum(seg)])
    dist = start_m + speed_mps * dt_s * frame
    target_xy = np.array([np.interp(dist, s, line[:, 0]), np.interp(dist, s, line[:, 1])])
    back_xy = np.array([np.interp(dist - behind_m, s, line[:, 0]),
                        np.interp(dist - behind_m, s, line[:, 1])])
    level = float(scene.water.level(target_xy[None])[0])
    eye = np.array([back_xy[0], back_xy[1], level + height_m])
    target = np.array([target_xy[0], target_xy[1], level])
    return eye, target


def make_world(scene, size=(320, 180), radius_px=5.0, seed=0, **config) -> RiverWorld:
    cfg = RiverConfig(radius_px=radius_px, tile_production="blocking", **config)
    return RiverWorld(scene, size=size, seed=seed, config=cfg)


def fly(world: RiverWorld, frames: int, start: int = 0, dt_s: float = 1 / 60, callback=None):
    for f in range(start, start + frames):
        world.camera.look_at(*flight_pose(world.scene, f, dt_s))
        world.step(dt_s)
        if callback is not None:
            callback(f, world)
