"""FlowNetwork: a hydro graph turned into the flat arrays the flow kernels read.

Re-does the curve selection of Proland's ``HydroFlowProducer::doCreateTile`` and
``HydroFlowTile::addBanks`` (reference §2.2-2.3), once for the whole graph:

* **axes** are non-bank curves with a width; **banks** carry a potential; **caps** are the
  zero-width closing segments of the water areas, oriented so the water is on their left (they
  close the water at river ends for the inside test, and carry no ψ);
* a bank without an axis link (an island, an obstacle) is linked to the axis that covers it
  (Proland ignores such banks: reference §7 defect 4);
* axes that share a node, or whose end lies inside another axis, form one **connected river
  network** (a component); every bank of a component may shape ψ anywhere in it, within the
  component's search radius R = ``search_radius_factor`` × its widest axis. This is a superset of
  Proland's "banks of the axis and of the axes meeting it", chosen so that ψ has no seam where
  the nearest axis changes (docs/deviations.md);
* banks of one component with equal ψ form one **ψ-group** (Proland's equal-ψ merging).
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from riverflow.hydro.graph import CurveType, GraphError, HydroGraph
from riverflow.kernels.flow import KIND_AXIS, KIND_BANK, KIND_CAP, OPEN_BANK, Network


@dataclass(eq=False)
class FlowNetwork:
    """Flat arrays for the flow kernels (see :mod:`riverflow.kernels.flow` for shapes)."""

    seg_ax: np.ndarray
    seg_ay: np.ndarray
    seg_bx: np.ndarray
    seg_by: np.ndarray
    curve_kind: np.ndarray
    curve_comp: np.ndarray
    curve_group: np.ndarray
    curve_hw2: np.ndarray
    curve_seg0: np.ndarray
    curve_seg1: np.ndarray
    curve_bbox: np.ndarray
    curve_cutoff: np.ndarray
    comp_radius: np.ndarray
    comp_group0: np.ndarray
    comp_group1: np.ndarray
    group_psi: np.ndarray
    curve_source: np.ndarray
    """(C,) int32 index of the graph curve each kernel curve comes from."""
    polylines: list[np.ndarray]
    """(M, 2) float64 flattened polyline of each kernel curve, in kernel order."""

    @property
    def n_segments(self) -> int:
        return int(self.seg_ax.shape[0])

    @property
    def n_curves(self) -> int:
        return int(self.curve_kind.shape[0])

    @property
    def n_groups(self) -> int:
        return int(self.group_psi.shape[0])

    def river_boxes(self) -> np.ndarray:
        """(A, 4) float64 xmin, ymin, xmax, ymax [m] of each axis's coverage (bbox ± half width)."""
        axes = np.flatnonzero(self.curve_kind == KIND_AXIS)
        hw = np.sqrt(self.curve_hw2[axes])[:, None]
        return np.ascontiguousarray(self.curve_bbox[axes] + np.hstack([-hw, -hw, hw, hw]))

    def axis_segments(self) -> np.ndarray:
        """(S, 4) float64 [m] ax, ay, bx, by of every axis segment."""
        rows = [np.stack([self.seg_ax[a:b], self.seg_ay[a:b], self.seg_bx[a:b], self.seg_by[a:b]],
                         1) for c, (a, b) in enumerate(zip(self.curve_seg0, self.curve_seg1))
                if self.curve_kind[c] == KIND_AXIS]
        return np.concatenate(rows) if rows else np.zeros((0, 4))

    def axis_half_widths(self) -> np.ndarray:
        """(S,) float64 [m] the half width of the axis of each of :meth:`axis_segments`."""
        axes = np.flatnonzero(self.curve_kind == KIND_AXIS)
        counts = self.curve_seg1[axes] - self.curve_seg0[axes]
        return np.repeat(np.sqrt(self.curve_hw2[axes]), counts)

    def geometry_args(self) -> tuple:
        """The segment arrays, in kernel argument order."""
        return (self.seg_ax, self.seg_ay, self.seg_bx, self.seg_by)

    def segment_psi(self) -> np.ndarray:
        """(S,) float64 [m²/s]: the ψ of each bank segment's ψ-group, NaN for axes and caps."""
        out = np.full(self.n_segments, np.nan)
        for c in np.flatnonzero(self.curve_kind == KIND_BANK):
            out[self.curve_seg0[c]:self.curve_seg1[c]] = self.group_psi[self.curve_group[c]]
        return out

    @cached_property
    def arrays(self) -> Network:
        """The segment and curve arrays as the ψ kernels take them (made once)."""
        return Network(*(getattr(self, name) for name in Network._fields))


MAX_PSI = 1e9
"""Largest |ψ| [m²/s] of a bank: ψ differences are discharges per unit depth (the Amazon's is
about 1e4 m²/s), and ψ is stored in float32 lattices."""


MAX_COORD_M = 1e8
"""Largest |coordinate| [m] of a graph's curves (the Earth is 4e7 m round): beyond it a
file's numbers are a mistake, and the quadtree could not reach a river's scale."""
MAX_WIDTH_M = 1e6
"""Largest axis width [m] (the widest estuaries are about 2e5 m)."""


def build_flow_network(graph: HydroGraph, search_radius_factor: float,
                       tolerance_m: float) -> FlowNetwork:
    """Prepare ``graph`` for the flow kernels.

    Raises:
        GraphError: a bank without a potential, a link to a curve that is not an axis, a graph
            without any axis, or a non-finite coordinate.
    """
    name = graph.source or "graph"
    axes = graph.axes()
    if not axes:
        raise GraphError(f"{name}: no river axis (a non-bank curve with a width > 0)")
    axis_set = set(axes)
    for i in range(len(graph.curves)):      # (the control points: before they are flattened)
        p = graph.vertices(i)
        if not np.all(np.isfinite(p)):
            raise GraphError(f"{name}: curve {i} has a non-finite coordinate")
        far = np.abs(p).max(initial=0.0)
        if far > MAX_COORD_M:
            raise GraphError(f"{name}: curve {i} has a coordinate {far:g} m from the origin, "
                             f"beyond {MAX_COORD_M:g} m (no map is that large; a unit or "
                             "origin mistake?)")
    poly = {i: graph.polyline(i, tolerance_m) for i in range(len(graph.curves))}
    for i, p in poly.items():
        c = graph.curves[i]
        if (c.is_bank or c.is_axis) and (len(p) < 2 or not np.any(p[1:] != p[0])):
            raise GraphError(f"{name}: curve {i} ({'a bank' if c.is_bank else 'an axis'}, "
                             f"nodes {c.start}->{c.end}) has zero length: all its points lie at "
                             f"({p[0, 0]:g}, {p[0, 1]:g})")
        if c.is_axis and not c.width_m <= MAX_WIDTH_M:
            raise GraphError(f"{name}: curve {i} (an axis) has the width {c.width_m:g} m, "
                             f"beyond {MAX_WIDTH_M:g} m (no river is that wide)")
    for i, c in enumerate(graph.curves):
        if c.is_bank and not abs(c.potential) <= MAX_PSI:   # NaN too
            raise GraphError(f"{name}: curve {i} (a bank) has the potential {c.potential!r} "
                             f"m²/s, beyond ±{MAX_PSI:g} (a discharge no river has; the "
                             "float32 ψ lattices could not carry its velocities)")

    # connected river networks over the axes (union-find)
    parent = {a: a for a in axes}

    def find(a: int) -> int:
        while parent[a] != a:
            parent[a] = parent[parent[a]]
            a = parent[a]
        return a

    by_node: dict[int, list[int]] = {}
    for a in axes:
        c = graph.curves[a]
        for n in {c.start, c.end}:
            by_node.setdefault(n, []).append(a)
    for group in by_node.values():
        for a in group[1:]:
            parent[find(a)] = find(group[0])
    # a still lake (its whole shore one ψ: no river runs through it) is a network of its
    # own, even where a river ends by its shore within its axes' width (a terminal lake)
    # a basin's mouth (:mod:`riverflow.hydro._basins`) is a bank of two areas, the river's and
    # the still basin's, linked to the river's axis: the basin's side gets a copy of it drawn
    # the other way (water on its left) linked to the basin's axis, so each network sees a
    # closed shore there and the inside test finds water on both sides (equal distances, lines
    # as far: the positive one wins); both copies are open banks (OPEN_BANK: no shore for the
    # distance to the shore, the water goes on across the mouth)
    uses: dict[int, list[int]] = {}
    for k, area in enumerate(graph.areas):
        for c, _ in area.curves:
            uses.setdefault(c, []).append(k)
    shared = {c for c, areas in uses.items() if len(areas) > 1 and 0 <= c < len(graph.curves)
              and graph.curves[c].is_bank}
    still = set()
    mouth_copy: dict[int, int] = {}
    for k in graph.lakes():
        shore = [graph.curves[c] for c, _ in graph.areas[k].curves]
        if all(c.is_bank for c in shore) and len({c.potential for c in shore}) == 1:
            own = {graph.curves[c].river for c, _ in graph.areas[k].curves
                   if c not in shared and graph.curves[c].river >= 0}
            still |= own
            for c, _ in graph.areas[k].curves:
                if c in shared and own:
                    mouth_copy[c] = min(own)
    # (each axis's box: an axis whose box lies farther than its half width from both ends
    # of another is not looked at; the same unions, in the same order, as asking every pair)
    axis_box = np.array([[*poly[a].min(axis=0), *poly[a].max(axis=0)] for a in axes])
    axis_hw = np.array([0.5 * graph.curves[a].width_m for a in axes])
    for a in axes:
        ends = poly[a][[0, -1]]
        near = np.flatnonzero(_box_distance(ends, axis_box).min(axis=0) < axis_hw)
        for b in (axes[k] for k in near.tolist()):
            if find(a) != find(b) and (a in still) == (b in still):
                hw = 0.5 * graph.curves[b].width_m
                if np.min(_points_to_polyline(ends, poly[b])) < hw:
                    parent[find(a)] = find(b)
    roots = sorted({find(a) for a in axes})
    comp_of_axis = {a: roots.index(find(a)) for a in axes}

    # banks and their (possibly automatic) axis links
    bank_axis: dict[int, int] = {}
    for i, c in enumerate(graph.curves):
        if not c.is_bank:
            continue
        if not c.has_potential:
            raise GraphError(f"{name}: bank curve {i} has no potential (stream function value)")
        if c.river >= 0:
            if c.river not in axis_set:
                raise GraphError(f"{name}: bank curve {i} links to curve {c.river}, which is not "
                                 "an axis (a non-bank curve with a width)")
            bank_axis[i] = c.river
        else:
            linked = _covering_axis(poly[i], axes, poly, graph)
            if linked is not None:
                bank_axis[i] = linked

    caps = _oriented_caps(graph, poly)
    cap_axis = {}
    for i, p in caps.items():
        mid = 0.5 * (p[0] + p[-1])[None, :]
        best = _nearest_axis(mid, axes, poly, axis_box)
        if _points_to_polyline(mid, poly[best])[0] <= 0.5 * graph.curves[best].width_m + 1e-6:
            cap_axis[i] = best

    n_comp = len(roots)
    comp_width = np.zeros(n_comp)
    for a in axes:
        comp_width[comp_of_axis[a]] = max(comp_width[comp_of_axis[a]], graph.curves[a].width_m)
    comp_radius = float(search_radius_factor) * comp_width

    # ψ-groups, contiguous per component
    group_psi: list[float] = []
    comp_group0 = np.zeros(n_comp, np.int32)
    comp_group1 = np.zeros(n_comp, np.int32)
    bank_group: dict[int, int] = {}
    copy_group: dict[int, int] = {}
    for k in range(n_comp):
        comp_group0[k] = len(group_psi)
        banks = [b for b, a in bank_axis.items() if comp_of_axis[a] == k]
        copies = [b for b, a in mouth_copy.items() if comp_of_axis[a] == k]
        values = sorted({graph.curves[b].potential for b in banks + copies})
        for b in banks:
            bank_group[b] = len(group_psi) + values.index(graph.curves[b].potential)
        for b in copies:
            copy_group[b] = len(group_psi) + values.index(graph.curves[b].potential)
        group_psi.extend(values)
        comp_group1[k] = len(group_psi)

    # kernel curves: axes, then banks, then caps, then the basins' sides of their mouths
    order = ([(a, KIND_AXIS) for a in axes] + [(b, KIND_BANK) for b in sorted(bank_axis)]
             + [(c, KIND_CAP) for c in sorted(cap_axis)]
             + [(c, -1) for c in sorted(mouth_copy)])
    seg_a, seg_b, polylines = [], [], []
    kind, comp, group, hw2, seg0, seg1, bbox, cutoff, source = ([] for _ in range(9))
    n_seg = 0
    for i, k in order:
        is_copy = k == -1
        p = caps[i] if k == KIND_CAP else poly[i][::-1].copy() if is_copy else poly[i]
        keep = np.any(p[1:] != p[:-1], axis=1)
        a_pts, b_pts = p[:-1][keep], p[1:][keep]
        if len(a_pts) == 0:
            continue
        axis = (i if k == KIND_AXIS else mouth_copy[i] if is_copy else
                bank_axis[i] if k == KIND_BANK else cap_axis[i])
        k = KIND_BANK if is_copy else k
        ck = comp_of_axis[axis]
        seg_a.append(a_pts)
        seg_b.append(b_pts)
        polylines.append(p)
        kind.append(k)
        comp.append(ck)
        group.append(copy_group[i] if is_copy else bank_group[i] if k == KIND_BANK else -1)
        hw2.append((0.5 * graph.curves[i].width_m) ** 2 if k == KIND_AXIS
                   else OPEN_BANK if i in mouth_copy else 0.0)   # a mouth: no shore
        seg0.append(n_seg)
        n_seg += len(a_pts)
        seg1.append(n_seg)
        bbox.append([p[:, 0].min(), p[:, 1].min(), p[:, 0].max(), p[:, 1].max()])
        if k == KIND_AXIS:
            cutoff.append(0.5 * graph.curves[i].width_m)
        elif k == KIND_BANK:
            cutoff.append(max(comp_radius[ck], comp_width[ck]))
        else:
            cutoff.append(comp_width[ck])
        source.append(i)
    sa = np.ascontiguousarray(np.vstack(seg_a))
    sb = np.ascontiguousarray(np.vstack(seg_b))
    return FlowNetwork(
        seg_ax=sa[:, 0].copy(), seg_ay=sa[:, 1].copy(), seg_bx=sb[:, 0].copy(),
        seg_by=sb[:, 1].copy(),
        curve_kind=np.asarray(kind, np.int32), curve_comp=np.asarray(comp, np.int32),
        curve_group=np.asarray(group, np.int32), curve_hw2=np.asarray(hw2, np.float64),
        curve_seg0=np.asarray(seg0, np.int32), curve_seg1=np.asarray(seg1, np.int32),
        curve_bbox=np.asarray(bbox, np.float64).reshape(-1, 4),
        curve_cutoff=np.asarray(cutoff, np.float64),
        comp_radius=np.asarray(comp_radius, np.float64), comp_group0=comp_group0,
        comp_group1=comp_group1, group_psi=np.asarray(group_psi, np.float64),
        curve_source=np.asarray(source, np.int32), polylines=polylines,
    )


def _box_distance(pts: np.ndarray, boxes: np.ndarray) -> np.ndarray:
    """(N, B) distance [m] from each of ``pts`` (N, 2) to each box (B, 4) [x0, y0, x1, y1]:
    no more than to anything in the box."""
    dx = np.maximum(np.maximum(boxes[None, :, 0] - pts[:, None, 0], 0.0),
                    pts[:, None, 0] - boxes[None, :, 2])
    dy = np.maximum(np.maximum(boxes[None, :, 1] - pts[:, None, 1], 0.0),
                    pts[:, None, 1] - boxes[None, :, 3])
    return np.hypot(dx, dy)


def _nearest_axis(pt: np.ndarray, axes: list[int], poly: dict, boxes: np.ndarray) -> int:
    """The axis nearest the point (1, 2), the first in ``axes`` of the equally near: as
    ``min(axes, key=distance)``, asking the axes in the order of their boxes' distances
    until a box lies farther than the nearest found."""
    lower = _box_distance(pt, boxes)[0]
    best, best_d = -1, np.inf
    for k in np.argsort(lower, kind="stable").tolist():
        if lower[k] > best_d:
            break
        d = float(_points_to_polyline(pt, poly[axes[k]])[0])
        if d < best_d or (d == best_d and k < best):
            best, best_d = k, d
    return axes[best]


def _points_to_polyline(pts: np.ndarray, line: np.ndarray) -> np.ndarray:
    """Distance [m] from each of ``pts`` (N, 2) to the polyline ``line`` (M, 2)."""
    a = line[:-1][None, :, :]
    e = (line[1:] - line[:-1])[None, :, :]
    d = pts[:, None, :] - a
    l2 = np.maximum((e * e).sum(-1), 1e-300)
    t = np.clip((d * e).sum(-1) / l2, 0.0, 1.0)
    q = d - t[..., None] * e
    if line.shape[0] < 2:
        return np.linalg.norm(pts - line[0], axis=1)
    return np.sqrt((q * q).sum(-1).min(axis=1))


def _covering_axis(bank: np.ndarray, axes: list[int], poly: dict, graph: HydroGraph) -> int | None:
    """The axis nearest to an unlinked bank (island, obstacle), if it covers most of it."""
    best, best_d = None, np.inf
    boxes = np.array([[*poly[a].min(axis=0), *poly[a].max(axis=0)] for a in axes])
    # (an axis farther than its half width from most of the bank's points, by its box, is
    # not looked at: its median distance is farther still)
    hw = np.array([0.5 * graph.curves[a].width_m for a in axes])
    maybe = np.median(_box_distance(bank, boxes), axis=0) <= hw
    for a in (a for a, ok in zip(axes, maybe.tolist()) if ok):
        d = _points_to_polyline(bank, poly[a])
        hw = 0.5 * graph.curves[a].width_m
        if np.median(d) <= hw and d.mean() < best_d:
            best, best_d = a, float(d.mean())
    return best


def _oriented_caps(graph: HydroGraph, poly: dict) -> dict[int, np.ndarray]:
    """Closing segments of water areas, as polylines with the water on their left.

    An area's banks say on which side of the loop traversal the water is (a bank traversed
    start→end has the water on the left); its zero-width curves get the same side. A closing
    segment of two areas (a lake's mouth, shared with its river) has water on both sides: it
    is no cap.
    """
    caps: dict[int, np.ndarray] = {}
    uses: dict[int, int] = {}
    for area in graph.areas:
        for c in {c for c, _ in area.curves}:
            uses[c] = uses.get(c, 0) + 1
    for area in graph.areas:
        water_left = None
        for c, o in area.curves:
            if 0 <= c < len(graph.curves) and graph.curves[c].is_bank:
                water_left = o == 0
                break
        if water_left is None:
            continue
        for c, o in area.curves:
            if not 0 <= c < len(graph.curves):
                continue
            curve = graph.curves[c]
            if curve.type == CurveType.BANK or curve.width_m > 0.0 or uses[c] > 1:
                continue
            p = poly[c]
            forward = (o == 0) == water_left
            caps[c] = p if forward else p[::-1].copy()
    return caps
