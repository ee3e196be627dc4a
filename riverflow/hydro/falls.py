"""Falls, weirs and dams: where a river's water drops by metres over a few metres.

A :class:`Fall` is a point on a branch's centre line (``at_m`` along it) with a drop [m] and a
*lip*: the straight line across the river, perpendicular to the centre line, over which the
water leaves the bed (a weir's or dam's crest runs across the whole river; a natural fall's
lip may be shorter than the river is wide). Falls come

* by hand: :meth:`RiverNetworkBuilder.add_fall(at_m, drop_m) <riverflow.hydro.builder.
  RiverNetworkBuilder.add_fall>`;
* from water levels: where the levels of a network (``builder.water_levels``: GIS bed
  elevations) drop by more than ``fall_min_drop_m`` over less than the drop's own height
  along the river (:func:`find_falls`);
* from GIS: OSM ``waterway=waterfall|weir|dam`` (:mod:`riverflow.gis`).

What a fall does to the flow (:mod:`riverflow.kernels.falls`): over ``approach_m`` upstream of
the lip the water speeds up to the lip speed ``max(√(g·depth), upstream speed)`` (critical
flow at the lip: Froude number 1, reached from the river's depth); it leaves the lip at that
speed and falls ballistically (g = 9.81 m/s²) along the *nappe*, whose horizontal length is
``throw_m = v_lip·√(2·drop/g)``; over ``plunge_m`` after it lands in the pool it slows back to
the river's own flow. The water surface follows the nappe (:func:`nappe_drop`), so anything
that rides on the surface (particles, boats) falls with the water. What departs from physics
is listed in docs/deviations.md.

A fall built into a graph is a :class:`Fall` with its geometry resolved (``centre_m``,
``direction``, ``width_m``, ``depth_m``, the speeds); ``graph.falls`` lists them.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

G_MPS2 = 9.81
"""Gravity [m/s²]."""
FALL_MIN_DROP_M = 1.0
"""A drop of the water level is a fall when it is larger than this [m] and happens over less
than its own height along the river (the default of ``RiverConfig.fall_min_drop_m`` and of
the builder's ``fall_min_drop_m``)."""
FALL_KINDS = ("fall", "weir", "dam")
"""What a fall may be: a natural fall, a weir, a dam's spillway (weirs and dams have a
straight lip across the whole river)."""
APPROACH_WIDTHS = 1.5
"""The flow speeds up toward the lip over this many river widths…"""
APPROACH_M = (10.0, 80.0)
"""…at least / at most this many metres."""
PLUNGE_WIDTHS = 1.0
"""Below the nappe the flow slows back to the river's over this many widths…"""
PLUNGE_M = (5.0, 60.0)
"""…at least / at most this many metres."""


def channel_depth_m(width_m):
    """Full (mid-stream) depth [m] of a river ``width_m`` wide: min(1 + width/50, 0.1·width)
    (the scenes' bed profile, :func:`riverflow.scenes.water.bed_depth`, reaches it)."""
    w = np.asarray(width_m, np.float64)
    return np.minimum(1.0 + w / 50.0, 0.1 * w)


@dataclass(frozen=True)
class Fall:
    """A fall on a branch, its geometry resolved (module docstring). Lengths [m], speeds [m/s].

    ``branch``: the branch's name; ``at_m``: the lip along its centre line; ``centre_m`` (2,)
    the lip's middle; ``direction`` (2,) the unit downstream tangent there; ``lip_m`` the
    lip's length (≤ ``width_m``); ``depth_m`` the river's depth above the lip; ``speed_mps``
    the river's mean speed there (discharge / width); ``lip_speed_mps`` the speed at the lip;
    ``in_levels``: the drop is already in the water levels it was found from (the landscape
    must not add it again).
    """

    branch: str
    at_m: float
    drop_m: float
    centre_m: tuple[float, float]
    direction: tuple[float, float]
    width_m: float
    lip_m: float
    depth_m: float
    speed_mps: float
    kind: str = "fall"
    in_levels: bool = False

    @property
    def lip_speed_mps(self) -> float:
        """Speed at the lip: critical flow from the river's depth, √(g·depth), or the
        river's own speed where that is faster (a flow already supercritical)."""
        return max(math.sqrt(G_MPS2 * self.depth_m), self.speed_mps)

    @property
    def fall_time_s(self) -> float:
        """Time from the lip to the pool: √(2·drop/g) (a ballistic fall from rest vertically)."""
        return math.sqrt(2.0 * self.drop_m / G_MPS2)

    @property
    def throw_m(self) -> float:
        """Horizontal length of the nappe [m]: lip speed × fall time."""
        return self.lip_speed_mps * self.fall_time_s

    @property
    def approach_m(self) -> float:
        return float(np.clip(APPROACH_WIDTHS * self.width_m, *APPROACH_M))

    @property
    def plunge_m(self) -> float:
        return float(np.clip(PLUNGE_WIDTHS * self.width_m, *PLUNGE_M))

    @property
    def lip_ends_m(self) -> np.ndarray:
        """(2, 2) the lip's end points [m], left then right (facing downstream)."""
        c = np.asarray(self.centre_m, np.float64)
        t = np.asarray(self.direction, np.float64)
        n = np.array([-t[1], t[0]])
        return np.stack([c + 0.5 * self.lip_m * n, c - 0.5 * self.lip_m * n])

    def nappe_drop(self, s_m) -> np.ndarray:
        """How far [m] the surface lies below the lip's level at ``s_m`` [m] along the river
        from the lip (:func:`nappe_drop`)."""
        return nappe_drop(s_m, self.drop_m, self.throw_m)


RAPIDS_MIN_SLOPE = 0.02
"""A reach whose water level falls faster than this [m/m] (2 %) but is no fall is a rapid
(the builder's ``rapids_min_slope``)."""
RAPIDS_FULL_SLOPE = 0.15
"""The water shader's standing waves grow from RAPIDS_MIN_SLOPE to full at this surface slope
(15 %: a cascade; a 3 % riffle gets a little of them), ``shaders/rapids.glsl``."""
RAPIDS_MIN_LENGTH_M = 10.0
"""A steep stretch of water levels shorter than this [m] is no rapid (a sampling step)."""
RAPIDS_SPEED_EXPONENT = 0.3
"""On a rapid the flow is faster by (slope / RAPIDS_MIN_SLOPE) ** this: Manning's uniform
flow at a fixed discharge per unit width, v = q^0.4 · S^0.3 / n^0.6, against the slope at which
a reach starts being a rapid (the river's own speed comes from its discharge and width, not its
slope: docs/deviations.md W11). A 3 % riffle: ×1.13; 10 %: ×1.62; 15 %: ×1.83…"""
RAPIDS_MAX_GAIN = 2.5
"""…at most this many times the river's speed."""
RAPIDS_RAMP = (0.2, 2.0, 20.0)
"""The flow speeds up over this fraction of a rapid's length before it, at least / at most
this many metres, and slows back over as much after it."""


@dataclass(frozen=True)
class Rapid:
    """A steep reach of a branch: from ``from_m`` to ``to_m`` [m] along its centre line the
    water drops by ``drop_m`` [m], evenly (slope = drop / length). ``centre_m`` (2,) is the
    centre-line point halfway along it; ``in_levels`` as for :class:`Fall`. The surface
    follows the slope, so the foam's steepness term whitens it in proportion (a 3 % riffle
    less than a 15 % cascade)."""

    branch: str
    from_m: float
    to_m: float
    drop_m: float
    centre_m: tuple[float, float]
    start_m: tuple[float, float]
    end_m: tuple[float, float]
    in_levels: bool = False
    width_m: float = 0.0
    """The river's widest [m] along the rapid (0: not known; the speed-up then reaches as
    far across as the rapid is long)."""

    @property
    def slope(self) -> float:
        return self.drop_m / max(self.to_m - self.from_m, 1e-9)

    @property
    def speed_gain(self) -> float:
        """How many times faster the water runs on the rapid than the river's own flow:
        clip((slope / RAPIDS_MIN_SLOPE) ** RAPIDS_SPEED_EXPONENT, 1, RAPIDS_MAX_GAIN)."""
        return float(np.clip((max(self.slope, 0.0) / RAPIDS_MIN_SLOPE) ** RAPIDS_SPEED_EXPONENT,
                             1.0, RAPIDS_MAX_GAIN))


def ramp_drop(s_m, drop_m: float, length_m: float) -> np.ndarray:
    """The water's fall below a rapid's start at ``s_m`` [m] downstream of it: 0 upstream,
    drop·s/length along it, the whole drop beyond."""
    return drop_m * np.clip(np.asarray(s_m, np.float64) / max(length_m, 1e-9), 0.0, 1.0)


def find_rapids(s_m: np.ndarray, level_m: np.ndarray, min_slope: float = RAPIDS_MIN_SLOPE,
                min_length_m: float = RAPIDS_MIN_LENGTH_M) -> list[tuple[float, float, float]]:
    """Rapids in a water-level profile: (from_m, to_m, drop_m) of every run of steps steeper
    than ``min_slope`` and gentler than a fall's 1 : 2 (:func:`find_falls`), at least
    ``min_length_m`` long."""
    s = np.asarray(s_m, np.float64)
    z = np.asarray(level_m, np.float64)
    if s.shape != z.shape or s.ndim != 1:
        raise ValueError(f"find_rapids: s_m and level_m must be (P,) arrays of one length, "
                         f"got {s.shape} and {z.shape}")
    if len(s) < 2:
        return []
    ds = np.maximum(np.diff(s), 1e-12)
    slope = (z[:-1] - z[1:]) / ds
    steep = (slope > min_slope) & (slope <= 0.5)
    return [(float(s[k]), float(s[e + 1]), float(z[k] - z[e + 1])) for k, e in _runs(steep)
            if s[e + 1] - s[k] >= min_length_m]


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """(first, last) index of each run of True in ``mask`` (N,), in order."""
    edges = np.flatnonzero(np.diff(np.concatenate([[0], mask.astype(np.int8), [0]])))
    return list(zip(edges[0::2].tolist(), (edges[1::2] - 1).tolist()))


def drop_along(s_m, drop_m: float, length_m: float, shape: str) -> np.ndarray:
    """How far [m] the water lies below its level at the start of a drop, ``s_m`` [m] past
    it: a fall's nappe (``shape`` "nappe", :func:`nappe_drop`) or a rapid's even slope
    ("ramp", :func:`ramp_drop`)."""
    if shape == "nappe":
        return nappe_drop(s_m, drop_m, length_m)
    if shape == "ramp":
        return ramp_drop(s_m, drop_m, length_m)
    raise ValueError(f"drop_along: shape must be 'nappe' or 'ramp', got {shape!r}")


def nappe_drop(s_m, drop_m: float, throw_m: float) -> np.ndarray:
    """The water's fall below the lip at ``s_m`` [m] downstream of it: 0 upstream,
    drop·(s/throw)² along the nappe (the ballistic parabola of water leaving the lip
    horizontally at throw / fall time), the whole drop from ``throw_m`` on."""
    t = np.clip(np.asarray(s_m, np.float64) / max(throw_m, 1e-9), 0.0, 1.0)
    return drop_m * t * t


def find_falls(s_m: np.ndarray, level_m: np.ndarray, min_drop_m: float = FALL_MIN_DROP_M
               ) -> list[tuple[float, float]]:
    """Falls in a water-level profile: (at_m, drop_m) of every run of the profile that drops
    by more than ``min_drop_m`` over less than its own height along the river.

    ``s_m`` (P,) increasing stations [m], ``level_m`` (P,) levels [m] there. A run is a
    stretch of consecutive steps steeper than 1 : 2 (sampled steps smear a vertical drop
    over one sample spacing); it is a fall when its drop exceeds ``min_drop_m`` and its
    length is at most its drop plus one sample spacing. ``at_m`` is where the run starts
    (the lip).
    """
    s = np.asarray(s_m, np.float64)
    z = np.asarray(level_m, np.float64)
    if s.shape != z.shape or s.ndim != 1:
        raise ValueError(f"find_falls: s_m and level_m must be (P,) arrays of one length, got "
                         f"{s.shape} and {z.shape}")
    if len(s) < 2:
        return []
    ds = np.diff(s)
    dz = z[:-1] - z[1:]
    steep = dz > 0.5 * np.maximum(ds, 1e-12)
    out = []
    for k, e in _runs(steep):
        drop = float(z[k] - z[e + 1])
        length = float(s[e + 1] - s[k])
        spacing = float(ds[k:e + 1].max())
        if drop > min_drop_m and length <= drop + spacing:
            out.append((float(s[k]), drop))
    return out
