"""Drawing streams with the tiles: the terrain and water meshes drawn are the view's cut
(stand-ins where a tile is not made yet), uploaded when first drawn and released with their
tiles; a long flight under a small cache keeps the GPU meshes bounded."""
from __future__ import annotations

import numpy as np
import pytest

from riverflow.components.river import TerrainView
from riverflow.engine.config import RiverConfig
from riverflow.scenes.default import default_scene
from riverflow.scenes.flight import flight_pose, main_centerline
from riverflow.scenes.tile_kinds import TERRAIN_MESH, WATER_MESH
from riverflow.tiles.table import codes

pytestmark = pytest.mark.gl
W, H = 160, 90


def _drawer(world):
    return world._drawer()


@pytest.mark.slow
def test_gpu_meshes_follow_the_tile_cache(gl_context):
    from riverflow.engine.world import RiverWorld
    scene = default_scene(seed=0)
    line = main_centerline(scene)
    world = RiverWorld(scene, size=(W, H), gl=True, seed=0,
                       config=RiverConfig(tile_production="blocking", tile_cache_mb=12))
    try:
        most = 0
        released = 0
        for f in range(0, 3000, 150):                  # hop down the whole river
            world.camera.look_at(*flight_pose(scene, f, speed_mps=60.0, line=line))
            world.step(1 / 60)
            world.render()
            gpu = _drawer(world).gpu
            tiles = world.tiles
            for kind in (TERRAIN_MESH, WATER_MESH):
                pool = tiles.cache.pools[kind]
                on_gpu = gpu.resident_codes(kind)
                assert on_gpu <= set(pool.codes().tolist()), kind     # released with its tile
                most = max(most, len(on_gpu))
            released += tiles.cache.pools[TERRAIN_MESH].evicted
            # what was drawn is the view's cut: its terrain tiles are all on the GPU
            cut = world.resource(TerrainView).cut
            assert set(codes(cut).tolist()) <= gpu.resident_codes(TERRAIN_MESH)
            arena = gpu.terrain.arena                  # one slot per terrain tile on the GPU
            assert len(arena) == len(gpu.resident_codes(TERRAIN_MESH))
            assert _drawer(world).last_tiles == len(cut)
        assert released > 0                            # the small cache did evict
        assert most < 400
    finally:
        world.close()


def test_a_missing_tile_is_drawn_by_its_ancestor(gl_context):
    """The tiles above the cut are made too: when a leaf's mesh is not resident, its finest
    resident ancestor is drawn in its place (one ancestor for all its missing leaves, never
    overlapping a drawn leaf), so the frame has no hole."""
    from riverflow.engine.world import RiverWorld
    scene = default_scene(seed=0)
    world = RiverWorld(scene, size=(W, H), gl=True, seed=0,
                       config=RiverConfig(tile_production="blocking"))
    try:
        world.camera.look_at(*flight_pose(scene, 0))
        world.step(1 / 60)
        full = world.render()
        drawer = _drawer(world)
        cut = world.resource(TerrainView).cut
        assert drawer.last_tiles == len(cut) > 8
        pool = world.tiles.cache.pools[TERRAIN_MESH]
        finest = int(cut[:, 0].max())
        assert len(pool) > len(cut)                    # the ancestors are made too
        # drop the finest leaves' meshes (not made yet, as far as drawing is concerned)
        dropped = [k for k in cut.tolist() if k[0] == finest]
        for k in dropped:
            pool.release(pool.slot(int(codes(np.array([k]))[0])))
        coarse = world.render()
        assert drawer.last_tiles < len(cut)            # parents stand in, fewer meshes
        assert (coarse[..., 3] == 255).all()
        # the same picture, a little coarser: no hole where the leaves were
        diff = np.abs(coarse.astype(int) - full.astype(int)).max(axis=2)
        assert (diff > 60).mean() < 0.05, (diff > 60).mean()
    finally:
        world.close()


def test_closing_the_world_releases_every_tile_mesh(gl_context):
    from riverflow.engine.world import RiverWorld
    world = RiverWorld(default_scene(seed=0), size=(W, H), gl=True, seed=0,
                       config=RiverConfig(tile_production="blocking"))
    world.camera.look_at(*flight_pose(world.scene, 0))
    world.step(1 / 60)
    world.render()
    gpu = _drawer(world).gpu
    arenas = [gpu.terrain.arena, gpu.water.arena]    # every tile's GPU data is in these
    assert all(len(arena) for arena in arenas)
    world.close()
    assert all(arena.vao == arena.vbo == arena.ebo == 0 for arena in arenas)
