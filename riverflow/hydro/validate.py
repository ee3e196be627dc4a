"""Validation of a hydro graph as a river network (reference §1.2 structural rules).

Proland trusts its graphs: a bank without a potential, a bank linked to a non-axis, a bank with the
water on its right, crossing banks or a ψ jump at a junction silently give a wrong velocity field.
This module checks those rules and reports every violation with the curve id:

=====================  =====================================================================
kind                   meaning
=====================  =====================================================================
``bad-node``           a curve's start/end node index is out of range
``non-finite``         a NaN/inf node, vertex, width or potential
``bad-curve``          negative width, or more than two Bézier control vertices in a row
``no-potential``       a BANK without a potential (ψ = ``NO_POTENTIAL``)
``bad-river``          a bank's ``river`` link is not an axis (non-bank curve with width > 0)
``wrong-side``         water not on the left of a bank (rule 4): the linked (or covering) axis
                       lies on its right, or an island loop runs counter-clockwise
``unlinked-bank``      an open bank with no river link and no axis covering it (side unknown)
``crossing``           two banks intersect other than at shared nodes (or a bank crosses itself)
``potential-mismatch`` banks meeting at a node with different potentials (rule 2)
``narrow-axis``        an axis whose half-width does not cover a linked bank (rule 1); reported
                       on the axis
``area-gap``           an area loop that is not continuous (or has a bad curve reference)
=====================  =====================================================================

A loop made only of banks (one curve with start == end, or a chain of banks end-to-start) is an
island or obstacle: the water is outside, so it must run clockwise (rule 6; Proland's example
island, curve 9, has signed area -915 m²). Its axis link, if any, is not used for the side test
(an axis may run through an island). Unlinked islands are *not* an issue: the flow field links
them to the axis that covers them itself.
"""
from __future__ import annotations

from collections import Counter
from dataclasses import dataclass

import numpy as np
import shapely
from shapely.geometry import LineString, MultiPoint

from riverflow.hydro.graph import NO_CURVE, GraphError, HydroGraph

__all__ = ["ValidationIssue", "validate_graph", "check_graph"]


@dataclass(frozen=True)
class ValidationIssue:
    """One problem of a hydro graph: ``curve`` id (None when not about one curve), a short
    ``kind`` code (see the module docstring) and a human-readable ``message``."""

    curve: int | None
    kind: str
    message: str

    def __str__(self) -> str:
        where = f"curve {self.curve}" if self.curve is not None else "graph"
        return f"{where}: [{self.kind}] {self.message}"


def validate_graph(graph: HydroGraph, *, tolerance_m: float = 0.5) -> list[ValidationIssue]:
    """Check the river-network rules of ``graph`` (and of its area subgraphs).

    Args:
        graph: the network, coordinates in metres.
        tolerance_m: slack [m] for the axis-coverage test (a bank vertex may lie up to
            ``width/2 + tolerance_m`` from its axis). Bézier patches are flattened to within
            ``min(0.25, tolerance_m)`` (like :meth:`HydroGraph.polyline`).

    Returns:
        All issues found, in curve order per check; empty for a valid network.
    """
    from riverflow._validate import finite_positive

    if not isinstance(graph, HydroGraph):
        raise TypeError(f"validate_graph: graph must be a HydroGraph, got {type(graph).__name__}")
    v = _Validator(graph, finite_positive(tolerance_m, "validate_graph: tolerance_m"))
    issues = v.run()
    for a, area in enumerate(graph.areas):
        if area.subgraph is not None:
            for i in validate_graph(area.subgraph, tolerance_m=tolerance_m):
                issues.append(ValidationIssue(i.curve, i.kind, f"area {a} subgraph: {i.message}"))
    return issues


def check_graph(graph: HydroGraph, *, tolerance_m: float = 0.5) -> None:
    """Raise :class:`GraphError` listing every issue of :func:`validate_graph`, if any."""
    issues = validate_graph(graph, tolerance_m=tolerance_m)
    if issues:
        name = graph.source or "hydro graph"
        lines = "\n".join(f"  - {i}" for i in issues)
        raise GraphError(f"{name}: {len(issues)} invalid river-network issue(s):\n{lines}")


class _Validator:
    def __init__(self, g: HydroGraph, tol: float) -> None:
        self.g, self.tol = g, tol
        self.issues: list[ValidationIssue] = []
        self.poly: dict[int, np.ndarray] = {}  # curve -> flattened polyline, for sound curves

    def add(self, curve: int | None, kind: str, msg: str) -> None:
        self.issues.append(ValidationIssue(curve, kind, msg))

    def run(self) -> list[ValidationIssue]:
        self._curves()
        self._banks()
        self._sides()
        self._crossings()
        self._junctions()
        self._coverage()
        self._areas()
        return self.issues

    # -- per-curve sanity ---------------------------------------------------------------------

    def _curves(self) -> None:
        g, n = self.g, len(self.g.nodes)
        bad_nodes = set(np.flatnonzero(~np.isfinite(g.nodes).all(axis=1)).tolist())
        for k in sorted(bad_nodes):
            self.add(None, "non-finite", f"node {k} has a non-finite position {g.nodes[k].tolist()}")
        for i, c in enumerate(g.curves):
            if not (0 <= c.start < n and 0 <= c.end < n):
                self.add(i, "bad-node", f"joins nodes {c.start}->{c.end}, not in [0, {n - 1}]")
                continue
            if {c.start, c.end} & bad_nodes or not np.isfinite(c.points).all():
                self.add(i, "non-finite", "has a non-finite vertex (or end node)")
                continue
            if not np.isfinite(c.width_m):
                self.add(i, "non-finite", f"width {c.width_m}")
                continue
            if c.width_m < 0:
                self.add(i, "bad-curve", f"negative width {c.width_m} m")
            try:
                self.poly[i] = g.polyline(i, min(0.25, max(self.tol, 0.01)))
            except ValueError as e:
                self.add(i, "bad-curve", str(e))

    def _is_axis(self, k: int) -> bool:
        return 0 <= k < len(self.g.curves) and self.g.curves[k].is_axis

    def _axis_of(self, bank: int) -> int | None:
        """The bank's linked axis when both have a usable geometry."""
        k = self.g.curves[bank].river
        ok = k != NO_CURVE and k != bank and self._is_axis(k) and k in self.poly
        return k if ok and bank in self.poly else None

    # -- banks: potential, river link ---------------------------------------------------------

    def _banks(self) -> None:
        for i in self.g.banks():
            c = self.g.curves[i]
            if not np.isfinite(c.potential):
                self.add(i, "non-finite", f"potential {c.potential}")
            elif not c.has_potential:
                self.add(i, "no-potential", f"BANK without a potential (psi = {c.potential:g})")
            if c.river != NO_CURVE and (c.river == i or not self._is_axis(c.river)):
                what = "out of range" if not 0 <= c.river < len(self.g.curves) else \
                    f"{self.g.curves[c.river]!r}, not an axis (a non-bank curve with width > 0)"
                self.add(i, "bad-river", f"river link {c.river} is {what}")

    # -- water on the left --------------------------------------------------------------------

    def _sides(self) -> None:
        g = self.g
        banks = [i for i in g.banks() if i in self.poly]
        in_loop: set[int] = set()
        # a lake's shore faces its axes every way (bays, spits): its axes only tie it to the
        # lake's network, its flow is the lake's own, and its area's orientation says where
        # its water is
        lake_shore = {c for a in g.lakes() for c, _ in g.areas[a].curves}
        for loop in _loops(g, banks):  # bank-only loops are islands: water outside
            in_loop.update(loop)
            if all(i in lake_shore for i in loop):
                continue            # a lake's whole shore (still water, no river): water inside
            pts = np.vstack([self.poly[i][:-1] for i in loop])
            if _signed_area(pts) > 0:
                for i in loop:
                    self.add(i, "wrong-side", f"island loop {loop} runs counter-clockwise: "
                             "the water (outside) is on its right; reverse it")
        for i in banks:
            river = g.curves[i].river
            if i in in_loop or i in lake_shore or (river != NO_CURVE
                                                   and self._axis_of(i) is None):
                continue
            if river == NO_CURVE:
                river = self._covering_axis(i)
                if river is None:
                    self.add(i, "unlinked-bank", "open bank with no river link and no axis "
                             "covering it: its water side cannot be checked")
                    continue
            left = _left_fraction(self.poly[i], self.poly[river])
            if left < 0.5:
                self.add(i, "wrong-side", f"axis {river} lies on the right of this bank for "
                         f"{100 * (1 - left):.0f}% of its length: the water must be on the "
                         "left; reverse the bank")

    def _covering_axis(self, bank: int) -> int | None:
        best, best_d = None, np.inf
        for k in self.g.axes():
            if k not in self.poly:
                continue
            d = _distances(self.poly[bank], self.poly[k])[0]
            if d.max() <= self.g.curves[k].width_m / 2 + self.tol and d.mean() < best_d:
                best, best_d = k, d.mean()
        return best

    # -- crossings ----------------------------------------------------------------------------

    def _crossings(self) -> None:
        g = self.g
        ids = [i for i in g.banks() if i in self.poly]
        lines = [LineString(self.poly[i]) for i in ids]
        for i, ln in zip(ids, lines):
            if not ln.is_simple:
                self.add(i, "crossing", "bank crosses itself")
        if len(lines) < 2:
            return
        eps = 1e-6 * max(1.0, float(np.abs(g.nodes).max(initial=1.0)))
        left, right = shapely.STRtree(lines).query(lines, predicate="intersects")
        for a, b in zip(left.tolist(), right.tolist()):
            if a >= b:
                continue
            ca, cb = g.curves[ids[a]], g.curves[ids[b]]
            shared = {ca.start, ca.end} & {cb.start, cb.end}
            inter = lines[a].intersection(lines[b])
            if shared:
                inter = inter.difference(MultiPoint(g.nodes[sorted(shared)]).buffer(eps))
            if not inter.is_empty:
                x, y = np.asarray(inter.representative_point().coords[0])
                for me, other in ((ids[a], ids[b]), (ids[b], ids[a])):
                    self.add(me, "crossing", f"crosses bank {other} near ({x:.2f}, {y:.2f})")

    # -- junctions ----------------------------------------------------------------------------

    def _junctions(self) -> None:
        g = self.g
        incident: dict[int, list[int]] = {}
        bad = {x.curve for x in self.issues if x.kind == "bad-node"}
        for i in g.banks():
            c = g.curves[i]
            if c.has_potential and i not in bad:
                for node in {c.start, c.end}:
                    incident.setdefault(node, []).append(i)
        for node, banks in sorted(incident.items()):
            pots = Counter(g.curves[i].potential for i in banks)
            if len(pots) < 2:
                continue
            (mode, n1), (_, n2) = pots.most_common(2)
            for i in banks:
                if n1 == n2 or g.curves[i].potential != mode:
                    others = {j: g.curves[j].potential for j in banks if j != i}
                    self.add(i, "potential-mismatch", f"psi {g.curves[i].potential:g} at node "
                             f"{node}, where banks {others} meet (no psi jump allowed)")

    # -- axis width covers its banks ----------------------------------------------------------

    def _coverage(self) -> None:
        g = self.g
        for i in g.banks():
            k = self._axis_of(i)
            if k is None:
                continue
            d, _ = _distances(self.poly[i], self.poly[k])
            half = g.curves[k].width_m / 2
            j = int(np.argmax(d))
            if d[j] > half + self.tol:
                x, y = self.poly[i][j]
                self.add(k, "narrow-axis", f"axis width {2 * half:g} m does not cover bank {i}: "
                         f"its point ({x:.2f}, {y:.2f}) is {d[j]:.2f} m from the axis "
                         f"(> {half:g} + {self.tol:g}); width needed >= {2 * d[j]:.2f} m")

    # -- areas are closed loops ---------------------------------------------------------------

    def _areas(self) -> None:
        g, m = self.g, len(self.g.curves)
        for a, area in enumerate(g.areas):
            loop = area.curves
            if not loop or any(not (0 <= c < m and o in (0, 1)) for c, o in loop):
                self.add(None, "area-gap", f"area {a} is empty or has a bad (curve, orientation) "
                         f"in {loop}")
                continue
            ends = [(g.curves[c].start, g.curves[c].end)[:: 1 - 2 * o] for c, o in loop]
            for k, (c, _) in enumerate(loop):
                nxt = (k + 1) % len(loop)
                if ends[k][1] != ends[nxt][0]:
                    self.add(c, "area-gap", f"area {a} is not continuous: after this curve the "
                             f"loop is at node {ends[k][1]} but curve {loop[nxt][0]} starts at "
                             f"node {ends[nxt][0]}")


# -- geometry helpers -------------------------------------------------------------------------

def _loops(g: HydroGraph, curves: list[int]) -> list[list[int]]:
    """Closed chains of ``curves`` following their stored direction (end node = next start)."""
    by_start: dict[int, list[int]] = {}
    for i in curves:
        by_start.setdefault(g.curves[i].start, []).append(i)
    loops, used = [], set()
    for i in curves:
        if i in used:
            continue
        chain, node = [i], g.curves[i].end
        while node != g.curves[i].start:
            nxt = [j for j in by_start.get(node, []) if j not in chain and j not in used]
            if len(nxt) != 1:
                break
            chain.append(nxt[0])
            node = g.curves[nxt[0]].end
        if node == g.curves[i].start:
            loops.append(chain)
            used.update(chain)
    return loops


def _signed_area(ring: np.ndarray) -> float:
    """Shoelace area of a closed ring (K, 2) [m²]: > 0 counter-clockwise."""
    x, y = ring[:, 0], ring[:, 1]
    return 0.5 * float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))


def _distances(points: np.ndarray, poly: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Distance from each of ``points`` (M, 2) to polyline ``poly`` (K, 2), and the nearest
    points on it: ((M,), (M, 2)) [m]."""
    line = LineString(poly)
    pts = shapely.points(points)
    near = shapely.line_interpolate_point(line, shapely.line_locate_point(line, pts))
    return shapely.distance(pts, line), shapely.get_coordinates(near)


def _left_fraction(bank: np.ndarray, axis: np.ndarray) -> float:
    """Length fraction of ``bank`` whose nearest axis point lies on its left (0..1)."""
    seg = bank[1:] - bank[:-1]
    length = np.hypot(seg[:, 0], seg[:, 1])
    mid = 0.5 * (bank[1:] + bank[:-1])
    _, q = _distances(mid, axis)
    r = q - mid
    cross = seg[:, 0] * r[:, 1] - seg[:, 1] * r[:, 0]
    total = length.sum()
    return float(length[cross > 0].sum() / total) if total > 0 else 1.0
