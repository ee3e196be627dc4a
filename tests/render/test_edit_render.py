"""A background edit of a drawn world (issue 25) is swapped in between the host's frames,
after a frame's draw, not between its step and its draw; the world draws on after it."""
from __future__ import annotations

import time

import numpy as np
import pytest

from riverflow.engine.config import RiverConfig
from riverflow.hydro.builder import RiverNetworkBuilder
from riverflow.scenes.landscape import landscape

pytestmark = pytest.mark.gl


def test_a_drawn_worlds_edit_is_swapped_in_after_its_draw(gl_context):
    from riverflow.engine.world import RiverWorld

    x = np.linspace(-200.0, 200.0, 21)
    line = np.c_[x, 8.0 * np.sin(x / 60.0)]
    builder = RiverNetworkBuilder(tolerance_m=0.25)
    builder.add_branch(line, 20.0, 10.0, name="river")
    scene = landscape(builder.build(), lambda x, y: 5.0 - 0.002 * x + 0.0 * y, cell_m=4.0,
                      pad_m=64.0)
    with RiverWorld(scene, size=(64, 48), gl=True, seed=0,
                    config=RiverConfig(tile_worker="thread")) as w:
        w.camera.look_at((0.0, -150.0, 120.0), (0.0, 0.0, 0.0))
        w.load_view()
        w.step(1 / 30)
        w.render()
        name = w.scene.branches[0].name
        end = time.perf_counter() + 60.0
        for k, drawn in enumerate((False, True)):
            bumped = line.copy()
            bumped[1:-1, 1] += (10.0 + 5.0 * k) * np.sin(np.linspace(0.0, np.pi, 21)[1:-1])
            future = w.move_axis(0, bumped, wait=False)
            while not future.done():
                assert time.perf_counter() < end, "the edit was not swapped in"
                w.step(1 / 30)
                if drawn:
                    w.render()
                time.sleep(0.03)
            assert future.result(0) == [name] and w.edits.applied == k + 1
            # steps only: a drawn world's frame is not over before its draw, so the edits'
            # thread never swaps between a step and its draw: the next frame swaps it in;
            # with draws, it is swapped in after one, between the frames
            assert w.edits.last["between_frames"] == drawn
        rgba = w.render()
        assert rgba.shape == (48, 64, 4) and rgba[..., 3].min() == 255
