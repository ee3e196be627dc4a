"""What the draw system shows: the display mode, debug overlays and the shading knobs.

A mutable resource of each world (``world.display``), toggled by games and the demo's keys.
:class:`DisplayMode` keeps Proland's ``MeshDisplayType`` numbers (reference §4.6); the GLSL
sees them as ``DISPLAY_MODE_*`` defines (:func:`riverflow.engine.gl.enum_defines`).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from enum import IntEnum

from riverflow.components.waves import WaveKind


class DisplayMode(IntEnum):
    """How the water is drawn."""

    NONE = 0
    """Ground only: no water surface (the carved bed shows)."""
    COVERAGE = 1
    """Red = sprites covering the pixel / 16, green where none covers, blue where the cell's
    list is full."""
    ADVECTED = 5
    """Per-pixel blending of the wave sprites carried by the particles (the paper's method)."""
    PRE_ADVECTED = 6
    """The same sum rasterised first, sprite by sprite, into a float target."""
    NON_ADVECTED = 10
    """The wave texture mapped in world space, not carried by the flow (for comparison)."""
    MESH = 11
    """The water mesh in one flat colour."""
    FOAM = 12
    """The foam the particles carry, alone: its amount blended like the sprites (ours)."""
    CONCENTRATION = 13
    """The spills' concentration (issue 24): log10 of it on a colour ramp over
    ``concentration_range_kg_m3`` (:func:`concentration_legend`), dark water below (ours)."""


@dataclass
class DisplaySettings:
    """Mode, overlays and shading parameters of the drawing (mutable: games toggle them)."""

    mode: DisplayMode = DisplayMode.ADVECTED
    show_grid: bool = False
    """Outline the sprite-indirection cells; full cells tinted green (Proland displayGrid)."""
    show_particles: bool = False
    """Particles as points coloured by flow status × intensity."""
    show_velocities: bool = False
    """An arrow per particle along its flow velocity."""
    wave: WaveKind = WaveKind.ANIMATED
    """Which wave tile the sprites sample."""
    wave_slope_factor: float = 0.2
    """Water normal = normalize(−slopes × this, 1); the tiles' slopes have RMS 1 (Proland
    waveSlopeFactor, whose tiles were not normalised)."""
    water_clarity_m: float = 2.5
    """Depth [m] over which the bed's light falls to 1/e."""
    fog_density_per_m: float = 1.0 / 6000.0
    """Exponential distance fog [1/m]."""
    arrow_s: float = 4.0
    """Velocity arrows are this many seconds of travel long."""
    fall_sheets: bool = True
    """The falls' falling sheets drawn over the water in the shaded modes
    (:mod:`riverflow.scenes.fall_sheets`); False: the water mesh alone (a cascade)."""
    rapids_wave_slope: float = 0.3
    """Slope of the standing waves on rapids where the surface is steepest (15 %; from 0 at
    2 %, ``shaders/rapids.glsl``); 0: none."""
    # -- spills (issue 24) --
    spill_visible_kg_m3: float = 1e-4
    """Concentration [kg/m³] at which a spill's colour covers 1 − 1/e of the water's (×0.75)
    in the normal look (per wave sprite, from the concentration its particle carries)."""
    concentration_range_kg_m3: tuple[float, float] = (1e-6, 1e-2)
    """The concentrations [kg/m³] at the two ends of the concentration mode's colour ramp."""
    concentration_legend: bool = True
    """The concentration mode draws its colour bar, with its values in kg/m³, into the frame
    (lower right; :mod:`riverflow.systems.legend`)."""
    # -- reflections (issue 12 item 3) --
    reflections: bool = True
    """Banks, props and sky mirrored in the water (a planar reflection pass at the level of
    the water in view, corrected per pixel for the river's slope); False: the sky
    alone is reflected, as before, and the pass is skipped."""
    reflection_scale: float = 0.5
    """Size of the reflection texture as a fraction of the viewport's (0 < scale ≤ 1); the
    wave distortion blurs it anyway, and its cost falls with the square of it."""
    reflection_distortion: float = 0.1
    """How far the wave normal bends the reflected rays (1: as the water normal says; 0: a
    flat mirror)."""

    def validate(self) -> None:
        """Raise ValueError naming the field if a value is not usable."""
        if type(self.mode) is not DisplayMode:      # (every frame: no enum call when it is)
            self.mode = DisplayMode(self.mode)
        if type(self.wave) is not WaveKind:
            self.wave = WaveKind(self.wave)
        lo, hi = self.concentration_range_kg_m3
        if not (math.isfinite(self.spill_visible_kg_m3) and self.spill_visible_kg_m3 > 0
                and math.isfinite(lo) and math.isfinite(hi) and 0 < lo < hi):
            raise ValueError("DisplaySettings: spill_visible_kg_m3 must be > 0 and "
                             "concentration_range_kg_m3 finite with 0 < low < high, got "
                             f"{self.spill_visible_kg_m3!r}, {self.concentration_range_kg_m3!r}")
        for name in ("wave_slope_factor", "water_clarity_m", "fog_density_per_m", "arrow_s",
                     "reflection_distortion", "rapids_wave_slope"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value >= 0):
                raise ValueError(f"DisplaySettings.{name} must be a finite number ≥ 0, "
                                 f"got {value!r}")
        scale = self.reflection_scale
        if not (isinstance(scale, (int, float)) and math.isfinite(scale) and 0 < scale <= 1):
            raise ValueError(f"DisplaySettings.reflection_scale must be in (0, 1], got {scale!r}")
        if type(self.reflections) is not bool:
            self.reflections = bool(self.reflections)


MODE_NAMES: dict[str, dict[str, object]] = {
    "none": {"mode": DisplayMode.NONE},
    "mesh": {"mode": DisplayMode.MESH},
    "coverage": {"mode": DisplayMode.COVERAGE},
    "advected": {"mode": DisplayMode.ADVECTED},
    "pre-advected": {"mode": DisplayMode.PRE_ADVECTED},
    "non-advected": {"mode": DisplayMode.NON_ADVECTED},
    "foam": {"mode": DisplayMode.FOAM},
    "concentration": {"mode": DisplayMode.CONCENTRATION},
    "grid": {"mode": DisplayMode.ADVECTED, "show_grid": True},
    "particles": {"mode": DisplayMode.ADVECTED, "show_particles": True},
    "velocities": {"mode": DisplayMode.ADVECTED, "show_velocities": True},
}
"""The display-mode names of the command line and the demo (SPEC §4) → settings."""

Colour = tuple[int, int, int]


def _rgb(r: float, g: float, b: float) -> Colour:
    """A shader's colour (0–1) as 8-bit RGB."""
    return (round(255 * r), round(255 * g), round(255 * b))


MODE_LEGENDS: dict[DisplayMode, list[tuple[Colour | None, str]]] = {
    DisplayMode.NONE: [(None, "water off: the carved river bed and the ground")],
    DisplayMode.MESH: [(_rgb(0.10, 0.35, 0.75), "the water mesh in one flat colour")],
    DisplayMode.COVERAGE: [
        (_rgb(1, 0, 0), "red: wave sprites covering the pixel, brighter = more (full at 16)"),
        (_rgb(0, 1, 0), "green: water no sprite covers (a hole in the particles)"),
        (_rgb(0, 0, 1), "blue: the pixel's grid cell lists 16 sprites, its most (full)"),
        (_rgb(1, 0, 1), "magenta: covered and in a full cell (red + blue)"),
    ],
    DisplayMode.ADVECTED: [(None, "wave sprites carried by the flow, blended per pixel")],
    DisplayMode.PRE_ADVECTED: [(None, "the same sprites, summed first into a float target")],
    DisplayMode.NON_ADVECTED: [(None, "the wave texture fixed in the world, not carried")],
    DisplayMode.FOAM: [
        (_rgb(1, 1, 1), "white: foam 1, the most a particle carries (blended like the sprites)"),
        (_rgb(0.02, 0.05, 0.16), "dark blue: no foam; grey between"),
    ],
    DisplayMode.CONCENTRATION: [],       # from the settings' range: concentration_legend
}
"""What each water mode's colours mean (``water.glsl``; the HUD and the README show it)."""

GRID_LEGEND: list[tuple[Colour | None, str]] = [
    (_rgb(0.8, 0.8, 0.8), "light lines: cells of the sprite grid (each lists up to 16)"),
    (_rgb(0, 1, 0), "green tint: a full cell (sprites beyond 16 are left out)"),
]
"""The sprite-grid overlay (``water.glsl``, ``u_show_grid``)."""

PARTICLE_LEGEND: list[tuple[Colour | None, str]] = [
    (_rgb(0, 0, 1), "blue: in the water (inside)"),
    (_rgb(0, 1, 0), "green: leaving the water, still drifting"),
    (_rgb(0, 0.5, 0.5), "teal: near, giving way to one inside"),
    (_rgb(1, 0, 0), "red: outside the water, stopped"),
    (_rgb(0.5, 0, 0.5), "purple: leaving the flow's domain"),
    (_rgb(1, 1, 0), "yellow: outside the flow's domain"),
    (_rgb(1, 1, 1), "white: on the sky"),
    (None, "dimmer = fading in or out; added to the picture: red on grass looks orange"),
]
"""Particles coloured by :class:`~riverflow.components.status.FlowStatus` × intensity
(``particles.glsl``)."""

ARROW_LEGEND: list[tuple[Colour | None, str]] = [
    (_rgb(1, 1, 0.3), "arrows: the flow at each particle, {arrow_s:g} s of travel; yellow slow"),
    (_rgb(1, 0.25, 0.1), "orange-red: 2 m/s or faster"),
]
"""Velocity arrows (``arrows.glsl``)."""


_SHADED = (DisplayMode.ADVECTED, DisplayMode.PRE_ADVECTED, DisplayMode.NON_ADVECTED)


CONCENTRATION_STOPS = ((0.05, 0.15, 0.60), (0.05, 0.70, 0.80), (0.20, 0.80, 0.20),
                       (0.95, 0.85, 0.10), (0.85, 0.10, 0.05))
"""The concentration mode's colour ramp, evenly spaced over log10(c) (``spill.glsl``'s
``concentration_ramp``)."""
NO_CONCENTRATION = (0.02, 0.05, 0.16)
"""The concentration mode's water below the ramp's range."""


def concentration_colour(c_kg_m3, settings: DisplaySettings) -> np.ndarray:
    """The concentration mode's linear RGB (..., 3) for concentrations [kg/m³] (the numpy twin
    of ``spill.glsl``'s ``concentration_colour``)."""
    import numpy as np

    c = np.asarray(c_kg_m3, np.float64)
    lo, hi = (math.log10(v) for v in settings.concentration_range_kg_m3)
    with np.errstate(divide="ignore"):
        t = np.clip((np.log10(c) - lo) / (hi - lo), 0.0, 1.0) * 4.0
    stops = np.asarray(CONCENTRATION_STOPS)
    k = np.minimum(np.floor(t).astype(int), 3)
    f = (t - k)[..., None]
    out = stops[k] * (1.0 - f) + stops[k + 1] * f
    return np.where((c > 10.0 ** lo)[..., None], out, np.asarray(NO_CONCENTRATION))


def concentration_legend(settings: DisplaySettings) -> list[tuple[Colour | None, str]]:
    """The concentration mode's legend: a swatch per decade of its range."""
    lo, hi = settings.concentration_range_kg_m3
    out: list[tuple[Colour | None, str]] = [(_rgb(*NO_CONCENTRATION),
                                             f"dark blue: below {lo:g} kg/m³ (no spill)")]
    decades = max(1, round(math.log10(hi / lo)))
    for k in range(decades + 1):
        c = lo * (hi / lo) ** (k / decades)
        rgb = concentration_colour(c * (1 + 1e-9), settings)
        out.append((_rgb(*rgb.tolist()), f"{c:.0e} kg/m³ ({c * 1e3:g} mg/L)"))
    return out


def legend(settings: DisplaySettings) -> list[tuple[Colour | None, str]]:
    """What the colours of the current drawing mean: (8-bit RGB or None, text) per line, the
    water mode first, then each overlay that is on."""
    mode = DisplayMode(settings.mode)
    out = list(MODE_LEGENDS[mode]) if mode != DisplayMode.CONCENTRATION \
        else concentration_legend(settings)
    if settings.show_grid and mode in _SHADED:       # mesh and coverage colours stay plain
        out += GRID_LEGEND if mode == DisplayMode.ADVECTED else GRID_LEGEND[:1]
    if settings.show_particles:
        out += PARTICLE_LEGEND
    if settings.show_velocities:
        out += [(c, t.format(arrow_s=settings.arrow_s)) for c, t in ARROW_LEGEND]
    return out


def settings_for(name: str, **overrides) -> DisplaySettings:
    """Settings of a named display mode (a key of :data:`MODE_NAMES`)."""
    try:
        fields = dict(MODE_NAMES[name])
    except KeyError:
        raise ValueError(f"unknown display mode {name!r}; one of {', '.join(MODE_NAMES)}") \
            from None
    fields.update(overrides)
    settings = DisplaySettings(**fields)
    settings.validate()
    return settings
