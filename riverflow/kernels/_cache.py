"""Where the kernels' machine code is kept: one folder per user, keyed so that stale code cannot load.

numba's own cache (``cache=True``) keys an entry on the source of the function's own file
only: an edit of an ``@njit`` helper in another module, or of a constant imported from one,
leaves its callers' cached machine code in place (``reference/ecosystem.md`` §3.1). Here each
kernel module keeps its entries in a folder of its own, named after a hash of

* its source and the source of every riverflow module it imports, directly or through other
  modules (helpers and the constants numba freezes into the machine code), and
* the numba, llvmlite, numpy and Python versions and the CPU target (triple, name, features),
  and :data:`NAMING` (how the machine code's function names are made unique),

so an edit anywhere in what a kernel is compiled from gives a new folder and the kernel is
compiled again; a module whose closure did not change keeps its machine code. A new folder is
first filled from the package's kernel pack when the pack has a folder of the same name
(:mod:`riverflow.kernels.pack`: the kernels compiled ahead of time for a portable CPU).

The folders live in ``$NUMBA_CACHE_DIR/riverflow`` when ``NUMBA_CACHE_DIR`` is set (the user's
choice of place wins; the key still picks the folder inside it), else in the platform's user
cache folder: ``$XDG_CACHE_HOME/riverflow/kernels`` (``~/.cache/…``) on Linux,
``~/Library/Caches/riverflow/kernels`` on macOS, ``%LOCALAPPDATA%\\riverflow\\Cache\\kernels`` on
Windows; a temporary folder when that cannot be written. When a module's folder is made, the
older folders of that module are pruned: the :data:`KEEP` most recently used stay.

:func:`install` puts the locator in front of numba's own; ``riverflow/kernels/__init__.py``
calls it, so it is in place before any kernel is decorated, whatever the entry point (the
command line, a demo, ``import riverflow`` in a script, the tests).
"""
from __future__ import annotations

import ast
import contextlib
import hashlib
import os
import secrets
import shutil
import sys
import tempfile
import time
from functools import cache, lru_cache
from pathlib import Path

KEEP = 3
"""Folders kept per kernel module (the current one and the most recently used others)."""

KERNELS_DIR = Path(__file__).resolve().parent
"""``riverflow/kernels``: the kernels of every ``@njit(cache=True)`` in this folder are kept here."""
_ROOT = KERNELS_DIR.parent.parent       # the folder that holds the ``riverflow`` package
_PACKAGE = KERNELS_DIR.parent.name      # "riverflow"


def cache_root() -> Path:
    """The folder that holds the keyed kernel folders (module docstring)."""
    from numba.core import config

    if config.CACHE_DIR:
        return Path(config.CACHE_DIR).expanduser() / _PACKAGE
    try:
        home = Path.home()
    except (RuntimeError, KeyError):      # no home folder (a service account, a container)
        return _fallback_root()
    if sys.platform == "win32":
        local = os.environ.get("LOCALAPPDATA")
        return (Path(local) if local else home / "AppData" / "Local") / _PACKAGE / "Cache" \
            / "kernels"
    if sys.platform == "darwin":
        return home / "Library" / "Caches" / _PACKAGE / "kernels"
    xdg = os.environ.get("XDG_CACHE_HOME", "")
    return (Path(xdg) if os.path.isabs(xdg) else home / ".cache") / _PACKAGE / "kernels"


def kernel_folder(py_file: str | os.PathLike) -> Path | None:
    """The keyed folder for the kernels of ``py_file``, or None when it is not a riverflow
    kernel module."""
    path = Path(py_file).resolve()
    if path.parent != KERNELS_DIR or path.suffix != ".py":
        return None
    return cache_root() / f"{path.stem}-{module_key(str(path))}"


@cache
def module_key(py_file: str) -> str:
    """16 hex digits: the sources ``py_file`` is compiled from and the toolchain (module
    docstring)."""
    digest = hashlib.sha256(_toolchain().encode())
    for dep in sorted(source_closure(py_file)):
        digest.update(b"\0" + os.path.relpath(dep, _ROOT).replace(os.sep, "/").encode() + b"\0")
        digest.update(Path(dep).read_bytes())
    return digest.hexdigest()[:16]


@lru_cache(maxsize=1)
def _toolchain() -> str:
    import llvmlite
    import llvmlite.binding as ll
    import numba
    import numpy
    from numba.core import config
    from numba.core.codegen import get_host_cpu_features

    cpu = config.CPU_NAME or ll.get_host_cpu_name()
    features = config.CPU_FEATURES if config.CPU_FEATURES is not None \
        else get_host_cpu_features()
    return "|".join((numba.__version__, llvmlite.__version__, numpy.__version__,
                     sys.implementation.cache_tag or "", getattr(sys, "abiflags", ""),
                     ll.get_process_triple(), cpu, features, NAMING))


def source_closure(py_file: str) -> set[str]:
    """``py_file`` and every riverflow module it imports, directly or not (by reading the
    import statements: a module imported inside a function counts too)."""
    seen: set[str] = set()
    todo = [str(Path(py_file).resolve())]
    while todo:
        file = todo.pop()
        if file in seen:
            continue
        seen.add(file)
        todo.extend(_imported_files(file))
    return seen


@lru_cache(maxsize=None)
def _imported_files(py_file: str) -> tuple[str, ...]:
    """The riverflow modules ``py_file`` imports (each file is read and parsed once a process:
    the kernel modules' closures share most of their files)."""
    source = Path(py_file).read_text(encoding="utf-8")
    package = _module_name(py_file).rpartition(".")[0]
    if Path(py_file).name == "__init__.py":
        package = _module_name(py_file)
    found: list[str] = []
    for node in ast.walk(ast.parse(source, py_file)):
        if isinstance(node, ast.Import):
            names = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                parts = package.split(".")
                parts = parts[:len(parts) - node.level + 1]
                base = ".".join(p for p in (*parts, base) if p)
            # "from a.b import c": c may be a module (a/b/c.py) or a name in a/b
            names = [base, *(f"{base}.{alias.name}" for alias in node.names)]
        else:
            continue
        for name in names:
            if name == _PACKAGE or name.startswith(_PACKAGE + "."):
                file = _module_file(name)
                if file is not None:
                    found.append(file)
    return tuple(found)


def _module_name(py_file: str) -> str:
    rel = Path(py_file).resolve().relative_to(_ROOT).with_suffix("")
    parts = rel.parts[:-1] if rel.name == "__init__" else rel.parts
    return ".".join(parts)


def _module_file(name: str) -> str | None:
    """The file of module ``name`` under the package root; packages' ``__init__`` files are
    left out (importing ``a.b.c`` runs them, but a kernel uses only what it names)."""
    file = _ROOT.joinpath(*name.split(".")).with_suffix(".py")
    return str(file) if file.is_file() else None


# -- the locator ---------------------------------------------------------------------------------

_made: set[str] = set()
"""Folders checked (made, written to, pruned) by this process."""


def _prepare(folder: Path) -> bool:
    """Make ``folder`` (pruning the module's old folders when it is new) and check it can be
    written; mark it used. False when it cannot be written."""
    key = str(folder)
    if key in _made and folder.is_dir():
        return True
    try:
        new = not folder.is_dir()
        folder.mkdir(parents=True, exist_ok=True)
        tempfile.TemporaryFile(dir=folder).close()
        os.utime(folder)                 # "last used": pruning keeps the newest
    except OSError:
        return False
    _made.add(key)
    _made_roots.add(str(folder.parent))
    if new:
        prune(folder)
    return True


def prune(folder: Path, keep: int = KEEP) -> list[Path]:
    """Remove the folders of ``folder``'s module but the ``keep`` most recently used (the
    current one always stays); returns what was removed. Errors are ignored: another process
    may be pruning too, and numba makes a removed folder again when it next writes to it."""
    module = folder.name.rpartition("-")[0]
    try:
        siblings = [p for p in folder.parent.iterdir()
                    if p.is_dir() and p != folder and p.name.rpartition("-")[0] == module
                    and len(p.name.rpartition("-")[2]) == 16]
        siblings.sort(key=lambda p: p.stat().st_mtime, reverse=True)
    except OSError:
        return []
    removed = siblings[keep - 1:]
    for p in removed:
        shutil.rmtree(p, ignore_errors=True)
    return removed


def _locator_class():
    from numba.core import caching

    base = caching._CacheLocator

    class RiverflowKernelLocator(base):
        """numba cache locator for riverflow's kernel modules: the keyed folder of the module
        (module docstring); other functions go on to numba's own locators."""

        def __init__(self, py_func, py_file, folder: Path) -> None:
            self._py_file = py_file
            self._lineno = py_func.__code__.co_firstlineno
            self._cache_path = str(folder)

        def ensure_cache_path(self) -> None:
            if not _prepare(Path(self._cache_path)):
                raise OSError(f"cannot write the kernel cache folder {self._cache_path}")

        def get_cache_path(self) -> str:
            return self._cache_path

        def get_source_stamp(self):
            # the folder's key already covers the file; its hash keeps numba's check exact
            return hashlib.sha256(Path(self._py_file).read_bytes()).hexdigest()

        def get_disambiguator(self) -> str:
            return str(self._lineno)

        @classmethod
        def from_function(cls, py_func, py_file):
            try:
                folder = kernel_folder(py_file)
            except Exception:  # noqa: BLE001 - no home, a zipped install: numba's own then
                return None
            if folder is None:
                return None
            for candidate in (folder, _fallback_root() / folder.name):
                if _prepare(candidate):
                    _seed(candidate)
                    return cls(py_func, py_file, candidate)
            return None

    return RiverflowKernelLocator


def _seed(folder: Path) -> None:
    """Fill a new keyed folder from the package's kernel pack, when the pack has its name
    (:mod:`riverflow.kernels.pack`); under the folder's lock, so processes starting together
    fill it once."""
    from riverflow.kernels import pack

    if pack.manifest() is None:
        return
    with _folder_lock(str(folder)):
        pack.seed(folder)


def _fallback_root() -> Path:
    try:
        user = str(os.getuid())
    except AttributeError:   # Windows
        user = os.environ.get("USERNAME", "user")
    return Path(tempfile.gettempdir()) / f"{_PACKAGE}-{user}" / "kernels"


_installed = None


def install() -> None:
    """Put riverflow's kernel locator in front of numba's, lock riverflow's folders around
    numba's index updates, and give compiled functions names no other process gives
    (:func:`_name_functions_uniquely`) (idempotent). Only functions of
    ``riverflow/kernels/*.py`` get the locator; the user's own ``cache=True`` functions keep
    numba's locators, and ``NUMBA_CACHE_LOCATOR_CLASSES`` still overrides everything."""
    global _installed
    if _installed is not None:
        return
    from numba.core import caching

    impl = getattr(caching, "CacheImpl", None) or caching._CacheImpl
    _installed = _locator_class()
    impl._locator_classes.insert(0, _installed)
    _lock_index_updates(caching)
    _name_functions_uniquely()


# -- names of compiled functions -----------------------------------------------------------------

NAMING = "uid=random64"
"""How this module makes compiled functions' names unique across processes (part of every
folder's key: machine code cached before, whose names may clash, is never loaded)."""


class RandomIds:
    """An endless iterator of random 64-bit numbers (the operating system's randomness: a
    forked child draws other numbers than its parent and siblings)."""

    def __iter__(self) -> RandomIds:
        return self

    def __next__(self) -> int:
        return secrets.randbits(64)


def _name_functions_uniquely() -> None:
    """Number the functions numba compiles from now on with random 64-bit ids instead of its
    per-process counter (1, 2, 3, …).

    numba names a compiled function by module, qualified name, argument types and that id
    (``…run_quicksort1B3v16…``), and every library that calls a helper carries its own copy
    under that name, as a weak symbol. When machine code compiled by several processes is
    loaded into one (the warm-up's worker processes, a later run filling the cache further,
    the cache of an earlier run), LLVM's linker takes the first definition of a name for all
    of them, which is right only if equal names mean equal code. The counter breaks that:
    two processes give the same number to different functions of the same name, e.g. numba's
    quicksort behind ``np.sort`` and behind ``np.argsort`` of an int64 array, and a kernel then
    calls another kernel's helper. That is how ``tile_cut.cut_standins`` segfaulted (it got
    ``np.sort``'s helper, which returns the sorted keys, not their order; loaded the other way
    round, ``tile_cut.coarser_across``'s ``np.sort`` gets ``np.argsort``'s, which its answers
    happen not to show). Random ids make equal names mean equal code
    (``tests/kernels/test_kernel_cache.py``). numba issue 10486 is this bug; numba 0.68 has no
    fix of its own. Applies to every function the process compiles after riverflow is
    imported (numba uses the ids only in names)."""
    try:
        from numba.core.bytecode import FunctionIdentity
    except ImportError:          # another numba: nothing to replace
        return
    if hasattr(FunctionIdentity, "_unique_ids") \
            and not isinstance(FunctionIdentity._unique_ids, RandomIds):
        FunctionIdentity._unique_ids = RandomIds()


def _lock_index_updates(caching) -> None:
    """Processes compiling at the same time (the warm-up's workers, two programs started
    together) may add different signatures of one helper to its index at once: numba's
    read-modify-write of the index could then name one data file for both, and a signature
    would load the other's machine code. Saves and loads in riverflow's folders hold the
    folder's lock file. Wrapped once per process, whatever imports this module (a second
    copy of riverflow imported from another path would otherwise take the lock again inside
    its own hold, and a second flock of one file in one process waits for ever)."""
    cls = getattr(caching, "IndexDataCacheFile", None)
    if cls is None or not hasattr(cls, "save") or not hasattr(cls, "load") \
            or getattr(cls.save, "riverflow_locked", False):
        return
    save, load = cls.save, cls.load

    def locked_save(self, key, data):
        with _folder_lock(getattr(self, "_cache_path", "")):
            return save(self, key, data)

    def locked_load(self, key):
        with _folder_lock(getattr(self, "_cache_path", "")):
            return load(self, key)

    locked_save.riverflow_locked = locked_load.riverflow_locked = True
    cls.save, cls.load = locked_save, locked_load


@contextlib.contextmanager
def _folder_lock(folder: str, wait_s: float = 60.0):
    """Hold ``folder/.lock`` (only riverflow's kernel folders; others pass through). Gives up
    waiting after ``wait_s`` (a lock left by a killed process on a system without advisory
    locks): numba's writes stay atomic, only the index merge is unguarded then."""
    if not folder or str(_made_root(folder)) not in _made_roots:
        yield
        return
    try:
        f = open(os.path.join(folder, ".lock"), "a+b")  # noqa: SIM115 - held for the block
    except OSError:
        yield
        return
    try:
        if os.name == "nt":
            import msvcrt

            end = time.monotonic() + wait_s
            locked = False
            while not locked and time.monotonic() < end:
                try:
                    msvcrt.locking(f.fileno(), msvcrt.LK_LOCK, 1)   # retries for ~10 s itself
                    locked = True
                except OSError:
                    pass
            try:
                yield
            finally:
                if locked:
                    f.seek(0)
                    msvcrt.locking(f.fileno(), msvcrt.LK_UNLCK, 1)
        else:
            import fcntl

            end = time.monotonic() + wait_s
            locked = False
            while True:
                try:
                    fcntl.flock(f.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
                    locked = True
                    break
                except OSError:
                    if time.monotonic() >= end:
                        break
                    time.sleep(0.01)
            try:
                yield
            finally:
                if locked:
                    fcntl.flock(f.fileno(), fcntl.LOCK_UN)
    finally:
        f.close()


_made_roots: set[str] = set()
"""Parents of the kernel folders this process uses (where the locks apply)."""


def _made_root(folder: str | os.PathLike) -> Path:
    return Path(folder).parent
