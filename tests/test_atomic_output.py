"""Atomic output (issue #30, item 4): every file the package writes appears complete or not at
all; a flow map and its sidecar appear together or not at all; sidecars are strict JSON; the
extension decides the format or is an error."""
from __future__ import annotations

import json
import os

import numpy as np
import pytest

import riverflow as rf
from riverflow import _atomic
from riverflow.gis import bake
from riverflow.hydro.builder import RiverNetworkBuilder
from riverflow.images import save_png

REGION = (-20.0, -60.0, 420.0, 60.0)


@pytest.fixture(scope="module")
def field():
    b = RiverNetworkBuilder()
    b.add_branch([(0, 0), (200, 30), (400, 0)], 40.0, discharge_m2s=40.0)
    return rf.FlowField(b.build())


def leftovers(folder):
    return sorted(p.name for p in folder.iterdir())


class Interrupted(Exception):
    pass


def test_a_bake_interrupted_between_image_and_sidecar_leaves_neither(field, tmp_path,
                                                                     monkeypatch):
    real = bake._write_png

    def image_then_stop(image, path, bits):
        real(image, path, bits)
        assert path.exists()                       # the image was written …
        raise Interrupted                          # … and the bake stops before the sidecar

    monkeypatch.setattr(bake, "_write_png", image_then_stop)
    with pytest.raises(Interrupted):
        rf.bake_flow_map(field, REGION, 4.0, tmp_path / "flow.png")
    assert leftovers(tmp_path) == []


def test_a_bake_whose_second_rename_fails_leaves_neither(field, tmp_path, monkeypatch):
    calls = []
    real = os.replace

    def second_fails(a, b):
        calls.append(b)
        if len(calls) == 2:
            raise OSError("disk gone")
        real(a, b)

    monkeypatch.setattr(_atomic.os, "replace", second_fails)
    with pytest.raises(OSError, match="disk gone"):
        rf.bake_flow_map(field, REGION, 4.0, tmp_path / "flow.png")
    assert len(calls) == 2
    assert leftovers(tmp_path) == []


def test_a_bake_replaces_an_old_pair_whole_and_leaves_no_temporaries(field, tmp_path):
    first = rf.bake_flow_map(field, REGION, 8.0, tmp_path / "flow.png")
    second = rf.bake_flow_map(field, REGION, 4.0, tmp_path / "flow.png", bits=16)
    assert leftovers(tmp_path) == ["flow.json", "flow.png"]
    meta = json.loads(second.sidecar.read_text())
    assert meta["bits"] == 16 and meta["cell_m"] == 4.0 and first.size_px != second.size_px
    velocity, water, _, _ = bake.decode_flow_map(second.image)
    assert velocity.shape[:2] == (second.size_px[1], second.size_px[0]) and water.any()


@pytest.mark.parametrize("bad", [float("nan"), float("inf"), -1.0, 0.0, "2"])
@pytest.mark.parametrize("name", ["max_speed_mps", "max_distance_m"])
def test_sidecar_values_must_be_finite_and_positive(field, tmp_path, name, bad):
    with pytest.raises(ValueError, match=name):
        rf.bake_flow_map(field, REGION, 4.0, tmp_path / "flow.png", **{name: bad})
    assert leftovers(tmp_path) == []


def test_a_sidecar_is_strict_json(field, tmp_path):
    result = rf.bake_flow_map(field, REGION, 4.0, tmp_path / "flow.png", max_speed_mps=2.5)
    text = result.sidecar.read_text()
    meta = json.loads(text, parse_constant=lambda c: pytest.fail(f"non-JSON constant {c}"))
    assert meta["max_speed_mps"] == 2.5
    with pytest.raises(ValueError, match=r"max_speed_mps is nan"):
        _atomic.strict_json({"max_speed_mps": float("nan")}, where="x")
    with pytest.raises(ValueError, match=r"bounds_m\[2\] is inf"):
        _atomic.strict_json({"bounds_m": [0.0, 1.0, float("inf")]}, where="x")


@pytest.mark.parametrize("name", ["flow.jpg", "flow.PNG.jpg", "flow", "flow.tif"])
@pytest.mark.parametrize("bits", [8, 16])
def test_the_extension_decides_the_format_or_is_an_error(field, tmp_path, name, bits):
    with pytest.raises(ValueError, match=r"\.png"):
        rf.bake_flow_map(field, REGION, 4.0, tmp_path / name, bits=bits)
    assert leftovers(tmp_path) == []
    rf.bake_flow_map(field, REGION, 8.0, tmp_path / "upper.PNG", bits=bits)
    assert (tmp_path / "upper.PNG").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_save_png_is_atomic_and_checks_its_input(tmp_path, monkeypatch):
    frame = np.zeros((4, 6, 4), np.uint8)
    path = save_png(frame, tmp_path / "a" / "frame.png")
    assert path.read_bytes()[:4] == b"\x89PNG"
    with pytest.raises(ValueError, match=r"frame\.jpg.*\.png"):
        save_png(frame, tmp_path / "frame.jpg")
    with pytest.raises(ValueError, match="frame must be"):
        save_png(frame[..., :3], tmp_path / "b.png")

    def broken(*args, **kwargs):
        raise Interrupted

    from PIL import Image
    monkeypatch.setattr(Image.Image, "save", broken)
    with pytest.raises(Interrupted):
        save_png(frame, tmp_path / "c.png")
    assert leftovers(tmp_path) == ["a"]
    assert leftovers(tmp_path / "a") == ["frame.png"]


def test_save_graph_is_atomic(field, tmp_path, monkeypatch):
    path = tmp_path / "river.graph"
    rf.save_graph(field.graph, path)
    before = path.read_bytes()
    assert len(rf.load_graph(path).curves) == len(field.graph.curves)

    class HalfFull:                             # the disk fills half way through
        def __init__(self, name, mode):
            self.f = open(name, mode)

        def __enter__(self):
            return self

        def __exit__(self, *exc):
            self.f.close()

        def write(self, data):
            self.f.write(data[:len(data) // 2])
            raise OSError("No space left on device")

    monkeypatch.setattr(_atomic, "open", HalfFull, raising=False)
    with pytest.raises(OSError, match="No space"):
        rf.save_graph(field.graph, path)
    monkeypatch.undo()
    assert path.read_bytes() == before              # the old file is whole
    assert leftovers(tmp_path) == ["river.graph"]   # no temporary left


def test_atomic_files_refuses_a_folder_and_needs_every_file(tmp_path):
    with pytest.raises(IsADirectoryError):
        with _atomic.atomic_files(tmp_path):
            pass
    with pytest.raises(OSError, match="nothing was written"):
        with _atomic.atomic_files(tmp_path / "a.txt", tmp_path / "b.txt") as (a, _b):
            a.write_text("only one")
    assert leftovers(tmp_path) == []


def test_temporaries_a_killed_writer_left_are_removed_and_nothing_else(tmp_path):
    """A worker killed between writing a tile's temporary and renaming it leaves the
    temporary: the bake sweeps its own folder once its workers are done."""
    from riverflow._atomic import _temporary, remove_temporaries

    left = _temporary(tmp_path / "14" / "3" / "7.png")
    left.parent.mkdir(parents=True)
    left.write_bytes(b"half a tile")
    keep = [tmp_path / "14" / "3" / "8.png", tmp_path / ".hidden", tmp_path / ".a.tmp-xyz.png"]
    for path in keep:
        path.write_bytes(b"x")
    assert remove_temporaries(tmp_path) == 1
    assert not left.exists() and all(p.exists() for p in keep)
