"""Triangle meshes of the streamed world's tiles for the draw system (SPEC §8). Plain numpy,
no GL: the draw system uploads these arrays as they are, into shared GPU buffers (a slot per
terrain tile, a run per water tile), and gives the room back when the tile leaves the cache.
Nothing here spans the whole map.

**Terrain** (:func:`tile_terrain_mesh`, :func:`tile_indices`, :func:`tile_index_parts`). Every
terrain tile has n cells per side (its quadtree level sets their size) and the same vertex
layout, so one index buffer serves all tiles. Its ``V = (n + 1)² + 4n`` vertices are

* ``j * (n + 1) + i`` (0 ≤ i, j ≤ n): the grid sample at the tile's node (i, j), at
  ``(x0 + i·cell, y0 + j·cell)`` with the height tile's height there (row-major, row = y);
* ``(n + 1)² + k`` (0 ≤ k < 4n): the skirt copy of border vertex ``k`` of the tile's border
  loop, ``skirt_m`` lower, same normal and distance to the shore, its water level ``skirt_m``
  lower too (shaded as its top: where a crack shows the skirt, it looks like the ground). The loop runs counter-clockwise seen from above,
  starting at the corner (0, 0): along j = 0 (i = 0 … n-1), up i = n (j = 0 … n-1), back along
  j = n (i = n … 1), down i = 0 (j = n … 1) (:func:`border_loop`).

Normals are central differences of the heights, read from a one-node ring around the tile,
so neighbouring tiles of one level agree on their shared border. The view draws a *cut* of
the quadtree: neighbouring tiles may be 1 … log2(n) levels apart, and the coarser one's
border (every 2^k-th node of the finer one's, the same heights) runs straight where the finer
one bends: a crack of up to a few metres on hills. Each tile hangs a vertical skirt from its
border, as deep as the largest such gap along it (:func:`tile_skirt_m`). This is the usual
skirt trick of tiled terrain renderers (Proland's own terrain blends levels in the vertex
shader instead; its rivers need no mesh, reference §4.1).

A skirt fills the crack but shows as a thin wall where the finer border bends below the
coarser one (seen from the side, a zig-zag fence on the grass). So the drawn tiles' borders
follow their coarser neighbours (:func:`coarser_neighbours`, :func:`edge_levels_up`) through
*edge index variants* (:func:`tile_index_parts`, the usual way of tiled terrain engines): a
tile's triangles are a core plus, per edge, a strip for each level difference k, which uses
only every 2^k-th border node (the nodes the neighbour has, with the same heights: point
samples of one height function) and fans the skipped ones' neighbours to them. The vertex data
is never changed for it: the draw system picks each tile's five index ranges when the drawn
set changes. Only a neighbour more than log2(n) levels coarser has no node at the finer
tile's corners; then :func:`stitch_tile` moves the tile's border vertices onto its border
(linear between its nodes; normal, water level and shore distance with them) and the tile is
re-uploaded, a rare case. Either way the two share their edge exactly and the skirts only
cover the rasteriser's pinholes where edges meet in T-junctions.

**Water** (:func:`triangulate_water`, :class:`WaterMesh`). A tile's water mesh triangulates
the tile's piece of the water polygon. Tessellating a wide water polygon in one piece gives
long thin triangles whose corners sample very different terrain altitudes, the artifact
Proland's documentation warns of (reference §4.1, §4.9). Here the piece is cut by a square
grid of cells first (WATER_MESH_CELLS per tile side, :mod:`riverflow.scenes.tile_kinds`) and
each cell's part is triangulated on its own, so every triangle lies inside one grid cell.

Orientation everywhere: x east, y north, z up; triangles are counter-clockwise seen from +z
(skirt triangles face outward, away from their tile).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
import shapely

from riverflow.kernels.tile_cut import coarser_across

MIN_SKIRT_CELLS = 2.0
"""The skirts reach at least this many cells below their border."""
_BLOCK = 16  # the water polygon is clipped to blocks of _BLOCK² cells, then to cells
_LATTICE = 1e4  # water vertices are merged on a 0.1 mm lattice [1/m]


# -- terrain tiles --------------------------------------------------------------------------


def level_count(n: int) -> int:
    """How many quadtree levels an n-cell tile's border can be drawn at: a neighbour l levels
    coarser draws every 2**l-th node, which exists while 2**l divides n, so 1 + log2(n) for a
    power of two (n = 64: the tile's own and 6 coarser)."""
    if n < 1:
        raise ValueError("a tile has at least one cell")
    return 1 + ((n & -n).bit_length() - 1)


def border_loop(n: int) -> tuple[np.ndarray, np.ndarray]:
    """The border of an n-cell tile as a counter-clockwise loop seen from above, starting at
    sample (0, 0): (i, j) sample indices, two (4n,) int64 arrays. Loop position k is skirt
    vertex ``(n + 1)² + k``; the corners are at k = 0, n, 2n, 3n."""
    r = np.arange(n)
    i = np.concatenate([r, np.full(n, n), n - r, np.zeros(n, np.int64)])
    j = np.concatenate([np.zeros(n, np.int64), r, np.full(n, n), n - r])
    return i, j


@dataclass(eq=False)
class TerrainTileMesh:
    """One streamed terrain tile as drawn: ``vertices`` (V, 8) float32 (x, y, z [m], unit
    normal, the water level seen from there [m], the distance to the shore in units of that
    river's size (metres divided by :func:`river_scale`), negative in the water) in the
    layout of the module docstring (grid samples, then the skirt),
    ``skirt_m`` [m], ``bounds_m`` (2, 3) float32 (min, max corner, skirt included)."""

    vertices: np.ndarray
    skirt_m: float
    bounds_m: np.ndarray

    @property
    def nbytes(self) -> int:
        return int(self.vertices.nbytes + self.bounds_m.nbytes)


def tile_terrain_mesh(z_ring: np.ndarray, x0_m: float, y0_m: float, cell_m: float,
                      level_m: np.ndarray,
                      shore_m: np.ndarray | None = None,
                      scale: np.ndarray | None = None) -> TerrainTileMesh:
    """The mesh of one n-cell terrain tile from its heights with a one-node ring
    ``z_ring`` (n + 3, n + 3) [m] (row = y; the ring gives central-difference normals that
    agree with the neighbours'), its corner and node spacing [m], ``level_m`` (n + 1, n + 1)
    the water level seen from each node and ``shore_m`` (n + 1, n + 1) each node's distance to
    the shore [m], negative in the water (None: far from every shore, 200 m), divided by
    ``scale`` (n + 1, n + 1) the :func:`river_scale` of that river (None: 1). The skirt hangs
    as deep as the largest crack any coarser neighbour can leave along its border
    (:func:`tile_skirt_m`); a finer neighbour is stitched to this one's border
    (:func:`stitch_tile`), so the skirt is for the rasteriser's pinholes at T-junctions."""
    z = np.asarray(z_ring, np.float64)
    n = z.shape[0] - 3
    side = n + 1
    inner = z[1:-1, 1:-1]
    dz_dx = (z[1:-1, 2:] - z[1:-1, :-2]) / (2.0 * cell_m)
    dz_dy = (z[2:, 1:-1] - z[:-2, 1:-1]) / (2.0 * cell_m)
    normal = np.stack([-dz_dx, -dz_dy, np.ones_like(dz_dx)], axis=-1)
    normal /= np.linalg.norm(normal, axis=-1, keepdims=True)
    skirt = tile_skirt_m(inner, cell_m)
    bi, bj = border_loop(n)
    grid_j, grid_i = np.divmod(np.arange(side * side), side)
    vj, vi = np.concatenate([grid_j, bj]), np.concatenate([grid_i, bi])
    out = np.empty((len(vi), 8), np.float32)
    out[:, 0] = x0_m + vi * cell_m
    out[:, 1] = y0_m + vj * cell_m
    out[:, 2] = inner[vj, vi]
    out[side * side:, 2] -= skirt
    out[:, 3:6] = normal[vj, vi]
    out[:, 6] = np.asarray(level_m)[vj, vi]
    out[side * side:, 6] -= skirt         # a skirt is shaded as its top: as high above the water
    out[:, 7] = 200.0 if shore_m is None else np.asarray(shore_m)[vj, vi]
    if scale is not None:
        out[:, 7] /= np.asarray(scale, np.float32)[vj, vi]
    bounds = np.array([[x0_m, y0_m, min(inner.min(), inner[bj, bi].min() - skirt)],
                       [x0_m + n * cell_m, y0_m + n * cell_m, inner.max()]], np.float32)
    return TerrainTileMesh(out, float(skirt), bounds)


FULL_SCALE_WIDTH_M = 8.0
"""Rivers at least this wide [m] have banks, sand and wet ground of full size (the terrain
shader's metres); narrower ones a fraction: :func:`river_scale`."""


def river_scale(width_m) -> np.ndarray:
    """The size of a river's shore features relative to a wide river's, (N,) float32:
    width / FULL_SCALE_WIDTH_M, between 0.05 and 1 (a 2 m creek: 0.25, so its sand strip is
    at most a quarter of a wide river's, 2.4 m). The terrain's shore distances are stored in
    these units, so the shader's sand widths scale with the river."""
    return np.clip(np.asarray(width_m, np.float64) / FULL_SCALE_WIDTH_M, 0.05, 1.0
                   ).astype(np.float32)


def tile_skirt_m(heights: np.ndarray, cell_m: float) -> float:
    """How deep a tile's skirt must hang [m]: the largest gap between its border, as drawn,
    and the same border drawn by a neighbour 1 … log2(n) levels coarser (the coarser one's
    nodes are every 2^k-th of this one's, the same heights: the gap is exact), and at least
    MIN_SKIRT_CELLS cells."""
    h = np.asarray(heights, np.float64)
    n = h.shape[0] - 1
    edges = np.stack([h[0, :], h[-1, :], h[:, 0], h[:, -1]])
    return float(max(_lod_gap(edges, n).max(), MIN_SKIRT_CELLS * cell_m))


def _lod_gap(edges: np.ndarray, n: int) -> np.ndarray:
    """Largest |I_la - I_lb| along each edge (..., n + 1) over all pairs of levels, (...)."""
    k = np.arange(n + 1)
    lo = hi = edges
    for level in range(1, level_count(n)):
        s = 1 << level
        a = np.minimum(k // s, n // s - 1)
        t = (k - a * s) / s
        interp = edges[..., a * s] * (1 - t) + edges[..., a * s + s] * t
        lo, hi = np.minimum(lo, interp), np.maximum(hi, interp)
    return (hi - lo).max(axis=-1)


EDGE_OFFSETS = ((0, -1), (1, 0), (0, 1), (-1, 0))
"""The neighbour across each edge of a tile, as (dx, dy) tiles: south (j = 0), east (i = n),
north (j = n), west (i = 0)."""


def coarser_neighbours(keys: np.ndarray) -> np.ndarray:
    """For each of the drawn tiles ``keys`` (K, 3) (level, tx, ty) — a set of quadtree tiles
    none of which contains another — the row of the tile across each edge
    (:data:`EDGE_OFFSETS`) when that tile is coarser, (K, 4) int64; −1 where the neighbour is
    as fine or finer, or none is drawn there. A tile coarser than ``T`` across an edge covers
    the whole edge, so one tile answers (:func:`riverflow.kernels.tile_cut.coarser_across`:
    ~10 µs for a frame's ~80 tiles, where the same in Python took 0.3 ms)."""
    keys = np.ascontiguousarray(keys, np.int64).reshape(-1, 3)
    out = np.empty((len(keys), 4), np.int64)
    coarser_across(keys, out)
    return out


def edge_levels_up(keys: np.ndarray, across: np.ndarray) -> np.ndarray:
    """How many levels coarser the tile across each edge is, (K, 4) int64 (0: as fine or
    finer, or none), for the drawn tiles ``keys`` (K, 3) and their :func:`coarser_neighbours`
    ``across`` (K, 4): which of :func:`tile_index_parts`' edge variants each tile draws."""
    level = np.asarray(keys, np.int64).reshape(-1, 3)[:, 0]
    across = np.asarray(across, np.int64)
    return np.where(across >= 0, level[:, None] - level[np.maximum(across, 0)], 0)


def _edge_nodes(e: int, n: int) -> tuple[np.ndarray, np.ndarray]:
    """(i, j) of the nodes of edge ``e`` of an n-cell tile, along it (x or y growing)."""
    k = np.arange(n + 1)
    fixed = np.full(n + 1, 0 if e in (0, 3) else n)
    return (k, fixed) if e in (0, 2) else (fixed, k)


def stitch_tile(vertices: np.ndarray, key, skirt_m: float,
                neighbours: list[tuple[int, tuple[int, int, int], np.ndarray]]) -> np.ndarray:
    """A copy of a terrain tile's ``vertices`` (V, 8) (:func:`tile_terrain_mesh`'s layout) of
    tile ``key`` whose border follows its coarser neighbours: for each (edge, neighbour key,
    neighbour's vertices as drawn) the edge's nodes take the neighbour's border linearly
    interpolated between its nodes (exact fractions of its cells: 2^-k steps): height, normal
    (renormalised), water level seen and shore distance; a corner only its height (a corner
    is shared with a third tile: its own normal and shading stay). The skirt vertices follow
    their border vertex, ``skirt_m`` lower."""
    v = np.array(vertices, np.float32, copy=True)
    n = math.isqrt(len(v) + 8) - 3                # V = (n + 1)² + 4n = (n + 3)² − 8
    if (n + 3) ** 2 - 8 != len(v):
        raise ValueError(f"{len(v)} vertices are not a terrain tile's (n + 1)² + 4n")
    side = n + 1
    grid = v[:side * side].reshape(side, side, 8)
    level, tx, ty = (int(c) for c in key)
    for e, (nl, nx, ny), nv in neighbours:
        k = level - int(nl)
        if k <= 0:
            continue
        ngrid = np.asarray(nv, np.float32)[:side * side].reshape(side, side, 8)
        i, j = _edge_nodes(e, n)
        along = np.arange(n + 1, dtype=np.int64) + (tx if e in (0, 2) else ty) * n
        g = along >> k                                  # the coarse node at or before
        t = ((along - (g << k)) / float(1 << k))[:, None]
        local = g - (nx if e in (0, 2) else ny) * n
        nxt = np.minimum(local + 1, n)
        ni, nj = _edge_nodes((e + 2) % 4, n)          # the neighbour's facing edge
        a = ngrid[nj[local], ni[local], 2:].astype(np.float64)
        b = ngrid[nj[nxt], ni[nxt], 2:].astype(np.float64)
        value = a * (1.0 - t) + b * t
        normal = value[:, 1:4]
        value[:, 1:4] = normal / np.linalg.norm(normal, axis=1, keepdims=True)
        inner = slice(1, n)
        grid[j[inner], i[inner], 2:] = value[inner]
        grid[j[[0, n]], i[[0, n]], 2] = value[[0, n], 0]
    bi, bj = border_loop(n)
    skirt = v[side * side:]
    skirt[:, 2:] = grid[bj, bi, 2:]
    skirt[:, 2] -= np.float32(skirt_m)
    skirt[:, 6] -= np.float32(skirt_m)
    return v


def tile_indices(n: int, stride: int = 1, skirts: bool = True) -> np.ndarray:
    """Triangle indices (K, 3) uint32 of an n-cell tile, the same for every tile (one index
    buffer serves them all): first the 2n² grid triangles (two per cell, the diagonal from
    (i, j) to (i + 1, j + 1)), counter-clockwise seen from +z, then (``skirts``) the 8n skirt
    triangles (two per border segment), facing outward. ``stride`` > 1 (dividing n) uses
    every stride-th node only, a coarser mesh of the same vertices (stride² fewer triangles;
    the reflection pass draws it, without skirts: seen from under the mirror they would hang
    in front of the ground as blocks)."""
    side = n + 1
    if stride < 1 or n % stride:
        raise ValueError(f"stride {stride} must divide the tile's {n} cells")
    g = np.arange(0, n, stride)
    jj, ii = np.meshgrid(g, g, indexing="ij")
    a = (jj * side + ii).ravel()  # (i, j)
    b, c, d = a + stride, a + stride * (side + 1), a + stride * side  # the cell's corners
    grid = np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)])
    if not skirts:
        return grid.astype(np.uint32)
    bi, bj = border_loop(n)
    k0 = np.arange(0, 4 * n, stride)
    k1 = (k0 + stride) % (4 * n)
    t0, t1 = bj[k0] * side + bi[k0], bj[k1] * side + bi[k1]
    b0, b1 = side * side + k0, side * side + k1
    skirt = np.concatenate([np.stack([t0, b0, b1], 1), np.stack([t0, b1, t1], 1)])
    return np.concatenate([grid, skirt]).astype(np.uint32)


class TileIndexParts(NamedTuple):
    """A terrain tile's triangles (:func:`tile_index_parts`) in five parts drawn together:
    ``core`` (T, 3) uint32, the cells at least one ``stride`` from the border, and ``edges``,
    for each edge (:data:`EDGE_OFFSETS` order) and each level difference k = 0 … L − 1 to the
    neighbour across it, the strip between the edge and the core's outline (T, 3) uint32
    through every (stride·2^k)-th border node (at most the whole edge), then its skirt."""

    core: np.ndarray
    edges: list[list[np.ndarray]]
    skirt_counts: list[list[int]]
    """Triangles of each ``edges`` part that are skirt (its last ones; 0 without skirts)."""


def tile_index_parts(n: int, stride: int = 1, skirts: bool = True) -> TileIndexParts:
    """The triangles of an n-cell tile (:func:`tile_indices`' vertices and winding) as a
    core and per-edge strips, one strip per level difference to the neighbour across the
    edge: the terrain's seams without touching the vertices (the usual edge index-buffer
    variants of tiled terrain). Toward a neighbour k levels coarser the strip uses every
    2^k-th border node only, the nodes the neighbour has (its border drawn linear between
    them: the same heights at the same places), fanned to the core's outline one node in; the
    border nodes in between are skipped, so the two tiles share their edge exactly. Beyond
    log2(n / stride) levels the edge is one segment (its corners, not the neighbour's nodes:
    :func:`stitch_tile` moves them). At k = 0 with ``stride`` 1 the parts hold the same
    triangles as :func:`tile_indices` but in two corner cells, cut along their other diagonal.
    ``stride`` (dividing n, n / stride ≥ 2) draws every stride-th node (the reflection)."""
    if stride < 1 or n % stride or n // stride < 2:
        raise ValueError(f"stride {stride} must divide the tile's {n} cells at least twice")
    side = n + 1
    s = stride
    g = np.arange(s, n - s, s)
    jj, ii = np.meshgrid(g, g, indexing="ij")
    a = (jj * side + ii).ravel()
    b, c, d = a + s, a + s * (side + 1), a + s * side
    core = np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)]).reshape(-1, 3)
    bi, bj = border_loop(n)
    levels = level_count(n // s)
    edges, skirt_counts = [], []
    for e in range(4):
        # the edge in the loop's direction, position p = 0 … n; inward one stride
        p = np.arange(n + 1)
        loop = (e * n + p) % (4 * n)
        inward = np.array([(0, 1), (-1, 0), (0, -1), (1, 0)][e])
        inner = np.arange(s, n - s + 1, s)
        inner_ij = np.stack([bi[(e * n + inner) % (4 * n)], bj[(e * n + inner) % (4 * n)]], 1) \
            + s * inward
        inner_v = inner_ij[:, 1] * side + inner_ij[:, 0]
        border_v = bj[loop] * side + bi[loop]
        tie_inner = e in (0, 2)                  # as tile_indices' diagonals at k = 0
        parts, counts = [], []
        for k in range(levels):
            step = min(s << k, n)
            bp = np.arange(0, n + 1, step)
            tris = _zip_strip(bp, border_v[bp], inner, inner_v, tie_inner)
            if skirts:
                t0, t1 = border_v[bp[:-1]], border_v[bp[1:]]
                b0 = side * side + loop[bp[:-1]]
                b1 = side * side + (e * n + bp[1:]) % (4 * n)
                skirt = np.concatenate([np.stack([t0, b0, b1], 1), np.stack([t0, b1, t1], 1)])
                tris = np.concatenate([tris, skirt])
                counts.append(len(skirt))
            else:
                counts.append(0)
            parts.append(tris.astype(np.uint32))
        edges.append(parts)
        skirt_counts.append(counts)
    return TileIndexParts(core.astype(np.uint32), edges, skirt_counts)


def _zip_strip(bp: np.ndarray, bv: np.ndarray, ip: np.ndarray, iv: np.ndarray,
               tie_inner: bool) -> np.ndarray:
    """Triangles (T, 3) joining a border polyline (positions ``bp``, vertices ``bv``) and the
    inner one (``ip``, ``iv``) running beside it: from the first pair to the last, each
    triangle advances the side whose next node comes first along the edge (``tie_inner``:
    the inner side on a tie), counter-clockwise seen from +z (positions grow along the
    border loop's counter-clockwise direction, the inner line on its left)."""
    out = []
    b = i = 0
    while b < len(bp) - 1 or i < len(ip) - 1:
        if i == len(ip) - 1 or (b < len(bp) - 1 and (bp[b + 1] < ip[i + 1] or (
                bp[b + 1] == ip[i + 1] and not tie_inner))):
            out.append((bv[b], bv[b + 1], iv[i]))
            b += 1
        else:
            out.append((bv[b], iv[i + 1], iv[i]))
            i += 1
    return np.array(out, np.int64).reshape(-1, 3)


# -- water --------------------------------------------------------------------------------


@dataclass(eq=False)
class WaterMesh:
    """The water surface as triangles: ``positions`` (V, 3) float32 [m] (x, y, water level),
    ``indices`` (K, 3) uint32 (counter-clockwise seen from +z), ``area_m2`` the triangles'
    total area seen from above [m²] and ``cell_m`` the grid every triangle keeps within."""

    positions: np.ndarray
    indices: np.ndarray
    area_m2: float
    cell_m: float


def triangulate_water(polygon, origin_m, cell_m: float, level) -> WaterMesh:
    """Triangulate ``polygon`` (a tile's piece of the water; islands are holes) cell by cell.

    The grid has ``cell_m`` cells and passes through ``origin_m`` (a tile's corner). Cells
    the polygon's boundary does not touch are either dry (skipped) or wholly wet (two
    triangles); the others are clipped to the polygon (``shapely.intersection``, vectorised,
    through blocks of 16 × 16 cells) and each piece is triangulated with
    ``shapely.constrained_delaunay_triangles``. So the mesh covers exactly the polygon, and
    every triangle lies inside one cell: none is longer than a cell's diagonal, whatever the
    river's width. Vertices are rounded to a 0.1 mm lattice, then to float32, and merged
    (shared by neighbouring triangles and cells: no T-junctions between cells); their z is
    ``level(xy)``. Triangles are wound counter-clockwise and those of zero area after the
    rounding are dropped (areas and signs are computed from the float32 positions).
    Triangles are sorted by cell (row-major), the triangles of one cell consecutive.

    Args:
        polygon: a shapely (multi)polygon, maybe empty.
        origin_m: (x, y) [m] a corner of the grid.
        cell_m: grid cell [m].
        level: ``level(xy (N, 2) float64) -> (N,)`` the water level [m].

    Returns:
        the :class:`WaterMesh` (a finest default-scene tile, 8 m cells: about 400
        triangles, at most about 1,300).
    """
    cell = float(cell_m)
    origin = np.asarray(origin_m, np.float64)
    if polygon.is_empty:
        return WaterMesh(np.zeros((0, 3), np.float32), np.zeros((0, 3), np.uint32), 0.0, cell)
    x0, y0, x1, y1 = polygon.bounds
    i0, j0 = int(np.floor((x0 - origin[0]) / cell)) - 1, int(np.floor((y0 - origin[1]) / cell)) - 1
    nx = int(np.ceil((x1 - origin[0]) / cell)) + 1 - i0
    ny = int(np.ceil((y1 - origin[1]) / cell)) + 1 - j0
    corner = origin + np.array([i0, j0]) * cell  # cell (0, 0) of the local grid

    edge = _edge_cells(polygon, corner, cell, nx, ny)
    ci, cj = np.meshgrid(np.arange(nx), np.arange(ny))
    centre = corner + (np.stack([ci.ravel(), cj.ravel()], 1) + 0.5) * cell
    inside = np.zeros(nx * ny, bool)
    rest = np.flatnonzero(~edge)
    if len(rest):
        shapely.prepare(polygon)  # no-op when it already is
        inside[rest] = shapely.contains_xy(polygon, centre[rest, 0], centre[rest, 1])

    full = np.flatnonzero(inside)
    lo = corner + np.stack([full % nx, full // nx], 1) * cell
    q = lo[:, None, :] + np.array([[0, 0], [cell, 0], [cell, cell], [0, cell]])[None]
    tris = [q[:, [0, 1, 2]], q[:, [0, 2, 3]]]

    cut = np.flatnonzero(edge)
    lo = corner + np.stack([cut % nx, cut // nx], 1) * cell
    boxes = shapely.box(lo[:, 0], lo[:, 1], lo[:, 0] + cell, lo[:, 1] + cell)
    # clip in two steps, blocks of _BLOCK² cells first: each cell then meets a small polygon
    block = (cut // nx) // _BLOCK * (nx // _BLOCK + 1) + (cut % nx) // _BLOCK
    blocks, of_cell = np.unique(block, return_inverse=True)
    blo = corner + np.stack([blocks % (nx // _BLOCK + 1), blocks // (nx // _BLOCK + 1)], 1) * (
        _BLOCK * cell)
    near = shapely.intersection(
        shapely.box(blo[:, 0], blo[:, 1], blo[:, 0] + _BLOCK * cell, blo[:, 1] + _BLOCK * cell),
        polygon)
    pieces = shapely.intersection(boxes, near[of_cell])
    parts = shapely.get_parts(pieces)  # polygons, and the odd line or point where it only touches
    parts = parts[np.isin(shapely.get_type_id(parts), (3, 6))]  # (multi)polygons
    triangles = shapely.get_parts(shapely.constrained_delaunay_triangles(parts))
    tris.append(shapely.get_coordinates(triangles).reshape(-1, 4, 2)[:, :3])

    tris = np.concatenate(tris)  # (K, 3, 2) float64 [m]
    cell_ij = np.floor((tris.mean(axis=1) - corner) / cell).astype(np.int64)
    tris = tris[np.argsort(cell_ij[:, 1] * nx + cell_ij[:, 0], kind="stable")]
    # merge on the lattice, then as float32 (what is drawn); signs and areas from those
    xy32 = (np.rint(tris * _LATTICE) / _LATTICE).astype(np.float32).reshape(-1, 2) + np.float32(0)
    unique, inverse = np.unique(xy32.view(np.uint64).ravel(), return_inverse=True)
    xy = unique.view(np.float32).reshape(-1, 2)
    indices = inverse.reshape(-1, 3)
    cross = _cross(xy, indices)
    keep = cross != 0.0
    indices, cross = indices[keep], cross[keep]
    indices[cross < 0] = indices[cross < 0][:, [0, 2, 1]]
    used = np.zeros(len(xy), bool)
    used[indices] = True  # vertices of dropped triangles only are dropped too
    renumber = np.cumsum(used) - 1
    positions = np.empty((int(used.sum()), 3), np.float32)
    positions[:, :2] = xy[used]
    positions[:, 2] = level(positions[:, :2].astype(np.float64))
    return WaterMesh(positions, renumber[indices].astype(np.uint32),
                     0.5 * float(np.abs(cross).sum()), cell)


def _cross(xy: np.ndarray, indices: np.ndarray) -> np.ndarray:
    """Twice the signed area [m²] of triangles (K, 3) of vertices (V, 2), (K,) float64,
    positive when counter-clockwise; exact but for the last bit from float32 inputs."""
    p = xy.astype(np.float64)
    a, b, c = p[indices[:, 0]], p[indices[:, 1]], p[indices[:, 2]]
    return (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])


def _edge_cells(polygon, corner: np.ndarray, cell: float, nx: int, ny: int) -> np.ndarray:
    """(ny * nx,) bool: cells of the local grid (cell (i, j) at corner + (i, j) · cell) that
    the polygon's boundary may touch: a superset found from the bounding boxes of its
    segments, split to at most half a cell, each widened by a hair so that a segment on a
    grid line marks the cells on both sides."""
    rings = shapely.segmentize(shapely.get_rings(shapely.get_parts(polygon)), 0.5 * cell)
    xy, ring = shapely.get_coordinates(rings, return_index=True)
    same = ring[1:] == ring[:-1]
    a, b = (xy[:-1][same] - corner) / cell, (xy[1:][same] - corner) / cell
    eps = 1e-9 * max(nx, ny)
    lo = np.floor(np.minimum(a, b) - eps).astype(np.int64)
    hi = np.floor(np.maximum(a, b) + eps).astype(np.int64)
    edge = np.zeros((ny, nx), bool)
    for di in range(3):  # segments up to half a cell (+ eps) span at most 3 cells per axis
        for dj in range(3):
            ok = (lo[:, 0] + di <= hi[:, 0]) & (lo[:, 1] + dj <= hi[:, 1])
            edge[lo[ok, 1] + dj, lo[ok, 0] + di] = True
    return edge.ravel()
