"""The water pass's rendering work on llvmpipe: the advected mode's per-pixel loop over the
GPU-made sprite grid against splatting the sprites (the pre-advected mode).

Run: ``python benchmarks/bench_water_pass.py [--size 1920x1080] [--radius 5] [--iters 10]``.
With no GPU, the nearest thing to a GPU figure: ``LP_NUM_THREADS=0`` (set here before the GL
context exists) makes llvmpipe render in this thread, so its work is this thread's CPU time
(a wait for a core is not counted). One frame of the chase flight (after 120 warm-up frames)
is drawn again and again, the variants interleaved, each followed by ``glFinish``:

* ``mesh``: the water meshes in one flat colour (the pass's fixed cost);
* ``grid``: the pass that makes the sprite grid (``sprite_lists.glsl``) alone;
* ``advected``: the grid pass, then the water with the per-pixel sprite loop;
* ``splat``: the position pass and every sprite as a quad added into a float target, then the
  water reading it (the pre-advected mode).

Prints medians [ms] and each sprite variant minus ``mesh``. Software rendering is 10–100×
slower than a GPU and weighs costs differently (no blending hardware, no texture caches): a
guide, not a GPU figure (docs/performance.md, Drawing).
"""
from __future__ import annotations

import argparse
import os
import time

os.environ.setdefault("PYGLET_HEADLESS", "1")
os.environ.setdefault("PYGLET_DEBUG_GL", "0")
os.environ.setdefault("NUMBA_NUM_THREADS", "1")
os.environ["LP_NUM_THREADS"] = "0"

import numpy as np  # noqa: E402


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", default="1920x1080")
    parser.add_argument("--radius", type=float, default=5.0)
    parser.add_argument("--iters", type=int, default=10)
    args = parser.parse_args(argv)
    size = tuple(int(v) for v in args.size.split("x"))

    import riverflow as rf
    from riverflow.components.display import DisplayMode
    from riverflow.engine import gl
    from riverflow.kernels.sprites import SPRITE_RADIUS_FACTOR
    from riverflow.scenes.flight import fly

    world = rf.RiverWorld(rf.default_scene(seed=0), size=size, gl=True, seed=0,
                          config=rf.RiverConfig(radius_px=args.radius,
                                                tile_production="blocking"))
    fly(world, 120)
    world.draw()
    gl.finish()
    drawer = world._drawer()
    gpu = drawer.gpu
    # the view block stays as the frame drawn above left it (the same camera)
    with world.active():
        waves, wave_tex = drawer._wave(world, gpu, world.display)
        ripples = drawer._upload_ripples(world, gpu, None)
        meshes = drawer._tile_meshes(world, gpu)

    def water(mode: DisplayMode) -> None:
        gpu.main_fb.bind()
        gl.set_depth(True)
        gl.set_blend(gl.BLEND_WATER)
        wave_tex.bind(1)
        gpu.params.bind(2)
        gpu.grid.bind(3)
        gpu.accum.bind(4)
        program = gpu.programs["water"]
        program.use()
        program.set(u_wave=1, u_params=2, u_grid=3, u_accum=4, u_mode=int(mode),
                    u_show_grid=False, u_slope_factor=0.2, u_clarity_m=2.5,
                    u_sprite_radius_factor=SPRITE_RADIUS_FACTOR,
                    u_grid_cell_px=float(gpu.grid_shape[0]), u_grid_size=gpu.grid_shape[1:],
                    **waves, **ripples)
        for mesh in meshes:
            mesh.draw()

    def splat() -> None:
        gpu.params.bind(2)
        wave_tex.bind(1)
        drawer._pre_advect(gpu, waves, drawer.last_sprites, meshes)
        water(DisplayMode.PRE_ADVECTED)

    variants = {
        "mesh": lambda: water(DisplayMode.MESH),
        "grid": lambda: drawer._make_grid(gpu, args.radius),
        "advected": lambda: (drawer._make_grid(gpu, args.radius), water(DisplayMode.ADVECTED)),
        "splat": splat,
    }
    times: dict[str, list[float]] = {name: [] for name in variants}
    for _ in range(args.iters):
        for name, run in variants.items():
            gl.finish()
            t0 = time.thread_time()
            run()
            gl.finish()
            times[name].append((time.thread_time() - t0) * 1e3)
    world.close()
    med = {name: float(np.median(v)) for name, v in times.items()}
    print(f"{size[0]}x{size[1]} r={args.radius:g}, {drawer.last_sprites} sprites drawn, "
          f"llvmpipe thread CPU, median of {args.iters}:")
    for name, value in med.items():
        extra = "" if name in ("mesh", "grid") else f"  (sprites: {value - med['mesh']:.1f} ms)"
        print(f"  {name:9s} {value:8.1f} ms{extra}")
    return med


if __name__ == "__main__":
    main()
