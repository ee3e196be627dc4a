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
