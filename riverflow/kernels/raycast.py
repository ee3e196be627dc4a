"""Rays cast onto the terrain and water heightfields: where a new particle lands in the world.

Re-does the unprojection of new particles in Proland's ``ScreenParticleLayer`` (reference §3.5).
Proland read the scene depth buffer back from the GPU (``glReadPixels`` or a point per particle
into a float target) and unprojected ``(x, y, depth)``; its header admits "bad depths retrieved
for particles on some viewpoints", and the read-back stalls the GPU. We instead cast each new
particle's pixel ray (:meth:`riverflow.engine.camera.Camera.screen_to_ray`) on the CPU onto the
heightfields the terrain is drawn from, and also learn whether it landed on water or land.

The surface
    The grid is node-based: ``heights[j, i]`` is the terrain altitude at
    ``(origin_x + i * cell_m, origin_y + j * cell_m)``; ``water[j, i]`` the water level there, NaN
    where dry. In each cell the terrain T is the bilinear patch of its four nodes. Water W exists
    in a cell with at least one wet node: dry corners take the mean level of the cell's wet
    corners, and W is the bilinear patch of the four. The surface is ``max(T, W)``; a hit is on
    water when W ≥ T there, so the shoreline inside a cell is where the water plane meets the
    terrain. Outside the grid there is no surface.

What counts as a hit
    The first point where the ray passes from above the surface to on or below it (it enters
    the ground or the water from above), within ``max_distance_m``. A ray that starts below the
    surface (camera under the terrain) or enters the grid's side below it sees nothing until it
    has come out above the surface, then takes the next such crossing, else the sky: what
    OpenGL shows with back faces culled, since a particle must sit on a visible front surface.
    Tangent touches are not hits.

How
    Along a ray the bilinear patch of a cell is a quadratic in the ray distance, so the crossing
    is the root of a quadratic, solved exactly (no bisection). Cells are reached through a
    max-mip pyramid (:func:`fill_height_pyramid`: per node of 2ᵏ × 2ᵏ cells, the lowest terrain
    and the highest surface): a node the ray passes above is skipped whole, then the walk goes
    up a level; a node it may touch is opened a level down (Tevs, Ihrke, Seidel 2008, "Maximum
    mipmaps for fast, accurate, and scalable dynamic height field rendering"). The ray is
    first clipped to the grid's box and to the height range of the whole surface, so rays above
    every peak and going up cost nothing.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from riverflow.kernels._jit import JIT_OPTIONS, WORKER_JIT_OPTIONS, is_finite

HIT_NONE = 0
"""Sky: nothing within the distance, or the ray misses the grid."""
HIT_LAND = 1
HIT_WATER = 2


def height_pyramid(heights: np.ndarray, water: np.ndarray) -> np.ndarray:
    """The max-mip pyramid of a heightfield: allocates (:func:`pyramid_size`), then
    :func:`fill_height_pyramid`. Compute it once per heightfield (it reads every node), not
    per frame."""
    ny, nx = heights.shape
    out = np.empty((pyramid_size(nx, ny), 2), np.float32)
    fill_height_pyramid(heights, water, out)
    return out


@njit(**JIT_OPTIONS)
def pyramid_size(nx, ny):
    """Rows of the pyramid of an (ny, nx)-node grid: levels k = 1 … K, level k has
    ⌈(nx−1)/2ᵏ⌉ × ⌈(ny−1)/2ᵏ⌉ nodes of 2ᵏ × 2ᵏ cells, and level K is a single node."""
    cx = max(nx - 1, 1)
    cy = max(ny - 1, 1)
    total = 0
    k = 1
    while True:
        sx = (cx + (1 << k) - 1) >> k
        sy = (cy + (1 << k) - 1) >> k
        total += sx * sy
        if sx == 1 and sy == 1:
            return total
        k += 1


@njit(**JIT_OPTIONS)
def pyramid_layout(nx, ny):
    """(offs, dims_x, levels) of the max-mip pyramid of an (ny, nx)-node grid: level k has
    dims_x[k] nodes per row, its first row at offs[k] (k = 1 … levels)."""
    cx = max(nx - 1, 1)
    cy = max(ny - 1, 1)
    levels = 1
    while (cx + (1 << levels) - 1) >> levels > 1 or (cy + (1 << levels) - 1) >> levels > 1:
        levels += 1
    offs = np.zeros(levels + 1, np.int64)
    dims_x = np.ones(levels + 1, np.int64)
    for k in range(1, levels + 1):
        dims_x[k] = (cx + (1 << k) - 1) >> k
        if k < levels:
            offs[k + 1] = offs[k] + dims_x[k] * ((cy + (1 << k) - 1) >> k)
    return offs, dims_x, levels


@njit(**WORKER_JIT_OPTIONS)
def fill_height_pyramid(
    heights,  # (ny, nx) float32  terrain altitude at the nodes [m]
    water,    # (ny, nx) float32  water level at the nodes [m], NaN where dry
    out,      # (pyramid_size(nx, ny), 2) float32  written: per pyramid node, level by level
              #   (k = 1 first, rows of x fastest), the lowest terrain and the highest surface
              #   (terrain or water) over the grid nodes of its cells [m]
):
    """Max-mip pyramid of the surface (and min-mip of the terrain) for
    :func:`cast_rays_onto_heightfield`. Returns the number of levels."""
    ny, nx = heights.shape
    if out.shape[0] != pyramid_size(nx, ny):
        raise ValueError("out must have pyramid_size(nx, ny) rows")
    cx = max(nx - 1, 1)
    cy = max(ny - 1, 1)
    # Level 1 from the grid nodes: node (I, J) covers grid nodes 2I … 2I+2 (clipped).
    sx = (cx + 1) >> 1
    sy = (cy + 1) >> 1
    for jj in range(sy):
        for ii in range(sx):
            lo = np.inf
            hi = -np.inf
            for j in range(2 * jj, min(2 * jj + 2, ny - 1) + 1):
                for i in range(2 * ii, min(2 * ii + 2, nx - 1) + 1):
                    h = heights[j, i]
                    w = water[j, i]
                    lo = min(lo, h)
                    hi = max(hi, h)
                    if not math.isnan(w):
                        hi = max(hi, w)
            out[jj * sx + ii, 0] = lo
            out[jj * sx + ii, 1] = hi
    # Level k from its children on level k − 1.
    prev = 0
    level = 1
    while sx > 1 or sy > 1:
        psx, psy = sx, sy
        sx = (psx + 1) >> 1
        sy = (psy + 1) >> 1
        base = prev + psx * psy
        for jj in range(sy):
            for ii in range(sx):
                lo = np.inf
                hi = -np.inf
                for j in range(2 * jj, min(2 * jj + 2, psy)):
                    for i in range(2 * ii, min(2 * ii + 2, psx)):
                        lo = min(lo, out[prev + j * psx + i, 0])
                        hi = max(hi, out[prev + j * psx + i, 1])
                out[base + jj * sx + ii, 0] = lo
                out[base + jj * sx + ii, 1] = hi
        prev = base
        level += 1
    return level


@njit(**JIT_OPTIONS)
def cast_rays_onto_heightfield(
    origins,         # (N, 3) float64  ray starts [m]
    directions,      # (N, 3) float64  ray directions, any length (normalised here)
    heights,         # (ny, nx) float32  terrain altitude at the nodes [m]
    water,           # (ny, nx) float32  water level at the nodes [m], NaN where dry
    origin_x,        # float  world x of node [0, 0] [m]
    origin_y,        # float  world y of node [0, 0] [m]
    cell_m,          # float  node spacing [m]
    max_distance_m,  # float  longest accepted hit distance along the ray [m] (inf allowed)
    out_xyz,         # (N, 3) float64  written: hit point [m] on the ray; for a miss the ray's
                     #                 origin, or 0 for non-finite input: never NaN
    out_hit,         # (N,) uint8      written: HIT_NONE / HIT_LAND / HIT_WATER
    pyramid,         # (M, 2) float32  fill_height_pyramid(heights, water), M = pyramid_size
):
    """First crossing of each ray into the surface max(terrain, water). Returns the hit count."""
    n = origins.shape[0]
    ny, nx = heights.shape
    if water.shape[0] != ny or water.shape[1] != nx:
        raise ValueError("water and heights must have the same shape")
    if pyramid.shape[0] != pyramid_size(nx, ny):
        raise ValueError("pyramid does not belong to a grid of this shape")
    offs, dims_x, levels = pyramid_layout(nx, ny)  # two tiny arrays per call, not per ray
    top = offs[levels]
    zmin = np.float64(pyramid[top, 0])
    zmax = np.float64(pyramid[top, 1])
    hits = 0
    for r in range(n):
        kind = _cast_ray(origins[r, 0], origins[r, 1], origins[r, 2],
                         directions[r, 0], directions[r, 1], directions[r, 2],
                         heights, water, origin_x, origin_y, cell_m, max_distance_m,
                         pyramid, offs, dims_x, levels, zmin, zmax, out_xyz, r)
        out_hit[r] = kind
        if kind != HIT_NONE:
            hits += 1
    return hits


# -- one ray --------------------------------------------------------------------------------
# Helpers that take arrays are inlined in numba's IR (inline="always"): a call would incref and
# decref every array argument (atomic NRT calls), measured 16 % of the kernel's time; the cost
# is a longer first compile (about 8 s cold on the 2-core machine, cached afterwards).


@njit(inline="always", **JIT_OPTIONS)
def _cast_ray(ox, oy, oz, dx, dy, dz, heights, water, origin_x, origin_y, cell_m, max_d,
              pyramid, offs, dims_x, levels, zmin, zmax, out_xyz, r):
    """Cast one ray; writes out_xyz[r] and returns the hit kind."""
    out_xyz[r, 0] = 0.0
    out_xyz[r, 1] = 0.0
    out_xyz[r, 2] = 0.0
    dx, dy, dz, ok = _ray_start(ox, oy, oz, dx, dy, dz, max_d, out_xyz, r)
    ny, nx = heights.shape
    if not ok or nx < 2 or ny < 2 or not (cell_m > 0.0):
        return HIT_NONE
    # Grid coordinates: node (i, j) at (i, j), cell (i, j) between nodes i … i+1, j … j+1;
    # t is the distance along the ray [m].
    gx0 = (ox - origin_x) / cell_m
    gy0 = (oy - origin_y) / cell_m
    gdx = dx / cell_m
    gdy = dy / cell_m
    t0, t1, ok = _clip_slab(gx0, gdx, 0.0, nx - 1.0, 0.0, max_d)
    if ok:
        t0, t1, ok = _clip_slab(gy0, gdy, 0.0, ny - 1.0, t0, t1)
    if ok:  # below the lowest terrain nothing can be hit; above the highest surface neither
        pad = 1e-3 * (1.0 + abs(zmin) + abs(zmax))  # so a hit on the lowest node is inside
        t0, t1, ok = _clip_slab(oz, dz, zmin - pad, zmax + pad, t0, t1)
    if not ok or not (t0 < t1):
        return HIT_NONE

    kind, _ = _walk_grid(ox, oy, oz, dx, dy, dz, heights, water, origin_x, origin_y, cell_m,
                         pyramid, offs, dims_x, levels, zmin, zmax, t0, t1, -1, out_xyz, r)
    return kind


@njit(inline="always", **JIT_OPTIONS)
def _ray_start(ox, oy, oz, dx, dy, dz, max_d, out_xyz, r):
    """The unit direction of a ray, and whether it can hit anything: out_xyz[r] is set to the
    origin (left 0 for a non-finite one, never NaN). The direction is scaled by its largest
    component first, so tiny or huge directions neither under- nor overflow."""
    scale = max(abs(dx), abs(dy), abs(dz))
    if not (is_finite(ox) and is_finite(oy) and is_finite(oz) and is_finite(scale)):
        return 0.0, 0.0, 1.0, False
    out_xyz[r, 0] = ox
    out_xyz[r, 1] = oy
    out_xyz[r, 2] = oz
    if scale == 0.0 or not (max_d > 0.0):
        return 0.0, 0.0, 1.0, False
    dx /= scale
    dy /= scale
    dz /= scale
    length = math.sqrt(dx * dx + dy * dy + dz * dz)
    return dx / length, dy / length, dz / length, True


@njit(inline="always", **JIT_OPTIONS)
def _walk_grid(ox, oy, oz, dx, dy, dz, heights, water, origin_x, origin_y, cell_m, pyramid,
               offs, dims_x, levels, zmin, zmax, t0, t1, above_in, out_xyz, r):
    """The max-mip walk of one grid along the unit ray (o, d) over [t0, t1] (a stretch inside
    the grid's box; t is the distance along the ray [m]). ``above_in``: whether the ray is
    above the surface at t0 (1), below it (0), or not known (−1: found here). On a hit writes
    out_xyz[r]. Returns (kind, above at t1): a caller that walks several grids one after the
    other (:mod:`riverflow.kernels.raycast_tiles`) carries ``above`` from one to the next."""
    ny, nx = heights.shape
    gx0 = (ox - origin_x) / cell_m
    gy0 = (oy - origin_y) / cell_m
    gdx = dx / cell_m
    gdy = dy / cell_m
    ncx = nx - 1
    ncy = ny - 1
    inv_x = 1.0 / gdx if gdx != 0.0 else 0.0
    inv_y = 1.0 / gdy if gdy != 0.0 else 0.0
    i = min(max(int(math.floor(gx0 + gdx * t0)), 0), ncx - 1)
    j = min(max(int(math.floor(gy0 + gdy * t0)), 0), ncy - 1)
    # Start above or below the surface? Above the top of a pyramid node holding the start is
    # enough, and the walk can start on the finest such level.
    z_start = oz + dz * t0
    k = levels
    above = above_in == 1
    if above_in < 0:
        above = z_start > zmax
    if above_in < 0 and not above and z_start >= zmin:
        for level in range(1, levels + 1):
            if z_start > pyramid[offs[level] + (j >> level) * dims_x[level] + (i >> level), 1]:
                above = True
                k = level
                break
        if not above:
            k = 0
            s_t, s_w = _surface_at(heights, water, min(max(gx0 + gdx * t0, 0.0), nx - 1.0),
                                   min(max(gy0 + gdy * t0, 0.0), ny - 1.0))
            above = z_start - max(s_t, s_w) >= 0.0

    # Max-mip traversal: test the node of level k holding cell (i, j) over the ray's stretch
    # in it; go down a level when the ray may touch its surface, else skip past the node and
    # go up a level. Level 0 is one cell, tested exactly.
    t = t0
    for _ in range(8 * (ncx + ncy + 2) * (levels + 1)):  # bound only: each step moves on
        lo_i = (i >> k) << k
        lo_j = (j >> k) << k
        size = 1 << k
        tx = _exit_time(gx0, gdx, inv_x, lo_i, size)
        ty = _exit_time(gy0, gdy, inv_y, lo_j, size)
        t_out = min(tx, ty, t1)
        if t_out > t:
            if k == 0:
                kind, s_hit, above = _cross_cell(oz, dz, gx0 + gdx * t - i, gy0 + gdy * t - j,
                                                 gdx, gdy, heights, water, i, j, t, t_out, above)
                if kind != HIT_NONE:
                    t_hit = t + s_hit
                    out_xyz[r, 0] = ox + dx * t_hit
                    out_xyz[r, 1] = oy + dy * t_hit
                    out_xyz[r, 2] = oz + dz * t_hit
                    return kind, False
            else:
                node = offs[k] + (j >> k) * dims_x[k] + (i >> k)
                za = oz + dz * t
                zb = oz + dz * t_out
                if min(za, zb) > pyramid[node, 1]:
                    above = True      # clear of everything in this node
                elif above or max(za, zb) >= pyramid[node, 0]:
                    k -= 1            # may cross the surface here: look closer
                    continue
                # else: still under the ground all through this node
        if t_out >= t1:
            return HIT_NONE, above
        # Leave the node through the face the ray reaches first (both at a corner); the
        # other index stays in the node's range and never moves backwards.
        if tx <= ty:
            i = lo_i + size if gdx > 0.0 else lo_i - 1
        elif gdx != 0.0:
            i_new = min(max(int(math.floor(gx0 + gdx * t_out)), lo_i), lo_i + size - 1)
            i = max(i, i_new) if gdx > 0.0 else min(i, i_new)
        if ty <= tx:
            j = lo_j + size if gdy > 0.0 else lo_j - 1
        elif gdy != 0.0:
            j_new = min(max(int(math.floor(gy0 + gdy * t_out)), lo_j), lo_j + size - 1)
            j = max(j, j_new) if gdy > 0.0 else min(j, j_new)
        if i < 0 or i >= ncx or j < 0 or j >= ncy:
            return HIT_NONE, above
        t = max(t, t_out)
        if k < levels:
            k += 1
    return HIT_NONE, above


@njit(inline="always", **JIT_OPTIONS)
def _cross_cell(oz, dz, u0, v0, gdx, gdy, heights, water, i, j, t_in, t_out, above):
    """The ray over cell (i, j) from t_in (at cell coordinates u0, v0) to t_out.
    Returns (kind, distance of the hit from t_in, above at t_out)."""
    h00 = np.float64(heights[j, i])
    h10 = np.float64(heights[j, i + 1])
    h01 = np.float64(heights[j + 1, i])
    h11 = np.float64(heights[j + 1, i + 1])
    w00, w10, w01, w11, wet = _cell_water(water, i, j)
    s_max = max(max(h00, h10), max(h01, h11))
    s_min = min(min(h00, h10), min(h01, h11))
    if wet:
        s_max = max(s_max, max(max(w00, w10), max(w01, w11)))
    za = oz + dz * t_in
    zb = oz + dz * t_out
    if min(za, zb) > s_max:
        return HIT_NONE, 0.0, True
    if not above and max(za, zb) < s_min:
        return HIT_NONE, 0.0, False
    length = t_out - t_in
    # g(s) = ray z − patch z = A + B s + C s² along the ray, s = t − t_in.
    at, bt, ct = _patch_quadratic(za, dz, u0, v0, gdx, gdy, h00, h10, h01, h11)
    rt1, rt2 = _roots_within(at, bt, ct, length)
    aw = bw = cw = 0.0
    rw1 = rw2 = np.inf
    if wet:
        aw, bw, cw = _patch_quadratic(za, dz, u0, v0, gdx, gdy, w00, w10, w01, w11)
        rw1, rw2 = _roots_within(aw, bw, cw, length)
    # Walk the pieces between breakpoints (0, the roots, length): the sign of
    # min(g_terrain, g_water) is constant on each, so test it at the middle.
    s = 0.0
    for _ in range(6):
        s_next = length
        for c in (rt1, rt2, rw1, rw2):
            if s < c < s_next:
                s_next = c
        m = 0.5 * (s + s_next)
        f = at + m * (bt + m * ct)
        if wet:
            f = min(f, aw + m * (bw + m * cw))
        if above and f <= 0.0:
            kind = HIT_LAND
            if wet:
                terrain = at + s * (bt + s * ct)  # ray − terrain; water ≥ terrain ⇔ g_w ≤ g_t
                if aw + s * (bw + s * cw) <= terrain:
                    kind = HIT_WATER
            return kind, s, False
        if not above and f > 0.0:
            above = True
        if s_next >= length:
            break
        s = s_next
    return HIT_NONE, 0.0, above


# -- scalar helpers -------------------------------------------------------------------------


@njit(**JIT_OPTIONS)
def _clip_slab(p0, d, lo, hi, t0, t1):
    """Clip [t0, t1] to the t where lo ≤ p0 + d t ≤ hi. Returns (t0, t1, non-empty)."""
    if d == 0.0:
        return t0, t1, lo <= p0 <= hi
    ta = (lo - p0) / d
    tb = (hi - p0) / d
    if ta > tb:
        ta, tb = tb, ta
    t0 = max(t0, ta)
    t1 = min(t1, tb)
    return t0, t1, t0 <= t1


@njit(**JIT_OPTIONS)
def _exit_time(g0, gd, inv, lo, size):
    """t at which g0 + gd t leaves [lo, lo + size] (inf when gd is 0); inv = 1 / gd."""
    if gd > 0.0:
        return (lo + size - g0) * inv
    if gd < 0.0:
        return (lo - g0) * inv
    return np.inf


@njit(inline="always", **JIT_OPTIONS)
def _cell_water(water, i, j):
    """Water levels at the corners of cell (i, j), dry corners filled with the mean of the
    wet ones. Returns (w00, w10, w01, w11, any wet)."""
    w00 = np.float64(water[j, i])
    w10 = np.float64(water[j, i + 1])
    w01 = np.float64(water[j + 1, i])
    w11 = np.float64(water[j + 1, i + 1])
    total = 0.0
    count = 0
    for w in (w00, w10, w01, w11):
        if not math.isnan(w):
            total += w
            count += 1
    if count == 0:
        return 0.0, 0.0, 0.0, 0.0, False
    if count < 4:
        mean = total / count
        w00 = mean if math.isnan(w00) else w00
        w10 = mean if math.isnan(w10) else w10
        w01 = mean if math.isnan(w01) else w01
        w11 = mean if math.isnan(w11) else w11
    return w00, w10, w01, w11, True


@njit(inline="always", **JIT_OPTIONS)
def _surface_at(heights, water, gx, gy):
    """(terrain, water or −inf) at grid coordinates (gx, gy) inside the grid."""
    ny, nx = heights.shape
    i = min(int(gx), nx - 2)
    j = min(int(gy), ny - 2)
    u = gx - i
    v = gy - j
    t = _bilinear(u, v, np.float64(heights[j, i]), np.float64(heights[j, i + 1]),
                  np.float64(heights[j + 1, i]), np.float64(heights[j + 1, i + 1]))
    w00, w10, w01, w11, wet = _cell_water(water, i, j)
    w = _bilinear(u, v, w00, w10, w01, w11) if wet else -np.inf
    return t, w


@njit(**JIT_OPTIONS)
def _bilinear(u, v, f00, f10, f01, f11):
    return f00 + u * (f10 - f00) + v * (f01 - f00) + u * v * (f00 - f10 - f01 + f11)


@njit(**JIT_OPTIONS)
def _patch_quadratic(z0, dz, u0, v0, du, dv, f00, f10, f01, f11):
    """(A, B, C) with ray z − patch z = A + B s + C s² at cell coordinates (u0 + du s, v0 + dv s)."""
    b = f10 - f00
    c = f01 - f00
    d = f00 - f10 - f01 + f11
    a = z0 - (f00 + b * u0 + c * v0 + d * u0 * v0)
    return a, dz - (b * du + c * dv + d * (u0 * dv + v0 * du)), -d * du * dv


@njit(**JIT_OPTIONS)
def _roots_within(a, b, c, length):
    """Real roots of a + b s + c s² in [0, length], ascending; inf where there is none."""
    r1 = np.inf
    r2 = np.inf
    if c == 0.0:
        if b != 0.0:
            r1 = -a / b
    else:
        disc = b * b - 4.0 * a * c
        if disc < 0.0:
            return np.inf, np.inf
        q = -0.5 * (b + math.copysign(math.sqrt(disc), b))  # no cancellation (Numerical Recipes)
        if q == 0.0:
            r1 = 0.0
        else:
            r1 = q / c
            r2 = a / q
            if r2 < r1:
                r1, r2 = r2, r1
    if not (0.0 <= r2 <= length):
        r2 = np.inf
    if not (0.0 <= r1 <= length):
        r1 = r2
        r2 = np.inf
    return r1, r2
