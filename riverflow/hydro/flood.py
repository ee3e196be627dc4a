"""FloodRouter: discharge over time on a river network (issue 25, item 2).

Hydrographs (inflow [m³/s] against world time) are routed down the spill network's cells
(:class:`~riverflow.hydro.spill_network.SpillNetwork`: one cut of the network into cells along
its links, shared with the spills) by the kinematic wave (:mod:`riverflow.kernels.flood`). What
the rest of the world reads from it, per cell, relative to base flow:

* the discharge ratio r = Q / Q₀;
* the flow speed factor U / U₀ = r^(2/5) (Manning, wide channel: h ∝ Q^(3/5), so the
  depth-averaged speed Q / (W h) grows as Q^(2/5)); the flow field multiplies its velocities
  by it (:meth:`FlowField.query`, the particles' query) — the ψ tiles are not re-made;
* the level rise Δz = h₀ (r^(3/5) − 1) [m] (the rating curve h = h₀ (Q / Q₀)^(3/5), i.e.
  Manning's h = (Q n / (W √S))^(3/5) with the slope and roughness the base state implies);
* on the floodplain (ground beside the river below the raised level, given :attr:`FloodRouter.
  ground`), a slow flow down the valley: the nearest centre line's downstream direction at
  Manning's speed for the water's depth there and the floodplain's roughness,
  U = U_c (h / h_c)^(2/3) / FLOODPLAIN_ROUGHNESS (U_c, h_c: the channel's mean speed and
  depth now; the slope cancels), 0 at the wet edge (:meth:`FloodRouter.floodplain_flow`).

The router steps in whole fixed steps (Courant number ≤ ``COURANT`` at the highest discharge
any hydrograph reaches), so a run depends on the world time only, never on how frames cut it.
"""
from __future__ import annotations

import math

import numpy as np

from riverflow.kernels.flood import (CellRaster, FloodNet, Hydrographs, flood_steps,
                                     sample_by_cells, scale_by_cells)

MAX_FLOOD_RATIO = 1e4
"""Largest hydrograph discharge over a link's base flow Q₀ (floods reach tens of times their
base flow): the fixed step shrinks as ratio^(-2/5), so a larger ratio (a unit mistake) would
stall the frames and overflow the step count."""
COURANT = 0.9
"""Largest Courant number c dt / Δx of the router's fixed step."""
ACTIVE_EPS = 1e-9
"""The flow field is left untouched while every cell's speed factor is within this of 1."""
RASTER_PIXELS_PER_CELL = 4
"""The cell raster's pixel is the shortest cell length over this (:func:`cell_raster`)."""
RASTER_REACH = 1.5
"""The cell raster covers this many half-widths (at least) on each side of a centre line."""
RASTER_MAX_PIXELS = 1 << 24
"""The cell raster's pixels (and its block table's entries) at most: its pixel grows by
powers of two until both fit (about 130 MB at most)."""
RASTER_BLOCK_PX = 16
LEVEL_TEXELS = 1024
"""Side [texels] of the drawn level's cell texture (:meth:`FloodRouter.level_textures`)."""
LEVEL_BLOCK = 16
"""The level texture is made in square blocks of this many texels a side (a block far from
every centre line asks no KD-tree; an edit makes again only the blocks near what changed)."""
RISE_ROW = 1024
"""Cells per row of the drawn level's rise texture."""
FLOODPLAIN_REACH_M = 250.0
"""The drawn level's cell texture reaches this far from a centre line [m] (the floodplain:
beyond the cell raster, the nearest cell by the KD-tree); the terrain shader floods the ground
below the level there (it knows the level within 200 m of a shore,
``scenes.tile_kinds.LEVEL_REACH_M``)."""
FLOODPLAIN_ROUGHNESS = 2.0
"""The floodplain's Manning n over the channel's (pasture or light brush, n ≈ 0.035–0.07,
against a clean natural channel's 0.03: Chow 1959, table 5-6): its water flows at most half
the channel's mean speed at the channel's depth."""
FLOODPLAIN_MIN_DEPTH_M = 1e-3
"""Ground under less water than this [m] is dry for the flow (the wet edge)."""
FLOODPLAIN_SHEAR_M = 10.0
"""Width [m] of the shear layer beside a flooded channel's bank: the floodplain's water
runs at the channel's mean speed at the bank (the base field's speed there, within a few
per cent: its flow is nearly uniform across) and slows to its own Manning speed over this
distance (smoothstep), so the flow is continuous across the bank (a compound channel's
mixing layer spans a few channel depths: Knight & Shiono 1990)."""
FLOOD_BLEND_M = 30.0
"""The drawn rise blends over this band [m] around the line where the nearest link changes
(:meth:`FloodRouter.level_textures`): a flooded river beside one that is not meets it on a
ramp, not a step along the terrain's triangles."""
WET_FALL_MPS = 0.5 / 3600.0
"""How fast the line of wet-looking ground falls behind a falling flood [m/s] (0.5 m an hour
of flood time): ground the flood covered looks wet for a while after the water left it."""


def _as_float_array(values, what: str) -> np.ndarray:
    try:
        arr = np.asarray(values, np.float64)
    except (TypeError, ValueError, OverflowError):
        raise ValueError(f"set_hydrograph: {what} must be numbers, got {values!r:.80}") from None
    if arr.ndim != 1 or len(arr) < 1:
        raise ValueError(f"set_hydrograph: {what} must be a 1-D sequence of one value or more, "
                         f"got shape {arr.shape}")
    return arr


def _same_link(old, ob: int, new, b: int) -> bool:
    """Whether link ``ob`` of spill network ``old`` and link ``b`` of ``new`` are the same
    link: the same cells (count, length, widths) and centre-line samples (places and arc
    lengths), so every lookup near it finds the same place and cell (up to where its cells
    are numbered)."""
    o0, o1 = int(old.net.link_c0[ob]), int(old.net.link_c1[ob])
    n0, n1 = int(new.net.link_c0[b]), int(new.net.link_c1[b])
    if o1 - o0 != n1 - n0 or old.link_dx_m[ob] != new.link_dx_m[b]:
        return False
    if not np.array_equal(old.cell_width_m[o0:o1], new.cell_width_m[n0:n1]):
        return False
    so, sn = old._sample_link == ob, new._sample_link == b
    return (np.array_equal(old._tree.data[so], new._tree.data[sn])
            and np.array_equal(old._sample_s[so], new._sample_s[sn]))


def base_discharges_m3s(network) -> np.ndarray:
    """(B,) each link's base discharge Q₀ [m³/s], consistent at every node: a source link's
    is its ψ difference times its depth (q h₀), a link below a node gets its share of what
    the links ending there carry (so base flow is a steady state of the routing, whatever
    rounding the scene's ψ differences and depths carry)."""
    s = network.net
    q0 = network.link_q_m2s * network.link_depth_m
    node = np.zeros(max(network.n_nodes, 1))
    for b in range(len(q0)):                                     # upstream-first order
        if s.link_start[b] >= 0:
            q0[b] = node[s.link_start[b]] * s.link_share[b]
        if s.link_end[b] >= 0:
            node[s.link_end[b]] += q0[b]
    return q0


def cell_raster(network, pixel_m: float | None = None) -> CellRaster:
    """The :class:`~riverflow.kernels.flood.CellRaster` of a spill network: blocks of
    ``RASTER_BLOCK_PX``² pixels of side ``pixel_m`` (default: the shortest cell over
    ``RASTER_PIXELS_PER_CELL``, doubled until it fits ``RASTER_MAX_PIXELS``) wherever a
    centre line's sample is within ``RASTER_REACH`` half-widths (+ one pixel) of the block;
    each pixel holds the cell coordinate its centre reads by :meth:`SpillNetwork.locate`
    (the nearest centre-line sample), so a point reads what the KD-tree gives the pixel's
    centre: within half a pixel diagonal of the point. The blocks lie on a lattice of their
    side from (0, 0)."""
    sample_xy = network._tree.data
    link = network._sample_link
    half = np.array([float(network.cell_width_m[network.net.link_c0[b]:
                                                network.net.link_c1[b]].max())
                     for b in range(len(network.names))]) * 0.5
    reach = RASTER_REACH * half[link]
    low = (sample_xy - reach[:, None]).min(axis=0)
    hi = (sample_xy + reach[:, None]).max(axis=0)
    px = float(pixel_m) if pixel_m is not None else \
        float(network.link_dx_m.min()) / RASTER_PIXELS_PER_CELL
    if not (math.isfinite(px) and px > 0):
        raise ValueError(f"cell_raster: pixel_m must be a finite number > 0, got {pixel_m!r}")
    B = RASTER_BLOCK_PX
    while True:
        block_m = B * px
        # its corner on a lattice of blocks: a live edit that moves the network's extent by
        # millimetres leaves the raster, and the level texture made from it, where it was
        lo = np.floor(low / block_m) * block_m
        nb = np.ceil((hi - lo) / block_m).astype(np.int64) + 2
        # blocks within reach of each sample (reach + one pixel, a square around it)
        r = reach + px
        b_lo = np.floor((sample_xy - r[:, None] - lo + block_m) / block_m).astype(np.int64)
        b_hi = np.floor((sample_xy + r[:, None] - lo + block_m) / block_m).astype(np.int64)
        span = (b_hi - b_lo + 1)
        n_marks = int((span[:, 0] * span[:, 1]).sum())
        if nb[0] * nb[1] <= RASTER_MAX_PIXELS and n_marks <= RASTER_MAX_PIXELS:
            rows = np.repeat(np.arange(len(sample_xy)), span[:, 0] * span[:, 1])
            k = np.arange(n_marks) - np.repeat(np.cumsum(span[:, 0] * span[:, 1])
                                               - span[:, 0] * span[:, 1], span[:, 0] * span[:, 1])
            bx = b_lo[rows, 0] + k % span[rows, 0]
            by = b_lo[rows, 1] + k // span[rows, 0]
            keys = np.unique(by * nb[0] + bx)
            if len(keys) * B * B <= RASTER_MAX_PIXELS:
                break
        px *= 2.0
    x0, y0 = lo - block_m                                         # one empty block around
    blocks = np.full((int(nb[1]), int(nb[0])), -1, np.int32)
    blocks.flat[keys] = np.arange(len(keys), dtype=np.int32)
    j, i = np.mgrid[0:B, 0:B]
    kx = (keys % nb[0])[:, None, None] * B + i[None]
    ky = (keys // nb[0])[:, None, None] * B + j[None]
    centres = np.stack([x0 + (kx + 0.5) * px, y0 + (ky + 0.5) * px], -1).reshape(-1, 2)
    lk, s, _ = network.locate(centres)
    cells = np.full(len(centres), -1.0)
    ok = lk >= 0
    c_a, c_b, w = network.weights(lk[ok], s[ok])
    cells[ok] = np.where(c_b > c_a, c_a + w, c_a)
    return CellRaster(x0=float(x0), y0=float(y0), pixel_m=px, block_px=B, blocks=blocks,
                      cells=np.ascontiguousarray(cells.reshape(len(keys), B, B)))


BROAD_CRESTED_WEIR = 1.705
"""Discharge coefficient of a broad-crested weir [m^(1/2)/s]: Q = C b H^(3/2) (SI units,
critical flow over the crest)."""


def level_pool_release(area_m2: float, head_m: float, breach_width_m: float,
                       inflow_m3s: float, duration_s: float, points: int = 241,
                       weir: float = BROAD_CRESTED_WEIR) -> tuple[np.ndarray, np.ndarray]:
    """A reservoir's outflow after its dam breaches, by level-pool (storage) routing: a
    prismatic reservoir of surface ``area_m2`` [m²] whose level stands ``head_m`` [m] over the
    breach's floor, emptied through the breach as over a broad-crested weir of width
    ``breach_width_m`` [m] (O = ``weir`` b h^(3/2)) while ``inflow_m3s`` [m³/s] still comes
    in: A dh/dt = I − O(h) (scipy's ``solve_ivp``, RK45). Returns ``points`` times [s] from
    the breach over ``duration_s`` and the outflow [m³/s] then: the jump to O(head) at once,
    falling towards the inflow as the reservoir empties — a hydrograph for
    :meth:`FloodRouter.set_hydrograph` (times shifted to the breach's time).

    Raises:
        ValueError: a value not finite, an area, head, width, duration or weir ≤ 0, a
            negative inflow, fewer than two points (naming which).
    """
    from scipy.integrate import solve_ivp

    values = {"area_m2": area_m2, "head_m": head_m, "breach_width_m": breach_width_m,
              "duration_s": duration_s, "weir": weir}
    for name, v in values.items():
        if not (isinstance(v, (int, float, np.floating)) and math.isfinite(v) and v > 0):
            raise ValueError(f"level_pool_release: {name} must be a finite number > 0, got {v!r}")
    if not (isinstance(inflow_m3s, (int, float, np.floating)) and math.isfinite(inflow_m3s)
            and inflow_m3s >= 0):
        raise ValueError(f"level_pool_release: inflow_m3s must be a finite number ≥ 0, got "
                         f"{inflow_m3s!r}")
    if int(points) < 2:
        raise ValueError(f"level_pool_release: points must be 2 or more, got {points!r}")
    k = weir * breach_width_m

    def dh(_t, h):
        return [(inflow_m3s - k * max(h[0], 0.0) ** 1.5) / area_m2]

    t = np.linspace(0.0, float(duration_s), int(points))
    sol = solve_ivp(dh, (0.0, float(duration_s)), [float(head_m)], t_eval=t, rtol=1e-8,
                    atol=1e-9 * head_m)
    return t, k * np.maximum(sol.y[0], 0.0) ** 1.5


class FloodRouter:
    """The flood state of a network (module docstring). ``network``: a
    :class:`~riverflow.hydro.spill_network.SpillNetwork`; ``t0_s``: the world time now."""

    def __init__(self, network, t0_s: float = 0.0) -> None:
        self.network = network
        s = network.net
        q0 = base_discharges_m3s(network)
        area0 = network.cell_width_m * network.link_depth_m[network.cell_link]
        self.net = FloodNet(cell_area0=np.ascontiguousarray(area0, np.float64),
                            link_q0=np.ascontiguousarray(q0, np.float64),
                            link_dx=np.ascontiguousarray(network.link_dx_m, np.float64),
                            link_c0=s.link_c0, link_c1=s.link_c1, link_start=s.link_start,
                            link_end=s.link_end, link_share=s.link_share)
        n = network.n_cells
        self.a = np.ones(n)
        """(N,) each cell's cross-section over its base one (= depth over base depth)."""
        self.hydrographs: dict[int, tuple[np.ndarray, np.ndarray]] = {}
        self.time_s = float(t0_s)
        """The flood's time [s]: how far the routing has stepped (whole fixed steps)."""
        self.clock_s = float(t0_s)
        """The time the flood has been asked to reach [s] (:attr:`time_s` is within one step
        below it)."""
        self._outflow = np.zeros(n)
        self._node_q = np.zeros(max(network.n_nodes, 1))
        self._inflow = np.zeros(len(q0))
        self._table = self._pack()
        self.dt_s = self._step_for(1.0)
        # no step: numba's first look at these argument types (~4 ms: its type dispatch
        # for each NamedTuple class), here and not in the frame of the flood's first step
        flood_steps(self.net, self._table, self.a, self.time_s, self.dt_s, 0, self._outflow,
                    self._node_q, self._inflow)
        self._raster: CellRaster | None = None
        self._level_tex = None
        self._link_trees = None
        self.wet_rise_m = np.zeros(n)
        """(N,) the rise [m] up to which the ground looks wet (the highest rise, falling
        behind a falling level by WET_FALL_MPS)."""
        self._missed = np.zeros(0, np.int64)
        self.ground = None
        """None, or a callable xy (P, 2) [m] → (terrain height (P,) [m], base-flow water level
        of the nearest river (P,) [m]) — what the terrain shader floods by — that the world
        sets: with it, :meth:`scale_velocity` gives flooded ground its
        :meth:`floodplain_flow`."""
        self._tangents: np.ndarray | None = None

    # -- input -------------------------------------------------------------------------------

    def link_index(self, link) -> int:
        """The link named ``link`` (a branch name) or numbered so (in the network's order)."""
        names = self.network.names
        if isinstance(link, (int, np.integer)) and not isinstance(link, bool):
            if 0 <= int(link) < len(names):
                return int(link)
            raise ValueError(f"set_hydrograph: link {link!r} out of range 0 … {len(names) - 1}")
        if link in names:
            return names.index(link)
        raise ValueError(f"set_hydrograph: no link named {link!r} (links: "
                         f"{', '.join(map(repr, names[:12]))}{' …' if len(names) > 12 else ''})")

    def set_hydrograph(self, link, times_s, discharge_m3s) -> None:
        """Replace the inflow at the start of ``link`` (a name or index; None: every source
        link, the discharge shared by their base discharges) by the piecewise-linear
        hydrograph (``times_s`` strictly increasing [s of world time], ``discharge_m3s`` finite
        ≥ 0, held beyond its ends). ``discharge_m3s`` None removes the link's hydrograph.

        Raises:
            ValueError: an unknown link, times not finite or not strictly increasing,
                discharges negative / NaN / infinite, lengths that differ; nothing changes.
        """
        if link is None:
            targets = [b for b in range(len(self.network.names))
                       if int(self.net.link_start[b]) < 0]
        else:
            targets = [self.link_index(link)]
        if discharge_m3s is None:
            for b in targets:
                self.hydrographs.pop(b, None)
            self._table = self._pack()
            return
        t = _as_float_array(times_s, "times_s")
        q = _as_float_array(discharge_m3s, "discharge_m3s")
        if t.shape != q.shape:
            raise ValueError(f"set_hydrograph: times_s has {len(t)} values, discharge_m3s "
                             f"{len(q)}")
        if not np.isfinite(t).all():
            k = int(np.flatnonzero(~np.isfinite(t))[0])
            raise ValueError(f"set_hydrograph: times_s must be finite, got times_s[{k}] = "
                             f"{t[k]!r}")
        bad = np.flatnonzero(~(np.isfinite(q) & (q >= 0)))
        if len(bad):
            raise ValueError(f"set_hydrograph: discharge_m3s[{int(bad[0])}] = {q[bad[0]]!r} "
                             "(needs a finite number ≥ 0 [m³/s])")
        steps = np.flatnonzero(np.diff(t) <= 0)
        if len(steps):
            k = int(steps[0])
            raise ValueError(f"set_hydrograph: times_s must increase strictly, but times_s[{k + 1}]"
                             f" = {t[k + 1]!r} ≤ times_s[{k}] = {t[k]!r}")
        base = self.net.link_q0[targets]
        k = int(np.argmax(q))
        if q[k] > MAX_FLOOD_RATIO * base.sum():      # checked before anything changes
            where = ("the sources' base flow together" if link is None else
                     f"link {self.network.names[targets[0]]!r}'s base flow")
            raise ValueError(f"set_hydrograph: discharge_m3s[{k}] = {q[k]:g} m³/s is "
                             f"{q[k] / base.sum():.3g} × {where} ({base.sum():g} m³/s); at "
                             f"most {MAX_FLOOD_RATIO:g} × is routed (the wave's time step "
                             "would shrink without end)")
        for b, share in zip(targets, base / base.sum()):
            self.hydrographs[b] = (t.copy(), q * share)
        self._table = self._pack()
        peak = max(float(np.max(hq / self.net.link_q0[b]))
                   for b, (_, hq) in self.hydrographs.items())
        self.dt_s = min(self.dt_s, self._step_for(max(peak, 1.0)))

    def base_inflow_m3s(self) -> float:
        """The base discharge entering the network [m³/s]: its source links' Q₀ together (what
        ``set_hydrograph(None, ...)`` shares among them)."""
        return float(sum(self.net.link_q0[b] for b in range(len(self.network.names))
                         if int(self.net.link_start[b]) < 0))

    def ratio_for_rise(self, link, rise_m: float) -> float:
        """The steady discharge over base flow, Q / Q₀, that raises ``link``'s (a name or
        index) level by ``rise_m`` [m]: the rating curve inverted, (1 + Δz / h₀)^(5/3)."""
        h0 = float(self.network.link_depth_m[self.link_index(link)])
        return (1.0 + float(rise_m) / h0) ** (5.0 / 3.0)

    def _pack(self) -> Hydrographs:
        links = sorted(self.hydrographs)
        times = [self.hydrographs[b][0] for b in links]
        qs = [self.hydrographs[b][1] for b in links]
        start = np.concatenate([[0], np.cumsum([len(t) for t in times])]).astype(np.int32)
        return Hydrographs(link=np.asarray(links, np.int32), start=start,
                           times=np.concatenate(times) if times else np.zeros(0),
                           q=np.concatenate(qs) if qs else np.zeros(0))

    def _step_for(self, ratio: float) -> float:
        """The fixed step [s] that keeps the Courant number ≤ COURANT at ``ratio`` × Q₀ in
        every cell (celerity (5/3) U₀ ratio^(2/5))."""
        u0 = self.net.link_q0[self.network.cell_link] / self.net.cell_area0
        dx = self.net.link_dx[self.network.cell_link]
        c = 5.0 / 3.0 * u0 * max(ratio, float(self.a.max()) ** 1.5) ** 0.4
        return float(COURANT * np.min(dx / c))

    # -- time --------------------------------------------------------------------------------

    def advance(self, seconds: float) -> None:
        """Run the flood's clock ``seconds`` [s] ahead (whole fixed steps are taken; what is
        left of a step waits for the next call)."""
        self.advance_to(self.clock_s + float(seconds))

    def advance_to(self, t_s: float) -> None:
        """Step (whole fixed steps) until the router's time is within one step of ``t_s``
        (a time behind the flood's clock does nothing)."""
        self.clock_s = max(self.clock_s, float(t_s))
        n = int(math.floor((self.clock_s - self.time_s) / self.dt_s + 1e-9))
        if n <= 0:
            return
        flood_steps(self.net, self._table, self.a, self.time_s, self.dt_s, n, self._outflow,
                    self._node_q, self._inflow)
        self.time_s += n * self.dt_s
        np.maximum(self.cell_level_rise_m(), self.wet_rise_m - WET_FALL_MPS * n * self.dt_s,
                   out=self.wet_rise_m)

    # -- what the world reads ------------------------------------------------------------------

    @property
    def active(self) -> bool:
        """Whether any cell's discharge differs from its base one (else the flow is left as
        it is)."""
        return bool(np.any(np.abs(self.a - 1.0) > ACTIVE_EPS))

    @property
    def textures_made(self) -> bool:
        """Whether :meth:`level_textures` has been made (it is made once, on first need)."""
        return self._level_tex is not None

    @property
    def drawn(self) -> bool:
        """Whether the drawn water or ground differs from base flow (:attr:`active`, or
        ground still wet from a flood)."""
        return self.active or bool(np.any(self.wet_rise_m > ACTIVE_EPS))

    def cell_discharge_m3s(self) -> np.ndarray:
        """(N,) each cell's discharge Q [m³/s]."""
        return self.net.link_q0[self.network.cell_link] * self.a ** (5.0 / 3.0)

    def cell_level_rise_m(self) -> np.ndarray:
        """(N,) each cell's level above its base-flow level [m] (rating curve)."""
        return self.network.link_depth_m[self.network.cell_link] * (self.a - 1.0)

    def cell_speed_factor(self) -> np.ndarray:
        """(N,) each cell's depth-averaged speed over its base one, r^(2/5) = a^(2/3)."""
        return self.a ** (2.0 / 3.0)

    @property
    def raster(self) -> CellRaster:
        """The network's :func:`cell_raster` (made on first use)."""
        if self._raster is None:
            self._raster = cell_raster(self.network)
        return self._raster

    def level_textures(self, previous: FloodRouter | None = None
                       ) -> tuple[tuple[float, float, float], np.ndarray]:
        """What the water and terrain shaders read to draw the level's rise
        (``shaders/flood.glsl``): the square (x0, y0, side) [m] around the network and its
        floodplain (FLOODPLAIN_REACH_M), and its (LEVEL_TEXELS, LEVEL_TEXELS, 3) float32
        texels: the cell coordinate c + w at each texel's centre (the :attr:`raster`'s,
        beyond it the KD-tree's within FLOODPLAIN_REACH_M; −1: no cell), the nearest other
        link's and the weight of its rise where the two are within FLOOD_BLEND_M of equally
        near (:meth:`_blend_links`; −1 and 0 elsewhere), made once; :meth:`rise_texels`
        holds the per-cell rises.

        ``previous``: the router on the network a live edit changed into this one's, its
        textures made: where the square and the raster's pixels are the same, only the
        blocks of texels within reach of a link that changed (its old or new centre line)
        are made; the others are its texels with their cell coordinates moved to this
        network's numbering (:meth:`_texels_after_edit`: the same texels as made anew, to
        a float32 rounding of the coordinate)."""
        if self._level_tex is None:
            frame = self._level_frame()
            n = LEVEL_TEXELS
            texels = None
            if previous is not None and previous._level_tex is not None:
                texels = self._texels_after_edit(previous, frame)
            if texels is None:
                texels = np.zeros((n * n, 3), np.float32)
                self._fill_blocks(frame, np.arange((n // LEVEL_BLOCK) ** 2), texels)
            self._level_tex = (frame, texels.reshape(n, n, 3))
        return self._level_tex

    def _level_frame(self) -> tuple[float, float, float]:
        """The level texture's square (x0, y0, side) [m]: the raster's with the floodplain."""
        r = self.raster
        by, bx = r.blocks.shape
        x0, y0 = r.x0 - FLOODPLAIN_REACH_M, r.y0 - FLOODPLAIN_REACH_M
        side = max(bx, by) * r.block_px * r.pixel_m + 2.0 * FLOODPLAIN_REACH_M
        return float(x0), float(y0), float(side)

    def _fill_blocks(self, frame: tuple[float, float, float], blocks: np.ndarray,
                     texels: np.ndarray) -> None:
        """Make the level texture's texels (LEVEL_TEXELS², 3) in ``blocks`` (M,) (of
        LEVEL_BLOCK² texels, row major), in place (:meth:`level_textures`): each texel's
        value is its own, whichever blocks are made with it."""
        x0, y0, side = frame
        n, blk = LEVEL_TEXELS, LEVEL_BLOCK
        nb = n // blk
        blocks = np.asarray(blocks, np.int64)
        rows, cols = np.divmod(blocks, nb)
        j, i = np.mgrid[0:blk, 0:blk]
        # each block's texels together, in its own row-major order
        tx = np.ravel(x0 + ((cols[:, None, None] * blk + i[None]) + 0.5) * (side / n))
        ty = np.ravel(y0 + ((rows[:, None, None] * blk + j[None]) + 0.5) * (side / n))
        xy = np.column_stack([tx, ty])
        cells = np.empty(len(xy))
        sample_by_cells(xy, len(xy), self.raster,
                        np.arange(self.network.n_cells, dtype=np.float64), -1.0, cells)
        # the floodplain: the nearest cell within reach, asked only in the blocks whose
        # centre is within reach + half their diagonal of a centre line
        centres = np.column_stack([x0 + (cols + 0.5) * (side / nb),
                                   y0 + (rows + 0.5) * (side / nb)])
        near = self.network.locate(centres, FLOODPLAIN_REACH_M + side / nb)[0] >= 0
        far = np.flatnonzero((cells < 0) & np.repeat(near, blk * blk))
        link, s, _ = self.network.locate(xy[far], FLOODPLAIN_REACH_M)
        ok = link >= 0
        a, b, w = self.network.weights(link[ok], s[ok])
        cells[far[ok]] = np.where(b > a, a + w, a)
        made = np.empty((len(xy), 3), np.float32)
        made[:, 0] = cells
        made[:, 1] = -1.0
        made[:, 2] = 0.0
        self._blend_links(xy, cells, centres, side / nb * 0.7072, made)
        if len(blocks) == nb * nb and np.array_equal(blocks, np.arange(nb * nb)):
            texels.reshape(nb, blk, nb, blk, 3)[...] = \
                made.reshape(nb, nb, blk, blk, 3).transpose(0, 2, 1, 3, 4)
        else:
            tex = ((rows[:, None, None] * blk + j[None]) * n
                   + cols[:, None, None] * blk + i[None]).reshape(-1)
            texels[tex] = made

    def _texels_after_edit(self, previous: FloodRouter, frame: tuple[float, float, float]
                           ) -> np.ndarray | None:
        """:meth:`level_textures` from ``previous``'s (LEVEL_TEXELS², 3), or None where its
        square or its raster's pixels differ (then all are made). A link is the same where
        its name, cells, samples and widths are: a texel farther than every lookup reaches
        (the raster's blocks, the floodplain's, the blend's) from each other link's samples,
        old and new, reads the same sample, so the same place on the same link; its cell
        coordinates are moved by the link's new first cell. The blocks within reach of a
        changed link, and any whose texels read one, are made anew."""
        (x0, y0, side), old_tex = previous._level_tex
        if (x0, y0, side) != frame:
            return None
        old, new = previous.network, self.network
        r_old, r_new = previous.raster, self.raster
        if (r_old.x0, r_old.y0, r_old.pixel_m, r_old.block_px) != (
                r_new.x0, r_new.y0, r_new.pixel_m, r_new.block_px):
            return None
        shift = np.full(len(old.names), np.nan)   # per old link: new first cell − old's
        moved = []
        old_index = {name: b for b, name in enumerate(old.names)}
        kept = set()
        for b, name in enumerate(new.names):
            ob = old_index.get(name)
            if ob is not None and _same_link(old, ob, new, b):
                shift[ob] = float(new.net.link_c0[b] - old.net.link_c0[ob])
                kept.add(ob)
            else:
                moved.append(new._tree.data[new._sample_link == b])
        moved += [old._tree.data[old._sample_link == ob] for ob in range(len(old.names))
                  if ob not in kept]
        n, blk = LEVEL_TEXELS, LEVEL_BLOCK
        nb = n // blk
        size = side / nb
        region = np.zeros((nb, nb), bool)
        if moved:
            from scipy.spatial import cKDTree

            # a texel reads the raster's pixel under it (each the nearest sample's cell within
            # RASTER_REACH half widths, in blocks of block_m), the nearest sample within
            # FLOODPLAIN_REACH_M and the links' nearest within FLOOD_BLEND_M more, asked per
            # block by its centre (± its half-diagonal): a block farther than that from
            # every changed link's sample, its centre by a diagonal more, reads none
            half = max(float(net.cell_width_m.max()) for net in (old, new)) * 0.5
            block_m = r_new.block_px * r_new.pixel_m
            reach = max(RASTER_REACH * half + 2.0 * r_new.pixel_m + math.sqrt(2.0) * block_m,
                        FLOODPLAIN_REACH_M + FLOOD_BLEND_M) + math.sqrt(2.0) * size
            centre = (np.arange(nb) + 0.5) * size
            gx, gy = np.meshgrid(x0 + centre, y0 + centre)
            d, _ = cKDTree(np.concatenate(moved)).query(np.column_stack([gx.ravel(), gy.ravel()]),
                                                        distance_upper_bound=reach)
            region |= np.isfinite(d).reshape(nb, nb)
        texels = old_tex.reshape(-1, 3).copy()
        for col in (0, 1):
            c = texels[:, col]
            has = np.flatnonzero(c >= 0)
            d = shift[old.cell_link[np.floor(c[has]).astype(np.int64)]]
            lost = np.isnan(d)
            c[has[~lost]] = (c[has[~lost]].astype(np.float64) + d[~lost]).astype(np.float32)
            t = has[lost]                   # a changed link's: its block is made anew
            region[(t // n) // blk, (t % n) // blk] = True
        blocks = np.flatnonzero(region.reshape(-1))
        if len(blocks):
            self._fill_blocks(frame, blocks, texels)
        return texels

    def _blend_links(self, xy: np.ndarray, cells: np.ndarray, centres: np.ndarray,
                     half_diag: float, texels: np.ndarray) -> None:
        """Fill the level texture's second cell coordinate and its weight (columns 1, 2 of
        ``texels`` (P, 3)) where two links' centre lines are within FLOOD_BLEND_M of being
        equally near a texel (xy (P, 2) [m] of blocks of LEVEL_BLOCK² texels, each block's
        together; ``cells`` (P,) their nearest cell coordinate, −1 none): the second link's nearest sample's cell coordinate and
        ½ (1 − smoothstep(0, FLOOD_BLEND_M, d₂ − d₁)), so the rise drawn crosses the line
        where the nearest link changes as a ramp, not a step (½ of each on the line). Only
        the blocks (centres (M, 2), half-diagonal ``half_diag`` [m]) where two links'
        nearest samples are that close are asked, per link."""
        net = self.network
        links = len(net.names)
        if links < 2:
            return
        xs, lk, ss = net._tree.data, net._sample_link, net._sample_s
        if self._link_trees is None:
            from scipy.spatial import cKDTree
            self._link_trees = [(cKDTree(xs[lk == b]), np.flatnonzero(lk == b))
                                for b in range(links)]
        reach = FLOODPLAIN_REACH_M + half_diag + FLOOD_BLEND_M
        d_block = np.stack([tree.query(centres, distance_upper_bound=reach)[0]
                            for tree, _ in self._link_trees])          # (B, blocks)
        order = np.sort(d_block, axis=0)
        # a block where the second-nearest link is within the blend of the nearest anywhere
        # in it (each distance moves by at most half_diag inside the block)
        finite = np.isfinite(order[1])
        cand = np.flatnonzero(finite)
        cand = cand[order[1, cand] - order[0, cand] < FLOOD_BLEND_M + 2.0 * half_diag]
        if not len(cand):
            return
        per = LEVEL_BLOCK * LEVEL_BLOCK
        local = (cand[:, None] * per + np.arange(per)[None]).reshape(-1)
        keep = cells[local] >= 0
        local = local[keep]
        if not len(local):
            return
        p = xy[local]
        # the links near enough to matter in each texel's block
        near = d_block[:, cand] <= order[0, cand] + FLOOD_BLEND_M + 2.0 * half_diag
        per_block = np.repeat(near, per, axis=1)[:, keep]          # (B, texels)
        d = np.full((links, len(local)), np.inf)
        coord = np.full((links, len(local)), -1.0)
        for b, (tree, index) in enumerate(self._link_trees):
            ask = np.flatnonzero(per_block[b])
            if not len(ask):
                continue
            db, k = tree.query(p[ask], distance_upper_bound=reach)
            ok = np.isfinite(db)
            ask, k = ask[ok], index[k[ok]]
            d[b, ask] = db[ok]
            a, c, w = net.weights(lk[k], ss[k])
            coord[b, ask] = np.where(c > a, a + w, a)
        first = np.argmin(d, axis=0)
        col = np.arange(len(local))
        d1 = d[first, col]
        d[first, col] = np.inf
        second = np.argmin(d, axis=0)
        d2 = d[second, col]
        blend = np.flatnonzero(np.isfinite(d1) & np.isfinite(d2))
        gap = d2[blend] - d1[blend]
        blend = blend[gap < FLOOD_BLEND_M]
        gap = d2[blend] - d1[blend]
        t = np.clip(gap / FLOOD_BLEND_M, 0.0, 1.0)
        # the nearest link's own coordinate too (the raster's may be the other link's, a
        # pixel's centre away from the line): the pair swaps across the line, both at ½
        at = local[blend]
        texels[at, 0] = coord[first[blend], col[blend]]
        texels[at, 1] = coord[second[blend], col[blend]]
        texels[at, 2] = 0.5 * (1.0 - t * t * (3.0 - 2.0 * t))

    def level_rise(self, xy) -> np.ndarray:
        """(N,) the level rise [m] at points (N, 2) [m], as the shaders draw it
        (``shaders/flood.glsl`` ``flood_at``, of which this is the CPU twin: the level
        texture's texel under each point, its cell coordinate's rise blended with the nearest
        other link's by its weight, :meth:`_blend_links`; 0 off the texture or its cells,
        i.e. farther than FLOODPLAIN_REACH_M from every centre line). One mechanism for
        everything that reads the raised level (boats, the mirror, ``world.water_level``,
        the floodplain's depth, the particles' placement): where two rivers' rises meet it
        ramps over FLOOD_BLEND_M as the drawn water does, never steps."""
        (x0, y0, side), texels = self.level_textures()
        xy = np.asarray(xy, np.float64).reshape(-1, 2)
        n = texels.shape[0]
        ij = np.floor((xy - [x0, y0]) / side * n)
        ok = np.isfinite(ij).all(axis=1) & (ij >= 0).all(axis=1) & (ij < n).all(axis=1)
        out = np.zeros(len(xy))
        t = texels[ij[ok, 1].astype(np.int64), ij[ok, 0].astype(np.int64)].astype(np.float64)
        rise = np.append(self.cell_level_rise_m(), 0.0)          # the padding cell: 0

        def at(p):
            c = np.floor(p).astype(np.int64)
            return rise[c] * (1.0 - (p - c)) + rise[np.minimum(c + 1, len(rise) - 1)] * (p - c)

        got = np.zeros(len(t))
        has = t[:, 0] >= 0
        got[has] = at(t[has, 0])
        two = has & (t[:, 1] >= 0)
        got[two] = (1.0 - t[two, 2]) * got[two] + t[two, 2] * at(t[two, 1])
        out[ok] = got
        return out

    def rise_texels(self, out: np.ndarray | None = None) -> np.ndarray:
        """(R, RISE_ROW, 2) float32 each cell's level rise [m] (:meth:`cell_level_rise_m`) and
        wet-looking rise (:attr:`wet_rise_m`), row major, one padding cell at least after the
        last (0); ``out`` is reused when its shape fits."""
        n = self.network.n_cells
        rows = n // RISE_ROW + 1
        if out is None or out.shape != (rows, RISE_ROW, 2):
            out = np.zeros((rows, RISE_ROW, 2), np.float32)
        flat = out.reshape(-1, 2)
        flat[:n, 0] = self.cell_level_rise_m()
        flat[:n, 1] = self.wet_rise_m
        return out

    def _at(self, values: np.ndarray, xy: np.ndarray, fill: float) -> np.ndarray:
        xy = np.asarray(xy, np.float64).reshape(-1, 2)
        finite = np.isfinite(xy).all(axis=1)
        out = np.full(len(xy), float(fill))
        link, s, _ = self.network.locate(xy[finite])
        got = self.network.interpolate(values, link, s)
        got[link < 0] = fill
        out[finite] = got
        return out

    def discharge(self, xy) -> np.ndarray:
        """(N,) the discharge [m³/s] at points (N, 2) [m] (of the nearest centre line)."""
        return self._at(self.cell_discharge_m3s(), xy, 0.0)

    def scale_velocity(self, xy: np.ndarray, status: np.ndarray, velocity: np.ndarray,
                       n: int | None = None, n_status: int | None = None) -> None:
        """Multiply the nonzero velocities (N, 2) float32 of the first ``n`` points by the
        speed factor of the nearest cell (in place; only while :attr:`active`): read through
        the :attr:`raster` (:func:`~riverflow.kernels.flood.scale_by_cells`), the KD-tree
        for the few points beyond it; then the first ``n`` get the floodplain's status and
        flow (:meth:`floodplain_flow`). Points ``n`` to ``n_status`` (the particles, INSIDE,
        that ask whether they still are, ``kernels.advection.move_particles``) the base
        field calls OUTSIDE stay INSIDE while the flood raises a level anywhere: on the
        floodplain, or leaving the water, their next velocity question (within
        ``VELOCITY_EVERY`` frames, a few centimetres on) says which (the floodplain's status
        is found per point: asked every frame for every particle on it, it cost more than
        the rest of the frame)."""
        if not self.active:
            return
        n = len(xy) if n is None else int(n)
        n_status = n if n_status is None else max(int(n_status), n)
        if n:
            self._scale(xy, velocity, n)
        if status is None or self.ground is None:
            return
        if n:
            self.floodplain_flow(xy, status, velocity, n)
        if n_status > n and np.any(self.cell_level_rise_m() > FLOODPLAIN_MIN_DEPTH_M):
            from riverflow.components.status import FlowStatus

            rows = status[n:n_status]
            rows[rows == FlowStatus.OUTSIDE] = FlowStatus.INSIDE

    def _scale(self, xy: np.ndarray, velocity: np.ndarray, n: int) -> None:
        if len(self._missed) < n:
            self._missed = np.empty(max(n, 2 * len(self._missed)), np.int64)
        factor = self.cell_speed_factor()
        pts = np.ascontiguousarray(xy[:n], np.float64)
        n_missed = scale_by_cells(pts, velocity, n, self.raster, factor, self._missed)
        if n_missed:
            rest = self._missed[:n_missed]
            f = self._at(factor, pts[rest], 1.0)
            velocity[rest] *= f[:, None].astype(velocity.dtype)

    def floodplain_flow(self, xy: np.ndarray, status: np.ndarray, velocity: np.ndarray,
                        n: int | None = None) -> int:
        """Give the flooded ground among the first ``n`` points its flow (in place): points
        the flow field left OUTSIDE (beside the base banks, not beyond the domain) within
        FLOODPLAIN_REACH_M of a centre line whose level rise puts water over the ground
        (:attr:`ground`: depth = base level + rise − terrain > FLOODPLAIN_MIN_DEPTH_M) become
        INSIDE, moving along the nearest centre line's downstream direction at
        U_c (h / h_c)^(2/3) / FLOODPLAIN_ROUGHNESS (module docstring; h at most h_c), and at
        the channel's U_c at its bank, blended over FLOODPLAIN_SHEAR_M (smoothstep of the
        distance beyond the bank, the centre line's distance less half the width there). Points
        already INSIDE (the channel's own flow) are not touched; dry ground stays OUTSIDE.
        Returns how many points became INSIDE."""
        from riverflow.components.status import FlowStatus

        n = len(xy) if n is None else int(n)
        if self.ground is None or not n:
            return 0
        rise_cells = self.cell_level_rise_m()
        if not np.any(rise_cells > FLOODPLAIN_MIN_DEPTH_M):
            return 0
        cand = np.flatnonzero(status[:n] == FlowStatus.OUTSIDE)
        if not len(cand):
            return 0
        pts = np.asarray(xy[cand], np.float64)
        ok = np.isfinite(pts).all(axis=1)
        cand, pts = cand[ok], pts[ok]
        net = self.network
        d, k = net._tree.query(pts, distance_upper_bound=FLOODPLAIN_REACH_M)   # as locate
        near = np.flatnonzero(np.isfinite(d))
        if not len(near):
            return 0
        k, cand, pts, d = k[near], cand[near], pts[near], d[near]
        a, b, w = net.weights(net._sample_link[k], net._sample_s[k])
        rise = self.level_rise(pts)                               # as drawn
        risen = np.flatnonzero(rise > FLOODPLAIN_MIN_DEPTH_M)
        if not len(risen):
            return 0
        k, cand, pts, d = k[risen], cand[risen], pts[risen], d[risen]
        a, b, w, rise = a[risen], b[risen], w[risen], rise[risen]
        ground, level = self.ground(pts)
        depth = np.asarray(level, np.float64) + rise - np.asarray(ground, np.float64)
        wet = np.flatnonzero(depth > FLOODPLAIN_MIN_DEPTH_M)
        if not len(wet):
            return 0
        a, b, w, depth, cand, k = a[wet], b[wet], w[wet], depth[wet], cand[wet], k[wet]
        d = d[wet]
        u_channel = self._channel_speed()
        h_channel = net.link_depth_m[net.cell_link] * self.a
        u_c = u_channel[a] * (1.0 - w) + u_channel[b] * w
        h_c = h_channel[a] * (1.0 - w) + h_channel[b] * w
        speed = u_c * (np.minimum(depth, h_c) / h_c) ** (2.0 / 3.0) / FLOODPLAIN_ROUGHNESS
        # the shear layer: from the channel's speed at its bank to the floodplain's own
        half = 0.5 * (net.cell_width_m[a] * (1.0 - w) + net.cell_width_m[b] * w)
        x = np.clip((d - half) / FLOODPLAIN_SHEAR_M, 0.0, 1.0)
        speed += (u_c - speed) * (1.0 - x * x * (3.0 - 2.0 * x))
        tangent = self._sample_tangents()[k]
        velocity[cand] = (tangent * speed[:, None]).astype(velocity.dtype)
        status[cand] = FlowStatus.INSIDE
        return len(cand)

    def lift_hits(self, directions: np.ndarray, hit_xyz: np.ndarray,
                  hit_kind: np.ndarray) -> int:
        """Move rays' hits on the base surface (:func:`~riverflow.kernels.raycast_tiles.
        cast_rays_onto_tiles`: max(terrain, base-flow water)) back along their ray
        (``directions`` (N, 3), unit) to the flood's raised water where it covers them (in
        place; only while :attr:`active` and with a :attr:`ground`): a hit below the raised
        level there (base level seen from the ground + :meth:`level_rise`) is where the ray
        went under the water; it crossed the surface ``(level − z) / −dz`` before (the
        level is nearly flat: the one at the hit, within millimetres of the one where it
        crossed; the ray was above the ground all the way to the hit, so the ground there is
        under the water). Land hits so moved become water hits (HIT_WATER): a new particle
        lands on the flooded floodplain's water, as on the channel's. Returns how many
        moved."""
        from riverflow.kernels.raycast import HIT_LAND, HIT_WATER

        if self.ground is None or not self.active:
            return 0
        hit = np.flatnonzero(((hit_kind == HIT_LAND) | (hit_kind == HIT_WATER))
                             & (directions[:, 2] < -1e-6))
        if not len(hit):
            return 0
        z = hit_xyz[hit, 2]
        d = directions[hit]
        _, base = self.ground(hit_xyz[hit, :2])
        level = np.asarray(base, np.float64) + self.level_rise(hit_xyz[hit, :2])
        back = (level - z) / -d[:, 2]
        wet = back * -d[:, 2] > FLOODPLAIN_MIN_DEPTH_M
        moved = hit[wet]
        hit_xyz[moved] -= back[wet, None] * d[wet]
        hit_kind[moved] = HIT_WATER
        return len(moved)

    def lift_altitudes(self, world_m: np.ndarray, rows: np.ndarray) -> None:
        """Raise the altitude of particles ``rows`` of ``world_m`` (C, 3) [m] (their altitude
        just read from the base surface, max(terrain, base-flow water)) to the flood's raised
        water where it is above them (in place; only while :attr:`active` and with a
        :attr:`ground`): the particles ride on the drawn water, the floodplain's too."""
        if self.ground is None or not self.active or not len(rows):
            return
        xy = world_m[rows, :2]
        _, base = self.ground(xy)
        level = np.asarray(base, np.float64) + self.level_rise(xy)
        world_m[rows, 2] = np.maximum(world_m[rows, 2], level)

    def _channel_speed(self) -> np.ndarray:
        """(N,) each cell's depth-averaged speed now [m/s]: U₀ a^(2/3), U₀ = Q₀ / A₀."""
        u0 = self.net.link_q0[self.network.cell_link] / self.net.cell_area0
        return u0 * self.cell_speed_factor()

    def _sample_tangents(self) -> np.ndarray:
        """(S, 2) the downstream unit direction of the network's centre line at each of its
        KD-tree's samples (central differences along the sample's link, by arc length)."""
        if self._tangents is None:
            net = self.network
            xy, link, s = net._tree.data, net._sample_link, net._sample_s
            order = np.lexsort((s, link))
            p, lk = xy[order], link[order]
            prev = np.r_[0, np.arange(len(p) - 1)]
            nxt = np.r_[np.arange(1, len(p)), len(p) - 1]
            prev = np.where(lk[prev] == lk, prev, np.arange(len(p)))
            nxt = np.where(lk[nxt] == lk, nxt, np.arange(len(p)))
            d = p[nxt] - p[prev]
            d /= np.maximum(np.hypot(*d.T), 1e-12)[:, None]
            out = np.empty_like(d)
            out[order] = d
            self._tangents = out
        return self._tangents
