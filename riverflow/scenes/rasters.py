"""Elevation rasters as height sources, read by windows (a raster larger than memory works).

- :class:`RasterSource`: a GeoTIFF (or any raster GDAL reads) through rasterio, band 1 by
  default, north-up; each :meth:`~RasterSource.heights` call reads only the windows its points
  touch (blocks of BLOCK_CELLS² cells). A raster in another CRS than the river network's is
  reprojected on the fly (rasterio's ``WarpedVRT``, bilinear), still by windows.
- :class:`PngHeightSource`: a 16-bit (or 8-bit) greyscale PNG heightmap with an origin and a
  cell size: decoded row by row (pypng) into a memory-mapped scratch array once, then read by
  windows like any :class:`~riverflow.scenes.sources.ArraySource`.

Both follow the :class:`~riverflow.scenes.sources.HeightSource` contract: pointwise bilinear
heights (bit-identical whatever batch a point comes in), no-data replaced by the lowest valid
height, a conservative height range.

``rf.landscape(graph, terrain="dem.tif")`` makes a :class:`RasterSource` (reprojected to
``graph.crs`` when the graph has one); ``terrain="heights.png", origin_m=…,
source_cell_m=…`` a :class:`PngHeightSource`.
"""
from __future__ import annotations

import math
import os
import shutil
import tempfile
import threading
import warnings
import weakref
from pathlib import Path

import numpy as np

from riverflow._validate import _number, as_floats
from riverflow._extras import require
from riverflow.scenes.sources import (
    FULL_SCAN_CELLS,
    ArraySource,
    HeightSource,
    _points,
    padded_range,
)

HEIGHT_LIMIT_M = 1.0e7
"""A raster cell farther from 0 than this [m] is no-data: beyond any height on Earth even in
millimetres (an undeclared no-data value: float32's lowest, −1e30, …)."""

BLOCK_CELLS = 512
"""Points are read in blocks of at most this many cells a side, so a batch spread over a huge
raster (a long river's profile) reads only the blocks it touches."""


SCAN_BLOCKS = 1024
"""A raster without overviews whose strided height-range read would touch more blocks than
this reads this many of its blocks instead, spread evenly (a 200 000² raster: 1 024 block
reads, not 600 000)."""


class RasterSource(HeightSource):
    """Bilinear heights [m] from band ``band`` of a north-up raster file.

    Args:
        path: a GeoTIFF or any raster rasterio opens.
        band: 1-based band index.
        crs: the CRS the heights are asked in (the river network's, ``graph.crs``); when the
            raster has another one it is reprojected on the fly (bilinear). None: the raster's.
        nodata: value marking missing cells (default: the raster's own no-data value).
        z_range_m: (lo, hi) [m] when known; else read from the raster (exactly up to
            FULL_SCAN_CELLS cells, from a decimated read beyond, widened as
            :class:`~riverflow.scenes.sources.ArraySource` does).

    Heights are the bilinear interpolation of the pixel centres; points outside the raster
    take the value at the nearest edge. Cells that are not finite or lie beyond
    ±HEIGHT_LIMIT_M are no-data too (a float raster's undeclared no-data, such as float32's
    lowest value, −3.4·10³⁸). ``cell_m`` is the finer pixel side, ``bounds_m`` the
    box of the pixel centres, ``crs`` the WKT of the coordinates.

    Raises:
        FileNotFoundError: no such file. ValueError: unreadable, rotated or empty raster, a
        band out of range, no valid cell. ImportError: the gis extra is missing.
    """

    def __init__(self, path, *, band: int = 1, crs=None, nodata: float | None = None,
                 z_range_m=None) -> None:
        dataset = open_raster(path, band)
        self.path = Path(path)
        self._file = self._ds = dataset
        try:
            self._open(dataset, band, crs, nodata, z_range_m)
        except Exception:
            self.close()
            raise

    def _open(self, dataset, band, crs, nodata, z_range_m) -> None:
        self.reprojected = False
        if crs is not None and dataset.crs is not None:
            from rasterio.crs import CRS
            from rasterio.enums import Resampling
            from rasterio.vrt import WarpedVRT

            try:
                target = CRS.from_user_input(crs)
                if target != dataset.crs:
                    dataset = WarpedVRT(dataset, crs=target, resampling=Resampling.bilinear)
                    self.reprojected = True
            except Exception as exc:  # rasterio.errors.CRSError, a failed warp
                raise ValueError(f"{self.path}: cannot reproject it from its CRS "
                                 f"({dataset.crs}) to {str(crs)[:80]!r}: {exc}") from None
        self._ds = dataset
        self.crs = None if dataset.crs is None else dataset.crs.to_wkt()
        self.band = int(band)
        t = dataset.transform
        if t.b != 0.0 or t.d != 0.0:
            raise ValueError(f"{self.path}: a rotated raster (transform {tuple(t)[:6]}) is not "
                             "supported; warp it north-up first (gdalwarp)")
        if dataset.width < 1 or dataset.height < 1:
            raise ValueError(f"{self.path}: an empty raster ({dataset.width}×{dataset.height})")
        self._x0, self._dx = t.c + 0.5 * t.a, t.a      # pixel-centre x of column 0, step
        self._y0, self._dy = t.f + 0.5 * t.e, t.e      # pixel-centre y of row 0, step (< 0)
        self._shape = (dataset.height, dataset.width)
        if nodata is not None:
            nodata = _number(nodata, f"RasterSource({self.path.name}): nodata")
        self.nodata = nodata if nodata is not None else dataset.nodatavals[band - 1]
        self.cell_m = float(min(abs(t.a), abs(t.e)))
        xs = (self._x0, self._x0 + (dataset.width - 1) * self._dx)
        ys = (self._y0, self._y0 + (dataset.height - 1) * self._dy)
        self.bounds_m = (min(xs), min(ys), max(xs), max(ys))
        self._lock = threading.Lock()   # a GDAL dataset is not to be read from two threads
        lo, hi, self.fill_m = self._scan()
        if z_range_m is not None:
            z = as_floats(z_range_m, f"RasterSource({self.path.name}): z_range_m")
            if z.shape != (2,) or not np.isfinite(z).all() or not z[0] <= z[1]:
                raise ValueError(f"RasterSource({self.path.name}): z_range_m must be finite "
                                 f"(lo, hi) with lo ≤ hi [m], got {z_range_m!r:.80}")
            lo, hi = float(z[0]), float(z[1])
        self.z_range_m = (lo, hi)

    def _valid(self, block: np.ndarray) -> np.ndarray:
        ok = np.isfinite(block) & (np.abs(block) <= HEIGHT_LIMIT_M)
        if self.nodata is not None and np.isfinite(self.nodata):
            ok &= block != self.nodata
        return ok

    def _scan(self) -> tuple[float, float, float]:
        """Height range (lo, hi) [m], padded, and the no-data fill."""
        from rasterio.enums import Resampling

        ny, nx = self._shape
        stride = max(1, math.ceil(math.sqrt(ny * nx / FULL_SCAN_CELLS)))
        bh, bw = self._ds.block_shapes[self.band - 1]
        with self._lock, _read_errors(self.path, "reading its height range"):
            if stride > 1 and not self._ds.overviews(self.band) \
                    and math.ceil(ny / bh) * math.ceil(nx / bw) > SCAN_BLOCKS:
                data = self._block_sample(bh, bw)    # a strided read would touch every block
            else:
                data = self._ds.read(self.band, out_shape=(max(1, ny // stride),
                                                           max(1, nx // stride)),
                                     resampling=Resampling.nearest).astype(np.float64)
        valid = data[self._valid(data)]
        if not valid.size:
            raise ValueError(f"{self.path}: no valid cell (all are no-data = {self.nodata}, "
                             f"not finite or beyond ±{HEIGHT_LIMIT_M:g} m)")
        lo, hi = float(valid.min()), float(valid.max())
        return padded_range(lo, hi, stride)

    def _block_sample(self, bh: int, bw: int) -> np.ndarray:
        """The cells of SCAN_BLOCKS of the raster's own blocks spread evenly over it (a huge
        raster without overviews: reading them costs SCAN_BLOCKS block reads, never all)."""
        from rasterio.windows import Window

        ny, nx = self._shape
        k = math.isqrt(SCAN_BLOCKS)
        rows = np.unique(np.linspace(0, math.ceil(ny / bh) - 1, k).round().astype(int)) * bh
        cols = np.unique(np.linspace(0, math.ceil(nx / bw) - 1, k).round().astype(int)) * bw
        parts = [self._ds.read(self.band, window=Window(int(c), int(r), min(bw, nx - int(c)),
                                                        min(bh, ny - int(r)))).ravel()
                 for r in rows for c in cols]
        return np.concatenate(parts).astype(np.float64)

    def heights(self, x_m, y_m) -> np.ndarray:
        shape, x, y = _points(x_m, y_m, f"RasterSource({self.path.name})")
        if x.size == 0:
            return np.empty(shape)
        ny, nx = self._shape
        i, i1, u = _axis((x - self._x0) / self._dx, nx)
        j, j1, v = _axis((y - self._y0) / self._dy, ny)
        z = np.empty(x.size)
        key = (j // BLOCK_CELLS) * (nx // BLOCK_CELLS + 1) + i // BLOCK_CELLS
        order = np.argsort(key, kind="stable")
        bounds = np.flatnonzero(np.diff(key[order])) + 1
        for idx in np.split(order, bounds):
            r0, c0 = int(j[idx].min()), int(i[idx].min())
            w = self._window(r0, int(j1[idx].max()) + 1, c0, int(i1[idx].max()) + 1)
            a, a1, b, b1 = i[idx] - c0, i1[idx] - c0, j[idx] - r0, j1[idx] - r0
            uu, vv = u[idx], v[idx]
            z[idx] = ((1.0 - vv) * ((1.0 - uu) * w[b, a] + uu * w[b, a1])
                      + vv * ((1.0 - uu) * w[b1, a] + uu * w[b1, a1]))
        return z.reshape(shape)

    def _window(self, r0: int, r1: int, c0: int, c1: int) -> np.ndarray:
        """Rows [r0, r1) and columns [c0, c1) as float64 [m], no-data filled."""
        from rasterio.windows import Window

        with self._lock, _read_errors(self.path, f"reading rows {r0}…{r1 - 1}, columns "
                                                  f"{c0}…{c1 - 1}"):
            block = self._ds.read(self.band, window=Window(c0, r0, c1 - c0, r1 - r0))
        block = block.astype(np.float64)
        bad = ~self._valid(block)
        if bad.any():
            block[bad] = self.fill_m
        return block

    def close(self) -> None:
        """Close the raster file (heights cannot be read afterwards)."""
        if self._ds is not self._file:
            self._ds.close()
        self._file.close()

    def __repr__(self) -> str:
        ny, nx = self._shape
        return (f"RasterSource({str(self.path)!r}, {nx}×{ny} cells of {self.cell_m:g} m"
                f"{', reprojected' if self.reprojected else ''})")


def open_raster(path, band: int = 1, what: str = "elevation raster"):
    """Open ``path`` with rasterio for its heights, band ``band``, after the checks every
    elevation raster passes (:class:`RasterSource`, ``rf.read_water(dem=)``): a file GDAL
    reads as a raster, the band present, real numbers (not complex), georeferenced (a PNG /
    JPEG renamed .tif has no geotransform), finite non-zero pixel sides. Errors name the file.

    Raises:
        FileNotFoundError: no such file. ValueError: any check failed.
    """
    if not isinstance(path, (str, os.PathLike)):
        raise TypeError(f"the {what} must be a file name, got {type(path).__name__} "
                        f"{path!r:.60}")
    rasterio = require("rasterio", f"reading the raster {path}")
    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(f"{what} not found: {str(path)!r}")
    if not path.is_file():
        raise ValueError(f"{path}: the {what} is not a file (a directory?)")
    try:
        with warnings.catch_warnings():      # no georeferencing is refused below, by name
            warnings.simplefilter("ignore", rasterio.errors.NotGeoreferencedWarning)
            dataset = rasterio.open(path)
    except Exception as exc:  # rasterio.errors.RasterioIOError
        raise ValueError(f"{path}: cannot read it as a raster: {exc}") from None
    try:
        if isinstance(band, bool) or not isinstance(band, (int, np.integer)) \
                or not 1 <= band <= dataset.count:
            raise ValueError(f"{path}: no band {band!r} (it has {dataset.count})")
        dtype = dataset.dtypes[band - 1]
        if "complex" in dtype:
            raise ValueError(f"{path}: band {band} holds complex numbers ({dtype}), not "
                             "heights; give a raster of real elevations [m]")
        t = dataset.transform
        if not all(math.isfinite(v) for v in tuple(t)[:6]):
            raise ValueError(f"{path}: its geotransform {tuple(t)[:6]} is not finite")
        if dataset.crs is None and t.is_identity and not dataset.gcps[0]:
            raise ValueError(f"{path}: not georeferenced (no geotransform and no CRS; "
                             f"{dataset.driver} data, an image renamed?): give a GeoTIFF, or "
                             "a PNG heightmap with origin_m and cell_m")
        if abs(t.a * t.e - t.b * t.d) == 0.0:
            raise ValueError(f"{path}: its pixels have no area (geotransform {tuple(t)[:6]})")
    except Exception:
        dataset.close()
        raise
    return dataset


class _read_errors:
    """Turn a failed read of a raster (a truncated or corrupt file, read lazily) into a
    ValueError naming the file and what was read."""

    def __init__(self, path: Path, what: str) -> None:
        self.path, self.what = path, what

    def __enter__(self):
        return self

    def __exit__(self, kind, exc, tb):
        from rasterio.errors import RasterioError

        if exc is not None and isinstance(exc, RasterioError):
            raise ValueError(f"{self.path}: cannot read the raster ({self.what}): {exc}; "
                             "the file is truncated or corrupt") from None
        return False


def _axis(g: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Lower node, upper node and fraction of fractional indices ``g`` into n nodes (clamped)."""
    g = np.clip(g, 0.0, n - 1.0)
    lo = np.minimum(g.astype(np.int64), max(n - 2, 0))
    return lo, np.minimum(lo + 1, n - 1), g - lo


class PngHeightSource(ArraySource):
    """A greyscale PNG heightmap (16- or 8-bit): height = ``offset_m`` + ``scale_m`` × value.

    ``origin_m`` (x, y) [m] is the south-west corner node (the bottom-left pixel: images are
    stored north-up, row 0 at the top), ``cell_m`` [m] the pixel spacing. The image is decoded
    row by row (pypng, never whole in memory) into a float32 memory-mapped scratch file
    (removed with the source), then read by windows as an
    :class:`~riverflow.scenes.sources.ArraySource` (row = y, up).
    """

    def __init__(self, path, origin_m, cell_m: float, *, scale_m: float = 1.0,
                 offset_m: float = 0.0) -> None:
        png = require("png", f"reading the PNG heightmap {path}")
        path = Path(path)
        if not path.is_file():
            raise FileNotFoundError(f"PNG heightmap not found: {str(path)!r}")
        try:
            width, height, rows, info = png.Reader(filename=str(path)).read()
        except Exception as exc:  # png.FormatError and friends
            raise ValueError(f"{path}: cannot read it as a PNG: {exc}") from None
        planes = int(info.get("planes", 1))
        if not info.get("greyscale", False):
            raise ValueError(f"{path}: a heightmap must be a greyscale PNG (this one has colour)")
        need = 4.0 * width * height            # the float32 scratch array [bytes]
        free = shutil.disk_usage(tempfile.gettempdir()).free
        if need > free:
            raise ValueError(f"{path}: a {width}×{height} heightmap needs {need / 2**30:,.1f} GiB "
                             f"of scratch space in {tempfile.gettempdir()}, which has "
                             f"{free / 2**30:,.1f} GiB free (a damaged header?)")
        scratch = tempfile.mkdtemp(prefix="riverflow-png-")
        self._cleanup = weakref.finalize(self, shutil.rmtree, scratch, True)
        try:
            array = np.lib.format.open_memmap(Path(scratch) / "heights.npy", mode="w+",
                                              dtype=np.float32, shape=(height, width))
            for k, row in enumerate(rows):   # north-up image: row k is y index height - 1 - k
                values = np.asarray(row, dtype=np.float64)[::planes]
                array[height - 1 - k] = offset_m + scale_m * values
            array.flush()
        except Exception as exc:   # png.FormatError / ChunkError of a truncated or corrupt file
            self._cleanup()
            raise ValueError(f"{path}: cannot read it as a PNG heightmap (truncated or "
                             f"corrupt?): {type(exc).__name__}: {exc}") from None
        self.scale_m, self.offset_m, self.bitdepth = float(scale_m), float(offset_m), info["bitdepth"]
        super().__init__(array, origin_m, cell_m)
        self.path = path

    def __repr__(self) -> str:
        ny, nx = self.array.shape
        return (f"PngHeightSource({str(self.path)!r}, {nx}×{ny}, {self.bitdepth}-bit, "
                f"origin_m={self.origin_m}, cell_m={self.cell_m})")
