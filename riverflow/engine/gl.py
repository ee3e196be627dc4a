"""The OpenGL module: contexts, shader programs, textures, meshes, framebuffers, read-back.

Every OpenGL call of riverflow lives here or in :mod:`riverflow.systems.draw` (pyglet 2.1,
OpenGL 3.3 core; pyglet 3 moves most of these names, hence the pin ``<3``).

* **Context**: a world made with ``gl=True`` draws with the pyglet context current when it
  is made (a pyglet window), or else with one hidden offscreen context per process (EGL
  pbuffer when there is no display: ``PYGLET_HEADLESS=1`` is set for you before pyglet's GL is
  imported if ``DISPLAY`` and ``WAYLAND_DISPLAY`` are unset); drawing offscreen, it makes the
  context the thread had current before (a host's) current again after
  (:func:`keeping_native_current`).
* **A host's context** (``gl="current"``, issue 28): whatever OpenGL ≥ 3.3 context the thread
  has current, asked of the platform (:func:`native_current_context`: EGL, GLX, WGL, CGL),
  not of pyglet: pyglet's GL functions are the platform library's and go to any current
  context; a :class:`HostContext` stands in for pyglet's context object (pyglet's programs
  and deletions need one). If a host's context is current when this module is imported,
  pyglet's hidden shadow window is not made (it would take the thread's current context).
  :func:`host_frame` checks the context (:class:`ContextError`), saves the host's state
  (:class:`HostState`), sets a neutral one, and puts the host's back afterwards.
* **Programs**: one file per program in ``riverflow/shaders`` (package data), its stages
  between ``#ifdef VERTEX`` / ``#ifdef GEOMETRY`` / ``#ifdef FRAGMENT``; ``#include "x.glsl"``
  pastes a shared file; Python enums become ``#define``s (:func:`enum_defines`), so numbers never
  drift between Python, numba and GLSL. ``#line`` directives keep the driver's line numbers
  those of the file, and compile errors are re-raised as :class:`ShaderError` naming
  ``file.glsl:line``.
* **Textures** are raw GL objects uploaded from C-contiguous numpy arrays
  (``glTexSubImage2D`` straight from ``ndarray.ctypes.data``, reference/ecosystem.md §2.3);
  integer textures use the ``*_INTEGER`` formats and NEAREST filtering.
* **Framebuffer**: an RGBA8 colour texture and a depth texture; :meth:`Framebuffer.read_rgba8`
  returns (H, W, 4) uint8 with row 0 at the top.
* **Meshes**: :class:`Mesh` owns its buffers; many meshes share buffers in a
  :class:`SlotArena` (all of one size and index pattern: the terrain tiles) or a
  :class:`MeshArena` (any size: the water tiles), which draw any set of them with one
  ``glMultiDrawElementsBaseVertex`` (OpenGL 3.2 core).
* **Lifetimes**: every object remembers the context it was made in and ``delete()`` goes
  through that context (pyglet's deferred deletion): at once when it is current on the main
  thread, else when it is next made current (a world's finalizer may run anywhere, and never
  switches contexts under a host); nothing when the context is gone (its objects went with it).
"""
from __future__ import annotations

import contextlib
import ctypes
import os
import re
import sys
import threading
from dataclasses import dataclass
from enum import IntEnum
from importlib import resources

import numpy as np


def native_current_context() -> tuple[str, int] | None:
    """The OpenGL context current on this thread, whoever made it: ``(api, handle)`` with api
    ``"egl"``, ``"glx"``, ``"wgl"`` or ``"cgl"``, or None when none is. Asked of the platform's
    own library (not pyglet's idea of what is current: a host's window made with pygame, glfw
    or Qt is invisible to pyglet)."""
    for api, function in _current_context_functions():
        try:
            handle = function()
        except OSError:                   # a library that cannot answer on this platform
            continue
        if handle:
            return api, int(handle)
    return None


_CURRENT_FUNCTIONS: list = []


def _current_context_functions() -> list:
    """The platform's ``*GetCurrentContext`` functions (ctypes, loaded once)."""
    if _CURRENT_FUNCTIONS:
        return _CURRENT_FUNCTIONS
    import ctypes.util

    names = {"win32": [("wgl", "opengl32", "wglGetCurrentContext")],
             "darwin": [("cgl", "/System/Library/Frameworks/OpenGL.framework/OpenGL",
                         "CGLGetCurrentContext")]}.get(
        sys.platform, [("egl", "EGL", "eglGetCurrentContext"),
                       ("glx", "GL", "glXGetCurrentContext")])
    for api, library, symbol in names:
        path = library if "/" in library else (ctypes.util.find_library(library)
                                               or f"lib{library}.so.1")
        try:
            lib = ctypes.WinDLL(path) if sys.platform == "win32" else ctypes.CDLL(path)
            function = getattr(lib, symbol)
        except (OSError, AttributeError):
            continue
        function.restype = ctypes.c_void_p
        function.argtypes = []
        _CURRENT_FUNCTIONS.append((api, function))
    if not _CURRENT_FUNCTIONS:
        _CURRENT_FUNCTIONS.append(("none", lambda: None))
    return _CURRENT_FUNCTIONS


@contextlib.contextmanager
def keeping_native_current():
    """Whatever context the thread has current when the block starts (a host's: Panda3D's,
    pygame's) is current again when it ends, if riverflow's own offscreen context was made
    current in between (EGL and GLX; elsewhere nothing is done)."""
    saved = _native_binding()
    previous = gl.current_context
    try:
        yield
    finally:
        if saved is not None and native_current_context() != (saved[0], saved[4]):
            _rebind(saved)
            # pyglet's current context is the one made current again if pyglet made it
            gl.current_context = previous if _pyglet_native(previous) == (
                saved[0], saved[4]) else None


def _native_binding():
    """(api, display, draw surface, read surface, context) current on this thread, or None."""
    native = native_current_context()
    if native is None or native[0] not in ("egl", "glx"):
        return None
    lib = _native_library(native[0])
    if native[0] == "egl":
        return ("egl", lib.eglGetCurrentDisplay(), lib.eglGetCurrentSurface(0x3059),
                lib.eglGetCurrentSurface(0x305A), native[1])          # EGL_DRAW, EGL_READ
    return ("glx", lib.glXGetCurrentDisplay(), lib.glXGetCurrentDrawable(),
            lib.glXGetCurrentReadDrawable(), native[1])


def _rebind(saved) -> None:
    api, display, draw, read, context = saved
    lib = _native_library(api)
    if api == "egl":
        lib.eglMakeCurrent(display, draw, read, context)
    else:
        lib.glXMakeContextCurrent(display, draw, read, context)


_NATIVE_LIBRARIES: dict = {}


def _native_library(api: str):
    lib = _NATIVE_LIBRARIES.get(api)
    if lib is None:
        import ctypes.util

        name = "EGL" if api == "egl" else "GL"
        lib = ctypes.CDLL(ctypes.util.find_library(name) or f"lib{name}.so.1")
        pointer = ctypes.c_void_p
        if api == "egl":
            lib.eglGetCurrentDisplay.restype = pointer
            lib.eglGetCurrentSurface.restype = pointer
            lib.eglGetCurrentSurface.argtypes = [ctypes.c_int]
            lib.eglMakeCurrent.argtypes = [pointer] * 4
        else:
            lib.glXGetCurrentDisplay.restype = pointer
            lib.glXGetCurrentDrawable.restype = ctypes.c_ulong
            lib.glXGetCurrentReadDrawable.restype = ctypes.c_ulong
            lib.glXMakeContextCurrent.argtypes = [pointer, ctypes.c_ulong, ctypes.c_ulong,
                                                  pointer]
        _NATIVE_LIBRARIES[api] = lib
    return lib


if "pyglet.gl" not in sys.modules:
    if native_current_context() is not None:
        # a host made its own context current before riverflow's GL was imported (pygame,
        # glfw, Qt): pyglet must not make its hidden "shadow window" and switch to it, which
        # takes the thread's current context from the host (its window would stay black)
        import pyglet

        pyglet.options["shadow_window"] = False
    elif not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
        os.environ.setdefault("PYGLET_HEADLESS", "1")

import pyglet  # noqa: E402

if os.environ.get("PYGLET_HEADLESS", "").lower() in ("1", "true", "yes"):
    pyglet.options["headless"] = True

import pyglet.gl  # noqa: E402

gl = sys.modules["pyglet.gl"]   # the module itself: ``pyglet.gl`` may be pyglet's lazy proxy,
#                                 which costs a Python call for every GL name looked up
from pyglet.graphics import shader as _pyglet_shader  # noqa: E402
from pyglet.graphics.shader import Shader, ShaderException, ShaderProgram  # noqa: E402

# pyglet 2.1 has no setter for the buffer texture samplers (GL_TEXTURE_BUFFER, core since
# OpenGL 3.1; its ShaderProgram fails on a program that has one): a texture unit, like a 2-D
# sampler's
for _kind in (gl.GL_SAMPLER_BUFFER, gl.GL_INT_SAMPLER_BUFFER,
              gl.GL_UNSIGNED_INT_SAMPLER_BUFFER):
    _pyglet_shader._uniform_setters.setdefault(
        _kind, _pyglet_shader._uniform_setters[gl.GL_SAMPLER_2D])

GLSL_VERSION = "#version 330 core"
STAGES = {"VERTEX": "vertex", "GEOMETRY": "geometry", "FRAGMENT": "fragment"}


class GLError(RuntimeError):
    """An OpenGL error flag was raised (the message names the error and where it was checked)."""


class ShaderError(RuntimeError):
    """A shader program failed to compile or link; the message names ``file.glsl:line``."""


_ERRORS = {gl.GL_INVALID_ENUM: "GL_INVALID_ENUM", gl.GL_INVALID_VALUE: "GL_INVALID_VALUE",
           gl.GL_INVALID_OPERATION: "GL_INVALID_OPERATION",
           gl.GL_INVALID_FRAMEBUFFER_OPERATION: "GL_INVALID_FRAMEBUFFER_OPERATION",
           gl.GL_OUT_OF_MEMORY: "GL_OUT_OF_MEMORY"}


def _take_errors() -> list[str]:
    """The error flags OpenGL has raised since they were last read (clearing them)."""
    found = []
    for _ in range(16):
        code = gl.glGetError()
        if code == gl.GL_NO_ERROR:
            break
        found.append(_ERRORS.get(code, hex(code)))
    return found


def check_errors(where: str) -> None:
    """Raise :class:`GLError` if OpenGL has raised error flags since the last check."""
    found = _take_errors()
    if found:
        raise GLError(f"OpenGL error(s) {', '.join(found)} at {where}")


# -- contexts --------------------------------------------------------------------------------

_offscreen_window = None


def acquire_context():
    """The context to draw with: the current one (a host's window) or the process's hidden
    offscreen one, created on first use. Returns a pyglet ``Context``."""
    global _offscreen_window
    current = gl.current_context
    if current is not None and context_alive(current):
        if not isinstance(current, HostContext) \
                and native_current_context() != _pyglet_native(current):
            current.set_current()        # pyglet's idea only: another library's since
        return current
    if _offscreen_window is None:
        config = gl.Config(major_version=3, minor_version=3, forward_compatible=True,
                           double_buffer=False, depth_size=24)
        try:
            _offscreen_window = pyglet.window.Window(width=16, height=16, visible=False,
                                                     config=config)
        except Exception as exc:  # no EGL / no display: say what would help
            raise GLError("no OpenGL context could be created (set PYGLET_HEADLESS=1 for EGL "
                          f"offscreen drawing, or run under a display): {exc}") from exc
    _offscreen_window.switch_to()
    return gl.current_context


def context_alive(context) -> bool:
    """``context`` is still attached to its window or pbuffer (not destroyed)."""
    return context is not None and getattr(context, "canvas", None) is not None


def _discard(context, kind: str, ident: int) -> None:
    """Delete GL object ``ident`` (``kind``: texture, buffer, vao, framebuffer) of ``context``
    now if that is safe, else when the context is next current; nothing if it is gone."""
    if not ident or not context_alive(context):
        return
    try:
        getattr(context, f"delete_{kind}")(ident)
    except (AttributeError, ImportError, TypeError):  # no context current; interpreter exit
        pass


def make_current(context) -> None:
    """Make ``context`` current if it is not: pyglet's idea of the current context, and the
    thread's own (another library's window, Panda3D's, may have made its context current
    since; pyglet would not know)."""
    if gl.current_context is not context:
        context.set_current()
    elif not isinstance(context, HostContext) \
            and native_current_context() != _pyglet_native(context):
        context.set_current()


def renderer_name() -> str:
    """The GL renderer string (e.g. ``llvmpipe (LLVM 15.0.6, 256 bits)``)."""
    return gl.gl_info.get_renderer()


# -- a host's own context (``RiverWorld(..., gl="current")``) -------------------------------

class ContextError(GLError):
    """No usable OpenGL context to draw a host's frame with: none current on this thread,
    one below OpenGL 3.3, or another one than the world was made with (another thread's)."""


_HOW_TO_ASK = ("ask your window for OpenGL 3.3 core, e.g. pygame: "
               "pygame.display.gl_set_attribute(pygame.GL_CONTEXT_MAJOR_VERSION, 3), "
               "(…MINOR_VERSION, 3), (…PROFILE_MASK, pygame.GL_CONTEXT_PROFILE_CORE) before "
               "set_mode(size, pygame.OPENGL | pygame.DOUBLEBUF); glfw: "
               "glfw.window_hint(glfw.CONTEXT_VERSION_MAJOR, 3), (…MINOR, 3), "
               "(glfw.OPENGL_PROFILE, glfw.OPENGL_CORE_PROFILE) before create_window")


class _HostCanvas:
    """What a :class:`HostContext` is attached to: the host's window, which pyglet never
    sees (pyglet only asks that a context has a canvas)."""


class HostContext(pyglet.gl.base.Context):
    """pyglet's stand-in for an OpenGL context pyglet did not make (a pygame, glfw, SDL or Qt
    window's): riverflow's GL objects remember it and are deleted through it, and while a
    world draws with it, it is pyglet's ``current_context`` (pyglet's GL functions are the
    platform library's, so they go to whatever context the thread has current). It never
    makes itself current: the host does; :func:`host_frame` checks that it has."""

    def __init__(self, native: tuple[str, int]) -> None:
        super().__init__(None)
        self.canvas = _HostCanvas()
        self.native = native
        self.thread = threading.get_ident()
        self.thread_name = threading.current_thread().name

    def set_current(self) -> None:
        """pyglet's bookkeeping only (pyglet's current context, deletions queued while it was
        not current); the native context is the host's to make current."""
        super().set_current()


def _pyglet_native(context) -> tuple[str, int] | None:
    """The native handle of a context pyglet made (EGL, GLX, WGL, CGL), if it tells."""
    if isinstance(context, HostContext):
        return context.native
    for api, attribute in (("egl", "egl_context"), ("glx", "glx_context"),
                           ("wgl", "_context"), ("cgl", "_nscontext")):
        handle = getattr(context, attribute, None)
        if handle is None:
            continue
        value = ctypes.cast(handle, ctypes.c_void_p).value if not isinstance(handle, int) \
            else handle
        return (api, int(value)) if value else None
    return None


def acquire_host_context():
    """The context a host made current on this thread, to draw a world with
    (``gl="current"``): pyglet's own when the host is a pyglet window (arcade), else a
    :class:`HostContext`. Raises :class:`ContextError` when no context is current or it is
    below OpenGL 3.3."""
    native = native_current_context()
    if native is None:
        raise ContextError(
            "RiverWorld(gl=\"current\"): no OpenGL context is current on this thread "
            f"({threading.current_thread().name}). Make the world after your window exists and "
            "its context is current (pygame: set_mode(..., pygame.OPENGL); glfw: "
            "make_context_current(window)), or use gl=True for riverflow's own offscreen "
            "context.")
    current = gl.current_context
    if current is not None and _pyglet_native(current) == native:
        context = current                 # a pyglet window (arcade): pyglet's own context
    else:
        context = HostContext(native)
    with _as_pyglet_current(context):
        check_version()
    return context


def check_version() -> tuple[int, int]:
    """The current context's OpenGL version; :class:`ContextError` below 3.3 or for OpenGL
    ES (a compatibility profile of 3.3 or later is accepted: riverflow uses core calls only)."""
    raw = gl.glGetString(gl.GL_VERSION)
    text = ctypes.cast(raw, ctypes.c_char_p).value.decode("ascii", "replace") if raw else ""
    match = re.match(r"\s*(OpenGL ES[^0-9]*)?(\d+)\.(\d+)", text)
    if match is None or match.group(1):
        raise ContextError(f"the current OpenGL context is {text or 'unknown'!r}: riverflow "
                           f"draws with desktop OpenGL 3.3 or later; {_HOW_TO_ASK}")
    version = (int(match.group(2)), int(match.group(3)))
    if version < (3, 3):
        raise ContextError(f"the current OpenGL context is version {text!r}, below the 3.3 "
                           f"core riverflow draws with; {_HOW_TO_ASK}")
    return version


@contextlib.contextmanager
def _as_pyglet_current(context):
    """``context`` as pyglet's current context for the block, then pyglet's previous one
    (for a :class:`HostContext`; a pyglet context is made current as usual)."""
    previous = gl.current_context
    if previous is context:
        yield
        return
    if not isinstance(context, HostContext):
        context.set_current()
        yield
        return
    context.set_current()
    try:
        yield
    finally:
        gl.current_context = previous


def check_blit_target(context) -> None:
    """:class:`ContextError` when the window current now is not the world's (``gl=True``):
    a copy onto framebuffer 0 of the world's own context would land in riverflow's hidden
    window, never on the host's screen (a pygame or glfw window: the silent black window of
    issue 28)."""
    native = native_current_context()
    if native is not None and native != _pyglet_native(context):
        raise ContextError(
            "blit_to_window(): the window current now is not the one this world draws with "
            "(gl=True made riverflow's own offscreen context: no pyglet window was current "
            "when the world was made), so the copy would never reach your window. For a "
            "pygame, glfw, Qt or SDL window make the world with gl=\"current\" and call "
            "draw(view, projection): it draws straight into your window.")
    make_current(context)


@contextlib.contextmanager
def deleting_with(context):
    """For the block, ``context`` is pyglet's current one if it is a :class:`HostContext`
    current on this thread now, so that GL objects made in it are deleted at once (a world
    closed while its host's context is current); else nothing changes (pyglet's contexts
    delete through themselves; a host context not current leaves its objects to the host's
    context, which takes them when it is destroyed)."""
    if isinstance(context, HostContext) and native_current_context() == context.native:
        with _as_pyglet_current(context):
            _take_errors()              # the host's (pyglet would blame its first call)
            yield
    else:
        yield


def check_host_current(context) -> None:
    """Raise :class:`ContextError` unless ``context`` (a world's, ``gl="current"``) is the
    context current on this thread now."""
    native = native_current_context()
    want = _pyglet_native(context)
    if native is not None and native == want:
        return
    owner = getattr(context, "thread", None)
    here = threading.get_ident()
    if owner is not None and owner != here:
        raise ContextError(
            f"this world draws with the OpenGL context of thread "
            f"{getattr(context, 'thread_name', owner)!r}, and draw() was called on thread "
            f"{threading.current_thread().name!r}, where "
            f"{'no context is' if native is None else 'another context is'} current: an "
            "OpenGL context is current on one thread at a time. Draw from the thread that "
            "owns your window (or make its context current on this one first).")
    if native is None:
        raise ContextError("draw(): no OpenGL context is current on this thread; make your "
                           "window's context current first (the world was made with "
                           "gl=\"current\" and draws with it)")
    raise ContextError("draw(): the OpenGL context current now is not the one this world was "
                       "made with (gl=\"current\"): its GL objects (vertex arrays, "
                       "framebuffers) live in that one; make it current before draw(), or "
                       "make one world per context")


@contextlib.contextmanager
def host_frame(context):
    """Draw a frame with a host's context: checks it is current here (:class:`ContextError`),
    makes it pyglet's current context for the block, saves every piece of GL state riverflow's
    drawing touches, sets the neutral state riverflow draws from (:data:`HOST_NEUTRAL`), and
    puts the host's state back afterwards, errors or not. Yields the host's
    :class:`HostState` (its framebuffer and viewport)."""
    check_host_current(context)
    with _as_pyglet_current(context):
        # pyglet checks glGetError after each of its calls: an error the host left pending
        # would be blamed on riverflow's first call. They are taken (and kept in the saved
        # state's ``host_errors``); riverflow's own are raised as they happen.
        pending = _take_errors()
        saved = HostState.save()
        saved.host_errors = pending
        try:
            saved.neutral()
            forget_state()
            yield saved
        finally:
            saved.restore()
            forget_state()


_TEXTURE_TARGETS = None
"""(binding query, target) of the texture targets riverflow binds (set on first use)."""

_ENABLES = None
"""The capabilities riverflow enables or that would change its drawing if a host left them
on, with riverflow's setting for each (set on first use)."""


def _host_tables():
    global _TEXTURE_TARGETS, _ENABLES
    if _TEXTURE_TARGETS is None:
        _TEXTURE_TARGETS = ((gl.GL_TEXTURE_BINDING_2D, gl.GL_TEXTURE_2D),
                            (gl.GL_TEXTURE_BINDING_2D_ARRAY, gl.GL_TEXTURE_2D_ARRAY),
                            (gl.GL_TEXTURE_BINDING_BUFFER, gl.GL_TEXTURE_BUFFER))
        _ENABLES = ((gl.GL_DEPTH_TEST, False), (gl.GL_BLEND, False),
                    (gl.GL_CULL_FACE, False), (gl.GL_CLIP_DISTANCE0, False),
                    (gl.GL_PROGRAM_POINT_SIZE, False), (gl.GL_SCISSOR_TEST, False),
                    (gl.GL_STENCIL_TEST, False), (gl.GL_FRAMEBUFFER_SRGB, False),
                    (gl.GL_POLYGON_OFFSET_FILL, False), (gl.GL_RASTERIZER_DISCARD, False),
                    (gl.GL_SAMPLE_ALPHA_TO_COVERAGE, False), (gl.GL_COLOR_LOGIC_OP, False),
                    (gl.GL_PRIMITIVE_RESTART, False))
    return _TEXTURE_TARGETS, _ENABLES


TEXTURE_UNITS = 16
"""Texture units riverflow draws with (0-15: the scratch unit is the last)."""

_BUFFER_TARGETS = None


def _buffer_targets():
    global _BUFFER_TARGETS
    if _BUFFER_TARGETS is None:
        _BUFFER_TARGETS = ((gl.GL_ARRAY_BUFFER_BINDING, gl.GL_ARRAY_BUFFER),
                           (gl.GL_UNIFORM_BUFFER_BINDING, gl.GL_UNIFORM_BUFFER),
                           (gl.GL_TEXTURE_BUFFER, gl.GL_TEXTURE_BUFFER),
                           (gl.GL_COPY_READ_BUFFER, gl.GL_COPY_READ_BUFFER),
                           (gl.GL_COPY_WRITE_BUFFER, gl.GL_COPY_WRITE_BUFFER),
                           (gl.GL_PIXEL_PACK_BUFFER_BINDING, gl.GL_PIXEL_PACK_BUFFER),
                           (gl.GL_PIXEL_UNPACK_BUFFER_BINDING, gl.GL_PIXEL_UNPACK_BUFFER))
    return _BUFFER_TARGETS


_PIXEL_STORE = None


def _pixel_store():
    global _PIXEL_STORE
    if _PIXEL_STORE is None:
        _PIXEL_STORE = tuple((name, default) for name, default in (
            (gl.GL_PACK_ALIGNMENT, 4), (gl.GL_UNPACK_ALIGNMENT, 4),
            (gl.GL_PACK_ROW_LENGTH, 0), (gl.GL_UNPACK_ROW_LENGTH, 0),
            (gl.GL_PACK_SKIP_ROWS, 0), (gl.GL_UNPACK_SKIP_ROWS, 0),
            (gl.GL_PACK_SKIP_PIXELS, 0), (gl.GL_UNPACK_SKIP_PIXELS, 0),
            (gl.GL_PACK_IMAGE_HEIGHT, 0), (gl.GL_UNPACK_IMAGE_HEIGHT, 0),
            (gl.GL_PACK_SKIP_IMAGES, 0), (gl.GL_UNPACK_SKIP_IMAGES, 0),
            (gl.GL_PACK_SWAP_BYTES, 0), (gl.GL_UNPACK_SWAP_BYTES, 0),
            (gl.GL_PACK_LSB_FIRST, 0), (gl.GL_UNPACK_LSB_FIRST, 0)))
    return _PIXEL_STORE


def _get_ints(pname: int, n: int = 1) -> tuple[int, ...]:
    out = (gl.GLint * max(n, 4))()
    gl.glGetIntegerv(pname, out)
    return tuple(out[:n])


def _get_floats(pname: int, n: int = 1) -> tuple[float, ...]:
    out = (gl.GLfloat * max(n, 4))()
    gl.glGetFloatv(pname, out)
    return tuple(out[:n])


class HostState:
    """The host's GL state that riverflow's drawing touches, read with ``glGet*``
    (:meth:`save`), put back (:meth:`restore`). ``framebuffer`` and ``viewport`` are where
    the host draws: riverflow composites its frame there (:meth:`as_dict` lists everything,
    for tests)."""

    UBO_BINDINGS = 8
    """Indexed uniform buffer binding points saved (riverflow's programs share one, the
    first free one pyglet hands out in the context: 0 in a host's own context, a low one
    after a pyglet host's own blocks)."""

    def __init__(self) -> None:
        self.values: dict[str, object] = {}
        self.host_errors: list[str] = []
        """GL errors the host had left pending when riverflow's draw began (taken then)."""

    @property
    def framebuffer(self) -> int:
        return int(self.values["draw_framebuffer"][0])

    @property
    def viewport(self) -> tuple[int, int, int, int]:
        return tuple(int(v) for v in self.values["viewport"])

    @classmethod
    def save(cls) -> HostState:
        textures, enables = _host_tables()
        state = cls()
        v = state.values
        v["draw_framebuffer"] = _get_ints(gl.GL_DRAW_FRAMEBUFFER_BINDING)
        v["read_framebuffer"] = _get_ints(gl.GL_READ_FRAMEBUFFER_BINDING)
        v["renderbuffer"] = _get_ints(gl.GL_RENDERBUFFER_BINDING)
        v["viewport"] = _get_ints(gl.GL_VIEWPORT, 4)
        v["program"] = _get_ints(gl.GL_CURRENT_PROGRAM)
        v["vertex_array"] = _get_ints(gl.GL_VERTEX_ARRAY_BINDING)
        for query, _ in _buffer_targets():
            v[f"buffer {query:#x}"] = _get_ints(query)
        for i in range(cls.UBO_BINDINGS):
            for query in (gl.GL_UNIFORM_BUFFER_BINDING, gl.GL_UNIFORM_BUFFER_START,
                          gl.GL_UNIFORM_BUFFER_SIZE):
                out = gl.GLint64()
                gl.glGetInteger64i_v(query, i, ctypes.byref(out))
                v[f"ubo {i} {query:#x}"] = (out.value,)
        v["active_texture"] = _get_ints(gl.GL_ACTIVE_TEXTURE)
        for unit in range(TEXTURE_UNITS):
            gl.glActiveTexture(gl.GL_TEXTURE0 + unit)
            for query, _ in textures:
                v[f"texture {unit} {query:#x}"] = _get_ints(query)
            v[f"sampler {unit}"] = _get_ints(gl.GL_SAMPLER_BINDING)
        gl.glActiveTexture(v["active_texture"][0])
        for cap, _ in enables:
            v[f"enabled {cap:#x}"] = (bool(gl.glIsEnabled(cap)),)
        v["depth_func"] = _get_ints(gl.GL_DEPTH_FUNC)
        v["depth_mask"] = _get_ints(gl.GL_DEPTH_WRITEMASK)
        v["depth_range"] = _get_floats(gl.GL_DEPTH_RANGE, 2)
        v["clear_depth"] = _get_floats(gl.GL_DEPTH_CLEAR_VALUE)
        v["clear_colour"] = _get_floats(gl.GL_COLOR_CLEAR_VALUE, 4)
        v["colour_mask"] = _get_ints(gl.GL_COLOR_WRITEMASK, 4)
        v["blend"] = (*_get_ints(gl.GL_BLEND_SRC_RGB), *_get_ints(gl.GL_BLEND_DST_RGB),
                      *_get_ints(gl.GL_BLEND_SRC_ALPHA), *_get_ints(gl.GL_BLEND_DST_ALPHA),
                      *_get_ints(gl.GL_BLEND_EQUATION_RGB),
                      *_get_ints(gl.GL_BLEND_EQUATION_ALPHA))
        v["blend_colour"] = _get_floats(gl.GL_BLEND_COLOR, 4)
        v["cull_face"] = _get_ints(gl.GL_CULL_FACE_MODE)
        v["front_face"] = _get_ints(gl.GL_FRONT_FACE)
        v["polygon_mode"] = _get_ints(gl.GL_POLYGON_MODE, 2)
        v["point_size"] = _get_floats(gl.GL_POINT_SIZE)
        v["line_width"] = _get_floats(gl.GL_LINE_WIDTH)
        for name, _ in _pixel_store():
            v[f"pixel_store {name:#x}"] = _get_ints(name)
        return state

    def as_dict(self) -> dict[str, object]:
        return dict(self.values)

    def neutral(self) -> None:
        """The state riverflow's drawing starts from (OpenGL's defaults where it matters):
        no host buffer, vertex array, sampler or pixel buffer in the way, nothing enabled
        that would change what it draws, full colour writes, depth range [0, 1]."""
        _, enables = _host_tables()
        gl.glBindVertexArray(0)
        for _, target in _buffer_targets():
            gl.glBindBuffer(target, 0)
        for unit in range(TEXTURE_UNITS):
            if self.values[f"sampler {unit}"][0]:
                gl.glBindSampler(unit, 0)
        for cap, on in enables:
            if self.values[f"enabled {cap:#x}"][0] != on:
                (gl.glEnable if on else gl.glDisable)(cap)
        gl.glColorMask(True, True, True, True)
        gl.glDepthRange(0.0, 1.0)
        gl.glClearDepth(1.0)
        gl.glPolygonMode(gl.GL_FRONT_AND_BACK, gl.GL_FILL)
        for name, default in _pixel_store():
            if self.values[f"pixel_store {name:#x}"][0] != default:
                gl.glPixelStorei(name, default)

    def restore(self) -> None:
        """Put every saved piece of state back."""
        textures, enables = _host_tables()
        v = self.values
        gl.glBindFramebuffer(gl.GL_DRAW_FRAMEBUFFER, v["draw_framebuffer"][0])
        gl.glBindFramebuffer(gl.GL_READ_FRAMEBUFFER, v["read_framebuffer"][0])
        gl.glBindRenderbuffer(gl.GL_RENDERBUFFER, v["renderbuffer"][0])
        gl.glViewport(*v["viewport"])
        gl.glUseProgram(v["program"][0])
        gl.glBindVertexArray(v["vertex_array"][0])
        for i in range(self.UBO_BINDINGS):
            ident = v[f"ubo {i} {gl.GL_UNIFORM_BUFFER_BINDING:#x}"][0]
            start = v[f"ubo {i} {gl.GL_UNIFORM_BUFFER_START:#x}"][0]
            size = v[f"ubo {i} {gl.GL_UNIFORM_BUFFER_SIZE:#x}"][0]
            if ident and size:
                gl.glBindBufferRange(gl.GL_UNIFORM_BUFFER, i, ident, start, size)
            else:
                gl.glBindBufferBase(gl.GL_UNIFORM_BUFFER, i, ident)
        for query, target in _buffer_targets():       # after the indexed ones (they set
            gl.glBindBuffer(target, v[f"buffer {query:#x}"][0])   # the generic binding too)
        for unit in range(TEXTURE_UNITS):
            gl.glActiveTexture(gl.GL_TEXTURE0 + unit)
            for query, target in textures:
                gl.glBindTexture(target, v[f"texture {unit} {query:#x}"][0])
            gl.glBindSampler(unit, v[f"sampler {unit}"][0])
        gl.glActiveTexture(v["active_texture"][0])
        for cap, _ in enables:
            (gl.glEnable if v[f"enabled {cap:#x}"][0] else gl.glDisable)(cap)
        gl.glDepthFunc(v["depth_func"][0])
        gl.glDepthMask(v["depth_mask"][0])
        gl.glDepthRange(*v["depth_range"])
        gl.glClearDepth(v["clear_depth"][0])
        gl.glClearColor(*v["clear_colour"])
        gl.glColorMask(*v["colour_mask"])
        b = v["blend"]
        gl.glBlendFuncSeparate(b[0], b[1], b[2], b[3])
        gl.glBlendEquationSeparate(b[4], b[5])
        gl.glBlendColor(*v["blend_colour"])
        gl.glCullFace(v["cull_face"][0])
        gl.glFrontFace(v["front_face"][0])
        gl.glPolygonMode(gl.GL_FRONT_AND_BACK, v["polygon_mode"][0])
        gl.glPointSize(v["point_size"][0])
        gl.glLineWidth(v["line_width"][0])
        for name, _ in _pixel_store():
            gl.glPixelStorei(name, v[f"pixel_store {name:#x}"][0])


# -- programs --------------------------------------------------------------------------------

def enum_defines(*enums: type[IntEnum], prefix: str = "") -> dict[str, int]:
    """``#define`` names for enum members: ``FlowStatus.INSIDE`` → ``FLOW_STATUS_INSIDE``."""
    out = {}
    for enum in enums:
        stem = re.sub(r"(?<!^)(?=[A-Z])", "_", enum.__name__).upper()
        for member in enum:
            out[f"{prefix}{stem}_{member.name}"] = int(member)
    return out


def _read_shader(name: str, directory: str | os.PathLike | None = None) -> str:
    """A shader file's text: from ``directory`` if it has the file, else the package's."""
    if directory is not None:
        path = os.path.join(directory, name)
        if os.path.exists(path):
            with open(path) as f:
                return f.read()
    try:
        return resources.files("riverflow.shaders").joinpath(name).read_text()
    except FileNotFoundError:
        raise ShaderError(f"no shader file riverflow/shaders/{name}") from None


_INCLUDE = re.compile(r'^\s*#include\s+"([^"]+)"\s*$')


def _expand(name: str, files: list[str], directory=None) -> str:
    """The file's text with includes pasted, framed by ``#line L S`` (S indexes ``files``)."""
    if name in files:
        raise ShaderError(f"{name} includes itself (via {' → '.join(files)})")
    index = len(files)
    files.append(name)
    out = [f"#line 1 {index}"]
    for number, line in enumerate(_read_shader(name, directory).splitlines(), start=1):
        match = _INCLUDE.match(line)
        if match:
            out.append(_expand(match.group(1), files, directory))
            out.append(f"#line {number + 1} {index}")
        else:
            out.append(line)
    return "\n".join(out)


def shader_sources(name: str, defines: dict[str, object] | None = None,
                   directory: str | os.PathLike | None = None
                   ) -> dict[str, tuple[str, list[str]]]:
    """Sources per stage of program file ``name`` (e.g. ``"water.glsl"``, from ``directory``
    or the package): {stage: (source, file names by #line source index)}."""
    files: list[str] = []
    body = _expand(name, files, directory)
    head = [GLSL_VERSION] + [f"#define {k} {v}" for k, v in (defines or {}).items()]
    text = _read_shader(name, directory)
    out = {}
    for macro, stage in STAGES.items():
        if re.search(rf"^\s*#if(def\s+|\s+defined\s*\(\s*){macro}\b", text, re.M):
            out[stage] = ("\n".join(head + [f"#define {macro} 1", body]) + "\n", files)
    if "vertex" not in out or "fragment" not in out:
        raise ShaderError(f"{name}: a program file needs #ifdef VERTEX and #ifdef FRAGMENT parts")
    return out


_LOG_LINE = re.compile(r"\b(\d+):(\d+)(\(\d+\))?")


def _name_lines(log: str, files: list[str]) -> str:
    """Rewrite the driver's ``S:L`` locations as ``file.glsl:L``."""
    def sub(match: re.Match) -> str:
        s = int(match.group(1))
        return f"{files[s] if s < len(files) else s}:{match.group(2)}{match.group(3) or ''}"
    return _LOG_LINE.sub(sub, log)


_NEVER = object()

VIEW_BLOCK = "View"
"""The uniform block every program shares (``shaders/common.glsl``), filled from a
:class:`UniformBuffer`."""


def _same_key(value):
    """What tells a uniform value from another: arrays by their bytes, a zero float (or a
    tuple holding one) by its text, so that −0.0 is not taken for 0.0."""
    if isinstance(value, np.ndarray):
        return value.dtype.str, value.shape, value.tobytes()
    if isinstance(value, (float, np.floating)):
        return value if value else repr(value)
    if isinstance(value, tuple) and 0.0 in value:
        return repr(value)
    return value


class Program:
    """A linked shader program (pyglet ``ShaderProgram``) with strict uniform setting."""

    def __init__(self, name: str, defines: dict[str, object] | None = None,
                 directory: str | os.PathLike | None = None) -> None:
        self.name = name
        shaders = []
        for stage, (source, files) in shader_sources(name, defines, directory).items():
            try:
                shaders.append(Shader(source, stage))
            except ShaderException as exc:
                raise ShaderError(f"{name} ({stage} stage) failed to compile:\n"
                                  f"{_name_lines(str(exc), files)}") from None
        try:
            self.program = ShaderProgram(*shaders)
        except ShaderException as exc:
            raise ShaderError(f"{name} failed to link:\n{exc}") from None
        self.uniforms = frozenset(self.program.uniforms)
        block = getattr(self.program, "uniform_blocks", {}).get(VIEW_BLOCK)
        self.view_binding = None if block is None else int(block.binding)
        """The binding point of the program's view block (None: it uses none). pyglet gives a
        block name the same binding point in every program of a context."""
        self._sent: dict[str, object] = {}       # uniform → what was last sent (_same_key)
        # pyglet's setter of each uniform: what ``program[name] = value`` calls, without its
        # lookups (pyglet 2.1 keeps its uniform objects in ``_uniforms``)
        objects = getattr(self.program, "_uniforms", None) or {}
        self._setters = {name: (objects[name].set if hasattr(objects.get(name), "set")
                                else self._item_setter(name)) for name in self.uniforms}

    def _item_setter(self, name: str):
        def setter(value) -> None:
            self.program[name] = value
        return setter

    def use(self) -> None:
        self.program.use()

    def set(self, **values) -> None:
        """Set uniforms by name; an unknown name raises :class:`ShaderError` (a typo, or a
        uniform the compiler dropped because it does not change the output). A value equal
        to the one last set (bit for bit) is not sent again: a program keeps its uniforms,
        and every uniform of riverflow's programs is set through here."""
        self._send(values, True)

    def set_if_used(self, **values) -> None:
        """Set the uniforms of ``values`` that this program uses; skip the others (shared
        uniforms of an included file that a program does not need)."""
        self._send(values, False)

    def _send(self, values: dict, strict: bool) -> None:
        setters, sent = self._setters, self._sent
        for key, value in values.items():
            setter = setters.get(key)
            if setter is None:
                if strict:
                    raise ShaderError(f"{self.name} has no active uniform {key!r}")
                continue
            kind = type(value)
            if kind is int or kind is bool:
                same = value
            elif kind is tuple:
                same = value if 0.0 not in value else repr(value)
            elif kind is float:
                same = value if value else repr(value)       # -0.0 is not 0.0
            else:
                same = _same_key(value)
            if sent.get(key, _NEVER) == same:
                continue
            try:
                setter(value.ravel().tolist() if isinstance(value, np.ndarray) else value)
            except gl.GLException as exc:
                raise ShaderException(exc) from exc
            sent[key] = same

    def delete(self) -> None:
        """Let the program go: pyglet deletes it through the context it was made in (at once
        when that context's objects are current on the main thread, else later)."""
        self.program = None


# -- textures --------------------------------------------------------------------------------

@dataclass(frozen=True)
class TexFormat:
    """Internal format, upload format and element type of a texture, and its numpy dtype and
    channel count."""

    internal: int
    upload: int
    gl_type: int
    dtype: type
    channels: int
    integer: bool = False


RGBA8 = TexFormat(gl.GL_RGBA8, gl.GL_RGBA, gl.GL_UNSIGNED_BYTE, np.uint8, 4)
RGBA32F = TexFormat(gl.GL_RGBA32F, gl.GL_RGBA, gl.GL_FLOAT, np.float32, 4)
RGBA16F = TexFormat(gl.GL_RGBA16F, gl.GL_RGBA, gl.GL_FLOAT, np.float32, 4)
RGB32F = TexFormat(gl.GL_RGB32F, gl.GL_RGB, gl.GL_FLOAT, np.float32, 3)
RG32F = TexFormat(gl.GL_RG32F, gl.GL_RG, gl.GL_FLOAT, np.float32, 2)
R32F = TexFormat(gl.GL_R32F, gl.GL_RED, gl.GL_FLOAT, np.float32, 1)
RGBA32I = TexFormat(gl.GL_RGBA32I, gl.GL_RGBA_INTEGER, gl.GL_INT, np.int32, 4, integer=True)
R32I = TexFormat(gl.GL_R32I, gl.GL_RED_INTEGER, gl.GL_INT, np.int32, 1, integer=True)
DEPTH24 = TexFormat(gl.GL_DEPTH_COMPONENT24, gl.GL_DEPTH_COMPONENT, gl.GL_FLOAT, np.float32, 1)


SCRATCH_UNIT = 15
"""Texture unit used to create, upload and read textures, so that doing so never replaces a
texture bound for drawing on units 0–14."""


def _bind_scratch(target: int, ident: int) -> None:
    gl.glActiveTexture(gl.GL_TEXTURE0 + SCRATCH_UNIT)
    gl.glBindTexture(target, ident)


class Texture:
    """A 2-D texture, or a 2-D array texture when ``layers`` is given.

    Args:
        size: (W, H) [texels].
        fmt: a :class:`TexFormat`.
        layers: None for ``GL_TEXTURE_2D``; else the layer count of a ``GL_TEXTURE_2D_ARRAY``.
        levels: mip levels allocated (1 = none).
        linear: LINEAR (trilinear with mips) filtering; integer formats are always NEAREST.
        repeat: REPEAT wrapping, else CLAMP_TO_EDGE.
    """

    def __init__(self, size: tuple[int, int], fmt: TexFormat, *, layers: int | None = None,
                 levels: int = 1, linear: bool = False, repeat: bool = False) -> None:
        self.width, self.height = (max(1, int(v)) for v in size)
        self.fmt, self.layers, self.levels = fmt, layers, levels
        self._last_upload: tuple[np.ndarray, int] | None = None
        self.target = gl.GL_TEXTURE_2D if layers is None else gl.GL_TEXTURE_2D_ARRAY
        ident = gl.GLuint()
        gl.glGenTextures(1, ctypes.byref(ident))
        self.id = ident.value
        self.context = gl.current_context
        _bind_scratch(self.target, self.id)
        for level in range(levels):
            w, h = max(1, self.width >> level), max(1, self.height >> level)
            if layers is None:
                gl.glTexImage2D(self.target, level, fmt.internal, w, h, 0, fmt.upload,
                                fmt.gl_type, None)
            else:
                gl.glTexImage3D(self.target, level, fmt.internal, w, h, layers, 0, fmt.upload,
                                fmt.gl_type, None)
        filt = gl.GL_LINEAR if linear and not fmt.integer else gl.GL_NEAREST
        min_filt = (gl.GL_LINEAR_MIPMAP_LINEAR if levels > 1 else gl.GL_LINEAR) \
            if filt == gl.GL_LINEAR else gl.GL_NEAREST
        wrap = gl.GL_REPEAT if repeat else gl.GL_CLAMP_TO_EDGE
        gl.glTexParameteri(self.target, gl.GL_TEXTURE_MIN_FILTER, min_filt)
        gl.glTexParameteri(self.target, gl.GL_TEXTURE_MAG_FILTER, filt)
        gl.glTexParameteri(self.target, gl.GL_TEXTURE_WRAP_S, wrap)
        gl.glTexParameteri(self.target, gl.GL_TEXTURE_WRAP_T, wrap)
        gl.glTexParameteri(self.target, gl.GL_TEXTURE_MAX_LEVEL, levels - 1)

    def upload(self, data: np.ndarray, *, rows: int | None = None, level: int = 0,
               layer: int | None = None, first_row: int = 0) -> None:
        """Write ``data`` ((H, W, C) or (H, W) for one channel) into the texture from row 0;
        ``rows`` limits the upload to the first rows (from ``first_row`` on: rows
        first_row … first_row + rows − 1 of ``data`` into the same rows; 2-D textures only).
        For array textures ``layer`` picks one layer, or ``data`` is (L, H, W, C) for all
        layers."""
        data = np.ascontiguousarray(data, dtype=self.fmt.dtype)
        w, h = max(1, self.width >> level), max(1, self.height >> level)
        first = int(first_row)
        if not 0 <= first <= h or (first and self.layers is not None):
            raise ValueError(f"Texture.upload: first_row {first_row!r} is not a row of this "
                             "2-D texture")
        n = h - first if rows is None else min(int(rows), h - first)
        if n <= 0:
            return
        _bind_scratch(self.target, self.id)
        gl.glPixelStorei(gl.GL_UNPACK_ALIGNMENT, 1)
        if self.layers is None:
            _check_shape(data, (h, w), self.fmt.channels, first + n)
            address = self._address(data) if not first else data[first].ctypes.data
            gl.glTexSubImage2D(self.target, level, 0, first, w, n, self.fmt.upload,
                               self.fmt.gl_type, address)
        else:
            count = 1 if layer is not None else self.layers
            if layer is None:
                _check_shape(data[0], (h, w), self.fmt.channels, n)
            else:
                _check_shape(data, (h, w), self.fmt.channels, n)
            gl.glTexSubImage3D(self.target, level, 0, 0, 0 if layer is None else layer, w, n,
                               count, self.fmt.upload, self.fmt.gl_type, self._address(data))

    def _address(self, data: np.ndarray) -> int:
        """``data.ctypes.data``, kept for the array uploaded last (the same array every frame:
        numpy makes a ctypes object for each ``.ctypes``); the reference kept pins its
        memory."""
        last = self._last_upload
        if last is not None and last[0] is data:
            return last[1]
        address = data.ctypes.data
        self._last_upload = (data, address)
        return address

    def bind(self, unit: int) -> None:
        gl.glActiveTexture(gl.GL_TEXTURE0 + unit)
        gl.glBindTexture(self.target, self.id)

    def generate_mipmaps(self) -> None:
        """Fill levels 1… from level 0 (a texture drawn into, e.g. the reflection)."""
        _bind_scratch(self.target, self.id)
        gl.glGenerateMipmap(self.target)

    def delete(self) -> None:
        _discard(self.context, "texture", self.id)
        self.id = 0


class BufferTexture:
    """A buffer texture (``GL_TEXTURE_BUFFER``, core since OpenGL 3.1): ``texels`` texels of
    ``fmt`` in a buffer object, read in GLSL with ``texelFetch(samplerBuffer, i)`` (an
    ``isamplerBuffer`` for integer formats): a plain copy of the bytes when written
    (:meth:`write`, ``glBufferSubData`` into fresh storage), no texture layout or row pitch.
    Raises
    :class:`GLError` past the driver's ``GL_MAX_TEXTURE_BUFFER_SIZE`` (at least 65536 texels;
    2^27 and more on desktop GPUs and Mesa)."""

    def __init__(self, texels: int, fmt: TexFormat) -> None:
        limit = gl.GLint()
        gl.glGetIntegerv(gl.GL_MAX_TEXTURE_BUFFER_SIZE, ctypes.byref(limit))
        self.texels = max(1, int(texels))
        if self.texels > limit.value:
            raise GLError(f"a buffer texture of {self.texels} texels is past this driver's "
                          f"GL_MAX_TEXTURE_BUFFER_SIZE ({limit.value})")
        self.fmt = fmt
        self.target = gl.GL_TEXTURE_BUFFER
        self.nbytes = self.texels * fmt.channels * np.dtype(fmt.dtype).itemsize
        self.context = gl.current_context
        self.buffer = _buffer(gl.GL_TEXTURE_BUFFER, None, self.nbytes)
        gl.glBindBuffer(gl.GL_TEXTURE_BUFFER, 0)
        ident = gl.GLuint()
        gl.glGenTextures(1, ctypes.byref(ident))
        self.id = ident.value
        _bind_scratch(self.target, self.id)
        gl.glTexBuffer(self.target, fmt.internal, self.buffer)
        self._last_write: tuple[np.ndarray, int] | None = None

    def write(self, data: np.ndarray, nbytes: int | None = None) -> None:
        """Copy the first ``nbytes`` (default: all) of C-contiguous ``data`` into the buffer
        from its start; the bytes past them are undefined after it. The buffer's storage is
        orphaned first (``glBufferData`` with no data): a draw of the previous frame may still
        read the old storage, and writing into it would wait for that draw to finish (a sync
        of the CPU with the GPU every frame; on llvmpipe the whole previous frame's
        rasterisation)."""
        n = data.nbytes if nbytes is None else min(int(nbytes), data.nbytes)
        if n > self.nbytes or not data.flags.c_contiguous:
            raise ValueError(f"{n} bytes into a buffer texture of {self.nbytes}")
        if n <= 0:
            return
        last = self._last_write
        if last is None or last[0] is not data:     # the same array every frame
            last = self._last_write = (data, data.ctypes.data)
        gl.glBindBuffer(gl.GL_COPY_WRITE_BUFFER, self.buffer)
        gl.glBufferData(gl.GL_COPY_WRITE_BUFFER, self.nbytes, None, gl.GL_STREAM_DRAW)
        gl.glBufferSubData(gl.GL_COPY_WRITE_BUFFER, 0, n, last[1])
        gl.glBindBuffer(gl.GL_COPY_WRITE_BUFFER, 0)

    def read(self) -> np.ndarray:
        """The whole buffer as (texels, channels) of the format's dtype (for tests)."""
        out = np.empty((self.texels, self.fmt.channels), self.fmt.dtype)
        _read_buffer(gl.GL_COPY_READ_BUFFER, self.buffer, 0, out)
        gl.glBindBuffer(gl.GL_COPY_READ_BUFFER, 0)
        return out

    def bind(self, unit: int) -> None:
        gl.glActiveTexture(gl.GL_TEXTURE0 + unit)
        gl.glBindTexture(self.target, self.id)

    def delete(self) -> None:
        _discard(self.context, "texture", self.id)
        _discard(self.context, "buffer", self.buffer)
        self.id = self.buffer = 0
        self._last_write = None


def _check_shape(data: np.ndarray, hw: tuple[int, int], channels: int, rows: int) -> None:
    want = hw if channels == 1 else (*hw, channels)
    got = data.shape if channels > 1 or data.ndim == 2 else data.shape[:2]
    if got[1:] != want[1:] or got[0] < rows:
        raise ValueError(f"texture upload of shape {data.shape} into {want}")


def read_texture(texture: Texture, level: int = 0) -> np.ndarray:
    """Read a texture back as (H, W, C) (or (H, W)) of its dtype, row 0 at the bottom; an
    array texture as (L, H, W, C) (or (L, H, W))."""
    w, h = max(1, texture.width >> level), max(1, texture.height >> level)
    c = texture.fmt.channels
    shape = (h, w, c) if c > 1 else (h, w)
    if texture.layers is not None:
        shape = (texture.layers, *shape)
    out = np.empty(shape, texture.fmt.dtype)
    _bind_scratch(texture.target, texture.id)
    gl.glPixelStorei(gl.GL_PACK_ALIGNMENT, 1)
    gl.glGetTexImage(texture.target, level, texture.fmt.upload, texture.fmt.gl_type,
                     out.ctypes.data)
    return out


# -- framebuffers ----------------------------------------------------------------------------

class Framebuffer:
    """Colour attachment(s) plus an optional depth texture (shared between framebuffers when
    passed in). A colour attachment is a 2-D texture or a (array texture, layer) pair; with
    several, fragment output ``location = i`` goes to attachment i."""

    def __init__(self, colour: list[Texture | tuple[Texture, int]],
                 depth: Texture | None = None) -> None:
        ident = gl.GLuint()
        gl.glGenFramebuffers(1, ctypes.byref(ident))
        self.id = ident.value
        self.context = gl.current_context
        self.colour, self.depth = colour, depth
        first = colour[0][0] if isinstance(colour[0], tuple) else colour[0]
        self.width, self.height = first.width, first.height
        gl.glBindFramebuffer(gl.GL_FRAMEBUFFER, self.id)
        for i, attachment in enumerate(colour):
            if isinstance(attachment, tuple):
                tex, layer = attachment
                gl.glFramebufferTextureLayer(gl.GL_FRAMEBUFFER, gl.GL_COLOR_ATTACHMENT0 + i,
                                             tex.id, 0, layer)
            else:
                gl.glFramebufferTexture2D(gl.GL_FRAMEBUFFER, gl.GL_COLOR_ATTACHMENT0 + i,
                                          gl.GL_TEXTURE_2D, attachment.id, 0)
        if len(colour) > 1:
            buffers = (gl.GLenum * len(colour))(*(gl.GL_COLOR_ATTACHMENT0 + i
                                                  for i in range(len(colour))))
            gl.glDrawBuffers(len(colour), buffers)
        if depth is not None:
            gl.glFramebufferTexture2D(gl.GL_FRAMEBUFFER, gl.GL_DEPTH_ATTACHMENT,
                                      gl.GL_TEXTURE_2D, depth.id, 0)
        status = gl.glCheckFramebufferStatus(gl.GL_FRAMEBUFFER)
        gl.glBindFramebuffer(gl.GL_FRAMEBUFFER, 0)
        if status != gl.GL_FRAMEBUFFER_COMPLETE:
            raise GLError(f"framebuffer incomplete: status {hex(status)}")

    def bind(self) -> None:
        gl.glBindFramebuffer(gl.GL_FRAMEBUFFER, self.id)
        gl.glViewport(0, 0, self.width, self.height)

    def read_rgba8(self, out: np.ndarray | None = None) -> np.ndarray:
        """The first colour attachment as (H, W, 4) uint8, row 0 at the **top** (image order)."""
        h, w = self.height, self.width
        buf = np.empty((h, w, 4), np.uint8)
        gl.glBindFramebuffer(gl.GL_READ_FRAMEBUFFER, self.id)
        gl.glReadBuffer(gl.GL_COLOR_ATTACHMENT0)
        gl.glPixelStorei(gl.GL_PACK_ALIGNMENT, 1)
        gl.glReadPixels(0, 0, w, h, gl.GL_RGBA, gl.GL_UNSIGNED_BYTE, buf.ctypes.data)
        gl.glBindFramebuffer(gl.GL_READ_FRAMEBUFFER, 0)
        if out is None:
            return buf[::-1].copy()
        out[...] = buf[::-1]
        return out

    def delete(self) -> None:
        _discard(self.context, "framebuffer", self.id)
        self.id = 0


def blit(source: Framebuffer, target: Framebuffer, depth: bool = False) -> None:
    """Copy ``source``'s colour (and depth) into ``target`` (same size: no filtering)."""
    gl.glBindFramebuffer(gl.GL_READ_FRAMEBUFFER, source.id)
    gl.glBindFramebuffer(gl.GL_DRAW_FRAMEBUFFER, target.id)
    mask = gl.GL_COLOR_BUFFER_BIT | (gl.GL_DEPTH_BUFFER_BIT if depth else 0)
    gl.glBlitFramebuffer(0, 0, source.width, source.height, 0, 0, target.width, target.height,
                         mask, gl.GL_NEAREST)
    gl.glBindFramebuffer(gl.GL_FRAMEBUFFER, 0)


def blit_to_window(source: Framebuffer, width_px: int, height_px: int) -> None:
    """Copy ``source``'s colour onto the window (framebuffer 0), scaled to its viewport."""
    gl.glBindFramebuffer(gl.GL_READ_FRAMEBUFFER, source.id)
    gl.glBindFramebuffer(gl.GL_DRAW_FRAMEBUFFER, 0)
    gl.glBlitFramebuffer(0, 0, source.width, source.height, 0, 0, max(1, width_px),
                         max(1, height_px), gl.GL_COLOR_BUFFER_BIT, gl.GL_LINEAR)
    gl.glBindFramebuffer(gl.GL_FRAMEBUFFER, 0)


def bind_default_framebuffer(width_px: int, height_px: int) -> None:
    """Draw into the window (framebuffer 0) over a ``width`` × ``height`` viewport."""
    gl.glBindFramebuffer(gl.GL_FRAMEBUFFER, 0)
    gl.glViewport(0, 0, max(1, width_px), max(1, height_px))


def bind_host_framebuffer(framebuffer: int, viewport: tuple[int, int, int, int]) -> None:
    """Draw into a host's framebuffer (0: its window) over its viewport (x, y, w, h)."""
    gl.glBindFramebuffer(gl.GL_DRAW_FRAMEBUFFER, int(framebuffer))
    gl.glViewport(*(int(v) for v in viewport))


# -- meshes ----------------------------------------------------------------------------------

class Mesh:
    """A vertex array: float32 vertex attributes in one interleaved buffer, optional uint32
    indices. ``attributes`` maps shader location → component count, in buffer order."""

    def __init__(self, vertices: np.ndarray | None, attributes: dict[int, int],
                 indices: np.ndarray | None = None) -> None:
        ident = gl.GLuint()
        gl.glGenVertexArrays(1, ctypes.byref(ident))
        self.vao = ident.value
        self.context = gl.current_context
        gl.glBindVertexArray(self.vao)
        self.vbo = self.ebo = 0
        self.vertex_count = 0
        self.index_count = 0
        if vertices is not None:
            v = np.ascontiguousarray(vertices, np.float32)
            self.vertex_count = v.shape[0]
            self.vbo = _buffer(gl.GL_ARRAY_BUFFER, v)
            _point_attributes(attributes)
        if indices is not None:
            idx = np.ascontiguousarray(indices, np.uint32)
            self.index_count = idx.size
            self.ebo = _buffer(gl.GL_ELEMENT_ARRAY_BUFFER, idx)
        gl.glBindVertexArray(0)

    def draw(self, mode: int = gl.GL_TRIANGLES, count: int | None = None, first: int = 0,
             base_vertex: int = 0) -> None:
        """Draw ``count`` indices from index ``first`` (indexed meshes, with ``base_vertex``
        added to every index), or ``count`` vertices from ``first`` (no indices; a mesh with
        no vertex buffer draws attribute-less vertices for ``gl_VertexID`` shaders)."""
        gl.glBindVertexArray(self.vao)
        if self.ebo:
            n = self.index_count if count is None else count
            if n > 0:
                gl.glDrawElementsBaseVertex(mode, n, gl.GL_UNSIGNED_INT,
                                            ctypes.c_void_p(4 * first), base_vertex)
        else:
            n = self.vertex_count if count is None else count
            if n > 0:
                gl.glDrawArrays(mode, first, n)
        gl.glBindVertexArray(0)

    def delete(self) -> None:
        _delete_vertex_array(self)


def _delete_vertex_array(obj) -> None:
    """Release a Mesh's or an arena's vertex array and its two buffers (through their own
    context) and zero their names."""
    for buf in (obj.vbo, obj.ebo):
        _discard(obj.context, "buffer", buf)
    _discard(obj.context, "vao", obj.vao)
    obj.vao = obj.vbo = obj.ebo = 0


def _buffer(target: int, data: np.ndarray | None, nbytes: int | None = None) -> int:
    """A new buffer object bound to ``target``, filled with ``data`` (or ``nbytes`` left
    undefined)."""
    ident = gl.GLuint()
    gl.glGenBuffers(1, ctypes.byref(ident))
    gl.glBindBuffer(target, ident.value)
    if data is None:
        gl.glBufferData(target, int(nbytes), None, gl.GL_STATIC_DRAW)
    else:
        gl.glBufferData(target, data.nbytes, data.ctypes.data, gl.GL_STATIC_DRAW)
    return ident.value


def _point_attributes(attributes: dict[int, int]) -> None:
    """Interleaved float32 attributes of the bound GL_ARRAY_BUFFER into the bound VAO."""
    stride = 4 * sum(attributes.values())
    offset = 0
    for location, count in attributes.items():
        gl.glEnableVertexAttribArray(location)
        gl.glVertexAttribPointer(location, count, gl.GL_FLOAT, gl.GL_FALSE, stride,
                                 ctypes.c_void_p(offset))
        offset += 4 * count


class _MultiDraw:
    """The arrays of a ``glMultiDrawElementsBaseVertex`` call (index counts, index offsets in
    bytes, base vertices), kept between calls with their ctypes pointers made once."""

    def __init__(self, n: int = 64) -> None:
        self._fit(n)

    def _fit(self, n: int) -> None:
        self.counts = np.zeros(n, np.int32)
        self.offsets = np.zeros(n, np.intp)
        self.base = np.zeros(n, np.int32)
        self._counts_p = self.counts.ctypes.data_as(ctypes.POINTER(gl.GLsizei))
        self._base_p = self.base.ctypes.data_as(ctypes.POINTER(gl.GLint))
        self._offsets_p = self.offsets.ctypes.data

    def room(self, n: int) -> None:
        """Room for ``n`` draws."""
        if n > len(self.counts):
            self._fit(2 * n)

    def call(self, vao: int, mode: int, n: int) -> None:
        """Draw the first ``n`` entries of the arrays through ``vao``."""
        gl.glBindVertexArray(vao)
        gl.glMultiDrawElementsBaseVertex(mode, self._counts_p, gl.GL_UNSIGNED_INT,
                                         self._offsets_p, n, self._base_p)
        gl.glBindVertexArray(0)


def _grown_buffer(target: int, old: int, old_bytes: int, new_bytes: int, context) -> int:
    """A new buffer of ``new_bytes`` bound to ``target`` holding ``old``'s first
    ``old_bytes`` (copied on the GPU); ``old`` is deleted."""
    ident = _buffer(target, None, new_bytes)
    if old:
        gl.glBindBuffer(gl.GL_COPY_READ_BUFFER, old)
        gl.glCopyBufferSubData(gl.GL_COPY_READ_BUFFER, target, 0, 0, old_bytes)
        gl.glBindBuffer(gl.GL_COPY_READ_BUFFER, 0)
        _discard(context, "buffer", old)
    return ident


def _read_buffer(target: int, ident: int, offset: int, out: np.ndarray) -> np.ndarray:
    gl.glBindBuffer(target, ident)
    gl.glGetBufferSubData(target, offset, out.nbytes, out.ctypes.data)
    return out


class SlotArena:
    """Meshes of one shape in shared GPU buffers, any set of them drawn with one call.

    Every mesh has ``slot_vertices`` vertices of one interleaved float32 layout
    (``attributes``: shader location → component count) and is drawn with the same
    ``indices`` (uint32, relative to its first vertex), or a range of them: the terrain tiles.
    The vertices live in *slots* of one vertex buffer (slot ``s`` holds vertices
    ``s·V … (s + 1)·V − 1``), the indices once in one index buffer, both in one vertex array.
    :meth:`alloc` hands out a free slot (the buffer doubles when none is free, the old
    slots' data copied on the GPU), :meth:`upload` writes a mesh into it
    (``glBufferSubData``), :meth:`free` gives slots back, :meth:`draw` draws a list of slots in
    its order with one ``glMultiDrawElementsBaseVertex`` (OpenGL 3.2 core): the same picture
    as drawing them one by one.
    """

    def __init__(self, slot_vertices: int, attributes: dict[int, int], indices: np.ndarray,
                 capacity: int = 64) -> None:
        self.slot_vertices = int(slot_vertices)
        self.attributes = dict(attributes)
        self.slot_bytes = self.slot_vertices * 4 * sum(self.attributes.values())
        self.context = gl.current_context
        ident = gl.GLuint()
        gl.glGenVertexArrays(1, ctypes.byref(ident))
        self.vao = ident.value
        gl.glBindVertexArray(self.vao)
        idx = np.ascontiguousarray(indices, np.uint32).ravel()
        self.index_count = idx.size
        self.ebo = _buffer(gl.GL_ELEMENT_ARRAY_BUFFER, idx)    # kept in the VAO's state
        gl.glBindVertexArray(0)
        self.vbo = 0
        self.capacity = 0
        self.used = np.zeros(0, bool)
        """Which slots are allocated."""
        self.grown = -1
        """Times the vertex buffer grew after it was made."""
        self._free: list[int] = []
        self._draws = _MultiDraw()
        self._part_draws: dict[str, list] = {}
        self._part_base = np.zeros((0, 0), np.int32)     # by slot and part: its base vertex
        """:meth:`draw_parts`' kept calls by name: [arrays, (revision, slots) filled for]."""
        self._grow(max(1, int(capacity)))

    def __len__(self) -> int:
        """Slots in use."""
        return self.capacity - len(self._free)

    def alloc(self) -> int:
        """A free slot: the last one given back, else the lowest never used (the buffer
        doubles when none is free)."""
        if not self._free:
            self._grow(2 * self.capacity)
        slot = self._free.pop()
        self.used[slot] = True
        return slot

    def free(self, slots) -> None:
        """Give slots back (their data stays until a new mesh is uploaded there)."""
        for slot in np.asarray(slots, np.int64).reshape(-1).tolist():
            if not 0 <= slot < self.capacity or not self.used[slot]:
                raise ValueError(f"slot {slot} is not in use")
            self.used[slot] = False
            self._free.append(slot)

    def upload(self, slot: int, vertices: np.ndarray) -> None:
        """Write a mesh's (V, C) vertices into ``slot``."""
        v = np.ascontiguousarray(vertices, np.float32)
        if v.nbytes != self.slot_bytes:
            raise ValueError(f"a slot holds {self.slot_bytes} bytes of vertices, "
                             f"got {v.shape} ({v.nbytes} bytes)")
        if not 0 <= slot < self.capacity or not self.used[slot]:
            raise ValueError(f"slot {slot} is not in use")
        gl.glBindBuffer(gl.GL_ARRAY_BUFFER, self.vbo)
        gl.glBufferSubData(gl.GL_ARRAY_BUFFER, slot * self.slot_bytes, self.slot_bytes,
                           v.ctypes.data)

    def read(self, slot: int) -> np.ndarray:
        """A slot's vertices as stored on the GPU, (V, C) float32 (for tests)."""
        out = np.empty((self.slot_vertices, sum(self.attributes.values())), np.float32)
        return _read_buffer(gl.GL_ARRAY_BUFFER, self.vbo, slot * self.slot_bytes, out)

    def draw(self, slots: np.ndarray, count: int | None = None, first: int = 0,
             mode: int = gl.GL_TRIANGLES) -> None:
        """Draw the meshes in ``slots`` (in that order), each through ``count`` indices from
        index ``first`` (default: all), with one multi-draw call."""
        n = len(slots)
        count = self.index_count if count is None else int(count)
        if n == 0 or count <= 0:
            return
        draws = self._draws
        draws.room(n)
        np.multiply(slots, self.slot_vertices, out=draws.base[:n], casting="unsafe")
        draws.counts[:n] = count
        draws.offsets[:n] = 4 * int(first)
        draws.call(self.vao, mode, n)

    def draw_parts(self, slots: np.ndarray, counts: np.ndarray, offsets: np.ndarray,
                   cache: tuple | None = None, mode: int = gl.GL_TRIANGLES) -> None:
        """Draw the meshes in ``slots`` (K,) (in that order), each through P ranges of the
        index buffer given by slot: ``counts`` (S, P) int32 indices and ``offsets`` (S, P)
        int64 their first index's byte offset (4 × the index: a terrain tile's core and its
        edges' variants), with one multi-draw call of K·P draws. ``cache`` (name,
        revision): the call's arrays are kept under that name and filled again only when
        the slots or the revision (of the tables) change."""
        k, parts = len(slots), counts.shape[1]
        n = k * parts
        if n == 0:
            return
        if cache is None:
            draws = self._draws
        else:
            kept = self._part_draws.get(cache[0])
            if kept is None:
                kept = self._part_draws[cache[0]] = [_MultiDraw(), None]
            draws, signature = kept[0], (cache[1], slots.dtype.str, slots.tobytes())
            if kept[1] == signature:
                draws.call(self.vao, mode, n)
                return
            kept[1] = signature
        if self._part_base.shape != (self.capacity, parts):
            self._part_base = np.repeat(
                (np.arange(self.capacity, dtype=np.int32) * self.slot_vertices)[:, None],
                parts, axis=1)
        draws.room(n)
        np.take(self._part_base, slots, axis=0, out=draws.base[:n].reshape(k, parts))
        np.take(counts, slots, axis=0, out=draws.counts[:n].reshape(k, parts))
        np.take(offsets, slots, axis=0, out=draws.offsets[:n].reshape(k, parts))
        draws.call(self.vao, mode, n)

    def _grow(self, capacity: int) -> None:
        if capacity * self.slot_vertices >= 2 ** 31:
            raise ValueError(f"{capacity} slots of {self.slot_vertices} vertices are past "
                             "a 32-bit base vertex")
        old = self.capacity
        self.vbo = _grown_buffer(gl.GL_ARRAY_BUFFER, self.vbo, old * self.slot_bytes,
                                 capacity * self.slot_bytes, self.context)
        gl.glBindVertexArray(self.vao)
        gl.glBindBuffer(gl.GL_ARRAY_BUFFER, self.vbo)
        _point_attributes(self.attributes)
        gl.glBindVertexArray(0)
        self.used = np.concatenate([self.used, np.zeros(capacity - old, bool)])
        self._free[:0] = range(capacity - 1, old - 1, -1)   # below the ones given back
        self.capacity = capacity
        self.grown += 1

    def delete(self) -> None:
        _delete_vertex_array(self)


class RangeAllocator:
    """First-fit ranges of a buffer of ``size`` units (no GL): :meth:`alloc` returns the start
    of the first free run long enough (or −1), :meth:`free` gives a range back (merged with
    free neighbours), :meth:`grow` adds room at the end."""

    def __init__(self, size: int) -> None:
        self.size = int(size)
        self.runs: list[list[int]] = [[0, self.size]] if self.size else []
        """Free runs [start, length], by start, none touching another."""

    def alloc(self, n: int) -> int:
        if n <= 0:
            raise ValueError(f"a range of {n} units")
        for k, run in enumerate(self.runs):
            if run[1] >= n:
                start = run[0]
                run[0] += n
                run[1] -= n
                if not run[1]:
                    del self.runs[k]
                return start
        return -1

    def free(self, start: int, n: int) -> None:
        if n <= 0 or start < 0 or start + n > self.size:
            raise ValueError(f"range ({start}, {n}) is outside the buffer of {self.size}")
        runs = self.runs
        k = 0
        while k < len(runs) and runs[k][0] < start:
            k += 1
        if (k and runs[k - 1][0] + runs[k - 1][1] > start) \
                or (k < len(runs) and start + n > runs[k][0]):
            raise ValueError(f"range ({start}, {n}) is free already")
        if k and runs[k - 1][0] + runs[k - 1][1] == start:
            runs[k - 1][1] += n
            if k < len(runs) and start + n == runs[k][0]:
                runs[k - 1][1] += runs[k][1]
                del runs[k]
        elif k < len(runs) and start + n == runs[k][0]:
            runs[k][0] = start
            runs[k][1] += n
        else:
            runs.insert(k, [start, n])

    def grow(self, size: int) -> None:
        """Room up to ``size`` units."""
        if size > self.size:
            self.runs.append([self.size, size - self.size])
            if len(self.runs) > 1 and self.runs[-2][0] + self.runs[-2][1] == self.size:
                self.runs[-2][1] += self.runs.pop()[1]
            self.size = int(size)

    @property
    def free_units(self) -> int:
        return sum(n for _, n in self.runs)


class MeshArena:
    """Indexed meshes of any size in one vertex buffer and one index buffer (one vertex
    array), any set of them drawn with one ``glMultiDrawElementsBaseVertex``: the water tiles.

    :meth:`add` places a mesh's vertices and its indices (uint32, relative to its first
    vertex) in the first free run of each buffer that holds them (a buffer doubles, its data
    copied on the GPU, when none does) and returns where: (first vertex, first index);
    :meth:`remove` gives both runs back. Buffers only grow (freed runs are reused, never
    compacted).
    """

    def __init__(self, attributes: dict[int, int], vertices: int = 1 << 16,
                 indices: int = 1 << 18) -> None:
        self.attributes = dict(attributes)
        self.vertex_bytes = 4 * sum(self.attributes.values())
        self.context = gl.current_context
        ident = gl.GLuint()
        gl.glGenVertexArrays(1, ctypes.byref(ident))
        self.vao = ident.value
        self.vbo = self.ebo = 0
        self.vertices = RangeAllocator(0)
        self.indices = RangeAllocator(0)
        self.meshes = 0
        self.grown = 0
        """Times a buffer grew after they were made."""
        self._draws = _MultiDraw()
        self._grow_vertices(max(1, int(vertices)))
        self._grow_indices(max(1, int(indices)))
        self.grown = 0

    def __len__(self) -> int:
        """Meshes held."""
        return self.meshes

    def add(self, vertices: np.ndarray, indices: np.ndarray) -> tuple[int, int]:
        """Upload a mesh; returns its (first vertex, first index)."""
        v = np.ascontiguousarray(vertices, np.float32)
        idx = np.ascontiguousarray(indices, np.uint32).ravel()
        if v.ndim != 2 or v.shape[1] * 4 != self.vertex_bytes or not len(v) or not idx.size:
            raise ValueError(f"a mesh of {v.shape} vertices and {idx.size} indices")
        v0 = self.vertices.alloc(len(v))
        while v0 < 0:
            self._grow_vertices(2 * self.vertices.size)
            v0 = self.vertices.alloc(len(v))
        i0 = self.indices.alloc(idx.size)
        while i0 < 0:
            self._grow_indices(2 * self.indices.size)
            i0 = self.indices.alloc(idx.size)
        gl.glBindBuffer(gl.GL_ARRAY_BUFFER, self.vbo)
        gl.glBufferSubData(gl.GL_ARRAY_BUFFER, v0 * self.vertex_bytes, v.nbytes, v.ctypes.data)
        gl.glBindBuffer(gl.GL_COPY_WRITE_BUFFER, self.ebo)   # not the VAO's element binding
        gl.glBufferSubData(gl.GL_COPY_WRITE_BUFFER, 4 * i0, idx.nbytes, idx.ctypes.data)
        gl.glBindBuffer(gl.GL_COPY_WRITE_BUFFER, 0)
        self.meshes += 1
        return v0, i0

    def remove(self, first_vertex: int, vertex_count: int, first_index: int,
               index_count: int) -> None:
        """Give a mesh's runs back."""
        self.vertices.free(first_vertex, vertex_count)
        self.indices.free(first_index, index_count)
        self.meshes -= 1

    def read(self, first_vertex: int, vertex_count: int, first_index: int,
             index_count: int) -> tuple[np.ndarray, np.ndarray]:
        """A mesh's vertices and indices as stored on the GPU (for tests)."""
        v = np.empty((vertex_count, self.vertex_bytes // 4), np.float32)
        i = np.empty(index_count, np.uint32)
        return (_read_buffer(gl.GL_ARRAY_BUFFER, self.vbo, first_vertex * self.vertex_bytes, v),
                _read_buffer(gl.GL_COPY_READ_BUFFER, self.ebo, 4 * first_index, i))

    def draw(self, first_index: np.ndarray, index_count: np.ndarray,
             first_vertex: np.ndarray, mode: int = gl.GL_TRIANGLES) -> None:
        """Draw meshes, given by their first index, index count and first vertex (arrays, in
        drawing order), with one multi-draw call."""
        n = len(first_index)
        if n == 0:
            return
        draws = self._draws
        draws.room(n)
        np.multiply(first_index, 4, out=draws.offsets[:n], casting="unsafe")
        draws.counts[:n] = index_count
        draws.base[:n] = first_vertex
        draws.call(self.vao, mode, n)

    def _grow_vertices(self, size: int) -> None:
        if size >= 2 ** 31:
            raise ValueError(f"{size} vertices are past a 32-bit base vertex")
        self.vbo = _grown_buffer(gl.GL_ARRAY_BUFFER, self.vbo,
                                 self.vertices.size * self.vertex_bytes,
                                 size * self.vertex_bytes, self.context)
        gl.glBindVertexArray(self.vao)
        gl.glBindBuffer(gl.GL_ARRAY_BUFFER, self.vbo)
        _point_attributes(self.attributes)
        gl.glBindVertexArray(0)
        self.vertices.grow(size)
        self.grown += 1

    def _grow_indices(self, size: int) -> None:
        self.ebo = _grown_buffer(gl.GL_COPY_WRITE_BUFFER, self.ebo, 4 * self.indices.size,
                                 4 * size, self.context)
        gl.glBindBuffer(gl.GL_COPY_WRITE_BUFFER, 0)
        gl.glBindVertexArray(self.vao)
        gl.glBindBuffer(gl.GL_ELEMENT_ARRAY_BUFFER, self.ebo)
        gl.glBindVertexArray(0)
        self.indices.grow(size)
        self.grown += 1

    def delete(self) -> None:
        _delete_vertex_array(self)


class UniformBuffer:
    """``count`` copies of a uniform block of ``floats`` float32 values in one buffer: ``data``
    (count, stride) float32 is written into the buffer whole by :meth:`write` (one call), and
    copy k is bound to a block's binding point by :meth:`bind` (each copy starts at a
    multiple of ``GL_UNIFORM_BUFFER_OFFSET_ALIGNMENT``)."""

    def __init__(self, floats: int, count: int) -> None:
        align = gl.GLint()
        gl.glGetIntegerv(gl.GL_UNIFORM_BUFFER_OFFSET_ALIGNMENT, ctypes.byref(align))
        step = max(16, int(align.value))
        self.block_bytes = 4 * int(floats)
        self.stride_bytes = -(-self.block_bytes // step) * step
        self.data = np.zeros((int(count), self.stride_bytes // 4), np.float32)
        self.context = gl.current_context
        self.id = _buffer(gl.GL_UNIFORM_BUFFER, self.data)
        gl.glBindBuffer(gl.GL_UNIFORM_BUFFER, 0)
        self._address = self.data.ctypes.data

    def write(self) -> None:
        """Copy ``data`` into the buffer."""
        gl.glBindBuffer(gl.GL_UNIFORM_BUFFER, self.id)
        gl.glBufferSubData(gl.GL_UNIFORM_BUFFER, 0, self.data.nbytes, self._address)

    def bind(self, copy: int, binding: int) -> None:
        """Bind copy ``copy`` to the uniform block binding point ``binding``."""
        gl.glBindBufferRange(gl.GL_UNIFORM_BUFFER, binding, self.id, copy * self.stride_bytes,
                             self.block_bytes)

    def delete(self) -> None:
        _discard(self.context, "buffer", self.id)
        self.id = 0


# -- state -----------------------------------------------------------------------------------

class GpuTimer:
    """The GPU's own time for the GL commands issued between :meth:`begin` and :meth:`end`
    (a ``GL_TIME_ELAPSED`` query: core since OpenGL 3.3). :meth:`result_ms` waits until the
    GPU has run them. One timer measures one span at a time."""

    def __init__(self) -> None:
        ident = gl.GLuint()
        gl.glGenQueries(1, ctypes.byref(ident))
        self.query = ident.value
        self.context = gl.current_context

    def begin(self) -> None:
        gl.glBeginQuery(gl.GL_TIME_ELAPSED, self.query)

    def end(self) -> None:
        gl.glEndQuery(gl.GL_TIME_ELAPSED)

    def result_ms(self) -> float:
        ns = ctypes.c_uint64()
        gl.glGetQueryObjectui64v(self.query, gl.GL_QUERY_RESULT, ctypes.byref(ns))
        return ns.value * 1e-6

    def delete(self) -> None:
        if self.query and gl.current_context is self.context:
            gl.glDeleteQueries(1, ctypes.byref(gl.GLuint(self.query)))
        self.query = 0


_state: dict[str, object] = {}
"""The depth, blend and cull state the setters below last set in ``_state_context``: a setter
makes no GL call for a part that is already so (a frame sets the same state again and again,
~a dozen calls a frame). Nothing else in riverflow sets these; a host may between frames, so
the draw system calls :func:`forget_state` at the start of each."""
_state_context = [None]


def forget_state() -> None:
    """Forget what the setters know of the current context's state: their next calls make
    every GL call again."""
    _state.clear()
    _state_context[0] = gl.current_context


def _known() -> dict[str, object]:
    """The state known of the current context (none if another context is current now)."""
    if _state_context[0] is not gl.current_context:
        forget_state()
    return _state


def _enable(state: dict[str, object], key: str, cap: int, on: bool) -> None:
    """glEnable or glDisable ``cap`` unless ``state[key]`` says it already is so."""
    if state.get(key) is not on:
        (gl.glEnable if on else gl.glDisable)(cap)
        state[key] = on


def clear(rgba: tuple[float, float, float, float] = (0, 0, 0, 0), depth: bool = True) -> None:
    """Clear the bound framebuffer's colour (and depth: glClear obeys the depth mask, so depth
    writes are turned on first and stay on)."""
    gl.glClearColor(*rgba)
    if depth:
        state = _known()
        if state.get("depth_write") is not True:
            gl.glDepthMask(gl.GL_TRUE)
            state["depth_write"] = True
    gl.glClear(gl.GL_COLOR_BUFFER_BIT | (gl.GL_DEPTH_BUFFER_BIT if depth else 0))


def set_depth(test: bool, write: bool = True) -> None:
    """Depth test (GL_LEQUAL) on or off, depth writes on or off."""
    state = _known()
    test, write = bool(test), bool(write)
    _enable(state, "depth_test", gl.GL_DEPTH_TEST, test)
    if "depth_func" not in state:
        gl.glDepthFunc(gl.GL_LEQUAL)
        state["depth_func"] = gl.GL_LEQUAL
    if state.get("depth_write") is not write:
        gl.glDepthMask(gl.GL_TRUE if write else gl.GL_FALSE)
        state["depth_write"] = write


BLEND_OFF, BLEND_ALPHA, BLEND_ADD, BLEND_WATER = range(4)


def set_blend(kind: int) -> None:
    """OFF; ALPHA (src·a + dst·(1−a)); ADD (src + dst); WATER (src + dst·src.a: the water
    shader writes what it adds and how much of the bed drawn before shows through). Blending
    never changes the target's alpha (the frame stays opaque)."""
    state = _known()
    on = kind != BLEND_OFF
    if on and state.get("blend_func") != kind:
        src, dst = {BLEND_ALPHA: (gl.GL_SRC_ALPHA, gl.GL_ONE_MINUS_SRC_ALPHA),
                    BLEND_ADD: (gl.GL_ONE, gl.GL_ONE),
                    BLEND_WATER: (gl.GL_ONE, gl.GL_SRC_ALPHA)}[kind]
        gl.glBlendEquation(gl.GL_FUNC_ADD)
        gl.glBlendFuncSeparate(src, dst, gl.GL_ZERO, gl.GL_ONE)
        state["blend_func"] = kind
    _enable(state, "blend", gl.GL_BLEND, on)


def mip_levels(width: int, height: int) -> int:
    """Levels of a full mip chain down to 1 × 1."""
    return max(int(width), int(height), 1).bit_length()


def set_cull(back: bool, mirrored: bool = False) -> None:
    """Cull back faces (or not). ``mirrored``: the geometry is drawn through a mirror, which
    turns counter-clockwise front faces clockwise (the planar reflection pass)."""
    state = _known()
    back, front = bool(back), gl.GL_CW if mirrored else gl.GL_CCW
    _enable(state, "cull", gl.GL_CULL_FACE, back)
    if "cull_face" not in state:
        gl.glCullFace(gl.GL_BACK)
        state["cull_face"] = gl.GL_BACK
    if state.get("front_face") != front:
        gl.glFrontFace(front)
        state["front_face"] = front


def set_clip_distance(on: bool) -> None:
    """Clip against the plane the vertex shaders write to ``gl_ClipDistance[0]`` (the
    reflection pass drops what is under the water), or not. Mesa's llvmpipe clips by
    ``gl_ClipDistance`` even while this is off, so a shader that writes it must write a
    positive distance when it does not mean to clip (``u_clip_water`` in terrain.glsl)."""
    (gl.glEnable if on else gl.glDisable)(gl.GL_CLIP_DISTANCE0)


def enable_program_point_size() -> None:
    gl.glEnable(gl.GL_PROGRAM_POINT_SIZE)


def finish() -> None:
    """Wait for the GPU (for timing)."""
    gl.glFinish()


POINTS, LINES, TRIANGLES = gl.GL_POINTS, gl.GL_LINES, gl.GL_TRIANGLES
