"""Live-edit benchmark (issue 25): how soon an edit's new tiles are in view, and what edits
cost the frames around them.

The built-in 4 km scene at ``--size`` (1920×1080), r = 10 px, default camera (on the main
river), ``gl=False`` (llvmpipe's draw would dominate the frame and says nothing about
edits), one core, frames paced at 60 fps (each step starts on a 1/60 s tick; the time left
is the idle time the tile worker and the edit thread run in), with a flood running (a
hydrograph on every source, as bench_flood):

1. ``--warm`` frames with nothing edited (600: as many as the edits run): the frame's median
   (wall and CPU ms) and how many were over 2× it (the host's own spikes: the baseline);
Frame CPU times are the frame's own thread's (``time.thread_time``: not the tile worker's nor
the edits' thread's, which run in its idle time).

2. ``--edits`` edits of the branch nearest the view's centre, one every ``--every``
   frames, each a centre-line bump of ±``--bump`` m (the demo's drag, made in the
   background: ``move_axis(..., wait=False)``): per edit the seconds from the call to its
   swap (the new network made), to the river's last new tile drawn (flow, water, water
   mesh), to the last new tile drawn (of the terrain kinds, the leaves of the view's cut;
   with the tile processes' CPU seconds then) and to the last new tile in view (no stale
   tile the frame asks for, ancestors included; an edit whose tiles are not in view by the
   next edit's time delays that edit, up to ``--wait`` s, so each edit reports a figure:
   ``in_view_past_next_edit`` counts them), the CPU
   seconds the tile processes (forked again for the edit) spent until then or until the next
   edit (what remaking the tiles costs, whatever the machine's load), and every frame's
   wall and CPU ms while edits run.

Target (the issue brief): an edit's new tiles in view within 0.5 s at 1080p; no frame over
2× the median while edits and a flood run (one core, paced 60 fps).

Run: ``NUMBA_NUM_THREADS=1 taskset -c 0 python benchmarks/bench_edit.py`` (``--json out.json``
to keep the figures; ``--in-place 7``: only the CPU of 7 edits made in place, the edit's own
work without its tiles; ``--remake 4``: the CPU of remaking 4 edits' tiles in view, made in
the frame's thread, per kind: what the tile process has to do, whatever the load;
``--floodplain 120 [--drawn]``: the frame's CPU over a flooded floodplain, dry and flooded).
Figures go to docs/performance.md.
"""
from __future__ import annotations

import argparse
import json
import time

import numpy as np


def _flood(world, peak: float = 3.0) -> None:
    world.set_hydrograph(None, [], None)                # makes the router
    router = world.flood
    sources = [b for b in range(len(router.network.names)) if router.net.link_start[b] < 0]
    q = float(router.net.link_q0[sources].sum())
    now = world.clock.now_s
    world.set_hydrograph(None, [now, now + 60.0, now + 600.0], [q, peak * q, q])


def _bumped(line: np.ndarray, dy_m: float, at: float, width_m: float) -> np.ndarray:
    """The line moved ``dy_m`` sideways at arc length ``at``, the demo drag's way
    (:func:`~riverflow.engine.controls.drag_weight`, ``width_m`` its spread)."""
    from riverflow.engine.controls import drag_weight

    arc = np.r_[0.0, np.cumsum(np.hypot(*np.diff(line, axis=0).T))]
    weight = drag_weight((arc - at) / width_m)
    weight[[0, -1]] = 0.0
    d = np.gradient(line, axis=0)
    normal = np.c_[-d[:, 1], d[:, 0]] / np.maximum(np.hypot(*d.T), 1e-9)[:, None]
    return line + (dy_m * weight)[:, None] * normal


def _branch_in_view(world) -> tuple[int, np.ndarray, float, float]:
    """The branch nearest the view's centre: its index, its centre line (a copy), the arc
    length [m] of its point nearest that centre and a bump's width (4 river widths) [m]."""
    target = np.asarray(world.camera.target[:2])
    link = int(np.argmin([float(np.hypot(*(b.centerline_m - target).T).min())
                          for b in world.scene.branches]))
    line0 = world.scene.branches[link].centerline_m.copy()
    arc = np.r_[0.0, np.cumsum(np.hypot(*np.diff(line0, axis=0).T))]
    at = float(arc[int(np.argmin(np.hypot(*(line0 - target).T)))])
    return link, line0, at, 4.0 * float(np.median(world.scene.branches[link].widths_m))


RIVER_KINDS = ("flow", "water", "water_mesh")
"""The tiles of the river itself (its flow, its level, its surface's mesh)."""


def _process_cpu_s(pid) -> float:
    """CPU seconds (user + system) a process has used (Linux /proc), NaN if unknown."""
    import os

    try:
        with open(f"/proc/{pid}/stat") as f:
            fields = f.read().rsplit(")", 1)[1].split()
        return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")
    except (OSError, ValueError, IndexError, TypeError):
        return float("nan")


def _stale_in_view(world, kinds=None, drawn: bool = False) -> int:
    """Stale tiles the latest frame asked for; ``drawn``: only those it draws (of the terrain
    kinds, the leaves of the view's cut, not their ancestors)."""
    from riverflow.components.flow_tiles import FLOW_KIND
    from riverflow.components.river import TerrainView
    from riverflow.tiles.table import codes as codes_of

    sched = world.tiles.scheduler
    cut = None
    if drawn:
        with world.active():
            cut = set(codes_of(world.resource(TerrainView).cut).tolist())
    return sum(len(sched.stale(k, wanted=True) if cut is None or k == FLOW_KIND
                   else sched.stale(k, wanted=True) & cut)
               for k in (kinds or sched.producers))


def run(size, edits: int, every: int, bump_m: float, warm: int, seed: int,
        wait_s: float = 30.0) -> dict:
    import riverflow as rf

    world = rf.RiverWorld(rf.default_scene(seed=seed), size=size, gl=False, seed=seed)
    world.load_view()
    _flood(world)
    link, line0, at, width = _branch_in_view(world)
    branch = world.scene.branches[link]
    tick = 1.0 / 60.0
    next_tick = time.perf_counter()
    systems: list[dict[str, float]] = []      # each frame's systems' wall ms

    def frame() -> tuple[float, float]:
        nonlocal next_tick
        now = time.perf_counter()
        if now < next_tick:
            time.sleep(next_tick - now)
        next_tick = max(next_tick + tick, time.perf_counter() - tick)
        w0, c0 = time.perf_counter(), time.thread_time()
        world.step(tick)
        systems.append(dict(world.timings_ms))
        return (time.perf_counter() - w0) * 1e3, (time.thread_time() - c0) * 1e3

    for _ in range(60):
        frame()
    quiet = np.array([frame() for _ in range(warm)])
    edit_from = len(systems)
    out: dict = {"size": f"{size[0]}x{size[1]}", "branch": branch.name,
                 "tile_workers": world.tiles.scheduler.workers,
                 "particles": len(world.particles),
                 "quiet_ms_median": float(np.median(quiet[:, 0])),
                 "quiet_cpu_ms_median": float(np.median(quiet[:, 1])),
                 "quiet_ms_max": float(quiet[:, 0].max()),
                 # the host's own: frames over 2x the median with nothing edited (the flood
                 # running), the baseline of frames_over_2x_median
                 "quiet_frames": len(quiet),
                 "quiet_frames_over_2x": int(np.sum(quiet[:, 0] > 2.0 * np.median(quiet[:, 0])))}
    during, swap_s, in_view_s, marked, swap_ms, river_s = [], [], [], [], [], []
    drawn_s, drawn_cpu_s = [], []
    worker_cpu_s: list[float] = []
    late = 0          # edits whose tiles were not in view by the next edit's time
    between = 0       # edits the edits' thread swapped in between frames
    for e in range(edits):
        sign = 1.0 if e % 2 == 0 else -1.0
        t0 = time.perf_counter()
        applied = world.edits.applied if world.edits is not None else 0
        future = world.move_axis(link, _bumped(line0, sign * bump_m, at, width), wait=False)
        swapped = river = drawn = None
        for k in range(max(every, int(wait_s * 60.0))):
            if k == every:
                late += 1        # not in view by the next edit's time: the edit waits
            during.append(frame())
            if swapped is None and world.edits.applied > applied:
                swapped = time.perf_counter() - t0
                pids = world.tiles.scheduler.worker_pids    # forked for this edit
                marked.append(sum(world.edits.last["marked"].values()))
                swap_ms.append(world.edits.last["swap_ms"])
                between += bool(world.edits.last.get("between_frames"))
            if swapped is not None and river is None \
                    and _stale_in_view(world, RIVER_KINDS, drawn=True) == 0:
                river = time.perf_counter() - t0
            if swapped is not None and drawn is None \
                    and _stale_in_view(world, drawn=True) == 0:
                drawn = time.perf_counter() - t0
                drawn_cpu_s.append(sum(map(_process_cpu_s, pids)))
            if swapped is not None and _stale_in_view(world) == 0:
                in_view_s.append(time.perf_counter() - t0)
                break
        else:
            in_view_s.append(np.nan)
        if swapped is not None:
            worker_cpu_s.append(sum(map(_process_cpu_s, pids)))
        river_s.append(river if river is not None else np.nan)
        drawn_s.append(drawn if drawn is not None else np.nan)
        swap_s.append(swapped if swapped is not None else np.nan)
        future.result(0) if future.done() else None
        for _ in range(every - 1 - k):        # none once past the next edit's time
            during.append(frame())
    during = np.array(during)
    med = float(np.median(during[:, 0]))
    out.update({
        "edits": edits, "edit_errors": len(world.edit_errors),
        "tiles_marked_per_edit_mean": float(np.mean(marked)) if marked else 0.0,
        "swap_ms_max": float(np.max(swap_ms)) if swap_ms else 0.0,
        "swapped_between_frames": between,
        "swap_s_median": float(np.nanmedian(swap_s)), "swap_s_max": float(np.nanmax(swap_s)),
        "worker_cpu_s_per_edit_median": float(np.nanmedian(worker_cpu_s))
        if worker_cpu_s else float("nan"),
        "river_in_view_s_median": float(np.nanmedian(river_s)),
        "river_in_view_s_max": float(np.nanmax(river_s)),
        "drawn_worker_cpu_s_median": float(np.nanmedian(drawn_cpu_s))
        if drawn_cpu_s else float("nan"),
        "drawn_in_view_s_median": float(np.nanmedian(drawn_s)),
        "drawn_in_view_s_max": float(np.nanmax(drawn_s)),
        "in_view_s_median": float(np.nanmedian(in_view_s)),
        "in_view_s_max": float(np.nanmax(in_view_s)),
        "in_view_late": int(np.sum(~(np.array(in_view_s) <= 0.5))),
        "in_view_past_next_edit": late,
        "edit_frames": len(during), "edit_ms_median": med,
        "edit_cpu_ms_median": float(np.median(during[:, 1])),
        "edit_ms_p99": float(np.percentile(during[:, 0], 99)),
        "edit_ms_max": float(during[:, 0].max()),
        "edit_cpu_ms_max": float(during[:, 1].max()),
        "frames_over_2x_median": int(np.sum(during[:, 0] > 2.0 * med)),
        "frames_over_2x_quiet_median": int(np.sum(during[:, 0] > 2.0 * out["quiet_ms_median"])),
        "particles_end": len(world.particles)})
    out.update(_spikes(during, systems[edit_from:], med))
    world.close()
    return out


def _spikes(during: np.ndarray, systems: list[dict[str, float]], median_ms: float) -> dict:
    """Which frames spike (wall over 2x the median) and why: those whose own thread's CPU
    is over 2x its median too (the frame's own work: the system that took longest) and
    those that waited (CPU normal: another thread or process held the interpreter lock or
    the core)."""
    over = np.flatnonzero(during[:, 0] > 2.0 * median_ms)
    cpu_med = float(np.median(during[:, 1]))
    own = [k for k in over.tolist() if during[k, 1] > 2.0 * cpu_med]
    top: dict[str, int] = {}
    for k in own:
        if k < len(systems) and systems[k]:
            name = max(systems[k], key=systems[k].get)
            top[name] = top.get(name, 0) + 1
    return {"spikes_own_cpu": len(own), "spikes_waiting": len(over) - len(own),
            "spikes_own_cpu_by_system": top}


def in_place(size, n: int, bump_m: float, seed: int) -> dict:
    """``--in-place N``: N edits made in place (``move_axis(..., wait=True)``: the builder,
    the water surface, the plan and the swap, no tile made), alternating ±``bump_m`` bumps
    of the branch in view as a drag makes them; CPU seconds (the load of a shared machine
    changes them less than wall seconds): the first one and the median of the others."""
    import riverflow as rf

    world = rf.RiverWorld(rf.default_scene(seed=seed), size=size, gl=False, seed=seed)
    world.load_view()
    _flood(world)
    world.step(1.0 / 60.0)
    link, line0, at, width = _branch_in_view(world)
    cpu, wall = [], []
    for k in range(n):
        c0, w0 = time.process_time(), time.perf_counter()
        world.move_axis(link, _bumped(line0, bump_m * (-1) ** k, at, width))
        cpu.append(time.process_time() - c0)
        wall.append(time.perf_counter() - w0)
    out = {"in_place_edits": n, "first_cpu_s": cpu[0],
           "next_cpu_s_median": float(np.median(cpu[1:])) if n > 1 else float("nan"),
           "next_wall_s_median": float(np.median(wall[1:])) if n > 1 else float("nan"),
           "marked": sum(world.edits.last["marked"].values())}
    world.close()
    return out


def remake(size, n: int, bump_m: float, seed: int) -> dict:
    """``--remake N``: the CPU seconds that remaking one edit's tiles in view costs, whatever
    the machine's load: tiles made in the frame's thread (``tile_production="blocking"``), N
    edits made in place (alternating ±``bump_m`` bumps of the branch in view), after each
    ``load_view()`` remakes every tile of the view the edit dropped
    (``time.process_time()``, one thread, KD-tree queries on one thread as in the tile
    process); per kind the tiles remade and their CPU
    (the scheduler's producers timed)."""
    import riverflow as rf
    from riverflow.components.flow_tiles import FLOW_KIND
    from riverflow.components.river import TerrainView
    from riverflow.engine.config import RiverConfig
    from riverflow.tiles.cache import tile_bytes
    from riverflow.tiles.table import codes as codes_of, tile_code

    world = rf.RiverWorld(rf.default_scene(seed=seed), size=size, gl=False, seed=seed,
                          config=RiverConfig(tile_production="blocking"))
    world.load_view()
    _flood(world)
    world.step(1.0 / 60.0)
    from riverflow.tiles import remote
    remote.IN_WORKER_PROCESS = True      # one-thread KD-tree queries, as in the tile process
    spent: dict[str, list[float]] = {}

    def timed_producers() -> None:        # an edit makes new producers: time those
        for kind, producer in world.tiles.scheduler.producers.items():
            if getattr(producer, "_bench_timed", False):
                continue
            spent.setdefault(kind, [0.0, 0, 0.0, 0])

            def timed(key, deps, _make=producer.produce, _kind=kind):
                c0 = time.process_time()
                try:
                    return _make(key, deps)
                finally:
                    used = time.process_time() - c0
                    spent[_kind][0] += used
                    spent[_kind][1] += 1
                    if _kind == FLOW_KIND or tile_code(*key) in drawn:     # a leaf of the cut
                        spent[_kind][2] += used
                        spent[_kind][3] += 1
            producer.produce, producer._bench_timed = timed, True

    # the stale tiles' data as the edit found them (blocking mode drops them at once):
    # a remade tile bit for bit the same as its stand-in need not have been remade
    scheduler = world.tiles.scheduler
    before: dict[str, dict[int, bytes]] = {}
    invalidate = scheduler.invalidate

    def kept_invalidate(stale, *args, **kwargs):
        for kind, codes in stale.items():
            pool = world.tiles.cache.pools[kind]
            for code in np.asarray(codes, np.int64).tolist():
                data = pool.get(code)
                if data is not None:
                    before.setdefault(kind, {})[code] = tile_bytes(data)
        return invalidate(stale, *args, **kwargs)
    scheduler.invalidate = kept_invalidate
    same: dict[str, int] = {}
    same_drawn: dict[str, int] = {}       # of them, the drawn ones (the cut's leaves, flow)

    link, line0, at, width = _branch_in_view(world)
    cpu = []
    drawn: set[int] = set()
    for k in range(n):
        before.clear()
        world.move_axis(link, _bumped(line0, bump_m * (-1) ** k, at, width))
        with world.active():       # the cut's leaves (what is drawn: not their ancestors)
            drawn = set(codes_of(world.resource(TerrainView).cut).tolist())
        timed_producers()
        c0 = time.process_time()
        world.load_view()
        cpu.append(time.process_time() - c0)
        for kind, old in before.items():
            pool = world.tiles.cache.pools[kind]
            for code, data in old.items():
                now = pool.get(code)
                if now is not None and tile_bytes(now) == data:
                    same[kind] = same.get(kind, 0) + 1
                    if kind == FLOW_KIND or code in drawn:
                        same_drawn[kind] = same_drawn.get(kind, 0) + 1
    out = {"remake_edits": n, "remake_cpu_s_median": float(np.median(cpu)),
           "remake_cpu_s_max": float(np.max(cpu))}
    for kind, (seconds, count, _, drawn_count) in spent.items():
        if count:
            out[f"{kind}_tiles_per_edit"] = count / n
            out[f"{kind}_drawn_per_edit"] = drawn_count / n
            out[f"{kind}_ms_per_tile"] = 1e3 * seconds / count
            out[f"{kind}_same_per_edit"] = same.get(kind, 0) / n
            out[f"{kind}_same_drawn_per_edit"] = same_drawn.get(kind, 0) / n
    out["drawn_cpu_s_per_edit"] = sum(v[2] for v in spent.values()) / n
    out["all_cpu_s_per_edit"] = sum(v[0] for v in spent.values()) / n
    world.close()
    return out



def floodplain(size, frames: int, seed: int, drawn: bool) -> dict:
    """``--floodplain N``: the frame's cost on a flooded floodplain (issue 25): the camera
    over the tributary's floodplain (35 m up, 35 m back, as tests/render/
    test_floodplain_render), N frames at 1/60 s dry, then N with the level 1 m over the bank
    top (steady: the router run ahead 6 h) after N to settle; tiles made in the frame's
    thread (``tile_production="blocking"``: the view's tiles are all made before timing).
    Per phase the frame's own thread's CPU (``time.thread_time``) and the process's
    (``time.process_time``: llvmpipe's threads too with ``--drawn``, which renders every frame
    with gl=True) median and p95 [ms], the advection and placement systems' median [ms], and
    the particles INSIDE on flooded ground beside the base banks."""
    import riverflow as rf
    from riverflow.engine.config import RiverConfig
    from riverflow.scenes.carving import Carving

    scene = rf.default_scene(seed=seed)
    world = rf.RiverWorld(scene, size=size, gl=drawn, seed=seed,
                          config=RiverConfig(tile_production="blocking"))
    line = scene.branch("tributary").centerline_m
    k = len(line) // 2
    t = line[k + 1] - line[k - 1]
    t = t / np.hypot(*t)
    normal = np.array([-t[1], t[0]])
    target = line[k] + 40.0 * normal                      # over the flooded plain
    z = float(scene.terrain.height(target[None])[0])
    eye = target - 35.0 * t
    world.camera.look_at((eye[0], eye[1], z + 35.0), (target[0], target[1], z))
    world.load_view()

    def frames_ms(n: int) -> dict:
        thread, process, systems = [], [], {"advection": [], "placement": []}
        for _ in range(n):
            c0, p0 = time.thread_time(), time.process_time()
            world.step(1.0 / 60.0)
            if drawn:
                world.render()
            thread.append(1e3 * (time.thread_time() - c0))
            process.append(1e3 * (time.process_time() - p0))
            for name in systems:
                systems[name].append(world.timings_ms.get(name, 0.0))
        out = {"thread_ms_p50": float(np.median(thread)),
               "thread_ms_p95": float(np.percentile(thread, 95)),
               "process_ms_p50": float(np.median(process)),
               "process_ms_p95": float(np.percentile(process, 95))}
        out.update({f"{name}_ms_p50": float(np.median(v)) for name, v in systems.items()})
        return out

    frames_ms(frames)                                     # particles settle
    out = {f"dry_{k}": v for k, v in frames_ms(frames).items()}
    world.set_hydrograph(None, [], None)
    router = world.flood
    ratio = router.ratio_for_rise("tributary", Carving().bank_rise_m + 1.0)
    q0 = router.base_inflow_m3s()
    now = world.flood_time_s
    world.set_hydrograph(None, [now, now + 1.0], [q0, ratio * q0])
    world.advance_flood(6 * 3600.0)
    frames_ms(frames)
    out.update({f"flooded_{k}": v for k, v in frames_ms(frames).items()})
    p = world.particles
    xy = p.world_m[:, :2]
    ground, level = router.ground(xy)
    depth = level + router.level_rise(xy) - ground
    router.ground, keep = None, router.ground
    base, _ = world.field.query(xy)
    router.ground = keep
    out["particles"] = len(p.status)
    out["inside_on_floodplain"] = int(((p.status == rf.FlowStatus.INSIDE)
                                       & (base == rf.FlowStatus.OUTSIDE) & (depth > 0.05)).sum())
    world.close()
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", type=int, nargs=2, default=(1920, 1080))
    ap.add_argument("--edits", type=int, default=10)
    ap.add_argument("--every", type=int, default=60, help="frames between edits")
    ap.add_argument("--bump", type=float, default=20.0, help="[m]")
    ap.add_argument("--warm", type=int, default=600,
                    help="frames with nothing edited (as many as the edits' by default)")
    ap.add_argument("--wait", type=float, default=30.0,
                    help="[s] longest an edit waits for its tiles in view (then NaN)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--json", default=None)
    ap.add_argument("--in-place", type=int, default=0,
                    help="only time this many edits made in place (CPU s), no frames")
    ap.add_argument("--remake", type=int, default=0,
                    help="only the CPU of remaking this many edits' tiles in view, made in "
                         "the frame's thread (tile_production='blocking')")
    ap.add_argument("--floodplain", type=int, default=0,
                    help="only the frame cost over a flooded floodplain: this many frames dry, "
                         "then flooded 1 m over the banks")
    ap.add_argument("--drawn", action="store_true",
                    help="with --floodplain: gl=True, every frame rendered (llvmpipe)")
    args = ap.parse_args()
    if args.floodplain:
        out = floodplain(tuple(args.size), args.floodplain, args.seed, args.drawn)
    elif args.remake:
        out = remake(tuple(args.size), args.remake, args.bump, args.seed)
    elif args.in_place:
        out = in_place(tuple(args.size), args.in_place, args.bump, args.seed)
    else:
        out = run(tuple(args.size), args.edits, args.every, args.bump, args.warm, args.seed,
                  args.wait)
    for k, v in out.items():
        print(f"{k:>30}: {v:.4g}" if isinstance(v, float) else f"{k:>30}: {v}")
    if args.json:
        with open(args.json, "w") as f:
            json.dump(out, f, indent=2)


if __name__ == "__main__":
    main()
