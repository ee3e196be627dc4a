"""Rivers in an arcade 3 game: arcade's window is a pyglet window; riverflow draws the river
into it (``gl="current"``) with the host's camera and depth, between the host's own crate
(drawn with ``arcade.gl``) and its HUD (arcade's text and shapes, drawn on top).

    python demos/arcade_host.py                               # a window; Esc quits
    python demos/arcade_host.py --frames 60 --out out/arcade_host.png
    python demos/arcade_host.py --headless --frames 60 --out out/arcade_host.png  # no display

Needs ``pip install arcade`` (riverflow's ``hosts`` extra).
"""
from __future__ import annotations

import os
import sys

import numpy as np

if "--headless" in sys.argv:
    os.environ["ARCADE_HEADLESS"] = "1"             # before arcade (and pyglet) are imported
    os.environ["PYGLET_HEADLESS"] = "1"

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import hostgame  # noqa: E402


def main(argv=None, *, scene=None, config=None, on_last_frame=None) -> int:
    """Play the game (``scene``, ``config``: a test's; ``on_last_frame(game, ...)`` is
    called after the last frame is shown, before anything closes)."""
    args = hostgame.parse(argv, __doc__.splitlines()[0])
    import arcade
    from arcade.gl import BufferDescription

    class RiverGame(arcade.Window):
        def __init__(self) -> None:
            super().__init__(*args.size, "riverflow in arcade", visible=not os.environ.get(
                "ARCADE_HEADLESS"))
            self.game = hostgame.Game(args.size, seed=args.seed)
            self.game.start(gl="current", scene=scene, config=config)   # RIVERS: into this window
            self.program = self.ctx.program(vertex_shader=hostgame.CRATE_VERTEX,
                                            fragment_shader=hostgame.CRATE_FRAGMENT)
            buffer = self.ctx.buffer(data=hostgame.cube(hostgame.CRATE_M).tobytes())
            self.crate = self.ctx.geometry([BufferDescription(buffer, "3f 3f",
                                                              ["in_position", "in_normal"])])
            self.score = arcade.Text("", 10, 10, arcade.color.WHITE, 14)
            self.frame = 0

        def on_update(self, dt: float) -> None:
            self.game.update(hostgame.STEP_S)

        def on_key_press(self, key: int, modifiers: int) -> None:
            if key == arcade.key.ESCAPE:
                self.close()

        def on_draw(self) -> None:
            self.clear(color=(140, 178, 230, 255))
            game = self.game
            view, projection = game.matrices()
            self.program["u_view"] = tuple(float(v) for v in view)
            self.program["u_projection"] = tuple(float(v) for v in projection)
            self.program["u_model"] = tuple(float(v) for v in game.crate_model())
            with self.ctx.enabled(self.ctx.DEPTH_TEST):
                self.crate.render(self.program)
            game.rivers.draw(view, projection)         # RIVERS: depth-tested against it
            arcade.draw_lrbt_rectangle_filled(0, 160, 0, 34, (0, 0, 0, 140))   # the HUD
            self.score.text = f"score {game.score}"
            self.score.draw()

    window = RiverGame()
    try:
        if not args.frames:
            arcade.run()
            return 0
        for _ in range(args.frames):                  # scripted: the same calls arcade makes
            window.dispatch_events()
            window.on_update(hostgame.STEP_S)
            window.on_draw()
            window.frame += 1
            if window.frame == args.frames and args.out:
                image = window.ctx.screen.read(components=4)
                rgba = np.frombuffer(image, np.uint8).reshape(args.size[1], args.size[0], 4)
                hostgame.save_png(rgba[::-1], args.out)
            window.flip()
        if on_last_frame is not None:
            on_last_frame(window.game, window)
    finally:
        window.game.rivers.close()
        window.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
