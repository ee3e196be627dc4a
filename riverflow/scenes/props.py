"""Triangle meshes of the props (plain numpy, no GL): a small motor boat and a barrel.

Each mesh is (V, 9) float32 rows of position (3) [m], normal (3), colour (3), three rows per
triangle (flat shading), in the prop's own frame: x forward (the bow), y to port, z up,
origin at the waterline centre.
"""
from __future__ import annotations

import numpy as np

HULL = (0.86, 0.86, 0.82)
STRIPE = (0.70, 0.12, 0.10)
CABIN = (0.92, 0.92, 0.95)
WOOD = (0.50, 0.33, 0.18)
HOOP = (0.25, 0.25, 0.27)


def _triangles(tris: list[tuple], colours: list[tuple]) -> np.ndarray:
    """(3T, 9) rows from triangles (3 points each) and one colour per triangle; normals are
    the faces' (counter-clockwise seen from outside)."""
    p = np.asarray(tris, np.float64).reshape(-1, 3, 3)
    n = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-12)
    c = np.asarray(colours, np.float64).reshape(-1, 1, 3)
    rows = np.concatenate([p, np.repeat(n[:, None], 3, 1), np.repeat(c, 3, 1)], axis=2)
    return rows.reshape(-1, 9).astype(np.float32)


def _quad(a, b, c, d) -> list[tuple]:
    return [(a, b, c), (a, c, d)]


def boat_mesh(length_m: float = 8.0, beam_m: float = 3.0, height_m: float = 1.2) -> np.ndarray:
    """A motor boat: a hull pointed at the bow (x = +L/2), flat transom, a deck and a cabin."""
    hl, hb = 0.5 * length_m, 0.5 * beam_m
    keel, deck = -0.45 * height_m, 0.55 * height_m
    # hull outline at deck level (counter-clockwise from above) and its narrower bottom
    top = [(hl, 0.0), (0.25 * hl, hb), (-hl, hb * 0.92), (-hl, -hb * 0.92), (0.25 * hl, -hb)]
    bottom = [(hl * 0.85, 0.0), (0.2 * hl, hb * 0.6), (-hl * 0.95, hb * 0.55),
              (-hl * 0.95, -hb * 0.55), (0.2 * hl, -hb * 0.6)]
    tris, cols = [], []
    k = len(top)
    for i in range(k):
        j = (i + 1) % k
        a, b = (*top[i], deck), (*top[j], deck)
        c, d = (*bottom[j], keel), (*bottom[i], keel)
        for t in _quad(d, c, b, a):
            tris.append(t)
            cols.append(STRIPE if i in (0, k - 1) else HULL)
    for i in range(1, k - 1):                           # deck and bottom as fans
        tris.append(((*top[0], deck), (*top[i], deck), (*top[i + 1], deck)))
        cols.append(WOOD)
        tris.append(((*bottom[0], keel), (*bottom[i + 1], keel), (*bottom[i], keel)))
        cols.append(HULL)
    # cabin: a box on the deck, aft of the middle
    x0, x1, y, z0, z1 = -0.55 * hl, 0.15 * hl, 0.6 * hb, deck, deck + 0.9 * height_m
    box = [((x1, -y, z0), (x1, y, z0), (x1, y, z1), (x1, -y, z1)),     # front
           ((x0, y, z0), (x0, -y, z0), (x0, -y, z1), (x0, y, z1)),     # back
           ((x1, y, z0), (x0, y, z0), (x0, y, z1), (x1, y, z1)),       # port
           ((x0, -y, z0), (x1, -y, z0), (x1, -y, z1), (x0, -y, z1)),   # starboard
           ((x0, -y, z1), (x1, -y, z1), (x1, y, z1), (x0, y, z1))]     # roof
    for face in box:
        for t in _quad(*face):
            tris.append(t)
            cols.append(CABIN)
    return _triangles(tris, cols)


def barrel_mesh(radius_m: float = 0.45, height_m: float = 1.2, sides: int = 14) -> np.ndarray:
    """A barrel lying in the water along x (half submerged: centre on the waterline)."""
    angles = np.linspace(0.0, 2 * np.pi, sides + 1)
    ring = np.stack([np.zeros_like(angles), np.cos(angles), np.sin(angles)], 1) * radius_m
    h = 0.5 * height_m
    tris, cols = [], []
    for i in range(sides):
        a, b = ring[i], ring[i + 1]
        quad = ((-h, a[1], a[2]), (-h, b[1], b[2]), (h, b[1], b[2]), (h, a[1], a[2]))
        for t in _quad(*quad):
            tris.append(t)
            cols.append(HOOP if i % 7 == 0 else WOOD)
        tris.append(((h, 0.0, 0.0), (h, a[1], a[2]), (h, b[1], b[2])))
        cols.append(WOOD)
        tris.append(((-h, 0.0, 0.0), (-h, b[1], b[2]), (-h, a[1], a[2])))
        cols.append(WOOD)
    return _triangles(tris, cols)


SHAPES = {"boat": boat_mesh, "barrel": barrel_mesh}
"""Mesh builders by :class:`riverflow.components.props.Prop` shape."""
