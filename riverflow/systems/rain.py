"""Rain (seed 002): new drops, their fall, their end on the surface or out of view — glue only.

Runs after the tiles system (it reads this frame's camera and surface tiles); the kernel is
:func:`riverflow.kernels.rain.step_rain`. Cost follows the drops in view (a box around the
camera), never the map.
"""
from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from riverflow.components.rain import Rain
from riverflow.components.river import FrameView, TerrainView
from riverflow.engine.system import System
from riverflow.kernels.rain import SPAWN_TRIES, drops_this_frame, step_rain
from riverflow.tiles.surface import one_tile_surface

if TYPE_CHECKING:
    from riverflow.engine.world import RiverWorld

_NO_SURFACE = None


def _no_surface():
    """A one-tile stand-in surface (never read: has_surface is False) of the kernel's type."""
    global _NO_SURFACE
    if _NO_SURFACE is None:
        z = np.zeros((2, 2), np.float32)
        _NO_SURFACE = one_tile_surface(z, z, 0.0, 0.0, 1.0)
    return _NO_SURFACE


class MakeRain(System):
    """Step the :class:`Rain` resource: drops born, moved, dead (``last`` holds the frame's
    (landed, culled, born))."""

    name = "rain"

    def __init__(self) -> None:
        self.last = (0, 0, 0)

    def process(self, world: RiverWorld, dt_s: float) -> None:
        rain = world.resources.get(Rain)
        if rain is None:
            return
        counts = rain.drops.counts
        if rain.drops_per_s <= 0.0 and counts[0] == 0:
            counts[1] = counts[2] = 0
            self.last = (0, 0, 0)
            return
        view = world.resource(FrameView)
        surface = world.resource(TerrainView).surface
        u = float(rain.rng.uniform(-1.0, 1.0))
        n_new, rain.carry = drops_this_frame(float(rain.drops_per_s), float(rain.variance),
                                             float(dt_s), u, float(rain.carry))
        randoms = rain.rng.random((n_new * SPAWN_TRIES, 3))
        has_surface = surface is not None
        wind_x, wind_y = (float(v) for v in rain.wind_mps)
        self.last = step_rain(
            rain.drops, n_new, randoms, float(dt_s), float(world.clock.now_s),
            float(rain.fall_mps), float(rain.gravity_mps2), wind_x, wind_y,
            view.clip_from_world, view.world_from_clip, np.asarray(view.eye_m, np.float64),
            float(rain.box_half_m), surface if has_surface else _no_surface(), has_surface,
            float(rain.ripple_life_s))
