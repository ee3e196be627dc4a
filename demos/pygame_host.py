"""Rivers in a pygame-ce game: the host opens an OpenGL 3.3 core window, draws its own crate
with moderngl, and riverflow draws the river into the same window (``gl="current"``), with
the host's camera and depth: the crate stands in the water, its lower half under it.

    python demos/pygame_host.py                               # a window; Esc quits
    python demos/pygame_host.py --frames 60 --out out/pygame_host.png

Needs ``pip install pygame-ce moderngl`` (riverflow's ``hosts`` extra).
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
    import moderngl
    import pygame

    pygame.display.init()
    pygame.display.gl_set_attribute(pygame.GL_CONTEXT_MAJOR_VERSION, 3)
    pygame.display.gl_set_attribute(pygame.GL_CONTEXT_MINOR_VERSION, 3)
    pygame.display.gl_set_attribute(pygame.GL_CONTEXT_PROFILE_MASK,
                                    pygame.GL_CONTEXT_PROFILE_CORE)
    pygame.display.gl_set_attribute(pygame.GL_DEPTH_SIZE, 24)
    pygame.display.set_mode(args.size, pygame.OPENGL | pygame.DOUBLEBUF)
    pygame.display.set_caption("riverflow in pygame-ce")
    ctx = moderngl.create_context()                  # the host's GL, in its own context
    game = hostgame.Game(args.size, seed=args.seed)
    game.start(gl="current", scene=scene, config=config)   # RIVERS: into this window
    crate = hostgame.ModernglCrate(ctx)
    clock = pygame.time.Clock()
    frame, running = 0, True
    try:
        while running:
            for event in pygame.event.get():
                if event.type == pygame.QUIT or (event.type == pygame.KEYDOWN
                                                 and event.key == pygame.K_ESCAPE):
                    running = False
            game.update(hostgame.STEP_S)
            view, projection = game.matrices()
            ctx.clear(0.55, 0.70, 0.90, 1.0, depth=1.0)
            crate.draw(game, view, projection)        # the host's scene first
            game.rivers.draw(view, projection)        # RIVERS: depth-tested against it
            frame += 1
            last = args.frames and frame >= args.frames
            if last and args.out:
                rgba = np.frombuffer(ctx.screen.read(components=4), np.uint8)
                hostgame.save_png(rgba.reshape(args.size[1], args.size[0], 4)[::-1], args.out)
            pygame.display.flip()
            pygame.display.set_caption(f"riverflow in pygame-ce: score {game.score}")
            if last:
                if on_last_frame is not None:
                    on_last_frame(game, pygame.display.get_wm_info().get("window"))
                break
            if not args.frames:
                clock.tick(60)
    finally:
        game.rivers.close()
        pygame.display.quit()
    return 0


if __name__ == "__main__":
    sys.exit(main())
