"""The planar reflection's mirror (plain numpy, no GL): its height and the mirrored camera.

Banks, props and sky are reflected in the water by a *planar reflection* (issue 12 item 3;
the choice and its measurements: ``docs/deviations.md``, ``docs/performance.md``): the land and
the props are drawn once more, mirrored in the horizontal plane z = L, into a texture the
water shader samples. A river's level falls along its course, so one plane is exact only
where the water is at L; L is taken where it matters most, at the visible water nearest the
camera (:func:`mirror_level`), and the water shader corrects every pixel for its own level
(``shaders/reflection.glsl``).
"""
from __future__ import annotations

import numpy as np

NEAREST_SAMPLES = 16
"""The mirror's height is the median level of this many visible water points nearest the
camera (one stray particle does not move it)."""
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
    the camera sees its mirror image, so the reflection texture lines up with the frame."""
    return (mirror_matrix(level_m) @ np.asarray(view_projection, np.float64)).astype(np.float32)


def mirror_level(eye_m, water_m: np.ndarray, fallback_m: float | None = None) -> float | None:
    """The mirror's height [m]: the median level (z) of the :data:`NEAREST_SAMPLES` points of
    ``water_m`` (N, 3) [m] (points on the visible water: the particles) nearest ``eye_m``;
    ``fallback_m`` when there are none (no water in view yet). Non-finite points are ignored;
    None when nothing is known."""
    eye = np.asarray(eye_m, np.float64).reshape(3)
    pts = np.asarray(water_m, np.float64).reshape(-1, 3)
    pts = pts[np.isfinite(pts).all(axis=1)]
    if len(pts) == 0:
        return None if fallback_m is None or not np.isfinite(fallback_m) else float(fallback_m)
    d2 = ((pts - eye) ** 2).sum(axis=1)
    k = min(NEAREST_SAMPLES, len(pts))
    near = np.argpartition(d2, k - 1)[:k] if k < len(pts) else np.arange(len(pts))
    return float(np.median(pts[near, 2]))


def reflection_size(width_px: int, height_px: int, scale: float) -> tuple[int, int]:
    """The reflection texture's size for a viewport and a resolution scale (≥ 1 × 1)."""
    return (max(1, int(round(width_px * scale))), max(1, int(round(height_px * scale))))
