"""Flood kernel: discharge routed down the river network by the kinematic wave.

The network is the spill network's (:mod:`riverflow.hydro.spill_network`): links in
upstream-first order, each cut into cells of length Δx, junctions as nodes. Each cell holds its
cross-section relative to base flow, a = A / A₀. With a wide channel and Manning's law
(Q ∝ W h^(5/3) √S / n) a cell's discharge is Q = Q₀ a^(5/3), its depth h = h₀ a, its mean
speed U = U₀ a^(2/3) and the kinematic-wave celerity dQ/dA = (5/3) U. Slope and roughness cancel in
these ratios: the base state (Q₀, h₀, W) carries them.

One explicit step of ``dt`` [s], conservative first-order upwind (the kinematic wave has no
upstream influence, so the upwind flux is the exact Godunov flux; a rising step becomes a
shock that travels at the Rankine–Hugoniot speed ΔQ / ΔA):

1. every cell's outflow Q_i = Q₀ a_i^(5/3) from the state at the start of the step;
2. links in upstream-first order: a link's inflow is the outflow its start node received in
   this step times its share (a confluence adds, a bifurcation splits by base discharge), or,
   for a source link, its base discharge; a hydrograph on a link replaces its inflow
   (a dam's release: the water above it is held);
3. A₀ Δa = dt / Δx (Q_in − Q_out) per cell.

Stable for a Courant number c dt / Δx ≤ 1 in every cell (the router picks dt).
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit

from riverflow.kernels._jit import JIT_OPTIONS


class FloodNet(NamedTuple):
    """The cells of a network for the flood (N cells, B links in upstream-first order)."""

    cell_area0: np.ndarray
    """(N,) float64 base cross-section A₀ = W h₀ [m²]."""
    link_q0: np.ndarray
    """(B,) float64 base discharge Q₀ [m³/s] of each link."""
    link_dx: np.ndarray
    """(B,) float64 cell length [m]."""
    link_c0: np.ndarray
    """(B,) int32 first cell of each link."""
    link_c1: np.ndarray
    """(B,) int32 one past its last cell."""
    link_start: np.ndarray
    """(B,) int32 node feeding the link, −1 for a source."""
    link_end: np.ndarray
    """(B,) int32 node the link drains into, −1 for an outlet."""
    link_share: np.ndarray
    """(B,) float64 the link's share of what reaches its start node."""


class Hydrographs(NamedTuple):
    """H hydrographs: inflow [m³/s] at the start of a link, piecewise linear in time, held
    at its ends."""

    link: np.ndarray
    """(H,) int32 the link whose inflow each replaces."""
    start: np.ndarray
    """(H + 1,) int32 offsets of each hydrograph's points in ``times``/``q``."""
    times: np.ndarray
    """(T,) float64 strictly increasing within a hydrograph [s of world time]."""
    q: np.ndarray
    """(T,) float64 discharge ≥ 0 [m³/s]."""


@njit(**JIT_OPTIONS)
def hydrograph_at(h, k, t):
    """Hydrograph k of ``h`` at time ``t`` (linear between points, held beyond its ends)."""
    i0 = h.start[k]
    i1 = h.start[k + 1]
    if t <= h.times[i0]:
        return h.q[i0]
    if t >= h.times[i1 - 1]:
        return h.q[i1 - 1]
    lo = i0
    hi = i1 - 1
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if h.times[mid] <= t:
            lo = mid
        else:
            hi = mid
    w = (t - h.times[lo]) / (h.times[hi] - h.times[lo])
    return h.q[lo] + w * (h.q[hi] - h.q[lo])


@njit(**JIT_OPTIONS)
def flood_steps(net, hydro, a, t_start, dt, n_steps, outflow, node_q, inflow):
    """Advance the relative cross-sections ``a`` (N,) by ``n_steps`` steps of ``dt`` [s] from
    world time ``t_start`` [s] (module docstring). ``outflow`` (N,), ``node_q`` (J,) and
    ``inflow`` (B,) float64 are scratch; ``inflow`` holds the last step's link inflows."""
    n_links = net.link_c0.shape[0]
    n_hydro = hydro.link.shape[0]
    for step in range(n_steps):
        t = t_start + step * dt
        for b in range(n_links):
            q0 = net.link_q0[b]
            for i in range(net.link_c0[b], net.link_c1[b]):
                outflow[i] = q0 * a[i] ** (5.0 / 3.0)
        for j in range(node_q.shape[0]):
            node_q[j] = 0.0
        for b in range(n_links):
            c0 = net.link_c0[b]
            c1 = net.link_c1[b]
            last = c1 - 1
            e = net.link_end[b]
            if e >= 0:
                node_q[e] += outflow[last]
        for b in range(n_links):
            n0 = net.link_start[b]
            inflow[b] = node_q[n0] * net.link_share[b] if n0 >= 0 else net.link_q0[b]
        for k in range(n_hydro):       # a hydrograph's value at the step's start (explicit)
            inflow[hydro.link[k]] = hydrograph_at(hydro, k, t)
        for b in range(n_links):
            c0 = net.link_c0[b]
            c1 = net.link_c1[b]
            r = dt / net.link_dx[b]
            upstream = inflow[b]
            for i in range(c0, c1):
                a[i] += r * (upstream - outflow[i]) / net.cell_area0[i]
                if a[i] < 0.0:
                    a[i] = 0.0
                upstream = outflow[i]


class CellRaster(NamedTuple):
    """Which cell a point of the plane reads its flood state from: a sparse raster of square
    pixels around the centre lines, in blocks of ``block_px`` × ``block_px`` pixels. Each
    pixel holds the cell coordinate p = c + w of its centre (the nearest centre-line sample's
    two cells c, c + 1 and the weight w of the second, :meth:`SpillNetwork.weights`), −1 for
    none; a block not near any centre line is absent (``blocks`` −1)."""

    x0: float
    """West edge of block (0, 0) [m]."""
    y0: float
    """South edge of block (0, 0) [m]."""
    pixel_m: float
    """Pixel side [m]."""
    block_px: int
    """Pixels along a block's side."""
    blocks: np.ndarray
    """(BY, BX) int32 each block's index in ``cells``, −1: absent."""
    cells: np.ndarray
    """(K, block_px, block_px) float64 each pixel's cell coordinate c + w, −1: none."""


@njit(inline="always", **JIT_OPTIONS)
def raster_cell(raster, x, y):
    """The cell coordinate c + w at (x, y) [m], or −1 where the raster has none."""
    fx = (x - raster.x0) / raster.pixel_m
    fy = (y - raster.y0) / raster.pixel_m
    if not (fx >= 0.0 and fy >= 0.0):              # also NaN
        return -1.0
    if fx >= raster.blocks.shape[1] * raster.block_px \
            or fy >= raster.blocks.shape[0] * raster.block_px:
        return -1.0
    ix = int(fx)
    iy = int(fy)
    bx = ix // raster.block_px
    by = iy // raster.block_px
    k = raster.blocks[by, bx]
    if k < 0:
        return -1.0
    return raster.cells[k, iy - by * raster.block_px, ix - bx * raster.block_px]


@njit(**JIT_OPTIONS)
def scale_by_cells(xy, velocity, n, raster, factor, missed):
    """Multiply the nonzero velocities (N, 2) float32 of the first ``n`` points ``xy``
    (N, 2) float64 [m] by the per-cell ``factor`` (C,) float64 interpolated at their raster
    cell coordinate (:class:`CellRaster`), in place. Points the raster does not cover are
    left as they are and listed in ``missed`` (int64, ≥ n long); returns how many."""
    n_missed = 0
    last = factor.shape[0] - 1
    for i in range(n):
        vx = velocity[i, 0]
        vy = velocity[i, 1]
        if vx == 0.0 and vy == 0.0:
            continue
        p = raster_cell(raster, xy[i, 0], xy[i, 1])
        if p < 0.0:
            missed[n_missed] = i
            n_missed += 1
            continue
        c = int(p)
        w = p - c
        f = factor[c]
        if w > 0.0 and c < last:
            f = f * (1.0 - w) + factor[c + 1] * w
        velocity[i, 0] = vx * f
        velocity[i, 1] = vy * f
    return n_missed


@njit(**JIT_OPTIONS)
def sample_by_cells(xy, n, raster, values, fill, out):
    """``out[i]`` = the per-cell ``values`` (C,) interpolated at the raster cell coordinate
    of point ``xy[i]`` for the first ``n`` points, ``fill`` where the raster has none;
    returns how many had none."""
    n_missed = 0
    last = values.shape[0] - 1
    for i in range(n):
        p = raster_cell(raster, xy[i, 0], xy[i, 1])
        if p < 0.0:
            out[i] = fill
            n_missed += 1
            continue
        c = int(p)
        w = p - c
        f = values[c]
        if w > 0.0 and c < last:
            f = f * (1.0 - w) + values[c + 1] * w
        out[i] = f
    return n_missed
