"""Which tiles a set of capsules (segments widened by a radius) touches, at every level.

Used to know, without making them, which tiles hold no river at all (dry flow tiles answer
OUTSIDE; dry tiles need no water level, no water mesh): the touched tiles of the finest level
are found by rasterising each segment's box, and a coarser tile is touched when one of its
children is. Cost and memory grow with the length of the network, never with the area.
"""
from __future__ import annotations

import numpy as np

from riverflow.tiles.quadtree import Quadtree
from riverflow.tiles.table import TileTable

_MAX_PER_BATCH = 1 << 22


def unique_codes(codes: np.ndarray) -> np.ndarray:
    """Sorted unique int64 tile codes, by sorting. numpy >= 2.3's ``np.unique`` hashes int64
    values, and tile codes (level << 56 | ty << 28 | tx) differ in their high bits: its table
    collides (1000 km scene's flow coverage: 0.4 s against 0.02 s for 700,000 codes)."""
    c = np.sort(np.asarray(codes, np.int64).ravel())
    if len(c) < 2:
        return c
    keep = np.empty(len(c), np.bool_)
    keep[0] = True
    np.not_equal(c[1:], c[:-1], out=keep[1:])
    return c[keep]


def touched_codes(quadtree: Quadtree, segments_m: np.ndarray, radius_m: np.ndarray | float,
                  level: int) -> np.ndarray:
    """Sorted unique codes of the tiles of ``level`` that the boxes of the capsules touch.

    Args:
        segments_m: (S, 4) float64 [m] ax, ay, bx, by.
        radius_m: (S,) or scalar [m] each capsule's radius.
    """
    seg = np.asarray(segments_m, np.float64).reshape(-1, 4)
    if not len(seg):
        return np.zeros(0, np.int64)
    radius = np.broadcast_to(np.asarray(radius_m, np.float64), (len(seg),))
    size = quadtree.tile_size_m(level)
    side = 1 << level
    # split long segments so that each piece's box stays close to its capsule
    length = np.hypot(seg[:, 2] - seg[:, 0], seg[:, 3] - seg[:, 1])
    pieces = np.maximum(np.ceil(length / size), 1).astype(np.int64)
    owner = np.repeat(np.arange(len(seg)), pieces)
    k = np.arange(len(owner)) - np.repeat(np.cumsum(pieces) - pieces, pieces)
    t0 = k / pieces[owner]
    t1 = (k + 1) / pieces[owner]
    s = seg[owner]
    ax = s[:, 0] + t0 * (s[:, 2] - s[:, 0])
    ay = s[:, 1] + t0 * (s[:, 3] - s[:, 1])
    bx = s[:, 0] + t1 * (s[:, 2] - s[:, 0])
    by = s[:, 1] + t1 * (s[:, 3] - s[:, 1])
    r = radius[owner]
    i0 = np.clip(np.floor((np.minimum(ax, bx) - r - quadtree.root_x_m) / size), 0, side - 1)
    i1 = np.clip(np.floor((np.maximum(ax, bx) + r - quadtree.root_x_m) / size), 0, side - 1)
    j0 = np.clip(np.floor((np.minimum(ay, by) - r - quadtree.root_y_m) / size), 0, side - 1)
    j1 = np.clip(np.floor((np.maximum(ay, by) + r - quadtree.root_y_m) / size), 0, side - 1)
    inside = ((np.maximum(ax, bx) + r >= quadtree.root_x_m)
              & (np.minimum(ax, bx) - r <= quadtree.root_x_m + quadtree.root_size_m)
              & (np.maximum(ay, by) + r >= quadtree.root_y_m)
              & (np.minimum(ay, by) - r <= quadtree.root_y_m + quadtree.root_size_m))
    i0, i1, j0, j1 = (a[inside].astype(np.int64) for a in (i0, i1, j0, j1))
    nx, ny = i1 - i0 + 1, j1 - j0 + 1
    count = nx * ny
    out = []
    start = 0
    bounds = np.cumsum(count)
    while start < len(count):  # in batches: a wide river at a fine level makes many tiles
        stop = int(np.searchsorted(bounds, (bounds[start - 1] if start else 0) + _MAX_PER_BATCH,
                                   side="right"))
        stop = max(stop, start + 1)
        c = count[start:stop]
        piece = np.repeat(np.arange(start, stop), c)
        q = np.arange(len(piece)) - np.repeat(np.cumsum(c) - c, c)
        ii = i0[piece] + q % nx[piece]
        jj = j0[piece] + q // nx[piece]
        out.append(unique_codes((np.int64(level) << 56) | (jj << 28) | ii))
        start = stop
    return unique_codes(np.concatenate(out)) if out else np.zeros(0, np.int64)


def with_ancestors(codes: np.ndarray) -> np.ndarray:
    """The codes and every ancestor's code, up to level 0 (sorted, unique). The codes may be
    of mixed levels (a view's cut): each one's ancestors are taken from its own level."""
    c = unique_codes(codes)
    if not len(c):
        return c
    mask = np.int64((1 << 28) - 1)
    lv = c >> 56
    tx, ty = c & mask, (c >> 28) & mask
    up = np.arange(int(lv.max()) + 1, dtype=np.int64)[None, :]   # 0: the code itself
    alv = lv[:, None] - up
    anc = (alv << 56) | ((ty[:, None] >> up) << 28) | (tx[:, None] >> up)
    return unique_codes(anc[alv >= 0])


def coverage_table(quadtree: Quadtree, segments_m: np.ndarray, radius_m, level: int
                   ) -> TileTable:
    """A table holding (value 1) every tile of levels 0 … ``level`` that the capsules touch."""
    codes = with_ancestors(touched_codes(quadtree, segments_m, radius_m, level))
    table = TileTable(len(codes))
    table.set_many(codes, 1)
    return table
