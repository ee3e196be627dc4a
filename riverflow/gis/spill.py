"""Spills out: concentration maps over time and gauge series for GIS platforms (issue 24).

:func:`bake_concentration` (``rf.bake_concentration``, ``riverflow spill``) runs a world's
spills to each of the given spill times and writes, per time, the concentration [kg/m³] at
every pixel centre of a region (north-up, the flow map's pixel layout:
:func:`riverflow.gis.bake.pixel_centres`):

- a float32 GeoTIFF ``concentration_<t>s.tif`` in the network's CRS (when known) through
  rasterio, the gis extra, or else
- a 16-bit greyscale PNG ``concentration_<t>s.png`` (value = round(65535 · c / max_kg_m3),
  max_kg_m3 the map's largest concentration) with a JSON sidecar (origin, cell, CRS, scale);

and ``gauges.csv``: the concentration at each gauge point at each time (columns
``time_s, <gauge name>…``), and ``spill.json``: the files, the spills' reports (mass in the
water, out per outlet, decayed) at each time.
"""
from __future__ import annotations

import csv
import json
import math
from pathlib import Path
from typing import NamedTuple

import numpy as np

from riverflow._atomic import atomic_files, strict_json
from riverflow._validate import check_allocation, finite_positive
from riverflow.gis.bake import BATCH_POINTS, MAX_SIDE_PX, _region, _write_png, pixel_centres

FORMAT = "riverflow-concentration/1"


class ConcentrationBake(NamedTuple):
    """What :func:`bake_concentration` wrote."""

    folder: Path
    images: list[Path]
    gauges_csv: Path | None
    index: Path
    times_s: list[float]
    """The spill times reached (whole solver steps: within one step of those asked for)."""
    size_px: tuple[int, int]
    geotiff: bool


def bake_concentration(world, region_m=None, cell_m: float | None = None, path="spill",
                       times_s=(0.0,), *, gauges_m=None, gauge_names=None,
                       geotiff: bool | None = None) -> ConcentrationBake:
    """Run ``world``'s spills to each of ``times_s`` (spill times [s], increasing, none before
    the spills' time now) and write a concentration map at each into the folder ``path``
    (module docstring).

    Args:
        world: a :class:`riverflow.RiverWorld` with spills (``world.add_spill``).
        region_m: (x0, y0, x1, y1) [m]; default: the network's bounds plus its widest axis.
        cell_m: pixel size [m]; default: the region's longer side / 1024.
        path: the output folder (made if missing).
        times_s: the spill times of the maps [s].
        gauges_m: (G, 2) gauge points [m] for ``gauges.csv`` (None: no CSV).
        gauge_names: their names (default ``gauge_<i>``).
        geotiff: True: GeoTIFF (ImportError without rasterio); False: PNG + JSON; None: GeoTIFF
            when rasterio is installed.

    Raises:
        ValueError: no spill in the world; times not finite, not increasing or before the
            spills' time; a bad region or cell size; a map over MAX_SIDE_PX a side.
    """
    solver = world.spill_solver
    if solver is None or not solver.n_spills:
        raise ValueError("bake_concentration: the world has no spill (world.add_spill first)")
    times = np.asarray(times_s, np.float64).reshape(-1)
    if not len(times) or not np.isfinite(times).all() or np.any(np.diff(times) <= 0):
        raise ValueError(f"bake_concentration: times_s must be finite and increasing, got "
                         f"{times_s!r:.80}")
    if times[0] < solver.time_s - solver.dt_s:
        raise ValueError(f"bake_concentration: times_s start at {times[0]:g} s, before the "
                         f"spills' time now, {solver.time_s:g} s")
    graph = world.scene.graph
    x0, y0, x1, y1 = _region(region_m, graph, world.field)
    if cell_m is None:
        cell_m = max(x1 - x0, y1 - y0) / 1024.0
    cell_m = finite_positive(cell_m, "bake_concentration: cell_m")
    fx, fy = (x1 - x0) / cell_m - 1e-9, (y1 - y0) / cell_m - 1e-9
    if not max(fx, fy) <= MAX_SIDE_PX:
        raise ValueError(f"bake_concentration: {fx:.4g}×{fy:.4g} px is over {MAX_SIDE_PX} px "
                         f"a side; use a larger cell_m than {cell_m:g} m or a smaller region_m")
    nx, ny = math.ceil(fx), math.ceil(fy)
    check_allocation(48.0 * nx * ny, f"bake_concentration: a {nx}×{ny} px map")
    gauges = None
    if gauges_m is not None:
        gauges = np.asarray(gauges_m, np.float64).reshape(-1, 2)
        if not np.isfinite(gauges).all():
            raise ValueError("bake_concentration: gauges_m must be finite (x, y) [m] points")
        names = list(gauge_names) if gauge_names is not None else \
            [f"gauge_{i}" for i in range(len(gauges))]
        if len(names) != len(gauges):
            raise ValueError("bake_concentration: one name per gauge point")
    if geotiff is None:
        try:
            import rasterio  # noqa: F401
            geotiff = True
        except ImportError:
            geotiff = False
    folder = Path(path)
    folder.mkdir(parents=True, exist_ok=True)
    centres = pixel_centres((x0, y0), cell_m, (nx, ny))
    psi = np.concatenate([world.field.potential(centres[a:a + BATCH_POINTS])
                          for a in range(0, len(centres), BATCH_POINTS)])   # once: ψ is steady
    wet = np.flatnonzero(np.isfinite(psi))
    gauge_psi = world.field.potential(gauges) if gauges is not None else None
    crs = getattr(graph, "crs", None)
    images, reached, rows, reports = [], [], [], []
    for t in times:
        world.advance_spills(max(float(t) - solver.time_s - solver.pending_s, 0.0))
        now = solver.time_s
        reached.append(now)
        c = np.zeros(nx * ny)
        if len(wet):
            c[wet] = solver.concentration(centres[wet], psi[wet])
        image = c.reshape(ny, nx)
        stem = f"concentration_{int(round(now)):07d}s"
        if geotiff:
            target = folder / f"{stem}.tif"
            _write_geotiff(image, target, (x0, y0 + ny * cell_m), cell_m, crs)
        else:
            target = folder / f"{stem}.png"
            _write_scaled_png(image, target, (x0, y0), cell_m, crs, now)
        images.append(target)
        if gauges is not None:
            rows.append([now, *solver.concentration(gauges, gauge_psi).tolist()])
        reports.append({"time_s": now, "image": target.name, "max_kg_m3": float(c.max()),
                        "spills": [_report_dict(solver.report(k)) for k in range(solver.n_spills)]})
    csv_path = None
    if gauges is not None:
        csv_path = folder / "gauges.csv"
        with atomic_files(csv_path) as (tmp,):
            with open(tmp, "w", newline="", encoding="utf-8") as f:
                w = csv.writer(f)
                w.writerow(["time_s", *names])
                w.writerows(rows)
    index = folder / "spill.json"
    meta = {"format": FORMAT, "origin_m": [x0, y0], "cell_m": cell_m, "size_px": [nx, ny],
            "bounds_m": [x0, y0, x0 + nx * cell_m, y0 + ny * cell_m],
            "rows": "north-up: row 0 is the northern edge (y = bounds_m[3])",
            "units": "kg/m3", "crs": crs, "geotiff": bool(geotiff),
            "gauges": None if gauges is None else
            [{"name": n, "xy_m": g.tolist()} for n, g in zip(names, gauges)],
            "frames": reports}
    text = strict_json(meta, where=f"bake_concentration: {index}", indent=2)
    with atomic_files(index) as (tmp,):
        tmp.write_text(text, encoding="utf-8")
    return ConcentrationBake(folder, images, csv_path, index, reached, (nx, ny), bool(geotiff))


def _report_dict(r) -> dict:
    return {"name": r.name, "released_kg": r.released_kg, "in_water_kg": r.in_water_kg,
            "out_kg": r.out_kg, "decayed_kg": r.decayed_kg,
            "front_m": None if math.isnan(r.front_m) else r.front_m,
            "tail_m": None if math.isnan(r.tail_m) else r.tail_m,
            "peak_kg_m3": r.peak_kg_m3}


def _write_geotiff(image: np.ndarray, path: Path, top_left, cell_m: float, crs) -> None:
    import rasterio
    from rasterio.transform import Affine

    h, w = image.shape
    with atomic_files(path) as (tmp,):
        with rasterio.open(tmp, "w", driver="GTiff", width=w, height=h, count=1,
                           dtype="float32", crs=crs, nodata=None,
                           transform=Affine(cell_m, 0.0, top_left[0], 0.0, -cell_m, top_left[1])) as ds:
            ds.write(image.astype(np.float32), 1)
            ds.update_tags(units="kg/m3")


def _write_scaled_png(image: np.ndarray, path: Path, origin, cell_m: float, crs, time_s) -> None:
    peak = float(image.max())
    scale = peak if peak > 0 else 1.0
    grey = np.clip(np.rint(65535.0 * image / scale), 0, 65535).astype(np.uint16)
    rgba = np.zeros(grey.shape + (4,), np.uint16)
    rgba[..., 0] = rgba[..., 1] = rgba[..., 2] = grey
    rgba[..., 3] = 65535
    sidecar = path.with_suffix(".json")
    meta = {"format": FORMAT, "image": path.name, "time_s": time_s, "origin_m": list(origin),
            "cell_m": cell_m, "size_px": [image.shape[1], image.shape[0]],
            "rows": "north-up: row 0 is the northern edge",
            "encoding": "R = G = B = round(65535 * c / max_kg_m3), c [kg/m3]",
            "max_kg_m3": scale, "crs": crs}
    text = strict_json(meta, where=f"bake_concentration: {sidecar}", indent=2)
    with atomic_files(sidecar, path) as (tmp_sidecar, tmp_image):
        _write_png(rgba, tmp_image, 16)
        tmp_sidecar.write_text(text, encoding="utf-8")


def read_concentration(path) -> tuple[np.ndarray, dict]:
    """A baked map back: concentration (rows, cols) [kg/m³] and its metadata (the GeoTIFF's
    transform and CRS, or the PNG's sidecar)."""
    path = Path(path)
    if path.suffix == ".tif":
        import rasterio

        with rasterio.open(path) as ds:
            return ds.read(1).astype(np.float64), {"transform": ds.transform, "crs": ds.crs}
    from riverflow._extras import require

    meta = json.loads(path.with_suffix(".json").read_text())
    png = require("png", "reading a 16-bit concentration map")
    width, height, rows, _ = png.Reader(filename=str(path)).asRGBA()
    rgba = np.vstack([np.asarray(r, np.float64) for r in rows]).reshape(height, width, 4)
    return rgba[..., 0] / 65535.0 * meta["max_kg_m3"], meta
