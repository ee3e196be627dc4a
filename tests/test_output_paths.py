"""--out where nothing can be written (input hardening): a folder where a file is meant, a
file where a folder is meant, a file in the way of the folders, a folder that cannot be
written: a clear error naming the path, before any scene is made or anything written."""
from __future__ import annotations

from pathlib import Path

import pytest

from riverflow.__main__ import main
from riverflow._atomic import atomic_write_bytes, writable_path

SCENE = ["--scene", "nowhere.graph"]   # never read: the --out check comes first


@pytest.fixture
def places(tmp_path):
    (tmp_path / "afile").write_text("x")
    (tmp_path / "adir").mkdir()
    (tmp_path / "old.png").write_bytes(b"old")
    return tmp_path


CASES = {   # name: (command line, the --out, the error's words)
    "render into a file's folder": (["render"], "afile/x.png", "afile is a file, not a folder"),
    "flowmap into a file's folder": (["flowmap"], "afile/x.png", "afile is a file"),
    "bake into a file's folder": (["bake"], "afile/sub/x.png", "afile is a file, not a folder"),
    "bake onto a folder": (["bake"], "adir", "is a folder, expected a file name"),
    "spill onto a file": (["spill", "--at", "0,0", "--mass", "1", "--hours", "1", "--every",
                           "10"], "old.png", "is a file, expected a folder"),
    "spill into a file's folder": (["spill", "--at", "0,0", "--mass", "1", "--hours", "1",
                                    "--every", "10"], "afile/run", "afile is a file"),
}


@pytest.mark.parametrize("name", CASES)
def test_an_out_that_cannot_be_written_is_refused_first(places, capsys, name):
    command, out, words = CASES[name]
    target = places / out
    before = sorted(p.name for p in places.rglob("*"))
    assert main([*command, *SCENE, "--out", str(target)]) in (1, 2)
    err = capsys.readouterr().err
    assert words in err and "Traceback" not in err and "nowhere.graph" not in err
    assert sorted(p.name for p in places.rglob("*")) == before        # nothing written


@pytest.mark.skipif(not Path("/proc/self").exists(), reason="needs Linux /proc")
def test_a_folder_that_refuses_files_is_named_even_for_root():
    with pytest.raises(PermissionError, match="cannot write /proc/x.png: the folder /proc"):
        writable_path("/proc/x.png")
    with pytest.raises(PermissionError, match="/proc"):
        atomic_write_bytes("/proc/x.bin", b"1")


def test_a_missing_folder_is_made_and_an_old_file_replaced(places):
    assert atomic_write_bytes(places / "new" / "deeper" / "a.bin", b"1").read_bytes() == b"1"
    assert atomic_write_bytes(places / "old.png", b"new").read_bytes() == b"new"
    assert not [p for p in places.rglob(".*")]                  # no temporaries, no probes


@pytest.mark.parametrize("command", [
    ["render", "--size", "32x24", "--frames", "1"],
    ["spill", "--at", "50,0", "--mass", "1", "--hours", "0.05", "--every", "1", "--png"]])
def test_a_graph_no_flow_runs_in_is_an_error_not_a_traceback(tmp_path, capsys, monkeypatch,
                                                             command):
    """A hand-edited graph whose axis is a self-loop of zero length: the world refuses it with
    a GraphError, which the command line prints (render said 'cannot draw', spill dumped a
    traceback)."""
    from riverflow.engine import world
    from riverflow.hydro.flow_field import FlowField
    from tests.hydro.test_graph_values import TINY

    class NoGL(world.RiverWorld):      # render: the world's flow field, without a GL context
        def __init__(self, scene, **_):
            FlowField(scene.graph)

    if command[0] == "render":
        monkeypatch.setattr(world, "RiverWorld", NoGL)
    if not TINY.exists():
        pytest.skip(f"shared data absent: {TINY}")
    lines = TINY.read_text().splitlines()
    lines[9] = "2 24.000 1 -1.000 -1 0 0 -1 -1 -1"
    graph = tmp_path / "loop.graph"
    graph.write_text("\n".join(lines) + "\n")
    out = tmp_path / ("r.png" if command[0] == "render" else "spill")
    assert main([*command, "--scene", str(graph), "--out", str(out)]) == 1
    err = capsys.readouterr().err
    assert "curve 0 (an axis, nodes 0->0) has zero length" in err and "cannot draw" not in err
    assert not out.exists()
