"""The tiles' shared GPU buffers: gl.SlotArena (the terrain tiles: fixed-size vertex slots,
one index buffer), gl.MeshArena (the water tiles: meshes of any size) and its
gl.RangeAllocator. One multi-draw call draws the same picture as the meshes drawn one by one
in the same order; slots and runs are reused after release; growing keeps what was uploaded;
the buffers go with delete(); a world's frame after evictions draws only resident tiles."""
from __future__ import annotations

import ctypes
from pathlib import Path

import numpy as np
import pytest

pytestmark = pytest.mark.gl
PROBES = Path(__file__).parent / "shaders"
W, H = 96, 64
CELLS = 4                                   # a probe tile is CELLS x CELLS quads
ATTRIBUTES = {0: 3, 1: 1}                   # clip-space position, shade


def _grid_indices(n: int) -> np.ndarray:
    side = n + 1
    j, i = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    a = (j * side + i).ravel()
    b, c, d = a + 1, a + side + 1, a + side
    return np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)]).astype(np.uint32)


def _tile(rng, n: int = CELLS) -> np.ndarray:
    """(n+1)² vertices of a square somewhere on screen, flat at one of three depths (so that
    overlapping tiles tie in depth and the order they are drawn in shows), shaded at random."""
    x0, y0 = rng.uniform(-1.0, 0.4, 2)
    size = rng.uniform(0.4, 0.9)
    t = np.linspace(0.0, size, n + 1)
    y, x = np.meshgrid(y0 + t, x0 + t, indexing="ij")
    z = np.full(x.shape, rng.choice([-0.2, 0.0, 0.3]))
    shade = rng.uniform(0.05, 0.95, x.shape)
    return np.stack([x, y, z, shade], -1).reshape(-1, 4).astype(np.float32)


@pytest.fixture
def target(gl_context):
    from riverflow.engine import gl
    colour = gl.Texture((W, H), gl.RGBA8)
    depth = gl.Texture((W, H), gl.DEPTH24)
    fb = gl.Framebuffer([colour], depth)
    program = gl.Program("probe_arena.glsl", directory=PROBES)

    def render(draw) -> np.ndarray:
        fb.bind()
        gl.clear((0.0, 0.0, 0.0, 1.0))
        gl.set_depth(True)
        gl.set_blend(gl.BLEND_OFF)
        program.use()
        draw()
        gl.check_errors("probe draw")
        return fb.read_rgba8()

    yield render
    for obj in (fb, colour, depth, program):
        obj.delete()


def _one_by_one(meshes, count=None, first=0):
    """Draw each gl.Mesh (its own buffers) in turn."""
    def draw():
        for mesh in meshes:
            mesh.draw(count=count, first=first)
    return draw


def _alive(vao: int, buffers) -> tuple[bool, ...]:
    from pyglet import gl as pgl
    return (bool(pgl.glIsVertexArray(vao)),) + tuple(bool(pgl.glIsBuffer(b)) for b in buffers)


# -- SlotArena -----------------------------------------------------------------------------

def test_one_multi_draw_draws_what_the_tiles_drawn_one_by_one_draw(target, rng):
    from riverflow.engine import gl
    indices = _grid_indices(CELLS)
    tiles = [_tile(rng) for _ in range(12)]
    arena = gl.SlotArena(len(tiles[0]), ATTRIBUTES, indices, capacity=16)
    meshes = [gl.Mesh(t, ATTRIBUTES, indices) for t in tiles]
    slots = [arena.alloc() for _ in tiles]
    for slot, tile in zip(slots, tiles):
        arena.upload(slot, tile)
    order = rng.permutation(len(tiles))
    try:
        multi = target(lambda: arena.draw(np.array(slots)[order]))
        single = target(_one_by_one([meshes[k] for k in order]))
        np.testing.assert_array_equal(multi, single)
        assert len(np.unique(multi.reshape(-1, 4), axis=0)) > 20      # something was drawn
        # the order is kept (ties in depth: the later tile wins), so the test can fail
        assert (target(lambda: arena.draw(np.array(slots)[order[::-1]])) != multi).any()
        # a range of the shared indices (the reflection's coarse mesh is one)
        half = indices.size // 2
        np.testing.assert_array_equal(
            target(lambda: arena.draw(np.array(slots)[order], count=half, first=half)),
            target(_one_by_one([meshes[k] for k in order], count=half, first=half)))
        np.testing.assert_array_equal(target(lambda: arena.draw(np.zeros(0, np.int32))),
                                      target(lambda: None))
    finally:
        arena.delete()
        for mesh in meshes:
            mesh.delete()


def test_draw_parts_draws_each_slot_through_its_own_ranges_and_keeps_its_arrays(target, rng):
    """``draw_parts``: each slot through its own P ranges of the shared indices (the terrain
    tiles' core and edge variants), in the slots' order, as drawing each mesh range by range;
    with ``cache`` the arrays are refilled when the slots' order or the revision changes."""
    from riverflow.engine import gl
    indices = _grid_indices(CELLS)
    tiles = [_tile(rng) for _ in range(8)]
    arena = gl.SlotArena(len(tiles[0]), ATTRIBUTES, indices, capacity=8)
    meshes = [gl.Mesh(t, ATTRIBUTES, indices) for t in tiles]
    slots = np.array([arena.alloc() for _ in tiles], np.int32)
    for slot, tile in zip(slots, tiles):
        arena.upload(slot, tile)
    tris = len(indices)
    counts = np.zeros((arena.capacity, 2), np.int32)
    firsts = np.zeros((arena.capacity, 2), np.int64)

    def ranges():             # two random runs of whole triangles per slot
        for s in slots.tolist():
            a, b = np.sort(rng.choice(tris, 2, replace=False))
            counts[s], firsts[s] = (3 * (b - a), 3 * (tris - b)), (3 * a, 3 * b)

    def one_by_one(order):
        def draw():
            for k in order:
                s = int(slots[k])
                for c, f in zip(counts[s].tolist(), firsts[s].tolist()):
                    meshes[k].draw(count=c, first=f)
        return draw

    try:
        ranges()
        order = rng.permutation(len(tiles))
        parts = target(lambda: arena.draw_parts(slots[order], counts, 4 * firsts,
                                                cache=("t", 0)))
        np.testing.assert_array_equal(parts, target(one_by_one(order)))
        assert len(np.unique(parts.reshape(-1, 4), axis=0)) > 20
        np.testing.assert_array_equal(
            target(lambda: arena.draw_parts(slots[order], counts, 4 * firsts)), parts)
        order = order[::-1]                       # another order: refilled
        np.testing.assert_array_equal(
            target(lambda: arena.draw_parts(slots[order], counts, 4 * firsts, cache=("t", 0))),
            target(one_by_one(order)))
        ranges()                                  # new ranges: a new revision refills
        np.testing.assert_array_equal(
            target(lambda: arena.draw_parts(slots[order], counts, 4 * firsts, cache=("t", 1))),
            target(one_by_one(order)))
    finally:
        arena.delete()
        for mesh in meshes:
            mesh.delete()


def test_slots_are_reused_after_release(gl_context, rng):
    from riverflow.engine import gl
    arena = gl.SlotArena((CELLS + 1) ** 2, ATTRIBUTES, _grid_indices(CELLS), capacity=4)
    try:
        assert [arena.alloc() for _ in range(3)] == [0, 1, 2] and len(arena) == 3
        kept = _tile(rng)
        arena.upload(0, kept)
        arena.free([1])
        assert len(arena) == 2 and not arena.used[1]
        assert arena.alloc() == 1                  # the slot given back, not a new one
        assert arena.alloc() == 3 and arena.capacity == 4 and arena.grown == 0
        np.testing.assert_array_equal(arena.read(0), kept)
        with pytest.raises(ValueError):
            arena.free([1, 1])                     # the second time: not in use
        with pytest.raises(ValueError):
            arena.upload(0, kept[:-1])             # a slot's size only
    finally:
        arena.delete()


def test_growing_keeps_the_tiles_uploaded_before(target, rng):
    from riverflow.engine import gl
    indices = _grid_indices(CELLS)
    tiles = [_tile(rng) for _ in range(7)]
    arena = gl.SlotArena(len(tiles[0]), ATTRIBUTES, indices, capacity=2)
    meshes = [gl.Mesh(t, ATTRIBUTES, indices) for t in tiles]
    try:
        slots = []
        for tile in tiles:
            slots.append(arena.alloc())
            arena.upload(slots[-1], tile)
        assert arena.capacity == 8 and arena.grown == 2
        for slot, tile in zip(slots, tiles):
            np.testing.assert_array_equal(arena.read(slot), tile)
        np.testing.assert_array_equal(target(lambda: arena.draw(np.array(slots))),
                                      target(_one_by_one(meshes)))
    finally:
        arena.delete()
        for mesh in meshes:
            mesh.delete()


def test_delete_releases_the_arenas_gpu_objects(gl_context, rng):
    from riverflow.engine import gl
    slots = gl.SlotArena((CELLS + 1) ** 2, ATTRIBUTES, _grid_indices(CELLS), capacity=1)
    slots.upload(slots.alloc(), _tile(rng))
    slots.alloc()                                  # grown once: the first buffer went then
    meshes = gl.MeshArena(ATTRIBUTES, vertices=8, indices=8)
    meshes.add(_tile(rng), _grid_indices(CELLS))  # both buffers grown
    names = [(a.vao, (a.vbo, a.ebo)) for a in (slots, meshes)]
    assert all(all(_alive(vao, bufs)) for vao, bufs in names)
    for arena in (slots, meshes):
        arena.delete()
        assert arena.vao == arena.vbo == arena.ebo == 0
    assert not any(any(_alive(vao, bufs)) for vao, bufs in names)


# -- MeshArena and RangeAllocator -------------------------------------------------------------

def test_range_allocator_against_a_twin(rng):
    from riverflow.engine.gl import RangeAllocator
    ranges = RangeAllocator(64)
    free = np.ones(64, bool)                       # the twin: which units are free
    held: list[tuple[int, int]] = []
    for _ in range(2000):
        if held and rng.random() < 0.45:
            start, n = held.pop(int(rng.integers(len(held))))
            ranges.free(start, n)
            free[start:start + n] = True
        else:
            n = int(rng.integers(1, 9))
            start = ranges.alloc(n)
            runs = np.flatnonzero(np.convolve(free, np.ones(n, int), "valid") == n)
            if not len(runs):                      # first fit found nothing: grow
                assert start == -1
                ranges.grow(ranges.size + 16)
                free = np.concatenate([free, np.ones(16, bool)])
                start = ranges.alloc(n)
                runs = np.flatnonzero(np.convolve(free, np.ones(n, int), "valid") == n)
            assert start == runs[0]                # the first run that fits
            free[start:start + n] = False
            held.append((start, n))
        # the free runs are the twin's, merged (no two touching)
        edges = np.flatnonzero(np.diff(np.concatenate([[0], free.astype(int), [0]])))
        assert ranges.runs == [[int(a), int(b - a)] for a, b in edges.reshape(-1, 2)]
    with pytest.raises(ValueError):
        ranges.free(ranges.runs[0][0], 1)          # already free


def test_mesh_arena_reuses_runs_grows_and_draws_like_the_meshes_one_by_one(target, rng):
    from riverflow.engine import gl
    arena = gl.MeshArena(ATTRIBUTES, vertices=64, indices=256)

    def mesh_data():
        n = int(rng.integers(1, 6))
        return _tile(rng, n), _grid_indices(n)

    data = [mesh_data() for _ in range(10)]
    where = [arena.add(v, i) for v, i in data]
    assert arena.grown > 0 and len(arena) == 10
    for (v, i), (v0, i0) in zip(data, where):      # growing kept every mesh
        got_v, got_i = arena.read(v0, len(v), i0, i.size)
        np.testing.assert_array_equal(got_v, v)
        np.testing.assert_array_equal(got_i, i.ravel())
    # give some back; a mesh that fits takes the first freed run
    for k in (2, 5):
        (v, i), (v0, i0) = data[k], where[k]
        arena.remove(v0, len(v), i0, i.size)
    small = (_tile(rng, 1), _grid_indices(1))
    got = arena.add(*small)
    assert got == where[2]
    data = [d for k, d in enumerate(data) if k not in (2, 5)] + [small]
    where = [w for k, w in enumerate(where) if k not in (2, 5)] + [got]
    assert len(arena) == 9
    meshes = [gl.Mesh(v, ATTRIBUTES, i) for v, i in data]
    try:
        order = rng.permutation(len(data))
        w = np.array(where)[order]
        counts = np.array([data[k][1].size for k in order])
        multi = target(lambda: arena.draw(w[:, 1], counts, w[:, 0]))
        np.testing.assert_array_equal(multi, target(_one_by_one([meshes[k] for k in order])))
        assert (target(lambda: arena.draw(w[::-1, 1], counts[::-1], w[::-1, 0])) != multi).any()
    finally:
        arena.delete()
        for mesh in meshes:
            mesh.delete()


# -- in a world ---------------------------------------------------------------------------------

def _drawn_one_by_one(monkeypatch):
    """Make every arena draw its meshes one glDrawElementsBaseVertex at a time."""
    from pyglet import gl as pgl

    from riverflow.engine import gl

    def call(self, vao, mode, n):
        pgl.glBindVertexArray(vao)
        for k in range(n):
            pgl.glDrawElementsBaseVertex(mode, int(self.counts[k]), pgl.GL_UNSIGNED_INT,
                                         ctypes.c_void_p(int(self.offsets[k])),
                                         int(self.base[k]))
        pgl.glBindVertexArray(0)

    monkeypatch.setattr(gl._MultiDraw, "call", call)


def test_a_world_frame_drawn_with_multi_draws_is_the_one_drawn_tile_by_tile(gl_context,
                                                                             monkeypatch):
    import riverflow as rf
    from riverflow.scenes.flight import flight_pose

    world = rf.RiverWorld(rf.default_scene(seed=0), size=(160, 90), gl=True, seed=0,
                          config=rf.RiverConfig(tile_production="blocking"))
    try:
        world.camera.look_at(*flight_pose(world.scene, 0))
        world.step(1 / 60)
        multi = world.render()
        drawer = world._drawer()
        assert drawer.last_tiles > 8 and drawer.last_mirror_level_m is not None
        with monkeypatch.context() as m:
            _drawn_one_by_one(m)
            single = world.render()
        np.testing.assert_array_equal(multi, single)
    finally:
        world.close()


def _drawn_terrain(world) -> dict[int, np.ndarray]:
    """The terrain tiles the last frame drew: code → the vertices its arena slot holds."""
    from riverflow.scenes.tile_kinds import TERRAIN_MESH
    gpu = world._drawer().gpu
    pool = world.tiles.cache.pools[TERRAIN_MESH]
    code_of = {int(gpu.terrain.arena_slot[pool.slot(c)]): c
               for c in gpu.resident_codes(TERRAIN_MESH)}
    drawn = world._drawer()._terrain_slots.tolist()
    assert len(set(drawn)) == len(drawn) and set(drawn) <= set(code_of)
    return {code_of[s]: gpu.terrain.arena.read(s) for s in drawn}


def _assert_own_data(world, drawn, pool) -> None:
    """Each drawn slot holds its own tile's vertices: as the pool holds them, or stitched to
    neighbours more than log2(n) levels coarser (the border and skirt only; what was
    stitched, recorded); and it is drawn through the index ranges of its edges' level
    differences to the frame's coarser neighbours."""
    from riverflow.scenes.meshes import coarser_neighbours, edge_levels_up, stitch_tile
    from riverflow.tiles.table import code_key, tile_code
    terrain = world._drawer().gpu.terrain
    keys = np.array(sorted(code_key(c) for c in drawn))
    across = coarser_neighbours(keys)
    up = edge_levels_up(keys, across)
    n = world.scene.terrain.tile_cells
    side = n + 1
    inner = np.zeros((side, side), bool)
    inner[1:-1, 1:-1] = True
    (core_count, core_first), edge = terrain.tables["full"]
    full = terrain.meshes.index("full")
    counts, firsts = terrain.counts[:, full], terrain.offsets[:, full] // 4
    for r, key in enumerate(keys.tolist()):
        code = tile_code(*key)
        data = pool.get(code)
        vertices = drawn[code]
        aslot = int(terrain.arena_slot[pool.slot(code)])
        k = np.minimum(up[r], edge.shape[1] - 1)
        assert counts[aslot].tolist() == [core_count] + edge[range(4), k, 0].tolist()
        assert firsts[aslot].tolist() == [core_first] + edge[range(4), k, 1].tolist()
        grid = vertices[:side * side][inner.ravel()]
        np.testing.assert_array_equal(grid, data.vertices[:side * side][inner.ravel()])
        stitched = terrain.stitched.get(pool.slot(code))
        big = np.where(up[r] > terrain.max_up, across[r], -1)
        if (big < 0).all():
            assert stitched is None
            np.testing.assert_array_equal(vertices, data.vertices)
        else:
            neighbours = [(e, tuple(keys[m].tolist()), drawn[tile_code(*keys[m])])
                          for e, m in enumerate(big.tolist()) if m >= 0]
            np.testing.assert_array_equal(vertices, stitch_tile(data.vertices, key,
                                                                data.skirt_m, neighbours))
    assert (up > 0).any()                 # the view has level borders


def _drawn_at_the_first_view():
    """A drawn 160 × 90 world (blocking tiles) stepped and rendered once at the flight's
    first view (the caller closes it)."""
    import riverflow as rf
    from riverflow.scenes.flight import flight_pose

    world = rf.RiverWorld(rf.default_scene(seed=0), size=(160, 90), gl=True, seed=0,
                          config=rf.RiverConfig(tile_production="blocking"))
    world.camera.look_at(*flight_pose(world.scene, 0))
    world.step(1 / 60)
    world.render()
    return world


def test_after_evictions_a_frame_draws_only_resident_tiles(gl_context):
    from riverflow.components.river import TerrainView
    from riverflow.scenes.tile_kinds import TERRAIN_MESH, WATER_MESH
    from riverflow.tiles.cut import standin_tiles
    from riverflow.tiles.table import codes

    world = _drawn_at_the_first_view()
    try:
        gpu = world._drawer().gpu
        terrain = world.tiles.cache.pools[TERRAIN_MESH]
        water = world.tiles.cache.pools[WATER_MESH]
        cut = world.resource(TerrainView).cut
        assert set(_drawn_terrain(world)) == set(codes(cut).tolist())
        assert len(gpu.water.arena) > 0
        # evict the cut's finest terrain leaves (their parents stand in, uploaded now, in the
        # slots given back) and every water tile
        finest = int(cut[:, 0].max())
        gone = {c for c, k in zip(codes(cut).tolist(), cut.tolist()) if k[0] == finest}
        for c in gone:
            terrain.release(terrain.slot(c))
        water.clear()
        world.render()                             # draws only: no tile is made again
        drawn = _drawn_terrain(world)
        assert set(drawn) == set(standin_tiles(cut, terrain).codes.tolist())
        assert not set(drawn) & gone and set(drawn) <= set(terrain.codes().tolist())
        _assert_own_data(world, drawn, terrain)    # each slot holds its own tile's data
        assert not gone & gpu.resident_codes(TERRAIN_MESH)
        assert len(gpu.terrain.arena) == len(gpu.resident_codes(TERRAIN_MESH))
        assert len(gpu.water.arena) == 0 and not gpu.resident_codes(WATER_MESH)
        # the next step makes them again: all drawn from their own data
        world.step(1 / 60)
        world.render()
        drawn = _drawn_terrain(world)
        assert set(drawn) == set(codes(world.resource(TerrainView).cut).tolist())
        _assert_own_data(world, drawn, terrain)
        assert len(gpu.water.arena) > 0
        assert gpu.resident_codes(WATER_MESH) <= set(water.codes().tolist())
    finally:
        world.close()


def test_the_same_drawn_set_is_not_stitched_again(gl_context, monkeypatch):
    """A frame whose cut or pools changed but whose drawn terrain tiles did not (the draw
    system's tile sync runs again) skips the stitch look-up and keeps what is on the GPU; a
    tile uploaded afresh (a stand-in for an evicted leaf) makes the set stitched again."""
    from riverflow.scenes.tile_kinds import TERRAIN_MESH
    from riverflow.tiles.table import code_key

    world = _drawn_at_the_first_view()
    try:
        drawer = world._drawer()
        terrain = drawer.gpu.terrain
        pool = world.tiles.cache.pools[TERRAIN_MESH]
        calls = []
        stitch = type(terrain)._seams
        monkeypatch.setattr(type(terrain), "_seams",
                            lambda self, *a: (calls.append(1), stitch(self, *a))[1])
        before = _drawn_terrain(world)
        drawer._tiles_for = None                   # as after a change of the cut or a pool
        world.render()
        assert calls == []
        after = _drawn_terrain(world)
        assert before.keys() == after.keys()
        for code, vertices in before.items():
            np.testing.assert_array_equal(after[code], vertices)
        # a leaf evicted: its parent stands in, uploaded now; the set is stitched again
        leaf = max(after, key=lambda c: code_key(c)[0])         # one of the finest
        pool.release(pool.slot(leaf))
        world.render()
        assert calls == [1]
        _assert_own_data(world, _drawn_terrain(world), pool)
    finally:
        world.close()
