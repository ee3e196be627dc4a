"""Web flow tiles: the river's flow as an XYZ PNG pyramid in Web Mercator, for browsers.

:func:`bake_tiles` (``rf.bake_tiles``, ``riverflow bake --tiles DIR --zoom Z0-Z1``) writes
``DIR/{z}/{x}/{y}.png`` (256 px, XYZ scheme: y = 0 at the north) for every tile of the zooms
that holds water, and ``DIR/tiles.json``, a TileJSON 3.0 document whose ``riverflow`` entry
carries max speed and the encoding::

    rf.bake_tiles(graph, "out/tiles", (10, 14))

Encoding of a pixel, sampled at its centre (8 bits, linear values, never premultiplied):

- R, G = round(255 · (0.5 + v / (2 · max_speed_mps))) for v = (vx, vy) [m/s] **rotated into
  EPSG:3857's axes** (x east along the Mercator grid, y north, i.e. up the tile) at that point
  and clipped: 128 is still water;
- B = 255 on water, 0 on land;
- A = 255 everywhere (a browser premultiplying alpha cannot destroy RGB).

The velocity is the FlowField's, queried in the network's CRS at the pixel centre unprojected
from Web Mercator; the rotation is the network CRS → EPSG:3857 Jacobian at that point divided
by its scale (exact for conformal CRSs: UTM, Lambert conformal, …).

Tiles with no water pixel are not written. The bake is resumable: tiles already in DIR are
skipped (every tile is written under a temporary name and renamed into place), and
``tiles.json`` (written first) fixes max speed for every later run. Tiles are baked in blocks
(:data:`BLOCK`) by the caller's process (``workers=1``), local processes
(``concurrent.futures``), or Dask (``riverflow[cluster]``: a ``LocalCluster`` of ``workers``
processes, or ``scheduler`` an existing cluster's address); the network goes to each worker
once (Dask: as a recipe, from which the worker makes the flow field again; the field's
obstacles are not carried) and a failed block is retried.
"""
from __future__ import annotations

import io
import json
import math
import sys
import time
from pathlib import Path
from typing import NamedTuple

import numpy as np

from riverflow._atomic import (atomic_write_bytes, atomic_write_text, remove_temporaries,
                               strict_json)
from riverflow._extras import require

TILE_PX = 256
MAX_ZOOM = 22
BLOCK = 16
"""Tiles a task bakes."""
RETRIES = 3
"""Times a failed block is run again (a worker killed, a lost Dask task)."""
FORMAT = "riverflow-flowtiles/1"
R_EARTH = 6378137.0
HALF = math.pi * R_EARTH
"""Half the width of the Web Mercator world [m]."""
SAMPLE_PX = 512
"""Side of the grid the default max speed is sampled on."""
HEADROOM = 1.25
"""The default max speed is the sampled one times this (water between the samples can be
faster, a confluence's jet: anything above max speed is clipped)."""


class TileSet(NamedTuple):
    """What :func:`bake_tiles` did."""

    folder: Path
    tilejson: Path
    zooms: tuple[int, int]
    written: int
    """Tiles written by this run."""
    skipped: int
    """Tiles already there (a resumed bake)."""
    empty: int
    """Candidate tiles with no water (not written)."""
    max_speed_mps: float
    seconds: float


class Job:
    """What every worker needs: the field, the network's CRS, max speed. (Not a tuple: Dask
    takes the tuples among a task's arguments apart and would pickle the field itself.)"""

    __slots__ = ("field", "crs", "max_speed_mps", "lock")

    def __init__(self, field, crs: str, max_speed_mps: float) -> None:
        import threading

        self.field, self.crs, self.max_speed_mps = field, crs, float(max_speed_mps)
        self.lock = threading.Lock()
        """FlowField is not thread-safe: threads of one process (Dask thread workers) query
        it one at a time."""

    def __reduce__(self):
        """Pickled (sent to a Dask worker): the graph and the field's quadtree and lattice,
        from which the worker makes the same field again (:func:`_job_from_recipe`)."""
        f = self.field
        qt = f.tiles.quadtree
        options = {"slip": f.slip, "search_radius_factor": f.search_radius_factor,
                   "domain_m": (qt.root_x_m, qt.root_y_m, qt.root_size_m),
                   "lattice_cells": f.tiles.n_cells,
                   # the node spacing of the field's finest level gives that level again
                   "potential_delta_m": qt.root_size_m / (f.tiles.n_cells * 2 ** f.max_level)}
        return (_job_from_recipe, (f.graph, options, f.max_level, self.crs,
                                   self.max_speed_mps))


def _job_from_recipe(graph, options, max_level, crs, max_speed_mps) -> Job:
    """A worker's Job (made once per worker: the job is scattered to each worker once)."""
    from riverflow.hydro.flow_field import FlowField

    field = FlowField(graph, **options)
    if field.max_level != max_level:
        raise RuntimeError(f"bake_tiles: the worker's flow field has quadtree level "
                           f"{field.max_level}, the caller's {max_level}")
    return Job(field, crs, max_speed_mps)


def parse_zooms(text) -> tuple[int, int]:
    """``"Z"`` or ``"Z0-Z1"`` (or a pair) → (z0, z1), each 0 … 22, z0 ≤ z1; else ValueError."""
    try:
        if isinstance(text, str):
            parts = text.split("-")
            z0, z1 = (int(parts[0]), int(parts[-1])) if len(parts) <= 2 else (None, None)
        else:
            z0, z1 = (int(v) for v in text)
    except (TypeError, ValueError):
        z0 = z1 = None
    if z0 is None or not (0 <= z0 <= z1 <= MAX_ZOOM):
        raise ValueError(f"bake_tiles: zoom must be Z or Z0-Z1 with 0 <= Z0 <= Z1 <= "
                         f"{MAX_ZOOM}, got {text!r:.40}")
    return z0, z1


def bake_tiles(field_or_scene, folder, zooms=(0, 14), *, crs: str | None = None,
               region_m=None, max_speed_mps: float | None = None, workers: int = 1,
               scheduler: str | None = None, dask: bool | None = None,
               progress: bool = False) -> TileSet:
    """Bake the flow into an XYZ tile pyramid (module docstring).

    Args:
        field_or_scene: a :class:`~riverflow.FlowField`, a scene or a hydro graph.
        folder: the pyramid's folder (made; tiles already there are kept and skipped).
        zooms: ``(z0, z1)`` or ``"Z0-Z1"``, 0 ≤ z0 ≤ z1 ≤ 22.
        crs: the network's CRS (default: the graph's; a built-in scene has none: give one).
        region_m: (x0, y0, x1, y1) in the network's CRS to bake (default: the whole network).
        max_speed_mps: speed of R, G = 0 or 255 (default: the one in an existing tiles.json,
            else HEADROOM × the fastest water on a 512² grid over the region; faster water
            is clipped).
        workers: processes (1: this one).
        scheduler: a Dask scheduler's address (``tcp://host:8786``), or a
            ``dask.distributed.Client``: bake there.
        dask: ``workers`` > 1 run on a Dask ``LocalCluster`` (True), on local processes
            (False), or on Dask where dask.distributed is installed (None).
        progress: a progress bar on stderr.

    Raises:
        ValueError: zooms out of 0 … 22, no CRS, a region with no water, a max speed that is
            not a finite positive number or differs from the existing tiles.json's, workers < 1.
        NotADirectoryError: folder is a file. Nothing is written before these checks pass.
        ImportError: pyproj missing (the gis extra); ``scheduler`` without dask.distributed.
        OSError: a scheduler that cannot be reached (nothing written).
    """
    from riverflow.gis.bake import _field, _region

    started = time.perf_counter()
    z0, z1 = parse_zooms(zooms)
    field = _field(field_or_scene)
    graph = field.graph
    folder = Path(folder)
    if folder.exists() and not folder.is_dir():
        raise NotADirectoryError(f"bake_tiles: {folder} is a file, expected a folder for the "
                                 "tiles")
    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
        raise ValueError(f"bake_tiles: workers must be a whole number >= 1, got {workers!r}")
    crs = crs or getattr(graph, "crs", None)
    if not crs:
        raise ValueError("bake_tiles: the network has no CRS (a built-in or Proland scene); "
                         "give crs= (riverflow bake --crs EPSG:…) to place it on the Earth")
    pyproj = require("pyproj", "baking web tiles")
    try:
        pyproj.CRS.from_user_input(crs)
    except pyproj.exceptions.CRSError as exc:
        raise ValueError(f"bake_tiles: crs {crs!r:.80} is not a CRS pyproj knows ({exc})") \
            from None
    region = _region(region_m, graph, field)
    water = water_shapes(graph, region)
    if water is None:
        raise ValueError(f"bake_tiles: no water in region {tuple(round(v, 1) for v in region)} "
                         f"of {graph.source or 'the network'}; nothing written")
    tilejson = folder / "tiles.json"
    existing = _existing_max_speed(tilejson)
    if max_speed_mps is not None:
        if not (isinstance(max_speed_mps, (int, float)) and math.isfinite(max_speed_mps)
                and max_speed_mps > 0):
            raise ValueError(f"bake_tiles: max_speed_mps must be a finite positive number, "
                             f"got {max_speed_mps!r}")
        if existing is not None and abs(existing - max_speed_mps) > 1e-12 * existing:
            raise ValueError(f"bake_tiles: {tilejson} was baked with max speed {existing} m/s, "
                             f"not {max_speed_mps}: bake into another folder")
    own_client = not (scheduler is not None and hasattr(scheduler, "submit"))
    if not own_client:
        client = scheduler                     # a dask.distributed Client the caller holds
    elif scheduler is not None:
        client = _dask_client(scheduler)
    elif workers > 1 and dask is not False:
        client = _local_cluster(workers, required=bool(dask))
    else:
        client = None
    try:
        candidates = candidate_tiles(water, crs, z0, z1)
        if not candidates:
            raise ValueError(f"bake_tiles: no tile of zooms {z0}-{z1} touches water in "
                             f"{folder}'s region; nothing written")
        speed = float(max_speed_mps or existing or sample_max_speed(field, region))
        meta = tile_json(graph, crs, z0, z1, water, speed)
        folder.mkdir(parents=True, exist_ok=True)
        if not tilejson.exists():
            atomic_write_text(tilejson, strict_json(meta, where=f"bake_tiles: {tilejson}",
                                                    indent=2))
        todo = [t for t in candidates if not tile_path(folder, *t).exists()]
        skipped = len(candidates) - len(todo)
        job = Job(field, crs, speed)
        blocks = [todo[a:a + BLOCK] for a in range(0, len(todo), BLOCK)]
        bar = _Progress(len(todo), progress)
        for processed in _run(job, folder, blocks, workers, client):
            bar.step(processed)
        bar.close()
    finally:
        if client is not None and own_client:
            _close(client)
    remove_temporaries(folder)   # what a worker killed mid-write left (its tiles were redone)
    # empty tiles: what was to do and is still not on disk
    empty = sum(1 for t in todo if not tile_path(folder, *t).exists())
    written = len(todo) - empty
    return TileSet(folder, tilejson, (z0, z1), written, skipped, empty, speed,
                   time.perf_counter() - started)


def tile_path(folder: Path, z: int, x: int, y: int) -> Path:
    return folder / str(z) / str(x) / f"{y}.png"


def tile_pixel_centres(z: int, x: int, y: int) -> np.ndarray:
    """EPSG:3857 centres (256², 2) [m] of a tile's pixels, row by row from the top (north)."""
    size = 2.0 * HALF / (1 << z)
    steps = (np.arange(TILE_PX) + 0.5) * (size / TILE_PX)
    xs = -HALF + x * size + steps
    ys = HALF - y * size - steps
    gx, gy = np.meshgrid(xs, ys)
    return np.column_stack([gx.ravel(), gy.ravel()])


def tile_bounds(z: int, x: int, y: int) -> tuple[float, float, float, float]:
    """(x0, y0, x1, y1) of a tile in EPSG:3857 [m]."""
    size = 2.0 * HALF / (1 << z)
    return -HALF + x * size, HALF - (y + 1) * size, -HALF + (x + 1) * size, HALF - y * size


def water_shapes(graph, region):
    """The network's water (each axis buffered by its half width, in the network's CRS) cut
    to region, or None where there is none."""
    import shapely

    parts = []
    for a in graph.axes():
        line = shapely.LineString(graph.polyline(a))
        parts.append(line.buffer(0.5 * graph.curves[a].width_m + 1.0))
    for k, _ in enumerate(getattr(graph, "areas", []) or []):
        try:
            from riverflow.hydro.areas import area_ring

            parts.append(shapely.Polygon(area_ring(graph, k)))
        except Exception:       # an area whose ring cannot be made: its axes still count
            continue
    if not parts:
        return None
    box = shapely.box(*region)
    water = shapely.intersection(shapely.union_all(parts), box)
    return None if water.is_empty else water


def candidate_tiles(water, crs: str, z0: int, z1: int) -> list[tuple[int, int, int]]:
    """Tiles (z, x, y) of zooms z0 … z1 whose footprint meets ``water`` (network CRS), found
    by descending from zoom 0 (children of tiles that meet it), sorted."""
    import pyproj
    import shapely

    to_net = pyproj.Transformer.from_crs("EPSG:3857", crs, always_xy=True)
    prepared = water
    shapely.prepare(prepared)
    out: list[tuple[int, int, int]] = []
    level = [(0, 0, 0)]
    for z in range(0, z1 + 1):
        keep = []
        for t in level:
            x0, y0, x1, y1 = tile_bounds(*t)
            # the tile's outline, densified, in the network's CRS (slightly grown: a pixel)
            pad = (x1 - x0) / TILE_PX
            s = np.linspace(0.0, 1.0, 9)
            xs = np.concatenate([x0 - pad + s * (x1 - x0 + 2 * pad), np.full(9, x1 + pad),
                                 x1 + pad - s * (x1 - x0 + 2 * pad), np.full(9, x0 - pad)])
            ys = np.concatenate([np.full(9, y0 - pad), y0 - pad + s * (y1 - y0 + 2 * pad),
                                 np.full(9, y1 + pad), y1 + pad - s * (y1 - y0 + 2 * pad)])
            with np.errstate(all="ignore"):
                nx, ny = to_net.transform(xs, ys)
            ok = np.isfinite(nx) & np.isfinite(ny)
            if ok.sum() < 3:
                continue
            if z < 3 or shapely.intersects(prepared, shapely.Polygon(
                    np.column_stack([nx[ok], ny[ok]])).buffer(0)):
                keep.append(t)
        if z >= z0:
            out.extend(keep)
        level = [(z + 1, 2 * x + i, 2 * y + j) for _, x, y in keep for j in (0, 1)
                 for i in (0, 1)]
    return sorted(out)


def sample_max_speed(field, region) -> float:
    """HEADROOM × the fastest water on a SAMPLE_PX² grid over region [m/s] (1 where none
    moves)."""
    from riverflow.components.status import FlowStatus
    from riverflow.gis.bake import pixel_centres

    x0, y0, x1, y1 = region
    cell = max(x1 - x0, y1 - y0) / SAMPLE_PX
    nx, ny = max(1, math.ceil((x1 - x0) / cell)), max(1, math.ceil((y1 - y0) / cell))
    status, velocity = field.query(pixel_centres((x0, y0), cell, (nx, ny)))
    speed = np.hypot(velocity[:, 0], velocity[:, 1])[status == FlowStatus.INSIDE]
    top = float(speed.max()) if speed.size else 0.0
    return HEADROOM * top if top > 0 else 1.0


def tile_json(graph, crs, z0, z1, water, max_speed_mps) -> dict:
    import pyproj

    to_ll = pyproj.Transformer.from_crs(crs, "EPSG:4326", always_xy=True)
    lon0, lat0, lon1, lat1 = to_ll.transform_bounds(*water.bounds, densify_pts=21)
    return {
        "tilejson": "3.0.0",
        "name": f"riverflow flow: {graph.source or 'network'}",
        "scheme": "xyz",
        "tiles": ["{z}/{x}/{y}.png"],
        "minzoom": z0,
        "maxzoom": z1,
        "bounds": [lon0, lat0, lon1, lat1],
        "center": [(lon0 + lon1) / 2, (lat0 + lat1) / 2, z1],
        "riverflow": {
            "format": FORMAT,
            "projection": "EPSG:3857",
            "tile_px": TILE_PX,
            "max_speed_mps": max_speed_mps,
            "crs": str(crs),
            "colour_space": "linear values; A = 255 (not premultiplied)",
            "encoding": {
                "R": "round(255 * (0.5 + vx / (2 * max_speed_mps))), vx along EPSG:3857's x "
                     "(east) [m/s]",
                "G": "round(255 * (0.5 + vy / (2 * max_speed_mps))), vy along EPSG:3857's y "
                     "(north, up the tile) [m/s]",
                "B": "255 water / 0 land",
                "A": "255",
            },
            "decode": "v = (rg * 2 - 1) * max_speed_mps (rg in 0..1); y up the tile",
            "empty_tiles": "not written: a missing tile holds no water",
        },
    }


def render_tile(job: Job, z: int, x: int, y: int) -> np.ndarray | None:
    """The RGBA (256, 256, 4) uint8 of one tile, or None where it holds no water."""
    from riverflow.components.status import FlowStatus

    to_net, to_merc = _transformers(job.crs)
    merc = tile_pixel_centres(z, x, y)
    with np.errstate(all="ignore"):
        nx, ny = to_net.transform(merc[:, 0], merc[:, 1])
    pts = np.column_stack([nx, ny])
    ok = np.isfinite(pts).all(axis=1)
    status = np.zeros(len(pts), np.uint8)
    velocity = np.zeros((len(pts), 2), np.float32)
    if ok.any():
        with job.lock:
            status[ok], velocity[ok] = job.field.query(pts[ok])
    water = status == FlowStatus.INSIDE
    if not water.any():
        return None
    v = rotate_to_mercator(to_merc, pts[water], velocity[water].astype(np.float64))
    rgba = np.empty((len(pts), 4), np.uint8)
    rgba[:, :2] = 128
    rgba[water, :2] = np.clip(np.rint(255.0 * (0.5 + v / (2.0 * job.max_speed_mps))), 0, 255)
    rgba[:, 2] = np.where(water, 255, 0)
    rgba[:, 3] = 255
    return rgba.reshape(TILE_PX, TILE_PX, 4)


def rotate_to_mercator(to_merc, points: np.ndarray, velocity: np.ndarray,
                       step_m: float = 1.0) -> np.ndarray:
    """Velocity (N, 2) at points (N, 2) of the network's CRS, in EPSG:3857's axes: the
    Jacobian of the projection (central differences of ``step_m``) divided by its scale
    √|det J|, so the speed [m/s] is kept and only the direction turns."""
    px, py = points[:, 0], points[:, 1]
    h = step_m
    ax, ay = to_merc.transform(px + h, py)
    bx, by = to_merc.transform(px - h, py)
    cx, cy = to_merc.transform(px, py + h)
    dx, dy = to_merc.transform(px, py - h)
    j11, j21 = (ax - bx) / (2 * h), (ay - by) / (2 * h)
    j12, j22 = (cx - dx) / (2 * h), (cy - dy) / (2 * h)
    scale = np.sqrt(np.abs(j11 * j22 - j12 * j21))
    vx, vy = velocity[:, 0], velocity[:, 1]
    return np.column_stack([(j11 * vx + j12 * vy) / scale, (j21 * vx + j22 * vy) / scale])


def encode_png(rgba: np.ndarray) -> bytes:
    from PIL import Image

    buf = io.BytesIO()
    Image.fromarray(rgba).save(buf, format="PNG")
    return buf.getvalue()


def bake_block(job: Job, folder: str, tiles) -> int:
    """Bake and write a block of tiles (skipping those already written); returns how many
    it processed. Safe to run twice (a retried task): every write is atomic."""
    folder = Path(folder)
    for z, x, y in tiles:
        path = tile_path(folder, z, x, y)
        if path.exists():
            continue
        rgba = render_tile(job, z, x, y)
        if rgba is None:
            continue
        _write_tile(path, encode_png(rgba))
    return len(tiles)


def _write_tile(path: Path, data: bytes) -> None:
    atomic_write_bytes(path, data)


_TRANSFORMERS: dict = {}


def _transformers(crs: str):
    if crs not in _TRANSFORMERS:
        import pyproj

        _TRANSFORMERS[crs] = (pyproj.Transformer.from_crs("EPSG:3857", crs, always_xy=True),
                              pyproj.Transformer.from_crs(crs, "EPSG:3857", always_xy=True))
    return _TRANSFORMERS[crs]


# --- where the blocks run -------------------------------------------------------------------

_WORKER_JOB: Job | None = None


def _init_worker(job: Job) -> None:
    global _WORKER_JOB
    _WORKER_JOB = job


def _worker_block(folder: str, tiles) -> int:
    return bake_block(_WORKER_JOB, folder, tiles)


def _run(job: Job, folder: Path, blocks, workers: int, client):
    """Bake the blocks; yields the tiles processed by each finished block."""
    if client is not None:
        yield from _run_dask(client, job, folder, blocks)
        return
    if workers == 1 or len(blocks) <= 1:
        for block in blocks:
            yield bake_block(job, str(folder), block)
        return
    from concurrent.futures import ProcessPoolExecutor, as_completed
    from concurrent.futures.process import BrokenProcessPool
    import multiprocessing

    ctx = multiprocessing.get_context("fork" if sys.platform.startswith("linux") else None)
    pending = list(range(len(blocks)))
    for attempt in range(RETRIES + 1):
        # a worker killed mid-bake breaks the pool: the blocks not reported are run again on a
        # new one (their tiles already written are skipped)
        try:
            with ProcessPoolExecutor(workers, mp_context=ctx, initializer=_init_worker,
                                     initargs=(job,)) as pool:
                futures = {pool.submit(_worker_block, str(folder), blocks[i]): i
                           for i in pending}
                for f in as_completed(futures):
                    yield f.result()
                    pending.remove(futures[f])
            return
        except BrokenProcessPool:
            if attempt == RETRIES:
                raise


def _local_cluster(workers: int, required: bool):
    """A Dask client on a new LocalCluster of ``workers`` one-thread processes (closed with
    the client), or None without dask.distributed unless ``required``."""
    try:
        dd = _require_dask()
    except ImportError:
        if required:
            raise
        return None
    cluster = dd.LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                              dashboard_address=None)
    client = dd.Client(cluster)
    client._riverflow_cluster = cluster
    return client


def _close(client) -> None:
    cluster = getattr(client, "_riverflow_cluster", None)
    client.close()
    if cluster is not None:
        cluster.close()


def _dask_client(scheduler: str):
    dd = _require_dask()
    if not isinstance(scheduler, str) or "://" not in scheduler and ":" not in scheduler:
        raise ValueError(f"bake_tiles: scheduler must be an address like tcp://host:8786, got "
                         f"{scheduler!r:.80}")
    try:
        return dd.Client(scheduler, timeout="3s")
    except (OSError, TimeoutError, ValueError) as exc:
        raise OSError(f"bake_tiles: cannot reach the Dask scheduler {scheduler!r}: {exc}") \
            from None


def _require_dask():
    try:
        import dask.distributed as dd
    except ImportError as exc:
        raise ImportError(f"baking on Dask needs dask.distributed ({exc}): pip install "
                          "'riverflow[cluster]'") from exc
    return dd


def _run_dask(client, job: Job, folder: Path, blocks):
    dd = _require_dask()
    # the network goes to each worker once: a task that holds the job (a task, not scattered
    # data, so that the scheduler can make it again when the worker holding it is killed)
    shared = client.submit(_hold, job, pure=False)
    futures = [client.submit(bake_block, shared, str(folder), b, retries=RETRIES, pure=False)
               for b in blocks]
    for f in dd.as_completed(futures):
        yield f.result()


def _hold(job: Job) -> Job:
    return job


def _existing_max_speed(tilejson: Path) -> float | None:
    if not tilejson.is_file():
        return None
    try:
        return float(json.loads(tilejson.read_text())["riverflow"]["max_speed_mps"])
    except (ValueError, KeyError, TypeError) as exc:
        raise ValueError(f"bake_tiles: {tilejson} is not a riverflow TileJSON ({exc}); bake "
                         "into another folder") from None


class _Progress:
    """A one-line progress bar on stderr."""

    def __init__(self, total: int, on: bool) -> None:
        self.total, self.done, self.on = total, 0, on and total > 0
        self.started = time.perf_counter()
        self._draw()

    def step(self, n: int) -> None:
        self.done = min(self.total, self.done + n)
        self._draw()

    def _draw(self) -> None:
        if not self.on:
            return
        width = 30
        fill = int(width * self.done / self.total)
        rate = self.done / max(time.perf_counter() - self.started, 1e-9)
        print(f"\r[{'#' * fill}{'.' * (width - fill)}] {self.done}/{self.total} tiles "
              f"({rate:.1f}/s)", end="", file=sys.stderr, flush=True)

    def close(self) -> None:
        if self.on:
            print(file=sys.stderr)

