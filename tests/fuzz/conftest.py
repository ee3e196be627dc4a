"""The fuzz suite of record (issue #30, item 6): property-based cases (Hypothesis) at the
public entry points, with a fixed seed (``derandomize``) and a small budget (the folder runs
in about 20 s); each case asserts the exact exception type and that the message names the
argument. Skipped where Hypothesis (the test extra) is not installed."""
from __future__ import annotations

import pytest

pytest.importorskip("hypothesis", reason="the test extra (pip install 'riverflow[test]')")
