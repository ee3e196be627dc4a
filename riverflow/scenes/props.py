"""Triangle meshes of the props (plain numpy, no GL): a small motor boat and a barrel.

Each mesh is (V, 10) float32 rows of position (3) [m], normal (3), colour (3) and gloss (1:
how much of the sky and the sun a surface mirrors, 0 matt … 1 glass), three rows per
triangle, in the prop's own frame: x forward (the bow), y to port, z up, origin at the
waterline centre. Triangles are counter-clockwise seen from outside. Normals are smooth within
a surface (the hull's side) and sharp across the edges between surfaces (keel, sheer line,
transom, the wheelhouse's corners). Every part is closed: each edge is shared by exactly two
triangles that run along it in opposite directions.

The boat (:func:`boat_mesh`) is made from its length, beam and height (keel to deck, the
:class:`~riverflow.components.boat.Boat` fields): a hull with a pointed, raked bow, a flat
transom stern, a sheer line rising towards the bow, sections going from a round bilge aft to
a V forward; antifouling below the waterline, a boot stripe, white topsides and a rubbing
strake; a cambered deck; a wheelhouse with a raked windscreen and side windows.
"""
from __future__ import annotations

import numpy as np

# colours (linear RGB) and gloss
ANTIFOULING = (0.42, 0.09, 0.07)
BOOT = (0.06, 0.08, 0.16)
TOPSIDES = (0.90, 0.90, 0.86)
RUBBING = (0.22, 0.22, 0.24)
DECK = (0.64, 0.63, 0.58)
CABIN = (0.92, 0.92, 0.90)
ROOF = (0.78, 0.78, 0.76)
GLASS = (0.07, 0.10, 0.13)
WOOD = (0.50, 0.33, 0.18)
HOOP = (0.25, 0.25, 0.27)
GLOSS = {ANTIFOULING: 0.05, BOOT: 0.35, TOPSIDES: 0.35, RUBBING: 0.2, DECK: 0.08, CABIN: 0.25,
         ROOF: 0.2, GLASS: 0.9, WOOD: 0.05, HOOP: 0.3}

# hull proportions (fractions of the height H keel to deck, the length L, the half-beam b)
DRAFT = 0.36
"""Keel depth below the waterline amidships, × H (the freeboard amidships is the rest of H;
the keel rises towards the stem)."""
SHEER_RISE = 0.22
"""How much higher the sheer line is at the bow than at the transom, × H."""
BOOT_TOP = 0.07
"""Top of the boot stripe above the waterline, × H."""
RUBBING_DEPTH = 0.06
"""Depth of the rubbing strake below the sheer line, × H."""
TRANSOM_BEAM = 0.9
"""Beam at the transom, × the beam."""
BOW_START = 0.45
"""Where the hull starts to narrow towards the bow (0 transom … 1 stem)."""
BOW_RAKE = 0.10
"""How far the stem's foot lies aft of its head, × L."""
CAMBER = 0.05
"""Rise of the deck's crown above its edges amidships, × the beam."""


class _Mesh:
    """Triangles with per-corner normals, one colour and gloss each, from grid patches."""

    def __init__(self) -> None:
        self.rows: list[np.ndarray] = []

    def patch(self, p: np.ndarray, colour, flip: bool = False,
              other_diagonal: np.ndarray | None = None) -> None:
        """A grid of points ``p`` (R, C, 3) as quads (two triangles each), counter-clockwise
        seen from the side its first axis × second axis points to (from the other side with
        ``flip``), normals averaged over the patch (area-weighted); ``colour(r, c)`` per quad.
        A quad (i, j) is split along its (i, j)-(i+1, j+1) diagonal, or along the other one
        where ``other_diagonal`` (R - 1, C - 1) bool says so. Triangles with no area (where a
        row collapses to a point) are left out."""
        rows, cols = p.shape[0], p.shape[1]
        ids = np.arange(rows * cols).reshape(rows, cols)
        a, b, d, e = ids[:-1, :-1], ids[1:, :-1], ids[1:, 1:], ids[:-1, 1:]
        alt = np.zeros(a.shape, bool) if other_diagonal is None else other_diagonal
        first = np.where(alt[..., None], np.stack([a, b, e], -1), np.stack([a, b, d], -1))
        second = np.where(alt[..., None], np.stack([b, d, e], -1), np.stack([a, d, e], -1))
        tris = np.concatenate([first.reshape(-1, 3), second.reshape(-1, 3)])
        quad = np.tile(np.arange(a.size), 2)
        if flip:
            tris = tris[:, ::-1]
        pts = p.reshape(-1, 3).astype(np.float64)
        q = pts[tris]
        face = np.cross(q[:, 1] - q[:, 0], q[:, 2] - q[:, 0])
        acc = np.zeros_like(pts)
        for k in range(3):
            np.add.at(acc, tris[:, k], face)
        area = np.linalg.norm(face, axis=1)
        keep = area > 1e-9 * float(np.ptp(pts, axis=0).max()) ** 2
        n = acc[tris[keep]]
        n /= np.maximum(np.linalg.norm(n, axis=-1, keepdims=True), 1e-12)
        qi, qj = np.divmod(quad[keep], a.shape[1])
        col = np.array([colour(i, j) for i, j in zip(qi.tolist(), qj.tolist())], np.float64)
        gloss = np.array([GLOSS[tuple(c)] for c in col.tolist()], np.float64)
        out = np.empty((int(keep.sum()), 3, 10))
        out[..., 0:3] = q[keep]
        out[..., 3:6] = n
        out[..., 6:9] = col[:, None, :]
        out[..., 9] = gloss[:, None]
        self.rows.append(out.reshape(-1, 10))

    def array(self) -> np.ndarray:
        return np.concatenate(self.rows).astype(np.float32)


def boat_mesh(length_m: float = 8.0, beam_m: float = 3.0, height_m: float = 1.2,
              stations: int = 28) -> np.ndarray:
    """A motor boat ``length_m`` long (stem head to transom), ``beam_m`` wide at its widest
    and ``height_m`` from keel to deck amidships, its waterline at z = 0 (module docstring)."""
    L, B, H = float(length_m), float(beam_m), float(height_m)
    if not (L > 0 and B > 0 and H > 0):
        raise ValueError(f"boat_mesh: length, beam and height must be positive, got "
                         f"{length_m}, {beam_m}, {height_m}")
    half_l, half_b = 0.5 * L, 0.5 * B
    t = np.linspace(0.0, 1.0, stations)
    u = 1.0 - (1.0 - t) ** 1.3                 # stations, closer together towards the bow

    sheer = H * (1.0 - DRAFT + SHEER_RISE * (u ** 2.2 - 0.5 ** 2.2))      # deck edge z
    keel = -DRAFT * H * (1.0 - 0.7 * u ** 3) / (1.0 - 0.7 * 0.5 ** 3)     # keel z
    taper = np.clip((u - BOW_START) / (1.0 - BOW_START), 0.0, 1.0)
    aft = np.clip(u / BOW_START, 0.0, 1.0)
    beam = half_b * (TRANSOM_BEAM + (1.0 - TRANSOM_BEAM) * np.sin(0.5 * np.pi * aft)) \
        * (1.0 - taper ** 1.8)                                            # half-beam at sheer
    beam[-1] = 0.0
    fullness = 3.4 - 2.0 * u ** 1.5             # section exponent: round bilge aft, V forward

    # rows of the hull's side at fixed bands: keel → waterline → boot top → strake → sheer
    bands = [(np.linspace(0.0, 1.0, 7), lambda f: keel + (0.0 - keel) * f, ANTIFOULING),
             (np.array([1.0]), lambda f: BOOT_TOP * H * f, BOOT),
             (np.linspace(0.0, 1.0, 4)[1:],
              lambda f: BOOT_TOP * H + (sheer - RUBBING_DEPTH * H - BOOT_TOP * H) * f, TOPSIDES),
             (np.array([1.0]), lambda f: sheer - RUBBING_DEPTH * H * (1.0 - f), RUBBING)]
    z_rows, row_colour = [], []
    for fractions, z_of, colour in bands:
        for f in fractions:
            z_rows.append(np.broadcast_to(z_of(f), u.shape))
            row_colour.append(colour)
    z = np.stack(z_rows)                                                 # (R, S)
    tau = (z - keel) / (sheer - keel)
    y = beam * (1.0 - (1.0 - tau) ** fullness)
    x = -half_l + u * L - BOW_RAKE * L * (1.0 - tau) * u ** 4
    side = np.stack([x, y, z], axis=-1)                                   # port side (R, S, 3)
    starboard = side * np.array([1.0, -1.0, 1.0])
    colours = row_colour[1:]                     # quad row i spans rows i → i + 1

    mesh = _Mesh()
    # the keel's last quad has three corners on the centre plane (keel, stem): split along its
    # other diagonal, or both sides would put the same triangle there
    stem = np.zeros((len(z) - 1, len(u) - 1), bool)
    stem[0, -1] = True
    mesh.patch(side, lambda i, j: colours[i], other_diagonal=stem)         # (rows up, x fwd)
    mesh.patch(starboard, lambda i, j: colours[i], flip=True, other_diagonal=stem)
    # transom: the u = 0 section, port to starboard, same rows (its top row is the deck's)
    v = np.linspace(1.0, -1.0, 9)
    transom = np.stack([np.broadcast_to(x[:, :1], (len(z), len(v))),
                        y[:, :1] * v[None, :],
                        np.broadcast_to(z[:, :1], (len(z), len(v)))], axis=-1)
    mesh.patch(transom, lambda i, j: colours[i], flip=True)
    # deck: stations × across, cambered, its edges the sheer line
    camber = CAMBER * B * np.sin(np.pi * u) ** 0.5
    deck = np.stack([np.broadcast_to(x[-1][:, None], (len(u), len(v))),
                     beam[:, None] * v[None, :],
                     sheer[:, None] + camber[:, None] * (1.0 - v[None, :] ** 2)], axis=-1)
    mesh.patch(deck, lambda i, j: DECK, flip=True)
    _wheelhouse(mesh, L, B, H, u, sheer, x[-1])
    return mesh.array()


def _wheelhouse(mesh: _Mesh, L: float, B: float, H: float, u: np.ndarray, sheer: np.ndarray,
                x_deck: np.ndarray) -> None:
    """A wheelhouse aft of amidships: a closed box on a lattice (so its faces share their
    edges' vertices), the windscreen raked back, the sides leaning in, windows as panes of the
    walls' lattice."""
    x0, x1 = -0.30 * L, 0.06 * L
    half_w = 0.36 * B
    base = float(np.interp(x0, x_deck, sheer)) - 0.03 * H          # sunk a little into the deck
    top = base + 1.15 * H
    X = x0 + (x1 - x0) * np.array([0.0, 0.08, 0.44, 0.52, 0.86, 1.0])
    Y = half_w * np.array([-1.0, -0.85, -0.05, 0.05, 0.85, 1.0])
    Z = base + (top - base) * np.array([0.0, 0.45, 0.88, 1.0])
    rake = 0.30 * (top - base)

    def at(xs, ys, zs) -> np.ndarray:
        xs, ys, zs = np.broadcast_arrays(xs, ys, zs)
        h = (zs - base) / (top - base)
        return np.stack([xs - rake * h * (xs - x0) / (x1 - x0), ys * (1.0 - 0.08 * h), zs], -1)

    def walls(i: int, j: int) -> tuple:
        # window panes: the middle band (j = 1), columns 1 and 3 of the lattice
        return GLASS if j == 1 and i in (1, 3) else CABIN

    # each face: a grid whose first axis × second axis points outward
    mesh.patch(at(X[:, None], Y[-1], Z[None, :]), walls, flip=True)
    mesh.patch(at(X[:, None], Y[0], Z[None, :]), walls)   # starboard
    mesh.patch(at(X[-1], Y[:, None], Z[None, :]), walls)   # front
    mesh.patch(at(X[0], Y[:, None], Z[None, :]), walls, flip=True)
    mesh.patch(at(X[:, None], Y[None, :], Z[-1]), lambda i, j: ROOF)                # roof
    mesh.patch(at(X[:, None], Y[None, :], Z[0]), lambda i, j: CABIN, flip=True)     # floor


def barrel_mesh(radius_m: float = 0.45, height_m: float = 1.2, sides: int = 14) -> np.ndarray:
    """A barrel lying in the water along x (half submerged: centre on the waterline)."""
    angles = np.linspace(0.0, 2 * np.pi, sides + 1)
    h = 0.5 * height_m
    ring = np.stack([np.zeros_like(angles), np.cos(angles), np.sin(angles)], 1) * radius_m
    mesh = _Mesh()
    stave = np.stack([ring + (-h, 0, 0), ring + (h, 0, 0)])                 # (2, sides+1, 3)
    mesh.patch(stave, lambda i, j: HOOP if j % 7 == 0 else WOOD, flip=True)
    hub = np.zeros((sides + 1, 3))
    mesh.patch(np.stack([ring + (h, 0, 0), hub + (h, 0, 0)]), lambda i, j: WOOD, flip=True)
    mesh.patch(np.stack([ring + (-h, 0, 0), hub + (-h, 0, 0)]), lambda i, j: WOOD)
    return mesh.array()


SHAPES = {"boat": boat_mesh, "barrel": barrel_mesh}
"""Mesh builders by :class:`riverflow.components.props.Prop` shape."""
