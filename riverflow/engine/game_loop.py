"""A fixed-step game loop: simulation at a fixed rate, drawing whenever the window presents.

The window's clock hands :meth:`FixedStep.advance` the real seconds since the last call; it
answers how many fixed steps to run now. After a hitch (a slow frame, a dragged window) at
most ``max_substeps`` run and the rest of the backlog is dropped, so one slow frame never
snowballs into more slow frames (the "spiral of death").
"""
from __future__ import annotations

import math
from dataclasses import dataclass


@dataclass
class FixedStep:
    """Accumulator of real time → whole simulation steps of ``step_s`` seconds."""

    step_s: float = 1.0 / 60.0
    max_substeps: int = 4
    accumulator_s: float = 0.0
    dropped_s: float = 0.0
    """Real time thrown away after hitches so far [s]."""

    def __post_init__(self) -> None:
        if not (math.isfinite(self.step_s) and self.step_s > 0):
            raise ValueError(f"FixedStep.step_s must be a positive number, got {self.step_s!r}")
        if self.max_substeps < 1:
            raise ValueError(f"FixedStep.max_substeps must be ≥ 1, got {self.max_substeps!r}")

    def advance(self, elapsed_s: float) -> int:
        """Add ``elapsed_s`` real seconds (negative or non-finite count as 0); return the steps
        to run now (0 … max_substeps)."""
        if not (math.isfinite(elapsed_s) and elapsed_s > 0):
            elapsed_s = 0.0
        self.accumulator_s += elapsed_s
        steps = int(self.accumulator_s / self.step_s)
        if steps > self.max_substeps:
            self.dropped_s += self.accumulator_s - self.max_substeps * self.step_s
            self.accumulator_s = 0.0
            return self.max_substeps
        self.accumulator_s -= steps * self.step_s
        return steps

    @property
    def alpha(self) -> float:
        """How far [0, 1) the present lies between the last step and the next."""
        return self.accumulator_s / self.step_s
