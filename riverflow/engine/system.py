"""System: the base of every per-frame system (one per file under riverflow/systems).

A system is glue: it reads components and resources of its :class:`RiverWorld`, calls one or
two kernels and writes back. Systems run in the one order of
:func:`riverflow.systems.schedule.default_systems`; esper's processor priorities are not used
(reference/aesthetics.md P7).
"""
from __future__ import annotations

from typing import TYPE_CHECKING, ClassVar

if TYPE_CHECKING:
    from riverflow.engine.world import RiverWorld


class System:
    """One step of the frame. Subclasses set ``name`` and implement :meth:`process`."""

    name: ClassVar[str] = "system"
    needs_gl: ClassVar[bool] = False
    """Skipped by a world made with ``gl=False``."""
    phase: ClassVar[str] = "update"
    """"update" systems run in :meth:`RiverWorld.step`; "draw" systems in
    :meth:`RiverWorld.draw` (a game steps at its fixed rate and draws when it presents)."""

    def process(self, world: RiverWorld, dt_s: float) -> None:
        raise NotImplementedError

    def close(self) -> None:
        """Release what the system holds (threads, GPU objects)."""
