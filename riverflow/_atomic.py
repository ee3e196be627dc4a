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
import secrets
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

__all__ = ["atomic_files", "atomic_write_bytes", "atomic_write_text", "require_suffix",
           "strict_json"]


def _temporary(path: Path) -> Path:
    return path.with_name(f".{path.name}.tmp-{secrets.token_hex(4)}{path.suffix}")


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


@contextmanager
def atomic_files(*paths: str | os.PathLike) -> Iterator[list[Path]]:
    """Temporary paths to write ``paths`` through; renamed into place when the block ends
    without an error, removed when it raises (module docstring). Makes the folders."""
    finals = [Path(p) for p in paths]
    for final in finals:
        if final.is_dir():
            raise IsADirectoryError(f"{final}: is a folder, expected a file name")
        final.parent.mkdir(parents=True, exist_ok=True)
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
    except BaseException:
        for temp in temps:
            temp.unlink(missing_ok=True)
        for final in done:                   # a later rename failed: all or nothing
            final.unlink(missing_ok=True)
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
