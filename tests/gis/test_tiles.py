"""rf.bake_tiles / riverflow bake --tiles (issue #26): a decoded tile pixel, un-projected, is the
FlowField's velocity there (rotation included); neighbouring tiles agree on their shared edge;
an interrupted bake resumed is byte-identical; several workers give the same bytes as one;
bad input is refused before anything is written. Also --format geotiff."""
from __future__ import annotations

import json

import numpy as np
import pytest
from PIL import Image

import riverflow as rf
from riverflow.gis import tiles as T
from tests.gis.conftest import ORIGIN, UTM, polyline, require_gis, write_lines

_, pyproj = require_gis()
ZOOMS = (14, 16)


@pytest.fixture(scope="module")
def river(tmp_path_factory):
    lines = [polyline((-300, 150), (-100, 60), (0, 0)), polyline((-300, -120), (0, 0)),
             polyline((0, 0), (150, -40), (300, 0))]
    path = write_lines(tmp_path_factory.mktemp("tiles") / "river.gpkg", lines,
                       {"W": np.array([24.0, 18.0, 36.0])})
    graph = rf.read_rivers(path, origin_m=None, width_m="W").build()
    return graph, rf.FlowField(graph)


@pytest.fixture(scope="module")
def baked(river, tmp_path_factory):
    _, field = river
    folder = tmp_path_factory.mktemp("pyramid") / "tiles"
    result = rf.bake_tiles(field, folder, ZOOMS)
    return result, _files(folder)


def _files(folder):
    return {p.relative_to(folder).as_posix(): p.read_bytes()
            for p in sorted(folder.rglob("*")) if p.is_file()}


def _tile(data):
    import io

    return np.asarray(Image.open(io.BytesIO(data)).convert("RGBA")).astype(np.float64)


def test_decoded_pixels_unprojected_are_the_flow(river, baked):
    _, field = river
    result, files = baked
    meta = json.loads(files["tiles.json"])
    assert meta["tilejson"] == "3.0.0" and meta["minzoom"] == 14 and meta["maxzoom"] == 16
    top = meta["riverflow"]["max_speed_mps"]
    assert top == result.max_speed_mps and "A" in meta["riverflow"]["encoding"]
    assert result.written == sum(k.endswith(".png") for k in files) >= 4
    assert result.empty > 0                                    # empty tiles are not written
    to_utm = pyproj.Transformer.from_crs("EPSG:3857", UTM, always_xy=True)
    errors, checked = [], 0
    for name, data in files.items():
        if not name.endswith(".png"):
            continue
        z, x, y = (int(v) for v in name[:-4].split("/"))
        rgba = _tile(data)
        assert (rgba[..., 3] == 255).all()
        water = (rgba[..., 2] > 127).ravel()
        merc = T.tile_pixel_centres(z, x, y)[water]
        v = ((rgba[..., :2] / 255.0 - 0.5) * 2.0 * top).reshape(-1, 2)[water]
        # un-project: a small step along the decoded vector, carried back into UTM
        speed = np.hypot(*v.T)
        step = 0.05 * np.stack([v[:, 0], v[:, 1]], 1) / np.maximum(speed, 1e-12)[:, None]
        ax, ay = to_utm.transform(merc[:, 0], merc[:, 1])
        bx, by = to_utm.transform(merc[:, 0] + step[:, 0], merc[:, 1] + step[:, 1])
        d = np.column_stack([bx - ax, by - ay])
        back = d / np.maximum(np.hypot(*d.T), 1e-15)[:, None] * speed[:, None]
        status, expected = field.query(np.column_stack([ax, ay]))
        assert (status == rf.FlowStatus.INSIDE).all()
        errors.append(np.hypot(*(back - expected).T))
        checked += water.sum()
    errors = np.concatenate(errors)
    assert checked > 1000
    assert errors.max() <= 0.02 * top
    # the rotation matters here: UTM 33N's grid is turned by ~0° at 15° E, so check the map
    # of a point off the central meridian turns vectors
    to_merc = pyproj.Transformer.from_crs(UTM, "EPSG:3857", always_xy=True)
    east = T.rotate_to_mercator(to_merc, np.array([[700_000.0, 5_000_000.0]]),
                                np.array([[0.0, 1.0]]))
    assert abs(np.degrees(np.arctan2(-east[0, 0], east[0, 1]))) > 1.0   # grid convergence


def test_neighbouring_tiles_agree_on_their_shared_edge(baked):
    _, files = baked
    names = {tuple(int(v) for v in k[:-4].split("/")) for k in files if k.endswith(".png")}
    pairs = 0
    for z, x, y in sorted(names):
        if (z, x + 1, y) not in names:
            continue
        a, b = (_tile(files[f"{z}/{x + i}/{y}.png"]) for i in (0, 1))
        across = np.abs(a[:, -1, :3] - b[:, 0, :3])
        inside = np.abs(a[:, -1, :3] - a[:, -2, :3])          # the step within a tile
        both = (a[:, -1, 2] > 127) & (b[:, 0, 2] > 127)
        assert both.sum() > 5
        assert across[both, :2].max() <= inside[both, :2].max() + 2
        assert (a[:, -1, 2] != b[:, 0, 2]).sum() <= (a[:, -1, 2] != a[:, -2, 2]).sum() + 2
        pairs += 1
    assert pairs >= 2


def test_an_interrupted_bake_resumed_is_byte_identical(river, baked, tmp_path, monkeypatch):
    _, field = river
    _, files = baked
    folder = tmp_path / "tiles"
    real, count = T._write_tile, []

    def dying(path, data):
        if len(count) == 2:
            raise KeyboardInterrupt("killed")
        count.append(path)
        real(path, data)

    monkeypatch.setattr(T, "_write_tile", dying)
    with pytest.raises(KeyboardInterrupt):
        rf.bake_tiles(field, folder, ZOOMS)
    monkeypatch.setattr(T, "_write_tile", real)
    partial = _files(folder)
    assert sum(k.endswith(".png") for k in partial) == 2 and "tiles.json" in partial
    resumed = rf.bake_tiles(field, folder, ZOOMS)
    assert resumed.skipped == 2
    assert _files(folder) == files                         # no temporaries left behind either


@pytest.fixture
def small_blocks(monkeypatch):
    """Blocks of 3 tiles: the pyramid's 16 candidate tiles make 6 tasks, for 2 workers."""
    monkeypatch.setattr(T, "BLOCK", 3)


def test_two_workers_give_the_bytes_of_one(river, baked, tmp_path, small_blocks):
    _, field = river
    _, files = baked
    result = rf.bake_tiles(field, tmp_path / "tiles", ZOOMS, workers=2, dask=False)
    assert _files(tmp_path / "tiles") == files
    assert result.written == sum(k.endswith(".png") for k in files)


def test_two_dask_workers_give_the_bytes_of_one(river, baked, tmp_path, small_blocks):
    dd = pytest.importorskip("dask.distributed", reason="the cluster extra (riverflow[cluster])")
    _, field = river
    _, files = baked
    # a LocalCluster of two thread workers in this process (cheap: no processes to start)
    with dd.LocalCluster(n_workers=2, threads_per_worker=1, processes=False,
                         dashboard_address=None) as cluster, dd.Client(cluster) as client:
        rf.bake_tiles(field, tmp_path / "tiles", ZOOMS, scheduler=client)
        assert len(client.scheduler_info()["workers"]) == 2
    assert _files(tmp_path / "tiles") == files


@pytest.mark.slow
def test_a_dask_worker_process_killed_mid_bake_loses_no_tiles(river, baked, tmp_path,
                                                               monkeypatch):
    """A LocalCluster of two worker processes; as soon as the first tile is on disk one worker
    is SIGKILLed (its nanny starts another, the scheduler hands its tasks on): the pyramid is
    still byte for byte the one worker's."""
    import os
    import signal
    import threading
    import time

    dd = pytest.importorskip("dask.distributed", reason="the cluster extra (riverflow[cluster])")
    _, field = river
    _, files = baked
    monkeypatch.setattr(T, "BLOCK", 1)                 # one task a tile: most are left to do
    out = tmp_path / "tiles"
    seen = {}
    with dd.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                         dashboard_address=None) as cluster, dd.Client(cluster) as client:
        def kill_one():
            deadline = time.monotonic() + 120.0
            while time.monotonic() < deadline and not any(out.rglob("*.png")):
                time.sleep(0.01)
            addr = sorted(client.scheduler_info()["workers"])[0]
            pid = client.run(os.getpid, workers=[addr])[addr]
            seen["on_disk"] = sum(1 for _ in out.rglob("*.png"))
            os.kill(pid, signal.SIGKILL)
            seen["killed"] = pid

        killer = threading.Thread(target=kill_one, daemon=True)
        killer.start()
        result = rf.bake_tiles(field, out, ZOOMS, scheduler=client)
        killer.join(timeout=30.0)
    assert "killed" in seen, "no worker was killed"
    assert seen["on_disk"] < result.written, f"killed after the bake: {seen}"
    assert _files(out) == files


def test_a_job_sent_to_another_process_bakes_the_same_bytes(river, baked, tmp_path):
    import pickle

    _, field = river
    _, files = baked
    job = T.Job(field, UTM, json.loads(files["tiles.json"])["riverflow"]["max_speed_mps"])
    sent = pickle.loads(pickle.dumps(job))          # what a Dask worker gets: the recipe
    assert sent.field is not field and sent.field.max_level == field.max_level
    name = next(k for k in files if k.endswith(".png"))
    z, x, y = (int(v) for v in name[:-4].split("/"))
    T.bake_block(sent, str(tmp_path), [(z, x, y)])
    assert (tmp_path / name).read_bytes() == files[name]


def test_a_worker_killed_mid_bake_loses_no_tiles(river, baked, tmp_path, monkeypatch,
                                                 small_blocks):
    import os

    _, field = river
    _, files = baked
    marker = tmp_path / "kill-once"
    marker.write_text("")
    real, parent = T.bake_block, os.getpid()

    def killed_once(job, folder, tiles):              # runs in the forked workers
        assert os.getpid() != parent
        real(job, folder, tiles[:1])                  # a tile written, then the process dies
        try:
            os.unlink(marker)
        except FileNotFoundError:
            return real(job, folder, tiles)
        os._exit(1)

    monkeypatch.setattr(T, "bake_block", killed_once)
    rf.bake_tiles(field, tmp_path / "tiles", ZOOMS, workers=2, dask=False)
    assert not marker.exists()
    assert _files(tmp_path / "tiles") == files


def test_bad_input_is_refused_and_nothing_written(river, tmp_path):
    graph, field = river
    out = tmp_path / "out"
    for zooms, match in (("13-23", "0 <= Z0"), ((-1, 3), "0 <= Z0"), ("5-3", "Z0 <= Z1"),
                         ("a-b", "Z0-Z1")):
        with pytest.raises(ValueError, match=match):
            rf.bake_tiles(field, out, zooms)
    (tmp_path / "file").write_text("x")
    with pytest.raises(NotADirectoryError, match="is a file"):
        rf.bake_tiles(field, tmp_path / "file", ZOOMS)
    with pytest.raises(ValueError, match="no water in region"):
        rf.bake_tiles(field, out, ZOOMS, region_m=(ORIGIN[0] + 5e3, ORIGIN[1], ORIGIN[0] + 6e3,
                                                   ORIGIN[1] + 1e3))
    with pytest.raises(ValueError, match="no CRS"):
        rf.bake_tiles(rf.FlowField(graph.__class__(**{**graph.__dict__, "crs": None})), out,
                      ZOOMS)
    pytest.importorskip("dask.distributed", reason="the cluster extra (riverflow[cluster])")
    with pytest.raises(OSError, match="cannot reach the Dask scheduler"):
        rf.bake_tiles(field, out, ZOOMS, scheduler="tcp://127.0.0.1:9")
    assert not out.exists()


def test_the_command_line_bakes_tiles_and_a_geotiff(tmp_path, capsys):
    rasterio = pytest.importorskip("rasterio")
    from riverflow.__main__ import main

    net = write_lines(tmp_path / "one.geojson", [polyline((-200, 0), (200, 0))],
                      {"width_m": np.array([20.0])})
    tiles = tmp_path / "tiles"
    assert main(["bake", "--scene", str(net), "--tiles", str(tiles), "--zoom", "15-15"]) == 0
    assert "tiles" in capsys.readouterr().out and (tiles / "tiles.json").exists()
    pngs = list(tiles.rglob("*.png"))
    assert pngs and all(p.parts[-3] == "15" for p in pngs)
    assert main(["bake", "--scene", str(net), "--tiles", str(tmp_path / "x"), "--zoom",
                 "3-30"]) == 1
    assert "--zoom" in capsys.readouterr().err or not (tmp_path / "x").exists()
    assert not (tmp_path / "x").exists()
    tif = tmp_path / "flow.tif"
    assert main(["bake", "--scene", str(net), "--region=-220,-40,220,40", "--cell-m", "4",
                 "--format", "geotiff", "--out", str(tif)]) == 0
    with rasterio.open(tif) as src:
        assert src.count == 4 and src.dtypes[0] == "float32" and src.crs is not None
        assert src.descriptions == ("vx", "vy", "mask", "distance")
        assert src.tags(ns="IMAGE_STRUCTURE")["LAYOUT"] == "COG"          # cloud-optimised
        vx, vy, mask, dist = src.read()
    water = mask > 0.5
    assert water.any() and (vx[water] > 0).all() and np.abs(vy[water]).max() < 0.2 * vx.max()
    assert np.isfinite(dist).all() and dist[water].max() <= 10.5
