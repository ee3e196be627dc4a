"""Spill: the component of a spill entity (a tracer released into the rivers, issue 24).

Plain data: the spill's row in the world's spill solver (a resource,
:class:`riverflow.hydro.spills.SpillSolver`, that holds every spill's cells), its name and its
colour in the normal look. ``world.add_spill`` makes the entity, ``world.spill(entity)`` reports
on it.
"""
from __future__ import annotations

from dataclasses import dataclass

SPILL_COLOURS = ((0.55, 0.33, 0.12), (0.80, 0.10, 0.45), (0.15, 0.55, 0.20), (0.85, 0.60, 0.05),
                 (0.35, 0.20, 0.60), (0.05, 0.45, 0.55))
"""Linear RGB of the water fully discoloured by a spill, cycled per spill (mud, dye magenta,
algae green, ochre, violet, teal)."""


@dataclass(eq=False)
class Spill:
    """One spill: its row in the solver, name, release, decay and colour (linear RGB)."""

    row: int
    name: str
    mass_kg: float
    duration_s: float
    decay_per_s: float
    colour: tuple[float, float, float]
