"""FlowProducer: the producer of the "flow" tile kind (Proland ``HydroFlowProducer``).

The tile framework (:mod:`riverflow.tiles`) schedules it like every other kind: the view's
flow tiles are requested each frame, made in the worker thread (background) or at once
(blocking) and installed into the flow pool of the shared cache, where
:meth:`FlowField.query` and the particles read them. Dry tiles (no axis near) are never made.
"""
from __future__ import annotations

import threading
from collections.abc import Mapping
from typing import Any

import numpy as np

from riverflow.components.flow_tiles import FLOW_KIND, flow_fields
from riverflow.hydro.flow_field import FlowField, TileBuilder
from riverflow.tiles.quadtree import TileKey
from riverflow.tiles.scheduler import Producer


class FlowProducer(Producer):
    """Makes the flow tiles of a :class:`FlowField` (ψ lattice and per-cell inside data)."""

    kind = FLOW_KIND

    def __init__(self, field: FlowField) -> None:
        self.field = field
        self.fields = flow_fields(field.tiles.n_cells)
        self.max_level = field.max_level
        self._local = threading.local()

    def is_empty(self, key: TileKey) -> bool:
        return not self.field.tiles.is_wet(*key)

    def empty_mask(self, codes: np.ndarray) -> np.ndarray:
        return self.field.tiles.wet.find_many(codes) < 0

    def produce(self, key: TileKey, deps: Mapping) -> Any:
        builder = getattr(self._local, "builder", None)
        if builder is None:  # scratch arrays per thread: the kernels release the GIL
            builder = self._local.builder = TileBuilder(self.field)
        return builder.make(*key)
