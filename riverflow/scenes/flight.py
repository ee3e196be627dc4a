"""A scripted camera flight over a scene: a chase view sliding down its main river.

Used by ``riverflow profile``, the benchmarks and the tests, so all of them time the same
thing. The main river is the scene's "main" branches (a landscape made from a graph marks the
longest path down its network so), or the longest axis of a graph.
"""
from __future__ import annotations

import numpy as np


def main_centerline(scene) -> np.ndarray:
    """(K, 2) [m] the river the flight follows, upstream first."""
    main = [b.centerline_m for b in getattr(scene, "branches", []) if b.kind == "main"]
    if main:
        return np.vstack(main)
    graph = scene.graph
    axes = graph.axes()
    lines = [graph.polyline(a) for a in axes]
    return max(lines, key=lambda p: float(np.linalg.norm(np.diff(p, axis=0), axis=1).sum()))


def main_width_m(scene) -> float:
    """The typical width [m] of the river the flight follows (the median of its widths)."""
    widths = [np.asarray(b.widths_m, float).ravel() for b in getattr(scene, "branches", [])
              if b.kind == "main"]
    if not widths:
        graph = scene.graph
        widths = [np.array([graph.curves[a].width_m for a in graph.axes()], float)]
    w = np.concatenate(widths) if widths else np.zeros(0)
    w = w[np.isfinite(w) & (w > 0)]
    return float(np.median(w)) if len(w) else 20.0


def default_view(scene) -> tuple[np.ndarray, np.ndarray]:
    """(eye, target) [m] a new world looks from: the scene's ``default_view`` (a pair or a
    callable giving one) when it has one, else the flight's first view scaled to its main
    river: 0.3 of its width above the water and 0.6 behind a point 300 m down it, so the
    river fills most of the frame whether it is a 2 m creek or a 200 m river."""
    view = getattr(scene, "default_view", None)
    if view is not None:
        eye, target = view() if callable(view) else view
        return np.asarray(eye, float), np.asarray(target, float)
    width = main_width_m(scene)
    return flight_pose(scene, 0, height_m=max(0.3 * width, 3.0), behind_m=max(0.6 * width, 6.0))


def flight_pose(scene, frame: int, dt_s: float = 1 / 60, speed_mps: float = 12.0,
                height_m: float = 70.0, behind_m: float = 140.0, start_m: float = 300.0,
                line: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(eye, target) [m] at ``frame``: the target slides down the river at ``speed_mps``, the
    eye follows ``behind_m`` back along it and ``height_m`` above the water (wrapping around
    at the river's end)."""
    line = main_centerline(scene) if line is None else line
    seg = np.linalg.norm(np.diff(line, axis=0), axis=1)
    s = np.concatenate([[0.0], np.cumsum(seg)])
    length = float(s[-1])
    start = min(start_m, 0.5 * length)
    dist = start + (speed_mps * dt_s * frame) % max(length - start, 1.0)
    target_xy = np.array([np.interp(dist, s, line[:, 0]), np.interp(dist, s, line[:, 1])])
    back = max(dist - behind_m, 0.0)
    back_xy = np.array([np.interp(back, s, line[:, 0]), np.interp(back, s, line[:, 1])])
    if np.allclose(back_xy, target_xy):
        back_xy = target_xy - np.array([behind_m, 0.0])
    level = float(scene.water.level(target_xy[None])[0])
    return (np.array([back_xy[0], back_xy[1], level + height_m]),
            np.array([target_xy[0], target_xy[1], level]))


def fly(world, frames: int, start: int = 0, dt_s: float = 1 / 60, callback=None,
        load: bool = True) -> None:
    """Step ``world`` ``frames`` times along the flight; ``callback(frame, world)`` after each.
    With ``load`` the tiles of the first view are made before the first step
    (:meth:`RiverWorld.load_view`): a scripted run starts on a complete view."""
    line = main_centerline(world.scene)
    for f in range(start, start + frames):
        world.camera.look_at(*flight_pose(world.scene, f, dt_s, line=line))
        if load and f == start:
            world.load_view()
        world.step(dt_s)
        if callback is not None:
            callback(f, world)
