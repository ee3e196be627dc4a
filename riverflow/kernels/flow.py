"""Flow-field kernels: ψ from the banks (uncached), ψ lattices per flow tile, cached queries.

Re-does Proland's ``HydroFlowTile`` (reference §2.3) with the corrections of SPEC §4:

* ψ(p) = Σ wᵢ ψᵢ / Σ wᵢ, wᵢ = (R/dᵢ)^slip · f(clamp(1 − dᵢ/R, 0, 1)), f(t) = 6t⁵ − 15t⁴ + 10t³
  (Yu et al. 2009; Proland's product form divided through, f clamped);
* dᵢ is the distance to boundary i, where banks of equal ψ are merged into one boundary and the
  signed nearest-segment distance settles a tie at a shared vertex by the vertex's
  pseudo-normal (the sign of the segment whose line p is farther from), not Proland's
  "positive wins", which reads land beyond a convex corner of the water as water;
* the inside test takes the *nearest* axis that covers the point, not the first one found
  (a river's before still water's); where the point lies behind that network's shore, the
  next network's (a basin's still water beside its river, across the mouth they share);
* velocity = (−∂ψ/∂y, ∂ψ/∂x), the true curl of a Catmull-Rom bicubic interpolant of the ψ
  lattice: continuous (C⁰) everywhere, exactly divergence-free inside each lattice cell.

Network arrays (:class:`Network`, built by :mod:`riverflow.hydro.flow_network`), S segments,
C curves, G ψ-groups, K connected components:

    seg_ax, seg_ay, seg_bx, seg_by   (S,) float64   segment ends [m]; banks and caps have the
                                                    water on their left (a → b)
    curve_kind      (C,) int32    KIND_AXIS / KIND_BANK / KIND_CAP
    curve_comp      (C,) int32    connected river network the curve belongs to
    curve_group     (C,) int32    ψ-group of a bank (-1 otherwise)
    curve_hw2       (C,) float64  squared half-width of an axis [m²]; OPEN_BANK on a bank that
                                  is an open boundary (a basin's mouth: a bank for ψ and the
                                  inside test, no shore for the distance to it); 0 otherwise
    curve_seg0/1    (C,) int32    the curve's segments are seg0 ≤ s < seg1
    curve_bbox      (C, 4) float64 xmin, ymin, xmax, ymax [m]
    curve_cutoff    (C,) float64  farther than this [m] the curve never matters
    comp_radius     (K,) float64  search radius R of the component [m]
    comp_group0/1   (K,) int32    the component's ψ-groups are group0 ≤ g < group1
    group_psi       (G,) float64  ψ of each group [m²/s]

No kernel allocates: scratch arrays come from the caller (:class:`BoxLists`, :class:`TileScratch`).
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from riverflow.kernels._jit import (EXACT_JIT_OPTIONS, JIT_OPTIONS, WORKER_JIT_OPTIONS,
                                   is_finite)
from riverflow.kernels.tile_table import table_find, tile_code

KIND_AXIS = 0
KIND_BANK = 1
KIND_CAP = 2

CELL_OUTSIDE = 0
CELL_INSIDE = 1
CELL_BOUNDARY = 2
CELL_CROWDED = 4
"""Flag on a BOUNDARY cell whose list of CELL_SEGMENTS nearest segments overflowed (coarse
tiles: cells of tens of metres meet more bank segments than the list holds), so the exact
inside test may miss a point's nearest segment: a query reading such a cell of a tile coarser
than the level it asked for (fallback) that is not a leaf of this frame's flow cut (so it only
stands in for a late tile) answers UNKNOWN, and the particle waits for its tile
(docs/deviations.md P10). A tile the view chose answers: its cells are ≤ ``flow_tile_px``
pixels on screen. The cell's kind is
``status & CELL_KIND``."""
CELL_KIND = 3
CELL_NEAR_BANK = 8
"""Flag on a cell that a bank segment comes within a cell diagonal of: queries there apply
the bank correction (:func:`_bank_correction`); read with the cell's status byte, so cells
away from banks pay nothing for it."""
_CELL_UNSET = 128

CELL_SEGMENTS = 4
"""Boundary segments kept per boundary cell for the exact inside test of cached queries."""

LATTICE_RING = 3
"""Extra lattice points computed around a tile (extrapolation needs two, Catmull-Rom one)."""

BLOCK = 8
"""Lattice points per side of the blocks that share one pruned segment list."""

SLOT_MISSING = -1
"""Tile table entry: the tile is not cached."""
SLOT_OUTSIDE_DOMAIN = -2
SLOT_DRY = -3
"""Tile table entry: no river axis comes near this tile: every point of it is OUTSIDE."""

STATUS_INSIDE = 1
STATUS_OUTSIDE = 4
STATUS_OUTSIDE_DOMAIN = 6
STATUS_UNKNOWN = 0

_TIE = 1e-4  # Proland's relative tolerance for "same distance" at a shared vertex
_ON_LINE = 1e-12
"""A point whose cross product with a segment is under this fraction of its two terms lies on
the segment's line (rounding): it is on the water side, so a point on a basin's mouth, whose
two copies run either way, is water for both (not, by the rounding of each, dry for one)."""
MAX_NETWORK_TRIES = 3
OPEN_BANK = -1.0
"""``curve_hw2`` of a bank that is an open boundary: a basin's mouth, one bank of the river's
area and the basin's (:mod:`riverflow.hydro._basins`). It carries ψ and closes each network's
shore for the inside test like any bank, but the water goes on across it, so the distance to
the shore (:func:`potential_and_shore_at`: foam's shore closeness, the distance map) does not
count it; the distance to the flow's banks (foam's impinging water: the river runs along the
mouth as along a bank, not into the basin's corner beyond it) does."""
"""How many river networks :func:`potential_and_shore_at` tries at a point behind a shore."""


class Network(NamedTuple):
    """The network arrays of the module docstring, as the ψ kernels read them (built once
    per network: ``FlowNetwork.arrays``)."""

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


class BoxLists(NamedTuple):
    """The pruned segment lists of one box (:func:`gather_box_segments`), C curves, S segments:
    list k is curve ``curve[k]``'s segments ``seg[start[k]:start[k] + count[k]]``, at least
    ``dmin2[k]`` [m²] (squared) from every point of the box; ``tmp_d2`` is scratch."""

    curve: np.ndarray       # (C,) int32
    start: np.ndarray       # (C,) int32
    count: np.ndarray       # (C,) int32
    seg: np.ndarray         # (S,) int32
    dmin2: np.ndarray       # (C,) float64
    tmp_d2: np.ndarray      # (S,) float64


class TileScratch(NamedTuple):
    """Scratch of :func:`build_flow_tile`: ``gval`` (2·G,) float64 (:func:`potential_at`),
    ``psi_full`` (M, M) float64 and ``inside_full`` (M, M) bool, M = n + 1 + 2·LATTICE_RING,
    ``cell_d2`` (n, n, CELL_SEGMENTS) float64."""

    gval: np.ndarray
    psi_full: np.ndarray
    inside_full: np.ndarray
    cell_d2: np.ndarray


class TileOut(NamedTuple):
    """What :func:`build_flow_tile` writes of one tile (shapes there)."""

    psi: np.ndarray
    cell_status: np.ndarray
    cell_segments: np.ndarray
    shore: np.ndarray
    bank: np.ndarray


# -- geometry helpers -------------------------------------------------------------------------


@njit(**JIT_OPTIONS)
def _dist2(px, py, ax, ay, bx, by):
    """Squared distance from p to segment ab."""
    ex = bx - ax
    ey = by - ay
    l2 = ex * ex + ey * ey
    t = 0.0
    if l2 > 0.0:
        t = ((px - ax) * ex + (py - ay) * ey) / l2
        t = min(max(t, 0.0), 1.0)
    qx = ax + t * ex - px
    qy = ay + t * ey - py
    return qx * qx + qy * qy


@njit(**JIT_OPTIONS)
def _signed_dist2(px, py, ax, ay, bx, by):
    """Squared distance from p to ab, negative when p is on the right of a → b (dry side); a
    point on the line within rounding (_ON_LINE) is on the left."""
    d2 = _dist2(px, py, ax, ay, bx, by)
    t1 = (bx - ax) * (py - ay)
    t2 = (by - ay) * (px - ax)
    if t2 - t1 > _ON_LINE * (abs(t1) + abs(t2)):      # cross < 0 beyond rounding
        return -d2
    return d2


@njit(**JIT_OPTIONS)
def _lead2(px, py, ax, ay, bx, by):
    """Squared distance from p to the line through a and b (0 for a point segment)."""
    ex = bx - ax
    ey = by - ay
    l2 = ex * ex + ey * ey
    if l2 <= 0.0:
        return 0.0
    cross = ex * (py - ay) - ey * (px - ax)
    return cross * cross / l2


@njit(**JIT_OPTIONS)
def _nearer(cur, cur_seg, s, seg, px, py, seg_ax, seg_ay, seg_bx, seg_by):
    """(signed squared distance, segment) of the nearer of the current best ``cur`` (of
    segment ``cur_seg``) and ``s`` (of ``seg``), signed as :func:`_signed_dist2`. At a tie of
    distances (p nearest to a vertex the two share) of opposite signs, the segment whose
    *line* p is farther from wins: its sign is that of (p − v)·(n₁ + n₂), the vertex's
    pseudo-normal test (n the segments' unit normals towards the water), right at a convex
    corner (p beyond it on one wall's extension is dry) as at a reflex one; where the lines
    are as far (two copies of one bank drawn either way: a basin's mouth), the positive one
    wins (Proland's rule, which it keeps at every tie: wrong at convex corners)."""
    a = abs(s)
    b = abs(cur)
    if a < b * (1.0 - _TIE):
        return s, seg
    if a > b * (1.0 + _TIE) or (s > 0.0) == (cur > 0.0):
        return cur, cur_seg
    lead = _lead2(px, py, seg_ax[seg], seg_ay[seg], seg_bx[seg], seg_by[seg])
    cur_lead = _lead2(px, py, seg_ax[cur_seg], seg_ay[cur_seg], seg_bx[cur_seg],
                      seg_by[cur_seg])
    if lead > cur_lead * (1.0 + _TIE) + 1e-300:
        return s, seg
    if lead >= cur_lead * (1.0 - _TIE) and s > 0.0:
        return s, seg
    return cur, cur_seg


@njit(**JIT_OPTIONS)
def _segment_hits_box(ax, ay, bx, by, x0, y0, x1, y1):
    """Liang-Barsky: does segment ab touch the box [x0, x1] × [y0, y1]?"""
    t0 = 0.0
    t1 = 1.0
    dx = bx - ax
    dy = by - ay
    for k in range(4):
        if k == 0:
            p, q = -dx, ax - x0
        elif k == 1:
            p, q = dx, x1 - ax
        elif k == 2:
            p, q = -dy, ay - y0
        else:
            p, q = dy, y1 - ay
        if p == 0.0:
            if q < 0.0:
                return False
        else:
            r = q / p
            if p < 0.0:
                if r > t1:
                    return False
                if r > t0:
                    t0 = r
            else:
                if r < t0:
                    return False
                if r < t1:
                    t1 = r
    return True


@njit(**JIT_OPTIONS)
def _box_point_dist2(px, py, x0, y0, x1, y1):
    dx = max(x0 - px, 0.0, px - x1)
    dy = max(y0 - py, 0.0, py - y1)
    return dx * dx + dy * dy


@njit(**JIT_OPTIONS)
def _segment_box_dist2(ax, ay, bx, by, x0, y0, x1, y1):
    """Smallest squared distance between segment ab and the box."""
    if _segment_hits_box(ax, ay, bx, by, x0, y0, x1, y1):
        return 0.0
    d = min(_box_point_dist2(ax, ay, x0, y0, x1, y1), _box_point_dist2(bx, by, x0, y0, x1, y1))
    d = min(d, _dist2(x0, y0, ax, ay, bx, by))
    d = min(d, _dist2(x1, y0, ax, ay, bx, by))
    d = min(d, _dist2(x0, y1, ax, ay, bx, by))
    return min(d, _dist2(x1, y1, ax, ay, bx, by))


@njit(**JIT_OPTIONS)
def _segment_box_maxdist2(ax, ay, bx, by, x0, y0, x1, y1):
    """Largest squared distance from a box point to segment ab (attained at a corner:
    the distance to a convex set is a convex function)."""
    d = max(_dist2(x0, y0, ax, ay, bx, by), _dist2(x1, y0, ax, ay, bx, by))
    d = max(d, _dist2(x0, y1, ax, ay, bx, by))
    return max(d, _dist2(x1, y1, ax, ay, bx, by))


# -- pruned segment lists for a box -----------------------------------------------------------


@njit(**JIT_OPTIONS)
def gather_box_segments(x0, y0, x1, y1, net, blk):
    """Collect, per curve of ``net`` (:class:`Network`), the segments that can be that curve's
    nearest for some point of the box, into ``blk`` (:class:`BoxLists`).

    A segment is kept when its distance to the box is at most the smallest "farthest distance"
    of the curve's segments (so each curve's nearest segment is kept for every box point) and at
    most the curve's cutoff. Writes ``blk.curve[:n]``, ``blk.start``/``blk.count`` into
    ``blk.seg`` and ``blk.dmin2``, the curve's smallest squared distance to the box (a lower
    bound for every box point). Returns n, the number of curves kept.
    """
    return _gather_listed(x0, y0, x1, y1, net, net.curve_seg0, net.curve_seg1, net.curve_seg0,
                          False, blk)


@njit(**JIT_OPTIONS)
def _gather_listed(x0, y0, x1, y1, net, list_lo, list_hi, listed, indexed, blk):
    """:func:`gather_box_segments` over the segments of each curve c at positions
    ``list_lo[c]`` … ``list_hi[c]``: the segments themselves (``indexed`` False: the curve's
    range) or ``listed[position]`` (True: a list from :func:`segments_near_box`)."""
    seg_ax, seg_ay, seg_bx, seg_by = net.seg_ax, net.seg_ay, net.seg_bx, net.seg_by
    curve_bbox, curve_cutoff = net.curve_bbox, net.curve_cutoff
    blk_curve, blk_start, blk_count, blk_seg, blk_dmin2, tmp_d2 = blk
    nb = 0
    ns = 0
    for c in range(curve_bbox.shape[0]):
        cut = curve_cutoff[c]
        cut2 = cut * cut
        dx = max(curve_bbox[c, 0] - x1, 0.0, x0 - curve_bbox[c, 2])
        dy = max(curve_bbox[c, 1] - y1, 0.0, y0 - curve_bbox[c, 3])
        if dx * dx + dy * dy > cut2:
            continue
        upper = np.inf
        for q in range(list_lo[c], list_hi[c]):
            s = listed[q] if indexed else q
            dmin = _segment_box_dist2(seg_ax[s], seg_ay[s], seg_bx[s], seg_by[s], x0, y0, x1, y1)
            tmp_d2[s] = dmin
            if dmin <= cut2:
                dmax = _segment_box_maxdist2(seg_ax[s], seg_ay[s], seg_bx[s], seg_by[s],
                                             x0, y0, x1, y1)
                if dmax < upper:
                    upper = dmax
        # a hair above the bound: the two distance paths may round differently (fastmath)
        limit = min(upper * (1.0 + 1e-9) + 1e-12, cut2)
        start = ns
        lower = np.inf
        for q in range(list_lo[c], list_hi[c]):
            s = listed[q] if indexed else q
            if tmp_d2[s] <= limit:
                blk_seg[ns] = s
                ns += 1
                lower = min(lower, tmp_d2[s])
        if ns > start:
            blk_dmin2[nb] = lower
            blk_curve[nb] = c
            blk_start[nb] = start
            blk_count[nb] = ns - start
            nb += 1
    return nb


NEAR_BOX_SLACK = 1e-6
"""Relative slack of :func:`segments_near_box` on a curve's squared cutoff (and 1e-6 m² more):
far above the rounding of the distances, so every segment a box inside it keeps is listed."""


@njit(**JIT_OPTIONS)
def segments_near_box(x0, y0, x1, y1, net, list_lo, list_hi, listed):
    """The segments of each curve c within (a hair more than) its cutoff of the box, in order,
    in ``listed[list_lo[c]:list_hi[c]]``; returns how many. For any box inside this one,
    :func:`_gather_listed` over these lists keeps what :func:`gather_box_segments` keeps, bit
    for bit (a segment left out is beyond the cutoff of every point of the box): a flow tile
    scans a long river's bank once, not once for every block of its lattice."""
    seg_ax, seg_ay, seg_bx, seg_by = net.seg_ax, net.seg_ay, net.seg_bx, net.seg_by
    curve_seg0, curve_seg1 = net.curve_seg0, net.curve_seg1
    curve_bbox, curve_cutoff = net.curve_bbox, net.curve_cutoff
    n = 0
    for c in range(curve_bbox.shape[0]):
        list_lo[c] = n
        cut = curve_cutoff[c]
        reach2 = cut * cut * (1.0 + NEAR_BOX_SLACK) + NEAR_BOX_SLACK
        dx = max(curve_bbox[c, 0] - x1, 0.0, x0 - curve_bbox[c, 2])
        dy = max(curve_bbox[c, 1] - y1, 0.0, y0 - curve_bbox[c, 3])
        if dx * dx + dy * dy <= reach2:
            for s in range(curve_seg0[c], curve_seg1[c]):
                if _segment_box_dist2(seg_ax[s], seg_ay[s], seg_bx[s], seg_by[s],
                                      x0, y0, x1, y1) <= reach2:
                    listed[n] = s
                    n += 1
        list_hi[c] = n
    return n


# -- ψ at one point -----------------------------------------------------------------------------


@njit(**JIT_OPTIONS)
def _fade(t):
    t = min(max(t, 0.0), 1.0)
    return t * t * t * (t * (t * 6.0 - 15.0) + 10.0)


@njit(**JIT_OPTIONS)
def potential_at(px, py, nb, blk, net, slip, gval):
    """ψ at p [m²/s] from ``blk``'s first ``nb`` pruned lists (:class:`BoxLists`) of a box
    containing p; NaN when p is not in the water.

    ``gval`` is (2·G,) scratch: the merged signed squared distance of each ψ-group, then
    the segment it is to (:func:`_nearer`).
    """
    return potential_and_shore_at(px, py, nb, blk.curve, blk.start, blk.count, blk.seg,
                                  blk.dmin2, net.seg_ax, net.seg_ay, net.seg_bx, net.seg_by,
                                  net.curve_kind, net.curve_comp, net.curve_group, net.curve_hw2,
                                  net.comp_radius, net.comp_group0, net.comp_group1,
                                  net.group_psi, slip, gval)[0]


@njit(**JIT_OPTIONS)
def potential_and_shore_at(
    px, py, nb, blk_curve, blk_start, blk_count, blk_seg, blk_dmin2,
    seg_ax, seg_ay, seg_bx, seg_by,
    curve_kind, curve_comp, curve_group, curve_hw2,
    comp_radius, comp_group0, comp_group1, group_psi, slip, gval,
):
    """(ψ [m²/s], squared distance to the nearest shore [m²], squared distance to the nearest
    bank [m²]) at p, as :func:`potential_at`; the distances are to the nearest bank or island
    shore of p's river network (the ψ-groups' nearest segments, which the weighting finds
    anyway), the shore's leaving out open banks (OPEN_BANK, a basin's mouth: the water goes on
    across it), the bank's counting them (the flow runs along them); inf where p is not in the
    water. They differ only where a mouth is nearer than every shore.

    p's network is that of the nearest axis covering it, a river's (a network with two shore
    ψ or more) before still water's (a lake or basin whose whole shore has one ψ); where p
    lies behind that network's shore (a bank or cap with p on its dry side within a river
    width), the next network is tried so, up to MAX_NETWORK_TRIES networks: where two
    networks' axes overlap across a shore they share (a basin's mouth beside its river), each
    point takes the one whose water it is in, and a river's water is never taken for a
    basin's at the basin's corners (the vertex tie rule, :func:`_nearer`).

    It and :func:`_network_potential` take the arrays they read one by one, not the
    :class:`Network` and :class:`BoxLists` tuples: they run once per lattice point, and passing
    whole tuples (arrays they do not read) made :func:`build_flow_tile` 25 % slower."""
    tried0 = -1
    tried1 = -1
    for _ in range(MAX_NETWORK_TRIES):
        axis = -1
        for rivers in (True, False):     # rivers first, then still water (one shore ψ)
            best = np.inf
            for k in range(nb):
                c = blk_curve[k]
                if curve_kind[c] != KIND_AXIS:
                    continue
                ck = curve_comp[c]
                if ck == tried0 or ck == tried1:
                    continue
                if rivers and comp_group1[ck] - comp_group0[ck] < 2:
                    continue
                hw2 = curve_hw2[c]
                for m in range(blk_start[k], blk_start[k] + blk_count[k]):
                    s = blk_seg[m]
                    d2 = _dist2(px, py, seg_ax[s], seg_ay[s], seg_bx[s], seg_by[s])
                    if d2 < hw2 and d2 < best:
                        best = d2
                        axis = c
            if axis >= 0:
                break
        if axis < 0:
            return np.nan, np.inf, np.inf
        psi, near2, bank2, behind = _network_potential(
            px, py, nb, blk_curve, blk_start, blk_count, blk_seg, blk_dmin2, seg_ax, seg_ay,
            seg_bx, seg_by, curve_kind, curve_comp, curve_group, curve_hw2, comp_radius,
            comp_group0, comp_group1, group_psi, slip, gval, axis)
        if not behind:
            return psi, near2, bank2
        if tried0 < 0:
            tried0 = curve_comp[axis]
        else:
            tried1 = curve_comp[axis]
    return np.nan, np.inf, np.inf


@njit(**JIT_OPTIONS)
def _network_potential(
    px, py, nb, blk_curve, blk_start, blk_count, blk_seg, blk_dmin2,
    seg_ax, seg_ay, seg_bx, seg_by,
    curve_kind, curve_comp, curve_group, curve_hw2,
    comp_radius, comp_group0, comp_group1, group_psi, slip, gval, axis,
):
    """(ψ, squared distance to the nearest shore, to the nearest bank, behind) at p in the
    network of ``axis``: ``behind`` when p lies on the dry side of one of its shores (then ψ is
    NaN). The shore's distance leaves out open banks (OPEN_BANK: a basin's mouth, which the
    water crosses), the bank's counts them."""
    comp = curve_comp[axis]
    radius = comp_radius[comp]
    width2 = 4.0 * curve_hw2[axis]  # sign tests only within one river width
    g0 = comp_group0[comp]
    g1 = comp_group1[comp]
    n_groups = group_psi.shape[0]           # gval[n_groups + g]: group g's nearest segment
    for g in range(g0, g1):
        gval[g] = np.inf
        gval[n_groups + g] = -1.0
    cap = np.inf
    cap_seg = -1
    shore2 = np.inf         # to the nearest bank segment that is not open
    saw_open = False
    for k in range(nb):
        c = blk_curve[k]
        kind = curve_kind[c]
        if kind == KIND_AXIS or curve_comp[c] != comp:
            continue
        shore = kind == KIND_BANK and curve_hw2[c] != OPEN_BANK
        saw_open = saw_open or (kind == KIND_BANK and not shore)
        cur = np.inf
        cur_seg = -1
        if kind == KIND_BANK:
            cur = gval[curve_group[c]]
            cur_seg = int(gval[n_groups + curve_group[c]])
        else:
            cur = cap
            cur_seg = cap_seg
        # no point of this curve can be nearer (nor nearer than the nearest shore, where an
        # open bank may have been its group's nearest: otherwise that is never farther)
        if blk_dmin2[k] > abs(cur) * (1.0 + _TIE) and not (
                shore and saw_open and blk_dmin2[k] < shore2):
            continue
        for m in range(blk_start[k], blk_start[k] + blk_count[k]):
            s = blk_seg[m]
            sd2 = _signed_dist2(px, py, seg_ax[s], seg_ay[s], seg_bx[s], seg_by[s])
            cur, cur_seg = _nearer(cur, cur_seg, sd2, s, px, py, seg_ax, seg_ay, seg_bx, seg_by)
            if shore:
                shore2 = min(shore2, abs(sd2))
        if kind == KIND_BANK:
            gval[curve_group[c]] = cur
            gval[n_groups + curve_group[c]] = cur_seg
        else:
            cap = cur
            cap_seg = cur_seg
    # behind a shore: the nearest shore of the network (its nearest cap or a ψ-group's
    # nearest bank, the vertex tie rule between them) has p on its dry side, within a river
    # width. Not any group's nearest: a pocket of water beside the river whose shore shares
    # a bank's ψ is nearer than that bank to some of the river's water, which lies on the
    # pocket's dry side
    best = cap
    best_seg = cap_seg
    for g in range(g0, g1):
        if gval[g] != np.inf:
            best, best_seg = _nearer(best, best_seg, gval[g], int(gval[n_groups + g]), px, py,
                                     seg_ax, seg_ay, seg_bx, seg_by)
    if best < 0.0 and -best < width2:
        return np.nan, np.inf, np.inf, True
    count = 0
    near2 = np.inf
    on_bank = -1
    sw = 0.0
    swp = 0.0
    for g in range(g0, g1):
        v = gval[g]
        if v == np.inf:
            continue
        count += 1
        near2 = min(near2, abs(v))
        d = math.sqrt(abs(v))
        if d <= 1e-9 * radius:
            on_bank = g
            continue
        f = _fade(1.0 - d / radius)
        if f > 0.0:
            if slip == 1.0:
                w = f * (radius / d)
            else:
                w = f * math.exp(slip * math.log(radius / d))
            sw += w
            swp += w * group_psi[g]
    if count < 2 and not (count == 1 and g1 - g0 == 1):
        # water lies between two shores of different ψ; a network whose whole shore has one
        # ψ (a lake no river touches) is still water
        return np.nan, np.inf, np.inf, False
    bank2 = near2
    if saw_open and shore2 < np.inf:
        near2 = shore2      # the water goes on across an open bank
    if on_bank >= 0:
        return group_psi[on_bank], near2 if saw_open else 0.0, 0.0, False
    if sw <= 0.0:
        return np.nan, np.inf, np.inf, False
    return swp / sw, near2, bank2, False


@njit(**JIT_OPTIONS)
def evaluate_potential(xy, out_psi, net, slip, blk, gval):
    """Exact (uncached) ψ at each point of ``xy`` (N, 2) float64 into ``out_psi`` (N,) float64.

    Slow path for tests and tools: each point gets its own pruned segment list (scratch
    ``blk``, :class:`BoxLists`; ``gval`` as :func:`potential_at`).
    """
    for i in range(xy.shape[0]):
        px = xy[i, 0]
        py = xy[i, 1]
        nb = gather_box_segments(px, py, px, py, net, blk)
        out_psi[i] = potential_at(px, py, nb, blk, net, slip, gval)


@njit(**JIT_OPTIONS)
def _mirrored_across_cap(px, py, reach, net, slip, blk, gval):
    """ψ at the mirror image of p (a dry point just beyond a cap) across its nearest cap
    segment's line, when that lies in the water and p within ``reach`` of the cap; else NaN.
    The ghosts of a river's open end: the water would go on, square to the cap."""
    seg_ax, seg_ay, seg_bx, seg_by = net.seg_ax, net.seg_ay, net.seg_bx, net.seg_by
    curve_kind, curve_seg0, curve_seg1, curve_bbox = (net.curve_kind, net.curve_seg0,
                                                      net.curve_seg1, net.curve_bbox)
    best = np.inf
    seg = -1
    for c in range(curve_kind.shape[0]):
        if curve_kind[c] != KIND_CAP:
            continue
        if (curve_bbox[c, 0] > px + reach or curve_bbox[c, 2] < px - reach
                or curve_bbox[c, 1] > py + reach or curve_bbox[c, 3] < py - reach):
            continue
        for s in range(curve_seg0[c], curve_seg1[c]):
            d2 = _dist2(px, py, seg_ax[s], seg_ay[s], seg_bx[s], seg_by[s])
            if d2 < best:
                best = d2
                seg = s
    if seg < 0 or best > reach * reach:
        return np.nan
    ax = seg_ax[seg]
    ay = seg_ay[seg]
    ex = seg_bx[seg] - ax
    ey = seg_by[seg] - ay
    len2 = ex * ex + ey * ey
    if len2 <= 0.0:
        return np.nan
    t = ((px - ax) * ex + (py - ay) * ey) / len2
    mx = 2.0 * (ax + t * ex) - px
    my = 2.0 * (ay + t * ey) - py
    nb = gather_box_segments(mx, my, mx, my, net, blk)
    if nb == 0:
        return np.nan
    return potential_at(mx, my, nb, blk, net, slip, gval)


# -- flow tiles ---------------------------------------------------------------------------------


@njit(**WORKER_JIT_OPTIONS)
def build_flow_tile(origin_x, origin_y, spacing_m, n_cells, gi0, gj0, net, slip, blk, scratch,
                    out):
    """Fill one flow tile: its ψ lattice (with extrapolated ghosts), per-cell inside data and
    the distance to the nearest bank or island shore at its lattice points.

    The tile has ``n_cells`` × ``n_cells`` lattice cells of ``spacing_m``; lattice point (a, b)
    lies at ``origin + ((gi0 + a)·h, (gj0 + b)·h)``, so neighbouring tiles compute bitwise
    equal values at shared points. ``net``: the network (:class:`Network`), ``slip`` its
    weighting exponent; scratch ``blk`` (:class:`BoxLists`) and ``scratch``
    (:class:`TileScratch`).

    Outputs (:class:`TileOut`): ``psi`` (n+3, n+3) float32, lattice points −1 … n+1 (NaN far
    from water;
    outside points next to the water hold ψ extrapolated from the water side, those within
    three spacings beyond a cap ψ of their mirror image across it);
    ``cell_status`` (n, n) uint8 CELL_* (BOUNDARY possibly with the CELL_CROWDED flag); ``cell_segments`` (n, n, CELL_SEGMENTS) int32,
    for boundary cells the nearest bank / cap segments (−1 padded); ``shore`` (n+3, n+3)
    float32, lattice points −1 … n+1: the distance [m] to the nearest bank or island shore
    (found by the ψ weighting anyway: :func:`potential_and_shore_at`), 0 at dry points, so
    that a bilinear blend falls to about 0 at the bank; ``bank`` (n+3, n+3) float32 the
    same with open banks (a basin's mouth) counted: the distance to the flow's nearest bank.
    Returns the number of lattice points inside the water.
    """
    (seg_ax, seg_ay, seg_bx, seg_by, curve_kind, curve_comp, curve_group, curve_hw2, _, _,
     curve_bbox, _, comp_radius, comp_group0, comp_group1, group_psi) = net
    blk_curve, blk_start, blk_count, blk_seg, blk_dmin2, _ = blk
    gval, psi_full, inside_full, cell_d2 = scratch
    out_psi, out_cell_status, out_cell_segments, out_shore, out_bank = out
    ring = LATTICE_RING
    m = n_cells + 1 + 2 * ring
    h = spacing_m
    n_inside = 0
    out_cell_status[:, :] = _CELL_UNSET
    out_cell_segments[:, :, :] = -1
    # the segments near the whole lattice, once: each block picks from these
    list_lo = np.empty(curve_bbox.shape[0], np.int32)
    list_hi = np.empty(curve_bbox.shape[0], np.int32)
    listed = np.empty(seg_ax.shape[0], np.int32)
    segments_near_box(origin_x + (gi0 - ring) * h, origin_y + (gj0 - ring) * h,
                      origin_x + (gi0 + m - 1 - ring) * h, origin_y + (gj0 + m - 1 - ring) * h,
                      net, list_lo, list_hi, listed)
    for bj in range(0, m, BLOCK):
        for bi in range(0, m, BLOCK):
            i_hi = min(bi + BLOCK, m)
            j_hi = min(bj + BLOCK, m)
            x0 = origin_x + (gi0 + bi - ring) * h
            y0 = origin_y + (gj0 + bj - ring) * h
            x1 = origin_x + (gi0 + min(i_hi, m - 1) - ring) * h
            y1 = origin_y + (gj0 + min(j_hi, m - 1) - ring) * h
            nb = _gather_listed(x0, y0, x1, y1, net, list_lo, list_hi, listed, True, blk)
            near_cap = False
            wet = False     # an axis within its half width of the block: else all is dry
            for k in range(nb):
                c = blk_curve[k]
                if curve_kind[c] == KIND_CAP:
                    near_cap = True
                elif curve_kind[c] == KIND_AXIS and not wet:
                    reach2 = curve_hw2[c] * (1.0 + NEAR_BOX_SLACK) + NEAR_BOX_SLACK
                    for q in range(blk_start[k], blk_start[k] + blk_count[k]):
                        s = blk_seg[q]
                        if _segment_box_dist2(seg_ax[s], seg_ay[s], seg_bx[s], seg_by[s],
                                              x0, y0, x1, y1) < reach2:
                            wet = True
                            break
            for j in range(bj, j_hi):
                py = origin_y + (gj0 + j - ring) * h
                for i in range(bi, i_hi):
                    px = origin_x + (gi0 + i - ring) * h
                    psi = np.nan
                    near2 = np.inf
                    bank2 = np.inf
                    if wet:
                        psi, near2, bank2 = potential_and_shore_at(
                            px, py, nb, blk_curve, blk_start, blk_count, blk_seg, blk_dmin2,
                            seg_ax, seg_ay, seg_bx, seg_by, curve_kind, curve_comp,
                            curve_group, curve_hw2, comp_radius, comp_group0, comp_group1,
                            group_psi, slip, gval)
                    inside_full[j, i] = not math.isnan(psi)
                    # dry by a cap: mirrored below
                    psi_full[j, i] = psi if inside_full[j, i] else (np.inf if near_cap
                                                                      else np.nan)
                    sj = j - ring + 1          # lattice points −1 … n+1 are kept
                    si = i - ring + 1
                    if 0 <= sj <= n_cells + 2 and 0 <= si <= n_cells + 2:
                        out_shore[sj, si] = (math.sqrt(near2) if inside_full[j, i]
                                             and near2 < np.inf else 0.0)
                        out_bank[sj, si] = (math.sqrt(bank2) if inside_full[j, i]
                                            and bank2 < np.inf else 0.0)
                    if inside_full[j, i] and ring <= i < m - ring and ring <= j < m - ring:
                        n_inside += 1
    # beyond a cap (a river's open end) the water would go on: ψ there is ψ at the point
    # mirrored across the cap (flow square to the cap), for the ghosts
    for j in range(m):
        for i in range(m):
            if psi_full[j, i] != np.inf:
                continue
            psi_full[j, i] = _mirrored_across_cap(
                origin_x + (gi0 + i - ring) * h, origin_y + (gj0 + j - ring) * h, 3.0 * h,
                net, slip, blk, gval)
    _mark_boundary_cells(origin_x + gi0 * h, origin_y + gj0 * h, h, n_cells, net, cell_d2,
                         out_cell_status, out_cell_segments)
    _classify_plain_cells(inside_full, n_cells, out_cell_status)
    _extrapolate_ghosts(psi_full, inside_full, n_cells, out_psi)
    return n_inside


@njit(**JIT_OPTIONS)
def _mark_boundary_cells(x0, y0, h, n_cells, net, cell_d2, out_cell_status, out_cell_segments):
    """Rasterise bank and cap segments onto the tile's cells.

    A cell that a segment touches is BOUNDARY; every cell keeps (up to CELL_SEGMENTS) the
    segments within one cell diagonal of it, nearest first: if any segment touches a cell, the
    nearest boundary segment of each of its points is among those (it is within a diagonal),
    unless more than CELL_SEGMENTS were that near: the cell is then flagged CELL_CROWDED.
    """
    seg_ax, seg_ay, seg_bx, seg_by = net.seg_ax, net.seg_ay, net.seg_bx, net.seg_by
    curve_kind, curve_seg0, curve_seg1, curve_bbox = (net.curve_kind, net.curve_seg0,
                                                      net.curve_seg1, net.curve_bbox)
    diag = math.sqrt(2.0) * h
    diag2 = 2.0 * h * h
    x1 = x0 + n_cells * h
    y1 = y0 + n_cells * h
    cell_d2[:, :, :] = np.inf
    for c in range(curve_kind.shape[0]):
        if curve_kind[c] == KIND_AXIS:
            continue
        if (curve_bbox[c, 0] > x1 + diag or curve_bbox[c, 2] < x0 - diag
                or curve_bbox[c, 1] > y1 + diag or curve_bbox[c, 3] < y0 - diag):
            continue
        for s in range(curve_seg0[c], curve_seg1[c]):
            ax, ay, bx, by = seg_ax[s], seg_ay[s], seg_bx[s], seg_by[s]
            i0 = max(int(math.floor((min(ax, bx) - diag - x0) / h)), 0)
            i1 = min(int(math.floor((max(ax, bx) + diag - x0) / h)), n_cells - 1)
            j0 = max(int(math.floor((min(ay, by) - diag - y0) / h)), 0)
            j1 = min(int(math.floor((max(ay, by) + diag - y0) / h)), n_cells - 1)
            for j in range(j0, j1 + 1):
                cy0 = y0 + j * h
                for i in range(i0, i1 + 1):
                    cx0 = x0 + i * h
                    d2 = _segment_box_dist2(ax, ay, bx, by, cx0, cy0, cx0 + h, cy0 + h)
                    if d2 > diag2:
                        continue
                    if curve_kind[c] == KIND_BANK:
                        out_cell_status[j, i] |= CELL_NEAR_BANK
                    if d2 == 0.0:
                        out_cell_status[j, i] = CELL_BOUNDARY | (
                            out_cell_status[j, i] & (CELL_CROWDED | CELL_NEAR_BANK))
                    pos = CELL_SEGMENTS
                    while pos > 0 and d2 < cell_d2[j, i, pos - 1]:
                        pos -= 1
                    if pos == CELL_SEGMENTS or cell_d2[j, i, CELL_SEGMENTS - 1] < np.inf:
                        out_cell_status[j, i] |= CELL_CROWDED   # one is left out
                    if pos < CELL_SEGMENTS:
                        for q in range(CELL_SEGMENTS - 1, pos, -1):
                            cell_d2[j, i, q] = cell_d2[j, i, q - 1]
                            out_cell_segments[j, i, q] = out_cell_segments[j, i, q - 1]
                        cell_d2[j, i, pos] = d2
                        out_cell_segments[j, i, pos] = s


@njit(**JIT_OPTIONS)
def _classify_plain_cells(inside_full, n_cells, out_cell_status):
    """Cells no boundary touches take their corners' status (mixed corners: BOUNDARY, no list;
    all agreeing: exact, whatever was left out of the list)."""
    ring = LATTICE_RING
    for j in range(n_cells):
        for i in range(n_cells):
            crowded = out_cell_status[j, i] & CELL_CROWDED
            near = out_cell_status[j, i] & CELL_NEAR_BANK
            if out_cell_status[j, i] & CELL_KIND == CELL_BOUNDARY:
                continue
            a = ring + i
            b = ring + j
            n = (int(inside_full[b, a]) + int(inside_full[b, a + 1])
                 + int(inside_full[b + 1, a]) + int(inside_full[b + 1, a + 1]))
            if n == 4:
                out_cell_status[j, i] = CELL_INSIDE | near
            elif n == 0:
                out_cell_status[j, i] = CELL_OUTSIDE | near
            else:
                out_cell_status[j, i] = CELL_BOUNDARY | crowded | near


@njit(**JIT_OPTIONS)
def _extrapolate_ghosts(psi_full, inside_full, n_cells, out_psi):
    """Copy lattice points −1 … n+1; dry points next to the water get extrapolations: along
    each lattice direction with water beside them, quadratic from the three points inward
    (linear from two where the third is dry), averaged. ψ bends near a bank (the bank's
    weight falls as 1/d), and a linear ghost made the flow one cell from a bank cross it by
    up to 7 % of its speed (issue 22's tangency figure; quadratic: 5 %; with the query's bank
    correction, :func:`_bank_correction`: 1.7 %). Points that already hold a value (ψ
    mirrored across a cap, :func:`_mirrored_across_cap`) are copied and extrapolated from."""
    ring = LATTICE_RING
    for sj in range(n_cells + 3):
        b = sj + ring - 1
        for si in range(n_cells + 3):
            a = si + ring - 1
            if not math.isnan(psi_full[b, a]):
                out_psi[sj, si] = psi_full[b, a]
                continue
            acc = 0.0
            n2 = 0
            acc1 = 0.0
            n1 = 0
            for d in range(4):
                da = 1 if d == 0 else (-1 if d == 1 else 0)
                db = 1 if d == 2 else (-1 if d == 3 else 0)
                if not math.isnan(psi_full[b + db, a + da]):
                    if not math.isnan(psi_full[b + 2 * db, a + 2 * da]):
                        b3 = b + 3 * db
                        a3 = a + 3 * da
                        if (0 <= b3 < inside_full.shape[0] and 0 <= a3 < inside_full.shape[1]
                                and not math.isnan(psi_full[b3, a3])):
                            acc += (3.0 * psi_full[b + db, a + da]
                                    - 3.0 * psi_full[b + 2 * db, a + 2 * da] + psi_full[b3, a3])
                        else:
                            acc += 2.0 * psi_full[b + db, a + da] - psi_full[b + 2 * db, a + 2 * da]
                        n2 += 1
                    else:
                        acc1 += psi_full[b + db, a + da]
                        n1 += 1
            if n2 > 0:
                out_psi[sj, si] = acc / n2
            elif n1 > 0:
                out_psi[sj, si] = acc1 / n1
            else:
                out_psi[sj, si] = np.nan


# -- cached queries -------------------------------------------------------------------------------


@njit(**JIT_OPTIONS)
def _catmull_rom(t):
    """Catmull-Rom weights and their derivatives at t ∈ [0, 1]."""
    t2 = t * t
    t3 = t2 * t
    w0 = 0.5 * (-t3 + 2.0 * t2 - t)
    w1 = 0.5 * (3.0 * t3 - 5.0 * t2 + 2.0)
    w2 = 0.5 * (-3.0 * t3 + 4.0 * t2 + t)
    w3 = 0.5 * (t3 - t2)
    d0 = 0.5 * (-3.0 * t2 + 4.0 * t - 1.0)
    d1 = 0.5 * (9.0 * t2 - 10.0 * t)
    d2 = 0.5 * (-9.0 * t2 + 8.0 * t + 1.0)
    d3 = 0.5 * (3.0 * t2 - 2.0 * t)
    return w0, w1, w2, w3, d0, d1, d2, d3


class CachedTiles(NamedTuple):
    """The flow tiles as the query kernels read them (built by ``FlowTiles.view()``).

    The quadtree root (``root_x``, ``root_y`` [m], side ``root_size`` [m]) and ``n_cells``
    lattice cells per tile side; ``keys``/``values`` the tile table (code → pool slot,
    :mod:`riverflow.kernels.tile_table`); ``wet_keys``/``wet_values`` the tiles an axis comes
    near (any other tile is dry: all OUTSIDE); the pool's columns ``psi`` (P, n+3, n+3) float32
    (lattice points −1 … n+1), ``cell_status`` (P, n, n) uint8, ``cell_segments``
    (P, n, n, CELL_SEGMENTS) int32, ``last_used`` (P,) int64 (LRU stamps) and ``in_cut`` (P,)
    uint8 (1: a leaf of this frame's flow cut, set by the tile system; a tile read with
    ``fallback`` > 0 that is not one stands in for a late tile).
    """

    root_x: float
    root_y: float
    root_size: float
    n_cells: int
    keys: np.ndarray
    values: np.ndarray
    wet_keys: np.ndarray
    wet_values: np.ndarray
    psi: np.ndarray
    cell_status: np.ndarray
    cell_segments: np.ndarray
    last_used: np.ndarray
    in_cut: np.ndarray


class Segments(NamedTuple):
    """The network's segments (S,) float64 [m]: a → b; banks and caps have the water on their
    left. ``psi`` (S,) float64 [m²/s]: the stream function of a bank segment's ψ-group, NaN
    for axes and caps (the bank correction, :func:`_bank_correction`)."""

    ax: np.ndarray
    ay: np.ndarray
    bx: np.ndarray
    by: np.ndarray
    psi: np.ndarray


@njit(**EXACT_JIT_OPTIONS)
def root_unit(p, root, root_size):
    """The coordinate ``(p − root) / root_size`` of p in the quadtree's root square: the one
    place tile ownership is computed from, by every query kernel and by
    ``FlowField.tile_of`` (its numpy twin, which must round the same way).

    Compiled without fast-math (an IEEE division, not a multiplication by a hoisted
    reciprocal, which rounds differently for a root side that is not a power of two), so that
    the tile the kernels look for is bitwise the tile Python makes for that point.

    The ownership rule (half-open): p is in the domain iff 0 ≤ u ≤ 1; at level l it belongs to
    tile ``tile_index(u, 2**l)`` = ⌊u·2^l⌋, except that u = 1 (the domain's far edge) belongs
    to the last tile. A point on an edge between tiles belongs to the tile above/right of it.
    Since u·2^l is exact, the tile of a level is its child's index >> 1 (level fallback agrees).
    """
    return (p - root) / root_size


@njit(inline="always", **JIT_OPTIONS)
def tile_index(u, nt):
    """The tile (0 … nt − 1) of root coordinate u ∈ [0, 1] at a level with ``nt`` tiles per
    side (:func:`root_unit`: half-open, the far edge closed)."""
    return min(int(u * nt), nt - 1)


@njit(inline="always", **JIT_OPTIONS)
def _locate(px, py, tiles, level, fallback):
    """(slot, level, cell i, cell j, fx, fy) of p: the cached tile of ``level`` under p, or of
    up to ``fallback`` coarser levels when that one is not cached.

    With ``fallback`` > 0 (a frame's queries, from the deepest level of its flow cut) the
    tile of this frame's cut under p is taken (``in_cut``) even where a finer tile is still
    cached from earlier frames: what a frame reads depends on its cut, not on what the cache
    happens to hold. Only where no cut tile under p is cached (a late one) is the first
    cached tile read, as a stand-in.

    slot = SLOT_OUTSIDE_DOMAIN outside the domain, SLOT_MISSING when no such tile is cached,
    SLOT_DRY when the tile (at any level tried) is known to hold no river.
    """
    u0 = root_unit(px, tiles.root_x, tiles.root_size)
    v0 = root_unit(py, tiles.root_y, tiles.root_size)
    if not (u0 >= 0.0 and v0 >= 0.0 and u0 <= 1.0 and v0 <= 1.0):
        return -2, level, 0, 0, 0.0, 0.0
    n_cells = tiles.n_cells
    lv = level
    found = -1
    found_lv = level
    while True:
        nt = 1 << lv
        code = tile_code(lv, tile_index(u0, nt), tile_index(v0, nt))
        slot = table_find(tiles.keys, tiles.values, code)
        if slot >= 0:
            if found < 0 or tiles.in_cut[slot] != 0:
                found = slot
                found_lv = lv
            if fallback == 0 or tiles.in_cut[slot] != 0:
                break
        elif found < 0 and table_find(tiles.wet_keys, tiles.wet_values, code) < 0:
            return SLOT_DRY, lv, 0, 0, 0.0, 0.0
        if lv == 0 or level - lv >= fallback:
            break
        lv -= 1
    if found < 0:
        return -1, level, 0, 0, 0.0, 0.0
    nt = 1 << found_lv
    fu = (u0 * nt - tile_index(u0, nt)) * n_cells
    fv = (v0 * nt - tile_index(v0, nt)) * n_cells
    ci = min(int(fu), n_cells - 1)
    cj = min(int(fv), n_cells - 1)
    return found, found_lv, ci, cj, fu - ci, fv - cj


@njit(inline="always", **JIT_OPTIONS)
def _boundary_inside(px, py, slot, ci, cj, fx, fy, cell_segments, psi_pool, segs):
    """Exact inside test in a BOUNDARY cell: the sign of the nearest listed bank/cap segment.

    Called only for boundary cells: the hot loops test the cell status inline (numba's
    reference counting of array arguments makes a helper call per point several times slower).
    """
    cur = np.inf
    cur_seg = -1
    for q in range(CELL_SEGMENTS):
        s = cell_segments[slot, cj, ci, q]
        if s < 0:
            break
        sd2 = _signed_dist2(px, py, segs.ax[s], segs.ay[s], segs.bx[s], segs.by[s])
        cur, cur_seg = _nearer(cur, cur_seg, sd2, s, px, py, segs.ax, segs.ay, segs.bx,
                               segs.by)
    if cur != np.inf:
        return cur >= 0.0
    # mixed corners, no boundary segment: the nearest lattice corner decides
    a = ci + 1 + (1 if fx >= 0.5 else 0)
    b = cj + 1 + (1 if fy >= 0.5 else 0)
    return not math.isnan(psi_pool[slot, b, a])


@njit(**JIT_OPTIONS)
def _rows(w0, w1, w2, w3, a, b, c, d):
    return w0 * a + w1 * b + w2 * c + w3 * d


@njit(**JIT_OPTIONS)
def _fill_stencil(patch):
    """Fill NaNs of a 4×4 ψ stencil by linear extrapolation along rows, then columns.
    Returns False if NaNs remain. (Rare: cells at the edge of the extrapolated ghosts.)"""
    for sweep in range(2):
        for r in range(4):
            for q in range(4):
                a, b = (r, q) if sweep == 0 else (q, r)
                if not math.isnan(patch[a, b]):
                    continue
                step = 1 if (b if sweep == 0 else a) <= 1 else -1  # towards the middle
                if sweep == 0:
                    v1, v2 = patch[a, b + step], patch[a, b + 2 * step]
                else:
                    v1, v2 = patch[a + step, b], patch[a + 2 * step, b]
                if not math.isnan(v1):
                    patch[a, b] = v1 if math.isnan(v2) else 2.0 * v1 - v2
    for r in range(4):
        for q in range(4):
            if math.isnan(patch[r, q]):
                return False
    return True


BANK_REACH = 1.4
"""The bank correction (:func:`_bank_correction`) fades out this many lattice spacings from a
bank: within one cell diagonal (√2) of a cell, every segment is in the cell's list."""


@njit(inline="always", **JIT_OPTIONS)
def _bicubic(patch, fx, fy):
    """(value, ∂/∂fx, ∂/∂fy) of the Catmull-Rom bicubic of a 4×4 stencil at (fx, fy) (lattice
    units; outside [0, 1] the cell's polynomial continued)."""
    wx0, wx1, wx2, wx3, dx0, dx1, dx2, dx3 = _catmull_rom(fx)
    wy0, wy1, wy2, wy3, dy0, dy1, dy2, dy3 = _catmull_rom(fy)
    r0w = _rows(wx0, wx1, wx2, wx3, patch[0, 0], patch[0, 1], patch[0, 2], patch[0, 3])
    r1w = _rows(wx0, wx1, wx2, wx3, patch[1, 0], patch[1, 1], patch[1, 2], patch[1, 3])
    r2w = _rows(wx0, wx1, wx2, wx3, patch[2, 0], patch[2, 1], patch[2, 2], patch[2, 3])
    r3w = _rows(wx0, wx1, wx2, wx3, patch[3, 0], patch[3, 1], patch[3, 2], patch[3, 3])
    r0d = _rows(dx0, dx1, dx2, dx3, patch[0, 0], patch[0, 1], patch[0, 2], patch[0, 3])
    r1d = _rows(dx0, dx1, dx2, dx3, patch[1, 0], patch[1, 1], patch[1, 2], patch[1, 3])
    r2d = _rows(dx0, dx1, dx2, dx3, patch[2, 0], patch[2, 1], patch[2, 2], patch[2, 3])
    r3d = _rows(dx0, dx1, dx2, dx3, patch[3, 0], patch[3, 1], patch[3, 2], patch[3, 3])
    val = _rows(wy0, wy1, wy2, wy3, r0w, r1w, r2w, r3w)
    gx = _rows(wy0, wy1, wy2, wy3, r0d, r1d, r2d, r3d)
    gy = _rows(dy0, dy1, dy2, dy3, r0w, r1w, r2w, r3w)
    return val, gx, gy


@njit(inline="always", **JIT_OPTIONS)
def _bank_correction(px, py, slot, ci, cj, fx, fy, inv_h, tiles, segs, patch):
    """The bank correction at p (in a CELL_NEAR_BANK cell of tile ``slot``; ``patch`` its
    cell's 4×4 ψ stencil, NaN-free):
    (δψ [m²/s], ∂δψ/∂x, ∂δψ/∂y [m/s]) to add to the lattice's bicubic ψ_L.

    The lattice is a few metres coarse; its bicubic is not constant along a bank, so the flow
    crossed it by up to 4 % of its speed 1 m in (issue 22). With f the foot of p on its nearest
    bank segment (ψ-group value ψ_b), d = |p − f| and w = 1 − fade(d / D), D = BANK_REACH
    lattice spacings, the corrected stream function is ψ = ψ_L(p) − w·(ψ_L(f) − ψ_b): exactly
    ψ_b on the bank, ψ_L from D on, and the velocity stays its curl (divergence-free). Its
    normal part at p is ∂ψ_L/∂t(p) − w·∂ψ_L/∂t(f): what the lattice gets wrong at the bank,
    cancelled near it. ψ_L(f) is p's own cell's bicubic continued to f (within D of p): the
    same polynomial on both sides of the difference, so that ∂ψ_L/∂t cancels where the lattice
    is rough (ghosts by a corner), at the price of ψ jumping a little (what the polynomials of
    two cells disagree on at f) where p crosses a cell edge within D of a bank. Caps carry no
    ψ and are skipped. Returns zeros when no bank is within D."""
    h = 1.0 / inv_h
    reach = BANK_REACH * h
    best = reach * reach
    fxm = 0.0
    fym = 0.0
    on_inside = False
    psi_b = 0.0
    tx = 0.0
    ty = 0.0
    tl2 = 1.0
    for q in range(CELL_SEGMENTS):
        s = tiles.cell_segments[slot, cj, ci, q]
        if s < 0:
            break
        if math.isnan(segs.psi[s]):
            continue
        ax = segs.ax[s]
        ay = segs.ay[s]
        ex = segs.bx[s] - ax
        ey = segs.by[s] - ay
        len2 = ex * ex + ey * ey
        t = 0.0
        if len2 > 0.0:
            t = min(max(((px - ax) * ex + (py - ay) * ey) / len2, 0.0), 1.0)
        qx = ax + t * ex
        qy = ay + t * ey
        d2 = (px - qx) * (px - qx) + (py - qy) * (py - qy)
        if d2 < best:
            best = d2
            fxm = qx
            fym = qy
            psi_b = segs.psi[s]
            on_inside = 0.0 < t < 1.0
            tx = ex
            ty = ey
            tl2 = len2
    if best >= reach * reach:
        return 0.0, 0.0, 0.0
    val, gfx, gfy = _bicubic(patch, fx + (fxm - px) * inv_h, fy + (fym - py) * inv_h)
    gfx *= inv_h
    gfy *= inv_h
    err = val - psi_b
    d = math.sqrt(best)
    x = d / reach
    w = 1.0 - x * x * x * (x * (x * 6.0 - 15.0) + 10.0)
    dw = -30.0 * x * x * (x - 1.0) * (x - 1.0) / reach      # dw/dd
    gx = 0.0
    gy = 0.0
    if d > 0.0:
        gx = -dw * err * (px - fxm) / d
        gy = -dw * err * (py - fym) / d
    if on_inside:           # ∇(ψ_L(f(p))) = t̂ (t̂ · ∇ψ_L(f)); at an end the foot stays put
        along = (tx * gfx + ty * gfy) / tl2
        gx -= w * along * tx
        gy -= w * along * ty
    return -w * err, gx, gy



@njit(**JIT_OPTIONS)
def query_velocity(xy, levels, level, fallback, tiles, tick, segs, n_velocity, out_status,
                   out_velocity):
    """Velocity [m/s] and FlowStatus at each point of ``xy`` (N, 2) from cached tiles
    (:class:`CachedTiles`); the points from ``n_velocity`` on get their status alone (no ψ
    stencil read, velocity 0).

    Point k uses the tiles of quadtree ``level`` (≥ 0), or of ``levels[k]`` when ``level`` < 0,
    falling back on up to ``fallback`` coarser levels when that tile is not cached. The slots
    used get ``tiles.last_used[slot] = tick`` (LRU bookkeeping). ``segs``: the network's
    :class:`Segments`. Writes ``out_status`` (N,) uint8 and ``out_velocity`` (N, 2) float32
    (zero unless INSIDE; never NaN). Returns the number of points with no cached tile (status
    UNKNOWN).
    """
    patch = np.empty((4, 4))
    missing = 0
    psi_pool = tiles.psi
    cell_status = tiles.cell_status
    last_used = tiles.last_used
    inv_root = 1.0 / tiles.root_size
    memo_code = np.int64(-1)
    memo = (0, 0)
    for k in range(xy.shape[0]):
        px = xy[k, 0]
        py = xy[k, 1]
        out_velocity[k, 0] = 0.0
        out_velocity[k, 1] = 0.0
        want = level if level >= 0 else np.int64(levels[k])
        # consecutive points mostly share a tile: skip the table when this one is the last one
        u0 = root_unit(px, tiles.root_x, tiles.root_size)   # as _locate: the same tile
        v0 = root_unit(py, tiles.root_y, tiles.root_size)
        code = np.int64(-2)
        if u0 >= 0.0 and v0 >= 0.0 and u0 <= 1.0 and v0 <= 1.0:
            nt = 1 << want
            code = tile_code(want, tile_index(u0, nt), tile_index(v0, nt))
        if code == memo_code and code >= 0:
            slot, lv = memo
            nt = 1 << lv
            fu = (u0 * nt - tile_index(u0, nt)) * tiles.n_cells
            fv = (v0 * nt - tile_index(v0, nt)) * tiles.n_cells
            ci = min(int(fu), tiles.n_cells - 1)
            cj = min(int(fv), tiles.n_cells - 1)
            fx = fu - ci
            fy = fv - cj
        else:
            slot, lv, ci, cj, fx, fy = _locate(px, py, tiles, want, fallback)
            memo_code = code
            memo = (slot, lv)
        if slot == SLOT_OUTSIDE_DOMAIN:
            out_status[k] = STATUS_OUTSIDE_DOMAIN
            continue
        if slot == SLOT_DRY:
            out_status[k] = STATUS_OUTSIDE
            continue
        if slot < 0:
            out_status[k] = STATUS_UNKNOWN
            missing += 1
            continue
        last_used[slot] = tick
        cell = cell_status[slot, cj, ci]
        near_bank = cell & CELL_NEAR_BANK
        if cell & CELL_CROWDED and lv < want and tiles.in_cut[slot] == 0:
            out_status[k] = STATUS_UNKNOWN   # a stand-in too coarse here: wait for the tile
            missing += 1
            continue
        cell &= CELL_KIND
        if cell == CELL_OUTSIDE or (cell == CELL_BOUNDARY and not _boundary_inside(
                px, py, slot, ci, cj, fx, fy, tiles.cell_segments, psi_pool, segs)):
            out_status[k] = STATUS_OUTSIDE
            continue
        out_status[k] = STATUS_INSIDE
        if k >= n_velocity:
            continue
        total = 0.0
        for r in range(4):
            for q in range(4):
                val = psi_pool[slot, cj + r, ci + q]
                patch[r, q] = val
                total += val
        if math.isnan(total) and not _fill_stencil(patch):
            continue
        wx0, wx1, wx2, wx3, dx0, dx1, dx2, dx3 = _catmull_rom(fx)
        wy0, wy1, wy2, wy3, dy0, dy1, dy2, dy3 = _catmull_rom(fy)
        # ∂ψ/∂x and ∂ψ/∂y of the bicubic, in lattice units, written out (no loops, no ifs)
        r0w = _rows(wx0, wx1, wx2, wx3, patch[0, 0], patch[0, 1], patch[0, 2], patch[0, 3])
        r1w = _rows(wx0, wx1, wx2, wx3, patch[1, 0], patch[1, 1], patch[1, 2], patch[1, 3])
        r2w = _rows(wx0, wx1, wx2, wx3, patch[2, 0], patch[2, 1], patch[2, 2], patch[2, 3])
        r3w = _rows(wx0, wx1, wx2, wx3, patch[3, 0], patch[3, 1], patch[3, 2], patch[3, 3])
        r0d = _rows(dx0, dx1, dx2, dx3, patch[0, 0], patch[0, 1], patch[0, 2], patch[0, 3])
        r1d = _rows(dx0, dx1, dx2, dx3, patch[1, 0], patch[1, 1], patch[1, 2], patch[1, 3])
        r2d = _rows(dx0, dx1, dx2, dx3, patch[2, 0], patch[2, 1], patch[2, 2], patch[2, 3])
        r3d = _rows(dx0, dx1, dx2, dx3, patch[3, 0], patch[3, 1], patch[3, 2], patch[3, 3])
        gx = _rows(wy0, wy1, wy2, wy3, r0d, r1d, r2d, r3d)
        gy = _rows(dy0, dy1, dy2, dy3, r0w, r1w, r2w, r3w)
        inv_h = (1 << lv) * tiles.n_cells * inv_root
        vx = -gy * inv_h
        vy = gx * inv_h
        if near_bank:                          # a bank may be near: its correction
            _, cx, cy = _bank_correction(px, py, slot, ci, cj, fx, fy, inv_h, tiles, segs,
                                         patch)
            vx -= cy
            vy += cx
        if is_finite(vx) and is_finite(vy):
            out_velocity[k, 0] = vx
            out_velocity[k, 1] = vy
    return missing


@njit(**JIT_OPTIONS)
def sample_potential(xy, levels, level, fallback, tiles, tick, segs, out_psi):
    """Interpolated ψ [m²/s] at each point of ``xy`` (N, 2) from cached tiles into ``out_psi``
    (N,) float64: NaN outside the water, outside the domain or in an uncached tile. Levels and
    arguments as in :func:`query_velocity`. Returns the number of points with no cached tile."""
    patch = np.empty((4, 4))
    missing = 0
    psi_pool = tiles.psi
    for k in range(xy.shape[0]):
        px = xy[k, 0]
        py = xy[k, 1]
        out_psi[k] = np.nan
        slot, lv, ci, cj, fx, fy = _locate(px, py, tiles, level if level >= 0 else levels[k],
                                           fallback)
        if slot < 0:
            if slot == SLOT_MISSING:
                missing += 1
            continue
        tiles.last_used[slot] = tick
        cell = tiles.cell_status[slot, cj, ci]
        near_bank = cell & CELL_NEAR_BANK
        if cell & CELL_CROWDED and lv < (level if level >= 0 else levels[k]) \
                and tiles.in_cut[slot] == 0:
            missing += 1
            continue
        cell &= CELL_KIND
        if cell == CELL_OUTSIDE or (cell == CELL_BOUNDARY and not _boundary_inside(
                px, py, slot, ci, cj, fx, fy, tiles.cell_segments, psi_pool, segs)):
            continue
        total = 0.0
        for r in range(4):
            for q in range(4):
                val = psi_pool[slot, cj + r, ci + q]
                patch[r, q] = val
                total += val
        if math.isnan(total) and not _fill_stencil(patch):
            continue
        wx0, wx1, wx2, wx3, _, _, _, _ = _catmull_rom(fx)
        wy0, wy1, wy2, wy3, _, _, _, _ = _catmull_rom(fy)
        acc = _rows(wy0, wy1, wy2, wy3,
                    _rows(wx0, wx1, wx2, wx3, patch[0, 0], patch[0, 1], patch[0, 2], patch[0, 3]),
                    _rows(wx0, wx1, wx2, wx3, patch[1, 0], patch[1, 1], patch[1, 2], patch[1, 3]),
                    _rows(wx0, wx1, wx2, wx3, patch[2, 0], patch[2, 1], patch[2, 2], patch[2, 3]),
                    _rows(wx0, wx1, wx2, wx3, patch[3, 0], patch[3, 1], patch[3, 2], patch[3, 3]))
        if near_bank:                          # a bank may be near: its correction
            acc += _bank_correction(px, py, slot, ci, cj, fx, fy,
                                    (1 << lv) * tiles.n_cells / tiles.root_size, tiles, segs,
                                    patch)[0]
        out_psi[k] = acc
    return missing


# -- what foam reads of the flow: banks, strain, vorticity --------------------------------------


@njit(**JIT_OPTIONS)
def _catmull_rom_dd(t):
    """Second derivatives of the Catmull-Rom weights at t ∈ [0, 1]."""
    return 2.0 - 3.0 * t, 9.0 * t - 5.0, 4.0 - 9.0 * t, 3.0 * t - 1.0


@njit(inline="always", **JIT_OPTIONS)
def flow_details_at(px, py, tiles, level, fallback, shore_pool, bank_pool, patch):
    """What the flow knows at p besides its velocity, from the cached tile under it (level
    ``level``, up to ``fallback`` coarser levels when that one is not cached): returns
    (found, shore [m], ∂bank/∂x, ∂bank/∂y, strain [1/s], vorticity [1/s]).

    ``shore`` is the bilinear blend of the tile's distance lattice (``shore_pool``, the flow
    pool's "shore" column: distance to the nearest bank or island shore, 0 at dry lattice
    points); the gradient is that of the bank lattice (``bank_pool``, the pool's "bank"
    column: the same with a basin's open mouth counted as the bank it is for the flow), the
    direction away from the bank the water runs along: across a mouth the shore is the basin's
    far side or its corners, which the river passes, not runs into; strain is the principal
    strain rate of the velocity, √(ψ_xy² + ¼(ψ_xx − ψ_yy)²), vorticity ψ_xx + ψ_yy, from the
    second derivatives of the ψ bicubic (piecewise linear: the interpolant is C¹). ``patch`` is
    (4, 4) float64 scratch. found is False where no tile is cached, outside the domain or in a
    dry tile; a point in a tile but outside the water gets what the lattice extrapolates (the
    caller knows its status).
    """
    slot, lv, ci, cj, fx, fy = _locate(px, py, tiles, level, fallback)
    if slot < 0:
        return False, 0.0, 0.0, 0.0, 0.0, 0.0
    inv_h = (1 << lv) * tiles.n_cells / tiles.root_size
    s00 = shore_pool[slot, cj + 1, ci + 1]
    s10 = shore_pool[slot, cj + 1, ci + 2]
    s01 = shore_pool[slot, cj + 2, ci + 1]
    s11 = shore_pool[slot, cj + 2, ci + 2]
    shore = ((1.0 - fy) * ((1.0 - fx) * s00 + fx * s10) + fy * ((1.0 - fx) * s01 + fx * s11))
    b00 = bank_pool[slot, cj + 1, ci + 1]
    b10 = bank_pool[slot, cj + 1, ci + 2]
    b01 = bank_pool[slot, cj + 2, ci + 1]
    b11 = bank_pool[slot, cj + 2, ci + 2]
    sx = ((1.0 - fy) * (b10 - b00) + fy * (b11 - b01)) * inv_h
    sy = ((1.0 - fx) * (b01 - b00) + fx * (b11 - b10)) * inv_h
    total = 0.0
    for r in range(4):
        for q in range(4):
            val = tiles.psi[slot, cj + r, ci + q]
            patch[r, q] = val
            total += val
    if math.isnan(total) and not _fill_stencil(patch):
        return True, shore, sx, sy, 0.0, 0.0
    wx0, wx1, wx2, wx3, dx0, dx1, dx2, dx3 = _catmull_rom(fx)
    wy0, wy1, wy2, wy3, dy0, dy1, dy2, dy3 = _catmull_rom(fy)
    ex0, ex1, ex2, ex3 = _catmull_rom_dd(fx)
    ey0, ey1, ey2, ey3 = _catmull_rom_dd(fy)
    pxx = 0.0      # Σ over rows of (row weight) · (the row's x-derivative of that order)
    pyy = 0.0
    pxy = 0.0
    for r in range(4):
        a, b, c, d = patch[r, 0], patch[r, 1], patch[r, 2], patch[r, 3]
        wy = wy0 if r == 0 else (wy1 if r == 1 else (wy2 if r == 2 else wy3))
        dy = dy0 if r == 0 else (dy1 if r == 1 else (dy2 if r == 2 else dy3))
        ey = ey0 if r == 0 else (ey1 if r == 1 else (ey2 if r == 2 else ey3))
        pxx += wy * _rows(ex0, ex1, ex2, ex3, a, b, c, d)
        pyy += ey * _rows(wx0, wx1, wx2, wx3, a, b, c, d)
        pxy += dy * _rows(dx0, dx1, dx2, dx3, a, b, c, d)
    h2 = inv_h * inv_h
    pxx *= h2
    pyy *= h2
    pxy *= h2
    strain = math.sqrt(pxy * pxy + 0.25 * (pxx - pyy) * (pxx - pyy))
    vorticity = pxx + pyy
    if not (is_finite(strain) and is_finite(vorticity)):
        return True, shore, sx, sy, 0.0, 0.0
    return True, shore, sx, sy, strain, vorticity


@njit(**JIT_OPTIONS)
def sample_flow_details(xy, level, fallback, tiles, shore_pool, bank_pool, out):
    """:func:`flow_details_at` at each point of ``xy`` (N, 2) float64 [m] into ``out`` (N, 5)
    float64: shore [m], ∂bank/∂x, ∂bank/∂y, strain [1/s], vorticity [1/s]; NaN rows where
    no tile answers. Returns the number of points with no tile."""
    patch = np.empty((4, 4))
    missing = 0
    for k in range(xy.shape[0]):
        found, shore, sx, sy, strain, vort = flow_details_at(xy[k, 0], xy[k, 1], tiles, level,
                                                             fallback, shore_pool, bank_pool,
                                                             patch)
        if not found:
            missing += 1
            for c in range(5):
                out[k, c] = np.nan
            continue
        out[k, 0] = shore
        out[k, 1] = sx
        out[k, 2] = sy
        out[k, 3] = strain
        out[k, 4] = vort
    return missing
