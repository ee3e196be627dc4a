"""The falls' drawing (issue #23), after the water in the shaded modes, depth-tested against
the ground and the water, not writing depth, alpha-blended (what is behind shows through):

* the falling sheets: one mesh of every fall's ribbon (:mod:`riverflow.scenes.fall_sheets`),
  made on the first frame and kept (the falls do not move), ``shaders/falls.glsl``; also in
  the reflection pass, mirrored and cut at the mirror's level, so the pool mirrors them;
* the spray and mist (:class:`~riverflow.components.spray.Spray`): its particles packed into
  a small float texture each frame (:func:`riverflow.kernels.spray.pack_spray`) and drawn as
  camera-facing soft sprites, six attribute-less vertices each, ``shaders/spray.glsl``."""
from __future__ import annotations

from typing import TYPE_CHECKING


import numpy as np

from riverflow.components.spray import Spray
from riverflow.engine import gl
from riverflow.kernels.spray import pack_spray
from riverflow.scenes.fall_sheets import (SHEET_ATTRIBUTES, SHEET_DEPTH_PULL_M, falls_boxes,
                                         in_view, lip_levels, sheet_mesh)

if TYPE_CHECKING:
    from riverflow.engine.world import RiverWorld


class FallSheets:
    """The GPU mesh of a world's falling sheets (None until the first draw; no falls: no
    mesh and nothing drawn)."""

    def __init__(self) -> None:
        self.mesh: gl.Mesh | None = None
        self.made = False
        self.triangles = 0
        self.boxes = np.zeros((0, 8, 4))
        """(F, 8, 4) a box around each fall's sheet and spray (:func:`falls_boxes`)."""

    def make(self, world: RiverWorld) -> None:
        scene = world.scene
        graph = getattr(scene, "graph", None)
        falls = list(getattr(graph, "falls", ()) or ())
        water = getattr(scene, "water", None)
        self.made = True
        if not falls or water is None:
            return
        lips = lip_levels(falls, water)
        vertices, indices = sheet_mesh(falls, lips)
        self.mesh = gl.Mesh(vertices, SHEET_ATTRIBUTES, indices)
        self.triangles = len(indices) // 3
        self.boxes = falls_boxes(falls, lips)

    def in_view(self, world: RiverWorld, clip_from_world: np.ndarray) -> bool:
        """Whether a fall (its sheet or spray) may be in the view (made on first use)."""
        if not self.made:
            self.make(world)
        return in_view(self.boxes, clip_from_world)

    def draw(self, world: RiverWorld, program: gl.Program, time_s: float,
             clip_level_m: float = 0.0) -> None:
        """Draw the sheets into the bound framebuffer (the view block bound); in the
        reflection pass (its mirrored view block bound, clip distances on) cut at
        ``clip_level_m``, the mirror's level."""
        if not self.made:
            self.make(world)
        if self.mesh is None:
            return
        program.use()
        program.set(u_time_s=float(time_s), u_depth_pull_m=SHEET_DEPTH_PULL_M,
                    u_clip_level_m=float(clip_level_m))
        gl.set_depth(True, write=False)
        gl.set_blend(gl.BLEND_ALPHA)
        self.mesh.draw()
        gl.set_depth(True)

    def delete(self) -> None:
        if self.mesh is not None:
            self.mesh.delete()
        self.mesh = None
        self.made = False


class SprayQuads:
    """The spray's GPU texture (grown to the pool's size) and its CPU copy."""

    def __init__(self) -> None:
        self.texture: gl.Texture | None = None
        self.cpu = np.zeros((0, 2, 4), np.float32)
        self.drawn = 0

    def draw(self, world: RiverWorld, program: gl.Program, empty: gl.Mesh, unit: int) -> None:
        """Draw the world's spray particles (none: nothing), the view block bound."""
        spray = world.resources.get(Spray)
        self.drawn = 0
        if spray is None or not spray.enabled or spray.count == 0:
            return
        n = spray.count
        if self.cpu.shape[0] < n:
            if self.texture is not None:
                self.texture.delete()
            self.cpu = np.zeros((n, 2, 4), np.float32)
            self.texture = gl.Texture((2, n), gl.RGBA32F)
        pack_spray(spray.particles, self.cpu)
        self.texture.upload(self.cpu, rows=n)
        self.texture.bind(unit)
        camera = world.camera
        program.use()
        program.set(u_right=tuple(float(v) for v in camera.right),
                    u_up=tuple(float(v) for v in camera.screen_up))
        gl.set_depth(True, write=False)
        gl.set_blend(gl.BLEND_ALPHA)
        empty.draw(gl.TRIANGLES, count=6 * n)
        gl.set_depth(True)
        self.drawn = n

    def delete(self) -> None:
        if self.texture is not None:
            self.texture.delete()
        self.texture = None
        self.cpu = np.zeros((0, 2, 4), np.float32)


__all__ = ["FallSheets", "SprayQuads"]
