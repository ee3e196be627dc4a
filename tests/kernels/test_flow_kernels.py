"""Each flow kernel against its plain-numpy twin in tests/reference.py."""
from __future__ import annotations

import numpy as np
import numpy.testing as npt
import pytest
import shapely

import riverflow as rf
from riverflow.kernels import flow as kf
from tests import reference
from tests.flow.networks import NETWORKS


@pytest.fixture(scope="module", params=list(NETWORKS))
def field(request):
    graph, _ = NETWORKS[request.param]()
    return rf.FlowField(graph, slip=1.3 if request.param == "confluence" else 1.0)


def _sample(field, rng, n):
    x0, y0, x1, y1 = field.graph.bounds()
    return rng.uniform((x0 - 20, y0 - 20), (x1 + 20, y1 + 20), (n, 2))


def test_evaluate_potential_matches_reference(field, rng):
    pts = _sample(field, rng, 300)
    got = field.exact_potential(pts)
    want = reference.potential(field.network, pts, field.slip)
    npt.assert_array_equal(np.isnan(got), np.isnan(want))
    # the vertex tie rule accepts distances within 1e-4 of the nearest: which of two tied
    # segments wins depends on pruning, so ψ may differ in the 5th digit
    npt.assert_allclose(got, want, rtol=1e-4, atol=1e-4)
    assert np.isfinite(got).sum() > 30


def test_proland_potential_matches_reference(proland_graph_path, rng):
    field = rf.FlowField(rf.load_graph(proland_graph_path), slip=1.3, search_radius_factor=20.0)
    pts = _sample(field, rng, 300)
    got = field.exact_potential(pts)
    npt.assert_allclose(got, reference.potential(field.network, pts, 1.3), rtol=1e-4, atol=1e-4)


def test_gather_box_segments_keeps_each_curves_nearest_segment(field, rng):
    net = field.network
    n = net.n_curves
    blk = kf.BoxLists(*[np.empty(n, np.int32) for _ in range(3)],
                      np.empty(net.n_segments, np.int32), np.empty(n), np.empty(net.n_segments))
    seg = blk.seg
    a = np.c_[net.seg_ax, net.seg_ay]
    b = np.c_[net.seg_bx, net.seg_by]
    for p0 in _sample(field, rng, 30):
        box = (p0[0], p0[1], p0[0] + 15.0, p0[1] + 11.0)
        nb = kf.gather_box_segments(*box, net.arrays, blk)
        kept = {blk.curve[k]: seg[blk.start[k]:blk.start[k] + blk.count[k]] for k in range(nb)}
        for p in rng.uniform(box[:2], box[2:], (10, 2)):
            for c in range(n):
                d = reference._dist2(p, a[net.curve_seg0[c]:net.curve_seg1[c]],
                                     b[net.curve_seg0[c]:net.curve_seg1[c]])
                if d.min() > net.curve_cutoff[c] ** 2:
                    continue
                assert c in kept
                assert reference._dist2(p, a[kept[c]], b[kept[c]]).min() == d.min()


def test_a_tiles_segment_list_gives_each_block_what_a_full_scan_keeps(field, rng):
    """``segments_near_box`` lists, once for a tile's lattice, each curve's segments within its
    cutoff of the box, or a hair beyond (its twin: shapely's distances), and a block inside
    the box gathering from that list (what ``build_flow_tile`` does) keeps what
    ``gather_box_segments`` keeps scanning every segment of every curve: the same curves,
    segments, order and distances."""
    net = field.network
    n, m = net.n_curves, net.n_segments
    lo, hi, listed = np.empty(n, np.int32), np.empty(n, np.int32), np.empty(m, np.int32)
    segments = shapely.linestrings(np.stack([np.c_[net.seg_ax, net.seg_ay],
                                             np.c_[net.seg_bx, net.seg_by]], axis=1))
    curve_of = np.repeat(np.arange(n), net.curve_seg1 - net.curve_seg0)
    full = kf.BoxLists(*[np.empty(n, np.int32) for _ in range(3)], np.empty(m, np.int32),
                       np.empty(n), np.empty(m))
    part = kf.BoxLists(*[np.empty_like(a) for a in full])
    checked = 0
    for p0 in _sample(field, rng, 12):
        size = rng.uniform(5.0, 120.0)
        tile = (p0[0], p0[1], p0[0] + size, p0[1] + size)
        count = kf.segments_near_box(*tile, net.arrays, lo, hi, listed)
        d2 = shapely.distance(shapely.box(*tile), segments) ** 2
        cut2 = net.curve_cutoff[curve_of] ** 2
        got = set(listed[:count].tolist())
        assert set(np.flatnonzero(d2 <= cut2).tolist()) <= got      # a hair more: the slack
        assert got <= set(np.flatnonzero(d2 <= cut2 * (1.0 + kf.NEAR_BOX_SLACK)
                                         + kf.NEAR_BOX_SLACK).tolist())
        for c in range(n):
            assert (np.diff(listed[lo[c]:hi[c]]) > 0).all()
            assert ((listed[lo[c]:hi[c]] >= net.curve_seg0[c])
                    & (listed[lo[c]:hi[c]] < net.curve_seg1[c])).all()
        for k in range(6):      # blocks inside the tile, on its edges and corners too
            u = np.sort(rng.uniform(0.0, 1.0, (2, 2)), axis=1)
            if k < 2:
                u[:, k] = k
            x0, x1 = tile[0] + u[0] * size
            y0, y1 = tile[1] + u[1] * size
            a = kf.gather_box_segments(x0, y0, x1, y1, net.arrays, full)
            b = kf._gather_listed(x0, y0, x1, y1, net.arrays, lo, hi, listed, True, part)
            assert a == b
            for x, y in zip((*full[:3], full.dmin2), (*part[:3], part.dmin2)):
                npt.assert_array_equal(x[:a], y[:a])
            used = full.start[:a] + full.count[:a]
            ns = int(used.max()) if a else 0
            npt.assert_array_equal(full.seg[:ns], part.seg[:ns])
            checked += ns
    assert checked > 100


def _lattice_of_a_river_tile(field):
    """(tiles, slot, gx, gy): the finest flow tile at the middle of the first river, made,
    and its stored ψ window's lattice points (one ghost ring and the far edge included)."""
    t = field.tiles
    lv = field.max_level
    xy = np.array(field.network.polylines[0][len(field.network.polylines[0]) // 2])[None]
    field.query(xy)
    tx, ty = field.tile_of(xy, lv)[0]
    ox, oy = t.tile_origin_m(lv, tx, ty)
    h = t.spacing_m(lv)
    idx = np.arange(-1, t.n_cells + 2)
    gx, gy = np.meshgrid(ox + idx * h, oy + idx * h)
    return t, t.slot_of(lv, tx, ty), gx, gy


def test_flow_tile_lattice_matches_reference(field):
    t, slot, gx, gy = _lattice_of_a_river_tile(field)
    want = reference.potential(field.network, np.c_[gx.ravel(), gy.ravel()], field.slip)
    got = t.psi[slot].ravel()
    inside = np.isfinite(want)
    assert inside.sum() > 50
    npt.assert_allclose(got[inside], want[inside], rtol=1e-4, atol=1e-4)
    # dry lattice points next to the water hold extrapolated values, far ones NaN
    assert np.isnan(got[~inside]).sum() > 0 or inside.all()


def test_query_velocity_matches_reference(field, rng):
    t = field.tiles
    lv = field.max_level
    h = t.spacing_m(lv)
    pts = _sample(field, rng, 3000)
    status, vel = field.query(pts)
    keys = field.tile_of(pts, lv)
    checked = 0
    for k in np.flatnonzero(status == rf.FlowStatus.INSIDE)[:300]:
        tx, ty = keys[k]
        slot = t.slot_of(lv, tx, ty)
        ox, oy = t.tile_origin_m(lv, tx, ty)
        i, j = int((pts[k, 0] - ox) / h), int((pts[k, 1] - oy) / h)
        if np.isnan(t.psi[slot, j:j + 4, i:i + 4]).any():
            continue  # stencil filled by local extrapolation: not the plain formula
        if (t.cell_segments[slot, j, i] >= 0).any():
            continue  # a bank may be near: its correction (the test below)
        want = reference.lattice_velocity(t.psi[slot], (ox, oy), h, pts[k:k + 1])
        npt.assert_allclose(vel[k], want[0], rtol=1e-4, atol=1e-5)
        checked += 1
    assert checked > 50
    # the points from n_velocity on get the same status and no velocity
    from riverflow.kernels.flow import query_velocity
    half = len(pts) // 2
    s2 = np.empty(len(pts), np.uint8)
    v2 = np.full((len(pts), 2), 9.0, np.float32)
    query_velocity(np.ascontiguousarray(pts), np.zeros(0, np.int8), lv, lv, t.view(),
                   t.cache.tick, field.segments, half, s2, v2)
    npt.assert_array_equal(s2, status)
    npt.assert_array_equal(v2[:half], vel[:half])
    assert np.all(v2[half:] == 0.0)


def test_the_bank_correction_matches_reference_and_its_velocity_is_its_curl(field, rng):
    """Near a bank the cached ψ is the lattice's bicubic corrected to the bank's exact ψ
    (twin: ``reference.bank_corrected_potential``), and the velocity is the curl of that ψ
    (central differences): divergence-free, and along the bank."""
    t = field.tiles
    lv = field.max_level
    h = t.spacing_m(lv)
    net = field.network
    banks = [c for c in range(net.n_curves) if net.curve_kind[c] == kf.KIND_BANK]
    # points 0 … 1.5 lattice spacings in from the banks
    pts = []
    for c in banks:
        s = rng.integers(net.curve_seg0[c], net.curve_seg1[c], 40)
        a = np.c_[net.seg_ax[s], net.seg_ay[s]]
        e = np.c_[net.seg_bx[s], net.seg_by[s]] - a
        left = np.c_[-e[:, 1], e[:, 0]] / np.linalg.norm(e, axis=1)[:, None]
        pts.append(a + rng.uniform(0.1, 0.9, (len(s), 1)) * e
                   + rng.uniform(0.05, 1.5, (len(s), 1)) * h * left)
    pts = np.vstack(pts)
    status, vel = field.query(pts)
    psi = field.potential(pts)
    keys = field.tile_of(pts, lv)
    eps = 1e-3 * h
    checked = corrected = 0
    for k in np.flatnonzero(status == rf.FlowStatus.INSIDE):
        if checked == 60:
            break
        tx, ty = keys[k]
        slot = t.slot_of(lv, tx, ty)
        ox, oy = t.tile_origin_m(lv, tx, ty)
        fu, fv = (pts[k] - (ox, oy)) / h
        i, j = int(fu), int(fv)
        if np.isnan(t.psi[slot, j:j + 4, i:i + 4]).any() or min(fu - i, fv - j) < 0.01 \
                or max(fu - i, fv - j) > 0.99:
            continue  # a stencil filled by local extrapolation; a cell edge in reach
        args = (t.psi[slot].astype(float), (ox, oy), h, t.cell_segments[slot], field.segments)
        want = reference.bank_corrected_potential(*args, pts[k:k + 1])[0]
        plain = reference.lattice_velocity(t.psi[slot].astype(float), (ox, oy), h,
                                           pts[k:k + 1])[0]
        npt.assert_allclose(psi[k], want, rtol=1e-5, atol=1e-5)
        around = pts[k] + np.array([[eps, 0], [-eps, 0], [0, eps], [0, -eps]])
        p4 = reference.bank_corrected_potential(*args, around)
        curl = np.array([-(p4[2] - p4[3]), p4[0] - p4[1]]) / (2 * eps)
        npt.assert_allclose(vel[k], curl, rtol=2e-3, atol=2e-4 * np.abs(curl).max() + 1e-5)
        checked += 1
        corrected += not np.allclose(vel[k], plain, rtol=1e-4, atol=1e-6)
    assert checked > 20 and corrected > 10, (checked, corrected)


def test_lattice_points_beyond_an_open_end_mirror_the_water(field):
    """Twin of ``_mirrored_across_cap``: a dry lattice point beyond a cap (a river's open end,
    within 3 lattice spacings of it) holds ψ at its mirror image across the cap's line, when
    that is in the water: the ghosts continue the flow square to the cap."""
    net = field.network
    t = field.tiles
    lv = field.max_level
    h = t.spacing_m(lv)
    caps = [s for c in range(net.n_curves) if net.curve_kind[c] == kf.KIND_CAP
            for s in range(net.curve_seg0[c], net.curve_seg1[c])]
    a = np.c_[net.seg_ax[caps], net.seg_ay[caps]]
    b = np.c_[net.seg_bx[caps], net.seg_by[caps]]
    mid = 0.5 * (a[0] + b[0])
    field.query(mid[None])
    tx, ty = field.tile_of(mid[None], lv)[0]
    ox, oy = t.tile_origin_m(lv, tx, ty)
    idx = np.arange(-1, t.n_cells + 2)
    gx, gy = np.meshgrid(ox + idx * h, oy + idx * h)
    pts = np.c_[gx.ravel(), gy.ravel()]
    got = t.psi[t.slot_of(lv, tx, ty)].ravel()
    # the lattice points within 3 spacings of a cap, on its dry side, and their mirror images
    cand, mirror = [], []
    for k, p in enumerate(pts):
        d2 = reference._dist2(p, a, b)
        q = int(np.argmin(d2))
        if d2[q] > (3 * h) ** 2 or reference._signed(p, a[q:q + 1], b[q:q + 1])[0][0] >= 0:
            continue
        e = b[q] - a[q]
        cand.append(k)
        mirror.append(2 * (a[q] + ((p - a[q]) @ e / (e @ e)) * e) - p)
    cand = np.array(cand)
    dry = ~np.isfinite(reference.potential(net, pts[cand], field.slip))
    want = reference.potential(net, np.array(mirror)[dry], field.slip)
    ok = np.isfinite(want)
    npt.assert_allclose(got[cand[dry][ok]], want[ok], rtol=1e-4, atol=1e-4)
    checked = int(ok.sum())
    assert checked > 10


def test_boundary_cells_are_where_banks_cross(field):
    t = field.tiles
    lv = field.max_level
    net = field.network
    h = t.spacing_m(lv)
    field.query(np.array(net.polylines[0]))
    banks = shapely.MultiLineString([p for p, k in zip(net.polylines, net.curve_kind)
                                     if k != kf.KIND_AXIS])
    for level, tx, ty in [k for k in t.pool.keys() if k[0] == lv][:4]:
        slot = t.slot_of(level, tx, ty)
        ox, oy = t.tile_origin_m(lv, tx, ty)
        j, i = np.mgrid[0:t.n_cells, 0:t.n_cells]
        cells = shapely.box(ox + i * h, oy + j * h, ox + (i + 1) * h, oy + (j + 1) * h)
        crossed = shapely.intersects(cells, banks)
        status = t.cell_status[slot]
        assert np.all(status[crossed] & kf.CELL_KIND == kf.CELL_BOUNDARY)
        assert set(np.unique(status & kf.CELL_KIND)) <= {kf.CELL_INSIDE, kf.CELL_OUTSIDE,
                                                         kf.CELL_BOUNDARY}


@pytest.fixture(scope="module")
def scene_field():
    return rf.FlowField(rf.default_scene(seed=0).graph)


def test_crowded_coarse_cells_are_flagged_and_stand_ins_wait(scene_field):
    """At a coarse level a cell meets more bank segments than its list keeps: it is flagged
    CELL_CROWDED, exactly where more than CELL_SEGMENTS segments come within a cell diagonal.
    A particle query (fallback > 0) reading such a cell of a tile that is not a leaf of the
    frame's flow cut (a stand-in for a late tile) answers UNKNOWN; the same tile as a leaf of
    the cut answers, and FlowField.query (fallback 0) always answers."""
    field = scene_field
    t = field.tiles
    net = field.network
    pts = np.array(net.polylines[0], np.float64)
    lv = 0
    status, _ = field.query(pts, level=lv)
    slot = t.slot_of(lv, 0, 0)
    assert slot >= 0
    cells = t.cell_status[slot]
    crowded = (cells & kf.CELL_CROWDED) != 0
    assert crowded.any(), "a 4 km root tile's cells are tens of metres: some are crowded"
    assert np.all(cells[crowded] & kf.CELL_KIND == kf.CELL_BOUNDARY)
    # the flag is right: more than CELL_SEGMENTS segments within a diagonal of a flagged cell
    h = t.spacing_m(lv)
    ox, oy = t.tile_origin_m(lv, 0, 0)
    seg = field.segments
    lines = shapely.linestrings(np.stack([np.c_[seg.ax, seg.ay], np.c_[seg.bx, seg.by]], 1))
    for j, i in list(zip(*np.nonzero(crowded)))[:5]:
        box = shapely.box(ox + i * h, oy + j * h, ox + (i + 1) * h, oy + (j + 1) * h)
        near = shapely.distance(lines, box) <= np.sqrt(2.0) * h
        assert near.sum() > kf.CELL_SEGMENTS
    # points in crowded cells of the root tile
    jj, ii = np.nonzero(crowded)
    xy = np.c_[ox + (ii + 0.5) * h, oy + (jj + 0.5) * h]
    s = np.empty(len(xy), np.uint8)
    v = np.empty((len(xy), 2), np.float32)
    from riverflow.tiles.table import TileTable, tile_code
    table = TileTable(4)                                # only the root tile is resident
    table.set(tile_code(0, 0, 0), slot)
    t.pool.arrays["in_cut"][:] = 0
    only_root = t.view()._replace(keys=table.keys, values=table.values)
    missing = kf.query_velocity(xy, np.zeros(0, np.int8), field.max_level, field.max_level,
                                only_root, t.cache.tick, field.segments, len(xy), s, v)
    assert missing == len(xy) and np.all(s == rf.FlowStatus.UNKNOWN)
    t.pool.arrays["in_cut"][slot] = 1                   # the root is the view's own leaf
    missing = kf.query_velocity(xy, np.zeros(0, np.int8), field.max_level, field.max_level,
                                only_root, t.cache.tick, field.segments, len(xy), s, v)
    assert missing == 0 and np.all(s != rf.FlowStatus.UNKNOWN)
    t.pool.arrays["in_cut"][slot] = 0
    status, _ = field.query(xy, level=0)                # no fallback: always answers
    assert np.all(status != rf.FlowStatus.UNKNOWN)


def test_no_nan_and_clear_status_for_bad_points(field):
    bad = np.array([[np.nan, 0.0], [np.inf, 1.0], [-np.inf, np.nan], [1e300, -1e300]])
    status, velocity = field.query(bad)
    assert np.all(status == rf.FlowStatus.OUTSIDE_DOMAIN)
    assert np.all(velocity == 0)
    assert np.all(np.isnan(field.potential(bad)))


def test_dry_lattice_points_hold_quadratic_extrapolations(field):
    """Twin of ``_extrapolate_ghosts``: a dry lattice point next to the water holds the mean,
    over the lattice directions with water beside it, of the quadratic extrapolation from
    the three points inward (linear from two where the third is dry, else the neighbour's
    value); checked where those points lie in the tile's stored window."""
    t, slot, gx, gy = _lattice_of_a_river_tile(field)
    # the water's lattice values are checked against the reference above; here the exact
    # (uncached) kernel gives them, fast
    exact = field.exact_potential(np.c_[gx.ravel(), gy.ravel()]).reshape(gx.shape)
    wet = np.isfinite(exact)
    got = t.psi[slot]
    m = got.shape[0]
    e = np.where(wet, exact, 0.0)
    core = (slice(3, m - 3), slice(3, m - 3))
    two_sum = np.zeros((m - 6, m - 6))
    two_n = np.zeros((m - 6, m - 6))
    one_sum = np.zeros((m - 6, m - 6))
    one_n = np.zeros((m - 6, m - 6))
    for dj, di in ((0, 1), (0, -1), (1, 0), (-1, 0)):
        def at(k):
            return (slice(3 + k * dj, m - 3 + k * dj), slice(3 + k * di, m - 3 + k * di))
        w1, w2, w3 = wet[at(1)], wet[at(2)], wet[at(3)]
        quad = 3 * e[at(1)] - 3 * e[at(2)] + e[at(3)]
        lin = 2 * e[at(1)] - e[at(2)]
        two_sum += np.where(w1 & w2, np.where(w3, quad, lin), 0.0)
        two_n += w1 & w2
        one_sum += np.where(w1 & ~w2, e[at(1)], 0.0)
        one_n += w1 & ~w2
    dry = ~wet[core] & ((two_n > 0) | (one_n > 0))
    want = np.where(two_n > 0, two_sum / np.maximum(two_n, 1), one_sum / np.maximum(one_n, 1))
    assert dry.sum() > 10
    npt.assert_allclose(got[core][dry], want[dry], rtol=1e-4, atol=1e-4)
