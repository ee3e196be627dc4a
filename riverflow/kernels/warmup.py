"""Compile (or load from the cache) the kernels a run needs before its first frame, with progress.

numba compiles a kernel at its first call. On a machine that has not compiled riverflow's
kernels yet (a new install, a new numba, an edited kernel: :mod:`riverflow.kernels._cache`)
that is about a minute of compiling spread over the first frames, a frozen window and a
silent terminal. :func:`compile_kernels` does it up front instead, kernel by kernel with the
argument types the run will call them with (:mod:`riverflow.kernels._signatures`, recorded
from real runs by ``tools/record_kernel_signatures.py``), and says how far it is::

    compiling riverflow kernels for this machine, first run only: 12/46

The line appears only when something is really compiled (a cold cache); loading machine code
from a warm cache says nothing. What the cache lacks is compiled by worker processes side by
side (one per core, up to 8), while this process stays free to draw a loading screen
(:mod:`riverflow.engine.loading`). :class:`riverflow.RiverWorld` and
:class:`riverflow.FlowField` call it when they are made; a host game with its own loading
screen calls it first with its own :class:`CompileProgress`. Kernels are grouped by what a run
does, so a run compiles only what it calls:

=========  =====================================================================================
``field``  :class:`riverflow.FlowField` (velocity and ψ queries, flow tiles)
``scene``  making a landscape (:func:`riverflow.default_scene`, :func:`riverflow.landscape`)
``world``  :class:`riverflow.RiverWorld` without drawing: particles, tiles, boats (and ``field``)
``draw``   what ``gl=True`` adds: wave tiles, sprite tables
=========  =====================================================================================

A kernel called with types not recorded (or a signature gone stale after an edit) still works:
numba compiles it at its first call, as it would without a warm-up.
"""
from __future__ import annotations

import importlib
import json
import os
import sys
import threading
import time
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO, Any

GROUPS = ("field", "scene", "world", "draw")
MESSAGE = "compiling riverflow kernels for this machine, first run only"

_KERNELS = __spec__.parent if __spec__ is not None else __name__.rpartition(".")[0]
"""``riverflow.kernels`` (also when this module runs as ``-m …warmup --worker``)."""
_lock = threading.RLock()
_warm: set[tuple[str, str]] = set()
"""(kernel, signature) pairs this process has compiled or loaded already."""
_recording = False
"""Set by ``tools/record_kernel_signatures.py``: the warm-up does nothing, so the real calls
are the first."""


# -- progress ------------------------------------------------------------------------------------

class CompileProgress:
    """What a warm-up reports: ``done`` of ``total`` kernels, and whether any was really
    compiled (``compiling``; False while everything loads from the cache). A window reads these
    attributes from its own thread and draws :attr:`text`; subclasses print."""

    def __init__(self) -> None:
        self.done = 0
        self.total = 0
        self.compiling = False
        self.finished = False
        self.started_s = time.perf_counter()
        self.work = Work()
        """The kernels' recorded compile costs: what is done, what is running since when."""

    @property
    def fraction(self) -> float:
        """How far the warm-up is, weighted by each kernel's recorded compile time, counting
        the kernels being compiled now by the time they have taken (so a window's line
        moves every second or so even while one costly kernel compiles)."""
        return self.work.fraction()

    @property
    def text(self) -> str:
        """The progress line, or "" while nothing is being compiled."""
        if not self.compiling:
            return ""
        return f"{MESSAGE}: {100 * self.fraction:.0f} % ({self.done}/{self.total})"

    def update(self, done: int, total: int, compiling: bool) -> None:
        self.done, self.total = done, total
        self.compiling = self.compiling or compiling

    def finish(self) -> None:
        self.finished = True


class Work:
    """The warm-up's work weighted by the recorded compile cost of each kernel (seconds on
    the recording machine, :data:`riverflow.kernels._signatures.COSTS`): the progress of a
    cold compile is the cost done plus, for each kernel being compiled, the time it has run
    (up to 90 % of its cost, scaled to this machine's pace so far), over the total cost."""

    def __init__(self) -> None:
        self.total = 0.0
        self.done = 0.0
        self.running: dict[Any, tuple[float, float]] = {}   # key → (start [s], cost [s])
        self._lock = threading.Lock()
        self._pace = 1.0          # this machine's seconds per recorded second (learnt)
        self._timed = [0.0, 0.0]  # recorded, measured seconds of the kernels finished

    def plan(self, costs: Iterable[float]) -> None:
        with self._lock:
            self.total += sum(costs)

    def start(self, key: Any, cost: float) -> None:
        with self._lock:
            self.running[key] = (time.perf_counter(), cost)

    def finish(self, key: Any, cost: float) -> None:
        with self._lock:
            started = self.running.pop(key, None)
            self.done += cost
            if started is not None and cost > 0:
                self._timed[0] += cost
                self._timed[1] += time.perf_counter() - started[0]
                self._pace = max(self._timed[1] / self._timed[0], 1e-3)

    def fraction(self) -> float:
        with self._lock:
            if self.total <= 0.0:
                return 0.0
            now = time.perf_counter()
            running = sum(min((now - t0) / self._pace, 0.9 * cost)
                          for t0, cost in self.running.values())
            return min((self.done + running) / self.total, 1.0)


class TerminalProgress(CompileProgress):
    """The progress line on a stream (default: stderr): rewritten in place on a terminal, a few
    plain lines otherwise (first compile, every ``every_s`` seconds, the end)."""

    def __init__(self, stream: IO[str] | None = None, every_s: float = 10.0) -> None:
        super().__init__()
        self.stream = stream if stream is not None else sys.stderr
        self.every_s = every_s
        self._printed_s: float | None = None
        try:
            self.tty = bool(self.stream.isatty())
        except (AttributeError, ValueError):
            self.tty = False

    def update(self, done: int, total: int, compiling: bool) -> None:
        super().update(done, total, compiling)
        if not self.compiling or self.stream is None:
            return
        now = time.perf_counter()
        if self.tty:
            self._write(f"\r{self.text}")
        elif self._printed_s is None or now - self._printed_s >= self.every_s:
            self._write(f"{self.text}\n")
        else:
            return
        self._printed_s = now

    def finish(self) -> None:
        super().finish()
        if self._printed_s is None or self.stream is None:
            return
        seconds = time.perf_counter() - self.started_s
        start = "\r" if self.tty else ""
        self._write(f"{start}{self.text} ({seconds:.0f} s)\n")

    def _write(self, text: str) -> None:
        try:
            self.stream.write(text)
            self.stream.flush()
        except (OSError, ValueError):      # a closed or broken stream: go quiet
            self.stream = None


# -- compile events ------------------------------------------------------------------------------

def is_riverflow_kernel(dispatcher: Any) -> bool:
    """A numba dispatcher of a function in ``riverflow/kernels``."""
    module = getattr(getattr(dispatcher, "py_func", None), "__module__", "") or ""
    return module.startswith(_KERNELS + ".")


class CompileCounter:
    """Counts numba compilations (cache misses, not loads) of riverflow kernels, in any thread,
    while installed: ``with CompileCounter() as c: …; c.compiled`` lists ``"module.name"`` per
    compiled signature, helpers compiled for a caller included."""

    def __init__(self, on_start=None) -> None:
        self.compiled: list[str] = []
        self._on_start = on_start
        self._listener = None

    def __enter__(self) -> CompileCounter:
        from numba.core import event

        counter = self

        class _Listener(event.Listener):
            def on_start(self, ev):
                dispatcher = ev.data["dispatcher"]
                if is_riverflow_kernel(dispatcher):
                    f = dispatcher.py_func
                    counter.compiled.append(f"{f.__module__.rpartition('.')[2]}.{f.__qualname__}")
                    if counter._on_start is not None:
                        counter._on_start()

            def on_end(self, ev):
                pass

        self._listener = _Listener()
        event.register("numba:compile", self._listener)
        return self

    def __exit__(self, *exc) -> None:
        from numba.core import event

        event.unregister("numba:compile", self._listener)


# -- the warm-up ---------------------------------------------------------------------------------

@dataclass
class WarmUp:
    """What :func:`compile_kernels` did."""

    kernels: int = 0
    """(kernel, signature) pairs compiled or loaded by this call."""
    compiled: list[str] = field(default_factory=list)
    """Kernels (helpers included) that were really compiled: empty on a warm cache."""
    failed: list[tuple[str, str, str]] = field(default_factory=list)
    """(kernel, signature, error) of recorded signatures that no longer compile (stale)."""
    seconds: float = 0.0


def compile_kernels(*groups: str, progress: CompileProgress | Sequence[CompileProgress] | str
                    | None = "auto", jobs: int | None = None) -> WarmUp:
    """Compile or load the kernels of ``groups`` (module docstring; default: all) with their
    recorded signatures, before a run calls them. ``progress``: ``"auto"`` prints the line
    to stderr when something is compiled; a :class:`CompileProgress` (or several) to draw it
    yourself; None for silence. ``jobs``: processes that compile side by side on a cold cache
    (default: :func:`default_jobs`; 1 compiles here, in this process). Pairs done before in
    this process are skipped, so calling it again is free. With ``NUMBA_DISABLE_JIT=1`` it
    does nothing."""
    return compile_entries(entries(*groups), progress=progress, jobs=jobs)


def default_jobs() -> int:
    """Compiling processes on a cold cache: ``RIVERFLOW_COMPILE_JOBS``, else one per CPU core
    up to 8 (each takes a few hundred MB while it compiles)."""
    text = os.environ.get("RIVERFLOW_COMPILE_JOBS", "")
    if text.strip().isdigit() and int(text) > 0:
        return int(text)
    return max(1, min(os.cpu_count() or 1, 8))


def compile_entries(pairs: Iterable[tuple[str, str]],
                    progress: CompileProgress | Sequence[CompileProgress] | str | None = "auto",
                    jobs: int | None = None) -> WarmUp:
    """:func:`compile_kernels` for given (``"module.function"``, signature text) pairs.

    What the cache holds is loaded first; what it does not is compiled, costliest first (the
    recorded compile times), by ``jobs`` worker processes into the shared cache, then loaded
    here. This process stays light meanwhile (a window keeps drawing). A pair a worker could
    not do is compiled here."""
    start = time.perf_counter()
    todo = [pair for pair in pairs if pair not in _warm]
    report = WarmUp()
    if not todo or _recording or _jit_disabled():
        return report
    if progress == "auto":
        progress = [TerminalProgress()] if sys.stderr is not None else []
    elif progress is None:
        progress = []
    elif isinstance(progress, CompileProgress):
        progress = [progress]
    done = [0]

    def tell(compiling: bool = False) -> None:
        for p in progress:
            p.update(done[0], len(todo), compiling)

    def started(pair) -> None:
        for p in progress:
            p.work.start(pair, _cost(pair[0]))

    def finished_one(pair) -> None:
        for p in progress:
            p.work.finish(pair, _cost(pair[0]))

    with _lock, CompileCounter(on_start=lambda: tell(True)) as counter:
        tell()
        misses = []
        for pair in todo:
            if _load_cached(*pair):
                done[0] += 1
                tell()
            else:
                misses.append(pair)
        if misses:
            for p in progress:
                p.work.plan(_cost(pair[0]) for pair in misses)
            tell(True)
            misses.sort(key=lambda pair: -_cost(pair[0]))
            workers = min(jobs if jobs is not None else default_jobs(), len(misses))
            if workers > 1:
                def one_done(pair, result: dict) -> None:
                    done[0] += 1
                    finished_one(pair)
                    report.compiled.extend(result.get("compiled", []))
                    tell(True)

                finished = _compile_in_workers(misses, workers, one_done, started)
            else:
                finished = set()
            for pair in misses:
                if pair not in finished:
                    started(pair)
                error = _compile_one(*pair)     # loads what a worker made, else compiles
                if error:
                    report.failed.append((*pair, error))
                if pair not in finished:
                    done[0] += 1
                    finished_one(pair)
                    tell()
        _warm.update(todo)
        for p in progress:
            p.finish()
    report.kernels = len(todo)
    report.compiled.extend(counter.compiled)
    report.seconds = time.perf_counter() - start
    return report


def entries(*groups: str) -> list[tuple[str, str]]:
    """The recorded (``"module.function"``, signature) pairs of ``groups`` (default: all), in
    recording order, each once."""
    from riverflow.kernels._signatures import SIGNATURES

    unknown = [g for g in groups if g not in GROUPS]
    if unknown:
        raise ValueError(f"unknown kernel groups {unknown}; known: {', '.join(GROUPS)}")
    seen: dict[tuple[str, str], None] = {}
    for group in groups or GROUPS:
        for name, sigs in SIGNATURES.get(group, {}).items():
            for sig in sigs:
                seen[(name, sig)] = None
    return list(seen)


def dispatcher_of(name: str) -> Any:
    """The dispatcher of ``"module.function"`` in ``riverflow.kernels``."""
    module, _, function = name.rpartition(".")
    return getattr(importlib.import_module(f"{_KERNELS}.{module}"), function)


def _compile_one(name: str, sig: str) -> str:
    """Compile or load one recorded signature; "" or what went wrong."""
    try:
        dispatcher = dispatcher_of(name)
        if not hasattr(dispatcher, "compile"):
            return ""                       # not a dispatcher (NUMBA_DISABLE_JIT)
        dispatcher.compile(decode_signature(sig, dispatcher.py_func.__globals__))
    except Exception as exc:  # noqa: BLE001 - a stale record must never stop a run
        return f"{type(exc).__name__}: {str(exc).splitlines()[0] if str(exc) else ''}"
    return ""


def _load_cached(name: str, sig: str) -> bool:
    """Load one recorded signature's machine code if the cache has it (never compiles);
    whether it is there now. Mirrors numba's ``Dispatcher.compile`` up to its cache load; any
    surprise (another numba) answers False, and the pair is compiled the usual way."""
    try:
        from numba.core.compiler_lock import global_compiler_lock

        dispatcher = dispatcher_of(name)
        if not hasattr(dispatcher, "_cache"):
            return True                     # not a dispatcher (NUMBA_DISABLE_JIT)
        args = decode_signature(sig)
        with global_compiler_lock:
            if dispatcher.overloads.get(args) is not None:
                return True
            cres = dispatcher._cache.load_overload(args, dispatcher.targetctx)
            if cres is None:
                return False
            if not cres.objectmode:
                dispatcher.targetctx.insert_user_function(cres.entry_point, cres.fndesc,
                                                          [cres.library])
            dispatcher.add_overload(cres)
            return True
    except Exception:  # noqa: BLE001 - compile it the public way instead
        return False


def _cost(name: str) -> float:
    """Recorded seconds to compile ``name`` cold (1 when not recorded)."""
    from riverflow.kernels import _signatures

    return getattr(_signatures, "COSTS", {}).get(name, 1.0)


# -- worker processes ----------------------------------------------------------------------------

_PREFIX = "riverflow-warmup "


def _compile_in_workers(pairs: list[tuple[str, str]], workers: int, one_done,
                        one_started=None) -> set:
    """Compile ``pairs`` in ``workers`` processes (each takes the next pair when it is free);
    ``one_started(pair)`` as a worker takes it, ``one_done(pair, result)`` after each.
    Returns the pairs they answered (with or without an
    error); an empty set when no process could be started (a frozen application, no
    interpreter)."""
    import queue
    import subprocess

    from numba.core import config

    if getattr(sys, "frozen", False) or not sys.executable:
        return set()
    env = dict(os.environ)
    if config.CACHE_DIR:
        env["NUMBA_CACHE_DIR"] = str(config.CACHE_DIR)
    root = str(Path(__file__).resolve().parents[2])
    env["PYTHONPATH"] = os.pathsep.join(p for p in (root, env.get("PYTHONPATH", "")) if p)
    todo: queue.Queue = queue.Queue()
    for pair in pairs:
        todo.put(pair)
    finished: set = set()
    guard = threading.Lock()

    def drive() -> None:
        try:
            proc = subprocess.Popen([sys.executable, "-m", f"{_KERNELS}.warmup", "--worker"],
                                    env=env,
                                    stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                    stderr=subprocess.DEVNULL, text=True, bufsize=1)
        except OSError:
            return
        try:
            while True:
                try:
                    pair = todo.get_nowait()
                except queue.Empty:
                    break
                if one_started is not None:
                    one_started(pair)
                proc.stdin.write(json.dumps(pair) + "\n")
                proc.stdin.flush()
                result = None
                for line in proc.stdout:
                    if line.startswith(_PREFIX):
                        result = json.loads(line[len(_PREFIX):])
                        break
                if result is None:          # the worker died: the pair is compiled here
                    break
                with guard:
                    finished.add(pair)
                    one_done(pair, result)
        except (OSError, ValueError):
            pass
        finally:
            try:
                proc.stdin.close()
            except OSError:
                pass
            proc.wait()

    threads = [threading.Thread(target=drive, name=f"riverflow-compile-{k}", daemon=True)
               for k in range(workers)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    return finished


def _worker_main() -> int:
    """A worker process: compile the pairs read from stdin (JSON lines), one answer line each.
    (Workers compile side by side; the cache folders' locks, :mod:`._cache`, keep their
    writes to one helper's index apart.)"""
    for line in sys.stdin:
        name, sig = json.loads(line)
        with CompileCounter() as counter:
            error = _compile_one(name, sig)
        answer = {"name": name, "error": error, "compiled": counter.compiled}
        sys.stdout.write(_PREFIX + json.dumps(answer) + "\n")
        sys.stdout.flush()
    return 0


def _jit_disabled() -> bool:
    from numba.core import config

    return bool(config.DISABLE_JIT)


# -- signatures as text --------------------------------------------------------------------------

def encode_signature(args: Iterable[Any]) -> str:
    """numba argument types → the text kept in ``_signatures.py`` (raises ``TypeError`` for a
    type it cannot write: literals, records, omitted arguments)."""
    return "(" + ", ".join(_encode(t) for t in args) + ("," if len(tuple(args)) == 1 else "") + ")"


def _encode(t: Any) -> str:
    from numba.core import types

    if isinstance(t, types.Array):
        if not isinstance(t.dtype, (types.Integer, types.Float, types.Boolean, types.Complex)):
            raise TypeError(f"cannot record array type {t}")
        extra = ("" if t.mutable else ", readonly=True") + ("" if t.aligned else ", aligned=False")
        return f"A({t.dtype}, {t.ndim}, {t.layout!r}{extra})"
    if isinstance(t, (types.Integer, types.Float, types.Boolean, types.Complex)) \
            and not isinstance(t, types.Literal):
        return str(t)
    if isinstance(t, types.NoneType):
        return "none"
    if isinstance(t, (types.NamedTuple, types.NamedUniTuple)):
        cls = t.instance_class
        return f"Named({cls.__module__}.{cls.__qualname__!s}, ({''.join(_encode(x) + ', ' for x in t.types)}))"
    if isinstance(t, types.UniTuple):
        return f"UniTuple({_encode(t.dtype)}, {t.count})"
    if isinstance(t, types.Tuple):
        return f"Tuple(({''.join(_encode(x) + ', ' for x in t.types)}))"
    raise TypeError(f"cannot record type {t!r}")


def decode_signature(text: str, namespace: dict[str, Any] | None = None) -> tuple[Any, ...]:
    """The text of :func:`encode_signature` → a tuple of numba types. Named tuples' classes are
    found by their dotted path."""
    from numba.core import types

    def array(dtype, ndim, layout, readonly=False, aligned=True):
        return types.Array(dtype, ndim, layout, readonly=readonly, aligned=aligned)

    def named(cls, tys):
        return types.BaseTuple.from_types(tuple(tys), cls)

    def tup(tys):
        return types.BaseTuple.from_types(tuple(tys))

    env: dict[str, Any] = {"A": array, "Named": named, "Tuple": tup,
                           "UniTuple": types.UniTuple, "none": types.none}
    for name in ("bool", "int8", "int16", "int32", "int64", "uint8", "uint16", "uint32",
                 "uint64", "float32", "float64", "complex64", "complex128"):
        env[name] = getattr(types, "boolean" if name == "bool" else name)
    env["riverflow"] = importlib.import_module(_KERNELS.partition(".")[0])
    for module in _named_modules(text):
        importlib.import_module(module)
    return tuple(eval(text, {"__builtins__": {}}, env))  # our own recorded text


def _named_modules(text: str) -> list[str]:
    """Modules named in ``Named(riverflow.a.b.Class, …)`` (imported before evaluating)."""
    out = []
    for part in text.split("Named(")[1:]:
        dotted = part.split(",", 1)[0].strip()
        out.append(dotted.rpartition(".")[0])
    return out


if __name__ == "__main__" and "--worker" in sys.argv[1:]:
    sys.exit(_worker_main())
