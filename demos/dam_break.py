"""Dam break: the built-in scene with a reservoir on its main river
(``rf.default_scene(dam=True)``) whose dam breaches: the outflow jumps from base flow to
``--factor`` times it and falls back as the reservoir empties (level-pool routing,
:func:`riverflow.hydro.flood.level_pool_release`: a ``--head`` m deep reservoir of ``--area``
m², a breach as wide as makes that peak), and the flood wave runs down the river.

The release is the hydrograph of the link that leaves the reservoir
(:data:`riverflow.scenes.default.DAM_OUTLET`, :func:`riverflow.demo.release_dam`): it starts
at the dam, not upstream of the lake. The wave is routed by the kinematic wave
(:mod:`riverflow.hydro.flood`); where the camera looks, below the dam, the flow speeds up by
(Q/Q₀)^(2/5), the water level rises by the rating curve and the drawn water with it, over its
banks where the valley is lower than the level. Velocity arrows show the flow.
``riverflow demo --dam`` plays it with the boat.

    python demos/dam_break.py --out /tmp/dam        # before.png, after.png and the numbers
"""
from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

os.environ.setdefault("PYGLET_HEADLESS", "1")

import numpy as np  # noqa: E402

import riverflow as rf  # noqa: E402
from riverflow.demo import release_dam  # noqa: E402
from riverflow.scenes.default import DAM_OUTLET  # noqa: E402
from riverflow.images import save_png  # noqa: E402

STEP_S = 1.0 / 60.0


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="out/dam_break")
    ap.add_argument("--size", default="640x360")
    ap.add_argument("--factor", type=float, default=8.0, help="peak release / base flow")
    ap.add_argument("--head", type=float, default=6.0, help="reservoir depth over the breach [m]")
    ap.add_argument("--area", type=float, default=4e5, help="reservoir surface [m²]")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args(argv)
    w, h = (int(v) for v in args.size.split("x"))
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    scene = rf.default_scene(seed=args.seed, dam=True)
    below = scene.branch(DAM_OUTLET).centerline_m
    with rf.RiverWorld(scene, size=(w, h), gl=True, seed=args.seed) as world:
        world.display.show_velocities = True
        target = below[int(0.35 * (len(below) - 1))][None, :]        # below the dam
        look = below[0] - below[-1]
        look = look / np.hypot(*look)
        z = float(world.water_level(target)[0])
        eye = target[0] - 420.0 * look + 260.0 * np.array([-look[1], look[0]])
        world.camera.look_at((*eye, z + 260.0), (*(target[0] + 150.0 * look), z))
        for _ in range(120):
            world.step(STEP_S)
        save_png(world.render(), out / "before.png")
        level0 = float(world.water_level(target)[0])
        v0 = float(np.hypot(*world.field.query(target)[1][0]))
        link, t, q = release_dam(world, factor=args.factor, head_m=args.head,
                                 area_m2=args.area)                    # the dam goes
        router = world.flood
        q0 = float(q[0])
        print(f"dam at the head of {link!r}: base {q0:.1f} m³/s, release {q[1]:.1f} m³/s, "
              f"{q[len(q) // 4]:.1f} m³/s an hour later")
        max_q = 0.0
        for minute in range(1, 241):
            world.advance_flood(60.0)
            rise = float(world.water_level(target)[0]) - level0
            if minute % 5 == 0 or rise > 0.01:
                print(f"  {minute:3d} min: Q {float(router.discharge(target)[0]):7.1f} m³/s, "
                      f"level +{rise:.2f} m")
            q_now = float(router.discharge(target)[0])
            if max_q > 1.5 * q0 and q_now < 0.99 * max_q:
                break                                             # just past the peak
            max_q = max(max_q, q_now)
        for _ in range(120):
            world.step(STEP_S)
        save_png(world.render(), out / "after.png")
        v1 = float(np.hypot(*world.field.query(target)[1][0]))
        print(f"at the camera's target: speed {v0:.2f} → {v1:.2f} m/s, level "
              f"{level0:.2f} → {float(world.water_level(target)[0]):.2f} m")
    print(f"pictures in {out}/")
    return 0


if __name__ == "__main__":
    sys.exit(main())
