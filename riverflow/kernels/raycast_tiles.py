"""Rays cast onto the surface tiles of the view: where a new particle lands (SPEC §8).

The same rays and the same surface as :mod:`riverflow.kernels.raycast` (first crossing from
above into max(terrain, water), bilinear patches per cell, exact quadratic roots, max-mip
skipping), but the surface is not one grid of the whole map: it is the *cut* of the quadtree
this frame's view needs (:class:`~riverflow.kernels.surface_tiles.SurfaceTiles`), each leaf a
raycast tile of (n + 1)² nodes with its own max-mip pyramid.

A ray is clipped to the root square, the scene's height range and the distance limit, then
marched leaf by leaf: in each leaf it meets, the grid walk of
:func:`riverflow.kernels.raycast._walk_grid` runs over the ray's stretch inside that leaf, on
the leaf's tile (or on the finest resident ancestor's, standing in until the leaf's own tile
is made), carrying whether the ray is above the surface from one leaf to the next.

A stretch over a leaf with no tile at all, where the ray is within the surface's height range,
may hide a hit: the ray then reports :data:`HIT_UNKNOWN` (its particle is not placed; the fill
tries again once the tile is there), never a wrong land or water hit. A ray that passes
through no leaf (outside the view's tiles) sees nothing there.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from riverflow.kernels._jit import JIT_OPTIONS
from riverflow.kernels.raycast import HIT_NONE, _clip_slab, _ray_start, _walk_grid, pyramid_layout
from riverflow.kernels.surface_tiles import NO_LEAF, find_leaf

HIT_UNKNOWN = 3
"""The ray crossed a part of the view whose surface tile is not made yet before any hit."""

_NUDGE = 1e-7
"""Step past a leaf's exit face, as a fraction of that leaf's side (so the next lookup lands in
the neighbour whatever the rounding on the face)."""


@njit(**JIT_OPTIONS)
def cast_rays_onto_tiles(
    origins,         # (N, 3) float64  ray starts [m]
    directions,      # (N, 3) float64  ray directions, any length (normalised here)
    surface,         # SurfaceTiles    this frame's cut and its raycast tiles
    max_distance_m,  # float  longest accepted hit distance along the ray [m] (inf allowed)
    out_xyz,         # (N, 3) float64  written: hit point [m]; for a miss the ray's origin, or 0
                     #                 for non-finite input: never NaN
    out_hit,         # (N,) uint8      written: HIT_NONE / HIT_LAND / HIT_WATER / HIT_UNKNOWN
):
    """First crossing of each ray into the surface of the view's tiles (module docstring).
    Returns the number of land or water hits."""
    offs, dims_x, levels = pyramid_layout(surface.n + 1, surface.n + 1)
    hits = 0
    for r in range(origins.shape[0]):
        kind = _cast_ray_tiles(origins[r, 0], origins[r, 1], origins[r, 2], directions[r, 0],
                               directions[r, 1], directions[r, 2], surface, max_distance_m,
                               offs, dims_x, levels, out_xyz, r)
        out_hit[r] = kind
        if kind != HIT_NONE and kind != HIT_UNKNOWN:
            hits += 1
    return hits


@njit(inline="always", **JIT_OPTIONS)
def _cast_ray_tiles(ox, oy, oz, dx, dy, dz, view, max_d, offs, dims_x, levels, out_xyz, r):
    out_xyz[r, 0] = 0.0
    out_xyz[r, 1] = 0.0
    out_xyz[r, 2] = 0.0
    dx, dy, dz, ok = _ray_start(ox, oy, oz, dx, dy, dz, max_d, out_xyz, r)
    if not ok or view.cut_keys.shape[0] == 0:
        return HIT_NONE
    x0 = view.root_x
    y0 = view.root_y
    side = view.root_size
    t0, t1, ok = _clip_slab(ox, dx, x0, x0 + side, 0.0, max_d)
    if ok:
        t0, t1, ok = _clip_slab(oy, dy, y0, y0 + side, t0, t1)
    zmin = view.z_min
    zmax = view.z_max
    if ok:
        pad = 1e-3 * (1.0 + abs(zmin) + abs(zmax))
        t0, t1, ok = _clip_slab(oz, dz, zmin - pad, zmax + pad, t0, t1)
    if not ok or not (t0 < t1):
        return HIT_NONE
    n = view.n
    above = -1
    t = t0
    finest = side / (1 << view.max_level)
    for _ in range(1 << 20):                       # bound only: each step moves on
        if t >= t1:
            return HIT_NONE
        px = ox + dx * t
        py = oy + dy * t
        leaf, level, tx, ty = find_leaf(view, px, py)
        if leaf == NO_LEAF:
            # not a tile of the view (beyond the frustum's tiles): skip one finest-level cell
            t = _square_exit(ox, oy, dx, dy, px, py, x0, y0, finest, t) + _NUDGE * finest
            above = -1
            continue
        size = side / (1 << level)
        t_exit = min(_square_exit(ox, oy, dx, dy, px, py, x0 + tx * size, y0 + ty * size,
                                  size, t), t1)
        slot = view.leaf_slot[leaf]
        if slot < 0:
            za = oz + dz * t
            zb = oz + dz * t_exit
            if max(za, zb) >= zmin and min(za, zb) <= zmax:
                return HIT_UNKNOWN
            above = -1
        elif t_exit > t:
            # the leaf's tile, or the ancestor's standing in (a coarser grid over the leaf)
            tile_size = side / (1 << view.leaf_key[leaf, 0])
            pyramid = view.pyramid[slot]
            top = offs[levels]
            kind, ab = _walk_grid(ox, oy, oz, dx, dy, dz, view.ground[slot], view.water[slot],
                                  x0 + view.leaf_key[leaf, 1] * tile_size,
                                  y0 + view.leaf_key[leaf, 2] * tile_size, tile_size / n,
                                  pyramid, offs, dims_x, levels, np.float64(pyramid[top, 0]),
                                  np.float64(pyramid[top, 1]), t, t_exit, above, out_xyz, r)
            if kind != HIT_NONE:
                return kind
            above = 1 if ab else 0
        t = t_exit + _NUDGE * size
    return HIT_NONE


@njit(inline="always", **JIT_OPTIONS)
def _square_exit(ox, oy, dx, dy, px, py, bx, by, size, t):
    """Distance along the unit-xy ray at which it leaves the square of side ``size`` holding
    its point (px, py) at t, on the grid of such squares through (bx, by); at least t."""
    cx = bx + math.floor((px - bx) / size) * size
    cy = by + math.floor((py - by) / size) * size
    tx = np.inf
    ty = np.inf
    if dx > 0.0:
        tx = (cx + size - ox) / dx
    elif dx < 0.0:
        tx = (cx - ox) / dx
    if dy > 0.0:
        ty = (cy + size - oy) / dy
    elif dy < 0.0:
        ty = (cy - oy) / dy
    return max(min(tx, ty), t)
