"""Optional extras: import a library of an extra, or say which extra to install.

Reading GIS files and elevation rasters needs ``riverflow[gis]`` (pyogrio, pyproj, rasterio,
pypng); :func:`require` says so when one is missing. The GIS readers (``riverflow.gis``) and
the raster height sources (``riverflow.scenes.rasters``) both call it, so it lives below them.
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
