"""Graph files are read streaming, in bounded memory, and only regular files are read
(issue #30, item 2): a 50 MB junk file stays under 200 MB RSS and raises at its first bad
token, naming the file and the byte offset; a FIFO, /dev/zero and a folder are refused at
once."""
from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
import threading
import time
from pathlib import Path

import pytest

from riverflow import GraphError, load_graph
from riverflow.hydro import io as graph_io

REPO = Path(__file__).resolve().parents[2]
MB = 1 << 20
HEADER = b"0 2 5 3 1 3 2 0 "          # ASCII basic, hydro params


def write_big(path: Path, head: bytes, filler: bytes, size: int) -> Path:
    """``head`` then ``filler`` repeated up to ``size`` bytes."""
    block = filler * (MB // len(filler) + 1)
    with open(path, "wb") as f:
        f.write(head)
        left = size - len(head)
        while left > 0:
            f.write(block[:min(left, MB)])
            left -= min(left, MB)
    return path


def load_in_fresh_process(path: Path) -> dict:
    """load_graph(path) in a new interpreter: its error, peak RSS [MB] and seconds."""
    code = textwrap.dedent(f"""
        import json, time
        from riverflow import GraphError, load_graph

        def peak_mb():  # this process's own peak (ru_maxrss would count the forking parent's)
            for line in open("/proc/self/status"):
                if line.startswith("VmHWM:"):
                    return int(line.split()[1]) / 1024

        t = time.perf_counter()
        try:
            load_graph({str(path)!r}); error = None
        except GraphError as exc:
            error = str(exc)
        print(json.dumps({{"error": error, "seconds": time.perf_counter() - t,
                          "rss_mb": peak_mb()}}))
    """)
    env = dict(os.environ, PYTHONPATH=str(REPO))
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True,
                         timeout=120, check=True).stdout
    return json.loads(out.strip().splitlines()[-1])


@pytest.mark.parametrize("case, head, filler, fragment", [
    # junk right after the header: the first bad token is the node count
    ("junk count", HEADER, b"junk ", "byte 16 (token 8)"),
    # a plausible node count: the rest of the file is counted (streaming) to check it, then
    # the first node's x is junk
    ("junk after a count", HEADER + b"1000 ", b"x7 ", "byte 21 (token 9)"),
    # one 50 MB token: refused at its start, not read whole
    ("no whitespace", HEADER, b"9", "byte 16 (token 8)"),
])
def test_a_50_mb_junk_file_stays_bounded_and_names_the_first_bad_token(
        tmp_path, case, head, filler, fragment):
    path = write_big(tmp_path / "junk.graph", head, filler, 50 * MB)
    result = load_in_fresh_process(path)
    assert result["error"] is not None and str(path) in result["error"], result
    assert fragment in result["error"], result
    assert result["rss_mb"] < 200, result


def test_the_first_bad_token_is_found_in_a_long_valid_run(tmp_path):
    """Many good nodes, then junk: the error names the junk token's exact byte offset."""
    node = b"1.5 -2.25 0 "
    n = 50_000
    head = HEADER + b"%d " % (n + 5)
    body = node * n
    bad_at = len(head) + len(body)
    path = tmp_path / "long.graph"
    path.write_bytes(head + body + b"1.0 nope 0 " + node * 10)
    with pytest.raises(GraphError) as info:
        load_graph(path)
    msg = str(info.value)
    assert f"byte {bad_at + 4} (token {9 + 3 * n + 1})" in msg, msg
    assert "y of node 50000" in msg and "'nope'" in msg


def test_tokens_crossing_read_chunks_are_read_whole(tmp_path, monkeypatch):
    """Tiny chunks: every token crosses a chunk boundary somewhere; the graph is the same."""
    from tests.hydro.test_io import channel_graph

    path = tmp_path / "g.graph"
    graph_io.save_graph(channel_graph(), path)
    graph_io.save_graph(channel_graph(), tmp_path / "i.graph", indexed=True)
    whole = load_graph(path)
    indexed = load_graph(tmp_path / "i.graph")
    monkeypatch.setattr(graph_io, "_CHUNK", 3)
    assert load_graph(path) == whole
    assert load_graph(tmp_path / "i.graph") == indexed == whole


def test_a_fifo_is_refused_at_once(tmp_path):
    fifo = tmp_path / "pipe.graph"
    os.mkfifo(fifo)
    done: list[BaseException | None] = []

    def load():
        try:
            load_graph(fifo)
            done.append(None)
        except BaseException as exc:  # noqa: BLE001 (reported below)
            done.append(exc)

    thread = threading.Thread(target=load, daemon=True)
    started = time.perf_counter()
    thread.start()
    thread.join(10.0)
    if thread.is_alive():              # unblock it before failing: open the writing end
        os.close(os.open(fifo, os.O_WRONLY | os.O_NONBLOCK))
        pytest.fail("load_graph blocked on a FIFO")
    assert time.perf_counter() - started < 5.0
    assert isinstance(done[0], GraphError) and "FIFO" in str(done[0]), done
    assert str(fifo) in str(done[0])


@pytest.mark.parametrize("path, kind", [("/dev/zero", "character device"), (None, "folder")])
def test_devices_and_folders_are_refused_at_once(tmp_path, path, kind):
    path = Path(path) if path else tmp_path
    if not path.exists():
        pytest.skip(f"{path} is absent here")
    started = time.perf_counter()
    with pytest.raises(GraphError, match=kind) as info:
        load_graph(path)
    assert str(path) in str(info.value)
    assert time.perf_counter() - started < 1.0


def test_a_missing_file_is_still_an_os_error(tmp_path):
    with pytest.raises(FileNotFoundError):
        load_graph(tmp_path / "nothing.graph")
