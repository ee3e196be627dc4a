"""The planar reflection's mirror (plain numpy, no GL): its height and the mirrored camera.

Banks, props and sky are reflected in the water by a *planar reflection* (issue 12 item 3;
the choice and its measurements: ``docs/deviations.md``, ``docs/performance.md``): the land and
the props are drawn once more, mirrored in the horizontal plane z = L, into a texture the
water shader samples. A river's level falls along its course, so one plane is exact only
where the water is at L; L is the mean level of the water in view, weighted by the share of
the screen it covers and its reflectance, none where the water shader shows no land in it
(:func:`mirror_level`: continuous as the camera moves), eased in time (:func:`ease_level`),
and the water shader corrects every pixel for its own level (``shaders/reflection.glsl``).
The passes are drawn at a held level, a second pass at a new level cross-faded in when the
eased one moves away (:func:`hold_levels`): never at a level that moves every frame.
"""
from __future__ import annotations

import math

import numpy as np

from riverflow.kernels.centre_line import view_level

TERRAIN_STRIDE = 2
"""The reflection draws the terrain tiles through every TERRAIN_STRIDE-th node (a quarter of
the triangles: on a software renderer the terrain's triangles, not its pixels, are most of
the pass's cost; the reflection is at a reduced resolution and blurred by the waves)."""
MIN_EYE_HEIGHT_M = 0.05
"""No reflection is drawn when the eye is less than this above the mirror (at or under the
water: the surface seen from below shows no mirror image of the land)."""
MIRROR_SETTLE_S = 0.5
"""The mirror's height follows the level of the water in view within about this time [s]
(:func:`ease_level`; 90 % of a step)."""
MIRROR_CUT_M = 50.0
"""An eye that moved farther than this [m] between two drawn frames jumped (a teleport, a
new shot): the mirror takes the new view's level at once, without easing."""
MIRROR_REFRESH_M = 1.0
MIRROR_REFRESH_RAD = math.radians(0.5)
"""In a moving view the level of the water in view is found again once the eye moved more
than MIRROR_REFRESH_M [m] or the view turned more than MIRROR_REFRESH_RAD since it was last
found (at 12 m/s and 60 frames a second, every 5th frame; the easing smooths the steps)."""
MIRROR_HOLD_M = 0.25
"""The mirror is drawn at a *held* level until the eased level of the water in view
(:func:`ease_level`) is more than this [m] away from it; then a second pass at the eased
level is cross-faded in (:func:`hold_levels`). The water's per-pixel correction is exact to
well within this; far water at another level (its reflected ray within a few texels of the
reflection texture) shows an erratic function of the mirror's level, so a mirror that moves
every frame makes it flicker (issue 29 item 2)."""
MIRROR_FADE_S = 0.25
"""The cross-fade from the held mirror's pass to the new level's takes this long [s]."""
FALLBACK_SHARE = 1e-4
"""The share of the screen with which the nearest river's level joins the level of the water
in view (:func:`mirror_level`): it decides where less water than that is in view."""


def mirror_matrix(level_m: float) -> np.ndarray:
    """(4, 4) float64 mirror in the plane z = ``level_m``, in pyrr's row-vector layout like
    :meth:`riverflow.engine.camera.Camera.view_projection` (``[x, y, z, 1] @ M =
    [x, y, 2L − z, 1]``)."""
    m = np.eye(4)
    m[2, 2] = -1.0
    m[3, 2] = 2.0 * float(level_m)
    return m


def mirrored_view_projection(view_projection: np.ndarray, level_m: float) -> np.ndarray:
    """World → clip of the mirrored pass (row-vector layout, float32): a point is drawn where
    the camera sees its mirror image, so the reflection texture lines up with the frame.

    ``mirror_matrix(level_m) @ view_projection`` written out (every frame: a 4 × 4 product
    through numpy costs more than the rest of the pass's setup), in Python floats (the same
    double operations, rounded once each, as numpy's elementwise ones; fewer calls): rows 0
    and 1 as they are, row 2 negated, row 3 plus 2L × row 2; + 0.0 makes every zero +0.0, as
    the product's sums do."""
    r0, r1, r2, r3 = np.asarray(view_projection, np.float64).tolist()
    two_l = 2.0 * float(level_m)
    return np.array([[v + 0.0 for v in r0], [v + 0.0 for v in r1], [-v + 0.0 for v in r2],
                     [a * two_l + b + 0.0 for a, b in zip(r2, r3)]], np.float32)


def mirror_level(water, eye_m, clip_from_world=None, near_m: float = 0.5) -> float | None:
    """The mirror's height [m] (``water`` a :class:`~riverflow.scenes.water.WaterSurface`, or
    None: no reflection). It depends on the camera alone, not on the particles: the frame
    stays a function of the view.

    Without ``clip_from_world``: the level of the river nearest the eye. With it (the
    camera's column-vector world → clip matrix, ``near_m`` its near plane): the mean level of
    the water in view, weighted by the share of the screen it covers
    (:func:`riverflow.kernels.centre_line.view_level`), joined by the nearest river's level
    with the share FALLBACK_SHARE (what it tends to when little water is in view). The
    mirror is exact where the water is at its level, and the water shader corrects every
    pixel for its own level, imperfectly where the mirrored view hides or lacks what that
    pixel's own mirror would show: so the level that the water on screen has is the one
    that matters, and as a weighted mean it changes continuously as the camera moves. The
    nearest river's level jumped where the nearest river changed (up to 43 m in the default
    scene between a tributary and the main river), and the whole reflection with it.
    Where the eye is not above the nearest river (under its water), that river's level is
    returned: the caller draws no reflection there (MIN_EYE_HEIGHT_M)."""
    if water is None:
        return None
    x, y, z = (float(v) for v in np.asarray(eye_m, np.float64).reshape(3).tolist())
    if not (math.isfinite(x) and math.isfinite(y) and math.isfinite(z)):
        return None
    level_at = getattr(water, "level_at", None)      # one point without numpy's overhead
    level = float(level_at(x, y) if level_at is not None
                  else water.level(np.array([[x, y]]))[0])
    if not math.isfinite(level):
        return None
    samples = getattr(water, "level_samples", None)
    if clip_from_world is None or samples is None or not z > level + MIN_EYE_HEIGHT_M:
        return level
    seen, _ = view_level(samples(), np.ascontiguousarray(clip_from_world, np.float64),
                         np.array((x, y, z)), float(near_m), MIN_EYE_HEIGHT_M, level,
                         FALLBACK_SHARE)
    return float(seen) if math.isfinite(seen) else level


def ease_level(level_m: float, rate_mps: float, target_m: float, dt_s: float,
               settle_s: float = MIRROR_SETTLE_S) -> tuple[float, float]:
    """The mirror's height and its rate of change [m/s] ``dt_s`` later, eased towards
    ``target_m`` by a critically damped spring (x'' = ω²(target − x) − 2ω x', exact for a
    constant target; ω = 3.9 / ``settle_s``: a step of the target is 90 % done after
    settle_s, its steepest change 1.43 × step / settle_s, and nothing overshoots). The
    mirror's height then changes smoothly in time, however fast the water in view changes
    (a camera turning, water entering or leaving the screen)."""
    omega = 3.9 / settle_s
    e = math.exp(-omega * dt_s)
    x0 = level_m - target_m
    c = rate_mps + omega * x0
    return target_m + (x0 + c * dt_s) * e, (rate_mps - omega * c * dt_s) * e


def hold_levels(held: tuple | None, level_m: float, dt_s: float, eye_z_m: float,
                hold_m: float = MIRROR_HOLD_M, fade_s: float = MIRROR_FADE_S) -> tuple:
    """The levels the reflection is drawn at this frame, (a, b, fade): the water shows
    mix(reflection at a, reflection at b, fade); b is None (one pass) when fade is 0.
    ``held`` is the last frame's answer (None: a cut, the mirror at ``level_m`` at once),
    ``level_m`` the eased level of the water in view, ``dt_s`` the time since that frame.

    The mirror stays at a while ``level_m`` is within ``hold_m`` of it; once it is farther,
    b = ``level_m`` is drawn too and faded in over ``fade_s`` (fixed meanwhile), then it is
    the held level. Each pass is at a fixed level, so each pixel's reflection changes with
    the view alone, and by the fade's step times the two passes' difference: however fast
    the level of the water in view changes, the water's reflection changes smoothly (a
    mirror moving every frame made far water at another level flicker, issue 29 item 2).
    A level at or above the eye (less than MIN_EYE_HEIGHT_M under it: the eye came down
    fast) is dropped for ``level_m`` at once."""
    if held is None or not dt_s >= 0.0:
        return (level_m, None, 0.0)
    a, b, fade = held
    low = eye_z_m - MIN_EYE_HEIGHT_M
    if not a < low:                             # the eye came down to the held mirror
        a, b, fade = (b, None, 0.0) if b is not None and b < low else (level_m, None, 0.0)
    elif b is not None and not b < low:
        b, fade = None, 0.0
    if b is not None:
        fade += dt_s / fade_s
        if fade >= 1.0:                         # the new level is the held one
            return (b, None, 0.0)
        return (a, b, fade)
    if abs(level_m - a) > hold_m and dt_s > 0.0:
        return (a, level_m, dt_s / fade_s) if dt_s < fade_s else (level_m, None, 0.0)
    return (a, None, 0.0)


def reflection_size(width_px: int, height_px: int, scale: float) -> tuple[int, int]:
    """The reflection texture's size for a viewport and a resolution scale (≥ 1 × 1)."""
    return (max(1, int(round(width_px * scale))), max(1, int(round(height_px * scale))))
