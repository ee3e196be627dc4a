"""Fixtures of the rendering tests: one offscreen OpenGL context (EGL on Mesa's llvmpipe in
CI), skipped cleanly where none can be made."""
from __future__ import annotations

import pytest


@pytest.fixture(scope="session")
def gl_context():
    try:
        from riverflow.engine import gl
        context = gl.acquire_context()
    except Exception as exc:  # no EGL / no libGL: the rest of the suite still runs
        pytest.skip(f"no OpenGL context: {exc}")
    return context
