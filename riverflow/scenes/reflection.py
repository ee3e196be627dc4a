"""The planar reflection's mirror (plain numpy, no GL): its height and the mirrored camera.

Banks, props and sky are reflected in the water by a *planar reflection* (issue 12 item 3;
the choice and its measurements: ``docs/deviations.md``, ``docs/performance.md``): the land and
the props are drawn once more, mirrored in the horizontal plane z = L, into a texture the
water shader samples. A river's level falls along its course, so one plane is exact only
where the water is at L; L is taken where it matters most, at the river nearest the camera
(:func:`mirror_level`), and the water shader corrects every pixel for its own level
(``shaders/reflection.glsl``).
"""
from __future__ import annotations

import math

import numpy as np

TERRAIN_STRIDE = 2
"""The reflection draws the terrain tiles through every TERRAIN_STRIDE-th node (a quarter of
the triangles: on a software renderer the terrain's triangles, not its pixels, are most of
the pass's cost; the reflection is at a reduced resolution and blurred by the waves)."""
MIN_EYE_HEIGHT_M = 0.05
"""No reflection is drawn when the eye is less than this above the mirror (at or under the
water: the surface seen from below shows no mirror image of the land)."""


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


def mirror_level(water, eye_m) -> float | None:
    """The mirror's height [m]: the level of the river nearest the eye (``water`` a
    :class:`~riverflow.scenes.water.WaterSurface`, or None: no reflection). Where the water
    is seen nearest, the mirror is exact; elsewhere the water shader corrects each pixel for
    its own level, so this choice only has to be close. It depends on the camera alone, not
    on the particles: the frame stays a function of the view."""
    if water is None:
        return None
    x, y, z = (float(v) for v in np.asarray(eye_m, np.float64).reshape(3).tolist())
    if not (math.isfinite(x) and math.isfinite(y) and math.isfinite(z)):
        return None
    level_at = getattr(water, "level_at", None)      # one point without numpy's overhead
    level = float(level_at(x, y) if level_at is not None
                  else water.level(np.array([[x, y]]))[0])
    return level if math.isfinite(level) else None


def reflection_size(width_px: int, height_px: int, scale: float) -> tuple[int, int]:
    """The reflection texture's size for a viewport and a resolution scale (≥ 1 × 1)."""
    return (max(1, int(round(width_px * scale))), max(1, int(round(height_px * scale))))
