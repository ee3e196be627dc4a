"""The built-in landscape: about 4 km of seeded procedural terrain around a river network.

``default_scene(seed)`` lays out a meandering main river (west to east, about 4.5 km, 55 m
wide at its source widening to 150 m at its mouth), a tributary joining it (confluence), an
island splitting it (a bifurcation that re-joins) and a small free island further down; the
:class:`~riverflow.hydro.builder.RiverNetworkBuilder` turns them into the hydro graph. The
terrain is designed around the river: a regional slope, a valley around the main river and
noise give a base ground; water profiles follow it downhill (running minimum, smoothing,
junctions pinned: :mod:`riverflow.scenes.water`); the final heightfield is the river bed
inside the water, banks that rise from the water line outside, blending into noise hills far
away. Same seed → bitwise the same scene.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import shapely
from scipy.ndimage import gaussian_filter
from scipy.spatial import cKDTree

from riverflow.components.terrain import Terrain
from riverflow.hydro.builder import RiverNetworkBuilder
from riverflow.hydro.graph import HydroGraph
from riverflow.scenes.water import WaterSurface, bed_depth, monotone_profiles, resample

HALF_SIZE_M = 2048.0
"""The terrain covers [-HALF_SIZE_M, HALF_SIZE_M]² [m]."""
CELL_M = 4.0
TILE_M = 256.0
PROFILE_SPACING_M = 10.0
"""Centre-line sample spacing of the branches and of their water profiles [m]."""
SURFACE_SPACING_M = 2.0
"""Centre-line sample spacing of the water-surface lookup [m]."""
FREEBOARD_M = 1.5
"""Water profiles are sampled this far below the base ground."""
COARSE = 8
"""Fields far from the river are computed every COARSE cells and interpolated."""
LEVEL_BLUR = 6.0
"""Far from the river the water level under the valley is blurred (σ in coarse cells) so that
the valleys of reaches at different levels meet without steps."""
LAND_LEVEL_BLUR = 4.0
"""σ [cells] of the smoothing of the water level under the land near the river."""
NEAR_M = 60.0
"""Within this distance outside a river's strip, fields are computed exactly per cell."""


@dataclass(eq=False)
class RiverBranch:
    """One branch as laid out: centre line (K, 2) [m] drawn downstream, widths (K,) [m],
    discharge [m²/s] (resolved by the builder), kind "main" / "tributary" / "arm", and the
    junction indices of its start and end (-1 = free end)."""

    name: str
    centerline_m: np.ndarray
    widths_m: np.ndarray
    discharge_m2s: float | None
    kind: str
    start_junction: int
    end_junction: int


@dataclass(eq=False)
class Scene:
    """A landscape with rivers: hydro graph, terrain, water surface, bounds (xmin, ymin,
    xmax, ymax) [m], seed, branches (upstream first) and free island outlines (M, 2)."""

    graph: HydroGraph
    terrain: Terrain
    water: WaterSurface
    bounds_m: tuple[float, float, float, float]
    seed: int
    branches: list[RiverBranch]
    islands: list[np.ndarray] = field(default_factory=list)

    def branch(self, name: str) -> RiverBranch:
        return next(b for b in self.branches if b.name == name)


def default_scene(seed: int = 0) -> Scene:
    """Build the default scene for ``seed`` (deterministic; about a second)."""
    rng = np.random.default_rng(seed)
    branches, islands = _layout(rng)
    builder = RiverNetworkBuilder(tolerance_m=0.25)
    for b in branches:
        builder.add_branch(b.centerline_m, b.widths_m, b.discharge_m2s, name=b.name)
    for outline in islands:
        builder.add_island(outline)
    graph = builder.build()
    for b, q in zip(branches, builder.discharges_m2s):
        b.discharge_m2s = q

    axis = np.arange(-HALF_SIZE_M, HALF_SIZE_M + 0.5 * CELL_M, CELL_M)
    gx, gy = np.meshgrid(axis, axis)
    main = np.vstack([b.centerline_m for b in branches if b.kind == "main"])
    coarse = axis[::COARSE]
    valley_m = _upsample(cKDTree(main).query(_grid(coarse), workers=-1)[0], len(axis))
    calm = 0.3 + 0.7 * _smoothstep(0.0, 600.0, valley_m)  # less noise along the main river
    base = (30.0 + 0.004 * (HALF_SIZE_M - gx) + 0.03 * np.minimum(valley_m, 1500.0)
            + calm * _fbm(rng, axis, [(700.0, 6.0), (220.0, 2.5), (70.0, 0.8)]))
    hills = 28.0 * np.clip(0.5 + 0.5 * _fbm(rng, axis, [(900.0, 0.8), (350.0, 0.3)]), 0.0, None)
    base_terrain = Terrain(base, (-HALF_SIZE_M, -HALF_SIZE_M), CELL_M, TILE_M)

    water = _water_surface(branches, base_terrain, builder.water_polygon)
    heights = _carve(axis, water, base + hills)
    terrain = Terrain(heights, (-HALF_SIZE_M, -HALF_SIZE_M), CELL_M, TILE_M)
    return Scene(graph, terrain, water, terrain.bounds_m, int(seed), branches, islands)


# -- layout -------------------------------------------------------------------------------


def _layout(rng: np.random.Generator) -> tuple[list[RiverBranch], list[np.ndarray]]:
    """Main river (split at the junctions), tributary, island arms and a free island."""
    x = np.linspace(-2000.0, 2000.0, 4001)
    a1, l1, p1 = rng.uniform(170, 250), rng.uniform(1300, 1800), rng.uniform(0, 2 * np.pi)
    a2, l2, p2 = rng.uniform(60, 130), rng.uniform(2800, 4200), rng.uniform(0, 2 * np.pi)
    y = rng.uniform(-300, 300) + a1 * np.sin(2 * np.pi * x / l1 + p1) + a2 * np.sin(2 * np.pi * x / l2 + p2)
    main, = resample(np.stack([x, y], axis=1), PROFILE_SPACING_M)
    s = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(main, axis=0).T))])
    width = 55.0 + 95.0 * s / s[-1]
    tangent = np.gradient(main, axis=0)
    tangent /= np.hypot(*tangent.T)[:, None]
    normal = np.stack([-tangent[:, 1], tangent[:, 0]], axis=1)

    def at(fraction: float) -> int:
        return int(np.searchsorted(s, fraction * s[-1]))

    ic = at(rng.uniform(0.22, 0.32))
    ib1 = at(rng.uniform(0.5, 0.58))
    ib2 = int(np.searchsorted(s, s[ib1] + rng.uniform(380, 520)))
    q_main = 55.0 * rng.uniform(0.9, 1.2)
    branches = [RiverBranch("main_upper", main[:ic + 1], width[:ic + 1], q_main, "main", -1, 0)]
    branches.append(_tributary(rng, main, width, tangent[ic], normal[ic], ic))
    branches.append(RiverBranch("main_middle", main[ic:ib1 + 1], width[ic:ib1 + 1], None, "main", 0, 1))
    seg = slice(ib1, ib2 + 1)
    t = (s[seg] - s[ib1]) / (s[ib2] - s[ib1])
    ease = np.clip(np.minimum(t, 1 - t) / 0.45, 0.0, 1.0)
    bump = 1.0 - (1.0 - ease) ** 2
    half_island = rng.uniform(22, 35)
    for name, side, share in (("arm_left", 1.0, 0.62), ("arm_right", -1.0, 0.5)):
        w = share * width[seg]
        pts = main[seg] + side * normal[seg] * ((half_island + 0.5 * w.max()) * bump)[:, None]
        branches.append(RiverBranch(name, pts, w, None, "arm", 1, 2))
    branches.append(RiverBranch("main_lower", main[ib2:], width[ib2:], None, "main", 2, -1))

    k = at(rng.uniform(0.8, 0.9))
    center = main[k] + normal[k] * rng.uniform(-0.12, 0.12) * width[k]
    ang = np.linspace(0, 2 * np.pi, 24, endpoint=False)
    ax, bx = rng.uniform(25, 45), rng.uniform(8, 14)
    outline = (center + np.outer(ax * np.cos(ang), tangent[k]) + np.outer(bx * np.sin(ang), normal[k]))
    return branches, [outline]


def _tributary(rng, main, width, t_c, n_c, ic) -> RiverBranch:
    """A tributary reaching the main river at sample ``ic`` from a random side, clear of the
    main river elsewhere and inside the terrain (re-drawn until it is)."""
    c = main[ic]
    tree = cKDTree(main)
    for _ in range(64):
        side = rng.choice([-1.0, 1.0])
        alpha, beta = np.radians(rng.uniform(35, 55)), np.radians(rng.uniform(10, 35))
        length = rng.uniform(1100, 1500)
        d_end = t_c * np.cos(alpha) - side * n_c * np.sin(alpha)
        gamma = alpha + beta
        p0 = c + length * (-np.cos(gamma) * t_c + side * np.sin(gamma) * n_c)
        p2 = c - d_end * 0.35 * length
        chord = p2 - p0
        perp = np.array([-chord[1], chord[0]]) / np.hypot(*chord)
        p1 = p0 + 0.33 * chord + perp * rng.uniform(-150, 150)
        u = np.linspace(0.0, 1.0, 400)[:, None]
        curve = ((1 - u) ** 3 * p0 + 3 * (1 - u) ** 2 * u * p1 + 3 * (1 - u) * u ** 2 * p2 + u ** 3 * c)
        pts, = resample(curve, PROFILE_SPACING_M)
        pts[-1] = c
        w_end = rng.uniform(40, 50)
        widths = np.linspace(35.0, w_end, len(pts))
        q = float(widths.mean() * rng.uniform(0.7, 1.0))
        if np.abs(pts).max() > 1990.0:
            continue
        st = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(pts, axis=0).T))])
        far = st < st[-1] - 250.0
        d, j = tree.query(pts[far])
        if np.all(d > 0.5 * width[j] + 0.5 * widths[far] + 60.0):
            return RiverBranch("tributary", pts, widths, q, "tributary", -1, 0)
    raise RuntimeError("could not lay out a tributary clear of the main river")


def _fbm(rng: np.random.Generator, axis_m: np.ndarray, octaves: list[tuple[float, float]]) -> np.ndarray:
    """Sum of cubic B-spline value-noise octaves [(feature size m, amplitude m)] on the square
    grid ``axis_m`` × ``axis_m``; (n, n) float64."""
    total = np.zeros((len(axis_m), len(axis_m)))
    for scale, amplitude in octaves:
        u = (axis_m - axis_m[0]) / scale + 1.0
        n = int(np.floor(u.max())) + 4
        lattice = rng.standard_normal((n, n))
        w = _bspline_weights(u, n)
        total += amplitude * (w @ lattice @ w.T)
    return total


def _bspline_weights(u: np.ndarray, n: int) -> np.ndarray:
    """(len(u), n) cubic B-spline interpolation matrix for lattice coordinates u."""
    i = np.floor(u).astype(np.int64)
    f = u - i
    cols = [(1 - f) ** 3 / 6, (3 * f ** 3 - 6 * f ** 2 + 4) / 6,
            (-3 * f ** 3 + 3 * f ** 2 + 3 * f + 1) / 6, f ** 3 / 6]
    w = np.zeros((len(u), n))
    rows = np.arange(len(u))
    for k, c in enumerate(cols):
        np.add.at(w, (rows, i - 1 + k), c)
    return w


# -- water and terrain --------------------------------------------------------------------


def _water_surface(branches: list[RiverBranch], base: Terrain, polygon) -> WaterSurface:
    """Monotone water profiles of the branches on the base ground, as a WaterSurface."""
    n_junctions = 1 + max(max(b.start_junction, b.end_junction) for b in branches)
    ground = [base.height(b.centerline_m) - FREEBOARD_M for b in branches]
    levels = monotone_profiles([b.centerline_m for b in branches], ground,
                               [b.start_junction for b in branches],
                               [b.end_junction for b in branches], n_junctions, half_window=12,
                               caps_m=_junction_caps(branches))
    samples, lv, wd, index, profiles = [], [], [], [], {}
    for k, (b, z) in enumerate(zip(branches, levels)):
        s = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(b.centerline_m, axis=0).T))])
        profiles[b.name] = (s, z)
        pts, zz, ww = resample(b.centerline_m, SURFACE_SPACING_M, z, b.widths_m)
        samples.append(pts)
        lv.append(np.minimum.accumulate(zz))
        wd.append(ww)
        index.append(np.full(len(pts), k))
    junctions = np.zeros((n_junctions, 2))
    members: list[tuple[int, ...]] = []
    for j in range(n_junctions):
        members.append(tuple(k for k, b in enumerate(branches) if j in (b.start_junction, b.end_junction)))
        b = branches[members[-1][0]]
        junctions[j] = b.centerline_m[0] if b.start_junction == j else b.centerline_m[-1]
    return WaterSurface(np.vstack(samples), np.concatenate(lv), np.concatenate(wd),
                        np.concatenate(index), polygon, profiles, junctions, members)


def _junction_caps(branches: list[RiverBranch]) -> list[tuple[float, float]]:
    """Per branch, the lengths [m] from its start / end junction along which it lies within one
    width of the other branches of that junction (at least their largest half-width): the
    water there is kept at the junction height, so the surface has no step at the mouth."""
    caps = []
    for b in branches:
        s = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(b.centerline_m, axis=0).T))])
        pts = shapely.points(b.centerline_m)
        ends = []
        for j, at_end in ((b.start_junction, False), (b.end_junction, True)):
            others = [o for o in branches
                      if o is not b and j >= 0 and j in (o.start_junction, o.end_junction)]
            if not others:
                ends.append(0.0)
                continue
            inside = np.zeros(len(s), bool)
            for o in others:
                # farther than one width from another centre line, no point of that
                # branch's water is nearer to this one: the surface switches without a step
                reach = float(o.widths_m.max()) + 0.1 * float(b.widths_m.max())
                inside |= shapely.distance(pts, shapely.LineString(o.centerline_m)) < reach
            from_j = (s[-1] - s) if at_end else s
            outside = from_j[~inside]
            cap = float(outside.min()) if len(outside) else float(s[-1])
            ends.append(max(cap, max(0.5 * float(o.widths_m.max()) for o in others)))
        caps.append((ends[0], ends[1]))
    return caps


def _smoothstep(e0: float, e1: float, x: np.ndarray) -> np.ndarray:
    t = np.clip((x - e0) / (e1 - e0), 0.0, 1.0)
    return t * t * (3 - 2 * t)


def _grid(axis_m: np.ndarray) -> np.ndarray:
    """Points (n², 2) of the square grid axis_m × axis_m, x fastest."""
    gx, gy = np.meshgrid(axis_m, axis_m)
    return np.stack([gx.ravel(), gy.ravel()], axis=1)


def _upsample(values: np.ndarray, n: int) -> np.ndarray:
    """Bilinear upsampling of a coarse square field (m², values every COARSE cells) to (n, n)."""
    m = int(round(np.sqrt(values.size)))
    u = np.arange(n) / COARSE
    i = np.minimum(u.astype(np.int64), m - 2)
    f = u - i
    w = np.zeros((n, m))
    w[np.arange(n), i] = 1 - f
    w[np.arange(n), i + 1] = f
    return w @ values.reshape(m, m) @ w.T


def _carve(axis_m: np.ndarray, water: WaterSurface, far_m: np.ndarray) -> np.ndarray:
    """Terrain heights (n, n) [m] on the grid axis_m²: river bed in the water, banks rising
    from the water line (always above the water level outside it), ``far_m`` (n, n) away
    from the river. Fields are exact per cell near the river, interpolated from a coarse
    grid farther away (KD-tree queries far from the data are slow)."""
    n = len(axis_m)
    coarse = _grid(axis_m[::COARSE])
    centre_c, level_c, width_c = water.nearest(coarse, stride=5)
    shore = _upsample(water.distance_to_shore(coarse, stride=5), n).ravel()  # exact near the river
    m = len(axis_m[::COARSE])
    level = _upsample(gaussian_filter(level_c.reshape(m, m), LEVEL_BLUR, mode="nearest"), n).ravel()
    width = _upsample(width_c, n).ravel()
    outside_strip = _upsample(centre_c - 0.5 * width_c, n).ravel()
    near = np.flatnonzero(outside_strip < NEAR_M + 2 * COARSE * (axis_m[1] - axis_m[0]))
    pts = _grid(axis_m)[near]
    shore_e = water.distance_to_shore(pts)
    centre_e, level_e, width_e = water.nearest(pts)
    inside = np.zeros(n * n, bool)
    inside[near] = water.contains(pts, shore_e)
    t = _smoothstep(0.5 * NEAR_M, NEAR_M, centre_e - 0.5 * width_e)
    shore[near] = (1 - t) * shore_e + t * shore[near]
    level[near] = (1 - t) * level_e + t * level[near]
    width[near] = (1 - t) * width_e + t * width[near]
    # the level under the land jumps where the nearest branch changes (around junctions):
    # smoothed away from the shore, exact at the water's edge (banks stay above their water)
    beta = _smoothstep(5.0, 25.0, shore)
    level_land = gaussian_filter(level.reshape(n, n), LAND_LEVEL_BLUR, mode="nearest").ravel()
    valley = ((1.0 - beta) * level + beta * level_land
              + 2.5 * (1.0 - np.exp(-shore / 12.0)) + 12.0 * (1.0 - np.exp(-shore / 250.0)))
    alpha = _smoothstep(60.0, 400.0, shore)
    far = far_m.ravel()
    land = (1.0 - alpha) * valley + alpha * np.maximum(far, valley)
    return np.where(inside, level - bed_depth(shore, width), land).reshape(n, n)
