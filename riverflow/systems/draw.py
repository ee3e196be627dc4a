"""Draw the rivers: sky, terrain tiles, the water with its wave sprites, debug overlays.

Per frame (reference §4; no one-frame latency: the tables are built from this frame's pool):

1. the sprite tables from the particle pool (numba, :mod:`riverflow.kernels.sprites`): the
   float32 sprite table, sorted by screen bin, and each bin's first entry, copied into an
   RGBA32F buffer texture (only the rows in use) and an R32I one; then, in the modes that blend
   sprites per pixel, the sprite grid made from them on the GPU (``sprite_lists.glsl``: each
   cell of r px lists up to 16 sprites, in an RGBA32I array texture);
2. sky (one full-screen triangle), then the terrain tiles of the view's cut (the tile system
   picks them: level of detail by distance; skirts hide the cracks between levels; a tile not
   made yet is stood in for by its finest resident ancestor), then the props (boats,
   barrels: :mod:`riverflow.components.props`), so that the water is drawn over their
   submerged part;
3. *pre-advected* mode only: the water's world position into a float target, then every
   sprite as a quad adding (w·slope, w²) into a second float target;
4. the water mesh tiles of the cut at the water level, shaded per :class:`DisplayMode`,
   blended over the bed drawn in step 2 (the shader writes what it adds and how much of the bed
   shows through); in the shaded modes the falls' sheets and spray over it
   (:mod:`riverflow.systems.draw_falls`; the sheets also in the reflection pass);
5. rain (:mod:`riverflow.systems.rain`): the drops as short streaks along their velocity
   (GL lines, depth-tested against the land and alpha-blended), and in step 4 ripple rings
   around the recent hits on the water, added to the water's slopes (none without rain);
   foam and wakes in step 4 too: each particle's foam (texel 3 of its sprite entry) blended
   through the sprite weights with a lace texture, the waterline's foam from the depth, and
   every boat's Kelvin wake added to the slopes (the wake table,
   :class:`~riverflow.components.wake.Wakes`); the spills' tint (issue 24) each particle
   carries (texel 3 too, sampled from the spills' grid before the tables are built:
   :meth:`DrawRivers._tint_particles`) blended alike (the concentration mode shows that grid
   as a texture);
6. overlays: particles as points, velocity arrows.

Reflections (issue 12 item 3; :attr:`DisplaySettings.reflections`, shaded water modes, the eye
above the water), before step 2: the terrain tiles (through every 2nd node) and the props
drawn mirrored in the mean level of the water in view (weighted by its share of the screen:
continuous as the camera moves; held, a second pass at a new level cross-faded in while it
changes), each cut at its own water
level, into a reduced-resolution colour + depth target with mip levels
(:mod:`riverflow.scenes.reflection`); in step 4 the water shader follows each pixel's
wave-bent reflected ray through it and Fresnel-weights what it finds over the sky
(``shaders/reflection.glsl``).

Everything is drawn into the world's own RGBA8 framebuffer (with a depth texture shared by
the passes); :meth:`DrawRivers.blit_to_window` copies it to the window a host draws in.

GPU objects follow the tile cache: a terrain or water tile is uploaded when it is first drawn
and released when the cache evicts it (:class:`_TerrainTiles`, :class:`_WaterTiles`). Every
terrain tile has the same vertex count and the same triangles, so all of them share GPU
buffers (a :class:`~riverflow.engine.gl.SlotArena`: one vertex buffer of fixed-size slots, one
index buffer holding the full and the reflection's coarse meshes in parts: a core and, per
edge, a strip for each level difference to the neighbour across, one vertex array), and a
pass draws all of a frame's terrain tiles, near to far, with one multi-draw call (five ranges
a tile, chosen when the drawn set changes: the seams to coarser neighbours cost no upload).
"""
from __future__ import annotations

import math
import time
import weakref
from typing import TYPE_CHECKING

import esper
import numpy as np
from riverflow.components.display import DisplayMode, DisplaySettings
from riverflow.components.foam import FoamSettings
from riverflow.components.wake import MAX_WAKES, TRAIL_POINTS, Wakes
from riverflow.components.props import Pose, Prop
from riverflow.components.rain import RIPPLE_RING, Rain
from riverflow.components.spill import Spill
from riverflow.components.river import TerrainView, Tiles
from riverflow.components.status import FlowStatus
from riverflow.components.waves import WaveTile
from riverflow.engine import gl
from riverflow.engine.system import System
from riverflow.systems.draw_falls import FallSheets, SprayQuads
from riverflow.systems.legend import concentration_bar, legend_panel_rgba
from riverflow.hydro.falls import RAPIDS_FULL_SLOPE, RAPIDS_MIN_SLOPE
from riverflow.hydro.spills import TINT_SAMPLE_EVERY, TINT_TEXELS, SpillTint
from riverflow.kernels.foam import foam_pattern_mips
from riverflow.kernels.spill import ParticleTint, TintGrid, sample_tint
from riverflow.kernels.tile_cut import EdgeParts, coarser_across, edge_parts, near_to_far
from riverflow.kernels.wake import wake_texture
from riverflow.kernels.sprites import (MAX_PER_CELL, NO_PARTICLE, PARTICLES_PER_ROW,
                                       SPRITE_RADIUS_FACTOR, TEXELS_PER_PARTICLE, bin_texels,
                                       build_sprite_tables, empty_sprite_tables, slot_span,
                                       sprite_bins, sprite_grid_shape, sprite_source)
from riverflow.scenes.meshes import (edge_levels_up, level_count,
                                     stitch_tile, tile_index_parts)
from riverflow.scenes.props import SHAPES
from riverflow.scenes.reflection import (MIN_EYE_HEIGHT_M, MIRROR_CUT_M, MIRROR_REFRESH_M,
                                          hold_levels,
                                         MIRROR_REFRESH_RAD, TERRAIN_STRIDE, ease_level, mirror_level, mirrored_view_projection,
                                         reflection_size)
from riverflow.scenes.tile_kinds import TERRAIN_MESH, WATER_MESH
from riverflow.tiles.cache import TilePool
from riverflow.tiles.cut import Standins, standin_tiles
from riverflow.tiles.table import codes

if TYPE_CHECKING:
    from riverflow.engine.world import RiverWorld

SUN_DIRECTION = np.array([-0.45, -0.55, 0.70]) / np.linalg.norm([-0.45, -0.55, 0.70])
"""Unit vector towards the sun (afternoon light from the south-west)."""
_SUN = tuple(SUN_DIRECTION.tolist())


def shader_defines() -> dict[str, int]:
    """The numbers the shaders share with Python and numba."""
    defines = gl.enum_defines(FlowStatus, DisplayMode)
    defines.update(MAX_PER_CELL=MAX_PER_CELL, NO_PARTICLE=NO_PARTICLE,
                   PARTICLES_PER_ROW=PARTICLES_PER_ROW,
                   TEXELS_PER_PARTICLE=TEXELS_PER_PARTICLE, DROPS_PER_ROW=DROPS_PER_ROW,
                   TRAIL_POINTS=TRAIL_POINTS)
    return defines


VIEW_FLOATS = 44
"""Floats of the view block (``shaders/common.glsl``: 168 bytes of std140, padded to 176)."""


def pack_view(out: np.ndarray, view_projection: np.ndarray, world_from_clip: np.ndarray,
              eye_m: np.ndarray, fog_density: float, clip_water: float,
              viewport_px: tuple[float, float]) -> None:
    """Write the view block of ``shaders/common.glsl`` (std140) into ``out`` (≥ VIEW_FLOATS
    float32): world → clip and clip → world as GL's column-major 4 × 4 ((16,) arrays: the
    transposes of the row-vector matrices, raveled), the eye [m] ((3,) array), the fog
    density, the sun's direction, ``clip_water`` (1: cut what is under the water) and the
    viewport [px], each cast to float32 as a ``glUniform*f`` call would (one assignment)."""
    out[:42] = [*view_projection.tolist(), *world_from_clip.tolist(), *eye_m.tolist(),
                fog_density, *_SUN, clip_water, *viewport_px]


DROPS_PER_ROW = 1024
"""Rain drops per row of the drop table (two RGBA32F texels each: position, velocity)."""

_SHADED_MODES = (DisplayMode.ADVECTED, DisplayMode.PRE_ADVECTED, DisplayMode.NON_ADVECTED)
_GRID_MODES = (DisplayMode.ADVECTED, DisplayMode.COVERAGE, DisplayMode.FOAM)
"""The modes whose water shader reads the sprite grid (blend_sprites)."""
"""The water modes shaded with reflections (the others draw debug colours)."""

TERRAIN_SLOTS = 128
"""Terrain tiles the GPU arena has room for at first (it doubles when full; a 1080p view's cut
is ~80-110 tiles)."""

FLOOD_CELLS_UNIT, FLOOD_RISE_UNIT = 16, 17
"""Texture units of the flood's cell texture and per-cell level rise (issue 25,
``shaders/flood.glsl``), read by the water's and the terrain's vertex shaders (15 is the GL
module's scratch unit)."""
FOAM_PATTERN_UNIT, WAKES_UNIT = 12, 13
SPILL_UNIT = 9
"""Texture unit of the spills' grid, the concentration mode's texture (issue 24,
``shaders/spill.glsl``). The falls' spray (SPRAY_UNIT) shares it: each binds its texture right
before the program that reads it draws (the grid before every water pass, the spray after the
water)."""
"""Texture units of the foam's lace pattern and the wake table (issue 12 items 1, 2)."""
FOAM_PATTERN_PX = 256
FOAM_SCALE_M = 3.0
"""World size of one period of the foam's lace pattern [m] (in each sprite's frame)."""


PARAMS_UNIT, GRID_UNIT, WAVE_UNIT, ACCUM_UNIT, WATER_POSITION_UNIT = 2, 3, 1, 4, 5
RIPPLES_UNIT, DROPS_UNIT, BINS_UNIT, SPRAY_UNIT = 6, 7, 8, 9
COMPOSITE_COLOUR_UNIT, COMPOSITE_DEPTH_UNIT = 0, 14
"""Texture units of the sprite table, sprite grid, wave tile, pre-advected sums, water
position, ripple table, rain drops and sprite bins."""


class _Gpu:
    """The world's GPU objects (made in the world's context on the first draw)."""

    def __init__(self, world: RiverWorld) -> None:
        defines = shader_defines()
        self.programs = {
            "sky": gl.Program("sky.glsl", defines),
            "terrain": gl.Program("terrain.glsl", defines),
            # the same for the reflection pass: each keeps its own uniforms (those of the
            # mirrored view are not sent again and again, twice a frame)
            "terrain_reflection": gl.Program("terrain.glsl", defines),
            "water": gl.Program("water.glsl", defines),
            "water_position": gl.Program("water.glsl", {**defines, "POSITION_PASS": 1}),
            "sprites": gl.Program("sprites.glsl", defines),
            "sprite_lists": gl.Program("sprite_lists.glsl", defines),
            "particles": gl.Program("particles.glsl", defines),
            "arrows": gl.Program("arrows.glsl", defines),
            "props": gl.Program("props.glsl", defines),
            "rain": gl.Program("rain.glsl", defines),
            "falls": gl.Program("falls.glsl", defines),
            "spray": gl.Program("spray.glsl", defines),
            "composite": gl.Program("composite.glsl"),
            "legend": gl.Program("legend.glsl"),
        }
        # the uniforms that never change (texture units, constants), set once: not checked
        # again every frame
        for program in self.programs.values():
            program.set_if_used(**_CONSTANT_UNIFORMS)
        bindings = {p.view_binding for p in self.programs.values()} - {None}
        if len(bindings) != 1:
            raise gl.GLError(f"the programs' view blocks have binding points {bindings}")
        self.view_binding = bindings.pop()
        self._defines = defines
        self.view = gl.UniformBuffer(VIEW_FLOATS, 2)
        """The view block: copy 0 for the frame's passes, 1 for the mirrored reflection pass."""
        self.drops = self.drops_cpu = None
        self.ripples_cpu = np.zeros((1, RIPPLE_RING, 4), np.float32)
        self.ripples = gl.Texture((RIPPLE_RING, 1), gl.RGBA32F)
        self.ripples.upload(self.ripples_cpu)
        levels = foam_pattern_mips(FOAM_PATTERN_PX, int(world.seed))
        self.foam_pattern = gl.Texture((FOAM_PATTERN_PX, FOAM_PATTERN_PX), gl.RG32F,
                                       levels=len(levels), linear=True, repeat=True)
        for k, level in enumerate(levels):
            self.foam_pattern.upload(level, level=k)
        self.wakes_cpu = np.zeros((MAX_WAKES, 1 + 2 * TRAIL_POINTS, 4), np.float32)
        self.wakes = gl.Texture((1 + 2 * TRAIL_POINTS, MAX_WAKES), gl.RGBA32F)
        self.spill_tint = SpillTint()
        self.spill = gl.Texture((TINT_TEXELS, TINT_TEXELS), gl.RGBA32F, linear=True)
        self.spill_version = -1
        self.tint_frame = -1                            # the frame the particles sampled it
        self.drawn_frame = -1                           # the last frame drawn
        self.legend: gl.Texture | None = None           # the concentration legend's panel
        self.legend_for: tuple = ()                     # (frame size, range) it was made for
        self.legend_bar = None
        self.flood_cells: gl.Texture | None = None      # made by the first flood drawn
        self.flood_rise: gl.Texture | None = None
        self.flood_rise_cpu: np.ndarray | None = None
        self.flood_for = None
        self.prop_meshes: dict[tuple, gl.Mesh] = {}
        self.terrain = _TerrainTiles(world.scene.terrain.tile_cells)
        self.water = _WaterTiles()
        self.empty = gl.Mesh(None, {})           # attribute-less draws (gl_VertexID)
        self.waves: dict[int, tuple[int, gl.Texture]] = {}
        self.size = (0, 0)
        self.fitted = None              # the arguments of the last fit()
        self.grid_shape = (1, 1, 1)
        self.bins_shape = None
        self.params = self.bins = self.grid = self.grid_fb = None
        self.params_cpu = self.starts_cpu = self.scratch = None
        self.targets: list = []
        self.reflection = _Reflection()
        self.reflection_b = _Reflection()       # the level faded in (hold_levels)
        self.fall_sheets = FallSheets()
        self.spray = SprayQuads()
        gl.check_errors("creating the river draw resources")

    # -- sized resources --------------------------------------------------------------------

    def fit(self, width: int, height: int, radius_px: float, capacity: int) -> None:
        """(Re)make the framebuffers and sprite tables for a viewport and radius."""
        fitted = (width, height, radius_px, capacity)
        if fitted == self.fitted:
            return                      # every frame but the first after a change
        width, height = max(1, width), max(1, height)
        bins = sprite_bins(width, height, radius_px)
        if (width, height) != self.size:
            for obj in self.targets:
                obj.delete()
            colour = gl.Texture((width, height), gl.RGBA8)
            depth = gl.Texture((width, height), gl.DEPTH24)
            position = gl.Texture((width, height), gl.RGBA32F)
            accum = gl.Texture((width, height), gl.RGBA32F)
            self.colour, self.depth, self.position, self.accum = colour, depth, position, accum
            self.main_fb = gl.Framebuffer([colour], depth)
            self.position_fb = gl.Framebuffer([position], depth)
            self.accum_fb = gl.Framebuffer([accum])
            self.targets = [self.main_fb, self.position_fb, self.accum_fb, colour, depth,
                            position, accum]
            self.size = (width, height)
        if self.params_cpu is None or bins != self.bins_shape \
                or self.params_cpu.shape[0] * PARTICLES_PER_ROW < capacity:
            for tex in (self.params, self.bins):
                if tex is not None:
                    tex.delete()
            self.params_cpu, self.starts_cpu, self.scratch = empty_sprite_tables(capacity, bins)
            self.params = gl.BufferTexture(self.params_cpu.size // 4, gl.RGBA32F)
            self.params.write(self.params_cpu)
            self.bins_view = bin_texels(self.starts_cpu, bins)   # the texture's texels
            self.bins = gl.BufferTexture(self.bins_view.size, gl.R32I)
            self.bins.write(self.bins_view)
            self.bins_shape = bins
        shape = sprite_grid_shape(width, height, radius_px)
        if self.grid is None or shape != self.grid_shape:
            for obj in (self.grid_fb, self.grid):
                if obj is not None:
                    obj.delete()
            _, gw, gh = shape
            layers = MAX_PER_CELL // 4
            self.grid = gl.Texture((gw, gh), gl.RGBA32I, layers=layers)
            self.grid.upload(np.full((layers, gh, gw, 4), NO_PARTICLE, np.int32))
            self.grid_fb = gl.Framebuffer([(self.grid, k) for k in range(layers)])
            self.grid_shape = shape
        self.fitted = fitted

    def flood_terrain(self) -> gl.Program:
        """The terrain's program with the flooded floodplain's waves (``FLOOD_WAVES``), made
        the first time a flood is drawn (the dry ground's program has none of its cost)."""
        program = self.programs.get("terrain_flood")
        if program is None:
            program = gl.Program("terrain.glsl", {**self._defines, "FLOOD_WAVES": 1})
            program.set_if_used(**_CONSTANT_UNIFORMS)
            if program.view_binding != self.view_binding:
                raise gl.GLError(f"the flood terrain's view block has binding point "
                                 f"{program.view_binding}, not {self.view_binding}")
            self.programs["terrain_flood"] = program
        return program

    def resident_codes(self, kind: str) -> set[int]:
        """Codes of the tiles of ``kind`` that have GPU data now."""
        return (self.terrain if kind == TERRAIN_MESH else self.water).codes()

    def wave_texture(self, entity: int, tile: WaveTile) -> gl.Texture:
        """The wave tile's array texture, (re)uploaded when its revision changes."""
        known = self.waves.get(entity)
        if known is not None and known[0] == tile.revision:
            return known[1]
        if known is not None:
            known[1].delete()
        levels = tile.levels
        frames, size = levels[0].shape[0], levels[0].shape[1]
        tex = gl.Texture((size, size), gl.RG32F, layers=frames, levels=len(levels),
                         linear=True, repeat=True)
        for k, level in enumerate(levels):
            tex.upload(level, level=k)
        self.waves[entity] = (tile.revision, tex)
        return tex

    def prop_mesh(self, prop: Prop) -> gl.Mesh:
        """The mesh of a prop's shape and size (made once per shape and size)."""
        key = (prop.shape, tuple(float(v) for v in prop.size_m))
        mesh = self.prop_meshes.get(key)
        if mesh is None:
            try:
                build = SHAPES[prop.shape]
            except KeyError:
                raise ValueError(f"unknown prop shape {prop.shape!r}; one of "
                                 f"{', '.join(SHAPES)}") from None
            length, width, height = key[1]
            rows = build(length, width, height) if prop.shape == "boat" else \
                build(0.5 * width, length)
            mesh = gl.Mesh(rows, {0: 3, 1: 3, 2: 3, 3: 1})   # position, normal, colour, gloss
            self.prop_meshes[key] = mesh
        return mesh

    def delete(self) -> None:
        for program in self.programs.values():
            program.delete()
        for mesh in self.prop_meshes.values():
            mesh.delete()
        self.prop_meshes.clear()
        self.terrain.delete()
        self.water.delete()
        for obj in [self.empty, self.view, self.params, self.bins, self.grid_fb, self.grid,
                    self.drops, self.ripples, self.foam_pattern, self.wakes, self.spill,
                    self.flood_cells, self.flood_rise, self.legend,
                    *self.targets,
                    *(tex for _, tex in self.waves.values())]:
            if obj is not None:
                obj.delete()
        self.waves.clear()
        self.targets = []
        self.reflection.delete()
        self.reflection_b.delete()
        self.fall_sheets.delete()
        self.spray.delete()


# -- tiles on the GPU --------------------------------------------------------------------------

class _PoolSync:
    """What of a tile pool is on the GPU, by pool slot: ``code_of`` the code of the tile whose
    data was uploaded for that slot (−1: none). A pool slot whose tile was released (or
    replaced) is found by comparing with the pool's own ``slot_code`` after an eviction."""

    def __init__(self) -> None:
        self.pool = lambda: None              # a weak reference to the pool synced with
        self.evicted = -1
        self.code_of = np.zeros(0, np.int64)

    def stale(self, pool: TilePool) -> np.ndarray:
        """Pool slots whose GPU data belongs to a tile the pool no longer holds there (all of
        them when the pool is another one); they are marked empty, the caller frees them.
        Makes room for the pool's slots."""
        if self.pool() is not pool:
            gone = np.flatnonzero(self.code_of >= 0)
            self.code_of[:] = -1
            self.pool, self.evicted = weakref.ref(pool), pool.evicted
        elif pool.evicted != self.evicted:     # a tile leaves its pool only by release()
            n = min(len(self.code_of), len(pool.slot_code))
            gone = np.flatnonzero((self.code_of[:n] >= 0)
                                  & (self.code_of[:n] != pool.slot_code[:n]))
            self.code_of[gone] = -1
            self.evicted = pool.evicted
        else:
            gone = np.zeros(0, np.intp)
        if len(self.code_of) < pool.capacity:
            self._grow(pool.capacity)
        return gone

    def missing(self, tiles: Standins) -> np.ndarray:
        """Indices into ``tiles`` of those whose data is not on the GPU yet."""
        return np.flatnonzero(self.code_of[tiles.slots] != tiles.codes)

    def _grow(self, n: int) -> None:
        self.code_of = np.concatenate([self.code_of,
                                       np.full(n - len(self.code_of), -1, np.int64)])

    def codes(self) -> set[int]:
        return set(self.code_of[self.code_of >= 0].tolist())


class _TerrainTiles(_PoolSync):
    """The terrain tiles on the GPU: each in a slot of one :class:`~riverflow.engine.gl.SlotArena`
    (``arena_slot`` by pool slot), its centre kept for the near-to-far order. The index buffer
    holds every tile's triangles in parts (:func:`~riverflow.scenes.meshes.tile_index_parts`):
    a core and, per edge, one strip for each level difference to the neighbour across it
    (the edge index-buffer variants: toward a coarser neighbour only the border nodes it has,
    so the vertex data is never changed for a seam); twice: the full mesh with skirts (drawn
    without them for the tests' reference reflection,
    :attr:`DrawRivers.debug_exact_reflection`) and the reflection's coarser one (every
    TERRAIN_STRIDE-th node, no skirts: mirrored, a skirt hangs in front of the ground).
    Each tile is drawn as five ranges (``counts``, ``offsets``, by arena slot), chosen when the frame's set
    of tiles changes. A neighbour more than log2(n) levels coarser has no node on a whole
    edge of the tile: then the tile's border vertices are moved onto its border
    (:func:`~riverflow.scenes.meshes.stitch_tile`) and re-uploaded, the rare case."""

    def __init__(self, cells: int) -> None:
        super().__init__()
        self.cells = int(cells)
        stride = TERRAIN_STRIDE if cells % TERRAIN_STRIDE == 0 \
            and cells // TERRAIN_STRIDE >= 2 else 1
        chunks: list[np.ndarray] = []

        def put(tris: np.ndarray) -> tuple[int, int]:
            first = sum(len(c) for c in chunks)
            chunks.append(tris.ravel())
            return tris.size, first

        tables = {}
        for name, parts in (("full", tile_index_parts(cells)),
                            ("coarse", tile_index_parts(cells, stride, skirts=False))):
            core = put(parts.core)
            edge = np.array([[put(part) for part in parts.edges[e]] for e in range(4)],
                            np.int64)                                    # (4, L, 2)
            tables[name] = (core, edge)
            if name == "full":                   # the same ranges without their skirts
                skirt = 3 * np.array(parts.skirt_counts, np.int64)
                exact = edge.copy()
                exact[..., 0] -= skirt
                tables["exact"] = (core, exact)
        self.tables = tables
        """By mesh ("full", "coarse", "exact"): the core's (count, first) and each edge's
        (count, first) by level difference (4, L, 2) in the index buffer."""
        self.max_up = level_count(cells) - 1
        """The largest level difference whose coarse nodes lie on a tile's edge: log2(n)."""
        self.meshes = tuple(tables)
        # the edges' ranges by level difference 0 … max_up + 1 (all beyond: the last), edge,
        # mesh: (max_up + 2, 4, M) counts and firsts (each mesh's own levels clamped)
        ups = np.arange(self.max_up + 2)
        lut = np.stack([edge[:, np.minimum(ups, edge.shape[1] - 1)].transpose(1, 0, 2)
                        for _, edge in tables.values()], axis=2)        # (U, 4, M, 2)
        self._lut_counts = np.ascontiguousarray(lut[..., 0], np.int32)
        self._lut_offsets = np.ascontiguousarray(4 * lut[..., 1], np.int64)   # bytes
        self._keys = np.empty((0, 3), np.int64)
        self._across = np.empty((0, 4), np.int64)
        """Scratch for the keys of the set drawn and the coarser tile across each edge
        (no allocation per set)."""
        self._core = np.array([core for core, _ in tables.values()], np.int64)   # (M, 2)
        # position, normal, water level seen, distance to the shore
        self.arena = gl.SlotArena((cells + 1) ** 2 + 4 * cells, {0: 3, 1: 3, 2: 1, 3: 1},
                                  np.concatenate(chunks), TERRAIN_SLOTS)
        self.counts = np.zeros((0, len(tables), 5), np.int32)
        self.offsets = np.zeros((0, len(tables), 5), np.int64)
        """By arena slot and mesh: the index counts and first indices' byte offsets of the
        tile's five index ranges (core, edges) for the neighbours of the last set drawn."""
        self.revision = 0
        """Counts the changes of ``counts`` and ``offsets`` (the arena refills its draw arrays
        after one)."""
        self.arena_slot = np.zeros(0, np.int32)
        self.centre = np.zeros((0, 3))
        self.stitched: dict[int, tuple[tuple, np.ndarray]] = {}
        """By pool slot, the tiles uploaded with their borders stitched to neighbours more
        than ``max_up`` levels coarser (:func:`~riverflow.scenes.meshes.stitch_tile`): (what
        they were stitched to, the vertices as uploaded). The others are uploaded as their
        pool holds them."""
        self.stitched_across = np.zeros((0, 4), np.int64)
        """By pool slot, the codes of the much coarser tiles across its edges (−1: none) that
        the tile on the GPU is stitched to; −2: not known (uploaded afresh)."""
        self._stitched_set: tuple[np.ndarray, np.ndarray] | None = None
        """The (codes, slots) of the last set :meth:`_seams` went through: the same set
        again, with no tile uploaded afresh, is drawn as it was (nothing to look up)."""

    def sync(self, pool: TilePool, tiles: Standins) -> tuple[np.ndarray, np.ndarray]:
        """Arena slots (K,) and centres (K, 3) [m] of ``tiles``, uploaded now if new, with
        the index ranges that join them to this set's coarser neighbours; the slots of tiles
        the pool released are given back."""
        gone = self.stale(pool)
        if len(gone):
            self.arena.free(self.arena_slot[gone])
            self.arena_slot[gone] = -1
            for slot in gone.tolist():
                self.stitched.pop(slot, None)
            self.stitched_across[gone] = -2
            self._stitched_set = None
        missing = self.missing(tiles)
        if len(missing):
            self._stitched_set = None
        for k in missing.tolist():
            slot = int(tiles.slots[k])
            data = pool.tile(slot)
            if self.arena_slot[slot] < 0:
                self.arena_slot[slot] = self.arena.alloc()
            self.arena.upload(int(self.arena_slot[slot]), data.vertices)
            self.stitched.pop(slot, None)
            self.stitched_across[slot] = -2
            self.centre[slot] = data.bounds_m.mean(axis=0)
            self.code_of[slot] = tiles.codes[k]
        last = self._stitched_set
        if last is None or not (np.array_equal(last[0], tiles.codes)
                                and np.array_equal(last[1], tiles.slots)):
            self._seams(pool, tiles)
            self._stitched_set = (tiles.codes.copy(), tiles.slots.copy())
        return self.arena_slot[tiles.slots], self.centre[tiles.slots]

    def _seams(self, pool: TilePool, tiles: Standins) -> None:
        """Choose each tile's index ranges for the level differences to its coarser
        neighbours among ``tiles`` (:func:`edge_levels_up`), and stitch the vertices of those
        with a neighbour more than ``max_up`` levels coarser (:meth:`_stitch`)."""
        self.revision += 1
        k = len(tiles.keys)
        if len(self._across) < k:
            self._across = np.empty((2 * k, 4), np.int64)
            self._keys = np.empty((2 * k, 3), np.int64)
        keys, across = self._keys[:k], self._across[:k]
        keys[:] = tiles.keys
        coarser_across(keys, across)
        if len(self.counts) < self.arena.capacity:
            self._grow_parts(self.arena.capacity)
        worst = edge_parts(keys, across, self.arena_slot[tiles.slots],
                           EdgeParts(self._lut_counts, self._lut_offsets,
                                     self.counts, self.offsets))
        if self.stitched or worst > self.max_up:                  # rare: a neighbour
            up = edge_levels_up(keys, across)                     # far coarser
            self._stitch(pool, tiles, np.where(up > self.max_up, across, -1))


    def _stitch(self, pool: TilePool, tiles: Standins, across: np.ndarray) -> None:
        """Upload each tile of ``tiles`` stitched to the much coarser neighbours ``across``
        (K, 4) (rows into ``tiles``, −1: none) (or as it is, with none), where what is on
        the GPU was made for other neighbours. Tiles are in (level, tx, ty) order: a neighbour
        is stitched before the finer tiles that follow it (a tile's corner may move onto a
        much coarser one's border)."""
        codes_across = np.where(across >= 0, tiles.codes[np.maximum(across, 0)], -1)
        if np.array_equal(self.stitched_across[tiles.slots], codes_across):
            return              # every tile is stitched to these neighbours already (most sets)
        self.stitched_across[tiles.slots] = codes_across
        signature: list[tuple] = []
        for r, slot in enumerate(tiles.slots.tolist()):
            sig = tuple((e, int(tiles.codes[m]), signature[m])
                        for e, m in enumerate(across[r].tolist()) if m >= 0)
            signature.append(sig)
            known = self.stitched.get(slot)
            if (known[0] if known is not None else ()) == sig:
                continue
            data = pool.tile(slot)
            if not sig:
                self.arena.upload(int(self.arena_slot[slot]), data.vertices)
                del self.stitched[slot]
                continue
            neighbours = []
            for e, m in enumerate(across[r].tolist()):
                if m >= 0:
                    other = int(tiles.slots[m])
                    drawn = self.stitched.get(other)
                    neighbours.append((e, tuple(tiles.keys[m].tolist()),
                                       drawn[1] if drawn is not None
                                       else pool.tile(other).vertices))
            vertices = stitch_tile(data.vertices, tiles.keys[r], data.skirt_m, neighbours)
            self.arena.upload(int(self.arena_slot[slot]), vertices)
            self.stitched[slot] = (sig, vertices)

    def draw(self, slots: np.ndarray, mesh: str) -> None:
        """Draw the tiles in arena ``slots`` (in that order) through ``mesh``'s index ranges
        ("full", "coarse", "exact"), with one multi-draw."""
        m = self.meshes.index(mesh)
        self.arena.draw_parts(slots, self.counts[:, m], self.offsets[:, m],
                              cache=(mesh, self.revision))

    def _grow_parts(self, n: int) -> None:
        old = len(self.counts)
        counts = np.zeros((n,) + self.counts.shape[1:], np.int32)
        offsets = np.zeros((n,) + self.offsets.shape[1:], np.int64)
        counts[:old], offsets[:old] = self.counts, self.offsets
        counts[old:, :, 0], offsets[old:, :, 0] = self._core[:, 0], 4 * self._core[:, 1]
        self.counts, self.offsets = counts, offsets

    def _grow(self, n: int) -> None:
        old = len(self.code_of)
        super()._grow(n)
        self.arena_slot = np.concatenate([self.arena_slot, np.full(n - old, -1, np.int32)])
        self.centre = np.concatenate([self.centre, np.zeros((n - old, 3))])
        self.stitched_across = np.concatenate([self.stitched_across,
                                               np.full((n - old, 4), -2, np.int64)])

    def delete(self) -> None:
        self.arena.delete()
        self.code_of[:] = -1
        self.arena_slot[:] = -1
        self.stitched.clear()
        self.stitched_across[:] = -2
        self._stitched_set = None


class _WaterTiles(_PoolSync):
    """The water tiles on the GPU: their meshes (of any size) in one
    :class:`~riverflow.engine.gl.MeshArena`; by pool slot, where (first vertex, vertex count,
    first index, index count; no index: a tile with nothing to draw, remembered as such)."""

    def __init__(self) -> None:
        super().__init__()
        self.arena = gl.MeshArena({0: 3, 1: 1})      # position, ground height
        self.where = np.zeros((0, 4), np.int64)

    def sync(self, pool: TilePool, tiles: Standins) -> list[_WaterBatch]:
        """This frame's water tiles with something to draw (one batch, drawn with one call;
        none: an empty list), uploaded now if new; those of tiles the pool released are
        given back."""
        for slot in self.stale(pool).tolist():
            self._drop(slot)
        for k in self.missing(tiles).tolist():
            slot = int(tiles.slots[k])
            self._drop(slot)
            mesh, ground = pool.tile(slot)
            if len(mesh.indices):
                vertices = np.concatenate([mesh.positions, ground[:, None]], axis=1)
                v0, i0 = self.arena.add(vertices, mesh.indices)
                self.where[slot] = v0, len(vertices), i0, mesh.indices.size
            self.code_of[slot] = tiles.codes[k]
        where = self.where[tiles.slots]
        where = where[where[:, 3] > 0]
        return [_WaterBatch(self.arena, where)] if len(where) else []

    def _drop(self, slot: int) -> None:
        if self.where[slot, 3] > 0:
            self.arena.remove(*self.where[slot].tolist())
        self.where[slot] = 0

    def _grow(self, n: int) -> None:
        self.where = np.concatenate([self.where, np.zeros((n - len(self.code_of), 4), np.int64)])
        super()._grow(n)

    def delete(self) -> None:
        self.arena.delete()
        self.code_of[:] = -1
        self.where[:] = 0


class _WaterBatch:
    """A frame's water tiles: ``where`` (K, 4) (first vertex, vertex count, first index,
    index count) in the arena, in drawing order; :meth:`draw` draws them with one call."""

    def __init__(self, arena: gl.MeshArena, where: np.ndarray) -> None:
        self.arena = arena
        self.where = where
        self.first_index = np.ascontiguousarray(where[:, 2])
        self.index_count = np.ascontiguousarray(where[:, 3])
        self.first_vertex = np.ascontiguousarray(where[:, 0])

    def __len__(self) -> int:
        return len(self.where)

    def draw(self) -> None:
        self.arena.draw(self.first_index, self.index_count, self.first_vertex)


# -- reflections (issue 12 item 3) -----------------------------------------------------------

REFLECTION_UNIT, REFLECTION_DEPTH_UNIT = 10, 11
REFLECTION_B_UNIT, REFLECTION_B_DEPTH_UNIT = 18, 19
"""Texture units of the reflection's colour and depth while the water is drawn (B: the
second pass, at the level being faded in: :func:`~riverflow.scenes.reflection.hold_levels`)."""


class _Reflection:
    """The planar reflection's render target (colour + depth at a reduced resolution), made
    on first use and remade when the viewport or the scale changes."""

    def __init__(self) -> None:
        self.size = (0, 0)
        self.fitted = None                      # the arguments of the last fit()
        self.colour = self.depth = self.fb = None

    def fit(self, width: int, height: int, scale: float) -> None:
        if (width, height, scale) == self.fitted:
            return                      # every frame but the first after a change
        size = reflection_size(width, height, scale)
        if size != self.size:
            self.delete()
            # half floats: the mip levels' coverage (alpha) keeps a one-texel prop, which the
            # march's early out (no coverage near the ray: the sky) relies on
            self.colour = gl.Texture(size, gl.RGBA16F, levels=gl.mip_levels(*size),
                                     linear=True)
            self.depth = gl.Texture(size, gl.DEPTH24)
            self.fb = gl.Framebuffer([self.colour], self.depth)
            self.size = size
        self.fitted = (width, height, scale)

    def delete(self) -> None:
        for obj in (self.fb, self.colour, self.depth):
            if obj is not None:
                obj.delete()
        self.colour = self.depth = self.fb = None
        self.size = (0, 0)
        self.fitted = None


_CONSTANT_UNIFORMS = dict(
    u_params=PARAMS_UNIT, u_grid=GRID_UNIT, u_wave=WAVE_UNIT, u_accum=ACCUM_UNIT,
    u_water_position=WATER_POSITION_UNIT, u_ripples=RIPPLES_UNIT, u_drops=DROPS_UNIT,
    u_bins=BINS_UNIT, u_foam_pattern=FOAM_PATTERN_UNIT, u_wakes=WAKES_UNIT, u_spill=SPILL_UNIT,
    u_legend=SPILL_UNIT,
    u_spray=SPRAY_UNIT, u_flood_cells=FLOOD_CELLS_UNIT, u_flood_rise=FLOOD_RISE_UNIT,
    u_reflection=REFLECTION_UNIT, u_reflection_depth=REFLECTION_DEPTH_UNIT,
    u_reflection_b=REFLECTION_B_UNIT, u_reflection_depth_b=REFLECTION_B_DEPTH_UNIT,
    u_colour=COMPOSITE_COLOUR_UNIT, u_depth=COMPOSITE_DEPTH_UNIT,
    u_sprite_radius_factor=SPRITE_RADIUS_FACTOR, u_foam_scale_m=FOAM_SCALE_M,
    u_foam_size_px=float(FOAM_PATTERN_PX))
"""The uniforms every program that uses them gets once, when it is made."""
_COS_REFRESH = math.cos(MIRROR_REFRESH_RAD)


def _moved(was: tuple, pose: tuple) -> bool:
    """Whether the camera ``pose`` (eye [m], view direction, vertical field of view, aspect
    ratio) is far enough from ``was`` for the level of the water in view to be found
    again: the eye moved more than MIRROR_REFRESH_M, the view turned more than
    MIRROR_REFRESH_RAD or the projection changed (or there is no ``was``)."""
    if len(was) != len(pose):
        return True
    ex, ey, ez, fx, fy, fz, sx, sy = was
    x, y, z, gx, gy, gz, tx, ty = pose
    return ((x - ex) ** 2 + (y - ey) ** 2 + (z - ez) ** 2 > MIRROR_REFRESH_M ** 2
            or fx * gx + fy * gy + fz * gz < _COS_REFRESH or sx != tx or sy != ty)


# -- the draw system ---------------------------------------------------------------------------

class DrawRivers(System):
    """Draws the world's current frame into its offscreen framebuffer (see the module doc).

    ``last_tables_ms`` is the CPU time of the last frame's sprite tables (built, uploaded, and
    the pass that makes the sprite grid from them submitted), ``last_sprites`` the sprites it
    drew on the water (INSIDE or LEAVING, within reach of the screen), ``last_tiles`` the
    terrain tiles drawn.
    """

    name = "draw"
    needs_gl = True
    phase = "draw"

    def __init__(self) -> None:
        self.gpu: _Gpu | None = None
        self._flood_uniforms = {"u_flood_on": 0, "u_flood_rect": (0.0, 0.0, 1.0)}
        self._clarity_m = 1.0
        self._flood_waves: dict = {"u_flood_waves": 0}
        self.context = None
        self.last_mirror_level_m: float | None = None
        """The reflection's mirror height [m] in the last frame (None: no reflection): the
        level of the water in view, eased; the passes are drawn at held levels near it
        (:attr:`last_mirror_levels`)."""
        self.last_mirror_levels: tuple | None = None
        """(a, b, fade) the last frame's reflection was drawn at (:func:`hold_levels`; b None
        with one pass), flood rise included; None: no reflection."""
        self._mirror_held = None
        """(clock time [s], camera revision, eye [m], hold_levels' answer) of the last frame
        drawn with a reflection (None: the next one is a cut, as in :meth:`_ease_mirror`)."""
        self._mirror_for: tuple = (-1, None, -math.inf, ())
        """(camera revision, the level of the water in view, clock time, pose) when the
        mirror's target was last found (:func:`_moved`)."""
        self._mirror_eased = None
        """(clock time [s], mirror height [m], its rate [m/s], camera revision, eye [m]) of
        the last frame drawn with a reflection."""
        self.last_tables_ms = 0.0
        self._terrain_slots = np.zeros(0, np.int32)   # this frame's, near to far
        self._tiles_for = None        # (pools and revisions, cut, what _tile_meshes found)
        self.last_tiles = 0
        self.last_sprites = 0
        self.debug_background: tuple[float, float, float] | None = None
        """Tests: an RGB colour (0-1) the main pass is cleared to instead of drawing the sky
        (a colour no material uses shows every pixel nothing covers: cracks)."""
        self.debug_materials = False
        self.debug_exact_reflection = False
        """Tests: the reflection pass through every node of the terrain tiles at the frame's
        full resolution (the mirrored scene as exactly as the drawing makes it)."""
        """Tests: the terrain drawn as (rock weight, slope of the drawn triangle / 90°, river
        bed weight, alpha 0.5: the ground) instead of its colour (``shaders/terrain.glsl``)."""

    def attach(self, context) -> None:
        """Draw with this GL context (the world's)."""
        self.context = context

    def process(self, world: RiverWorld, dt_s: float) -> None:
        if self.context is not None:
            gl.make_current(self.context)
        gl.forget_state()                       # (a host may have changed it since)
        if self.gpu is None:
            self.gpu = _Gpu(world)
        gpu = self.gpu
        settings: DisplaySettings = world.resource(DisplaySettings)
        settings.validate()
        camera = world.camera
        width, height = camera.size_px
        config = world.config
        gpu.fit(width, height, config.radius_px, world.pool.capacity)
        span = slot_span(world.pool.alive)      # (the tint's and the tables' slots)
        self._tint_particles(world, gpu, span)
        t0 = time.perf_counter_ns()
        n_drawn, n_entries = self._upload_tables(
            world, gpu, settings.show_particles or settings.show_velocities, span)
        if settings.mode in _GRID_MODES:
            self._make_grid(gpu, config.radius_px)
        self.last_tables_ms = (time.perf_counter_ns() - t0) * 1e-6

        clip_from_world, world_from_clip = camera.matrices_for_kernels()
        # the view block, for every program (the mirrored copy: _draw_reflection)
        pack_view(gpu.view.data[0], clip_from_world.T.ravel(),   # pyrr's view_projection,
                  world_from_clip.T.ravel(), camera.position,    # in closed form
                  float(settings.fog_density_per_m),
                  0.0,                  # gl_ClipDistance is honoured even when disabled
                  (float(gpu.size[0]), float(gpu.size[1])))
        wave_uniforms, wave_tex = self._wave(world, gpu, settings)
        rain = world.resources.get(Rain)
        ripple_uniforms = self._upload_ripples(world, gpu, rain)
        foam_uniforms = self._upload_foam_and_wakes(world, gpu)
        foam_uniforms.update(self._upload_spill(world, gpu, settings))
        flood_uniforms = self._upload_flood(world, gpu)
        self._clarity_m = float(settings.water_clarity_m)      # a flood's water (terrain)
        water_meshes = self._tile_meshes(world, gpu)
        reflection_uniforms = self._draw_reflection(world, gpu, settings, clip_from_world)
        if not reflection_uniforms["u_reflect"]:
            gpu.view.write()                    # (else written for the reflection pass)
        gpu.view.bind(0, gpu.view_binding)

        gpu.main_fb.bind()
        background = self.debug_background
        gl.clear((0.0, 0.0, 0.0, 1.0) if background is None else (*background, 1.0))
        gl.set_cull(False)
        gl.set_blend(gl.BLEND_OFF)
        # sky: depth test off, nothing written to depth
        gl.set_depth(False, write=False)
        if background is None:
            sky = gpu.programs["sky"]
            sky.use()
            gpu.empty.draw(gl.TRIANGLES, count=3)
        # terrain (a flooded floodplain's waves: the sprites', as the water's)
        mode = settings.mode
        gpu.params.bind(PARAMS_UNIT)
        gpu.grid.bind(GRID_UNIT)
        wave_tex.bind(WAVE_UNIT)
        waves = (0 if not flood_uniforms["u_flood_on"] or mode not in _SHADED_MODES
                 else 2 if mode == DisplayMode.ADVECTED else 1)
        self._flood_waves = dict(u_flood_waves=waves, u_slope_factor=settings.wave_slope_factor,
                                 u_grid_cell_px=float(gpu.grid_shape[0]),
                                 u_grid_size=gpu.grid_shape[1:], **wave_uniforms)
        gl.set_depth(True)
        self._draw_terrain(world, gpu)
        self._draw_props(gpu)

        if mode == DisplayMode.PRE_ADVECTED:
            self._pre_advect(gpu, wave_uniforms, n_drawn, water_meshes, flood_uniforms)
        if mode != DisplayMode.NONE:
            water = gpu.programs["water"]
            water.use()
            gpu.accum.bind(ACCUM_UNIT)
            water.set(u_mode=int(mode), u_show_grid=bool(settings.show_grid),
                      u_grid_cell_px=float(gpu.grid_shape[0]), u_grid_size=gpu.grid_shape[1:],
                      u_slope_factor=settings.wave_slope_factor,
                      u_rapids=(float(settings.rapids_wave_slope), RAPIDS_MIN_SLOPE,
                                RAPIDS_FULL_SLOPE),
                      u_clarity_m=settings.water_clarity_m, **wave_uniforms, **ripple_uniforms,
                      **foam_uniforms, **flood_uniforms)
            water.set_if_used(**reflection_uniforms)
            gl.set_blend(gl.BLEND_WATER)
            for mesh in water_meshes:
                mesh.draw()
            if mode in _SHADED_MODES and gpu.fall_sheets.in_view(world, clip_from_world):
                if settings.fall_sheets:        # the falls' sheets and spray, over the water
                    gpu.fall_sheets.draw(world, gpu.programs["falls"],
                                         foam_uniforms["u_time_s"])
                gpu.spray.draw(world, gpu.programs["spray"], gpu.empty, SPRAY_UNIT)
        self._draw_rain(gpu, rain)
        gl.set_depth(False, write=False)
        if settings.show_velocities and n_entries:
            arrows = gpu.programs["arrows"]
            arrows.use()
            arrows.set(u_arrow_s=float(settings.arrow_s))
            gl.set_blend(gl.BLEND_ALPHA)
            gpu.empty.draw(gl.LINES, count=6 * n_entries)
        if settings.show_particles and n_entries:
            points = gpu.programs["particles"]
            points.use()
            gl.enable_program_point_size()
            gl.set_blend(gl.BLEND_ADD)
            gpu.empty.draw(gl.POINTS, count=n_entries)
        if mode == DisplayMode.CONCENTRATION and settings.concentration_legend:
            self._draw_legend(gpu, settings)
        gl.set_blend(gl.BLEND_OFF)
        gl.set_depth(False)

    # -- passes -----------------------------------------------------------------------------

    def _upload_tables(self, world: RiverWorld, gpu: _Gpu, overlays: bool, span: int
                       ) -> tuple[int, int]:
        """Build this frame's sprite table and bins and copy them into their buffer textures
        (the table's rows in use, all the bins); returns (entries drawn on the water, all
        entries). The particles that are not drawn on the water are in the table only for
        ``overlays`` (the particle points and velocity arrows): ~3/4 of the pool in a chase
        view. ``span``: the slots that hold every live particle (``slot_span``)."""
        pool = world.pool
        n_drawn, n_entries, rows = build_sprite_tables(
            sprite_source(pool), float(world.config.radius_px), span,
            gpu.bins_shape, gpu.params_cpu, gpu.starts_cpu, gpu.scratch, bool(overlays))
        if rows:
            gpu.params.write(gpu.params_cpu, rows * gpu.params_cpu[0].nbytes)
        gpu.bins.write(gpu.bins_view)
        self.last_sprites = int(n_drawn)
        return int(n_drawn), int(n_entries)

    def _make_grid(self, gpu: _Gpu, radius_px: float) -> None:
        """The sprite grid from the sprite table and bins: one fragment a cell
        (``sprite_lists.glsl``) into the four layers of ``gpu.grid``."""
        bins = gpu.bins_shape
        gpu.grid_fb.bind()
        gl.set_depth(False, write=False)
        gl.set_blend(gl.BLEND_OFF)
        gpu.params.bind(PARAMS_UNIT)
        gpu.bins.bind(BINS_UNIT)
        program = gpu.programs["sprite_lists"]
        program.use()
        program.set(u_bin_px=(bins.bin_w, bins.bin_h),       # sent only when changed
                    u_bin_margin=(bins.margin_x, bins.margin_y), u_bin_count=(bins.bw, bins.bh),
                    u_sprite_radius_px=float(SPRITE_RADIUS_FACTOR * radius_px),
                    u_cell_px=int(gpu.grid_shape[0]))
        gpu.empty.draw(gl.TRIANGLES, count=3)

    def _upload_ripples(self, world: RiverWorld, gpu: _Gpu, rain: Rain | None) -> dict:
        """The water shader's ripple uniforms; the ripple table uploaded (only with rain:
        without, u_ripple_count = 0 and the water is drawn as before)."""
        count = 0
        life = 1.0
        if rain is not None:
            hits = rain.drops.hits
            life = float(rain.ripple_life_s)
            now = world.clock.now_s
            # any hit with 0 ≤ age < life (64 of them: in Python floats, cheaper than numpy)
            if any(0.0 <= now - t < life for t in hits[:, 3].tolist()):
                age = now - hits[:, 3]
                table = gpu.ripples_cpu[0]
                table[:, :3] = hits[:, :3]
                table[:, 3] = np.where(np.isfinite(age), age, -1.0)
                gpu.ripples.upload(gpu.ripples_cpu)
                count = len(hits)
        gpu.ripples.bind(RIPPLES_UNIT)
        return {"u_ripple_count": count, "u_ripple_life_s": life}

    def _upload_foam_and_wakes(self, world: RiverWorld, gpu: _Gpu) -> dict:
        """The water shader's foam and wake uniforms; the wake table uploaded (the first
        MAX_WAKES boats of :class:`Wakes`, nearest the camera; none: u_wake_count = 0)."""
        wakes = world.resources.get(Wakes)
        count = 0 if wakes is None else min(wakes.count, MAX_WAKES)
        if count:
            wake_texture(wakes.table[:count], gpu.wakes_cpu)
            gpu.wakes.upload(gpu.wakes_cpu, rows=count)
        foam = world.resources.get(FoamSettings)
        shoreline = float(foam.shoreline) if foam is not None and foam.enabled else 0.0
        gpu.foam_pattern.bind(FOAM_PATTERN_UNIT)
        gpu.wakes.bind(WAKES_UNIT)
        return {"u_time_s": float(world.clock.now_s % 3600.0), "u_wake_count": count,
                "u_shoreline": shoreline,
                "u_crest_foam": 1.0 if foam is not None and foam.enabled else 0.0}

    def _tint_particles(self, world: RiverWorld, gpu: _Gpu, span: int) -> None:
        """The spills' discolouring the wave particles carry (issue 24; the water shader blends
        it with the sprites' weights): the spills' grid follows the spills
        (:class:`~riverflow.hydro.spills.SpillTint`, every TINT_REFRESH_S of spill time; its
        square placed in a thread, swapped in at a fixed later frame; at once when a frame is
        drawn again), each
        particle samples it where it is (:func:`~riverflow.kernels.spill.sample_tint`) when
        new and every TINT_SAMPLE_EVERY frames (staggered: a changed grid reaches them all
        within those frames, ~0.05 ms a frame for 5000 particles where all of them cost
        0.4 ms), all of them when the grid changed while the frame stood still (a paused
        world's spills advanced); once a frame otherwise (a second draw of the same frame
        samples nothing). ``span``: the slots that hold every live particle."""
        frame = int(world.clock.frame)
        again = frame == gpu.drawn_frame            # (a paused host's, a screenshot's)
        gpu.drawn_frame = frame
        solver = world.spill_solver
        if solver is None or not solver.n_spills:
            return
        colours = sorted((s.row, s.colour) for _, s in esper.get_component(Spill))
        tint = gpu.spill_tint
        changed = tint.update(solver, world.field, [c for _, c in colours], frame, again)
        still = frame == gpu.tint_frame
        if still and not changed:
            return
        gpu.tint_frame = frame
        pool = world.pool
        sample_tint(TintGrid(tint.rgba, np.asarray(tint.rect_m, np.float64)),
                    ParticleTint(pool.alive, pool.has_world, pool.ids, pool.world_m, pool.tint,
                                 pool.tint_id),
                    span, frame, TINT_SAMPLE_EVERY, bool(changed and still))

    def _upload_spill(self, world: RiverWorld, gpu: _Gpu, settings: DisplaySettings) -> dict:
        """The concentration mode's spill uniforms, the spills' grid uploaded as its texture
        when it changed (:class:`~riverflow.hydro.spills.SpillTint`, kept by
        :meth:`_tint_particles`); the other modes read no texture (u_spill_on = 0: the normal
        look's tint is the sprites')."""
        solver = world.spill_solver
        on = settings.mode == DisplayMode.CONCENTRATION and solver is not None \
            and solver.n_spills > 0
        if on:
            tint = gpu.spill_tint
            if tint.version != gpu.spill_version:
                # the rows it changed, unless a change was missed (then all)
                first, end = tint.rows if tint.version == gpu.spill_version + 1 \
                    else (0, TINT_TEXELS)
                gpu.spill.upload(tint.rgba, first_row=first, rows=end - first)
                gpu.spill_version = tint.version
            on = gpu.spill_tint.rect_m[2] > 0.0
        if on:              # (off, the shaders read no texture there: the spray's unit too)
            gpu.spill.bind(SPILL_UNIT)
        lo, hi = settings.concentration_range_kg_m3
        return {"u_spill_on": int(on), "u_spill_rect": gpu.spill_tint.rect_m,
                "u_spill_visible": float(settings.spill_visible_kg_m3),
                "u_spill_range": (math.log10(lo), math.log10(hi))}

    def _draw_legend(self, gpu: _Gpu, settings: DisplaySettings) -> None:
        """The concentration mode's colour bar with its ticks and values in kg/m³, in the
        frame's lower right corner (:mod:`riverflow.systems.legend`, ``shaders/legend.glsl``);
        its panel image remade when the frame's size or the range changes."""
        key = (gpu.size, tuple(settings.concentration_range_kg_m3))
        if key != gpu.legend_for:
            gpu.legend_for = key
            if gpu.legend is not None:
                gpu.legend.delete()
                gpu.legend = None
            gpu.legend_bar = concentration_bar(settings.concentration_range_kg_m3, gpu.size)
            if gpu.legend_bar is not None:
                rgba = legend_panel_rgba(gpu.legend_bar)
                gpu.legend = gl.Texture(rgba.shape[1::-1], gl.RGBA8)
                gpu.legend.upload(rgba)
        bar = gpu.legend_bar
        if bar is None:
            return
        gpu.legend.bind(SPILL_UNIT)
        program = gpu.programs["legend"]
        program.use()
        program.set(u_legend_panel=bar.panel_px, u_legend_bar=bar.bar_px,
                    u_legend_frame=(float(gpu.size[0]), float(gpu.size[1])))
        gl.set_depth(True, write=True)
        gl.set_blend(gl.BLEND_ALPHA)
        gpu.empty.draw(gl.TRIANGLES, count=6)
        gl.set_depth(False, write=False)

    def _upload_flood(self, world: RiverWorld, gpu: _Gpu) -> dict:
        """The water and terrain shaders' flood uniforms (``shaders/flood.glsl``): the
        router's cell texture uploaded once, its per-cell level rise and wet rise each frame
        while the flood is drawn (:meth:`~riverflow.hydro.flood.FloodRouter.level_textures`,
        :attr:`~riverflow.hydro.flood.FloodRouter.drawn`); else u_flood_on = 0."""
        router = world.flood
        on = router is not None and router.drawn
        rect = (0.0, 0.0, 1.0)
        if on:
            rect, cells = router.level_textures()
            if gpu.flood_for is not router:
                for tex in (gpu.flood_cells, gpu.flood_rise):
                    if tex is not None:
                        tex.delete()
                gpu.flood_cells = gl.Texture(cells.shape[1::-1], gl.RGB32F)
                gpu.flood_cells.upload(cells)
                gpu.flood_rise_cpu = router.rise_texels()
                gpu.flood_rise = gl.Texture(gpu.flood_rise_cpu.shape[1::-1], gl.RG32F)
                gpu.flood_for = router
            gpu.flood_rise.upload(router.rise_texels(gpu.flood_rise_cpu))
            gpu.flood_cells.bind(FLOOD_CELLS_UNIT)
            gpu.flood_rise.bind(FLOOD_RISE_UNIT)
        self._flood_uniforms = {"u_flood_on": int(on), "u_flood_rect": rect}
        return self._flood_uniforms

    def _draw_rain(self, gpu: _Gpu, rain: Rain | None) -> None:
        """The live drops as streaks (depth-tested, not written; alpha-blended)."""
        n = 0 if rain is None else rain.count
        if n == 0:
            return
        rows = -(-n // DROPS_PER_ROW)
        if gpu.drops_cpu is None or gpu.drops_cpu.shape[0] < rows:
            if gpu.drops is not None:
                gpu.drops.delete()
            total = -(-rain.drops.position.shape[0] // DROPS_PER_ROW)
            gpu.drops_cpu = np.zeros((total, DROPS_PER_ROW, 2, 4), np.float32)
            gpu.drops = gl.Texture((2 * DROPS_PER_ROW, total), gl.RGBA32F)
        flat = gpu.drops_cpu.reshape(-1, 2, 4)
        flat[:n, 0, :3] = rain.drops.position[:n]
        flat[:n, 1, :3] = rain.drops.velocity[:n]
        gpu.drops.upload(gpu.drops_cpu.reshape(gpu.drops_cpu.shape[0], 2 * DROPS_PER_ROW, 4),
                         rows=rows)
        gpu.drops.bind(DROPS_UNIT)
        program = gpu.programs["rain"]
        program.use()
        program.set(u_streak_s=float(rain.streak_s))
        gl.set_depth(True, write=False)
        gl.set_blend(gl.BLEND_ALPHA)
        gpu.empty.draw(gl.LINES, count=2 * n)
        gl.set_blend(gl.BLEND_OFF)

    def _wave(self, world: RiverWorld, gpu: _Gpu, settings: DisplaySettings):
        """Uniforms and texture of the wave tile the settings ask for (else the first one)."""
        tiles = esper.get_component(WaveTile)
        if not tiles:
            raise RuntimeError("no wave tile entity in the world")
        entity, tile = next(((e, t) for e, t in tiles if t.kind == settings.wave), tiles[0])
        tex = gpu.wave_texture(entity, tile)
        a, b, blend = tile.frame_blend()
        return dict(u_wave_frames=(int(a), int(b)), u_wave_blend=float(blend),
                    u_wave_length_m=float(tile.wave_length_m)), tex

    def _tile_meshes(self, world: RiverWorld, gpu: _Gpu) -> list:
        """Sync the GPU tiles with the cache; keep this frame's terrain tiles' arena slots,
        near to far (for :meth:`_draw_terrain`), and return its water tiles (a list of one
        batch, drawn with one call, or none; see the module docstring)."""
        tiles = world.resource(Tiles)
        cut = world.resource(TerrainView).cut
        pools = tiles.cache.pools
        terrain, water = pools[TERRAIN_MESH], pools[WATER_MESH]
        # the same cut over the same resident tiles (no install, no release since: the pools'
        # revisions) draws the same tiles: most frames
        key = (gpu, terrain, terrain.revision, water, water.revision)
        last = self._tiles_for
        if last is not None and last[0] == key and last[1].shape == cut.shape \
                and last[1].tobytes() == cut.tobytes():
            slots, centres, batches = last[2]
        else:
            dry = tiles.scheduler.producers[WATER_MESH].empty_mask(codes(cut))
            slots, centres = gpu.terrain.sync(terrain, standin_tiles(cut, terrain))
            batches = gpu.water.sync(water, standin_tiles(cut, water, skip=dry))
            self._tiles_for = (key, cut, (slots, centres, batches))
        # near to far: the depth test then rejects hidden ground before it is shaded
        self._terrain_slots = order = np.empty_like(slots)
        near_to_far(slots, centres, np.asarray(world.camera.position, np.float64), order)
        return batches

    def _draw_terrain(self, world: RiverWorld, gpu: _Gpu, detail: str = "full") -> None:
        """This frame's terrain tiles, through all their nodes (``detail`` "full") or the
        reflection's coarser mesh ("coarse", or "exact": every node, with the reflection's
        own program object), near to far, in one multi-draw."""
        waves = detail == "full" and self._flood_waves["u_flood_waves"] > 0
        program = (gpu.flood_terrain() if waves
                   else gpu.programs["terrain" if detail == "full" else "terrain_reflection"])
        program.use()
        if detail == "full":
            program.set(u_debug_materials=self.debug_materials)   # sent only when changed
        if waves:
            program.set_if_used(**self._flood_waves)
        program.set_if_used(**self._flood_uniforms, u_clarity_m=self._clarity_m)
        gpu.terrain.draw(self._terrain_slots, detail)
        if detail == "full":
            self.last_tiles = len(self._terrain_slots)

    def _draw_props(self, gpu: _Gpu, mirrored: bool = False) -> None:
        """Every prop; ``mirrored``: in the reflection pass (winding turned, each prop cut
        at its waterline)."""
        props = esper.get_components(Prop, Pose)
        if not props:
            return
        program = gpu.programs["props"]
        program.use()
        gl.set_cull(True, mirrored=mirrored)
        for _, (prop, pose) in props:
            model = pose.matrix()
            if not np.isfinite(model).all():
                continue                    # a bad pose is not drawn, never crashes a frame
            program.set(u_model=np.ascontiguousarray(model.T, np.float32))
            if mirrored:
                program.set(u_clip_level_m=float(pose.position_m[2]))
            gpu.prop_mesh(prop).draw()
        gl.set_cull(False)

    # -- reflections (issue 12 item 3) ------------------------------------------------------

    def _draw_reflection(self, world: RiverWorld, gpu: _Gpu, settings: DisplaySettings,
                         clip_from_world: np.ndarray) -> dict:
        """The planar reflection pass (``shaders/reflection.glsl``): terrain and props mirrored
        in the level of the water in view (:func:`mirror_level`, eased in time:
        :meth:`_ease_mirror`, held: :func:`hold_levels`; while a new level is faded in, a
        second pass at it into the second target), cut at their water level, into the
        reflection target; returns
        the water shader's reflection uniforms (``u_reflect`` false, and no
        pass, when reflections are off, the water mode is not shaded, or the eye is not above
        the mirror). With a pass, the view block is written (its copy 0 packed by the caller,
        copy 1 the mirrored view, bound for the pass)."""
        off = {"u_reflect": False}
        self.last_mirror_level_m = self.last_mirror_levels = None
        if not settings.reflections or settings.mode not in _SHADED_MODES:
            return off
        camera = world.camera
        eye = camera.position
        now = world.clock.now_s
        pose = (float(eye[0]), float(eye[1]), float(eye[2]),
                *clip_from_world[3, :3].tolist(), camera.fov_y_deg, camera.aspect)
        last = self._mirror_for
        if last[0] != camera.revision and (not now > last[2] or _moved(last[3], pose)):
            # the water in view (a pass over the centre-line samples), again when the camera
            # moved or turned enough (the easing smooths what changed meanwhile), or at once
            # for a view with no time passed (a still, a jump)
            self._mirror_for = (camera.revision,
                                mirror_level(getattr(world.scene, "water", None), eye,
                                             clip_from_world, camera.near_m), now, pose)
        eased = self._ease_mirror(self._mirror_for[1], now, camera.revision, pose[:3])
        held = self._mirror_held
        if eased is None:
            self._mirror_held = None
            return off
        if held is None or (not now > held[0] and held[1] != camera.revision) \
                or math.dist(held[2], pose[:3]) > MIRROR_CUT_M:
            levels = hold_levels(None, eased, 0.0, pose[2])     # a cut: as _ease_mirror
        else:
            levels = hold_levels(held[3], eased, now - held[0], pose[2])
        self._mirror_held = (now, camera.revision, pose[:3], levels)
        level, level_b, fade = levels
        if world.flood is not None and world.flood.active:      # the flood's rise near the eye
            rise = float(world.flood.level_rise(np.array([eye[:2]], np.float64))[0])
            eased, level = eased + rise, level + rise
            level_b = None if level_b is None else level_b + rise
        self.last_mirror_level_m = eased
        self.last_mirror_levels = (level, level_b, fade)
        exact = self.debug_exact_reflection
        view = gpu.view.data                # copy 1: copy 0 (pack_view) but for
        view[1] = view[0]
        view[1, 39] = 1.0                   # (no fog: fogged in the water shader, over the
        #                                     ray) cut what is under the water
        self._mirror_pass(world, gpu, settings, clip_from_world, gpu.reflection, level, exact)
        gpu.reflection.colour.bind(REFLECTION_UNIT)
        gpu.reflection.depth.bind(REFLECTION_DEPTH_UNIT)
        uniforms = {"u_reflect": True, "u_mirror_level_m": float(level),
                    "u_reflection_distortion": float(settings.reflection_distortion),
                    "u_reflection_fade": 0.0}
        if level_b is not None:
            self._mirror_pass(world, gpu, settings, clip_from_world, gpu.reflection_b, level_b,
                              exact)
            gpu.reflection_b.colour.bind(REFLECTION_B_UNIT)
            gpu.reflection_b.depth.bind(REFLECTION_B_DEPTH_UNIT)
            uniforms.update(u_mirror_level_b_m=float(level_b), u_reflection_fade=float(fade))
        return uniforms

    def _mirror_pass(self, world: RiverWorld, gpu: _Gpu, settings: DisplaySettings,
                     clip_from_world: np.ndarray, reflection: _Reflection, level: float,
                     exact: bool) -> None:
        """One mirrored pass at ``level`` into ``reflection`` (the view block's copy 1 made
        from copy 0 by the caller: its mirrored matrix and eye written here)."""
        eye = world.camera.position
        reflection.fit(*gpu.size, 1.0 if exact else settings.reflection_scale)
        mirrored_eye = (float(eye[0]), float(eye[1]), 2.0 * level - float(eye[2]))
        # the frame's own world → clip matrix (pyrr's view_projection in closed form, as the
        # main pass draws with), mirrored
        vp = mirrored_view_projection(clip_from_world.T, level)
        view = gpu.view.data
        view[1, :16] = vp.ravel()           # the mirrored world → clip
        view[1, 32:36] = (*mirrored_eye, 0.0)   # the eye
        gpu.view.write()
        gpu.view.bind(1, gpu.view_binding)
        reflection.fb.bind()
        gl.clear((0.0, 0.0, 0.0, 0.0))             # alpha 0: the sky (drawn by the water)
        gl.set_blend(gl.BLEND_OFF)
        gl.set_depth(True)
        gl.set_clip_distance(True)
        self._draw_terrain(world, gpu, "exact" if exact else "coarse")
        self._draw_props(gpu, mirrored=True)
        if settings.fall_sheets and gpu.fall_sheets.in_view(world, vp.T):   # the falls' sheets
            gpu.fall_sheets.draw(world, gpu.programs["falls"], world.clock.now_s % 3600.0,
                                 clip_level_m=level)
        gl.set_clip_distance(False)
        reflection.colour.generate_mipmaps()        # blurred levels for rough water

    def _ease_mirror(self, target: float | None, now_s: float, revision: int,
                     eye: tuple[float, float, float]) -> float | None:
        """The mirror's height this frame: eased towards ``target`` (the level of the water in
        view) as time passes (:func:`ease_level`), so that it changes smoothly however fast
        the view does. It is the target at once after a cut: the first frame, another view
        with no time passed (a still, a test), or an eye more than MIRROR_CUT_M from the last
        frame's (a teleport). None (no reflection) when the eye is not above the target or
        the eased height."""
        last = self._mirror_eased
        eye_z = eye[2]
        if target is None or not eye_z > target + MIN_EYE_HEIGHT_M:
            self._mirror_eased = None
            return None
        level, rate = target, 0.0
        if last is not None:
            t, was, was_rate, seen, (x, y, z) = last
            dt = now_s - t
            if math.hypot(eye[0] - x, eye[1] - y, eye_z - z) > MIRROR_CUT_M:
                pass                                    # a cut: the target at once
            elif dt > 0.0:
                level, rate = ease_level(was, was_rate, target, min(dt, 10.0))
            elif seen == revision:                      # the same view again: as it was
                level, rate = was, was_rate
        if not eye_z > level + MIN_EYE_HEIGHT_M:       # the eye came down fast: the target
            level, rate = target, 0.0
        self._mirror_eased = (now_s, level, rate, revision, eye)
        return level

    def _pre_advect(self, gpu: _Gpu, wave_uniforms: dict,
                    n_drawn: int, water_meshes: list, flood_uniforms: dict) -> None:
        # the water's world position where it is visible (depth test against the terrain)
        gpu.position_fb.bind()
        gl.clear((0.0, 0.0, 0.0, 0.0), depth=False)
        gl.set_depth(True, write=False)
        program = gpu.programs["water_position"]
        program.use()
        program.set(**flood_uniforms)
        for mesh in water_meshes:
            mesh.draw()
        # the sprites, added up
        gpu.accum_fb.bind()
        gl.clear((0.0, 0.0, 0.0, 0.0), depth=False)
        gl.set_depth(False, write=False)
        if n_drawn:
            gpu.position.bind(WATER_POSITION_UNIT)
            program = gpu.programs["sprites"]
            program.use()
            program.set(**wave_uniforms)
            gl.set_blend(gl.BLEND_ADD)
            gpu.empty.draw(gl.TRIANGLES, count=6 * n_drawn)
            gl.set_blend(gl.BLEND_OFF)
        gpu.main_fb.bind()
        gl.set_depth(True)

    # -- output -----------------------------------------------------------------------------

    def read_rgba8(self) -> np.ndarray:
        """The last drawn frame as (H, W, 4) uint8, row 0 at the top."""
        if self.gpu is None:
            raise RuntimeError("nothing drawn yet")
        if self.context is not None:
            gl.make_current(self.context)
        return self.gpu.main_fb.read_rgba8()

    def composite(self, framebuffer: int, viewport: tuple[int, int, int, int],
                  sky: bool) -> None:
        """Draw the last drawn frame into a host's ``framebuffer`` over its ``viewport``
        (x, y, w, h: the frame's size), depth-tested (``<=``) against the host's depth and
        writing it (``shaders/composite.glsl``): ``RiverWorld(gl="current")``. The caller
        (:func:`riverflow.engine.gl.host_frame`) puts the host's state back afterwards."""
        gpu = self.gpu
        if gpu is None:
            raise RuntimeError("nothing drawn yet")
        x, y, w, h = viewport
        if (w, h) != gpu.size:
            raise RuntimeError(f"composite: the host's viewport {w}×{h} is not the frame's "
                               f"{gpu.size[0]}×{gpu.size[1]}")
        gl.bind_host_framebuffer(framebuffer, viewport)
        gl.set_blend(gl.BLEND_OFF)
        gl.set_cull(False)
        gl.set_depth(True)
        gpu.colour.bind(COMPOSITE_COLOUR_UNIT)
        gpu.depth.bind(COMPOSITE_DEPTH_UNIT)
        program = gpu.programs["composite"]
        program.use()
        program.set(u_origin_px=(int(x), int(y)), u_sky=bool(sky))
        gpu.empty.draw(gl.TRIANGLES, count=3)

    def colour_texture(self) -> int:
        """The GL name of the last drawn frame's RGBA8 colour texture (row 0 at the bottom),
        in the world's context: valid until the viewport changes or the world closes."""
        if self.gpu is None:
            raise RuntimeError("nothing drawn yet")
        return int(self.gpu.colour.id)

    def blit_to_window(self, width_px: int, height_px: int) -> None:
        """Copy the last drawn frame onto the current window."""
        if self.gpu is None:
            raise RuntimeError("nothing drawn yet")
        gl.blit_to_window(self.gpu.main_fb, width_px, height_px)

    def close(self) -> None:
        """Release the GPU objects through their context, without making it current (a
        world's finalizer must not switch contexts under a host: :mod:`riverflow.engine.gl`)."""
        self._tiles_for = None
        if self.gpu is not None:
            with gl.deleting_with(self.context):
                self.gpu.delete()
            self.gpu = None
