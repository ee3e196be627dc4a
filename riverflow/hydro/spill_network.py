"""SpillNetwork: the river network cut into cells for the spill solver (:mod:`riverflow.kernels.spill`).

A link is one branch of a scene (centre line drawn downstream, widths, discharge, the junctions
at its ends). Each link is cut into cells of about one river width (``cell_m``), each with:

* cross-section A = W · h, W the river's width at the cell, h the link's depth
  (:func:`riverflow.hydro.falls.channel_depth_m` of its median width, one depth per link so
  that the discharge Q = q · h [m³/s] is the same in every cell of the link: q [m²/s] is the
  link's ψ difference, so the cell's mean speed U = Q / A = q / W is the flow field's);
* longitudinal dispersion K [m²/s], Fischer's relation by default
  K = 0.011 U² W² / (h u*), u* = n U √g / h^(1/6) (Manning's friction velocity, n = 0.03), or
  a constant (:class:`Dispersion`);
* transverse mixing ε_t = 0.6 h u* (Fischer), used near the source (:mod:`riverflow.components.spill`).

Junctions are the nodes; a link's share of its start node is its discharge over the
discharges of every link leaving that node. A link whose end node no link leaves drains
through an outlet.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from riverflow.hydro.falls import channel_depth_m
from riverflow.kernels.spill import SpillNet

G_MPS2 = 9.81


@dataclass(frozen=True)
class Dispersion:
    """How the tracer spreads (all settable; docs/deviations.md says where they come from).

    ``longitudinal_m2s``: a constant longitudinal dispersion coefficient K [m²/s], or None for
    Fischer's K = ``fischer`` · U² W² / (h u*) per cell. ``manning_n``: Manning's roughness
    [s/m^(1/3)] for the friction velocity u* = n U √g / h^(1/6). ``transverse``: ε_t / (h u*),
    the transverse mixing coefficient (Fischer: 0.6). ``cell_m``: cell length [m] (None: each
    link's median width, at least 1 m)."""

    longitudinal_m2s: float | None = None
    fischer: float = 0.011
    manning_n: float = 0.03
    transverse: float = 0.6
    cell_m: float | None = None

    def __post_init__(self) -> None:
        for name in ("fischer", "manning_n", "transverse"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise ValueError(f"Dispersion: {name} must be a finite number > 0, got {v!r}")
        for name in ("longitudinal_m2s", "cell_m"):
            v = getattr(self, name)
            if v is not None and not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise ValueError(f"Dispersion: {name} must be None or a finite number > 0, "
                                 f"got {v!r}")


@dataclass(eq=False)
class SpillNetwork:
    """The cells of a river network (module docstring). Cells of a link are contiguous,
    upstream first; links are in upstream-first order."""

    net: SpillNet
    names: list[str]
    """(B,) each link's name."""
    lines: list[np.ndarray]
    """(B,) each link's centre line (K, 2) [m], drawn downstream."""
    link_length_m: np.ndarray
    link_dx_m: np.ndarray
    link_q_m2s: np.ndarray
    """(B,) float64 the link's discharge per unit depth [m²/s] (its ψ difference)."""
    link_depth_m: np.ndarray
    cell_link: np.ndarray
    cell_s_m: np.ndarray
    """(N,) arc length of the cell's centre from its link's start [m]."""
    cell_xy_m: np.ndarray
    cell_width_m: np.ndarray
    cell_speed_mps: np.ndarray
    cell_k_m2s: np.ndarray
    """(N,) longitudinal dispersion coefficient [m²/s]."""
    cell_eps_m2s: np.ndarray
    """(N,) transverse mixing coefficient ε_t [m²/s]."""
    outlets: list[str]
    """Names of the links draining through each outlet, in outlet order."""
    n_nodes: int
    dt_max_s: float
    """Largest stable step [s] (Cr ≤ ½, diffusion number ≤ ¼ in every cell)."""
    dispersion: Dispersion
    _tree: cKDTree
    _sample_link: np.ndarray
    _sample_s: np.ndarray
    link_psi_m2s: np.ndarray | None = None
    """(B, 2) the smallest and largest ψ across each link's middle section [m²/s] (the
    stream function is one over the network: a tributary's range is its side of the range
    below the confluence); filled by the world with :func:`section_psi_range` for the
    mixing below junctions (:func:`riverflow.hydro.spills.plume_sections`); None: not known."""

    @property
    def n_cells(self) -> int:
        return int(self.net.cell_q.shape[0])

    def locate(self, xy: np.ndarray, max_distance_m: float = np.inf
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The link (−1 if none within ``max_distance_m``), arc length along it [m] and distance
        [m] of the nearest centre-line sample to each point (N, 2)."""
        xy = np.asarray(xy, np.float64).reshape(-1, 2)
        d, k = self._tree.query(xy, distance_upper_bound=max_distance_m)
        ok = np.isfinite(d)
        kk = np.where(ok, k, 0)
        link = np.where(ok, self._sample_link[kk], -1)
        s = np.where(ok, self._sample_s[kk], np.nan)
        return link.astype(np.int64), s, d

    def cell_of(self, link: np.ndarray, s_m: np.ndarray) -> np.ndarray:
        """The cell holding arc length ``s_m`` [m] along ``link`` (link ≥ 0), (P,) int64."""
        link = np.asarray(link, np.int64)
        c0, c1 = self.net.link_c0[link], self.net.link_c1[link]
        k = np.floor(np.maximum(np.asarray(s_m, np.float64), 0.0) / self.link_dx_m[link])
        return np.minimum(c0 + k.astype(np.int64), c1 - 1).astype(np.int64)

    def weights(self, link: np.ndarray, s_m: np.ndarray
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The two cells (P,) and the weight (P,) of the second that linearly interpolate
        between cell centres at (link, s) (link ≥ 0)."""
        c0 = self.net.link_c0[link]
        n = self.net.link_c1[link] - c0
        p = np.clip(s_m / self.link_dx_m[link] - 0.5, 0.0, np.maximum(n - 1, 0))
        i0 = np.minimum(np.floor(p).astype(np.int64), np.maximum(n - 2, 0))
        w = np.clip(p - i0, 0.0, 1.0)
        return c0 + i0, c0 + np.minimum(i0 + 1, n - 1), w

    def interpolate(self, values: np.ndarray, link: np.ndarray, s_m: np.ndarray) -> np.ndarray:
        """Per-cell ``values`` (..., N) linearly interpolated between cell centres at (link, s)
        (link −1: 0); (..., P)."""
        out = np.zeros(values.shape[:-1] + link.shape)
        ok = link >= 0
        if not ok.any():
            return out
        a, b, w = self.weights(link[ok], s_m[ok])
        out[..., ok] = values[..., a] * (1.0 - w) + values[..., b] * w
        return out

    def downstream_distance(self, link: int, s_m: float) -> np.ndarray:
        """(N,) distance [m] along the river from (link, s) to each cell, downstream positive
        (upstream on the same link negative; NaN for cells not reached from there)."""
        out = np.full(self.n_cells, np.nan)
        start = {link: -float(s_m)}
        c0, c1, end = self.net.link_c0, self.net.link_c1, self.net.link_end
        begins = self.net.link_start
        for b in range(link, len(self.names)):     # upstream-first order
            if b not in start:
                continue
            cells = slice(int(c0[b]), int(c1[b]))
            out[cells] = start[b] + self.cell_s_m[cells]
            e = int(end[b])
            if e >= 0:
                for d in np.flatnonzero(begins == e):
                    d = int(d)
                    far = start[b] + float(self.link_length_m[b])
                    start[d] = max(start.get(d, -np.inf), far)
        return out


def same_place(old: SpillNetwork, new: SpillNetwork, link: np.ndarray, s_m: np.ndarray,
               xy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Points of ``old`` (its ``link`` (P,), arc length ``s_m`` (P,) along it, position
    ``xy`` (P, 2)) on ``new`` (a live edit's network): the link of the same name at the same
    fraction of its length, or where a link is gone the nearest sample of ``new`` to ``xy``.
    Returns (P,) links and (P,) arc lengths [m] of ``new``."""
    index = {name: k for k, name in enumerate(new.names)}
    link = np.asarray(link, np.int64).reshape(-1)
    to = np.array([index.get(old.names[k], -1) for k in link.tolist()], np.int64)
    s_new = np.empty(len(to))
    kept = to >= 0
    s_new[kept] = (np.asarray(s_m, np.float64)[kept] / old.link_length_m[link[kept]]
                   * new.link_length_m[to[kept]])
    if (~kept).any():
        to[~kept], s_new[~kept], _ = new.locate(np.asarray(xy, np.float64)[~kept])
    return to, s_new


def cell_map(old: SpillNetwork, new: SpillNetwork) -> np.ndarray:
    """(N_old,) the cell of ``new`` at the same place as each cell of ``old``
    (:func:`same_place`)."""
    link, s = same_place(old, new, old.cell_link, old.cell_s_m, old.cell_xy_m)
    return new.cell_of(link, s)


def build_spill_network(branches, discharges_m2s, dispersion: Dispersion | None = None
                        ) -> SpillNetwork:
    """Cells of the ``branches`` (objects with ``name``, ``centerline_m`` (K, 2) drawn
    downstream, ``widths_m`` (K,), ``start_junction``, ``end_junction``; −1: a free end), with
    their discharges per unit depth ``discharges_m2s`` [m²/s].

    Raises:
        ValueError: no branch, a branch with fewer than two points, non-finite or non-positive
            widths or discharges (naming the branch), or a cycle in the junctions.
    """
    disp = dispersion if dispersion is not None else Dispersion()
    branches = list(branches)
    if not branches:
        raise ValueError("spill network: the scene has no river branch")
    qs = [float(q) for q in discharges_m2s]
    for b, q in zip(branches, qs):
        line = np.asarray(b.centerline_m, np.float64)
        w = np.asarray(b.widths_m, np.float64)
        if line.ndim != 2 or len(line) < 2 or not np.isfinite(line).all():
            raise ValueError(f"spill network: branch {b.name!r} needs a finite centre line of "
                             "two points or more")
        if not (np.isfinite(w).all() and (w > 0).all()):
            raise ValueError(f"spill network: branch {b.name!r} has a width ≤ 0 or not finite")
        if not (math.isfinite(q) and q > 0):
            raise ValueError(f"spill network: branch {b.name!r} has the discharge {q!r} m²/s "
                             "(needs a finite number > 0)")
    order = _upstream_first([b.start_junction for b in branches],
                            [b.end_junction for b in branches])
    branches = [branches[k] for k in order]
    qs = [qs[k] for k in order]
    starts = np.array([b.start_junction for b in branches], np.int64)
    ends = np.array([b.end_junction for b in branches], np.int64)
    n_nodes = int(max(starts.max(), ends.max(), -1)) + 1
    leaving = {j: [k for k in range(len(branches)) if starts[k] == j] for j in range(n_nodes)}

    cq, cv, ck, ckl, ceps, clink, cs, cxy, cw, cu = ([] for _ in range(10))
    c0, c1, length, dxs, depths, share, outlet_of, end_node = [], [], [], [], [], [], [], []
    outlets: list[str] = []
    n = 0
    samples_xy, samples_link, samples_s = [], [], []
    lines = []
    for k, (b, q) in enumerate(zip(branches, qs)):
        line = np.asarray(b.centerline_m, np.float64)
        keep = np.concatenate([[True], np.any(np.diff(line, axis=0) != 0.0, axis=1)])
        line = line[keep]
        w_pts = np.asarray(b.widths_m, np.float64)[keep]
        arc = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(line, axis=0).T))])
        L = float(arc[-1])
        h = float(channel_depth_m(float(np.median(w_pts))))
        cell = disp.cell_m if disp.cell_m is not None else max(float(np.median(w_pts)), 1.0)
        m = max(1, int(math.ceil(L / cell - 1e-9)))
        dx = L / m
        s = (np.arange(m) + 0.5) * dx
        w = np.interp(s, arc, w_pts)
        xy = np.stack([np.interp(s, arc, line[:, 0]), np.interp(s, arc, line[:, 1])], 1)
        u = q / w
        ustar = disp.manning_n * u * math.sqrt(G_MPS2) / h ** (1.0 / 6.0)
        if disp.longitudinal_m2s is None:
            kl = disp.fischer * u * u * w * w / (h * ustar)
        else:
            kl = np.full(m, float(disp.longitudinal_m2s))
        area = w * h
        face = np.zeros(m)
        if m > 1:
            face[:-1] = 0.5 * (kl[:-1] + kl[1:]) * 0.5 * (area[:-1] + area[1:]) / dx
        cq.append(np.full(m, q * h))
        cv.append(area * dx)
        ck.append(face)
        ckl.append(np.asarray(kl, np.float64))
        ceps.append(disp.transverse * h * ustar)
        clink.append(np.full(m, k))
        cs.append(s)
        cxy.append(xy)
        cw.append(w)
        cu.append(u)
        c0.append(n)
        n += m
        c1.append(n)
        length.append(L)
        dxs.append(dx)
        depths.append(h)
        j0 = int(starts[k])
        share.append(q / sum(qs[d] for d in leaving[j0]) if j0 >= 0 else 1.0)
        e = int(ends[k])
        if e < 0 or not leaving.get(e):
            outlet_of.append(len(outlets))
            outlets.append(b.name)
            end_node.append(-1)
        else:
            outlet_of.append(-1)
            end_node.append(e)
        step = max(0.25 * dx, 0.5)
        ss = np.linspace(0.0, L, max(2, int(math.ceil(L / step)) + 1))
        samples_xy.append(np.stack([np.interp(ss, arc, line[:, 0]),
                                    np.interp(ss, arc, line[:, 1])], 1))
        samples_link.append(np.full(len(ss), k))
        samples_s.append(ss)
        lines.append(line)
    cell_q = np.concatenate(cq)
    cell_vol = np.concatenate(cv)
    face_k = np.concatenate(ck)
    net = SpillNet(cell_q=cell_q, cell_vol=cell_vol, face_k=face_k,
                   link_c0=np.asarray(c0, np.int32), link_c1=np.asarray(c1, np.int32),
                   link_start=np.asarray(starts, np.int32),
                   link_end=np.asarray(end_node, np.int32),
                   link_outlet=np.asarray(outlet_of, np.int32),
                   link_share=np.asarray(share, np.float64))
    k_left = np.concatenate([[0.0], face_k[:-1]])
    dt_max = float(min(np.min(0.5 * cell_vol / cell_q),
                       np.min(0.25 * cell_vol / np.maximum(face_k + k_left, 1e-300))))
    return SpillNetwork(
        net=net, names=[b.name for b in branches], lines=lines,
        link_length_m=np.asarray(length), link_dx_m=np.asarray(dxs),
        link_q_m2s=np.asarray(qs, np.float64), link_depth_m=np.asarray(depths),
        cell_link=np.concatenate(clink), cell_s_m=np.concatenate(cs),
        cell_xy_m=np.concatenate(cxy), cell_width_m=np.concatenate(cw),
        cell_speed_mps=np.concatenate(cu),
        cell_k_m2s=np.concatenate(ckl),
        cell_eps_m2s=np.concatenate(ceps), outlets=outlets, n_nodes=n_nodes,
        dt_max_s=dt_max, dispersion=disp,
        _tree=cKDTree(np.concatenate(samples_xy)),
        _sample_link=np.concatenate(samples_link), _sample_s=np.concatenate(samples_s))


def _upstream_first(starts: list[int], ends: list[int]) -> list[int]:
    """Indices of the branches so that every branch comes after those draining into its start
    junction (Kahn's order, stable); ValueError on a cycle."""
    n = len(starts)
    into: dict[int, list[int]] = {}
    for k, e in enumerate(ends):
        if e >= 0:
            into.setdefault(e, []).append(k)
    waiting = [len(into.get(s, ())) if s >= 0 else 0 for s in starts]
    ready = [k for k in range(n) if waiting[k] == 0]
    order: list[int] = []
    done = set()
    while ready:
        k = min(ready)
        ready.remove(k)
        order.append(k)
        done.add(k)
        e = ends[k]
        if e >= 0:
            for d in range(n):
                if starts[d] == e and d not in done and d not in ready:
                    waiting[d] -= 1
                    if waiting[d] == 0:
                        ready.append(d)
    if len(order) != n:
        raise ValueError("spill network: the branches' junctions form a cycle (no upstream-first "
                         "order)")
    return order


def section_psi_range(potential, line: np.ndarray, s_m: float, width_m: float
                      ) -> tuple[float, float]:
    """Smallest and largest ψ [m²/s] across the river at arc length ``s_m`` of its centre line
    (``potential(xy) -> ψ``, NaN outside the water), sampled across 1.2 widths (NaN, NaN if
    no water is found there)."""
    line = np.asarray(line, np.float64)
    arc = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(line, axis=0).T))])
    s_m = float(np.clip(s_m, 0.0, arc[-1]))
    p = np.array([np.interp(s_m, arc, line[:, 0]), np.interp(s_m, arc, line[:, 1])])
    k = int(np.clip(np.searchsorted(arc, s_m), 1, len(line) - 1))
    t = line[k] - line[k - 1]
    t = t / max(float(np.hypot(*t)), 1e-12)
    normal = np.array([-t[1], t[0]])
    off = np.linspace(-0.6 * width_m, 0.6 * width_m, 241)
    psi = np.asarray(potential(p[None, :] + off[:, None] * normal[None, :]), np.float64)
    psi = psi[np.isfinite(psi)]
    if len(psi) < 2:
        return float("nan"), float("nan")
    return float(psi.min()), float(psi.max())


def section_discharge_m2s(potential, line: np.ndarray, widths_m: np.ndarray) -> float:
    """A branch's discharge per unit depth [m²/s]: the ψ difference across its middle section
    (:func:`section_psi_range`)."""
    line = np.asarray(line, np.float64)
    arc = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(line, axis=0).T))])
    mid = 0.5 * arc[-1]
    lo, hi = section_psi_range(potential, line, mid, float(np.interp(mid, arc, widths_m)))
    return hi - lo
