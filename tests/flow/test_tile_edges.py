"""Points on flow-tile edges, corners and the domain's edge (issue #30, item 3).

A point lying exactly on the edge between two tiles belongs to one of them (the half-open
rule of ``kernels.flow.root_unit``); the tile ``FlowField`` makes for it must be the tile the
kernels read, so ``query`` answers INSIDE or OUTSIDE, as its neighbours 1 µm away do, and
never UNKNOWN. The root side of the built-in scene is a power of two (4096 m), where a
multiplication by the reciprocal rounds like the division; the shifted domain is not, so it
also catches a kernel and its numpy twin rounding differently.
"""
from __future__ import annotations

import numpy as np
import pytest

import riverflow as rf

MICRON = 1e-6
N_POINTS = 100_000


def edge_points(field: rf.FlowField, rng: np.random.Generator, n: int, level: int,
                anchors: int | None = None) -> tuple[np.ndarray, np.ndarray]:
    """``n`` points near the rivers snapped exactly onto the tile edges of ``level`` (a third
    on vertical edges, a third on horizontal ones, a third on corners), and (n, 4, 2) of their
    neighbours 1 µm away on each side of the edge(s) they lie on. ``anchors``: near that many
    axis points only (few tiles to make in a large world), default near every one."""
    t = field.tiles
    axes = field.graph.axes()
    centre = np.concatenate([np.asarray(field.graph.curves[a].points)[:, :2] for a in axes])
    if anchors is not None:
        centre = centre[rng.choice(len(centre), min(anchors, len(centre)), replace=False)]
    width = max(field.graph.curves[a].width_m for a in axes)
    spread = min(0.6 * width, 0.5 * t.tile_size_m(field.max_level))
    pts = centre[rng.integers(0, len(centre), n)] + rng.normal(0.0, spread, (n, 2))
    size = t.tile_size_m(level)
    root = np.array([t.root_x_m, t.root_y_m])
    k = np.round((pts - root) / size)
    k = np.clip(k, 0, 1 << level)                     # on the domain's edges too
    snapped = root + k * size
    mode = rng.integers(0, 3, n)                      # 0: x edge, 1: y edge, 2: corner
    on_x = mode != 1
    on_y = mode != 0
    pts[on_x, 0] = snapped[on_x, 0]
    pts[on_y, 1] = snapped[on_y, 1]
    sx = np.where(on_x, MICRON, 0.0)
    sy = np.where(on_y, MICRON, 0.0)
    signs = np.array([(-1, -1), (-1, 1), (1, -1), (1, 1)], np.float64)
    neighbours = pts[:, None, :] + signs[None] * np.stack([sx, sy], 1)[:, None, :]
    return pts, neighbours


def check_edges(field: rf.FlowField, rng: np.random.Generator, n: int,
                anchors: int | None = None) -> int:
    """Query ``n`` edge points spread over every level (at their level and at the finest);
    returns how many were INSIDE (the test must exercise water)."""
    inside = 0
    levels = range(field.max_level + 1)
    per_level = n // (2 * len(levels))
    for level in levels:
        pts, nb = edge_points(field, rng, per_level, level, anchors)
        for query_level in (level, field.max_level):   # a coarse level's edges at every level
            status, velocity = field.query(pts, level=query_level)
            assert not (status == rf.FlowStatus.UNKNOWN).any(), (
                level, query_level, pts[status == rf.FlowStatus.UNKNOWN][:5])
            assert np.isin(status, (rf.FlowStatus.INSIDE, rf.FlowStatus.OUTSIDE,
                                    rf.FlowStatus.OUTSIDE_DOMAIN)).all()
            assert np.isfinite(velocity).all()
            s_nb, _ = field.query(nb.reshape(-1, 2), level=query_level)
            s_nb = s_nb.reshape(-1, 4)
            assert not (s_nb == rf.FlowStatus.UNKNOWN).any()
            in_domain = s_nb != rf.FlowStatus.OUTSIDE_DOMAIN
            # the point is in the domain when one of its neighbours is (the domain is closed)
            assert (status != rf.FlowStatus.OUTSIDE_DOMAIN)[in_domain.any(1)].all()
            nb_inside = np.where(in_domain, s_nb == rf.FlowStatus.INSIDE, False)
            nb_outside = np.where(in_domain, s_nb == rf.FlowStatus.OUTSIDE, False)
            all_in = nb_inside.sum(1) == in_domain.sum(1)
            all_out = nb_outside.sum(1) == in_domain.sum(1)
            has = in_domain.any(1)
            bad_in = has & all_in & (status != rf.FlowStatus.INSIDE)
            bad_out = has & all_out & (status != rf.FlowStatus.OUTSIDE)
            assert not bad_in.any(), (level, query_level, pts[bad_in][:5])
            assert not bad_out.any(), (level, query_level, pts[bad_out][:5])
            psi = field.potential(pts, level=query_level)
            assert np.isnan(psi[status != rf.FlowStatus.INSIDE]).all()
            if query_level == field.max_level:         # coarse tiles may lack a ψ stencil
                assert np.isfinite(psi[status == rf.FlowStatus.INSIDE]).all()
            inside += int((status == rf.FlowStatus.INSIDE).sum())
    return inside


@pytest.fixture(scope="module")
def scene():
    return rf.default_scene(seed=0)


def test_built_in_scene_tile_edges_are_never_unknown(scene):
    field = rf.FlowField.for_scene(scene)
    assert check_edges(field, np.random.default_rng(30), N_POINTS) > N_POINTS // 10


def test_a_domain_whose_side_is_no_power_of_two(scene):
    """4201.9 m: x / s and x · (1/s) round differently for some x."""
    x0, y0, x1, y1 = scene.bounds_m
    field = rf.FlowField(scene.graph, domain_m=(x0 - 53.3, y0 - 2.7, x1 - x0 + 105.9),
                         cache_tiles=64)
    assert check_edges(field, np.random.default_rng(31), N_POINTS // 2) > N_POINTS // 20


def test_tile_of_is_the_tile_the_kernels_read(scene):
    """The numpy twin (FlowField.tile_of) against the kernels: with exactly the tiles it names
    made, a query of the same points finds every one of them cached."""
    field = rf.FlowField(scene.graph, domain_m=(-2100.3, -2050.7, 4201.9), cache_tiles=4096)
    rng = np.random.default_rng(32)
    lv = field.max_level
    pts, _ = edge_points(field, rng, 20_000, lv)
    keys = field.tile_of(pts, lv)
    wet = [tuple(k) for k in np.unique(keys[keys[:, 0] >= 0], axis=0)
           if field.tiles.is_wet(lv, *k)]
    field.ensure_tiles(lv, wet)
    from riverflow.kernels import flow as kf
    status = np.empty(len(pts), np.uint8)
    velocity = np.empty((len(pts), 2), np.float32)
    missing = kf.query_velocity(np.ascontiguousarray(pts), np.zeros(0, np.int8), lv, 0,
                                field.tiles.view(), field.tiles.cache.next_tick(),
                                field.segments, len(pts), status, velocity)
    assert missing == 0
    # the far edge of the domain is in the last tile, outside it is outside
    t = field.tiles
    far = np.array([[t.root_x_m + t.root_size_m, t.root_y_m + t.root_size_m],
                    [t.root_x_m + t.root_size_m, t.root_y_m],
                    [t.root_x_m + t.root_size_m + 1e-3, t.root_y_m],
                    [t.root_x_m - 1e-3, t.root_y_m]])
    n = 1 << lv
    assert field.tile_of(far, lv).tolist() == [[n - 1, n - 1], [n - 1, 0], [-1, -1], [-1, -1]]


@pytest.mark.slow
def test_a_1000_km_scene_tile_edges_are_never_unknown():
    field = rf.FlowField.for_scene(rf.default_scene(seed=0, size_km=1000.0), cache_tiles=512)
    # near one axis point: 100,000 points on every level's edges in a few tiles (8 took 48 s)
    assert check_edges(field, np.random.default_rng(33), N_POINTS, anchors=1) > N_POINTS // 10
