"""A real package: the wheel built from the sources holds every module, the shaders and the
license, its metadata is current (PEP 639), and installed (not editable) into a fresh venv it
renders a frame headless from a folder outside the checkout. Nothing is downloaded: the wheel
is built without isolation (setuptools from the test extra) and installed with --no-index,
the dependencies read from this interpreter's site-packages."""
from __future__ import annotations

import os
import shutil
import site
import subprocess
import sys
import venv
import zipfile
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


def _setuptools_version() -> tuple[int, ...]:
    try:
        from importlib.metadata import version

        return tuple(int(p) for p in version("setuptools").split(".")[:2] if p.isdigit())
    except Exception:  # noqa: BLE001 - not installed or an odd version string
        return (0,)


@pytest.fixture(scope="module")
def wheel(tmp_path_factory) -> Path:
    """The wheel of a copy of the sources (pyproject, README, LICENSE, riverflow/)."""
    return _wheel(tmp_path_factory.mktemp("package"))


def _wheel(tmp: Path, pack: dict[str, bytes] | None = None) -> Path:
    """Build the wheel of a copy of the sources in ``tmp``; ``pack``: files to put in
    ``riverflow/kernels/_pack/`` first (a stand-in for what ``make pack`` writes)."""
    if _setuptools_version() < (77,):
        pytest.skip("building without isolation needs setuptools>=77 here "
                    "(pip install -e '.[test]')")
    src = tmp / "src"
    src.mkdir()
    for name in ("pyproject.toml", "README.md", "LICENSE"):
        shutil.copy2(REPO / name, src / name)
    shutil.copytree(REPO / "riverflow", src / "riverflow",
                    ignore=shutil.ignore_patterns("__pycache__", "*.pyc", "*.nbi", "*.nbc",
                                                  "_pack"))   # a kernel pack `make pack` left
    for name, blob in (pack or {}).items():
        path = src / "riverflow" / "kernels" / "_pack" / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_bytes(blob)
    result = subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps",
                             "--no-build-isolation", "--no-index", "-w", str(tmp / "dist"),
                             str(src)], capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stdout + result.stderr
    said = (result.stdout + result.stderr).lower()
    assert "deprecat" not in said, result.stdout + result.stderr
    (built,) = (tmp / "dist").glob("riverflow-*.whl")
    return built


@pytest.mark.slow
def test_the_wheel_holds_every_module_the_shaders_and_the_license(wheel):
    names = set(zipfile.ZipFile(wheel).namelist())
    sources = {p.relative_to(REPO).as_posix() for p in (REPO / "riverflow").rglob("*")
               if p.suffix in (".py", ".glsl", ".js", ".css") and "__pycache__" not in p.parts}
    assert sources <= names, sorted(sources - names)
    assert "riverflow/py.typed" in names
    assert "riverflow/web/leaflet/LICENSE" in names          # riverflow view's Leaflet
    info = next(n for n in names if n.endswith(".dist-info/METADATA"))
    metadata = zipfile.ZipFile(wheel).read(info).decode()
    assert "License-Expression: BSD-3-Clause" in metadata
    assert "License-File: LICENSE" in metadata
    assert any(n.endswith(".dist-info/licenses/LICENSE") for n in names)
    entry = next(n for n in names if n.endswith(".dist-info/entry_points.txt"))
    assert "riverflow = riverflow.__main__:main" in zipfile.ZipFile(wheel).read(entry).decode()


@pytest.mark.slow
def test_a_wheel_built_after_make_pack_carries_the_kernel_pack(tmp_path):
    pack = {"manifest.json": b"{}", "flow-0123456789abcdef/flow.f-10.py311.nbi": b"index",
            "flow-0123456789abcdef/flow.f-10.py311.0.nbc": b"code"}
    names = set(zipfile.ZipFile(_wheel(tmp_path, pack)).namelist())
    assert {f"riverflow/kernels/_pack/{name}" for name in pack} <= names


@pytest.mark.slow
@pytest.mark.gl
def test_the_installed_wheel_renders_headless(wheel, tmp_path):
    env_dir = tmp_path / "venv"
    venv.create(env_dir, with_pip=False)
    python = env_dir / "bin" / "python"
    if not python.exists():
        pytest.skip("a POSIX venv layout is expected")
    purelib = subprocess.run([str(python), "-c", "import sysconfig; "
                              "print(sysconfig.get_paths()['purelib'])"],
                             capture_output=True, text=True, check=True).stdout.strip()
    # the dependencies (numpy, numba, pyglet…) from this interpreter, not from an index
    deps = [p for p in site.getsitepackages() if os.path.isdir(p)]
    Path(purelib, "_riverflow_test_deps.pth").write_text("\n".join(deps) + "\n")
    install = subprocess.run([sys.executable, "-m", "pip", "--python", str(python), "install",
                              "--no-deps", "--no-index", str(wheel)],
                             capture_output=True, text=True, timeout=300)
    assert install.returncode == 0, install.stdout + install.stderr
    env = {k: v for k, v in os.environ.items()
           if k not in ("DISPLAY", "WAYLAND_DISPLAY", "PYTHONPATH")}
    env["PYGLET_HEADLESS"] = "1"
    where = subprocess.run([str(python), "-c", "import riverflow; print(riverflow.__file__)"],
                           cwd=tmp_path, env=env, capture_output=True, text=True, timeout=120)
    assert where.returncode == 0, where.stderr
    assert Path(where.stdout.strip()).is_relative_to(env_dir), where.stdout   # not the checkout
    out = tmp_path / "frame.png"
    render = subprocess.run([str(env_dir / "bin" / "riverflow"), "render", "--size", "64x48",
                             "--frames", "2", "--out", str(out)], cwd=tmp_path, env=env,
                            capture_output=True, text=True, timeout=600)
    assert render.returncode == 0, render.stdout + render.stderr
    assert f"wrote {out}" in render.stdout
    assert out.read_bytes()[:8] == PNG_SIGNATURE
