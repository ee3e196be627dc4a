"""Plain-numpy twins of the numba kernels: slow, obvious, the specification of each kernel."""
from __future__ import annotations

import numpy as np

from riverflow.hydro.flow_network import FlowNetwork
from riverflow.kernels.flow import KIND_AXIS, KIND_BANK, KIND_CAP

TIE = 1e-4


def _dist2(p, a, b):
    """Squared distances from p (2,) to segments a→b (S, 2)."""
    e = b - a
    l2 = (e * e).sum(1)
    t = np.where(l2 > 0, ((p - a) * e).sum(1) / np.where(l2 > 0, l2, 1), 0.0)
    t = np.clip(t, 0.0, 1.0)
    q = a + t[:, None] * e - p
    return (q * q).sum(1)


def _signed(p, a, b):
    d2 = _dist2(p, a, b)
    cross = (b[:, 0] - a[:, 0]) * (p[1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (p[0] - a[:, 0])
    return np.where(cross < 0, -d2, d2)


def _nearer(cur, s):
    if abs(s) < abs(cur) * (1 - TIE):
        return s
    if abs(s) <= abs(cur) * (1 + TIE) and s > 0:
        return s
    return cur


def potential(net: FlowNetwork, xy: np.ndarray, slip: float) -> np.ndarray:
    """ψ at each point by brute force over every segment (twin of ``evaluate_potential``)."""
    a = np.c_[net.seg_ax, net.seg_ay]
    b = np.c_[net.seg_bx, net.seg_by]
    owner = np.repeat(np.arange(net.n_curves), net.curve_seg1 - net.curve_seg0)
    out = np.full(len(xy), np.nan)
    for k, p in enumerate(np.asarray(xy, float)):
        d2 = _dist2(p, a, b)
        is_axis = net.curve_kind[owner] == KIND_AXIS
        ok = is_axis & (d2 < net.curve_hw2[owner])
        if not ok.any():
            continue
        axis = owner[ok][np.argmin(d2[ok])]
        comp = net.curve_comp[axis]
        radius = net.comp_radius[comp]
        width2 = 4 * net.curve_hw2[axis]
        signed = _signed(p, a, b)
        groups: dict[int, float] = {}
        cap = np.inf
        for c in range(net.n_curves):
            if net.curve_kind[c] == KIND_AXIS or net.curve_comp[c] != comp:
                continue
            segs = range(net.curve_seg0[c], net.curve_seg1[c])
            if min(d2[s] for s in segs) > net.curve_cutoff[c] ** 2:
                continue
            cur = groups.get(net.curve_group[c], np.inf) if net.curve_kind[c] == KIND_BANK else cap
            for s in segs:
                cur = _nearer(cur, signed[s])
            if net.curve_kind[c] == KIND_BANK:
                groups[net.curve_group[c]] = cur
            elif net.curve_kind[c] == KIND_CAP:
                cap = cur
        if cap < 0 and -cap < width2:
            continue
        vals = np.array([groups[g] for g in sorted(groups)])
        psis = net.group_psi[sorted(groups)]
        if len(vals) < 2 or np.any((vals < 0) & (-vals < width2)):
            continue
        d = np.sqrt(np.abs(vals))
        if np.any(d <= 1e-9 * radius):
            out[k] = psis[np.argmax(d <= 1e-9 * radius)]
            continue
        t = np.clip(1 - d / radius, 0, 1)
        w = (6 * t**5 - 15 * t**4 + 10 * t**3) * (radius / d) ** slip
        if w.sum() > 0:
            out[k] = (w * psis).sum() / w.sum()
    return out


def catmull_rom(t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Weights (N, 4) and their derivatives (N, 4) of the Catmull-Rom spline at t (N,)."""
    m = 0.5 * np.array([[0, -1, 2, -1], [2, 0, -5, 3], [0, 1, 4, -3], [0, 0, -1, 1]], float)
    powers = np.stack([np.ones_like(t), t, t * t, t**3], 1)
    dpowers = np.stack([np.zeros_like(t), np.ones_like(t), 2 * t, 3 * t * t], 1)
    return powers @ m.T, dpowers @ m.T


def lattice_velocity(psi: np.ndarray, origin: tuple[float, float], h: float, xy: np.ndarray):
    """Curl of the Catmull-Rom bicubic of a stored ψ lattice (points −1 … n+1 at ``origin`` +
    (index − 1)·h), at points xy (N, 2): (N, 2) velocity, the twin of ``query_velocity``."""
    u = (xy[:, 0] - origin[0]) / h
    v = (xy[:, 1] - origin[1]) / h
    n = psi.shape[0] - 3
    i = np.minimum(np.floor(u).astype(int), n - 1)
    j = np.minimum(np.floor(v).astype(int), n - 1)
    wx, dx = catmull_rom(u - i)
    wy, dy = catmull_rom(v - j)
    out = np.zeros((len(xy), 2))
    for k in range(len(xy)):
        patch = psi[j[k]:j[k] + 4, i[k]:i[k] + 4]
        gx = wy[k] @ patch @ dx[k]
        gy = dy[k] @ patch @ wx[k]
        out[k] = (-gy / h, gx / h)
    return out
