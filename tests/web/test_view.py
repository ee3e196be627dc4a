"""riverflow view (issue #26) in a real headless Chromium: the page loads with no console error
and animates the water: two screenshots 0.5 s apart differ on water pixels and not on land."""
from __future__ import annotations

import io

import numpy as np
import pytest

import riverflow as rf
from tests.gis.conftest import polyline, require_gis, write_lines
from tests.web.cdp import Browser, chromium

require_gis()


@pytest.fixture(scope="module")
def pyramid(tmp_path_factory):
    folder = tmp_path_factory.mktemp("view")
    lines = [polyline((-300, 150), (-100, 60), (0, 0)), polyline((-300, -120), (0, 0)),
             polyline((0, 0), (150, -40), (300, 0))]
    net = write_lines(folder / "river.gpkg", lines, {"W": np.array([24.0, 18.0, 36.0])})
    graph = rf.read_rivers(net, origin_m=None, width_m="W").build()
    rf.bake_tiles(graph, folder / "tiles", (15, 16))
    return folder / "tiles"


def test_the_command_line_writes_the_page(pyramid, tmp_path, capsys):
    from riverflow.__main__ import main

    assert main(["view", str(pyramid)]) == 0
    page = (pyramid / "index.html").read_text()
    import re

    assert not re.search(r"<(script|link)[^>]*(src|href)=\"(https?:)?//", page)   # no CDN
    assert "L.version" in page or 't.version="1.9.4"' in page                 # Leaflet inlined
    assert (pyramid / "leaflet-LICENSE.txt").read_text().startswith("BSD 2-Clause")
    assert main(["view", str(tmp_path)]) == 1
    assert "tiles.json" in capsys.readouterr().err
    assert main(["view", str(pyramid), "--basemap", "ftp://x/{z}"]) == 1


def test_the_water_flows_in_a_headless_chromium(pyramid, tmp_path):
    if chromium() is None:
        pytest.skip("no chromium: install the system's package (apt-get install chromium; "
                    ".ci/run does) to run the browser test of riverflow view")
    from PIL import Image

    from riverflow.web import LAND, serve, write_viewer

    write_viewer(pyramid)
    server = serve(pyramid, 0, background=True)
    browser = Browser(tmp_path / "profile")
    try:
        for domain in ("Runtime", "Log", "Page"):
            browser.call(f"{domain}.enable")
        port = server.server_address[1]
        browser.call("Page.navigate", url=f"http://127.0.0.1:{port}/index.html")
        browser.pump(2.0)                    # tiles loaded, particles spread over the water
        shots = [np.asarray(Image.open(io.BytesIO(browser.screenshot())).convert("RGB"))]
        browser.pump(0.5)
        shots.append(np.asarray(Image.open(io.BytesIO(browser.screenshot())).convert("RGB")))
        errors = [e for e in browser.events
                  if e.get("method") == "Runtime.exceptionThrown"
                  or (e.get("method") == "Runtime.consoleAPICalled"
                      and e["params"]["type"] in ("error", "assert"))
                  or (e.get("method") == "Log.entryAdded"
                      and e["params"]["entry"]["level"] == "error")]
        assert errors == []
    finally:
        browser.close()
        server.shutdown()
        server.server_close()
    a, b = (s.astype(int) for s in shots)
    Image.fromarray(shots[0]).save("/tmp/riverflow-view-test.png")
    land_rgb = np.array([int(LAND[i:i + 2], 16) for i in (1, 3, 5)])
    land = (np.abs(a - land_rgb).max(-1) <= 2) & (np.abs(b - land_rgb).max(-1) <= 2)
    # land far (4 px) from anything else on the screen: not under a stroke's edge
    from scipy.ndimage import binary_erosion

    land = binary_erosion(land, iterations=4)
    water = (np.abs(a - [38, 104, 168]).max(-1) <= 60) | (a.min(-1) > 200) & ~land
    water &= ~land
    changed = np.abs(a - b).max(-1) > 8
    assert land.mean() > 0.3 and water.mean() > 0.01
    assert (changed & land).sum() == 0
    assert (changed & water).sum() > 50
