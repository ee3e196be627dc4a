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

That is the ``"raw"`` preset. ``preset=`` writes what another engine's documented flow-map
shaders read instead (:data:`PRESETS`, docs/flowmaps.md): the same RG velocity, but with the V
axis of that engine's textures (``unreal``, ``source`` and ``godot-waterways`` sample with V
down the image, so G = 0.5 − vy / (2 · max_speed_mps)) and its B and A channels (Waterways:
foam and noise, plus its distance map; Unity, after Catlike Coding's flow shaders: speed and
noise). Every preset is linear data (no sRGB curve: import the texture as linear / non-colour).
:func:`direction_test_map` writes a known rotating flow in any preset, to check an import.
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
from riverflow._extras import require
from riverflow.hydro.graph import HydroGraph

MAX_SIDE_PX = 16384
"""Largest side of a baked map [px]."""
BATCH_POINTS = 1 << 16
"""Pixels queried at a time."""
FORMAT = "riverflow-flowmap/1"


class Preset(NamedTuple):
    """How one engine's flow-map shaders read a texture (docs/flowmaps.md)."""

    v_down: bool
    """True: the engine samples V down the image (DirectX, Godot): G holds −vy (south)."""
    blue: str
    """What B holds: "water", "speed", "foam" or "zero"."""
    alpha: str
    """What A holds: "distance", "noise" or "one"."""
    distance_map: bool
    """A second PNG ``<name>_dist.png``: R = 1 − distance / max_distance_m (Waterways)."""
    decode: str
    """The engine's formula, for the sidecar."""
    import_settings: str


PRESETS: dict[str, Preset] = {
    "raw": Preset(False, "water", "distance", False,
                  "v = (rg * 2 - 1) * max_speed_mps; x east, y north (V up the image)",
                  "linear data (no sRGB), no compression, bilinear filtering"),
    "unity": Preset(False, "speed", "noise", False,
                    "float2 flow = tex2D(_FlowMap, uv).rg * 2 - 1;  // UV space, V up "
                    "(Catlike Coding 'Texture Distortion'); B = speed / max_speed_mps "
                    "('Directional Flow'), A = noise (time offset)",
                    "Texture Type: Default; sRGB (Color Texture): off; Compression: None; "
                    "Wrap Mode: Clamp"),
    "unreal": Preset(True, "water", "distance", False,
                     "flow = (Texture.rg * 2 - 1) * float2(1, 1); UV space with V down the "
                     "image: G = 0.5 - vy / (2 max_speed_mps)",
                     "sRGB: off; Compression Settings: VectorDisplacementmap (RGBA8, no "
                     "compression); Texture Group: World; Address: Clamp"),
    "godot-waterways": Preset(True, "foam", "noise", True,
                              "flow = (texture(i_flowmap, uv).xy - 0.5) * 2.0 (V down); "
                              "b = foam mask, a = noise (time offset); i_distmap r = "
                              "1 - distance / max_distance_m, g = pressure (0)",
                              "Import as Texture: Compress Mode Lossless, sRGB / 'Detect 3D' "
                              "off (Godot 3: Flags > sRGB off; Godot 4: it is data, no "
                              "normal-map import), Mipmaps off, Filter on"),
    "source": Preset(True, "zero", "one", False,
                     "flow = tex2D(FlowmapSampler, uv).rg * 2 - 1 (V down the image, as "
                     "Source's textures are sampled)",
                     "VTF (VTFEdit): format RGBA8888, no gamma correction (linear), "
                     "Clamp S/T; $flowmap in the Water material, $flow_worlduvscale = 1 / "
                     "the map's width in world units"),
}
"""The presets ``bake_flow_map(preset=...)`` and ``riverflow bake --preset`` know."""


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
                  max_distance_m: float | None = None, preset: str = "raw") -> FlowMap:
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
        preset: one of :data:`PRESETS` (module docstring); ``"godot-waterways"`` also writes
            ``<name>_dist.png`` beside the map (and names it in the sidecar).

    Returns:
        A :class:`FlowMap`.

    Raises:
        ValueError: an unknown preset, a bad region, cell size, bit depth, max_speed_mps or max_distance_m
            (not a finite positive number), a file name not ending in ``.png``, or a map over
            MAX_SIDE_PX (checked before any pixel is computed).
        TypeError: region_m or cell_m not numbers (text, None inside, …), naming them.
        ImportError: ``bits=16`` without pypng (the gis extra).
    """
    started = time.perf_counter()
    field = _field(field_or_scene)
    graph = field.graph
    spec = preset_spec(preset, "bake_flow_map")
    if bits not in (8, 16):
        raise ValueError(f"bake_flow_map: bits must be 8 or 16, got {bits!r}")
    require_suffix(path, (".png",), f"a {bits}-bit flow map")
    for label, value in (("max_speed_mps", max_speed_mps), ("max_distance_m", max_distance_m)):
        if value is not None and not (isinstance(value, (int, float, np.number))
                                      and math.isfinite(value) and value > 0):
            raise ValueError(f"bake_flow_map: {label} must be a finite positive number, got "
                             f"{value!r}")
    (x0, y0, x1, y1), cell_m, (nx, ny), centres, status, velocity = _sample(
        field, region_m, cell_m, "bake_flow_map")
    water = status == FlowStatus.INSIDE
    speed = np.hypot(velocity[:, 0], velocity[:, 1])
    if max_speed_mps is None:
        max_speed_mps = float(speed[water].max()) if water.any() else 1.0
        max_speed_mps = max_speed_mps if max_speed_mps > 0 else 1.0
    distance = bank_distance(graph, centres, max_distance_m)
    if max_distance_m is None:
        max_distance_m = float(distance[water].max()) if water.any() else cell_m
        max_distance_m = max(max_distance_m, 1e-6)
    images = encode(preset, velocity, water, distance, (ny, nx), bits, max_speed_mps,
                    max_distance_m)
    path = Path(path)
    sidecar = path.with_suffix(".json")
    paths = [path] + ([distance_map_path(path)] if spec.distance_map else [])
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
        **preset_meta(preset, bits),
        "crs": getattr(graph, "crs", None),
        "source": graph.source,
    }
    if spec.distance_map:
        meta["distance_map"] = paths[1].name
    _write_all(images, paths, sidecar, meta, bits)
    return FlowMap(path, sidecar, (nx, ny), (x0, y0), cell_m, float(max_speed_mps),
                   float(max_distance_m), float(water.mean()), time.perf_counter() - started)


def preset_spec(preset, where: str) -> Preset:
    """The :class:`Preset` called ``preset``, or a ValueError naming ``where`` and the known
    ones."""
    if not isinstance(preset, str) or preset not in PRESETS:
        raise ValueError(f"{where}: unknown preset {preset!r:.80}; known: {', '.join(PRESETS)}")
    return PRESETS[preset]


def preset_meta(preset: str, bits: int) -> dict:
    """The sidecar's ``preset``, ``colour_space``, ``v_axis``, ``encoding``, ``decode`` and
    ``import_settings`` entries."""
    spec = PRESETS[preset]
    n = (1 << bits) - 1
    g = "0.5 - vy / (2 * max_speed_mps)" if spec.v_down else "0.5 + vy / (2 * max_speed_mps)"
    blue = {"water": f"water {n} / land 0",
            "speed": "min(|v| / max_speed_mps, 1)",
            "foam": "shore foam: clamp(distance_weight * shore * exp(-d / shore_m) * "
                    "(shore_calm + (1 - shore_calm) * min(|v| / speed_mps, 1)), 0, 1) "
                    "(riverflow.FoamSettings' defaults) on water, 0 on land",
            "zero": "0 (unused)"}[spec.blue]
    alpha = {"distance": "min(distance to the nearest bank / max_distance_m, 1)",
             "noise": "smooth value noise in [0, 1] (a time offset against pulsing)",
             "one": "1 (opaque)"}[spec.alpha]
    meta = {
        "preset": preset,
        "colour_space": "linear: mark the texture linear / non-colour (sRGB off)",
        "v_axis": ("down the image (south): G grows southward" if spec.v_down
                   else "up the image (north): G grows northward"),
        "encoding": {
            "R": f"0.5 + vx / (2 * max_speed_mps), vx east [m/s], times {n}",
            "G": f"{g}, vy north [m/s], times {n}",
            "B": f"{blue}, times {n}",
            "A": f"{alpha}, times {n}",
        },
        "decode": spec.decode,
        "import_settings": spec.import_settings,
    }
    if spec.distance_map:
        meta["encoding"]["distance_map"] = (f"R = (1 - min(d / max_distance_m, 1)) times {n}, "
                                            "G = 0 (pressure), B = 0, A = n")
    return meta


def encode(preset: str, velocity: np.ndarray, water: np.ndarray, distance: np.ndarray,
           shape: tuple[int, int], bits: int, max_speed_mps: float, max_distance_m: float
           ) -> list[np.ndarray]:
    """The images (rows, cols, 4) of a preset from per-pixel velocity (N, 2) [m/s], water (N,)
    bool and bank distance (N,) [m] (rows north-up, row by row): the map, then its distance
    map where the preset has one."""
    spec = PRESETS[preset]
    n = (1 << bits) - 1
    dtype = np.uint8 if bits == 8 else np.uint16
    v = velocity.astype(np.float64) / (2.0 * max_speed_mps)
    if spec.v_down:
        v[:, 1] = -v[:, 1]
    rgba = np.empty((len(velocity), 4), dtype)
    rgba[:, :2] = np.clip(np.rint(n * (0.5 + v)), 0, n)
    near = np.minimum(distance / max_distance_m, 1.0)
    speed = np.hypot(velocity[:, 0].astype(np.float64), velocity[:, 1])
    if spec.blue == "water":
        blue = np.where(water, 1.0, 0.0)
    elif spec.blue == "speed":
        blue = np.minimum(speed / max_speed_mps, 1.0)
    elif spec.blue == "foam":
        blue = np.where(water, shore_foam(distance, speed), 0.0)
    else:
        blue = np.zeros(len(velocity))
    if spec.alpha == "distance":
        alpha = near
    elif spec.alpha == "noise":
        alpha = value_noise(shape).ravel()
    else:
        alpha = np.ones(len(velocity))
    rgba[:, 2] = np.clip(np.rint(n * blue), 0, n)
    rgba[:, 3] = np.clip(np.rint(n * alpha), 0, n)
    images = [rgba.reshape(*shape, 4)]
    if spec.distance_map:
        dist = np.zeros((len(velocity), 4), dtype)
        dist[:, 0] = np.clip(np.rint(n * (1.0 - near)), 0, n)
        dist[:, 3] = n
        images.append(dist.reshape(*shape, 4))
    return images


def shore_foam(distance: np.ndarray, speed: np.ndarray, settings=None) -> np.ndarray:
    """The foam particles make at a shore (:mod:`riverflow.kernels.foam`'s shore term, with
    ``FoamSettings``' defaults): distance-weighted shore closeness, stronger where the water is
    fast, in [0, 1]."""
    from riverflow.components.foam import FoamSettings

    s = settings or FoamSettings()
    d = np.maximum(np.nan_to_num(distance, nan=np.inf, posinf=np.inf), 0.0)
    fast = np.minimum(speed / s.speed_mps, 1.0)
    shore = s.shore * np.exp(-d / s.shore_m) * (s.shore_calm + (1.0 - s.shore_calm) * fast)
    return np.clip(s.base + s.distance * np.clip(shore, 0.0, 1.0), 0.0, 1.0)


def value_noise(shape: tuple[int, int], cell_px: int = 16, seed: int = 26) -> np.ndarray:
    """Smooth value noise in [0, 1], (rows, cols): random values on a grid every ``cell_px``
    pixels, blended bilinearly with a smoothstep (the same for the same shape and seed)."""
    rows, cols = shape
    grid = np.random.default_rng(seed).random((rows // cell_px + 2, cols // cell_px + 2))
    y = (np.arange(rows) + 0.5) / cell_px
    x = (np.arange(cols) + 0.5) / cell_px
    iy, ix = y.astype(int), x.astype(int)
    fy, fx = y - iy, x - ix
    fy, fx = fy * fy * (3 - 2 * fy), fx * fx * (3 - 2 * fx)
    a = grid[iy][:, ix] * (1 - fx) + grid[iy][:, ix + 1] * fx
    b = grid[iy + 1][:, ix] * (1 - fx) + grid[iy + 1][:, ix + 1] * fx
    return a * (1 - fy)[:, None] + b * fy[:, None]


def distance_map_path(path) -> Path:
    """``flow.png`` → ``flow_dist.png`` (the Waterways distance map)."""
    path = Path(path)
    return path.with_name(path.stem + "_dist" + path.suffix)


def direction_test_map(path, preset: str = "raw", size_px: int = 256, *, bits: int = 8,
                       max_speed_mps: float = 1.0) -> Path:
    """Write the **direction test map** of a preset (and its sidecar): water turning
    counter-clockwise (seen from above, north up) about the image's centre, in a disc of radius
    0.45 · size_px px, at max_speed_mps on the rim; still land outside. Imported right, a
    flow-map shader sends the texture *up* the image on its right (east) side and to the
    *left* at its top (north); mirrored or reversed motion means a flipped axis
    (docs/flowmaps.md). Pixels are 1 m; returns the PNG's path."""
    spec = preset_spec(preset, "direction_test_map")
    if bits not in (8, 16):
        raise ValueError(f"direction_test_map: bits must be 8 or 16, got {bits!r}")
    require_suffix(path, (".png",), "a direction test map")
    size = int(size_px)
    if not 8 <= size <= MAX_SIDE_PX:
        raise ValueError(f"direction_test_map: size_px must be 8 … {MAX_SIDE_PX}, got "
                         f"{size_px!r}")
    centres = pixel_centres((-size / 2, -size / 2), 1.0, (size, size))
    velocity, water, distance = rotating_flow(centres, 0.45 * size, max_speed_mps)
    images = encode(preset, velocity, water, distance, (size, size), bits, max_speed_mps,
                    0.45 * size)
    path = Path(path)
    paths = [path] + ([distance_map_path(path)] if spec.distance_map else [])
    meta = {"format": FORMAT, "image": path.name, "origin_m": [-size / 2, -size / 2],
            "cell_m": 1.0, "size_px": [size, size], "bits": bits,
            "rows": "north-up: row 0 is the northern edge",
            "max_speed_mps": float(max_speed_mps), "max_distance_m": 0.45 * size,
            **preset_meta(preset, bits), "crs": None,
            "source": "riverflow direction test map: counter-clockwise rotation, "
                      "v = (-y, x) * max_speed_mps / radius about the centre"}
    if spec.distance_map:
        meta["distance_map"] = paths[1].name
    _write_all(images, paths, path.with_suffix(".json"), meta, bits)
    return path


def rotating_flow(points: np.ndarray, radius_m: float, max_speed_mps: float):
    """The direction test map's flow at points (N, 2) [m] about (0, 0): velocity (N, 2)
    [m/s] (counter-clockwise, max_speed_mps on the rim), water (N,) inside the disc, distance
    to the rim [m]."""
    r = np.hypot(points[:, 0], points[:, 1])
    water = r < radius_m
    omega = max_speed_mps / radius_m
    velocity = np.where(water[:, None], np.column_stack([-points[:, 1], points[:, 0]]) * omega,
                        0.0).astype(np.float32)
    return velocity, water, np.abs(radius_m - r)


def _write_all(images, paths, sidecar: Path, meta: dict, bits: int) -> None:
    """The images and the sidecar, together or not at all (the sidecar is renamed in first,
    so that a map found is whole)."""
    text = strict_json(meta, where=f"bake_flow_map: the sidecar {sidecar}", indent=2)
    with atomic_files(sidecar, *paths) as (tmp_sidecar, *tmp_images):
        for image, tmp in zip(images, tmp_images):
            _write_png(image, tmp, bits)
        tmp_sidecar.write_text(text, encoding="utf-8")


def _sample(field, region_m, cell_m, where: str):
    """The region, cell size, size, pixel centres and FlowField.query of a north-up map."""
    x0, y0, x1, y1 = _region(region_m, field.graph, field)
    if cell_m is None:
        cell_m = max(x1 - x0, y1 - y0) / 1024.0
    cell_m = finite_positive(cell_m, f"{where}: cell_m")   # a number (TypeError), > 0
    fx, fy = (x1 - x0) / cell_m - 1e-9, (y1 - y0) / cell_m - 1e-9
    if not max(fx, fy) <= MAX_SIDE_PX:        # also inf (a region of 1e308 m, cell_m 5e-324)
        raise ValueError(f"{where}: {fx:.4g}×{fy:.4g} px is over {MAX_SIDE_PX} px a "
                         f"side; use a larger cell_m than {cell_m:g} m or a smaller "
                         "region_m")
    nx, ny = max(1, math.ceil(fx)), max(1, math.ceil(fy))   # a cell wider than the region: 1 px
    # centres 16, status 1, velocity 8, speed 4, distance 8 + temporaries, RGBA ≤ 8 B a pixel
    check_allocation(64.0 * nx * ny, f"{where}: a {nx}×{ny} px map (cell_m={cell_m:g})")
    centres = pixel_centres((x0, y0), cell_m, (nx, ny))
    status = np.empty(nx * ny, np.uint8)
    velocity = np.empty((nx * ny, 2), np.float32)
    for a in range(0, nx * ny, BATCH_POINTS):
        status[a:a + BATCH_POINTS], velocity[a:a + BATCH_POINTS] = field.query(
            centres[a:a + BATCH_POINTS])
    return (x0, y0, x1, y1), cell_m, (nx, ny), centres, status, velocity


def bake_geotiff(field_or_scene, region_m=None, cell_m: float | None = None,
                 path="flow.tif") -> FlowMap:
    """Bake the flow of a region into a cloud-optimised GeoTIFF (``riverflow bake --format
    geotiff``) for QGIS and rasterio: four float32 bands, ``vx`` and ``vy`` [m/s] (x east, y
    north of the network's CRS), ``mask`` (1 water, 0 land) and ``distance`` to the nearest
    bank [m], north-up, in the network's CRS (none where the network has none), pixels as
    :func:`bake_flow_map`'s. Written under a temporary name and renamed into place.

    Raises:
        ValueError / TypeError: as :func:`bake_flow_map`; a name not ending in .tif/.tiff.
        ImportError: rasterio missing (the gis extra).
    """
    started = time.perf_counter()
    field = _field(field_or_scene)
    graph = field.graph
    require_suffix(path, (".tif", ".tiff"), "a cloud-optimised GeoTIFF")
    require("rasterio", "writing a GeoTIFF flow map")
    from rasterio.io import MemoryFile
    from rasterio.shutil import copy as rio_copy
    from rasterio.transform import from_origin

    (x0, y0, x1, y1), cell_m, (nx, ny), centres, status, velocity = _sample(
        field, region_m, cell_m, "bake_geotiff")
    water = status == FlowStatus.INSIDE
    distance = bank_distance(graph, centres)
    bands = np.stack([velocity[:, 0], velocity[:, 1], water.astype(np.float32),
                      np.where(np.isfinite(distance), distance, np.nan).astype(np.float32)]
                     ).reshape(4, ny, nx).astype(np.float32)
    crs = getattr(graph, "crs", None)
    profile = {"driver": "GTiff", "width": nx, "height": ny, "count": 4, "dtype": "float32",
               "transform": from_origin(x0, y0 + ny * cell_m, cell_m, cell_m),
               "crs": crs}
    path = Path(path)
    with atomic_files(path) as (tmp,):
        with MemoryFile() as mem:
            with mem.open(**profile) as dst:
                dst.write(bands)
                for i, (name, unit) in enumerate((("vx", "m/s"), ("vy", "m/s"),
                                                  ("mask", "1 water / 0 land"),
                                                  ("distance", "m")), start=1):
                    dst.set_band_description(i, name)
                    dst.update_tags(i, unit=unit)
                dst.update_tags(format=FORMAT, source=str(graph.source),
                                axes="vx east, vy north of the CRS; rows north-up")
            with mem.open() as src:
                rio_copy(src, str(tmp), driver="COG", COMPRESS="DEFLATE", PREDICTOR="3")
    speed = np.hypot(velocity[:, 0], velocity[:, 1])
    max_speed = float(speed[water].max()) if water.any() else 0.0
    finite = distance[water & np.isfinite(distance)]
    return FlowMap(path, path, (nx, ny), (x0, y0), cell_m, max_speed,
                   float(finite.max()) if finite.size else 0.0, float(water.mean()),
                   time.perf_counter() - started)


def pixel_centres(origin_m, cell_m: float, size_px) -> np.ndarray:
    """Centres (rows · cols, 2) [m] of a north-up map's pixels, row by row from the top."""
    x0, y0 = origin_m
    nx, ny = size_px
    xs = x0 + (np.arange(nx) + 0.5) * cell_m
    ys = y0 + (ny - np.arange(ny) - 0.5) * cell_m
    gx, gy = np.meshgrid(xs, ys)
    return np.column_stack([gx.ravel(), gy.ravel()])


def decode_flow_map(path) -> tuple[np.ndarray, np.ndarray, np.ndarray, dict]:
    """Read a baked map back (any preset): velocity (rows, cols, 2) [m/s] (x east, y north),
    water (rows, cols) bool and the distance to the nearest bank (rows, cols) [m] (clipped at
    max_distance_m) where the preset holds them (else None), and the sidecar's dict."""
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
    spec = PRESETS[meta.get("preset", "raw")]
    velocity = (rgba[..., :2] / n - 0.5) * 2.0 * meta["max_speed_mps"]
    if spec.v_down:
        velocity[..., 1] *= -1.0
    water = rgba[..., 2] > n / 2 if spec.blue == "water" else None
    distance = rgba[..., 3] / n * meta["max_distance_m"] if spec.alpha == "distance" else None
    return velocity, water, distance, meta


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
