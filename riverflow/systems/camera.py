"""UpdateCamera: the camera as this frame's kernels need it (matrices, eye, pixel angle)."""
from __future__ import annotations

import math

from riverflow.components.river import FrameView
from riverflow.engine.system import System


class UpdateCamera(System):
    """Copy the camera resource into the :class:`FrameView` resource when it changed."""

    name = "camera"

    def process(self, world, dt_s: float) -> None:
        camera = world.camera
        view = world.resource(FrameView)
        if view.revision == camera.revision:
            return
        view.clip_from_world, view.world_from_clip = camera.matrices_for_kernels()
        view.eye_m = camera.position.astype(float).copy()
        view.width_px, view.height_px = (int(v) for v in camera.size_px)
        fov = math.radians(camera.fov_y_deg)
        view.rad_per_px = 2.0 * math.tan(0.5 * fov) / max(view.height_px, 1)
        view.revision = camera.revision
