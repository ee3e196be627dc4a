"""A loading screen: the kernels compile in a worker thread while the window keeps drawing.

On a cold kernel cache (a new install, a new numba, an edited kernel) compiling takes about a
minute; a window that compiled in its own thread would freeze for that long. Here the window
runs its own small event loop and draws the progress line of
:func:`riverflow.kernels.warmup.compile_kernels` ("compiling riverflow kernels for this
machine, first run only: 12/46"), or "loading…" while machine code only loads from the
cache, until the kernels are ready. numba's compiler holds the GIL most of the time, but the
interpreter hands it over every few milliseconds, so the window still answers and redraws.

    window = pyglet.window.Window(...)
    if compile_with_loading_screen(window, ("scene", "world", "draw")).closed:
        return            # the window was closed while loading
"""
from __future__ import annotations

import threading
import time
from collections.abc import Sequence
from dataclasses import dataclass

from riverflow.kernels.warmup import CompileProgress, TerminalProgress, compile_kernels

FRAME_S = 1.0 / 30.0


@dataclass
class Loading:
    """How the loading screen went."""

    closed: bool
    """The window was closed while loading."""
    frames: int
    """Frames drawn."""
    longest_s: float
    """The longest time between two drawn frames [s] (the window never froze for longer)."""
    seconds: float


def compile_with_loading_screen(window, groups: Sequence[str], *, title: str = "riverflow",
                                terminal: bool = True) -> Loading:
    """Compile (or load) the kernels of ``groups`` in a worker thread while ``window`` shows
    the progress; the same line goes to stderr with ``terminal``. If the window is closed
    meanwhile (``Loading.closed``) the compiling goes on in the background and its machine
    code is kept in the cache. An error of the warm-up is raised here."""
    import pyglet

    progress = CompileProgress()
    reporters: list[CompileProgress] = [progress]
    if terminal:
        reporters.append(TerminalProgress())
    done = threading.Event()
    errors: list[BaseException] = []

    def work() -> None:
        try:
            compile_kernels(*groups, progress=reporters)
        except BaseException as exc:  # noqa: BLE001 - raised in the main thread
            errors.append(exc)
        finally:
            done.set()

    threading.Thread(target=work, name="riverflow-compile-kernels", daemon=True).start()
    heading = pyglet.text.Label(title, font_size=24, anchor_x="center", anchor_y="center",
                                color=(235, 240, 245, 255))
    line = pyglet.text.Label("", font_size=12, anchor_x="center", anchor_y="center",
                             color=(190, 205, 215, 255))
    closed = [False]

    def on_close():
        closed[0] = True
        return pyglet.event.EVENT_HANDLED

    def on_draw():
        window.clear()
        heading.x = line.x = window.width // 2
        heading.y = window.height // 2 + 24
        line.y = window.height // 2 - 16
        line.text = progress.text or _loading_text(progress)
        heading.draw()
        line.draw()
        return pyglet.event.EVENT_HANDLED

    window.set_handlers()   # a base frame first: popping ours must not leave pyglet's stack
    window.push_handlers(on_close=on_close, on_draw=on_draw)   # empty (window.event fails)
    start = last = time.perf_counter()
    frames, longest = 0, 0.0
    try:
        while not closed[0]:
            pyglet.clock.tick()
            window.switch_to()
            window.dispatch_events()
            if closed[0] or done.is_set():
                break
            window.dispatch_event("on_draw")
            window.flip()
            now = time.perf_counter()
            frames, longest, last = frames + 1, max(longest, now - last), now
            done.wait(max(0.0, FRAME_S - (time.perf_counter() - now)))
    finally:
        window.pop_handlers()
    if errors:
        raise errors[0]
    return Loading(closed[0], frames, longest, time.perf_counter() - start)


def show_message(window, title: str, text: str) -> None:
    """Draw one loading-screen frame (``title`` over ``text``) and show it: it stays on the
    window while the caller works in this thread (making the first view's tiles)."""
    import pyglet

    window.switch_to()
    window.dispatch_events()
    window.clear()
    for label_text, size, dy, colour in ((title, 24, 24, (235, 240, 245, 255)),
                                         (text, 12, -16, (190, 205, 215, 255))):
        pyglet.text.Label(label_text, font_size=size, anchor_x="center", anchor_y="center",
                          x=window.width // 2, y=window.height // 2 + dy, color=colour).draw()
    window.flip()


def _loading_text(progress: CompileProgress) -> str:
    dots = "." * (1 + int(time.monotonic() * 3) % 3)
    return f"loading{dots}"
