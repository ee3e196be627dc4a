"""Wave-tile animation: move every wave tile's clock on by the frame's seconds.

Proland switched its animated tile's frame every 5 *frames* with no blending (reference §7,
defect 9); our tiles run on seconds and the draw system cross-fades adjacent frames
(:meth:`riverflow.components.waves.WaveTile.frame_blend`). The waves keep moving while the
particles are paused: the water still looks alive.
"""
from __future__ import annotations

from typing import TYPE_CHECKING

import esper

from riverflow.components.waves import WaveTile
from riverflow.engine.system import System

if TYPE_CHECKING:
    from riverflow.engine.world import RiverWorld


class AnimateWaveTiles(System):
    name = "waves"

    def process(self, world: RiverWorld, dt_s: float) -> None:
        for _, tile in esper.get_component(WaveTile):
            tile.advance(dt_s)
