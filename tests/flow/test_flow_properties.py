"""Physical properties of the flow field (issue: river networks and their procedural flow).

On the Proland example graph (skipped when ../shared/data is absent) and on networks built in
the tests: a straight channel, a bend with an island, a confluence, a bifurcation that re-joins.
"""
from __future__ import annotations

import numpy as np
import pytest
import shapely

import riverflow as rf
from riverflow.hydro.areas import water_polygon
from tests.flow.networks import NETWORKS, divergence_and_gradient

NAMES = [*NETWORKS, "proland"]


@pytest.fixture(scope="module", params=NAMES)
def case(request):
    """(graph, field, water polygon, typical width [m])."""
    if request.param == "proland":
        from tests.conftest import PROLAND_GRAPH

        if not PROLAND_GRAPH.exists():
            pytest.skip("shared data absent")
        graph = rf.load_graph(PROLAND_GRAPH)
    else:
        graph, _ = NETWORKS[request.param]()
    field = rf.FlowField(graph)
    widths = [graph.curves[a].width_m for a in graph.axes()]
    return request.param, graph, field, water_polygon(graph), float(np.median(widths))


def _bank_psi(graph, point):
    """ψ of the bank nearest to ``point``."""
    best, psi = np.inf, np.nan
    for i in graph.banks():
        d = shapely.LineString(graph.polyline(i)).distance(shapely.Point(point))
        if d < best:
            best, psi = d, graph.curves[i].potential
    return psi


def _sections(graph, water, width, n=12):
    """Water intervals of lines across every axis, away from the axis ends: [(A, B)]."""
    out = []
    for a in graph.axes():
        line = graph.polyline(a)
        ls = shapely.LineString(line)
        for frac in np.linspace(0.2, 0.8, n // 3):
            p = np.array(ls.interpolate(frac, normalized=True).coords[0])
            q = np.array(ls.interpolate(min(frac + 0.01, 1.0), normalized=True).coords[0])
            t = (q - p) / np.linalg.norm(q - p)
            nrm = np.array([-t[1], t[0]])
            cut = shapely.LineString([p - 2 * width * nrm, p + 2 * width * nrm])
            inter = cut.intersection(water)
            for part in getattr(inter, "geoms", [inter]):
                if part.geom_type != "LineString" or part.length < 0.2 * width:
                    continue
                if part.distance(shapely.Point(p)) > 1e-6:  # another reach of the network
                    continue
                A, B = (np.array(c) for c in part.coords[:2])
                out.append((A, B))
    return out


def test_discharge_between_banks_equals_psi_difference(case):
    name, graph, field, water, width = case
    sections = _sections(graph, water, width)
    assert sections
    checked = 0
    for A, B in sections:
        s = np.linspace(0.0, 1.0, 801)
        pts = A + s[:, None] * (B - A)
        status, v = field.query(pts)
        t = (B - A) / np.linalg.norm(B - A)
        n = np.array([-t[1], t[0]])  # flux to the left of A→B equals ψ(B) − ψ(A)
        flux = np.trapezoid(v.astype(float) @ n, s * np.linalg.norm(B - A))
        expected = _bank_psi(graph, B) - _bank_psi(graph, A)
        if expected == 0:
            continue
        assert flux == pytest.approx(expected, rel=0.05), (name, A, B)
        checked += 1
    assert checked >= 3


def test_velocity_is_tangent_to_banks_and_island_shores(case):
    name, graph, field, water, width = case
    offset = 0.04 * width
    ratios = []
    nodes = graph.nodes
    for i in graph.banks():
        bank = shapely.LineString(graph.polyline(i))
        for dist in np.arange(0.5 * width, bank.length - 0.5 * width, 0.25 * width):
            a = np.array(bank.interpolate(dist - 0.01 * width).coords[0])
            b = np.array(bank.interpolate(dist + 0.01 * width).coords[0])
            mid = np.array(bank.interpolate(dist).coords[0])
            seg = b - a
            length = np.linalg.norm(seg)
            if np.min(np.linalg.norm(nodes - mid, axis=1)) < width:  # junctions, river ends
                continue
            inward = np.array([-seg[1], seg[0]]) / length  # water is on the left
            p = mid + offset * inward
            if water.boundary.distance(shapely.Point(p)) < 0.5 * offset:
                continue
            status, v = field.query(p[None])
            speed = float(np.hypot(*v[0]))
            if status[0] != rf.FlowStatus.INSIDE or speed < 1e-3:
                continue
            ratios.append(abs(float(v[0] @ inward)) / speed)
    assert len(ratios) > 10
    assert np.max(ratios) < 0.10, (name, np.max(ratios), np.mean(ratios))


def test_divergence_is_near_zero(case, rng):
    name, graph, field, water, width = case
    h = field.tiles.spacing_m(field.max_level)
    pts = _inside_points(field, water, rng, 400, margin=3 * h)
    eps = 0.05 * h
    div, grad = divergence_and_gradient(field, pts, eps)
    scale = np.median(grad) + 1e-9
    assert np.max(np.abs(div)) < 0.05 * scale, (name, np.max(np.abs(div)), scale)
    # integral form: the flux through small closed squares vanishes
    side = 2.5 * h
    s = np.linspace(0, 1, 41)
    for p in pts[:40]:
        corners = p + side * np.array([[0, 0], [1, 0], [1, 1], [0, 1], [0, 0]]) - side / 2
        total = 0.0
        for a, b in zip(corners[:-1], corners[1:]):
            _, v = field.query(a + s[:, None] * (b - a))
            t = (b - a) / side
            total += np.trapezoid(v.astype(float) @ np.array([t[1], -t[0]]), s * side)  # outward
        speed = float(np.hypot(*field.query(p[None])[1][0]))
        assert abs(total) < 0.01 * speed * side + 1e-6, (name, p, total)


def _inside_points(field, water, rng, n, margin):
    x0, y0, x1, y1 = water.bounds
    pts = rng.uniform((x0, y0), (x1, y1), (20 * n, 2))
    inner = water.buffer(-margin)
    keep = shapely.contains_xy(inner, pts[:, 0], pts[:, 1])
    return pts[keep][:n]


def test_inside_outside_agrees_with_water_polygon(case, rng):
    name, graph, field, water, width = case
    x0, y0, x1, y1 = water.bounds
    pts = rng.uniform((x0 - width, y0 - width), (x1 + width, y1 + width), (40000, 2))
    near = shapely.distance(water.boundary, shapely.points(pts)) < 0.02 * width
    pts = pts[~near]
    status, velocity = field.query(pts)
    in_water = shapely.contains_xy(water, pts[:, 0], pts[:, 1])
    inside = status == rf.FlowStatus.INSIDE
    wrong = pts[inside != in_water]
    assert len(wrong) == 0, (name, len(wrong), wrong[:5])
    assert np.all(velocity[~inside] == 0)
    assert np.all(np.isfinite(velocity))


def test_mean_flow_points_downstream_in_every_reach(case):
    name, graph, field, water, width = case
    for a in graph.axes():
        line = graph.polyline(a)
        ls = shapely.LineString(line)
        s = np.linspace(0.1, 0.9, 50)
        pts = np.array([ls.interpolate(f, normalized=True).coords[0] for f in s])
        ahead = np.array([ls.interpolate(f + 0.01, normalized=True).coords[0] for f in s])
        tangent = (ahead - pts) / np.linalg.norm(ahead - pts, axis=1)[:, None]
        status, v = field.query(pts)
        inside = status == rf.FlowStatus.INSIDE
        assert inside.mean() > 0.8, (name, a)
        along = (v[inside].astype(float) * tangent[inside]).sum(1)
        assert along.mean() > 0, (name, a, along.mean())


def test_velocity_is_continuous_across_tile_and_cell_borders(case, rng):
    name, graph, field, water, width = case
    t = field.tiles
    lv = field.max_level
    h = t.spacing_m(lv)
    size = t.tile_size_m(lv)
    pts = _inside_points(field, water, rng, 3000, margin=2 * h)
    for grid, label in ((size, "tile"), (h, "cell")):
        # move each point onto the nearest vertical grid line, test both sides
        gx = t.root_x_m + np.round((pts[:, 0] - t.root_x_m) / grid) * grid
        on = np.c_[gx, pts[:, 1]]
        keep = shapely.contains_xy(water.buffer(-2 * h), on[:, 0], on[:, 1])
        on = on[keep]
        if len(on) == 0:
            continue
        eps = 1e-6 * h
        s1, left = field.query(on - (eps, 0))
        s2, right = field.query(on + (eps, 0))
        ok = (s1 == 1) & (s2 == 1)
        jump = np.abs(left[ok] - right[ok]).max(1)
        # velocity difference between neighbouring lattice points, for scale
        _, far = field.query(on[ok] + (h, 0))
        neighbour = np.abs(far - right[ok]).max(1)
        assert np.all(jump <= neighbour + 1e-4), (name, label, jump.max())
        assert jump.max() < 1e-3 * max(1e-3, float(np.abs(right[ok]).max())), (name, label)


def test_flow_splits_around_islands():
    for build in (NETWORKS["bend_island"], NETWORKS["bifurcation"]):
        graph, builder = build()
        field = rf.FlowField(graph)
        water = builder.water_polygon
        for hole in water.interiors:
            island = shapely.Polygon(hole)
            c = np.array(island.centroid.coords[0])
            # a line through the island across the flow: both arms carry water downstream
            for direction in (np.array([0.0, 1.0]), np.array([1.0, 1.0]) / np.sqrt(2)):
                cut = shapely.LineString([c - 200 * direction, c + 200 * direction])
                parts = cut.intersection(water)
                arms = [p for p in getattr(parts, "geoms", [parts])
                        if p.geom_type == "LineString" and p.length > 1.0
                        and p.distance(island) < 1e-6]
                if len(arms) < 2:
                    continue
                fluxes = []
                for arm in arms[:2]:
                    A, B = (np.array(q) for q in arm.coords[:2])
                    s = np.linspace(0, 1, 401)
                    _, v = field.query(A + s[:, None] * (B - A))
                    t = (B - A) / np.linalg.norm(B - A)
                    fluxes.append(abs(np.trapezoid(v.astype(float) @ np.array([-t[1], t[0]]),
                                                   s * np.linalg.norm(B - A))))
                assert min(fluxes) > 0.1 * max(fluxes), fluxes
                break
