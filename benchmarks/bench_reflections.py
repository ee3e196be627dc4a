"""Cost of reflections (issue 12 item 3): the planar reflection pass and its per-pixel march,
against the same frames with reflections off, and against a screen-space probe (the other
candidate) on Mesa's llvmpipe.

Run: ``python benchmarks/bench_reflections.py [--json] [--frames N] [--sizes 640x360,...]``.
The chase flight of ``benchmarks/bench_draw.py`` (advected mode, r = 10 px); each flight frame
is drawn with reflections on and off back to back (``glFinish`` after each), so a machine
shared with other work slows both alike; the figures are medians over the frames of

* ``frame_on`` / ``frame_off``: the whole frame, drawn and finished [ms];
* ``cost``: their difference, frame by frame;
* ``work_*``: the same as CPU time of this process (every llvmpipe thread's work: much less
  sensitive than wall time to other processes on a shared machine);
* ``pass``: the reflection pass alone (terrain and props mirrored, mip levels), finished
  before and after;
* ``cpu``: the draw system's CPU time with and without reflections (issuing the calls);
* ``ssr``: what screen-space reflections would cost on the same frame: copying the frame's
  colour and depth (they cannot be sampled while drawn into) and marching every water pixel's
  reflected ray through the copied depth at full resolution (``benchmarks/shaders/
  ssr_probe.glsl``, the same march as ``shaders/reflection.glsl``'s, flat water);
  the candidate the planar pass was chosen over (``docs/deviations.md``).

Figures go to docs/performance.md. No test asserts on time.
"""
from __future__ import annotations

import argparse
import json
import os
import time
from pathlib import Path

os.environ.setdefault("PYGLET_HEADLESS", "1")
os.environ.setdefault("PYGLET_DEBUG_GL", "0")

import numpy as np  # noqa: E402

import riverflow as rf  # noqa: E402
from riverflow.components.display import settings_for  # noqa: E402
from riverflow.scenes.flight import fly  # noqa: E402

SHADERS = Path(__file__).parent / "shaders"


def _clock() -> tuple[float, float]:
    """Wall time and this process's CPU time (every llvmpipe thread's work) [s]."""
    return time.perf_counter(), time.process_time()


def _since(t0: tuple[float, float]) -> tuple[float, float]:
    """Wall and CPU milliseconds since ``t0``."""
    wall, cpu = _clock()
    return (wall - t0[0]) * 1e3, (cpu - t0[1]) * 1e3


def _median(values) -> float:
    return float(np.median(values)) if len(values) else float("nan")


class SsrProbe:
    """Screen-space reflections' GPU work on a drawn frame: copy colour and depth, then draw
    the water meshes with a shader that marches the copied depth (benchmark only)."""

    def __init__(self, drawer) -> None:
        from riverflow.engine import gl
        gpu = drawer.gpu
        w, h = gpu.size
        self.colour = gl.Texture((w, h), gl.RGBA8, linear=True)
        self.depth = gl.Texture((w, h), gl.DEPTH24)
        self.fb = gl.Framebuffer([self.colour], self.depth)
        self.program = gl.Program("ssr_probe.glsl", directory=SHADERS)

    def run(self, world, drawer) -> tuple[float, float]:
        """Wall and CPU milliseconds of the copy and the marching pass, finished."""
        from riverflow.engine import gl
        gpu = drawer.gpu
        gl.finish()
        t0 = _clock()
        gl.blit(gpu.main_fb, self.fb, depth=True)
        gpu.main_fb.bind()
        self.colour.bind(12)
        self.depth.bind(13)
        program = self.program
        program.use()
        program.set(u_colour=12, u_depth=13)   # the view block: as the frame left it
        gl.set_depth(True, write=False)
        gl.set_blend(gl.BLEND_ALPHA)
        for mesh in drawer._tile_meshes(world, gpu):
            mesh.draw()
        gl.set_blend(gl.BLEND_OFF)
        gl.finish()
        return _since(t0)

    def delete(self) -> None:
        for obj in (self.fb, self.colour, self.depth, self.program):
            obj.delete()


def run_case(scene, size, frames: int, warmup: int, ssr: bool, scale: float = 0.5) -> dict:
    from riverflow.engine import gl
    world = rf.RiverWorld(scene, size=size, gl=True, seed=0,
                          config=rf.RiverConfig(radius_px=10.0, tile_production="blocking"))
    for key, value in vars(settings_for("advected")).items():
        setattr(world.display, key, value)
    world.display.reflection_scale = scale
    fly(world, warmup)
    world.draw()
    gl.finish()
    drawer = next(s for s in world.systems if s.name == "draw")
    inner = drawer._draw_reflection
    split: list[float] = []
    split_cpu: list[float] = []

    def timed_pass(*args, **kwargs):
        gl.finish()
        t0 = _clock()
        out = inner(*args, **kwargs)
        gl.finish()
        wall, cpu = _since(t0)
        split.append(wall)
        split_cpu.append(cpu)
        return out

    probe = SsrProbe(drawer) if ssr else None
    rows = {"frame_on": [], "frame_off": [], "cost": [], "cpu_on": [], "cpu_off": [],
            "ssr": [], "work_on": [], "work_off": [], "work_cost": [], "ssr_work": []}
    mirrored = 0
    for i in range(frames):
        fly(world, 1, start=warmup + i)
        times, work = {}, {}
        for on in (True, False):
            world.display.reflections = on
            gl.finish()
            t0 = _clock()
            world.draw()
            t1 = time.perf_counter()
            gl.finish()
            times[on], work[on] = _since(t0)
            rows["cpu_on" if on else "cpu_off"].append((t1 - t0[0]) * 1e3)
            if on:
                mirrored += drawer.last_mirror_level_m is not None
        rows["frame_on"].append(times[True])
        rows["frame_off"].append(times[False])
        rows["cost"].append(times[True] - times[False])
        rows["work_on"].append(work[True])
        rows["work_off"].append(work[False])
        rows["work_cost"].append(work[True] - work[False])
        world.display.reflections = True
        drawer._draw_reflection = timed_pass          # the pass alone, finished around it
        world.draw()
        drawer._draw_reflection = inner
        if probe is not None:                         # on the reflection-less frame
            world.display.reflections = False
            world.draw()
            wall, cpu = probe.run(world, drawer)
            rows["ssr"].append(wall)
            rows["ssr_work"].append(cpu)
    if probe is not None:
        probe.delete()
    world.close()
    out = {k: _median(v) for k, v in rows.items()}
    out.update({f"{k}_min": float(np.min(v)) for k, v in rows.items() if len(v)})
    out.update(size=list(size), scale=scale, frames=frames, pass_ms=_median(split),
               pass_min=float(np.min(split)), pass_work=_median(split_cpu), mirrored=mirrored,
               renderer=gl.renderer_name())
    return out


def main(argv: list[str] | None = None) -> list[dict]:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--json", action="store_true")
    parser.add_argument("--frames", type=int, default=12)
    parser.add_argument("--warmup", type=int, default=120)
    parser.add_argument("--sizes", default="640x360,1920x1080")
    parser.add_argument("--no-ssr", action="store_true", help="skip the screen-space probe")
    parser.add_argument("--scale", type=float, default=0.5,
                        help="DisplaySettings.reflection_scale (default: %(default)s)")
    args = parser.parse_args(argv)
    scene = rf.default_scene(seed=0)
    results = []
    for text in args.sizes.split(","):
        size = tuple(int(v) for v in text.lower().split("x"))
        r = run_case(scene, size, args.frames, args.warmup, not args.no_ssr, args.scale)
        results.append(r)
        if not args.json:
            print(f"{size[0]}x{size[1]} scale {args.scale:g}: frame off p50 "
                  f"{r['frame_off']:.1f} (min {r['frame_off_min']:.1f}) ms, on "
                  f"{r['frame_on']:.1f} (min {r['frame_on_min']:.1f}) ms; cost p50 "
                  f"{r['cost']:.1f} ms, min-to-min "
                  f"{r['frame_on_min'] - r['frame_off_min']:.1f} ms; pass p50 "
                  f"{r['pass_ms']:.1f} (min {r['pass_min']:.1f}) ms; draw CPU "
                  f"{r['cpu_off']:.1f} → {r['cpu_on']:.1f} ms; screen-space probe p50 "
                  f"{r['ssr']:.1f} (min {r.get('ssr_min', float('nan')):.1f}) ms; "
                  f"{r['mirrored']}/{r['frames']} frames mirrored [{r['renderer']}]\n"
                  f"    CPU work (all llvmpipe threads, p50): frame off {r['work_off']:.1f} ms, "
                  f"on {r['work_on']:.1f} ms, cost {r['work_cost']:.1f} ms, pass "
                  f"{r['pass_work']:.1f} ms, screen-space probe {r['ssr_work']:.1f} ms",
                  flush=True)
    if args.json:
        print(json.dumps(results, indent=2))
    return results


if __name__ == "__main__":
    main()
