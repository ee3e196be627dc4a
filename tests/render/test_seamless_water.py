"""Water without seams (issue 29, item 2), drawn for real (offscreen, 256×144).

Twenty views of the default scene along its main river (low and grazing, middle, high
above) cross borders of the water mesh's tiles (of one level and of two levels) and a border
of the sprites' coverage: the world's particle pool is kept small (``capacity``), so the
particles cover only part of the water and the rest is drawn without sprites, as where
particles are missing in a real frame (a full pool, tiles not made yet, a gap). Particles
fade in within 0.1 s here, so the covered side is the sprites' blend at full weight.

In each view, for each kind of border and each mode (advected, pre-advected and, for tile
borders, non-advected), the *mean colour step* across the borders — the mean RGB distance
between the two pixels of each pixel pair that crosses them (one pixel apart along the
screen axis that crosses a border most), away from the shore's own edge — is no larger than
across any of 24 copies of the same pairs moved 1 to 12 pixels across (lines of the same
length over the same water: the waves' own contrast and the shade's slow change with
distance). Measured: the borders' steps are at most 0.9 of their copies' largest. The shader
before the fix fails it on the coverage borders (up to 3.1× in the advected mode, 2.3× in
the pre-advected one): the waves switched at once from the sprites' blend to the world-fixed
waves where the last sprite's disc ended (a jagged line along the discs' rims), and the
sprites' foam amount jumped from 0 to its value there.

Where each pixel's water lies in the world comes from the pre-advected mode's position pass
(``DrawRivers.gpu.position``: the surface's world position, alpha 0 where no water is drawn);
the coverage from the coverage mode (green: no sprite).
"""
from __future__ import annotations

import numpy as np
import pytest
from scipy import ndimage

import riverflow as rf
from riverflow.components.river import TerrainView
from riverflow.engine import gl
from riverflow.scenes.flight import flight_pose, main_width_m

pytestmark = [pytest.mark.gl, pytest.mark.slow]     # 20 views in every mode: ~14 s of CPU
W, H = 256, 144
SHIFTS_PX = tuple(k for k in range(-12, 13) if k)
MIN_PAIRS = 12                         # a border with fewer pixel pairs on screen is skipped
STEPS = 6                              # frames stepped a view: particles faded in (0.1 s)
MODES = ("ADVECTED", "PRE_ADVECTED", "NON_ADVECTED")


@pytest.fixture(scope="module")
def world(gl_context):
    from riverflow.scenes.default import default_scene

    scene = default_scene(seed=0)
    w = rf.RiverWorld(scene, size=(W, H), gl=True, seed=0,
                      config=rf.RiverConfig(tile_production="blocking", capacity=150,
                                            radius_px=4.0, fade_in_s=0.1))
    yield w
    w.close()


def _views(scene):
    """(eye, target) of 20 views down the main river: low, middle and high."""
    width = main_width_m(scene)
    out = []
    for start in np.linspace(300.0, 2600.0, 7):
        for height, behind in ((0.3, 0.6), (1.0, 2.5), (4.0, 6.0)):
            if len(out) < 20:
                out.append(flight_pose(scene, 0, height_m=height * width,
                                       behind_m=behind * width, start_m=float(start)))
    return out


def _pairs(inside: np.ndarray, valid: np.ndarray, axis: int) -> np.ndarray:
    """(N, 2) pixel (row, column) on the inside of the border of ``inside`` whose neighbour
    one pixel on along ``axis`` is outside, both valid: the border, crossed along ``axis``."""
    a, b = inside & valid, ~inside & valid
    lo = [slice(None)] * 2
    hi = [slice(None)] * 2
    lo[axis], hi[axis] = slice(0, -1), slice(1, None)
    lo, hi = tuple(lo), tuple(hi)
    up = np.zeros_like(inside)
    up[lo] = (a[lo] & b[hi]) | (b[lo] & a[hi])
    return np.argwhere(up)


def _crossings(inside: np.ndarray, valid: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
    """The border of ``inside`` within the valid pixels and its copies moved across it:
    for each shift of (0, *SHIFTS_PX), the pixel pairs (p, q) (two (N, 2) arrays of (row,
    column)), q one pixel on from p along the screen axis that crosses the border most. The
    same N pairs at every shift, those whose two pixels are valid at all of them (lines of
    the same length over water); [] when fewer than MIN_PAIRS are."""
    counts = [len(_pairs(inside, valid, a)) for a in (0, 1)]
    axis = int(np.argmax(counts))
    pairs = _pairs(inside, valid, axis)
    e = np.zeros(2, int)
    e[axis] = 1
    ends = []
    keep = np.ones(len(pairs), bool)
    for k in (0, *SHIFTS_PX):
        p, q = pairs + k * e, pairs + (k + 1) * e
        ok = (p >= 0).all(axis=1) & (q < valid.shape).all(axis=1)
        p, q = np.where(ok[:, None], p, 0), np.where(ok[:, None], q, 0)
        keep &= ok & valid[p[:, 0], p[:, 1]] & valid[q[:, 0], q[:, 1]]
        ends.append((p, q))
    if keep.sum() < MIN_PAIRS:
        return []
    return [(p[keep], q[keep]) for p, q in ends]


def _steps(colour: np.ndarray, crossings: list) -> np.ndarray:
    """The mean colour step (RGB distance |colour(q) - colour(p)|) over every pair of the
    borders ``crossings`` (a list of :func:`_crossings`), at each shift: (1 + len(SHIFTS_PX),)."""
    out = []
    for s in range(1 + len(SHIFTS_PX)):
        p = np.concatenate([c[s][0] for c in crossings])
        q = np.concatenate([c[s][1] for c in crossings])
        out.append(np.linalg.norm(colour[p[:, 0], p[:, 1]] - colour[q[:, 0], q[:, 1]],
                                  axis=1).mean())
    return np.array(out)


def _tile_borders(scene, cut: np.ndarray, xy: np.ndarray, water: np.ndarray):
    """For each edge between two tiles of the cut, both with water on screen: (levels,
    pixels of the first tile, pixels of the two)."""
    q = scene.quadtree
    boxes = np.array([q.tile_box_m(*k) for k in cut.tolist()])
    where = np.full(water.shape, -1)
    px = xy[water]
    inside = ((px[:, None, 0] >= boxes[None, :, 0]) & (px[:, None, 0] < boxes[None, :, 2])
              & (px[:, None, 1] >= boxes[None, :, 1]) & (px[:, None, 1] < boxes[None, :, 3]))
    where[water] = np.where(inside.any(axis=1), inside.argmax(axis=1), -1)
    seen = np.unique(where[where >= 0])
    out = []
    for i in seen:
        for j in seen[seen > i]:
            a, b = boxes[i], boxes[j]
            # sharing an edge of positive length
            touch_x = (a[2] == b[0] or b[2] == a[0]) and min(a[3], b[3]) > max(a[1], b[1])
            touch_y = (a[3] == b[1] or b[3] == a[1]) and min(a[2], b[2]) > max(a[0], b[0])
            if touch_x or touch_y:
                out.append(((int(cut[i, 0]), int(cut[j, 0])), where == i,
                            (where == i) | (where == j)))
    return out


@pytest.fixture(scope="module")
def seams(world):
    """(kind, mode, step across a view's borders of that kind, the largest step across their
    moved copies, (eye, target)) over the twenty views; the number of views with a coverage
    border; the tile levels seen."""
    drawer = world._drawer()
    scene = world.scene
    rows, levels, covered_views = [], set(), 0
    for eye, target in _views(scene):
        world.camera.look_at(eye, target)
        world.load_view()
        for _ in range(STEPS):
            world.step(1 / 30)
        world.display.mode = rf.DisplayMode.COVERAGE
        cov = world.render()
        frames = {}
        for mode in MODES:
            world.display.mode = getattr(rf.DisplayMode, mode)
            frames[mode] = world.render()[..., :3].astype(np.float64)
            if mode == "PRE_ADVECTED":       # the position pass of this very frame
                pos = gl.read_texture(drawer.gpu.position)[::-1].astype(np.float64)
        water = pos[..., 3] > 0
        inner = ndimage.binary_erosion(water, iterations=2)    # not the shore's own edge
        xy = pos[..., :2]
        uncovered = (cov[..., 1] == 255) & (cov[..., 0] == 0)
        covered = water & ~uncovered
        cut = world.resource(TerrainView).cut
        levels |= set(cut[:, 0].tolist())
        borders = {"coverage": [], "tile": [], "level": []}
        if covered.any() and (water & uncovered).any():
            covered_views += 1
            borders["coverage"] = [c for c in [_crossings(covered, inner)] if c]
        for (la, lb), inside, region in _tile_borders(scene, cut, xy, water):
            c = _crossings(inside, inner & region)
            if c:
                borders["level" if la != lb else "tile"].append(c)
        for kind, crossings in borders.items():
            if not crossings:
                continue
            for mode in MODES if kind != "coverage" else MODES[:2]:
                steps = _steps(frames[mode], crossings)
                rows.append((kind, mode, steps[0], steps[1:].max(), (eye, target)))
    world.display.mode = rf.DisplayMode.ADVECTED
    return rows, covered_views, levels


def _summary(rows) -> dict:
    """(kind, mode) → each view's step across its borders over the largest across their
    moved copies (for the failure message)."""
    out = {}
    for kind, mode, step, other, _ in rows:
        out.setdefault((kind, mode), []).append(round(step / other, 2))
    return out


def test_the_views_cross_every_kind_of_border(seams):
    rows, covered_views, levels = seams
    assert covered_views >= 10, covered_views
    assert len(levels) >= 4, levels
    counts = {kind: {} for kind in ("coverage", "tile", "level")}
    for kind, mode, *_ in rows:
        counts[kind][mode] = counts[kind].get(mode, 0) + 1
    assert all(counts["coverage"].get(m, 0) >= 5 for m in MODES[:2]), counts
    assert all(counts["tile"].get(m, 0) >= 3 for m in MODES), counts
    assert all(counts["level"].get(m, 0) >= 1 for m in MODES), counts


@pytest.mark.parametrize("kind", ["coverage", "tile", "level"])
def test_no_colour_step_along_a_border(seams, kind):
    rows, _, _ = seams
    bad = [(mode, round(step, 2), round(other, 2), view) for k, mode, step, other, view in rows
           if k == kind and step > other]
    assert not bad, (bad, _summary(rows))

