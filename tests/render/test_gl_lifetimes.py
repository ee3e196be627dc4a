"""GPU objects follow their world: a drawn world dropped without close() deletes its textures,
buffers, vertex arrays, framebuffers and programs (through the context they were made in);
objects of a context that is gone are not touched."""
from __future__ import annotations

import weakref

import pytest

import riverflow as rf
from riverflow.engine.config import RiverConfig

pytestmark = pytest.mark.gl


def _names(world) -> dict[str, list[int]]:
    """The GL names of a drawn world's objects, by kind."""
    drawer = next(s for s in world.systems if s.name == "draw")
    gpu = drawer.gpu
    arenas = [gpu.terrain.arena, gpu.water.arena]      # the tiles' shared buffers
    reflection = gpu.reflection
    return {"texture": [t.id for t in (gpu.colour, gpu.depth, gpu.position, gpu.accum,
                                       gpu.params, gpu.grid, reflection.colour,
                                       reflection.depth)],
            "buffer": [b for a in arenas for b in (a.vbo, a.ebo)],
            "vao": [a.vao for a in arenas],
            "framebuffer": [gpu.main_fb.id, gpu.position_fb.id, gpu.accum_fb.id,
                            reflection.fb.id],
            "program": [p.program.id for p in gpu.programs.values()]}


def _alive(names: dict[str, list[int]]) -> dict[str, int]:
    from pyglet import gl as pgl

    pgl.glUseProgram(0)          # a program in use is only flagged for deletion
    test = {"texture": pgl.glIsTexture, "buffer": pgl.glIsBuffer,
            "vao": pgl.glIsVertexArray, "framebuffer": pgl.glIsFramebuffer,
            "program": pgl.glIsProgram}
    return {kind: sum(bool(test[kind](n)) for n in ids) for kind, ids in names.items()}


def test_a_dropped_drawn_world_deletes_its_gpu_objects(gl_context):
    scene = rf.default_scene(seed=0)
    world = rf.RiverWorld(scene, size=(96, 64), gl=True, seed=0,
                          config=RiverConfig(tile_production="blocking"))
    world.camera.look_at((-1700, -420, 110), (-1550, -250, 40))
    for _ in range(3):
        world.step(1 / 60)
    world.render()
    names = _names(world)
    gpu = next(s for s in world.systems if s.name == "draw").gpu
    assert len(gpu.terrain.arena) and len(gpu.water.arena), "no tile mesh was uploaded"
    del gpu
    assert all(_alive(names)[kind] == len(ids) for kind, ids in names.items())
    ref = weakref.ref(world)
    del world
    assert ref() is None
    assert _alive(names) == {kind: 0 for kind in names}


def test_objects_of_a_destroyed_context_are_left_alone(gl_context):
    """A host's window closed before its world: deleting then must not touch the GL."""
    from riverflow.engine import gl

    texture = gl.Texture((4, 4), gl.RGBA8)
    ident = texture.id

    class Gone:                  # a destroyed pyglet context: detached from its canvas
        canvas = None

        def delete_texture(self, _ident):
            raise AssertionError("a destroyed context was asked to delete an object")

    texture.context = Gone()
    texture.delete()
    assert texture.id == 0
    from pyglet import gl as pgl

    assert pgl.glIsTexture(ident)            # still there: it belonged to the live context
    pgl.glDeleteTextures(1, pgl.GLuint(ident))
