"""Time to the first drawn frame (or first result), on a cold and on a warm kernel cache.

Each case runs as a new user runs it, in a fresh process, with the kernel cache in a new
temporary folder (``XDG_CACHE_HOME``; NUMBA_CACHE_DIR unset): the first run compiles every
kernel it needs (cold), the second finds them (warm). Cases: the headless ``make demo``
(until its first frame is written), ``riverflow render`` (one frame), and the README's three
Python snippets (flow query, headless particles, a drawn frame).

Run: ``python benchmarks/bench_startup.py [--cases demo,render] [--runs cold,warm] [--json]``.
A cold run compiles for about a minute on the 2-core machine, so all cases take several
minutes. Figures go to docs/performance.md ("Start-up: compiled kernels").
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import textwrap
import time
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


def _env(cache: str) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if not k.startswith("NUMBA_")}
    env.update(PYGLET_HEADLESS="1", PYTHONPATH=str(REPO))
    env["NUMBA_CACHE_DIR" if NUMBA_CACHE_DIR else "XDG_CACHE_HOME"] = cache
    return env


def _snippet(code: str):
    def run(cache: str, out: Path) -> tuple[float, str]:
        start = time.perf_counter()
        proc = subprocess.run([sys.executable, "-c", textwrap.dedent(code)], env=_env(cache),
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
        proc = subprocess.Popen([sys.executable, "-m", "riverflow", *args], env=_env(cache),
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


def main(argv: list[str] | None = None) -> list[dict]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cases", default=",".join(CASES))
    parser.add_argument("--runs", default="cold,warm")
    parser.add_argument("--json", action="store_true")
    parser.add_argument("--numba-cache-dir", action="store_true",
                        help="pass the cache folder as NUMBA_CACHE_DIR")
    args = parser.parse_args(argv)
    global NUMBA_CACHE_DIR
    NUMBA_CACHE_DIR = args.numba_cache_dir
    results = []
    for name in args.cases.split(","):
        with tempfile.TemporaryDirectory(prefix="riverflow-startup-") as tmp:
            cache, out = Path(tmp) / "cache", Path(tmp) / "out"
            out.mkdir()
            for run in args.runs.split(","):
                seconds, err = CASES[name](str(cache), out)
                row = {"case": name, "run": run, "seconds": round(seconds, 2),
                       "progress_line": "compiling riverflow kernels" in err}
                results.append(row)
                if not args.json:
                    print(f"{name:18s} {run:5s} {seconds:6.1f} s   progress line: "
                          f"{'yes' if row['progress_line'] else 'no'}", flush=True)
    if args.json:
        print(json.dumps(results, indent=2))
    return results


if __name__ == "__main__":
    main()
