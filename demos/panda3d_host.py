"""Rivers in a Panda3D game, which owns and hides its OpenGL context: riverflow draws in its
own offscreen context and hands each frame over as RGBA8 numpy (``world.render()``), which
Panda3D shows on a card (a screen standing by the river) while the host floats its own
crate on its own water plane with riverflow's height and velocity queries
(``rivers.scene.water.level``, ``rivers.field.query``).

    python demos/panda3d_host.py                              # a window; Esc quits
    python demos/panda3d_host.py --frames 30 --out out/panda3d_host.png
    python demos/panda3d_host.py --headless --frames 30 --out out/panda3d_host.png

Needs ``pip install panda3d`` (riverflow's ``hosts`` extra). ursina is Panda3D underneath:
the same texture hand-off (``Texture.setRamImageAs``) works there.
"""
from __future__ import annotations

import os
import sys

import numpy as np

if "--headless" in sys.argv:
    os.environ["PYGLET_HEADLESS"] = "1"    # riverflow's context: EGL, as Panda3D's below

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import hostgame  # noqa: E402


def main(argv=None, *, scene=None, config=None, on_last_frame=None) -> int:
    """Play the game (``scene``, ``config``: a test's; ``on_last_frame(game, ...)`` is
    called after the last frame is shown, before anything closes)."""
    args = hostgame.parse(argv, __doc__.splitlines()[0])
    from panda3d.core import (AmbientLight, CardMaker, DirectionalLight, Filename, Texture,
                              loadPrcFileData)

    loadPrcFileData("", f"win-size {args.size[0]} {args.size[1]}\n"
                        "window-title riverflow in Panda3D\nsync-video false\n"
                        "audio-library-name null\n")
    if args.headless:
        loadPrcFileData("", "load-display p3headlessgl\nwindow-type offscreen\n")
    from direct.showbase.ShowBase import ShowBase

    base = ShowBase()
    card_px = (320, 180)
    game = hostgame.Game(card_px, seed=args.seed)
    game.start(gl=True, scene=scene, config=config)   # RIVERS: its own context

    # the card: a screen by the river showing riverflow's frame
    texture = Texture("river")
    texture.setup2dTexture(*card_px, Texture.T_unsigned_byte, Texture.F_rgba8)
    maker = CardMaker("river-card")
    maker.setFrame(-8.0, 8.0, -4.5, 4.5)
    card = base.render.attachNewNode(maker.generate())
    card.setTexture(texture)
    card.setPos(0.0, 30.0, 6.0)
    card.setTwoSided(True)
    # the host's own water: a flat plane at riverflow's water level under the crate, and the
    # crate floating on it, carried by riverflow's flow
    plane = base.render.attachNewNode(CardMaker("water").generate())
    plane.setScale(60.0, 1.0, 40.0)
    plane.setPos(-30.0, 20.0, 0.0)
    plane.setP(-90.0)
    plane.setColor(0.18, 0.32, 0.42, 1.0)
    crate = base.loader.loadModel("models/box")
    crate.reparentTo(base.render)
    crate.setScale(2.0)
    crate.setColor(0.85, 0.45, 0.12, 1.0)
    sun = base.render.attachNewNode(DirectionalLight("sun"))
    sun.setHpr(30.0, -50.0, 0.0)
    base.render.setLight(sun)
    base.render.setLight(base.render.attachNewNode(AmbientLight("sky")))
    base.setBackgroundColor(0.55, 0.70, 0.90, 1.0)
    base.disableMouse()
    base.camera.setPos(14.0, -22.0, 9.0)
    base.camera.lookAt(0.0, 22.0, 3.0)
    start_xy = game.crate_xy.copy()
    state = {"frame": 0}

    def step(task):
        game.update(hostgame.STEP_S)
        frame = game.rivers.render()                     # RIVERS: (H, W, 4) uint8, top row
        texture.setRamImageAs(np.ascontiguousarray(frame[::-1]).tobytes(), "RGBA")
        # the crate: riverflow's position relative to where it started, on its water level
        dx, dy = (game.crate_xy - start_xy) * 0.25
        crate.setPos(-1.0 + dx, 15.0 + dy, game.crate_z - game.rivers.scene.water.level(
            start_xy[None])[0] - 1.0)
        crate.setH(np.degrees(game.crate_yaw))
        state["frame"] += 1
        return task.cont

    base.taskMgr.add(step, "rivers")
    base.accept("escape", sys.exit)
    try:
        if not args.frames:
            base.run()
        else:
            for _ in range(args.frames):
                base.taskMgr.step()
            if args.out:
                base.graphicsEngine.renderFrame()
                base.win.saveScreenshot(Filename.fromOsSpecific(os.path.abspath(args.out)))
                print(f"wrote {args.out}")
            if on_last_frame is not None:
                on_last_frame(game, base, card)
    finally:
        game.rivers.close()
        base.destroy()
    return 0


if __name__ == "__main__":
    sys.exit(main())
