"""Compare the graphs two versions of the code build from the same GIS data (a check that a
speed-up keeps the output): ``dump OUT.pkl`` builds Red Butte (../shared/data/gis/redbutte)
and the bench_gis network (``--copies N``, default 1) and keeps nodes, curves, areas and the
water polygon; ``compare A.pkl B.pkl`` says whether they are byte for byte the same and, if
not, how far the water outline, the banks (all together and curve by curve; Hausdorff distances
between vertices) and ψ moved.

Run the dump once per version (``PYTHONPATH=<checkout>`` picks it), then compare:
``python benchmarks/compare_gis_build.py dump /tmp/a.pkl`` ... ``compare /tmp/a.pkl /tmp/b.pkl``.
"""
from __future__ import annotations

import argparse
import pickle
import sys
import tempfile
from pathlib import Path

import numpy as np
import shapely

REDBUTTE = Path(__file__).resolve().parents[2] / "shared" / "data" / "gis" / "redbutte" / "a001_network.shp"


def _bench_builder(copies: int):
    import pyogrio.raw

    import riverflow as rf
    sys.path.insert(0, str(Path(__file__).parent))
    import bench_gis as bg
    one, areas = bg.network(200.0, 4.0, 12.0, 4.0)
    span = 2.0 * (12.0 + 4.0) * 1000.0 + 5000.0
    lines = [p + (0.0, k * span) for k in range(copies) for p in one]
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "network.gpkg"
        geoms = np.array([shapely.to_wkb(shapely.LineString(p + bg.ORIGIN)) for p in lines], dtype=object)
        pyogrio.raw.write(str(path), geoms, [np.tile(areas, copies)], ["area_km2"], driver="GPKG",
                          crs=bg.UTM, geometry_type="LineString")
        return rf.read_rivers(path, drainage_area_km2="area_km2")


def _dump(builder) -> dict:
    graph = builder.build()
    return {"nodes": graph.nodes,
            "curves": [(c.start, c.end, c.points, int(c.type), c.potential) for c in graph.curves],
            "areas": [(a.curves, a.info, a.parent) for a in graph.areas],
            "water": shapely.to_wkb(builder.water_polygon)}


def dump(out: Path, copies: int, redbutte: Path) -> None:
    import riverflow as rf
    res = {"bench": _dump(_bench_builder(copies))}
    if redbutte.exists():
        res["redbutte"] = _dump(rf.read_rivers(redbutte))
    out.write_bytes(pickle.dumps(res))


def compare(a_path: Path, b_path: Path) -> None:
    a, b = pickle.loads(a_path.read_bytes()), pickle.loads(b_path.read_bytes())
    for key in sorted(set(a) & set(b)):
        A, B = a[key], b[key]
        wa, wb = shapely.from_wkb(A["water"]), shapely.from_wkb(B["water"])
        print(f"{key}: water byte for byte {A['water'] == B['water']}, outline Hausdorff "
              f"{shapely.hausdorff_distance(wa.boundary, wb.boundary):.4f} m, symmetric difference "
              f"{shapely.symmetric_difference(wa, wb).area:.3f} m²")
        same = (len(A["curves"]) == len(B["curves"]) and len(A["nodes"]) == len(B["nodes"])
                and A["areas"] == B["areas"]
                and all(ca[:2] == cb[:2] and ca[3] == cb[3] for ca, cb in zip(A["curves"], B["curves"])))
        print(f"  {len(A['nodes'])} / {len(B['nodes'])} nodes, {len(A['curves'])} / {len(B['curves'])} "
              f"curves, same topology {same}")
        if not same:
            continue
        def banks(D):
            return shapely.union_all([shapely.LineString(c[2]) for c in D["curves"]
                                      if c[3] == 2 and len(c[2]) > 1])
        moves = [shapely.hausdorff_distance(shapely.LineString(ca[2]), shapely.LineString(cb[2]))
                 for ca, cb in zip(A["curves"], B["curves"])
                 if not (ca[2].shape == cb[2].shape and np.array_equal(ca[2], cb[2]))
                 and len(ca[2]) > 1 and len(cb[2]) > 1]
        psi_a = np.array([c[4] for c in A["curves"]])
        psi_b = np.array([c[4] for c in B["curves"]])
        print(f"  curves byte for byte {not moves}, all banks together Hausdorff "
              f"{shapely.hausdorff_distance(banks(A), banks(B)):.4f} m, largest move of "
              f"one curve {max(moves, default=0.0):.4f} m, ψ equal {np.array_equal(psi_a, psi_b, equal_nan=True)}")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = parser.add_subparsers(dest="cmd", required=True)
    d = sub.add_parser("dump")
    d.add_argument("out", type=Path)
    d.add_argument("--copies", type=int, default=1)
    d.add_argument("--redbutte", type=Path, default=REDBUTTE)
    c = sub.add_parser("compare")
    c.add_argument("a", type=Path)
    c.add_argument("b", type=Path)
    args = parser.parse_args(argv)
    if args.cmd == "dump":
        dump(args.out, args.copies, args.redbutte)
    else:
        compare(args.a, args.b)
    return 0


if __name__ == "__main__":
    sys.exit(main())
