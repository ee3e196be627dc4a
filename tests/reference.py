"""Plain-numpy twins of the numba kernels: slow, obvious, the specification of each kernel."""
from __future__ import annotations

import numpy as np

from riverflow.hydro.flow_network import FlowNetwork
from riverflow.kernels.flow import KIND_AXIS, KIND_BANK, KIND_CAP, MAX_NETWORK_TRIES

TIE = 1e-4
ON_LINE = 1e-12


def _dist2(p, a, b):
    """Squared distances from p (2,) to segments a→b (S, 2)."""
    e = b - a
    l2 = (e * e).sum(1)
    t = np.where(l2 > 0, ((p - a) * e).sum(1) / np.where(l2 > 0, l2, 1), 0.0)
    t = np.clip(t, 0.0, 1.0)
    q = a + t[:, None] * e - p
    return (q * q).sum(1)


def _signed(p, a, b):
    """Signed squared distances (negative on the dry side, the right of a → b) and leads (the
    squared distances to the segments' lines)."""
    d2 = _dist2(p, a, b)
    t1 = (b[:, 0] - a[:, 0]) * (p[1] - a[:, 1])
    t2 = (b[:, 1] - a[:, 1]) * (p[0] - a[:, 0])
    cross = t1 - t2
    cross = np.where(np.abs(cross) <= ON_LINE * (np.abs(t1) + np.abs(t2)), 0.0, cross)
    l2 = ((b - a) ** 2).sum(1)
    lead = np.where(l2 > 0, cross**2 / np.where(l2 > 0, l2, 1), 0.0)
    return np.where(cross < 0, -d2, d2), lead


def _nearer(cur, s):
    """The nearer of two (signed squared distance, lead) pairs: at a tie of distances with
    opposite signs (a vertex both segments share), the one whose line p is farther from (the
    vertex's pseudo-normal); lines as far: the positive one."""
    (c, cl), (v, vl) = cur, s
    if abs(v) < abs(c) * (1 - TIE):
        return s
    if abs(v) > abs(c) * (1 + TIE) or (v > 0) == (c > 0):
        return cur
    if vl > cl * (1 + TIE) + 1e-300:
        return s
    if vl >= cl * (1 - TIE) and v > 0:
        return s
    return cur


def potential(net: FlowNetwork, xy: np.ndarray, slip: float) -> np.ndarray:
    """ψ at each point by brute force over every segment (twin of ``evaluate_potential``)."""
    a = np.c_[net.seg_ax, net.seg_ay]
    b = np.c_[net.seg_bx, net.seg_by]
    owner = np.repeat(np.arange(net.n_curves), net.curve_seg1 - net.curve_seg0)
    out = np.full(len(xy), np.nan)
    for k, p in enumerate(np.asarray(xy, float)):
        d2 = _dist2(p, a, b)
        is_axis = net.curve_kind[owner] == KIND_AXIS
        tried: list[int] = []
        for _ in range(MAX_NETWORK_TRIES):    # behind a network's shore: the next network's
            ok = is_axis & (d2 < net.curve_hw2[owner]) & ~np.isin(net.curve_comp[owner], tried)
            groups = net.comp_group1 - net.comp_group0
            river = ok & (groups[net.curve_comp[owner]] >= 2)   # rivers before still water
            ok = river if river.any() else ok
            if not ok.any():
                break
            axis = owner[ok][np.argmin(d2[ok])]
            psi, behind = _network_potential(net, p, a, b, d2, axis, slip)
            if not behind:
                out[k] = psi
                break
            tried.append(net.curve_comp[axis])
    return out


def _network_potential(net, p, a, b, d2, axis, slip):
    """(ψ, behind its shore) at p in the network of ``axis``."""
    comp = net.curve_comp[axis]
    radius = net.comp_radius[comp]
    width2 = 4 * net.curve_hw2[axis]
    signed, lead = _signed(p, a, b)
    groups: dict[int, tuple[float, float]] = {}
    cap = (np.inf, 0.0)
    for c in range(net.n_curves):
        if net.curve_kind[c] == KIND_AXIS or net.curve_comp[c] != comp:
            continue
        segs = range(net.curve_seg0[c], net.curve_seg1[c])
        if min(d2[s] for s in segs) > net.curve_cutoff[c] ** 2:
            continue
        cur = (groups.get(net.curve_group[c], (np.inf, 0.0)) if net.curve_kind[c] == KIND_BANK
               else cap)
        for s in segs:
            cur = _nearer(cur, (signed[s], lead[s]))
        if net.curve_kind[c] == KIND_BANK:
            groups[net.curve_group[c]] = cur
        elif net.curve_kind[c] == KIND_CAP:
            cap = cur
    nearest = cap                      # the network's nearest shore: behind it?
    for g in sorted(groups):
        nearest = _nearer(nearest, groups[g])
    if nearest[0] < 0 and -nearest[0] < width2:
        return np.nan, True
    vals = np.array([groups[g][0] for g in sorted(groups)])
    psis = net.group_psi[sorted(groups)]
    one = net.comp_group1[comp] - net.comp_group0[comp] == 1   # a still lake's one shore
    if len(vals) < 2 and not (len(vals) == 1 and one):
        return np.nan, False
    d = np.sqrt(np.abs(vals))
    if np.any(d <= 1e-9 * radius):
        return psis[np.argmax(d <= 1e-9 * radius)], False
    t = np.clip(1 - d / radius, 0, 1)
    w = (6 * t**5 - 15 * t**4 + 10 * t**3) * (radius / d) ** slip
    if w.sum() > 0:
        return (w * psis).sum() / w.sum(), False
    return np.nan, False


def catmull_rom(t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Weights (N, 4) and their derivatives (N, 4) of the Catmull-Rom spline at t (N,)."""
    m = 0.5 * np.array([[0, -1, 2, -1], [2, 0, -5, 3], [0, 1, 4, -3], [0, 0, -1, 1]], float)
    powers = np.stack([np.ones_like(t), t, t * t, t**3], 1)
    dpowers = np.stack([np.zeros_like(t), np.ones_like(t), 2 * t, 3 * t * t], 1)
    return powers @ m.T, dpowers @ m.T


def lattice_velocity(psi: np.ndarray, origin: tuple[float, float], h: float, xy: np.ndarray):
    """Curl of the Catmull-Rom bicubic of a stored ψ lattice (points −1 … n+1 at ``origin`` +
    (index − 1)·h), at points xy (N, 2): (N, 2) velocity, the twin of ``query_velocity``."""
    u = (xy[:, 0] - origin[0]) / h
    v = (xy[:, 1] - origin[1]) / h
    n = psi.shape[0] - 3
    i = np.minimum(np.floor(u).astype(int), n - 1)
    j = np.minimum(np.floor(v).astype(int), n - 1)
    wx, dx = catmull_rom(u - i)
    wy, dy = catmull_rom(v - j)
    out = np.zeros((len(xy), 2))
    for k in range(len(xy)):
        patch = psi[j[k]:j[k] + 4, i[k]:i[k] + 4]
        gx = wy[k] @ patch @ dx[k]
        gy = dy[k] @ patch @ wx[k]
        out[k] = (-gy / h, gx / h)
    return out


def bank_corrected_potential(psi: np.ndarray, origin: tuple[float, float], h: float,
                             cell_segments: np.ndarray, segs, xy: np.ndarray,
                             reach_cells: float = 1.4) -> np.ndarray:
    """ψ of a stored ψ lattice with its bank correction at points xy (N, 2), the twin of
    ``sample_potential`` where the point's 4×4 stencil has no NaN: ψ_L(p) − w·(ψ_L(f) − ψ_b),
    f the foot of p on the nearest bank segment of its cell's list (``segs``: the field's
    :class:`~riverflow.kernels.flow.Segments`, NaN ψ for caps), d = |p − f|,
    w = 1 − fade(d / (reach_cells·h)), ψ_L(f) from p's own cell's bicubic."""
    u = (xy[:, 0] - origin[0]) / h
    v = (xy[:, 1] - origin[1]) / h
    n = psi.shape[0] - 3
    i = np.minimum(np.floor(u).astype(int), n - 1)
    j = np.minimum(np.floor(v).astype(int), n - 1)
    a = np.c_[segs.ax, segs.ay]
    b = np.c_[segs.bx, segs.by]

    def bicubic(k, uu, vv):
        wx, _ = catmull_rom(np.array([uu - i[k]]))
        wy, _ = catmull_rom(np.array([vv - j[k]]))
        return float(wy[0] @ psi[j[k]:j[k] + 4, i[k]:i[k] + 4] @ wx[0])

    out = np.empty(len(xy))
    reach = reach_cells * h
    for k, p in enumerate(xy):
        out[k] = bicubic(k, u[k], v[k])
        listed = [s for s in cell_segments[j[k], i[k]] if s >= 0 and np.isfinite(segs.psi[s])]
        if not listed:
            continue
        d2 = _dist2(p, a[listed], b[listed])
        s = listed[int(np.argmin(d2))]
        d = np.sqrt(d2.min())
        if d >= reach:
            continue
        e = b[s] - a[s]
        t = np.clip((p - a[s]) @ e / (e @ e), 0.0, 1.0)
        f = a[s] + t * e
        x = d / reach
        w = 1.0 - x**3 * (x * (x * 6 - 15) + 10)
        out[k] -= w * (bicubic(k, (f[0] - origin[0]) / h, (f[1] - origin[1]) / h) - segs.psi[s])
    return out


# -- raycast (riverflow.kernels.raycast) --------------------------------------------------------


def surface_at(heights: np.ndarray, water: np.ndarray, gx: np.ndarray, gy: np.ndarray):
    """Terrain and water (NaN where the cell has no wet corner) at grid coordinates (gx, gy)
    inside the grid, (N,) each: bilinear per cell, a dry corner of a wet cell takes the mean
    of the cell's wet corners."""
    ny, nx = heights.shape
    i = np.minimum(np.floor(gx).astype(int), nx - 2)
    j = np.minimum(np.floor(gy).astype(int), ny - 2)
    u, v = gx - i, gy - j
    weights = [(1 - u) * (1 - v), u * (1 - v), (1 - u) * v, u * v]
    corners = [(j, i), (j, i + 1), (j + 1, i), (j + 1, i + 1)]
    h = np.stack([heights[c].astype(np.float64) for c in corners])
    w = np.stack([water[c].astype(np.float64) for c in corners])
    wet = ~np.isnan(w)
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = np.nansum(w, axis=0) / wet.sum(0)
    w = np.where(wet, w, mean)
    terrain = sum(k * hk for k, hk in zip(weights, h))
    level = sum(k * wk for k, wk in zip(weights, w))
    return terrain, np.where(wet.any(0), level, np.nan)


def height_pyramid(heights: np.ndarray, water: np.ndarray) -> np.ndarray:
    """(M, 2) float32 max-mip pyramid, levels k = 1, 2, … until one node: per node of 2ᵏ × 2ᵏ
    cells (x fastest), the lowest terrain and the highest terrain-or-water grid node of its
    cells, computed straight from the nodes."""
    ny, nx = heights.shape
    top = np.fmax(heights, water)
    cx, cy = max(nx - 1, 1), max(ny - 1, 1)
    rows, k = [], 1
    while True:
        size = 1 << k
        sx, sy = -(-cx // size), -(-cy // size)
        for jj in range(sy):
            for ii in range(sx):
                nodes = (slice(jj * size, min(jj * size + size, ny - 1) + 1),
                         slice(ii * size, min(ii * size + size, nx - 1) + 1))
                rows.append((heights[nodes].min(), top[nodes].max()))
        if sx == 1 and sy == 1:
            return np.array(rows, np.float32)
        k += 1


def cast_rays_onto_heightfield(origins, directions, heights, water, origin_x, origin_y, cell_m,
                               max_distance_m, step_m=0.02):
    """Brute force: sample each ray every ``step_m`` up to ``max_distance_m``; the hit is the
    first sample pair, both over the grid, going from above the surface max(terrain, water) to
    on or below it, refined by bisection. Returns (xyz (N, 3), hit (N,) uint8: 0 sky, 1 land,
    2 water, where water ≥ terrain at the hit)."""
    ny, nx = heights.shape
    n = len(origins)
    xyz = np.array(origins, dtype=np.float64, copy=True)
    hit = np.zeros(n, np.uint8)
    s = np.arange(0.0, max_distance_m + step_m, step_m)

    def f_of(o, d, t):
        p = o + t[:, None] * d
        gx = (p[:, 0] - origin_x) / cell_m
        gy = (p[:, 1] - origin_y) / cell_m
        inside = (gx >= 0) & (gx <= nx - 1) & (gy >= 0) & (gy <= ny - 1)
        terrain, level = surface_at(heights, water, np.clip(gx, 0, nx - 1), np.clip(gy, 0, ny - 1))
        return p[:, 2] - np.fmax(terrain, level), inside, terrain, level

    for k in range(n):
        d = np.asarray(directions[k], dtype=np.float64)
        if not np.linalg.norm(d) > 0:
            continue
        d = d / np.linalg.norm(d)
        o = np.asarray(origins[k], dtype=np.float64)
        f, inside, _, _ = f_of(o, d, s)
        cross = inside[:-1] & inside[1:] & (f[:-1] > 0) & (f[1:] <= 0)
        if not cross.any():
            continue
        a = int(np.argmax(cross))
        lo, hi = s[a], s[a + 1]
        for _ in range(40):
            mid = 0.5 * (lo + hi)
            if f_of(o, d, np.array([mid]))[0][0] > 0:
                lo = mid
            else:
                hi = mid
        _, _, terrain, level = f_of(o, d, np.array([hi]))
        xyz[k] = o + hi * d
        hit[k] = 2 if level[0] >= terrain[0] else 1
    return xyz, hit


# -- particles ----------------------------------------------------------------------------------


def intensity(age_s, fade_in_s, active_s, fade_out_s):
    """Twin of ``intensity_at``: linear ramps in and out."""
    age = np.asarray(age_s, float)
    return np.clip(np.where(age < fade_in_s, age / fade_in_s,
                            np.where(age < fade_in_s + active_s, 1.0,
                                     1.0 - (age - fade_in_s - active_s) / fade_out_s)), 0.0, 1.0)


def project(world_m, clip_from_world, width_px, height_px):
    """Twin of the projection in ``project_particles``: (screen (N, 2), w (N,))."""
    p = np.c_[world_m, np.ones(len(world_m))] @ clip_from_world.T
    w = p[:, 3]
    return (p[:, :2] / w[:, None] * 0.5 + 0.5) * (width_px, height_px), w


def cull_in_slot_order(screen_px, keep_candidates, cull_px, cell_px=None, per_cell=None):
    """Twin of ``cull_crowded_particles``: greedy in slot order, a candidate is accepted when no
    accepted particle is closer than ``cull_px`` (and, given ``cell_px`` and ``per_cell``,
    when its grid cell holds fewer than ``per_cell`` accepted ones). Returns the accepted
    slots."""
    accepted = []
    held: dict[tuple[int, int], int] = {}
    for i in np.flatnonzero(keep_candidates):
        if not all(np.hypot(*(screen_px[i] - screen_px[j])) >= cull_px for j in accepted):
            continue
        if per_cell is not None:
            cell = tuple(np.floor(screen_px[i] / cell_px).astype(int))
            if held.get(cell, 0) >= per_cell:
                continue
            held[cell] = held.get(cell, 0) + 1
        accepted.append(i)
    return np.array(accepted, int)


def blocked_directions(radius_px, gap_px, cell_px, n, bins=64):
    """Twin of ``blocked_direction_table``: (n, n, bins) bool, entry [iy, ix, k] true when every
    corner of the square [ix·cell − n·cell/2, …) × [iy·cell − n·cell/2, …) is closer than the
    gap (less a 10⁻⁶ relative margin on its square) to both ends of the arc
    [k, k + 1)·2π/bins of the circle of radius 2r."""
    theta = 2 * np.pi * np.arange(bins + 1) / bins
    ends = 2 * radius_px * np.c_[np.cos(theta), np.sin(theta)]          # (bins + 1, 2)
    edges = np.arange(n + 1) * cell_px - 0.5 * n * cell_px
    cx, cy = np.meshgrid(edges, edges)                                   # corner grid
    d2 = ((cx[..., None] - ends[:, 0]) ** 2 + (cy[..., None] - ends[:, 1]) ** 2)
    near = d2 < gap_px**2 * (1 - 1e-6)                                   # (n+1, n+1, bins+1)
    corners = near[:-1, :-1] & near[1:, :-1] & near[:-1, 1:] & near[1:, 1:]
    return corners[..., :-1] & corners[..., 1:]


def touched_directions(radius_px, gap_px, cell_px, n, bins=64):
    """Twin of ``blocked_direction_table``'s ``out_touched``: (n, n, bins) bool, entry
    [iy, ix, k] true when the square's centre is within gap + ρ + σ of the middle of the arc
    [k, k + 1)·2π/bins (ρ: the arc's farthest point from its middle, σ: the square's half
    diagonal)."""
    mid = 2 * np.pi * (np.arange(bins) + 0.5) / bins
    arc = 2 * radius_px * np.c_[np.cos(mid), np.sin(mid)]                 # (bins, 2)
    centres = (np.arange(n) + 0.5) * cell_px - 0.5 * n * cell_px
    cx, cy = np.meshgrid(centres, centres)
    d2 = (cx[..., None] - arc[:, 0]) ** 2 + (cy[..., None] - arc[:, 1]) ** 2
    rho = 4 * radius_px * np.sin(0.25 * 2 * np.pi / bins)
    reach = gap_px * (1 + 1e-6) + rho + cell_px * np.sqrt(0.5)
    return d2 < reach**2


def euler_move(world_m, velocity_mps, dt_s):
    """Twin of ``move_particles`` in the plane: x, y += v·dt."""
    out = np.array(world_m, float, copy=True)
    out[:, :2] += velocity_mps * dt_s
    return out


def _within(points, x, y, reach):
    """Rows of points (N, 2) closer than reach to (x, y) (float32 arithmetic, as the kernels)."""
    d = points.astype(np.float32) - np.array([x, y], np.float32)
    return (d * d).sum(1) < reach * reach


def water_hint(x, y, screen_xy, eye_xy, clip_from_world, width, height, hints, grid_x, grid_y,
               cell, track=(0.0, -0.03, 0.03, -0.1, 0.1, -0.3, 0.3, 1.0)):
    """Twin of ``_water_hint``: of the hints (x, y, level) of the hint grid nodes nearest the
    points (x, y) + f · ((x, y) − eye) of the ray's ground track, the one that projects
    nearest ``screen_xy`` (the first of equals), or None."""
    rows, cols = hints.shape[:2]
    best, hint = np.inf, None
    for f in track:
        px, py = x + f * (x - eye_xy[0]), y + f * (y - eye_xy[1])
        i, j = int(np.floor((px - grid_x) / cell + 0.5)), int(np.floor((py - grid_y) / cell + 0.5))
        if not (0 <= i < cols and 0 <= j < rows) or not hints[j, i, 0] < np.inf:
            continue
        h = hints[j, i].astype(float)
        clip = clip_from_world @ np.r_[h, 1.0]
        if not clip[3] > 1e-9:
            continue
        d = np.sum(((clip[:2] / clip[3] * 0.5 + 0.5) * (width, height) - screen_xy) ** 2)
        if d < best:
            best, hint = d, h
    return hint


def check_outside_near_water(alive, ids, status, screen_px, world_m, birth_s, now_s, fade_at,
                             items, frame, probe_every, replace_every, reach_px, cover_px, width,
                             height, clip_from_world, eye_xy, hints, grid_x, grid_y, cell):
    """Twin of ``check_outside_near_water``: the steady OUTSIDE particles whose slot + frame
    is a multiple of probe_every, in slot order: replaced when a live INSIDE one of ``items``
    (the accepted particles) is within reach and slot + frame is also a multiple of
    replace_every, else their water hint projected, kept when within reach of it, on screen
    and farther than ``cover_px`` from every live INSIDE/LEAVING one of ``items``. Returns
    (removed slots, probes (P, 2), owners (P,))."""
    slots = np.arange(len(alive))
    items = np.asarray(items)
    inside = items[(status[items] == 1) & alive[items]]
    carriers = items[((status[items] == 1) | (status[items] == 2)) & alive[items]]
    removed, probes, owners = [], [], []
    for i in slots:
        if (not alive[i] or status[i] != 4 or now_s - birth_s[i] >= fade_at
                or (i + frame) % probe_every):
            continue
        if ((i + frame) % replace_every == 0
                and _within(screen_px[inside], *screen_px[i], reach_px).any()):
            removed.append(i)
            continue
        hint = water_hint(world_m[i, 0], world_m[i, 1], screen_px[i], eye_xy, clip_from_world,
                          width, height, hints, grid_x, grid_y, cell)
        if hint is None:
            continue
        clip = clip_from_world @ np.r_[hint, 1.0]
        if not clip[3] > 1e-9:
            continue
        q = (clip[:2] / clip[3] * 0.5 + 0.5) * (width, height)
        if np.hypot(*(q - screen_px[i])) >= reach_px or not (0 <= q[0] < width
                                                             and 0 <= q[1] < height):
            continue
        if (np.hypot(*(screen_px[carriers] - q).T) < cover_px).any():
            continue
        probes.append(q)
        owners.append(i)
    return (np.array(removed, int), np.array(probes, float).reshape(-1, 2),
            np.array(owners, int))


def place_at_seen_water(alive, status, screen_px, birth_s, now_s, fade_at, items, probes, hit,
                        flow_status, gap_px):
    """Twin of ``place_at_seen_water``'s choices: for each probe in order that saw water in the
    flow, the steady ``items`` closer than the gap give way unless one is INSIDE, LEAVING or
    UNKNOWN or a particle placed before is that close. Returns (placed probe rows, removed
    slots)."""
    alive = alive.copy()
    placed, removed = [], []
    for k, (x, y) in enumerate(probes):
        if hit[k] != 2 or flow_status[k] != 1:
            continue
        if placed and _within(probes[placed], x, y, gap_px).any():
            continue
        live = items[alive[items] & (now_s - birth_s[items] < fade_at)]
        close = live[_within(screen_px[live], x, y, gap_px)]
        if np.isin(status[close], (0, 1, 2)).any():
            continue
        alive[close] = False
        removed.extend(close.tolist())
        placed.append(k)
    return np.array(placed, int), np.array(removed, int)
