"""The collector pause around big reads and builds (riverflow/_memory.py)."""
from __future__ import annotations

import gc

import pytest

from riverflow._memory import collector_paused, without_collector


def test_the_collector_is_paused_inside_and_restored_after_nesting_and_errors():
    assert gc.isenabled()
    with collector_paused():
        assert not gc.isenabled()
        with collector_paused():
            assert not gc.isenabled()
        assert not gc.isenabled()                 # the inner block does not re-enable it
    assert gc.isenabled()
    with pytest.raises(ValueError), collector_paused():
        raise ValueError("a failed build")
    assert gc.isenabled()
    gc.disable()                                  # a host that runs without the collector
    try:
        with collector_paused():
            pass
        assert not gc.isenabled()
    finally:
        gc.enable()


def test_the_builder_builds_with_the_collector_paused(monkeypatch):
    from riverflow.hydro.builder import RiverNetworkBuilder

    seen = []
    build = RiverNetworkBuilder._build
    monkeypatch.setattr(RiverNetworkBuilder, "_build",
                        lambda self: (seen.append(gc.isenabled()), build(self))[1])
    b = RiverNetworkBuilder()
    b.add_branch([(0.0, 0.0), (200.0, 0.0)], 20.0, 1.0)
    b.build()
    assert seen == [False] and gc.isenabled()
    assert without_collector(gc.isenabled)() is False
