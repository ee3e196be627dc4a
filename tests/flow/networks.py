"""River networks built in the tests with the public builder (SPEC §1 "Author it")."""
from __future__ import annotations

import numpy as np

from riverflow.hydro.builder import RiverNetworkBuilder


def straight_channel():
    """A 400 m straight channel, 40 m wide, flowing +x, discharge 40 m²/s (mean 1 m/s)."""
    b = RiverNetworkBuilder()
    b.add_branch([(0, 0), (400, 0)], 40.0, discharge_m2s=40.0, name="main")
    return b.build(), b


def bend_with_island():
    """A 90° bend, 60 m wide, with a free island (an obstacle) in the middle of the bend."""
    t = np.linspace(0, np.pi / 2, 40)
    arc = np.c_[200 * np.sin(t), 200 * (1 - np.cos(t))]
    line = np.vstack([[(-200, 0)], arc, [(200, 400)]])
    b = RiverNetworkBuilder()
    b.add_branch(line, 60.0, discharge_m2s=60.0, name="bend")
    c = np.array([200 * np.sin(np.pi / 4), 200 * (1 - np.cos(np.pi / 4))])
    ang = np.linspace(0, 2 * np.pi, 24, endpoint=False)
    b.add_island(c + np.c_[9 * np.cos(ang), 9 * np.sin(ang)])
    return b.build(), b


def confluence():
    """Two rivers (30 and 20 m²/s) joining into one 60 m wide."""
    b = RiverNetworkBuilder()
    b.add_branch([(-300, 150), (-150, 60), (0, 0)], 40.0, discharge_m2s=30.0, name="left")
    b.add_branch([(-300, -160), (-140, -70), (0, 0)], 30.0, discharge_m2s=20.0, name="right")
    b.add_branch([(0, 0), (200, 0), (400, 30)], 60.0, name="lower")
    return b.build(), b


def bifurcation():
    """One river splitting into two arms around an island, which join again."""
    b = RiverNetworkBuilder()
    b.add_branch([(-300, 0), (0, 0)], 60.0, discharge_m2s=60.0, name="upper")
    x = np.linspace(0, 350, 60)
    bulge = np.sin(np.pi * x / 350) ** 0.7
    b.add_branch(np.c_[x, 75 * bulge], 40.0, discharge_m2s=35.0, name="north")
    b.add_branch(np.c_[x, -65 * bulge], 35.0, discharge_m2s=25.0, name="south")
    b.add_branch([(350, 0), (650, 0)], 60.0, name="lower")
    return b.build(), b


NETWORKS = {
    "straight": straight_channel,
    "bend_island": bend_with_island,
    "confluence": confluence,
    "bifurcation": bifurcation,
}


def bending_confluence():
    """A bending main river, a tributary joining it half way (a confluence), on no round
    coordinates (the landscapes of the tile seam and tile ray-cast tests)."""
    import riverflow as rf
    b = rf.RiverNetworkBuilder(tolerance_m=0.25)
    x = np.linspace(0.0, 1200.0, 25)
    main = np.c_[x, 80.0 * np.sin(x / 200.0)]
    b.add_branch(main[:13], [30.0] * 13, 20.0, name="upper")
    trib = np.c_[np.linspace(600.0, main[12, 0], 10), np.linspace(-400.0, main[12, 1], 10)]
    b.add_branch(trib, 18.0, 10.0, name="trib")
    b.add_branch(main[12:], np.linspace(40.0, 50.0, 13), name="lower")
    return b.build()



def divergence_and_gradient(field, pts: np.ndarray, eps: float) -> tuple[np.ndarray, np.ndarray]:
    """Central differences of ``field.query`` at ``pts`` with step ``eps`` [m]: (divergence
    (N,), largest velocity-gradient component (N,)), both [1/s]."""
    _, vxp = field.query(pts + (eps, 0))
    _, vxm = field.query(pts - (eps, 0))
    _, vyp = field.query(pts + (0, eps))
    _, vym = field.query(pts - (0, eps))
    div = (vxp[:, 0] - vxm[:, 0] + vyp[:, 1] - vym[:, 1]) / (2 * eps)
    grad = np.abs(np.c_[vxp - vxm, vyp - vym]).max(1) / (2 * eps)
    return div, grad
