"""Tests of riverflow.hydro.io: the four Proland graph variants, exact round trips, and a
located GraphError for every malformed file (reference §1.3-1.7)."""
from __future__ import annotations

import struct
from pathlib import Path

import numpy as np
import pytest

from riverflow.hydro.graph import NO_CURVE, NO_POTENTIAL, Area, Curve, CurveType, GraphError, HydroGraph
from riverflow.hydro.io import load_graph, save_graph

VARIANTS = [
    pytest.param(False, False, id="ascii-basic"),
    pytest.param(False, True, id="ascii-indexed"),
    pytest.param(True, False, id="binary-basic"),
    pytest.param(True, True, id="binary-indexed"),
]


# -- helpers ----------------------------------------------------------------------------------

def channel_graph() -> HydroGraph:
    """A tiny-channel-like graph built in code: banks first, axis last (forward river links),
    Bézier control vertices, awkward floats, and a nested subgraph two levels deep."""
    nodes = [(0.1, 0.2 + 0.1), (100.0, 1e-7), (0.0, -10.0), (100.0, -10.0), (100.0, 10.0),
             (0.0, 10.0), (1 / 3, 2 / 3)]
    curves = [
        Curve(2, 3, [(25.0, -12.0), (50.0, -9.5), (75.0, -12.5)], [True, False, True],
              24.0, CurveType.BANK, 100.0, 5, parent=7),
        Curve(3, 4, width_m=0.0, type=CurveType.CLOSING_SEGMENT),
        Curve(4, 5, [(60.0, 11.0), (40.0, 9.0), (np.pi, 10.0)], [True, True, False],
              24.0, CurveType.BANK, 0.0, 5),
        Curve(5, 2, width_m=0.0, type=CurveType.CLOSING_SEGMENT),
        Curve(6, 6, [(1.0, 1.0), (1.0, 0.5)], [False, False], 0.0, CurveType.BANK, 50.0),
        Curve(0, 1, [(50.0, 0.123456789012345)], [False], 24.0, CurveType.AXIS),
    ]
    inner = HydroGraph(np.array([[0.0, 0.0], [1.0, 1.5]]),
                       [Curve(0, 1, width_m=2.5, type=CurveType.AXIS)],
                       [Area([(0, 0)], info=-3)])
    mid = HydroGraph(np.array([[5.0, 5.0], [6.0, 7.25]]),
                     [Curve(1, 0, [(5.5, 6.5)], [True], 1.0, CurveType.CLOSING_SEGMENT)],
                     [Area([(0, 1)], info=9, subgraph=inner), Area([(0, 0)], parent=4)])
    areas = [Area([(0, 0), (1, 0), (2, 0), (3, 0)], info=26139, subgraph=mid),
             Area([(4, 1)], info=-7, parent=2)]
    return HydroGraph(np.array(nodes), curves, areas)


def rounded_f32(g: HydroGraph) -> HydroGraph:
    """``g`` with every float rounded to float32, as a binary file stores it."""
    def f(x):
        return np.asarray(x, dtype=np.float32).astype(np.float64)

    curves = [Curve(c.start, c.end, f(c.points), c.is_control, float(f(c.width_m)), c.type,
                    float(f(c.potential)), c.river, c.parent) for c in g.curves]
    areas = [Area(a.curves, a.info, a.parent, None if a.subgraph is None else rounded_f32(a.subgraph))
             for a in g.areas]
    return HydroGraph(f(g.nodes), curves, areas)


def tokens(path: Path) -> list[str]:
    return path.read_text().split()


def write_tokens(path: Path, toks: list[str]) -> Path:
    path.write_text(" ".join(toks) + "\n")
    return path


def expect_error(path: Path, *fragments: str, binary: bool = False) -> str:
    with pytest.raises(GraphError) as info:
        load_graph(path)
    msg = str(info.value)
    assert path.name in msg and "byte " in msg, msg
    if not binary and "empty file" not in msg and "magic" not in msg:
        assert "(token " in msg, msg
    for frag in fragments:
        assert frag in msg, msg
    return msg


# -- the real files ---------------------------------------------------------------------------

def test_load_proland_example(proland_graph_path):
    g = load_graph(proland_graph_path)
    assert g.source == str(proland_graph_path)
    assert (len(g.nodes), len(g.curves), len(g.areas)) == (21, 20, 2)
    assert g.nodes[0].tolist() == [-337.186, 362.438]
    table = {  # curve: (size, width, type, potential, river)   reference §1.7
        0: (9, 70, 1, -1, -1), 1: (5, 60, 1, -1, -1), 2: (5, 60, 1, -1, -1),
        3: (3, 60, 1, -1, -1), 4: (5, 60, 1, -1, -1), 9: (8, 0, 2, 50, -1),
        10: (30, 70, 2, 100, 0), 19: (39, 70, 2, 0, 0), 17: (13, 60, 2, 100, 3),
        14: (13, 60, 2, 50, 3), 13: (24, 60, 2, 50, 4), 18: (27, 60, 2, 0, 4),
        15: (18, 60, 2, 100, 1), 11: (18, 60, 2, 75, 1), 16: (12, 60, 2, 75, 2),
        12: (12, 60, 2, 50, 2),
    }
    for i in range(5, 9):
        table[i] = (2, 0, 1, -1, -1)
    assert sorted(table) == list(range(20))
    for i, (size, width, ctype, psi, river) in table.items():
        c = g.curves[i]
        assert (len(c.points) + 2, c.width_m, int(c.type), c.potential, c.river) == \
            (size, width, ctype, psi, river), i
    ends = {0: (0, 4), 1: (2, 1), 2: (2, 5), 3: (4, 2), 4: (4, 3), 9: (20, 20), 10: (7, 11),
            19: (18, 9)}
    for i, (s, e) in ends.items():
        assert (g.curves[i].start, g.curves[i].end) == (s, e)
    assert np.allclose(g.nodes[4], [32.140, 21.427])
    assert not g.curves[9].is_control.any()  # island: 6 regular intermediate vertices
    assert g.curves[0].is_control.tolist() == [True, False, True, True, False, True, True]
    assert g.curves[3].is_control.tolist() == [True]
    assert all(c.parent == NO_CURVE for c in g.curves)
    a0, a1 = g.areas
    assert len(a0.curves) == 14 and a0.info == 26139 and a1.info == 7967
    assert {c for c, _ in a0.curves} == set(range(5, 9)) | set(range(10, 20))
    assert all(o == (0 if c == 5 else 1) for c, o in a0.curves)
    assert a1.curves == [(9, 0)]
    assert a0.subgraph is None and a1.subgraph is None and a0.parent == -1


def test_load_tiny_channel(tiny_channel_path):
    g = load_graph(tiny_channel_path)
    assert (len(g.nodes), len(g.curves), len(g.areas)) == (6, 5, 1)
    assert g.nodes.tolist() == [[0, 0], [100, 0], [0, -10], [100, -10], [100, 10], [0, 10]]
    expect = [(0, 1, 24, 1, -1, -1), (2, 3, 24, 2, 100, 0), (3, 4, 0, 1, -1, -1),
              (4, 5, 24, 2, 0, 0), (5, 2, 0, 1, -1, -1)]
    assert [(c.start, c.end, c.width_m, int(c.type), c.potential, c.river) for c in g.curves] == expect
    assert all(len(c.points) == 0 for c in g.curves)
    assert g.areas == [Area([(1, 0), (2, 0), (3, 0), (4, 0)], info=0, parent=-1)]


# -- round trips ------------------------------------------------------------------------------

@pytest.mark.parametrize("binary, indexed", VARIANTS)
@pytest.mark.parametrize("which", ["proland", "tiny", "synthetic"])
def test_round_trip(which, binary, indexed, tmp_path, request):
    if which == "synthetic":
        g = channel_graph()
    else:
        fixture = "proland_graph_path" if which == "proland" else "tiny_channel_path"
        g = load_graph(request.getfixturevalue(fixture))
    p, q, r = tmp_path / "variant.graph", tmp_path / "a.graph", tmp_path / "b.graph"
    save_graph(g, p, binary=binary, indexed=indexed)
    g1 = load_graph(p)
    assert g1 == (rounded_f32(g) if binary else g)
    save_graph(g1, q)
    g2 = load_graph(q)
    assert g2 == g1
    save_graph(g2, r)
    assert q.read_bytes() == r.read_bytes()
    save_graph(g2, r, binary=binary, indexed=indexed)
    assert r.read_bytes() == p.read_bytes()  # writing is deterministic


def test_ascii_basic_is_proland_layout(tiny_channel_path, tmp_path):
    g = load_graph(tiny_channel_path)
    p = tmp_path / "t.graph"
    save_graph(g, p)
    assert tokens(p)[:8] == ["0", "2", "5", "3", "1", "3", "2", "0"]
    assert len(tokens(p)) == len(tokens(tiny_channel_path)) == 101  # 100 after the magic
    assert [float(a) for a in tokens(p)] == [float(b) for b in tokens(tiny_channel_path)]


def test_indexed_layouts(tiny_channel_path, tmp_path):
    g = load_graph(tiny_channel_path)
    p = tmp_path / "ai.graph"
    save_graph(g, p, indexed=True)
    data = p.read_bytes()
    assert data.startswith(b"1 2 5 3 1 3 2 0 ")
    field = data[16:26]  # the patchable 10-character offset field
    assert len(field.strip()) < 10 and data[26:27].isspace()
    at = int(field)
    assert data[at:].split()[:4] == [b"6", b"5", b"1", b"0"]
    # Proland writes a single line: newlines -> spaces keeps every offset valid
    p.write_bytes(data.replace(b"\n", b" "))
    assert load_graph(p) == g
    save_graph(g, p, binary=True, indexed=True)
    data = p.read_bytes()
    assert struct.unpack_from("<8i", data) == (1, 2, 5, 3, 1, 3, 2, 0)
    at = struct.unpack_from("<q", data, 32)[0]
    assert struct.unpack_from("<4i", data, at) == (6, 5, 1, 0)
    offsets = struct.unpack_from("<12q", data, at + 16)
    assert offsets[0] == 40 and struct.unpack_from("<2f", data, offsets[1]) == (100.0, 0.0)
    assert len(data) == at + 16 + 12 * 8


def test_extra_parameters_are_skipped(tmp_path):
    """nParams* larger than the defaults: extra values are skipped once per element."""
    g = channel_graph()
    g.areas[0].subgraph = None
    toks = ["0", "3", "7", "5", "2", "5", "4", "1", str(len(g.nodes))]
    for (x, y), inc in zip(g.nodes, g.incident_curves()):
        toks += [repr(float(x)), repr(float(y)), "9.5", str(len(inc)), *map(str, inc)]
    toks.append(str(len(g.curves)))
    for c in g.curves:
        toks += [str(len(c.points) + 2), repr(c.width_m), str(int(c.type)), repr(c.potential),
                 str(c.river), "-8", "-9", str(c.start), "1e3"]
        for (x, y), k in zip(c.points, c.is_control):
            toks += [repr(float(x)), repr(float(y)), str(int(k)), "7", "7.5"]
        toks += [str(c.end), "2", "-1", "-1", str(c.parent)]
    toks.append(str(len(g.areas)))
    for a in g.areas:
        toks += [str(len(a.curves)), str(a.info), "0", "11", "12"]
        for c, o in a.curves:
            toks += [str(c), str(o), "13", "14"]
        toks += ["15", str(a.parent)]
    assert load_graph(write_tokens(tmp_path / "x.graph", toks)) == g


def test_basic_graph_without_potentials(tmp_path):
    toks = "0 2 3 3 1 3 2 0 2 0 0 1 0 5 5 1 0 1 2 4.5 0 0 1 -1 -1 -1 1 1 7 0 0 0 -1".split()
    g = load_graph(write_tokens(tmp_path / "basic.graph", toks))
    (c,) = g.curves
    assert (c.type, c.width_m, c.potential, c.river) == (CurveType.AXIS, 4.5, NO_POTENTIAL, NO_CURVE)
    toks[20] = "2"  # a BANK in a file without potentials
    expect_error(write_tokens(tmp_path / "bank.graph", toks), "curve 0", "potential")


def test_missing_file_is_os_error(tmp_path):
    with pytest.raises(FileNotFoundError):
        load_graph(tmp_path / "nope.graph")


# -- malformed ASCII files --------------------------------------------------------------------

def _set(i, v):
    def f(t):
        t[i] = v
        return t
    return f


ASCII_CASES = [  # (id, change to the tiny channel's token list, fragment of the message)
    ("non-numeric count", _set(8, "abc"), "node count, got 'abc'"),
    ("float count", _set(37, "5.0"), "integer curve count"),
    ("negative count", _set(8, "-1"), "node count between 0"),
    ("huge count", _set(37, "99999"), "curve count between 0"),
    ("huge int", _set(8, "12345678901234567890"), "32-bit"),
    ("nan x", _set(9, "nan"), "finite number (x of node 0)"),
    ("inf y", _set(10, "inf"), "y of node 0"),
    ("overflow x", _set(13, "1e999"), "x of node 1"),
    ("nan width", _set(49, "NaN"), "width of curve 1"),
    ("negative width", _set(49, "-3"), "width >= 0"),
    ("nan potential", _set(51, "nan"), "potential of curve 1"),
    ("bank without potential", _set(51, "-1"), "curve 1, a BANK"),
    ("bad type", _set(50, "7"), "type of curve 1"),
    ("size < 2", _set(48, "1"), "vertex count of curve 1"),
    ("start node out of range", _set(53, "6"), "start node of curve 1 in [0, 5]"),
    ("end node out of range", _set(54, "-1"), "end node of curve 1"),
    ("river out of range", _set(52, "5"), "river axis index of curve 1"),
    ("river to a bank", _set(72, "1"), "curve 3's river link"),
    ("river to a closing segment", _set(72, "2"), "axis"),
    ("river to itself", _set(52, "1"), "curve 1's river link"),
    ("node curve list out of range", _set(12, "5"), "node curve index in [0, 4]"),
    ("curve parent < -1", _set(57, "-2"), "parent of curve 1"),
    ("area curve out of range", _set(92, "5"), "curve index in area 0"),
    ("orientation 2", _set(93, "2"), "orientation (0/1)"),
    ("subgraph flag 2", _set(91, "2"), "subgraph flag"),
    ("missing subgraph", _set(91, "1"), "end of file"),
    ("area without curves", _set(89, "0"), "curve count of area 0"),
    ("param too small", _set(2, "1"), "nParamsCurves"),
    ("param absurd", _set(1, "100000"), "nParamsNodes"),
    ("trailing garbage", lambda t: t + ["0"], "trailing garbage"),
    ("trailing text", lambda t: t + ["x"], "end of file"),
    ("non-ascii token", _set(9, "\u00e9\u00e8"), "x of node 0"),
    ("glued tokens", _set(9, "0.0abc"), "'0.0abc'"),
    ("truncated", lambda t: t[:60], "curve count between 0 and 2"),
    ("truncated before the last token", lambda t: t[:100], "end of file"),
]


@pytest.mark.parametrize("change, fragment", [pytest.param(c, f, id=i) for i, c, f in ASCII_CASES])
def test_malformed_ascii(change, fragment, tiny_channel_path, tmp_path):
    toks = tokens(tiny_channel_path)
    assert (toks[8], toks[37], toks[51], toks[72], toks[88], toks[89]) == ("6", "5", "100.000", "0", "1", "4")
    expect_error(write_tokens(tmp_path / "bad.graph", change(list(toks))), fragment)


@pytest.mark.parametrize("data, fragment", [
    (b"", "empty file"), (b"2 2 5 3", "magic"), (b"00 2 5", "magic"), (b"0", "magic"),
    (b"\x07\x00\x00\x00\x02\x00\x00\x00", "magic"), (b"\x00\x00", "magic"),
    (b"0 ", "nParamsNodes"), (b"1\n2 5 3 1 3 2 0", "index offset"),
])
def test_malformed_start(data, fragment, tmp_path):
    p = tmp_path / "start.graph"
    p.write_bytes(data)
    expect_error(p, fragment, binary=True)


def test_control_vertices(tmp_path):
    base = ("0 2 5 3 1 3 2 0 2 0 0 1 0 9 0 1 0 1 {n} 1 1 -1 -1 0 {pts} 1 -1 -1 -1 0").split()
    pts = lambda flags: " ".join(f"{k} {k} {f}" for k, f in enumerate(flags))  # noqa: E731
    ok = [t.format(n=6, pts=pts([1, 0, 1, 1])) for t in base]
    g = load_graph(write_tokens(tmp_path / "ok.graph", " ".join(ok).split()))
    assert g.curves[0].is_control.tolist() == [True, False, True, True]
    bad = " ".join(t.format(n=6, pts=pts([0, 1, 1, 1])) for t in base).split()
    expect_error(write_tokens(tmp_path / "three.graph", bad), "two Bézier control vertices")
    bad = " ".join(t.format(n=3, pts=pts([2])) for t in base).split()
    expect_error(write_tokens(tmp_path / "flag.graph", bad), "isControl flag")


# -- malformed binary and indexed files -------------------------------------------------------

def _binary(g: HydroGraph, tmp_path: Path, indexed: bool = False) -> bytes:
    p = tmp_path / "src.graph"
    save_graph(g, p, binary=True, indexed=indexed)
    return p.read_bytes()


def test_malformed_binary(tiny_channel_path, tmp_path):
    g = load_graph(tiny_channel_path)
    data = _binary(g, tmp_path)
    curve0 = 36 + sum(12 + 4 * len(inc) for inc in g.incident_curves()) + 4
    cases = [
        (32, "<i", -1, "node count between 0"), (32, "<i", 10**6, "node count between 0"),
        (36, "<f", float("nan"), "finite float32 x of node 0"),
        (40, "<f", float("inf"), "y of node 0"),
        (curve0 + 4, "<f", float("nan"), "width of curve 0"),
        (curve0 + 20, "<i", 99, "start node of curve 0"),
        (curve0 + 40 + 16, "<i", 7, "river axis index of curve 1"),
        (curve0 + 40 + 12, "<f", -1.0, "curve 1, a BANK"),
        (0, "<i", 2, "magic"),
    ]
    p = tmp_path / "bad.graph"
    for off, fmt, value, fragment in cases:
        arr = bytearray(data)
        struct.pack_into(fmt, arr, off, value)
        p.write_bytes(bytes(arr))
        msg = expect_error(p, fragment, binary=True)
        if fragment != "magic":
            assert f"byte {off}" in msg
    p.write_bytes(data + b"\x00")
    expect_error(p, "trailing garbage", binary=True)


def test_malformed_indexed(tiny_channel_path, tmp_path):
    g = load_graph(tiny_channel_path)
    data = _binary(g, tmp_path, indexed=True)
    at = struct.unpack_from("<q", data, 32)[0]
    p = tmp_path / "bad.graph"
    for change, fragment in [
        (lambda a: struct.pack_into("<q", a, 32, at - 4), "index"),
        (lambda a: struct.pack_into("<q", a, 32, 10**12), "index offset"),
        (lambda a: struct.pack_into("<q", a, at + 16 + 8, 41), "node 1 at the byte offset 41"),
        (lambda a: struct.pack_into("<i", a, at, 7), "index"),
        (lambda a: struct.pack_into("<i", a, at + 12, 1), "subgraph"),
    ]:
        arr = bytearray(data)
        change(arr)
        p.write_bytes(bytes(arr))
        expect_error(p, fragment, binary=True)
    save_graph(g, p, indexed=True)
    text = p.read_bytes()
    p.write_bytes(text[:16] + b"%10d" % (int(text[16:26]) + 1) + text[26:])
    expect_error(p, "in the index")


@pytest.mark.parametrize("binary, indexed", VARIANTS)
def test_truncation_always_graph_error(binary, indexed, proland_graph_path, tiny_channel_path,
                                       tmp_path, rng):
    for src in (tiny_channel_path, proland_graph_path):
        p = tmp_path / "full.graph"
        save_graph(load_graph(src), p, binary=binary, indexed=indexed)
        data = p.read_bytes()
        n = len(data)
        cuts = set(range(min(n, 80))) | set(range(max(0, n - 80), n))
        cuts |= set(rng.integers(0, n, 150).tolist())
        q = tmp_path / "cut.graph"
        for cut in sorted(cuts):
            q.write_bytes(data[:cut])
            if not binary and not data[cut:].strip():
                assert load_graph(q) == load_graph(p)  # only whitespace was cut
                continue
            with pytest.raises(GraphError, match="byte "):
                load_graph(q)


@pytest.mark.parametrize("binary, indexed", VARIANTS)
def test_fuzz_flipped_bytes(binary, indexed, proland_graph_path, tmp_path):
    rng = np.random.default_rng(1234 + 2 * binary + indexed)
    p = tmp_path / "full.graph"
    save_graph(load_graph(proland_graph_path), p, binary=binary, indexed=indexed)
    data = p.read_bytes()
    q, r = tmp_path / "fuzz.graph", tmp_path / "resaved.graph"
    loaded = 0
    for _ in range(300):
        arr = bytearray(data)
        for pos in rng.integers(0, len(arr), rng.integers(1, 5)):
            arr[pos] = int(rng.integers(0, 256))
        q.write_bytes(bytes(arr))
        try:
            g = load_graph(q)
        except GraphError:
            continue
        loaded += 1
        save_graph(g, r)  # whatever loads is a savable, reloadable graph
        assert load_graph(r) == g
    assert loaded < 300


# -- saving refuses what could not be loaded back ---------------------------------------------

def test_save_refuses_invalid_graphs(tmp_path):
    p = tmp_path / "out.graph"
    cases = []
    g = channel_graph(); g.curves[0].potential = NO_POTENTIAL; cases.append((g, "BANK"))  # noqa: E702
    g = channel_graph(); g.nodes[1, 0] = np.nan; cases.append((g, "non-finite"))  # noqa: E702
    g = channel_graph(); g.curves[2].river = 1; cases.append((g, "river link"))  # noqa: E702
    g = channel_graph(); g.curves[1].end = 99; cases.append((g, "nodes"))  # noqa: E702
    g = channel_graph(); g.areas[0].curves.append((9, 0)); cases.append((g, "area 0"))  # noqa: E702
    g = channel_graph(); g.areas[0].subgraph.curves[0].width_m = -1.0  # noqa: E702
    cases.append((g, "subgraph of area 0"))
    for g, fragment in cases:
        with pytest.raises(GraphError, match=fragment):
            save_graph(g, p)
    g = channel_graph()
    g.nodes[0, 0] = 1e300
    save_graph(g, p)  # fine in ASCII
    assert load_graph(p) == g
    with pytest.raises(GraphError, match="float32"):
        save_graph(g, p, binary=True)
