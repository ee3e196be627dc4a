"""Dam break: a dam on the built-in scene's main river breaches; its reservoir's outflow jumps
from base flow to ``--factor`` times it and falls back as the reservoir empties (level-pool
routing, :func:`riverflow.hydro.flood.level_pool_release`: a ``--head`` m deep reservoir of
``--area`` m², a breach as wide as makes that peak), and the flood wave runs down the river
past the demo camera.

The dam stands at the head of the river link the demo camera looks at
(``world.set_hydrograph(link, …)`` replaces that link's inflow: the water above is held, its
release follows the hydrograph). The wave is routed by the kinematic wave
(:mod:`riverflow.hydro.flood`): it reaches the camera after its travel time; there the flow
speeds up by (Q/Q₀)^(2/5), the water level rises by the rating curve and the drawn water with
it, over its banks where the valley is lower than the level. Velocity arrows show the flow.

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
from riverflow.hydro.flood import BROAD_CRESTED_WEIR, level_pool_release  # noqa: E402
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
    scene = rf.default_scene(seed=args.seed)
    with rf.RiverWorld(scene, size=(w, h), gl=True, seed=args.seed) as world:
        world.display.show_velocities = True
        target = np.asarray(world.camera.target, np.float64)[None, :2]
        for _ in range(120):
            world.step(STEP_S)
        save_png(world.render(), out / "before.png")
        level0 = float(world.water_level(target)[0])
        v0 = float(np.hypot(*world.field.query(target)[1][0]))
        world.set_hydrograph(None, [], None)                # the flood router, no change yet
        router = world.flood
        link, s, _ = router.network.locate(target)
        link, s = int(link[0]), float(s[0])
        q0 = float(router.net.link_q0[link])
        now = world.flood_time_s
        width = args.factor * q0 / (BROAD_CRESTED_WEIR * args.head ** 1.5)
        t, q = level_pool_release(args.area, args.head, width, q0, 4 * 3600.0)
        world.set_hydrograph(link, np.concatenate([[now], now + 1.0 + t]),
                             np.concatenate([[q0], q]))                      # the dam goes
        print(f"dam on {router.network.names[link]!r}, {s:.0f} m above the camera's target; "
              f"base {q0:.1f} m³/s, breach {width:.1f} m wide: release {q[0]:.1f} m³/s, "
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
