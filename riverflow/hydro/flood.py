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
  Manning's h = (Q n / (W √S))^(3/5) with the slope and roughness the base state implies).

The router steps in whole fixed steps (Courant number ≤ ``COURANT`` at the highest discharge
any hydrograph reaches), so a run depends on the world time only, never on how frames cut it.
"""
from __future__ import annotations

import math

import numpy as np

from riverflow.kernels.flood import FloodNet, Hydrographs, flood_steps

COURANT = 0.9
"""Largest Courant number c dt / Δx of the router's fixed step."""
ACTIVE_EPS = 1e-9
"""The flow field is left untouched while every cell's speed factor is within this of 1."""


def _as_float_array(values, what: str) -> np.ndarray:
    try:
        arr = np.asarray(values, np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"set_hydrograph: {what} must be numbers, got {values!r:.80}") from None
    if arr.ndim != 1 or len(arr) < 1:
        raise ValueError(f"set_hydrograph: {what} must be a 1-D sequence of one value or more, "
                         f"got shape {arr.shape}")
    return arr


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
        for b, share in zip(targets, base / base.sum()):
            self.hydrographs[b] = (t.copy(), q * share)
        self._table = self._pack()
        peak = max(float(np.max(hq / self.net.link_q0[b]))
                   for b, (_, hq) in self.hydrographs.items())
        self.dt_s = min(self.dt_s, self._step_for(max(peak, 1.0)))

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

    # -- what the world reads ------------------------------------------------------------------

    @property
    def active(self) -> bool:
        """Whether any cell's discharge differs from its base one (else the flow is left as
        it is)."""
        return bool(np.any(np.abs(self.a - 1.0) > ACTIVE_EPS))

    def cell_discharge_m3s(self) -> np.ndarray:
        """(N,) each cell's discharge Q [m³/s]."""
        return self.net.link_q0[self.network.cell_link] * self.a ** (5.0 / 3.0)

    def cell_level_rise_m(self) -> np.ndarray:
        """(N,) each cell's level above its base-flow level [m] (rating curve)."""
        return self.network.link_depth_m[self.network.cell_link] * (self.a - 1.0)

    def cell_speed_factor(self) -> np.ndarray:
        """(N,) each cell's depth-averaged speed over its base one, r^(2/5) = a^(2/3)."""
        return self.a ** (2.0 / 3.0)

    def _at(self, values: np.ndarray, xy: np.ndarray, fill: float) -> np.ndarray:
        xy = np.asarray(xy, np.float64).reshape(-1, 2)
        link, s, _ = self.network.locate(xy)
        out = self.network.interpolate(values, link, s)
        out[link < 0] = fill
        return out

    def level_rise(self, xy) -> np.ndarray:
        """(N,) the level rise [m] at points (N, 2) [m] (of the nearest centre line)."""
        return self._at(self.cell_level_rise_m(), xy, 0.0)

    def discharge(self, xy) -> np.ndarray:
        """(N,) the discharge [m³/s] at points (N, 2) [m] (of the nearest centre line)."""
        return self._at(self.cell_discharge_m3s(), xy, 0.0)

    def scale_velocity(self, xy: np.ndarray, status: np.ndarray, velocity: np.ndarray,
                       n: int | None = None) -> None:
        """Multiply the velocities (N, 2) of the first ``n`` points by the speed factor of the
        nearest cell (in place; only while :attr:`active`)."""
        if not self.active:
            return
        n = len(xy) if n is None else int(n)
        moving = np.flatnonzero(np.any(velocity[:n] != 0.0, axis=1))
        if not len(moving):
            return
        factor = self._at(self.cell_speed_factor(), xy[moving], 1.0)
        velocity[moving] *= factor[:, None].astype(velocity.dtype)
