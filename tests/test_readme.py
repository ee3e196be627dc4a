"""Every README snippet that makes a world, pasted as written, shows a river: after its own
frames, and at least a quarter of a second of them, at least half of its particles are on
the water (issue #27 item 2, #29 item 5)."""
from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

import riverflow as rf

README = Path(__file__).resolve().parents[1] / "README.md"


def _world_snippets() -> list[str]:
    blocks = re.findall(r"```python\n(.*?)```", README.read_text(encoding="utf-8"), re.S)
    # the embedding snippets need the host's window and camera: demos/embed.py and the host
    # demos (tests/render/test_hosts.py) are their tests
    return [b for b in blocks if "RiverWorld(" in b and "pyglet.window" not in b
            and "window.get_" not in b and 'gl="current"' not in b]


SNIPPETS = _world_snippets()


def test_the_readme_has_world_snippets():
    assert len(SNIPPETS) >= 3


@pytest.mark.slow
@pytest.mark.parametrize("index", range(len(SNIPPETS)))
def test_readme_snippet_shows_water(index):
    names: dict = {"rf": rf, "np": np}
    for earlier in SNIPPETS[:index]:             # the scene a reader made before
        if "scene = " in earlier and "scene = " not in SNIPPETS[index]:
            made = [line for line in earlier.splitlines()
                    if line.startswith(("scene = ", "import ", "from "))]
            exec(compile("\n".join(made), "README.md", "exec"), names)
    code = SNIPPETS[index]
    if "gl=True" in code:
        pytest.importorskip("pyglet")
    exec(compile(code, "README.md", "exec"), names)
    world = names["world"]
    try:
        while world.clock.frame < 15:             # the snippets that step run 120
            world.step(1 / 60)
        p = world.particles
        assert len(p) > 100
        inside = float(np.mean(p.status == rf.FlowStatus.INSIDE))
        assert inside >= 0.5, f"snippet {index}: {inside:.0%} of {len(p)} particles on water"
        if "frame" in names:
            frame = names["frame"]
            assert frame.shape[2] == 4 and frame[..., :3].std() > 10   # not a frame of haze
    finally:
        world.close()
