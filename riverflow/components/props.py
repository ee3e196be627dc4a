"""Props: small solid objects drawn with the river (boats, barrels, buoys) — plain data.

A prop entity has a :class:`Prop` (which mesh, its size) and a :class:`Pose` (where it is).
Gameplay moves the pose; the draw system draws every prop of its world, lit and fogged like
the terrain. Meshes come from :mod:`riverflow.scenes.props`.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


SHAPES = ("boat", "barrel")
"""The prop meshes there are (riverflow.scenes.props)."""


@dataclass(eq=False)
class Prop:
    """``shape`` is "boat" or "barrel"; ``size_m`` (length, width, height) [m]."""

    shape: str
    size_m: tuple[float, float, float]

    def __post_init__(self) -> None:   # checked once, where a prop is made (not per frame)
        from riverflow._validate import choice, finite_positive

        choice(self.shape, "Prop.shape", SHAPES)
        try:
            size = tuple(self.size_m)
        except TypeError:
            size = ()
        if len(size) != 3:
            raise ValueError(f"Prop.size_m must be (length, width, height) [m], got "
                             f"{self.size_m!r}")
        self.size_m = tuple(finite_positive(v, f"Prop.size_m[{i}]") for i, v in enumerate(size))


@dataclass(eq=False)
class Pose:
    """Position (3,) [m] of the prop's origin (its waterline centre), heading (yaw about +z
    from +x), pitch (nose up) and roll (starboard down) [rad]."""

    position_m: np.ndarray = field(default_factory=lambda: np.zeros(3))
    yaw_rad: float = 0.0
    pitch_rad: float = 0.0
    roll_rad: float = 0.0

    def matrix(self) -> np.ndarray:
        """(4, 4) float64 model → world matrix, column-vector convention."""
        cy, sy = np.cos(self.yaw_rad), np.sin(self.yaw_rad)
        cp, sp = np.cos(self.pitch_rad), np.sin(self.pitch_rad)
        cr, sr = np.cos(self.roll_rad), np.sin(self.roll_rad)
        yaw = np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1.0]])
        pitch = np.array([[cp, 0, -sp], [0, 1.0, 0], [sp, 0, cp]])   # +x (bow) goes up
        roll = np.array([[1.0, 0, 0], [0, cr, sr], [0, -sr, cr]])    # +y (port) goes up
        m = np.eye(4)
        m[:3, :3] = yaw @ pitch @ roll
        m[:3, 3] = self.position_m
        return m
