"""Draw docs/images/water-areas-basins.jpg (docs/gis.md "Basins").

Run: ``python tools/basins_image.py [--out docs/images]``. The river polygon of
``tests/gis/test_water_basins.py`` (a straight 60 m river with a square basin, an L-shaped
dock and a marina) read with ``rf.read_water``: the running flow field's speed on a 1 m grid
(white where it is not INSIDE), its streamlines, the polygon's outline (black) and the basins'
mouths (dashed red). Needs matplotlib.
"""
from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

import riverflow as rf  # noqa: E402


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=REPO / "docs" / "images")
    args = parser.parse_args()
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from PIL import Image

    from tests.gis.conftest import ORIGIN
    from tests.gis.test_water import write_polygons
    from tests.gis.test_water_basins import harbour_river

    water, _ = harbour_river()
    with tempfile.TemporaryDirectory() as tmp:
        builder = rf.read_water(write_polygons(Path(tmp) / "harbour.geojson", [water]),
                                origin_m=ORIGIN)
        field = rf.FlowField(builder.build())
    x0, y0, x1, y1 = 70.0, 215.0, 530.0, 410.0
    gx, gy = np.meshgrid(np.arange(x0, x1, 1.0), np.arange(y0, y1, 1.0))
    status, v = field.query(np.c_[gx.ravel(), gy.ravel()])
    inside = (status == rf.FlowStatus.INSIDE).reshape(gx.shape)
    vx = np.where(inside, v[:, 0].reshape(gx.shape), np.nan)
    vy = np.where(inside, v[:, 1].reshape(gx.shape), np.nan)
    speed = np.hypot(vx, vy)

    fig, ax = plt.subplots(figsize=(9.0, 4.6), dpi=100)
    im = ax.imshow(np.ma.masked_invalid(speed), origin="lower", extent=(x0, x1, y0, y1),
                   cmap="viridis", vmin=0.0, vmax=0.9, interpolation="nearest")
    ax.streamplot(gx, gy, np.nan_to_num(vx), np.nan_to_num(vy), color="white", density=1.6,
                  linewidth=0.6, arrowsize=0.6)
    for ring in [water.exterior, *water.interiors]:
        ax.plot(*np.asarray(ring.coords).T, color="black", linewidth=0.8)
    for b in builder.basins:
        ax.plot(*b.mouth.T, color="red", linewidth=1.6, linestyle="--")
    ax.set_xlim(x0, x1)
    ax.set_ylim(y0, y1)
    ax.set_aspect("equal")
    ax.set_title("riverflow: a square basin, an L-shaped dock and a marina off a 60 m river "
                 "(mouths dashed red)", fontsize=8)
    fig.colorbar(im, ax=ax, label="speed [m/s]", shrink=0.9)
    png = Path(tempfile.mkdtemp()) / "basins.png"
    fig.savefig(png)
    plt.close(fig)
    args.out.mkdir(parents=True, exist_ok=True)
    out = args.out / "water-areas-basins.jpg"
    Image.open(png).convert("RGB").save(out, quality=88)
    print(out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
