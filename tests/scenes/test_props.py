"""Prop meshes (issue 12, item 5: a boat mesh that reads as a boat): closed, consistently
wound surfaces with outward normals, sized from the Boat's length, beam and height, floating
with the waterline at z = 0; the hull's bands, deck and windows coloured as such."""
from __future__ import annotations

import numpy as np
import pytest

from riverflow.scenes import props
from riverflow.scenes.props import SHAPES, barrel_mesh, boat_mesh

SIZES = [(8.0, 3.0, 1.2), (5.0, 2.2, 0.9), (24.0, 6.0, 2.5)]


def _triangles(rows: np.ndarray) -> np.ndarray:
    """(T, 3) vertex ids of the triangles, vertices merged on a 10 µm lattice."""
    key = np.round(rows[:, :3].astype(np.float64) / 1e-5).astype(np.int64)
    _, ids = np.unique(key, axis=0, return_inverse=True)
    return ids.reshape(-1, 3)


def _signed_volume(rows: np.ndarray) -> float:
    p = rows[:, :3].astype(np.float64).reshape(-1, 3, 3)
    return float(np.einsum("ij,ij->i", p[:, 0], np.cross(p[:, 1], p[:, 2])).sum() / 6.0)


@pytest.mark.parametrize("make", [lambda: boat_mesh(*SIZES[0]), lambda: boat_mesh(*SIZES[2]),
                                  lambda: barrel_mesh(0.45, 1.2)])
def test_meshes_are_closed_and_consistently_wound(make):
    rows = make()
    assert rows.dtype == np.float32 and rows.shape[1] == 10 and len(rows) % 3 == 0
    assert np.isfinite(rows).all()
    tri = _triangles(rows)
    assert (tri[:, 0] != tri[:, 1]).all() and (tri[:, 1] != tri[:, 2]).all() \
        and (tri[:, 2] != tri[:, 0]).all()                   # no degenerate triangle
    directed = np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]])
    edges, counts = np.unique(directed, axis=0, return_counts=True)
    assert (counts == 1).all()                               # no edge twice the same way
    reverse = {tuple(e) for e in edges[:, ::-1].tolist()}
    assert reverse == {tuple(e) for e in edges.tolist()}     # every edge once each way: closed
    assert _signed_volume(rows) > 0                          # wound counter-clockwise outside


@pytest.mark.parametrize("make", [lambda: boat_mesh(*SIZES[0]), lambda: barrel_mesh()])
def test_normals_are_unit_and_agree_with_the_winding(make):
    rows = make()
    n = rows[:, 3:6].astype(np.float64)
    assert np.allclose(np.linalg.norm(n, axis=1), 1.0, atol=1e-5)
    p = rows[:, :3].astype(np.float64).reshape(-1, 3, 3)
    face = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    face /= np.linalg.norm(face, axis=1, keepdims=True)
    cos = np.einsum("tij,tj->ti", n.reshape(-1, 3, 3), face)
    assert cos.min() > 0.3                  # smooth normals lean, but never across the face


@pytest.mark.parametrize("length, beam, height", SIZES)
def test_boat_has_the_boats_dimensions_and_floats_at_its_waterline(length, beam, height):
    rows = boat_mesh(length, beam, height)
    p = rows[:, :3].astype(np.float64)
    assert p[:, 0].min() == pytest.approx(-0.5 * length, abs=1e-5)     # transom
    assert p[:, 0].max() == pytest.approx(0.5 * length, abs=1e-5)      # stem head
    assert np.abs(p[:, 1]).max() == pytest.approx(0.5 * beam, rel=1e-3)
    colour = [tuple(c) for c in rows[:, 6:9].astype(np.float64).round(6).tolist()]
    hull = np.array([c not in {props.CABIN, props.ROOF, props.GLASS} for c in colour])
    side = hull & np.array([c != props.DECK for c in colour])
    mid = side & (np.abs(p[:, 0]) < 0.05 * length)
    assert p[mid, 2].max() - p[mid, 2].min() == pytest.approx(height, rel=0.03)  # keel to sheer
    # the waterline: the hull crosses z = 0 along most of its length and beam
    water = hull & (np.abs(p[:, 2]) < 1e-6)
    assert np.ptp(p[water, 0]) > 0.8 * length
    assert 0.7 * beam < np.ptp(p[water, 1]) <= beam
    assert p[mid, 2].min() == pytest.approx(-props.DRAFT * height, rel=0.02)  # keel below it
    # the bow is pointed (the beam goes to 0 at the stem), the transom is flat and wide
    bow = p[p[:, 0] > 0.5 * length - 0.02 * length]
    assert np.abs(bow[:, 1]).max() < 0.1 * beam
    stern = p[np.abs(p[:, 0] + 0.5 * length) < 1e-6]
    assert np.ptp(stern[:, 1]) > 0.8 * beam


def test_boat_colours_the_hull_bands_the_deck_and_the_windows():
    rows = boat_mesh(*SIZES[0])
    p, colour, gloss = rows[:, :3], rows[:, 6:9].astype(np.float64), rows[:, 9]
    tri_z = p[:, 2].reshape(-1, 3).mean(axis=1)
    tri_colour = [tuple(c) for c in colour[::3].round(6).tolist()]

    def has(c):
        return np.array([t == tuple(np.round(c, 6)) for t in tri_colour])

    assert (tri_z[has(props.ANTIFOULING)] < 0).all()         # below the waterline
    assert (tri_z[has(props.TOPSIDES)] > 0).all()
    assert has(props.BOOT).any() and has(props.DECK).any() and has(props.RUBBING).any()
    glass = has(props.GLASS)
    assert glass.sum() >= 16                                  # windscreen and side windows
    assert (gloss.reshape(-1, 3)[glass] > 0.8).all()          # glass mirrors the sky
    deck_z = p[:, 2].reshape(-1, 3)[has(props.DECK)]
    assert (tri_z[glass] > deck_z.max()).all()                # in the wheelhouse, above deck


def test_every_shape_builds_and_bad_sizes_raise():
    assert set(SHAPES) == {"boat", "barrel"}
    with pytest.raises(ValueError, match="positive"):
        boat_mesh(0.0, 3.0, 1.2)
