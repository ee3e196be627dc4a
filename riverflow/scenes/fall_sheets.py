"""The falling sheets: one ribbon mesh per fall, from its lip down the nappe to the pool (#23).

A fall's water leaves the lip (:class:`riverflow.hydro.falls.Fall`) horizontally at the lip
speed v0 and falls ballistically: t seconds after the lip it is ``v0·t`` past the lip along
the river and ``g·t²/2`` below it (the nappe, :func:`riverflow.hydro.falls.nappe_drop`), and
moves at ``v = √(v0² + (g·t)²) = √(v0² + 2·g·d)`` with d the height fallen. The ribbon is the
lip's line × that parabola: ``across`` vertices along the lip by ``down`` rows in equal steps
of t from the lip (t = 0) to the pool (t = the fall time √(2·drop/g)). The lip is straight and
the distance to its nearer end is linear on either side of its middle, so three vertices across
draw it exactly (the streaks are the fragment shader's): few triangles to set up.

Each vertex carries, besides its world position, (across [m] from the lip's middle, t [s],
v [m/s], its distance [m] to the nearer end of the lip). The sheet's shader
(``shaders/falls.glsl``) reads its streak pattern at (across, now − t): the water that left
the lip at one moment carries one row of the pattern down, so the pattern moves down at the
water's own speed and its streaks stretch as the water speeds up (rows that left Δτ apart
lie v·Δτ apart); it is translucent where the lip ends and whiter as the falling water breaks
up. Made once per scene (the falls do not move); all falls in one mesh.
"""
from __future__ import annotations

import numpy as np

from riverflow.hydro.falls import G_MPS2

SHEET_ATTRIBUTES = {0: 3, 1: 4, 2: 1}
"""The mesh's vertex attributes (shader location → floats): world position [m]; (across [m],
t [s], speed [m/s], distance to the lip's nearer end [m]); t / the fall time."""
SHEET_LIFT_M = 0.03
"""The ribbon lies this far above the nappe: in front of the water mesh, whose coarse level
cells cut under the parabola (the chords of a concave curve lie below it)."""
SHEET_DEPTH_PULL_M = 1.5
"""…and at its foot, where the water mesh's chord runs on past the landing above the pool
and would hide it, the depth test sees it this much nearer the eye (from 0 at the lip, in
proportion to t / the fall time; ``shaders/falls.glsl``)."""


def sheet_mesh(falls, lip_levels_m, across: int = 3, down: int = 12
               ) -> tuple[np.ndarray, np.ndarray]:
    """The ribbons of ``falls`` (a sequence of :class:`~riverflow.hydro.falls.Fall`) whose
    lips lie at ``lip_levels_m`` (F,) [m]: (vertices (F·across·down, 8) float32 — position,
    across, t, speed, edge distance, t / fall time: :data:`SHEET_ATTRIBUTES` —, triangle indices (K,) uint32).
    No falls: empty arrays."""
    levels = np.asarray(lip_levels_m, np.float64).reshape(-1)
    if len(levels) != len(falls):
        raise ValueError(f"sheet_mesh: {len(falls)} falls but {len(levels)} lip levels")
    if across < 2 or down < 2:
        raise ValueError(f"sheet_mesh: across and down must be ≥ 2, got {across}, {down}")
    if not np.isfinite(levels).all():
        bad = int(np.flatnonzero(~np.isfinite(levels))[0])
        raise ValueError(f"sheet_mesh: the lip level of fall {bad} "
                         f"({falls[bad].branch} at {falls[bad].at_m:g} m) is {levels[bad]}")
    vertices, indices = [], []
    u = np.linspace(-0.5, 0.5, across)
    grid = np.arange((across - 1) * (down - 1))
    i, j = grid // (down - 1), grid % (down - 1)              # quad (across i, row j)
    a = i * down + j
    quads = np.stack([a, a + down, a + 1, a + 1, a + down, a + down + 1], 1).ravel()
    for k, (fall, lip) in enumerate(zip(falls, levels)):
        c = np.asarray(fall.centre_m, np.float64)
        d = np.asarray(fall.direction, np.float64)
        n = np.array([-d[1], d[0]])
        v0 = fall.lip_speed_mps
        t = np.linspace(0.0, fall.fall_time_s, down)
        e = u * fall.lip_m                                    # across [m]
        ee, tt = np.meshgrid(e, t, indexing="ij")             # (across, down)
        xy = c + (v0 * tt)[..., None] * d + ee[..., None] * n
        z = lip + SHEET_LIFT_M - 0.5 * G_MPS2 * tt * tt
        speed = np.sqrt(v0 * v0 + (G_MPS2 * tt) ** 2)
        edge = 0.5 * fall.lip_m - np.abs(ee)
        rows = np.concatenate([xy, z[..., None], ee[..., None], tt[..., None],
                               speed[..., None], edge[..., None],
                               (tt / max(fall.fall_time_s, 1e-9))[..., None]], -1).reshape(-1, 8)
        indices.append(quads + k * across * down)
        vertices.append(rows)
    if not vertices:
        return np.zeros((0, 8), np.float32), np.zeros(0, np.uint32)
    return (np.concatenate(vertices).astype(np.float32),
            np.concatenate(indices).astype(np.uint32))


def lip_levels(falls, water) -> np.ndarray:
    """(F,) the water level [m] at each fall's lip (``water``: the scene's
    :class:`~riverflow.scenes.water.WaterSurface`-like object with ``level(xy)``)."""
    if not falls:
        return np.zeros(0)
    return np.asarray(water.level(np.array([f.centre_m for f in falls], np.float64)),
                      np.float64)


SPRAY_HEIGHT_M = 8.0
"""The falls' boxes (:func:`falls_boxes`) reach this far above the lips (the spray's mist)."""


def falls_boxes(falls, lip_levels_m) -> np.ndarray:
    """(F, 8, 4) float64: the corners (x, y, z, 1) of a box around each fall's sheet and spray
    (its lip's line from 2 m above to the pool, the nappe's throw and 10 m beyond it, and
    SPRAY_HEIGHT_M over the lip): :func:`in_view` skips what is out of view."""
    out = np.ones((len(falls), 8, 4))
    for k, (f, lip) in enumerate(zip(falls, np.asarray(lip_levels_m, np.float64).reshape(-1))):
        c, d = np.asarray(f.centre_m, np.float64), np.asarray(f.direction, np.float64)
        n = np.array([-d[1], d[0]])
        half = 0.5 * f.lip_m + 3.0
        corners = [c + a * d + b * half * n for a in (-2.0, f.throw_m + 10.0) for b in (-1, 1)]
        out[k, :, :2] = np.array(corners * 2)
        out[k, :4, 2] = lip - f.drop_m - 1.0
        out[k, 4:, 2] = lip + SPRAY_HEIGHT_M
    return out


def in_view(boxes: np.ndarray, clip_from_world: np.ndarray) -> bool:
    """Whether any of ``boxes`` (F, 8, 4) may be seen through ``clip_from_world`` (4, 4),
    column vectors: a box is out of view when all its corners lie beyond one of the frustum's
    side planes or behind the eye (conservative: a box may be kept that is not seen)."""
    if not len(boxes):
        return False
    clip = boxes @ clip_from_world.T                         # (F, 8, 4)
    x, y, w = clip[..., 0], clip[..., 1], clip[..., 3]
    out = ((x < -w).all(1) | (x > w).all(1) | (y < -w).all(1) | (y > w).all(1)
           | (w <= 0.0).all(1))
    return not bool(out.all())
