"""Particle kernels against their numpy twins (tests/reference.py) and their properties."""
from __future__ import annotations

import math

import numpy as np
import numpy.testing as npt
import pytest

from riverflow.components.particles import FadeReason, ParticlePool
from riverflow.components.status import FlowStatus
from riverflow.engine.camera import Camera
from riverflow.kernels import advection as ka
from riverflow.kernels import lifecycle as kl
from riverflow.kernels import placement as kpl
from riverflow.kernels import poisson_cull as kc
from riverflow.kernels import poisson_fill as kf
from riverflow.kernels import screen as ks
from riverflow.tiles.surface import one_tile_surface
from tests import reference

FI, AC, FO = 2.0, 30.0, 2.0


def _pool(rng, n, capacity=None, w=320, h=180):
    pool = ParticlePool(capacity or n)
    for _ in range(n):
        kl.allocate_particle(pool.alive, pool.ids, pool.counters, 0)
    pool.screen_px[:n] = rng.uniform((0, 0), (w, h), (n, 2))
    pool.birth_s[:n] = rng.uniform(-40, 0, n)
    return pool


def test_allocation_takes_the_lowest_free_slot_and_ids_are_stable():
    pool = ParticlePool(5)
    slots = [kl.allocate_particle(pool.alive, pool.ids, pool.counters, 0) for _ in range(5)]
    assert slots == [0, 1, 2, 3, 4]
    assert kl.allocate_particle(pool.alive, pool.ids, pool.counters, 0) == -1
    kl.free_particle(3, pool.alive, pool.ids, pool.counters)
    kl.free_particle(1, pool.alive, pool.ids, pool.counters)
    assert pool.count == 3
    assert kl.allocate_particle(pool.alive, pool.ids, pool.counters, 0) == 1
    assert pool.ids.tolist() == [0, 5, 2, -1, 4]


def test_the_slot_bound_covers_every_live_slot(rng):
    """Passes over the pool stop at counters[2]: allocations raise it, the life-cycle pass
    lowers it to the last live slot + 1, and no live slot is ever at or beyond it."""
    pool = ParticlePool(64)
    pool.birth_s[:] = 0.0
    for step in range(200):
        if rng.random() < 0.6:
            kl.allocate_particle(pool.alive, pool.ids, pool.counters, 0)
        live = np.flatnonzero(pool.alive)
        if len(live) and rng.random() < 0.4:
            kl.free_particle(rng.choice(live), pool.alive, pool.ids, pool.counters)
        if step % 10 == 0:
            kl.age_particles(pool.alive, pool.ids, pool.counters, pool.birth_s, pool.intensity,
                             1.0, FI, AC, FO)
            live = np.flatnonzero(pool.alive)
            assert pool.counters[2] == (live[-1] + 1 if len(live) else 0)
        assert not pool.alive[pool.counters[2]:].any()
    assert pool.counters[2] > 10


def test_ageing_matches_reference(rng):
    pool = _pool(rng, 400)
    now = 3.0
    age = now - pool.birth_s
    removed = kl.age_particles(pool.alive, pool.ids, pool.counters, pool.birth_s, pool.intensity,
                               now, FI, AC, FO)
    dead = age >= FI + AC + FO
    assert removed == dead.sum()
    npt.assert_array_equal(pool.alive, ~dead)
    npt.assert_allclose(pool.intensity[~dead], reference.intensity(age[~dead], FI, AC, FO),
                        rtol=1e-6, atol=1e-6)
    assert pool.intensity.min() >= 0 and pool.intensity.max() <= 1


def test_fade_out_keeps_the_current_intensity():
    birth = np.array([0.0, 0.0, 0.0])
    for now, expect in ((1.0, 0.5), (10.0, 1.0)):
        birth[:] = 0.0
        assert kl.start_fade_out(0, birth, now, FI, AC, FO)
        assert kl.intensity_at(now - birth[0], FI, AC, FO) == np.float64(expect)
        assert not kl.start_fade_out(0, birth, now, FI, AC, FO)  # already fading
        assert kl.intensity_at(now + 0.5 - birth[0], FI, AC, FO) < expect


def test_projection_matches_reference_and_fades_or_kills_off_screen(rng):
    cam = Camera(position=(0, -200, 100), target=(0, 0, 0), size_px=(320, 180))
    m, _ = cam.matrices_for_kernels()
    pool = _pool(rng, 500)
    pool.birth_s[:] = 0.0
    pool.world_m[:500] = rng.uniform((-400, -400, -10), (400, 400, 50), (500, 3))
    pool.has_world[:500] = True
    screen, w = reference.project(pool.world_m[:500], m, 320, 180)
    killed, faded = ks.project_particles(
        pool.alive, pool.ids, pool.counters, pool.has_world, pool.world_m, pool.screen_px,
        pool.birth_s, pool.fade_reason, m, 320, 180, 20.0, 10.0, FI, AC, FO)
    on = (w > 0) & np.all((screen >= 0) & (screen < (320, 180)), axis=1)
    margin = (w > 0) & np.all((screen >= -20) & (screen < (340, 200)), axis=1)
    npt.assert_array_equal(pool.alive[:500], margin)
    assert killed == (~margin).sum() and faded == (margin & ~on).sum()
    npt.assert_allclose(pool.screen_px[:500][margin], screen[margin], rtol=1e-4, atol=1e-3)
    assert np.all(pool.fade_reason[:500][margin & ~on] == FadeReason.OUTSIDE_VIEWPORT)
    # screen positions agree with the camera's own projection
    mine, _, front = cam.world_to_screen(pool.world_m[:500][on])
    npt.assert_allclose(pool.screen_px[:500][on], mine, atol=1e-3)


def test_zero_viewport_kills_projected_particles_without_nan(rng):
    pool = _pool(rng, 50)
    pool.has_world[:50] = True
    ks.project_particles(pool.alive, pool.ids, pool.counters, pool.has_world, pool.world_m,
                         pool.screen_px, pool.birth_s, pool.fade_reason, np.eye(4), 0, 0, 20.0,
                         0.0, FI, AC, FO)
    assert pool.count == 0 and np.isfinite(pool.screen_px).all()


def _grid(w, h, cell, capacity, per_cell=32):
    """A screen grid for the Poisson kernels (``ScreenGrid.arrays``), K = ``per_cell``."""
    gw, gh = math.ceil(w / cell), math.ceil(h / cell)
    n = gw * gh
    return kc.Grid(w, h, float(cell), gw, gh, np.zeros(n, np.int32),
                   np.zeros((n, per_cell), np.int32), np.zeros(n, np.uint8), np.zeros(n, np.uint8),
                   np.zeros(n + 1, np.int32), np.zeros(capacity, np.int32),
                   np.zeros((capacity, 2), np.float32), np.zeros(n, np.uint8),
                   np.zeros(capacity, np.int32), np.zeros(capacity, np.int32))


@pytest.mark.parametrize("cell_r", [4.0, 3.0, 1.5])  # half cells; whole cells; plain pass
def test_cull_matches_reference(rng, cell_r):
    r = 6.0
    pool = _pool(rng, 900)
    pool.birth_s[:] = 0.0
    pool.birth_s[::7] = -31.0  # some are fading out already
    grid = _grid(320, 180, cell_r * r, pool.capacity)
    gw, gh, count, items = grid.gw, grid.gh, grid.cell_count, grid.cell_items
    carriers = grid.carrier_cells
    keep = pool.alive & (1.0 - pool.birth_s < FI + AC)
    want = reference.cull_in_slot_order(pool.screen_px, keep, 1.96 * r)
    pool.status[:] = rng.choice(np.array([FlowStatus.INSIDE, FlowStatus.LEAVING,
                                          FlowStatus.OUTSIDE, FlowStatus.OUTSIDE,
                                          FlowStatus.OUTSIDE, FlowStatus.OUTSIDE], np.uint8),
                                pool.capacity)
    faded = kc.cull_crowded_particles(pool.arrays, grid, 1.0, 1 / 60, FI, AC, FO, 1.96 * r, 0, 2)
    start, slots, xy = grid.acc_start, grid.acc_slot, grid.acc_xy
    npt.assert_array_equal(np.sort(slots[:start[-1]]), want)  # the same, compact
    npt.assert_array_equal(xy[:start[-1]], pool.screen_px[slots[:start[-1]]])
    # the carrier flags of each cell's accepted particles: 1 INSIDE, 2 INSIDE or LEAVING
    s = pool.status[slots[:start[-1]]]
    for c in range(gw * gh):
        cs = s[start[c]:start[c + 1]]
        want_flags = (1 if (cs == FlowStatus.INSIDE).any() else 0) | (
            2 if ((cs == FlowStatus.INSIDE) | (cs == FlowStatus.LEAVING)).any() else 0)
        assert carriers[c] == want_flags
    got = np.sort(np.concatenate([items[c, :count[c]] for c in range(gw * gh)]))
    npt.assert_array_equal(got, want)
    assert faded == keep.sum() - len(want)
    assert np.all(pool.fade_reason[np.setdiff1d(np.flatnonzero(keep), want)]
                  == FadeReason.POISSON_DISK)


def test_cull_keeps_the_slot_order_when_cells_overflow(rng):
    r = 6.0
    pool = _pool(rng, 900)
    pool.birth_s[:] = 0.0
    grid = _grid(320, 180, 4 * r, pool.capacity, per_cell=3)  # room for 3: some cells overflow
    want = reference.cull_in_slot_order(pool.screen_px, pool.alive, 1.5 * r, 4 * r, 3)
    kc.cull_crowded_particles(pool.arrays, grid, 1.0, 1 / 60, FI, AC, FO, 1.5 * r, 0, 2)
    count, items = grid.cell_count, grid.cell_items
    got = np.concatenate([items[c, :count[c]] for c in range(grid.gw * grid.gh)])
    npt.assert_array_equal(np.sort(got), want)
    start, slots, xy = grid.acc_start, grid.acc_slot, grid.acc_xy
    npt.assert_array_equal(slots[:start[-1]], got)  # the same rows, compact, with positions
    npt.assert_array_equal(xy[:start[-1]], pool.screen_px[got])


def test_blocked_direction_table_matches_reference_and_is_sound(rng):
    r, gap = 5.0, 1.92 * 5.0
    table, touched, cell = kf.direction_table(r, gap)
    n = table.shape[0]
    assert n * cell > 2 * (2 * r + gap)
    want = reference.blocked_directions(r, gap, cell, n)
    bits = (table[..., None] >> np.arange(64, dtype=np.uint64)) & np.uint64(1)
    npt.assert_array_equal(bits.astype(bool), want)
    may = reference.touched_directions(r, gap, cell, n)
    bits = (touched[..., None] >> np.arange(64, dtype=np.uint64)) & np.uint64(1)
    npt.assert_array_equal(bits.astype(bool), may)
    assert not (want & ~may).any()  # surely blocked ⊂ maybe blocked
    # sound: a set bit of the first means the whole arc is blocked for any neighbour in the
    # square; a direction blocked by a neighbour has its bit in the second
    q = rng.uniform(-2 * r - gap, 2 * r + gap, (20000, 2))
    theta = rng.uniform(0, 2 * np.pi, 20000)
    ix = ((q + 0.5 * n * cell) / cell).astype(int)
    k = (theta / (2 * np.pi / 64)).astype(int)
    blocked = want[ix[:, 1], ix[:, 0], k]
    assert blocked.sum() > 1000
    p = 2 * r * np.c_[np.cos(theta), np.sin(theta)]
    close = np.hypot(*(p - q).T) < gap
    assert np.all(close[blocked])
    assert close.sum() > 2000 and np.all(may[ix[:, 1], ix[:, 0], k][close])
    assert (~may[ix[:, 1], ix[:, 0], k]).sum() > 5000  # and it does rule many out


def test_fill_shortcuts_give_the_same_disk():
    """The tables only skip work that finds nothing (candidates with no free arc, neighbours
    that block nothing in the bins left free): with no shortcuts (no bin surely blocked, every
    bin maybe blocked) the fill of a stretching screen places as many particles (the random
    choices differ), both keep the gap and leave no hole."""
    from scipy.spatial import cKDTree

    pools = [ParticlePool(3000) for _ in range(2)]
    r, w, h, gap = 5.0, 240, 160, 1.92 * 5.0
    for pool, shortcuts in zip(pools, (True, False)):
        grid = _grid(w, h, 4 * r, pool.capacity)
        table = kf.direction_table(r, gap)
        if not shortcuts:
            table.blocked[:] = 0
            table.touched[:] = ~np.uint64(0)
        for f in range(12):
            pool.screen_px[pool.alive] *= 1.01  # stretch: holes open between frames
            kc.cull_crowded_particles(pool.arrays, grid, 1.0, 1 / 60, FI, AC, FO, 1.9 * r, f, 2)
            kf.fill_poisson_holes(pool.arrays, grid, table, 1.0, r, gap, 5 + f, -1.0, -1.0, 1.0,
                                  1.0)
        pts = pool.screen_px[pool.alive]
        new_pts = pool.screen_px[pool.alive & (pool.birth_s == 1.0)]
        d, _ = cKDTree(pts).query(new_pts, k=2)
        assert d[:, 1].min() >= gap - 1e-3
        gx, gy = np.meshgrid(np.arange(0.5, w), np.arange(0.5, h))
        hole, _ = cKDTree(pts).query(np.c_[gx.ravel(), gy.ravel()])
        assert hole.max() < 3 * r
    assert pools[0].count > 300
    assert abs(pools[0].count - pools[1].count) <= 0.03 * pools[1].count


def _fill(pool, r, w, h, seed=3, frames=1):
    grid = _grid(w, h, 4 * r, pool.capacity)
    table = kf.direction_table(r, 2.0 * r)
    total = 0
    for f in range(frames):
        kc.cull_crowded_particles(pool.arrays, grid, 1.0, 1 / 60, FI, AC, FO, 1.96 * r, f, 2)
        total += kf.fill_poisson_holes(pool.arrays, grid, table, 1.0, r, 2.0 * r, seed + f,
                                       -1.0, -1.0, 1.0, 1.0)
    return total


def test_fill_from_empty_screen_gives_a_poisson_disk(rng):
    r, w, h = 5.0, 320, 180
    pool = ParticlePool(4000)
    n = _fill(pool, r, w, h, frames=20)
    pts = pool.screen_px[pool.alive]
    assert n == pool.count > 0
    assert np.all((pts >= 0) & (pts < (w, h)))
    from scipy.spatial import cKDTree

    d, _ = cKDTree(pts).query(pts, k=2)
    assert d[:, 1].min() >= 1.96 * r - 1e-3
    density = len(pts) / (w * h / (2 * r) ** 2)
    assert 0.87 * 0.85 < density < 0.87 * 1.15, density
    # maximal: every pixel is within 2r (a little more at the border) of a particle
    gx, gy = np.meshgrid(np.arange(0.5, w), np.arange(0.5, h))
    gap, _ = cKDTree(pts).query(np.c_[gx.ravel(), gy.ravel()])
    assert gap.max() < 3 * r
    # new particles start invisible, uninitialised, with offsets in the box
    assert np.all(pool.intensity[pool.alive] == 0)
    assert np.all(pool.status[pool.alive] == FlowStatus.UNKNOWN)
    assert np.all(np.abs(pool.offset_m[pool.alive]) <= 1.0)


def test_fill_stops_cleanly_when_the_pool_is_full():
    pool = ParticlePool(37)
    n = _fill(pool, 5.0, 320, 180, frames=3)
    assert n == 37 and pool.count == 37 and pool.alive.all()


def test_fill_is_deterministic_for_a_seed():
    a, b = ParticlePool(2000), ParticlePool(2000)
    _fill(a, 5.0, 200, 100, seed=11, frames=5)
    _fill(b, 5.0, 200, 100, seed=11, frames=5)
    npt.assert_array_equal(a.screen_px, b.screen_px)
    npt.assert_array_equal(a.offset_m, b.offset_m)


def test_move_matches_reference(rng):
    pool = _pool(rng, 300)
    pool.has_world[:] = True
    pool.has_world[rng.random(300) < 0.1] = False
    pool.world_m[:] = rng.uniform(0, 10, (300, 3))
    pool.velocity_mps[:] = rng.uniform(-2, 2, (300, 2))
    pool.status[:] = rng.choice([FlowStatus.INSIDE, FlowStatus.LEAVING, FlowStatus.OUTSIDE,
                                 FlowStatus.UNKNOWN, FlowStatus.ON_SKY], 300)
    live = pool.alive & pool.has_world
    moving = live & ((pool.status == FlowStatus.INSIDE) | (pool.status == FlowStatus.LEAVING))
    asking = moving | (live & (pool.status == FlowStatus.UNKNOWN))
    start = pool.world_m.copy()
    want = reference.euler_move(pool.world_m, pool.velocity_mps, 0.25)
    flat = np.zeros((3, 3), np.float32)
    water = np.full((3, 3), np.nan, np.float32)
    surface = one_tile_surface(flat, water, -100.0, -100.0, 100.0)
    index = np.zeros(300, np.int32)
    xy = np.zeros((300, 2))
    no_box = np.array([np.inf, np.inf, -np.inf, -np.inf])
    moved, n, n_status = ka.move_particles(
        pool.counters[2], pool.alive, pool.has_world, pool.world_m, pool.velocity_mps,
        pool.status, 0.25, surface, 0, 1, 1, no_box, no_box, index, xy)
    assert moved == moving.sum() and n_status == 0
    npt.assert_allclose(pool.world_m[moving, :2], want[moving, :2], rtol=1e-6)
    npt.assert_array_equal(pool.world_m[~moving], start[~moving])
    assert np.allclose(pool.world_m[moving, 2], 0.0)  # altitude follows the (flat) ground
    # the particles that ask the flow, in slot order, at their new positions
    npt.assert_array_equal(index[:n], np.flatnonzero(asking))
    npt.assert_array_equal(xy[:n], pool.world_m[asking, :2])
    # every 2nd frame, staggered by slot, an INSIDE particle asks for its status alone (listed
    # from the end), except inside the box (moving obstacles)
    box = np.array([0.0, 0.0, 5.0, 5.0])
    _, n, n_status = ka.move_particles(
        pool.counters[2], pool.alive, pool.has_world, pool.world_m, pool.velocity_mps,
        pool.status, 0.25, surface, 1, 1, 2, box, no_box, index, xy)
    slots = np.arange(pool.capacity)
    in_box = np.all((pool.world_m[:, :2] >= 0) & (pool.world_m[:, :2] <= 5), axis=1)
    quiet = asking & (pool.status == FlowStatus.INSIDE) & ((slots + 1) % 2 == 1) & ~in_box
    npt.assert_array_equal(index[:n], np.flatnonzero(asking & ~quiet))
    npt.assert_array_equal(index[300 - n_status:][::-1], np.flatnonzero(quiet))
    npt.assert_array_equal(xy[300 - n_status:][::-1], pool.world_m[quiet, :2])
    assert n_status > 20 and n + n_status == asking.sum()
    pool.world_m[:, 2] = 0.0
    ka.move_particles(pool.counters[2], pool.alive, pool.has_world, pool.world_m,
                      pool.velocity_mps, pool.status, 0.25,
                      one_tile_surface(flat + 1, water, -100.0, -100.0, 100.0), 1, 4, 1, no_box,
                      no_box, index, xy)
    looked_up = moving & ((np.arange(pool.capacity) + 1) % 4 == 0)
    assert np.allclose(pool.world_m[looked_up, 2], 1.0)  # every 4th frame, by slot
    assert np.allclose(pool.world_m[moving & ~looked_up, 2], 0.0)
    # and every frame inside the altitude box (over a fall), whatever the slot
    pool.world_m[:, 2] = 0.0
    ka.move_particles(pool.counters[2], pool.alive, pool.has_world, pool.world_m,
                      pool.velocity_mps, pool.status, 0.25,
                      one_tile_surface(flat + 1, water, -100.0, -100.0, 100.0), 1, 4, 1, no_box,
                      box, index, xy)
    z_box = np.all((pool.world_m[:, :2] >= 0) & (pool.world_m[:, :2] <= 5), axis=1)
    assert (moving & z_box & ~looked_up).sum() > 3
    assert np.allclose(pool.world_m[moving & (looked_up | z_box), 2], 1.0)
    assert np.allclose(pool.world_m[moving & ~looked_up & ~z_box, 2], 0.0)


def test_status_machine():
    pool = ParticlePool(6)
    for _ in range(6):
        kl.allocate_particle(pool.alive, pool.ids, pool.counters, 0)
    S = FlowStatus
    pool.status[:] = [S.UNKNOWN, S.UNKNOWN, S.INSIDE, S.INSIDE, S.LEAVING, S.LEAVING]
    pool.first_query[:] = [True, True, False, False, False, False]
    pool.velocity_mps[:] = 1.0
    answers = np.array([S.INSIDE, S.OUTSIDE, S.INSIDE, S.OUTSIDE, S.INSIDE, S.OUTSIDE], np.uint8)
    vel = np.full((6, 2), 2.0, np.float32)
    g = _grid(100, 100, 40, pool.capacity)
    gw, gh, count, items = g.gw, g.gh, g.cell_count, g.cell_items
    waiting = ka.apply_flow_status(pool.alive, pool.velocity_mps, pool.status, pool.first_query,
                                   pool.screen_px, 6, np.arange(6, dtype=np.int32), answers, vel,
                                   6, 40.0, gw, gh, count, items, 40.0)
    assert waiting == 0
    assert pool.status.tolist() == [S.INSIDE, S.OUTSIDE, S.INSIDE, S.LEAVING, S.INSIDE, S.OUTSIDE]
    assert pool.velocity_mps[:, 0].tolist() == [2, 0, 2, 1, 2, 0]  # LEAVING keeps its velocity
    assert not pool.first_query.any()
    unknown = np.array([S.UNKNOWN], np.uint8)
    pool.status[0] = S.INSIDE
    assert ka.apply_flow_status(pool.alive, pool.velocity_mps, pool.status, pool.first_query,
                                pool.screen_px, 1, np.zeros(1, np.int32), unknown, vel, 1, 40.0,
                                gw, gh, count, items, 40.0) == 1
    # a status-only answer (from keep_velocity_from on) keeps the velocity, INSIDE or leaving
    pool.status[2:4] = S.INSIDE
    pool.velocity_mps[2:4] = 3.0
    ka.apply_flow_status(pool.alive, pool.velocity_mps, pool.status, pool.first_query,
                         pool.screen_px, 2, np.array([2, 3], np.int32),
                         np.array([S.INSIDE, S.OUTSIDE], np.uint8), vel, 0, 40.0, gw, gh, count,
                         items, 40.0)
    assert pool.status[2:4].tolist() == [S.INSIDE, S.LEAVING]
    assert pool.velocity_mps[2:4, 0].tolist() == [3, 3]


def test_pixel_rays_match_the_camera():
    cam = Camera(position=(10, -50, 30), target=(0, 0, 0), size_px=(320, 180))
    _, inv = cam.matrices_for_kernels()
    screen = np.array([[0.5, 0.5], [160, 90], [319.5, 10]], np.float32)
    origin = np.zeros((3, 3))
    direction = np.zeros((3, 3))
    kpl.pixel_rays(np.arange(3, dtype=np.int32), 3, screen, inv, 320, 180, origin, direction)
    _, want = cam.screen_to_ray(screen.astype(float))
    npt.assert_allclose(direction, want, atol=1e-6)


def _river_view(rng, r=5.0, w=320, h=180, n=700):
    """A camera over a flat valley with a 80 m wide river along y (water level 0), particles
    at random pixels, INSIDE over the river and OUTSIDE beside it, in a neighbour grid; the
    valley's surface as one tile (10 m nodes) with its water hints (every 80 m: the deep
    water nearest each hint node, |x| ≤ 20 m)."""
    cam = Camera(position=(30, -260, 120), target=(0, 0, 0), size_px=(w, h))
    fwd, inv = cam.matrices_for_kernels()
    pool = ParticlePool(n + 400)
    for _ in range(n):
        kl.allocate_particle(pool.alive, pool.ids, pool.counters, 0)
    pool.screen_px[:n] = rng.uniform((0, 0), (w, h), (n, 2))
    origin, direction = cam.screen_to_ray(pool.screen_px[:n].astype(float))
    t = -origin[:, 2] / direction[:, 2]
    pool.world_m[:n] = origin + t[:, None] * direction
    pool.has_world[:n] = True
    river = np.abs(pool.world_m[:n, 0]) < 40
    pool.status[:n] = np.where(river, FlowStatus.INSIDE, FlowStatus.OUTSIDE)
    pool.status[:n][rng.random(n) < 0.05] = FlowStatus.LEAVING
    gx = np.arange(-400, 401, 10.0)
    ground = np.zeros((len(gx), len(gx)), np.float32)
    water = np.where(np.abs(gx)[None, :] < 40, 0.0, np.nan).astype(np.float32) + ground
    grids = one_tile_surface(ground, water, -400.0, -400.0, 10.0, _valley_hints())
    g = _grid(w, h, 4 * r, pool.capacity)
    gw, gh, count, items = g.gw, g.gh, g.cell_count, g.cell_items
    cells = (np.floor(pool.screen_px[:n, 1] / (4 * r)) * gw
             + np.floor(pool.screen_px[:n, 0] / (4 * r))).astype(int)
    for i in np.argsort(cells, kind="stable"):
        items[cells[i], count[cells[i]]] = i
        count[cells[i]] += 1
    order = np.concatenate([items[c, :count[c]] for c in range(gw * gh)])
    return pool, (fwd, inv), grids, g, order


def _valley_hints() -> np.ndarray:
    """(11, 11, 3): the flat valley's hints every 80 m from (-400, -400): deep water nearest
    the node (x clipped to ±20 m, the same y, level 0)."""
    node = np.arange(-400.0, 401.0, 80.0)
    hints = np.zeros((11, 11, 3), np.float32)
    hints[..., 0] = np.clip(node, -20, 20)[None, :]
    hints[..., 1] = node[:, None]
    return hints


def test_one_tile_surface_serves_the_kernels():
    gx = np.arange(-400, 401, 10.0)
    ground = np.zeros((len(gx), len(gx)), np.float32)
    water = np.where(np.abs(gx)[None, :] < 40, 0.0, np.nan).astype(np.float32) + ground
    s = one_tile_surface(ground, water, -400.0, -400.0, 10.0, _valley_hints())
    assert s.n == 80 and s.root_size == 800.0 and s.hint_cells == 10
    from riverflow.kernels.surface_tiles import hint_at, sample_surface, surface_altitude
    assert sample_surface(s, 0.0, 0.0) == (0.0, 0.0, True)
    g, w, found = sample_surface(s, 100.0, 5.0)
    assert found and g == 0.0 and math.isnan(w)
    assert not sample_surface(s, 500.0, 0.0)[2]            # outside the tile
    assert surface_altitude(s, 100.0, 0.0) == 0.0
    assert hint_at(s, 30.0, 35.0) == (0, 5, 5)              # nearest hint node (0, 0)
    with pytest.raises(ValueError):
        one_tile_surface(ground[:, :-1], water[:, :-1], 0.0, 0.0, 1.0)


def _near_args(pool, grid, r):
    """The NEAR check's arguments up to ``reach_px``, the grid's particles as the cull's
    accepted ones (compact by cell) with their carrier flags."""
    gw, gh, count, items = grid.gw, grid.gh, grid.cell_count, grid.cell_items
    start = np.r_[0, np.cumsum(count)].astype(np.int32)
    slots = np.concatenate([items[c, :count[c]] for c in range(gw * gh)]).astype(np.int32)
    grid.acc_start[:] = start
    grid.acc_slot[:len(slots)] = slots
    grid.acc_xy[:len(slots)] = pool.screen_px[slots]
    s = pool.status[slots]
    for c in range(gw * gh):
        cs = s[start[c]:start[c + 1]]
        grid.carrier_cells[c] = 3 if (cs == FlowStatus.INSIDE).any() else (
            2 if (cs == FlowStatus.LEAVING).any() else 0)
    return pool.arrays, grid, 1.0, FI + AC, 4 * r


def test_near_water_check_matches_reference(rng):
    r, w, h = 5.0, 320, 180
    pool, (fwd, inv), grids, grid, order = _river_view(rng)
    hints, hint_cell = _valley_hints(), 80.0
    pool.birth_s[:] = 0.0
    pool.birth_s[rng.random(pool.capacity) < 0.1] = -40.0  # fading: not looked at
    before = pool.alive.copy()
    for frame in range(4):
        want_removed, want_probes, want_owners = reference.check_outside_near_water(
            pool.alive, pool.ids, pool.status, pool.screen_px, pool.world_m, pool.birth_s, 1.0,
            FI + AC, order, frame, 2, 4, 4 * r, 2 * r, w, h, fwd, (30.0, -260.0), hints,
            -400.0, -400.0, hint_cell)
        out = np.zeros((4000, 2), np.float32)
        owner = np.zeros(4000, np.int32)
        alive = pool.alive.copy()
        n_removed, n = ka.check_outside_near_water(
            *_near_args(pool, grid, r), frame, 2, 4, 2 * r, w, h, fwd, 30.0, -260.0, grids, out,
            owner)
        npt.assert_array_equal(np.flatnonzero(alive & ~pool.alive), np.sort(want_removed))
        assert n_removed == len(want_removed)
        npt.assert_allclose(out[:n], want_probes, atol=1e-3)
        npt.assert_array_equal(owner[:n], want_owners)
    assert (before & ~pool.alive).sum() > 3  # some were replaced
    assert np.all(pool.status[before & ~pool.alive] == FlowStatus.NEAR)


def test_near_water_probes_find_the_river_with_no_particle_on_it(rng):
    """The water hints lead to the river even when no particle is INSIDE (a thin far river
    that every particle missed): each probe is on screen, uncovered, and its pixel sees the
    deep water; a hint is found once per particle and kept."""
    r, w, h = 5.0, 320, 180
    pool, (fwd, inv), grids, grid, order = _river_view(rng, n=250)
    pool.status[pool.alive] = FlowStatus.OUTSIDE  # nobody landed on the river
    out = np.zeros((8000, 2), np.float32)
    owner = np.zeros(8000, np.int32)
    _, n = ka.check_outside_near_water(
        *_near_args(pool, grid, r), 0, 1, 2**30, 2 * r, w, h, fwd, 30.0, -260.0, grids, out, owner)
    assert n > 5
    cam = Camera(position=(30, -260, 120), target=(0, 0, 0), size_px=(w, h))
    origin, direction = cam.screen_to_ray(out[:n].astype(float))
    x = origin[:, 0] - origin[:, 2] / direction[:, 2] * direction[:, 0]
    assert np.all(np.abs(x) <= 20 + 0.1)  # on the deep water (the hint nodes)
    d = np.hypot(*(out[:n] - pool.screen_px[owner[:n]]).T)
    assert np.all(d < 4 * r)
    assert np.all(pool.hint_id[owner[:n]] == pool.ids[owner[:n]])
    # a hint given up (x = inf) is not probed again; a new particle in the slot gets its own
    pool.water_hint_m[owner[:n], 0] = np.inf
    _, n2 = ka.check_outside_near_water(
        *_near_args(pool, grid, r), 0, 1, 2**30, 2 * r, w, h, fwd, 30.0, -260.0, grids, out, owner)
    assert n2 == 0
    pool.ids[pool.alive] += 1000
    _, n3 = ka.check_outside_near_water(
        *_near_args(pool, grid, r), 0, 1, 2**30, 2 * r, w, h, fwd, 30.0, -260.0, grids, out, owner)
    assert n3 == n


def test_place_at_seen_water_matches_reference(rng):
    r = 5.0
    pool, _, _, grid, order = _river_view(rng, n=500)
    pool.status[pool.status == FlowStatus.INSIDE] = FlowStatus.OUTSIDE  # a dry river to fill
    pool.status[:20] = FlowStatus.UNKNOWN
    pool.birth_s[:] = 0.0
    pool.birth_s[20:40] = -40.0  # fading: not in the way
    probes = rng.uniform((0, 0), (320, 180), (200, 2)).astype(np.float32)
    hit = rng.choice(np.array([1, 2], np.uint8), 200, p=(0.3, 0.7))
    flow = rng.choice(np.array([FlowStatus.INSIDE, FlowStatus.OUTSIDE], np.uint8), 200,
                      p=(0.8, 0.2))
    want_rows, want_removed = reference.place_at_seen_water(
        pool.alive, pool.status, pool.screen_px, pool.birth_s, 1.0, FI + AC, order, probes,
        hit, flow, 1.92 * r)
    before = pool.alive.copy()
    ids = pool.ids.copy()
    xyz = rng.uniform(-5, 5, (200, 3))
    vel = rng.uniform(-1, 1, (200, 2)).astype(np.float32)
    placed, removed = ka.place_at_seen_water(
        pool.arrays, grid, ka.Probes(probes, hit, xyz, flow, vel), 200, 1.0, FI, AC, 1.92 * r, 3,
        -1.0, -1.0, 1.0, 1.0)
    new = grid.new_slots
    assert placed == len(want_rows) > 10 and removed == len(want_removed)
    gone = before & (~pool.alive | (pool.ids != ids))  # (a freed slot may take a new one)
    npt.assert_array_equal(np.flatnonzero(gone), np.sort(want_removed))
    slots = new[:placed]
    npt.assert_array_equal(pool.screen_px[slots], probes[want_rows])
    npt.assert_array_equal(pool.world_m[slots], xyz[want_rows])
    assert np.all(pool.status[slots] == FlowStatus.INSIDE) and pool.has_world[slots].all()
    assert not pool.first_query[slots].any()
    npt.assert_array_equal(pool.velocity_mps[slots], vel[want_rows])


def test_a_hint_is_looked_for_again_while_its_tile_is_not_made(rng):
    """A land particle whose hint track crosses a leaf with no hints tile yet finds no hint
    and keeps none (hint_id unset), so it looks again once the tile is there."""
    r, w, h = 5.0, 320, 180
    pool, (fwd, inv), grids, grid, order = _river_view(rng, n=250)
    pool.status[pool.alive] = FlowStatus.OUTSIDE
    waiting = grids._replace(hint_slot=np.full(1, -1, np.int32))
    out = np.zeros((8000, 2), np.float32)
    owner = np.zeros(8000, np.int32)
    _, n = ka.check_outside_near_water(
        *_near_args(pool, grid, r), 0, 1, 2**30, 2 * r, w, h, fwd, 30.0, -260.0, waiting, out,
        owner)
    assert n == 0
    on_tile = pool.alive & np.all(np.abs(pool.world_m[:, :2]) < 400.0, axis=1)
    assert on_tile.sum() > 100
    assert not np.any(pool.hint_id[on_tile] == pool.ids[on_tile])
    _, n = ka.check_outside_near_water(
        *_near_args(pool, grid, r), 0, 1, 2**30, 2 * r, w, h, fwd, 30.0, -260.0, grids, out,
        owner)
    assert n > 5                                       # the tile came: hints, probes
