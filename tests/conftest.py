"""Shared fixtures. PYGLET_HEADLESS is set before anything can import pyglet.gl."""
from __future__ import annotations

import os
import shutil
import subprocess
import time
from pathlib import Path

os.environ.setdefault("PYGLET_HEADLESS", "1")

import numpy as np  # noqa: E402
import pytest  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
SHARED_DATA = Path(os.environ.get("RIVERFLOW_SHARED_DATA", REPO.parent / "shared" / "data"))
PROLAND_GRAPH = SHARED_DATA / "proland" / "rivers.graph"
TINY_CHANNEL = SHARED_DATA / "tiny_channel.graph"


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(20240521)


@pytest.fixture
def proland_graph_path() -> Path:
    if not PROLAND_GRAPH.exists():
        pytest.skip(f"shared data absent: {PROLAND_GRAPH}")
    return PROLAND_GRAPH


@pytest.fixture
def tiny_channel_path() -> Path:
    if not TINY_CHANNEL.exists():
        pytest.skip(f"shared data absent: {TINY_CHANNEL}")
    return TINY_CHANNEL


@pytest.fixture
def xvfb():
    """A virtual X display (Xvfb) for windowed runs; skipped where Xvfb is missing."""
    binary = shutil.which("Xvfb")
    if binary is None:
        pytest.skip("Xvfb is not installed (apt-get install xvfb)")
    display = f":{90 + os.getpid() % 9}"
    proc = subprocess.Popen([binary, display, "-screen", "0", "640x480x24", "-nolisten", "tcp"],
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    time.sleep(1.0)
    if proc.poll() is not None:
        pytest.skip("Xvfb did not start")
    yield display
    proc.terminate()
    proc.wait(timeout=10)
