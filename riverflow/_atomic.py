"""Atomic output: every file riverflow writes appears complete or not at all (issue #30).

Each file is written under a temporary name in its own folder (same file system, so the
rename is atomic), flushed to disk, and renamed into place only when every file of the group
is complete; on any error the temporaries are removed and nothing of the group is left::

    with atomic_files(image, sidecar) as (tmp_image, tmp_sidecar):
        write_png(tmp_image); tmp_sidecar.write_text(...)   # both renamed at the end

The temporary names keep the final extension (``.flow.png.tmp-1a2b3c.png``), so writers that
choose the format by the extension (Pillow, matplotlib) see the right one. A group of files
is renamed in the order given; should a later rename fail, those already renamed are
removed again (the group stays all or nothing; a pre-existing file of that name is then lost,
which only a failing rename within one folder can cause).

:func:`require_suffix` makes the extension decide the format, or be an error.
"""
from __future__ import annotations

import json
import math
import os
import re
import secrets
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

__all__ = ["atomic_files", "atomic_write_bytes", "atomic_write_text", "require_suffix",
           "remove_temporaries", "strict_json", "writable_path"]


def _temporary(path: Path) -> Path:
    return path.with_name(f".{path.name}.tmp-{secrets.token_hex(4)}{path.suffix}")


_TEMPORARY = re.compile(r"^\..+\.tmp-[0-9a-f]{8}(\.[^.]*)?$")


def remove_temporaries(folder: str | os.PathLike) -> int:
    """Remove the temporaries of :func:`atomic_files` under ``folder`` (every depth) that a
    writer killed mid-write left behind (a SIGKILLed worker process: nothing of it runs to
    clean up); returns how many. Only for a folder no one else is writing into now (a bake's
    own output once its workers are done)."""
    n = 0
    for path in Path(folder).rglob(".*.tmp-*"):
        if _TEMPORARY.match(path.name) and path.is_file():
            path.unlink(missing_ok=True)
            n += 1
    return n


def _sync(path: Path) -> None:
    """Flush a finished temporary to disk (so a crash cannot rename an empty file in)."""
    try:
        fd = os.open(path, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


def writable_path(path: str | os.PathLike, *, folder: bool = False) -> Path:
    """``path`` as a Path after checking, before any work, that a file (``folder``: a folder)
    can be written there: not a folder where a file is meant (or a file where a folder is),
    its nearest existing folder above a folder and writable (an empty file is made there and
    removed). Raises an OSError naming the path and what is in the way; returns the path."""
    p = Path(path)
    if folder and p.exists() and not p.is_dir():
        raise NotADirectoryError(f"{p}: is a file, expected a folder")
    if not folder and p.is_dir():
        raise IsADirectoryError(f"{p}: is a folder, expected a file name")
    above = p if folder else p.parent
    above = above if str(above) else Path(".")
    while not above.exists() and above != above.parent:
        above = above.parent
    if not above.is_dir():
        raise NotADirectoryError(f"cannot write {p}: {above} is a file, not a folder")
    probe = above / f".riverflow-probe-{secrets.token_hex(4)}"
    try:                   # a real try: os.access says yes to root on a read-only file system
        os.close(os.open(probe, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o600))
    except OSError as exc:
        raise PermissionError(exc.errno, f"cannot write {p}: the folder {above} is not "
                                         f"writable ({exc.strerror or exc})") from None
    probe.unlink(missing_ok=True)
    return p


@contextmanager
def atomic_files(*paths: str | os.PathLike) -> Iterator[list[Path]]:
    """Temporary paths to write ``paths`` through; renamed into place when the block ends
    without an error, removed when it raises (module docstring). Makes the folders."""
    finals = [Path(p) for p in paths]
    for final in finals:
        writable_path(final)
        try:
            final.parent.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise type(exc)(exc.errno, f"cannot write {final}: cannot make its folder: "
                                       f"{exc.strerror or exc}") from None
    temps = [_temporary(p) for p in finals]
    done: list[Path] = []
    try:
        yield temps
        for temp, final in zip(temps, finals):
            if not temp.exists():
                raise OSError(f"{final}: nothing was written")
            _sync(temp)
        for temp, final in zip(temps, finals):
            os.replace(temp, final)
            done.append(final)
    except BaseException as exc:
        for temp in temps:
            temp.unlink(missing_ok=True)
        for final in done:                   # a later rename failed: all or nothing
            final.unlink(missing_ok=True)
        named = getattr(exc, "filename", None)
        if isinstance(exc, OSError) and named is not None and exc.strerror:
            for temp, final in zip(temps, finals):   # name the file asked for, not a temporary
                if os.fspath(named) == os.fspath(temp):
                    raise type(exc)(exc.errno, f"cannot write {final}: {exc.strerror}") \
                        from None
        raise


def atomic_write_bytes(path: str | os.PathLike, data: bytes) -> Path:
    """Write ``data`` to ``path`` atomically; returns the path."""
    with atomic_files(path) as (temp,):
        with open(temp, "wb") as f:
            f.write(data)
    return Path(path)


def atomic_write_text(path: str | os.PathLike, text: str) -> Path:
    """Write UTF-8 ``text`` to ``path`` atomically; returns the path."""
    return atomic_write_bytes(path, text.encode("utf-8"))


def require_suffix(path: str | os.PathLike, allowed: dict[str, str] | tuple[str, ...],
                   what: str) -> str:
    """The format a file name's extension names (case-insensitive), or a ValueError naming
    the file and the extensions ``what`` can be written as. ``allowed`` maps extensions
    (".png") to format names, or is a tuple of extensions (their own names)."""
    table = allowed if isinstance(allowed, dict) else {s: s.lstrip(".") for s in allowed}
    suffix = Path(path).suffix.lower()
    if suffix not in table:
        raise ValueError(f"{os.fspath(path)!s}: {what} can be written as "
                         f"{', '.join(sorted(table))} only, not {suffix or 'a file without an extension'}"
                         " (the extension decides the format)")
    return table[suffix]


def strict_json(obj, *, where: str, **dumps_options) -> str:
    """``json.dumps`` that refuses NaN and infinities (they are not JSON), naming the key."""
    bad = _non_finite(obj, "")
    if bad is not None:
        raise ValueError(f"{where}: {bad[0] or 'the value'} is {bad[1]!r}, which JSON cannot hold "
                         "(a finite number is needed)")
    return json.dumps(obj, allow_nan=False, **dumps_options)


def _non_finite(obj, key: str):
    if isinstance(obj, float):
        return None if math.isfinite(obj) else (key, obj)
    if isinstance(obj, dict):
        for k, v in obj.items():
            found = _non_finite(v, f"{key}.{k}" if key else str(k))
            if found is not None:
                return found
    elif isinstance(obj, (list, tuple)):
        for i, v in enumerate(obj):
            found = _non_finite(v, f"{key}[{i}]")
            if found is not None:
                return found
    return None
