"""What to draw for a cut of the quadtree when some of its tiles are not made yet.

A view needs the leaves of a *cut* (each at the level its distance needs). A leaf whose tile
is not resident is drawn by its finest resident ancestor instead, and a tile drawn that way
covers all of its descendants, so none of them is drawn too (no overlap, no z-fighting): the
view is coarser there until the tiles arrive, never empty, never doubled.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from riverflow.kernels.tile_cut import cut_standins
from riverflow.tiles.cache import TilePool


class Standins(NamedTuple):
    """The tiles to draw (K of them, in (level, tx, ty) order): ``keys`` (K, 3) int32,
    their pool ``slots`` (K,) int32 and ``codes`` (K,) int64."""

    keys: np.ndarray
    slots: np.ndarray
    codes: np.ndarray


def standin_tiles(cut: np.ndarray, pool: TilePool, skip: np.ndarray | None = None) -> Standins:
    """The tiles of ``pool`` to use for the leaves ``cut`` (L, 3): each leaf's own tile or its
    finest resident ancestor, none for leaves with none or marked in ``skip`` (L,) bool (e.g.
    known empty), and no tile that another one listed contains (one numba pass,
    :func:`riverflow.kernels.tile_cut.cut_standins`)."""
    cut = np.ascontiguousarray(cut, np.int32).reshape(-1, 3)
    n = len(cut)
    skip = np.zeros(n, np.bool_) if skip is None else np.ascontiguousarray(skip, np.bool_)
    if skip.shape != (n,):
        raise ValueError(f"skip has shape {skip.shape}, the cut {n} leaves")
    keys = np.empty((n, 3), np.int32)
    slots = np.empty(n, np.int32)
    codes = np.empty(n, np.int64)
    m = cut_standins(cut, n, pool.table.keys, pool.table.values, skip, keys, slots, codes)
    return Standins(keys[:m], slots[:m], codes[:m])


def standins(cut: np.ndarray, pool: TilePool, skip: np.ndarray | None = None) -> np.ndarray:
    """(K, 3) int32 keys of the tiles of ``pool`` to use for the leaves ``cut`` (L, 3)
    (:func:`standin_tiles`)."""
    return standin_tiles(cut, pool, skip).keys
