"""Rivers in a glfw game: the host makes an OpenGL 3.3 core window with glfw, draws its own
crate with moderngl, and riverflow draws the river into the same window (``gl="current"``)
with the host's camera and depth.

    python demos/glfw_host.py                                 # a window; Esc quits
    python demos/glfw_host.py --frames 60 --out out/glfw_host.png

Needs ``pip install glfw moderngl`` (riverflow's ``hosts`` extra). moderngl-window's glfw
backend is the same: make the world after the window, pass its camera's matrices.
"""
from __future__ import annotations

import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import hostgame  # noqa: E402


def main(argv=None, *, scene=None, config=None, on_last_frame=None) -> int:
    """Play the game (``scene``, ``config``: a test's; ``on_last_frame(game, ...)`` is
    called after the last frame is shown, before anything closes)."""
    args = hostgame.parse(argv, __doc__.splitlines()[0])
    import glfw
    import moderngl

    if not glfw.init():
        raise SystemExit("glfw could not start (no display?)")
    try:
        glfw.window_hint(glfw.CONTEXT_VERSION_MAJOR, 3)
        glfw.window_hint(glfw.CONTEXT_VERSION_MINOR, 3)
        glfw.window_hint(glfw.OPENGL_PROFILE, glfw.OPENGL_CORE_PROFILE)
        glfw.window_hint(glfw.OPENGL_FORWARD_COMPAT, True)
        glfw.window_hint(glfw.DEPTH_BITS, 24)
        window = glfw.create_window(*args.size, "riverflow in glfw", None, None)
        if not window:
            raise SystemExit("glfw could not open an OpenGL 3.3 core window")
        glfw.make_context_current(window)
        ctx = moderngl.create_context()
        game = hostgame.Game(args.size, seed=args.seed)
        game.start(gl="current", scene=scene, config=config)   # RIVERS: into this window
        crate = hostgame.ModernglCrate(ctx)
        frame = 0
        try:
            while not glfw.window_should_close(window):
                glfw.poll_events()
                if glfw.get_key(window, glfw.KEY_ESCAPE) == glfw.PRESS:
                    break
                game.update(hostgame.STEP_S)
                view, projection = game.matrices()
                ctx.clear(0.55, 0.70, 0.90, 1.0, depth=1.0)
                crate.draw(game, view, projection)
                game.rivers.draw(view, projection)    # RIVERS
                frame += 1
                last = args.frames and frame >= args.frames
                if last and args.out:
                    rgba = np.frombuffer(ctx.screen.read(components=4), np.uint8)
                    hostgame.save_png(rgba.reshape(args.size[1], args.size[0], 4)[::-1],
                                      args.out)
                glfw.swap_buffers(window)
                glfw.set_window_title(window, f"riverflow in glfw: score {game.score}")
                if last:
                    if on_last_frame is not None:
                        on_last_frame(game, glfw.get_x11_window(window))
                    break
        finally:
            game.rivers.close()
            glfw.destroy_window(window)
    finally:
        glfw.terminate()
    return 0


if __name__ == "__main__":
    sys.exit(main())
