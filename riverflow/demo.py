"""The playable boat demo: a river world, the player's boat, cameras, keys and a HUD.

:class:`BoatDemo` is the game without a window: it owns the :class:`RiverWorld`, the boat, the
camera rigs and the input state, and steps at a fixed rate. :func:`run_window` puts it in a
pyglet window (fixed-step loop, resize, vsync, HUD, help overlay); :func:`run_headless` feeds
it a :class:`~riverflow.engine.controls.KeyScript` frame by frame and writes PNG frames and an
animated GIF — what ``make demo`` does on a machine with no display, and what tests drive.
The HUD (fps, ms a frame, particles, ms per system, and a legend of the colours of the debug
mode on screen: :func:`riverflow.components.display.legend`) is on both.

Keys (pyglet names) — also shown by the help overlay (H):

========================  ==============================================================
W / S, UP / DOWN          throttle forward / back (free camera: fly forward / back)
A / D, LEFT / RIGHT       rudder left / right (free camera: strafe)
Q / E                     free camera: down / up; mouse drag turns it
C                         chase camera ↔ free-fly camera
1 … 7                     water: none, mesh, coverage, advected, pre-advected, non-advected,
                          foam
G / P / V                 sprite grid / particles / velocity arrows on or off
SPACE                     pause the particles
+ / −                     flow speed factor up / down
T                         next wave tile (animated, Perlin, static)
R                         rain on / off (streaks, ripple rings on the water)
M                         reflections of the banks, boat and props on / off
F2                        screenshot to PNG
H, F1                     help overlay;  ESCAPE quits
========================  ==============================================================
"""
from __future__ import annotations

import math
import re
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from riverflow._atomic import atomic_files
from riverflow.components.display import DisplayMode, legend
from riverflow.components.waves import WaveKind
from riverflow.engine.camera_rigs import ChaseCamera, FreeFlyCamera
from riverflow.engine.config import RiverConfig
from riverflow.engine.controls import CentreLineDrag, InputState, KeyScript
from riverflow.engine.game_loop import FixedStep
from riverflow.engine.world import RiverWorld

STEP_S = 1.0 / 60.0
RAIN_DROPS_PER_S = 3000.0
"""The demo's rain (key R): new drops a second in the view."""
MODE_KEYS = {"_1": DisplayMode.NONE, "_2": DisplayMode.MESH, "_3": DisplayMode.COVERAGE,
             "_4": DisplayMode.ADVECTED, "_5": DisplayMode.PRE_ADVECTED,
             "_6": DisplayMode.NON_ADVECTED, "_7": DisplayMode.FOAM}
KEYS = frozenset({"W", "S", "A", "D", "UP", "DOWN", "LEFT", "RIGHT", "Q", "E", "C", *MODE_KEYS,
                  "G", "P", "V", "T", "R", "M", "SPACE", "PLUS", "EQUAL", "NUM_ADD", "MINUS",
                  "NUM_SUBTRACT", "H", "F1", "F2", "ESCAPE", "X"})
"""The keys the demo reacts to (pyglet names); a key script naming another is an error."""
HELP = """riverflow boat demo
W/S or UP/DOWN   throttle        A/D or LEFT/RIGHT  rudder
C  chase / free camera (free: WASD, Q/E, mouse drag)
1-7  water: none, mesh, coverage, advected, pre-advected, non-advected, foam
G grid   P particles   V velocity arrows   T wave tile   R rain   M reflections
SPACE pause particles   +/- flow speed   F2 screenshot
X edit mode: drag a river's centre line with the mouse
H help   ESC quit"""

DEFAULT_SCRIPT = """# the scripted run of `riverflow demo --headless` (make demo with no display)
0    W    down     # full throttle down the river
150  D    down     # turn to starboard, towards the bank
210  D    up
300  A    down     # and back
390  A    up
420  3    tap      # coverage view
480  4    tap      # advected wave sprites again
480  P    tap      # particles on
540  P    tap      # and off
560  W    up       # drift with the flow
"""


@dataclass
class Hud:
    """What the HUD shows, refreshed every frame."""

    fps: float = 0.0
    frame_ms: float = 0.0
    """Wall time of a frame (window: between draws; headless: step + draw + read-back)."""
    particles: int = 0
    timings_ms: dict[str, float] = field(default_factory=dict)
    message: str = ""
    message_until_s: float = 0.0

    def lines(self, demo: BoatDemo) -> list[str]:
        boat = demo.boat_state
        speed = float(np.hypot(*boat.velocity_mps))
        world = demo.world
        display = world.display
        mode = display.mode.name.lower().replace("_", "-")
        mode += "".join(f" + {name}" for name, on in (("grid", display.show_grid),
                                                       ("particles", display.show_particles),
                                                       ("arrows", display.show_velocities))
                        if on)
        if not display.reflections:
            mode += " (no reflections)"
        total = sum(v for k, v in self.timings_ms.items() if k != "draw")
        rate = f"{self.fps:5.1f} fps {self.frame_ms:5.1f} ms   " if self.fps > 0 else ""
        out = [f"{rate}{self.particles} particles   "
               f"{'PAUSED   ' if world.paused else ''}flow x{world.speed_factor:g}"
               f"{f'   rain {len(world.rain_drops)} drops (R)' if demo.raining else ''}",
               f"boat {speed:4.1f} m/s  throttle {boat.throttle:+.1f}  rudder {boat.rudder:+.1f}"
               f"   camera {demo.camera_mode}   water {mode}",
               f"simulation {total:.2f} ms: " + "  ".join(
                   f"{k} {v:.2f}" for k, v in self.timings_ms.items() if k != "draw"),
               f"draw {self.timings_ms.get('draw', 0.0):.2f} ms (CPU)   H: help"]
        if demo.edit_mode:
            errors = world.edit_errors
            out.append("EDIT MODE (X): drag a river's centre line"
                       + (f"   last refused: {errors[-1][:60]}" if errors else ""))
        if self.message and time.monotonic() < self.message_until_s:
            out.append(self.message)
        return out

    @staticmethod
    def legend(demo: BoatDemo) -> list[tuple[tuple[int, int, int] | None, str]]:
        """What the colours on screen mean: (8-bit RGB swatch or None, text) per line."""
        return legend(demo.world.display)


class BoatDemo:
    """The game, window-less: world, boat, camera rigs, input → actions, fixed steps.

    Args:
        scene: the landscape (default: :func:`riverflow.default_scene`).
        size: viewport (W, H) [px].
        seed: seeds the world.
        config: the world's :class:`RiverConfig`.
        gl: draw (the HUD, screenshots and headless frames need it).
        screenshots: folder for F2 screenshots.
    """

    def __init__(self, scene=None, size=(1280, 720), *, seed: int = 0,
                 config: RiverConfig | None = None, gl: bool = True,
                 screenshots: Path = Path("out/screenshots")) -> None:
        if scene is None:
            from riverflow.scenes.default import default_scene

            scene = default_scene(seed=seed)
        self.scene = scene
        self.world = RiverWorld(scene, size=size, gl=gl, seed=seed, config=config)
        position, heading = _start_pose(scene)
        self.boat = self.world.add_boat(position, heading_rad=heading,
                                        **_boat_size(scene, position))
        self.dam = release_dam(self.world, after_s=DAM_BREAK_AFTER_S) if _has_dam(scene) else None
        """The dam's release (the outlet link, its times [s] and discharges [m³/s]) in a
        ``default_scene(dam=True)`` (``riverflow demo --dam``), else None."""
        self.chase = ChaseCamera()
        self.free = FreeFlyCamera()         # placed at the chase view when switched to
        self.camera_mode = "chase"
        self.input = InputState()
        self.loop = FixedStep(STEP_S)
        self.frame = 0
        self.hud = Hud()
        self.show_help = False
        self.raining = False
        self.quit_requested = False
        self.screenshots = Path(screenshots)
        self.screenshot_count = 0
        self.edit_mode = False
        """Key X: the mouse drags rivers' centre lines (live edits) instead of the camera."""
        self.drag = CentreLineDrag()
        self._place_chase(0.0)

    @property
    def boat_state(self):
        """The boat's component (position, heading, velocity, throttle, rudder…)."""
        return self.world.boat(self.boat)

    # -- one fixed step ------------------------------------------------------------------------

    def step(self, dt_s: float = STEP_S) -> None:
        """Apply this frame's input, move the camera rig, step the world."""
        self._apply_input(dt_s)
        if self.camera_mode == "chase":
            self._place_chase(dt_s)
        else:
            self.free.update(self.world.camera)
        self.world.step(dt_s)
        self.hud.particles = len(self.world.particles)
        self.hud.timings_ms = dict(self.world.timings_ms)
        self.input.end_frame()
        self.frame += 1

    def _place_chase(self, dt_s: float) -> None:
        boat = self.boat_state
        z = float(boat.altitude_m)
        self.chase.update(self.world.camera, (*boat.position_m, z), float(boat.heading_rad),
                          dt_s)

    def _apply_input(self, dt_s: float) -> None:
        inp = self.input
        for key in inp.pressed:
            self._action(key)
        forward = float(inp.any_held("W", "UP")) - float(inp.any_held("S", "DOWN"))
        port = float(inp.any_held("A", "LEFT")) - float(inp.any_held("D", "RIGHT"))
        boat = self.boat_state
        if self.camera_mode == "chase":
            boat.throttle = forward
            boat.rudder = port               # rudder +1 turns to port (counter-clockwise)
        else:
            boat.throttle = boat.rudder = 0.0
            up = float(inp.any_held("E")) - float(inp.any_held("Q"))
            self.free.move(forward, -port, up, dt_s)

    def _action(self, key: str) -> None:
        world, display = self.world, self.world.display
        if key in MODE_KEYS:
            display.mode = MODE_KEYS[key]
        elif key == "G":
            display.show_grid = not display.show_grid
        elif key == "P":
            display.show_particles = not display.show_particles
        elif key == "V":
            display.show_velocities = not display.show_velocities
        elif key == "SPACE":
            world.paused = not world.paused
        elif key in ("PLUS", "EQUAL", "NUM_ADD"):
            world.speed_factor = min(world.speed_factor * 1.5, 20.0)
        elif key in ("MINUS", "NUM_SUBTRACT"):
            world.speed_factor = max(world.speed_factor / 1.5, 0.05)
        elif key == "R":
            self.raining = not self.raining
            world.set_rain(RAIN_DROPS_PER_S if self.raining else 0.0)
        elif key == "M":
            display.reflections = not display.reflections
        elif key == "T":
            kinds = list(WaveKind)
            display.wave = kinds[(kinds.index(display.wave) + 1) % len(kinds)]
        elif key == "C":
            if self.camera_mode == "chase":
                cam = world.camera
                self.free = FreeFlyCamera.from_view(cam.position, cam.target)
                self.camera_mode = "free"
            else:
                self.camera_mode = "chase"
        elif key == "X":
            self.edit_mode = not self.edit_mode
            self.drag.release()
            self.hud.message = ("edit mode: drag a river's centre line" if self.edit_mode
                                else "edit mode off")
            self.hud.message_until_s = time.monotonic() + 3.0
        elif key in ("H", "F1"):
            self.show_help = not self.show_help
        elif key == "F2":
            path = self.screenshot()
            self.hud.message = f"screenshot: {path}"
            self.hud.message_until_s = time.monotonic() + 3.0
        elif key == "ESCAPE":
            self.quit_requested = True

    # -- output --------------------------------------------------------------------------------

    def screenshot(self, path: Path | None = None) -> Path:
        """Draw the current frame and write it as a PNG; returns the path."""
        from riverflow.images import save_png

        if path is None:
            self.screenshot_count += 1
            path = self.screenshots / f"riverflow-{self.frame:06d}-{self.screenshot_count}.png"
        return save_png(self.world.render(), path)

    def close(self) -> None:
        """Release the world (idempotent)."""
        if self.world is not None:
            self.world.close()
            self.world = None


DAM_BREAK_AFTER_S = 5.0
"""In a scene with a dam (``riverflow demo --dam``) the dam breaks this long after the start."""


def _has_dam(scene) -> bool:
    from riverflow.scenes.default import DAM_OUTLET

    return any(b.name == DAM_OUTLET for b in getattr(scene, "branches", ()))


def release_dam(world, *, factor: float = 8.0, head_m: float = 6.0, area_m2: float = 4e5,
                after_s: float = 0.0, duration_s: float = 4 * 3600.0):
    """Break the dam of a ``default_scene(dam=True)`` world ``after_s`` [s] of the flood's
    clock from now: its outflow jumps from the base flow Q₀ of the outlet link
    (:data:`~riverflow.scenes.default.DAM_OUTLET`) to ``factor`` Q₀ and falls back as the
    reservoir (``area_m2`` [m²], ``head_m`` [m] over the breach) empties
    (:func:`~riverflow.hydro.flood.level_pool_release`: a breach as wide as makes that peak);
    the release is the outlet's hydrograph (``world.set_hydrograph``), routed downstream from
    the dam. Returns (link name, times [s], discharges [m³/s]).

    Raises:
        ValueError: the world's scene has no dam, or a bad number (naming it).
    """
    from riverflow.hydro.flood import BROAD_CRESTED_WEIR, level_pool_release
    from riverflow.scenes.default import DAM_OUTLET

    if not _has_dam(world.scene):
        raise ValueError(f"release_dam: the scene has no branch {DAM_OUTLET!r}: build it with "
                         f"default_scene(..., dam=True)")
    if not (math.isfinite(factor) and factor > 0 and math.isfinite(after_s) and after_s >= 0):
        raise ValueError(f"release_dam: factor must be > 0 and after_s ≥ 0, got {factor!r}, "
                         f"{after_s!r}")
    if world.flood is None:
        world.set_hydrograph(None, [], None)            # the flood router, no change yet
    router = world.flood
    q0 = float(router.net.link_q0[router.link_index(DAM_OUTLET)])
    width = factor * q0 / (BROAD_CRESTED_WEIR * head_m ** 1.5)
    t, q = level_pool_release(area_m2, head_m, width, q0, duration_s)
    now = world.flood_time_s
    times = np.concatenate([[now], now + after_s + 1.0 + t])
    flows = np.concatenate([[q0], q])
    world.set_hydrograph(DAM_OUTLET, times, flows)
    return DAM_OUTLET, times, flows


FALL_START_M = 45.0
"""In a scene with falls the boat starts this far above the first one's lip, heading for it
(the chase camera then passes the fall: ``riverflow demo --falls``)."""


def _start_pose(scene) -> tuple[np.ndarray, float]:
    """A point a fifth of the way down the main river and the downstream heading there; in a
    scene with falls, FALL_START_M above the first fall's lip, heading downstream to it."""
    from riverflow.scenes.flight import main_centerline

    falls = getattr(getattr(scene, "graph", None), "falls", None)
    if falls:
        f = falls[0]
        t = np.asarray(f.direction, np.float64)
        return _onto_axis(scene, np.asarray(f.centre_m, np.float64) - FALL_START_M * t,
                          math.atan2(t[1], t[0]))

    line = main_centerline(scene)
    s = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(line, axis=0).T))])
    at = 0.2 * s[-1]
    i = int(np.searchsorted(s, at))
    p = np.array([np.interp(at, s, line[:, 0]), np.interp(at, s, line[:, 1])])
    d = line[min(i + 1, len(line) - 1)] - line[max(i - 1, 0)]
    return _onto_axis(scene, p, math.atan2(d[1], d[0]))


def _onto_axis(scene, p: np.ndarray, heading: float) -> tuple[np.ndarray, float]:
    """``p`` moved onto the nearest river axis of the scene's graph: the flight's centre line
    is resampled every 10 m, which on a narrow winding creek (GIS data) cuts its corners onto
    the banks. The heading is kept, turned to the axis' direction there."""
    from riverflow.hydro.nearest import PolylineIndex

    graph = getattr(scene, "graph", None)
    if graph is None or not graph.axes():
        return p, heading
    best = None
    for a in graph.axes():
        index = PolylineIndex(graph.polyline(a))
        dist, q, arc = index.nearest(p[None])
        if best is None or dist[0] < best[0]:
            best = (dist[0], q[0], index, arc[0])
    _, q, index, arc = best
    k = int(np.clip(np.searchsorted(index.s0, arc, side="right") - 1, 0, len(index.d) - 1))
    t = index.d[k]
    along = math.atan2(t[1], t[0])
    if math.cos(along - heading) < 0:      # the axis may be drawn upstream
        along += math.pi
    return q, along


def _boat_size(scene, position: np.ndarray) -> dict[str, float]:
    """The boat's size on the scene's river at ``position``: the Boat's default (8 × 3 m), or
    smaller where the river is narrower than three beams (a creek from GIS data is 2 m wide):
    beam a third of the width, the hull as long as it is in proportion."""
    water = getattr(scene, "water", None)
    if water is None:
        return {}
    width = float(water.nearest(np.asarray(position, np.float64).reshape(1, 2))[2][0])
    beam = width / 3.0
    if not (np.isfinite(beam) and beam < 3.0):
        return {}
    return {"beam_m": beam, "length_m": 8.0 * beam / 3.0}


# -- headless ------------------------------------------------------------------------------------

@dataclass
class HeadlessRun:
    """What :func:`run_headless` wrote, the boat's path (F, 3) (x, y [m], heading [rad]) and
    the HUD's lines on the last frame written."""

    frames: list[Path]
    animation: Path | None
    path: np.ndarray
    hud: list[str] = field(default_factory=list)


def fit_lines(lines: list[str], width_px: float, measure) -> list[str]:
    """The HUD's ``lines`` wrapped to ``width_px`` (``measure(text)`` gives a text's width in
    pixels): a line breaks between its fields (runs of two or more spaces), then between
    words; continuation lines are indented. A narrow window shows every field."""
    out: list[str] = []
    for text in lines:
        line = ""
        for field_ in re.split(r" {2,}", text.strip()):
            for part in ([field_] if measure(field_) <= width_px else field_.split(" ")):
                trial = f"{line}   {part}" if line.strip() else f"{line}{part}"
                if line.strip() and measure(trial) > width_px:
                    out.append(line)
                    line = "  " + part
                else:
                    line = trial
        out.append(line)
    return out


def draw_hud(image, lines: list[str], entries: list) -> None:
    """Write the HUD's ``lines`` (top left) and the colour legend ``entries`` (bottom left,
    a swatch per colour) onto a PIL RGBA ``image``, on translucent panels."""
    from PIL import Image, ImageDraw, ImageFont

    font = ImageFont.load_default(size=10)
    step = 12
    panel = Image.new("RGBA", image.size, (0, 0, 0, 0))
    shade = ImageDraw.Draw(panel)
    lines = fit_lines(lines, image.size[0] - 16, lambda t: shade.textlength(t, font=font))

    def box(x0, y0, texts, pad):
        if texts:
            w = max(shade.textlength(t, font=font) for t in texts) + pad + 8
            shade.rectangle((x0 - 4, y0 - 3, x0 + w, y0 + step * len(texts) + 1),
                            fill=(0, 0, 0, 110))
    box(6, 4, lines, 0)
    y_legend = image.size[1] - 6 - step * len(entries)
    box(6, y_legend, [t for _, t in entries], 14)
    image.alpha_composite(panel)
    draw = ImageDraw.Draw(image)
    for k, line in enumerate(lines):
        draw.text((6, 4 + step * k), line, fill=(255, 255, 255, 255), font=font)
    for k, (colour, text) in enumerate(entries):
        y = y_legend + step * k
        if colour is not None:
            draw.rectangle((6, y + 2, 14, y + 10), fill=(*colour, 255),
                           outline=(255, 255, 255, 160))
        draw.text((20, y), text, fill=(255, 255, 255, 255), font=font)


def run_headless(frames: int, out: Path, *, scene=None, size=(640, 360), seed: int = 0,
                 script: KeyScript | None = None, every: int = 10,
                 config: RiverConfig | None = None, hud: bool = True) -> HeadlessRun:
    """Play ``frames`` fixed steps of the demo with ``script`` (default: the built-in run) and
    no window; write every ``every``-th frame (and the last) as ``out/frame_NNNNN.png`` and all
    of them as ``out/demo.gif``, with the HUD (``hud``: fps and ms of the frame as measured
    here — step, draw and read-back —, particles, ms per system, the colour legend).
    Deterministic: flow tiles are made in the frame, so the same seed and script give the same
    path and, but for the HUD's measured times (``hud=False``), the same frames."""
    import dataclasses

    from PIL import Image

    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    config = dataclasses.replace(config or RiverConfig(), tile_production="blocking")
    script = script if script is not None else KeyScript.from_text(DEFAULT_SCRIPT, "built-in")
    demo = BoatDemo(scene, size, seed=seed, config=config, screenshots=out)
    written, stills, path, lines = [], [], [], []
    try:
        for f in range(frames):
            script.feed(f, demo.input)
            t0 = time.perf_counter()
            demo.step(STEP_S)
            step_ms = (time.perf_counter() - t0) * 1e3
            boat = demo.boat_state
            path.append((*boat.position_m, boat.heading_rad))
            if f % every == 0 or f == frames - 1:
                t0 = time.perf_counter()
                image = Image.fromarray(demo.world.render())
                frame_ms = step_ms + (time.perf_counter() - t0) * 1e3
                demo.hud.frame_ms = frame_ms
                demo.hud.fps = 1e3 / max(frame_ms, 1e-3)
                demo.hud.timings_ms = dict(demo.world.timings_ms)   # with this frame's draw
                if hud:
                    lines = demo.hud.lines(demo)
                    draw_hud(image, lines, demo.hud.legend(demo))
                file = out / f"frame_{f:05d}.png"
                with atomic_files(file) as (temp,):
                    image.save(temp)
                written.append(file)
                stills.append(image.convert("RGB").resize((size[0] // 2, size[1] // 2)))
    finally:
        demo.close()
    animation = None
    if stills:
        animation = out / "demo.gif"
        with atomic_files(animation) as (temp,):
            stills[0].save(temp, save_all=True, append_images=stills[1:],
                           duration=int(round(1000 * every * STEP_S)), loop=0)
    return HeadlessRun(written, animation, np.asarray(path, np.float64), lines)


# -- window --------------------------------------------------------------------------------------

def run_window(*, scene=None, size=(1280, 720), seed: int = 0, frames: int | None = None,
               config: RiverConfig | None = None) -> int:
    """Play in a pyglet window until ESCAPE or the window closes (or ``frames`` drawn
    frames, for smoke tests). Returns the frames drawn."""
    import pyglet
    from pyglet.window import key as keys

    gl_config = pyglet.gl.Config(double_buffer=True, depth_size=24, major_version=3,
                                 minor_version=3, forward_compatible=True)
    window = pyglet.window.Window(*size, caption="riverflow — boat demo", resizable=True,
                                  vsync=True, config=gl_config)
    import dataclasses

    from riverflow.engine.loading import compile_with_loading_screen, show_message

    if compile_with_loading_screen(window, ("scene", "world", "draw"),
                                   title="riverflow — boat demo").closed:
        window.close()                # closed while the kernels compiled
        return 0
    # a player steers live: a frame never waits for a tile (the scripted headless run waits)
    config = dataclasses.replace(config or RiverConfig(), deterministic=False)
    show_message(window, "riverflow — boat demo", "making the river's first view…")
    demo = BoatDemo(scene, window.get_framebuffer_size(), seed=seed, config=config)
    demo.world.load_view()          # the first drawn frame has its tiles and its particles
    batch = pyglet.graphics.Batch()
    back, front = pyglet.graphics.Group(order=0), pyglet.graphics.Group(order=1)
    shade = pyglet.shapes.Rectangle(0, window.height - 96, window.width, 96,
                                    color=(0, 0, 0, 110), batch=batch, group=back)
    hud = pyglet.text.Label("", x=10, y=window.height - 10, anchor_y="top", multiline=True,
                            width=max(window.width - 20, 100), font_size=11, batch=batch,
                            group=front, color=(255, 255, 255, 255))
    help_label = pyglet.text.Label(HELP, x=10, y=10, anchor_y="bottom", multiline=True,
                                   width=max(window.width - 20, 100), font_size=12,
                                   color=(255, 255, 210, 255))
    legend_panel = _WindowLegend()
    drawn = [0]
    clock = {"last": time.perf_counter(), "fps": 0.0}

    def on_key_press(symbol, modifiers):
        demo.input.key_down(keys.symbol_string(symbol))
        return pyglet.event.EVENT_HANDLED  # ESCAPE quits through the demo, not pyglet

    def on_key_release(symbol, modifiers):
        demo.input.key_up(keys.symbol_string(symbol))

    def to_framebuffer(x, y):
        fw, fh = window.get_framebuffer_size()
        return x * fw / max(window.width, 1), y * fh / max(window.height, 1)

    def on_mouse_press(x, y, buttons, modifiers):
        if demo.edit_mode:
            demo.drag.press(demo.world, *to_framebuffer(x, y))

    def on_mouse_release(x, y, buttons, modifiers):
        demo.drag.release()

    def on_mouse_drag(x, y, dx, dy, buttons, modifiers):
        if demo.edit_mode:
            demo.drag.drag(demo.world, *to_framebuffer(x, y))
        elif demo.camera_mode == "free":
            demo.free.turn(dx, dy)

    def on_resize(width, height):
        fw, fh = window.get_framebuffer_size()
        demo.world.camera.set_viewport(fw, fh)
        hud.y, hud.width = height - 10, max(width - 20, 100)
        shade.y, shade.width = height - 96, width
        help_label.width = max(width - 20, 100)

    def on_draw():
        window.clear()
        fw, fh = window.get_framebuffer_size()
        if fw > 0 and fh > 0:
            demo.world.draw()
            demo.world.blit_to_window(fw, fh)
        hud.text = "\n".join(demo.hud.lines(demo))
        shade.height = hud.content_height + 16        # the lines wrap in a narrow window
        shade.y = window.height - shade.height
        batch.draw()
        if demo.show_help:
            help_label.draw()
        else:
            legend_panel.draw(demo.hud.legend(demo))
        if drawn[0] == 0:         # the loading screen made the first view: water, particles
            print(f"riverflow demo: first frame drawn with {demo.world.pool.alive.sum()} "
                  "particles", flush=True)
        drawn[0] += 1
        now = time.perf_counter()
        dt = now - clock["last"]
        clock["last"] = now
        if dt > 0:
            clock["fps"] = 0.9 * clock["fps"] + 0.1 / dt if clock["fps"] else 1.0 / dt
        demo.hud.fps = clock["fps"]
        demo.hud.frame_ms = 1e3 / clock["fps"] if clock["fps"] > 0 else 0.0
        if frames is not None and drawn[0] >= frames:
            demo.quit_requested = True

    def quit_game():
        pyglet.clock.unschedule(tick)
        demo.close()                  # GPU objects go while the window's context lives
        window.close()
        pyglet.app.exit()

    def on_close():
        quit_game()
        return pyglet.event.EVENT_HANDLED

    def tick(dt):
        for _ in range(demo.loop.advance(dt)):
            demo.step(STEP_S)
        if demo.quit_requested:
            quit_game()

    # pushed as a frame of their own: after the loading screen pushed and removed its
    # handlers, pyglet's stack is an empty list, which window.event / set_handler fail on
    window.push_handlers(on_key_press=on_key_press, on_key_release=on_key_release,
                         on_mouse_drag=on_mouse_drag, on_mouse_press=on_mouse_press,
                         on_mouse_release=on_mouse_release, on_resize=on_resize, on_draw=on_draw,
                         on_close=on_close)
    pyglet.clock.schedule(tick)
    try:
        pyglet.app.run(interval=0)
    finally:
        demo.close()
    return drawn[0]


class _WindowLegend:
    """The colour legend of the window's HUD (bottom left): a swatch and a label per line,
    remade when the lines change (a key switched the mode or an overlay)."""

    LINE_PX = 17

    def __init__(self) -> None:
        self.entries: list = []
        self.batch = None
        self.items: list = []

    def draw(self, entries: list) -> None:
        if entries != self.entries:
            self._build(entries)
        if self.batch is not None:
            self.batch.draw()

    def _build(self, entries: list) -> None:
        import pyglet

        self.entries = list(entries)
        self.batch = pyglet.graphics.Batch()
        back, front = pyglet.graphics.Group(order=0), pyglet.graphics.Group(order=1)
        n = len(entries)
        labels = [pyglet.text.Label(text, x=30, y=10 + self.LINE_PX * (n - 1 - k) + 1,
                                    font_size=10, color=(255, 255, 255, 255), batch=self.batch,
                                    group=front) for k, (_, text) in enumerate(entries)]
        width = max((label.content_width for label in labels), default=0) + 30
        self.items = [*labels, pyglet.shapes.Rectangle(4, 5, width, self.LINE_PX * n + 6,
                                                       color=(0, 0, 0, 110), batch=self.batch,
                                                       group=back)]
        for k, (colour, _) in enumerate(entries):
            if colour is not None:
                self.items.append(pyglet.shapes.Rectangle(
                    12, 10 + self.LINE_PX * (n - 1 - k) + 2, 11, 11, color=(*colour, 255),
                    batch=self.batch, group=front))
