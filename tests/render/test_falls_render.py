"""A fall drawn (issue #23), offscreen on Mesa's llvmpipe, tiny frames: seen from the side, the
falling sheet covers the band between lip and pool where the ground shows without it, and its
streaks move down between two frames; the plunge pool is whiter than the river 50 m below it
(the foam mode)."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import riverflow as rf
from riverflow.components.display import DisplayMode
from riverflow.engine import gl
from riverflow.engine.config import RiverConfig
from tests.hydro.test_falls import DROP, LIP_X, _straight

pytestmark = pytest.mark.gl
PROBES = Path(__file__).parent / "shaders"
W, H = 160, 90


RAPID = (100.0, 160.0, 6.0)
"""A 10 % rapid well above the fall (from, to, drop)."""


@pytest.fixture(scope="module")
def scene():
    b = _straight()
    b.add_rapids(*RAPID)
    return rf.landscape(b.build(), seed=0)


@pytest.fixture(scope="module")
def world(gl_context, scene):
    w = rf.RiverWorld(scene, size=(W, H), gl=True, seed=0,
                      config=RiverConfig(radius_px=5.0, tile_production="blocking"))
    yield w
    w.close()


def _lip(world) -> float:
    return float(world.scene.water.level(np.array([[LIP_X, 0.0]]))[0])


def test_a_fall_seen_from_the_side_is_a_sheet_of_water(world):
    """From the pool's side, the band the nappe spans on screen shows the ground without the
    water (mode NONE); drawn, it is water-coloured (blue at least red: water or white foam,
    where grass and sand are not) and it is the falling sheet's (it changes with it)."""
    (f,) = world.scene.graph.falls
    lip = _lip(world)
    # from the pool's side, obliquely, a little above the pool
    world.camera.look_at((LIP_X + 25.0, -14.0, lip - DROP + 2.0),
                         (LIP_X + 0.5 * f.throw_m, 0.0, lip - 0.5 * DROP))
    for _ in range(10):
        world.step(1 / 30)
    frames = {}
    for name, mode, sheets in (("ground", DisplayMode.NONE, True),
                               ("water", DisplayMode.ADVECTED, False),
                               ("sheet", DisplayMode.ADVECTED, True)):
        world.display.mode = mode
        world.display.fall_sheets = sheets
        frames[name] = world.render()[..., :3].astype(int)
    gl.check_errors("drawing the falling sheet and spray")
    # the band the nappe spans on screen: between the lip and the pool, across the river
    corners = np.array([[LIP_X + 0.3 * f.throw_m, -6.0, lip - 0.09 * DROP],
                        [LIP_X + 0.7 * f.throw_m, 6.0, lip - 0.49 * DROP]])
    px, _, front = world.camera.world_to_screen(corners)
    assert front.all()
    x0, x1 = sorted(px[:, 0].astype(int))
    y0, y1 = sorted((H - px[:, 1]).astype(int))          # rows from the top
    band = (slice(max(y0, 0), min(y1 + 1, H)), slice(max(x0, 0), min(x1 + 1, W)))
    ground, sheet = frames["ground"][band], frames["sheet"][band]
    changed = np.abs(sheet - ground).sum(-1)
    assert changed.size >= 20
    assert (changed > 30).mean() > 0.8        # water where the ground showed
    land = ground[..., 2] < ground[..., 0]              # grass, sand, rock (else sky)
    assert land.mean() > 0.3
    assert (sheet[land][:, 2] >= sheet[land][:, 0]).mean() > 0.9   # now water, foam
    assert (np.abs(sheet - frames["water"][band]).sum(-1) > 30).mean() > 0.5   # the sheet


def test_the_sheets_texture_moves_down_with_the_falling_water(world):
    """Two frames 2/30 s apart, the camera still in front of the fall: the sheet's pixels
    match best shifted down the screen (the streaks fall with the water, at 4-11 m/s: a few
    pixels here), and better down than up."""
    (f,) = world.scene.graph.falls
    lip = _lip(world)
    world.camera.look_at((LIP_X + 14.0, -3.0, lip - DROP + 1.0),
                         (LIP_X + 0.5 * f.throw_m, 0.0, lip - 0.5 * DROP))
    from riverflow.components.spray import Spray
    spray = world.resource(Spray)
    spray.enabled = False                   # the sheet alone (the mist drifts over it)
    try:
        world.step(1 / 30)
        world.display.fall_sheets = False
        off = world.render()[..., :3].astype(float)
        world.display.fall_sheets = True
        a = world.render()[..., :3].astype(float)
        world.step(1 / 30)
        world.step(1 / 30)
        b = world.render()[..., :3].astype(float)
    finally:
        spray.enabled = True
    cols = slice(W // 4, 3 * W // 4)
    sheet = np.abs(a - off).sum(-1)[:, cols] > 30
    rows = np.flatnonzero(sheet.mean(1) > 0.95)             # the rows the sheet covers
    rows = rows[:1 + np.argmax(np.append(np.diff(rows) != 1, True))]   # (the first run)
    assert len(rows) > 15
    r0, r1 = rows[0] + 3, rows[-1] - 3
    la, lb = a.mean(-1)[:, cols], b.mean(-1)[:, cols]
    err = {k: np.abs(la[r0:r1] - lb[r0 + k:r1 + k]).mean() for k in range(-3, 4)}
    best = min(err, key=err.get)
    assert best > 0, err                                    # rows grow down the screen
    assert err[best] < err[0] - 0.5 and err[best] < err[-best] - 2.0, err


def test_the_pool_mirrors_the_sheet(world):
    """Low over the pool, looking at the fall (spray off): with reflections, drawing the
    sheet changes pixels of the pool below it that it does not cover itself (its mirror
    image: the sheet is drawn into the reflection pass too)."""
    from riverflow.components.spray import Spray
    lip = _lip(world)
    world.camera.look_at((LIP_X + 35.0, -3.0, lip - DROP + 1.2), (LIP_X, 0.0, lip - DROP + 0.5))
    world.step(1 / 30)
    spray, display = world.resource(Spray), world.display
    frames = {}
    try:
        spray.enabled = False
        for reflect in (False, True):
            display.reflections = reflect
            for sheets in (True, False):
                display.fall_sheets = sheets
                frames[reflect, sheets] = world.render()[..., :3].astype(float)
    finally:
        spray.enabled, display.reflections, display.fall_sheets = True, True, True
    direct = np.abs(frames[False, True] - frames[False, False]).sum(-1) > 10
    mirrored = np.abs(frames[True, True] - frames[True, False]).sum(-1) > 10
    only = mirrored & ~direct
    assert direct.sum() > 200
    assert only.sum() > 60, only.sum()
    assert np.median(np.nonzero(only)[0]) > np.nonzero(direct)[0].max()    # below the foot


def test_spray_and_mist_whiten_the_air_over_the_impact(world):
    """From below the fall, the air 1-3 m over where the nappe lands is whiter with the
    spray drawn than without it (Spray.enabled), and the mist is soft: no pixel turns
    white."""
    from riverflow.components.spray import Spray
    (f,) = world.scene.graph.falls
    lip = _lip(world)
    world.camera.look_at((LIP_X + 30.0, -4.0, lip - DROP + 2.0), (LIP_X, 0.0, lip - DROP + 1.5))
    for _ in range(30):
        world.step(1 / 30)
    spray = world.resource(Spray)
    shots = {}
    for on in (False, True):
        spray.enabled = on
        shots[on] = world.render()[..., :3].astype(float).mean(-1)
    assert spray.count == spray.per_fall
    probes = np.array([[LIP_X + f.throw_m + 1.0, y, lip - DROP + z]
                       for y in (-6.0, -3.0, 0.0, 3.0, 6.0) for z in (1.0, 2.0, 3.0)])
    px, _, front = world.camera.world_to_screen(probes)
    assert front.all()
    cols, rows = px[:, 0].astype(int), (H - px[:, 1]).astype(int)
    assert ((cols >= 0) & (cols < W) & (rows >= 0) & (rows < H)).all()
    gain = shots[True][rows, cols] - shots[False][rows, cols]
    assert gain.mean() > 8.0, gain
    assert np.abs(shots[True] - shots[False]).max() < 200.0


def test_the_plunge_pool_is_whiter_than_the_river_below(gl_context, scene):
    """In the foam mode, from a world's first drawn frame (the mode makes its own sprite
    grid: it once showed only what an advected frame before it had left)."""
    world = rf.RiverWorld(scene, size=(W, H), gl=True, seed=0,
                          config=RiverConfig(radius_px=5.0, tile_production="blocking"))
    (f,) = world.scene.graph.falls
    lip = _lip(world)
    pool_x = LIP_X + f.throw_m + 4.0
    world.camera.look_at((pool_x + 25.0, -45.0, lip + 25.0), (pool_x + 25.0, 0.0, lip - DROP))
    for _ in range(60):
        world.step(1 / 30)
    world.display.mode = DisplayMode.FOAM
    image = world.render()[..., :3].astype(float).mean(-1)
    world.close()
    probes = np.array([[pool_x + dx, dy, lip - DROP] for dx in (0.0, 50.0)
                       for dy in (-4.0, 0.0, 4.0)])
    px, _, front = world.camera.world_to_screen(probes)
    assert front.all()
    cols = px[:, 0].astype(int)
    rows = (H - px[:, 1]).astype(int)
    assert ((cols >= 0) & (cols < W) & (rows >= 0) & (rows < H)).all()
    bright = np.array([image[max(r - 1, 0):r + 2, max(c - 1, 0):c + 2].mean()
                       for r, c in zip(rows, cols)])
    pool, below = bright[:3].mean(), bright[3:].mean()
    assert pool > below + 20.0, (pool, below)


# -- rapids: standing waves --------------------------------------------------------------------

def _standing_twin(p, grad, px_m, amp, lo, hi):
    """Numpy twin of standing_slopes (shaders/rapids.glsl): (slopes (N, 2), crest (N,))."""
    def smooth(e0, e1, x):
        t = np.clip((x - e0) / (e1 - e0), 0.0, 1.0)
        return t * t * (3 - 2 * t)

    s = np.hypot(*grad.T)
    amount = smooth(lo, hi, s) * (1.0 - smooth(0.33, 0.5, s))
    visible = np.clip((3.0 / px_m - 3.0) / 3.0, 0.0, 1.0)
    d = -grad / np.maximum(s, 1e-12)[:, None]
    across = np.stack([-d[:, 1], d[:, 0]], 1)
    k = 2 * np.pi / 3.0
    a = np.einsum("ij,ij->i", p, d)
    c = np.einsum("ij,ij->i", p, across)
    phase = k * a + 1.7 * np.sin(0.37 * k * c) + 0.9 * np.sin(0.23 * k * c + 1.3)
    envelope = 0.65 + 0.35 * np.sin(0.29 * k * c + 0.6 * np.sin(0.11 * k * a))
    on = (amount > 0) & (visible > 0) & (amp > 0)
    crest = np.where(on, amount * envelope * smooth(0.75, 0.98, np.sin(phase)), 0.0)
    slopes = np.where(on[:, None], (visible * amount * envelope * amp * np.cos(phase))[:, None]
                      * d, 0.0)
    return slopes, crest


def test_the_standing_waves_shader_matches_its_numpy_twin(gl_context):
    from riverflow.engine import gl
    from riverflow.systems.draw import shader_defines
    rng = np.random.default_rng(5)
    size = (48, 32)
    n = size[0] * size[1]
    p = rng.uniform(-40.0, 40.0, (n, 2))
    slope = rng.choice([0.005, 0.03, 0.08, 0.2, 0.4, 0.7], n)
    angle = rng.uniform(0, 2 * np.pi, n)
    grad = slope[:, None] * np.stack([np.cos(angle), np.sin(angle)], 1)
    points = np.concatenate([p, grad], 1).reshape(size[1], size[0], 4).astype(np.float32)
    tex = gl.Texture(size, gl.RGBA32F)
    tex.upload(points)
    target = gl.Texture(size, gl.RGBA32F)
    fb = gl.Framebuffer([target])
    program = gl.Program("probe_rapids.glsl", shader_defines(), directory=PROBES)
    fb.bind()
    gl.clear((0, 0, 0, 0), depth=False)
    tex.bind(4)
    program.use()
    program.set(u_points=4, u_px_m=0.05, u_rapids=(0.3, 0.02, 0.15))
    empty = gl.Mesh(None, {})
    empty.draw(gl.TRIANGLES, count=3)
    probe = gl.read_texture(target).reshape(-1, 4)
    gl.check_errors("rapids probe")
    for obj in (empty, fb, target, program, tex):
        obj.delete()
    pts = points.reshape(-1, 4).astype(np.float64)
    want, want_crest = _standing_twin(pts[:, :2], pts[:, 2:], 0.05, 0.3, 0.02, 0.15)
    assert np.abs(want).max() > 0.1 and want_crest.max() > 0.3
    assert np.abs(probe[:, :2] - want).max() < 2e-3
    assert np.abs(probe[:, 2] - want_crest).max() < 2e-3
    # none on a lowland river (0.5 %) or a fall's nappe (70 %); more on 20 % than on 3 %
    mag = np.hypot(*want.T)
    assert mag[slope == 0.005].max() == 0.0 and mag[slope == 0.7].max() == 0.0
    assert mag[slope == 0.2].mean() > 3.0 * mag[slope == 0.03].mean()


def test_the_standing_waves_stay_in_place_while_particles_pass(world):
    """On a 10 % rapid, with the sprites' waves and the foam off, the water's look at fixed
    pixels (a fixed camera) is the standing waves': it changes by under 10 % of what they
    add over 2 s of frames, while the particles run through."""
    mid = 0.5 * (RAPID[0] + RAPID[1])
    z = float(world.scene.water.level(np.array([[mid, 0.0]]))[0])
    world.camera.look_at((mid + 12.0, -16.0, z + 12.0), (mid - 2.0, 0.0, z))
    display = world.display
    kept = (display.wave_slope_factor, display.reflections, display.rapids_wave_slope)
    try:
        display.wave_slope_factor = 0.0
        display.reflections = False
        world.foam.enabled = False
        for _ in range(5):
            world.step(1 / 30)
        shots = []
        for rapids in (0.3, 0.0, 0.3):
            world.display.rapids_wave_slope = rapids
            shots.append(world.render()[..., :3].astype(float))
            if len(shots) == 2:
                for _ in range(60):
                    world.step(1 / 30)
        before, flat, after = shots
        water = np.abs(before - flat).sum(-1) > 0
        assert water.mean() > 0.2
        added = np.abs(before - flat)[water].mean()
        moved = np.abs(after - before)[water].mean()
        assert added > 1.5, added
        assert moved < 0.1 * added, (moved, added)
        assert len(world.particles) > 20                    # particles there, running through
    finally:
        display.wave_slope_factor, display.reflections, display.rapids_wave_slope = kept
        world.foam.enabled = True
