"""The kernel pack (issue #27, item 3): kernels compiled ahead of time for a portable CPU and
shipped in the package fill a new user cache, so a first run compiles nothing; a pack built
from other sources (an edited kernel), a damaged file or a damaged manifest is ignored and
the kernel compiles, never crashes.

A copy of the sources makes a pack of one tiny kernel (``lifecycle.intensity_at``); each case
runs in a fresh interpreter with an empty cache folder and that pack
(``RIVERFLOW_KERNEL_PACK=<folder>``)."""
from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from riverflow.kernels import pack
from tests.kernels.test_kernel_cache import run

REPO = Path(__file__).resolve().parents[2]

CALL = """
    import json
    from numba.core import config
    from riverflow.kernels.warmup import CompileCounter
    with CompileCounter() as counter:
        from riverflow.kernels import lifecycle
        value = lifecycle.intensity_at(0.5, 1.0, 2.0, 1.0)
    print(json.dumps({"compiled": counter.compiled, "value": value, "cpu": config.CPU_NAME,
                      "folder": lifecycle.intensity_at._cache._cache_path}))
"""

pytestmark = pytest.mark.skipif(not pack.host_has(pack.TARGET_FEATURES),
                                reason=f"this CPU cannot run {pack.TARGET} code")


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    """(sources, pack folder, the run that compiled it): the pack of a copy of the sources,
    compiled for the pack's target."""
    import llvmlite.binding as ll

    tmp = tmp_path_factory.mktemp("pack")
    src = tmp / "src"
    shutil.copytree(REPO / "riverflow", src / "riverflow",
                    ignore=shutil.ignore_patterns("__pycache__", "_pack"))
    first = run(CALL, tmp / "build-cache", cwd=src, NUMBA_CPU_NAME=pack.TARGET,
                NUMBA_CPU_FEATURES="", RIVERFLOW_KERNEL_PACK="0")
    assert first["compiled"] == ["lifecycle.intensity_at"]
    data = pack.write(tmp / "build-cache" / "riverflow", tmp / "pack", ll.get_process_triple())
    assert [name.rpartition("-")[0] for name in data["folders"]] == ["lifecycle"]
    return src, tmp / "pack", first


def test_a_new_cache_is_filled_from_the_pack_and_nothing_compiles(built, tmp_path):
    src, where, first = built
    answer = run(CALL, tmp_path / "cache", cwd=src, RIVERFLOW_KERNEL_PACK=str(where))
    assert answer["compiled"] == []
    assert answer["cpu"] == pack.TARGET          # the process compiles for the pack's CPU
    assert answer["value"] == first["value"] == pytest.approx(0.5)
    assert Path(answer["folder"]).name in json.loads((where / pack.MANIFEST).read_text())[
        "folders"]


@pytest.mark.parametrize("choice", ["pack off", "user's CPU"])
def test_the_users_choice_wins_over_the_pack(built, tmp_path, choice):
    """RIVERFLOW_KERNEL_PACK=0 keeps numba's host target; a NUMBA_CPU_NAME of the user's is
    kept too (the pack is then used only if it was built for that CPU: here it was not)."""
    src, where, _ = built
    env = {"RIVERFLOW_KERNEL_PACK": "0"} if choice == "pack off" else \
        {"RIVERFLOW_KERNEL_PACK": str(where), "NUMBA_CPU_NAME": "generic"}
    answer = run(CALL, tmp_path / "cache", cwd=src, **env)
    assert answer["compiled"] == ["lifecycle.intensity_at"]
    assert answer["cpu"] == (None if choice == "pack off" else "generic")


def test_a_pack_of_other_sources_is_ignored(built, tmp_path):
    """An edited kernel module has another key: the pack's folder is not its folder."""
    src, where, _ = built
    edited = tmp_path / "src"
    shutil.copytree(src, edited)
    lifecycle = edited / "riverflow" / "kernels" / "lifecycle.py"
    lifecycle.write_text(lifecycle.read_text() + "\n# edited\n")
    answer = run(CALL, tmp_path / "cache", cwd=edited, RIVERFLOW_KERNEL_PACK=str(where))
    assert answer["compiled"] == ["lifecycle.intensity_at"]
    assert answer["value"] == pytest.approx(0.5)


@pytest.mark.parametrize("damage", ["data", "index", "manifest"])
def test_a_damaged_pack_compiles_and_never_crashes(built, tmp_path, damage):
    src, where, _ = built
    broken = tmp_path / "pack"
    shutil.copytree(where, broken)
    suffix = {"data": "*/*.nbc", "index": "*/*.nbi", "manifest": pack.MANIFEST}[damage]
    victim = next(broken.glob(suffix))
    blob = bytearray(victim.read_bytes())
    blob[len(blob) // 2] ^= 0xFF
    victim.write_bytes(bytes(blob))
    answer = run(CALL, tmp_path / "cache", cwd=src, RIVERFLOW_KERNEL_PACK=str(broken))
    assert answer["compiled"] == ["lifecycle.intensity_at"]
    assert answer["value"] == pytest.approx(0.5)


def test_a_folder_that_holds_an_index_is_left_alone(built, tmp_path, monkeypatch):
    _, where, _ = built
    monkeypatch.setenv(pack.ENV_SWITCH, str(where))
    name = next(iter(pack.manifest()["folders"]))
    folder = tmp_path / name
    folder.mkdir()
    (folder / "other.nbi").write_bytes(b"numba's own")
    assert pack.seed(folder) == 0
    assert sorted(p.name for p in folder.iterdir()) == ["other.nbi"]
    fresh = tmp_path / "fresh" / name
    fresh.mkdir(parents=True)
    assert pack.seed(fresh) == len(pack.manifest()["folders"][name])
    assert pack.seed(fresh) == 0                 # once per process
