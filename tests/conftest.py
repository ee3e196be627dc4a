"""Shared fixtures. PYGLET_HEADLESS is set before anything can import pyglet.gl."""
from __future__ import annotations

import os
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
