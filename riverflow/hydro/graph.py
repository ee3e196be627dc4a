"""HydroGraph: a river network as Proland stores it (nodes, curves, areas), in plain data.

Re-does Proland's ``Graph``/``HydroGraph``/``HydroCurve`` data model (reference §1.1-1.2):

* a **node** is a 2-D point [m];
* a **curve** runs from a start node to an end node through intermediate vertices, some of
  which are Bézier control points; it has a width [m], a :class:`CurveType`, a stream-function
  value ``potential`` ψ [m²/s] (banks only; ``NO_POTENTIAL`` otherwise) and ``river``, the index
  of the axis a bank belongs to (``NO_CURVE`` if none);
* an **area** is a closed loop of ``(curve, orientation)`` pairs (orientation 0: start→end,
  1: end→start), optionally with a nested subgraph.

Identifiers are indices in the lists, as in the file formats. Curve/area adjacency (Proland's
``area1``/``area2``) is derived from the areas, never stored twice.
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from enum import IntEnum

import numpy as np

NO_POTENTIAL = -1.0
"""Proland's "no potential" marker (HydroCurve default)."""

NO_CURVE = -1
"""Marker for "no curve" in ``Curve.river`` and ``Curve.parent``."""

LAKE_INFO = 2
"""``Area.info`` of a lake (a water body with a flat surface) whose level follows the terrain
(Proland's ``WaterElevationCurveData::LAKE`` is 2 too)."""
LAKE_LEVEL_INFO = 3
"""``Area.info`` of a lake at a given level, ``Area.level_m`` (saved as the area's extra
value in graph files)."""


class GraphError(ValueError):
    """A hydro-graph file or network that cannot be used; the message says where and what."""


class CurveType(IntEnum):
    """Proland ``HydroCurve::HYDRO_CURVE_TYPE``."""

    AXIS = 0
    """River axis (may be drawn)."""
    CLOSING_SEGMENT = 1
    """Not drawn: closes bank loops at river ends; also used for axes (Proland's advice)."""
    BANK = 2
    """River bank, island shore or obstacle; carries a potential."""


@dataclass(eq=False)
class Curve:
    """One curve of a hydro graph.

    ``points`` are the intermediate vertices only (the end vertices are the nodes), shape
    (K, 2) float64 [m]; ``is_control`` (K,) bool marks Bézier control vertices.
    """

    start: int
    end: int
    points: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    is_control: np.ndarray = field(default_factory=lambda: np.zeros(0, bool))
    width_m: float = 0.0
    type: CurveType = CurveType.BANK
    potential: float = NO_POTENTIAL
    river: int = NO_CURVE
    parent: int = NO_CURVE

    def __post_init__(self) -> None:
        self.points = np.asarray(self.points, dtype=np.float64).reshape(-1, 2)
        self.is_control = np.asarray(self.is_control, dtype=bool).reshape(-1)
        if self.is_control.shape[0] != self.points.shape[0]:
            raise ValueError(
                f"curve has {self.points.shape[0]} points but {self.is_control.shape[0]} control flags"
            )
        self.type = CurveType(int(self.type))
        self.width_m = float(self.width_m)
        self.potential = float(self.potential)

    @property
    def is_bank(self) -> bool:
        return self.type == CurveType.BANK

    @property
    def is_axis(self) -> bool:
        """A non-bank curve with a width: it marks where a river is (reference §1.2 rule 1)."""
        return self.type != CurveType.BANK and self.width_m > 0.0

    @property
    def has_potential(self) -> bool:
        return self.potential != NO_POTENTIAL and np.isfinite(self.potential)

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Curve):
            return NotImplemented
        return (
            self.start == other.start
            and self.end == other.end
            and np.array_equal(self.points, other.points)
            and np.array_equal(self.is_control, other.is_control)
            and self.width_m == other.width_m
            and self.type == other.type
            and self.potential == other.potential
            and self.river == other.river
            and self.parent == other.parent
        )

    def __repr__(self) -> str:
        return (
            f"Curve({self.type.name}, {self.start}->{self.end}, {len(self.points)} pts, "
            f"width={self.width_m:g}, psi={self.potential:g}, river={self.river})"
        )


@dataclass(eq=False)
class Area:
    """A closed loop of curves: ``curves[i] = (curve index, orientation)``, orientation 0 =
    start→end, 1 = end→start. ``info`` is Proland's user integer; ``subgraph`` an optional
    nested graph. A **lake** is an area with ``info`` LAKE_INFO (level from the terrain) or
    LAKE_LEVEL_INFO (level ``level_m`` [m]); it shares the closing segments across its mouths
    with the river areas that run into and out of it."""

    curves: list[tuple[int, int]]
    info: int = 0
    parent: int = NO_CURVE
    subgraph: HydroGraph | None = None
    level_m: float | None = None

    def __post_init__(self) -> None:
        self.curves = [(int(c), int(o)) for c, o in self.curves]
        if self.level_m is not None:
            self.level_m = float(self.level_m)

    @property
    def is_lake(self) -> bool:
        return self.info in (LAKE_INFO, LAKE_LEVEL_INFO)

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Area):
            return NotImplemented
        return (
            self.curves == other.curves
            and self.info == other.info
            and self.parent == other.parent
            and self.subgraph == other.subgraph
            and self.level_m == other.level_m
        )

    def __repr__(self) -> str:
        sub = ", subgraph" if self.subgraph is not None else ""
        level = f", level={self.level_m:g} m" if self.level_m is not None else ""
        return f"Area({len(self.curves)} curves, info={self.info}{level}{sub})"


@dataclass(eq=False)
class HydroGraph:
    """A river network. ``nodes`` is (N, 2) float64 [m]."""

    nodes: np.ndarray
    curves: list[Curve] = field(default_factory=list)
    areas: list[Area] = field(default_factory=list)
    source: str | None = None
    """Where it came from (file path or builder); not part of equality."""
    crs: str | None = None
    """The coordinate reference system of the coordinates (WKT or ``EPSG:n``) when known, e.g.
    from GIS data (:func:`riverflow.read_rivers`); not part of equality, not saved in graph
    files."""
    water_levels: Callable[[np.ndarray], np.ndarray] | None = None
    """Optional water level [m] at points (N, 2) [m] near the rivers, given by the data (GIS
    bed elevations); :func:`riverflow.landscape` then follows it instead of the terrain. Not
    part of equality, not saved in graph files."""
    falls: list = field(default_factory=list)
    """The falls, weirs and dams on its rivers (:class:`riverflow.hydro.falls.Fall`), placed
    with the builder's ``add_fall``, found from its water levels or read from GIS. Not part of
    equality, not saved in graph files."""
    rapids: list = field(default_factory=list)
    """Its steep reaches (:class:`riverflow.hydro.falls.Rapid`), given to the builder
    (``add_rapids``) or found in its water levels. Not part of equality, not saved."""

    def __post_init__(self) -> None:
        self.nodes = np.asarray(self.nodes, dtype=np.float64).reshape(-1, 2)

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, HydroGraph):
            return NotImplemented
        return (
            np.array_equal(self.nodes, other.nodes)
            and self.curves == other.curves
            and self.areas == other.areas
        )

    def __repr__(self) -> str:
        return (
            f"HydroGraph({len(self.nodes)} nodes, {len(self.curves)} curves, "
            f"{len(self.areas)} areas, source={self.source!r})"
        )

    # -- geometry ---------------------------------------------------------------------------

    def vertices(self, curve: int) -> np.ndarray:
        """All vertices of a curve including its end nodes, (K + 2, 2) float64 [m]."""
        c = self.curves[curve]
        return np.vstack([self.nodes[c.start], c.points, self.nodes[c.end]])

    def control_flags(self, curve: int) -> np.ndarray:
        """``is_control`` for :meth:`vertices` (end nodes are never control points)."""
        c = self.curves[curve]
        return np.concatenate([[False], c.is_control, [False]])

    def polyline(self, curve: int, tolerance_m: float = 0.25) -> np.ndarray:
        """The curve with Bézier patches flattened to within ``tolerance_m``, (M, 2) float64."""
        from riverflow.hydro.bezier import flatten_curve

        return flatten_curve(self.vertices(curve), self.control_flags(curve), tolerance_m)

    def bounds(self) -> tuple[float, float, float, float]:
        """(xmin, ymin, xmax, ymax) of all nodes and vertices [m]."""
        pts = [self.nodes] + [c.points for c in self.curves]
        allp = np.vstack([p for p in pts if len(p)])
        return (float(allp[:, 0].min()), float(allp[:, 1].min()),
                float(allp[:, 0].max()), float(allp[:, 1].max()))

    # -- topology ---------------------------------------------------------------------------

    def incident_curves(self) -> list[list[int]]:
        """For each node, the curves that start or end there (Proland rebuilds this on load)."""
        inc: list[list[int]] = [[] for _ in range(len(self.nodes))]
        for i, c in enumerate(self.curves):
            inc[c.start].append(i)
            if c.end != c.start:
                inc[c.end].append(i)
        return inc

    def curve_areas(self, curve: int) -> tuple[int, int]:
        """The (up to two) areas a curve borders, -1 where none (Proland area1/area2)."""
        found = [a for a, area in enumerate(self.areas) if any(c == curve for c, _ in area.curves)]
        found += [-1, -1]
        return found[0], found[1]

    def axes(self) -> list[int]:
        return [i for i, c in enumerate(self.curves) if c.is_axis]

    def banks(self) -> list[int]:
        return [i for i, c in enumerate(self.curves) if c.is_bank]

    def lakes(self) -> list[int]:
        """The indices of the areas that are lakes (:attr:`Area.is_lake`)."""
        return [i for i, a in enumerate(self.areas) if a.is_lake]
