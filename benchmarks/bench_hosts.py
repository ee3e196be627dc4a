"""Cost of drawing the rivers in other libraries' windows (issue 28): the CPU time of a frame's
draw in a pygame-ce, glfw and arcade host (``gl="current"``: the host's state saved, the
frame drawn offscreen, composited into the host's framebuffer with its depth, the state put
back) against the pyglet path at the same size (``gl=True`` in a pyglet window:
``draw()`` then ``blit_to_window()``). Issue target: each host within 10 % of the pyglet path.

Run: ``python benchmarks/bench_hosts.py [--size 640x360] [--frames 60] [--json]``. Each host
runs in a process of its own (one windowing library per process, as in a game) on one X
display: ``$DISPLAY``, else an Xvfb the script starts. What is timed, per frame after 20
warm-up frames of a fixed view (the default scene's), with a ``step(1/60)`` between frames
(not timed): this thread's CPU time (``time.thread_time``: time spent waiting for a core on
the shared machine is not counted) of the draw call(s), ``PYGLET_DEBUG_GL=0`` (no error check
after every GL call). On Mesa's llvmpipe the draw's rasterisation runs in llvmpipe's own
threads, which this does not count (``LP_NUM_THREADS=0`` would count it, and then the
figures measure the software renderer: ``benchmarks/bench_draw.py --frame-times``).
Also reported: the host state's save and restore alone (``HostState``), per frame.
"""
from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import time

os.environ.setdefault("PYGLET_DEBUG_GL", "0")
os.environ.setdefault("NUMBA_NUM_THREADS", "1")

HOSTS = ("pyglet", "pygame", "glfw", "arcade")
WARMUP = 20


def _world(size):
    import riverflow as rf

    return rf.RiverWorld(rf.default_scene(seed=0), size=size, gl="current", seed=0)


def _time_frames(world, frames: int, draw) -> list[float]:
    out = []
    for k in range(WARMUP + frames):
        world.step(1 / 60)
        t0 = time.thread_time()
        draw()
        if k >= WARMUP:
            out.append((time.thread_time() - t0) * 1e3)
    return out


def _state_ms(world, repeats: int = 200) -> float:
    from riverflow.engine import gl

    with gl._as_pyglet_current(world.context):
        t0 = time.thread_time()
        for _ in range(repeats):
            gl.HostState.save().restore()
        return (time.thread_time() - t0) * 1e3 / repeats


def run_host(host: str, size, frames: int) -> dict:
    import numpy as np

    w, h = size
    state_ms = None
    if host == "pyglet":
        import pyglet

        import riverflow as rf

        window = pyglet.window.Window(w, h, visible=True)
        world = rf.RiverWorld(rf.default_scene(seed=0), size=size, gl=True, seed=0)

        def draw():
            world.draw()
            world.blit_to_window(w, h)
        times = _time_frames(world, frames, draw)
        world.close()
        window.close()
    elif host == "pygame":
        import pygame

        pygame.display.init()
        for key, value in ((pygame.GL_CONTEXT_MAJOR_VERSION, 3),
                           (pygame.GL_CONTEXT_MINOR_VERSION, 3),
                           (pygame.GL_CONTEXT_PROFILE_MASK, pygame.GL_CONTEXT_PROFILE_CORE),
                           (pygame.GL_DEPTH_SIZE, 24)):
            pygame.display.gl_set_attribute(key, value)
        pygame.display.set_mode(size, pygame.OPENGL | pygame.DOUBLEBUF)
        world = _world(size)
        view, projection = (m.ravel() for m in (world.camera.view_matrix(),
                                                world.camera.projection_matrix()))
        times = _time_frames(world, frames, lambda: world.draw(view, projection))
        state_ms = _state_ms(world)
        world.close()
        pygame.display.quit()
    elif host == "glfw":
        import glfw

        glfw.init()
        glfw.window_hint(glfw.CONTEXT_VERSION_MAJOR, 3)
        glfw.window_hint(glfw.CONTEXT_VERSION_MINOR, 3)
        glfw.window_hint(glfw.OPENGL_PROFILE, glfw.OPENGL_CORE_PROFILE)
        glfw.window_hint(glfw.OPENGL_FORWARD_COMPAT, True)
        window = glfw.create_window(w, h, "bench", None, None)
        glfw.make_context_current(window)
        world = _world(size)
        view, projection = (m.ravel() for m in (world.camera.view_matrix(),
                                                world.camera.projection_matrix()))
        times = _time_frames(world, frames, lambda: world.draw(view, projection))
        state_ms = _state_ms(world)
        world.close()
        glfw.destroy_window(window)
        glfw.terminate()
    elif host == "arcade":
        import arcade

        window = arcade.Window(w, h, "bench")
        world = _world(size)
        view, projection = (m.ravel() for m in (world.camera.view_matrix(),
                                                world.camera.projection_matrix()))
        times = _time_frames(world, frames, lambda: world.draw(view, projection))
        state_ms = _state_ms(world)
        world.close()
        window.close()
    else:
        raise SystemExit(f"unknown host {host!r}; one of {', '.join(HOSTS)}")
    t = np.asarray(times)
    return {"host": host, "size": list(size), "frames": frames,
            "draw_cpu_ms_median": float(np.median(t)),
            "draw_cpu_ms_p95": float(np.percentile(t, 95)),
            "state_save_restore_ms": state_ms}


def _start_xvfb():
    binary = shutil.which("Xvfb")
    if binary is None:
        raise SystemExit("no $DISPLAY and no Xvfb: run under a display or install xvfb")
    read, write = os.pipe()
    proc = subprocess.Popen([binary, "-displayfd", str(write), "-screen", "0", "1920x1080x24",
                             "-nolisten", "tcp"], pass_fds=(write,),
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    os.close(write)
    with os.fdopen(read) as pipe:
        return proc, f":{pipe.readline().strip()}"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", default="640x360")
    parser.add_argument("--frames", type=int, default=60)
    parser.add_argument("--json", action="store_true")
    parser.add_argument("--host", help=argparse.SUPPRESS)     # one host, in this process
    args = parser.parse_args()
    size = tuple(int(v) for v in args.size.lower().split("x"))
    if args.host:
        print(json.dumps(run_host(args.host, size, args.frames)))
        return
    xvfb = None
    env = dict(os.environ)
    env.pop("PYGLET_HEADLESS", None)
    if not env.get("DISPLAY"):
        xvfb, env["DISPLAY"] = _start_xvfb()
    results = []
    try:
        for host in HOSTS:
            run = subprocess.run([sys.executable, __file__, "--host", host, "--size",
                                  args.size, "--frames", str(args.frames)], env=env,
                                 capture_output=True, text=True)
            lines = [line for line in run.stdout.splitlines() if line.startswith("{")]
            if run.returncode or not lines:
                results.append({"host": host, "error": run.stderr.strip()[-400:]})
            else:
                results.append(json.loads(lines[-1]))
    finally:
        if xvfb is not None:
            xvfb.terminate()
    if args.json:
        print(json.dumps(results, indent=1))
        return
    base = next((r["draw_cpu_ms_median"] for r in results if r["host"] == "pyglet"
                 and "error" not in r), None)
    print(f"draw CPU per frame at {args.size}, {args.frames} frames (thread CPU time, ms)")
    for r in results:
        if "error" in r:
            print(f"  {r['host']:7s} failed: {r['error']}")
            continue
        ratio = f"{r['draw_cpu_ms_median'] / base - 1:+.0%} vs pyglet" if base else ""
        state = (f", state save+restore {r['state_save_restore_ms']:.3f} ms"
                 if r["state_save_restore_ms"] is not None else "")
        print(f"  {r['host']:7s} median {r['draw_cpu_ms_median']:6.2f}  p95 "
              f"{r['draw_cpu_ms_p95']:6.2f}  {ratio}{state}")


if __name__ == "__main__":
    main()
