"""Spill kernel: a tracer carried down the river network by a 1-D advection–dispersion solver.

The network is cut into cells along its links (:mod:`riverflow.hydro.spill_network`); a cell
holds a *mass* [kg] per spill, its concentration is mass / volume. One step of ``dt`` [s],
explicit, for every spill:

1. **Release**: the spill's source cell receives what its release has let out by the end of
   the step (all of it at once for an instant release, at a constant rate over its duration
   otherwise), exactly the difference to what was released before.
2. **Advection** with the link's discharge Q [m³/s] through each face between two cells of a
   link: a flux-limited second-order upwind flux (Lax–Wendroff corrected by van Leer's limiter,
   TVD), Q · (cᵢ + ½ (1 − Crᵢ) φ(rᵢ) (cᵢ₊₁ − cᵢ)); first order at a link's first and last
   face. Mass leaving a link's last cell goes to the node it drains into, or out through an
   outlet (counted per outlet).
3. **Dispersion** through the same faces: k · (cᵢ − cᵢ₊₁), k = K A / Δx [m³/s] (Fischer's K by
   default, set by the network builder). No dispersive flux crosses a node.
4. **Junctions**: links are in upstream-first order, so when a link's turn comes the mass that
   reached its start node in this step is complete; the link takes its share of it (its
   discharge over the discharges leaving the node: a bifurcation splits by discharge, a
   confluence mixes).
5. **Decay**: every cell's mass is multiplied by exp(−k dt), the loss counted.

Every flux is taken from one cell and given to another (or to a node, an outlet): mass is
conserved by construction, to rounding. A link holding no mass and receiving none is skipped
(its cells stay exactly 0). Fluxes use the concentrations at the start of the
step; the step is stable and keeps masses non-negative for Cr ≤ ½ and a diffusion number
Σk dt / V ≤ ¼ per cell (the network's ``dt_max_s``).
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from riverflow.kernels._jit import JIT_OPTIONS


class SpillNet(NamedTuple):
    """The cells of a network (N cells, B links in upstream-first order, each link's cells
    contiguous, upstream first)."""

    cell_q: np.ndarray
    """(N,) float64 discharge through the cell [m³/s] (its link's)."""
    cell_vol: np.ndarray
    """(N,) float64 volume [m³]."""
    face_k: np.ndarray
    """(N,) float64 dispersive conductance K·A/Δx [m³/s] between cell i and cell i + 1 of the
    same link (0 at a link's last cell)."""
    link_c0: np.ndarray
    """(B,) int32 first cell of each link."""
    link_c1: np.ndarray
    """(B,) int32 one past its last cell."""
    link_start: np.ndarray
    """(B,) int32 node feeding the link, −1 for a source."""
    link_end: np.ndarray
    """(B,) int32 node the link drains into, −1 for an outlet."""
    link_outlet: np.ndarray
    """(B,) int32 index of the outlet the link drains through, −1 if it ends at a node."""
    link_share: np.ndarray
    """(B,) float64 the link's share of what reaches its start node (its discharge over the
    discharges of every link leaving that node; 1 for a source)."""


class SpillBook(NamedTuple):
    """The spills' state and bookkeeping (S spills), written in place."""

    mass: np.ndarray
    """(S, N) float64 mass in each cell [kg]."""
    source_cell: np.ndarray
    """(S,) int32 the cell each spill is released into."""
    release_t0: np.ndarray
    """(S,) float64 start of the release [s of spill time]."""
    release_t1: np.ndarray
    """(S,) float64 its end (= start for an instant release)."""
    release_kg: np.ndarray
    """(S,) float64 the mass to release."""
    decay_per_s: np.ndarray
    """(S,) float64 first-order decay rate [1/s]."""
    released: np.ndarray
    """(S,) float64 released so far [kg]."""
    outflow: np.ndarray
    """(S, O) float64 mass out through each outlet so far [kg]."""
    decayed: np.ndarray
    """(S,) float64 mass decayed so far [kg]."""
    passed: np.ndarray
    """(S, B) float64 mass that has left each link through its end so far [kg] (to its end
    node or outlet)."""


@njit(**JIT_OPTIONS)
def released_by(t0, t1, total, t):
    """Mass [kg] a release of ``total`` over [t0, t1] has let out by time ``t``."""
    if t < t0:
        return 0.0
    if t >= t1:
        return total
    return total * (t - t0) / (t1 - t0)


@njit(**JIT_OPTIONS)
def spill_steps(net, book, t_start, dt, n_steps, work, node_mass):
    """Advance every spill of ``book`` by ``n_steps`` steps of ``dt`` [s] from spill time
    ``t_start`` [s] (module docstring). ``work`` (N,) and ``node_mass`` (J,) float64 are
    scratch."""
    n_spills = book.mass.shape[0]
    n_links = net.link_c0.shape[0]
    q = net.cell_q
    vol = net.cell_vol
    fk = net.face_k
    for step in range(n_steps):
        t1 = t_start + (step + 1) * dt
        for s in range(n_spills):
            target = released_by(book.release_t0[s], book.release_t1[s], book.release_kg[s], t1)
            add = target - book.released[s]
            if add > 0.0:
                book.mass[s, book.source_cell[s]] += add
                book.released[s] += add
            if book.released[s] == 0.0:
                continue
            m = book.mass[s]
            for i in range(m.shape[0]):
                work[i] = m[i]
            for j in range(node_mass.shape[0]):
                node_mass[j] = 0.0
            for b in range(n_links):
                c0 = net.link_c0[b]
                c1 = net.link_c1[b]
                n0 = net.link_start[b]
                inflow = node_mass[n0] * net.link_share[b] if n0 >= 0 else 0.0
                if inflow == 0.0:                  # a link the spill has not reached: skip
                    empty = True
                    for i in range(c0, c1):
                        if m[i] != 0.0:
                            empty = False
                            break
                    if empty:
                        continue
                work[c0] += inflow
                for i in range(c0, c1):
                    ci = m[i] / vol[i]
                    if i + 1 < c1:
                        cn = m[i + 1] / vol[i + 1]
                        dc = cn - ci
                        phi = 0.0
                        if i > c0 and dc != 0.0:
                            r = (ci - m[i - 1] / vol[i - 1]) / dc
                            phi = (r + abs(r)) / (1.0 + abs(r))
                        cr = q[i] * dt / vol[i]
                        f = dt * (q[i] * (ci + 0.5 * (1.0 - cr) * phi * dc) + fk[i] * (ci - cn))
                        work[i] -= f
                        work[i + 1] += f
                    else:
                        f = dt * q[i] * ci
                        work[i] -= f
                        book.passed[s, b] += f
                        e = net.link_end[b]
                        if e >= 0:
                            node_mass[e] += f
                        else:
                            book.outflow[s, net.link_outlet[b]] += f
            k = book.decay_per_s[s]
            if k > 0.0:
                keep = math.exp(-k * dt)
                lost = 0.0
                for i in range(m.shape[0]):
                    v = work[i] * keep
                    lost += work[i] - v
                    m[i] = v
                book.decayed[s] += lost
            else:
                for i in range(m.shape[0]):
                    m[i] = work[i]


class TintTexels(NamedTuple):
    """Where the spill tint's texels sit on the network
    (:class:`riverflow.hydro.spills.SpillTint`)."""

    wet: np.ndarray
    """(W,) int64 flat index of each wet texel."""
    cell_a: np.ndarray
    """(W,) int64 the first of the two cells interpolated at it."""
    cell_b: np.ndarray
    """(W,) int64 the second."""
    weight_b: np.ndarray
    """(W,) float64 the second cell's weight."""
    profile: np.ndarray
    """(S, W) float64 each spill's transverse profile there."""
    fringe: np.ndarray
    """(F,) int64 dry texels next to the water, which take ..."""
    fringe_from: np.ndarray
    """(F,) int64 ... the value of this wet texel."""


@njit(**JIT_OPTIONS)
def tint_texels(texels, conc, colours, out):
    """Write the tint at the wet texels and their fringe into ``out`` (T, 4) float32 (RGB:
    the concentration-weighted mean of the spills' ``colours`` (S, 3); A: the total
    concentration, each spill's ``conc`` (S, N) [kg/m³] interpolated between the texel's two
    cells times its profile). Returns (first, last + 1) of the texture rows (of
    ``row_texels`` texels: ``out`` is square) holding a texel with A > 0 ((0, 0): none)."""
    n_spills = conc.shape[0]
    side = int(math.sqrt(out.shape[0]) + 0.5)
    first, end = side, 0
    for k in range(texels.wet.shape[0]):
        a, b, w = texels.cell_a[k], texels.cell_b[k], texels.weight_b[k]
        total = 0.0
        r = 0.0
        g = 0.0
        bl = 0.0
        for s in range(n_spills):
            c = (conc[s, a] * (1.0 - w) + conc[s, b] * w) * texels.profile[s, k]
            total += c
            r += colours[s, 0] * c
            g += colours[s, 1] * c
            bl += colours[s, 2] * c
        inv = 1.0 / max(total, 1e-30)
        t = texels.wet[k]
        out[t, 0] = r * inv
        out[t, 1] = g * inv
        out[t, 2] = bl * inv
        out[t, 3] = total
        if out[t, 3] > 0.0:
            row = t // side
            first = min(first, row)
            end = max(end, row + 1)
    for k in range(texels.fringe.shape[0]):
        t, f = texels.fringe[k], texels.fringe_from[k]
        for ch in range(4):
            out[t, ch] = out[f, ch]
        if out[t, 3] > 0.0:
            row = t // side
            first = min(first, row)
            end = max(end, row + 1)
    if end == 0:
        return 0, 0
    return first, end


class TintGrid(NamedTuple):
    """The spill tint's texels (:class:`riverflow.hydro.spills.SpillTint`) as the particles
    sample them."""

    rgba: np.ndarray
    """(n, n, 4) float32: RGB the spills' concentration-weighted colour, A the concentration
    [kg/m³]; texel (row j, column i) centred at (x0 + (i + ½)·side/n, y0 + (j + ½)·side/n)."""
    rect: np.ndarray
    """(3,) float64 (x0, y0, side) [m] of the square (side 0: nothing is tinted)."""


class ParticleTint(NamedTuple):
    """The particle pool's columns that the spill tint reads and writes
    (:class:`riverflow.components.particles.ParticlePool`)."""

    alive: np.ndarray
    has_world: np.ndarray
    ids: np.ndarray
    world_m: np.ndarray
    tint: np.ndarray
    """(C, 4) float32, written: (r, g, b, c): the spills' colour and concentration [kg/m³]
    where the particle was when it last sampled."""
    tint_id: np.ndarray
    """(C,) int64, written: the id of the particle whose tint the slot holds."""


@njit(**JIT_OPTIONS)
def _tint_at(grid, x, y, out):
    """Bilinear (between texel centres, clamped at the square's edge texels as GL's linear
    filter with clamp-to-edge) of the premultiplied colour A·RGB and of A at (x, y); 0
    outside the square. Writes (r, g, b, c) into ``out`` (4,)."""
    for ch in range(4):
        out[ch] = 0.0
    x0, y0, side = grid.rect[0], grid.rect[1], grid.rect[2]
    n = grid.rgba.shape[0]
    if not side > 0.0 or not (x0 <= x <= x0 + side and y0 <= y <= y0 + side):
        return
    u = min(max((x - x0) / side * n - 0.5, 0.0), n - 1.0)
    v = min(max((y - y0) / side * n - 0.5, 0.0), n - 1.0)
    i0 = min(int(u), n - 2) if n > 1 else 0
    j0 = min(int(v), n - 2) if n > 1 else 0
    fu = u - i0
    fv = v - j0
    a = 0.0
    r = 0.0
    g = 0.0
    b = 0.0
    for dj in range(2):
        wj = fv if dj else 1.0 - fv
        j = min(j0 + dj, n - 1)
        for di in range(2):
            w = wj * (fu if di else 1.0 - fu)
            i = min(i0 + di, n - 1)
            c = w * grid.rgba[j, i, 3]
            a += c
            r += c * grid.rgba[j, i, 0]
            g += c * grid.rgba[j, i, 1]
            b += c * grid.rgba[j, i, 2]
    if a > 0.0:
        out[0] = r / a
        out[1] = g / a
        out[2] = b / a
        out[3] = a


@njit(**JIT_OPTIONS)
def sample_tint(grid, particles, n_slots, frame, every, everyone):
    """Each live particle with a world position below slot ``n_slots`` samples the spill
    tint at its position (:func:`_tint_at`) into its ``tint``: a new one (``tint_id`` not its
    id) at once, the others every ``every`` frames (a power of two; staggered by slot: slot i
    when i ≡ ``frame`` mod ``every``), or all of them when ``everyone``.
    Between samples a particle carries its tint with it. Returns the particles sampled."""
    sampled = 0
    mask = every - 1
    phase = frame & mask
    for i in range(n_slots):
        if not (particles.alive[i] and particles.has_world[i]):
            continue
        if not (everyone or particles.tint_id[i] != particles.ids[i] or (i & mask) == phase):
            continue
        _tint_at(grid, particles.world_m[i, 0], particles.world_m[i, 1], particles.tint[i])
        particles.tint_id[i] = particles.ids[i]
        sampled += 1
    return sampled
