"""What to draw for a cut of the quadtree when some of its tiles are not made yet.

A view needs the leaves of a *cut* (each at the level its distance needs). A leaf whose tile
is not resident is drawn by its finest resident ancestor instead, and a tile drawn that way
covers all of its descendants, so none of them is drawn too (no overlap, no z-fighting): the
view is coarser there until the tiles arrive, never empty, never doubled.
"""
from __future__ import annotations

import numpy as np

from riverflow.kernels.surface_tiles import leaf_standins
from riverflow.tiles.cache import TilePool

_MASK = (1 << 28) - 1


def standins(cut: np.ndarray, pool: TilePool, skip: np.ndarray | None = None) -> np.ndarray:
    """(K, 3) int32 keys of the tiles of ``pool`` to use for the leaves ``cut`` (L, 3): each
    leaf's own tile or its finest resident ancestor, none for leaves with none or marked in
    ``skip`` (L,) bool (e.g. known empty), and no tile that another one listed contains."""
    cut = np.ascontiguousarray(cut, np.int32).reshape(-1, 3)
    slot = np.empty(len(cut), np.int32)
    key = np.zeros((len(cut), 3), np.int32)
    leaf_standins(cut, len(cut), pool.table.keys, pool.table.values, slot, key)
    keep = slot >= 0
    if skip is not None:
        keep &= ~skip
    k = key[keep].astype(np.int64)
    # the distinct tiles, one int64 each, in (level, tx, ty) order: (level, tx, ty) < 2^(8, 28, 28)
    tiles = np.unique((k[:, 0] << 56) | (k[:, 1] << 28) | k[:, 2])
    if not len(tiles):
        return np.zeros((0, 3), np.int32)
    level, tx, ty = tiles >> 56, (tiles >> 28) & _MASK, tiles & _MASK
    covered = np.zeros(len(tiles), bool)
    for coarse in np.unique(level)[:-1].tolist():          # each level some tile is finer than
        finer = level > coarse
        up = level[finer] - coarse
        ancestor = (coarse << 56) | ((tx[finer] >> up) << 28) | (ty[finer] >> up)
        at = np.minimum(np.searchsorted(tiles, ancestor), len(tiles) - 1)
        covered[finer] |= tiles[at] == ancestor
    return np.stack([level, tx, ty], axis=1)[~covered].astype(np.int32)
