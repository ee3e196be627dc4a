"""Rivers in another library's window (issue 28): ``RiverWorld(gl="current")`` draws with the
context a pygame-ce, glfw or arcade host made current, into the host's framebuffer, with the
host's camera and depth, and leaves the host's GL state as it was; no usable context is a
clear error.

The hosts run in this process, one Xvfb display for the module (pygame and glfw make GLX
contexts on it; arcade is a pyglet window, an EGL pbuffer like the other tests' contexts under
PYGLET_HEADLESS). The window's pixels are read from the host's own framebuffer after the
host's swap (its front buffer). Small windows, a few frames: the module costs a few seconds
of CPU, most of it the worlds' first frames.
"""
from __future__ import annotations

import ctypes
import importlib.util
import os
import subprocess
import sys
import threading
from types import SimpleNamespace

import numpy as np
import pytest

import riverflow as rf
from riverflow.engine import gl as rgl
from tests.conftest import REPO

pytestmark = pytest.mark.gl

W, H = 160, 120
HOST_CLEAR = (0.5, 0.0, 0.5)                    # a colour nothing of the river's has
HOST_CLEAR_U8 = (128, 0, 128)
GL_RGBA, GL_UNSIGNED_BYTE = 0x1908, 0x1401
CONFIG = dict(capacity=2048, terrain_tile_px=48.0, flow_tile_px=16.0, freeze_gc_on_load=False)
"""Coarse tiles, fewer particles, no garbage collection on load: a small window shows the
same river, for a fraction of the first frame's CPU time."""


def _libgl():
    lib = ctypes.CDLL("libGL.so.1")
    lib.glReadPixels.argtypes = [ctypes.c_int] * 4 + [ctypes.c_uint] * 2 + [ctypes.c_void_p]
    return lib


def read_pixels() -> np.ndarray:
    """The bound read framebuffer as (H, W, 4) uint8, row 0 at the top, read with the host's
    own GL calls (plain libGL)."""
    out = np.empty((H, W, 4), np.uint8)
    _libgl().glReadPixels(0, 0, W, H, GL_RGBA, GL_UNSIGNED_BYTE, out.ctypes.data)
    return out[::-1].copy()


class _XImage(ctypes.Structure):
    _fields_ = [(name, ctypes.c_int) for name in ("width", "height", "xoffset", "format")] + [
        ("data", ctypes.c_void_p)] + [(name, ctypes.c_int) for name in (
            "byte_order", "bitmap_unit", "bitmap_bit_order", "bitmap_pad", "depth",
            "bytes_per_line", "bits_per_pixel")]


def window_pixels(window_id: int) -> np.ndarray:
    """What the X server shows in the host's window after its swap, as (H, W, 4) uint8 RGBA
    (XGetImage: Mesa's front buffer on Xvfb is the window itself, not readable with GL)."""
    x11 = ctypes.CDLL("libX11.so.6")
    x11.XOpenDisplay.restype = ctypes.c_void_p
    x11.XOpenDisplay.argtypes = [ctypes.c_char_p]
    x11.XGetImage.restype = ctypes.POINTER(_XImage)
    x11.XGetImage.argtypes = [ctypes.c_void_p, ctypes.c_ulong, ctypes.c_int, ctypes.c_int,
                              ctypes.c_uint, ctypes.c_uint, ctypes.c_ulong, ctypes.c_int]
    x11.XFree.argtypes = [ctypes.c_void_p]
    x11.XCloseDisplay.argtypes = [ctypes.c_void_p]
    display = x11.XOpenDisplay(None)
    pointer = x11.XGetImage(display, window_id, 0, 0, W, H, 0xFFFFFFFF, 2)   # ZPixmap
    image = pointer.contents
    assert (image.width, image.height, image.bits_per_pixel) == (W, H, 32)
    rows = np.ctypeslib.as_array((ctypes.c_uint8 * (image.bytes_per_line * H)).from_address(
        image.data)).reshape(H, image.bytes_per_line // 4, 4)[:, :W]
    out = np.empty((H, W, 4), np.uint8)
    out[..., :3] = rows[..., 2::-1]             # BGRX
    out[..., 3] = 255
    x11.XFree(image.data)
    x11.XFree(ctypes.cast(pointer, ctypes.c_void_p))
    x11.XCloseDisplay(display)
    return out


@pytest.fixture(scope="module")
def display(xvfb_module):
    """The Xvfb display for the hosts' windows. The thread's EGL context (the offscreen one
    earlier tests of this process made current) is put aside while the hosts' GLX contexts
    live (a thread cannot have both) and made current again afterwards."""
    old = os.environ.get("DISPLAY")
    os.environ["DISPLAY"] = xvfb_module
    previous = rgl.gl.current_context
    native = rgl.native_current_context()
    if native is not None and native[0] == "egl":
        egl = ctypes.CDLL("libEGL.so.1")
        egl.eglGetCurrentDisplay.restype = ctypes.c_void_p
        egl.eglMakeCurrent.argtypes = [ctypes.c_void_p] * 4
        egl.eglMakeCurrent(egl.eglGetCurrentDisplay(), None, None, None)
    yield xvfb_module
    if old is None:
        os.environ.pop("DISPLAY", None)
    else:
        os.environ["DISPLAY"] = old
    if previous is not None and rgl.context_alive(previous):
        previous.set_current()


def _demo(name: str):
    """A module of demos/ (each is a complete small host game)."""
    path = REPO / "demos" / f"{name}.py"
    spec = importlib.util.spec_from_file_location(f"demo_{name}", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def scene():
    return rf.default_scene(seed=0)


def _camera_matrices(world):
    """The host's camera, as a host has it: column-major view and projection (pyrr's
    row-vector matrices ravelled are exactly that)."""
    camera = world.camera
    return camera.view_matrix().ravel(), camera.projection_matrix().ravel()


def test_no_context_is_a_clear_error(display, scene):
    assert rgl.native_current_context() is None
    assert rf.ContextError is rgl.ContextError
    with pytest.raises(rf.ContextError, match="no OpenGL context is current on this thread"):
        rf.RiverWorld(scene, size=(W, H), gl="current")
    with pytest.raises(ValueError, match='gl must be False, True or "current"'):
        rf.RiverWorld(scene, size=(W, H), gl="yes")


@pytest.fixture(scope="module")
def pygame_host(display, scene):
    """demos/pygame_host.py's window and game (its world made with the module's scene)."""
    pygame = pytest.importorskip("pygame")
    pytest.importorskip("moderngl")
    demo = _demo("pygame_host")
    mgl = demo.open_window((W, H))               # the host's own GL (moderngl)
    game = demo.hostgame.Game((W, H), seed=0)
    game.start(gl="current", scene=scene, config=rf.RiverConfig(**CONFIG))
    game.update(demo.hostgame.STEP_S)               # the host's camera, particles
    yield SimpleNamespace(pygame=pygame, mgl=mgl, world=game.rivers, demo=demo, game=game,
                          window=pygame.display.get_wm_info()["window"])
    game.rivers.close()
    mgl.release()
    pygame.display.quit()


def _assert_same_frame(window: np.ndarray, own: np.ndarray, world, rows: int = H) -> None:
    """The host's window shows riverflow's own offscreen frame (but where the host drew in
    front of it: a few pixels), and water where the particles are (on the water by
    construction)."""
    same = (np.abs(window[..., :3].astype(int) - own[..., :3].astype(int)) <= 2).all(-1)
    assert same.mean() > 0.97, same.mean()
    p = world.particles
    inside = p.screen_px[(p.status == rf.FlowStatus.INSIDE)]
    inside = inside[(inside[:, 0] >= 0) & (inside[:, 0] < W) & (inside[:, 1] >= H - rows)
                    & (inside[:, 1] < H)]             # (the top ``rows`` rows)
    assert len(inside) > 10
    cols, rows = inside[:, 0].astype(int), H - 1 - inside[:, 1].astype(int)
    water = window[rows, cols, :3].astype(int)
    assert np.mean(water[:, 2] > water[:, 0]) > 0.8          # blue-grey water, not land
    assert not (window[..., :3] == HOST_CLEAR_U8).all(-1).any()   # the sky drawn too


def test_pygame_demo_window_shows_the_river(pygame_host):
    h = pygame_host

    def check(game):
        shown = window_pixels(h.window)
        _assert_same_frame(shown, game.rivers.render(), game.rivers)

    h.demo.play(h.game, h.mgl, frames=2, on_last_frame=check)


_QUAD_PROGRAM = """
#version 330 core
uniform mat4 u_view_projection;
in vec3 in_position;
void main() { gl_Position = u_view_projection * vec4(in_position, 1.0); }
"""
_QUAD_COLOUR = """
#version 330 core
uniform vec3 u_colour;
out vec4 frag;
void main() { frag = vec4(u_colour, 1.0); }
"""


def _host_quad(mgl, program, corners):
    buffer = mgl.buffer(np.asarray(corners, np.float32).tobytes())
    return mgl.vertex_array(program, [(buffer, "3f", "in_position")]), buffer


def test_depth_host_quads_in_front_and_under_the_water(pygame_host):
    """A host quad between the eye and the river hides the water; one just under the water
    surface is hidden by it (the host's matrices, the host's depth buffer)."""
    h, world = pygame_host, pygame_host.world
    mgl, camera = h.mgl, world.camera
    view, projection = _camera_matrices(world)
    program = mgl.program(vertex_shader=_QUAD_PROGRAM, fragment_shader=_QUAD_COLOUR)
    program["u_view_projection"].write(camera.view_projection().tobytes())
    eye, f, r, u = camera.position, camera.forward, camera.right, camera.screen_up
    centre = eye + 30.0 * f - 8.0 * r - 5.0 * u           # lower left of the view, 30 m off
    front = [centre + a * r + b * u for a, b in ((-3, -3), (3, -3), (3, 3), (-3, -3), (3, 3),
                                                (-3, 3))]
    p = world.particles
    on_water = p.world_m[(p.status == rf.FlowStatus.INSIDE) & p.has_world]
    spot = on_water[np.argmin(np.linalg.norm(on_water - (eye + 80.0 * f), axis=1))]
    level = float(world.scene.water.level(spot[None, :2])[0])
    under = [(spot[0] + a, spot[1] + b, level - 0.3) for a, b in ((-8, -8), (8, -8), (8, 8),
                                                                  (-8, -8), (8, 8), (-8, 8))]
    quads = [(_host_quad(mgl, program, front), (1.0, 0.0, 0.0)),
             (_host_quad(mgl, program, under), (0.0, 1.0, 0.0))]

    def host_frame(with_river: bool) -> np.ndarray:
        mgl.clear(*HOST_CLEAR, 1.0, depth=1.0)
        mgl.enable(mgl.DEPTH_TEST)
        for (vao, _), colour in quads:
            program["u_colour"].value = colour
            vao.render()
        mgl.disable(mgl.DEPTH_TEST)
        if with_river:
            world.draw(view, projection, sky=False)
        h.pygame.display.flip()
        return window_pixels(h.window)

    alone, with_river = host_frame(False), host_frame(True)
    red = (alone[..., :3] == (255, 0, 0)).all(-1)
    green = (alone[..., :3] == (0, 255, 0)).all(-1)
    assert red.sum() > 100 and green.sum() > 20          # both quads are in the view
    assert (with_river[red][:, :3] == (255, 0, 0)).all()     # in front: still the host's
    assert not (with_river[..., :3] == (0, 255, 0)).all(-1).any()   # under: the water's
    assert np.abs(with_river[green][:, :3].astype(int) - (0, 255, 0)).sum(-1).min() > 100
    for (vao, buffer), _ in quads:
        vao.release()
        buffer.release()
    program.release()


def _host_state(world) -> dict:
    with rgl._as_pyglet_current(world.context):
        return rgl.HostState.save().as_dict()


def test_gl_state_is_the_hosts_after_a_draw(pygame_host):
    """Every piece of state the draw touches, set by the host to something other than
    OpenGL's defaults and riverflow's own choices, reads the same after ``draw()``; and every
    state-changing GL call the draw makes is of state :class:`HostState` saves."""
    h, world = pygame_host, pygame_host.world
    mgl = h.mgl
    program = mgl.program(vertex_shader=_QUAD_PROGRAM, fragment_shader=_QUAD_COLOUR)
    buffer = mgl.buffer(np.zeros(9, np.float32).tobytes())
    vao = mgl.vertex_array(program, [(buffer, "3f", "in_position")])
    texture = mgl.texture((4, 4), 4)
    ubo = mgl.buffer(reserve=256)
    lib = _libgl()
    # the host's state: a bound program, vertex array, textures, a uniform buffer, blending,
    # culling, depth, a sub-viewport, its clear colour, pixel alignment...
    mgl.enable(mgl.BLEND | mgl.CULL_FACE | mgl.DEPTH_TEST | mgl.PROGRAM_POINT_SIZE)
    mgl.blend_func = mgl.SRC_ALPHA, mgl.ONE
    mgl.blend_equation = mgl.FUNC_REVERSE_SUBTRACT
    mgl.front_face = "cw"
    mgl.cull_face = "front"
    texture.use(3)
    texture.use(0)
    ubo.bind_to_uniform_block(0)
    lib.glUseProgram(program.glo)
    lib.glBindVertexArray(vao.glo)
    lib.glBindBuffer(0x8892, buffer.glo)              # GL_ARRAY_BUFFER
    lib.glActiveTexture(0x84C0 + 5)
    lib.glDepthFunc(0x0201)                           # GL_LESS
    lib.glDepthMask(0)
    lib.glViewport(10, 5, W - 20, H - 10)
    lib.glClearColor(ctypes.c_float(0.1), ctypes.c_float(0.2), ctypes.c_float(0.3),
                     ctypes.c_float(0.4))
    lib.glPixelStorei(0x0CF5, 2)                      # GL_UNPACK_ALIGNMENT
    lib.glPixelStorei(0x0D05, 8)                      # GL_PACK_ALIGNMENT
    before = _host_state(world)
    assert before["enabled 0xbe2"] == (True,) and before["program"] == (program.glo,)
    assert before["viewport"] == (10, 5, W - 20, H - 10)

    calls = _record_gl_calls(lambda: world.draw())
    after = _host_state(world)
    changed = {k: (before[k], after[k]) for k in before if before[k] != after[k]}
    assert not changed
    _assert_calls_covered(calls, before)
    assert world.camera.size_px == (W - 20, H - 10)      # the host's viewport
    lib.glViewport(0, 0, W, H)
    mgl.disable(mgl.BLEND | mgl.CULL_FACE | mgl.DEPTH_TEST | mgl.PROGRAM_POINT_SIZE)
    lib.glDepthMask(1)
    lib.glBindVertexArray(0)
    lib.glUseProgram(0)
    for obj in (vao, buffer, texture, ubo, program):
        obj.release()
    world.draw()
    assert world.camera.size_px == (W, H)


def test_drawing_from_another_thread_is_a_clear_error(pygame_host):
    world = pygame_host.world
    errors = []

    def draw():
        try:
            world.draw()
        except Exception as exc:  # noqa: BLE001 - what the thread saw
            errors.append(exc)

    thread = threading.Thread(target=draw, name="render-thread")
    thread.start()
    thread.join()
    assert len(errors) == 1 and isinstance(errors[0], rgl.ContextError)
    message = str(errors[0])
    assert "'MainThread'" in message and "'render-thread'" in message
    world.draw()                                        # still fine on its own thread


def test_draws_into_a_hosts_framebuffer_object_at_its_viewport(pygame_host):
    """draw(framebuffer=fbo): into the host's framebuffer object, not the bound one, over the
    host's viewport (an offset one here): inside it riverflow's frame, outside it the host's
    pixels."""
    h, world = pygame_host, pygame_host.world
    mgl = h.mgl
    colour, depth = mgl.texture((W, H), 4), mgl.depth_texture((W, H))
    fbo = mgl.framebuffer(color_attachments=[colour], depth_attachment=depth)
    fbo.use()
    mgl.clear(*HOST_CLEAR, 1.0, depth=1.0)
    mgl.screen.use()
    mgl.clear(0.0, 1.0, 0.0, 1.0, depth=1.0)              # the window: green
    x, y, w, hh = 10, 5, W - 20, H - 10
    mgl.viewport = (x, y, w, hh)
    world.draw(framebuffer=fbo.glo)
    mgl.viewport = (0, 0, W, H)
    drawn = np.frombuffer(fbo.read(components=4), np.uint8).reshape(H, W, 4)[::-1]
    window = np.frombuffer(mgl.screen.read(components=4), np.uint8).reshape(H, W, 4)
    assert (window[..., :3] == (0, 255, 0)).all()          # the bound framebuffer untouched
    own = world.render()
    assert own.shape == (hh, w, 4)
    inside = drawn[H - y - hh:H - y, x:x + w]
    same = (np.abs(inside[..., :3].astype(int) - own[..., :3].astype(int)) <= 2).all(-1)
    assert same.mean() > 0.99
    outside = np.ones((H, W), bool)
    outside[H - y - hh:H - y, x:x + w] = False
    assert (drawn[outside][:, :3] == HOST_CLEAR_U8).all()
    for obj in (fbo, colour, depth):
        obj.release()
    world.draw()                                           # back to the whole window


def test_render_to_texture_is_a_texture_of_the_hosts_context(pygame_host):
    """render_to_texture(): the frame as a GL texture name the host samples with its own GL
    (moderngl here), the same pixels as render(), the host's state left as it was."""
    h, world = pygame_host, pygame_host.world
    before = _host_state(world)
    name = world.render_to_texture()
    assert _host_state(world) == before
    texture = h.mgl.external_texture(name, (W, H), 4, 0, "f1")
    pixels = np.frombuffer(texture.read(), np.uint8).reshape(H, W, 4)[::-1]   # row 0: bottom
    np.testing.assert_array_equal(pixels, world.render())


def test_blit_from_another_context_is_a_clear_error(pygame_host):
    """The issue's black window: a gl=True world (riverflow's own offscreen context) copied
    onto "the window" while a pygame window is current would never reach it: an error that
    says to use gl="current"."""
    own_context = SimpleNamespace(egl_context=1)      # a pyglet context that is not current
    with pytest.raises(rgl.ContextError, match='gl="current"'):
        rgl.check_blit_target(own_context)


# -- every GL call the draw makes, and the state it changes ----------------------------------

_NO_CONTEXT_STATE = {
    # draws, reads, queries, object creation and deletion, and calls that change the state
    # of riverflow's own objects (its textures, buffers, vertex arrays, framebuffers) only
    "glGetError", "glGetIntegerv", "glGetFloatv", "glGetInteger64i_v", "glIsEnabled",
    "glGetString", "glGenTextures", "glGenBuffers", "glGenVertexArrays", "glGenFramebuffers",
    "glGenQueries", "glDeleteTextures", "glDeleteBuffers", "glDeleteVertexArrays",
    "glDeleteFramebuffers", "glDeleteQueries", "glTexImage2D", "glTexImage3D",
    "glTexSubImage2D", "glTexSubImage3D", "glTexParameteri", "glTexBuffer",
    "glGenerateMipmap", "glBufferData", "glBufferSubData", "glCopyBufferSubData",
    "glGetBufferSubData", "glFramebufferTexture2D", "glFramebufferTextureLayer",
    "glCheckFramebufferStatus", "glDrawBuffers", "glReadBuffer", "glVertexAttribPointer",
    "glEnableVertexAttribArray", "glDrawArrays", "glDrawElementsBaseVertex",
    "glMultiDrawElementsBaseVertex", "glClear", "glReadPixels", "glGetTexImage",
    "glBlitFramebuffer", "glFinish", "glFlush", "glBeginQuery", "glEndQuery",
    "glGetQueryObjectui64v",
}
"""(glDrawBuffers and glReadBuffer are only called with riverflow's framebuffers bound.)"""

_STATE_KEYS = {
    "glBindFramebuffer": ("draw_framebuffer", "read_framebuffer"),
    "glBindRenderbuffer": ("renderbuffer",),
    "glViewport": ("viewport",), "glUseProgram": ("program",),
    "glBindVertexArray": ("vertex_array",), "glActiveTexture": ("active_texture",),
    "glDepthFunc": ("depth_func",), "glDepthMask": ("depth_mask",),
    "glDepthRange": ("depth_range",), "glClearDepth": ("clear_depth",),
    "glClearColor": ("clear_colour",), "glColorMask": ("colour_mask",),
    "glBlendFuncSeparate": ("blend",), "glBlendEquation": ("blend",),
    "glBlendEquationSeparate": ("blend",), "glBlendColor": ("blend_colour",),
    "glCullFace": ("cull_face",), "glFrontFace": ("front_face",),
    "glPolygonMode": ("polygon_mode",), "glPointSize": ("point_size",),
    "glLineWidth": ("line_width",),
}


def _record_gl_calls(action) -> list[tuple[str, tuple]]:
    """Run ``action`` with every GL function riverflow's GL module calls recorded."""
    module = rgl.gl
    calls: list[tuple[str, tuple]] = []
    originals = {name: getattr(module, name) for name in dir(module)
                 if name.startswith("gl") and name[2:3].isupper()
                 and callable(getattr(module, name))}

    def recorder(name, function):
        def call(*args):
            calls.append((name, args))
            return function(*args)
        return call

    for name, function in originals.items():
        setattr(module, name, recorder(name, function))
    try:
        action()
    finally:
        for name, function in originals.items():
            setattr(module, name, function)
    return calls


def _assert_calls_covered(calls, saved: dict) -> None:
    """Each state-changing call is of a piece of state in ``saved`` (one the host state
    reads and puts back); a GL call this table does not know fails the test (classify it)."""
    unknown = set()
    for name, args in calls:
        if name in _NO_CONTEXT_STATE:
            continue
        if name in _STATE_KEYS:
            assert all(k in saved for k in _STATE_KEYS[name]), name
        elif name in ("glEnable", "glDisable"):
            assert f"enabled {int(args[0]):#x}" in saved, (name, hex(int(args[0])))
        elif name == "glPixelStorei":
            assert f"pixel_store {int(args[0]):#x}" in saved, (name, hex(int(args[0])))
        elif name == "glBindTexture":
            query = {int(t): int(q) for q, t in rgl._host_tables()[0]}[int(args[0])]
            assert f"texture 0 {query:#x}" in saved, name
        elif name == "glBindBuffer":
            queries = {int(t): int(q) for q, t in rgl._buffer_targets()}
            assert int(args[0]) in queries or int(args[0]) == 0x8893, name  # or an index
        elif name in ("glBindBufferRange", "glBindBufferBase"):    # buffer, in a VAO
            assert int(args[1]) < rgl.HostState.UBO_BINDINGS, (name, args[1])
        elif name == "glBindSampler":
            assert f"sampler {int(args[0])}" in saved, name
        else:
            unknown.add(name)
    assert not unknown, f"GL calls of the draw not classified by this test: {sorted(unknown)}"


def _run_demo(name: str, scene, check, *extra: str) -> None:
    """Play the demo for 2 frames in a W × H window with the module's scene; ``check`` sees
    the game (and the host's window) after the last frame is shown."""
    seen = []

    def on_last_frame(game, *host):
        check(game, *host)
        seen.append(True)

    module = _demo(name)
    assert module.main(["--frames", "2", "--size", f"{W}x{H}", *extra], scene=scene,
                       config=rf.RiverConfig(**CONFIG), on_last_frame=on_last_frame) == 0
    assert seen == [True]


def test_glfw_demo_window_shows_the_river(display, scene):
    pytest.importorskip("glfw")
    pytest.importorskip("moderngl")

    def check(game, x_window):
        shown = window_pixels(x_window)
        _assert_same_frame(shown, game.rivers.render(), game.rivers)
        orange = (shown[..., 0] > 150) & (shown[..., 1] < 140) & (shown[..., 2] < 90)
        assert orange.sum() > 4                       # the host's crate, in front

    _run_demo("glfw_host", scene, check)


def test_arcade_demo_window_shows_the_river(display, scene):
    """arcade 3 (on pyglet): its window's context is pyglet's own, which gl="current" draws
    with as it is (a pbuffer here: pyglet runs headless in the tests)."""
    os.environ.setdefault("ARCADE_HEADLESS", "1")
    pytest.importorskip("arcade")

    def check(game, window):
        assert game.rivers.context is rgl.gl.current_context     # pyglet's, no stand-in
        shown = read_pixels()
        hud = shown[-34:, :, :3].astype(int)
        own = game.rivers.render()
        river_there = own[-34:, :, :3].astype(int)
        shown[-34:] = own[-34:] = 0                   # the host's HUD, drawn on top
        _assert_same_frame(shown, own, game.rivers, rows=H - 34)
        assert hud.mean() < river_there.mean() - 5    # its dark band over the river

    _run_demo("arcade_host", scene, check, "--headless")


# -- no silent failure -----------------------------------------------------------------------

_OLD_CONTEXT = """
import os, sys
import glfw
assert glfw.init()
glfw.window_hint(glfw.VISIBLE, False)
glfw.window_hint(glfw.CONTEXT_VERSION_MAJOR, 2)
glfw.window_hint(glfw.CONTEXT_VERSION_MINOR, 1)
window = glfw.create_window(64, 64, "2.1", None, None)
glfw.make_context_current(window)
from riverflow.engine import gl
try:
    gl.acquire_host_context()
except gl.ContextError as exc:
    print(exc)
    sys.exit(3)
"""


def test_a_2_1_context_is_a_clear_error(display):
    """Mesa makes the 2.1 context asked for when its version is overridden (per process:
    a process of its own)."""
    pytest.importorskip("glfw")
    env = dict(os.environ, MESA_GL_VERSION_OVERRIDE="2.1", DISPLAY=display)
    env.pop("PYGLET_HEADLESS", None)
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(rgl.__file__).rsplit(
        "/riverflow/", 1)[0], env.get("PYTHONPATH")]))
    run = subprocess.run([sys.executable, "-c", _OLD_CONTEXT], env=env, capture_output=True,
                         text=True, timeout=60)
    assert run.returncode == 3, run.stderr[-2000:]
    assert "version '2.1" in run.stdout and "below the 3.3 core" in run.stdout
    assert "pygame.display.gl_set_attribute" in run.stdout      # says what to do


def test_panda3d_demo_shows_the_river_on_its_card(scene, tmp_path):
    """Panda3D owns its context (an EGL offscreen buffer here, as riverflow's): the river
    comes over as numpy, and the frame Panda3D writes shows it on the card."""
    pytest.importorskip("panda3d")
    out = tmp_path / "panda.png"

    def check(game, base, card):
        from PIL import Image

        river = game.rivers.render()
        shot = np.asarray(Image.open(out).convert("RGB")).astype(int)
        lens, (h, w) = base.cam.node().getLens(), shot.shape[:2]
        corners = []
        for corner in ((-8, 0, -4.5), (8, 0, 4.5)):
            from panda3d.core import Point2, Point3

            point = base.cam.getRelativePoint(card, Point3(*corner))
            screen = Point2()
            assert lens.project(point, screen)
            corners.append(((screen[0] + 1) * 0.5 * w, (1 - screen[1]) * 0.5 * h))
        (x0, y1), (x1, y0) = corners
        inner = shot[int(y0) + 3:int(y1) - 3, int(x0) + 3:int(x1) - 3]
        assert inner.shape[0] > 5 and inner.shape[1] > 10
        assert inner.std() > 10                          # an image, not a flat colour
        assert np.abs(inner.mean((0, 1)) - river[..., :3].mean((0, 1))).max() < 25
        background = shot[2, 2]
        assert np.abs(inner - background).sum(-1).min() > 30   # none of it is the sky

    _run_demo("panda3d_host", scene, check, "--headless", "--out", str(out))
