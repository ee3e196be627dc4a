"""Record the argument types riverflow's kernels are called with; write ``riverflow/kernels/_signatures.py``.

The warm-up (:func:`riverflow.kernels.warmup.compile_kernels`) compiles each kernel before
the first frame with the types recorded here. Run this after changing a kernel's arguments
(``make kernel-signatures``); ``--check`` says whether the file is current (exit 1 if not).

Each group's workload runs in a fresh process with the warm-up off, twice: on a new cache
(the compile time of each kernel, for the warm-up's order) and again on that now warm cache,
where every first call of a riverflow kernel from Python (not a helper compiled for another
kernel) is recorded with its argument types. ``draw`` keeps only what drawing adds to
``world``. About three minutes on the 2-core machine.

    python tools/record_kernel_signatures.py [--check] [--groups world,draw]
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
OUT = REPO / "riverflow" / "kernels" / "_signatures.py"
GROUPS = ("field", "scene", "world", "draw")
SUBTRACT = {"draw": ("world",)}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--check", action="store_true", help="compare, do not write")
    parser.add_argument("--cache", default=None, metavar="DIR",
                        help="NUMBA_CACHE_DIR of the workloads (default: a new temporary one, "
                             "so that the compile times recorded for ordering are cold ones)")
    parser.add_argument("--workload", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.workload:
        return _record(args.workload)
    if args.cache is None:
        temp = tempfile.TemporaryDirectory(prefix="riverflow-record-")
        args.cache = temp.name
    # first pass: compile times (cold when the cache is new); second pass, on the now warm
    # cache: the signatures (a kernel that Python calls but that the first pass compiled
    # earlier as another kernel's helper is only seen when it loads from the cache)
    costs: dict[str, float] = {}
    for g in GROUPS:
        for name, seconds in _run(g, args.cache)["costs"].items():
            costs.setdefault(name, seconds)
    recorded = {g: _run(g, args.cache)["signatures"] for g in GROUPS}
    for group, others in SUBTRACT.items():
        drop = {(k, s) for o in others for k, sigs in recorded[o].items() for s in sigs}
        recorded[group] = {k: [s for s in sigs if (k, s) not in drop]
                           for k, sigs in recorded[group].items()}
        recorded[group] = {k: v for k, v in recorded[group].items() if v}
    text = _render(recorded, costs)
    if args.check:
        current = OUT.read_text() if OUT.exists() else ""
        if _body(current) != _body(text):
            print(f"{OUT.relative_to(REPO)} is not current: run make kernel-signatures")
            return 1
        print(f"{OUT.relative_to(REPO)} is current")
        return 0
    OUT.write_text(text)
    n = sum(len(s) for g in recorded.values() for s in g.values())
    print(f"wrote {OUT.relative_to(REPO)}: {n} signatures in {len(GROUPS)} groups")
    return 0


def _run(group: str, cache: str) -> dict:
    env = dict(os.environ, PYGLET_HEADLESS="1", NUMBA_CACHE_DIR=cache)
    proc = subprocess.run([sys.executable, __file__, "--workload", group], env=env, cwd=REPO,
                          capture_output=True, text=True, check=False)
    if proc.returncode != 0:
        sys.stderr.write(proc.stdout + proc.stderr)
        raise SystemExit(f"workload {group} failed")
    return json.loads(proc.stdout.strip().splitlines()[-1])


def _body(text: str) -> str:
    """The signatures (not the comment, not the compile times, which vary run to run)."""
    return text[text.find("SIGNATURES"):text.find("COSTS")]


def _render(recorded: dict[str, dict[str, list[str]]], costs: dict[str, float]) -> str:
    import numba

    lines = ['"""Argument types of riverflow\'s kernels per group, for the warm-up',
             "(:mod:`riverflow.kernels.warmup`).", "",
             (f"Written by ``tools/record_kernel_signatures.py`` (numba {numba.__version__}, "
              f"Python {sys.version.split()[0]}): do"),
             "not edit; run ``make kernel-signatures`` after changing a kernel's arguments.",
             '"""', "", "SIGNATURES = {"]
    for group in GROUPS:
        lines.append(f"    {group!r}: {{")
        for kernel, sigs in recorded[group].items():
            lines.append(f"        {kernel!r}: [")
            lines += [f"            {s!r}," for s in sigs]
            lines.append("        ],")
        lines.append("    },")
    lines.append("}")
    lines += ["", "# seconds to compile each kernel on a cold cache when recorded (the warm-up starts",
              "# the costliest first, so that side-by-side compiling ends together)", "COSTS = {"]
    lines += [f"    {k!r}: {v:.2f}," for k, v in sorted(costs.items(), key=lambda kv: -kv[1])]
    lines.append("}")
    return "\n".join(lines) + "\n"


# -- one workload, in its own process --------------------------------------------------------------

def _record(group: str) -> int:
    from numba.core import sigutils
    from numba.core.dispatcher import Dispatcher

    from riverflow.kernels import warmup

    warmup._recording = True               # the warm-up must not call the kernels first
    found: dict[str, list[str]] = {}
    costs: dict[str, float] = {}
    depth = threading.local()
    original = Dispatcher.compile

    def compile(self, sig):
        level = getattr(depth, "n", 0)
        args = tuple(sigutils.normalize_signature(sig)[0])
        first = level == 0 and warmup.is_riverflow_kernel(self) and args not in self.overloads
        depth.n = level + 1
        started = time.perf_counter()
        try:
            result = original(self, sig)
        finally:
            depth.n = level
        if first:
            f = self.py_func
            name = f"{f.__module__.rpartition('.')[2]}.{f.__name__}"
            costs[name] = max(costs.get(name, 0.0), time.perf_counter() - started)
            try:
                text = warmup.encode_signature(args)
            except TypeError as exc:
                print(f"not recorded: {name}: {exc}", file=sys.stderr)
            else:
                if text not in found.setdefault(name, []):
                    found[name].append(text)
        return result

    Dispatcher.compile = compile
    WORKLOADS[group]()
    print(json.dumps({"signatures": found, "costs": costs}))
    return 0


def _network():
    """The README's builder example: a confluence."""
    import riverflow as rf

    b = rf.RiverNetworkBuilder(tolerance_m=0.25)
    b.add_branch([(0, 0), (400, 40), (800, 0)], widths_m=[40, 50, 60], discharge_m2s=45.0,
                 name="main")
    b.add_branch([(300, 400), (800, 0)], 30.0, discharge_m2s=20.0, name="tributary")
    b.add_branch([(800, 0), (1400, -100)], 70.0, name="lower")
    return b.build()


def _field() -> None:
    import numpy as np

    import riverflow as rf

    for graph in (_network(), rf.default_scene(seed=0).graph):
        field = rf.FlowField(graph, slip=1.0, search_radius_factor=5.0)
        xy = np.random.default_rng(0).uniform(-200, 1400, (500, 2))
        field.query(xy)
        field.query(xy.astype(np.float32))
        field.potential(xy)


def _scene() -> None:
    import riverflow as rf

    rf.default_scene(seed=0)
    rf.default_scene(seed=1, size_km=20.0)
    rf.landscape(_network(), seed=0)


def _world() -> None:
    import dataclasses

    import riverflow as rf
    from riverflow.scenes.flight import fly

    _field()
    scene = rf.default_scene(seed=0)
    for production in ("blocking", "background"):
        config = dataclasses.replace(rf.RiverConfig(), tile_production=production)
        with rf.RiverWorld(scene, size=(320, 180), seed=0, config=config) as world:
            fly(world, 20)
            world.set_rain(1000.0)                 # the rain kernels (key R in the demo)
            fly(world, 10, start=20, load=False)
            world.field.query(world.particles.world_m[:, :2])
    _boat_run(scene, gl=False)


def _draw() -> None:
    import riverflow as rf

    _boat_run(rf.default_scene(seed=0), gl=True)


def _boat_run(scene, gl: bool) -> None:
    """The demo's boat under the chase camera (particles meet the hull) and a spill, with
    drawing: every display mode and wave tile."""
    import dataclasses

    import riverflow as rf
    from riverflow.components.display import MODE_NAMES, settings_for
    from riverflow.components.waves import WaveKind
    from riverflow.demo import BoatDemo

    config = dataclasses.replace(rf.RiverConfig(), tile_production="blocking")
    demo = BoatDemo(scene, (320, 180), config=config, gl=gl)
    try:
        demo.world.load_view()
        # a spill (issue 24): its steps (world) and, drawn, its tint grid and the particles'
        # sampling of it (draw), so that the first spill does not compile them in a frame
        main = next(b for b in scene.branches if b.kind == "main").centerline_m
        demo.world.add_spill(main[len(main) // 2], 100.0, 60.0, name="record")
        demo.world.advance_spills(60.0)
        # a flood (issue 25): its routing steps and what reads its speed and level (world),
        # its drawn level (draw), so that a first flood does not load them in a frame
        world = demo.world
        world.set_hydrograph(None, [], None)
        q, now = world.flood.base_inflow_m3s(), world.flood_time_s
        world.set_hydrograph(None, [now, now + 60.0], [q, 3.0 * q])
        world.advance_flood(120.0)
        demo.input.key_down("W")
        for _ in range(30):
            demo.step()
        if gl:
            for mode in MODE_NAMES:
                for name, value in dataclasses.asdict(settings_for(mode)).items():
                    setattr(demo.world.display, name, value)
                for kind in WaveKind:
                    demo.world.display.wave = kind
                    demo.step()
                    demo.world.render()
    finally:
        demo.close()


WORKLOADS = {"field": _field, "scene": _scene, "world": _world, "draw": _draw}

if __name__ == "__main__":
    sys.exit(main())
