"""Screen projection kernels: world → screen, and fading of particles that leave the view.

Re-does Proland's ``ScreenParticleLayer::moveParticles`` (reference §3.3): particles with a
world position are projected with the camera's world→clip matrix; outside the viewport they
fade out (reason OUTSIDE_VIEWPORT), and beyond ``kill_margin_px`` outside it they die at once,
as do particles behind the camera.
"""
from __future__ import annotations

from numba import njit

from riverflow.kernels._jit import JIT_OPTIONS
from riverflow.kernels.lifecycle import free_particle, start_fade_out

REASON_OUTSIDE_VIEWPORT = 2


@njit(**JIT_OPTIONS)
def project_particles(
    alive, ids, counters, has_world, world_m, screen_px, birth_s, fade_reason,
    clip_from_world, width_px, height_px, kill_margin_px, now_s, fade_in_s, active_s, fade_out_s,
):
    """Project every live particle that has a world position.

    ``world_m`` (C, 3) float64 [m]; ``screen_px`` (C, 2) float32 written [px], origin at the
    bottom-left; ``clip_from_world`` (4, 4) float64 column-vector matrix (clip = M @ [x y z 1]).
    A zero-size viewport kills every projected particle. Returns (killed, faded).
    """
    killed = 0
    faded = 0
    m = clip_from_world
    for i in range(min(counters[2], alive.shape[0])):  # (no live slot beyond the bound)
        if not alive[i] or not has_world[i]:
            continue
        x = world_m[i, 0]
        y = world_m[i, 1]
        z = world_m[i, 2]
        cx = m[0, 0] * x + m[0, 1] * y + m[0, 2] * z + m[0, 3]
        cy = m[1, 0] * x + m[1, 1] * y + m[1, 2] * z + m[1, 3]
        cw = m[3, 0] * x + m[3, 1] * y + m[3, 2] * z + m[3, 3]
        if not cw > 1e-9 or width_px <= 0 or height_px <= 0:
            free_particle(i, alive, ids, counters)
            killed += 1
            continue
        sx = (cx / cw * 0.5 + 0.5) * width_px
        sy = (cy / cw * 0.5 + 0.5) * height_px
        if not (abs(sx) < 1e7 and abs(sy) < 1e7):  # also catches NaN
            free_particle(i, alive, ids, counters)
            killed += 1
            continue
        screen_px[i, 0] = sx
        screen_px[i, 1] = sy
        if sx < 0.0 or sy < 0.0 or sx >= width_px or sy >= height_px:
            if (sx < -kill_margin_px or sy < -kill_margin_px
                    or sx >= width_px + kill_margin_px or sy >= height_px + kill_margin_px):
                free_particle(i, alive, ids, counters)
                killed += 1
            elif start_fade_out(i, birth_s, now_s, fade_in_s, active_s, fade_out_s):
                fade_reason[i] = REASON_OUTSIDE_VIEWPORT
                faded += 1
    return killed, faded
