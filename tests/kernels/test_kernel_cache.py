"""Compiled kernels managed by the package (issue #13): one keyed cache folder per user, a
second process compiles nothing, an edited helper is compiled again, machine code compiled by
two processes loads into one, the warm-up's progress line shows on a cold cache only, and the
recorded signatures match the kernels.

Processes run with their own NUMBA_CACHE_DIR (a temporary folder) and compile one or two tiny
kernels, so these tests stay cheap; the slow one warms the whole world group on the user's
own cache."""
from __future__ import annotations

import inspect
import json
import os
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from riverflow.kernels import _cache, warmup
from riverflow.kernels._signatures import SIGNATURES

REPO = Path(__file__).resolve().parents[2]
KERNELS = REPO / "riverflow" / "kernels"


def run(code: str, cache: Path | None, cwd: Path = REPO, **env_extra) -> dict:
    """Run ``code`` in a fresh interpreter with ``cache`` as NUMBA_CACHE_DIR (None: the
    user's own kernel cache); its last stdout line is JSON. Adds "stderr" to the answer."""
    env = dict(os.environ)
    if cache is not None:           # None: the user's own cache, as this process has it
        env = {k: v for k, v in env.items() if not k.startswith("NUMBA_")}
        env["NUMBA_CACHE_DIR"] = str(cache)
    # the compile path: a kernel pack `make pack` left in the checkout is not used
    env.update(PYTHONPATH=str(cwd), RIVERFLOW_KERNEL_PACK="0")
    env.update(env_extra)
    result = subprocess.run([sys.executable, "-c", textwrap.dedent(code)], cwd=cwd, env=env,
                            capture_output=True, text=True, timeout=300, check=False)
    assert result.returncode == 0, result.stderr[-3000:]
    answer = json.loads(result.stdout.strip().splitlines()[-1])
    answer["stderr"] = result.stderr
    return answer


CALL_INTENSITY = """
    import json
    from riverflow.kernels.warmup import CompileCounter
    with CompileCounter() as counter:
        from riverflow.kernels import lifecycle
        value = lifecycle.intensity_at(0.5, 1.0, 2.0, 1.0)
    print(json.dumps({"compiled": counter.compiled, "value": value,
                      "folder": lifecycle.intensity_at._cache._cache_path}))
"""


def test_a_second_process_compiles_nothing(tmp_path):
    first = run(CALL_INTENSITY, tmp_path)
    second = run(CALL_INTENSITY, tmp_path)
    assert first["compiled"] == ["lifecycle.intensity_at"]
    assert second["compiled"] == []
    assert second["value"] == first["value"] == pytest.approx(0.5)
    folder = Path(first["folder"])
    assert folder.parent == tmp_path / "riverflow"        # NUMBA_CACHE_DIR is honoured …
    assert folder.name == f"lifecycle-{_cache.module_key(str(KERNELS / 'lifecycle.py'))}"
    assert any(folder.glob("lifecycle.intensity_at-*.nbi"))   # … inside a keyed folder


PROBE = """
    from numba import njit

    from riverflow.kernels._jit import JIT_OPTIONS
    from riverflow.kernels.probe_helper import helper


    @njit(**JIT_OPTIONS)
    def entry(x):
        return helper(x) * 2.0
"""
HELPER = """
    from numba import njit

    from riverflow.kernels._jit import JIT_OPTIONS

    OFFSET = {offset}


    @njit(**JIT_OPTIONS)
    def helper(x):
        return x + OFFSET
"""
CALL_PROBE = """
    import json
    from riverflow.kernels.warmup import CompileCounter
    with CompileCounter() as counter:
        from riverflow.kernels.probe import entry
        value = entry(1.0)
    print(json.dumps({"compiled": counter.compiled, "value": value}))
"""


def test_editing_a_helper_in_another_module_compiles_its_caller_again(tmp_path):
    """numba's own cache would answer 4.0 after the edit (its key is the caller's file only:
    reference/ecosystem.md §3.1); the keyed folders answer 202.0."""
    package = tmp_path / "src"
    shutil.copytree(REPO / "riverflow", package / "riverflow",
                    ignore=shutil.ignore_patterns("__pycache__"))
    kernels = package / "riverflow" / "kernels"
    (kernels / "probe.py").write_text(textwrap.dedent(PROBE))
    (kernels / "probe_helper.py").write_text(textwrap.dedent(HELPER).format(offset=1.0))
    cache = tmp_path / "cache"

    first = run(CALL_PROBE, cache, cwd=package)
    again = run(CALL_PROBE, cache, cwd=package)
    (kernels / "probe_helper.py").write_text(textwrap.dedent(HELPER).format(offset=100.0))
    edited = run(CALL_PROBE, cache, cwd=package)

    assert (first["value"], again["value"], edited["value"]) == (4.0, 4.0, 202.0)
    assert set(first["compiled"]) == {"probe.entry", "probe_helper.helper"}
    assert again["compiled"] == []
    assert "probe.entry" in edited["compiled"]
    folders = sorted(p.name.rpartition("-")[0] for p in (cache / "riverflow").iterdir())
    assert folders.count("probe") == 2        # the old key's folder is kept (KEEP = 3) …


def test_a_modules_key_covers_what_it_imports():
    closure = {Path(p).relative_to(REPO).as_posix()
               for p in _cache.source_closure(str(KERNELS / "advection.py"))}
    assert {"riverflow/kernels/advection.py", "riverflow/kernels/lifecycle.py",
            "riverflow/kernels/surface_tiles.py", "riverflow/kernels/_jit.py"} <= closure
    sprites = {Path(p).name for p in _cache.source_closure(str(KERNELS / "sprites.py"))}
    assert "advection.py" in sprites          # the flow statuses are frozen into the code
    noise = {Path(p).name for p in _cache.source_closure(str(KERNELS / "noise.py"))}
    assert "flow.py" not in noise             # an unrelated edit keeps noise's machine code
    assert _cache.kernel_folder(REPO / "riverflow" / "engine" / "world.py") is None


def test_old_folders_are_pruned(tmp_path):
    root = tmp_path / "riverflow"
    for k in range(5):
        folder = root / f"flow-{k:016x}"
        folder.mkdir(parents=True)
        os.utime(folder, (1000 + k, 1000 + k))
    (root / "noise-0000000000000000").mkdir()
    removed = _cache.prune(root / f"flow-{4:016x}", keep=3)
    assert sorted(p.name for p in removed) == [f"flow-{k:016x}" for k in (0, 1)]
    assert sorted(p.name for p in root.iterdir()) == [
        *(f"flow-{k:016x}" for k in (2, 3, 4)), "noise-0000000000000000"]


def test_the_platform_folder_is_used_without_numba_cache_dir(tmp_path):
    env = {k: v for k, v in os.environ.items() if not k.startswith("NUMBA_")}
    env.update(XDG_CACHE_HOME=str(tmp_path), HOME=str(tmp_path))
    code = "from riverflow.kernels import _cache; print(_cache.cache_root())"
    result = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True,
                            text=True, cwd=REPO, timeout=120, check=False)
    assert result.returncode == 0, result.stderr
    root = Path(result.stdout.strip())
    if sys.platform.startswith("linux"):
        assert root == tmp_path / "riverflow" / "kernels"
    else:
        assert root.parts[-1] == "kernels" and str(tmp_path) in str(root)



TWO_SCALERS = """
    import numpy as np
    from numba import njit


    def scaler(k):
        @njit
        def scale(x):                   # big enough not to be inlined into its caller
            out = np.empty_like(x)
            for i in range(x.size):
                v = x[i]
                if v > 100.0:
                    v = np.sqrt(v) + np.log(v)
                elif v < -100.0:
                    v = np.exp(v / 1000.0) - np.sin(v)
                elif v == 7.0:
                    v = np.cos(v) * np.tan(v) + np.arctan2(v, 3.0)
                out[i] = v * k
            return out
        return scale


    double, triple = scaler(2.0), scaler(3.0)


    @njit(cache=True)
    def doubled(x):
        return double(x)


    @njit(cache=True)
    def tripled(x):
        return triple(x)
"""
CALL_SCALERS = """
    import json
    import sys

    import numpy as np

    import riverflow.kernels  # noqa: F401 - what every riverflow process imports first
    sys.path.insert(0, {folder!r})
    import two_scalers
    x = np.array([1.0, 2.0])
    values = [getattr(two_scalers, name)(x).tolist() for name in {names!r}]
    print(json.dumps({{"values": values,
                      "loaded": sum(two_scalers.doubled.stats.cache_hits.values())}}))
"""


def test_machine_code_compiled_by_two_processes_loads_into_one(tmp_path):
    """The segfault of ``tile_cut.cut_standins`` on a cold cache, in small: two processes (the
    warm-up's workers, or two runs) each compiled one function that calls a helper of the same
    name; numba numbered both helpers alike (a per-process counter), so a third process that
    loads both called the first one loaded for both (LLVM takes one definition per name):
    ``tripled`` answered ``doubled``'s numbers here, and ``cut_standins`` got ``np.sort``'s
    helper for ``np.argsort``'s. Random ids (``_cache._name_functions_uniquely``) keep the
    names apart."""
    (tmp_path / "two_scalers.py").write_text(textwrap.dedent(TWO_SCALERS))
    cache = tmp_path / "cache"
    first = run(CALL_SCALERS.format(folder=str(tmp_path), names=["doubled"]), cache)
    second = run(CALL_SCALERS.format(folder=str(tmp_path), names=["tripled", "doubled"]), cache)
    assert first["values"] == [[2.0, 4.0]]
    assert second["loaded"] == 1                  # doubled: the first process's machine code
    assert second["values"] == [[3.0, 6.0], [2.0, 4.0]]


def test_compiled_functions_are_numbered_at_random():
    from numba.core.bytecode import FunctionIdentity

    assert isinstance(FunctionIdentity._unique_ids, _cache.RandomIds)
    ids = {next(FunctionIdentity._unique_ids) for _ in range(1000)}
    assert len(ids) == 1000 and max(ids) > 2 ** 40
    assert _cache.NAMING in _cache._toolchain()     # older machine code is never loaded


WARM_TWO = """
    import json
    from riverflow.kernels.warmup import CompileCounter, compile_entries, entries
    pairs = [p for p in entries("world") if p[0] in ("surface_tiles.water_level_at",
                                                     "tile_table.codes_of")]
    with CompileCounter() as here:
        report = compile_entries(pairs, jobs={jobs})
    print(json.dumps({{"compiled": sorted(report.compiled), "here": here.compiled,
                      "failed": report.failed, "pairs": len(pairs)}}))
"""


@pytest.mark.parametrize("jobs", [1, 2])
def test_the_progress_line_shows_on_a_cold_cache_only(tmp_path, jobs):
    """jobs=2: two worker processes compile, this one only loads their machine code (one
    signature names a NamedTuple class, which the workers must find)."""
    cold = run(WARM_TWO.format(jobs=jobs), tmp_path)
    warm = run(WARM_TWO.format(jobs=jobs), tmp_path)
    assert cold["pairs"] == 2 and not cold["failed"]
    assert {"surface_tiles.water_level_at", "tile_table.codes_of"} <= set(cold["compiled"])
    assert sorted(cold["here"]) == ([] if jobs == 2 else cold["compiled"])
    assert f"{warmup.MESSAGE}: 0 % (0/2)" in cold["stderr"]
    assert f"{warmup.MESSAGE}: 100 % (2/2)" in cold["stderr"]
    assert warm["compiled"] == [] and warm["here"] == [] and not warm["failed"]
    assert warmup.MESSAGE not in warm["stderr"]


def test_terminal_progress_rewrites_its_line_on_a_terminal():
    class Tty:
        def __init__(self):
            self.text = ""

        def isatty(self):
            return True

        def write(self, text):
            self.text += text

        def flush(self):
            pass

    stream = Tty()
    progress = warmup.TerminalProgress(stream)
    progress.update(0, 3, False)
    assert stream.text == ""                       # loading from the cache says nothing
    progress.update(0, 3, True)
    progress.update(1, 3, False)
    progress.update(3, 3, False)
    progress.finish()
    lines = stream.text.split("\r")
    assert lines[1:4] == [f"{warmup.MESSAGE}: 0 % ({k}/3)" for k in (0, 1, 3)]
    assert stream.text.endswith("s)\n") and stream.text.count("\n") == 1


def test_the_progress_is_weighted_by_cost_and_moves_while_a_kernel_compiles():
    """A window's line must not sit at 7/53 for two thirds of the compile: the fraction
    weighs each kernel by its recorded cost and counts the time a running one has taken."""
    import time

    work = warmup.Work()
    work.plan([0.2, 0.2, 0.01])
    assert work.fraction() == 0.0
    work.start("big", 0.2)
    first = work.fraction()
    time.sleep(0.05)
    moving = work.fraction()
    assert 0.0 <= first < moving < 0.9 * 0.2 / 0.41 + 1e-9     # moves, capped below its cost
    time.sleep(0.25)
    assert work.fraction() == pytest.approx(0.9 * 0.2 / 0.41)   # never past 90 % of it
    work.finish("big", 0.2)
    assert work.fraction() == pytest.approx(0.2 / 0.41)         # one costly kernel: ~half
    work.finish("small", 0.01)
    work.start("other", 0.2)
    work.finish("other", 0.2)
    assert work.fraction() == pytest.approx(1.0)
    progress = warmup.CompileProgress()
    progress.work = work
    progress.update(3, 3, True)
    assert progress.text == f"{warmup.MESSAGE}: 100 % (3/3)"


def test_recorded_signatures_match_the_kernels():
    """Every recorded kernel exists, takes as many arguments as recorded, and its types read
    back (tools/record_kernel_signatures.py --check redoes the recording)."""
    assert set(SIGNATURES) == set(warmup.GROUPS)
    for name, sig in warmup.entries():
        kernel = warmup.dispatcher_of(name)
        types = warmup.decode_signature(sig)
        params = inspect.signature(kernel.py_func).parameters
        assert len(types) == len(params), name
        assert warmup.encode_signature(types) == sig


def test_config_keeps_floats_so_kernels_are_not_compiled_again_for_ints():
    import riverflow as rf

    config = rf.RiverConfig(radius_px=8, fade_in_s=1, capacity=100)
    assert type(config.radius_px) is float and type(config.fade_in_s) is float
    assert type(config.capacity) is int


WORLD_AFTER_WARM_UP = """
    import importlib, json, pkgutil
    import riverflow as rf
    import riverflow.kernels as kernels
    from riverflow.demo import BoatDemo
    from riverflow.kernels.warmup import CompileCounter, compile_kernels, is_riverflow_kernel

    def overloads():
        found = {}
        for info in pkgutil.iter_modules(kernels.__path__):
            module = importlib.import_module(f"riverflow.kernels.{info.name}")
            for name, value in vars(module).items():
                if is_riverflow_kernel(value):
                    found[f"{info.name}.{name}"] = {str(k) for k in value.overloads}
        return found

    report = compile_kernels("world")
    before = overloads()
    with CompileCounter() as counter:
        config = rf.RiverConfig(radius_px=8, tile_production="blocking")  # an int r
        demo = BoatDemo(None, (160, 90), gl=False, config=config)
        demo.input.key_down("W")
        for _ in range(10):
            demo.step()
        demo.close()
    after = overloads()
    added = sorted(k for k, v in after.items() if v - before.get(k, set()))
    print(json.dumps({"warm_up": report.compiled, "failed": report.failed,
                      "frames": counter.compiled, "added": added}))
"""


@pytest.mark.slow
def test_the_warm_up_covers_a_world_and_a_second_process_compiles_nothing():
    """A world group warm-up, then frames with a boat in view: the frames add no signature
    to any kernel, compiled or loaded from the cache (so what the warm-up loads is all a
    world calls); a second process then compiles nothing and prints no progress.

    Both run on the user's own kernel cache, as the rest of the suite does: on a warm cache
    the warm-up loads, on a cold one it compiles once for every test (a private cold cache
    here cost ~100 s of compiling on every run; the progress line on a cold cache is
    ``test_the_progress_line_shows_on_a_cold_cache_only``)."""
    first = run(WORLD_AFTER_WARM_UP, None)
    second = run(WORLD_AFTER_WARM_UP, None)
    assert not first["failed"]
    assert first["added"] == [] and first["frames"] == []
    assert second["warm_up"] == [] and second["frames"] == [] and second["added"] == []
    assert warmup.MESSAGE not in second["stderr"]


# -- the loading screen (a real window under Xvfb) -------------------------------------------------

LOADING = """
    import json
    import numpy as np
    import pyglet
    from riverflow.engine.loading import compile_with_loading_screen

    window = pyglet.window.Window(320, 180, caption="loading")
    shots = []

    def shot(dt):
        window.dispatch_event("on_draw")
        buffer = pyglet.image.get_buffer_manager().get_color_buffer().get_image_data()
        rgba = np.frombuffer(buffer.get_data("RGBA", 320 * 4), np.uint8)
        shots.append(int((rgba.reshape(-1, 4)[:, :3].max(axis=1) > 150).sum()))

    pyglet.clock.schedule_interval(shot, 0.2)
    # the scene group without the builder's junction fillets (13 s of the group's 16 s cold):
    # a few seconds of compiling are what the loading screen has to draw through
    from riverflow.kernels._signatures import SIGNATURES
    for name in [n for n in SIGNATURES["scene"] if n.startswith("fillets.")]:
        del SIGNATURES["scene"][name]
    loading = compile_with_loading_screen(window, ("scene",))

    @window.event                   # the window takes its game's handlers afterwards
    def on_draw():
        window.clear()

    window.close()
    print(json.dumps({**loading.__dict__, "bright_pixels": shots}))
"""



@pytest.mark.gl
@pytest.mark.slow
def test_the_loading_screen_keeps_drawing_while_kernels_compile(xvfb, tmp_path):
    """The scene group (the terrain noise, ~3 s cold; the builder's fillets left out) compiles
    in a thread while the window draws the progress line: frames keep coming, none late by a
    second."""
    loading = run(LOADING, tmp_path, DISPLAY=xvfb, PYGLET_HEADLESS="")
    assert not loading["closed"]
    assert loading["frames"] >= 5 and loading["longest_s"] < 1.0, loading
    assert max(loading["bright_pixels"], default=0) > 50         # the text is drawn
    assert warmup.MESSAGE in loading["stderr"]


def test_a_kernel_folder_lock_held_twice_in_one_process_gives_up_waiting(tmp_path, monkeypatch):
    """A second hold of one folder's lock in one process (a second copy of riverflow imported
    from another path wrapped numba's saves again) waited for ever on POSIX: it now gives up
    after its wait, as a lock left by a killed process does; numba's saves are wrapped once."""
    import time

    from numba.core import caching

    folder = tmp_path / "root" / "kernels-x"
    folder.mkdir(parents=True)
    monkeypatch.setattr(_cache, "_made_roots", {str(folder.parent)})
    t0 = time.monotonic()
    with _cache._folder_lock(str(folder)), _cache._folder_lock(str(folder), wait_s=0.2):
        pass
    assert time.monotonic() - t0 < 30.0
    save = caching.IndexDataCacheFile.save
    _cache._lock_index_updates(caching)               # what a second copy would do
    assert caching.IndexDataCacheFile.save is save
