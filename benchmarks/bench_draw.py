"""Cost of drawing: the CPU side (sprite tables, the whole draw system) and the whole frame.

Run: ``make bench`` or ``python benchmarks/bench_draw.py [--json] [--frames N] [--repeats N]
[--frame-times]``. Issue target (issue 12, item 6): the CPU side of drawing ≤ 1 ms a frame at
1920×1080 with r = 5 px. Figures go to docs/performance.md.

What is timed, per frame of the chase flight (``riverflow.scenes.flight``), after 120 warm-up
frames, one core (``NUMBA_NUM_THREADS=1``), ``PYGLET_DEBUG_GL=0`` (no error check after every
GL call):

* **tables**: ``DrawRivers.last_tables_ms`` (thread CPU time, below), the sprite table and bins built (numba) and
  uploaded, and the GPU pass that makes the sprite grid from them submitted (advected and
  coverage modes only);
* **draw CPU**: ``world.timings_ms["draw"]`` (likewise), the whole draw system, with the GL calls
  that render made no-ops (draws, multi-draws, clears and mipmap generation; their number is
  counted). On Mesa's llvmpipe (no GPU) those calls are where the rendering itself runs on the
  CPU: vertex shading and binning inside the call, rasterisation when a later call needs the
  result (or in llvmpipe's threads, which then compete with this one for the machine's two
  cores; in this thread when the process is pinned to one core: the reflection's mip chain
  alone was 2.8 ms a frame at 1920×1080). A GPU driver returns from such a call in
  microseconds. Every other GL call (state, uniforms, buffer and texture uploads) is made for
  real; the framebuffers are made in an untimed first frame that draws for real;
* with ``--frame-times``: the whole frame on llvmpipe, ``glFinish`` included (reported, not a
  target: software rendering is 10–100× slower than any GPU), and, with ``LP_NUM_THREADS=0``
  set before the GL context exists, llvmpipe's work as this thread's CPU time (a steadier
  proxy for the GPU's work on a loaded machine: no waiting for a core is counted).

The machine is shared: the CPU figures are this thread's CPU time (``time.thread_time_ns``
in place of the clock the draw system reads: time spent waiting for a core is not counted),
and ``--repeats`` runs every case that many times in turn and reports the median of the runs'
medians (p95 likewise).
"""
from __future__ import annotations

import argparse
import json
import os
import time

os.environ.setdefault("PYGLET_HEADLESS", "1")
os.environ.setdefault("PYGLET_DEBUG_GL", "0")
os.environ.setdefault("NUMBA_NUM_THREADS", "1")

import numpy as np  # noqa: E402

CASES = (((1920, 1080), 5.0, "advected"), ((1920, 1080), 5.0, "pre-advected"),
         ((1920, 1080), 10.0, "advected"), ((1920, 1080), 10.0, "pre-advected"),
         ((640, 360), 10.0, "advected"))
DRAW_CALLS = ("glDrawArrays", "glDrawElementsBaseVertex", "glMultiDrawElementsBaseVertex",
              "glClear", "glGenerateMipmap")


class _ThreadClock:
    """Stands in for the ``time`` module of the draw system and the world: its
    ``perf_counter_ns`` is this thread's CPU time."""

    def __getattr__(self, name):
        return getattr(time, name)

    @staticmethod
    def perf_counter_ns() -> int:
        return time.thread_time_ns()


class _NoDraw:
    """Within ``with``: pyglet's draw and clear calls do nothing and are counted."""

    def __init__(self) -> None:
        import pyglet.gl as pgl
        self.pgl = pgl
        self.real = {name: getattr(pgl, name) for name in DRAW_CALLS}
        self.calls = 0

    def _count(self, *args) -> None:
        self.calls += 1

    def __enter__(self):
        import riverflow.engine.world as world_module
        import riverflow.systems.draw as draw_module
        self.modules = (world_module, draw_module)
        for name in DRAW_CALLS:
            setattr(self.pgl, name, self._count)
        for module in self.modules:
            module.time = _ThreadClock()
        return self

    def __exit__(self, *exc) -> None:
        for name, fn in self.real.items():
            setattr(self.pgl, name, fn)
        for module in self.modules:
            module.time = time


def drawn_world(scene, size, radius, mode: str, warmup: int):
    """A drawing world on ``scene`` in display mode ``mode`` (blocking tiles), flown
    ``warmup`` frames along the chase flight and drawn once (programs, framebuffers, tile
    buffers and textures made), the GPU idle (bench_gpu.py uses it too)."""
    import riverflow as rf
    from riverflow.components.display import settings_for
    from riverflow.engine import gl
    from riverflow.scenes.flight import fly

    world = rf.RiverWorld(scene, size=size, gl=True, seed=0,
                          config=rf.RiverConfig(radius_px=radius, tile_production="blocking"))
    for key, value in vars(settings_for(mode)).items():
        setattr(world.display, key, value)
    fly(world, warmup)
    world.draw()
    gl.finish()
    return world


def run_case(scene, size, radius, mode, frames: int, warmup: int, frame_times: bool) -> dict:
    from riverflow.engine import gl
    from riverflow.scenes.flight import fly

    world = drawn_world(scene, size, radius, mode, warmup)
    drawer = world._drawer()
    tables, cpu, calls, frame, thread = [], [], [], [], []
    for i in range(frames):
        fly(world, 1, start=warmup + i)
        gl.finish()
        with _NoDraw() as counted:
            world.draw()
        tables.append(drawer.last_tables_ms)
        cpu.append(world.timings_ms["draw"])
        calls.append(counted.calls)
        if frame_times:
            gl.finish()
            t0, c0 = time.perf_counter(), time.thread_time()
            world.draw()
            gl.finish()
            frame.append((time.perf_counter() - t0) * 1e3)
            thread.append((time.thread_time() - c0) * 1e3)
    out = {"size": list(size), "radius_px": radius, "mode": mode, "frames": frames,
           "particles": len(world.particles), "sprites_drawn": drawer.last_sprites,
           "renderer": gl.renderer_name(), "tables_ms": _stats(tables),
           "draw_cpu_ms": _stats(cpu), "draw_calls": int(np.median(calls))}
    if frame_times:
        out["frame_with_finish_ms"] = _stats(frame)
        out["frame_thread_cpu_ms"] = _stats(thread)
    world.close()
    return out


def _stats(v) -> dict:
    return {"p50": float(np.median(v)), "p95": float(np.percentile(v, 95))}


def _merge(runs: list[dict]) -> dict:
    """Median over repeated runs of each run's p50 and p95."""
    out = dict(runs[0])
    for key, value in runs[0].items():
        if isinstance(value, dict):
            out[key] = {k: float(np.median([r[key][k] for r in runs])) for k in value}
    out["repeats"] = len(runs)
    return out


def main(argv: list[str] | None = None) -> list[dict]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--json", action="store_true")
    parser.add_argument("--frames", type=int, default=60)
    parser.add_argument("--warmup", type=int, default=120)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--frame-times", action="store_true",
                        help="also time whole frames on llvmpipe (slow: ~0.1-0.7 s a frame)")
    parser.add_argument("--cases", default="all",
                        help="comma-separated case numbers (0-based) of CASES, or 'all'")
    args = parser.parse_args(argv)
    if args.frame_times:
        os.environ.setdefault("LP_NUM_THREADS", "0")     # llvmpipe's work in this thread
    import riverflow as rf

    scene = rf.default_scene(seed=0)
    cases = CASES if args.cases == "all" else [CASES[int(k)] for k in args.cases.split(",")]
    runs: dict[int, list[dict]] = {k: [] for k in range(len(cases))}
    for _ in range(args.repeats):
        for k, (size, radius, mode) in enumerate(cases):
            runs[k].append(run_case(scene, size, radius, mode, args.frames, args.warmup,
                                    args.frame_times))
    results = [_merge(runs[k]) for k in range(len(cases))]
    if not args.json:
        for r in results:
            line = (f"{r['size'][0]}x{r['size'][1]} r={r['radius_px']:g} {r['mode']:13s} "
                    f"particles {r['particles']:5d} (drawn {r['sprites_drawn']:5d})  "
                    f"tables p50 {r['tables_ms']['p50']:.3f} p95 {r['tables_ms']['p95']:.3f} ms  "
                    f"draw CPU p50 {r['draw_cpu_ms']['p50']:.3f} p95 {r['draw_cpu_ms']['p95']:.3f}"
                    f" ms ({r['draw_calls']} draw calls not made)")
            if args.frame_times:
                line += (f"  frame (+glFinish) p50 {r['frame_with_finish_ms']['p50']:.1f} ms, "
                         f"thread CPU {r['frame_thread_cpu_ms']['p50']:.1f} ms")
            print(line + f"  [{r['renderer']}, {r['repeats']} runs]", flush=True)
    else:
        print(json.dumps(results, indent=2))
    return results


if __name__ == "__main__":
    main()
