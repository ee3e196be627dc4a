"""The falling sheets' drawing (issue #23): one mesh of every fall's ribbon
(:mod:`riverflow.scenes.fall_sheets`), made on the first frame and kept (the falls do not
move), drawn after the water in the shaded modes with ``shaders/falls.glsl``: depth-tested
against the ground and the water, not writing depth, alpha-blended (what is behind the sheet
shows through it where it is thin)."""
from __future__ import annotations

from typing import TYPE_CHECKING


from riverflow.engine import gl
from riverflow.scenes.fall_sheets import (SHEET_ATTRIBUTES, SHEET_DEPTH_PULL_M, lip_levels,
                                         sheet_mesh)

if TYPE_CHECKING:
    from riverflow.engine.world import RiverWorld


class FallSheets:
    """The GPU mesh of a world's falling sheets (None until the first draw; no falls: no
    mesh and nothing drawn)."""

    def __init__(self) -> None:
        self.mesh: gl.Mesh | None = None
        self.made = False
        self.triangles = 0

    def make(self, world: RiverWorld) -> None:
        scene = world.scene
        graph = getattr(scene, "graph", None)
        falls = list(getattr(graph, "falls", ()) or ())
        water = getattr(scene, "water", None)
        self.made = True
        if not falls or water is None:
            return
        vertices, indices = sheet_mesh(falls, lip_levels(falls, water))
        self.mesh = gl.Mesh(vertices, SHEET_ATTRIBUTES, indices)
        self.triangles = len(indices) // 3

    def draw(self, world: RiverWorld, program: gl.Program, time_s: float) -> None:
        """Draw the sheets into the bound framebuffer (the view block bound)."""
        if not self.made:
            self.make(world)
        if self.mesh is None:
            return
        program.use()
        program.set(u_time_s=float(time_s), u_depth_pull_m=SHEET_DEPTH_PULL_M)
        gl.set_depth(True, write=False)
        gl.set_blend(gl.BLEND_ALPHA)
        self.mesh.draw()
        gl.set_depth(True)

    def delete(self) -> None:
        if self.mesh is not None:
            self.mesh.delete()
        self.mesh = None
        self.made = False


__all__ = ["FallSheets"]
