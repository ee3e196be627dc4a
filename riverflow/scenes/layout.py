"""River layouts of the procedural scenes: centre lines, widths and discharges of the branches,
and free island outlines, ready for :class:`~riverflow.hydro.builder.RiverNetworkBuilder`.

:func:`small_layout` is the built-in 4 km scene (a main river, one tributary, an island splitting
it and a free island); :func:`large_layout` makes square worlds from about 1 km to 600 km: a main
river crossing the square from west to east, meandering at several scales, with tributaries from
both sides (and, from about 40 km, second-order tributaries joining those), islands splitting
the main river into two arms that re-join, and free islands. :func:`layout` picks one by size.

Every layout is valid for the builder by construction: branches join only at shared end points
(a junction), strips (centre line ± width/2) do not come near each other elsewhere, bends are
wide compared with the river, islands lie well inside the water, and all of it lies inside the
square, at least :func:`edge_margin_m` from its edges. Candidate tributaries are drawn at random
and checked (KD-trees of the centre lines) before they are accepted; a tributary that cannot be
placed after a bounded number of draws is left out, so a layout is always returned and is the
same for the same random state.

Discharges [m²/s, per unit depth, as the builder takes them] are given for every branch and are
consistent (summed at confluences, split in proportion to the widths at bifurcations). Widths
follow a hydraulic geometry of the accumulated discharge, width ∝ Q^0.85: the builder's
discharge is speed × width, which for Leopold-Maddock rivers (width ∝ Qᵥ^0.5, speed ∝ Qᵥ^0.1 of
the volumetric discharge Qᵥ) is ∝ Qᵥ^0.6, so width ∝ Q^(0.5/0.6); mean speeds stay between
about 0.6 and 1.4 m/s from 20 m brooks to 500 m streams.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.spatial import cKDTree

from riverflow.scenes.water import resample

PROFILE_SPACING_M = 10.0
"""Centre-line sample spacing of the branches and of their water profiles [m]."""
DEFAULT_SIZE_M = 4096.0
"""Side of the built-in scene's square [m]: :func:`layout` gives :func:`small_layout` for it."""

WIDTH_REF_M = 25.0
DISCHARGE_REF_M2S = 20.0
WIDTH_EXPONENT = 0.85
"""Hydraulic geometry: width = WIDTH_REF_M · (Q / DISCHARGE_REF_M2S) ** WIDTH_EXPONENT."""
MIN_SOURCE_WIDTH_M = 20.0
"""Narrowest river source [m]."""
NETWORK_RATIO = 2.3
"""Target total network length of a large layout, in sides of its square."""
EDGE_MARGIN_FRACTION = 0.025
"""Rivers keep this fraction of the side (at least EDGE_MARGIN_MIN_M) from the square's edges."""
EDGE_MARGIN_MIN_M = 40.0
MAIN_SOURCE_SHARE = 0.4
"""Share of the mouth discharge that enters with the main river at its source."""
WIDTH_GROWTH = 1.08
"""Widening along a branch that ends in a river mouth or joins a larger river."""
MAX_RAMP = 1.5
"""Along a branch the width grows at most by this factor towards its downstream junction
(it steps up there otherwise), so that its mean speed stays plausible."""
BEND_RADIUS_WIDTHS = 3.0
"""Sharpest bend of a centre line, in local river widths (main river and tributaries)."""
SUBTRIBUTARY_MIN_SIZE_M = 40_000.0
"""Squares at least this large get second-order tributaries."""
ARM_SHARES = (0.62, 0.5)
"""Widths of the two arms around an island, as fractions of the main river's width."""
_TRIES = 24
"""Random candidates drawn per tributary before it is left out."""
_ATTEMPTS = 4
"""Whole layouts drawn at most while the network is shorter than 1.8 sides."""


# -- the 4 km scene -----------------------------------------------------------------------


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


def small_layout(rng: np.random.Generator) -> tuple[list[RiverBranch], list[np.ndarray]]:
    """The built-in 4 km layout (square [-2048, 2048]² m): main river (split at the junctions),
    tributary, island arms and a free island. Same random draws as it always had."""
    return _layout(rng)


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


# -- choosing a layout --------------------------------------------------------------------


def layout(rng: np.random.Generator, size_m: float = DEFAULT_SIZE_M
           ) -> tuple[list[RiverBranch], list[np.ndarray]]:
    """:func:`small_layout` for the built-in size (DEFAULT_SIZE_M ± 1 m), else
    :func:`large_layout` for the square [-size_m/2, size_m/2]²."""
    if abs(float(size_m) - DEFAULT_SIZE_M) <= 1.0:
        return small_layout(rng)
    return large_layout(rng, size_m)


def network_length_m(branches: list[RiverBranch]) -> float:
    """Sum of the centre-line lengths of the branches [m] (both arms around an island count)."""
    return float(sum(_arc(b.centerline_m)[-1] for b in branches))


_RATIO_SIZES_M = np.array([1000.0, 2000.0, 4000.0, 8000.0, 16000.0, 32000.0, 64000.0,
                           128000.0, 256000.0, 512000.0])
_RATIOS = np.array([1.62, 1.85, 2.02, 2.15, 2.2, 2.22, 2.24, 2.24, 2.25, 2.25])
"""Mean network length / side of large layouts, measured over seeds 0-7 (see the tests)."""


def size_for_network_length(length_m: float) -> float:
    """Side [m] of the square whose :func:`large_layout` has a network of about ``length_m``
    (within some 10 % from seed to seed). Small networks (a few km) give small squares, down to
    a single main river and one tributary in about 600 m; never the built-in size, which would
    select :func:`small_layout`."""
    length_m = float(length_m)
    if not (np.isfinite(length_m) and length_m > 0):
        raise ValueError(f"length_m must be a positive number, got {length_m!r}")
    lengths = _RATIO_SIZES_M * _RATIOS
    log_size = np.interp(np.log(length_m), np.log(lengths), np.log(_RATIO_SIZES_M))
    if length_m < lengths[0]:
        log_size = np.log(length_m / _RATIOS[0])
    elif length_m > lengths[-1]:
        log_size = np.log(length_m / _RATIOS[-1])
    size = float(np.exp(log_size))
    size = max(size, 400.0)
    if abs(size - DEFAULT_SIZE_M) <= 1.0:
        size = DEFAULT_SIZE_M + 2.0
    return size


# -- hydraulic geometry -------------------------------------------------------------------


def width_for_discharge(q_m2s):
    """River width [m] for a discharge [m²/s] (hydraulic geometry, see the module doc)."""
    return WIDTH_REF_M * (np.asarray(q_m2s, dtype=np.float64) / DISCHARGE_REF_M2S) ** WIDTH_EXPONENT


def discharge_for_width(width_m):
    """Inverse of :func:`width_for_discharge`."""
    return DISCHARGE_REF_M2S * (np.asarray(width_m, dtype=np.float64) / WIDTH_REF_M) ** (1.0 / WIDTH_EXPONENT)


def edge_margin_m(size_m: float) -> float:
    """Distance [m] every river keeps from the edges of a large layout's square."""
    return max(EDGE_MARGIN_FRACTION * float(size_m), EDGE_MARGIN_MIN_M)


def mouth_width_m(size_m: float) -> float:
    """Planned width [m] of the main river at its mouth (60 m at 8 km, ~390 m at 512 km)."""
    return float(np.clip(60.0 * (float(size_m) / 8000.0) ** 0.45, 35.0, 450.0))


def _ramp(fraction: np.ndarray, cuts: list[float], w_at: list[float], w_last: float) -> np.ndarray:
    """Widths at arc fractions (P,) of a river whose discharge steps up at ``cuts`` (sorted
    fractions, the first 0): on [cuts[k], cuts[k+1]] the width grows linearly from w_at[k]
    towards w_at[k+1] (at most ×MAX_RAMP), on the last piece towards ``w_last``."""
    out = np.empty(len(fraction))
    ends = list(cuts[1:]) + [1.0]
    targets = list(w_at[1:]) + [w_last]
    for k, (a, b) in enumerate(zip(cuts, ends)):
        sel = (fraction >= a) & ((fraction < b) if k < len(cuts) - 1 else (fraction <= 1.0 + 1e-12))
        u = (fraction[sel] - a) / max(b - a, 1e-12)
        w0 = w_at[k]
        w1 = min(targets[k], MAX_RAMP * w0)
        out[sel] = w0 + (w1 - w0) * u
    return out


# -- large layouts ------------------------------------------------------------------------


@dataclass
class _Record:
    """A placed river for clearance checks: samples (P, 2), half-widths used in the checks."""

    pts: np.ndarray
    half: np.ndarray
    tree: cKDTree = field(init=False)

    def __post_init__(self) -> None:
        self.tree = cKDTree(self.pts)


@dataclass
class _Sub:
    """A planned second-order tributary: junction fraction on its parent (from the parent's
    source), side, planned length, source direction angle, and once placed its centre line."""

    fraction: float
    side: float
    length_m: float
    gamma: float
    q_plan: float = 0.0
    pts: np.ndarray | None = None
    widths: np.ndarray | None = None
    q: float = 0.0
    j: int = -1


@dataclass
class _Trib:
    """A planned first-order tributary (see _Sub), its subs and, once placed, centre line."""

    fraction: float
    side: float
    length_m: float
    gamma: float
    subs: list[_Sub] = field(default_factory=list)
    q_plan: float = 0.0
    index: int = 0
    ic: int = 0
    exempt_m: float = 0.0
    pts: np.ndarray | None = None
    widths: np.ndarray | None = None
    q: float = 0.0
    record: _Record | None = None


class _World:
    """Geometry shared by the steps of one large layout."""

    def __init__(self, size_m: float) -> None:
        self.size = float(size_m)
        self.half = 0.5 * self.size
        self.margin = edge_margin_m(self.size)
        self.gap = max(10.0, 0.002 * self.size)
        self.spacing = PROFILE_SPACING_M

    def inside(self, pts: np.ndarray, half_w: np.ndarray) -> bool:
        lim = self.half - self.margin - half_w
        return bool(np.all(np.abs(pts[:, 0]) <= lim) and np.all(np.abs(pts[:, 1]) <= lim))

    def reach(self, c: np.ndarray, v: np.ndarray, inset: float) -> float:
        """Distance from c along the unit vector v to the square inset by margin + inset."""
        lim = self.half - self.margin - inset
        t = np.inf
        for k in range(2):
            if v[k] > 1e-12:
                t = min(t, (lim - c[k]) / v[k])
            elif v[k] < -1e-12:
                t = min(t, (-lim - c[k]) / v[k])
        return float(max(t, 0.0))

    def exempt_m(self, h_parent: float, h_child: float) -> float:
        """Arc length [m] of a tributary, from its mouth, not checked against its parent
        (half-widths as in the checks): where it approaches at 35° or more, it is then
        farther than the checks ask (1.5 × the half-widths + gap)."""
        return (1.5 * (h_parent + h_child) + self.gap) / np.sin(np.radians(35.0)) + h_child


def large_layout(rng: np.random.Generator, size_m: float) -> tuple[list[RiverBranch], list[np.ndarray]]:
    """A river network filling the square [-size_m/2, size_m/2]² (size about 1 km to 600 km).

    A main river runs from the west to the east edge region (branches "main_0", "main_1", …
    split at every junction, kind "main"), meandering at the scale of the square and at the
    scale of its width (bends at least BEND_RADIUS_WIDTHS widths wide, so its strip never
    overlaps itself). Tributaries ("trib_<i>_<piece>", kind "tributary") join it from both
    sides, spread along it and reaching a good part of the way to the north / south edges; in
    squares of SUBTRIBUTARY_MIN_SIZE_M and more, second-order tributaries
    ("trib_<i>_sub<m>") join those. Every so often the main river splits into two arms
    ("arm_<k>_left" / "_right", kind "arm") around an island and re-joins; free islands lie in
    the main river. The whole network is about NETWORK_RATIO sides long (1.8–2.5; less in
    squares of a few km, where a main river and one or two tributaries fill it).

    Widths grow downstream with the accumulated discharge (sources ≥ MIN_SOURCE_WIDTH_M, the
    mouth about :func:`mouth_width_m`); discharges are given for every branch, consistent at
    the junctions. Branches are listed upstream first (every branch after all the branches
    flowing into its start); junction indices are numbered by first appearance.

    Centre lines are sampled every PROFILE_SPACING_M (10 m) at every size: 1200 km of rivers
    are about 120 000 samples, which the builder handles (see the tests for its time).

    Deterministic: the same generator state gives bitwise the same layout.
    """
    size = float(size_m)
    if not (np.isfinite(size) and size >= 400.0):
        raise ValueError(f"size_m must be at least 400 m, got {size_m!r}")
    best = None
    for _ in range(_ATTEMPTS):
        branches, islands = _large_attempt(rng, size)
        ratio = network_length_m(branches) / size
        if best is None or ratio > best[0]:
            best = (ratio, branches, islands)
        if ratio >= 1.8 or size < 12_000.0:
            break
    return best[1], best[2]


def _large_attempt(rng: np.random.Generator, size: float):
    world = _World(size)
    w_mouth = mouth_width_m(size)
    q_mouth = float(discharge_for_width(w_mouth))
    q_floor = float(discharge_for_width(MIN_SOURCE_WIDTH_M))
    q_main_src = max(q_floor, MAIN_SOURCE_SHARE * q_mouth)

    # -- plan: tributaries, their lengths (upper bounds) and the discharges ---------------
    if size < 2500.0:
        n1 = 1
    elif size < 6000.0:
        n1 = 2
    elif size < 20000.0:
        n1 = 3
    elif size < 150_000.0:
        n1 = 4
    else:
        n1 = 5
    span_x = size - 2.0 * world.margin
    budget = NETWORK_RATIO * size - 1.08 * span_x  # tributary length left by the main river
    with_subs = size >= SUBTRIBUTARY_MIN_SIZE_M
    b1 = budget * (0.7 if with_subs else 1.0)
    first_side = rng.choice([-1.0, 1.0])
    tribs: list[_Trib] = []
    for i in range(n1):
        if n1 == 1:
            f = rng.uniform(0.3, 0.6)
        else:
            f = 0.1 + 0.8 * (i + 0.5 + rng.uniform(-0.25, 0.25)) / n1
        side = first_side * (1.0 if i % 2 == 0 else -1.0)
        gamma = np.radians(rng.uniform(60.0, 95.0))
        tribs.append(_Trib(f, side, 1.4 * b1 / n1, gamma, index=i))
    if with_subs:
        counts = [int(rng.integers(1, 3)) for _ in tribs]
        l2 = 1.4 * budget * 0.3 / max(1, sum(counts))
        for t, m in zip(tribs, counts):
            for k in range(m):
                g = 0.25 + 0.5 * (k + 0.5 + rng.uniform(-0.2, 0.2)) / m
                t.subs.append(_Sub(g, rng.choice([-1.0, 1.0]), min(l2, 0.6 * t.length_m),
                                   np.radians(rng.uniform(55.0, 90.0))))
    sources = [t.length_m for t in tribs] + [s.length_m for t in tribs for s in t.subs]
    scale = (1.0 - MAIN_SOURCE_SHARE) * q_mouth / sum(length ** 1.2 for length in sources)

    def q_source(length_m: float) -> float:
        return max(q_floor, scale * length_m ** 1.2)

    for t in tribs:
        t.q_plan = q_source(t.length_m)
        for s in t.subs:
            s.q_plan = q_source(s.length_m)

    def main_widths(fraction: np.ndarray, q_of) -> np.ndarray:
        order = sorted(tribs, key=lambda t: t.fraction)
        cuts, qs = [0.0], [q_main_src]
        for t in order:
            q = q_of(t)
            if q > 0:
                cuts.append(t.fraction)
                qs.append(qs[-1] + q)
        w = [float(width_for_discharge(q)) for q in qs]
        return _ramp(fraction, cuts, w, WIDTH_GROWTH * w[-1])

    def trib_total_plan(t: _Trib) -> float:
        return t.q_plan + sum(s.q_plan for s in t.subs)

    # -- main river ---------------------------------------------------------------------
    main = _main_centerline(rng, world, lambda f: main_widths(f, trib_total_plan))
    s_main = _arc(main)
    length_main = s_main[-1]
    w_main_plan = main_widths(s_main / length_main, trib_total_plan)
    tangent, normal = _frames(main)
    records: list[_Record] = [_Record(main, w_main_plan)]  # half-width ×2: room for the arms

    # -- tributaries: fit the lengths to the budget, place them ---------------------------
    budget = NETWORK_RATIO * size - length_main
    b1 = budget * (0.7 if with_subs else 1.0)
    caps = []
    for t in tribs:
        ic = int(np.searchsorted(s_main, t.fraction * length_main))
        t.ic = min(max(ic, 1), len(main) - 2)
        v = -np.cos(t.gamma) * tangent[t.ic] + t.side * np.sin(t.gamma) * normal[t.ic]
        w_t = float(width_for_discharge(trib_total_plan(t)))
        caps.append(min(t.length_m, 1.1 * 0.9 * world.reach(main[t.ic], v, w_t)))
    for t, length in zip(tribs, _water_fill(caps, b1)):
        t.length_m = length
    placed: list[_Trib] = []
    for t in tribs:
        _place_tributary(rng, world, t, main, tangent, normal, s_main, w_main_plan, records, placed)
    if with_subs:
        placed = [t for t in tribs if t.pts is not None]
        b2 = NETWORK_RATIO * size - length_main - sum(_arc(t.pts)[-1] for t in placed)
        subs = [(t, s) for t in placed for s in t.subs]
        caps = [min(s.length_m, 0.6 * _arc(t.pts)[-1]) for t, s in subs]
        for (t, s), length in zip(subs, _water_fill(caps, max(b2, 0.0))):
            s.length_m = length
        for t in placed:
            for s in t.subs:
                _place_sub(rng, world, t, s, records)
    tribs = [t for t in tribs if t.pts is not None]
    for t in tribs:
        t.subs = [s for s in t.subs if s.pts is not None]

    # -- final discharges and widths (never wider than planned) ---------------------------
    for t in tribs:
        t.q = q_source(_arc(t.pts)[-1])
        for s in t.subs:
            s.q = q_source(_arc(s.pts)[-1])
            s.widths = _ramp(_arc(s.pts) / _arc(s.pts)[-1], [0.0], [float(width_for_discharge(s.q))],
                             WIDTH_GROWTH * float(width_for_discharge(s.q)))
        cuts, qs = [0.0], [t.q]
        for s in t.subs:
            cuts.append(s.fraction)
            qs.append(qs[-1] + s.q)
        w = [float(width_for_discharge(q)) for q in qs]
        t.widths = _ramp(_arc(t.pts) / _arc(t.pts)[-1], cuts, w, WIDTH_GROWTH * w[-1])
    w_main = main_widths(s_main / length_main,
                         lambda t: (t.q + sum(s.q for s in t.subs)) if t.pts is not None else 0.0)
    return _assemble(rng, world, main, s_main, w_main, tangent, normal, q_main_src, tribs)


def _water_fill(caps: list[float], total: float) -> list[float]:
    """Lengths ≤ caps summing to ``total`` (or to all caps), as equal as the caps allow."""
    caps = [max(c, 0.0) for c in caps]
    if not caps:
        return []
    if sum(caps) <= total:
        return list(caps)
    lo, hi = 0.0, max(caps)
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        if sum(min(c, mid) for c in caps) > total:
            hi = mid
        else:
            lo = mid
    return [min(c, lo) for c in caps]


def _arc(points: np.ndarray) -> np.ndarray:
    return np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(points, axis=0).T))])


def _frames(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Unit tangents and left normals (P, 2) of a polyline."""
    tangent = np.gradient(points, axis=0)
    tangent /= np.hypot(*tangent.T)[:, None]
    return tangent, np.stack([-tangent[:, 1], tangent[:, 0]], axis=1)


def _bend_radius(points: np.ndarray) -> np.ndarray:
    """Radius of curvature [m] at the interior points of a polyline (P-2,)."""
    d = np.diff(points, axis=0)
    seg = np.hypot(*d.T)
    turn = np.abs(np.arctan2(d[:-1, 0] * d[1:, 1] - d[:-1, 1] * d[1:, 0], np.einsum("ij,ij->i", d[:-1], d[1:])))
    return 0.5 * (seg[:-1] + seg[1:]) / np.maximum(turn, 1e-12)


def _main_centerline(rng: np.random.Generator, world: _World, widths_of) -> np.ndarray:
    """The main river: y = f(x) from the west to the east edge region, sum of sines at the
    scale of the square and meanders whose wavelength follows the local width; amplitudes
    are scaled down until every bend is BEND_RADIUS_WIDTHS widths wide (a graph over x with
    wide bends cannot overlap itself)."""
    size, half = world.size, world.half
    f_lin = np.linspace(0.0, 1.0, 1001)
    w_lin = widths_of(f_lin)
    h0, h1 = 0.5 * w_lin[0], 0.5 * w_lin[-1]
    x0, x1 = -half + world.margin + h0 + 1.0, half - world.margin - h1 - 1.0
    n = max(200, int(np.ceil((x1 - x0) / (0.5 * world.spacing)))) + 1
    x = np.linspace(x0, x1, n)
    fx = (x - x0) / (x1 - x0)
    # widths are non-decreasing downstream: the width at a slightly larger fraction bounds it
    w_bound = 1.05 * np.interp(np.minimum(fx + 0.15, 1.0), f_lin, w_lin) + 2.0
    y0 = rng.uniform(-0.04, 0.04) * size
    big = [(rng.uniform(0.9, 1.4) * size, rng.uniform(0.05, 0.08) * size, rng.uniform(0, 2 * np.pi)),
           (rng.uniform(0.35, 0.5) * size, rng.uniform(0.015, 0.03) * size, rng.uniform(0, 2 * np.pi)),
           (rng.uniform(0.12, 0.18) * size, rng.uniform(0.005, 0.01) * size, rng.uniform(0, 2 * np.pi))]
    small = [(rng.uniform(11.0, 15.0), rng.uniform(0.9, 1.4), rng.uniform(0, 2 * np.pi)),
             (rng.uniform(35.0, 50.0), rng.uniform(1.5, 3.0), rng.uniform(0, 2 * np.pi))]
    mod_len, mod_phase = rng.uniform(0.15, 0.3) * size, rng.uniform(0, 2 * np.pi)
    modulation = 0.65 + 0.35 * np.sin(2 * np.pi * x / mod_len + mod_phase)
    y_big = y0 + sum(a * np.sin(2 * np.pi * x / lam + p) for lam, a, p in big)
    dx = np.diff(x, prepend=x[0])
    y_small = np.zeros_like(x)
    for ratio, amp, p in small:
        phase = p + np.cumsum(2 * np.pi * dx / (ratio * w_bound))
        y_small += amp * w_bound * modulation * np.sin(phase)
    k_big, k_small = 1.0, 1.0
    for _ in range(40):
        y = y_big * k_big + (1.0 - k_big) * y0 + k_small * y_small
        d1 = np.gradient(y, x)
        d2 = np.gradient(d1, x)
        radius = (1.0 + d1 ** 2) ** 1.5 / np.maximum(np.abs(d2), 1e-15)
        ok = np.all(radius[2:-2] >= BEND_RADIUS_WIDTHS * w_bound[2:-2])
        ok &= bool(np.all(np.abs(y) <= half - world.margin - 0.5 * w_bound - 1.0))
        if ok:
            break
        k_small *= 0.85
        k_big *= 0.95
    else:
        y = np.full_like(x, y0)
    main, = resample(np.stack([x, y], axis=1), world.spacing)
    return main


def _bezier(p0, p1, p2, p3, n: int) -> np.ndarray:
    u = np.linspace(0.0, 1.0, n)[:, None]
    return (1 - u) ** 3 * p0 + 3 * (1 - u) ** 2 * u * p1 + 3 * (1 - u) * u ** 2 * p2 + u ** 3 * p3


def _candidate(rng: np.random.Generator, world: _World, c: np.ndarray, t_c: np.ndarray,
               n_c: np.ndarray, side: float, gamma: float, length: float, widths_of,
               w_max: float, exempt_m: float) -> tuple[np.ndarray, np.ndarray] | None:
    """A meandering river of about ``length`` ending at ``c`` from side ``side`` of a parent
    whose downstream tangent / left normal there are t_c / n_c, its source in the direction
    ``gamma`` (from the parent's upstream direction); None if it does not fit. Returns the
    centre line (P, 2) and widths (P,) from ``widths_of(arc fractions)``."""
    alpha = np.radians(rng.uniform(35.0, 60.0))
    gamma = gamma + np.radians(rng.uniform(-12.0, 12.0))
    v = -np.cos(gamma) * t_c + side * np.sin(gamma) * n_c
    chord = min(0.95 * length, 0.92 * world.reach(c, v, w_max))
    jitter = rng.uniform(-0.12, 0.12)
    comps = [(rng.uniform(0.3, 0.55), rng.uniform(0.02, 0.05), rng.uniform(0, 2 * np.pi)),
             (rng.uniform(0.1, 0.18), rng.uniform(0.006, 0.012), rng.uniform(0, 2 * np.pi))]
    w_ratio, w_amp, w_phase = rng.uniform(11.0, 15.0), rng.uniform(0.8, 1.3), rng.uniform(0, 2 * np.pi)
    if chord < max(4.0 * w_max, 1.33 * exempt_m, 10.0 * world.spacing):
        return None
    p0 = c + chord * v
    d_end = np.cos(alpha) * t_c - side * np.sin(alpha) * n_c
    p2 = c - d_end * 0.3 * chord
    perp = np.array([-(p2 - p0)[1], (p2 - p0)[0]]) / np.hypot(*(p2 - p0))
    p1 = p0 + 0.35 * (p2 - p0) + perp * jitter * chord
    n = max(200, int(np.ceil(1.3 * chord / (0.5 * world.spacing))))
    base = _bezier(p0, p1, p2, c, n)
    s = _arc(base)
    big_l = s[-1]
    _, nb = _frames(base)
    taper_end = min(max(1.2 * exempt_m, 0.1 * big_l), 0.4 * big_l)
    taper = _smoothstep(0.0, 0.08 * big_l, s) * _smoothstep(0.0, taper_end, big_l - s)
    wave = sum(a * big_l * np.sin(2 * np.pi * s / (lam * big_l) + p) for lam, a, p in comps)
    w_mean = float(np.mean(widths_of(np.linspace(0.0, 1.0, 50))))
    meander = w_amp * w_mean * np.sin(2 * np.pi * s / (w_ratio * w_mean) + w_phase)
    for _ in range(8):
        pts = base + nb * (taper * (wave + meander))[:, None]
        st = _arc(pts)
        if st[-1] > length:  # shorten from the source end
            pts = pts[max(int(np.searchsorted(st, st[-1] - length)) - 1, 0):]
        pts, = resample(pts, world.spacing)
        pts[-1] = c
        widths = widths_of(_arc(pts) / _arc(pts)[-1])
        if len(pts) >= 4 and np.all(_bend_radius(pts) >= BEND_RADIUS_WIDTHS * widths[1:-1]):
            break
        wave, meander = 0.7 * wave, 0.7 * meander
    else:
        return None
    if not world.inside(pts, 0.5 * widths) or not _self_clear(pts, widths, world):
        return None
    return pts, widths


def _self_clear(pts: np.ndarray, widths: np.ndarray, world: _World) -> bool:
    """No two parts of one river, far apart along it (arc distance > 2.2 r), come within its
    width of each other (0.75 × the sum of their widths + the gap, which is at most r).

    Measured between chunks of the river r/4 long, not point by point over all pairs within
    r: those are almost all neighbours along the river, which the arc test throws away (a
    1000 km main river: ~10⁷ pairs, half of the world's layout time). Two chunks of ids 8 or
    more apart are farther than 2.2 r along the river for some of their points; chunks whose
    boxes are farther than r apart hold no pair near enough. What is left is compared point
    by point: the same pairs, the same tests, the same answer."""
    stride = max(1, int(0.25 * widths.min() / world.spacing))
    p, w = pts[::stride], widths[::stride]
    s = _arc(pts)[::stride]
    r = 1.5 * float(w.max()) + world.gap
    quarter = 0.25 * r
    chunk = np.floor(s / quarter).astype(np.int64)       # s grows along the river
    ids, first = np.unique(chunk, return_index=True)
    ends = np.append(first[1:], len(p))
    lo, hi = np.minimum.reduceat(p, first, axis=0), np.maximum.reduceat(p, first, axis=0)
    centre, half = 0.5 * (lo + hi), 0.5 * np.hypot(*(hi - lo).T)
    pairs = cKDTree(centre).query_pairs(r + 2.0 * float(half.max()), output_type="ndarray")
    for a, b in pairs[np.abs(ids[pairs[:, 0]] - ids[pairs[:, 1]]) >= 8]:
        ia, ib = slice(first[a], ends[a]), slice(first[b], ends[b])
        d = np.hypot(p[ia, None, 0] - p[None, ib, 0], p[ia, None, 1] - p[None, ib, 1])
        near = d < 0.75 * (w[ia, None] + w[None, ib]) + world.gap
        if np.any(near & (np.abs(s[ia, None] - s[None, ib]) > 2.2 * r)):
            return False
    return True


def _self_clear_pairwise(pts: np.ndarray, widths: np.ndarray, world: _World) -> bool:
    """:func:`_self_clear` as every pair within r (its numpy twin, for the tests)."""
    stride = max(1, int(0.25 * widths.min() / world.spacing))
    p, w = pts[::stride], widths[::stride]
    s = _arc(pts)[::stride]
    r = 1.5 * float(w.max()) + world.gap
    pairs = cKDTree(p).query_pairs(r, output_type="ndarray")
    if not len(pairs):
        return True
    i, j = pairs[:, 0], pairs[:, 1]
    d = np.hypot(*(p[i] - p[j]).T)
    near = d < 0.75 * (w[i] + w[j]) + world.gap
    return not np.any(near & (np.abs(s[i] - s[j]) > 2.2 * r))


def _clear_of(pts: np.ndarray, half: np.ndarray, records: list[_Record], world: _World,
              parent: _Record | None, exempt: np.ndarray) -> bool:
    """The candidate (points, half-widths) keeps 1.5 × the sum of half-widths + gap from every
    record; points flagged ``exempt`` (near its mouth) are not checked against ``parent``."""
    for r in records:
        sel = ~exempt if r is parent else slice(None)
        p, h = pts[sel], half[sel]
        if not len(p):
            continue
        bound = 1.5 * (float(h.max()) + float(r.half.max())) + world.gap
        d, j = r.tree.query(p, distance_upper_bound=bound)
        hit = np.isfinite(d)
        if np.any(d[hit] < 1.5 * (h[hit] + r.half[j[hit]]) + world.gap):
            return False
    return True


def _place_tributary(rng, world: _World, t: _Trib, main, tangent, normal, s_main, w_main, records,
                     placed: list[_Trib]) -> None:
    """Draw first-order tributary ``t`` until it fits (shorter after every 8 misses)."""
    c, t_c, n_c = main[t.ic], tangent[t.ic], normal[t.ic]
    parent = records[0]
    cuts = [0.0] + [s.fraction for s in t.subs]
    qs = [t.q_plan]
    for s in t.subs:
        qs.append(qs[-1] + s.q_plan)
    w = [float(width_for_discharge(q)) for q in qs]

    def widths_of(f):
        return _ramp(f, cuts, w, WIDTH_GROWTH * w[-1])

    w_max = WIDTH_GROWTH * w[-1]
    w_m = float(w_main[t.ic])
    exempt_m = world.exempt_m(w_m, 0.5 * w_max)  # the main river is checked with twice its width
    # the part not checked against the main river must not reach its free ends or other junctions
    s_c = s_main[t.ic]
    if s_c < exempt_m + 3.0 * w_m or s_main[-1] - s_c < exempt_m + 3.0 * float(w_main[-1]):
        return
    for o in placed:
        if abs(s_main[o.ic] - s_c) < exempt_m + o.exempt_m + 2.0 * float(w_main.max()):
            return
    t.exempt_m = exempt_m
    length = t.length_m
    for attempt in range(_TRIES):
        if attempt and attempt % 8 == 0:
            length *= 0.8
        got = _candidate(rng, world, c, t_c, n_c, t.side, t.gamma, length, widths_of, w_max, exempt_m)
        if got is None:
            continue
        pts, widths = got
        st = _arc(pts)
        exempt = st > st[-1] - exempt_m
        if _clear_of(pts, 0.5 * widths, records, world, parent, exempt):
            t.pts, t.widths = pts, widths
            t.record = _Record(pts, 0.5 * widths)
            records.append(t.record)
            placed.append(t)
            return


def _place_sub(rng, world: _World, t: _Trib, sub: _Sub, records) -> None:
    """Draw second-order tributary ``sub`` of ``t`` until it fits; its junction must lie clear
    of the parent's ends and of its other subs' junctions."""
    st = _arc(t.pts)
    length_t = st[-1]
    w_sub = WIDTH_GROWTH * float(width_for_discharge(sub.q_plan))
    j = int(np.searchsorted(st, sub.fraction * length_t))
    j = min(max(j, 1), len(st) - 2)
    w_parent = float(t.widths[j])
    exempt_m = world.exempt_m(0.5 * w_parent, 0.5 * w_sub)
    reserve = exempt_m + 2.0 * w_parent
    if st[j] < reserve or length_t - st[j] < reserve + t.exempt_m:
        return
    for other in t.subs:
        if other is not sub and other.pts is not None and abs(st[other.j] - st[j]) < 2.0 * reserve:
            return
    tangent, normal = _frames(t.pts)
    q = sub.q_plan
    w0 = float(width_for_discharge(q))

    def widths_of(f):
        return _ramp(f, [0.0], [w0], WIDTH_GROWTH * w0)

    length = sub.length_m
    for attempt in range(_TRIES):
        if attempt and attempt % 8 == 0:
            length *= 0.8
        got = _candidate(rng, world, t.pts[j], tangent[j], normal[j], sub.side, sub.gamma, length,
                         widths_of, w_sub, exempt_m)
        if got is None:
            continue
        pts, widths = got
        s = _arc(pts)
        exempt = s > s[-1] - exempt_m
        if _clear_of(pts, 0.5 * widths, records, world, t.record, exempt):
            sub.pts, sub.widths, sub.j = pts, widths, j
            records.append(_Record(pts, 0.5 * widths))
            sub.fraction = float(st[j] / length_t)
            return


def _assemble(rng, world: _World, main, s_main, w_main, tangent, normal, q_main_src,
              tribs: list[_Trib]) -> tuple[list[RiverBranch], list[np.ndarray]]:
    """Split the main river at the tributary junctions, add island arms and free islands, and
    list every branch upstream first with numbered junctions."""
    length = s_main[-1]
    events = []  # (index on main, kind, payload)
    reserved = [(0.0, 0.05 * length + 3.0 * w_main[0]), (length - 0.05 * length - 3.0 * w_main[-1], length)]
    for t in tribs:
        r = t.exempt_m + 2.0 * float(w_main[t.ic])
        reserved.append((s_main[t.ic] - r, s_main[t.ic] + r))
        events.append((t.ic, "trib", t))
    n_arms = int(np.clip(1 + length // 60_000.0, 1, 10))
    for _ in range(n_arms):
        for _ in range(30):
            a = rng.uniform(0.0, length)
            ia = int(np.searchsorted(s_main, a))
            if ia >= len(main) - 2:
                continue
            w = float(w_main[ia])
            span = rng.uniform(5.0, 8.0) * w
            ib = int(np.searchsorted(s_main, s_main[ia] + span))
            pad = 3.0 * w + world.gap
            lo, hi = s_main[ia] - pad, s_main[min(ib, len(main) - 1)] + pad
            if ib >= len(main) - 1 or any(lo < b and a2 < hi for a2, b in reserved):
                continue
            reserved.append((lo, hi))
            events.append((ia, "arm", (ib, rng.uniform(0.2, 0.3) * w, bool(rng.integers(0, 2)))))
            break
    islands = []
    n_free = int(np.clip(1 + length // 40_000.0, 1, 14))
    for _ in range(n_free):
        for _ in range(30):
            a = rng.uniform(0.0, length)
            k = int(np.searchsorted(s_main, a))
            if k >= len(main) - 1:
                continue
            w = float(w_main[k])
            ax, bx = rng.uniform(0.3, 0.45) * w, rng.uniform(0.08, 0.12) * w
            off = rng.uniform(-0.12, 0.12) * w
            pad = ax + 2.0 * w + world.gap
            lo, hi = s_main[k] - pad, s_main[k] + pad
            if any(lo < b and a2 < hi for a2, b in reserved):
                continue
            reserved.append((lo, hi))
            ang = np.linspace(0, 2 * np.pi, 24, endpoint=False)
            center = main[k] + normal[k] * off
            islands.append(center + np.outer(ax * np.cos(ang), tangent[k]) + np.outer(bx * np.sin(ang), normal[k]))
            break
    events.sort(key=lambda e: e[0])

    branches: list[RiverBranch] = []
    next_j = [0]

    def junction() -> int:
        next_j[0] += 1
        return next_j[0] - 1

    q = q_main_src
    start, j_start, piece = 0, -1, 0

    def add_main(end: int, j_end: int) -> None:
        nonlocal piece
        branches.append(RiverBranch(f"main_{piece}", main[start:end + 1], _upstream_of_step(w_main[start:end + 1]),
                                    q, "main", j_start, j_end))
        piece += 1

    for k, kind, payload in events:
        if kind == "trib":
            j = junction()
            add_main(k, j)
            branches.extend(_trib_branches(payload, j, junction))
            q = q + payload.q + sum(s.q for s in payload.subs)
            start, j_start = k, j
        else:
            ib, half_island, swap = payload
            j1 = junction()
            add_main(k, j1)
            j2 = junction()
            seg = slice(k, ib + 1)
            t = (s_main[seg] - s_main[k]) / (s_main[ib] - s_main[k])
            ease = np.clip(np.minimum(t, 1 - t) / 0.45, 0.0, 1.0)
            bump = 1.0 - (1.0 - ease) ** 2
            shares = ARM_SHARES[::-1] if swap else ARM_SHARES
            q_left = q * shares[0] / (shares[0] + shares[1])
            for name, side, share, qa in (("left", 1.0, shares[0], q_left), ("right", -1.0, shares[1], q - q_left)):
                w = share * w_main[seg]
                pts = main[seg] + side * normal[seg] * ((half_island + 0.5 * w.max()) * bump)[:, None]
                pts[0], pts[-1] = main[k], main[ib]
                branches.append(RiverBranch(f"arm_{sum(1 for b in branches if b.kind == 'arm') // 2}_{name}",
                                            pts, w, qa, "arm", j1, j2))
            start, j_start = ib, j2
    add_main(len(main) - 1, -1)
    return branches, islands


def _trib_branches(t: _Trib, j_mouth: int, junction) -> list[RiverBranch]:
    """The pieces of tributary ``t`` (split where its subs join) and its subs, upstream first."""
    out = []
    start, j_start, q = 0, -1, t.q
    for m, s in enumerate(t.subs):
        j = junction()
        out.append(RiverBranch(f"trib_{t.index}_{m}", t.pts[start:s.j + 1],
                               _upstream_of_step(t.widths[start:s.j + 1]), q, "tributary", j_start, j))
        out.append(RiverBranch(f"trib_{t.index}_sub{m}", s.pts, s.widths, s.q, "tributary", -1, j))
        q = q + s.q
        start, j_start = s.j, j
    out.append(RiverBranch(f"trib_{t.index}_{len(t.subs)}", t.pts[start:], t.widths[start:], q, "tributary",
                           j_start, j_mouth))
    return out


def _upstream_of_step(widths: np.ndarray) -> np.ndarray:
    """Widths of a piece ending where the discharge steps up: its last sample carries the
    width downstream of the step; continue the piece's own ramp instead."""
    w = widths.copy()
    if len(w) >= 3:
        w[-1] = min(w[-1], 2.0 * w[-2] - w[-3])
    return w


def _smoothstep(e0: float, e1: float, x: np.ndarray) -> np.ndarray:
    t = np.clip((x - e0) / max(e1 - e0, 1e-12), 0.0, 1.0)
    return t * t * (3 - 2 * t)
