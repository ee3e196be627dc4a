"""Height sources (riverflow.scenes.sources) and the hashed value noise under FbmSource
(riverflow.kernels.noise), with the noise's plain-numpy twin."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from riverflow.kernels import noise
from riverflow.scenes import sources
from riverflow.scenes.sources import (ArraySource, CallableSource, FbmSource, HeightSource,
                                      as_height_source)

DEFAULT_OCTAVES = ((700.0, 6.0), (220.0, 2.5), (70.0, 0.8))
SEED = np.uint64(12345)

# -- plain-numpy twin of riverflow.kernels.noise --------------------------------------------

_U = np.uint64
_SQRT3 = math.sqrt(3.0)


def twin_mix64(z: np.ndarray) -> np.ndarray:
    """splitmix64 finaliser on uint64 arrays (wrapping)."""
    with np.errstate(over="ignore"):
        z = (z ^ (z >> _U(30))) * _U(0xBF58476D1CE4E5B9)
        z = (z ^ (z >> _U(27))) * _U(0x94D049BB133111EB)
        return z ^ (z >> _U(31))


def twin_hash(ix: np.ndarray, iy: np.ndarray, seed: int, octave: int) -> np.ndarray:
    """uint64 hash of lattice nodes (ix, iy) int64 of octave ``octave`` of ``seed``."""
    with np.errstate(over="ignore"):
        state = np.array([int(seed) % 2 ** 64], _U) + _U(octave + 1) * _U(0x9E3779B97F4A7C15)
        key = twin_mix64(state)
        row = twin_mix64(key ^ (np.asarray(iy, np.int64).astype(_U) * _U(0xC2B2AE3D27D4EB4F)))
        return twin_mix64(row ^ (np.asarray(ix, np.int64).astype(_U) * _U(0x165667B19E3779F9)))


def twin_lattice_values(ix, iy, seed, octave) -> np.ndarray:
    """√3 · (sum of the hash's four 16-bit uniforms (c + ½) / 2¹⁶, minus 2)."""
    h = twin_hash(ix, iy, seed, octave)
    chunks = [(h >> _U(16 * k)) & _U(0xFFFF) for k in range(4)]
    uniforms = sum((c.astype(np.float64) + 0.5) / 65536.0 for c in chunks)
    return _SQRT3 * (uniforms - 2.0)


def twin_bspline(f: np.ndarray) -> list[np.ndarray]:
    return [(1 - f) ** 3 / 6, (3 * f ** 3 - 6 * f ** 2 + 4) / 6,
            (-3 * f ** 3 + 3 * f ** 2 + 3 * f + 1) / 6, f ** 3 / 6]


def twin_value_noise(u: np.ndarray, v: np.ndarray, seed: int, octave: int) -> np.ndarray:
    """Cubic B-spline interpolation of the lattice values at lattice coordinates (u, v)."""
    iu, iv = np.floor(u), np.floor(v)
    wx, wy = twin_bspline(u - iu), twin_bspline(v - iv)
    iu, iv = iu.astype(np.int64), iv.astype(np.int64)
    total = np.zeros(np.shape(u))
    for j in range(4):
        for i in range(4):
            total += wx[i] * wy[j] * twin_lattice_values(iu - 1 + i, iv - 1 + j, seed, octave)
    return total


def twin_fbm(x: np.ndarray, y: np.ndarray, seed: int, octaves) -> np.ndarray:
    total = np.zeros(np.shape(x))
    for k, (scale, amplitude) in enumerate(octaves):
        inv = 1.0 / scale
        total += amplitude * twin_value_noise(x * inv, y * inv, seed, k)
    return total


def python_hash(ix: int, iy: int, seed: int, octave: int) -> int:
    """The hash in Python integers (no fixed-width arithmetic at all)."""
    m = 2 ** 64

    def mix(z: int) -> int:
        z = ((z ^ (z >> 30)) * 0xBF58476D1CE4E5B9) % m
        z = ((z ^ (z >> 27)) * 0x94D049BB133111EB) % m
        return z ^ (z >> 31)

    key = mix((seed + (octave + 1) * 0x9E3779B97F4A7C15) % m)
    row = mix(key ^ ((iy % m) * 0xC2B2AE3D27D4EB4F % m))
    return mix(row ^ ((ix % m) * 0x165667B19E3779F9 % m))


# -- noise kernels --------------------------------------------------------------------------

EXTREME = np.array([0, 1, -1, 2, -2, 2 ** 31, -(2 ** 31), 2 ** 53 + 1, 2 ** 62 + 12345,
                    -(2 ** 63), 2 ** 63 - 1, 987654321987], np.int64)


@pytest.mark.parametrize("seed", [0, 7, -3, 2 ** 64 - 1, 2 ** 63 + 5])
def test_hash_is_exact_uint64_arithmetic(seed):
    """Products of 64-bit values: any detour through float64 would lose low bits."""
    iy = EXTREME[::-1].copy()
    out = np.empty(len(EXTREME), np.uint64)
    noise.lattice_hash(EXTREME, iy, np.uint64(seed % 2 ** 64), 3, out)
    expected = [python_hash(int(a), int(b), seed % 2 ** 64, 3) for a, b in zip(EXTREME, iy)]
    assert [int(h) for h in out] == expected
    assert np.array_equal(out, twin_hash(EXTREME, iy, seed, 3))


def test_lattice_values_twin_and_distribution(rng):
    ix = rng.integers(-(2 ** 40), 2 ** 40, 200_000)
    iy = rng.integers(-(2 ** 40), 2 ** 40, 200_000)
    out = np.empty(len(ix))
    noise.lattice_values(ix, iy, SEED, 1, out)
    np.testing.assert_allclose(out, twin_lattice_values(ix, iy, SEED, 1), rtol=0, atol=1e-12)
    assert abs(out.mean()) < 0.02
    assert abs(out.var() - noise.LATTICE_VARIANCE) < 0.02
    assert np.abs(out).max() <= noise.LATTICE_MAX
    assert abs(np.mean(out ** 4) - 2.7) < 0.05  # Irwin–Hall n = 4: excess kurtosis -6/(5n)


def test_value_noise_matches_twin(rng):
    u = np.concatenate([rng.uniform(-50, 50, 5000), rng.uniform(-3e4, 3e4, 5000),
                        np.arange(-5.0, 5.0, 0.25)])
    v = np.concatenate([rng.uniform(-50, 50, 5000), rng.uniform(-3e4, 3e4, 5000),
                        np.arange(-5.0, 5.0, 0.25)[::-1]])
    out = np.empty(len(u))
    noise.value_noise(u, v, SEED, 2, out)
    np.testing.assert_allclose(out, twin_value_noise(u, v, SEED, 2), rtol=0, atol=1e-12)


def test_fbm_matches_twin(rng):
    x = np.concatenate([rng.uniform(-3000, 3000, 4000), rng.uniform(-2e6, 2e6, 4000)])
    y = np.concatenate([rng.uniform(-3000, 3000, 4000), rng.uniform(-2e6, 2e6, 4000)])
    out = FbmSource(int(SEED), DEFAULT_OCTAVES, offset_m=0.0).heights(x, y)
    np.testing.assert_allclose(out, twin_fbm(x, y, int(SEED), DEFAULT_OCTAVES), rtol=0, atol=1e-12)


def test_noise_variance_constant():
    """NOISE_VARIANCE rests on ∫B₃² = 151/315: the mean over the fraction of Σ wᵢ²."""
    f = (np.arange(200_000) + 0.5) / 200_000
    assert abs(np.mean(sum(w ** 2 for w in twin_bspline(f))) - 151 / 315) < 1e-9


# -- pointwise: the same point gives the same bits in any batch ------------------------------


def _tile_grid(x0_m: float, y0_m: float, n: int = 64, cell_m: float = 4.0):
    axis = np.arange(n + 1) * cell_m
    return np.meshgrid(x0_m + axis, y0_m + axis)


def _assert_pointwise(source: HeightSource, x0_m: float, y0_m: float, rng) -> None:
    """Border of two neighbouring tiles, alone and in both grids; shuffles, slices of every
    length, 2-D and transposed (non-contiguous) inputs, scalars."""
    ax, ay = _tile_grid(x0_m, y0_m)
    bx, by = _tile_grid(x0_m + 256.0, y0_m)
    assert np.array_equal(ax[:, -1], bx[:, 0])
    border = source.heights(ax[:, -1].copy(), ay[:, -1].copy())
    assert np.array_equal(source.heights(ax, ay)[:, -1], border)
    assert np.array_equal(source.heights(bx, by)[:, 0], border)
    assert np.array_equal(source.heights(bx.T, by.T)[0, :], border)
    assert np.array_equal(source.heights(ax[::3, -1], ay[::3, -1]), border[::3])
    assert source.heights(float(ax[5, -1]), float(ay[5, -1])) == border[5]

    x = np.concatenate([ax.ravel(), bx.ravel()])
    y = np.concatenate([ay.ravel(), by.ravel()])
    full = source.heights(x, y)
    perm = rng.permutation(len(x))
    assert np.array_equal(source.heights(x[perm], y[perm]), full[perm])
    for length in (1, 2, 3, 4, 5, 7, 8, 9, 15, 16, 17, 31, 33, 100):
        start = int(rng.integers(0, len(x) - length))
        part = source.heights(x[start:start + length], y[start:start + length])
        assert np.array_equal(part, full[start:start + length]), length
    assert np.array_equal(source.heights(x.reshape(-1, 65), y.reshape(-1, 65)).ravel(), full)


@pytest.mark.parametrize("x0_m, y0_m", [(-128.0, 32.0), (999_936.0, -1_000_448.0)])
def test_fbm_is_pointwise(x0_m, y0_m, rng):
    _assert_pointwise(FbmSource(3), x0_m, y0_m, rng)


def test_array_source_is_pointwise(rng):
    source = ArraySource(rng.normal(size=(300, 400)).astype(np.float32), (-400.0, -300.0), 4.0)
    _assert_pointwise(source, -400.0, -300.0, rng)
    _assert_pointwise(source, 1000.0, 10.0, rng)  # partly outside: clamped


def test_callable_source_is_pointwise(rng):
    source = CallableSource(lambda x, y: np.sin(x / 90.0) * np.cos(y / 70.0) * 5.0, (-5.0, 5.0))
    _assert_pointwise(source, 100.0, -7.5, rng)


# -- fbm statistics and smoothness ----------------------------------------------------------


def test_fbm_statistics_and_range(rng):
    source = FbmSource(11)
    n = 100_000
    x = rng.uniform(-1e6, 1e6, n)
    y = rng.uniform(-1e6, 1e6, n)
    x[:1000] = 1e6 - rng.uniform(0, 500, 1000)
    y[1000:2000] = -1e6 + rng.uniform(0, 500, 1000)
    z = source.heights(x, y)
    lo, hi = source.z_range_m
    assert np.isfinite(z).all() and lo <= z.min() and z.max() <= hi
    assert abs(z.mean()) < 0.05 * source.std_m
    assert abs(z.std() / source.std_m - 1.0) < 0.03
    assert abs(source.std_m - 3.139) < 0.01


def test_fbm_offset_and_range():
    source = FbmSource(1, ((100.0, 2.0), (10.0, -1.0)), offset_m=40.0)
    assert source.z_range_m == pytest.approx((40.0 - 3.0 * noise.LATTICE_MAX, 40.0 + 3.0 * noise.LATTICE_MAX))
    x = np.linspace(-500, 500, 2001)
    z = source.heights(x, 0.5 * x)
    assert source.z_range_m[0] <= z.min() and z.max() <= source.z_range_m[1]
    no_octaves = FbmSource(1, (), offset_m=-2.0)
    assert np.array_equal(no_octaves.heights(x, x), np.full_like(x, -2.0))
    assert no_octaves.z_range_m == (-2.0, -2.0)


@pytest.mark.parametrize("centre_m", [0.0, 2e6, -2e6])
def test_fbm_is_smooth(centre_m, rng):
    """First and second differences within the bounds of a C² spline (Σ|w'| ≤ 1.5,
    Σ|w''| ≤ 4), at points straddling the lattice lines of every octave."""
    source = FbmSource(5)
    delta = 0.01
    grad = sum(1.5 * noise.LATTICE_MAX * abs(a) / s for s, a in DEFAULT_OCTAVES)
    curv = sum(4.0 * noise.LATTICE_MAX * abs(a) / s ** 2 for s, a in DEFAULT_OCTAVES)
    lines = np.concatenate([s * np.round((centre_m + rng.uniform(-5e3, 5e3, 1000)) / s)
                            for s, _ in DEFAULT_OCTAVES])
    across = lines + rng.uniform(-delta, delta, len(lines))
    along = centre_m + rng.uniform(-5e3, 5e3, len(lines))
    for x, y, dx, dy in ((across, along, delta, 0.0), (along, across, 0.0, delta)):
        h0 = source.heights(x, y)
        hp = source.heights(x + dx, y + dy)
        hm = source.heights(x - dx, y - dy)
        assert np.abs(hp - h0).max() <= grad * delta * 1.001
        assert np.abs(hp - 2 * h0 + hm).max() <= curv * delta ** 2 * 1.01 + 1e-12


def test_seeds_differ_and_wrap(rng):
    x = rng.uniform(-1e5, 1e5, 20_000)
    y = rng.uniform(-1e5, 1e5, 20_000)
    a, b = FbmSource(0).heights(x, y), FbmSource(1).heights(x, y)
    assert np.mean(a == b) < 1e-3
    assert abs(np.corrcoef(a, b)[0, 1]) < 0.05
    assert np.array_equal(FbmSource(-1).heights(x, y), FbmSource(2 ** 64 - 1).heights(x, y))


def test_fbm_bad_input():
    with pytest.raises(TypeError, match="seed"):
        FbmSource(1.5)
    with pytest.raises(ValueError, match="octave 1 feature size"):
        FbmSource(0, ((10.0, 1.0), (0.0, 1.0)))
    with pytest.raises(ValueError, match="finite"):
        FbmSource(0, ((math.inf, 1.0),))
    with pytest.raises(ValueError, match=r"1 of 3 points .*nan"):
        FbmSource(0).heights([0.0, np.nan, 1.0], 0.0)


# -- ArraySource ----------------------------------------------------------------------------

ORIGIN = (-100.0, 250.0)
CELL = 4.0


@pytest.fixture
def grid(rng) -> np.ndarray:
    return rng.normal(20.0, 5.0, size=(40, 60))


def _node_xy(ny: int, nx: int):
    return np.meshgrid(ORIGIN[0] + CELL * np.arange(nx), ORIGIN[1] + CELL * np.arange(ny))


def test_array_exact_at_nodes_and_bilinear_between(grid, rng):
    source = ArraySource(grid, ORIGIN, CELL)
    assert source.cell_m == CELL and source.bounds_m == (-100.0, 250.0, 136.0, 406.0)
    assert np.array_equal(source.heights(*_node_xy(*grid.shape)), grid)
    i, j = rng.integers(0, 59, 2000), rng.integers(0, 39, 2000)
    u, v = rng.uniform(0, 1, 2000), rng.uniform(0, 1, 2000)
    expected = ((1 - u) * (1 - v) * grid[j, i] + u * (1 - v) * grid[j, i + 1]
                + (1 - u) * v * grid[j + 1, i] + u * v * grid[j + 1, i + 1])
    z = source.heights(ORIGIN[0] + CELL * (i + u), ORIGIN[1] + CELL * (j + v))
    np.testing.assert_allclose(z, expected, rtol=0, atol=1e-10)
    lo, hi = source.z_range_m
    assert lo <= grid.min() and grid.max() <= hi and hi - lo < np.ptp(grid) + 1e-6


def test_array_clamps_outside(grid, rng):
    source = ArraySource(grid, ORIGIN, CELL)
    x0, y0, x1, y1 = source.bounds_m
    x = rng.uniform(x0 - 1e5, x1 + 1e5, 3000)
    y = rng.uniform(y0 - 1e5, y1 + 1e5, 3000)
    assert np.array_equal(source.heights(x, y), source.heights(np.clip(x, x0, x1), np.clip(y, y0, y1)))
    corners = source.heights([x0 - 10, x1 + 10, x0 - 1e9, x1 + 1e9], [y0 - 10, y0 - 10, y1 + 1e9, y1 + 7])
    assert np.array_equal(corners, [grid[0, 0], grid[0, -1], grid[-1, 0], grid[-1, -1]])


def test_array_nodata_and_nan_never_returned(grid):
    holed = grid.copy()
    holed[3, 4] = -9999.0
    holed[10, 10:13] = np.nan
    source = ArraySource(holed, ORIGIN, CELL, nodata=-9999.0)
    valid = holed[np.isfinite(holed) & (holed != -9999.0)]
    assert source.fill_m == valid.min()
    z = source.heights(*_node_xy(*grid.shape))
    assert np.isfinite(z).all() and z[3, 4] == valid.min() and np.all(z[10, 10:13] == valid.min())
    assert source.z_range_m[0] <= valid.min() and valid.max() <= source.z_range_m[1]
    with pytest.raises(ValueError, match="no valid cell"):
        ArraySource(np.full((3, 3), -9999.0), ORIGIN, CELL, nodata=-9999.0)


def test_array_small_shapes():
    single = ArraySource(np.array([[7.0]]), (0.0, 0.0), 1.0)
    assert np.array_equal(single.heights([-5.0, 0.0, 3.0], [1.0, 0.0, -2.0]), [7.0, 7.0, 7.0])
    row = ArraySource(np.array([[1.0, 3.0]]), (0.0, 0.0), 2.0)
    assert np.array_equal(row.heights([1.0, 5.0], [9.0, -9.0]), [2.0, 3.0])
    assert ArraySource(np.ones((2, 2), np.int16), (0.0, 0.0), 1.0).heights(0.5, 0.5) == 1.0


def test_memmap_equals_in_memory(grid, tmp_path, rng):
    path = tmp_path / "heights.npy"
    np.save(path, grid.astype(np.float32))
    in_memory = ArraySource(grid.astype(np.float32), ORIGIN, CELL)
    x = rng.uniform(-150, 200, 5000)
    y = rng.uniform(200, 450, 5000)
    for source in (ArraySource(path, ORIGIN, CELL), ArraySource(str(path), ORIGIN, CELL),
                   ArraySource(np.load(path, mmap_mode="r"), ORIGIN, CELL)):
        assert isinstance(source.array, np.memmap)
        assert np.array_equal(source.heights(x, y), in_memory.heights(x, y))
        assert source.z_range_m == in_memory.z_range_m


class _Recording(np.ndarray):
    """An ndarray view that logs every index it is read with."""

    log: list = []

    def __getitem__(self, key):
        _Recording.log.append(key)
        return super().__getitem__(key)


def _cells(key, shape) -> int:
    """How many cells an index of a 2-D array selects."""
    assert isinstance(key, tuple) and len(key) == 2 and all(isinstance(k, slice) for k in key), key
    return len(range(*key[0].indices(shape[0]))) * len(range(*key[1].indices(shape[1])))


def test_array_reads_only_the_window_of_a_large_memmap(tmp_path, monkeypatch):
    shape = (1200, 1500)
    path = tmp_path / "large.npy"
    ramp = np.add.outer(np.arange(shape[0]) * 0.01, np.arange(shape[1]) * 0.02).astype(np.float32)
    np.save(path, ramp)
    monkeypatch.setattr(_Recording, "log", [])
    monkeypatch.setattr(sources, "FULL_SCAN_CELLS", 10_000)
    recorded = np.load(path, mmap_mode="r").view(_Recording)
    source = ArraySource(recorded, (0.0, 0.0), 2.0)

    scan = _Recording.log[0]
    assert scan[0].step == scan[1].step == math.ceil(math.sqrt(ramp.size / 10_000))
    assert _cells(scan, shape) <= 10_000
    lo, hi = source.z_range_m
    assert lo <= ramp.min() and ramp.max() <= hi

    _Recording.log.clear()
    tx, ty = _tile_grid(1000.0, 1400.0, n=16, cell_m=2.0)
    z = source.heights(tx, ty)
    assert len(_Recording.log) == 1
    assert _cells(_Recording.log[0], shape) <= 18 * 18
    assert np.array_equal(z, ArraySource(ramp, (0.0, 0.0), 2.0).heights(tx, ty))


def test_array_bad_input(grid, tmp_path):
    with pytest.raises(ValueError, match=r"2-D .*\(40, 60, 1\)"):
        ArraySource(grid[..., None], ORIGIN, CELL)
    with pytest.raises(ValueError, match="cell_m must be > 0"):
        ArraySource(grid, ORIGIN, 0.0)
    with pytest.raises(ValueError, match="cell_m must be finite"):
        ArraySource(grid, ORIGIN, math.nan)
    with pytest.raises(ValueError, match=r"origin_m\[1\] must be finite"):
        ArraySource(grid, (0.0, math.inf), CELL)
    with pytest.raises(TypeError, match="origin_m"):
        ArraySource(grid, 5.0, CELL)
    missing = tmp_path / "nowhere" / "dem.npy"
    with pytest.raises(FileNotFoundError, match="nowhere"):
        ArraySource(missing, ORIGIN, CELL)
    with pytest.raises(TypeError, match="real numbers"):
        ArraySource(grid.astype(complex), ORIGIN, CELL)
    with pytest.raises(ValueError, match="empty"):
        ArraySource(np.zeros((0, 4)), ORIGIN, CELL)


# -- CallableSource -------------------------------------------------------------------------


def test_callable_values_and_estimated_range():
    def bowl(x, y):
        return 1e-4 * (x ** 2 + y ** 2)

    source = CallableSource(bowl, extent_m=(-100.0, -100.0, 100.0, 100.0))
    assert source.name == "bowl"
    assert np.array_equal(source.heights([[3.0, 4.0]], [[4.0, 0.0]]), 1e-4 * np.array([[25.0, 16.0]]))
    lo, hi = source.z_range_m
    assert lo < 0.0 and hi > bowl(200.0, 200.0)
    default = CallableSource(bowl)
    assert default.z_range_m[1] > bowl(4096.0, 4096.0)
    assert CallableSource(lambda x, y: 3.0, (3.0, 3.0)).heights(np.zeros((2, 3)), 0.0).shape == (2, 3)


def test_callable_errors():
    with pytest.raises(ValueError, match=r"returned shape \(1,\) for points of shape \(4,\)"):
        CallableSource(lambda x, y: x[:1], (0.0, 1.0)).heights(np.arange(4.0), 0.0)

    def holes(x, y):
        return np.where(x > 1.5, np.nan, x)

    with pytest.raises(ValueError, match=r"'holes'.* 2 non-finite heights of 4 points.*\(2\.0, 0\.0\)"):
        CallableSource(holes, (0.0, 3.0)).heights(np.arange(4.0), 0.0)
    with pytest.raises(ValueError, match="non-finite heights"):
        CallableSource(holes)  # the estimate samples the function too
    with pytest.raises(ValueError, match="lo must not exceed hi"):
        CallableSource(holes, (2.0, 1.0))
    with pytest.raises(TypeError, match="callable"):
        CallableSource(3.0)


# -- as_height_source -----------------------------------------------------------------------


def test_as_height_source_dispatch(grid, tmp_path):
    assert as_height_source(None) is None
    fbm = FbmSource(0)
    assert as_height_source(fbm) is fbm
    assert isinstance(as_height_source(lambda x, y: 0 * x), CallableSource)
    array = as_height_source(grid, origin_m=ORIGIN, cell_m=CELL)
    assert isinstance(array, ArraySource) and array.array is grid
    path = tmp_path / "h.npy"
    np.save(path, grid)
    for p in (path, str(path)):
        loaded = as_height_source(p, origin_m=ORIGIN, cell_m=CELL)
        assert isinstance(loaded.array, np.memmap) and loaded.path == Path(path)
    memmap = np.load(path, mmap_mode="r")
    assert as_height_source(memmap, origin_m=ORIGIN, cell_m=CELL).array is memmap
    window = as_height_source(grid[:33, :33], origin_m=ORIGIN, cell_m=CELL)  # same nodes
    assert isinstance(window, ArraySource) and window.bounds_m == (-100.0, 250.0, 28.0, 378.0)
    xy = np.array([[-98.3, 251.7], [-10.0, 300.0], [20.1, 377.9]])
    np.testing.assert_allclose(window.heights(xy[:, 0], xy[:, 1]),
                               array.heights(xy[:, 0], xy[:, 1]), atol=1e-9)


def test_as_height_source_errors(grid):
    with pytest.raises(ValueError, match="origin_m and cell_m"):
        as_height_source(grid)
    with pytest.raises(ValueError, match="cell_m"):
        as_height_source("dem.npy", origin_m=ORIGIN)
    # rasters go to riverflow.scenes.rasters: a missing file, or the missing extra, is named
    with pytest.raises((FileNotFoundError, ImportError), match=r"dem.tif|riverflow\[gis\]"):
        as_height_source("dem.tif", origin_m=ORIGIN, cell_m=CELL)
    with pytest.raises((FileNotFoundError, ImportError), match=r"DEM.TIFF|riverflow\[gis\]"):
        as_height_source(Path("DEM.TIFF"))
    with pytest.raises(ValueError, match="cell_m"):
        as_height_source("dem.png", origin_m=ORIGIN)
    with pytest.raises(ValueError, match="unsupported suffix '.bmp'"):
        as_height_source("dem.bmp", origin_m=ORIGIN, cell_m=CELL)
    with pytest.raises(TypeError, match="accepted"):
        as_height_source([[1.0, 2.0], [3.0, 4.0]])
    with pytest.raises(TypeError, match="accepted"):
        as_height_source(5.0)
