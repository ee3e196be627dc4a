"""The centre-line projection kernel against its plain numpy twin (the vectorised code it
replaced in WaterSurface's nearest-point queries): the same numbers bit for bit."""
from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from riverflow.kernels.centre_line import CentreSamples, project_to_centre


def _project_twin(samples: CentreSamples, k: np.ndarray, p: np.ndarray):
    """Plain numpy twin of project_to_centre."""
    xy, levels, widths, branch = samples
    n = len(xy)
    best_d = np.full(len(p), np.inf)
    level = np.full(len(p), np.nan)
    width = np.full(len(p), np.nan)
    for a_off in (-1, 0):
        a = np.clip(k + a_off, 0, max(n - 2, 0))
        b = np.minimum(a + 1, n - 1)
        same = branch[a] == branch[b]
        sa, sb = xy[a], xy[b]
        ab = sb - sa
        ab2 = np.maximum(np.einsum("ij,ij->i", ab, ab), 1e-12)
        t = np.clip(np.einsum("ij,ij->i", p - sa, ab) / ab2, 0, 1)
        t = np.where(same, t, np.where(a == k, 0.0, 1.0))
        d = np.hypot(*(sa + t[:, None] * ab - p).T)
        better = d < best_d
        best_d = np.where(better, d, best_d)
        level = np.where(better, (1 - t) * levels[a] + t * levels[b], level)
        width = np.where(better, (1 - t) * widths[a] + t * widths[b], width)
    return best_d, level, width


def test_the_projection_kernel_gives_its_numpy_twins_numbers_bit_for_bit():
    rng = np.random.default_rng(3)
    lines, levels, widths, branch = [], [], [], []
    for b in range(3):                          # three wiggly branches, one of 2 samples
        m = 2 if b == 1 else 60
        x = np.cumsum(rng.uniform(2.0, 9.0, m)) + 40.0 * b
        y = 30.0 * np.sin(x / 25.0 + b) + 50.0 * b
        lines.append(np.c_[x, y])
        levels.append(100.0 - 0.01 * x - b)
        widths.append(rng.uniform(3.0, 30.0, m))
        branch.append(np.full(m, b))
    samples = CentreSamples(np.ascontiguousarray(np.vstack(lines)), np.concatenate(levels),
                            np.concatenate(widths), np.concatenate(branch).astype(np.int64))
    xy = samples.xy
    p = np.vstack([rng.uniform(xy.min(0) - 50.0, xy.max(0) + 50.0, (3000, 2)),
                   xy,                                       # on the samples, branch ends too
                   0.5 * (xy[1:] + xy[:-1])])                # mid-segment (and across ends)
    _, k = cKDTree(xy).query(p)
    got = [np.empty(len(p)) for _ in range(3)]
    project_to_centre(samples, k.astype(np.int64), p, *got)
    for a, b in zip(got, _project_twin(samples, k, p)):
        assert np.array_equal(a, b)
    assert np.all(np.isfinite(got[0])) and got[0][3000:3000 + len(xy)].max() == 0.0
