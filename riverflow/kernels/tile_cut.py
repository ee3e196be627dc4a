"""What to draw for a cut of the quadtree (:func:`riverflow.tiles.cut.standins`), in one pass.

For each leaf of a cut: its own resident tile, or its finest resident ancestor; then the
distinct tiles in (level, tx, ty) order, less every tile that another one listed contains (an
ancestor stands in for leaves around it: its descendants are not drawn too).
:func:`near_to_far` orders a frame's tiles for drawing; :func:`coarser_across` finds the coarser
tile across each edge of every drawn tile (the terrain's stitching) and :func:`edge_parts`
picks each tile's edge index ranges for those level differences.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit

from riverflow.kernels._jit import EXACT_JIT_OPTIONS, JIT_OPTIONS
from riverflow.kernels.tile_table import table_find, tile_code

_MASK = (1 << 28) - 1


@njit(inline="always", **JIT_OPTIONS)
def _order_key(level, tx, ty):
    """(level, tx, ty) as one int64 that sorts in that order (tile codes put ty before tx)."""
    return (np.int64(level) << 56) | (np.int64(tx) << 28) | np.int64(ty)


@njit(inline="always", **JIT_OPTIONS)
def _find(sorted_keys, n, key):
    """The index of ``key`` in ``sorted_keys[:n]``, or −1 (binary search)."""
    lo, hi = 0, n
    while lo < hi:
        mid = (lo + hi) >> 1
        if sorted_keys[mid] < key:
            lo = mid + 1
        else:
            hi = mid
    return lo if lo < n and sorted_keys[lo] == key else -1


@njit(inline="always", **JIT_OPTIONS)
def _listed(sorted_keys, n, key):
    """``key`` is in ``sorted_keys[:n]``."""
    return _find(sorted_keys, n, key) >= 0


@njit(**JIT_OPTIONS)
def cut_standins(leaf_keys, n_leaves, pool_keys, pool_values, skip, out_key, out_slot,
                 out_code):
    """The tiles to draw for the leaves ``leaf_keys[:n_leaves]`` (L, 3) of a cut, from a pool's
    table (``pool_keys``, ``pool_values``: code → slot): leaves marked in ``skip`` (L,) bool
    are left out, the others give their own tile or their finest resident ancestor (none if
    none is resident); the distinct tiles, in (level, tx, ty) order, less those another listed
    tile contains. Writes each tile's key (level, tx, ty), pool slot and code into
    ``out_key`` (L, 3), ``out_slot`` (L,), ``out_code`` (L,); returns how many."""
    found = np.empty(n_leaves, np.int64)
    slot_of = np.empty(n_leaves, np.int32)
    m = 0
    for k in range(n_leaves):
        if skip[k]:
            continue
        level = np.int64(leaf_keys[k, 0])
        tx = np.int64(leaf_keys[k, 1])
        ty = np.int64(leaf_keys[k, 2])
        while level >= 0:
            slot = table_find(pool_keys, pool_values, tile_code(level, tx, ty))
            if slot >= 0:
                found[m] = _order_key(level, tx, ty)
                slot_of[m] = slot
                m += 1
                break
            level -= 1
            tx >>= 1
            ty >>= 1
    if m == 0:
        return 0
    order = np.argsort(found[:m])
    tiles = np.empty(m, np.int64)
    slots = np.empty(m, np.int32)
    u = 0
    for i in order:
        if u == 0 or found[i] != tiles[u - 1]:
            tiles[u] = found[i]
            slots[u] = slot_of[i]
            u += 1
    coarsest = tiles[0] >> 56
    out = 0
    for i in range(u):
        level = tiles[i] >> 56
        tx = (tiles[i] >> 28) & _MASK
        ty = tiles[i] & _MASK
        covered = False
        up, ax, ay = level - 1, tx >> 1, ty >> 1
        while up >= coarsest:
            if _listed(tiles, u, _order_key(up, ax, ay)):
                covered = True
                break
            up -= 1
            ax >>= 1
            ay >>= 1
        if not covered:
            out_key[out, 0] = level
            out_key[out, 1] = tx
            out_key[out, 2] = ty
            out_slot[out] = slots[i]
            out_code[out] = tile_code(level, tx, ty)
            out += 1
    return out


@njit(**EXACT_JIT_OPTIONS)
def near_to_far(slots, centres, eye, out):
    """Write ``slots`` (K,) into ``out[:K]`` ordered by the squared distance of their
    ``centres`` (K, 3) [m] from ``eye`` (3,) [m], nearest first, ties in their given order:
    ``slots[np.argsort(((centres - eye) ** 2).sum(axis=1), kind="stable")]`` (the draw
    system's near-to-far order, one call where numpy takes four), with numpy's numbers: no
    fast-math, each row summed (dx² + dy²) + dz² as numpy does."""
    n = min(slots.shape[0], centres.shape[0], out.shape[0])
    d = np.empty(n)
    for i in range(n):
        dx = centres[i, 0] - eye[0]
        dy = centres[i, 1] - eye[1]
        dz = centres[i, 2] - eye[2]
        d[i] = dx * dx + dy * dy + dz * dz
    order = np.argsort(d, kind="mergesort")
    for i in range(n):
        out[i] = slots[order[i]]


_EDGE_DX = (0, 1, 0, -1)
_EDGE_DY = (-1, 0, 1, 0)


@njit(**JIT_OPTIONS)
def coarser_across(keys, out):
    """For each of the drawn tiles ``keys`` (K, 3) int64 (level, tx, ty) — quadtree tiles none
    of which contains another, in any order — write into ``out`` (K, 4) int64 the row of the
    tile across each edge (south, east, north, west:
    :data:`riverflow.scenes.meshes.EDGE_OFFSETS`) when that tile is coarser; −1 where the
    neighbour is as fine or finer (the same tile drawn, or one of its descendants), none is
    drawn there, or the edge is the map's. A tile coarser than the tile across an edge covers
    the whole edge: the nearest drawn ancestor of the same-level neighbour answers. Binary
    searches in the sorted keys and in the sorted strict ancestors of the drawn tiles."""
    k = keys.shape[0]
    order_keys = np.empty(k, np.int64)
    depth = 0
    for r in range(k):
        order_keys[r] = _order_key(keys[r, 0], keys[r, 1], keys[r, 2])
        depth += keys[r, 0]
    order = np.argsort(order_keys, kind="mergesort")
    drawn = order_keys[order]
    above = np.empty(max(depth, 1), np.int64)      # every drawn tile's strict ancestors
    n = 0
    for r in range(k):
        level, tx, ty = keys[r, 0], keys[r, 1], keys[r, 2]
        for up in range(1, level + 1):
            above[n] = _order_key(level - up, tx >> up, ty >> up)
            n += 1
    above = np.sort(above[:n])
    for r in range(k):
        level, tx, ty = keys[r, 0], keys[r, 1], keys[r, 2]
        side = np.int64(1) << level
        for e in range(4):
            out[r, e] = -1
            x, y = tx + _EDGE_DX[e], ty + _EDGE_DY[e]
            if x < 0 or y < 0 or x >= side or y >= side:
                continue                                # the edge of the map
            same = _order_key(level, x, y)
            if _find(drawn, k, same) >= 0 or _find(above, n, same) >= 0:
                continue                                # as fine, or finer
            for up in range(1, level + 1):
                found = _find(drawn, k, _order_key(level - up, x >> up, y >> up))
                if found >= 0:
                    out[r, e] = order[found]
                    break


class EdgeParts(NamedTuple):
    """The terrain tiles' index ranges by edge (:func:`edge_parts`). ``lut_counts`` (U, 4, M)
    int32 and ``lut_offsets`` (U, 4, M) int64: by level difference 0 … U − 1 (all beyond: the
    last), edge and mesh, the index count and first index's byte offset of that edge variant;
    ``counts`` (S, M, 5) int32 and ``offsets`` (S, M, 5) int64: by arena slot and mesh, the
    five ranges (core, then the four edges) each tile draws, written for the edges."""
    lut_counts: np.ndarray
    lut_offsets: np.ndarray
    counts: np.ndarray
    offsets: np.ndarray


@njit(**JIT_OPTIONS)
def edge_parts(keys, across, aslots, parts):
    """For the drawn tiles ``keys`` (K, 3) int64 and their :func:`coarser_across` rows
    ``across`` (K, 4) int64, write into ``parts.counts`` and ``parts.offsets`` at rows
    ``aslots`` (K,) int32 (each tile's arena slot), columns 1 … 4, the edge variant of each
    edge for its level difference (the level of the tile minus that of the coarser tile
    across, 0 where none is coarser; clamped to the tables' last); return the largest level
    difference (beyond the tables' last: the tile's vertices need stitching)."""
    last = parts.lut_counts.shape[0] - 1
    meshes = parts.lut_counts.shape[2]
    worst = 0
    for r in range(keys.shape[0]):
        a = aslots[r]
        for e in range(4):
            m = across[r, e]
            up = 0 if m < 0 else keys[r, 0] - keys[m, 0]
            if up > worst:
                worst = up
            u = min(up, last)
            for mesh in range(meshes):
                parts.counts[a, mesh, 1 + e] = parts.lut_counts[u, e, mesh]
                parts.offsets[a, mesh, 1 + e] = parts.lut_offsets[u, e, mesh]
    return worst
