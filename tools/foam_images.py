"""Draw the foam and wake pictures of docs/images (640x360, advected water unless named).

Run: ``python tools/foam_images.py [--out docs/images]``. The demo's boat at 65 % throttle
(about 6 m/s through the water) down the built-in river, a turn half way:

* ``foam-wake-chase.png``: a chase camera behind and above the boat: the wash's foam carried
  away behind the stern, the Kelvin wake's first crests along the cusp lines;
* ``foam-mode.png``: the same view in the "foam" display mode (the foam amount alone);
* ``kelvin-wake.png``: the wake (the sprites' own waves turned down to 0.05 so that the
  wake's stand out) from behind and to the side, higher up: the V and its breaking crests;
* ``foam-banks.png`` / ``foam-banks-mode.png``: a junction seen from 40 m up: foam along the
  banks and the island's shore, the waterline's own line, streaks off the corners.
"""
from __future__ import annotations

import argparse
import math
import os
from pathlib import Path

os.environ.setdefault("PYGLET_HEADLESS", "1")

import numpy as np  # noqa: E402

import riverflow as rf  # noqa: E402
from riverflow.components.display import DisplayMode  # noqa: E402
from riverflow.demo import BoatDemo  # noqa: E402
from riverflow.images import save_png  # noqa: E402

SIZE = (640, 360)


def _look(world, boat, back_m: float, side_m: float, up_m: float, ahead_m: float,
          frames: int = 150) -> None:
    """Follow the boat for ``frames`` from this camera (the particles a new view needs fade
    in over two seconds)."""
    for _ in range(frames):
        f = np.array([math.cos(boat.heading_rad), math.sin(boat.heading_rad)])
        s = np.array([-f[1], f[0]])
        c = np.array([*boat.position_m, boat.altitude_m])
        world.camera.look_at(c + np.array([*(-back_m * f + side_m * s), up_m]),
                             c + np.array([*(ahead_m * f), 0.0]))
        world.step(1 / 60)


def boat_pictures(out: Path) -> None:
    config = rf.RiverConfig(tile_production="blocking")
    demo = BoatDemo(size=SIZE, config=config)
    world = demo.world
    try:
        world.load_view()
        boat = demo.boat_state
        for frame in range(480):
            boat.throttle = 0.65
            boat.rudder = 0.45 if 240 < frame < 320 else 0.0
            demo._place_chase(1 / 60)
            world.step(1 / 60)
        _look(world, boat, 24.0, 0.0, 10.0, 8.0, frames=30)
        save_png(world.render(), out / "foam-wake-chase.png")
        world.display.mode = DisplayMode.FOAM
        save_png(world.render(), out / "foam-mode.png")
        world.display.mode = DisplayMode.ADVECTED
        world.display.wave_slope_factor = 0.05
        _look(world, boat, 30.0, 22.0, 14.0, -12.0)
        save_png(world.render(), out / "kelvin-wake.png")
    finally:
        demo.close()


def bank_pictures(out: Path) -> None:
    scene = rf.default_scene(seed=0)
    config = rf.RiverConfig(tile_production="blocking")
    with rf.RiverWorld(scene, size=SIZE, gl=True, seed=0, config=config) as world:
        z = float(scene.water.level(np.array([[170.0, 230.0]]))[0])
        world.camera.look_at((95.0, 150.0, z + 40.0), (175.0, 235.0, z))
        world.load_view()
        for _ in range(600):
            world.step(1 / 60)
        save_png(world.render(), out / "foam-banks.png")
        world.display.mode = DisplayMode.FOAM
        save_png(world.render(), out / "foam-banks-mode.png")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("docs/images"))
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    boat_pictures(args.out)
    bank_pictures(args.out)


if __name__ == "__main__":
    main()
