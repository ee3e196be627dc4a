"""Spill benchmark (issue 24): a spill on the 1000 km built-in network run for 24 simulated hours.

The network is the procedural ``default_scene`` whose rivers add up to about ``--network-km``
(1000 km: :func:`~riverflow.scenes.layout.size_for_network_length`, one try); the world is not
drawn (``gl=False``). The spill is released at the head of the main river (its first branch's
first tenth) and run with ``world.advance_spills`` in one-hour chunks. Reported: the network's
cells and the solver's fixed step, the wall and CPU time of the solver's set-up (the cells, the
discharges) and of the 24 hours, the steps taken, cell-updates per second, and the mass
bookkeeping at the end (released = in the water + out + decayed).

Target (the issue): ≤ 30 s wall for the 24 hours on one core, world not drawn; with a world
drawn at 1080p and a plume on screen, ≤ 0.3 ms added to the frame. Reported for that: the
spill system's ms per step of the undrawn 1000 km world at ``clock.speed_factor`` 60 (one
simulated minute a second) over 600 frames of 1/60 s (its ``timings_ms["spill"]``), and
(:func:`drawn`) a 1920×1080 drawn world of the built-in 4 km scene with two plumes on screen:
the spill system plus the draw system's spill part per frame.

Run: ``NUMBA_NUM_THREADS=1 taskset -c 0 python benchmarks/bench_spill.py`` (``--network-km 100``
for a quicker one, ``--json out.json`` to keep the figures; ``--drawn-ab 200``: the plumes'
addition to a whole finished frame, paired within one run, :func:`drawn_ab`). Figures go to docs/performance.md.
"""
from __future__ import annotations

import argparse
import json
import time


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--network-km", type=float, default=1000.0)
    ap.add_argument("--hours", type=float, default=24.0)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--json", default=None)
    ap.add_argument("--drawn-frames", type=int, default=120,
                    help="frames of the drawn 1080p world (0: skip it)")
    ap.add_argument("--drawn-speed", type=float, default=60.0,
                    help="clock.speed_factor of the drawn world (the plumes outgrow their "
                         "square sooner the faster)")
    ap.add_argument("--drawn-young", action="store_true",
                    help="the drawn world's only plume released as the drawn frames start: it "
                         "outgrows its tint square within them (the square's moves timed)")
    ap.add_argument("--drawn-ab", type=int, default=0,
                    help="frames of a paired A/B run of the drawn world (0: skip): the spills "
                         "on and off in alternate frames (ABBA), each frame finished "
                         "(glFinish), the difference of the means with its 95 %% interval")
    ap.add_argument("--tint-refreshes", type=int, default=60,
                    help="refreshes of the spill tint timed alone (0: skip)")
    args = ap.parse_args()

    import numpy as np

    import riverflow as rf
    from riverflow.scenes.layout import network_length_m, size_for_network_length

    out: dict = {}
    t0, c0 = time.perf_counter(), time.process_time()
    scene = rf.default_scene(seed=args.seed,
                             size_km=size_for_network_length(args.network_km * 1000.0) / 1000.0)
    world = rf.RiverWorld(scene, size=(64, 36), gl=False, seed=args.seed)
    out["network_km"] = network_length_m(scene.branches) / 1000.0
    out["branches"] = len(scene.branches)
    out["scene_and_world_wall_s"] = time.perf_counter() - t0
    out["scene_and_world_cpu_s"] = time.process_time() - c0

    t0, c0 = time.perf_counter(), time.process_time()
    solver = world.configure_spills()
    net = solver.network
    main = next(b for b in scene.branches if b.kind == "main")
    e = world.add_spill(main.centerline_m[len(main.centerline_m) // 10], 1000.0, name="bench")
    out["setup_wall_s"] = time.perf_counter() - t0
    out["setup_cpu_s"] = time.process_time() - c0
    out["cells"] = net.n_cells
    out["dt_s"] = solver.dt_s

    steps = 0
    t0, c0 = time.perf_counter(), time.process_time()
    hours = 0.0
    while hours < args.hours - 1e-9:
        chunk = min(1.0, args.hours - hours)
        steps += solver.advance(3600.0 * chunk)
        hours += chunk
    out["run_wall_s"] = time.perf_counter() - t0
    out["run_cpu_s"] = time.process_time() - c0
    out["steps"] = steps
    out["cell_updates_per_s"] = steps * net.n_cells / max(out["run_cpu_s"], 1e-9)
    r = world.spill(e)
    out["released_kg"] = r.released_kg
    out["in_water_kg"] = r.in_water_kg
    out["out_kg"] = sum(r.out_kg.values())
    out["balance_kg"] = r.balance_kg
    out["front_km"] = r.front_m / 1000.0

    # the frame's share: the spill system at 60x, 600 frames
    world.speed_factor = 60.0
    for _ in range(10):
        world.step(1 / 60)
    ms = []
    for _ in range(600):
        world.step(1 / 60)
        ms.append(world.timings_ms["spill"])
    out["frame_spill_ms_mean"] = float(np.mean(ms))
    out["frame_spill_ms_p99"] = float(np.percentile(ms, 99))
    out["frame_spill_ms_max"] = float(np.max(ms))
    world.close()
    if args.tint_refreshes:
        out.update(tint_alone(args.tint_refreshes))
    if args.drawn_frames:
        out.update(drawn(args.drawn_frames, args.drawn_speed, args.drawn_young))
    if args.drawn_ab:
        out.update(drawn_ab(args.drawn_ab, args.drawn_speed))
    for k, v in out.items():
        print(f"{k:>24}: {v:.6g}" if isinstance(v, float) else f"{k:>24}: {v}")
    if args.json:
        with open(args.json, "w") as f:
            json.dump(out, f, indent=2)


def drawn(frames: int, speed: float = 60.0, young: bool = False) -> dict:
    """What the spills add to a drawn frame: a 1920×1080 ``gl=True`` world of the built-in
    4 km scene looking at the confluence, two plumes on screen, ``speed_factor`` 60; per frame
    the spill system's time (``timings_ms["spill"]``) and the draw system's spill part (the
    spills' grid followed and sampled by the wave particles, ``DrawRivers._tint_particles``,
    and the concentration mode's texture uniforms, ``DrawRivers._upload_spill``, both timed
    by wrapping them), wall, CPU time of the process (``time.process_time_ns``: llvmpipe's
    threads still drawing the previous frame count in it) and of the calling thread alone
    (``time.thread_time_ns``: the spill part's own)."""
    import numpy as np

    import riverflow as rf
    from riverflow.systems import draw as draw_module

    spent = []
    acc = [0.0, 0.0, 0.0]
    originals = {name: getattr(draw_module.DrawRivers, name)
                 for name in ("_tint_particles", "_upload_spill")
                 if hasattr(draw_module.DrawRivers, name)}     # (an older draw: the latter)

    def timing(original):
        def timed(self, *args):
            w0, c0, t0 = time.perf_counter_ns(), time.process_time_ns(), time.thread_time_ns()
            try:
                return original(self, *args)
            finally:
                acc[0] += (time.perf_counter_ns() - w0) * 1e-6
                acc[1] += (time.process_time_ns() - c0) * 1e-6
                acc[2] += (time.thread_time_ns() - t0) * 1e-6
        return timed

    for name, original in originals.items():
        setattr(draw_module.DrawRivers, name, timing(original))
    world = _drawn_world(speed, plumes=not young)
    scene = world.scene
    for _ in range(10):
        world.step(1 / 60)
        world.draw()
    if young:       # the only plume, below the confluence, released now: it outgrows its
        middle = scene.branch("main_middle").centerline_m
        world.add_spill(middle[int(len(middle) * 0.1)], 100.0, name="young")   # square soon
    system = []
    whole = []
    tint = world._drawer().gpu.spill_tint
    rect, moves, placed0 = tint.rect_m, 0, getattr(tint, "placements", 0)
    for _ in range(frames):
        w0, c0 = time.perf_counter_ns(), time.thread_time_ns()
        world.step(1 / 60)
        system.append(world.timings_ms["spill"])
        acc[:] = 0.0, 0.0, 0.0
        world.draw()
        whole.append(((time.perf_counter_ns() - w0) * 1e-6, (time.thread_time_ns() - c0) * 1e-6))
        spent.append(tuple(acc))
        moves += tint.rect_m != rect
        rect = tint.rect_m
    placements = getattr(tint, "placements", placed0) - placed0
    world.close()
    for name, original in originals.items():
        setattr(draw_module.DrawRivers, name, original)
    wall = np.array([w for w, _, _ in spent])
    cpu = np.array([c for _, c, _ in spent])
    thread = np.array([t for _, _, t in spent])
    added = np.array(system) + wall
    frame_wall = np.array([w for w, _ in whole])
    frame_cpu = np.array([c for _, c in whole])
    return {"drawn_square_moves": int(moves),
            "drawn_square_placements": int(placements),
            "drawn_frame_wall_ms_p50": float(np.median(frame_wall)),
            "drawn_frame_wall_ms_p99": float(np.percentile(frame_wall, 99)),
            "drawn_frame_wall_ms_max": float(frame_wall.max()),
            "drawn_frame_thread_cpu_ms_p50": float(np.median(frame_cpu)),
            "drawn_frame_thread_cpu_ms_max": float(frame_cpu.max()),
            "drawn_spill_system_ms_mean": float(np.mean(system)),
            "drawn_tint_wall_ms_p50": float(np.median(wall)),
            "drawn_tint_wall_ms_p99": float(np.percentile(wall, 99)),
            "drawn_tint_wall_ms_mean": float(wall.mean()),
            "drawn_tint_cpu_ms_mean": float(cpu.mean()),
            "drawn_tint_wall_ms_max": float(wall.max()),
            "drawn_tint_cpu_ms_max": float(cpu.max()),
            "drawn_tint_thread_cpu_ms_mean": float(thread.mean()),
            "drawn_tint_thread_cpu_ms_p50": float(np.median(thread)),
            "drawn_tint_thread_cpu_ms_p99": float(np.percentile(thread, 99)),
            "drawn_tint_thread_cpu_ms_max": float(thread.max()),
            "drawn_added_ms_max": float(added.max()),
            "drawn_added_ms_mean": float(added.mean()),
            "drawn_added_ms_p50": float(np.median(added)),
            "drawn_added_ms_p99": float(np.percentile(added, 99))}


def _drawn_world(speed: float, plumes: bool = True):
    """:func:`drawn`'s world: 1920×1080, the confluence, two plumes 15 minutes old (none
    if not ``plumes``)."""
    import riverflow as rf

    scene = rf.default_scene(seed=0)
    world = rf.RiverWorld(scene, size=(1920, 1080), gl=True, seed=0)
    j = scene.water.junctions_m[0]
    world.camera.look_at((j[0] - 150.0, j[1] - 450.0, 380.0), (j[0] + 150.0, j[1], 0.0))
    if plumes:
        trib = scene.branch("tributary").centerline_m
        upper = scene.branch("main_upper").centerline_m
        world.add_spill(trib[int(len(trib) * 0.75)], 300.0, 3600.0, name="dye")
        world.add_spill(upper[int(len(upper) * 0.7)], 200.0, 3600.0, name="mud")
        world.advance_spills(900.0)
    world.speed_factor = speed
    world.load_view()
    return world


def drawn_ab(frames: int, speed: float = 60.0) -> dict:
    """What the plumes add to a whole drawn frame, paired within one run so that the
    machine's load cancels: :func:`drawn`'s world (two plumes on screen, 1080p), the frames
    alternately with the spills on (as always) and off (the spill system and the draw's
    tint sampling skipped, the particles' tint zeroed for that frame and put back after it,
    outside the timing) in the order ABBA ABBA…, each frame's step + draw followed by
    ``glFinish`` (its own rasterisation counted in it, not the next frame's). Per frame the
    wall time and the calling thread's CPU time; reported: the mean of on − off over the
    adjacent pairs (on, off) with its 95 % interval (normal, 1.96 standard errors), and the
    frame's mean. On llvmpipe the wall time is mostly the rasteriser's: an addition under
    its noise shows as an interval around 0."""
    import numpy as np
    from pyglet import gl as pgl

    from riverflow.systems import draw as draw_module
    from riverflow.systems import spill as spill_module

    state = {"on": True}
    tint_particles = draw_module.DrawRivers._tint_particles
    advance = spill_module.AdvanceSpills.process

    def maybe_tint(self, *args):
        if state["on"]:
            return tint_particles(self, *args)

    def maybe_advance(self, *args):
        if state["on"]:
            return advance(self, *args)

    draw_module.DrawRivers._tint_particles = maybe_tint
    spill_module.AdvanceSpills.process = maybe_advance
    try:
        world = _drawn_world(speed)
        for _ in range(10):
            world.step(1 / 60)
            world.draw()
        pgl.glFinish()
        pool = world.pool
        kept = np.empty_like(pool.tint)
        wall, cpu, on = [], [], []
        for i in range(frames + frames % 2):
            state["on"] = i % 4 in (0, 3)               # ABBA
            if not state["on"]:
                kept[:] = pool.tint
                pool.tint[:] = 0.0
            w0, c0 = time.perf_counter_ns(), time.thread_time_ns()
            world.step(1 / 60)
            world.draw()
            pgl.glFinish()
            wall.append((time.perf_counter_ns() - w0) * 1e-6)
            cpu.append((time.thread_time_ns() - c0) * 1e-6)
            on.append(state["on"])
            if not state["on"]:
                pool.tint[:] = kept
        world.close()
    finally:
        draw_module.DrawRivers._tint_particles = tint_particles
        spill_module.AdvanceSpills.process = advance
    on = np.array(on)
    out = {"ab_pairs": int(len(on) // 2)}
    for name, v in (("wall", np.array(wall)), ("thread_cpu", np.array(cpu))):
        pairs = v.reshape(-1, 2)
        d = np.where(on[0::2], pairs[:, 0] - pairs[:, 1], pairs[:, 1] - pairs[:, 0])
        half = 1.96 * d.std(ddof=1) / np.sqrt(len(d))
        out[f"ab_{name}_ms_frame_mean"] = float(v.mean())
        out[f"ab_{name}_ms_added_mean"] = float(d.mean())
        out[f"ab_{name}_ms_added_ci95_lo"] = float(d.mean() - half)
        out[f"ab_{name}_ms_added_ci95_hi"] = float(d.mean() + half)
    return out


def tint_alone(refreshes: int) -> dict:
    """The spill tint's refresh (``SpillTint.update``) and upload (the whole texture and the
    rows it changed, each followed by ``glFinish``) timed alone: the drawn part's two plumes
    in a 64×36 world, a refresh every 5 s of spill time; CPU time. Refreshes where the tint's
    square moved (its texels placed on the network again) are counted apart."""
    import numpy as np
    from pyglet import gl as pgl

    import riverflow as rf
    from riverflow.engine import gl
    from riverflow.hydro.spills import TINT_TEXELS, SpillTint

    scene = rf.default_scene(seed=0)
    world = rf.RiverWorld(scene, size=(64, 36), gl=True, seed=0)
    trib = scene.branch("tributary").centerline_m
    upper = scene.branch("main_upper").centerline_m
    world.add_spill(trib[int(len(trib) * 0.75)], 300.0, 3600.0, name="dye")
    world.add_spill(upper[int(len(upper) * 0.7)], 200.0, 3600.0, name="mud")
    world.advance_spills(900.0)
    world.step(1 / 60)
    world.draw()
    gl.make_current(world.context)
    solver = world.spill_solver
    tint = SpillTint()
    colours = [(1.0, 0.0, 0.0), (0.0, 0.0, 1.0)]
    tint.update(solver, world.field, colours)
    tex = gl.Texture((TINT_TEXELS, TINT_TEXELS), gl.RGBA32F, linear=True)
    tex.upload(tint.rgba)
    update, moved_ms, whole, rows = [], [], [], []
    for _ in range(refreshes):
        solver.advance(5.0)
        c0 = time.process_time()
        tint.update(solver, world.field, colours)
        ms = (time.process_time() - c0) * 1e3
        (moved_ms if tint.rows == (0, TINT_TEXELS) else update).append(ms)
        pgl.glFinish()
        c0 = time.process_time()
        tex.upload(tint.rgba)
        pgl.glFinish()
        whole.append((time.process_time() - c0) * 1e3)
        first, end = tint.rows
        c0 = time.process_time()
        tex.upload(tint.rgba, first_row=first, rows=end - first)
        pgl.glFinish()
        rows.append((time.process_time() - c0) * 1e3)
    tex.delete()
    world.close()
    return {"tint_refresh_cpu_ms_mean": float(np.mean(update)),
            "tint_refresh_cpu_ms_max": float(np.max(update)),
            "tint_square_moves": len(moved_ms),
            "tint_square_move_cpu_ms_max": float(max(moved_ms, default=0.0)),
            "tint_upload_whole_cpu_ms_p50": float(np.median(whole)),
            "tint_upload_rows_cpu_ms_p50": float(np.median(rows))}


if __name__ == "__main__":
    main()
