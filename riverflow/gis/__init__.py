"""GIS in and out: real river networks and elevation rasters in, flow maps out.

- :func:`riverflow.gis.rivers.read_rivers` (``rf.read_rivers``): stream centre lines from a
  shapefile, GeoPackage or GeoJSON → a filled :class:`~riverflow.RiverNetworkBuilder`, widths
  and discharges from the attributes or from hydraulic geometry.
- :func:`riverflow.gis.water.read_water` (``rf.read_water``): water polygons (islands as
  holes) or a raster water mask → a filled builder whose banks are the polygons' rings, axes
  from waterway lines or the polygons' skeleton.
- :func:`riverflow.gis.bake.bake_flow_map` (``rf.bake_flow_map``): the flow as an image other
  engines' flow-map shaders read, with a JSON sidecar.

Reading GIS files needs the optional extra ``riverflow[gis]`` (pyogrio, pyproj, rasterio,
pypng); :func:`~riverflow._extras.require` says so when one is missing. Nothing here imports
them at import time. Elevation rasters as height sources (``rf.landscape(graph,
terrain="dem.tif")``) are :mod:`riverflow.scenes.rasters`: the land's sources, below GIS.
"""
from __future__ import annotations
