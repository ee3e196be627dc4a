"""Height sources: terrains sampled point by point, so a streamed map needs no whole-map array.

A tile samples its source at the points it needs; the tiles on both sides of a border sample
the same border points. Every source here is pointwise: the height at (x, y) is bit-identical
whatever batch, order or array shape the point comes in.

- :class:`FbmSource`: seeded hashed value-noise fBm (:mod:`riverflow.kernels.noise`), infinite.
- :class:`CallableSource`: any pointwise function ``fn(x_m, y_m) -> z_m``.
- :class:`ArraySource`: a heightfield array (in memory, ``np.memmap`` or a ``.npy`` file),
  read one window per batch, so a raster larger than memory works with small tiles.
- :func:`as_height_source`: turns what a user passes as "terrain" into a source (GeoTIFF and
  16-bit PNG files through :mod:`riverflow.scenes.rasters`).
"""
from __future__ import annotations

import math
import operator
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np

from riverflow.kernels.noise import LATTICE_MAX, NOISE_VARIANCE, fbm

FULL_SCAN_CELLS = 1 << 24
"""Arrays up to this many cells (~16 M) are read whole once for their height range; larger
ones through a strided subsample of at most this many cells."""
SUBSAMPLE_MARGIN = 0.25
"""A subsampled height range is widened by this fraction of its span (plus
:data:`SUBSAMPLE_MARGIN_M`) on each side, for peaks and pits between the samples."""
SUBSAMPLE_MARGIN_M = 1.0
EXACT_MARGIN = 1e-9
"""A height range read from every value is widened by this fraction of (1 m + its largest
|z|) on each side, for the rounding of bilinear interpolation."""


def padded_range(lo: float, hi: float, stride: int) -> tuple[float, float, float]:
    """(z_min, z_max, lo) of a height range read as (``lo``, ``hi``) from every
    ``stride``-th row and column: widened by EXACT_MARGIN when every value was read, by
    SUBSAMPLE_MARGIN (+ SUBSAMPLE_MARGIN_M) when only a subsample was."""
    if stride == 1:
        pad = EXACT_MARGIN * (1.0 + max(abs(lo), abs(hi)))
    else:
        pad = SUBSAMPLE_MARGIN * (hi - lo) + SUBSAMPLE_MARGIN_M
    return lo - pad, hi + pad, lo


ESTIMATE_GRID = 129
"""A :class:`CallableSource` estimates its height range from ESTIMATE_GRID² samples."""
DEFAULT_ESTIMATE_EXTENT_M = (-4096.0, -4096.0, 4096.0, 4096.0)
"""(xmin, ymin, xmax, ymax) [m] sampled for a :class:`CallableSource`'s height range when it is
given neither ``z_range_m`` nor ``extent_m``."""
ESTIMATE_PAD = 0.5
"""The estimate's extent is widened by this fraction of its size on each side, and its height
range by this fraction of its span (plus ESTIMATE_PAD_M) on each side."""
ESTIMATE_PAD_M = 1.0
RASTER_SUFFIXES = (".tif", ".tiff", ".vrt", ".asc", ".img")
"""Elevation rasters read by rasterio (:class:`riverflow.scenes.rasters.RasterSource`)."""
_ROW_BLOCK_CELLS = 1 << 20


class HeightSource:
    """Terrain altitude [m] as a function of the horizontal position (x, y) [m].

    Subclasses implement :meth:`heights` and set the three attributes below.

    Contract of :meth:`heights`
        Pointwise and pure: the value at a point depends only on its coordinates, so the same
        (x, y) float64 pair gives bit-identical heights whatever batch, order or shape it is
        evaluated in (no reductions over the batch, no RNG state); the result is float64 and
        never NaN or infinite. Inputs must be finite (a ``ValueError`` names the first bad
        point otherwise).

    Attributes
        ``z_range_m``: (lo, hi) [m], bounds of every value :meth:`heights` can return (ray
        casts and frustum tests trust them; keep them conservative).
        ``cell_m``: native sample spacing [m] (arrays), or None when the source has no native
        resolution (functions, noise).
        ``bounds_m``: (xmin, ymin, xmax, ymax) [m] where the data is defined (arrays; outside
        it values are extended), or None when defined everywhere.
    """

    z_range_m: tuple[float, float]
    cell_m: float | None = None
    bounds_m: tuple[float, float, float, float] | None = None

    def heights(self, x_m, y_m) -> np.ndarray:
        """Altitudes [m] at x_m, y_m [m] (array-likes broadcast together): float64 of the
        broadcast shape."""
        raise NotImplementedError

    def __repr__(self) -> str:
        lo, hi = self.z_range_m
        return f"{type(self).__name__}(z {lo:.6g}…{hi:.6g} m)"


def _points(x_m, y_m, who: str) -> tuple[tuple[int, ...], np.ndarray, np.ndarray]:
    """Broadcast shape of x_m, y_m [m] and both flattened to contiguous float64; ValueError
    naming ``who`` and an example if a coordinate is not finite."""
    x, y = np.broadcast_arrays(np.asarray(x_m, dtype=np.float64), np.asarray(y_m, dtype=np.float64))
    shape = x.shape
    x = np.ascontiguousarray(x).reshape(-1)
    y = np.ascontiguousarray(y).reshape(-1)
    bad = ~(np.isfinite(x) & np.isfinite(y))
    if bad.any():
        k = int(np.flatnonzero(bad)[0])
        raise ValueError(f"{who}: {int(bad.sum())} of {x.size} points have non-finite coordinates, "
                         f"e.g. (x, y) = ({float(x[k])!r}, {float(y[k])!r}) m")
    return shape, x, y


def _finite_float(value, what: str) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise TypeError(f"{what} must be a number, got {value!r}") from None
    if not math.isfinite(v):
        raise ValueError(f"{what} must be finite, got {v!r}")
    return v


def _z_range(value, what: str) -> tuple[float, float]:
    """A validated (lo, hi) height range [m]."""
    try:
        lo, hi = value
    except (TypeError, ValueError):
        raise TypeError(f"{what} must be a pair (lo, hi) [m], got {value!r}") from None
    lo, hi = _finite_float(lo, f"{what}[0]"), _finite_float(hi, f"{what}[1]")
    if lo > hi:
        raise ValueError(f"{what} = ({lo}, {hi}): lo must not exceed hi")
    return lo, hi


class FbmSource(HeightSource):
    """Seeded fractal value noise: ``offset_m + Σₖ aₖ · noise(x / sₖ, y / sₖ, octave k)``.

    ``octaves`` are (feature size sₖ [m] > 0, amplitude aₖ [m]) pairs; octave k's lattice is
    hashed from (node, k, seed) (:func:`riverflow.kernels.noise.fbm`), so reordering octaves
    changes the terrain. Defined everywhere at any resolution; heights within
    ``offset_m ± LATTICE_MAX · Σ|aₖ|`` (``z_range_m``); averaged over the plane the standard
    deviation is ``std_m`` = √(NOISE_VARIANCE · Σ aₖ²) (≈ 3.14 m for the defaults). The seed
    is any int, taken modulo 2⁶⁴.
    """

    def __init__(self, seed: int,
                 octaves: Sequence[tuple[float, float]] = ((700.0, 6.0), (220.0, 2.5), (70.0, 0.8)),
                 offset_m: float = 0.0) -> None:
        try:
            self.seed = operator.index(seed)
        except TypeError:
            raise TypeError(f"FbmSource: seed must be an integer, got {seed!r}") from None
        self.octaves = tuple(self._octave(o, k) for k, o in enumerate(octaves))
        self.offset_m = _finite_float(offset_m, "FbmSource offset_m")
        self._seed_u64 = np.uint64(self.seed % 2 ** 64)
        self._scales_m = np.array([s for s, _ in self.octaves], dtype=np.float64)
        self._amplitudes_m = np.array([a for _, a in self.octaves], dtype=np.float64)
        reach = LATTICE_MAX * float(np.abs(self._amplitudes_m).sum())
        self.z_range_m = (self.offset_m - reach, self.offset_m + reach)

    @staticmethod
    def _octave(octave, k: int) -> tuple[float, float]:
        """Validated (feature size [m], amplitude [m]) of octave k."""
        try:
            scale, amplitude = octave
        except (TypeError, ValueError):
            raise TypeError(f"FbmSource octave {k} must be (feature size m, amplitude m), "
                            f"got {octave!r}") from None
        scale = _finite_float(scale, f"FbmSource octave {k} feature size [m]")
        if scale <= 0:
            raise ValueError(f"FbmSource octave {k} feature size must be > 0 m, got {scale}")
        return scale, _finite_float(amplitude, f"FbmSource octave {k} amplitude [m]")

    @property
    def std_m(self) -> float:
        """Standard deviation of the heights over the plane [m]."""
        return math.sqrt(NOISE_VARIANCE * float(np.square(self._amplitudes_m).sum()))

    def heights(self, x_m, y_m) -> np.ndarray:
        shape, x, y = _points(x_m, y_m, "FbmSource.heights")
        out = np.empty(x.size, dtype=np.float64)
        fbm(x, y, self._seed_u64, self._scales_m, self._amplitudes_m, out)
        out += self.offset_m
        return out.reshape(shape)

    def __repr__(self) -> str:
        return f"FbmSource(seed={self.seed}, octaves={self.octaves}, offset_m={self.offset_m})"


class CallableSource(HeightSource):
    """Heights from a function ``fn(x_m, y_m) -> z_m`` [m].

    ``fn`` receives two float64 arrays of the same shape (any shape, possibly 0-d or empty)
    and must return heights of that shape (a scalar is broadcast), all finite; otherwise
    :meth:`heights` raises a ValueError saying how many points failed and one coordinate.
    ``fn`` must be pointwise (the height at a point depends on that point only) for tiles to
    join without cracks; nothing can check that.

    ``z_range_m`` (lo, hi) [m] bounds ``fn``. When it is None it is *estimated*: ``fn`` is
    sampled on an ESTIMATE_GRID² grid over ``extent_m`` = (xmin, ymin, xmax, ymax) [m]
    (:data:`DEFAULT_ESTIMATE_EXTENT_M` when None) widened by ESTIMATE_PAD of its size on each
    side, and the sampled range is widened by ESTIMATE_PAD of its span plus ESTIMATE_PAD_M
    on each side. ``extent_m`` serves only this estimate; an estimate cannot see what ``fn``
    does outside or between the samples, so pass ``z_range_m`` when it is known.
    """

    def __init__(self, fn: Callable[[np.ndarray, np.ndarray], np.ndarray], z_range_m=None,
                 name: str | None = None, *, extent_m=None) -> None:
        if not callable(fn):
            raise TypeError(f"CallableSource: fn must be callable, got {type(fn).__name__}")
        self.fn = fn
        self.name = name or getattr(fn, "__name__", type(fn).__name__)
        if z_range_m is not None:
            self.z_range_m = _z_range(z_range_m, f"CallableSource {self.name!r} z_range_m")
        else:
            self.z_range_m = self._estimate_z_range(extent_m)

    def heights(self, x_m, y_m) -> np.ndarray:
        shape, x, y = _points(x_m, y_m, f"CallableSource {self.name!r}")
        x, y = x.reshape(shape), y.reshape(shape)
        z = np.asarray(self.fn(x, y), dtype=np.float64)
        if z.shape != shape:
            if z.ndim != 0:
                raise ValueError(f"CallableSource {self.name!r}: fn returned shape {z.shape} "
                                 f"for points of shape {shape}")
            z = np.full(shape, float(z))
        bad = ~np.isfinite(z)
        if bad.any():
            k = np.flatnonzero(bad.reshape(-1))[0]
            raise ValueError(f"CallableSource {self.name!r}: fn returned {int(bad.sum())} non-finite "
                             f"heights of {z.size} points, e.g. z = {float(z.reshape(-1)[k])!r} at (x, y) = "
                             f"({float(x.reshape(-1)[k])!r}, {float(y.reshape(-1)[k])!r}) m")
        return np.ascontiguousarray(z)

    def _estimate_z_range(self, extent_m) -> tuple[float, float]:
        """Padded range of fn on a grid over the padded extent (see the class doc)."""
        what = f"CallableSource {self.name!r} extent_m"
        if extent_m is None:
            extent_m = DEFAULT_ESTIMATE_EXTENT_M
        try:
            x0, y0, x1, y1 = extent_m
        except (TypeError, ValueError):
            raise TypeError(f"{what} must be (xmin, ymin, xmax, ymax) [m], got {extent_m!r}") from None
        x0, y0, x1, y1 = (_finite_float(v, what) for v in (x0, y0, x1, y1))
        if x1 < x0 or y1 < y0:
            raise ValueError(f"{what} = {tuple(extent_m)}: need xmin ≤ xmax and ymin ≤ ymax")
        px, py = ESTIMATE_PAD * (x1 - x0), ESTIMATE_PAD * (y1 - y0)
        gx, gy = np.meshgrid(np.linspace(x0 - px, x1 + px, ESTIMATE_GRID),
                             np.linspace(y0 - py, y1 + py, ESTIMATE_GRID))
        z = self.heights(gx, gy)
        lo, hi = float(z.min()), float(z.max())
        pad = ESTIMATE_PAD * (hi - lo) + ESTIMATE_PAD_M
        return lo - pad, hi + pad

    def __repr__(self) -> str:
        lo, hi = self.z_range_m
        return f"CallableSource({self.name!r}, z {lo:.6g}…{hi:.6g} m)"


class ArraySource(HeightSource):
    """Bilinear heights from a grid: ``array[j, i]`` is the altitude [m] at
    ``origin_m + (i, j) · cell_m`` (row = y).

    ``array``: a 2-D real ndarray, an ``np.memmap``, or the path of a ``.npy`` file (opened
    with ``np.load(mmap_mode="r")``, never read whole). ``origin_m`` (x, y) [m] finite,
    ``cell_m`` [m] finite and > 0.

    Sampling
        Bilinear inside each cell, exact at the nodes. Points outside ``bounds_m`` take the
        value at the nearest point of the edge (coordinates clamped into the grid). Each call
        reads only the window of rows and columns its points touch (their bounding box), so
        small tiles of a raster larger than memory are cheap; a batch spread over the whole
        raster reads its whole bounding box.

    No data
        Cells that are NaN, infinite, or equal to ``nodata`` are replaced by ``fill_m``, the
        smallest valid value found when the height range was computed (of the whole array, or
        of its subsample for huge arrays), so heights are never NaN. An array with no valid
        value raises a ValueError.

    Height range
        ``z_range_m`` (lo, hi) [m] may be given. Otherwise arrays up to FULL_SCAN_CELLS are
        read once and the exact range is widened by EXACT_MARGIN · (1 m + max |z|); larger
        ones are read through a strided subsample of at most FULL_SCAN_CELLS cells and the
        range is widened by SUBSAMPLE_MARGIN of its span plus SUBSAMPLE_MARGIN_M on each side
        (an estimate: a peak between the samples can exceed it; pass ``z_range_m`` if known).
    """

    def __init__(self, array, origin_m, cell_m: float, *, nodata: float | None = None,
                 z_range_m=None) -> None:
        self.path = None
        if isinstance(array, (str, Path)):
            self.path = Path(array)
            array = _open_npy(self.path)
        if not isinstance(array, np.ndarray):
            raise TypeError(f"ArraySource: array must be an ndarray, np.memmap or .npy path, "
                            f"got {type(array).__name__}")
        where = f" ({self.path})" if self.path else ""
        if array.ndim != 2:
            raise ValueError(f"ArraySource{where}: array must be 2-D (rows = y, columns = x), "
                             f"got shape {array.shape}")
        if array.size == 0:
            raise ValueError(f"ArraySource{where}: array is empty (shape {array.shape})")
        if not (np.issubdtype(array.dtype, np.integer) or np.issubdtype(array.dtype, np.floating)):
            raise TypeError(f"ArraySource{where}: array must hold real numbers, got dtype {array.dtype}")
        self.array = array
        self.origin_m = self._origin(origin_m, where)
        self.cell_m = _finite_float(cell_m, f"ArraySource{where} cell_m")
        if self.cell_m <= 0:
            raise ValueError(f"ArraySource{where}: cell_m must be > 0 m, got {self.cell_m}")
        self.nodata = None if nodata is None else _finite_float(nodata, f"ArraySource{where} nodata")
        ny, nx = array.shape
        x0, y0 = self.origin_m
        self.bounds_m = (x0, y0, x0 + (nx - 1) * self.cell_m, y0 + (ny - 1) * self.cell_m)
        lo, hi, self.fill_m = self._scan(where)
        self.z_range_m = ((lo, hi) if z_range_m is None
                          else _z_range(z_range_m, f"ArraySource{where} z_range_m"))

    @staticmethod
    def _origin(origin_m, where: str) -> tuple[float, float]:
        try:
            x0, y0 = origin_m
        except (TypeError, ValueError):
            raise TypeError(f"ArraySource{where}: origin_m must be (x, y) [m], got {origin_m!r}") from None
        return (_finite_float(x0, f"ArraySource{where} origin_m[0]"),
                _finite_float(y0, f"ArraySource{where} origin_m[1]"))

    def _valid(self, block: np.ndarray) -> np.ndarray:
        """Mask of the valid cells of a float64 block (finite and not nodata)."""
        ok = np.isfinite(block)
        if self.nodata is not None:
            ok &= block != self.nodata
        return ok

    def _scan(self, where: str) -> tuple[float, float, float]:
        """Padded height range (lo, hi) [m] and the no-data fill [m] (see the class doc)."""
        stride = max(1, math.ceil(math.sqrt(self.array.size / FULL_SCAN_CELLS)))
        sample = self.array[::stride, ::stride]
        rows = max(1, _ROW_BLOCK_CELLS // sample.shape[1])
        lo, hi = math.inf, -math.inf
        for j in range(0, sample.shape[0], rows):
            block = np.asarray(sample[j:j + rows], dtype=np.float64)
            valid = block[self._valid(block)]
            if valid.size:
                lo, hi = min(lo, float(valid.min())), max(hi, float(valid.max()))
        if lo > hi:
            scope = "" if stride == 1 else f" (every {stride}th row and column sampled)"
            raise ValueError(f"ArraySource{where}: no valid cell{scope}: all are NaN, infinite "
                             f"or nodata={self.nodata}")
        return padded_range(lo, hi, stride)

    def heights(self, x_m, y_m) -> np.ndarray:
        shape, x, y = _points(x_m, y_m, "ArraySource.heights")
        if x.size == 0:
            return np.empty(shape, dtype=np.float64)
        ny, nx = self.array.shape
        i, i1, u = self._axis(x, self.origin_m[0], nx)
        j, j1, v = self._axis(y, self.origin_m[1], ny)
        r0, c0 = int(j.min()), int(i.min())
        window = self._window(r0, int(j1.max()) + 1, c0, int(i1.max()) + 1)
        i, i1, j, j1 = i - c0, i1 - c0, j - r0, j1 - r0
        z = ((1.0 - v) * ((1.0 - u) * window[j, i] + u * window[j, i1])
             + v * ((1.0 - u) * window[j1, i] + u * window[j1, i1]))
        return z.reshape(shape)

    def _axis(self, p_m: np.ndarray, origin_m: float, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Lower node index, upper node index and fraction along one axis of coordinates p_m
        [m], clamped into the grid of n nodes."""
        g = np.clip((p_m - origin_m) / self.cell_m, 0.0, n - 1.0)
        lo = np.minimum(g.astype(np.int64), max(n - 2, 0))
        return lo, np.minimum(lo + 1, n - 1), g - lo

    def _window(self, r0: int, r1: int, c0: int, c1: int) -> np.ndarray:
        """Rows [r0, r1) and columns [c0, c1) as float64 [m], no-data filled: the only read
        of the array when sampling."""
        window = np.array(self.array[r0:r1, c0:c1], dtype=np.float64)
        bad = ~self._valid(window)
        if bad.any():
            window[bad] = self.fill_m
        return window

    def __repr__(self) -> str:
        ny, nx = self.array.shape
        src = str(self.path) if self.path else f"{ny}×{nx} {self.array.dtype}"
        return f"ArraySource({src}, origin_m={self.origin_m}, cell_m={self.cell_m})"


def _open_npy(path: Path) -> np.ndarray:
    """Memory-map a .npy file read-only; errors name the file."""
    if path.suffix.lower() != ".npy":
        raise ValueError(f"ArraySource reads .npy files only, got {str(path)!r}")
    if not path.is_file():
        raise FileNotFoundError(f"height array file not found: {str(path)!r}")
    return np.load(path, mmap_mode="r", allow_pickle=False)


def as_height_source(terrain, *, origin_m=None, cell_m=None, crs=None) -> HeightSource | None:
    """The :class:`HeightSource` for what a user passes as terrain.

    - None → None; a HeightSource → itself;
    - an ndarray / np.memmap, or a str / Path of a ``.npy`` file → :class:`ArraySource`
      (``origin_m`` (x, y) [m] and ``cell_m`` [m] required);
    - a str / Path of a ``.tif`` / ``.tiff`` (any of RASTER_SUFFIXES) raster →
      :class:`riverflow.scenes.rasters.RasterSource` (riverflow[gis]; reprojected on the fly to
      ``crs`` when given and different from the raster's);
    - a str / Path of a 16-bit ``.png`` heightmap → :class:`riverflow.scenes.rasters.PngHeightSource`
      (``origin_m`` of its south-west corner and ``cell_m`` required; values in metres);
    - any other callable → :class:`CallableSource` (height range estimated, see there).

    Other str / Path suffixes raise ValueError, anything else TypeError.
    """
    if terrain is None or isinstance(terrain, HeightSource):
        return terrain
    if isinstance(terrain, (str, Path)):
        suffix = Path(terrain).suffix.lower()
        if suffix in RASTER_SUFFIXES:
            from riverflow.scenes.rasters import RasterSource

            return RasterSource(terrain, crs=crs)
        if suffix == ".png":
            from riverflow.scenes.rasters import PngHeightSource

            missing = [n for n, v in (("origin_m", origin_m), ("cell_m", cell_m)) if v is None]
            if missing:
                raise ValueError(f"as_height_source: a PNG heightmap needs {' and '.join(missing)} "
                                 "(origin_m = (x, y) [m] of its south-west corner, cell_m = "
                                 "spacing [m])")
            return PngHeightSource(terrain, origin_m, cell_m)
        if suffix != ".npy":
            raise ValueError(f"terrain file {str(terrain)!r}: unsupported suffix {suffix!r} "
                             f"(accepted: .npy, .png, rasters {', '.join(RASTER_SUFFIXES)})")
    if isinstance(terrain, (str, Path, np.ndarray)):
        missing = [n for n, v in (("origin_m", origin_m), ("cell_m", cell_m)) if v is None]
        if missing:
            raise ValueError(f"as_height_source: a height array needs {' and '.join(missing)} "
                             "(origin_m = (x, y) [m] of array[0, 0], cell_m = spacing [m])")
        return ArraySource(terrain, origin_m, cell_m)
    if callable(terrain):
        return CallableSource(terrain)
    raise TypeError(f"as_height_source: cannot make a height source of {type(terrain).__name__}; "
                    "accepted: None, a HeightSource, a 2-D ndarray / np.memmap or .npy path "
                    "(with origin_m and cell_m), or a callable fn(x_m, y_m) -> z_m")
