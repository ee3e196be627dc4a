"""The flow in a lake: the potential flow from its inlets to its outlets (issue 22).

Proland's ψ interpolation (a weighted mean of the shores' ψ, reference §2) is made for
channels: in a wide lake it bends sharply near the shore (the weights go as 1/d), and the ψ
lattice, a few metres coarse, then crosses the shore by about 10 % of the speed a metre in.
In a lake the flow is the slow *potential* flow instead: ψ solves Laplace's equation on the
lake's polygon,

    ∇²ψ = 0 in the lake,  ψ = ψ_b on each piece of shore (its banks' ψ),
    ψ = Proland's ψ along each mouth (the river's own ψ across it),
    ψ = c_k on island k's shore, c_k such that the circulation around the island is zero,

so the flow is irrotational, divergence-free, tangent to every shore and smooth up to it.

One mechanism: the solution is sampled at the lattice points of the flow tiles
(:meth:`LakeGrid.lattice_psi`), replacing Proland's ψ there before the tile's ghosts are
extrapolated (:class:`riverflow.hydro.flow_field.TileBuilder`); queries, particles, the bank
correction and the tiles' borders are those of the rivers.

The grid is the flow field's finest lattice (or, for a lake of more than MAX_NODES lattice
points, the lattice of the finest level coarse enough), so the lattice points of every level
at or above it are nodes of the solution; finer lattice points take the bilinear value of
the nearest lake nodes. Near the shore the five-point Laplacian uses the Shortley–Weller arms
(the distance to where each grid line crosses the shore and ψ there), second-order accurate up
to the shore; the sparse system is solved with SciPy's SuperLU.
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import shapely

from riverflow.hydro.graph import GraphError, HydroGraph

MAX_NODES = 1_500_000
"""Largest lake grid solved at the finest lattice; beyond it the grid is coarsened by 2."""
MIN_ARM = 1e-3
"""Shortest Shortley–Weller arm, in grid spacings (a node on the shore)."""

_DIRS = ((1, 0), (-1, 0), (0, 1), (0, -1))


@dataclass
class LakeGrid:
    """One lake's ψ on lattice-aligned nodes: node (a, b) lies at the flow field's root
    origin + ((i0 + a)·h, (j0 + b)·h); ``psi`` (ny, nx) float64 [m²/s], NaN outside the lake;
    ``inside`` (ny, nx) bool; ``island_psi``: ψ on each island's shore."""

    area: int
    root_x_m: float
    root_y_m: float
    h: float
    i0: int
    j0: int
    psi: np.ndarray
    inside: np.ndarray
    island_psi: list[float] = field(default_factory=list)

    @property
    def box_m(self) -> tuple[float, float, float, float]:
        ny, nx = self.psi.shape
        return (self.root_x_m + self.i0 * self.h, self.root_y_m + self.j0 * self.h,
                self.root_x_m + (self.i0 + nx - 1) * self.h,
                self.root_y_m + (self.j0 + ny - 1) * self.h)

    def lattice_psi(self, gi: np.ndarray, gj: np.ndarray, spacing_m: float) -> np.ndarray:
        """ψ at the lattice points (gi[b], gj[a]) of a lattice of ``spacing_m`` on the same
        root (integer indices (M,) each): (len(gj), len(gi)) float64, NaN where the point is
        not a lake point (its nearest node is outside the lake)."""
        ratio = spacing_m / self.h
        u = np.asarray(gi, np.float64) * ratio - self.i0
        v = np.asarray(gj, np.float64) * ratio - self.j0
        if ratio >= 1.0:
            u, v = np.rint(u), np.rint(v)          # exact: a coarser level's points are nodes
        return self._bilinear(u[None, :] + 0.0 * v[:, None], v[:, None] + 0.0 * u[None, :])

    def sample(self, xy: np.ndarray) -> np.ndarray:
        """ψ at points (N, 2) [m] (bilinear over the lake nodes), NaN off the lake."""
        xy = np.asarray(xy, np.float64).reshape(-1, 2)
        return self._bilinear((xy[:, 0] - self.root_x_m) / self.h - self.i0,
                              (xy[:, 1] - self.root_y_m) / self.h - self.j0)

    def _bilinear(self, u: np.ndarray, v: np.ndarray) -> np.ndarray:
        ny, nx = self.psi.shape
        out = np.full(u.shape, np.nan)
        near_i, near_j = np.rint(u).astype(np.int64), np.rint(v).astype(np.int64)
        ok = (near_i >= 0) & (near_i < nx) & (near_j >= 0) & (near_j < ny)
        ok[ok] = self.inside[near_j[ok], near_i[ok]]
        if not ok.any():
            return out
        uu, vv = u[ok], v[ok]
        a = np.clip(np.floor(uu).astype(np.int64), 0, nx - 2)
        b = np.clip(np.floor(vv).astype(np.int64), 0, ny - 2)
        fx, fy = uu - a, vv - b
        acc = np.zeros(len(uu))
        wsum = np.zeros(len(uu))
        for da, db, w in ((0, 0, (1 - fx) * (1 - fy)), (1, 0, fx * (1 - fy)),
                          (0, 1, (1 - fx) * fy), (1, 1, fx * fy)):
            inn = self.inside[b + db, a + da]
            w = np.where(inn, w, 0.0)
            acc += w * np.where(inn, self.psi[b + db, a + da], 0.0)
            wsum += w
        out[ok] = acc / np.maximum(wsum, 1e-300)
        return out


def _pieces(graph: HydroGraph, area: int, tolerance_m: float):
    """The lake's outline: (exterior ring (M, 2), [LineString], ψ of each piece (NaN for a
    mouth), for each mouth the ψ of the shore pieces before and after it (NaN for a bank))."""
    lines, values, ring = [], [], []
    for c, o in graph.areas[area].curves:
        p = graph.polyline(c, tolerance_m)
        p = p[::-1] if o else p
        ring.append(p[:-1])
        curve = graph.curves[c]
        lines.append(shapely.LineString(p))
        values.append(curve.potential if curve.is_bank and curve.has_potential else np.nan)
    values = np.asarray(values)
    ends = np.full((len(values), 2), np.nan)
    for k in np.flatnonzero(np.isnan(values)):
        ends[k] = values[k - 1], values[(k + 1) % len(values)]
    return np.vstack(ring), lines, values, ends


def lake_islands(graph: HydroGraph, area: int, tolerance_m: float, starts=None) -> list[int]:
    """The areas that are islands in lake ``area`` (loops inside its outline, odd winding:
    a loop's vertex inside it, not a point inside the loop: a pond on a river's island is
    inside the loops of the river and the island). ``starts``: :func:`loop_starts` of the
    graph, made once for all its lakes."""
    from riverflow.hydro.areas import area_ring

    areas, first = starts if starts is not None else loop_starts(graph, tolerance_m)
    outline = shapely.Polygon(area_ring(graph, area, tolerance_m))
    other = areas != area
    inside = shapely.contains_xy(outline, first[other, 0], first[other, 1])
    return areas[other][inside].tolist()


def loop_starts(graph: HydroGraph, tolerance_m: float) -> tuple[np.ndarray, np.ndarray]:
    """(the areas that are not lakes and whose loops have 3 points or more (K,), each loop's
    first point (K, 2) [m]): what :func:`lake_islands` tests."""
    from riverflow.hydro.areas import area_ring

    areas, first = [], []
    for a in range(len(graph.areas)):
        if graph.areas[a].is_lake:
            continue
        ring = area_ring(graph, a, tolerance_m)
        if len(ring) >= 3:
            areas.append(a)
            first.append(ring[0])
    return np.asarray(areas, np.int64), np.asarray(first, np.float64).reshape(-1, 2)


def set_island_potentials(graph: HydroGraph, tolerance_m: float, nodes: int = 40_000) -> None:
    """Give the shore of every island in a lake the ψ of zero circulation around it (the
    potential flow goes by both sides of it in the ratio of the sides' conductances), solved
    on a grid of about ``nodes`` points with ψ linear across the mouths. Sets the island
    curves' ``potential`` in ``graph``."""
    from riverflow.hydro.areas import area_ring

    starts = None
    for k in graph.lakes():
        starts = loop_starts(graph, tolerance_m) if starts is None else starts
        isl = lake_islands(graph, k, tolerance_m, starts)
        if not isl:
            continue
        ring, _, values, _ = _pieces(graph, k, tolerance_m)
        if len(set(values[np.isfinite(values)].tolist())) < 2:
            psi = [float(values[np.isfinite(values)][0])] * len(isl) if np.isfinite(values).any() \
                else [0.0] * len(isl)
        else:
            h = np.sqrt(shapely.Polygon(ring).area / nodes)
            grid = solve_lake(graph, k, (0.0, 0.0), h, None, tolerance_m,
                              [area_ring(graph, a, tolerance_m) for a in isl], max_nodes=4 * nodes)
            psi = grid.island_psi
        for a, v in zip(isl, psi):
            for c, _ in graph.areas[a].curves:
                if graph.curves[c].is_bank:
                    graph.curves[c].potential = float(v)


def solve_lake(graph: HydroGraph, area: int, root_xy: tuple[float, float], finest_m: float,
               mouth_psi: Callable[[np.ndarray], np.ndarray] | None, tolerance_m: float,
               islands: list[np.ndarray] = (), island_values: list[float] | None = None,
               max_nodes: int = MAX_NODES) -> LakeGrid:
    """ψ of the potential flow in lake ``area`` (module docstring) on the lattice of spacing
    ``finest_m`` (or 2ᵏ·``finest_m``) rooted at ``root_xy``. ``mouth_psi``: Proland's ψ at
    points (N, 2) on the mouths (None: linear between the shore pieces beside each mouth);
    ``islands``: rings (M, 2) of the islands in the lake, with their ψ ``island_values`` or,
    None, the ψ of zero circulation round each (:attr:`LakeGrid.island_psi`)."""
    from scipy import sparse
    from scipy.sparse.linalg import splu

    ring, lines, values, mouth_ends = _pieces(graph, area, tolerance_m)
    n_pieces = len(values)
    poly = shapely.Polygon(ring, [np.asarray(r) for r in islands])
    if not poly.is_valid or poly.area <= 0.0:
        raise GraphError(f"lake area {area}: its outline is not a valid polygon "
                         f"({shapely.is_valid_reason(poly)})")
    for r in islands:
        lines.append(shapely.LineString(np.vstack([r, r[:1]])))
    if island_values is not None:
        values = np.r_[values, np.asarray(island_values, np.float64)]
        island_of_piece = np.full(len(values), -1)
        n_islands = 0
    else:
        n_islands = len(islands)
        island_of_piece = np.r_[np.full(len(values), -1), np.arange(n_islands)]
        values = np.r_[values, np.zeros(n_islands)]
    x0, y0, x1, y1 = poly.bounds
    rx, ry = root_xy
    h = float(finest_m)
    while ((x1 - x0) / h + 4) * ((y1 - y0) / h + 4) > max_nodes:
        h *= 2.0
    i0 = int(np.floor((x0 - rx) / h)) - 1
    j0 = int(np.floor((y0 - ry) / h)) - 1
    nx = int(np.ceil((x1 - rx) / h)) + 2 - i0
    ny = int(np.ceil((y1 - ry) / h)) + 2 - j0
    gx = rx + (i0 + np.arange(nx)) * h
    gy = ry + (j0 + np.arange(ny)) * h
    X, Y = np.meshgrid(gx, gy)
    inside = shapely.contains_xy(poly, X, Y)
    inside[[0, -1], :] = False
    inside[:, [0, -1]] = False
    n = int(inside.sum())
    if n == 0:
        raise GraphError(f"lake area {area}: narrower than its lattice spacing {h:g} m")
    index = np.full(inside.shape, -1, np.int64)
    index[inside] = np.arange(n)
    jj, ii = np.nonzero(inside)
    boundary = poly.boundary
    tree = shapely.STRtree(lines)
    arms, nbr, gval, gisl = [], [], [], []
    for di, dj in _DIRS:
        to_i, to_j = ii + di, jj + dj
        wet = inside[to_j, to_i]
        arm = np.ones(n)
        g = np.zeros(n)
        isl = np.full(n, -1)
        dry = np.flatnonzero(~wet)
        if len(dry):
            a = np.c_[gx[ii[dry]], gy[jj[dry]]]
            b = np.c_[gx[to_i[dry]], gy[to_j[dry]]]
            cross = shapely.intersection(shapely.linestrings(np.stack([a, b], axis=1)), boundary)
            pts, which = shapely.get_coordinates(cross, return_index=True)
            best = np.full(len(dry), np.inf)
            hit = b.copy()                        # no crossing found: the neighbour is on it
            if len(pts):
                d = np.hypot(*(pts - a[which]).T)
                order = np.lexsort((d, which))
                first = np.r_[True, which[order][1:] != which[order][:-1]]
                k = order[first]
                best[which[k]] = d[k]
                hit[which[k]] = pts[k]
            arm[dry] = np.clip(np.where(np.isfinite(best), best / h, 1.0), MIN_ARM, 1.0)
            near = tree.query_nearest(shapely.points(hit), all_matches=False)
            piece = np.empty(len(dry), np.int64)
            piece[near[0]] = near[1]
            val = values[piece].copy()
            isl[dry] = island_of_piece[piece]
            mouth = np.isnan(val)
            if mouth.any() and mouth_psi is not None:
                val[mouth] = mouth_psi(hit[mouth])
            elif mouth.any():
                for q in np.flatnonzero(mouth):
                    line = lines[piece[q]]
                    t = line.project(shapely.Point(hit[q]), normalized=True)
                    a0, a1 = mouth_ends[piece[q]]
                    val[q] = a0 + t * (a1 - a0)
            if not np.isfinite(val).all():
                raise GraphError(f"lake area {area}: no ψ at {int((~np.isfinite(val)).sum())} "
                                 f"shore point(s) (a mouth outside its river?)")
            g[dry] = val
        arms.append(arm)
        nbr.append(np.where(wet, index[to_j, to_i], -1))
        gval.append(g)
        gisl.append(isl)
    rows, cols, data = [], [], []
    rhs = np.zeros((n, 1 + n_islands))
    diag = np.zeros(n)
    for (pa, pb) in ((0, 1), (2, 3)):
        for me, other in ((pa, pb), (pb, pa)):
            c = 2.0 / (arms[me] * (arms[me] + arms[other]))
            diag -= c
            wet = nbr[me] >= 0
            rows.append(np.flatnonzero(wet))
            cols.append(nbr[me][wet])
            data.append(c[wet])
            shore = ~wet & (gisl[me] < 0)
            rhs[shore, 0] -= c[shore] * gval[me][shore]
            for k in range(n_islands):
                on = ~wet & (gisl[me] == k)
                rhs[on, 1 + k] -= c[on]
    rows.append(np.arange(n))
    cols.append(np.arange(n))
    data.append(diag)
    A = sparse.csc_matrix((np.concatenate(data), (np.concatenate(rows), np.concatenate(cols))),
                          shape=(n, n))
    # (minimum degree on AᵀA's pattern, which is A's here: half COLAMD's fill, as fast)
    sol = splu(A, permc_spec="MMD_AT_PLUS_A").solve(rhs)
    psi_nodes = sol[:, 0]
    island_psi: list[float] = []
    if n_islands:
        # zero circulation around each island: the flux of ∇ψ into island k, a linear function
        # of the islands' ψ (superposition of the solutions with ψ = 1 on one island)
        flux = np.zeros((n_islands, 1 + n_islands))
        for me in range(4):
            wet = nbr[me] >= 0
            for k in range(n_islands):
                on = ~wet & (gisl[me] == k)
                if not on.any():
                    continue
                w = 1.0 / arms[me][on]
                base = np.zeros(1 + n_islands)
                base[1 + k] = 1.0
                base[0] = 0.0
                # (ψ_island − ψ_node) / arm, for every right-hand side
                vals = base[None, :] - sol[on]
                flux[k] += (w[:, None] * vals).sum(axis=0)
        c_k = np.linalg.solve(flux[:, 1:], -flux[:, 0])
        psi_nodes = sol[:, 0] + sol[:, 1:] @ c_k
        island_psi = [float(v) for v in c_k]
    psi = np.full(inside.shape, np.nan)
    psi[inside] = psi_nodes
    return LakeGrid(area, rx, ry, h, i0, j0, psi, inside, island_psi)
