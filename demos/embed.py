"""Embedding riverflow in a host game: its own esper world, entities and pyglet window.

The host below is a tiny game of its own (a camera orbiting a landscape, a barrel floating
down the river, a score ticking). The river part is the few lines marked RIVERS: make a
``RiverWorld`` once the window exists (it draws with the window's OpenGL context), step it in
the host's fixed-step update, draw it and copy it to the window in ``on_draw``, and ask the
flow where gameplay needs it (``rivers.field.query``).

    python demos/embed.py                          # a window
    python demos/embed.py --headless --frames 120 --out out/embed.png   # no window (offscreen)
"""
from __future__ import annotations

import argparse
import math
import os
import sys
from dataclasses import dataclass, field

import numpy as np

if "--headless" in sys.argv:
    os.environ["PYGLET_HEADLESS"] = "1"          # before pyglet's GL is imported

import esper  # noqa: E402

import riverflow as rf  # noqa: E402

STEP_S = 1.0 / 60.0
HOST_WORLD = "host-game"


# -- the host game's own components and processor -------------------------------------------

@dataclass
class Floating:
    """Something the river carries: position (2,) [m], height [m], stranded flag."""

    position_m: np.ndarray
    altitude_m: float = 0.0
    stranded: bool = False
    prop: int = -1            # its river prop entity (drawn by the river world)


@dataclass
class Score:
    points: int = 0
    ticks: int = 0


@dataclass
class Orbit:
    """The host's camera: circles a point."""

    centre_m: np.ndarray
    radius_m: float = 160.0
    height_m: float = 90.0
    angle_rad: float = 0.0
    rate_rps: float = 0.05
    history: list = field(default_factory=list)


class HostLogic(esper.Processor):
    """The host's gameplay: floats ride the flow, the score ticks, the camera orbits."""

    def __init__(self, rivers: rf.RiverWorld) -> None:
        self.rivers = rivers

    def process(self, dt_s: float) -> None:
        for _, score in esper.get_component(Score):
            score.ticks += 1
        for _, orbit in esper.get_component(Orbit):
            orbit.angle_rad += orbit.rate_rps * dt_s
        items = esper.get_component(Floating)
        if not items:
            return
        xy = np.array([f.position_m for _, f in items])
        status, velocity = self.rivers.field.query(xy)                     # RIVERS: ask the flow
        levels = self.rivers.scene.water.level(xy)
        for (_, f), s, v, z in zip(items, status, velocity, levels):
            f.stranded = int(s) != int(rf.FlowStatus.INSIDE)
            if not f.stranded:
                f.position_m = f.position_m + v.astype(np.float64) * dt_s
                f.altitude_m = float(z)
            if f.prop >= 0:
                pose = self.rivers.pose(f.prop)                            # RIVERS: move the prop
                pose.position_m = np.array([*f.position_m, f.altitude_m])
                if np.hypot(*v) > 1e-3:
                    pose.yaw_rad = math.atan2(v[1], v[0])


class HostGame:
    """The host: its own esper world and entities, plus a river world it embeds."""

    def __init__(self, size: tuple[int, int], seed: int) -> None:
        scene = rf.default_scene(seed=seed)
        self.rivers = rf.RiverWorld(scene, size=size, gl=True, seed=seed)  # RIVERS: add rivers
        start = _river_point(scene, 0.3)
        previous = esper.current_world
        esper.switch_world(HOST_WORLD)
        self.score = esper.create_entity(Score())
        self.camera = esper.create_entity(Orbit(np.array([*start, 0.0])))
        barrel = self.rivers.add_prop("barrel", (1.2, 0.9, 0.9), (*start, 0.0))
        self.barrel = esper.create_entity(Floating(start.copy(), prop=barrel))
        esper.add_processor(HostLogic(self.rivers))
        esper.switch_world(previous)
        self.frames = 0
        self._aim_camera()
        self.rivers.load_view()          # RIVERS: the first view's tiles (the level's loading)

    def _aim_camera(self) -> None:
        previous = esper.current_world
        esper.switch_world(HOST_WORLD)
        orbit = esper.component_for_entity(self.camera, Orbit)
        barrel = esper.component_for_entity(self.barrel, Floating)
        esper.switch_world(previous)
        centre = np.array([*barrel.position_m, barrel.altitude_m])
        eye = centre + np.array([orbit.radius_m * math.cos(orbit.angle_rad),
                                 orbit.radius_m * math.sin(orbit.angle_rad), orbit.height_m])
        self.rivers.camera.look_at(eye, centre)

    def update(self, dt_s: float) -> None:
        previous = esper.current_world
        esper.switch_world(HOST_WORLD)
        esper.process(dt_s)
        esper.switch_world(previous)
        self._aim_camera()
        self.rivers.step(dt_s)                                             # RIVERS: step
        self.frames += 1

    def entity(self, entity: int, kind):
        """One of the host's own components (for tests and the HUD)."""
        previous = esper.current_world
        esper.switch_world(HOST_WORLD)
        try:
            return esper.component_for_entity(entity, kind)
        finally:
            esper.switch_world(previous)

    def close(self) -> None:
        self.rivers.close()
        if HOST_WORLD in esper.list_worlds() and esper.current_world != HOST_WORLD:
            esper.delete_world(HOST_WORLD)


def _river_point(scene, fraction: float) -> np.ndarray:
    from riverflow.scenes.flight import main_centerline

    line = main_centerline(scene)
    s = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(line, axis=0).T))])
    at = fraction * s[-1]
    return np.array([np.interp(at, s, line[:, 0]), np.interp(at, s, line[:, 1])])


def run(frames: int | None, seed: int = 0, headless: bool = False,
        size: tuple[int, int] = (960, 540), out: str | None = None) -> HostGame:
    """Run the host game for ``frames`` steps (None: until the window closes); headless, write
    the last frame to the PNG file ``out`` if given."""
    if headless:
        game = HostGame(size, seed)
        for _ in range(frames or 60):
            game.update(STEP_S)
        if out:
            from PIL import Image

            os.makedirs(os.path.dirname(os.path.abspath(out)), exist_ok=True)
            Image.fromarray(game.rivers.render()).save(out, format="PNG")
        return game

    import pyglet

    window = pyglet.window.Window(*size, caption="a host game with riverflow rivers",
                                  resizable=True, vsync=True)
    game = HostGame(window.get_framebuffer_size(), seed)                   # after the window
    label = pyglet.text.Label("", x=10, y=10, font_size=12)
    accumulator = [0.0]

    @window.event
    def on_draw():
        window.clear()
        game.rivers.draw()                                                 # RIVERS: draw
        game.rivers.blit_to_window(*window.get_framebuffer_size())
        barrel = game.entity(game.barrel, Floating)
        label.text = (f"barrel at ({barrel.position_m[0]:.0f}, {barrel.position_m[1]:.0f}) m"
                      f"{'  stranded' if barrel.stranded else ''}   "
                      f"score ticks {game.entity(game.score, Score).ticks}")
        label.draw()

    @window.event
    def on_resize(width, height):
        game.rivers.camera.set_viewport(*window.get_framebuffer_size())

    def tick(dt):
        accumulator[0] = min(accumulator[0] + dt, 4 * STEP_S)
        while accumulator[0] >= STEP_S:
            game.update(STEP_S)
            accumulator[0] -= STEP_S
        if frames is not None and game.frames >= frames:
            window.close()
            pyglet.app.exit()

    pyglet.clock.schedule(tick)
    pyglet.app.run(interval=0)
    return game


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--headless", action="store_true", help="no window (offscreen)")
    parser.add_argument("--frames", type=int, default=None,
                        help="steps to run (headless default: 60; windowed: until closed)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the built-in scene")
    parser.add_argument("--out", default=None, metavar="FILE.png",
                        help="headless: write the last frame to this PNG file")
    args = parser.parse_args(argv)
    if args.out is not None and (args.out.endswith(("/", os.sep)) or os.path.isdir(args.out)):
        parser.error(f"--out takes a file name (e.g. {os.path.join(args.out, 'embed.png')}), "
                     f"not the folder {args.out!r}")
    game = run(args.frames, args.seed, args.headless, out=args.out)
    barrel = game.entity(game.barrel, Floating)
    print(f"{game.frames} frames; barrel at ({barrel.position_m[0]:.1f}, "
          f"{barrel.position_m[1]:.1f}) m; score ticks {game.entity(game.score, Score).ticks}"
          + (f"; wrote {os.path.abspath(args.out)}" if args.out and args.headless else ""))
    game.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
