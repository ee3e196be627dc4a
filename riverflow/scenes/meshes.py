"""Triangle meshes of a scene for the draw system: terrain tiles with levels of detail, and
the water surface. Plain numpy, no GL: the draw system uploads these arrays as they are.

**Terrain** (:func:`terrain_mesh`, :func:`lod_indices`, :func:`choose_levels`,
:func:`tile_bounds`). Every tile has the same vertex layout, so one index buffer per level of
detail serves all tiles (drawn with a base vertex of ``t * vertices_per_tile``). Tile ``t =
iy * tiles_x + ix``; with ``n = cells_per_tile`` its ``V = (n + 1)² + 4n`` vertices are

* ``j * (n + 1) + i`` (0 ≤ i, j ≤ n): the grid sample ``heights_m[iy·n + j, ix·n + i]`` at
  ``origin_m + ((ix·n + i), (iy·n + j)) · cell_m`` (row-major, row = y);
* ``(n + 1)² + k`` (0 ≤ k < 4n): the skirt copy of border vertex ``k`` of the tile's border
  loop, ``skirt_m[t]`` lower. The loop runs counter-clockwise seen from above, starting at the
  corner (0, 0): along j = 0 (i = 0 … n-1), up i = n (j = 0 … n-1), back along j = n
  (i = n … 1), down i = 0 (j = n … 1) (:func:`border_loop`).

Level ``l`` draws every ``2**l``-th sample. Where neighbouring tiles are drawn at different
levels their shared edges differ (T-junctions, a crack of up to a few metres on hills); each
tile hangs a vertical skirt from its border, deep enough to hide the largest such crack
(:func:`skirt_depths`). This is the usual skirt trick of tiled terrain renderers (Proland's
own terrain blends levels in the vertex shader instead; its rivers need no mesh, reference
§4.1).

**Water** (:func:`water_mesh`). Tessellating a wide water polygon in one piece gives long
thin triangles whose corners sample very different terrain altitudes, the artifact Proland's
documentation warns of (reference §4.1, §4.9). Here the polygon is cut by a square grid first
and each piece is triangulated on its own, so every triangle lies inside one grid cell.

Orientation everywhere: x east, y north, z up; triangles are counter-clockwise seen from +z
(skirt triangles face outward, away from their tile).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import shapely

LOD_DISTANCE_M = 512.0
"""Default distance [m] within which tiles are drawn at full detail (level 0)."""
MIN_SKIRT_CELLS = 2.0
"""The skirts reach at least this many cells below their border."""
WATER_CELL_M = 8.0
"""Default grid cell [m] of the water mesh."""
_BLOCK = 16  # the water polygon is clipped to blocks of _BLOCK² cells, then to cells
_LATTICE = 1e4  # water vertices are merged on a 0.1 mm lattice [1/m]


# -- terrain ------------------------------------------------------------------------------


@dataclass(eq=False)
class TerrainMesh:
    """Vertices of every terrain tile (layout in the module docstring).

    ``positions`` (T, V, 3) float32 [m] and ``normals`` (T, V, 3) float32 (unit), with T
    tiles (``t = iy * tiles[0] + ix``) and V = (n + 1)² + 4n vertices per tile;
    ``skirt_m`` (T,) float32 [m] how far each tile's skirt hangs below its border;
    ``bounds_m`` (T, 2, 3) float32 [m] the (min, max) corners of each tile's box, skirt
    included; ``cells_per_tile`` n; ``tiles`` (tiles along x, tiles along y).
    """

    positions: np.ndarray
    normals: np.ndarray
    skirt_m: np.ndarray
    bounds_m: np.ndarray
    cells_per_tile: int
    tiles: tuple[int, int]

    @property
    def vertices_per_tile(self) -> int:
        """V = (n + 1)² grid vertices + 4n skirt vertices."""
        return self.positions.shape[1]

    @property
    def centres_m(self) -> np.ndarray:
        """(T, 3) float32 [m] centres of the tiles' boxes (for :func:`choose_levels`)."""
        return self.bounds_m.mean(axis=1)

    @property
    def levels(self) -> int:
        """Number of levels of detail (see :func:`level_count`)."""
        return level_count(self.cells_per_tile)


def level_count(n: int) -> int:
    """Levels of detail of an n-cell tile: level l (stride 2**l) exists while 2**l divides n,
    so 1 + log2(n) levels for a power of two (n = 64: levels 0 … 6)."""
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


def lod_indices(n: int, levels: int | None = None) -> list[np.ndarray]:
    """Triangle indices of an n-cell tile at each level of detail (same for every tile).

    Level l uses the samples at stride s = 2**l. Each array is (K_l, 3) uint32, indices
    relative to the tile's first vertex: first the 2·(n/s)² grid triangles (two per quad, the
    diagonal from (i, j) to (i + s, j + s)), counter-clockwise seen from +z, then the
    2·4·(n/s) skirt triangles (two per border segment of length s), facing outward.

    Args:
        n: cells per tile.
        levels: how many levels (default and maximum :func:`level_count` (n)).

    Returns:
        list of ``levels`` arrays, level 0 (full detail, 2n² + 8n triangles) first.
    """
    top = level_count(n)
    levels = top if levels is None else int(levels)
    if not 1 <= levels <= top:
        raise ValueError(f"an {n}-cell tile has 1 … {top} levels, not {levels}")
    side = n + 1
    out = []
    for level in range(levels):
        s = 1 << level
        g = np.arange(0, n, s)
        jj, ii = np.meshgrid(g, g, indexing="ij")
        a = (jj * side + ii).ravel()  # (i, j)
        b, c, d = a + s, a + s * side + s, a + s * side  # (i+s, j), (i+s, j+s), (i, j+s)
        grid = np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)])
        bi, bj = border_loop(n)
        k0 = np.arange(0, 4 * n, s)
        k1 = (k0 + s) % (4 * n)
        t0, t1 = bj[k0] * side + bi[k0], bj[k1] * side + bi[k1]
        b0, b1 = side * side + k0, side * side + k1
        skirt = np.concatenate([np.stack([t0, b0, b1], 1), np.stack([t0, b1, t1], 1)])
        out.append(np.concatenate([grid, skirt]).astype(np.uint32))
    return out


def skirt_depths(terrain) -> np.ndarray:
    """Default skirt depth of every tile [m], (T,) float32.

    Along a tile edge, the edge drawn at level l is the piecewise-linear interpolation of the
    samples at stride 2**l; two tiles at levels la and lb leave a vertical gap of
    |I_la(x) - I_lb(x)| between them, which the skirt of the higher side hides if it is at
    least that deep. Each tile's skirt is the largest such gap over any pair of levels along
    any of its four edges (exact, computed at the samples where the gap peaks), and at least
    ``MIN_SKIRT_CELLS`` cells (also hides pixel-wide rasterisation gaps at T-junctions on
    flat ground). Default scene: 8 m (the minimum) to about 10 m.
    """
    h = terrain.heights_m.astype(np.float64)
    n = terrain.cells_per_tile
    tx, ty = terrain.tile_count
    win = np.lib.stride_tricks.sliding_window_view
    rows = win(h[::n, :], n + 1, axis=1)[:, ::n]  # (ty + 1, tx, n + 1): edges along x
    cols = win(h[:, ::n].T, n + 1, axis=1)[:, ::n]  # (tx + 1, ty, n + 1): edges along y
    gap_rows, gap_cols = _lod_gap(rows, n), _lod_gap(cols, n)
    tile = np.maximum(np.maximum(gap_rows[:-1], gap_rows[1:]),  # (ty, tx)
                      np.maximum(gap_cols[:-1], gap_cols[1:]).T)
    return np.maximum(tile, MIN_SKIRT_CELLS * terrain.cell_m).astype(np.float32).ravel()


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


def tile_bounds(terrain, skirt_m: float | np.ndarray | None = None) -> np.ndarray:
    """Axis-aligned box of every tile, skirt included, for frustum culling.

    Args:
        terrain: a :class:`~riverflow.components.terrain.Terrain`.
        skirt_m: skirt depth [m], one for all or (T,); default :func:`skirt_depths`.

    Returns:
        (T, 2, 3) float32 [m]: ``[t, 0]`` the (x, y, z) minimum, ``[t, 1]`` the maximum.
    """
    n = terrain.cells_per_tile
    tx, ty = terrain.tile_count
    skirt = skirt_depths(terrain) if skirt_m is None else np.broadcast_to(
        np.asarray(skirt_m, np.float32), (tx * ty,))
    blocks = np.lib.stride_tricks.sliding_window_view(terrain.heights_m, (n + 1, n + 1))[::n, ::n]
    x0 = terrain.origin_m[0] + np.arange(tx) * terrain.tile_size_m
    y0 = terrain.origin_m[1] + np.arange(ty) * terrain.tile_size_m
    gx, gy = np.meshgrid(x0, y0)  # (ty, tx)
    out = np.empty((ty * tx, 2, 3), np.float64)
    out[:, 0, 0], out[:, 0, 1] = gx.ravel(), gy.ravel()
    out[:, 1, 0], out[:, 1, 1] = gx.ravel() + terrain.tile_size_m, gy.ravel() + terrain.tile_size_m
    bi, bj = border_loop(n)
    out[:, 0, 2] = np.minimum(blocks.min(axis=(2, 3)).ravel(),
                              blocks[..., bj, bi].min(axis=-1).ravel() - skirt)
    out[:, 1, 2] = blocks.max(axis=(2, 3)).ravel()
    return out.astype(np.float32)


def terrain_normals(terrain) -> np.ndarray:
    """Unit normals of the whole heightfield, (ny, nx, 3) float32: central differences
    inside, one-sided at the terrain's edges (so tiles agree on their shared borders)."""
    dz_dy, dz_dx = np.gradient(terrain.heights_m.astype(np.float64), terrain.cell_m)
    normal = np.stack([-dz_dx, -dz_dy, np.ones_like(dz_dx)], axis=-1)
    normal /= np.linalg.norm(normal, axis=-1, keepdims=True)
    return normal.astype(np.float32)


def terrain_mesh(terrain, skirt_m: float | None = None) -> TerrainMesh:
    """Vertices of every tile of ``terrain`` (layout in the module docstring).

    Args:
        terrain: a :class:`~riverflow.components.terrain.Terrain`.
        skirt_m: depth of every skirt [m]; default per tile :func:`skirt_depths` (deep
            enough that no level-of-detail crack shows).

    Returns:
        the :class:`TerrainMesh` (default scene: 256 tiles × 4,481 vertices, 27.5 MB).
    """
    n = terrain.cells_per_tile
    tx, ty = terrain.tile_count
    side = n + 1
    skirt = skirt_depths(terrain) if skirt_m is None else np.full(tx * ty, skirt_m, np.float32)
    win = np.lib.stride_tricks.sliding_window_view
    bi, bj = border_loop(n)
    grid_j, grid_i = np.divmod(np.arange(side * side), side)
    vj, vi = np.concatenate([grid_j, bj]), np.concatenate([grid_i, bi])  # (V,) per-tile sample

    heights = win(terrain.heights_m, (side, side))[::n, ::n].reshape(tx * ty, side, side)
    positions = np.empty((tx * ty, len(vi), 3), np.float32)
    tile_j, tile_i = np.divmod(np.arange(tx * ty), tx)
    positions[..., 0] = terrain.origin_m[0] + (tile_i[:, None] * n + vi) * terrain.cell_m
    positions[..., 1] = terrain.origin_m[1] + (tile_j[:, None] * n + vj) * terrain.cell_m
    positions[..., 2] = heights[:, vj, vi]
    positions[:, side * side:, 2] -= skirt[:, None]

    normals = win(terrain_normals(terrain), (side, side), axis=(0, 1))[::n, ::n]
    normals = np.moveaxis(normals.reshape(tx * ty, 3, side, side), 1, -1)[:, vj, vi]
    bounds = tile_bounds(terrain, skirt)
    return TerrainMesh(positions, np.ascontiguousarray(normals), skirt, bounds, n, (tx, ty))


def choose_levels(tile_centres: np.ndarray, eye: np.ndarray, tile_size_m: float, n: int,
                  lod_distance_m: float = LOD_DISTANCE_M) -> np.ndarray:
    """Level of detail of every tile for an eye position.

    The distance of a tile is the eye's distance to its centre less half the tile's diagonal
    (so a tile is never coarser than its nearest corner would ask, to within its height).
    Level 0 within ``lod_distance_m``, one level coarser per doubling beyond, at most the
    coarsest level of an n-cell tile: ``ceil(log2(d / lod_distance_m))``, clipped.

    Args:
        tile_centres: (T, 3) [m], e.g. :attr:`TerrainMesh.centres_m`.
        eye: (3,) [m] camera position.
        tile_size_m: tile side [m].
        n: cells per tile.
        lod_distance_m: the full-detail distance [m].

    Returns:
        (T,) int64 levels, non-decreasing with distance.
    """
    c = np.asarray(tile_centres, np.float64).reshape(-1, 3)
    d = np.linalg.norm(c - np.asarray(eye, np.float64).reshape(3), axis=1)
    d = np.maximum(d - tile_size_m * np.sqrt(0.5), 0.0)
    ratio = np.maximum(d / float(lod_distance_m), 1.0)
    return np.clip(np.ceil(np.log2(ratio)), 0, level_count(n) - 1).astype(np.int64)


# -- one tile of the streamed terrain --------------------------------------------------------


@dataclass(eq=False)
class TerrainTileMesh:
    """One streamed terrain tile as drawn: ``vertices`` (V, 7) float32 (x, y, z [m], unit
    normal, the water level seen from there [m]) in the layout of the module docstring (grid
    samples, then the skirt), ``skirt_m`` [m], ``bounds_m`` (2, 3) float32 (min, max corner,
    skirt included)."""

    vertices: np.ndarray
    skirt_m: float
    bounds_m: np.ndarray

    @property
    def nbytes(self) -> int:
        return int(self.vertices.nbytes + self.bounds_m.nbytes)


def tile_terrain_mesh(z_ring: np.ndarray, x0_m: float, y0_m: float, cell_m: float,
                      level_m: np.ndarray) -> TerrainTileMesh:
    """The mesh of one n-cell terrain tile from its heights with a one-node ring
    ``z_ring`` (n + 3, n + 3) [m] (row = y; the ring gives central-difference normals that
    agree with the neighbours'), its corner and node spacing [m] and ``level_m`` (n + 1, n + 1)
    the water level seen from each node. The skirt hangs as deep as the largest crack any
    coarser neighbour can leave along its border (:func:`tile_skirt_m`)."""
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
    out = np.empty((len(vi), 7), np.float32)
    out[:, 0] = x0_m + vi * cell_m
    out[:, 1] = y0_m + vj * cell_m
    out[:, 2] = inner[vj, vi]
    out[side * side:, 2] -= skirt
    out[:, 3:6] = normal[vj, vi]
    out[:, 6] = np.asarray(level_m)[vj, vi]
    bounds = np.array([[x0_m, y0_m, min(inner.min(), inner[bj, bi].min() - skirt)],
                       [x0_m + n * cell_m, y0_m + n * cell_m, inner.max()]], np.float32)
    return TerrainTileMesh(out, float(skirt), bounds)


def tile_skirt_m(heights: np.ndarray, cell_m: float) -> float:
    """How deep a tile's skirt must hang [m]: the largest gap between its border, as drawn,
    and the same border drawn by a neighbour 1 … log2(n) levels coarser (the coarser one's
    nodes are every 2^k-th of this one's, the same heights: the gap is exact), and at least
    MIN_SKIRT_CELLS cells."""
    h = np.asarray(heights, np.float64)
    n = h.shape[0] - 1
    edges = np.stack([h[0, :], h[-1, :], h[:, 0], h[:, -1]])
    return float(max(_lod_gap(edges, n).max(), MIN_SKIRT_CELLS * cell_m))


def tile_indices(n: int) -> np.ndarray:
    """Triangle indices (K, 3) uint32 of an n-cell tile at full detail, skirt included (the
    same for every tile: one index buffer serves them all)."""
    return lod_indices(n, 1)[0]


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


def water_mesh(scene, cell_m: float = WATER_CELL_M) -> WaterMesh:
    """Triangulate ``scene.water.polygon`` (islands are holes) cell by cell.

    The grid is aligned with the terrain's samples (``scene.terrain.origin_m``). Cells the
    polygon's boundary does not touch are either dry (skipped) or wholly wet (two triangles);
    the others are clipped to the polygon (``shapely.intersection``, vectorised, through
    blocks of 16 × 16 cells) and each piece
    is triangulated with ``shapely.constrained_delaunay_triangles``. So the mesh covers
    exactly the water, and every triangle lies inside one cell: none is longer than a cell's
    diagonal, whatever the river's width. Vertices are rounded to a 0.1 mm lattice, then to
    float32, and merged (shared by neighbouring triangles and cells: no T-junctions between
    cells); they take ``scene.water.level`` as z. Triangles are wound counter-clockwise and
    those of zero area after the rounding are dropped (areas and signs are computed from the
    float32 positions). Triangles are sorted by cell (row-major), the triangles of one cell
    consecutive.

    Args:
        scene: anything with ``.water`` (``polygon``, ``level``) and ``.terrain``.
        cell_m: grid cell [m]. A multiple of the terrain cell keeps the water's triangles
            inside terrain cells too.

    Returns:
        the :class:`WaterMesh` (default scene at 8 m: 11.8k vertices, 20.4k triangles, 0.4 MB).
    """
    return triangulate_water(scene.water.polygon, scene.terrain.origin_m, cell_m,
                             scene.water.level)


def triangulate_water(polygon, origin_m, cell_m: float, level) -> WaterMesh:
    """:func:`water_mesh` of any polygon (a tile's piece of the water, say) on the grid of
    ``cell_m`` cells through ``origin_m``, vertices at ``level(xy)`` [m]."""
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
