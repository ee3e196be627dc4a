"""GIS in and out: real river networks and elevation rasters in, flow maps out.

- :func:`riverflow.gis.rivers.read_rivers` (``rf.read_rivers``): stream centre lines from a
  shapefile, GeoPackage or GeoJSON → a filled :class:`~riverflow.RiverNetworkBuilder`, widths
  and discharges from the attributes or from hydraulic geometry.
- :func:`riverflow.gis.water.read_water` (``rf.read_water``): water polygons (islands as
  holes) or a raster water mask → a filled builder whose banks are the polygons' rings, axes
  from waterway lines or the polygons' skeleton.
- :class:`riverflow.gis.rasters.RasterSource`: a GeoTIFF (any GDAL raster) as a height source,
  read one window per tile; :class:`~riverflow.gis.rasters.PngHeightSource` for 16-bit PNG
  heightmaps. ``rf.landscape(graph, terrain="dem.tif")`` uses them.
- :func:`riverflow.gis.bake.bake_flow_map` (``rf.bake_flow_map``): the flow as an image other
  engines' flow-map shaders read, with a JSON sidecar.

Reading GIS files needs the optional extra ``riverflow[gis]`` (pyogrio, pyproj, rasterio,
pypng); :func:`require` says so when one is missing. Nothing here imports them at import time.
"""
from __future__ import annotations

import importlib
from types import ModuleType

INSTALL_HINT = "pip install 'riverflow[gis]'"
"""What to run when a GIS library is missing."""


def require(module: str, purpose: str) -> ModuleType:
    """Import ``module`` (a library of the ``gis`` extra), or raise an ImportError that names
    ``purpose``, the missing module and the extra to install."""
    try:
        return importlib.import_module(module)
    except ImportError as exc:
        raise ImportError(f"{purpose} needs the optional GIS extra, and {module} is not "
                          f"installed ({exc}): {INSTALL_HINT}") from exc
