"""Small link networks for the 1-D cells that spills and floods share
(:func:`riverflow.hydro.spill_network.build_spill_network`)."""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from riverflow.hydro.spill_network import build_spill_network


def branch(name, line, width, start=-1, end=-1):
    """A scene branch as the network builder reads it: a centre line of constant width."""
    line = np.asarray(line, np.float64)
    return SimpleNamespace(name=name, centerline_m=line, widths_m=np.full(len(line), width),
                           start_junction=start, end_junction=end)


def straight(length_m, n=201, y=0.0, x0=0.0):
    """A straight centre line along x, n points."""
    x = np.linspace(x0, x0 + length_m, n)
    return np.stack([x, np.full(n, y)], 1)


def diamond(left=None, bottom_m: float = 1500.0):
    """A source splitting at a bifurcation into two arms of different discharges that meet
    again, a tributary joining below, and an outlet (``left``: the left arm's centre line
    instead of its straight one; ``bottom_m``: the outlet's length)."""
    return build_spill_network(
        [branch("top", straight(1500.0, 31), 40.0, -1, 0),
         branch("left", straight(1200.0, 25, 60.0, 1500.0) if left is None else left, 30.0,
                0, 1),
         branch("right", straight(900.0, 19, -60.0, 1500.0), 20.0, 0, 1),
         branch("trib", straight(800.0, 17, 300.0, 1900.0), 15.0, -1, 1),
         branch("bottom", straight(bottom_m, 31, 0.0, 2700.0), 45.0, 1, -1)],
        [40.0, 25.0, 15.0, 10.0, 50.0])


def flood_over_the_banks(world, above_m: float = 1.0):
    """Flood ``world``'s tributary ``above_m`` over its bank top and run it to steady: every
    source's inflow raised by the rating curve's inverse. Returns (rise [m], ratio, q0)."""
    from riverflow.scenes.carving import Carving

    world.set_hydrograph(None, [], None)
    router = world.flood
    rise = Carving().bank_rise_m + above_m
    ratio = router.ratio_for_rise("tributary", rise)      # the rating curve, inverted
    q0 = router.base_inflow_m3s()
    now = world.flood_time_s
    world.set_hydrograph(None, [now, now + 1.0], [q0, ratio * q0])
    world.advance_flood(6 * 3600.0)                       # steady
    return rise, ratio, q0
