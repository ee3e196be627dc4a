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
    found = np.unique(key[keep], axis=0)
    if not len(found):
        return found
    level = found[:, 0].astype(np.int64)
    code = (level << 56) | (found[:, 2].astype(np.int64) << 28) | found[:, 1]
    have = set(code.tolist())
    covered = np.zeros(len(found), bool)
    for up in range(1, int(level.max()) + 1):
        lv = level - up
        ok = lv >= 0
        anc = (lv << 56) | ((found[:, 2].astype(np.int64) >> up) << 28) | (found[:, 1] >> up)
        covered |= ok & np.fromiter((int(a) in have for a in anc), bool, len(anc))
    return found[~covered]
