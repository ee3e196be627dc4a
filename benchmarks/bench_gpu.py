"""GPU frame times of every display mode at 1920×1080 and 3840×2160 (issue 12, item 6).

For each mode and size: a world on the default scene (blocking tile production, r = 10 px
unless ``--radius``), the chase flight (:func:`riverflow.scenes.flight.fly`) for ``--warmup``
frames, then ``--frames`` frames, each stepped and then drawn with:

* **GPU ms**: the GPU's own time for the whole draw (``GL_TIME_ELAPSED`` around
  ``world.draw()``: :class:`riverflow.engine.gl.GpuTimer`), read after the frame;
* **frame ms**: the wall time of ``world.draw()`` and a ``glFinish`` (the CPU side of drawing
  and the GPU's work, end to end, as a host waiting for vsync would see it).

On Mesa's llvmpipe (every machine here) the "GPU" is the CPU: the figures are those of
software rendering. On a real GPU run it where the device tool lends one, with
``PYGLET_HEADLESS=1`` and the GPU's EGL driver (``benchmarks/gpu_device.sh`` sets up a machine
that has the NVIDIA driver but no GL loader). Figures go to docs/performance.md.

Run: ``python benchmarks/bench_gpu.py [--sizes 1920x1080 3840x2160] [--modes all]
[--frames 60] [--warmup 60] [--json out.json]`` (on a software renderer, without ``--sizes``,
640×360 only: ``make bench`` runs it too).
"""
from __future__ import annotations

import argparse
import json
import os
import time

os.environ.setdefault("PYGLET_HEADLESS", "1")
os.environ.setdefault("PYGLET_DEBUG_GL", "0")

import numpy as np  # noqa: E402


def run_case(scene, size, radius, mode, frames: int, warmup: int) -> dict:
    from bench_draw import drawn_world
    from riverflow.engine import gl
    from riverflow.scenes.flight import fly

    world = drawn_world(scene, size, radius, mode, warmup)
    timer = gl.GpuTimer()
    gpu, frame, cpu = [], [], []
    for i in range(frames):
        fly(world, 1, start=warmup + i, load=False)
        gl.finish()
        t0 = time.perf_counter()
        timer.begin()
        world.draw()
        timer.end()
        gl.finish()
        frame.append((time.perf_counter() - t0) * 1e3)
        cpu.append(world.timings_ms["draw"])
        gpu.append(timer.result_ms())
    out = {"size": list(size), "radius_px": radius, "mode": mode, "frames": frames,
           "renderer": gl.renderer_name(), "particles": len(world.particles),
           "gpu_ms": _stats(gpu), "frame_ms": _stats(frame), "draw_cpu_ms": _stats(cpu),
           "gpu_ms_per_frame": [round(v, 4) for v in gpu]}
    timer.delete()
    world.close()
    return out


def _stats(v) -> dict:
    v = np.asarray(v, float)
    return {"p50": float(np.median(v)), "p95": float(np.percentile(v, 95)),
            "max": float(v.max())}


def main(argv: list[str] | None = None) -> list[dict]:
    from riverflow.components.display import MODE_NAMES

    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--sizes", nargs="+", default=None,
                        help="viewports WxH (default 1920x1080 3840x2160 on a GPU; on a "
                             "software renderer, where those take minutes a mode, 640x360)")
    parser.add_argument("--modes", nargs="+", default=["all"],
                        help=f"display modes ({', '.join(MODE_NAMES)}) or all")
    parser.add_argument("--radius", type=float, default=10.0, help="particle radius r [px]")
    parser.add_argument("--frames", type=int, default=60)
    parser.add_argument("--warmup", type=int, default=60)
    parser.add_argument("--json", metavar="PATH", help="also write the figures to PATH")
    args = parser.parse_args(argv)
    import riverflow as rf

    from riverflow.engine import gl

    modes = list(MODE_NAMES) if args.modes == ["all"] else args.modes
    if args.sizes is None:
        gl.acquire_context()
        software = any(name in gl.renderer_name().lower()
                       for name in ("llvmpipe", "softpipe", "swrast"))
        args.sizes = ["640x360"] if software else ["1920x1080", "3840x2160"]
        if software:
            print(f"software renderer ({gl.renderer_name()}): 640x360 only (--sizes to ask "
                  "for more)")
    sizes = [tuple(int(v) for v in s.lower().split("x")) for s in args.sizes]
    scene = rf.default_scene(seed=0)
    results = []
    for size in sizes:
        for mode in modes:
            r = run_case(scene, size, args.radius, mode, args.frames, args.warmup)
            results.append(r)
            print(f"{size[0]}x{size[1]} r={args.radius:g} {mode:<13} GPU p50 "
                  f"{r['gpu_ms']['p50']:7.3f} p95 {r['gpu_ms']['p95']:7.3f} ms   frame "
                  f"(draw + glFinish) p50 {r['frame_ms']['p50']:7.2f} p95 "
                  f"{r['frame_ms']['p95']:7.2f} ms   draw CPU p50 "
                  f"{r['draw_cpu_ms']['p50']:5.2f} ms   [{r['renderer']}]", flush=True)
    if args.json:
        with open(args.json, "w") as f:
            json.dump(results, f, indent=2)
    return results


if __name__ == "__main__":
    main()
