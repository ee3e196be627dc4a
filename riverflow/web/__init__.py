"""The rivers flowing in a browser: ``riverflow view DIR [--serve]`` (issue #26).

:func:`write_viewer` writes ``DIR/index.html`` beside a tile pyramid that
:func:`riverflow.bake_tiles` baked: one self-contained page (no CDN, nothing fetched but the
tiles and the optional basemap) with Leaflet 1.9.4 inlined (BSD-2-Clause; its licence is
written beside the page as ``leaflet-LICENSE.txt`` and quoted in the page) and
``viewer.js``, which draws the water from the tiles and animates it with particles that
sample the tiles' velocity. The basemap is a plain colour unless ``basemap`` gives an XYZ
tile URL (``https://…/{z}/{x}/{y}.png``).

Browsers refuse to read the pixels of images opened from ``file://``; :func:`serve` (``--serve``)
serves DIR on localhost, and answers a tile the bake left out (no water there) with an empty
tile, so the page loads without errors.
"""
from __future__ import annotations

import functools
import html
import http.server
import io
import json
import threading
from pathlib import Path

HERE = Path(__file__).parent
LEAFLET = HERE / "leaflet"
PAGE = "index.html"
LAND = "#e9e5da"
"""The plain basemap's colour."""


def write_viewer(folder, *, basemap: str | None = None, attribution: str = "",
                 particles: int = 1500, title: str | None = None) -> Path:
    """Write ``folder/index.html`` (and ``leaflet-LICENSE.txt``) for the pyramid in
    ``folder``; returns the page's path.

    Raises:
        FileNotFoundError: no ``tiles.json`` in folder (not a riverflow tile pyramid).
        ValueError: a tiles.json that is not riverflow's, a basemap URL without {z}, {x}, {y}
            or not http(s), particles not in 1 … 100000.
    """
    from riverflow._atomic import atomic_files

    folder = Path(folder)
    tilejson = folder / "tiles.json"
    if not tilejson.is_file():
        raise FileNotFoundError(f"write_viewer: {tilejson} not found; bake tiles first "
                                "(riverflow bake --tiles DIR)")
    try:
        meta = json.loads(tilejson.read_text())
        meta["riverflow"]["max_speed_mps"], meta["tiles"][0], meta["bounds"]
    except (ValueError, KeyError, IndexError, TypeError) as exc:
        raise ValueError(f"write_viewer: {tilejson} is not a riverflow TileJSON ({exc!r})") \
            from None
    if basemap is not None and (not basemap.startswith(("http://", "https://"))
                                or not all(k in basemap for k in ("{z}", "{x}", "{y}"))):
        raise ValueError(f"write_viewer: basemap must be an http(s) XYZ URL with {{z}}, "
                         f"{{x}} and {{y}}, got {basemap!r:.120}")
    if isinstance(particles, bool) or not isinstance(particles, int) or not \
            1 <= particles <= 100_000:
        raise ValueError(f"write_viewer: particles must be 1 … 100000, got {particles!r}")
    config = {"tilejson": meta, "basemap": basemap, "attribution": attribution,
              "particles": particles}
    licence = (LEAFLET / "LICENSE").read_text(encoding="utf-8")
    page = PAGE_TEMPLATE.format(
        title=html.escape(title or meta.get("name", "riverflow")),
        land=LAND,
        licence=licence.replace("*/", "* /"),
        leaflet_css=(LEAFLET / "leaflet.css").read_text(encoding="utf-8"),
        leaflet_js=(LEAFLET / "leaflet.js").read_text(encoding="utf-8"),
        viewer_js=(HERE / "viewer.js").read_text(encoding="utf-8"),
        config=json.dumps(config).replace("</", "<\\/"),
    )
    out = folder / PAGE
    with atomic_files(out, folder / "leaflet-LICENSE.txt") as (tmp_page, tmp_licence):
        tmp_page.write_text(page, encoding="utf-8")
        tmp_licence.write_text(licence, encoding="utf-8")
    return out


PAGE_TEMPLATE = """<!DOCTYPE html>
<html lang="en">
<head>
<meta charset="utf-8">
<meta name="viewport" content="width=device-width, initial-scale=1">
<title>{title}</title>
<link rel="icon" href="data:,">
<!-- Leaflet 1.9.4, https://leafletjs.com, under this licence:
{licence}
-->
<style>
{leaflet_css}
html, body, #map {{ margin: 0; height: 100%; width: 100%; }}
#map {{ background: {land}; }}
.rf-particles {{ position: absolute; left: 0; top: 0; z-index: 450; pointer-events: none; }}
</style>
</head>
<body>
<div id="map"></div>
<script type="application/json" id="rf-config">{config}</script>
<script>
{leaflet_js}
</script>
<script>
{viewer_js}
</script>
</body>
</html>
"""


@functools.lru_cache(maxsize=1)
def empty_tile() -> bytes:
    """A 256² tile with no water (R = G = 128, B = 0, A = 255)."""
    from PIL import Image

    buf = io.BytesIO()
    Image.new("RGBA", (256, 256), (128, 128, 0, 255)).save(buf, format="PNG")
    return buf.getvalue()


class _Handler(http.server.SimpleHTTPRequestHandler):
    def send_error(self, code, message=None, explain=None):
        # a tile the bake left out holds no water: an empty tile, not a 404
        parts = self.path.split("?")[0].strip("/").split("/")
        if code == 404 and len(parts) == 3 and parts[2].endswith(".png") and \
                all(p.isdigit() for p in (parts[0], parts[1], parts[2][:-4])):
            data = empty_tile()
            self.send_response(200)
            self.send_header("Content-Type", "image/png")
            self.send_header("Content-Length", str(len(data)))
            self.end_headers()
            if self.command != "HEAD":
                self.wfile.write(data)
            return
        super().send_error(code, message, explain)

    def log_message(self, format, *args):      # quiet unless asked
        if getattr(self.server, "verbose", False):
            super().log_message(format, *args)


def serve(folder, port: int = 8000, *, host: str = "127.0.0.1", verbose: bool = False,
          background: bool = False) -> http.server.ThreadingHTTPServer:
    """Serve ``folder`` on http://host:port/ (port 0: any free one; ``server.server_address``
    says which). ``background``: in a daemon thread, returning at once (call
    ``server.shutdown()``); else until interrupted."""
    folder = Path(folder)
    if not folder.is_dir():
        raise NotADirectoryError(f"serve: {folder} is not a folder")
    if isinstance(port, bool) or not isinstance(port, int) or not 0 <= port <= 65535:
        raise ValueError(f"serve: port must be a whole number 0 … 65535, got {port!r}")
    handler = functools.partial(_Handler, directory=str(folder))
    server = http.server.ThreadingHTTPServer((host, port), handler)
    server.verbose = verbose
    if background:
        threading.Thread(target=server.serve_forever, daemon=True).start()
        return server
    try:
        server.serve_forever()
    except KeyboardInterrupt:
        pass
    finally:
        server.server_close()
    return server
