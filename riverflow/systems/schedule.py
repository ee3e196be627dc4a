"""The one ordered list of river systems (SPEC §3). Changing the order is a reviewed diff here.

1. boats (``MoveBoats``: the boats' physics, and their hulls as obstacles in the flow; a host
   game's input comes before ``world.step``)   1b. wakes (each boat's trail through the water,
   packed for the foam and the water shader)   1c. flood (issue 25: hydrographs routed down
   the network up to the clock; the flow query reads its speed factors)   2. camera
3. tile production (every kind: flow, terrain, water, meshes, particle tables)   4. advection   5. screen projection   6. life cycle
7. Poisson-disk maintenance, then placement of the new particles   7b. foam (each particle's
   foam from the flow, shores, hulls and wakes: it reads where they are now, new ones included)
7c. spills (issue 24: the tracers carried down the whole network, camera-independent)
8. wave-tile animation
8b. rain (seed 002: drops born in the view, falling, dying on the surface; it reads this
   frame's camera and surface tiles)   8c. spray (the falls' spray and mist, issue #23)
9. drawing (``gl=True`` worlds only; it is the one "draw"-phase system: ``world.step`` runs
   1–8, ``world.draw`` / ``world.render`` run 9, so a game may step at a fixed rate and draw
   when it presents a frame)

The list lives with the systems, not in the engine: every system imports the engine's
:class:`~riverflow.engine.system.System`, so an engine module that imported this list would
close a circle. :class:`~riverflow.engine.world.RiverWorld` runs the systems it is given and
asks for :func:`default_systems` only when it is given none.
"""
from __future__ import annotations

from riverflow.engine.system import System
from riverflow.systems.advection import AdvectParticles
from riverflow.systems.boat import MoveBoats
from riverflow.systems.camera import UpdateCamera
from riverflow.systems.flood import AdvanceFlood
from riverflow.systems.foam import UpdateFoam
from riverflow.systems.lifecycle import AgeParticles
from riverflow.systems.placement import PlaceNewParticles
from riverflow.systems.poisson import MaintainPoissonDisk
from riverflow.systems.rain import MakeRain
from riverflow.systems.screen import ProjectParticles
from riverflow.systems.spill import AdvanceSpills
from riverflow.systems.spray import MakeSpray
from riverflow.systems.tiles import ProduceTiles
from riverflow.systems.wake import UpdateWakes
from riverflow.systems.waves import AnimateWaveTiles

SYSTEM_ORDER = (
    "boat",
    "wake",
    "flood",
    "camera",
    "tiles",
    "advection",
    "screen",
    "lifecycle",
    "poisson",
    "placement",
    "foam",
    "spill",
    "waves",
    "rain",
    "spray",
    "draw",
)
"""Names of the default systems, in frame order."""


def default_systems(gl: bool = True) -> list[System]:
    """A fresh instance of every default system, in frame order; ``gl=False`` leaves out the
    draw system (and never imports OpenGL)."""
    systems = [MoveBoats(), UpdateWakes(), AdvanceFlood(), UpdateCamera(), ProduceTiles(),
               AdvectParticles(), ProjectParticles(), AgeParticles(), MaintainPoissonDisk(),
               PlaceNewParticles(), UpdateFoam(), AdvanceSpills(), AnimateWaveTiles(), MakeRain(),
               MakeSpray()]
    if gl:
        from riverflow.systems.draw import DrawRivers  # imports pyglet's GL: only when drawing

        systems.append(DrawRivers())
    return systems
