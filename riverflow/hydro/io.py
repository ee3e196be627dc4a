"""Proland hydro-graph files: read all four variants, write them back losslessly.

Re-does Proland's ``HydroGraph::load`` / ``loadIndexed`` / ``save`` / ``indexedSave`` with its
``FileReader`` / ``FileWriter`` (reference §1.3-1.5). The variant is detected from the first
bytes: int32 ``0`` / ``1`` = binary basic / indexed (little-endian int32, float32, int64 offsets);
ASCII ``'0'`` / ``'1'`` plus one whitespace character = ASCII basic / indexed (whitespace
separated tokens, C++ ``>>`` style, no comments).

Differences from Proland, all deliberate:

* every malformed file raises :class:`GraphError` naming the file, the byte offset (and, in ASCII,
  the 0-based token index, the magic being token 0) and what was expected; nothing is truncated;
  trailing data after the graph is an error; tokens must be whole numbers (``12abc`` is refused);
* extra ``nParamsCurves`` values are skipped once (Proland skips them twice);
* ASCII floats are written with Python ``repr`` (shortest round trip), not ``%.3f``, so
  ``load_graph(save_graph(g)) == g`` exactly. Binary files store float32: a binary round trip
  gives the graph with every coordinate, width and potential rounded to float32;
* curves are written in graph order (Proland puts non-banks first); node curve lists and
  ``area1``/``area2`` are written for Proland but ignored on load (derived data).
"""
from __future__ import annotations

import math
import mmap
import os
import re
import struct
import stat
from collections import deque
from pathlib import Path

import numpy as np

from riverflow._atomic import atomic_write_bytes
from riverflow.hydro.graph import (LAKE_LEVEL_INFO, NO_CURVE, NO_POTENTIAL, Area, Curve, CurveType,
                                   GraphError, HydroGraph)

__all__ = ["load_graph", "save_graph"]

_PARAM_NAMES = ("nParamsNodes", "nParamsCurves", "nParamsAreas", "nParamsCurveExtremities",
                "nParamsCurvePoints", "nParamsAreaCurves", "nParamsSubgraphs")
_PARAM_MIN = (2, 3, 3, 1, 3, 2, 0)
_PARAM_MAX = 1000
_HYDRO_PARAMS = (2, 5, 3, 1, 3, 2, 0)


def _params_of(g: HydroGraph) -> tuple[int, ...]:
    """The params a graph is written with: one extra area value (a lake's level, 0 for other
    areas) when some lake has a level, else Proland's own."""
    if any(a.level_m is not None for a in g.areas):
        return (2, 5, 4, 1, 3, 2, 0)
    return _HYDRO_PARAMS
_MAX_DEPTH = 32
_INT32 = (-(2**31), 2**31 - 1)
_INT_RE = re.compile(rb"[+-]?[0-9]+")
_FLOAT_RE = re.compile(rb"[+-]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?")
_WS = b" \t\n\r\v\f"


# ---------------------------------------------------------------------------------------------
# readers: one cursor over tokens (ASCII) or bytes (binary), same methods
# ---------------------------------------------------------------------------------------------

class _Reader:
    """Cursor with ``limit`` (end of the readable region); subclasses define the encoding."""

    int_size = float_size = long_size = 1

    def __init__(self, name: str) -> None:
        self.name = name

    def fail(self, what: str, got: str, at: int | None = None) -> GraphError:
        return GraphError(f"{self.name}: {self.where(self.pos if at is None else at)}: "
                          f"expected {what}, got {got}")

    def int(self, what: str, lo: int = _INT32[0], hi: int = _INT32[1], size: int = 4) -> int:
        """An int32 (``size`` 8: an int64 offset) in ``[lo, hi]``."""
        at = self.last = self.pos
        v = self._int(what, size)
        if not lo <= v <= hi:
            raise self.fail(f"{what} in [{lo}, {hi}]", str(v), at)
        return v

    def long(self, what: str, lo: int, hi: int) -> int:
        return self.int(what, lo, hi, 8)

    def remaining(self) -> int:
        return self.limit - self.pos

    def count(self, what: str, unit: int) -> int:
        """A non-negative count of items each at least ``unit`` values long."""
        at = self.pos
        v = self._int(what, 4)
        room = self.remaining() // max(unit * self.int_size, 1)
        if v < 0 or v > room:
            raise self.fail(f"{what} between 0 and {room} (what the rest of the file can hold)",
                            str(v), at)
        return v

    def skip(self, n: int, what: str) -> None:
        for _ in range(n):
            self.float(f"extra {what} value")


_TOKEN_RE = re.compile(rb"\S+")
_CHUNK = 1 << 18
"""Bytes read at a time: a graph file is read streaming, never whole (issue #30)."""
MAX_TOKEN_BYTES = 256
"""Longest ASCII token read [bytes] (the longest number written is 24): a longer one is an
error at its byte offset, not a string grown to the file's size."""


class _TokenStream:
    """The tokens (whitespace-separated runs) of a file from a byte offset on, read in chunks
    of _CHUNK bytes: (start byte, token) pairs; a token over MAX_TOKEN_BYTES comes back cut
    to MAX_TOKEN_BYTES + 1 bytes (the reader refuses it)."""

    def __init__(self, f, start: int) -> None:
        self.f = f
        self.buf = b""
        self.base = start          # file offset of buf[0]
        self.at = start            # file offset of the next read
        self.i = 0
        self.eof = False

    def next(self) -> tuple[int, bytes] | None:
        while True:
            m = _TOKEN_RE.search(self.buf, self.i)
            if m is not None and (m.end() < len(self.buf) or self.eof):
                self.i = m.end()
                return self.base + m.start(), m.group()
            if m is None and self.eof:
                self.i = len(self.buf)
                return None
            keep = m.start() if m is not None else len(self.buf)
            if len(self.buf) - keep > MAX_TOKEN_BYTES:       # a token without end in sight
                self.i = len(self.buf)
                return self.base + keep, self.buf[keep:keep + MAX_TOKEN_BYTES + 1]
            self.f.seek(self.at)
            chunk = self.f.read(_CHUNK)
            self.at += len(chunk)
            self.eof = not chunk
            self.base += keep
            self.buf = self.buf[keep:] + chunk
            self.i = 0


def _count_tokens(f, start: int, stop: int) -> int:
    """Tokens with a byte in [start, stop) of the file (``start`` at a token's start or in
    whitespace), counted chunk by chunk in bounded memory."""
    n = 0
    glued = False           # the previous chunk ended inside a token
    at = start
    while at < stop:
        f.seek(at)
        chunk = f.read(min(_CHUNK, stop - at))
        if not chunk:
            break
        n += len(chunk.split()) - (1 if glued and chunk[:1] not in _WS_SET else 0)
        glued = chunk[-1:] not in _WS_SET
        at += len(chunk)
    return n


_WS_SET = frozenset(bytes([c]) for c in _WS)


class _AsciiReader(_Reader):
    """Tokens read streaming from an open file (bounded memory whatever the file's size):
    ``pos`` is the index of the next token (the magic is token 0, not counted here); the
    total number of tokens is counted, in a second streaming pass, only when a count must be
    checked against what the rest of the file can hold."""

    def __init__(self, name: str, f, size: int) -> None:
        super().__init__(name)
        self.f = f
        self.size = size
        self._limit: int | None = None
        self._total: int | None = None
        self._done = False
        self._start_at(2, 0, 0)

    def _start_at(self, byte: int, index: int, last_end: int) -> None:
        self.stream = _TokenStream(self.f, byte)
        self.pos = index
        self.last_end = last_end
        self.recent: deque[tuple[int, int, int]] = deque(maxlen=64)   # (index, start, end)
        self.peeked: tuple[int, bytes] | None | bool = False

    def _peek(self) -> tuple[int, bytes] | None:
        if self.peeked is False:
            self.peeked = self.stream.next()
            if self.peeked is None and self._total is None:
                self._total = self.pos
        return self.peeked

    # -- the cursor the parser sees --------------------------------------------------------

    @property
    def end(self) -> int:
        if self._total is None:
            nxt = self._peek()
            self._total = self.pos if nxt is None else (
                self.pos + _count_tokens(self.f, nxt[0], self.size))
        return self._total

    @property
    def limit(self) -> int:
        return self.end if self._limit is None else self._limit

    @limit.setter
    def limit(self, value: int | None) -> None:
        self._limit = value

    def more(self) -> bool:
        if self._done:
            return False
        if self._limit is not None:
            return self.pos < self._limit
        return self._peek() is not None

    def finish(self) -> None:
        self._done = True

    def save(self) -> tuple[int, int, int]:
        nxt = self._peek()
        return (self.pos, self.size if nxt is None else nxt[0], self.last_end)

    def restore(self, state: tuple[int, int, int]) -> None:
        index, byte, last_end = state
        self._start_at(byte, index, last_end)

    def _start_of(self, at: int) -> tuple[int, int]:
        """(start, end) bytes of token ``at`` ((size, size) past the last token)."""
        if at == self.pos:
            nxt = self._peek()
            return (self.size, self.size) if nxt is None else (nxt[0], nxt[0] + len(nxt[1]))
        for index, start, stop in self.recent:
            if index == at:
                return start, stop
        stream = _TokenStream(self.f, 2)              # an old token: an error's rare path
        for _ in range(at + 1):
            tok = stream.next()
            if tok is None:
                return self.size, self.size
        return tok[0], tok[0] + len(tok[1])

    def where(self, at: int) -> str:
        return f"byte {self._start_of(at)[0]} (token {at + 1})"

    def _next(self, what: str) -> bytes:
        if self._limit is not None and self.pos >= self._limit:
            raise self.fail(what, "the start of the index")
        nxt = self._peek()
        if nxt is None:
            raise self.fail(what, "end of file")
        start, tok = nxt
        if len(tok) > MAX_TOKEN_BYTES:
            raise self.fail(f"{what} (a token of at most {MAX_TOKEN_BYTES} bytes)",
                            f"{_show(tok)} (longer)")
        self.recent.append((self.pos, start, start + len(tok)))
        self.last_end = start + len(tok)
        self.peeked = False
        self.pos += 1
        return tok

    def _int(self, what: str, size: int) -> int:
        tok = self._next(what)
        if not _INT_RE.fullmatch(tok):
            raise self.fail(f"an integer {what}", _show(tok), self.pos - 1)
        v = int(tok)
        if abs(v) >= 2 ** (8 * size - 1):
            raise self.fail(f"a {8 * size}-bit integer {what}", _show(tok), self.pos - 1)
        return v

    def float(self, what: str) -> float:
        self.last = self.pos
        tok = self._next(what)
        v = float(tok) if _FLOAT_RE.fullmatch(tok) else None
        if v is None or not math.isfinite(v):
            raise self.fail(f"a finite number ({what})", _show(tok), self.pos - 1)
        return v

    def tell(self) -> int:
        nxt = self._peek()
        return self.size if nxt is None else nxt[0]

    def _byte(self, offset: int) -> bytes:
        if not 0 <= offset < self.size:
            return b" "
        self.f.seek(offset)
        return self.f.read(1) or b" "

    def seek(self, offset: int) -> None:
        """Go to byte ``offset``: the first token at or after it (C++ ``seekg`` + ``>>``)."""
        before = _count_tokens(self.f, 2, max(offset, 2))
        if offset > 2 and self._byte(offset - 1) not in _WS_SET \
                and self._byte(offset) not in _WS_SET:
            raise GraphError(f"{self.name}: {self.where(before - 1)}: expected the index offset "
                             f"{offset} to point at the start of a token, not inside one")
        self._start_at(max(offset, 2), before, offset)

    def is_at(self, offset: int) -> bool:
        nxt = self._peek()
        return self.last_end <= offset <= (math.inf if nxt is None else nxt[0])


class _BinaryReader(_Reader):
    int_size = float_size = 4
    long_size = 8

    def __init__(self, name: str, data) -> None:
        super().__init__(name)
        self.data = data           # bytes or a read-only mmap of the file
        self.pos = 4
        self.size = self.end = self.limit = len(data)

    def more(self) -> bool:
        return self.pos < self.limit

    def finish(self) -> None:
        self.pos = self.limit = self.end

    def save(self) -> int:
        return self.pos

    def restore(self, state: int) -> None:
        self.pos = state

    def where(self, at: int) -> str:
        return f"byte {at}"

    def _unpack(self, fmt: str, size: int, what: str) -> int | float:
        if self.pos + size > self.limit:
            got = "end of file" if self.limit == self.end else "the start of the index"
            raise self.fail(what, f"{got} ({self.limit - self.pos} bytes left)")
        v = struct.unpack_from(fmt, self.data, self.pos)[0]
        self.pos += size
        return v

    def _int(self, what: str, size: int) -> int:
        return self._unpack("<i" if size == 4 else "<q", size, f"{8 * size}-bit integer {what}")

    def float(self, what: str) -> float:
        self.last = self.pos
        v = float(self._unpack("<f", 4, f"float32 {what}"))
        if not math.isfinite(v):
            raise self.fail(f"a finite float32 {what}", repr(v), self.pos - 4)
        return v

    def tell(self) -> int:
        return self.pos

    def seek(self, offset: int) -> None:
        self.pos = offset

    def is_at(self, offset: int) -> bool:
        return offset == self.pos


def _show(tok: bytes) -> str:
    s = tok[:24].decode("ascii", "backslashreplace")
    return repr(s + ("..." if len(tok) > 24 else ""))


# ---------------------------------------------------------------------------------------------
# loading
# ---------------------------------------------------------------------------------------------

def load_graph(path: str | os.PathLike) -> HydroGraph:
    """Read a Proland graph file of any of the four variants (reference §1.3-1.5).

    Returns a :class:`HydroGraph` with ``source = str(path)``; coordinates and widths in metres.
    Basic (non-hydro) files give potential ``NO_POTENTIAL`` and river ``NO_CURVE``.

    Raises:
        GraphError: malformed content (message: file, byte/token offset, what was expected).
        OSError: the file cannot be opened or read.
    """
    if not isinstance(path, (str, os.PathLike)):
        raise TypeError(f"load_graph: path must be a file name, got {type(path).__name__}")
    name = str(path)
    with _open_regular(path, name) as f:
        size = os.fstat(f.fileno()).st_size
        head = f.read(4)
        if not head:
            raise GraphError(f"{name}: byte 0: expected a graph file, got an empty file")
        magic = struct.unpack_from("<i", head)[0] if len(head) >= 4 else None
        data = None
        if magic in (0, 1):
            data = mmap.mmap(f.fileno(), 0, access=mmap.ACCESS_READ)  # paged in as read
            r: _Reader = _BinaryReader(name, data)
        elif head[:1] in (b"0", b"1") and len(head) >= 2 and head[1] in _WS:
            r = _AsciiReader(name, f, size)
            magic = int(head[:1])
        else:
            raise GraphError(f"{name}: byte 0: expected the magic number 0 or 1 (int32 or ASCII "
                             f"digit plus one whitespace), got {_show(head)}")
        try:
            graph = _read_indexed(r) if magic == 1 else _read_graph(r, 0)
            if r.more():
                raise r.fail("end of file", "more data (trailing garbage)")
        finally:
            if data is not None:
                data.close()
    graph.source = name
    return graph


_KINDS = ((stat.S_ISDIR, "a folder"), (stat.S_ISFIFO, "a FIFO (named pipe)"),
          (stat.S_ISCHR, "a character device"), (stat.S_ISBLK, "a block device"),
          (stat.S_ISSOCK, "a socket"))


def _open_regular(path, name: str):
    """The file opened for reading, or GraphError at once when it is not a regular file (a
    FIFO would block, /dev/zero never end): opened without blocking, then checked."""
    fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0))
    try:
        mode = os.fstat(fd).st_mode
        if not stat.S_ISREG(mode):
            kind = next((k for test, k in _KINDS if test(mode)), "not a regular file")
            raise GraphError(f"{name}: byte 0: expected a regular graph file, got {kind}")
        if hasattr(os, "set_blocking"):
            os.set_blocking(fd, True)
        return os.fdopen(fd, "rb", buffering=0)
    except BaseException:
        os.close(fd)
        raise


def _read_params(r: _Reader) -> tuple[int, ...]:
    return tuple(r.int(n, lo, _PARAM_MAX) for n, lo in zip(_PARAM_NAMES, _PARAM_MIN))


def _read_indexed(r: _Reader) -> HydroGraph:
    """Indexed layout (§1.5): params, indexOffset, bodies without counts, subgraphs, index."""
    params = _read_params(r)
    index_at = r.long("index offset", r.tell() + 1, r.size)
    body = r.save()
    r.seek(index_at)
    index_pos = r.pos
    counts = [r.count(f"{k} count in the index", r.long_size // r.int_size)
              for k in ("node", "curve", "area", "subgraph")]
    offsets = [r.long("element offset", 0, index_at) for _ in range(sum(counts[:3]))]
    sub_offsets: dict[int, int] = {}
    for _ in range(counts[3]):
        a = r.int("subgraph area index (each area once)", 0, counts[2] - 1)
        if a in sub_offsets:
            raise r.fail("each area index once in the subgraph index", f"area {a} twice", r.last)
        sub_offsets[a] = r.long("subgraph offset", 0, index_at)
    if r.more():
        raise r.fail("end of file after the index", "more data (trailing garbage)")
    r.restore(body)
    r.limit = index_pos
    g = _read_graph(r, 0, params=params, counts=counts, offsets=offsets, sub_offsets=sub_offsets)
    if r.more():
        raise r.fail(f"the index at byte {index_at}", "more data before it")
    r.finish()
    return g


def _read_graph(r: _Reader, depth: int, params: tuple[int, ...] | None = None,
                counts: list[int] | None = None, offsets: list[int] | None = None,
                sub_offsets: dict[int, int] | None = None) -> HydroGraph:
    """One graph in basic layout (or the body of an indexed file when ``counts`` is given)."""
    if depth > _MAX_DEPTH:
        raise r.fail(f"subgraphs nested at most {_MAX_DEPTH} deep", "deeper nesting")
    pn, pc, pa, pe, pp, pac, ps = params or _read_params(r)
    hydro = pc >= 5
    pos_iter = iter(offsets or [])

    def element(kind: str, i: int) -> None:
        if offsets is not None:
            off = next(pos_iter)
            if not r.is_at(off):
                raise r.fail(f"{kind} {i} at the byte offset {off} given by the index",
                             f"it at byte {r.tell()}")

    n_nodes = counts[0] if counts else r.count("node count", 3 + pn - 2)
    nodes = []
    node_links: list[tuple[int, int]] = []  # (token/byte position, curve index)
    for i in range(n_nodes):
        element("node", i)
        nodes.append((r.float(f"x of node {i}"), r.float(f"y of node {i}")))
        r.skip(pn - 2, f"node {i}")
        for _ in range(r.count(f"curve count of node {i}", 1)):
            node_links.append((r.pos, r.int(f"curve index in node {i}")))

    n_curves = counts[1] if counts else r.count("curve count", pc + 3 + 2 * pe)
    for at, c in node_links:
        if not 0 <= c < n_curves:
            raise r.fail(f"a node curve index in [0, {n_curves - 1}]", str(c), at)
    curves: list[Curve] = []
    rivers: list[tuple[int, int]] = []
    for i in range(n_curves):
        element("curve", i)
        at = r.pos
        size = r.int(f"vertex count of curve {i}", 2, 2 + r.remaining() // (3 * r.int_size))
        width = r.float(f"width of curve {i}")
        if width < 0:
            raise r.fail(f"a width >= 0 for curve {i}", repr(width), r.last)
        ctype = CurveType(r.int(f"type of curve {i} (0 AXIS, 1 CLOSING_SEGMENT, 2 BANK)", 0, 2))
        potential, river = NO_POTENTIAL, NO_CURVE
        if hydro:
            potential = r.float(f"potential of curve {i}")
            if ctype == CurveType.BANK and potential == NO_POTENTIAL:
                raise r.fail(f"a potential for curve {i}, a BANK", "-1 (no potential)", r.last)
            rivers.append((r.pos, r.int(f"river axis index of curve {i}", -1, n_curves - 1)))
        elif ctype == CurveType.BANK:
            raise r.fail(f"a potential for curve {i}, a BANK", "a file without potentials", at)
        r.skip(pc - (5 if hydro else 3), f"curve {i}")
        start = r.int(f"start node of curve {i}", 0, n_nodes - 1)
        r.skip(pe - 1, f"curve {i} start")
        pts, ctrl = [], []
        for j in range(1, size - 1):
            pts.append((r.float(f"x of vertex {j} of curve {i}"), r.float(f"y of vertex {j}")))
            ctrl.append(r.int(f"isControl flag (0/1) of vertex {j} of curve {i}", 0, 1))
            r.skip(pp - 3, f"curve {i} vertex")
            if ctrl[-3:] == [1, 1, 1]:
                raise r.fail(f"at most two Bézier control vertices in a row in curve {i}",
                             f"a third one (vertex {j})", r.last)
        end = r.int(f"end node of curve {i}", 0, n_nodes - 1)
        r.skip(pe - 1, f"curve {i} end")
        r.int(f"area1 of curve {i}", -1)
        r.int(f"area2 of curve {i}", -1)
        parent = r.int(f"parent of curve {i}", -1)
        curves.append(Curve(start, end, pts, ctrl, width, ctype, potential, NO_CURVE, parent))
    for i, (at, river) in enumerate(rivers):
        if river != NO_CURVE and (river == i or not curves[river].is_axis):
            raise r.fail(f"curve {i}'s river link to be an axis (a non-bank curve with a width)",
                         f"curve {river} ({curves[river]!r})", at)
        curves[i].river = river

    n_areas = counts[2] if counts else r.count("area count", 4 + pa - 3 + ps)
    areas: list[Area] = []
    flags: list[int] = []
    for i in range(n_areas):
        element("area", i)
        n = r.int(f"curve count of area {i}", 1, r.remaining() // (2 * r.int_size))
        info = r.int(f"info of area {i}")
        flags.append(r.int(f"subgraph flag (0/1) of area {i}", 0, 1))
        level = None
        if pa > 3:      # riverflow writes a lake's level as the first extra value
            value = r.float(f"extra area {i} value (a lake's level)")
            if info == LAKE_LEVEL_INFO:
                level = value
            r.skip(pa - 4, f"area {i}")
        loop = []
        for _ in range(n):
            loop.append((r.int(f"curve index in area {i}", 0, n_curves - 1),
                         r.int(f"orientation (0/1) in area {i}", 0, 1)))
            r.skip(pac - 2, f"area {i} curve")
        r.skip(ps, f"area {i} subgraph")
        areas.append(Area(loop, info, r.int(f"parent of area {i}", -1), level_m=level))
    if sub_offsets is not None and set(sub_offsets) != {i for i, f in enumerate(flags) if f}:
        raise GraphError(f"{r.name}: the index lists subgraphs for areas {sorted(sub_offsets)} "
                         f"but the areas with a subgraph flag are "
                         f"{[i for i, f in enumerate(flags) if f]}")
    for i, f in enumerate(flags):
        if f:
            if sub_offsets is not None and not r.is_at(sub_offsets[i]):
                raise r.fail(f"the subgraph of area {i} at byte {sub_offsets[i]}",
                             f"it at byte {r.tell()}")
            areas[i].subgraph = _read_graph(r, depth + 1)
    return HydroGraph(np.array(nodes, dtype=np.float64).reshape(-1, 2), curves, areas)


# ---------------------------------------------------------------------------------------------
# saving
# ---------------------------------------------------------------------------------------------

def save_graph(graph: HydroGraph, path: str | os.PathLike, *, binary: bool = False,
               indexed: bool = False) -> None:
    """Write ``graph`` as a Proland hydro-graph file (params ``2 5 3 1 3 2 0``; ``2 5 4 1 3 2 0``
    when a lake has a level, which is then each area's extra value).

    The default, ASCII basic, is what Proland's examples use and round-trips exactly
    (floats written with ``repr``). ``binary=True`` writes int32/float32 little-endian (values
    rounded to float32, offsets int64); ``indexed=True`` writes the indexed layout (§1.5).

    Raises:
        GraphError: the graph cannot be written so that it loads back (bad index, NaN, a bank
            without a potential, a value that does not fit int32/float32, ...).
    """
    if not isinstance(graph, HydroGraph):
        raise TypeError(f"save_graph: graph must be a HydroGraph, got {type(graph).__name__}")
    if not isinstance(path, (str, os.PathLike)):
        raise TypeError(f"save_graph: path must be a file name, got {type(path).__name__}")
    _check_savable(graph, "graph")
    w = _Writer(binary)
    w.row("i", 1 if indexed else 0, newline=False)
    if indexed:
        _write_indexed(graph, w)
    else:
        _write_graph(graph, w)
    atomic_write_bytes(path, b"".join(w.parts))   # complete or not at all


class _Writer:
    """Accumulates a file: ``row("iif", 1, 2, 3.5)`` writes int32 / int64 (``q``) / float32
    values in binary, or tokens (ints, 10-wide int64, ``repr`` floats) on one ASCII line."""

    def __init__(self, binary: bool) -> None:
        self.binary = binary
        self.parts: list[bytes] = []
        self.size = 0

    def row(self, fmt: str, *values, newline: bool = True) -> None:
        if self.binary:
            with np.errstate(over="ignore"):
                f32 = np.asarray([v for k, v in zip(fmt, values) if k == "f"], np.float32)
            if not np.isfinite(f32).all():
                bad = [v for k, v in zip(fmt, values) if k == "f"][int(np.argmin(np.isfinite(f32)))]
                raise GraphError(f"{bad!r} does not fit a float32 (binary files store float32)")
            b = struct.pack("<" + fmt, *[float(v) if k == "f" else int(v) for k, v in zip(fmt, values)])
        else:
            tok = {"i": lambda v: b"%d" % v, "q": lambda v: b"%10d" % v,
                   "f": lambda v: repr(float(v)).encode()}
            b = b" ".join(tok[k](v) for k, v in zip(fmt, values)) + (b"\n" if newline else b" ")
        self.parts.append(b)
        self.size += len(b)


def _write_graph(g: HydroGraph, w: _Writer, offsets: list[int] | None = None,
                 sub_offsets: list[tuple[int, int]] | None = None) -> None:
    """Basic layout without magic; with ``offsets`` the indexed body (no counts, the byte
    offset of each element appended to ``offsets``, of each subgraph to ``sub_offsets``)."""
    indexed = offsets is not None
    levels = _params_of(g)[2] > 3
    if not indexed:
        w.row("i" * 7, *_params_of(g))
    adjacent: list[list[int]] = [[] for _ in g.curves]  # Proland's area1 / area2
    for k, area in enumerate(g.areas):
        for c, _ in area.curves:
            if k not in adjacent[c]:
                adjacent[c].append(k)
    elements = [(len(g.nodes), [
        ("ffi" + "i" * len(inc), (x, y, len(inc), *inc))
        for (x, y), inc in zip(g.nodes, g.incident_curves())
    ]), (len(g.curves), [
        ("ififii" + "ffi" * len(c.points) + "iiii",
         (len(c.points) + 2, c.width_m, int(c.type), c.potential, c.river, c.start,
          *[v for (x, y), k in zip(c.points, c.is_control) for v in (x, y, int(k))],
          c.end, *(adjacent[i] + [-1, -1])[:2], c.parent))
        for i, c in enumerate(g.curves)
    ]), (len(g.areas), [
        ("iii" + "f" * levels + "ii" * len(a.curves) + "i",
         (len(a.curves), a.info, a.subgraph is not None,
          *([a.level_m if a.level_m is not None else 0.0] if levels else []),
          *[v for co in a.curves for v in co], a.parent))
        for a in g.areas
    ])]
    for count, rows in elements:
        if not indexed:
            w.row("i", count)
        for fmt, values in rows:
            if indexed:
                offsets.append(w.size)
            w.row(fmt, *values)
    for i, a in enumerate(g.areas):
        if a.subgraph is not None:
            if sub_offsets is not None:
                sub_offsets.append((i, w.size))
            _write_graph(a.subgraph, w)


def _write_indexed(g: HydroGraph, w: _Writer) -> None:
    """Indexed layout (§1.5); the index offset is patched into its fixed-width field."""
    w.row("i" * 7, *_params_of(g), newline=False)
    slot = len(w.parts)
    w.row("q", 0)
    offsets: list[int] = []
    subs: list[tuple[int, int]] = []
    _write_graph(g, w, offsets, subs)
    index_at = w.size
    w.row("iiii" + "q" * len(offsets) + "iq" * len(subs), len(g.nodes), len(g.curves),
          len(g.areas), len(subs), *offsets, *[v for sub in subs for v in sub])
    old = w.parts[slot]
    w.parts[slot] = struct.pack("<q", index_at) if w.binary else b"%10d\n" % index_at
    if len(w.parts[slot]) != len(old):
        raise GraphError(f"index offset {index_at} does not fit the 10-character ASCII field")


def _check_savable(g: HydroGraph, what: str, depth: int = 0) -> None:
    """Refuse what :func:`load_graph` would refuse, so that a saved graph always loads back."""
    def bad(msg: str) -> GraphError:
        return GraphError(f"cannot save {what}: {msg}")

    n, m = len(g.nodes), len(g.curves)
    if depth > _MAX_DEPTH:
        raise bad(f"subgraphs nested more than {_MAX_DEPTH} deep")
    if not np.isfinite(g.nodes).all():
        raise bad(f"node {int(np.argwhere(~np.isfinite(g.nodes))[0, 0])} has a non-finite coordinate")
    for i, c in enumerate(g.curves):
        k = c.is_control.astype(int)
        river_ok = c.river == NO_CURVE or (0 <= c.river < m and c.river != i
                                           and g.curves[c.river].is_axis)
        for failed, problem in (
            (not (0 <= c.start < n and 0 <= c.end < n), f"joins nodes {c.start}->{c.end}"),
            (not np.isfinite([*c.points.ravel(), c.width_m, c.potential]).all(),
             "has a non-finite vertex, width or potential"),
            (c.width_m < 0, f"has a negative width {c.width_m!r}"),
            (c.is_bank and c.potential == NO_POTENTIAL, "is a BANK without a potential"),
            (not river_ok, f"has a river link {c.river} that is not an axis of this graph"),
            (len(k) >= 3 and (k[:-2] & k[1:-1] & k[2:]).any(),
             "has more than two Bézier control vertices in a row"),
            (not -1 <= c.parent <= _INT32[1], f"has parent {c.parent}, not an int32 >= -1"),
        ):
            if failed:
                raise bad(f"curve {i} {problem}")
    for i, a in enumerate(g.areas):
        if not a.curves or any(not (0 <= c < m and o in (0, 1)) for c, o in a.curves):
            raise bad(f"area {i} has no curves or a bad (curve, orientation) in {a.curves}")
        if not (-1 <= a.parent <= _INT32[1] and _INT32[0] <= a.info <= _INT32[1]):
            raise bad(f"area {i} has parent {a.parent} / info {a.info} out of int32 (parent >= -1)")
        if a.level_m is not None and not np.isfinite(a.level_m):
            raise bad(f"area {i} (a lake) has a non-finite level {a.level_m!r}")
        if a.subgraph is not None:
            _check_savable(a.subgraph, f"{what} > subgraph of area {i}", depth + 1)
