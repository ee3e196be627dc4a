"""Live edit: the river the demo camera looks at bends 25 m aside while the world runs.

The branch nearest the view's centre gets a smooth bump of its centre line (as the demo's
edit mode, key X, makes with the mouse: ``world.move_axis``); the frames go on while the tiles
within reach are made again, and the picture after is taken once the view's new tiles are in.
Velocity arrows show the flow.

    python demos/live_edit.py --out /tmp/edit      # before.png, after.png, before-after.png
"""
from __future__ import annotations

import argparse
import os
from pathlib import Path

os.environ.setdefault("PYGLET_HEADLESS", "1")

import numpy as np  # noqa: E402

import riverflow as rf  # noqa: E402
from riverflow.images import save_png  # noqa: E402

STEP_S = 1.0 / 60.0


def bumped(line: np.ndarray, shift_m: float, at_m: float, width_m: float) -> np.ndarray:
    """``line`` with a Gaussian bump of ``shift_m`` [m] sideways at ``at_m`` along it."""
    arc = np.r_[0.0, np.cumsum(np.hypot(*np.diff(line, axis=0).T))]
    weight = np.exp(-((arc - at_m) / width_m) ** 2)
    weight[[0, -1]] = 0.0
    d = np.gradient(line, axis=0)
    normal = np.c_[-d[:, 1], d[:, 0]] / np.maximum(np.hypot(*d.T), 1e-9)[:, None]
    return line + (shift_m * weight)[:, None] * normal


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="out/live_edit")
    ap.add_argument("--size", default="640x360")
    ap.add_argument("--shift", type=float, default=25.0, help="[m]")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args(argv)
    w, h = (int(v) for v in args.size.split("x"))
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    world = rf.RiverWorld(rf.default_scene(seed=args.seed), size=(w, h), gl=True,
                          seed=args.seed)
    try:
        world.display.show_velocities = True
        world.load_view()
        for _ in range(60):
            world.step(STEP_S)
        before = world.render()
        target = np.asarray(world.camera.target[:2])
        near = [float(np.hypot(*(b.centerline_m - target).T).min())
                for b in world.scene.branches]
        branch = world.scene.branches[int(np.argmin(near))]
        line = branch.centerline_m
        arc = np.r_[0.0, np.cumsum(np.hypot(*np.diff(line, axis=0).T))]
        at = float(arc[int(np.argmin(np.hypot(*(line - target).T)))])
        world.move_axis(branch.name, bumped(line, args.shift, at, 3.0 * np.median(branch.widths_m)))
        frames = 0
        sched = world.tiles.scheduler
        while frames < 1200 and (frames < 60 or any(sched.stale(k, wanted=True)
                                                    for k in sched.producers)):
            world.step(STEP_S)
            sched.wait(1.0)
            frames += 1
        for _ in range(60):
            world.step(STEP_S)
        after = world.render()
        save_png(before, out / "before.png")
        save_png(after, out / "after.png")
        gap = np.full((h, 8, 4), 255, np.uint8)
        save_png(np.concatenate([before, gap, after], axis=1), out / "before-after.png")
        print(f"{branch.name}: {args.shift:g} m aside at {at:.0f} m along it; "
              f"{sum(world.edits.last['marked'].values())} tiles made again; new tiles in "
              f"view after {frames} frames; {len(world.particles)} particles")
    finally:
        world.close()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
