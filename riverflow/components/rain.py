"""Rain: the settings of :meth:`RiverWorld.set_rain`, the drop pool and the ripple ring — plain data.

A resource of each world (one rain per world). The "rain" system
(:mod:`riverflow.systems.rain`) runs :func:`riverflow.kernels.rain.step_rain` on it each frame;
the draw system draws the live drops as streaks and the recent water hits as ripple rings.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from riverflow.kernels.rain import RainDrops, empty_drops

RIPPLE_RING = 64
"""Water hits remembered for ripples (the water shader loops over them: keep it small)."""


@dataclass(eq=False)
class Rain:
    """Rain settings and state.

    ``drops_per_s``: new drops a second in the view volume (0: no new drops); ``variance``:
    relative spread of the count per frame (count = mean · (1 + rand[−1, 1] · variance));
    ``wind_mps`` (vx, vy) [m/s]: the drops' horizontal velocity; ``fall_mps``: downward speed
    of a new drop; ``gravity_mps2``: its constant downward acceleration (no terminal
    velocity: the seed's model); ``box_half_m``: drops live in the cube of this half-side
    around the camera; ``streak_s``: a streak is the path of the last ``streak_s`` seconds;
    ``ripple_life_s``: how long a ripple ring lasts.
    """

    drops_per_s: float = 0.0
    variance: float = 0.1
    wind_mps: tuple[float, float] = (0.0, 0.0)
    fall_mps: float = 6.0
    gravity_mps2: float = 9.81
    box_half_m: float = 40.0
    streak_s: float = 0.05
    ripple_life_s: float = 1.2
    capacity: int = 16384
    seed: int = 0
    carry: float = 0.0
    """Fraction of a drop carried over to the next frame."""
    drops: RainDrops = field(default=None)  # type: ignore[assignment]
    rng: np.random.Generator = field(default=None)  # type: ignore[assignment]

    def __post_init__(self) -> None:
        if self.drops is None:
            self.drops = empty_drops(self.capacity, RIPPLE_RING)
        if self.rng is None:
            # not the world's generator: rain on or off never changes the particles' draws
            self.rng = np.random.default_rng([int(self.seed), 2002])

    @property
    def count(self) -> int:
        """Live drops."""
        return int(self.drops.counts[0])

    def add_hit(self, x_m: float, y_m: float, z_m: float, t_s: float) -> None:
        """Start a ripple ring at (x, y) on water of level ``z_m`` at time ``t_s`` (what a drop
        landing on water does; also for games: a stone thrown in)."""
        hits, counts = self.drops.hits, self.drops.counts
        hits[counts[3] % len(hits)] = (x_m, y_m, z_m, t_s)
        counts[3] += 1

    def clear(self) -> None:
        """Remove every drop and ripple."""
        self.drops.counts[:] = 0
        self.drops.hits[:] = 0.0
        self.drops.hits[:, 3] = -np.inf
        self.carry = 0.0
