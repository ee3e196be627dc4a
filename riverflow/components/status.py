"""Enums shared by Python, numba kernels and (later) GLSL: one source of truth for the numbers."""
from __future__ import annotations

from enum import IntEnum


class FlowStatus(IntEnum):
    """Where a point lies relative to the water (Proland ``FlowTile::DATATYPE`` numbering).

    The flow field itself returns INSIDE, OUTSIDE and OUTSIDE_DOMAIN; the particle systems
    use LEAVING and NEAR for their status machine.
    """

    UNKNOWN = 0
    INSIDE = 1
    LEAVING = 2
    NEAR = 3
    OUTSIDE = 4
    LEAVING_DOMAIN = 5
    OUTSIDE_DOMAIN = 6
    ON_SKY = 7
