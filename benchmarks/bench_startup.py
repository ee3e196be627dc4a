"""Time to the first drawn frame (or first result), on a cold and on a warm kernel cache,
from the checkout and from a fresh venv.

Each case runs as a new user runs it, in a fresh process, with the kernel cache in a new
temporary folder (``XDG_CACHE_HOME``; NUMBA_CACHE_DIR unset): the first run finds an empty
cache (cold: it loads the kernel pack, ``riverflow/kernels/pack.py``, when one is built and
matches, else compiles every kernel it needs), the second finds the first's (warm). Cases: the
headless ``make demo`` (until its first frame is written), ``riverflow render`` (one frame),
and the README's three Python snippets (flow query, headless particles, a drawn frame).

``--fresh-venv`` runs ``riverflow render`` as after ``pip install`` on a machine that never ran
riverflow: the wheel of this checkout (``pip wheel --no-deps --no-build-isolation``, carrying
the pack when ``make pack`` built one) is installed into a new venv whose dependencies are
this interpreter's site-packages (a ``.pth`` file: nothing is downloaded), and its
``riverflow`` command runs outside the checkout with an empty cache. ``--no-pack`` runs
everything with ``RIVERFLOW_KERNEL_PACK=0`` (the compile path, host-tuned, as before the pack).

Each row gives wall seconds to the first frame and the CPU seconds (user + system) of the
command and of the compile workers it started. Run: ``python benchmarks/bench_startup.py
[--cases demo,render] [--runs cold,warm] [--fresh-venv] [--no-pack] [--json]``. A cold run
without the pack compiles for about a minute on the 2-core machine. Figures go to
docs/performance.md ("Start-up: compiled kernels").
"""
from __future__ import annotations

import argparse
import json
import os
import resource
import shutil
import site
import subprocess
import sys
import tempfile
import textwrap
import time
import venv
import zipfile
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]

FIELD = """
    import time, numpy as np, riverflow as rf
    b = rf.RiverNetworkBuilder(tolerance_m=0.25)
    b.add_branch([(0, 0), (400, 40), (800, 0)], widths_m=[40, 50, 60], discharge_m2s=45.0)
    b.add_branch([(300, 400), (800, 0)], 30.0, discharge_m2s=20.0)
    b.add_branch([(800, 0), (1400, -100)], 70.0)
    field = rf.FlowField(b.build(), slip=1.0, search_radius_factor=5.0)
    status, velocity = field.query(np.array([[0.0, 50.0], [300.0, 300.0]]))
    print("FIRST", time.perf_counter())
"""
PARTICLES = """
    import time, riverflow as rf
    scene = rf.default_scene(seed=0)
    world = rf.RiverWorld(scene, size=(640, 360), seed=0, config=rf.RiverConfig(radius_px=8))
    world.camera.look_at((-1770, -130, 75), (-1715, -110, 45))
    world.step(1 / 60)
    print("FIRST", time.perf_counter())
"""
DRAWN = """
    import time, riverflow as rf
    scene = rf.default_scene(seed=0)
    world = rf.RiverWorld(scene, size=(640, 360), gl=True, seed=0)
    world.camera.look_at((-1770, -130, 75), (-1715, -110, 45))
    world.step(1 / 60)
    frame = world.render()
    print("FIRST", time.perf_counter())
"""


NUMBA_CACHE_DIR = False
"""--numba-cache-dir: the cache folder given as NUMBA_CACHE_DIR (how the Makefile ran before
the package kept its kernels itself), not as the platform's user cache folder."""


NO_PACK = False
"""--no-pack: RIVERFLOW_KERNEL_PACK=0 (compile for the host, as without a pack)."""


def _env(cache: str, checkout: bool = True) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items()
           if not k.startswith("NUMBA_") and k not in ("PYTHONPATH", "RIVERFLOW_KERNEL_PACK")}
    env["PYGLET_HEADLESS"] = "1"
    if checkout:
        env["PYTHONPATH"] = str(REPO)
    if NO_PACK:
        env["RIVERFLOW_KERNEL_PACK"] = "0"
    env["NUMBA_CACHE_DIR" if NUMBA_CACHE_DIR else "XDG_CACHE_HOME"] = cache
    return env


def _children_cpu() -> float:
    """CPU seconds of the finished child processes so far (their own children included)."""
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


RIVERFLOW = [sys.executable, "-m", "riverflow"]
"""The command: the checkout's, or the fresh venv's ``riverflow`` (--fresh-venv)."""
VENV: Path | None = None


def _snippet(code: str):
    def run(cache: str, out: Path) -> tuple[float, str]:
        python = str(VENV / "bin" / "python") if VENV is not None else sys.executable
        start = time.perf_counter()
        proc = subprocess.run([python, "-c", textwrap.dedent(code)],
                              env=_env(cache, checkout=VENV is None),
                              cwd=out, capture_output=True, text=True, check=True)
        first = next(float(line.split()[1]) for line in proc.stdout.splitlines()
                     if line.startswith("FIRST"))
        return first - start, proc.stderr
    return run


def _command(args: list[str], wait_for: str | None):
    """A ``riverflow`` command; with ``wait_for`` the time until that file appears (the
    process is then stopped), else until it exits."""
    def run(cache: str, out: Path) -> tuple[float, str]:
        if wait_for is not None:
            (out / wait_for).unlink(missing_ok=True)        # from the run before
        start = time.perf_counter()
        proc = subprocess.Popen([*RIVERFLOW, *args], env=_env(cache, checkout=VENV is None),
                                cwd=out, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                text=True)
        if wait_for is None:
            _, err = proc.communicate()
            if proc.returncode:
                raise RuntimeError(err)
            return time.perf_counter() - start, err
        target = out / wait_for
        while not target.exists():
            if proc.poll() is not None:
                raise RuntimeError(proc.stderr.read())
            time.sleep(0.05)
        seconds = time.perf_counter() - start
        proc.terminate()
        _, err = proc.communicate()
        return seconds, err
    return run


CASES = {
    "demo": _command(["demo", "--headless", "--out", "demo"], "demo/frame_00000.png"),
    "render": _command(["render", "--frames", "1", "--size", "640x360", "--mode", "advected",
                        "--out", "r.png"], None),
    "readme-field": _snippet(FIELD),
    "readme-particles": _snippet(PARTICLES),
    "readme-drawn": _snippet(DRAWN),
}


def fresh_venv(tmp: Path) -> dict:
    """Build this checkout's wheel and install it into a new venv under ``tmp`` (module
    docstring); sets :data:`VENV` and :data:`RIVERFLOW`. Returns what was built and how long
    it took."""
    global VENV
    start = time.perf_counter()
    src = tmp / "src"                   # a copy: building in place leaves build/ and egg-info
    src.mkdir()
    for name in ("pyproject.toml", "README.md", "LICENSE"):
        shutil.copy2(REPO / name, src / name)
    shutil.copytree(REPO / "riverflow", src / "riverflow",
                    ignore=shutil.ignore_patterns("__pycache__", "*.pyc"))
    subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation",
                    "--no-index", "-q", "-w", str(tmp / "dist"), str(src)], check=True,
                   capture_output=True)
    (wheel,) = (tmp / "dist").glob("riverflow-*.whl")
    names = zipfile.ZipFile(wheel).namelist()
    built = time.perf_counter()
    env_dir = tmp / "venv"
    venv.create(env_dir, with_pip=False)
    python = env_dir / "bin" / "python"
    purelib = subprocess.run([str(python), "-c", "import sysconfig; "
                              "print(sysconfig.get_paths()['purelib'])"],
                             capture_output=True, text=True, check=True).stdout.strip()
    deps = [p for p in site.getsitepackages() if os.path.isdir(p)]
    Path(purelib, "_riverflow_bench_deps.pth").write_text("\n".join(deps) + "\n")
    subprocess.run([sys.executable, "-m", "pip", "--python", str(python), "install", "-q",
                    "--no-deps", "--no-index", str(wheel)], check=True, capture_output=True)
    VENV = env_dir
    RIVERFLOW[:] = [str(env_dir / "bin" / "riverflow")]
    return {"wheel": wheel.name, "wheel_mb": round(wheel.stat().st_size / 1e6, 1),
            "pack_files": sum(n.startswith("riverflow/kernels/_pack/") for n in names),
            "wheel_s": round(built - start, 1),
            "install_s": round(time.perf_counter() - built, 1)}


def main(argv: list[str] | None = None) -> list[dict]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cases", default=None,
                        help=f"of {', '.join(CASES)} (default: all; render with --fresh-venv)")
    parser.add_argument("--runs", default="cold,warm")
    parser.add_argument("--json", action="store_true")
    parser.add_argument("--numba-cache-dir", action="store_true",
                        help="pass the cache folder as NUMBA_CACHE_DIR")
    parser.add_argument("--fresh-venv", action="store_true",
                        help="install this checkout's wheel into a new venv and run from it")
    parser.add_argument("--no-pack", action="store_true",
                        help="RIVERFLOW_KERNEL_PACK=0: compile, as without the kernel pack")
    args = parser.parse_args(argv)
    global NUMBA_CACHE_DIR, NO_PACK
    NUMBA_CACHE_DIR, NO_PACK = args.numba_cache_dir, args.no_pack
    cases = args.cases or ("render" if args.fresh_venv else ",".join(CASES))
    results = []
    with tempfile.TemporaryDirectory(prefix="riverflow-venv-") as venv_tmp:
        where = "checkout"
        if args.fresh_venv:
            install = fresh_venv(Path(venv_tmp))
            where = "fresh venv"
            if not args.json:
                print(f"fresh venv: {install['wheel']} ({install['wheel_mb']} MB, "
                      f"{install['pack_files']} kernel pack files), wheel built in "
                      f"{install['wheel_s']} s, installed in {install['install_s']} s",
                      flush=True)
        for name in cases.split(","):
            with tempfile.TemporaryDirectory(prefix="riverflow-startup-") as tmp:
                cache, out = Path(tmp) / "cache", Path(tmp) / "out"
                out.mkdir()
                for run in args.runs.split(","):
                    cpu = _children_cpu()
                    seconds, err = CASES[name](str(cache), out)
                    cpu = _children_cpu() - cpu
                    row = {"case": name, "run": run, "from": where, "pack": not NO_PACK,
                           "seconds": round(seconds, 2), "cpu_seconds": round(cpu, 2),
                           "progress_line": "compiling riverflow kernels" in err}
                    results.append(row)
                    if not args.json:
                        print(f"{name:18s} {run:5s} {seconds:6.1f} s wall {cpu:6.1f} s CPU   "
                              f"progress line: {'yes' if row['progress_line'] else 'no'}",
                              flush=True)
    if args.json:
        print(json.dumps(results, indent=2))
    return results


if __name__ == "__main__":
    main()
