"""SpillSolver: the spills of a world on a :class:`~riverflow.hydro.spill_network.SpillNetwork`.

It holds every spill's cells and bookkeeping (:class:`riverflow.kernels.spill.SpillBook`),
advances them in whole steps of a fixed ``dt_s`` (so a result depends on the simulated time
only, never on how it was cut into frames or on the camera), and answers concentrations at
points.

**2-D near the source.** The solver is 1-D: a cell's concentration is the cross-section mean.
On the source's own link the plume is not yet mixed across the river: the concentration at a
point is the mean times a transverse profile, a Gaussian in the cross-river coordinate
η = (ψ − ψ_left) / (ψ_right − ψ_left) ∈ [0, 1] (the stream function: streamlines are lines of
constant η, so the plume follows the bends, islands and banks) centred on the source's η₀,
reflected at both banks, of standard deviation σ = √(2 ε_t τ) / W, τ = |s − s₀| / U the travel
time from the source. Its mean across the river is 1, so the cross-section mean stays the
solver's; once σ ≳ W it is flat (fully mixed).

**Below junctions** (:func:`plume_sections`). The stream function is one over the network:
below a confluence a tributary's water keeps its ψ range, its side of the river (its share of
the discharge), and a bifurcation's arms take theirs. So the profile at the start of a link
downstream is the upstream profile(s) at their ends, carried over in ψ (a clean tributary's
range at 0; links carrying the same spill taken at equal mean concentration), expressed in the
link's η, and from there it spreads by the same transverse mixing: a cosine series in η
(reflecting banks), mode n damped by exp(−n²π² σ²/2), σ² = ∫ 2 ε_t / (U W²) ds along the
link. Its mean across the river is 1 as well (the 1-D solver keeps the mass). Fully mixed
(within 1 %) after about 0.4 U W² / ε_t; then 1, and so on downstream.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy.spatial import cKDTree

from riverflow.hydro.spill_network import SpillNetwork
from riverflow.kernels.spill import SpillBook, TintTexels, spill_steps, tint_texels

MIN_SIGMA_ETA = 0.02
"""Smallest transverse standard deviation (in river widths) of a plume at its source."""
FRONT_FRACTION = 1e-3
"""A plume's front and tail: the farthest cells downstream and upstream whose concentration is
at least this fraction of its peak."""
_IMAGES = 3
SECTION_MODES = 64
"""Cosine modes of a plume's transverse profile below a junction."""
_SECTION_GRID = 256
MIXED_WITHIN = 0.01
"""A profile is fully mixed when it is within this of 1 across the river."""


@dataclass(frozen=True)
class PlumeSection:
    """A spill's transverse profile on one link below its source's (:func:`plume_sections`):
    f(η, s) = 1 + Σₙ aₙ cos(nπη) exp(−n²π² σ²(s) / 2), η = (ψ − ψ_lo) / (ψ_hi − ψ_lo),
    σ²(s) = σ₀² + ∫₀ˢ 2 ε_t / (U W²) ds."""

    psi_lo: float
    psi_hi: float
    coeffs: np.ndarray
    """(SECTION_MODES,) a₁ … aₙ at the link's start."""
    var_s: np.ndarray
    """(cells + 1,) σ² at the link's start, its cell boundaries and its end (s = 0, dx, … L)."""
    dx_m: float
    width_m: float
    """The link's median width [m]."""

    def profile(self, s_m: np.ndarray, psi: np.ndarray, min_sigma_m: float = 0.0
                ) -> np.ndarray:
        """f at points (s (P,), ψ (P,)); σ at least ``min_sigma_m`` [m] (a texel)."""
        span = self.psi_hi - self.psi_lo
        eta = np.clip((np.asarray(psi, np.float64) - self.psi_lo) / span, 0.0, 1.0)
        var = np.maximum(np.interp(np.asarray(s_m, np.float64) / self.dx_m,
                                   np.arange(len(self.var_s)), self.var_s),
                         (min_sigma_m / self.width_m) ** 2)
        n = np.arange(1, len(self.coeffs) + 1)
        damp = np.exp(-0.5 * (n * math.pi) ** 2 * var[:, None]) * self.coeffs
        return np.maximum(1.0 + np.einsum("pn,pn->p", np.cos(math.pi * eta[:, None] * n), damp),
                          0.0)


@dataclass
class SpillSource:
    """Where and how a spill is released (plain data, filled by :class:`SpillSolver`)."""

    xy_m: np.ndarray
    """(2,) release point [m] (moved into the water when given on land, see ``moved_m``)."""
    moved_m: float
    link: int
    s_m: float
    cell: int
    eta: float
    psi_left: float
    psi_right: float
    sections: dict = field(default_factory=dict)
    """{link: :class:`PlumeSection`} below the source's link where the plume is not yet mixed
    across the river (:func:`plume_sections`; empty: mixed at once below the source's link)."""


@dataclass
class SpillReport:
    """What :meth:`riverflow.RiverWorld.spill` says of one spill, at spill time ``time_s``."""

    name: str
    time_s: float
    released_kg: float
    in_water_kg: float
    out_kg: dict[str, float]
    """Mass out through each outlet (keyed by the outlet link's name) [kg]."""
    passed_kg: dict[str, float]
    """Mass that has left each link through its downstream end (keyed by link name) [kg]:
    at a bifurcation, what went down each arm."""
    decayed_kg: float
    front_m: float
    """The plume's front: distance along the river downstream of the source [m] (NaN: none)."""
    tail_m: float
    """Its tail (negative: upstream of the source) [m]."""
    front_xy_m: np.ndarray
    tail_xy_m: np.ndarray
    peak_kg_m3: float
    """Largest cross-section mean concentration [kg/m³]."""
    source_xy_m: np.ndarray
    moved_m: float
    """How far the release point was moved into the water [m] (0: it was in the water)."""

    @property
    def balance_kg(self) -> float:
        """released − (in water + out + decayed): 0 up to rounding."""
        return self.released_kg - (self.in_water_kg + sum(self.out_kg.values())
                                   + self.decayed_kg)


@dataclass(eq=False)
class SpillSolver:
    """The spills of one world (module docstring)."""

    network: SpillNetwork
    dt_s: float = 0.0
    """The fixed step [s] (default: the network's largest stable step)."""
    time_s: float = 0.0
    """Spill time reached, in whole steps [s]."""
    pending_s: float = 0.0
    book: SpillBook = field(init=False)
    sources: list[SpillSource] = field(default_factory=list)
    names: list[str] = field(default_factory=list)
    gone_out_kg: dict[str, np.ndarray] = field(default_factory=dict)
    """Mass [kg] each spill (by row) let out through an outlet that a live edit removed,
    by the outlet's name (:meth:`carried_to`): still in the reports' ``out_kg``."""

    def __post_init__(self) -> None:
        if not self.dt_s:
            self.dt_s = self.network.dt_max_s
        if not (math.isfinite(self.dt_s) and 0 < self.dt_s <= self.network.dt_max_s * (1 + 1e-9)):
            raise ValueError(f"SpillSolver: dt_s must be in (0, {self.network.dt_max_s:g}] s "
                             f"(the network's stable step), got {self.dt_s!r}")
        n = self.network.n_cells
        o = len(self.network.outlets)
        z = np.zeros(0)
        self.book = SpillBook(np.zeros((0, n)), np.zeros(0, np.int32), z, z.copy(), z.copy(),
                              z.copy(), z.copy(), np.zeros((0, o)), z.copy(),
                              np.zeros((0, len(self.network.names))))
        self._work = np.zeros(n)
        self._nodes = np.zeros(max(self.network.n_nodes, 1))

    @property
    def n_spills(self) -> int:
        return len(self.sources)

    def add(self, source: SpillSource, name: str, mass_kg: float, duration_s: float,
            decay_per_s: float) -> int:
        """Add a spill released from now (the next step) on; its row."""
        b = self.book
        t0 = self.time_s
        rows = [np.vstack([b.mass, np.zeros((1, b.mass.shape[1]))]),
                np.append(b.source_cell, np.int32(source.cell)).astype(np.int32),
                np.append(b.release_t0, t0), np.append(b.release_t1, t0 + float(duration_s)),
                np.append(b.release_kg, float(mass_kg)), np.append(b.decay_per_s, decay_per_s),
                np.append(b.released, 0.0), np.vstack([b.outflow, np.zeros((1, b.outflow.shape[1]))]),
                np.append(b.decayed, 0.0), np.vstack([b.passed, np.zeros((1, b.passed.shape[1]))])]
        self.book = SpillBook(*(np.ascontiguousarray(r) for r in rows))
        if not source.sections and self.network.link_psi_m2s is not None:
            source.sections = plume_sections(self.network, source)
        self.sources.append(source)
        self.names.append(name)
        return len(self.sources) - 1

    def advance(self, seconds: float) -> int:
        """Advance by ``seconds`` of spill time (whole steps; the rest waits for the next call);
        returns the steps taken."""
        self.pending_s += float(seconds)
        n = int(math.floor(self.pending_s / self.dt_s + 1e-9))
        if n <= 0:
            return 0
        if self.n_spills:
            spill_steps(self.network.net, self.book, self.time_s, self.dt_s, n, self._work,
                        self._nodes)
        self.time_s += n * self.dt_s
        self.pending_s = max(self.pending_s - n * self.dt_s, 0.0)
        return n

    def carried_to(self, network: SpillNetwork) -> SpillSolver:
        """This solver's spills on ``network`` (a live edit's, :mod:`riverflow.engine.edits`):
        each cell's mass goes to the new cell at the same place along the river (its link by
        name at the same fraction of its length; a link gone: the new cell nearest its
        centre), so the mass in the water is the same; each source goes with its link alike
        (its point: to the nearest new cell when its link is gone); the releases, decay and
        counts go on; what left through an outlet that is gone stays counted
        (:attr:`gone_out_kg`). Same clock, same step (the new network's stable step if
        smaller)."""
        from riverflow.hydro.spill_network import cell_map, same_place

        old, b = self.network, self.book
        new = SpillSolver(network, dt_s=min(self.dt_s, network.dt_max_s), time_s=self.time_s,
                          pending_s=self.pending_s)
        index = {name: k for k, name in enumerate(network.names)}
        cells = cell_map(old, network)
        n = network.n_cells
        mass = np.array([np.bincount(cells, weights=m, minlength=n) for m in b.mass]
                        ).reshape(len(b.mass), n)
        sources = []
        for src in self.sources:
            (k,), (s,) = same_place(old, network, np.array([src.link]), np.array([src.s_m]),
                                    src.xy_m[None, :])
            sources.append(SpillSource(src.xy_m.copy(), src.moved_m, int(k), float(s),
                                       int(network.cell_of(np.array([k]), np.array([s]))[0]),
                                       src.eta, src.psi_left, src.psi_right))
        outlets = {name: k for k, name in enumerate(old.outlets)}
        outflow = np.zeros((len(b.mass), len(network.outlets)))
        for j, name in enumerate(network.outlets):
            if name in outlets:
                outflow[:, j] = b.outflow[:, outlets[name]]
        gone = {name: np.array(v, np.float64) for name, v in self.gone_out_kg.items()}
        for name, k in outlets.items():
            if name not in network.outlets:
                gone[name] = gone.get(name, np.zeros(0))
                gone[name] = np.r_[gone[name], np.zeros(len(b.mass) - len(gone[name]))] \
                    + b.outflow[:, k]
        passed = np.zeros((len(b.mass), len(network.names)))
        for k, name in enumerate(old.names):
            if name in index:
                passed[:, index[name]] = b.passed[:, k]
        new.book = SpillBook(*(np.ascontiguousarray(r) for r in (
            mass, np.array([s.cell for s in sources], np.int32), b.release_t0, b.release_t1,
            b.release_kg, b.decay_per_s, b.released, outflow, b.decayed, passed)))
        new.sources, new.names, new.gone_out_kg = sources, list(self.names), gone
        return new

    def cell_concentration(self) -> np.ndarray:
        """(S, N) cross-section mean concentration of each spill in each cell [kg/m³]."""
        return self.book.mass / self.network.net.cell_vol

    def concentration(self, xy_m: np.ndarray, psi: np.ndarray, per_spill: bool = False
                      ) -> np.ndarray:
        """Concentration [kg/m³] at points (P, 2) whose stream function is ``psi`` (P,) (NaN:
        not in the water, concentration 0): (P,) the sum over spills, or (S, P) each."""
        xy = np.asarray(xy_m, np.float64).reshape(-1, 2)
        psi = np.asarray(psi, np.float64).reshape(-1)
        net = self.network
        out = np.zeros((self.n_spills, len(xy)))
        wet = np.isfinite(psi)
        if self.n_spills and wet.any():
            link, s, _ = net.locate(xy[wet])
            c = net.interpolate(self.cell_concentration(), link, s)
            for k in range(self.n_spills):
                c[k] *= self.transverse(k, link, s, psi[wet])
            out[:, wet] = c
        return out if per_spill else out.sum(axis=0)

    def transverse(self, row: int, link: np.ndarray, s_m: np.ndarray, psi: np.ndarray,
                   min_sigma_m: float = 0.0) -> np.ndarray:
        """Spill ``row``'s transverse profile (mean 1 across the river) at points on the
        network (link (P,), arc length s (P,), stream function ψ (P,)): its near field on the
        source's link, its sections below junctions, 1 where it is mixed (module docstring)."""
        src = self.sources[row]
        f = np.ones(len(link))
        here = link == src.link
        if here.any():
            f[here] = near_field_profile(self.network, src, s_m[here], psi[here],
                                         min_sigma_m)
        for b, section in src.sections.items():
            here = link == b
            if here.any():
                f[here] = section.profile(s_m[here], psi[here], min_sigma_m)
        return f

    def report(self, row: int) -> SpillReport:
        net = self.network
        b = self.book
        c = b.mass[row] / net.net.cell_vol
        src = self.sources[row]
        peak = float(c.max()) if len(c) else 0.0
        front = tail = float("nan")
        fxy = txy = np.full(2, np.nan)
        if peak > 0:
            dist = net.downstream_distance(src.link, src.s_m)
            on = np.flatnonzero((c >= FRONT_FRACTION * peak) & np.isfinite(dist))
            if len(on):
                f, t = on[np.argmax(dist[on])], on[np.argmin(dist[on])]
                front, tail = float(dist[f]), float(dist[t])
                fxy, txy = net.cell_xy_m[f].copy(), net.cell_xy_m[t].copy()
        return SpillReport(
            name=self.names[row], time_s=self.time_s, released_kg=float(b.released[row]),
            in_water_kg=float(b.mass[row].sum()),
            out_kg={**{name: float(v) for name, v in zip(net.outlets, b.outflow[row])},
                    **{name: float(v[row]) for name, v in self.gone_out_kg.items()
                       if row < len(v)}},
            passed_kg={name: float(v) for name, v in zip(net.names, b.passed[row])},
            decayed_kg=float(b.decayed[row]), front_m=front, tail_m=tail, front_xy_m=fxy,
            tail_xy_m=txy, peak_kg_m3=peak, source_xy_m=src.xy_m.copy(), moved_m=src.moved_m)


TINT_TEXELS = 256
"""Side of the spill tint texture [texels]."""
TINT_REFRESH_S = 5.0
"""The tint follows the spills every this many seconds of spill time (a plume moves a few
metres: less than a texel)."""
TINT_SAMPLE_EVERY = 16
"""A wave particle samples the spills' grid for the tint it carries when it is made and every
this many frames (a power of two; staggered by slot), all of them when the grid changes while
the frame stands still (a paused world): between samples it carries its tint along
(:func:`riverflow.kernels.spill.sample_tint`)."""
TINT_MIN_SIDE_M = 256.0
"""Smallest side of the square the tint covers [m] (sides are this × a power of two)."""
TINT_SWAP_FRAMES = 8
"""A square placed in the background (:class:`SpillTint` with frames) is swapped in this many
frames after it was asked for, its thread waited for then: a frame fixed when it is asked for,
never the time the thread took, so the frames stay deterministic (~30 ms of work has 8
frames to run)."""
TINT_PLACE_CACHE_TILES = 32
"""Flow tiles the tint's own cache holds (:meth:`riverflow.FlowField.detached`): the coarse
level's tiles under a square, kept for the next square (~3 MB)."""


@dataclass(eq=False)
class TintPlacement:
    """Each texel of one square on the network (:func:`place_texels`), found once per square:
    the costly part of a square move."""

    rect: tuple[float, float, float]
    """(x0, y0, side) [m] (side 0: nothing to tint)."""
    network: SpillNetwork
    texels: TintTexels
    """The wet texels (flat indices, row-major), their two cells and weight, the spills'
    profiles there, the fringe (:func:`riverflow.kernels.spill.tint_texels`)."""
    psi: np.ndarray
    link: np.ndarray
    s: np.ndarray
    texel_m: float

    @property
    def n_spills(self) -> int:
        """The spills whose profiles it holds (the first ones)."""
        return len(self.texels.profile)


def place_texels(solver: SpillSolver, flow, rect: tuple[float, float, float],
                 n_spills: int | None = None) -> TintPlacement:
    """Each texel's place on the network for the square ``rect`` and the first ``n_spills``
    spills' transverse profiles there (default: all). It reads ``solver``'s network and
    sources only, never its masses: a thread may run it while the frames step the solver.

    The stream function at the texels near a river comes from the flow tiles of the coarsest
    level whose lattice is at most half a texel (``FlowField.level_for_spacing``): a 32 m
    texel reads 16 m tiles, a few of them, not the finest level's hundreds; the η it gives
    differs from the finest level's by ~0.2 % of the river's ψ range (p95; a texel is tens of
    percent of it). ``flow`` is the world's field or its :meth:`~riverflow.FlowField.detached`
    twin (the same tiles); without obstacles (a boat passing when the square is placed is not
    frozen into it). The dry texels next to the water take their nearest wet texel's value,
    so that the texture's bilinear filter does not darken the water along the banks."""
    net = solver.network
    n_spills = solver.n_spills if n_spills is None else int(n_spills)
    x0, y0, side = rect
    n = TINT_TEXELS
    cell = side / n if side > 0 else 0.0
    xy, near = np.zeros((0, 2)), np.zeros(0, np.int64)
    if side > 0:
        g = (np.arange(n) + 0.5) * cell
        gx, gy = np.meshgrid(x0 + g, y0 + g)
        xy = np.column_stack([gx.ravel(), gy.ravel()])
        # only texels near a centre line can be water: the stream function there alone
        near = _near_texels(net, xy, n, cell, float(net.cell_width_m.max()))
    psi = flow.potential(xy[near], level=flow.level_for_spacing(0.5 * cell),
                         exclude_obstacles=True) if len(near) else np.zeros(0)
    water = np.isfinite(psi)
    wet, psi = near[water], psi[water]
    link, s, _ = net.locate(xy[wet])
    ia, ib, iw = net.weights(link, s)
    fringe = near[~water]
    fringe_from = np.zeros(0, np.int64)
    if len(wet) and len(fringe):
        _, k = cKDTree(xy[wet]).query(xy[fringe])
        fringe_from = wet[k]
    prof = np.ones((n_spills, len(wet)))
    for k in range(n_spills):
        prof[k] = solver.transverse(k, link, s, psi, cell)
    as64 = lambda a: np.ascontiguousarray(a, np.int64)           # noqa: E731
    texels = TintTexels(as64(wet), as64(ia), as64(ib), np.ascontiguousarray(iw, np.float64),
                        prof, as64(fringe), as64(fringe_from))
    return TintPlacement(rect, net, texels, psi, link, s, cell)


class _PlaceJob:
    """:func:`place_texels` in a thread of its own, waited for at frame ``swap_frame``."""

    def __init__(self, solver: SpillSolver, flow, rect, swap_frame: int) -> None:
        import threading

        self.rect = rect
        self.n_spills = solver.n_spills
        self.swap_frame = int(swap_frame)
        self.flow = flow
        self.result: TintPlacement | None = None
        self.error: BaseException | None = None
        self.thread = threading.Thread(target=self._run, args=(solver,), daemon=True,
                                       name="riverflow-spill-tint")
        self.thread.start()

    def _run(self, solver: SpillSolver) -> None:
        try:
            self.result = place_texels(solver, self.flow, self.rect, self.n_spills)
        except BaseException as exc:  # noqa: BLE001 - raised in the frame that waits for it
            self.error = exc

    def join(self) -> TintPlacement:
        self.thread.join()
        if self.error is not None:
            raise self.error
        return self.result


@dataclass(eq=False)
class SpillTint:
    """The spills' concentration at draw resolution, a small RGBA float32 grid over a square of
    the world that holds the plumes: what the wave particles sample for the tint they carry in
    the normal look (:func:`riverflow.kernels.spill.sample_tint`) and the concentration display
    mode's texture (``shaders/spill.glsl``):
    RGB the concentration-weighted mean colour of the spills there, A the total concentration
    [kg/m³]. The square's side is TINT_MIN_SIDE_M × a power of two and its corner a multiple
    of a quarter of it; each texel's place on the network (link, arc length, ψ, the spills'
    transverse profiles) is found once per square (the slow part, ~30 ms:
    :func:`place_texels`), its concentration again when the spills have stepped by
    TINT_REFRESH_S.

    Without frames (``update(..., frame=None)``) the square is the smallest that holds the
    plumes, placed at once when that changes. With frames (the draw system) a square is
    never placed in a frame (but in a frame drawn again: ``update``'s ``again``): it is kept while it holds the plumes grown by what they can
    travel before the next square could be swapped in (twice the network's fastest flow, or
    the plumes' growth if faster, over TINT_REFRESH_S and TINT_SWAP_FRAMES frames of spill
    time); when they would outgrow it (or a smaller one would do, or a spill was added) the
    next square is placed in a thread and swapped in TINT_SWAP_FRAMES frames later, the old
    one drawn meanwhile (a plume that has left it meanwhile, after a jump in spill time or a
    young plume's first square, placed before its growth was measured, is drawn in part for
    those frames). What a frame draws depends on the frames and the spills only, never on
    when the thread ended.
    """

    rect_m: tuple[float, float, float] = (0.0, 0.0, 0.0)
    """(x0, y0, side) [m] of the square (side 0: nothing to tint)."""
    rgba: np.ndarray = field(default_factory=lambda: np.zeros((TINT_TEXELS, TINT_TEXELS, 4),
                                                              np.float32))
    version: int = 0
    """Increases whenever ``rgba`` or ``rect_m`` changed (the draw system uploads then)."""
    rows: tuple[int, int] = (0, TINT_TEXELS)
    """The rows [first, last + 1) of ``rgba`` that the last change can have changed (those
    holding a tinted texel before or after it; all of them when the square moved): the
    draw system uploads those alone."""
    placed: TintPlacement | None = None
    """The square drawn now and its texels on the network."""
    placements: int = 0
    """Squares placed so far (in a thread or not)."""
    _tinted_rows: tuple[int, int] = (0, 0)
    _key: tuple = ()
    _job: _PlaceJob | None = None
    _network: object = None
    _flow: object = None
    _twin: object = None
    _pace: tuple = ()
    _origin: tuple = ()
    _reach: tuple = ()           # (the network's fastest flow, its longest cell) [m/s, m]

    def update(self, solver: SpillSolver, flow, colours, frame: int | None = None,
               again: bool = False) -> bool:
        """Follow the solver (``flow`` the world's :class:`~riverflow.hydro.flow_field.
        FlowField`, for ψ at the texels; ``colours`` (S, 3) the spills' RGB; ``frame`` the
        world's frame: squares placed in a thread, None: at once; ``again``: this frame was
        drawn before (a paused host, a screenshot): a square the plumes have left, or a
        spill not placed yet, is placed at once, as without frames); True if the texture
        changed."""
        if self._network is not solver.network:      # a live edit's new cells: placed again
            self._network, self._key, self.placed, self._job = solver.network, (), None, None
            self._origin = ()
            net = solver.network
            self._reach = (float(net.cell_speed_mps.max()), float(net.link_dx_m.max()))
        job = self._job
        due = job is not None and frame is not None and frame >= job.swap_frame
        if not due and self._key and self._key[1] == solver.n_spills \
                and 0.0 <= solver.time_s - self._key[0] < TINT_REFRESH_S:
            return False
        extent = _extent(solver, self._reach[1])
        moved = False
        if frame is None:
            rect = _square_of(extent)
            placed = self.placed
            if placed is None or rect != placed.rect or placed.n_spills != solver.n_spills:
                self._install(place_texels(solver, self._twin_of(flow, fresh=False), rect))
                moved = True
        else:
            if due:
                self._install(job.join())
                self._job = job = None
                moved = True
            placed = self.placed
            if again and (placed is None or placed.n_spills != solver.n_spills
                          or extent is not None and not _holds(placed.rect, extent)):
                self._install(place_texels(solver, self._twin_of(
                    flow, fresh=job is not None and job.thread.is_alive()),
                    _square_of(extent)))
                self._job = job = None
                moved = True
            elif placed is None:                     # nothing drawn until the first swap
                self._install(place_texels(solver, flow, (0.0, 0.0, 0.0), 0))
                moved = True
            job = self._job
            if job is None or job.n_spills != solver.n_spills:
                rect = self._next_square(solver, extent, frame)
                if rect is not None:
                    if rect[2] == 0.0:               # no plume left: nothing to place
                        self._install(place_texels(solver, flow, rect))
                        self._job = None
                        moved = True
                    else:
                        busy = job is not None and job.thread.is_alive()
                        self._job = _PlaceJob(solver, self._twin_of(flow, fresh=busy), rect,
                                              frame + TINT_SWAP_FRAMES)
            self._pace = (solver.time_s, frame)
        self._key = (solver.time_s, solver.n_spills)
        placed = self.placed
        now = (0, 0)
        if moved:
            self.rgba[:] = 0.0
        rows = placed.n_spills                       # (with frames: those placed so far)
        if len(placed.texels.wet) and rows:
            now = tint_texels(placed.texels, np.ascontiguousarray(
                solver.cell_concentration()[:rows]),
                np.asarray(colours, np.float64)[:rows, :3].copy(), self.rgba.reshape(-1, 4))
        was = self._tinted_rows
        if moved:
            self.rows = (0, TINT_TEXELS)
        elif now[1] > now[0] and was[1] > was[0]:
            self.rows = (min(now[0], was[0]), max(now[1], was[1]))
        else:
            self.rows = now if now[1] > now[0] else was
        self._tinted_rows = now
        self.version += 1
        return True

    def _install(self, placed: TintPlacement) -> None:
        self.placed = placed
        self.rect_m = placed.rect
        self.placements += 1

    def _twin_of(self, flow, fresh: bool):
        """The world's field with a tile cache of the tint's own (a new one when ``fresh``:
        a thread still uses the old one)."""
        if self._twin is None or self._flow is not flow or fresh:
            self._flow = flow
            self._twin = flow.detached(TINT_PLACE_CACHE_TILES)
        return self._twin

    def _next_square(self, solver: SpillSolver, extent, frame: int):
        """The square to place next in the background (class docstring), or None: the plumes'
        extent grown by ``grow``, twice the fastest flow (or the box's mean growth since these
        spills were first seen, if faster) over TINT_REFRESH_S and TINT_SWAP_FRAMES frames of
        spill time (the spill time per frame measured since the last refresh), fits the
        square drawn, no smaller square would hold it grown by four times that, and every
        spill is placed. The next square holds the extent grown by twice that (a margin both
        ways: no square flickers between two sizes)."""
        placed = self.placed
        if extent is None:
            return (0.0, 0.0, 0.0) if placed.rect[2] > 0.0 else None
        per_frame = 0.0
        if self._pace and frame > self._pace[1]:
            per_frame = max(solver.time_s - self._pace[0], 0.0) / (frame - self._pace[1])
        speed = self._reach[0]
        if self._origin and self._origin[1] == solver.n_spills:
            # how fast the plumes' box has grown since these spills were first seen (a young
            # plume's faint edge spreads faster than the flow)
            t, _, lo, hi = self._origin
            if solver.time_s - t >= TINT_REFRESH_S:
                (lx, ly), (hx, hy) = lo - extent[0], extent[1] - hi
                speed = max(speed, float(max(lx, ly, hx, hy)) / (solver.time_s - t))
        else:
            self._origin = (solver.time_s, solver.n_spills, *extent)
        ahead_s = TINT_REFRESH_S + TINT_SWAP_FRAMES * per_frame
        grow = 2.0 * speed * ahead_s
        held = _holds(placed.rect, (extent[0] - grow, extent[1] + grow)) \
            and _square_of((extent[0] - 4.0 * grow, extent[1] + 4.0 * grow))[2] \
            >= placed.rect[2]
        if held and placed.n_spills == solver.n_spills:
            return None
        return _square_of((extent[0] - 2.0 * grow, extent[1] + 2.0 * grow))


def _extent(solver: SpillSolver, dx_max: float | None = None):
    """(lo (2,), hi (2,)) [m]: the box around every cell holding a spill (at least
    FRONT_FRACTION of its peak), padded by the widest river and a cell (``dx_max``: the
    network's longest, if known); None: no plume."""
    if not solver.n_spills:
        return None
    c = solver.cell_concentration()
    # c > 0 and c ≥ FRONT_FRACTION × peak in one comparison: the least positive double is
    # the threshold where that product is not positive (a spill with nothing left)
    least = np.maximum(FRONT_FRACTION * c.max(axis=1, keepdims=True), 5e-324)
    on = np.flatnonzero((c >= least).any(axis=0))
    if not len(on):
        return None
    net = solver.network
    if dx_max is None:
        dx_max = float(net.link_dx_m.max())
    pad = float(net.cell_width_m[on].max()) + dx_max
    xy = net.cell_xy_m[on]
    return xy.min(axis=0) - pad, xy.max(axis=0) + pad


def _square_of(extent) -> tuple[float, float, float]:
    """The smallest aligned square (SpillTint's docstring) holding ``extent``; side 0: None."""
    if extent is None:
        return (0.0, 0.0, 0.0)
    lo, hi = extent
    side = TINT_MIN_SIDE_M
    while True:
        step = 0.25 * side
        x0, y0 = (math.floor(v / step) * step for v in lo)
        if x0 + side >= hi[0] and y0 + side >= hi[1]:
            return (float(x0), float(y0), float(side))
        side *= 2.0


def _holds(rect, extent) -> bool:
    x0, y0, side = rect
    lo, hi = extent
    return side > 0 and x0 <= lo[0] and y0 <= lo[1] and x0 + side >= hi[0] \
        and y0 + side >= hi[1]


def _near_texels(net: SpillNetwork, xy: np.ndarray, n: int, cell: float, reach: float
                 ) -> np.ndarray:
    """The texels (flat indices into ``xy``, the centres of an n × n grid of ``cell`` [m]
    texels, row-major) within ``reach`` [m] of a centre-line sample of ``net``: those of the
    blocks of 8 × 8 texels whose centre is within ``reach`` + half their diagonal of one
    (a few of them) looked up alone, the same texels as looking up every one."""
    b = 8 if n % 8 == 0 else 1
    m = n // b
    centres = xy.reshape(m, b, m, b, 2).mean(axis=(1, 3)).reshape(-1, 2)
    blocks = net.locate(centres, reach + 0.5 * math.sqrt(2.0) * b * cell * (1 + 1e-9))[0] >= 0
    candidates = np.flatnonzero(np.repeat(np.repeat(blocks.reshape(m, m), b, 0), b, 1))
    return candidates[net.locate(xy[candidates], reach)[0] >= 0]


def near_field_profile(net: SpillNetwork, src: SpillSource, s_m: np.ndarray, psi: np.ndarray,
                       min_sigma_m: float = 0.0) -> np.ndarray:
    """The transverse profile (mean 1 across the river) on the source's link; its standard
    deviation at least ``min_sigma_m`` [m] (a texture's texel: no plume narrower than what
    can be drawn, which would alias into beads)."""
    lk = np.full(len(s_m), src.link)
    u = net.interpolate(net.cell_speed_mps, lk, s_m)
    eps = net.interpolate(net.cell_eps_m2s, lk, s_m)
    w = net.interpolate(net.cell_width_m, lk, s_m)
    tau = np.abs(s_m - src.s_m) / np.maximum(u, 1e-9)
    sigma = np.maximum(np.sqrt(2.0 * eps * tau + min_sigma_m ** 2) / w, MIN_SIGMA_ETA)
    span = src.psi_right - src.psi_left
    eta = np.clip((psi - src.psi_left) / span, 0.0, 1.0) if span > 0 else np.full(len(psi), 0.5)
    f = np.zeros(len(s_m))
    for k in range(-_IMAGES, _IMAGES + 1):
        for centre in (src.eta + 2 * k, -src.eta + 2 * k):
            f += np.exp(-0.5 * ((eta - centre) / sigma) ** 2)
    return f / (sigma * math.sqrt(2.0 * math.pi))


def plume_sections(network: SpillNetwork, source: SpillSource) -> dict[int, PlumeSection]:
    """The transverse profiles of a spill released at ``source`` on the links below its own,
    down to where it is fully mixed (module docstring); needs ``network.link_psi_m2s``.

    Walks the links in their upstream-first order: a link reached by the spill starts with the
    profiles of the reached links ending at its start junction, carried over in ψ (a reached
    link's profile at its end, 1 if mixed; 0 over the ψ range of a link the spill has not
    reached), normalised to mean 1 over the link's ψ range (each reached link is taken at the
    same mean concentration), as cosine coefficients; a flat one (within MIXED_WITHIN) is not
    kept."""
    psi = network.link_psi_m2s
    if psi is None:
        return {}
    net = network.net
    eta = (np.arange(_SECTION_GRID) + 0.5) / _SECTION_GRID
    n = np.arange(1, SECTION_MODES + 1)
    basis = np.cos(math.pi * eta[:, None] * n)                      # (G, M)
    reached = {source.link}
    ends: dict[int, object] = {}        # reached link -> its profile at its end (None: flat)
    ends[source.link] = _source_end(network, source)
    out: dict[int, PlumeSection] = {}
    for b in range(source.link + 1, len(network.names)):
        j = int(net.link_start[b])
        if j < 0:
            continue
        into = [int(a) for a in np.flatnonzero(net.link_end == j)]
        if not any(a in reached for a in into):
            continue
        reached.add(b)
        lo, hi = (float(v) for v in psi[b])
        if not hi > lo:
            ends[b] = None
            continue
        here = lo + eta * (hi - lo)
        # each point of the section takes the water of the link whose ψ range is nearest
        # (the ranges, measured mid-link, tile the section to a fraction of a percent)
        gap = np.stack([np.maximum(np.maximum(psi[a, 0] - here, here - psi[a, 1]), 0.0)
                        for a in into])
        nearest = np.asarray(into)[np.argmin(gap, axis=0)]
        g = np.zeros(_SECTION_GRID)
        for a in into:
            inside = nearest == a
            if a not in reached or not inside.any():
                continue
            g[inside] = 1.0 if ends[a] is None else ends[a](here[inside])
        mean = g.mean()
        if not mean > 0 or np.abs(g / mean - 1.0).max() <= MIXED_WITHIN:
            ends[b] = None                 # mixed (or the spill's water is not here)
            continue
        g = g / mean
        coeffs = 2.0 * (basis * (g - 1.0)[:, None]).mean(axis=0)
        cells = slice(int(net.link_c0[b]), int(net.link_c1[b]))
        rate = 2.0 * network.cell_eps_m2s[cells] / (network.cell_speed_mps[cells]
                                                    * network.cell_width_m[cells] ** 2)
        dx = float(network.link_dx_m[b])
        var = MIN_SIGMA_ETA ** 2 + np.concatenate([[0.0], np.cumsum(rate * dx)])
        out[b] = section = PlumeSection(lo, hi, coeffs, var, dx,
                                        float(np.median(network.cell_width_m[cells])))
        ends[b] = _flat_or(lambda p, sec=section, s=float(network.link_length_m[b]):
                           sec.profile(np.full(len(p), s), p), lo, hi)
    return out


def _flat_or(profile, lo: float, hi: float):
    """``profile`` (a function of ψ), or None if it is flat within MIXED_WITHIN over [lo, hi]."""
    f = profile(lo + np.linspace(0.0, 1.0, 65) * (hi - lo))
    return None if np.abs(f - 1.0).max() <= MIXED_WITHIN else profile


def _source_end(network: SpillNetwork, source: SpillSource):
    """The near field at the end of the source's link as a function of ψ (None: flat)."""
    s = float(network.link_length_m[source.link])
    return _flat_or(lambda p: near_field_profile(network, source, np.full(len(p), s),
                                                 np.asarray(p, np.float64)),
                    source.psi_left, source.psi_right)
