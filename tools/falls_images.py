"""Draw the falls pictures of docs/images (README "Falls, weirs and rapids").

Run: ``python tools/falls_images.py [--out docs/images]``. The built-in scene with
``falls=True``: its 6 m fall from the plunge pool (falls-below.png) and from the side
(falls-side.png); a 1.5 m weir across a 30 m river (weir.png). 480×270, advected water, after
two seconds of frames (the particles, foam and spray settled).
"""
from __future__ import annotations

import argparse
import os
from pathlib import Path

os.environ.setdefault("PYGLET_HEADLESS", "1")

import numpy as np  # noqa: E402
from PIL import Image  # noqa: E402

import riverflow as rf  # noqa: E402

SIZE = (480, 270)


def _fall_frame(f, lip):
    c, t = np.asarray(f.centre_m), np.asarray(f.direction)
    return c, t, np.array([-t[1], t[0]]), lip


def _shots(world, views, out: Path) -> None:
    for name, (eye, target) in views.items():
        world.camera.look_at(eye, target)
        for _ in range(60):
            world.step(1 / 30)
        path = out / f"{name}.png"
        Image.fromarray(world.render()[..., :3]).save(path)
        print(f"wrote {path}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("docs/images"))
    args = parser.parse_args()
    config = rf.RiverConfig(radius_px=5.0, tile_production="blocking")
    scene = rf.default_scene(seed=0, falls=True)
    (f,) = scene.graph.falls
    c, t, n, lip = _fall_frame(f, float(scene.water.level(np.asarray(f.centre_m)[None])[0]))
    pool = lip - f.drop_m
    world = rf.RiverWorld(scene, size=SIZE, gl=True, seed=0, config=config)
    _shots(world, {
        "falls-below": ((*(c + 38.0 * t - 4.0 * n), pool + 3.0),
                        (*(c + 0.5 * f.throw_m * t), pool + 0.55 * f.drop_m)),
        "falls-side": ((*(c + 22.0 * t + 16.0 * n), pool + 3.0),
                       (*(c + 0.5 * f.throw_m * t), pool + 0.45 * f.drop_m)),
    }, args.out)
    world.close()

    b = rf.RiverNetworkBuilder()
    x = np.linspace(0.0, 600.0, 61)
    b.add_branch(np.stack([x, 0.02 * (x - 300.0) ** 2 / 30.0], 1), 30.0, discharge_m2s=15.0,
                 name="river")
    b.add_fall(300.0, 1.5, kind="weir")
    weir_scene = rf.landscape(b.build(), seed=0)
    (w,) = weir_scene.graph.falls
    c, t, n, lip = _fall_frame(w, float(weir_scene.water.level(np.asarray(w.centre_m)[None])[0]))
    world = rf.RiverWorld(weir_scene, size=SIZE, gl=True, seed=0, config=config)
    _shots(world, {"weir": ((*(c + 30.0 * t - 22.0 * n), lip + 5.0), (*c, lip - 1.0))},
           args.out)
    world.close()


if __name__ == "__main__":
    main()
