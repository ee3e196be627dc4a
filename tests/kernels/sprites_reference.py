"""Plain-numpy twins of riverflow.kernels.sprites: slow, obvious, the specification of each."""
from __future__ import annotations

import numpy as np

from riverflow.components.status import FlowStatus

PER_ROW = 256
PER_CELL = 16


def _finite_or_zero(a: np.ndarray) -> np.ndarray:
    return np.where(np.isfinite(a), a, 0).astype(np.float32)


def fill_sprite_params(alive, has_world, screen_px, world_m, offset_m, intensity, status,
                       velocity_mps, radius_px, n_slots, out) -> int:
    """Twin of ``fill_sprite_params``: writes rows [0, rows) of ``out``, returns rows."""
    n = min(n_slots, len(alive), out.shape[0] * PER_ROW)
    n = max(n, 0)
    rows = -(-n // PER_ROW)
    table = np.zeros((rows * PER_ROW, 3, 4), np.float32)
    table[:, 2, 0] = -1.0
    with np.errstate(over="ignore", invalid="ignore"):
        screen = screen_px[:n].astype(np.float32)
        world = world_m[:n].astype(np.float32)
        level = intensity[:n].astype(np.float32)
        r = np.float32(radius_px)
    r = r if np.isfinite(r) else np.float32(0)
    ok = (alive[:n] & has_world[:n] & np.isfinite(screen).all(1) & np.isfinite(world).all(1)
          & np.isfinite(level))
    vals = np.zeros((n, 3, 4), np.float32)
    vals[:, 0, :2] = screen
    vals[:, 0, 2:] = world[:, :2]
    vals[:, 1, :2] = _finite_or_zero(offset_m[:n].astype(np.float32))
    vals[:, 1, 2] = level
    vals[:, 1, 3] = r
    vals[:, 2, 0] = status[:n]
    vals[:, 2, 1:3] = _finite_or_zero(velocity_mps[:n].astype(np.float32))
    vals[:, 2, 3] = world[:, 2]
    table[:n][ok] = vals[ok]
    out[:rows] = table.reshape(rows, PER_ROW * 3, 4)
    return rows


def drawable(alive, has_world, screen_px, intensity, status) -> np.ndarray:
    """Which slots go into the grid: alive, with a world position, INSIDE or LEAVING,
    intensity > 0, finite screen position."""
    st = np.asarray(status)
    return (alive & has_world & ((st == FlowStatus.INSIDE) | (st == FlowStatus.LEAVING))
            & (intensity > 0) & np.isfinite(screen_px.astype(np.float64)).all(1))


def build_sprite_grid(alive, has_world, screen_px, intensity, status, n_slots, sprite_radius_px,
                      cell_px, gw, gh) -> tuple[list[list[int]], int]:
    """Twin of ``build_sprite_grid``: each cell's slot list (index cy·gw + cx) and the number
    of full cells."""
    cells: list[list[int]] = [[] for _ in range(gw * gh)]
    radius, cell = float(sprite_radius_px), float(cell_px)
    if not (radius > 0 and cell > 0 and np.isfinite(radius) and np.isfinite(cell)):
        return cells, 0
    n = max(min(n_slots, len(alive)), 0)
    ok = drawable(alive[:n], has_world[:n], screen_px[:n], intensity[:n], status[:n])
    for i in np.flatnonzero(ok):
        px, py = float(screen_px[i, 0]), float(screen_px[i, 1])
        x_lo, x_hi = (px - radius) / cell, (px + radius) / cell
        y_lo, y_hi = (py - radius) / cell, (py + radius) / cell
        if x_hi < 0 or y_hi < 0 or x_lo >= gw or y_lo >= gh:
            continue
        cxs = np.arange(int(max(x_lo, 0.0)), int(min(x_hi, gw - 1.0)) + 1)
        cys = np.arange(int(max(y_lo, 0.0)), int(min(y_hi, gh - 1.0)) + 1)
        x0, y0 = cxs * cell, cys * cell
        dx = np.maximum(np.maximum(x0 - px, px - (x0 + cell)), 0.0)
        dy = np.maximum(np.maximum(y0 - py, py - (y0 + cell)), 0.0)
        hit = (dx * dx)[None, :] <= (radius * radius - dy * dy)[:, None]
        for a, b in zip(*np.nonzero(hit)):
            lst = cells[cys[a] * gw + cxs[b]]
            if len(lst) < PER_CELL:
                lst.append(int(i))
                continue
            levels = intensity[lst]
            j = int(np.argmin(levels))  # first of the dimmest
            if intensity[i] > levels[j]:
                lst[j] = int(i)
    return cells, sum(len(c) == PER_CELL for c in cells)


def grid_lists(grid: np.ndarray, gw: int, gh: int) -> list[list[int]]:
    """Each cell's slot list read from a kernel-built grid (up to −1 or 16 entries)."""
    cells = []
    for cy in range(gh):
        for cx in range(gw):
            entries = grid[cy, PER_CELL * cx:PER_CELL * (cx + 1)].tolist()
            cells.append(entries[:entries.index(-1)] if -1 in entries else entries)
    return cells
