"""Flow maps out: the river's flow baked into an image other engines' flow-map shaders read.

:func:`bake_flow_map` (``rf.bake_flow_map``, ``riverflow bake``) samples
:meth:`~riverflow.FlowField.query` at the centre of every pixel of a region and writes an RGBA
PNG (8 or 16 bits a channel) in the layout of Waterways (Godot), Unity and Unreal flow-map
shaders, and a JSON sidecar that says how to read it::

    rf.bake_flow_map(scene, (x0, y0, x1, y1), 2.0, "out/flow.png")    # + out/flow.json

Encoding (``n`` = 2^bits − 1):

- R, G = round(n · (0.5 + v / (2 · max_speed_mps))) for v = vx (east), vy (north) [m/s],
  clipped to [0, n]: 0.5 is still water, 0 and n are ±max_speed_mps;
- B = n on water (the flow's status is INSIDE), 0 on land;
- A = round(n · min(d / max_distance_m, 1)), d the distance [m] from the pixel centre to the
  nearest bank (a BANK curve: river shores and island shores, not the closing segments across
  river ends), on water and land alike.

Rows are north-up: row 0 is the northern edge. Pixel (column i, row j) is centred at
x = x0 + (i + ½)·cell_m, y = y0 + (rows − j − ½)·cell_m, with (x0, y0) = ``origin_m`` the
south-west corner of the map. The sidecar repeats this, with the CRS of the coordinates when
known, so a map can be placed on the ground again.
"""
from __future__ import annotations

import json
import math
import time
from pathlib import Path
from typing import NamedTuple

import numpy as np
import shapely

from riverflow._atomic import atomic_files, require_suffix, strict_json
from riverflow._validate import check_allocation, finite_positive
from riverflow.components.status import FlowStatus
from riverflow.gis import require
from riverflow.hydro.graph import HydroGraph

MAX_SIDE_PX = 16384
"""Largest side of a baked map [px]."""
BATCH_POINTS = 1 << 16
"""Pixels queried at a time."""
FORMAT = "riverflow-flowmap/1"


class FlowMap(NamedTuple):
    """What :func:`bake_flow_map` wrote."""

    image: Path
    sidecar: Path
    size_px: tuple[int, int]
    """(width, height) [px]."""
    origin_m: tuple[float, float]
    """South-west corner (x0, y0) [m]."""
    cell_m: float
    max_speed_mps: float
    max_distance_m: float
    water_fraction: float
    seconds: float
    """Wall time of the bake [s]."""


def bake_flow_map(field_or_scene, region_m=None, cell_m: float | None = None,
                  path="flow.png", *, bits: int = 8, max_speed_mps: float | None = None,
                  max_distance_m: float | None = None) -> FlowMap:
    """Bake the flow of a region into a flow-map PNG and its JSON sidecar (module docstring).

    Args:
        field_or_scene: a :class:`~riverflow.FlowField`, a scene (``rf.landscape``,
            ``rf.default_scene``: its flow on the scene's quadtree) or a hydro graph.
        region_m: (x0, y0, x1, y1) [m]; default: the network's bounds plus its widest axis.
        cell_m: pixel size [m]; default: the longer side of the region / 1024.
        path: the PNG to write (its folder is made; a ``.png`` name: the extension decides
            the format); the sidecar is the same path with ``.json``. Both are written under
            temporary names and renamed into place together once complete: an interrupted
            bake leaves neither.
        bits: 8 or 16 bits a channel.
        max_speed_mps: speed of R, G = 0 or n; default: the fastest water in the map.
        max_distance_m: distance of A = n; default: the farthest water pixel from a bank.

    Returns:
        A :class:`FlowMap`.

    Raises:
        ValueError: a bad region, cell size, bit depth, max_speed_mps or max_distance_m
            (not a finite positive number), a file name not ending in ``.png``, or a map over
            MAX_SIDE_PX (checked before any pixel is computed).
        TypeError: region_m or cell_m not numbers (text, None inside, …), naming them.
        ImportError: ``bits=16`` without pypng (the gis extra).
    """
    started = time.perf_counter()
    field = _field(field_or_scene)
    graph = field.graph
    if bits not in (8, 16):
        raise ValueError(f"bake_flow_map: bits must be 8 or 16, got {bits!r}")
    require_suffix(path, (".png",), f"a {bits}-bit flow map")
    for label, value in (("max_speed_mps", max_speed_mps), ("max_distance_m", max_distance_m)):
        if value is not None and not (isinstance(value, (int, float, np.number))
                                      and math.isfinite(value) and value > 0):
            raise ValueError(f"bake_flow_map: {label} must be a finite positive number, got "
                             f"{value!r}")
    x0, y0, x1, y1 = _region(region_m, graph, field)
    if cell_m is None:
        cell_m = max(x1 - x0, y1 - y0) / 1024.0
    cell_m = finite_positive(cell_m, "bake_flow_map: cell_m")   # a number (TypeError), > 0
    fx, fy = (x1 - x0) / cell_m - 1e-9, (y1 - y0) / cell_m - 1e-9
    if not max(fx, fy) <= MAX_SIDE_PX:        # also inf (a region of 1e308 m, cell_m 5e-324)
        raise ValueError(f"bake_flow_map: {fx:.4g}×{fy:.4g} px is over {MAX_SIDE_PX} px a "
                         f"side; use a larger cell_m than {cell_m:g} m or a smaller "
                         "region_m")
    nx, ny = math.ceil(fx), math.ceil(fy)
    # centres 16, status 1, velocity 8, speed 4, distance 8 + temporaries, RGBA ≤ 8 B a pixel
    check_allocation(64.0 * nx * ny, f"bake_flow_map: a {nx}×{ny} px map (cell_m={cell_m:g})")
    centres = pixel_centres((x0, y0), cell_m, (nx, ny))
    status = np.empty(nx * ny, np.uint8)
    velocity = np.empty((nx * ny, 2), np.float32)
    for a in range(0, nx * ny, BATCH_POINTS):
        status[a:a + BATCH_POINTS], velocity[a:a + BATCH_POINTS] = field.query(
            centres[a:a + BATCH_POINTS])
    water = status == FlowStatus.INSIDE
    speed = np.hypot(velocity[:, 0], velocity[:, 1])
    if max_speed_mps is None:
        max_speed_mps = float(speed[water].max()) if water.any() else 1.0
        max_speed_mps = max_speed_mps if max_speed_mps > 0 else 1.0
    distance = bank_distance(graph, centres, max_distance_m)
    if max_distance_m is None:
        max_distance_m = float(distance[water].max()) if water.any() else cell_m
        max_distance_m = max(max_distance_m, 1e-6)
    n = (1 << bits) - 1
    dtype = np.uint8 if bits == 8 else np.uint16
    rgba = np.empty((nx * ny, 4), dtype)
    rgba[:, :2] = np.clip(np.rint(n * (0.5 + velocity.astype(np.float64) / (2.0 * max_speed_mps))),
                          0, n)
    rgba[:, 2] = np.where(water, n, 0)
    rgba[:, 3] = np.clip(np.rint(n * np.minimum(distance / max_distance_m, 1.0)), 0, n)
    image = rgba.reshape(ny, nx, 4)
    path = Path(path)
    sidecar = path.with_suffix(".json")
    crs = getattr(graph, "crs", None)
    meta = {
        "format": FORMAT,
        "image": path.name,
        "origin_m": [x0, y0],
        "cell_m": cell_m,
        "size_px": [nx, ny],
        "bounds_m": [x0, y0, x0 + nx * cell_m, y0 + ny * cell_m],
        "rows": "north-up: row 0 is the northern edge (y = bounds_m[3])",
        "pixel_centre_m": "x = x0 + (i + 0.5) * cell_m, y = y0 + (rows - j - 0.5) * cell_m "
                          "for column i, row j",
        "bits": bits,
        "max_speed_mps": float(max_speed_mps),
        "max_distance_m": float(max_distance_m),
        "encoding": {
            "R": f"0.5 + vx / (2 * max_speed_mps), vx east [m/s], times {n}",
            "G": f"0.5 + vy / (2 * max_speed_mps), vy north [m/s], times {n}",
            "B": f"water {n} / land 0",
            "A": f"min(distance to the nearest bank / max_distance_m, 1), times {n}",
        },
        "crs": crs,
        "source": graph.source,
    }
    text = strict_json(meta, where=f"bake_flow_map: the sidecar {sidecar}", indent=2)
    # together or not at all; the sidecar is renamed in first, so that a map found is whole
    with atomic_files(sidecar, path) as (tmp_sidecar, tmp_image):
        _write_png(image, tmp_image, bits)
        tmp_sidecar.write_text(text, encoding="utf-8")
    return FlowMap(path, sidecar, (nx, ny), (x0, y0), cell_m, float(max_speed_mps),
                   float(max_distance_m), float(water.mean()), time.perf_counter() - started)


def pixel_centres(origin_m, cell_m: float, size_px) -> np.ndarray:
    """Centres (rows · cols, 2) [m] of a north-up map's pixels, row by row from the top."""
    x0, y0 = origin_m
    nx, ny = size_px
    xs = x0 + (np.arange(nx) + 0.5) * cell_m
    ys = y0 + (ny - np.arange(ny) - 0.5) * cell_m
    gx, gy = np.meshgrid(xs, ys)
    return np.column_stack([gx.ravel(), gy.ravel()])


def decode_flow_map(path) -> tuple[np.ndarray, np.ndarray, np.ndarray, dict]:
    """Read a baked map back: velocity (rows, cols, 2) [m/s], water (rows, cols) bool,
    distance to the nearest bank (rows, cols) [m] (clipped at max_distance_m), and the
    sidecar's dict."""
    path = Path(path)
    meta = json.loads(path.with_suffix(".json").read_text())
    bits = int(meta["bits"])
    n = (1 << bits) - 1
    if bits == 8:
        from PIL import Image

        rgba = np.asarray(Image.open(path).convert("RGBA"), np.float64)
    else:
        png = require("png", "reading a 16-bit flow map")
        width, height, rows, _ = png.Reader(filename=str(path)).asRGBA()
        rgba = np.vstack([np.asarray(r, np.float64) for r in rows]).reshape(height, width, 4)
    velocity = (rgba[..., :2] / n - 0.5) * 2.0 * meta["max_speed_mps"]
    return velocity, rgba[..., 2] > n / 2, rgba[..., 3] / n * meta["max_distance_m"], meta


def bank_distance(graph: HydroGraph, points: np.ndarray, limit_m: float | None = None
                  ) -> np.ndarray:
    """Distance [m] from points (N, 2) to the nearest bank curve of ``graph`` (inf where no
    bank is within ``limit_m``)."""
    segments = []
    for i in graph.banks():
        p = graph.polyline(i)
        segments.append(np.stack([p[:-1], p[1:]], axis=1))
    if not segments:
        return np.full(len(points), np.inf)
    tree = shapely.STRtree(shapely.linestrings(np.concatenate(segments)))
    out = np.full(len(points), np.inf)
    for a in range(0, len(points), BATCH_POINTS):
        pts = shapely.points(points[a:a + BATCH_POINTS])
        (idx, _), dist = tree.query_nearest(pts, max_distance=limit_m, return_distance=True,
                                            all_matches=False)
        out[a + idx] = dist
    return out


def _field(thing):
    from riverflow.hydro.flow_field import FlowField

    if isinstance(thing, FlowField):
        return thing
    if isinstance(thing, HydroGraph):
        return FlowField(thing)
    if hasattr(thing, "graph") and hasattr(thing, "bounds_m"):
        return FlowField.for_scene(thing)
    raise TypeError(f"bake_flow_map: needs a FlowField, a scene or a HydroGraph, got "
                    f"{type(thing).__name__}")


def _region(region_m, graph: HydroGraph, field) -> tuple[float, float, float, float]:
    if region_m is None:
        x0, y0, x1, y1 = graph.bounds()
        pad = max(graph.curves[a].width_m for a in graph.axes())
        return x0 - pad, y0 - pad, x1 + pad, y1 + pad
    if isinstance(region_m, (str, bytes)):
        raise TypeError(f"bake_flow_map: region_m must be (x0, y0, x1, y1) [m], got "
                        f"{region_m!r:.80}")
    try:
        x0, y0, x1, y1 = region_m
    except (TypeError, ValueError):
        raise ValueError(f"bake_flow_map: region_m must be (x0, y0, x1, y1) [m], got "
                         f"{region_m!r:.80}") from None
    x0, y0, x1, y1 = (_number(v, "bake_flow_map: region_m") for v in (x0, y0, x1, y1))
    if not all(map(math.isfinite, (x0, y0, x1, y1))) or x1 <= x0 or y1 <= y0:
        raise ValueError(f"bake_flow_map: region_m {region_m!r} needs finite x0 < x1, y0 < y1")
    return x0, y0, x1, y1


def _number(value, name: str) -> float:
    """A real number (NaN/inf pass: the caller's range check names them), else TypeError."""
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise TypeError(f"{name} must hold numbers [m], got {type(value).__name__} "
                        f"{value!r:.80}")
    try:
        return float(value)
    except OverflowError:                        # an int beyond float: not finite
        return math.inf


def _write_png(image: np.ndarray, path: Path, bits: int) -> None:
    """An (H, W, 4) RGBA array as a PNG: Pillow for 8 bits; pypng for 16 (Pillow cannot
    write 16-bit RGBA)."""
    if bits == 8:
        from PIL import Image

        Image.fromarray(np.ascontiguousarray(image)).save(path)
        return
    png = require("png", "writing a 16-bit flow map")
    h, w, _ = image.shape
    writer = png.Writer(w, h, greyscale=False, alpha=True, bitdepth=16)
    with open(path, "wb") as f:
        writer.write(f, image.reshape(h, w * 4))
