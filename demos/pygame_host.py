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


def open_window(size: tuple[int, int]):
    """The host's window: pygame with an OpenGL 3.3 core context and a depth buffer; returns
    the host's moderngl context on it."""
    import moderngl
    import pygame

    pygame.display.init()
    pygame.display.gl_set_attribute(pygame.GL_CONTEXT_MAJOR_VERSION, 3)
    pygame.display.gl_set_attribute(pygame.GL_CONTEXT_MINOR_VERSION, 3)
    pygame.display.gl_set_attribute(pygame.GL_CONTEXT_PROFILE_MASK,
                                    pygame.GL_CONTEXT_PROFILE_CORE)
    pygame.display.gl_set_attribute(pygame.GL_DEPTH_SIZE, 24)
    pygame.display.set_mode(size, pygame.OPENGL | pygame.DOUBLEBUF)
    pygame.display.set_caption("riverflow in pygame-ce")
    return moderngl.create_context()                 # the host's GL, in its own context


def play(game: hostgame.Game, ctx, frames: int = 0, out: str | None = None,
         on_last_frame=None) -> None:
    """The game loop: ``frames`` frames (0: until the window closes), the last one written
    to ``out``; ``on_last_frame(game)`` after it is shown."""
    import pygame

    crate = hostgame.ModernglCrate(ctx)
    clock = pygame.time.Clock()
    frame, running = 0, True
    while running:
        for event in pygame.event.get():
            if event.type == pygame.QUIT or (event.type == pygame.KEYDOWN
                                             and event.key == pygame.K_ESCAPE):
                running = False
        game.update(hostgame.STEP_S)
        view, projection = game.matrices()
        ctx.clear(0.55, 0.70, 0.90, 1.0, depth=1.0)
        crate.draw(game, view, projection)            # the host's scene first
        game.rivers.draw(view, projection)            # RIVERS: depth-tested against it
        frame += 1
        last = frames and frame >= frames
        if last and out:
            w, h = game.size
            rgba = np.frombuffer(ctx.screen.read(components=4), np.uint8)
            hostgame.save_png(rgba.reshape(h, w, 4)[::-1], out)
        pygame.display.flip()
        pygame.display.set_caption(f"riverflow in pygame-ce: score {game.score}")
        if last:
            if on_last_frame is not None:
                on_last_frame(game)
            break
        if not frames:
            clock.tick(60)


def main(argv=None) -> int:
    args = hostgame.parse(argv, __doc__.splitlines()[0])
    import pygame

    ctx = open_window(args.size)
    game = hostgame.Game(args.size, seed=args.seed)
    game.start(gl="current")                         # RIVERS: into this window
    try:
        play(game, ctx, args.frames, args.out)
    finally:
        game.rivers.close()
        pygame.display.quit()
    return 0


if __name__ == "__main__":
    sys.exit(main())
