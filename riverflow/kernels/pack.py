"""The kernel pack: riverflow's kernels compiled ahead of time for a portable CPU target and
shipped inside the package, so a new install draws its first frame without compiling.

numba keys its cached machine code on the CPU it was compiled for (name and features). Code
compiled for the host (numba's default) is valid on that CPU model only; code compiled for a
named baseline, ``x86-64-v3`` (AVX2, FMA, BMI2: nearly every x86 CPU since 2015), runs on every
CPU that has those features. The pack is that code: a copy of the keyed cache folders
(:mod:`riverflow.kernels._cache`) of every kernel module, compiled for :data:`TARGET` with the
recorded signatures of every warm-up group (:mod:`riverflow.kernels.warmup`), in
``riverflow/kernels/_pack/``, with ``manifest.json`` (the target, the features the CPU needs,
each file's SHA-256).

At import (:func:`choose_target`, from ``riverflow/kernels/__init__.py``, before any kernel is
made) a process whose CPU has the pack's features, and whose user did not choose a CPU
(``NUMBA_CPU_NAME``), compiles for the pack's target: numba's configuration is set, for this
process and the processes it starts (``NUMBA_CPU_NAME``/``NUMBA_CPU_FEATURES`` in
``os.environ``). That applies to every numba function of the process, the host program's too:
set ``RIVERFLOW_KERNEL_PACK=0`` to keep host-tuned code (the first run then compiles, as
without a pack). When a kernel module's keyed folder is made in the user's cache, the
locator fills it from the pack (:func:`seed`) if the pack has a folder of the same name: the
name is the hash of the module's sources and of the toolchain (numba, llvmlite, numpy and
Python versions, CPU target), so a pack built from other sources or for another toolchain is
never loaded (those modules compile, with the progress line); a file whose hash differs from
the manifest's leaves its module out of the pack. Nothing here raises: a pack that cannot be
read is a pack that is not there.

The pack is built, not committed: ``tools/build_kernel_pack.py`` (``make pack``) compiles
every recorded signature for :data:`TARGET` in a new cache folder, with the warm-up's worker
processes, and writes ``riverflow/kernels/_pack/``; a wheel built afterwards carries it
(package data). A build of the pack after a kernel edit makes a new one; a pack left from an
older build is harmless (its names no longer match) and ``make pack`` replaces it.
"""
from __future__ import annotations

import hashlib
import json
import os
import shutil
import sys
import tempfile
from functools import lru_cache
from pathlib import Path

TARGET = "x86-64-v3"
"""The CPU the pack is compiled for (an LLVM CPU name; the features are the name's own)."""
TARGET_FEATURES = ("avx", "avx2", "bmi", "bmi2", "cmov", "cx16", "cx8", "f16c", "fma", "fxsr",
                   "lzcnt", "mmx", "movbe", "popcnt", "sahf", "sse", "sse2", "sse3", "sse4.1",
                   "sse4.2", "ssse3", "xsave")
"""What a CPU needs to run :data:`TARGET` code (the x86-64-v3 level, as LLVM names them)."""
PACK_DIR = Path(__file__).resolve().parent / "_pack"
MANIFEST = "manifest.json"
FORMAT = 1
ENV_SWITCH = "RIVERFLOW_KERNEL_PACK"
"""``RIVERFLOW_KERNEL_PACK=0``: neither use the pack nor change numba's CPU target;
``RIVERFLOW_KERNEL_PACK=/a/folder``: use the pack in that folder instead of the package's."""


def pack_dir() -> Path | None:
    """The pack in use: the package's, the one ``RIVERFLOW_KERNEL_PACK`` names, or None."""
    value = os.environ.get(ENV_SWITCH, "").strip()
    if value.lower() in ("0", "no", "false", "off"):
        return None
    return Path(value) if value and value != "1" else PACK_DIR


def manifest() -> dict | None:
    """The manifest of the pack in use, or None (no pack, an unreadable or foreign one)."""
    where = pack_dir()
    return None if where is None else _read_manifest(where)


@lru_cache(maxsize=4)
def _read_manifest(where: Path) -> dict | None:
    try:
        data = json.loads((where / MANIFEST).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    if not isinstance(data, dict) or data.get("format") != FORMAT \
            or not isinstance(data.get("folders"), dict):
        return None
    return data


def host_has(features) -> bool:
    """Whether this CPU has every one of ``features`` (LLVM's names)."""
    try:
        from numba.core.codegen import get_host_cpu_features

        have = {f[1:] for f in get_host_cpu_features().split(",") if f.startswith("+")}
    except Exception:  # noqa: BLE001 - no feature list: assume nothing
        return False
    return set(features) <= have


def choose_target() -> str | None:
    """Make this process compile for the pack's CPU target when the pack can be used (module
    docstring); returns the target chosen, or None (numba's own choice stays). Must run before
    numba's CPU codegen is made (before any numba function is compiled); when it was made
    already, nothing changes."""
    try:
        data = manifest()
        if data is None or os.environ.get("NUMBA_CPU_NAME"):
            return None
        import llvmlite.binding as ll
        from numba.core import config, registry

        if data.get("triple") != ll.get_process_triple() \
                or not host_has(data.get("requires", ())):
            return None
        if "_toplevel_target_context" in vars(registry.cpu_target):
            return None                    # numba compiled something already: too late
        name, features = data["cpu_name"], data.get("cpu_features", "")
        os.environ["NUMBA_CPU_NAME"] = name           # numba's reload keeps it; workers inherit
        os.environ["NUMBA_CPU_FEATURES"] = features
        config.reload_config()
        config.CPU_NAME, config.CPU_FEATURES = name, features
        return name
    except Exception:  # noqa: BLE001 - never stop an import over the pack
        return None


_seeded: set[str] = set()


def seed(folder: Path) -> int:
    """Fill the keyed cache ``folder`` from the pack's folder of the same name when the pack has
    one and ``folder`` holds no index yet; returns the files copied (0: nothing to do, or a file
    of the pack is damaged: then nothing is copied and the kernels compile). The caller holds
    the folder's lock."""
    key = str(folder)
    if key in _seeded:
        return 0
    _seeded.add(key)
    try:
        data, where = manifest(), pack_dir()
        if data is None:
            return 0
        files = data["folders"].get(folder.name)
        if not files or any(folder.glob("*.nbi")):
            return 0
        blobs = {}
        for name, digest in files.items():
            if Path(name).name != name:
                return 0                   # a manifest naming other places: not ours
            blob = (where / folder.name / name).read_bytes()
            if hashlib.sha256(blob).hexdigest() != digest:
                return 0
            blobs[name] = blob
        # data files first, the indexes last: an index never names a file not yet there
        for name in sorted(blobs, key=lambda n: n.endswith(".nbi")):
            fd, tmp = tempfile.mkstemp(dir=folder, prefix=".seed-")
            with os.fdopen(fd, "wb") as f:
                f.write(blobs[name])
            os.replace(tmp, folder / name)
        return len(blobs)
    except Exception:  # noqa: BLE001 - a pack that cannot be read is no pack
        return 0


# -- building the pack ---------------------------------------------------------------------------

def build(out: Path = PACK_DIR, jobs: int | None = None) -> dict:
    """Compile every recorded signature for :data:`TARGET` in a new cache folder (in worker
    processes) and write the pack to ``out`` (replaced). Returns the manifest."""
    import subprocess

    with tempfile.TemporaryDirectory(prefix="riverflow-pack-") as tmp:
        env = {k: v for k, v in os.environ.items() if not k.startswith("NUMBA_")}
        env.update(NUMBA_CPU_NAME=TARGET, NUMBA_CPU_FEATURES="", XDG_CACHE_HOME=tmp,
                   **{ENV_SWITCH: "0"})
        if jobs:
            env["RIVERFLOW_COMPILE_JOBS"] = str(jobs)
        root = str(Path(__file__).resolve().parents[2])
        env["PYTHONPATH"] = os.pathsep.join(p for p in (root, env.get("PYTHONPATH", "")) if p)
        code = ("import json, llvmlite.binding as ll\n"
                "from riverflow.kernels import warmup\n"
                "r = warmup.compile_kernels(progress='auto')\n"
                "print('PACK', json.dumps({'failed': r.failed, 'triple': "
                "ll.get_process_triple()}))\n")
        proc = subprocess.run([sys.executable, "-c", code], env=env, stdout=subprocess.PIPE,
                              text=True, check=True)
        result = json.loads(next(line for line in proc.stdout.splitlines()
                                 if line.startswith("PACK "))[5:])
        if result["failed"]:
            raise RuntimeError(f"kernels that did not compile for the pack: {result['failed']}")
        data = write(Path(tmp) / "riverflow" / "kernels", out, result["triple"])
    return data


def write(cache: Path, out: Path, triple: str, cpu_name: str = TARGET,
          requires=TARGET_FEATURES) -> dict:
    """Write the pack of the keyed cache folders in ``cache`` (compiled for ``cpu_name``) to
    ``out``, replacing it; returns the manifest."""
    folders = {}
    out.parent.mkdir(parents=True, exist_ok=True)
    staging = Path(tempfile.mkdtemp(prefix="_pack-", dir=out.parent))
    try:
        for folder in sorted(p for p in cache.iterdir() if p.is_dir()):
            files = {}
            for f in sorted(folder.iterdir()):
                if f.suffix in (".nbi", ".nbc"):
                    (staging / folder.name).mkdir(exist_ok=True)
                    shutil.copy2(f, staging / folder.name / f.name)
                    files[f.name] = hashlib.sha256(f.read_bytes()).hexdigest()
            if files:
                folders[folder.name] = files
        data = {"format": FORMAT, "cpu_name": cpu_name, "cpu_features": "",
                "requires": list(requires), "triple": triple, "folders": folders}
        (staging / MANIFEST).write_text(json.dumps(data, indent=1, sort_keys=True),
                                        encoding="utf-8")
        shutil.rmtree(out, ignore_errors=True)
        os.replace(staging, out)
    except BaseException:
        shutil.rmtree(staging, ignore_errors=True)
        raise
    _read_manifest.cache_clear()
    return data


def main(argv: list[str] | None = None) -> int:
    import argparse
    import time

    parser = argparse.ArgumentParser(description="build riverflow's kernel pack "
                                     f"(the kernels compiled for {TARGET})")
    parser.add_argument("--out", type=Path, default=PACK_DIR)
    parser.add_argument("--jobs", type=int, default=None,
                        help="compiling processes (default: one per core, up to 8)")
    args = parser.parse_args(argv)
    start, cpu = time.perf_counter(), os.times()
    data = build(args.out, args.jobs)
    end = os.times()
    size = sum(f.stat().st_size for f in args.out.rglob("*") if f.is_file())
    compile_cpu = end.children_user + end.children_system \
        - cpu.children_user - cpu.children_system
    print(f"wrote {args.out}: {len(data['folders'])} kernel modules, {size / 1e6:.1f} MB, "
          f"for {data['cpu_name']} in {time.perf_counter() - start:.1f} s "
          f"({compile_cpu:.1f} s of compile CPU)")
    return 0
