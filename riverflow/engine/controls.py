"""Keyboard input as data: which keys are held, which were pressed this frame, and scripts of
key presses per frame that drive the demo without a window (tests, headless runs).

Keys are named as pyglet names them (``pyglet.window.key.symbol_string``: ``"W"``, ``"UP"``,
``"SPACE"``, ``"_1"``, ``"F2"``…), so a window and a script speak the same language. A script
may also write a key as it is on the keyboard: ``3`` for pyglet's ``_3``, ``+`` / ``-`` for
``PLUS`` / ``MINUS``, ``ESC`` for ``ESCAPE``; letters in either case.

Script text, one event per line (``#`` starts a comment)::

    0    W      down     # hold W from frame 0
    240  W      up
    300  3      tap      # press and release 3 at frame 300
"""
from __future__ import annotations

from collections.abc import Collection
from dataclasses import dataclass, field

KINDS = ("down", "up", "tap")
ALIASES = {"+": "PLUS", "-": "MINUS", "=": "EQUAL", "ESC": "ESCAPE", "RETURN": "ENTER"}
"""Keys a script may write as on the keyboard → pyglet's names (digits too: ``3`` → ``_3``)."""


def key_name(word: str) -> str:
    """pyglet's name of a key as a script writes it (``3`` → ``_3``, ``w`` → ``W``)."""
    name = word.upper()
    if len(name) == 1 and name.isdigit():
        return f"_{name}"
    return ALIASES.get(name, name)


@dataclass
class InputState:
    """Keys held now, and keys pressed since the last :meth:`end_frame`."""

    held: set[str] = field(default_factory=set)
    pressed: list[str] = field(default_factory=list)

    def key_down(self, name: str) -> None:
        if name not in self.held:
            self.pressed.append(name)
        self.held.add(name)

    def key_up(self, name: str) -> None:
        self.held.discard(name)

    def any_held(self, *names: str) -> bool:
        return any(n in self.held for n in names)

    def end_frame(self) -> None:
        self.pressed.clear()


@dataclass(frozen=True)
class KeyEvent:
    frame: int
    key: str
    kind: str  # "down", "up" or "tap"


class KeyScript:
    """Key events by frame, fed to an :class:`InputState` frame by frame."""

    def __init__(self, events: list[KeyEvent] | list[tuple[int, str, str]] = ()) -> None:
        parsed = []
        for event in events:
            e = event if isinstance(event, KeyEvent) else KeyEvent(int(event[0]), str(event[1]),
                                                                   str(event[2]))
            if e.kind not in KINDS:
                raise ValueError(f"key event {e}: kind must be one of {', '.join(KINDS)}")
            if e.frame < 0:
                raise ValueError(f"key event {e}: frame must be ≥ 0")
            parsed.append(e)
        self.events = sorted(parsed, key=lambda e: e.frame)
        self._releases: dict[int, list[str]] = {}

    @classmethod
    def from_text(cls, text: str, source: str = "<script>",
                  keys: Collection[str] | None = None) -> KeyScript:
        """Parse the module's script format; errors name the source and the line. ``keys``:
        the pyglet names a game reacts to; any other key is an error (a typo would otherwise
        do nothing, silently)."""
        if not isinstance(text, str):
            raise TypeError(f"KeyScript.from_text: text must be the script's text (str), got "
                            f"{type(text).__name__} {text!r:.60}")
        events = []
        for number, line in enumerate(text.splitlines(), start=1):
            words = line.split("#", 1)[0].split()
            if not words:
                continue
            if len(words) != 3 or not words[0].isdigit() or words[2] not in KINDS:
                raise ValueError(f"{source}:{number}: expected 'FRAME KEY down|up|tap', "
                                 f"got {line.strip()!r}")
            key = key_name(words[1])
            if keys is not None and key not in keys:
                raise ValueError(f"{source}:{number}: unknown key {words[1]!r}; keys: "
                                 f"{', '.join(_spoken(k) for k in keys)}")
            events.append(KeyEvent(int(words[0]), key, words[2]))
        return cls(events)

    @property
    def last_frame(self) -> int:
        return self.events[-1].frame if self.events else 0

    def feed(self, frame: int, state: InputState) -> None:
        """Apply the events of ``frame`` (taps are released on the next frame)."""
        for key in self._releases.pop(frame, []):
            state.key_up(key)
        for e in self.events:
            if e.frame == frame:
                if e.kind == "up":
                    state.key_up(e.key)
                else:
                    state.key_down(e.key)
                    if e.kind == "tap":
                        self._releases.setdefault(frame + 1, []).append(e.key)


def _spoken(name: str) -> str:
    """A pyglet key name as a script may write it (``_3`` → ``3``)."""
    return name[1:] if len(name) == 2 and name[0] == "_" and name[1].isdigit() else name


DRAG_REACH = 1.83
"""drag_weight is 0 beyond this many spreads (it is ½ at 0.83, as a Gaussian exp(−u²))."""


def drag_weight(u):
    """How far a point ``u`` spreads along the arc from the one dragged moves with it: 1 there,
    smoothly (twice differentiable) down to exactly 0 at DRAG_REACH spreads, a Gaussian's
    shape with compact support (a Gaussian moves every point of the river by some 1e-13 m,
    so an edit would change its water, and remake its tiles, for kilometres)."""
    import numpy as np

    t = np.clip(1.0 - (np.asarray(u, np.float64) / DRAG_REACH) ** 2, 0.0, None)
    return t * t * t


class CentreLineDrag:
    """The mouse drags a river's centre line (the demo's edit mode; issue 25 live edits).

    :meth:`press` picks the centre-line point nearest the cursor on screen (within
    ``reach_px``), :meth:`drag` moves it under the cursor on the water's plane there and
    bends the line around it (:func:`drag_weight` along the arc, ``falloff`` river widths
    wide: the points farther than ~1.8 × that stay exactly where they were, and so does the
    water there; the ends stay put), asking the world for the edit in the background
    (:meth:`~riverflow.engine.world.RiverWorld.move_axis` with ``wait=False``: a drag asks
    each frame, only the newest waiting edit is made), :meth:`release` lets go. Pixels have
    their origin at the bottom left, as the camera's.
    """

    def __init__(self, reach_px: float = 40.0, falloff: float = 3.0) -> None:
        self.reach_px = float(reach_px)
        self.falloff = float(falloff)
        self.link: int | None = None
        """The branch held (an index of ``world.scene.branches``), None when none is."""
        self._line = None
        self._index = 0
        self._level = 0.0
        self.last = None
        """The last edit asked for (a ``concurrent.futures.Future``)."""

    def press(self, world, x_px: float, y_px: float) -> bool:
        """Pick the centre-line point nearest (x_px, y_px); returns whether one was near."""
        import numpy as np

        best = None
        for k, b in enumerate(world.scene.branches):
            line = np.asarray(b.centerline_m, np.float64)
            level = np.asarray(world.scene.water.level(line), np.float64)
            screen, _, in_front = world.camera.world_to_screen(np.c_[line, level])
            d = np.hypot(screen[:, 0] - x_px, screen[:, 1] - y_px)
            d[~in_front] = np.inf
            i = int(np.argmin(d))
            if d[i] <= self.reach_px and (best is None or d[i] < best[0]):
                best = (float(d[i]), k, i, float(level[i]))
        if best is None:
            self.link = None
            return False
        _, self.link, self._index, self._level = best
        self._line = np.array(world.scene.branches[self.link].centerline_m, np.float64)
        return True

    def drag(self, world, x_px: float, y_px: float):
        """Move the held point under (x_px, y_px); returns the edit's Future (None when no
        branch is held or the cursor's ray misses the water's plane)."""
        import numpy as np

        if self.link is None:
            return None
        origin, direction = world.camera.screen_to_ray([(x_px, y_px)])
        dz = float(direction[0, 2])
        if abs(dz) < 1e-6:
            return None
        t = (self._level - float(origin[0, 2])) / dz
        if not t > 0:
            return None
        target = origin[0, :2] + t * direction[0, :2]
        line = self._line
        arc = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(line, axis=0).T))])
        width = float(np.asarray(world.scene.branches[self.link].widths_m)[self._index])
        spread = max(self.falloff * width, 2.0 * float(arc[-1]) / max(len(line) - 1, 1))
        weight = drag_weight((arc - arc[self._index]) / spread)
        weight[[0, -1]] = 0.0
        moved = line + weight[:, None] * (target - line[self._index])[None, :]
        self.last = world.move_axis(self.link, moved, wait=False)
        return self.last

    def release(self) -> None:
        self.link = None
        self._line = None
