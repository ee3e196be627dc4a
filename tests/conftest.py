"""Shared fixtures. PYGLET_HEADLESS is set before anything can import pyglet.gl, and
RIVERFLOW_KERNEL_PACK=0 before anything imports riverflow: the tests run the host-tuned
kernels CI runs, whether or not ``make pack`` left a kernel pack in the checkout (the pack's
own tests name theirs)."""
from __future__ import annotations

import os
import shutil
import subprocess
from pathlib import Path

os.environ.setdefault("PYGLET_HEADLESS", "1")
os.environ.setdefault("RIVERFLOW_KERNEL_PACK", "0")

import numpy as np  # noqa: E402
import pytest  # noqa: E402


SHARED_MEMO_MB = 96.0
"""The shared built-in scenes' tile memo (a world's default 24 MB holds about one view)."""


def _share_built_in_scenes() -> None:
    """Each test process builds each built-in scene once: ``default_scene`` (1.5 s of CPU for
    the 4 km one, 11 s for 1000 km, asked for by some fifty tests) hands back a new
    ``Landscape`` that shares the network, terrain, water and tile memo of the first call with
    the same arguments, as a game reopening a level does (deviation T8): a world's first view
    takes the array tiles earlier tests made (the same bytes: tests/render/test_first_frame.py
    compares). A test about making tiles gives its scene a memo of its own (``TileMemo()``, or
    ``TileMemo(0)`` for none). ``REAL_DEFAULT_SCENE`` builds afresh
    (tests/scenes/test_default_scene.py's determinism)."""
    import dataclasses
    import functools

    from riverflow.scenes import default
    from riverflow.tiles.memo import TileMemo

    real = default.default_scene

    @functools.lru_cache(maxsize=6)
    def built(seed, size_km, falls, dam):
        scene = real(seed=seed, size_km=size_km, falls=falls, dam=dam)
        scene.tile_memo = TileMemo(SHARED_MEMO_MB)
        return scene

    @functools.wraps(real)
    def shared(seed=0, size_km=4.0, *, falls=False, dam=False):
        try:
            scene = built(seed, size_km, falls, dam)
        except TypeError:            # an unhashable argument: the real one says what is wrong
            return real(seed=seed, size_km=size_km, falls=falls, dam=dam)
        return dataclasses.replace(scene)

    default.default_scene = shared
    globals()["REAL_DEFAULT_SCENE"] = real


_share_built_in_scenes()

REPO = Path(__file__).resolve().parents[1]
SHARED_DATA = Path(os.environ.get("RIVERFLOW_SHARED_DATA", REPO.parent / "shared" / "data"))
PROLAND_GRAPH = SHARED_DATA / "proland" / "rivers.graph"
TINY_CHANNEL = SHARED_DATA / "tiny_channel.graph"


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(20240521)


@pytest.fixture
def proland_graph_path() -> Path:
    if not PROLAND_GRAPH.exists():
        pytest.skip(f"shared data absent: {PROLAND_GRAPH}")
    return PROLAND_GRAPH


@pytest.fixture
def tiny_channel_path() -> Path:
    if not TINY_CHANNEL.exists():
        pytest.skip(f"shared data absent: {TINY_CHANNEL}")
    return TINY_CHANNEL


def _xvfb():
    """Start a virtual X display (Xvfb) on a free display number (``-displayfd``: Xvfb
    picks it and says when it is ready); yields ``":N"``; skips where Xvfb is missing."""
    binary = shutil.which("Xvfb")
    if binary is None:
        pytest.skip("Xvfb is not installed (apt-get install xvfb)")
    read, write = os.pipe()
    proc = subprocess.Popen([binary, "-displayfd", str(write), "-screen", "0", "640x480x24",
                             "-nolisten", "tcp"], pass_fds=(write,),
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    os.close(write)
    with os.fdopen(read) as pipe:
        number = pipe.readline().strip()     # written once the server accepts clients
    if not number or proc.poll() is not None:
        proc.kill()
        pytest.skip("Xvfb did not start")
    try:
        yield f":{number}"
    finally:
        proc.terminate()
        proc.wait(timeout=10)


@pytest.fixture
def xvfb():
    """A virtual X display (Xvfb) for windowed runs; skipped where Xvfb is missing."""
    yield from _xvfb()


@pytest.fixture(scope="module")
def xvfb_module():
    """One virtual X display for all the tests of a module (see :func:`xvfb`)."""
    yield from _xvfb()



@pytest.hookimpl(wrapper=True)
def pytest_collection_modifyitems(config, items):
    """Under ``--dist loadgroup`` (``make test``) the tests that share a fixture of their module
    (a scene, a world, a flight: scope module, class or package) run on one worker, which
    builds it once; xdist would otherwise deal a module's tests out to the workers in turn,
    and each would build it. The other tests go to whichever worker is free."""
    grouped = getattr(config.option, "loadgroup", False)     # set on xdist's workers
    if grouped:
        for item in items:
            info = getattr(item, "_fixtureinfo", None)
            if info is None or item.get_closest_marker("xdist_group") is not None:
                continue
            if any(defs and defs[-1].scope in ("module", "class", "package")
                   for defs in info.name2fixturedefs.values()):
                item.add_marker(pytest.mark.xdist_group(item.nodeid.split("::")[0]))
    result = yield
    if grouped:
        _name_the_groups(items)
        _slow_first(items)
    return result


def _slow_first(items) -> None:
    """xdist deals tests (and groups) out in the order they were collected: a slow test last
    in line leaves one worker running alone at the end. Tests marked ``slow``, and the groups
    they are in, go first (the longest jobs first keeps the workers evenly busy); the order
    is otherwise kept, the same on every worker."""
    def group(item):
        tail = item.nodeid.rsplit("]", 1)[-1]
        return item.nodeid.rsplit("@", 1)[1] if "@" in tail else None

    slow = {id(i) for i in items if i.get_closest_marker("slow") is not None}
    slow_groups = {group(i) for i in items if id(i) in slow} - {None}
    items.sort(key=lambda i: not (id(i) in slow or group(i) in slow_groups))


def _name_the_groups(items) -> None:
    """xdist tells the groups to its scheduler as a suffix '@group' of each test's id, which
    pytest >= 9.2 no longer lets it write (pytest-dev/pytest-xdist#1386): tests marked with
    ``xdist_group`` whose id lacks it get it here."""
    for item in items:
        names = sorted({str(m.args[0] if m.args else m.kwargs.get("name", "default"))
                        for m in item.iter_markers("xdist_group")})
        if not names or "@" in item.nodeid.rsplit("]", 1)[-1]:
            continue
        nodeid = f"{item.nodeid}@{'_'.join(names)}"
        if hasattr(item, "_id"):                       # pytest >= 9.2: a structured NodeId
            from _pytest.nodeid import NodeId
            item._id = NodeId.parse(nodeid)
        else:
            item._nodeid = nodeid
