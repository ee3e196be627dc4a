"""Check (issue 26): a Dask worker process killed mid-bake loses no tiles.

Bakes a small river at zooms 15-18 on one worker (the reference), then on a Dask LocalCluster of
two processes, SIGKILLs one worker 4 s in, and compares the pyramids byte for byte. Needs
riverflow[cluster] and riverflow[gis]; about 30 s. Not in the test suite (a cluster of
processes costs more than the suite can spend): run ``python tools/check_dask_kill.py``.
Prints ``identical: True`` when no tile was lost.
"""
import os
import shutil
import signal
import sys
import tempfile
import threading
import time
from pathlib import Path
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))   # the repository: tests.gis


def main():
    import numpy as np
    import riverflow as rf
    from riverflow.gis import tiles as T
    from tests.gis.conftest import polyline, write_lines
    import dask.distributed as dd
    d = Path(tempfile.mkdtemp(prefix="dask-kill-"))
    lines = [polyline((-300, 150), (-100, 60), (0, 0)), polyline((-300, -120), (0, 0)),
             polyline((0, 0), (150, -40), (300, 0))]
    net = write_lines(d / "river.gpkg", lines, {"W": np.array([24.0, 18.0, 36.0])})
    graph = rf.read_rivers(net, origin_m=None, width_m="W").build()
    field = rf.FlowField(graph)
    ref = rf.bake_tiles(field, d / "ref", (15, 18))
    print("reference", ref.written, "tiles", flush=True)
    T.BLOCK = 2
    cluster = dd.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                              dashboard_address=None)
    client = dd.Client(cluster)

    def killer():
        time.sleep(4.0)
        addr = sorted(client.scheduler_info()["workers"])[0]
        pid = client.run(os.getpid, workers=[addr])[addr]
        os.kill(pid, signal.SIGKILL)
        print("killed worker pid", pid, flush=True)
    threading.Thread(target=killer, daemon=True).start()
    t = time.perf_counter()
    got = rf.bake_tiles(field, d / "got", (15, 18), scheduler=client)
    print("baked", got.written, "in", round(time.perf_counter() - t, 1), "s", flush=True)
    files = lambda f: {p.relative_to(f).as_posix(): p.read_bytes() for p in sorted(f.rglob("*")) if p.is_file()}
    same = files(d / "ref") == files(d / "got")
    print("identical:", same, flush=True)
    client.close()
    cluster.close()
    shutil.rmtree(d, ignore_errors=True)
    return 0 if same else 1


if __name__ == "__main__":
    raise SystemExit(main())
