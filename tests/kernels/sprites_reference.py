"""Plain-numpy twins of riverflow.kernels.sprites and of the sprite grid that the GPU makes
from it (``sprite_lists.glsl``): slow, obvious, the specification of each."""
from __future__ import annotations

import numpy as np

from riverflow.components.status import FlowStatus

PER_ROW = 256
PER_CELL = 16


def _finite_or_zero(a: np.ndarray) -> np.ndarray:
    return np.where(np.isfinite(a), a, 0).astype(np.float32)


def sprite_entries(alive, has_world, screen_px, world_m, offset_m, intensity, status,
                   velocity_mps, radius_px, n, foam=None, tint=None
                   ) -> tuple[np.ndarray, np.ndarray]:
    """Every slot's entry of the sprite table (n, 4, 4) float32 and whether it is usable
    (``foam``: each slot's foam, ``tint`` (r, g, b, c) its spill tint; None for none)."""
    with np.errstate(over="ignore", invalid="ignore"):
        screen = screen_px[:n].astype(np.float32)
        world = world_m[:n].astype(np.float32)
        level = intensity[:n].astype(np.float32)
        r = np.float32(radius_px)
    r = r if np.isfinite(r) else np.float32(0)
    usable = (alive[:n] & has_world[:n] & np.isfinite(screen).all(1) & np.isfinite(world).all(1)
              & np.isfinite(level))
    vals = np.zeros((n, 4, 4), np.float32)
    vals[:, 0, :2] = screen
    vals[:, 0, 2:] = world[:, :2]
    vals[:, 1, :2] = _finite_or_zero(offset_m[:n].astype(np.float32))
    vals[:, 1, 2] = level
    vals[:, 1, 3] = r
    vals[:, 2, 0] = status[:n]
    vals[:, 2, 1:3] = _finite_or_zero(velocity_mps[:n].astype(np.float32))
    vals[:, 2, 3] = world[:, 2]
    if foam is not None:
        f = np.asarray(foam[:n], np.float32)
        vals[:, 3, 0] = np.where(np.isfinite(f), np.clip(f, 0, 1), 0)
    if tint is not None:
        t = np.asarray(tint[:n], np.float32)
        on = np.isfinite(t[:, 3]) & (t[:, 3] > 0)
        with np.errstate(invalid="ignore"):
            rgb = np.where(np.isfinite(t[:, :3]), np.clip(t[:, :3], 0, 1), 0)
        q = np.floor(rgb.astype(np.float64) * 255.0 + 0.5).astype(np.int64)
        vals[:, 3, 1] = np.where(on, t[:, 3], 0)
        vals[:, 3, 2] = np.where(on, q[:, 0] * 65536 + q[:, 1] * 256 + q[:, 2], 0)
    return vals, usable


def build_sprite_tables(alive, has_world, screen_px, world_m, offset_m, intensity, status,
                        velocity_mps, radius_px, n_slots, bins, capacity_rows, with_tail=True,
                        foam=None, tint=None):
    """Twin of ``build_sprite_tables`` (sorting by Python's stable sort, not counting):
    (table (rows·256, 4, 4) float32, starts (bh, bw + 1) int32, n_drawn, n_entries, rows)."""
    n = max(min(n_slots, len(alive)), 0)
    capacity = capacity_rows * PER_ROW
    vals, usable = sprite_entries(alive, has_world, screen_px, world_m, offset_m, intensity,
                                  status, velocity_mps, radius_px, n, foam, tint)
    bw, bh = bins.bw, bins.bh
    radius = float(radius_px)
    drawing = (bw > 0 and bh > 0 and bins.bin_w > 0 and bins.bin_h > 0 and np.isfinite(radius)
               and radius > 0)
    st = np.asarray(status[:n])
    drawn = usable & ((st == FlowStatus.INSIDE) | (st == FlowStatus.LEAVING)) & (intensity[:n] > 0)
    key = np.full(n, -1, np.int64)
    if drawing:
        with np.errstate(invalid="ignore"):
            sx = vals[:, 0, 0].astype(np.float64)
            sy = vals[:, 0, 1].astype(np.float64)
            bx = np.floor(sx / bins.bin_w) + bins.margin_x
            by = np.floor(sy / bins.bin_h) + bins.margin_y
        inside = drawn & (bx >= 0) & (by >= 0) & (bx < bw) & (by < bh)
        key[inside] = (by[inside] * (bw + 1) + bx[inside]).astype(np.int64)
    first = np.flatnonzero(key >= 0)
    first = first[np.argsort(key[first], kind="stable")]
    rest = np.flatnonzero(usable & (key < 0)) if with_tail else np.zeros(0, np.int64)
    order = np.concatenate([first, rest])[:capacity]
    n_entries = len(order)
    rows = -(-n_entries // PER_ROW)
    table = np.zeros((rows * PER_ROW, 4, 4), np.float32)
    table[:, 2, 0] = -1.0
    table[:n_entries] = vals[order]
    counts = np.bincount(key[first], minlength=max(bh * (bw + 1), 0))
    starts = np.concatenate([[0], np.cumsum(counts)])[:bh * (bw + 1)]
    starts = np.minimum(starts, capacity).astype(np.int32).reshape(bh, bw + 1) if bw > 0 \
        else np.zeros((0, 1), np.int32)
    return table, starts, min(len(first), capacity), n_entries, rows


def bins_touching(bins, lo, hi, radius) -> list[tuple[int, int, int]]:
    """Twin of ``sprite_bins.glsl`` (float64): (row, first bin, last bin) per bin row that may
    hold the centre of a sprite of ``radius`` meeting the rectangle [lo, hi]."""
    reach = radius + 0.5
    out = []
    first_row = max(int(np.floor((lo[1] - reach) / bins.bin_h)) + bins.margin_y, 0)
    last_row = min(int(np.floor((hi[1] + reach) / bins.bin_h)) + bins.margin_y, bins.bh - 1)
    for by in range(first_row, last_row + 1):
        y0 = (by - bins.margin_y) * bins.bin_h
        dy = max(y0 - hi[1], lo[1] - (y0 + bins.bin_h), 0.0)
        half = np.sqrt(max(reach * reach - dy * dy, 0.0)) + 0.5
        a = int(np.clip(np.floor((lo[0] - half) / bins.bin_w) + bins.margin_x, 0, bins.bw - 1))
        b = int(np.clip(np.floor((hi[0] + half) / bins.bin_w) + bins.margin_x, 0, bins.bw - 1))
        out.append((by, a, b))
    return out


def drawable(alive, has_world, screen_px, intensity, status) -> np.ndarray:
    """Which slots go into the grid: alive, with a world position, INSIDE or LEAVING,
    intensity > 0, finite screen position."""
    st = np.asarray(status)
    return (alive & has_world & ((st == FlowStatus.INSIDE) | (st == FlowStatus.LEAVING))
            & (intensity > 0) & np.isfinite(screen_px.astype(np.float64)).all(1))


def build_sprite_grid(alive, has_world, screen_px, intensity, status, n_slots, sprite_radius_px,
                      cell_px, gw, gh) -> tuple[list[list[int]], int]:
    """The sprite grid (made on the GPU by ``sprite_lists.glsl``): each cell's slot list
    (index cy·gw + cx), in slot order, and the number of full cells. A full cell swaps its
    first dimmest entry for a strictly brighter slot; the GPU visits the sprites in bin order,
    so among equally bright ones it may keep others."""
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


def grid_lists(layers: np.ndarray) -> list[list[int]]:
    """Each cell's list (index cy·gw + cx, up to −1 or 16 entries) read back from the GPU's
    sprite grid, (4, gh, gw, 4) int32 (layer, row, column, component)."""
    _, gh, gw, _ = layers.shape
    flat = np.moveaxis(layers, 0, 2).reshape(gh * gw, PER_CELL)
    cells = []
    for entries in flat.tolist():
        cells.append(entries[:entries.index(-1)] if -1 in entries else entries)
    return cells
