"""Draw the reflection pictures of docs/images (reflections on | off, side by side).

Run: ``python tools/reflection_images.py [--out docs/images]``. A low camera on the built-in
river looks across at the boat near the far bank, 640x360 each half, advected water.
"""
from __future__ import annotations

import argparse
import os
from pathlib import Path

os.environ.setdefault("PYGLET_HEADLESS", "1")

import numpy as np  # noqa: E402

import riverflow as rf  # noqa: E402
from riverflow.scenes.flight import main_centerline  # noqa: E402

SIZE = (640, 360)


def _shore(water, p: np.ndarray, side: np.ndarray) -> float:
    """Distance from p along side to the water's edge [m]."""
    t = 0.0
    while water.contains((p + (t + 0.5) * side)[None])[0]:
        t += 0.5
    return t


def views(scene) -> dict[str, tuple]:
    """name → (eye, target, boat xy, boat heading) for the pictures."""
    water = scene.water
    line = main_centerline(scene)
    out = {}
    for name, at, from_bank, back, height in (("reflections-boat", 0.45, 10.0, 22.0, 1.4),
                                              ("reflections-bank", 0.62, 14.0, 60.0, 2.5)):
        k = int(at * (len(line) - 4))
        p = line[k]
        d = (line[k + 3] - p) / np.linalg.norm(line[k + 3] - p)
        side = np.array([-d[1], d[0]])
        edge = p + _shore(water, p, side) * side
        boat = edge - from_bank * side
        level = float(water.level(boat[None])[0])
        eye_xy = boat - back * side - 0.35 * back * d
        eye = (*eye_xy, level + height)
        target = (*(boat + 6.0 * side), level + 1.0)
        out[name] = (eye, target, boat, float(np.arctan2(d[1], d[0])))
    return out


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--out", type=Path, default=Path("docs/images"))
    parser.add_argument("--distortion", type=float, default=None,
                        help="DisplaySettings.reflection_distortion (default: its default)")
    args = parser.parse_args(argv)
    from PIL import Image, ImageDraw
    scene = rf.default_scene(seed=0)
    args.out.mkdir(parents=True, exist_ok=True)
    for name, (eye, target, boat_xy, heading) in views(scene).items():
        world = rf.RiverWorld(scene, size=SIZE, gl=True, seed=0,
                              config=rf.RiverConfig(tile_production="blocking"))
        world.add_boat(boat_xy, heading_rad=heading)
        if args.distortion is not None:
            world.display.reflection_distortion = args.distortion
        world.camera.look_at(eye, target)
        world.load_view()
        for _ in range(90):
            world.step(1 / 60)
        halves = []
        for on in (True, False):
            world.display.reflections = on
            halves.append(Image.fromarray(world.render()).convert("RGB"))
        world.close()
        both = Image.new("RGB", (2 * SIZE[0], SIZE[1]))
        for i, (half, label) in enumerate(zip(halves, ("reflections on", "reflections off"))):
            both.paste(half, (i * SIZE[0], 0))
            ImageDraw.Draw(both).text((i * SIZE[0] + 8, 6), label, fill=(255, 255, 255))
        path = args.out / f"{name}.png"
        both.save(path, optimize=True)
        print(f"wrote {path}")


if __name__ == "__main__":
    main()
