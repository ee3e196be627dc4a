"""Spray and mist at the falls (issue #23): the settings and the particle pool — plain data.

A resource of each world. The "spray" system (:mod:`riverflow.systems.spray`) makes the pool
on its first frame, from the scene's falls (``per_fall`` particles each), and steps it with
:func:`riverflow.kernels.spray.step_spray`; the draw system draws the particles as soft
sprites (``shaders/spray.glsl``). A scene without falls has an empty pool and costs nothing.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from riverflow.kernels.spray import SprayParticles, SpraySources


@dataclass(eq=False)
class Spray:
    """Spray settings and state.

    ``enabled``: False stops and hides it; ``per_fall``: particles a fall (a fixed pool);
    ``wind_mps`` (vx, vy) [m/s]: the air the mist drifts with (a light breeze by default).
    """

    enabled: bool = True
    per_fall: int = 96
    wind_mps: tuple[float, float] = (1.2, 0.6)
    seed: int = 0
    particles: SprayParticles | None = None
    sources: SpraySources | None = None
    rng: np.random.Generator = field(default=None)  # type: ignore[assignment]

    def __post_init__(self) -> None:
        if self.rng is None:
            # its own generator: spray on or off never changes the river particles' draws
            self.rng = np.random.default_rng([int(self.seed), 2023])

    @property
    def count(self) -> int:
        """Particles in the pool (0 before the first frame or without falls)."""
        return 0 if self.particles is None else len(self.particles.age)
