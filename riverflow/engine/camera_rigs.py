"""Camera rigs: who moves the camera. A smooth chase camera behind a boat and a free-fly
camera steered by keys and the mouse. Both only call ``Camera.look_at``."""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np


def _smooth(rate_per_s: float, dt_s: float) -> float:
    """Share of the way to go in ``dt_s`` for an exponential approach at ``rate_per_s``."""
    return 1.0 - math.exp(-rate_per_s * max(dt_s, 0.0))


@dataclass
class ChaseCamera:
    """Follows a target (position (3,), heading) from behind and above, smoothly."""

    distance_m: float = 26.0
    height_m: float = 9.0
    lead_m: float = 10.0
    rate_per_s: float = 3.0
    eye_m: np.ndarray | None = None
    look_m: np.ndarray | None = None

    def update(self, camera, position_m, heading_rad: float, dt_s: float) -> None:
        p = np.asarray(position_m, np.float64)
        forward = np.array([math.cos(heading_rad), math.sin(heading_rad), 0.0])
        eye = p - forward * self.distance_m + np.array([0.0, 0.0, self.height_m])
        look = p + forward * self.lead_m
        if self.eye_m is None or not np.isfinite(self.eye_m).all():
            self.eye_m, self.look_m = eye, look
        else:
            k = _smooth(self.rate_per_s, dt_s)
            self.eye_m = self.eye_m + k * (eye - self.eye_m)
            self.look_m = self.look_m + k * (look - self.look_m)
        camera.look_at(self.eye_m, self.look_m)


@dataclass
class FreeFlyCamera:
    """Position, yaw and pitch; keys move it along its view, the mouse turns it."""

    position_m: np.ndarray = field(default_factory=lambda: np.zeros(3))
    yaw_rad: float = 0.0
    pitch_rad: float = -0.3
    speed_mps: float = 40.0
    turn_rad_per_px: float = 0.004

    @classmethod
    def from_view(cls, eye_m, target_m) -> FreeFlyCamera:
        d = np.asarray(target_m, np.float64) - np.asarray(eye_m, np.float64)
        yaw = math.atan2(d[1], d[0])
        pitch = math.atan2(d[2], max(math.hypot(d[0], d[1]), 1e-9))
        return cls(np.array(eye_m, np.float64), yaw, pitch)

    @property
    def forward(self) -> np.ndarray:
        cp = math.cos(self.pitch_rad)
        return np.array([cp * math.cos(self.yaw_rad), cp * math.sin(self.yaw_rad),
                         math.sin(self.pitch_rad)])

    def turn(self, dx_px: float, dy_px: float) -> None:
        self.yaw_rad -= dx_px * self.turn_rad_per_px
        self.pitch_rad = float(np.clip(self.pitch_rad + dy_px * self.turn_rad_per_px,
                                       -1.5, 1.5))

    def move(self, forward: float, right: float, up: float, dt_s: float) -> None:
        """Move by (forward, right, up) ∈ [−1, 1]³ × speed × dt."""
        f = self.forward
        r = np.array([math.sin(self.yaw_rad), -math.cos(self.yaw_rad), 0.0])
        step = (forward * f + right * r + np.array([0.0, 0.0, up])) * self.speed_mps * dt_s
        if np.isfinite(step).all():
            self.position_m = self.position_m + step

    def update(self, camera) -> None:
        camera.look_at(self.position_m, self.position_m + self.forward)
