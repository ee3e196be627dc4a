"""The little game the host demos share (``pygame_host.py``, ``glfw_host.py``,
``arcade_host.py``, ``panda3d_host.py``): a crate the river carries, a camera circling it, a
score. Everything here is the host's own: its camera matrices (built with pyrr, as a host
would with its maths library), its crate (drawn by the host, standing in the water), its
rules. The river is the few lines marked RIVERS.

Run a demo with ``--frames N --out FILE.png`` to play N frames and write the last one (what
the host's framebuffer shows) to a file; without ``--frames`` it plays until the window
closes (Esc quits).
"""
from __future__ import annotations

import argparse
import math
from dataclasses import dataclass, field

import numpy as np
from pyrr import matrix44

import riverflow as rf

STEP_S = 1.0 / 60.0
FOV_Y_DEG, NEAR_M, FAR_M = 50.0, 0.5, 20000.0
CRATE_M = 4.0                          # edge of the host's crate [m]


def parse(argv, description: str) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=description)
    parser.add_argument("--frames", type=int, default=0,
                        help="play this many frames, then quit (0: until the window closes)")
    parser.add_argument("--out", help="write the last frame to this PNG file")
    parser.add_argument("--size", default="640x360", help="window size WxH [px]")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--headless", action="store_true",
                        help="no display: an offscreen window (EGL)")
    args = parser.parse_args(argv)
    try:
        w, h = (int(v) for v in args.size.lower().split("x"))
    except ValueError:
        parser.error(f"--size must be WxH, got {args.size!r}")
    args.size = (w, h)
    if args.frames < 0:
        parser.error("--frames must be ≥ 0")
    return args


@dataclass
class Game:
    """The host's game state. ``rivers`` is made by :meth:`start`, once the host's window
    (and, for ``gl="current"``, its OpenGL context) exists."""

    size: tuple[int, int]
    seed: int = 0
    crate_xy: np.ndarray = field(default_factory=lambda: np.zeros(2))
    crate_z: float = 0.0
    crate_yaw: float = 0.0
    score: int = 0
    orbit_rad: float = 0.0
    rivers: rf.RiverWorld | None = None

    def start(self, gl="current", scene=None, config: rf.RiverConfig | None = None) -> None:
        """Make the rivers (``scene``, ``config``: the tests pass theirs)."""
        scene = rf.default_scene(seed=self.seed) if scene is None else scene
        self.rivers = rf.RiverWorld(scene, size=self.size, gl=gl, seed=self.seed,  # RIVERS
                                    config=config)
        # the crate starts on the water a little ahead of riverflow's default view
        eye, target = (np.asarray(v, float) for v in (self.rivers.camera.position,
                                                      self.rivers.camera.target))
        self.crate_xy = target[:2] + 0.3 * (eye[:2] - target[:2])
        self.crate_z = float(scene.water.level(self.crate_xy[None])[0])

    def update(self, dt_s: float) -> None:
        rivers = self.rivers
        status, velocity = rivers.field.query(self.crate_xy[None])      # RIVERS: the flow
        v = velocity[0]
        if status[0] == rf.FlowStatus.INSIDE:
            self.crate_xy = self.crate_xy + v * dt_s
            self.score += 1
        self.crate_z = float(rivers.scene.water.level(self.crate_xy[None])[0])   # RIVERS
        if np.hypot(*v) > 1e-3:
            self.crate_yaw = math.atan2(v[1], v[0])
        self.orbit_rad += 0.15 * dt_s
        rivers.camera.set_matrices(*self.matrices())       # RIVERS: the host's camera
        rivers.step(dt_s)                                  # RIVERS

    def eye_target(self) -> tuple[np.ndarray, np.ndarray]:
        target = np.array([*self.crate_xy, self.crate_z])
        a = self.orbit_rad
        eye = target + np.array([-60.0 * math.cos(a), -60.0 * math.sin(a), 28.0])
        return eye, target

    def matrices(self) -> tuple[np.ndarray, np.ndarray]:
        """The host's view and projection, column-major (pyrr's row-vector matrices ravelled
        are exactly GL's column-major order)."""
        eye, target = self.eye_target()
        view = matrix44.create_look_at(eye, target, (0.0, 0.0, 1.0), dtype=np.float32)
        projection = matrix44.create_perspective_projection(
            FOV_Y_DEG, self.size[0] / self.size[1], NEAR_M, FAR_M, dtype=np.float32)
        return view.ravel(), projection.ravel()

    def crate_model(self) -> np.ndarray:
        """The crate's model matrix (column-major): half under the water line."""
        rotation = matrix44.create_from_z_rotation(-self.crate_yaw, dtype=np.float32)
        translation = matrix44.create_from_translation(
            (*self.crate_xy, self.crate_z), dtype=np.float32)
        return (rotation @ translation).ravel()


def cube(edge_m: float) -> np.ndarray:
    """A cube centred on the origin: (36, 6) float32 rows of position and normal."""
    h = 0.5 * edge_m
    rows = []
    for axis in range(3):
        for sign in (-1.0, 1.0):
            n = np.zeros(3)
            n[axis] = sign
            u, v = np.roll(np.eye(3), 1, axis=0)[axis], np.roll(np.eye(3), 2, axis=0)[axis]
            corners = [n * h + (a * u + b * v) * h for a, b in ((-1, -1), (1, -1), (1, 1),
                                                               (-1, 1))]
            for k in (0, 1, 2, 0, 2, 3):
                rows.append([*corners[k], *n])
    return np.asarray(rows, np.float32)


CRATE_VERTEX = """
#version 330 core
uniform mat4 u_view, u_projection, u_model;
in vec3 in_position;
in vec3 in_normal;
out vec3 v_normal;
void main() {
    v_normal = mat3(u_model) * in_normal;
    gl_Position = u_projection * u_view * u_model * vec4(in_position, 1.0);
}
"""
CRATE_FRAGMENT = """
#version 330 core
in vec3 v_normal;
out vec4 frag;
void main() {
    float light = 0.45 + 0.55 * max(dot(normalize(v_normal), normalize(vec3(-0.4, -0.5, 0.8))),
                                    0.0);
    frag = vec4(vec3(0.85, 0.45, 0.12) * light, 1.0);
}
"""


class ModernglCrate:
    """The crate drawn with moderngl in the host's context (pygame and glfw demos)."""

    def __init__(self, ctx) -> None:
        self.ctx = ctx
        self.program = ctx.program(vertex_shader=CRATE_VERTEX, fragment_shader=CRATE_FRAGMENT)
        self.buffer = ctx.buffer(cube(CRATE_M).tobytes())
        self.vao = ctx.vertex_array(self.program,
                                    [(self.buffer, "3f 3f", "in_position", "in_normal")])

    def draw(self, game: Game, view, projection) -> None:
        self.program["u_view"].write(np.asarray(view, np.float32).tobytes())
        self.program["u_projection"].write(np.asarray(projection, np.float32).tobytes())
        self.program["u_model"].write(game.crate_model().tobytes())
        self.ctx.enable(self.ctx.DEPTH_TEST)
        self.vao.render()
        self.ctx.disable(self.ctx.DEPTH_TEST)


def save_png(rgba: np.ndarray, path: str) -> None:
    """Write (H, W, 4) uint8, row 0 at the top."""
    from PIL import Image

    Image.fromarray(np.ascontiguousarray(rgba)).save(path)
    print(f"wrote {path}")
